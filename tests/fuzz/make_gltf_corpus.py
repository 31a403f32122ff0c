#!/usr/bin/env python3
"""Writes the seed corpus of the glTF fuzz target into tests/fuzz/corpus/gltf/.

Small valid documents (triangle lists, strips, fans, non-indexed, sparse
accessors, KHR_mesh_quantization, materials and textures with a data: image,
a GLB, Draco-compressed GLBs) and one file per hostile case of
tests/importers/gltf_hostile_test.cc (truncated and lying GLBs, accessors
past their views, absurd counts, escaping URIs, non-finite positions, deep
JSON, refused features, Draco garbage, ...).

Standard library only. Files are rewritten byte-identically on every run;
files of the folder that this script does not name (inputs the fuzzer found,
named found-*) are left alone.

The Draco GLBs are made by the project's own CLI (`meshstream convert X.obj
Y.glb --draco`); without the CLI the committed ones are kept. BoxTextured.glb
is copied from ../shared/models/gltf when present.

usage: tests/fuzz/make_gltf_corpus.py [--meshstream build/bin/meshstream] [--out DIR]
"""

import argparse
import base64
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))

BYTE, UNSIGNED_BYTE, SHORT, UNSIGNED_SHORT, UNSIGNED_INT, FLOAT = 5120, 5121, 5122, 5123, 5125, 5126
GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942



