#!/usr/bin/env python3
"""Generate the ftpd3d glTF demo scene(s) (standard library only).

Run from anywhere:  python3 scenes/generate_gltf.py
It (re)writes cornell_point.gltf next to this script, with its binary buffer
embedded as a base64 data URI (one self-contained file). The output is
deterministic, so re-running it must leave `git diff` empty.

Conventions (as for the OBJ scenes, see scenes/README.md): metres, y up,
counter-clockwise winding seen from the front, the room's walls face inward.
Materials are glTF metallic-roughness with metallicFactor 0 and
roughnessFactor 1, which the loader maps to Lambertian baseColorFactor.

cornell_point: the 2 x 2 x 2 m room of cornell_mirror (x, z in [-1, 1],
y in [0, 2], white floor/ceiling/back/front, red left wall, green right wall)
without its area light or objects, lit by one KHR_lights_punctual point light
at (0, 1.5, 0), white, intensity 5, and seen by a perspective camera inside
the room at (0, 1, 0.95) looking along -z (yfov 0.9 rad, aspect 1).
"""

import base64
import json
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

WHITE = (0.73, 0.73, 0.73)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.09)


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def room():
    """The 8 corners and, per material, the inward-facing triangles (index
    triples into the corners)."""
    corners = [(x, y, z) for x in (-1.0, 1.0) for y in (0.0, 2.0)
               for z in (-1.0, 1.0)]
    centre = (0.0, 1.0, 0.0)

    def face(axis, value):
        """The two triangles of the wall where coordinate `axis` is `value`,
        wound so that the normal points at the room's centre."""
        quad = [i for i, c in enumerate(corners) if c[axis] == value]
        # Order the 4 corners around the wall (quad = a b d c as listed).
        a, b, c, d = quad
        ring = [a, b, d, c]
        p = [corners[i] for i in ring]
        n = cross(sub(p[1], p[0]), sub(p[2], p[0]))
        if dot(n, sub(centre, p[0])) < 0:
            ring.reverse()
        return [(ring[0], ring[1], ring[2]), (ring[0], ring[2], ring[3])]

    white = face(1, 0.0) + face(1, 2.0) + face(2, -1.0) + face(2, 1.0)
    return corners, [("white", WHITE, white),
                     ("red", RED, face(0, -1.0)),
                     ("green", GREEN, face(0, 1.0))]


def cornell_point():
    corners, parts = room()
    data = bytearray()
    views, accessors = [], []

    def add_view(raw):
        while len(data) % 4:
            data.append(0)
        views.append({"buffer": 0, "byteOffset": len(data),
                      "byteLength": len(raw)})
        data.extend(raw)
        return len(views) - 1

    pos_raw = b"".join(struct.pack("<3f", *c) for c in corners)
    accessors.append({
        "bufferView": add_view(pos_raw), "componentType": 5126,
        "count": len(corners), "type": "VEC3",
        "min": [min(c[k] for c in corners) for k in range(3)],
        "max": [max(c[k] for c in corners) for k in range(3)],
    })
    materials, primitives = [], []
    for name, colour, tris in parts:
        idx = [i for t in tris for i in t]
        accessors.append({
            "bufferView": add_view(struct.pack("<%dH" % len(idx), *idx)),
            "componentType": 5123, "count": len(idx), "type": "SCALAR",
        })
        materials.append({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": list(colour) + [1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
        })
        primitives.append({"attributes": {"POSITION": 0},
                           "indices": len(accessors) - 1,
                           "material": len(materials) - 1})
    uri = ("data:application/octet-stream;base64,"
           + base64.b64encode(bytes(data)).decode("ascii"))
    return {
        "asset": {"version": "2.0",
                  "generator": "ftpd3d scenes/generate_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "bulb", "type": "point", "color": [1.0, 1.0, 1.0],
             "intensity": 5.0},
        ]}},
        "scene": 0,
        "scenes": [{"name": "cornell_point", "nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "room", "mesh": 0},
            {"name": "bulb", "translation": [0.0, 1.5, 0.0],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            # glTF cameras look along their node's -z with +y up.
            {"name": "inside", "translation": [0.0, 1.0, 0.95], "camera": 0},
        ],
        "cameras": [{"name": "inside", "type": "perspective",
                     "perspective": {"yfov": 0.9, "aspectRatio": 1.0,
                                     "znear": 0.01}}],
        "meshes": [{"name": "room", "primitives": primitives}],
        "materials": materials,
        "buffers": [{"byteLength": len(data), "uri": uri}],
        "bufferViews": views,
        "accessors": accessors,
    }


def main():
    path = os.path.join(HERE, "cornell_point.gltf")
    with open(path, "w", encoding="ascii", newline="\n") as f:
        json.dump(cornell_point(), f, indent=2)
        f.write("\n")
    print("wrote", os.path.relpath(path))


if __name__ == "__main__":
    main()
