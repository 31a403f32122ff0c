#!/usr/bin/env python3
"""Writes the seed corpora of the progressive fuzz targets:

  corpus/progressive_glb/  progressive .glb files made by `meshstream encode`
      (spheres with and without normals and UVs in both packings, at two qp
      and a small packet size, one cut into spatial parts, a two-mesh glTF scene, fandisk when the shared
      models are there), a plain .glb without our extension, and truncated
      and bit-flipped variants;
  corpus/split_bits/       the real control blocks of the sphere stream of
      sphere_stream.h (written by fuzz_split_bits_replay with
      MESHSTREAM_FUZZ_SEED_DIR), plus truncated, bit-flipped and misplaced
      ones;
  corpus/datagram/         the real datagrams of that stream, alone and all
      together (written by fuzz_datagram_replay), plus truncated ones, flipped
      bits and hostile headers (bad magic, kind, stride, offset, count,
      refinement, stream).

Every file is written byte-identically on every run for a given build; files
of the folders that this script does not name (inputs the fuzzer found,
named found-*) are left alone. Standard library only.

usage: tests/fuzz/make_progressive_corpus.py [--build build] [--out tests/fuzz/corpus]
"""

import argparse
import base64
import json
import math
import os
import random
import shutil
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
MODELS = os.path.join(os.path.dirname(ROOT), "shared", "models")
PREFIXES = ("glb-", "control-", "split-", "bundled-", "mut-")


def sphere(rings, segments, radius=1.0, centre=(0.0, 0.0, 0.0)):
    """A UV sphere: positions, normals, UVs (one per vertex) and triangles."""
    pos, nrm, uv = [], [], []

    def add(theta, phi):
        n = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
        bump = 1.0 + 0.05 * math.sin(3 * phi) * math.sin(2 * theta)
        pos.append(tuple(centre[k] + radius * bump * n[k] for k in range(3)))
        nrm.append(n)
        uv.append((phi / (2 * math.pi), theta / math.pi))

    add(0.0, 0.0)
    for i in range(1, rings):
        for s in range(segments):
            add(math.pi * i / rings, 2 * math.pi * s / segments)
    add(math.pi, 0.0)
    south = len(pos) - 1

    def vid(i, s):
        return 1 + (i - 1) * segments + s % segments

    tris = [(0, vid(1, s), vid(1, s + 1)) for s in range(segments)]
    for i in range(1, rings - 1):
        for s in range(segments):
            tris.append((vid(i, s), vid(i + 1, s), vid(i + 1, s + 1)))
            tris.append((vid(i, s), vid(i + 1, s + 1), vid(i, s + 1)))
    tris += [(south, vid(rings - 1, s + 1), vid(rings - 1, s)) for s in range(segments)]
    return pos, nrm, uv, tris


def write_obj(path, rings, segments, attributes):
    pos, nrm, uv, tris = sphere(rings, segments)
    with open(path, "w") as f:
        for p in pos:
            f.write("v %.6f %.6f %.6f\n" % p)
        if attributes:
            for n in nrm:
                f.write("vn %.6f %.6f %.6f\n" % n)
            for t in uv:
                f.write("vt %.6f %.6f\n" % t)
        for t in tris:
            a, b, c = (i + 1 for i in t)
            f.write(("f %d/%d/%d %d/%d/%d %d/%d/%d\n" % (a, a, a, b, b, b, c, c, c)) if attributes
                    else "f %d %d %d\n" % (a, b, c))


def write_two_mesh_gltf(path):
    """Two spheres as two meshes under a node tree, one buffer as a data: URI."""
    blob = b""
    views, accessors, meshes = [], [], []
    for m, (rings, segments, radius, centre) in enumerate([(7, 10, 1.0, (0, 0, 0)), (6, 8, 0.5, (3, 0, 0))]):
        pos, _, _, tris = sphere(rings, segments, radius, centre)
        pbytes = b"".join(struct.pack("<3f", *p) for p in pos)
        ibytes = b"".join(struct.pack("<3H", *t) for t in tris)
        lo = [min(p[k] for p in pos) for k in range(3)]
        hi = [max(p[k] for p in pos) for k in range(3)]
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(pbytes)})
        blob += pbytes
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(ibytes)})
        blob += ibytes + b"\0" * (-len(ibytes) % 4)
        accessors.append({"bufferView": 2 * m, "componentType": 5126, "count": len(pos), "type": "VEC3",
                          "min": lo, "max": hi})
        accessors.append({"bufferView": 2 * m + 1, "componentType": 5123, "count": 3 * len(tris), "type": "SCALAR"})
        meshes.append({"primitives": [{"attributes": {"POSITION": 2 * m}, "indices": 2 * m + 1}]})
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "children": [1]}, {"mesh": 1, "translation": [0, 1, 0]}],
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    with open(path, "w") as f:
        json.dump(doc, f)


