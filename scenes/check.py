#!/usr/bin/env python3
"""Sanity checks for the OBJ+MTL scenes in this directory (standard library only).

    python3 scenes/check.py            # checks every scene listed in EXPECT
    python3 scenes/check.py a.obj ...  # checks the given files (generic checks only)

For every OBJ it verifies
  * every face has >= 3 vertices and valid (1-based or negative) indices,
    polygons with more than 3 vertices are planar, and every `usemtl` names
    a material of the `mtllib`;
  * no triangle (after fan triangulation, as the loader does) has zero area;
  * closed solids are watertight and consistently wound: every edge is shared
    by exactly two triangles that traverse it in opposite directions, no two
    vertices of an object coincide, and the signed volume has the expected
    sign (> 0 for outward-facing solids, < 0 for the inward-facing room);
  * objects do not intersect each other: no edge of one object crosses a
    triangle of another, and no two triangles of different objects are
    coplanar and overlap;
  * every light (material with non-zero Ke) is flat, the centre of the
    scene's non-emissive geometry lies on its front side, and a ray from its
    centre along its front normal hits non-emissive geometry (it shines into
    the scene); in a room every object lies strictly inside the room;
  * stair wall only: the centre of every tread sees the light's centre and
    corners;
  * flatland scenes (flat_* and those in FLATLAND): every triangle crossing
    z = 0 has its normal in that plane (the scene is extruded along z, as
    --flatland requires);
  * texture coordinates and maps: every `vt` has two or three numbers, every face
    of a material with a map gives a `vt` for each corner (indices in range),
    every map file exists next to the MTL and is a PNG that decodes (chunk
    CRCs, zlib stream, filters, size), a `map_d` image has an alpha channel
    (or is grey), and (courtyard) the leaf mask's alpha is 0 or 255 only;
  * sidecars (`.toml` listed in SIDECARS, read with tomllib): the mesh and the
    environment map exist, the map is a Radiance RGBE image that decodes with
    finite non-negative texels, every sun is above the horizon, every
    named slice and camera lies inside the scene's bounds, and every point
    light is finite and lies in every named slice;
and prints bounds per scene and object. Exits non-zero on any failure.
"""

import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))

# Expected kind of each object: 'solid' (closed, outward), 'room' (closed,
# inward) or 'open' (an open surface: panels, planes, lights). Objects of a
# scene not listed here are an error, so new objects must be declared.
EXPECT = {
    'cornell_mirror.obj': {'room': 'room', 'light': 'open',
                           'tall_box': 'solid', 'mirror_panel': 'solid'},
    'stair_wall.obj': {'stairs': 'solid', 'light': 'open'},
    'mirror_plane.obj': {'plane': 'open'},
    'diffuse_plane.obj': {'plane': 'open'},
    'glossy_panels.obj': {'panel_0_phong37': 'open', 'strip_0': 'open',
                          'panel_1_phong112': 'open', 'strip_1': 'open',
                          'panel_2_phong1029': 'open', 'strip_2': 'open',
                          'panel_3_mirror': 'open', 'light': 'open'},
    'glass_sphere.obj': {'sphere': 'solid', 'floor': 'open', 'light': 'open'},
    'smooth_sphere.obj': {'sphere': 'solid', 'floor': 'open', 'light': 'open'},
    'flat_stair_wall.obj': {'stairs': 'solid', 'light': 'open'},
    'flat_mirrors.obj': {'light': 'open', 'mirror_left': 'solid', 'mirror_right': 'solid',
                         'box_left': 'solid', 'box_right': 'solid'},
    'courtyard/courtyard.obj': {
        'ground': 'open',
        'north_arcade_front': 'solid', 'north_back_wall': 'solid', 'north_roof': 'solid',
        'south_arcade_front': 'solid', 'south_back_wall': 'solid', 'south_roof': 'solid',
        'trunk': 'solid', 'leaves': 'open'},
    # The paper's figures (generate_paper.py)
    'paper/fig3a_stairs.obj': {'stairs': 'solid', 'light': 'open'},
    'paper/fig3b_mirrors.obj': {'light': 'open', 'mirror_left': 'solid', 'mirror_right': 'solid',
                                'box_left': 'solid', 'box_right': 'solid'},
    'paper/fig3c_curved_mirror.obj': {'light': 'open', 'curved_mirror': 'solid', 'cube': 'solid'},
    'paper/fig4a_glossy_reflectors.obj': {'light': 'open', 'mirror_left': 'solid',
                                          'mirror_right': 'solid', 'box_left': 'solid',
                                          'box_right': 'solid'},
    'paper/fig4c_patches.obj': {'border_left': 'open', 'patch_0_phong37': 'open',
                                'strip_0': 'open', 'patch_1_phong112': 'open', 'strip_1': 'open',
                                'patch_2_phong1029': 'open', 'strip_2': 'open',
                                'patch_3_mirror': 'open', 'border_right': 'open'},
    'paper/fig5_glass.obj': {'glass': 'solid', 'floor': 'open', 'light': 'open'},
    'paper/fig6a_u_room.obj': {'room': 'room', 'partition': 'solid', 'light': 'open'},
    'paper/fig6b_door.obj': {'room': 'room', 'wall_back': 'solid', 'wall_front': 'solid',
                             'lintel': 'solid', 'door': 'solid'},
    'paper/fig6c_canal.obj': {'canal': 'open'},
    'paper/fig6c_canal_obstacle.obj': {'canal': 'open', 'obstacle': 'solid'},
    'paper/fig7a_mirror_prism.obj': {'room': 'room', 'arrow': 'solid', 'square': 'solid',
                                     'mirror': 'solid', 'prism': 'solid'},
}

