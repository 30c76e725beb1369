#!/usr/bin/env python3
"""Writes a forest as one .glb: a tree of about 5,000 triangles (a trunk and a round canopy, two
materials) placed N times by EXT_mesh_gpu_instancing on a square grid, each instance turned about
the vertical axis and scaled. With N = 1 the tree is written once, without the extension: the
baseline of docs/performance.md ("Instanced glTF").

    python3 scripts/forest_gltf.py OUT.glb N

Only the standard library: the file is small (the tree and N × 40 bytes of instance data).
"""
import json
import math
import struct
import sys


def tree():
    """Positions, normals and u32 triangles of the trunk (a closed cylinder) and the canopy (a
    UV sphere); 4,960 triangles."""
    prims = []
    # Trunk: 32 segments, radius 0.15, height 1.5, sides only.
    seg = 32
    pos, nrm, idx = [], [], []
    for k in range(seg + 1):
        a = 2 * math.pi * k / seg
        c, s = math.cos(a), math.sin(a)
        for y in (0.0, 1.5):
            pos.append((0.15 * c, y, 0.15 * s))
            nrm.append((c, 0.0, s))
    for k in range(seg):
        a, b, c, d = 2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 3
        idx += [a, b, c, c, b, d]
    prims.append((pos, nrm, idx))
    # Canopy: 64 × 38 quads of a sphere of radius 1 centred 2.2 up (the poles' quads degenerate
    # into triangles, written as two anyway: counted as triangles by the reader, zero-area ones
    # dropped).
    lon, lat = 64, 38
    pos, nrm, idx = [], [], []
    for j in range(lat + 1):
        th = math.pi * j / lat
        for i in range(lon + 1):
            ph = 2 * math.pi * i / lon
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos.append((n[0], 2.2 + n[1], n[2]))
            nrm.append(n)
    for j in range(lat):
        for i in range(lon):
            a = j * (lon + 1) + i
            b, c, d = a + 1, a + lon + 1, a + lon + 2
            idx += [a, b, c, b, d, c]
    prims.append((pos, nrm, idx))
    return prims


def main():
    out, n = sys.argv[1], int(sys.argv[2])
    bin_ = bytearray()
    views, accessors = [], []

    def add(data, count, ctype, typ, extra=None):
        while len(bin_) % 4:
            bin_.append(0)
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": len(data)})
        bin_.extend(data)
        acc = {"bufferView": len(views) - 1, "componentType": ctype, "count": count, "type": typ}
        acc.update(extra or {})
        accessors.append(acc)
        return len(accessors) - 1

    primitives = []
    for m, (pos, nrm, idx) in enumerate(tree()):
        lo = [min(p[k] for p in pos) for k in range(3)]
        hi = [max(p[k] for p in pos) for k in range(3)]
        pa = add(b"".join(struct.pack("<3f", *p) for p in pos), len(pos), 5126, "VEC3",
                 {"min": lo, "max": hi})
        na = add(b"".join(struct.pack("<3f", *v) for v in nrm), len(nrm), 5126, "VEC3")
        ia = add(struct.pack(f"<{len(idx)}I", *idx), len(idx), 5125, "SCALAR")
        primitives.append({"attributes": {"POSITION": pa, "NORMAL": na}, "indices": ia,
                           "material": m})
    node = {"mesh": 0}
    doc = {"asset": {"version": "2.0"}}
    if n > 1:
        side = math.ceil(math.sqrt(n))
        t, r, s = [], [], []
        for k in range(n):
            x, z = 4.0 * (k % side), 4.0 * (k // side)
            a = 0.5 * (k * 2.399963) % (2 * math.pi)
            t.append((x, 0.0, z))
            r.append((0.0, math.sin(a / 2), 0.0, math.cos(a / 2)))
            f = 0.8 + 0.4 * ((k * 7919) % 101) / 100
            s.append((f, f, f))
        ta = add(b"".join(struct.pack("<3f", *v) for v in t), n, 5126, "VEC3")
        ra = add(b"".join(struct.pack("<4f", *v) for v in r), n, 5126, "VEC4")
        sa = add(b"".join(struct.pack("<3f", *v) for v in s), n, 5126, "VEC3")
        node["extensions"] = {"EXT_mesh_gpu_instancing": {
            "attributes": {"TRANSLATION": ta, "ROTATION": ra, "SCALE": sa}}}
        doc["extensionsUsed"] = ["EXT_mesh_gpu_instancing"]
        doc["extensionsRequired"] = ["EXT_mesh_gpu_instancing"]
    doc.update({
        "scenes": [{"nodes": [0]}],
        "scene": 0,
        "nodes": [node],
        "meshes": [{"name": "Tree", "primitives": primitives}],
        "materials": [
            {"name": "bark", "pbrMetallicRoughness": {
                "baseColorFactor": [0.3, 0.2, 0.1, 1], "metallicFactor": 0, "roughnessFactor": 1}},
            {"name": "leaves", "pbrMetallicRoughness": {
                "baseColorFactor": [0.1, 0.5, 0.1, 1], "metallicFactor": 0, "roughnessFactor": 1}},
        ],
        "buffers": [{"byteLength": len(bin_)}],
        "bufferViews": views,
        "accessors": accessors,
    })
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    bin_ += b"\0" * (-len(bin_) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(out, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(bin_), b"BIN\0") + bin_)


if __name__ == "__main__":
    main()
