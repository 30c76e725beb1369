"""Shared fixtures: the repository root, the command line binary the Python module is compared
with (FTPD3D_BIN, else release or debug in cargo's target directory), and an EXR reader independent of ftpd3d
(OpenEXR 3) where installed."""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENE = str(ROOT / "scenes" / "cornell_mirror.obj")


def target_dir():
    """Cargo's target directory as `cargo metadata` names it (./target, or CARGO_TARGET_DIR)."""
    try:
        out = subprocess.run(
            ["cargo", "metadata", "--format-version", "1", "--no-deps"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        )
        return pathlib.Path(json.loads(out.stdout)["target_directory"])
    except (OSError, subprocess.CalledProcessError, KeyError, ValueError):
        return ROOT / "target"


def cli_binary():
    given = os.environ.get("FTPD3D_BIN")
    if given:
        return given
    for profile in ("release", "debug"):
        p = target_dir() / profile / "ftpd3d"
        if p.is_file():
            return str(p)
    return None


@pytest.fixture(scope="session")
def cli():
    """Runs the command line with arguments; returns nothing, fails with its stderr."""
    binary = cli_binary()
    if binary is None:
        pytest.fail("no ftpd3d binary: set FTPD3D_BIN or run cargo build")

    def run(*args):
        out = subprocess.run(
            [binary, "--quiet", "--no-png", *map(str, args)],
            cwd=ROOT,
            capture_output=True,
            text=True,
        )
        assert out.returncode == 0, out.stderr
        return out

    return run


def exr_channels(path):
    """Every channel of every part of an EXR as NumPy arrays (rows from the top) and part 0's
    ftpd3d.* header attributes, read by OpenEXR when it is installed (CI installs it), else by
    ftpd3d.read; part 0's channel wins where both parts have one (samples, batches)."""
    try:
        import OpenEXR
    except ImportError:
        import ftpd3d

        r = ftpd3d.read(path)
        return {c: r[c] for c in r.channels}, dict(r.header)
    channels = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            for name, ch in part.channels.items():
                channels.setdefault(name, np.array(ch.pixels))
        meta = {
            k[len("ftpd3d.") :]: (v.decode() if isinstance(v, bytes) else str(v))
            for k, v in f.parts[0].header.items()
            if k.startswith("ftpd3d.")
        }
    return channels, meta
