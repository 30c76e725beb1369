#!/usr/bin/env python3
"""Generate the flatland scenes of ftpd3d as OBJ+MTL files (standard library only).

Run from anywhere:  python3 scenes/generate_flat.py
It (re)writes flat_*.obj / flat_*.mtl next to this script, deterministically.

A flatland scene is a 2D scene (a profile in the x-y plane) extruded along z
over z in [-1, 1], so that the slice z = 0 lies in the middle and every
surface it crosses has its normal in the slice plane, as `--flatland` requires
(ftpd3d --scene scenes/flat_mirrors.obj --slice z=0 --flatland). The scenes
follow the paper's flatland figures (its Fig. 3 a/b).

Conventions are those of generate.py (whose helpers this script uses):
metres, y up, counter-clockwise winding = front side, closed solids face
outward, lights emit from their front side only, no vertex normals. Solids
are closed prisms (with end caps at z = -1 and z = 1, which the slice never
meets); a light is a single extruded quad, i.e. a segment in 2D.
"""

import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import generate as g  # noqa: E402  (the shared mesh helpers and writers)

Z0, Z1 = -1.0, 1.0
GENERATOR = 'scenes/generate_flat.py'


def prism(name, material, profile):
    """A closed prism over the CCW 2D `profile` (star-shaped from its first
    point), extruded over z in [Z0, Z1]."""
    return g.extruded_profile(name, material, profile, Z0, Z1)


def slab(name, material, centre, direction_deg, length, thickness):
    """A thin rectangular prism: its long axis at `direction_deg` from +x,
    centred at `centre` (2D). Both long faces are reflective surfaces."""
    a = math.radians(direction_deg)
    t = (math.cos(a), math.sin(a))          # along the slab
    n = (-t[1], t[0])                       # left of t
    hl, hw = length / 2.0, thickness / 2.0
    cx, cy = centre

    def p(sl, sw):
        return (cx + sl * hl * t[0] + sw * hw * n[0], cy + sl * hl * t[1] + sw * hw * n[1])
    # Counter-clockwise: (-t,-n), (+t,-n), (+t,+n), (-t,+n).
    return prism(name, material, [p(-1, -1), p(1, -1), p(1, 1), p(-1, 1)])


def box2d(name, material, x0, y0, x1, y1):
    return prism(name, material, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def segment_light(name, material, a, b):
    """An extruded segment from 2D point `a` to `b` emitting to its right
    (seen walking from a to b with +z towards the viewer), i.e. its front
    normal is (b - a) x (+z)."""
    m = g.Mesh(name, material)
    idx = [m.vert((a[0], a[1], Z0)), m.vert((b[0], b[1], Z0)),
           m.vert((b[0], b[1], Z1)), m.vert((a[0], a[1], Z1))]
    m.face(*idx)
    return m


# The stair wall of Fig. 3(a): five steps of 0.4 m x 0.4 m rising towards +x
# (the profile of generate.py's stair_wall), lit from the upper right by a
# tilted area light. Its light travels down-left, steeper than the stairs'
# 45-degree slope: the risers (facing -x) get no direct light, and each step's
# outer corner shades the back part of the tread below it, so every corner
# starts a shadow boundary.
def stair_wall_parts():
    """The meshes and materials of the flatland stair wall."""
    stairs = prism('stairs', 'wall', g.stair_profile())
    # Light: 0.8 m long, front normal n = (-1, -2)/sqrt(5), its centre 2.4 m
    # from the middle of the third tread (0, 1.2) along -n.
    n = (-1.0 / math.sqrt(5.0), -2.0 / math.sqrt(5.0))
    t = (-n[1], n[0])                       # walking direction: normal on its right
    c = (0.0 - 2.4 * n[0], 1.2 - 2.4 * n[1])
    a = (c[0] - 0.4 * t[0], c[1] - 0.4 * t[1])
    b = (c[0] + 0.4 * t[0], c[1] + 0.4 * t[1])
    lamp = segment_light('light', 'light', a, b)
    return [stairs, lamp], {'wall': g.diffuse(0.7), 'light': g.light(10, 10, 10)}


def flat_stair_wall():
    meshes, materials = stair_wall_parts()
    g.write_scene('flat_stair_wall',
                  'Flatland stair wall (cf. Fig. 3a), extruded over z in [-1, 1]; slice z = 0',
                  meshes, materials, generator=GENERATOR)


# Fig. 3(b): an area light that reaches two diffuse objects only through a
# two-piece mirror system. The light (a segment at y = 0.3 facing up) shines
# into a 45-degree mirror above it, which sends the light to the right into a
# second 45-degree mirror, which sends it down onto two diffuse boxes. The
# boxes lie below the light's plane, so no light reaches them directly.
def mirrors_parts(left=None, right=None):
    """The meshes and materials of the two-mirror system; `left` and `right` replace the
    mirrors' material (MTL lines) when given (the paper's Fig. 4a makes them glossy)."""
    lamp = segment_light('light', 'light', (-1.3, 0.3), (-1.9, 0.3))   # normal +y
    mat_a, mat_b = ('mirror', 'mirror') if left is None else ('reflector_left', 'reflector_right')
    mirror_a = slab('mirror_left', mat_a, (-1.6, 2.3), 45.0, 1.2, 0.04)
    mirror_b = slab('mirror_right', mat_b, (1.6, 2.3), -45.0, 1.2, 0.04)
    box_a = box2d('box_left', 'grey', 1.15, 0.0, 1.45, 0.28)
    box_b = box2d('box_right', 'grey', 1.65, 0.0, 2.05, 0.18)
    materials = {'grey': g.diffuse(0.7)}
    if left is None:
        materials['mirror'] = g.mirror(0.9)
    else:
        materials['reflector_left'] = left
        materials['reflector_right'] = right
    materials['light'] = g.light(10, 10, 10)
    return [lamp, mirror_a, mirror_b, box_a, box_b], materials


def flat_mirrors():
    meshes, materials = mirrors_parts()
    g.write_scene('flat_mirrors',
                  'Flatland two-mirror system (cf. Fig. 3b), extruded over z in [-1, 1]; slice z = 0',
                  meshes, materials, generator=GENERATOR)


def main():
    flat_stair_wall()
    flat_mirrors()


if __name__ == '__main__':
    main()
