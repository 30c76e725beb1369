"""Type stubs of the native part of ftpd3d (see the package's docstring and docs/python.md)."""

from os import PathLike
from typing import Callable, Iterator, Literal, Optional, Sequence, Tuple, Union

# Stubs are read by type checkers only: typing_extensions is theirs, not a runtime dependency.
from typing_extensions import TypedDict, Unpack

import numpy as np
import numpy.typing as npt

__version__: str

Vec3 = Tuple[float, float, float]
StrPath = Union[str, "PathLike[str]"]
Sun = Union[Tuple[Vec3, Vec3], Tuple[Vec3, Vec3, float]]
Env = Union[StrPath, Tuple[StrPath, float], Tuple[StrPath, float, float]]
Weighting = Literal["radiance", "unweighted", "importance"]
Progress = Union[None, bool, Callable[[int, Optional[int]], object]]
# The deflection pairs of a sample, (kA, kB, J, M) or "kA,kB,J,M"; None: the weighting's.
Pairs = Union[None, Tuple[int, int, int, int], str]

class RunOptions(TypedDict, total=False):
    """The keywords every run takes (``slice``, ``flatland``, ``camera``, ``volume``), with the
    defaults a run uses when one is left out (``help()`` of each method lists them too)."""

    spp: Optional[int]  # None
    time: Optional[float]  # None (seconds)
    target_error: Optional[float]  # None (p95 relative error)
    seed: int  # 1
    weighting: Weighting  # "radiance"; "importance" for camera
    t0: Optional[float]  # None: 0.1 of the scene's diagonal
    t1: Optional[float]  # None: 0.5 of the scene's diagonal
    angle: float  # 2.0 (degrees)
    max_bounces: int  # 32
    radiance_bounces: Optional[int]  # None: max_bounces
    pairs: Pairs  # None: 2,2,2,2 radiance-weighted, else 2,2,1,2
    guide: bool  # False: guided radiance paths (radiance weighting)
    batches: int  # 8
    pass_spp: Optional[int]  # None
    adaptive: Optional[bool]  # None: adaptive when the run stops at a target error
    adaptive_cap: Optional[int]  # None
    threads: int  # 0: all cores
    tile: Optional[str]  # None, or "i/N"
    separatrices: bool  # False
    sep_threshold: float  # 3.0
    sep_scale: Optional[float]  # None
    sep_tau: Optional[float]  # None
    progress: Progress  # None: a tqdm bar when tqdm is installed

class Field:
    """A field with its channels, as a run returns it or ``read`` gives it back.

    ``r[name]`` is a new NumPy array of the channel ``name`` of the file the command line writes:
    shaped (height, width) with row 0 at the top for slices and camera images (the EXR's layout;
    float32 for its view channels, uint32 for its exact counts and sums), (nz, ny, nx) for
    volumes (the VTI's, x fastest; a last axis for arrays of several components).
    """

    @property
    def channels(self) -> list[str]:
        """The channel names, in the file's order (the EXR's part 0, then part 1's others)."""
    @property
    def meta(self) -> dict[str, Union[str, int, float, bool, Tuple[Union[int, float], ...]]]:
        """The run's description, each value of its type: int or float, a tuple of numbers (a
        point, a size), bool (flags), or text (paths, names, the plane)."""
    @property
    def header(self) -> dict[str, str]:
        """The run's description as the file's header holds it (key to text)."""
    @property
    def stats(self) -> dict[str, Union[int, float, str]]:
        """What the run did: samples, rays, capped, clamped, seconds, passes, stop (empty for a
        field read from a file)."""
    @property
    def shape(self) -> list[int]:
        """(height, width), or (nz, ny, nx) for a volume."""
    @property
    def partial(self) -> bool:
        """Whether the run stopped before its budget."""
    def __getitem__(self, name: str) -> npt.NDArray[np.generic]: ...
    def __contains__(self, name: str) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[str]: ...
    def separatrices(
        self, threshold: float = 3.0, scale: Optional[float] = None, tau: Optional[float] = None
    ) -> "Field":
        """A new field with the separatrix channels extracted from this one (as
        ``separatrices=True`` on a run adds them)."""
    def write(self, path: StrPath, png: bool = False) -> None:
        """Writes the field as the command line does: ``.exr`` (slices, camera images) or ``.vti``
        (volumes), with the PNG previews beside it when ``png``; ``.png`` writes the previews
        alone. Written under a temporary name and renamed: never a half-written file."""

