"""Plots a field's σ, its standard error and the fluence of a file the command line (or Python)
wrote, with Matplotlib.

    python examples/python/plot_channels.py out/cornell_z0.exr [plot.png]
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import ftpd3d

path = sys.argv[1] if len(sys.argv) > 1 else "out/cornell_z0_python.exr"
plot = sys.argv[2] if len(sys.argv) > 2 else "out/channels.png"
r = ftpd3d.read(path)
panels = [("ftpd", "σ"), ("ftpd.stderr", "standard error of σ")]
if "fluence.R" in r:
    panels.append(("fluence", "fluence (RGB)"))
fig, axes = plt.subplots(1, len(panels), figsize=(4 * len(panels), 4), constrained_layout=True)
for ax, (name, title) in zip(axes, panels):
    if name == "fluence":
        rgb = np.stack([r["fluence.R"], r["fluence.G"], r["fluence.B"]], axis=-1)
        ax.imshow(np.clip(rgb / max(float(np.quantile(rgb, 0.99)), 1e-12), 0, 1))
    else:
        im = ax.imshow(r[name], cmap="magma")
        fig.colorbar(im, ax=ax, shrink=0.8)
    ax.set_title(title)
    ax.set_axis_off()
fig.savefig(plot, dpi=120)
print("wrote", plot)
