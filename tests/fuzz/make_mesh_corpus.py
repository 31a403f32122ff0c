#!/usr/bin/env python3
"""Writes the seed corpora of the mesh-file fuzz targets into
tests/fuzz/corpus/{obj,ply,off,stl}/.

Small pieces of the shared models (the first vertices of an OBJ with the faces
that use only them, a binary PLY cut from horse.ply) and hand-made edge cases:
CRLF, no newline at end of file, negative (relative) OBJ indices, polygons,
PLY lists of odd types, big-endian PLY, tristrips, a stray PLY header line,
OFF with colours and normals, ascii and binary STL, headers claiming huge
counts, invalid UTF-8 in names.

Standard library only; files are rewritten byte-identically on every run and
files this script does not name (inputs the fuzzer found) are left alone.

usage: tests/fuzz/make_mesh_corpus.py [--models ../shared/models] [--out tests/fuzz/corpus]
"""

import argparse
import os
import struct


def obj_piece(path, faces_wanted):
    """The first `faces_wanted` faces of an OBJ with the v/vt/vn lines they
    use, renumbered in order of first use (a consistent, small OBJ)."""
    lines = {"v": [], "vt": [], "vn": []}
    faces = []
    with open(path, "rb") as f:
        for raw in f:
            words = raw.split()
            if not words:
                continue
            key = words[0].decode("ascii", "replace")
            if key in lines:
                lines[key].append(raw.rstrip(b"\r\n"))
            elif key == "f" and len(faces) < faces_wanted:
                faces.append(words[1:])
    remap = {"v": {}, "vt": {}, "vn": {}}
    out_faces = []
    for words in faces:
        corners = []
        for w in words:
            parts = w.split(b"/")
            new = []
            for kind, part in zip(("v", "vt", "vn"), parts):
                if not part:
                    new.append(b"")
                    continue
                i = int(part)
                i = i - 1 if i > 0 else len(lines[kind]) + i
                new.append(b"%d" % (remap[kind].setdefault(i, len(remap[kind])) + 1))
            corners.append(b"/".join(new))
        out_faces.append(b"f " + b" ".join(corners))
    out = []
    for kind in ("v", "vt", "vn"):
        for i, _ in sorted(remap[kind].items(), key=lambda kv: kv[1]):
            out.append(lines[kind][i])
    return b"\n".join(out + out_faces) + b"\n"