# Flatland scenes (checked for extrusion along z): the flat_* scenes and these.
FLATLAND = {'paper/fig3a_stairs.obj', 'paper/fig3b_mirrors.obj', 'paper/fig3c_curved_mirror.obj',
            'paper/fig4a_glossy_reflectors.obj', 'paper/fig4c_patches.obj',
            'paper/fig5_glass.obj', 'paper/fig7a_mirror_prism.obj'}

# Sidecar scene files to check (relative to this directory).
SIDECARS = ['courtyard/courtyard.toml', 'paper/fig4c_patches.toml', 'paper/fig6b_door.toml',
            'paper/fig6c_canal.toml', 'paper/fig6c_canal_obstacle.toml',
            'courtyard/fig7c_courtyard.toml']

# Map images whose alpha must be binary (0 or 255): cut-out masks meant to be exact.
BINARY_ALPHA = {'courtyard/leaf_mask.png'}

EPS = 1e-9


# ----------------------------------------------------------------------------
# Vector helpers
# ----------------------------------------------------------------------------

def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return math.sqrt(dot(a, a))


def unit(a):
    n = norm(a)
    return (a[0] / n, a[1] / n, a[2] / n)


def fmtv(v):
    return '(%s)' % ', '.join('%.4g' % (c + 0.0) for c in v)


# ----------------------------------------------------------------------------
# Parsing
# ----------------------------------------------------------------------------

class Obj:
    def __init__(self, name):
        self.name = name
        self.tris = []            # (i0, i1, i2) global 0-based vertex indices
        self.tri_mats = []        # material of each triangle


def parse_mtl(path):
    mats, cur = {}, None
    with open(path) as f:
        for line in f:
            tok = line.split()
            if not tok or tok[0].startswith('#'):
                continue
            if tok[0] == 'newmtl':
                cur = tok[1]
                mats[cur] = {}
            elif cur is not None and (tok[0].startswith('map_') or tok[0] in ('bump', 'disp')):
                mats[cur][tok[0]] = line.split(None, 1)[1].strip()      # options and a file name
            elif cur is not None:
                mats[cur][tok[0]] = [float(t) for t in tok[1:]]
    return mats


def textured(mats, m):
    return any(k.startswith('map_') for k in mats.get(m, {}))


