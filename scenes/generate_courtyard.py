#!/usr/bin/env python3
"""Generate the outdoor scene scenes/courtyard/ (standard library only).

Run from anywhere:  python3 scenes/generate_courtyard.py
It (re)writes, deterministically (re-running leaves `git diff` empty):

  courtyard/courtyard.obj, courtyard.mtl   the geometry, with `vt` on textured faces
  courtyard/floor.png                      one floor tile per metre (map_Kd of the ground)
  courtyard/stone.png                      ashlar blocks, 1 m x 1 m (map_Kd of the arcades)
  courtyard/leaf.png                       leaf colour (map_Kd of the leaf cards)
  courtyard/leaf_mask.png                  leaf silhouette in the alpha channel, 0 or 255 (map_d)
  courtyard/sky.hdr                        lat-long sky without a sun, Radiance RGBE, 128 x 64
  courtyard/courtyard.toml                 sidecar: mesh, sun, environment, camera, named slices

A square courtyard (x, z in [-6, 6], 12 m) with an arcade on its north (-z) and south (+z) sides
(six square columns, five semicircular arches of 12 segments, a roof slab and a back wall each)
and a tree in the middle (a tapered trunk and a crown of leaf cards: alpha-masked quads at
pseudo-random positions and orientations in an ellipsoid shell). With -z as north, the east
and west sides (+-x) are open, so the sky and the low sun reach the ground.

Conventions are those of generate.py (whose mesh helpers this script uses): metres, y up,
counter-clockwise winding = front side, closed solids face outward and are watertight by index,
solids standing on the ground are lifted by LIFT. The textured materials carry a `Kd` equal to
their texture's mean linear albedo, so a loader that ignores the maps sees the same brightness.

The images are written by hand (PNG: stored deflate blocks, CRC and Adler-32 from zlib; RGBE:
literal run-length scanlines), so their bytes depend on nothing but this script (a compressing
zlib could change its output between versions and break the empty `git diff`).
"""

import math
import os
import struct
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import generate as g  # noqa: E402  (the shared mesh helpers)

OUT = os.path.join(HERE, 'courtyard')
GENERATOR = 'scenes/generate_courtyard.py'
LIFT = g.LIFT

# ----------------------------------------------------------------------------
# Deterministic pseudo-random numbers (SplitMix64: the same on every Python)
# ----------------------------------------------------------------------------

MASK64 = (1 << 64) - 1


class Rng:
    def __init__(self, seed):
        self.state = seed & MASK64

    def next_u64(self):
        self.state = (self.state + 0x9E3779B97F4A7C15) & MASK64
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
        return z ^ (z >> 31)

    def uniform(self, lo=0.0, hi=1.0):
        return lo + (hi - lo) * (self.next_u64() >> 11) / float(1 << 53)


def hash01(*ints):
    """A value in [0, 1) from integers (texel noise)."""
    r = Rng(0)
    for i in ints:
        r.state = (r.state ^ (i & MASK64)) * 0x100000001B3 & MASK64
        r.next_u64()
    return (r.next_u64() >> 11) / float(1 << 53)


# ----------------------------------------------------------------------------
# Vector helpers
# ----------------------------------------------------------------------------

def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


# ----------------------------------------------------------------------------
# Images
# ----------------------------------------------------------------------------

def srgb_to_linear(c):
    """8-bit sRGB value / 255 to linear (as the loader decodes colour maps)."""
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def write_png(path, width, height, pixels, channels):
    """8-bit RGB (channels 3) or RGBA (4) PNG, rows from the top; `pixels[y][x]` is a tuple of
    ints 0..255. The zlib stream is made of stored (uncompressed) deflate blocks."""
    raw = bytearray()
    for row in pixels:
        raw.append(0)                                   # filter: none
        for px in row:
            raw.extend(px[:channels])
    z = bytearray(b'\x78\x01')                          # deflate, 32K window, no dictionary
    for start in range(0, len(raw), 65535):
        block = raw[start:start + 65535]
        final = 1 if start + 65535 >= len(raw) else 0
        z.append(final)                                 # BFINAL, BTYPE = 00 (stored)
        z.extend(struct.pack('<HH', len(block), len(block) ^ 0xFFFF))
        z.extend(block)
    z.extend(struct.pack('>I', zlib.adler32(bytes(raw)) & 0xFFFFFFFF))

    def chunk(kind, data):
        return (struct.pack('>I', len(data)) + kind + data
                + struct.pack('>I', zlib.crc32(kind + data) & 0xFFFFFFFF))
    colour_type = {3: 2, 4: 6}[channels]
    png = (b'\x89PNG\r\n\x1a\n'
           + chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, colour_type, 0, 0, 0))
           + chunk(b'IDAT', bytes(z))
           + chunk(b'IEND', b''))
    with open(path, 'wb') as f:
        f.write(png)