def ply_piece(path, vertices):
    """A binary little-endian PLY with the first `vertices` vertices of a
    float x y z nx ny nz / uchar int face PLY and the faces among them."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    nv = int([l for l in header if l.startswith("element vertex")][0].split()[2])
    body = data[end:]
    stride = 24
    verts = body[: vertices * stride]
    faces, off = [], nv * stride
    while off < len(body) and len(faces) < 2 * vertices:
        k = body[off]
        idx = struct.unpack_from("<%di" % k, body, off + 1)
        off += 1 + 4 * k
        if all(i < vertices for i in idx):
            faces.append(bytes([k]) + struct.pack("<%di" % k, *idx))
    head = ("ply\nformat binary_little_endian 1.0\ncomment cut from horse.ply\n"
            "element vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            "element face %d\nproperty list uchar int vertex_indices\nend_header\n") % (vertices, len(faces))
    return head.encode() + verts + b"".join(faces)


QUAD_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]


def ply_binary(fmt, big, count_type="uchar", index_type="int", extra=b""):
    e = ">" if big else "<"
    head = ("ply\nformat %s 1.0\n%selement vertex 4\nproperty %s x\nproperty %s y\nproperty %s z\n"
            "element face 2\nproperty list %s %s vertex_indices\nend_header\n") % (
        "binary_big_endian" if big else "binary_little_endian", extra.decode(), fmt, fmt, fmt,
        count_type, index_type)
    vf = {"float": "f", "double": "d"}[fmt]
    ct = {"uchar": "B", "uint8": "B", "uint16": "H", "int": "i"}[count_type]
    it = {"int": "i", "uint": "I", "short": "h", "ushort": "H", "uchar": "B", "char": "b", "int32": "i"}[index_type]
    body = b"".join(struct.pack(e + vf * 3, *v) for v in QUAD_V)
    for face in ((0, 1, 2), (0, 2, 3)):
        body += struct.pack(e + ct, 3) + struct.pack(e + it * 3, *face)
    return head.encode() + body


def stl_binary(triangles):
    out = b"binary stl".ljust(80, b" ") + struct.pack("<I", len(triangles))
    for t in triangles:
        out += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *v) for v in t) + b"\0\0"
    return out


def corpus(models):
    files = {"obj": {}, "ply": {}, "off": {}, "stl": {}}
    o = files["obj"]
    for name in ("spot", "fandisk", "rocker-arm", "stanford-bunny"):
        p = os.path.join(models, name + ".obj")
        if os.path.exists(p):
            o["piece-%s.obj" % name] = obj_piece(p, 40)
    o["quad.obj"] = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    o["quad-crlf.obj"] = o["quad.obj"].replace(b"\n", b"\r\n")
    o["quad-cr-only.obj"] = o["quad.obj"].replace(b"\n", b"\r")
    o["no-newline-at-eof.obj"] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3"
    o["negative-indices.obj"] = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\nf -4/-3/-1 -3/-2/-1 -2/-1/-1\nf 1//1 3//1 4//1\n"
    o["pentagon-and-hexagon.obj"] = b"v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 2 0\nv -1 1 0\nf 1 2 3 4 5\nf 1 2 3 4 5 6\n"
    o["seams.obj"] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\nvn 0 0 1\nvn 0 0 -1\nf 1/1/1 2/2/1 3/3/1\nf 2/4/2 4/2/2 3/1/2\n"
    o["vertex-colours.obj"] = b"v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n"
    o["groups-and-materials.obj"] = b"mtllib none.mtl\no first\ng a b\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng other\nusemtl blue\ns 1\nf 3 2 1\n"
    o["invalid-utf8-names.obj"] = b"o bad\xff\xfename\ng gr\xc3oup\nusemtl m\xe9tal\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
    o["out-of-range.obj"] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"
    o["nan.obj"] = b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
    o["line-and-point.obj"] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\np 3\nf 1 2 3\n"
    o["comments-and-continuation.obj"] = b"# c\nv 0 0 0 # x\nv 1 0 \\\n0\nv 0 1 0\nf 1 2 3 # t\n"
    p = files["ply"]
    if os.path.exists(os.path.join(models, "horse.ply")):
        p["piece-horse.ply"] = ply_piece(os.path.join(models, "horse.ply"), 30)
    ascii_quad = (b"ply\nformat ascii 1.0\ncomment a quad\nelement vertex 4\nproperty float x\n"
                  b"property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
                  b"property uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                  b"0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 255 255 255\n4 0 1 2 3\n")
    p["ascii-quad-colours.ply"] = ascii_quad
    p["ascii-quad-crlf.ply"] = ascii_quad.replace(b"\n", b"\r\n")
    p["ascii-no-newline-at-eof.ply"] = ascii_quad[:-1]
    p["ascii-normals-uv.ply"] = (b"ply\nformat ascii 1.0\nobj_info x\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 b"property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                                 b"property float u\nproperty float v\nelement face 1\n"
                                 b"property list uchar int vertex_indices\nend_header\n"
                                 b"0 0 0 0 0 2 0 0\n1 0 0 0 0 2 1 0\n0 1 0 0 0 2 0 1\n3 0 1 2\n")
    p["binary-le-float.ply"] = ply_binary("float", False)
    p["binary-be-double.ply"] = ply_binary("double", True)
    p["binary-le-uint16-ushort.ply"] = ply_binary("float", False, "uint16", "ushort")
    p["binary-be-int-uchar.ply"] = ply_binary("float", True, "int", "uchar")
    p["binary-le-uint8-char.ply"] = ply_binary("float", False, "uint8", "char")
    p["binary-stray-line.ply"] = ply_binary("float", False, extra=b"Created by Blender3D 247 - www.blender.org, source file: 'x.blend'\n")
    p["ascii-stray-line.ply"] = ascii_quad.replace(b"comment a quad\n", b"Created by Blender3D 247 - www.blender.org\n")
    p["ascii-tristrips.ply"] = (b"ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                                b"element tristrips 1\nproperty list int int vertex_indices\nend_header\n"
                                b"0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 1 0\n7 0 1 2 3 -1 2 4\n")
    p["huge-counts-binary.ply"] = (b"ply\nformat binary_little_endian 1.0\nelement vertex 400000000\nproperty float x\n"
                                   b"property float y\nproperty float z\nelement face 400000000\n"
                                   b"property list uchar int vertex_indices\nend_header\n" + b"\0" * 120)
    p["huge-counts-ascii.ply"] = (b"ply\nformat ascii 1.0\nelement vertex 4294967295\nproperty float x\nproperty float y\n"
                                  b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n")
    p["huge-list-length.ply"] = (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 b"property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n"
                                 + b"\0" * 36 + struct.pack("<i", 0x7fffffff) + b"\0" * 12)
    p["comment-utf8.ply"] = ascii_quad.replace(b"comment a quad", b"comment caf\xe9 \xff")
    f = files["off"]
    f["quad.off"] = b"OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"
    f["quad-crlf.off"] = f["quad.off"].replace(b"\n", b"\r\n")
    f["no-newline-at-eof.off"] = b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2"
    f["coff.off"] = b"COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2 10 20 30\n"
    f["noff.off"] = b"NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n"
    f["cnoff.off"] = b"CNOFF\n3 1 0\n0 0 0 0 0 1 0.5 0.5 0.5\n1 0 0 0 0 1 1 0 0\n0 1 0 0 0 1 0 1 0\n3 0 1 2\n"
    f["comments.off"] = b"OFF # a comment\n# another\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    f["huge-counts.off"] = b"OFF\n4000000000 4000000000 0\n0 0 0\n"
    f["binary.off"] = b"OFF BINARY\n" + struct.pack(">3i", 3, 1, 0)
    f["pentagon.off"] = b"OFF\n5 1 0\n0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 2 0\n5 0 1 2 3 4\n"
    s = files["stl"]
    tris = [((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((1, 0, 0), (1, 1, 0), (0, 1, 0))]
    s["two-triangles-binary.stl"] = stl_binary(tris)
    s["degenerate-binary.stl"] = stl_binary(tris + [((0, 0, 0), (0, 0, 0), (1, 1, 1))])
    ascii = b"solid t\n"
    for t in tris:
        ascii += b"facet normal 0 0 1\nouter loop\n" + b"".join(b"vertex %g %g %g\n" % v for v in t) + b"endloop\nendfacet\n"
    ascii += b"endsolid t\n"
    s["two-triangles-ascii.stl"] = ascii
    s["ascii-crlf.stl"] = ascii.replace(b"\n", b"\r\n")
    s["ascii-uppercase.stl"] = ascii.upper()
    s["ascii-no-newline-at-eof.stl"] = ascii[:-1]
    s["solid-binary.stl"] = b"solid".ljust(80, b" ") + struct.pack("<I", 1) + stl_binary(tris[:1])[84:]
    s["huge-count-binary.stl"] = b"x".ljust(80, b" ") + struct.pack("<I", 0xffffffff) + b"\0" * 50
    return files


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser()
    parser.add_argument("--models", default=os.path.join(here, "..", "..", "..", "shared", "models"))
    parser.add_argument("--out", default=os.path.join(here, "corpus"))
    args = parser.parse_args()
    for fmt, entries in corpus(args.models).items():
        folder = os.path.join(args.out, fmt)
        os.makedirs(folder, exist_ok=True)
        for name, data in entries.items():
            with open(os.path.join(folder, name), "wb") as f:
                f.write(data)
        print("%s: %d files" % (folder, len(entries)))


if __name__ == "__main__":
    main()
