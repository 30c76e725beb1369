#!/usr/bin/env python3
"""Generate the ftpd3d test/demo scenes as OBJ+MTL files (standard library only).

Run from anywhere:  python3 scenes/generate.py
It (re)writes the .obj/.mtl files next to this script. The output is
deterministic, so re-running it must leave `git diff` empty.

Loader conventions followed here (see scenes/README.md):
  * units are metres, y is up;
  * faces are triangles or planar convex quads (the loader fan-triangulates
    quads as (v0,v1,v2),(v0,v2,v3));
  * winding is counter-clockwise seen from the front, i.e. the geometric
    normal (v1-v0) x (v2-v0) is the front side;
  * emitters emit from their front side only, so every light faces into the
    scene; closed solids face outward, the Cornell room's walls face inward;
  * no vertex normals (all geometry is flat-shaded), vertices are shared
    within an object so that closed objects are watertight by index.
"""

import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


# ----------------------------------------------------------------------------
# Tiny vector helpers
# ----------------------------------------------------------------------------

def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def rot_y(deg):
    """Unit axes (ex, ey, ez) of a frame rotated by `deg` degrees about +y
    (right-handed: positive angles turn +x towards -z, seen from above)."""
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    return (c, 0.0, -s), (0.0, 1.0, 0.0), (s, 0.0, c)


# ----------------------------------------------------------------------------
# Meshes: a named object with one material, its own vertex list and faces
# given as tuples of indices into that list.
# ----------------------------------------------------------------------------

class Mesh:
    def __init__(self, name, material):
        self.name = name
        self.verts = []
        # faces: list of (material, (i0, i1, i2[, i3]))
        self.faces = []
        self.material = material
        # Optional per-vertex shading normals (one per vertex, written as `vn`).
        self.normals = None

    def vert(self, p):
        self.verts.append(p)
        return len(self.verts) - 1

    def face(self, *idx, material=None):
        self.faces.append((material or self.material, idx))


def box(name, material, center, size, yaw_deg=0.0, inward=False, face_materials=None):
    """A closed box of `size` (sx, sy, sz) centred at `center`, rotated about y.

    8 shared corners, 6 quads. Normals face outward, or inward when
    `inward` (used for the room). `face_materials` may override the material
    of individual faces, keyed by '-x', '+x', '-y', '+y', '-z', '+z'
    (in the box's local frame).
    """
    axes = rot_y(yaw_deg)
    half = [s / 2.0 for s in size]
    m = Mesh(name, material)
    corner = {}
    for sx in (-1, 1):
        for sy in (-1, 1):
            for sz in (-1, 1):
                p = center
                for axis, h, sgn in zip(axes, half, (sx, sy, sz)):
                    p = add(p, scale(axis, sgn * h))
                corner[(sx, sy, sz)] = m.vert(p)

    # For the face whose outward normal is sign*axis[a], pick in-plane axes
    # (u, v) with u x v = axis[a]; corners (-u-v, +u-v, +u+v, -u+v) are then
    # counter-clockwise seen from outside. (y,z)->x, (z,x)->y, (x,y)->z.
    for a, (u, v) in enumerate(((1, 2), (2, 0), (0, 1))):
        for sign in (-1, 1):
            if sign < 0:
                u_, v_ = v, u            # swapping u and v flips the normal
            else:
                u_, v_ = u, v
            quad = []
            for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                s = [0, 0, 0]
                s[a], s[u_], s[v_] = sign, su, sv
                quad.append(corner[tuple(s)])
            if inward:
                quad.reverse()
            key = ('-' if sign < 0 else '+') + 'xyz'[a]
            mat = (face_materials or {}).get(key, material)
            m.face(*quad, material=mat)
    return m


