"""Sweeps the longest run length t1 and plots σ for each (Matplotlib), with the median relative
error of each run: a parameter study without shell loops or reading files back.

    python examples/python/sweep_t1.py [scene] [plot.png]
"""

import sys

import numpy as np

import ftpd3d

scene_path = sys.argv[1] if len(sys.argv) > 1 else "scenes/cornell_mirror.obj"
plot = sys.argv[2] if len(sys.argv) > 2 else "out/sweep_t1.png"

scene = ftpd3d.Scene(scene_path)
(lo, hi) = scene.bounds
diagonal = float(np.linalg.norm(np.subtract(hi, lo)))
t1s = [f * diagonal for f in (0.2, 0.35, 0.5, 0.75, 1.0)]
fields = []
for t1 in t1s:
    r = scene.slice("z=0", res=96, spp=32, seed=1, t0=0.1 * diagonal, t1=t1, progress=False)
    valid = r["valid"] > 0
    print(f"t1 = {t1:.3f}: mean sigma {r['ftpd'][valid].mean():.5f}, "
          f"median relative error {np.median(r['ftpd.relerr'][valid]):.3f}")
    fields.append(r["ftpd"])

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

vmax = max(float(np.quantile(f, 0.99)) for f in fields)
fig, axes = plt.subplots(1, len(fields), figsize=(3 * len(fields), 3.2), constrained_layout=True)
for ax, t1, f in zip(axes, t1s, fields):
    # Row 0 is the top of the slice (as in the EXR): imshow's default origin shows it upright.
    im = ax.imshow(f, cmap="magma", vmin=0, vmax=vmax)
    ax.set_title(f"t1 = {t1:.2f}")
    ax.set_axis_off()
fig.colorbar(im, ax=axes, shrink=0.8, label="σ (FTPD)")
fig.savefig(plot, dpi=120)
print("wrote", plot)