def png_1x1():
    """A valid 1x1 grey PNG, so textured documents carry a real image."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    header = struct.pack(">IIBBBBB", 1, 1, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\x00\x80"))
            + chunk(b"IEND", b""))


PNG_1X1 = png_1x1()


def f32(*values):
    return struct.pack("<%df" % len(values), *values)


def u16(*values):
    return struct.pack("<%dH" % len(values), *values)


def u32(*values):
    return struct.pack("<%dI" % len(values), *values)


def data_uri(data, mime="application/octet-stream"):
    return "data:%s;base64,%s" % (mime, base64.b64encode(data).decode("ascii"))


def dumps(doc):
    return json.dumps(doc, separators=(",", ":"))


def pack_glb(text, bin_data=b"", version=2):
    """A well-formed GLB; returns (bytes, offset of the BIN chunk header or 0)."""
    raw = text.encode("utf-8")
    raw += b" " * (-len(raw) % 4)
    out = bytearray(struct.pack("<III", GLB_MAGIC, version, 0))
    out += struct.pack("<II", len(raw), JSON_CHUNK) + raw
    bin_chunk = 0
    if bin_data:
        bin_chunk = len(out)
        padded = bin_data + b"\0" * (-len(bin_data) % 4)
        out += struct.pack("<II", len(padded), BIN_CHUNK) + padded
    struct.pack_into("<I", out, 8, len(out))
    return bytes(out), bin_chunk


class Doc:
    """One buffer, one mesh, one node, one scene."""

    def __init__(self):
        self.bin = bytearray()
        self.doc = {
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": []}],
            "bufferViews": [],
            "accessors": [],
        }

    def view(self, data, stride=0):
        self.bin += b"\0" * (-len(self.bin) % 4)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride:
            v["byteStride"] = stride
        self.bin += data
        self.doc["bufferViews"].append(v)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, **fields):
        self.doc["accessors"].append(fields)
        return len(self.doc["accessors"]) - 1

    def positions(self, *xyz):
        v = self.view(f32(*xyz))
        return self.accessor(bufferView=v, componentType=FLOAT, count=len(xyz) // 3, type="VEC3",
                             min=[min(xyz[i::3]) for i in range(3)], max=[max(xyz[i::3]) for i in range(3)])

    def indices(self, *idx):
        v = self.view(u16(*idx))
        return self.accessor(bufferView=v, componentType=UNSIGNED_SHORT, count=len(idx), type="SCALAR")

    def primitive(self, **prim):
        self.doc["meshes"][0]["primitives"].append(prim)

    def gltf(self):
        d = json.loads(json.dumps(self.doc))
        if self.bin:
            d["buffers"] = [{"byteLength": len(self.bin), "uri": data_uri(bytes(self.bin))}]
        return dumps(d).encode("utf-8")

    def glb(self):
        d = json.loads(json.dumps(self.doc))
        if self.bin:
            d["buffers"] = [{"byteLength": len(self.bin)}]
        return pack_glb(dumps(d), bytes(self.bin))


def triangle():
    d = Doc()
    pos = d.positions(0, 0, 0, 1, 0, 0, 0, 1, 0)
    idx = d.indices(0, 1, 2)
    d.primitive(attributes={"POSITION": pos}, indices=idx)
    return d


def quad_positions(d):
    return d.positions(0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0)


def sparse_doc(indices, count=4):
    d = Doc()
    base = d.view(f32(0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0))
    iv = d.view(u16(*indices))
    vv = d.view(f32(*([9.0, 8.0, 7.0] * len(indices))))
    d.accessor(bufferView=base, componentType=FLOAT, count=count, type="VEC3",
               sparse={"count": len(indices),
                       "indices": {"bufferView": iv, "componentType": UNSIGNED_SHORT},
                       "values": {"bufferView": vv}})
    idx = d.indices(0, 1, 2, 0, 2, 3)
    d.primitive(attributes={"POSITION": 0}, indices=idx)
    return d


def good_files(files):
    files["triangle_list.gltf"] = triangle().gltf()
    files["triangle.glb"] = triangle().glb()[0]

    d = Doc()
    pos = d.positions(0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 2, 0)
    idx = d.indices(0, 1, 2, 2, 3, 4)
    d.primitive(attributes={"POSITION": pos}, indices=idx, mode=5)
    files["triangle_strip.gltf"] = d.gltf()

    d = Doc()
    pos = quad_positions(d)
    idx = d.indices(0, 1, 2, 3)
    d.primitive(attributes={"POSITION": pos}, indices=idx, mode=6)
    files["triangle_fan.gltf"] = d.gltf()

    d = Doc()
    pos = d.positions(0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5, 6, 5, 5, 5, 6, 5)
    d.primitive(attributes={"POSITION": pos})
    files["non_indexed.gltf"] = d.gltf()

    files["sparse.gltf"] = sparse_doc([1, 3]).gltf()

    d = Doc()
    zi = d.view(u32(2))
    zv = d.view(f32(4, 5, 6))
    d.accessor(componentType=FLOAT, count=3, type="VEC3",
               sparse={"count": 1, "indices": {"bufferView": zi, "componentType": UNSIGNED_INT},
                       "values": {"bufferView": zv}})
    d.primitive(attributes={"POSITION": 0})
    files["sparse_over_zeros.gltf"] = d.gltf()

    d = Doc()
    pv = d.view(struct.pack("<12h", 32767, 0, -32767, 0, -32768, 16384, 1, 0, 0, -16384, 32767, 0), stride=8)
    d.accessor(bufferView=pv, componentType=SHORT, normalized=True, count=3, type="VEC3")
    uv = d.view(u16(0, 65535, 65535, 0, 32768, 32768))
    d.accessor(bufferView=uv, componentType=UNSIGNED_SHORT, normalized=True, count=3, type="VEC2")
    nv = d.view(struct.pack("<12b", 0, 0, 127, 0, 0, 0, -127, 0, 0, -128, 0, 0), stride=4)
    d.accessor(bufferView=nv, componentType=BYTE, normalized=True, count=3, type="VEC3")
    d.primitive(attributes={"POSITION": 0, "TEXCOORD_0": 1, "NORMAL": 2})
    d.doc["extensionsUsed"] = ["KHR_mesh_quantization"]
    d.doc["extensionsRequired"] = ["KHR_mesh_quantization"]
    files["quantized_shorts.gltf"] = d.gltf()
    files["quantized_shorts.glb"] = d.glb()[0]

    d = Doc()
    pos = quad_positions(d)
    nrm = d.view(f32(*([0, 0, 1] * 4)))
    d.accessor(bufferView=nrm, componentType=FLOAT, count=4, type="VEC3")
    uvs = d.view(f32(0, 0, 1, 0, 1, 1, 0, 1))
    d.accessor(bufferView=uvs, componentType=FLOAT, count=4, type="VEC2")
    col = d.view(f32(*([1, 0.5, 0.25, 1] * 4)))
    d.accessor(bufferView=col, componentType=FLOAT, count=4, type="VEC4")
    idx = d.indices(0, 1, 2, 0, 2, 3)
    d.primitive(attributes={"POSITION": pos, "NORMAL": 1, "TEXCOORD_0": 2, "COLOR_0": 3, "TANGENT": 3},
                indices=idx, material=0)
    d.doc["materials"] = [{"name": "m", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                                   "metallicFactor": 0.5},
                           "extensions": {"KHR_materials_unlit": {}, "EXT_made_up_material": {}}}]
    d.doc["textures"] = [{"source": 0, "sampler": 0}]
    d.doc["samplers"] = [{"magFilter": 9729, "minFilter": 9987}]
    d.doc["images"] = [{"uri": data_uri(PNG_1X1, "image/png")}]
    d.doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]
    d.doc["nodes"] = [{"mesh": 0, "children": [1], "translation": [1, 2, 3]},
                      {"camera": 0, "rotation": [0, 0, 0, 1]}]
    d.doc["extensionsUsed"] = ["KHR_materials_unlit", "EXT_made_up_optional"]
    files["textured.gltf"] = d.gltf()
    # The same with the image in a bufferView of the BIN chunk.
    d.doc["images"] = [{"bufferView": d.view(PNG_1X1), "mimeType": "image/png"}]
    files["textured.glb"] = d.glb()[0]

    d = triangle()
    d.doc["extensionsUsed"] = ["EXT_made_up_optional"]
    files["unknown_optional_extension.gltf"] = d.gltf()

    d = triangle()
    d.doc["meshes"].append({"primitives": [{"attributes": {"POSITION": 0}}]})
    d.doc["nodes"] = [{"mesh": 0, "children": [1, 2]}, {"mesh": 1, "matrix": [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0,
                                                                              1, 1, 1, 1]}, {"children": [3]}, {}]
    files["two_meshes_node_tree.gltf"] = d.gltf()


def hostile_files(files):
    glb, bin_chunk = triangle().glb()
    json_size = bin_chunk - 20
    for name, cut in [("header", 10), ("json_chunk", 20 + json_size // 2),
                      ("bin_header", bin_chunk + 4), ("bin_chunk", len(glb) - 5)]:
        files["hostile_glb_truncated_in_%s.glb" % name] = glb[:cut]

    def patched(offset, value, data=glb):
        out = bytearray(data)
        struct.pack_into("<I", out, offset, value)
        return bytes(out)

    files["hostile_glb_total_length_too_large.glb"] = patched(8, len(glb) + 100)
    files["hostile_glb_total_length_hides_bin.glb"] = patched(8, bin_chunk)
    files["hostile_glb_json_length_overflow.glb"] = patched(12, 0xFFFFFFF0)
    files["hostile_glb_bin_length_overflow.glb"] = patched(bin_chunk, 0xFFFFFFF0)
    files["hostile_glb_bin_length_plus_8.glb"] = patched(bin_chunk, len(glb) - bin_chunk)
    files["hostile_glb_version_1.glb"] = patched(4, 1)

    d = triangle()
    doc = dict(d.doc, buffers=[{"byteLength": len(d.bin)}])
    text = dumps(doc)
    text += " " * ((1 - len(text)) % 4)  # length = 1 mod 4, then 3 bytes of padding
    raw = text.encode()
    out = bytearray(struct.pack("<IIIII", GLB_MAGIC, 2, 0, len(raw), JSON_CHUNK)) + raw + b"   "
    out += struct.pack("<II", len(d.bin), BIN_CHUNK) + d.bin
    struct.pack_into("<I", out, 8, len(out))
    files["hostile_glb_unpadded_json_before_bin.glb"] = bytes(out)

    d = triangle()
    doc = dict(d.doc, buffers=[{"byteLength": len(d.bin) + 4}])
    files["hostile_buffer_larger_than_bin.glb"] = pack_glb(dumps(doc), bytes(d.bin))[0]

    def variant(name, change, glb_too=False):
        d = triangle()
        change(d)
        files[name + ".gltf"] = d.gltf()
        if glb_too:
            files[name + ".glb"] = d.glb()[0]

    variant("hostile_accessor_count_past_view", lambda d: d.doc["accessors"][0].update(count=4))
    variant("hostile_accessor_offset_past_view", lambda d: d.doc["accessors"][0].update(byteOffset=40))
    variant("hostile_view_past_buffer", lambda d: d.doc["bufferViews"][0].update(byteOffset=1000), glb_too=True)
    variant("hostile_absurd_count", lambda d: d.doc["accessors"][0].update(count=4000000000))
    variant("hostile_zero_byte_view", lambda d: d.doc["bufferViews"][1].update(byteLength=0))
    variant("hostile_points", lambda d: d.doc["meshes"][0]["primitives"][0].update(mode=0))
    variant("hostile_lines", lambda d: d.doc["meshes"][0]["primitives"][0].update(mode=1))
    variant("hostile_line_strip", lambda d: d.doc["meshes"][0]["primitives"][0].update(mode=3))
    variant("hostile_dangling_material_texture", lambda d: (
        d.doc.update(materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 3}}}]),
        d.doc["meshes"][0]["primitives"][0].update(material=0)))
    variant("hostile_node_cycle", lambda d: d.doc.update(nodes=[{"mesh": 0, "children": [1]}, {"children": [0]}]))
    variant("hostile_unknown_required_extension", lambda d: d.doc.update(
        extensionsUsed=["EXT_made_up_required"], extensionsRequired=["EXT_made_up_required"]))

    d = Doc()
    pos = d.positions(0, 0, 0, 1, 0, 0, 0, 1, 0)
    idx = d.indices(0, 1, 7)
    d.primitive(attributes={"POSITION": pos}, indices=idx)
    files["hostile_index_out_of_range.gltf"] = d.gltf()

    d = Doc()
    d.accessor(componentType=FLOAT, count=2147483648, type="VEC3")
    d.primitive(attributes={"POSITION": 0})
    files["hostile_zero_filled_huge_accessor.gltf"] = d.gltf()

    files["hostile_sparse_out_of_range.gltf"] = sparse_doc([1, 5]).gltf()
    files["hostile_sparse_not_increasing.gltf"] = sparse_doc([3, 1]).gltf()

    for name, value in [("nan", float("nan")), ("inf", float("inf"))]:
        d = Doc()
        pv = d.view(f32(0, 0, 0, 1, value, 0, 0, 1, 0))
        d.accessor(bufferView=pv, componentType=FLOAT, count=3, type="VEC3")
        d.primitive(attributes={"POSITION": 0})
        files["hostile_%s_positions.gltf" % name] = d.gltf()
        files["hostile_%s_positions.glb" % name] = d.glb()[0]

    for i, uri in enumerate(["../secret.bin", "/etc/passwd", "%2e%2e/x.bin", "file:///etc/passwd",
                             "http://example.com/a.bin", "sub/../../x.bin", "model.bin"]):
        d = triangle()
        doc = dict(d.doc, buffers=[{"byteLength": len(d.bin), "uri": uri}])
        files["hostile_uri_%d.gltf" % i] = dumps(doc).encode()
    d = triangle()
    doc = json.loads(d.gltf())
    doc["images"] = [{"uri": "../../etc/passwd"}]
    files["hostile_image_uri.gltf"] = dumps(doc).encode()

    files["hostile_deep_nesting.gltf"] = b"[" * 10000 + b"]" * 10000
    doc = json.loads(triangle().gltf())
    text = dumps(doc)[:-1] + ',"extras":' + '{"a":' * 200 + "1" + "}" * 200 + "}"
    files["hostile_deep_extras.glb"] = pack_glb(text)[0]
    files["hostile_garbage.gltf"] = bytes(range(256)) * 2
    files["hostile_empty.gltf"] = b""
    files["hostile_not_an_object.gltf"] = b"[1,2,3]"
    files["hostile_wrong_types.gltf"] = dumps({"asset": {"version": "2.0"}, "accessors": {"count": "x"},
                                               "bufferViews": [1], "meshes": "m"}).encode()

    d = triangle()
    jv = d.view(bytes(12))
    d.accessor(bufferView=jv, componentType=UNSIGNED_BYTE, count=3, type="VEC4")
    d.doc["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"] = 2
    files["hostile_joints.gltf"] = d.gltf()

    d = triangle()
    delta = d.positions(0, 0, 1, 0, 0, 1, 0, 0, 1)
    d.doc["meshes"][0]["primitives"][0]["targets"] = [{"POSITION": delta}]
    files["hostile_morph_targets.gltf"] = d.gltf()

    d = triangle()
    d.doc["skins"] = [{"joints": [0]}]
    files["hostile_skin.gltf"] = d.gltf()

    for name, stream in [("garbage", bytes((i * 37 + 11) & 0xFF for i in range(64))),
                         ("lying_header", b"DRACO\x02\x02\x01\x01\x00\x00" + b"\xff" * 53)]:
        d = Doc()
        v = d.view(stream)
        pos = d.accessor(componentType=FLOAT, count=3, type="VEC3")
        idx = d.accessor(componentType=UNSIGNED_SHORT, count=3, type="SCALAR")
        d.primitive(attributes={"POSITION": pos}, indices=idx,
                    extensions={"KHR_draco_mesh_compression": {"bufferView": v, "attributes": {"POSITION": 0}}})
        d.doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
        d.doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
        files["hostile_draco_%s.glb" % name] = d.glb()[0]


def glb_to_gltf(glb):
    """The same document with the BIN chunk as a data: URI."""
    json_len = struct.unpack_from("<I", glb, 12)[0]
    doc = json.loads(glb[20:20 + json_len])
    bin_len = struct.unpack_from("<I", glb, 20 + json_len)[0]
    bin_data = glb[28 + json_len:28 + json_len + bin_len]
    doc["buffers"][0]["uri"] = data_uri(bin_data)
    return dumps(doc).encode()


PYRAMID_OBJ = """v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
v 0.5 0.5 1
vt 0 0
vt 1 0
vt 0 1
vt 1 1
vt 0.5 0.5
vn 0 0 -1
vn 0 0.6 0.8
f 1/1/1 3/3/1 2/2/1
f 2/2/1 3/3/1 4/4/1
f 1/1/2 2/2/2 5/5/2
f 2/2/2 4/4/2 5/5/2
f 4/4/2 3/3/2 5/5/2
f 3/3/2 1/1/2 5/5/2
"""


def draco_files(files, meshstream, out_dir):
    """Draco GLBs made by the CLI; without it the committed files stay."""
    names = ["draco_pyramid.glb", "draco_pyramid_attributes.glb", "draco_pyramid.gltf"]
    if not meshstream or not os.access(meshstream, os.X_OK):
        for name in names:
            path = os.path.join(out_dir, name)
            if os.path.exists(path):
                with open(path, "rb") as f:
                    files[name] = f.read()
        print("no meshstream CLI: kept the committed Draco files", file=sys.stderr)
        return
    with tempfile.TemporaryDirectory() as tmp:
        plain = os.path.join(tmp, "pyramid.obj")
        with open(plain, "w") as f:
            f.write("\n".join(l for l in PYRAMID_OBJ.splitlines() if l.startswith("v ")) + "\n")
            f.write("f 1 3 2\nf 2 3 4\nf 1 2 5\nf 2 4 5\nf 4 3 5\nf 3 1 5\n")
        full = os.path.join(tmp, "pyramid_attributes.obj")
        with open(full, "w") as f:
            f.write(PYRAMID_OBJ)
        for obj, name in [(plain, "draco_pyramid.glb"), (full, "draco_pyramid_attributes.glb")]:
            out = os.path.join(tmp, name)
            subprocess.run([meshstream, "convert", obj, out, "--draco"], check=True, stdout=subprocess.DEVNULL)
            with open(out, "rb") as f:
                files[name] = f.read()
    files["draco_pyramid.gltf"] = glb_to_gltf(files["draco_pyramid.glb"])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshstream", default=os.path.join(ROOT, "build", "bin", "meshstream"))
    parser.add_argument("--out", default=os.path.join(HERE, "corpus", "gltf"))
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    files = {}
    good_files(files)
    hostile_files(files)
    draco_files(files, args.meshstream, args.out)
    box = os.path.join(ROOT, "..", "shared", "models", "gltf", "BoxTextured.glb")
    if os.path.exists(box):
        shutil.copyfile(box, os.path.join(args.out, "BoxTextured.glb"))

    for name, data in sorted(files.items()):
        with open(os.path.join(args.out, name), "wb") as f:
            f.write(data)
    total = sum(os.path.getsize(os.path.join(args.out, n)) for n in os.listdir(args.out))
    print("%d generated files in %s (folder total %d bytes)" % (len(files), args.out, total))


if __name__ == "__main__":
    main()