def parse_obj(path, errors):
    verts, objects, mats = [], [], {}
    obj, mat = None, None
    n_vt = 0
    with open(path) as f:
        for lineno, line in enumerate(f, 1):
            tok = line.split()
            if not tok or tok[0].startswith('#'):
                continue
            kind = tok[0]
            if kind == 'v':
                verts.append(tuple(float(t) for t in tok[1:4]))
            elif kind == 'vt':
                if len(tok) not in (3, 4):
                    errors.append('line %d: vt needs 2 or 3 numbers' % lineno)
                [float(t) for t in tok[1:]]
                n_vt += 1
            elif kind == 'mtllib':
                mats.update(parse_mtl(os.path.join(os.path.dirname(path), tok[1])))
            elif kind in ('o', 'g'):
                obj = Obj(tok[1])
                objects.append(obj)
            elif kind == 'usemtl':
                mat = tok[1]
                if mat not in mats:
                    errors.append('line %d: usemtl %s not in the mtllib' % (lineno, mat))
            elif kind == 'f':
                if obj is None:
                    obj = Obj('(default)')
                    objects.append(obj)
                idx = []
                without_vt = False
                for t in tok[1:]:
                    parts = t.split('/')
                    if len(parts) > 1 and parts[1]:
                        k = int(parts[1])
                        k = k - 1 if k > 0 else n_vt + k
                        if not 0 <= k < n_vt:
                            errors.append('line %d: texture coordinate index %s out of range'
                                          % (lineno, t))
                    else:
                        without_vt = True
                    i = int(parts[0])
                    i = i - 1 if i > 0 else len(verts) + i
                    if not 0 <= i < len(verts):
                        errors.append('line %d: vertex index %s out of range' % (lineno, t))
                        i = None
                    idx.append(i)
                if without_vt and textured(mats, mat):
                    errors.append('line %d: a face of textured material %s without a vt on '
                                  'every corner' % (lineno, mat))
                if len(idx) < 3:
                    errors.append('line %d: face with %d vertices' % (lineno, len(idx)))
                    continue
                if None in idx:
                    continue
                if len(idx) > 3 and not planar([verts[i] for i in idx]):
                    errors.append('line %d: non-planar polygon' % lineno)
                for k in range(1, len(idx) - 1):      # fan, as the loader does
                    obj.tris.append((idx[0], idx[k], idx[k + 1]))
                    obj.tri_mats.append(mat)
            elif kind == 'vn':
                # Shading normals: only smooth_sphere has them, and they must be unit vectors.
                n = tuple(float(t) for t in tok[1:4])
                if not os.path.basename(path).startswith('smooth_'):
                    errors.append('line %d: unexpected vertex normal (flat geometry only)' % lineno)
                elif abs(math.sqrt(dot(n, n)) - 1.0) > 1e-5:
                    errors.append('line %d: vertex normal is not unit length' % lineno)
    return verts, objects, mats


# ----------------------------------------------------------------------------
# Geometry tests
# ----------------------------------------------------------------------------

def planar(pts, tol=1e-5):
    n = unit(cross(sub(pts[1], pts[0]), sub(pts[2], pts[0])))
    return all(abs(dot(n, sub(p, pts[0]))) < tol for p in pts[3:])


def tri_pts(verts, t):
    return verts[t[0]], verts[t[1]], verts[t[2]]


def tri_normal(verts, t):
    a, b, c = tri_pts(verts, t)
    return cross(sub(b, a), sub(c, a))      # length = 2 * area


def ray_tri(orig, d, a, b, c, eps=1e-9):
    """Moller-Trumbore. Returns (t, u, v) or None. eps > 0 accepts interior
    hits only; eps < 0 also accepts hits on the edges."""
    e1, e2 = sub(b, a), sub(c, a)
    p = cross(d, e2)
    det = dot(e1, p)
    if abs(det) < 1e-12:
        return None                      # parallel (or coplanar)
    inv = 1.0 / det
    s = sub(orig, a)
    u = dot(s, p) * inv
    if u < eps or u > 1 - eps:
        return None
    q = cross(s, e1)
    v = dot(d, q) * inv
    if v < eps or u + v > 1 - eps:
        return None
    return dot(e2, q) * inv, u, v


def edge_crosses_tri(p, q, tri, eps=1e-7):
    hit = ray_tri(p, sub(q, p), *tri, eps=eps)
    return hit is not None and eps < hit[0] < 1 - eps


