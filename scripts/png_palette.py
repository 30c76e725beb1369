#!/usr/bin/env python3
"""Rewrites an 8-bit RGB PNG as a palette PNG of at most 256 colours (standard library only), to
keep the gallery's pictures (docs/gallery.md) small: scripts/gallery.sh runs it on the copies in
docs/img/gallery/.

    python3 scripts/png_palette.py IN.png OUT.png

The colour maps of ftpd3d's previews have a few hundred distinct colours: up to 256 are kept
exactly, chosen by frequency but skipping colours within 4 levels per channel of one already kept
(so that the rare colours of the separatrices' lines stay), and every other colour becomes the
nearest kept one (in RGB). An image with more than 4096
distinct colours (a photograph-like beauty image) is copied unchanged. Deterministic (with the
same zlib): the same input gives the same bytes.
"""

import os
import struct
import sys
import zlib

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'scenes'))

from check import read_png  # noqa: E402  (the PNG decoder of the scene checks)


def chunk(kind, body):
    return struct.pack('>I', len(body)) + kind + body + struct.pack(
        '>I', zlib.crc32(kind + body) & 0xFFFFFFFF)


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    src, dst = argv[1], argv[2]
    w, h, ch, rows = read_png(src)
    if ch != 3:
        raise SystemExit('%s: only RGB images are converted (%d channels)' % (src, ch))
    pixels = [[r[i:i + 3] for i in range(0, 3 * w, 3)] for r in rows]
    counts = {}
    for row in pixels:
        for p in row:
            counts[p] = counts.get(p, 0) + 1
    if len(counts) > 4096:
        with open(src, 'rb') as f:
            data = f.read()
    else:
        def dist2(c, d):
            return sum((a - b) ** 2 for a, b in zip(c, d))
        # Most frequent first, but a colour within 4 levels per channel of a kept one is not kept,
        # so that rare distinct colours (the separatrices' lines) keep a slot of their own.
        by_use = sorted(counts, key=lambda c: (-counts[c], c))
        kept = []
        for c in by_use:
            if len(kept) == 256:
                break
            if all(dist2(c, k) > 48 for k in kept):
                kept.append(c)
        index = {c: i for i, c in enumerate(kept)}
        for c in by_use:
            if c not in index:
                index[c] = min(range(len(kept)), key=lambda i: dist2(c, kept[i]))
        raw, prev = bytearray(), bytes(w)
        for row in pixels:
            line = bytes(index[p] for p in row)
            up = bytes((a - b) & 0xFF for a, b in zip(line, prev))
            # Filter "Up" where it gives more zeros (the enlarged previews repeat their rows).
            if up.count(0) > line.count(0):
                raw += b'\x02' + up
            else:
                raw += b'\x00' + line
            prev = line
        data = (b'\x89PNG\r\n\x1a\n'
                + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 3, 0, 0, 0))
                + chunk(b'PLTE', b''.join(kept))
                + chunk(b'IDAT', zlib.compress(bytes(raw), 9))
                + chunk(b'IEND', b''))
    tmp = dst + '.tmp'
    with open(tmp, 'wb') as f:
        f.write(data)
    os.replace(tmp, dst)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
