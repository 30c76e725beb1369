#!/usr/bin/env python3
"""A glTF of 36 leaf cards with an 8x8 checkerboard alpha texture over a floor, lit by a point
light: the scene on which docs/performance.md#what-absent-features-cost measures what alpha
cut-outs cost per sample.

    python3 scripts/cutout_cards.py MASK|BLEND OUT.gltf

then, for instance, instructions per sample as the difference of two sample counts:
    valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
        target/release/ftpd3d --scene OUT.gltf --slice z=0.1 --res 24 --spp 8 \
        --batches 2 --threads 1 --no-png --quiet -o /tmp/c.exr      (and --spp 136)
"""
import base64, json, struct, sys, zlib

mode = sys.argv[1]  # MASK or BLEND
assert mode in ("MASK", "BLEND"), "first argument: MASK or BLEND"
N = 8


def png_rgba(n, pixel):
    """An n x n RGBA PNG (8 bits per channel) of pixel(i, j)."""
    rows = b"".join(b"\0" + b"".join(bytes(pixel(i, j)) for i in range(n)) for j in range(n))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    head = struct.pack(">IIBBBBB", n, n, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", head) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


png = png_rgba(N, lambda i, j: (200, 200, 200, 255 if (i + j) % 2 == 0 else 0))
pos, uv, idx = [], [], []
def quad(x0, z0, x1, z1, y, up=True):
    b = len(pos)
    for (x, z) in [(x0, z0), (x1, z0), (x1, z1), (x0, z1)]:
        pos.append((x, y, z)); uv.append(((x - x0) / (x1 - x0), (z - z0) / (z1 - z0)))
    # counter-clockwise seen from +y: (x0,z0),(x0,z1),(x1,z1)... choose winding facing +y
    t = [(b, b + 3, b + 2), (b, b + 2, b + 1)]
    idx.extend(t)
quad(-2, -2, 2, 2, 0.0)
floor_count = len(idx)
K = 6
for a in range(K):
    for c in range(K):
        x0 = -1.5 + 3.0 * a / K; z0 = -1.5 + 3.0 * c / K
        quad(x0, z0, x0 + 3.0 / K * 0.9, z0 + 3.0 / K * 0.9, 1.0 + 0.1 * ((a + c) % 3))
buf = b''
def add(data):
    global buf
    off = len(buf); buf += data
    while len(buf) % 4: buf += b'\0'
    return off, len(data)
pb = b''.join(struct.pack('<3f', *p) for p in pos)
ub = b''.join(struct.pack('<2f', *t) for t in uv)
ib_floor = b''.join(struct.pack('<3I', *t) for t in idx[:floor_count])
ib_leaf = b''.join(struct.pack('<3I', *t) for t in idx[floor_count:])
views = []
for data in (pb, ub, ib_floor, ib_leaf):
    o, l = add(data); views.append({'buffer': 0, 'byteOffset': o, 'byteLength': l})
xs = [p[0] for p in pos]; ys = [p[1] for p in pos]; zs = [p[2] for p in pos]
acc = [
 {'bufferView': 0, 'componentType': 5126, 'count': len(pos), 'type': 'VEC3', 'min': [min(xs), min(ys), min(zs)], 'max': [max(xs), max(ys), max(zs)]},
 {'bufferView': 1, 'componentType': 5126, 'count': len(uv), 'type': 'VEC2'},
 {'bufferView': 2, 'componentType': 5125, 'count': floor_count * 3, 'type': 'SCALAR'},
 {'bufferView': 3, 'componentType': 5125, 'count': (len(idx) - floor_count) * 3, 'type': 'SCALAR'},
]
leaf = {'name': 'leaf', 'pbrMetallicRoughness': {'baseColorTexture': {'index': 0}, 'metallicFactor': 0, 'roughnessFactor': 1}, 'alphaMode': mode, 'doubleSided': True}
if mode == 'MASK': leaf['alphaCutoff'] = 0.5
g = {
 'asset': {'version': '2.0'},
 'extensionsUsed': ['KHR_lights_punctual'],
 'extensions': {'KHR_lights_punctual': {'lights': [{'type': 'point', 'color': [1, 1, 1], 'intensity': 200.0}]}},
 'scene': 0, 'scenes': [{'nodes': [0, 1]}],
 'nodes': [{'mesh': 0}, {'translation': [0.3, 2.5, 0.2], 'extensions': {'KHR_lights_punctual': {'light': 0}}}],
 'meshes': [{'primitives': [
    {'attributes': {'POSITION': 0, 'TEXCOORD_0': 1}, 'indices': 2, 'material': 0},
    {'attributes': {'POSITION': 0, 'TEXCOORD_0': 1}, 'indices': 3, 'material': 1}]}],
 'materials': [{'name': 'floor', 'pbrMetallicRoughness': {'baseColorFactor': [0.6, 0.6, 0.6, 1], 'metallicFactor': 0, 'roughnessFactor': 1}}, leaf],
 'textures': [{'source': 0, 'sampler': 0}],
 'samplers': [{'magFilter': 9728, 'minFilter': 9728}],
 'images': [{'uri': 'data:image/png;base64,' + base64.b64encode(png).decode()}],
 'accessors': acc, 'bufferViews': views,
 'buffers': [{'byteLength': len(buf), 'uri': 'data:application/octet-stream;base64,' + base64.b64encode(buf).decode()}],
}
json.dump(g, open(sys.argv[2], 'w'))