def coplanar_overlap(t1, t2, eps=1e-7):
    """True if triangles t1, t2 (point triples) lie in one plane and their
    interiors overlap with positive area (sharing an edge is fine)."""
    n = cross(sub(t1[1], t1[0]), sub(t1[2], t1[0]))
    nn = norm(n)
    n = mul(n, 1.0 / nn)
    if any(abs(dot(n, sub(p, t1[0]))) > eps for p in t2):
        return False
    drop = max(range(3), key=lambda i: abs(n[i]))       # project to 2D
    keep = [i for i in range(3) if i != drop]
    a = [(p[keep[0]], p[keep[1]]) for p in t1]
    b = [(p[keep[0]], p[keep[1]]) for p in t2]
    for poly in (a, b):
        for k in range(3):
            e = (poly[(k + 1) % 3][0] - poly[k][0], poly[(k + 1) % 3][1] - poly[k][1])
            ax = (-e[1], e[0])
            pa = [ax[0] * x + ax[1] * y for x, y in a]
            pb = [ax[0] * x + ax[1] * y for x, y in b]
            tol = eps * math.hypot(*ax)
            if max(pa) <= min(pb) + tol or max(pb) <= min(pa) + tol:
                return False                           # separating axis
    return True


def bounds(points):
    lo = tuple(min(p[i] for p in points) for i in range(3))
    hi = tuple(max(p[i] for p in points) for i in range(3))
    return lo, hi


def first_hit(verts, objects, orig, d, skip=None):
    """Nearest proper hit (t, object, material) along orig + t d, t > 1e-6."""
    best = None
    for o in objects:
        if o is skip:
            continue
        for t, m in zip(o.tris, o.tri_mats):
            h = ray_tri(orig, d, *tri_pts(verts, t), eps=-1e-9)   # edges count
            if h and h[0] > 1e-6 and (best is None or h[0] < best[0]):
                best = (h[0], o, m)
    return best


def is_emissive(mats, m):
    return any(c > 0 for c in mats.get(m, {}).get('Ke', [0.0]))


# ----------------------------------------------------------------------------
# The check
# ----------------------------------------------------------------------------