def rect(name, material, center, u, v):
    """A single rectangle with corner offsets +-u, +-v from `center`.
    Its front (normal) is u x v."""
    m = Mesh(name, material)
    idx = [m.vert(add(center, add(scale(u, su), scale(v, sv))))
           for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    m.face(*idx)
    return m


def extruded_profile(name, material, profile, z0, z1):
    """Closed prism: a polygon `profile` in the x-y plane (counter-clockwise
    seen from +z, and star-shaped from profile[0], which is the fan origin
    of the two caps) extruded along z from z0 to z1 (z0 < z1)."""
    m = Mesh(name, material)
    n = len(profile)
    back = [m.vert((x, y, z0)) for x, y in profile]
    front = [m.vert((x, y, z1)) for x, y in profile]
    # Caps: fan from vertex 0. Front cap (+z) keeps the CCW order, back cap
    # (-z) reverses it.
    for k in range(1, n - 1):
        m.face(front[0], front[k], front[k + 1])
    for k in range(1, n - 1):
        m.face(back[0], back[k + 1], back[k])
    # Sides: for a CCW profile the outward normal of edge a->b is to its
    # right; quad (a,z0),(b,z0),(b,z1),(a,z1) has normal (b-a) x (+z) = right.
    for k in range(n):
        a, b = k, (k + 1) % n
        m.face(back[a], back[b], front[b], front[a])
    return m


def uv_sphere(name, material, center, radius, n_seg=32, n_ring=16):
    """Closed, watertight UV sphere with shared vertices: one vertex per pole,
    (n_ring - 1) rings of n_seg vertices, quads between rings and triangles at
    the poles, all counter-clockwise seen from outside."""
    m = Mesh(name, material)
    cx, cy, cz = center

    def point(theta, phi):           # theta: polar angle from +y
        return (cx + radius * math.sin(theta) * math.cos(phi),
                cy + radius * math.cos(theta),
                cz + radius * math.sin(theta) * math.sin(phi))

    north = m.vert((cx, cy + radius, cz))
    rings = []
    for j in range(1, n_ring):
        theta = math.pi * j / n_ring
        rings.append([m.vert(point(theta, 2.0 * math.pi * i / n_seg))
                      for i in range(n_seg)])
    south = m.vert((cx, cy - radius, cz))

    # Walking +phi then +theta gives d/dphi x d/dtheta, which points outward.
    for i in range(n_seg):
        i1 = (i + 1) % n_seg
        m.face(north, rings[0][i1], rings[0][i])
        for j in range(n_ring - 2):
            m.face(rings[j][i], rings[j][i1], rings[j + 1][i1], rings[j + 1][i])
        m.face(rings[-1][i], rings[-1][i1], south)
    return m


# ----------------------------------------------------------------------------
# Writers
# ----------------------------------------------------------------------------

def fmt(x):
    s = '%.6f' % x
    s = s.rstrip('0').rstrip('.')
    return '0' if s in ('-0', '') else s


def write_scene(stem, title, meshes, materials, generator='scenes/generate.py', directory=HERE):
    """Write <stem>.obj and <stem>.mtl into `directory` (default: this one). `materials` maps
    name -> list of MTL statement lines; it is written in the given order. `generator` names
    the script in the files' header comment."""
    used = {mat for m in meshes for mat, _ in m.faces}
    missing = used - set(materials)
    assert not missing, 'undefined materials: %s' % sorted(missing)

    with open(os.path.join(directory, stem + '.mtl'), 'w', newline='\n') as f:
        f.write('# %s -- generated by %s, do not edit\n' % (title, generator))
        for name, lines in materials.items():
            f.write('\nnewmtl %s\n' % name)
            for line in lines:
                f.write(line + '\n')

    with open(os.path.join(directory, stem + '.obj'), 'w', newline='\n') as f:
        f.write('# %s -- generated by %s, do not edit\n' % (title, generator))
        f.write('# metres, y up, CCW winding = front side\n')
        f.write('mtllib %s.mtl\n' % stem)
        base = 1                      # OBJ indices are 1-based and global
        nbase = 1
        for m in meshes:
            f.write('\no %s\n' % m.name)
            for p in m.verts:
                f.write('v %s %s %s\n' % tuple(fmt(c) for c in p))
            for n in m.normals or []:
                f.write('vn %s %s %s\n' % tuple(fmt(c) for c in n))
            current = None
            for mat, idx in m.faces:
                if mat != current:
                    f.write('usemtl %s\n' % mat)
                    current = mat
                if m.normals:
                    # Vertex and normal lists are parallel: the same index for both.
                    f.write('f %s\n' % ' '.join('%d//%d' % (base + i, nbase + i) for i in idx))
                else:
                    f.write('f %s\n' % ' '.join(str(base + i) for i in idx))
            base += len(m.verts)
            nbase += len(m.normals or [])


def diffuse(r, g=None, b=None):
    g = r if g is None else g
    b = r if b is None else b
    return ['illum 1', 'Kd %s %s %s' % (fmt(r), fmt(g), fmt(b))]


def mirror(ks):
    return ['illum 3', 'Kd 0 0 0', 'Ks %s %s %s' % (fmt(ks), fmt(ks), fmt(ks))]


def glossy(kd, ks, ns):
    return ['illum 2', 'Kd %s %s %s' % (fmt(kd), fmt(kd), fmt(kd)),
            'Ks %s %s %s' % (fmt(ks), fmt(ks), fmt(ks)), 'Ns %s' % fmt(ns)]


def glass(ni):
    return ['illum 7', 'Kd 0 0 0', 'Ni %s' % fmt(ni), 'Tf 1 1 1']


def light(r, g, b):
    return ['illum 1', 'Kd 0 0 0', 'Ke %s %s %s' % (fmt(r), fmt(g), fmt(b))]


DOWN_U = (1.0, 0.0, 0.0)   # for a horizontal rect: (x) x (z) = -y, i.e. facing down
DOWN_V = (0.0, 0.0, 1.0)
UP_U = (0.0, 0.0, 1.0)     # (z) x (x) = +y, facing up
UP_V = (1.0, 0.0, 0.0)


def horizontal_rect(name, material, center, sx, sz, facing_up):
    if facing_up:
        return rect(name, material, center, scale(UP_U, sz / 2), scale(UP_V, sx / 2))
    return rect(name, material, center, scale(DOWN_U, sx / 2), scale(DOWN_V, sz / 2))


# ----------------------------------------------------------------------------
# Scenes
# ----------------------------------------------------------------------------

# Solids standing on a floor are lifted by this much so that their bottom
# face is not coplanar with (and overlapping) the floor.
LIFT = 0.001


def cornell_mirror():
    room = box('room', 'white', (0.0, 1.0, 0.0), (2.0, 2.0, 2.0), inward=True,
               face_materials={'-x': 'red', '+x': 'green'})
    lamp = horizontal_rect('light', 'light', (0.0, 1.98, 0.0), 0.5, 0.5, facing_up=False)
    tall = box('tall_box', 'white', (-0.4, 0.6 + LIFT, -0.4), (0.6, 1.2, 0.6), yaw_deg=15.0)
    # Panel lies in its local x-y plane; its big local +z face looks towards
    # the front-left of the room after the -20 degree turn.
    panel = box('mirror_panel', 'mirror', (0.45, 0.7 + LIFT, -0.55), (0.9, 1.4, 0.02),
                yaw_deg=-20.0)
    write_scene('cornell_mirror', 'Closed Cornell box with a tall box and a mirror panel',
                [room, lamp, tall, panel],
                {'white': diffuse(0.73),
                 'red': diffuse(0.63, 0.065, 0.05),
                 'green': diffuse(0.14, 0.45, 0.09),
                 'mirror': mirror(0.95),
                 'light': light(17, 12, 4)})


# Five steps, 0.4 m tread and 0.4 m rise, rising towards +x over x in [-1, 1].
STEP = 0.4
N_STEPS = 5


def stair_profile():
    """CCW profile starting at the bottom-right corner (1, 0). The stairs rise
    monotonically with x, so every point of the profile is visible from that
    corner: the cap fan from it is valid (no T-junctions, no overlaps)."""
    x0 = -N_STEPS * STEP / 2.0
    x1 = -x0
    top = N_STEPS * STEP
    pts = [(x1, 0.0), (x1, top)]
    for i in range(N_STEPS - 1, 0, -1):      # walk the treads right to left
        xl = x0 + i * STEP
        pts += [(xl, (i + 1) * STEP), (xl, i * STEP)]
    pts += [(x0, STEP), (x0, 0.0)]
    return pts


def stair_wall():
    stairs = extruded_profile('stairs', 'wall', stair_profile(), -2.0, 2.0)
    lamp = horizontal_rect('light', 'light', (0.0, 4.0, 0.0), 1.0, 4.0, facing_up=False)
    write_scene('stair_wall', "The 'stair wall' extruded along z (slice z = 0 is the flatland scene)",
                [stairs, lamp],
                {'wall': diffuse(0.7), 'light': light(10, 10, 10)})


def big_plane(stem, title, material_lines):
    plane = horizontal_rect('plane', 'plane', (0.0, 0.0, 0.0), 20.0, 20.0, facing_up=True)
    write_scene(stem, title, [plane], {'plane': material_lines})


def glossy_panels():
    gap = 0.1                                    # diffuse strip width
    n = 4
    width = n * 1.0 + (n - 1) * gap
    x = -width / 2.0
    meshes = []
    finishes = ['phong37', 'phong112', 'phong1029', 'mirror']
    for i, mat in enumerate(finishes):
        meshes.append(horizontal_rect('panel_%d_%s' % (i, mat), mat,
                                      (x + 0.5, 0.0, 0.0), 1.0, 1.0, facing_up=True))
        x += 1.0
        if i < n - 1:
            meshes.append(horizontal_rect('strip_%d' % i, 'strip',
                                          (x + gap / 2.0, 0.0, 0.0), gap, 1.0, facing_up=True))
            x += gap
    meshes.append(horizontal_rect('light', 'light', (0.0, 1.5, 0.0), 0.2, 0.2, facing_up=False))
    write_scene('glossy_panels', 'Phong panels of rising exponent and a mirror (cf. Fig. 4c)',
                meshes,
                {'phong37': glossy(0.0, 0.9, 37),
                 'phong112': glossy(0.0, 0.9, 112),
                 'phong1029': glossy(0.0, 0.9, 1029),
                 'mirror': mirror(0.9),
                 'strip': diffuse(0.5),
                 'light': light(50, 50, 50)})


def glass_sphere():
    sphere = uv_sphere('sphere', 'glass', (0.0, 0.6, 0.0), 0.5)
    floor = horizontal_rect('floor', 'floor', (0.0, 0.0, 0.0), 6.0, 6.0, facing_up=True)
    lamp = horizontal_rect('light', 'light', (-1.0, 2.5, 0.0), 0.3, 0.3, facing_up=False)
    write_scene('glass_sphere', 'Glass sphere over a diffuse floor (cf. Fig. 5)',
                [sphere, floor, lamp],
                {'glass': glass(1.5), 'floor': diffuse(0.7), 'light': light(30, 30, 30)})


def smooth_sphere():
    """A coarse diffuse sphere with per-vertex normals (`vn`): smooth shading over 8 x 6 facets,
    the scene that exercises shading normals."""
    c, r = (0.0, 0.6, 0.0), 0.5
    sphere = uv_sphere('sphere', 'white', c, r, n_seg=8, n_ring=6)
    sphere.normals = [tuple((p[k] - c[k]) / r for k in range(3)) for p in sphere.verts]
    floor = horizontal_rect('floor', 'floor', (0.0, 0.0, 0.0), 6.0, 6.0, facing_up=True)
    lamp = horizontal_rect('light', 'light', (-1.0, 2.5, 0.0), 0.3, 0.3, facing_up=False)
    write_scene('smooth_sphere', 'Coarse diffuse sphere with vertex normals over a floor',
                [sphere, floor, lamp],
                {'white': diffuse(0.8), 'floor': diffuse(0.7), 'light': light(30, 30, 30)})


def main():
    cornell_mirror()
    stair_wall()
    big_plane('mirror_plane', 'One 20 x 20 m perfect mirror at y = 0 facing +y', mirror(1.0))
    big_plane('diffuse_plane', 'One 20 x 20 m diffuse plane at y = 0 facing +y', diffuse(0.8))
    glossy_panels()
    glass_sphere()
    smooth_sphere()


if __name__ == '__main__':
    main()
