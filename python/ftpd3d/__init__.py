"""Finite-Time Path Deflection (FTPD) fields of 3D scenes as NumPy arrays.

The library of the ``ftpd3d`` command line, called directly: for the same scene, options and seed
every channel is bit-identical to the command line's file.

    >>> import ftpd3d
    >>> scene = ftpd3d.Scene("scenes/cornell_mirror.obj")
    >>> r = scene.slice("z=0", res=64, spp=16, seed=3)
    >>> r["ftpd"].shape           # (height, width), row 0 at the top, as in the EXR
    (64, 64)
    >>> r.write("cornell_z0.exr")  # the file the command line writes
    >>> ftpd3d.read("cornell_z0.exr")["ftpd"]

``Scene(path, point_lights=..., sun=..., sky=..., env=..., strict=...)`` loads a scene;
``Scene.slice``, ``Scene.flatland``, ``Scene.camera`` and ``Scene.volume`` run a domain with the
command line's defaults and return a ``Field``: ``r[name]`` for each channel of the file
(``r.channels``), ``r.meta`` (the run's description, as the file's header holds it), ``r.write``.
Long runs release the GIL, show a tqdm bar when tqdm is installed (or call ``progress(done,
total)``), and stop on Ctrl-C with ``KeyboardInterrupt``. Errors are ``ftpd3d.Error`` subclasses
that are also ``FileNotFoundError``, ``ValueError``, ``OSError`` or ``RuntimeError``.
See docs/python.md.
"""

from ._errors import (
    Error,
    FileError,
    FormatError,
    MissingFileError,
    ParameterError,
    RunError,
    SceneError,
)
from ._native import Field, Scene, __version__, read

__all__ = [
    "Scene",
    "Field",
    "read",
    "Error",
    "MissingFileError",
    "SceneError",
    "ParameterError",
    "FormatError",
    "FileError",
    "RunError",
    "__version__",
]