def check_file(path):
    name = os.path.basename(path)
    rel = os.path.relpath(os.path.abspath(path), HERE).replace(os.sep, '/')
    errors = []
    verts, objects, mats = parse_obj(path, errors)
    expect = EXPECT.get(rel)
    print('== %s: %d vertices, %d objects, %d triangles'
          % (name, len(verts), len(objects), sum(len(o.tris) for o in objects)))

    lo, hi = bounds(verts)
    print('   bounds   min %s  max %s  size %s' % (fmtv(lo), fmtv(hi), fmtv(sub(hi, lo))))

    for o in objects:
        used = sorted({v for t in o.tris for v in t})
        olo, ohi = bounds([verts[v] for v in used])
        kind = expect.get(o.name, '?') if expect else 'auto'
        desc = '   %-18s %-5s %4d tris  min %s max %s' % (o.name, kind, len(o.tris), fmtv(olo), fmtv(ohi))

        # zero-area triangles
        for t in o.tris:
            if norm(tri_normal(verts, t)) < 1e-10:
                errors.append('%s: zero-area triangle %s' % (o.name, t))

        # closedness / orientation: count directed edges
        directed = {}
        for t in o.tris:
            for k in range(3):
                e = (t[k], t[(k + 1) % 3])
                directed[e] = directed.get(e, 0) + 1
        undirected = {}
        for (a, b), c in directed.items():
            key = (min(a, b), max(a, b))
            undirected[key] = undirected.get(key, 0) + c
        closed = all(c == 2 for c in undirected.values())
        consistent = all(c == 1 and directed.get((b, a)) == 1 for (a, b), c in directed.items())
        # signed volume (divergence theorem), > 0 when normals face outward
        vol = sum(dot(verts[t[0]], cross(verts[t[1]], verts[t[2]])) for t in o.tris) / 6.0

        if expect is not None and o.name not in expect:
            errors.append('%s: object not declared in EXPECT' % o.name)
        if kind in ('solid', 'room'):
            if not closed:
                bad = [e for e, c in undirected.items() if c != 2][:3]
                errors.append('%s: not closed, e.g. edges %s' % (o.name, bad))
            elif not consistent:
                errors.append('%s: inconsistent winding' % o.name)
            if kind == 'solid' and not vol > 0:
                errors.append('%s: solid faces inward (volume %g)' % (o.name, vol))
            if kind == 'room' and not vol < 0:
                errors.append('%s: room faces outward (volume %g)' % (o.name, vol))
            seen = {}
            for v in used:
                key = tuple(round(c, 6) for c in verts[v])
                if key in seen:
                    errors.append('%s: duplicate vertex at %s' % (o.name, fmtv(verts[v])))
                seen[key] = v
            desc += '  closed, volume %.4g m^3' % vol
        elif kind == 'open':
            if closed:
                errors.append('%s: declared open but is closed' % o.name)
            desc += '  open, area %.4g m^2' % (sum(norm(tri_normal(verts, t)) for t in o.tris) / 2)
        print(desc)
    if expect is not None:
        for missing in set(expect) - {o.name for o in objects}:
            errors.append('%s: expected object missing' % missing)

    # no object intersects another (edges crossing triangles, coplanar overlap); objects whose
    # bounding boxes are apart (by more than the tolerance) cannot
    boxes = [bounds([verts[v] for t in o.tris for v in t]) for o in objects]

    def apart(i, j, eps=1e-6):
        (alo, ahi), (blo, bhi) = boxes[i], boxes[j]
        return any(alo[k] > bhi[k] + eps or blo[k] > ahi[k] + eps for k in range(3))
    for i, a in enumerate(objects):
        a_edges = {(min(t[k], t[(k + 1) % 3]), max(t[k], t[(k + 1) % 3]))
                   for t in a.tris for k in range(3)}
        for j, b in enumerate(objects):
            if i == j or apart(i, j):
                continue
            b_tris = [tri_pts(verts, t) for t in b.tris]
            crossing = next(((e, tb) for e in a_edges for tb in b_tris
                             if edge_crosses_tri(verts[e[0]], verts[e[1]], tb)), None)
            if crossing:
                errors.append('edge of %s crosses a triangle of %s' % (a.name, b.name))
            if i < j:
                overlap = any(coplanar_overlap(tri_pts(verts, ta), tb)
                              for ta in a.tris for tb in b_tris)
                if overlap:
                    errors.append('%s and %s have overlapping coplanar faces' % (a.name, b.name))

    # everything strictly inside the room, if there is one
    rooms = [o for o in objects if expect and expect.get(o.name) == 'room']
    for room in rooms:
        rlo, rhi = bounds([verts[v] for t in room.tris for v in t])
        for o in objects:
            if o is room:
                continue
            for v in {v for t in o.tris for v in t}:
                p = verts[v]
                if not all(rlo[k] < p[k] < rhi[k] for k in range(3)):
                    errors.append('%s: vertex %s not inside %s' % (o.name, fmtv(p), room.name))
                    break

    # lights
    lights = [o for o in objects if any(is_emissive(mats, m) for m in o.tri_mats)]
    for o in lights:
        if not all(is_emissive(mats, m) for m in o.tri_mats):
            errors.append('%s: mixes emissive and non-emissive faces' % o.name)
        normals = [tri_normal(verts, t) for t in o.tris]
        area = sum(norm(n) for n in normals) / 2
        n = unit(normals[0])
        if any(dot(unit(m), n) < 1 - 1e-9 for m in normals):
            errors.append('%s: light is not flat' % o.name)
        centre = (0.0, 0.0, 0.0)
        for t, nt in zip(o.tris, normals):
            c = mul(add(add(verts[t[0]], verts[t[1]]), verts[t[2]]), 1 / 3)
            centre = add(centre, mul(c, norm(nt) / 2 / area))
        # The scene (bounding-box centre of all non-emissive geometry) must
        # lie in front of the light, and the front ray must hit something.
        others = [verts[v] for x in objects if x not in lights for t in x.tris for v in t]
        slo, shi = bounds(others)
        towards = sub(mul(add(slo, shi), 0.5), centre)
        if not dot(n, towards) > 0:
            errors.append('%s: faces away from the scene centre %s'
                          % (o.name, fmtv(mul(add(slo, shi), 0.5))))
        hit = first_hit(verts, objects, centre, n, skip=o)
        ke = mats[o.tri_mats[0]]['Ke']
        msg = '   light %-10s Ke %s  area %.4g m^2  centre %s  front normal %s' % (
            o.name, ke, area, fmtv(centre), fmtv(n))
        if hit is None:
            errors.append('%s: front side faces empty space' % o.name)
            msg += '  -> hits nothing'
        else:
            t, ho, hm = hit
            msg += '  -> hits %s (%s) after %.3g m' % (ho.name, hm, t)
            if is_emissive(mats, hm):
                errors.append('%s: front side faces another light' % o.name)
        print(msg)
        if name == 'stair_wall.obj':
            check_treads_lit(verts, objects, o, errors)
    if name.startswith('flat_') or rel in FLATLAND:
        check_extruded(verts, objects, errors)
    check_maps(path, mats, errors)

    for e in errors:
        print('   ERROR: ' + e)
    print('   %s' % ('OK' if not errors else '%d error(s)' % len(errors)))
    return not errors