def mean_linear(pixels, weight=None):
    """Mean linear albedo (r, g, b) of an sRGB image, optionally over texels with weight 1."""
    acc, n = [0.0, 0.0, 0.0], 0
    for y, row in enumerate(pixels):
        for x, px in enumerate(row):
            if weight is not None and not weight(x, y):
                continue
            for k in range(3):
                acc[k] += srgb_to_linear(px[k] / 255.0)
            n += 1
    return tuple(a / n for a in acc)


def clamp8(v):
    return max(0, min(255, int(round(v))))


TEX = 64      # texels per side of every texture


def floor_texture():
    """One square floor tile per texture (1 m): terracotta with texel noise, 3 cm grout lines
    (2 texels on each edge)."""
    px = []
    for y in range(TEX):
        row = []
        for x in range(TEX):
            n = hash01(1, x, y) - 0.5
            if min(x, y) < 2 or max(x, y) >= TEX - 2:
                row.append(tuple(clamp8(c + 10 * n) for c in (148, 142, 132)))
            else:
                shade = 1.0 + 0.08 * n + 0.04 * math.sin(0.31 * x + 0.17 * y)
                row.append(tuple(clamp8(c * shade) for c in (186, 112, 74)))
        px.append(row)
    return px


def stone_texture():
    """Ashlar, 1 m x 1 m: four courses of 0.25 m, blocks 0.5 m long shifted by half a block on
    every other course, 1-texel mortar lines, each block its own shade of sandstone."""
    course, block = TEX // 4, TEX // 2
    px = []
    for y in range(TEX):
        row = []
        c = y // course
        for x in range(TEX):
            xs = (x + (block // 2 if c % 2 else 0)) % TEX
            b = xs // block
            n = hash01(2, x, y) - 0.5
            if y % course == 0 or xs % block == 0:
                row.append(tuple(clamp8(v + 8 * n) for v in (170, 164, 150)))
            else:
                shade = 0.92 + 0.16 * hash01(3, c, b) + 0.06 * n
                row.append(tuple(clamp8(v * shade) for v in (214, 196, 160)))
        px.append(row)
    return px


def leaf_inside(x, y):
    """Whether texel (x, y) (row y from the top) lies in the leaf: a stalk from the bottom edge
    (v = 0) and a pointed blade up to v = 0.96 (the tip towards v = 1)."""
    u = (x + 0.5) / TEX
    v = 1.0 - (y + 0.5) / TEX
    if v < 0.14:
        return abs(u - 0.5) < 0.03
    if v > 0.96:
        return False
    s = (v - 0.1) / 0.86
    half = 0.40 * math.sin(math.pi * s) ** 0.8 * (1.0 - 0.25 * s)
    return abs(u - 0.5) < half


def leaf_textures():
    """Colour (RGB) and mask (RGBA, alpha 0 or 255) of the leaf. The colour is defined
    everywhere (no dark fringe where bilinear lookups reach outside the silhouette)."""
    colour, mask = [], []
    for y in range(TEX):
        crow, mrow = [], []
        v = 1.0 - (y + 0.5) / TEX
        for x in range(TEX):
            u = (x + 0.5) / TEX
            n = hash01(4, x, y) - 0.5
            d = abs(u - 0.5)
            vein = d < 0.02 or abs(d * 1.6 - (v - 0.2) % 0.16) < 0.012 and 0.2 < v < 0.9
            base = (112, 160, 58) if vein else (58, 112, 34)
            shade = 0.9 + 0.25 * v + 0.08 * n
            crow.append(tuple(clamp8(c * shade) for c in base))
            mrow.append((255, 255, 255, 255 if leaf_inside(x, y) else 0))
        colour.append(crow)
        mask.append(mrow)
    return colour, mask


def write_hdr(path, width, height, pixel):
    """Radiance RGBE (new-style run-length scanlines, every run a literal dump); `pixel(x, y)`
    gives linear (r, g, b) for column x, row y from the top."""
    out = bytearray(b'#?RADIANCE\n# generated by %s\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n'
                    % (GENERATOR.encode(), height, width))
    for y in range(height):
        rgbe = []
        for x in range(width):
            r, gr, b = pixel(x, y)
            v = max(r, gr, b)
            if v < 1e-32:
                rgbe.append((0, 0, 0, 0))
            else:
                m, e = math.frexp(v)
                s = m * 256.0 / v
                rgbe.append((int(r * s), int(gr * s), int(b * s), e + 128))
        out.extend(bytes((2, 2, width >> 8, width & 0xFF)))
        for k in range(4):
            comp = [p[k] for p in rgbe]
            for start in range(0, width, 128):
                run = comp[start:start + 128]
                out.append(len(run))                    # a dump of len(run) literal bytes
                out.extend(bytes(run))
    with open(path, 'wb') as f:
        f.write(out)


SKY_W, SKY_H = 128, 64
ZENITH = (0.10, 0.20, 0.48)
HORIZON = (0.62, 0.68, 0.78)
BELOW = (0.16, 0.14, 0.12)       # the land beyond the courtyard, lit by sun and sky


def sky_pixel(x, y):
    """Lat-long sky (row 0 the zenith): a blue gradient brightening towards the horizon; below it
    a dim ground colour. No sun (the sidecar's [[sun]] is that), no dependence on azimuth."""
    theta = math.pi * (y + 0.5) / SKY_H
    elev = math.pi / 2 - theta
    if elev <= 0.0:
        return BELOW
    w = (1.0 - math.sin(elev)) ** 3
    return tuple(z + (h - z) * w for z, h in zip(ZENITH, HORIZON))


# ----------------------------------------------------------------------------
# Geometry
# ----------------------------------------------------------------------------

HALF = 6.0            # the courtyard spans x, z in [-HALF, HALF]
COL = 0.4             # square columns, COL x COL
N_COL = 6             # columns per arcade (five bays)
SPRING = 2.4          # height of the arches' springing
BEAM_TOP = 3.6        # top of the arcade front (and of the back wall)
ROOF = 0.25           # roof slab thickness
FRONT = (-3.4, -3.0)  # z range of the north arcade's front (columns and arches)
WALL = (-6.0, -5.7)   # z range of the north back wall
ARCH_SEGMENTS = 12


class TexMesh(g.Mesh):
    """A Mesh whose faces may carry explicit texture coordinates (one (u, v) per corner);
    faces of textured materials without them get a planar projection when written."""

    def __init__(self, name, material):
        super().__init__(name, material)
        self.uvs = {}            # face index -> tuple of (u, v)

    def face_uv(self, uvs, *idx, material=None):
        self.face(*idx, material=material)
        self.uvs[len(self.faces) - 1] = tuple(uvs)


def as_texmesh(m):
    t = TexMesh(m.name, m.material)
    t.verts, t.faces = m.verts, m.faces
    return t


def arcade_front(name, material, z0, z1):
    """The front of an arcade running along x over [-HALF, HALF]: N_COL square columns and the
    semicircular arches between them with the wall above, one closed prism over z in [z0, z1].

    The profile (x-y plane, counter-clockwise seen from +z) runs along the column feet and up
    and over every arch; the caps are the column rectangles plus one vertical strip (a
    trapezoid) per segment of the chain of column tops and arch points, up to BEAM_TOP, so no
    fan and no T-junction is needed."""
    span = (2 * HALF - N_COL * COL) / (N_COL - 1)
    r = span / 2.0
    pts = []

    def p(x, y):
        pts.append((x, y))
        return len(pts) - 1

    chain = []           # lower chain of the beam: column tops and arch points, x increasing
    feet = []            # (left foot, right foot) of every column
    for i in range(N_COL):
        c0 = -HALF + i * (COL + span)
        c1 = c0 + COL
        feet.append((p(c0, LIFT), p(c1, LIFT)))
        chain += [p(c0, SPRING), p(c1, SPRING)]
        if i < N_COL - 1:
            xm = c1 + r
            for k in range(1, ARCH_SEGMENTS):
                a = math.pi * (1.0 - k / ARCH_SEGMENTS)
                chain.append(p(xm + r * math.cos(a), SPRING + r * math.sin(a)))
    top = [p(pts[c][0], BEAM_TOP) for c in chain]

    # chain[PER * i] and chain[PER * i + 1] are column i's top left and top right corners, the
    # arch points of bay i follow them.
    per = 2 + ARCH_SEGMENTS - 1
    # The profile, counter-clockwise: feet, column sides and arches left to right, then the top
    # right to left, then down the left end.
    profile = []
    for i, (lf, rf) in enumerate(feet):
        if i > 0:
            profile.append(chain[per * i])           # down the column's left side
        profile += [lf, rf]
        profile += chain[per * i + 1:per * (i + 1)]  # up its right side and over the arch
    profile += top[::-1]
    profile.append(chain[0])
    assert len(set(profile)) == len(profile) == len(pts), 'profile must use every point once'

    caps = [[lf, rf, chain[per * i + 1], chain[per * i]] for i, (lf, rf) in enumerate(feet)]
    caps += [[chain[k], chain[k + 1], top[k + 1], top[k]] for k in range(len(chain) - 1)]

    m = TexMesh(name, material)
    back = [m.vert((x, y, z0)) for x, y in pts]
    front = [m.vert((x, y, z1)) for x, y in pts]
    for c in caps:
        m.face(*[front[i] for i in c])
        m.face(*[back[i] for i in reversed(c)])
    n = len(profile)
    for k in range(n):
        a, b = profile[k], profile[(k + 1) % n]
        m.face(back[a], back[b], front[b], front[a])
    return m


def turned(m, name):
    """A copy of mesh `m` turned by 180 degrees about +y (x, z -> -x, -z): a rotation, so the
    winding keeps its sense."""
    t = TexMesh(name, m.material)
    t.verts = [(-x, y, -z) for x, y, z in m.verts]
    t.faces = list(m.faces)
    t.uvs = dict(getattr(m, 'uvs', {}))
    return t


def arcade(side):
    """The north arcade (side 'north', along z = -HALF) or its copy turned to the south."""
    front = arcade_front('arcade_front', 'stone', FRONT[0], FRONT[1])
    wall = as_texmesh(g.box('back_wall', 'stone', (0.0, (BEAM_TOP + LIFT) / 2, sum(WALL) / 2),
                            (2 * HALF, BEAM_TOP - LIFT, WALL[1] - WALL[0])))
    roof = as_texmesh(g.box('roof', 'plaster',
                            (0.0, BEAM_TOP + LIFT + ROOF / 2, (WALL[0] + FRONT[1]) / 2),
                            (2 * HALF, ROOF, FRONT[1] - WALL[0])))
    parts = [front, wall, roof]
    if side == 'north':
        for p in parts:
            p.name = '%s_%s' % (side, p.name)
        return parts
    return [turned(p, '%s_%s' % (side, p.name)) for p in parts]


def ground():
    m = TexMesh('ground', 'floor')
    idx = [m.vert(p) for p in ((-HALF, 0.0, HALF), (HALF, 0.0, HALF),
                               (HALF, 0.0, -HALF), (-HALF, 0.0, -HALF))]
    m.face(*idx)         # (+x) x (-z) = +y: faces up; uv by planar projection (1 tile per metre)
    return m


TRUNK_SIDES = 8
TRUNK_R = (0.17, 0.11)          # radius at the foot and at the top
TRUNK_TOP = 3.3
CROWN_C = (0.0, 3.7, 0.0)
CROWN_R = (1.9, 1.3, 1.9)       # semi-axes of the crown's ellipsoid
N_LEAVES = 240


def trunk():
    """A tapered prism with TRUNK_SIDES sides (faces, not corners, towards +-x and +-z), closed
    by its foot and top: watertight, outward."""
    m = g.Mesh('trunk', 'bark')
    ring = []
    for y, r in ((LIFT, TRUNK_R[0]), (TRUNK_TOP, TRUNK_R[1])):
        ring.append([m.vert((r * math.cos(a), y, r * math.sin(a)))
                     for a in (2 * math.pi * (k + 0.5) / TRUNK_SIDES for k in range(TRUNK_SIDES))])
    lo, hi = ring
    n = TRUNK_SIDES
    for k in range(n):
        k1 = (k + 1) % n
        # phi grows from +x towards +z: up x (the direction of growing phi) points outward.
        m.face(lo[k], hi[k], hi[k1], lo[k1])
    m.face(*hi[::-1])      # top: seen from above, phi's sense is clockwise, so reversed
    m.face(*lo)            # foot, facing down
    return m


def leaves():
    """N_LEAVES square cards of side 0.3 to 0.5 m, their centres in the shell 0.55..1 of the
    crown's ellipsoid, each facing a random direction tilted upwards, its leaf (v from stalk to
    tip) pointing away from the crown's centre with a random twist; uv 0..1 per card. Cards
    that could touch the trunk are redrawn."""
    rng = Rng(20240611)
    m = TexMesh('leaves', 'leaf')
    made = 0
    while made < N_LEAVES:
        # A point in the ellipsoid shell: a uniform direction, radius^3 uniform in [0.55^3, 1].
        zc = rng.uniform(-1.0, 1.0)
        ph = rng.uniform(0.0, 2.0 * math.pi)
        s = math.sqrt(1.0 - zc * zc)
        d = (s * math.cos(ph), zc, s * math.sin(ph))
        rad = rng.uniform(0.55 ** 3, 1.0) ** (1.0 / 3.0)
        c = tuple(CROWN_C[k] + CROWN_R[k] * rad * d[k] for k in range(3))
        size = rng.uniform(0.3, 0.5)
        # Facing: a uniform direction pulled upwards.
        zc = rng.uniform(-1.0, 1.0)
        ph = rng.uniform(0.0, 2.0 * math.pi)
        s = math.sqrt(1.0 - zc * zc)
        n = unit((s * math.cos(ph), zc + 0.8, s * math.sin(ph)))
        twist = rng.uniform(-0.5, 0.5)
        half_diag = size * math.sqrt(0.5)
        if (math.hypot(c[0], c[2]) < TRUNK_R[0] + half_diag + 0.05
                and c[1] < TRUNK_TOP + half_diag + 0.05):
            continue
        out = sub(c, CROWN_C)
        b = sub(out, tuple(dot(out, n) * nk for nk in n))          # outward, in the card
        if dot(b, b) < 1e-6:
            b = cross(n, (1.0, 0.0, 0.0))
        b = unit(b)
        t = cross(b, n)                                          # t x b = n: CCW front is n
        ct, st = math.cos(twist), math.sin(twist)
        t, b = (tuple(ct * t[k] + st * b[k] for k in range(3)),
                tuple(-st * t[k] + ct * b[k] for k in range(3)))
        h = size / 2.0
        corners = [tuple(c[k] + h * (su * t[k] + sv * b[k]) for k in range(3))
                   for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        idx = [m.vert(p) for p in corners]
        m.face_uv(((0, 0), (1, 0), (1, 1), (0, 1)), *idx)
        made += 1
    return m


# ----------------------------------------------------------------------------
# Writers
# ----------------------------------------------------------------------------

def planar_uv(p, n):
    """Texture coordinates in metres on the plane the face's dominant normal axis picks, turned
    so that the texture is not mirrored seen from the front (v up on walls, -z on floors)."""
    a = max(range(3), key=lambda k: abs(n[k]))
    s = 1.0 if n[a] > 0 else -1.0
    x, y, z = p
    if a == 0:
        return (-s * z, y)
    if a == 2:
        return (s * x, y)
    return (x, -s * z)


def write_obj_mtl(meshes, materials, textured):
    fmt = g.fmt
    title = 'A courtyard with two arcades and a tree of leaf cards'
    with open(os.path.join(OUT, 'courtyard.mtl'), 'w', newline='\n') as f:
        f.write('# %s -- generated by %s, do not edit\n' % (title, GENERATOR))
        for name, lines in materials.items():
            f.write('\nnewmtl %s\n' % name)
            for line in lines:
                f.write(line + '\n')

    vts, vt_index = [], {}

    def vt(uv):
        key = (fmt(uv[0]), fmt(uv[1]))
        if key not in vt_index:
            vts.append(key)
            vt_index[key] = len(vts)
        return vt_index[key]

    body = []
    base = 1
    for m in meshes:
        body.append('\no %s\n' % m.name)
        for p in m.verts:
            body.append('v %s %s %s\n' % tuple(fmt(c) for c in p))
        current = None
        uvs = getattr(m, 'uvs', {})
        for fi, (mat, idx) in enumerate(m.faces):
            if mat != current:
                body.append('usemtl %s\n' % mat)
                current = mat
            if mat in textured:
                if fi in uvs:
                    corner_uv = uvs[fi]
                else:
                    pv = [m.verts[i] for i in idx]
                    n = cross(sub(pv[1], pv[0]), sub(pv[2], pv[0]))
                    corner_uv = [planar_uv(p, n) for p in pv]
                body.append('f %s\n' % ' '.join('%d/%d' % (base + i, vt(uv))
                                                for i, uv in zip(idx, corner_uv)))
            else:
                body.append('f %s\n' % ' '.join(str(base + i) for i in idx))
        base += len(m.verts)

    with open(os.path.join(OUT, 'courtyard.obj'), 'w', newline='\n') as f:
        f.write('# %s -- generated by %s, do not edit\n' % (title, GENERATOR))
        f.write('# metres, y up, CCW winding = front side; vt in metres on the floor and stone\n')
        f.write('mtllib courtyard.mtl\n\n')
        for u, v in vts:
            f.write('vt %s %s\n' % (u, v))
        f.write(''.join(body))


SUN_DIRECTION = (-0.5, 0.8, 0.3)     # towards the sun: from -x (west) and a little +z, 54 deg high
SUN_IRRADIANCE = (5.0, 4.7, 4.2)     # slightly warm afternoon light

SIDECAR = '''\
# The courtyard: two arcades and a tree of alpha-masked leaf cards under an afternoon sun and a
# sky map -- generated by {gen}, do not edit.
mesh = "courtyard.obj"

[[sun]]                             # afternoon: west-south-west (-z is north), {elev:.0f} degrees high
direction = [{sd}]
irradiance = [{si}]
diameter_deg = 0.53

[environment]                       # the sky without the sun: blue, brighter towards the horizon
file = "sky.hdr"
scale = 1.0
rotation_deg = 0.0

[[camera]]                          # under the south arcade, through the middle arch and the tree
name = "arcade"
eye = [-0.8, 1.5, 5.2]
target = [0.4, 2.9, -4.0]
fov = 60.0

[[slice]]                           # just above the floor: the shadows of arcades and leaves
name = "ground"
plane = "y=0.05"

[[slice]]                           # eye height, through the columns, the trunk and the arcades
name = "walk"
plane = "y=1.2"

[[slice]]                           # vertical, north to south through the trunk's axis and crown
name = "tree"
plane = "x=0"
'''


def main():
    os.makedirs(OUT, exist_ok=True)
    floor_px = floor_texture()
    stone_px = stone_texture()
    leaf_px, mask_px = leaf_textures()
    write_png(os.path.join(OUT, 'floor.png'), TEX, TEX, floor_px, 3)
    write_png(os.path.join(OUT, 'stone.png'), TEX, TEX, stone_px, 3)
    write_png(os.path.join(OUT, 'leaf.png'), TEX, TEX, leaf_px, 3)
    write_png(os.path.join(OUT, 'leaf_mask.png'), TEX, TEX, mask_px, 4)
    write_hdr(os.path.join(OUT, 'sky.hdr'), SKY_W, SKY_H, sky_pixel)

    def kd(rgb):
        return 'Kd %s %s %s' % tuple(g.fmt(round(c, 4)) for c in rgb)
    materials = {
        'floor': ['illum 1', kd(mean_linear(floor_px)), 'map_Kd floor.png'],
        'stone': ['illum 1', kd(mean_linear(stone_px)), 'map_Kd stone.png'],
        'plaster': g.diffuse(0.75, 0.72, 0.66),
        'bark': g.diffuse(0.22, 0.16, 0.11),
        'leaf': ['illum 1', kd(mean_linear(leaf_px, lambda x, y: leaf_inside(x, y))),
                 'map_Kd leaf.png', 'map_d leaf_mask.png'],
    }
    meshes = [ground()] + arcade('north') + arcade('south') + [trunk(), leaves()]
    write_obj_mtl(meshes, materials, textured={'floor', 'stone', 'leaf'})

    s = SUN_DIRECTION
    elev = math.degrees(math.asin(s[1] / math.sqrt(dot(s, s))))
    with open(os.path.join(OUT, 'courtyard.toml'), 'w', newline='\n') as f:
        f.write(SIDECAR.format(gen=GENERATOR, elev=elev,
                               sd=', '.join('%.1f' % c for c in SUN_DIRECTION),
                               si=', '.join('%.1f' % c for c in SUN_IRRADIANCE)))


if __name__ == '__main__':
    main()