def write(path, data):
    with open(path, "wb") as f:
        f.write(data)


def flip(data, rng, count, start=0):
    """`count` single-bit flips at positions from `start` on."""
    out = bytearray(data)
    for _ in range(count):
        at = rng.randrange(start, len(out))
        out[at] ^= 1 << rng.randrange(8)
    return bytes(out)


def glb_bin_offset(glb):
    """Offset of the BIN chunk's data in a GLB (its JSON chunk comes first)."""
    json_length = struct.unpack_from("<I", glb, 12)[0]
    return 12 + 8 + json_length + 8


def varint(v):
    out = bytearray()
    while v >= 0x80:
        out.append((v & 0x7F) | 0x80)
        v >>= 7
    out.append(v)
    return bytes(out)


def read_varint(data, at):
    v, shift = 0, 0
    while True:
        b = data[at]
        at += 1
        v |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            return v, at


def replace_stream(glb, transform):
    """The GLB with the blob of its (one) MESHSTREAM_progressive bufferView
    replaced by transform(blob); later views move, lengths follow."""
    json_length = struct.unpack_from("<I", glb, 12)[0]
    doc = json.loads(glb[20:20 + json_length])
    bin_data = glb[20 + json_length + 8:]
    view = doc["meshes"][0]["primitives"][0]["extensions"]["MESHSTREAM_progressive"]["bufferView"]
    v = doc["bufferViews"][view]
    start, length = v.get("byteOffset", 0), v["byteLength"]
    new = transform(bin_data[start:start + length])
    delta = len(new) - length
    for other in doc["bufferViews"]:
        if other.get("byteOffset", 0) > start:
            other["byteOffset"] += delta
    v["byteLength"] = len(new)
    body = bin_data[:start] + new + bin_data[start + length:doc["buffers"][0]["byteLength"]]
    doc["buffers"][0]["byteLength"] = len(body)
    body += b"\0" * (-len(body) % 4)
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(body)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(text), 0x4E4F534A) + text
            + struct.pack("<II", len(body), 0x004E4942) + body)


def edit_header(blob, edit):
    """A stream blob ("MSPS", version, header block, ...) with edit(header)."""
    header_length, at = read_varint(blob, 5)
    header = edit(blob[at:at + header_length])
    return blob[:5] + varint(len(header)) + header + blob[at + header_length:]


def header_counts_at(header):
    """Offset of the base vertex count in a stream header (the tools field:
    none in version 1, one byte in version 2, two in version 3; version 4
    has its profile byte before them)."""
    tools = {1: 0, 2: 1, 3: 2, 4: 3}[header[0]]
    sets, colours = header[22 + tools], header[23 + tools]
    return 24 + tools + 12 * sets + (20 if colours else 0)


def with_base_vertices(header, count):
    at = header_counts_at(header)
    _, end = read_varint(header, at)
    return header[:at] + varint(count) + header[end:]


def run(cmd, **kwargs):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kwargs)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr.decode(errors="replace")))
    return r


def clean(folder):
    os.makedirs(folder, exist_ok=True)
    for name in os.listdir(folder):
        if name.startswith(PREFIXES):
            os.remove(os.path.join(folder, name))