def check_extruded(verts, objects, errors):
    """Flatland scenes: every triangle that meets the slice z = 0 along more
    than a point has its normal in that plane (what `--flatland` requires)."""
    crossing = 0
    for o in objects:
        for t in o.tris:
            zs = [verts[v][2] for v in t]
            if min(zs) >= 0 or max(zs) <= 0:
                if not (min(zs) == max(zs) == 0) and sum(z == 0 for z in zs) < 2:
                    continue
            crossing += 1
            n = unit(tri_normal(verts, t))
            if abs(n[2]) > 1e-9:
                errors.append('%s: a triangle crosses z = 0 with its normal %.3g deg out of the plane'
                              % (o.name, math.degrees(math.asin(min(1.0, abs(n[2]))))))
    print('   extruded along z: %d triangles cross z = 0, all with in-plane normals' % crossing
          if not errors else '   extrusion check failed')


def check_treads_lit(verts, objects, lamp, errors):
    """Stair wall: the centre (at z = 0) of every upward-facing tread must see
    the light's centre and all of its corners unoccluded and from the front."""
    stairs = next(o for o in objects if o.name == 'stairs')
    treads = {}
    for t in stairs.tris:
        n = unit(tri_normal(verts, t))
        if n[1] > 1 - 1e-9:
            y = verts[t[0]][1]
            xs = [verts[v][0] for v in t]
            lo, hi = treads.get(y, (math.inf, -math.inf))
            treads[y] = (min(lo, *xs), max(hi, *xs))
    lamp_pts = [verts[v] for v in {v for t in lamp.tris for v in t}]
    n_lamp = unit(tri_normal(verts, lamp.tris[0]))
    centre = tuple(sum(p[k] for p in lamp_pts) / len(lamp_pts) for k in range(3))
    lamp_pts.append(centre)
    for y, (x0, x1) in sorted(treads.items()):
        p = ((x0 + x1) / 2, y, 0.0)
        visible = 0
        for q in lamp_pts:
            d = sub(q, p)
            if dot(n_lamp, d) >= 0:            # q must see p from its front side
                continue
            hit = first_hit(verts, objects, p, d, skip=lamp)
            if hit is None or hit[0] >= 1 - 1e-9:
                visible += 1
        print('   tread y=%.2f x=[%.2f, %.2f]: centre sees %d/%d light sample points'
              % (y, x0, x1, visible, len(lamp_pts)))
        if visible != len(lamp_pts):
            errors.append('tread at y=%g is (partly) shadowed at its centre' % y)

# ----------------------------------------------------------------------------
# Texture maps (PNG) and sidecars (TOML, Radiance RGBE)
# ----------------------------------------------------------------------------

