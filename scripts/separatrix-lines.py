#!/usr/bin/env python3
"""Separatrix lines of EXR fields against a reference field's: how many of the reference's lines
each field finds and how many of its own lines the reference does not have.

    scripts/separatrix-lines.py REFERENCE.exr FIELD.exr...

A line is a connected set (8-neighbourhood) of the thinned line cells of the `separatrix.line`
channel (written by `--separatrices` in 2D: jump and ridge lines). A reference line is found when at least half of its cells have a marked cell
of the field within `NEAR` cells; a line of the field is spurious when fewer than half of its cells
have a reference cell within `NEAR`. Used by scripts/separatrix-lines.sh
(docs/performance.md#gradient-domain).
"""
import sys
from collections import deque

import numpy as np
import OpenEXR

NEAR = 2


def mask(path):
    ch = OpenEXR.File(path).parts[0].channels
    if "separatrix.line" not in ch:
        sys.exit(f"{path}: no `separatrix.line` channel (run a plane with --separatrices)")
    return np.array(ch["separatrix.line"].pixels) > 0


def lines(m):
    """The connected sets of marked cells, each as a list of (row, column)."""
    seen = np.zeros_like(m, dtype=bool)
    out = []
    h, w = m.shape
    for start in zip(*np.nonzero(m)):
        if seen[start]:
            continue
        seen[start] = True
        comp, queue = [], deque([start])
        while queue:
            r, c = queue.popleft()
            comp.append((r, c))
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < h and 0 <= cc < w and m[rr, cc] and not seen[rr, cc]:
                        seen[rr, cc] = True
                        queue.append((rr, cc))
        out.append(comp)
    return out


def grow(m, k):
    """Cells within k cells (Chebyshev) of a marked cell."""
    g = m.copy()
    for _ in range(k):
        p = np.pad(g, 1)
        g = np.zeros_like(g)
        for dr in (0, 1, 2):
            for dc in (0, 1, 2):
                g |= p[dr : dr + m.shape[0], dc : dc + m.shape[1]]
    return g


def covered(comp, near):
    return sum(near[rc] for rc in comp) * 2 >= len(comp)


ref = mask(sys.argv[1])
ref_lines = lines(ref)
ref_near = grow(ref, NEAR)
for path in sys.argv[2:]:
    m = mask(path)
    if m.shape != ref.shape:
        sys.exit(f"{path}: {m.shape} cells, the reference has {ref.shape}")
    near = grow(m, NEAR)
    found = sum(covered(c, near) for c in ref_lines)
    own = lines(m)
    spurious = sum(not covered(c, ref_near) for c in own)
    print(
        f"{path}: reference lines found {found} of {len(ref_lines)}, "
        f"lines {len(own)}, spurious {spurious}, cells {m.sum()} (reference {ref.sum()})"
    )