def make_glb_corpus(meshstream, out, tmp):
    folder = os.path.join(out, "progressive_glb")
    clean(folder)
    plain_obj = os.path.join(tmp, "sphere.obj")
    attr_obj = os.path.join(tmp, "sphere-attributes.obj")
    scene = os.path.join(tmp, "two-meshes.gltf")
    write_obj(plain_obj, 9, 12, attributes=False)
    write_obj(attr_obj, 8, 10, attributes=True)
    write_two_mesh_gltf(scene)
    # Both profiles in one file as the server stores them (the loss-tolerant
    # stream, which the packings and packet sizes shape, and the reliable
    # one), one profile alone, version 3, the crossings tool and the looser
    # batch rule.
    both = ["--profile", "both"]
    jobs = [
        ("glb-sphere-split", plain_obj, ["--packing", "split"] + both),
        ("glb-sphere-bundled", plain_obj, ["--packing", "bundled"] + both),
        ("glb-sphere-qp8-small-packets", plain_obj, ["--qp", "8", "--packet-bytes", "64"] + both),
        ("glb-sphere-attributes-split", attr_obj, ["--packing", "split"] + both),
        ("glb-sphere-attributes-bundled", attr_obj, ["--packing", "bundled", "--qp", "14"] + both),
        ("glb-sphere-three-levels", plain_obj, ["--levels", "3"] + both),
        ("glb-two-meshes", scene, both),
        ("glb-sphere-reliable", plain_obj, ["--profile", "reliable"]),
        ("glb-sphere-attributes-reliable-crossings", attr_obj, ["--profile", "reliable", "--tools", "all"]),
        ("glb-sphere-loss-tolerant-crossings", plain_obj, ["--profile", "loss-tolerant", "--tools", "all"]),
        ("glb-sphere-matching", plain_obj, ["--batch-rule", "matching", "--profile", "reliable"]),
        ("glb-sphere-version3", plain_obj, ["--format-version", "3"]),
        # A mesh cut into spatial parts (four primitives of one mesh).
        ("glb-sphere-parts", plain_obj, ["--part-vertices", "30"] + both),
    ]
    fandisk = os.path.join(MODELS, "fandisk.obj")
    if os.path.exists(fandisk):
        jobs.append(("glb-fandisk", fandisk, ["--qp", "10", "--packing", "bundled"] + both))
    made = {}
    for name, src, flags in jobs:
        dst = os.path.join(folder, name + ".glb")
        run([meshstream, "encode", src, "-o", dst, "--json"] + flags)
        made[name] = open(dst, "rb").read()
    # A plain GLB without our extension (the base of the sphere as any reader sees it).
    run([meshstream, "convert", "--quiet", plain_obj, os.path.join(folder, "glb-plain.glb")])

    # Headers that lie: a base of almost 2^28 vertices (the most a stream may have)
    # whose fix-ups must not be allocated before the bytes show them, and one
    # more vertex than the Draco base has.
    # (In a file of both profiles the stream edited is the loss-tolerant one;
    # the -reliable files edit the reliable profile's only stream.)
    for source, suffix in (("glb-sphere-split", ""), ("glb-sphere-reliable", "-reliable")):
        sphere = made[source]
        write(os.path.join(folder, "mut-header-huge-base%s.glb" % suffix),
              replace_stream(sphere, lambda b: edit_header(b, lambda h: with_base_vertices(h, (1 << 28) - 1000))))
        write(os.path.join(folder, "mut-header-base-plus-one%s.glb" % suffix),
              replace_stream(sphere, lambda b: edit_header(
                  b, lambda h: with_base_vertices(h, read_varint(h, header_counts_at(h))[0] + 1))))
        # The same stream through the rewriting above: must still decode.
        write(os.path.join(folder, "mut-stream-identity%s.glb" % suffix), replace_stream(sphere, lambda b: b))

    rng = random.Random(3)
    for name in ("glb-sphere-split", "glb-sphere-attributes-bundled", "glb-two-meshes", "glb-sphere-reliable",
                 "glb-sphere-attributes-reliable-crossings", "glb-sphere-parts"):
        data = made[name]
        n = len(data)
        for cut in (n // 2, 3 * n // 4, n - 9):
            write(os.path.join(folder, "mut-%s-truncated-%d.glb" % (name[4:], cut)), data[:cut])
        start = glb_bin_offset(data)
        for k in range(6):
            write(os.path.join(folder, "mut-%s-flip-%d.glb" % (name[4:], k)), flip(data, rng, 1 + k % 3, start))


def make_stream_corpora(build, out, tmp):
    for target, corpus in (("fuzz_split_bits", "split_bits"), ("fuzz_datagram", "datagram")):
        folder = os.path.join(out, corpus)
        clean(folder)
        replay = os.path.join(build, "bin", target + "_replay")
        one = os.path.join(tmp, target + "-one")
        os.makedirs(one)
        write(os.path.join(one, "empty"), b"")
        run([replay, one], env=dict(os.environ, MESHSTREAM_FUZZ_SEED_DIR=folder))
    rng = random.Random(5)

    folder = os.path.join(out, "split_bits")
    controls = sorted(name for name in os.listdir(folder) if name.startswith("control-"))
    for name in controls[:4]:
        data = open(os.path.join(folder, name), "rb").read()
        write(os.path.join(folder, "mut-%s-truncated" % name), data[:len(data) // 2])
        write(os.path.join(folder, "mut-%s-no-models" % name), data[:1 + 1 + data[1]] if data[1] < 0x80 else data[:2])
        write(os.path.join(folder, "mut-%s-next-refinement" % name), bytes([(data[0] + 1) & 0xFF]) + data[1:])
        for k in range(3):
            write(os.path.join(folder, "mut-%s-flip-%d" % (name, k)), flip(data, rng, 1 + k, start=1))

    folder = os.path.join(out, "datagram")
    singles = sorted(name for name in os.listdir(folder) if name.startswith(("split-", "bundled-"))
                     and name.endswith("-d0"))
    for name in singles[:6]:
        data = open(os.path.join(folder, name), "rb").read()
        select, body = data[0], data[1:]
        write(os.path.join(folder, "mut-%s-truncated" % name), data[:1 + len(body) * 2 // 3])
        for k in range(3):
            write(os.path.join(folder, "mut-%s-flip-%d" % (name, k)), flip(data, rng, 1 + k, start=1))
        # body: magic, version, kind, then varints stream, refinement, stride, offset, count.
        hostile = {
            "bad-magic": bytes([0x00]) + body[1:],
            "bad-version": body[:1] + bytes([9]) + body[2:],
            "bad-kind": body[:2] + bytes([7]) + body[3:],
            "other-stream": body[:3] + bytes([1]) + body[4:],
            "huge-count": body[:3] + bytes([0]) + body[4:5] + b"\x01\x00\xff\xff\xff\x7f" + body[8:],
            "zero-stride": body[:3] + bytes([0]) + body[4:5] + b"\x00\x00\x01" + body[8:],
            "offset-past-stride": body[:3] + bytes([0]) + body[4:5] + b"\x02\x05\x01" + body[8:],
            "payload-garbage": body[:8] + bytes(rng.randrange(256) for _ in range(40)),
        }
        for what, payload in hostile.items():
            write(os.path.join(folder, "mut-%s-%s" % (name, what)), bytes([select]) + payload)
        # The same datagram twice, then the real ones (duplicates are dropped).
        pair = bytes([select & ~0x02]) + (struct.pack("<H", len(body)) + body) * 2
        write(os.path.join(folder, "mut-%s-twice" % name), pair)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"),
                        help="build folder with bin/meshstream and bin/fuzz_*_replay")
    parser.add_argument("--out", default=os.path.join(HERE, "corpus"))
    args = parser.parse_args()
    meshstream = os.path.join(args.build, "bin", "meshstream")
    for tool in (meshstream, os.path.join(args.build, "bin", "fuzz_split_bits_replay"),
                 os.path.join(args.build, "bin", "fuzz_datagram_replay")):
        if not os.path.exists(tool):
            sys.exit("%s is missing: build first (make)" % tool)
    tmp = tempfile.mkdtemp(prefix="meshstream-corpus-")
    try:
        make_glb_corpus(meshstream, args.out, tmp)
        make_stream_corpora(args.build, args.out, tmp)
    finally:
        shutil.rmtree(tmp)
    for corpus in ("progressive_glb", "split_bits", "datagram"):
        folder = os.path.join(args.out, corpus)
        files = os.listdir(folder)
        size = sum(os.path.getsize(os.path.join(folder, f)) for f in files)
        print("%s: %d files, %d bytes" % (folder, len(files), size))


if __name__ == "__main__":
    main()