def read_png(path):
    """Decodes an 8-bit, non-interlaced PNG: (width, height, channels, rows of bytes). Raises
    ValueError on anything else or on a corrupt file."""
    import struct
    import zlib
    with open(path, 'rb') as f:
        data = f.read()
    if data[:8] != b'\x89PNG\r\n\x1a\n':
        raise ValueError('not a PNG file')
    pos, idat, ihdr = 8, b'', None
    while pos < len(data):
        n, kind = struct.unpack('>I4s', data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack('>I', data[pos + 8 + n:pos + 12 + n])
        if zlib.crc32(kind + body) & 0xFFFFFFFF != crc:
            raise ValueError('bad CRC in chunk %s' % kind.decode('latin-1'))
        if kind == b'IHDR':
            ihdr = struct.unpack('>IIBBBBB', body)
        elif kind == b'IDAT':
            idat += body
        elif kind == b'IEND':
            break
        pos += 12 + n
    if ihdr is None:
        raise ValueError('no IHDR chunk')
    w, h, depth, ctype, _, _, interlace = ihdr
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(ctype)
    if depth != 8 or channels is None or interlace:
        raise ValueError('only 8-bit grey, grey+alpha, RGB, RGBA, not interlaced, are checked')
    raw = zlib.decompress(idat)
    stride = w * channels
    if len(raw) != h * (stride + 1):
        raise ValueError('image data of %d bytes, expected %d' % (len(raw), h * (stride + 1)))
    rows, prev = [], bytearray(stride)
    for y in range(h):
        ftype = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if ftype == 0:
                pred = 0
            elif ftype == 1:
                pred = a
            elif ftype == 2:
                pred = b
            elif ftype == 3:
                pred = (a + b) // 2
            elif ftype == 4:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            else:
                raise ValueError('unknown filter type %d' % ftype)
            line[i] = (line[i] + pred) & 0xFF
        rows.append(bytes(line))
        prev = line
    return w, h, channels, rows


def check_maps(path, mats, errors):
    """Every map statement names a PNG next to the MTL that decodes; map_d images have alpha."""
    seen = {}
    for m, stmts in sorted(mats.items()):
        for key, value in sorted(stmts.items()):
            if not key.startswith('map_'):
                continue
            f = os.path.join(os.path.dirname(path), value.split()[-1].replace('\\', '/'))
            rel = os.path.relpath(os.path.abspath(f), HERE).replace(os.sep, '/')
            if not os.path.isfile(f):
                errors.append('%s %s: no file %s' % (m, key, rel))
                continue
            if f not in seen:
                try:
                    seen[f] = read_png(f)
                except (ValueError, OSError, Exception) as e:
                    errors.append('%s %s: %s: %s' % (m, key, rel, e))
                    seen[f] = None
            img = seen[f]
            if img is None:
                continue
            w, h, ch, rows = img
            note = ''
            if key == 'map_d':
                if ch not in (1, 2, 4):
                    errors.append('%s map_d: %s has neither alpha nor grey' % (m, rel))
                elif ch in (2, 4):
                    alpha = {r[i] for r in rows for i in range(ch - 1, len(r), ch)}
                    cover = sum(r[i] == 255 for r in rows for i in range(ch - 1, len(r), ch))
                    note = ', alpha values %s, %.0f %% opaque' % (
                        'binary' if alpha <= {0, 255} else '%d distinct' % len(alpha),
                        100.0 * cover / (w * h))
                    if rel in BINARY_ALPHA and not alpha <= {0, 255}:
                        errors.append('%s map_d: %s has alpha other than 0 and 255' % (m, rel))
            print('   map %-10s %-7s %s  %dx%d, %d channel(s)%s' % (m, key, rel, w, h, ch, note))


def read_rgbe(path):
    """Decodes a Radiance RGBE image (flat or new-style run-length scanlines, -Y h +X w):
    (width, height, list of (r, g, b) rows from the top)."""
    import math
    with open(path, 'rb') as f:
        data = f.read()
    if not data.startswith(b'#?'):
        raise ValueError('not a Radiance file')
    end = data.index(b'\n\n')
    header = data[:end].decode('latin-1').split('\n')
    if 'FORMAT=32-bit_rle_rgbe' not in header:
        raise ValueError('not 32-bit_rle_rgbe')
    nl = data.index(b'\n', end + 2)
    res = data[end + 2:nl].decode('latin-1').split()
    if len(res) != 4 or res[0] != '-Y' or res[2] != '+X':
        raise ValueError('resolution line %r: only -Y h +X w is checked' % ' '.join(res))
    h, w = int(res[1]), int(res[3])
    pos, rows = nl + 1, []
    for _ in range(h):
        if data[pos] == 2 and data[pos + 1] == 2 and (data[pos + 2] << 8 | data[pos + 3]) == w:
            pos += 4
            comps = []
            for _ in range(4):
                c = bytearray()
                while len(c) < w:
                    n = data[pos]
                    if n > 128:
                        c.extend(bytes([data[pos + 1]]) * (n - 128))
                        pos += 2
                    else:
                        c.extend(data[pos + 1:pos + 1 + n])
                        pos += 1 + n
                if len(c) != w:
                    raise ValueError('a run crosses the end of a scanline')
                comps.append(c)
            px = list(zip(*comps))
        else:
            px = [tuple(data[pos + 4 * i:pos + 4 * i + 4]) for i in range(w)]
            pos += 4 * w
        rows.append([(0.0, 0.0, 0.0) if e == 0 else
                     tuple(math.ldexp(c + 0.5, e - 136) for c in (r, g, b))
                     for r, g, b, e in px])
    if pos != len(data):
        raise ValueError('%d bytes after the last scanline' % (len(data) - pos))
    return w, h, rows


def check_sidecar(path):
    """The sidecar names files that exist and decode, suns above the horizon, and slices and
    cameras inside the scene's bounds."""
    rel = os.path.relpath(path, HERE)
    print('== %s' % rel)
    errors = []
    try:
        import tomllib
    except ImportError:                                 # Python < 3.11
        print('   (tomllib not available: sidecar not checked)')
        return True
    with open(path, 'rb') as f:
        sc = tomllib.load(f)
    base = os.path.dirname(path)
    mesh = os.path.join(base, sc.get('mesh', ''))
    lo = hi = None
    if not os.path.isfile(mesh):
        errors.append('mesh %s does not exist' % sc.get('mesh'))
    else:
        verts, _, _ = parse_obj(mesh, [])
        lo, hi = bounds(verts)
    env = sc.get('environment')
    if env:
        f = os.path.join(base, env['file'])
        try:
            w, h, rows = read_rgbe(f)
            px = [c for r in rows for c in r]
            if not all(math.isfinite(c) and c >= 0 for p in px for c in p):
                errors.append('environment %s: a texel is negative or not finite' % env['file'])
            top = [sum(p) / 3 for p in rows[0]]
            mid = [sum(p) / 3 for p in rows[h // 2 - 1]]
            print('   environment %s: %dx%d, mean radiance at the zenith %.3g, just above the '
                  'horizon %.3g, max %.3g' % (env['file'], w, h, sum(top) / w, sum(mid) / w,
                                             max(max(p) for p in px)))
        except (OSError, ValueError, IndexError) as e:
            errors.append('environment %s: %s' % (env['file'], e))
    for k, sun in enumerate(sc.get('sun', [])):
        d = sun['direction']
        elev = math.degrees(math.asin(d[1] / norm(d)))
        print('   sun #%d: direction %s, %.1f degrees above the horizon, irradiance %s'
              % (k + 1, fmtv(d), elev, sun['irradiance']))
        if not elev > 0:
            errors.append('sun #%d is below the horizon' % (k + 1))
    for k, pl in enumerate(sc.get('point_light', [])):
        pos = pl['position']
        print('   point light #%d at %s, intensity %s' % (k + 1, fmtv(pos), pl['intensity']))
        if not (all(math.isfinite(c) for c in pos) and all(c >= 0 for c in pl['intensity'])):
            errors.append('point light #%d: position not finite or intensity negative' % (k + 1))
        # The paper's runs put their point lights in the slice (its section 5.5: light
        # separatrices show best there); flatland needs it.
        for sl in sc.get('slice', []):
            axis, _, value = sl['plane'].partition('=')
            if abs(pos['xyz'.index(axis.strip())] - float(value)) > 1e-9:
                errors.append('point light #%d does not lie in slice %s (%s)'
                              % (k + 1, sl['name'], sl['plane']))
    if lo is not None:
        inside = lambda p: all(lo[k] <= p[k] <= hi[k] for k in range(3))
        for cam in sc.get('camera', []):
            print('   camera %s: eye %s target %s' % (cam.get('name'), fmtv(cam['eye']),
                                                     fmtv(cam['target'])))
            if not inside(cam['eye']):
                errors.append('camera %s: eye outside the scene bounds' % cam.get('name'))
        for sl in sc.get('slice', []):
            axis, _, value = sl['plane'].partition('=')
            k = 'xyz'.index(axis.strip())
            print('   slice %-8s %s' % (sl['name'], sl['plane']))
            if not lo[k] < float(value) < hi[k]:
                errors.append('slice %s: %s outside the bounds' % (sl['name'], sl['plane']))
    for e in errors:
        print('   ERROR: ' + e)
    print('   %s' % ('OK' if not errors else '%d error(s)' % len(errors)))
    return not errors


def main(argv):
    paths = argv[1:] or [os.path.join(HERE, n) for n in EXPECT]
    ok = all([check_file(p) for p in paths])
    if not argv[1:]:
        ok = all([check_sidecar(os.path.join(HERE, n)) for n in SIDECARS]) and ok
    print('ALL OK' if ok else 'FAILED')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main(sys.argv))