class Scene:
    """A scene loaded from ``.obj`` (with its ``.mtl``), ``.gltf``/``.glb`` or a sidecar ``.toml``,
    with lights added to the file's.

    ``point_lights``: [((x, y, z), (r, g, b)), ...], radiant intensity per steradian.
    ``sun``: ((direction towards it), (irradiance)[, angular diameter in degrees, default 0.53]),
    or a list of them. ``sky``: (r, g, b) radiance from every direction leaving the scene.
    ``env``: a lat-long ``.exr``/``.hdr`` map (+y up), or (file, scale[, rotation in degrees]).
    ``strict``: refuse, naming the file and line, what a tolerant load warns about.
    ``allow_outside_uris``: let the scene file read files outside its own folder (refused
    otherwise, with a ``SceneError`` naming the reference).

    Raises ``MissingFileError`` (a ``FileNotFoundError``) for a missing file, ``SceneError`` (a
    ``ValueError``) for a file that cannot be loaded, ``ParameterError`` for a light's bad value.
    """

    def __init__(
        self,
        path: StrPath,
        *,
        point_lights: Sequence[Tuple[Vec3, Vec3]] = ...,
        sun: Union[None, Sun, Sequence[Sun]] = None,
        sky: Optional[Vec3] = None,
        env: Optional[Env] = None,
        strict: bool = False,
        allow_outside_uris: bool = False,
    ) -> None: ...
    @property
    def path(self) -> str: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def triangles(self) -> int: ...
    @property
    def bounds(self) -> Tuple[Vec3, Vec3]: ...
    @property
    def cameras(self) -> list[str]: ...
    def slice(
        self,
        slice: str = "z=0",
        *,
        res: int = 256,
        window: Optional[Tuple[float, float, float, float]] = None,
        flatland: bool = False,
        **options: Unpack[RunOptions],
    ) -> Field:
        """The field of a slice (``"z=0"``, a slice named in the scene file, or ``"origin=X,Y,Z
        normal=X,Y,Z [up=X,Y,Z] [size=W,H]"``), ``res`` cells along the longer side; the run's
        keywords are ``RunOptions``'s.

        Sampling: ``spp`` samples per cell, ``time`` seconds, ``target_error`` (p95 relative
        error); none of them: stop at 0.05 or after 60 s. ``seed``: same seed, same field, on any
        number of ``threads`` (0: all cores). Run lengths ``t0``, ``t1`` default to 0.1 and 0.5
        of the scene's diagonal. ``pairs`` (kA, kB, J, M): the deflection pairs of a sample
        (None: the weighting's, 2,2,2,2 radiance-weighted, else 2,2,1,2). ``progress``: None (a tqdm bar if tqdm is installed),
        False, True, or ``f(done, total)`` (total None without ``spp``). Ctrl-C raises
        ``KeyboardInterrupt`` after the cells in flight."""
    def flatland(
        self,
        slice: str = "z=0",
        *,
        res: int = 256,
        window: Optional[Tuple[float, float, float, float]] = None,
        **options: Unpack[RunOptions],
    ) -> Field:
        """``slice`` with every direction confined to the plane (2D light transport)."""
    def camera(
        self,
        name: Optional[str] = None,
        *,
        eye: Optional[Vec3] = None,
        target: Optional[Vec3] = None,
        up: Optional[Vec3] = None,
        fov: float = 40.0,
        size: Tuple[int, int] = (512, 512),
        **options: Unpack[RunOptions],
    ) -> Field:
        """A camera image (``size`` = (width, height)) from a camera of the scene file (``name``
        or index; None: the first) or one placed by ``eye``, ``target``, ``up``, ``fov``;
        importance-weighted (``weighting`` defaults to ``"importance"`` here)."""
    def volume(
        self,
        res: Union[int, Tuple[int, int, int]],
        *,
        box: Optional[Tuple[float, float, float, float, float, float]] = None,
        **options: Unpack[RunOptions],
    ) -> Field:
        """A voxel grid over ``box`` (None: the scene's bounds), ``res`` voxels along its longest
        side or (nx, ny, nz); channels as the ``.vti`` holds them, shaped (nz, ny, nx)."""

def read(path: StrPath) -> Field:
    """Reads a field ftpd3d wrote (``.exr`` slice or camera image, ``.vti`` volume)."""
