"""A slice computed from Python, saved as the command line saves it.

    python examples/python/slice.py [scene] [out.exr]
"""

import sys

import numpy as np

import ftpd3d

scene_path = sys.argv[1] if len(sys.argv) > 1 else "scenes/cornell_mirror.obj"
out = sys.argv[2] if len(sys.argv) > 2 else "out/cornell_z0_python.exr"

scene = ftpd3d.Scene(scene_path)
r = scene.slice("z=0", res=128, spp=64, seed=1)
sigma, valid = r["ftpd"], r["valid"] > 0
rel = r["ftpd.relerr"][valid]
print(f"{r!r}: mean sigma {sigma[valid].mean():.5f}, p95 relative error {np.quantile(rel, 0.95):.3f}")
print("weighting", r.meta["weighting"], "| t0..t1", r.meta["t0"], r.meta["t1"])
r.write(out, png=True)
print("wrote", out)
