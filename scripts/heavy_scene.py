#!/usr/bin/env python3
"""Writes a heavy benchmark scene: a closed diffuse room (the Cornell box's size) filled with a grid
of small glossy and diffuse icospheres, lit by a ceiling area light.

    python3 scripts/heavy_scene.py OUT.obj [SPHERES_PER_SIDE] [SUBDIVISIONS] [--attributes]
        [--materials M]

Default: 8 x 8 x 8 = 512 spheres of 1280 triangles (655k triangles, ~30 MB). Not shipped: the
benchmarks generate it when they need it. Standard library only; deterministic.

--attributes gives the spheres' vertices normals and texture coordinates (`vn`, `vt`, faces
`v/vt/vn`), as exported architecture scenes have; --materials M spreads the spheres over M materials
(diffuse and glossy, in turn) instead of two. The loading benchmark's scene, 10.2 M triangles in
about 1 GB, as users bring (docs/performance.md#loading-10-m-triangles):

    python3 scripts/heavy_scene.py OUT.obj 20 3 --attributes --materials 300
"""
import math
import os
import sys


def icosphere(level):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
         (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(level):
        cache = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                n = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / n for x in p))
                cache[key] = len(v) - 1
            return cache[key]

        nf = []
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return v, f


def main():
    args = sys.argv[1:]
    attributes = "--attributes" in args
    args = [a for a in args if a != "--attributes"]
    n_materials = None
    if "--materials" in args:
        k = args.index("--materials")
        n_materials = int(args[k + 1])
        del args[k:k + 2]
    out = args[0]
    n = int(args[1]) if len(args) > 1 else 8
    level = int(args[2]) if len(args) > 2 else 3
    verts, faces = icosphere(level)
    # Texture coordinates: longitude and latitude of the unit-sphere point.
    uvs = [(0.5 + math.atan2(p[2], p[0]) / (2 * math.pi), math.acos(max(-1.0, min(1.0, p[1]))) / math.pi)
           for p in verts]
    mtl = os.path.splitext(os.path.basename(out))[0] + ".mtl"
    with open(os.path.splitext(out)[0] + ".mtl", "w") as m:
        m.write("newmtl wall\nillum 1\nKd 0.7 0.7 0.7\n")
        m.write("newmtl light\nillum 1\nKd 0 0 0\nKe 20 20 20\n")
        m.write("newmtl matte\nillum 1\nKd 0.6 0.5 0.4\n")
        m.write("newmtl shiny\nillum 2\nKd 0.1 0.1 0.1\nKs 0.7 0.7 0.7\nNs 200\n")
        for k in range(n_materials or 0):
            g = 0.2 + 0.6 * k / max(1, n_materials - 1)
            if k % 2:
                m.write(f"newmtl m{k}\nillum 2\nKd {g * 0.5:.3f} {g * 0.4:.3f} 0.1\nKs 0.3 0.3 0.3\nNs {10 + k}\n")
            else:
                m.write(f"newmtl m{k}\nillum 1\nKd {g:.3f} {1 - g:.3f} 0.5\n")
    with open(out, "w") as o:
        o.write(f"mtllib {mtl}\n")
        nv = 0
        # Room: 2 x 2 x 2, inward-facing quads.
        room = [((-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)),   # floor (normal +y)
                ((-1, 2, -1), (-1, 2, 1), (1, 2, 1), (1, 2, -1)),   # ceiling (-y)
                ((-1, 0, -1), (-1, 2, -1), (1, 2, -1), (1, 0, -1)),  # back (+z)
                ((-1, 0, 1), (1, 0, 1), (1, 2, 1), (-1, 2, 1)),     # front (-z)
                ((-1, 0, -1), (-1, 0, 1), (-1, 2, 1), (-1, 2, -1)),  # left (+x)
                ((1, 0, -1), (1, 2, -1), (1, 2, 1), (1, 0, 1))]     # right (-x)
        o.write("o room\nusemtl wall\n")
        for q in room:
            for p in q:
                o.write("v %g %g %g\n" % p)
            o.write(f"f {nv + 1} {nv + 2} {nv + 3} {nv + 4}\n")
            nv += 4
        o.write("o light\nusemtl light\n")
        for p in ((-0.25, 1.98, -0.25), (-0.25, 1.98, 0.25), (0.25, 1.98, 0.25), (0.25, 1.98, -0.25)):
            o.write("v %g %g %g\n" % p)
        o.write(f"f {nv + 1} {nv + 2} {nv + 3} {nv + 4}\n")
        nv += 4
        r = 0.8 / n * 0.45
        na = 0  # vt and vn written so far
        for i in range(n):
            for j in range(n):
                for k in range(n):
                    c = (-0.8 + (i + 0.5) * 1.6 / n, 0.1 + (j + 0.5) * 1.6 / n, -0.8 + (k + 0.5) * 1.6 / n)
                    if n_materials:
                        name = f"m{((i * n + j) * n + k) % n_materials}"
                    else:
                        name = 'shiny' if (i + j + k) % 2 else 'matte'
                    o.write(f"o s{i}_{j}_{k}\nusemtl {name}\n")
                    o.write("".join("v %.6f %.6f %.6f\n" % (c[0] + r * p[0], c[1] + r * p[1], c[2] + r * p[2])
                                    for p in verts))
                    if attributes:
                        # One vt and one vn per vertex, so a corner's three indices are equal.
                        o.write("".join("vt %.6f %.6f\n" % uv for uv in uvs))
                        o.write("".join("vn %.6f %.6f %.6f\n" % p for p in verts))
                        # The room's vertices have neither, so vt/vn indices lag the v ones by nv - na.
                        o.write("".join(f"f {nv + a + 1}/{na + a + 1}/{na + a + 1} {nv + b + 1}/{na + b + 1}/{na + b + 1} "
                                        f"{nv + cc + 1}/{na + cc + 1}/{na + cc + 1}\n" for a, b, cc in faces))
                        na += len(verts)
                    else:
                        o.write("".join(f"f {nv + a + 1} {nv + b + 1} {nv + cc + 1}\n" for a, b, cc in faces))
                    nv += len(verts)


if __name__ == "__main__":
    main()
