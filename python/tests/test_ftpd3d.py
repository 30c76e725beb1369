"""The Python module against the command line: the same channels bit for bit, the same files,
exceptions instead of a dead interpreter, Ctrl-C, read/write round trips."""

import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import ftpd3d
from conftest import ROOT, SCENE, exr_channels

# Attributes that say when and how long a run took, which no two runs share.
TIMING = {"elapsed", "remaining.time"}


def assert_same_channels(r, path):
    """Every channel of the file at `path` equals r[channel] exactly (values and type), and
    the run's description matches but for timing."""
    channels, meta = exr_channels(path)
    assert channels, path
    for name, want in channels.items():
        got = r[name]
        assert got.shape == want.shape, name
        assert got.dtype == want.dtype, name
        assert np.array_equal(got, want), f"channel {name} differs"
    for k, v in meta.items():
        if k not in TIMING:
            assert r.header.get(k) == v, f"attribute {k}: {r.header.get(k)!r} != {v!r}"


@pytest.fixture(scope="module")
def scene():
    return ftpd3d.Scene(SCENE)


def test_slice_is_bit_identical_to_the_command_line(scene, cli, tmp_path):
    out = tmp_path / "cli.exr"
    cli("--scene", SCENE, "--slice", "z=0", "--res", 32, "--spp", 16, "--seed", 3, "-o", out)
    r = scene.slice("z=0", res=32, spp=16, seed=3, progress=False)
    assert r.shape == [32, 32]
    assert r["ftpd"].dtype == np.float32
    assert set(r.channels) >= {"ftpd", "ftpd.stderr", "ftpd.relerr", "valid", "samples"}
    assert_same_channels(r, out)
    # On one thread too, and the file Python writes holds the same channels as the command line's.
    one = scene.slice("z=0", res=32, spp=16, seed=3, threads=1, progress=False)
    assert_same_channels(one, out)
    mine = tmp_path / "py.exr"
    r.write(mine)
    assert_same_channels(ftpd3d.read(mine), out)


def test_other_domains_and_options_match_the_command_line(scene, cli, tmp_path):
    same = dict(seed=5, progress=False)
    runs = [
        (
            ["--slice", "y=0.5", "--res", 24, "--spp", 8, "--weight", "unweighted", "--t1", 1.5],
            lambda: scene.slice("y=0.5", res=24, spp=8, weighting="unweighted", t1=1.5, **same),
        ),
        (
            ["--slice", "z=0", "--res", 24, "--spp", 8, "--flatland"],
            lambda: scene.flatland("z=0", res=24, spp=8, **same),
        ),
        (
            ["--slice", "z=0", "--res", 24, "--spp", 8, "--separatrices"],
            lambda: scene.slice("z=0", res=24, spp=8, separatrices=True, **same),
        ),
        (
            ["--eye", "0,1,3.5", "--target", "0,1,0", "--size", "16,12", "--spp", 4],
            lambda: scene.camera(eye=(0, 1, 3.5), target=(0, 1, 0), size=(16, 12), spp=4, **same),
        ),
        (
            ["--slice", "z=0", "--res", 16, "--spp", 8, "--pairs", "1,1,2,8"],
            lambda: scene.slice("z=0", res=16, spp=8, pairs=(1, 1, 2, 8), **same),
        ),
        (
            ["--slice", "z=0", "--res", 12, "--spp", 4, "--guide", "on"],
            lambda: scene.slice("z=0", res=12, spp=4, guide=True, **same),
        ),
        (
            ["--slice", "z=0", "--res", 16, "--spp", 8, "--pairs", "1,1,1,1", "--flatland"],
            lambda: scene.flatland("z=0", res=16, spp=8, pairs="1,1,1,1", **same),
        ),
        (
            ["--slice", "z=0", "--res", 16, "--spp", 64, "--gradient-domain", "--gradient-alpha", 0.3],
            lambda: scene.slice("z=0", res=16, spp=64, gradient_domain=True, gradient_alpha=0.3, **same),
        ),
        (
            ["--slice", "z=0", "--res", 16, "--target-error", 0.3, "--time", 30],
            lambda: scene.slice("z=0", res=16, target_error=0.3, time=30, **same),
        ),
    ]
    for k, (args, run) in enumerate(runs):
        out = tmp_path / f"cli{k}.exr"
        cli("--scene", SCENE, *args, "--seed", 5, "-o", out)
        assert_same_channels(run(), out)


def test_volume_is_bit_identical_to_the_command_line(scene, cli, tmp_path):
    out = tmp_path / "cli.vti"
    cli("--scene", SCENE, "--volume", 6, "--spp", 4, "--seed", 2, "-o", out)
    r = scene.volume(6, spp=4, seed=2, progress=False)
    want = ftpd3d.read(out)
    assert r.channels == want.channels
    for name in want.channels:
        assert r[name].dtype == want[name].dtype, name
        assert np.array_equal(r[name], want[name]), name
    nz, ny, nx = r.shape
    assert r["ftpd"].shape == (nz, ny, nx)
    mine = tmp_path / "py.vti"
    r.write(mine)
    back = ftpd3d.read(mine)
    for name in want.channels:
        assert np.array_equal(back[name], want[name]), name


def test_read_write_round_trip(scene, tmp_path):
    r = scene.slice("x=0", res=16, spp=4, separatrices=True, progress=False)
    p = tmp_path / "a.exr"
    r.write(p, png=True)
    assert (tmp_path / "a.png").is_file() and (tmp_path / "a.grad.png").is_file()
    back = ftpd3d.read(p)
    assert back.channels == r.channels
    for name in r.channels:
        assert np.array_equal(back[name], r[name]), name
    assert dict(back.meta) == dict(r.meta)
    # Written again from what was read: the same channels and description (the EXR writer's
    # header attributes come in no fixed order, so the bytes may differ).
    q = tmp_path / "b.exr"
    back.write(q)
    again = ftpd3d.read(q)
    assert again.channels == r.channels and dict(again.meta) == dict(r.meta)
    for name in r.channels:
        assert np.array_equal(again[name], r[name]), name
    r.write(tmp_path / "only.png")
    assert (tmp_path / "only.png").is_file() and not (tmp_path / "only.exr").exists()


def test_progress_callback_sees_every_sample(scene):
    seen = []
    r = scene.slice("z=0", res=8, spp=8, progress=lambda done, total: seen.append((done, total)))
    assert seen, "the callback was called"
    assert seen[-1] == (8 * 8 * 8, 8 * 8 * 8)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    assert r.stats["samples"] == 8 * 8 * 8


def test_a_failing_callback_stops_the_run(scene):
    def boom(done, total):
        raise RuntimeError("callback says stop")

    with pytest.raises(RuntimeError, match="callback says stop"):
        scene.slice("z=0", res=64, spp=4096, progress=boom)


# Exceptions: each path raises instead of killing the interpreter, naming what is wrong.


def test_missing_scene_names_the_file(tmp_path):
    missing = tmp_path / "nope.obj"
    with pytest.raises(FileNotFoundError) as e:
        ftpd3d.Scene(missing)
    assert isinstance(e.value, ftpd3d.Error)
    assert isinstance(e.value, ftpd3d.MissingFileError)
    assert str(missing) in str(e.value)
    assert e.value.filename == str(missing)


def test_strict_load_names_the_line(tmp_path):
    obj = tmp_path / "bad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf 1 2 3\n")
    with pytest.warns(UserWarning):
        ftpd3d.Scene(obj)
    with pytest.raises(ValueError) as e:
        ftpd3d.Scene(obj, strict=True)
    assert isinstance(e.value, ftpd3d.SceneError)
    assert "bad.obj" in str(e.value) and "4" in str(e.value)
    garbage = tmp_path / "garbage.obj"
    garbage.write_text("v 0 0 zero\n")
    with pytest.raises(ftpd3d.SceneError, match="garbage.obj"):
        ftpd3d.Scene(garbage)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(slice="q=1"), "q=1"),
        (dict(slice="origin=0,0,0"), "normal"),
        (dict(slice="front"), "front"),
        (dict(slice="z=0", t0=2.0, t1=1.0), "t0"),
        (dict(slice="z=0", angle=95.0), "90"),
        (dict(slice="z=0", spp=0), "spp=0"),
        (dict(slice="z=0", res=0), "res=0"),
        (dict(slice="z=0", time=-1.0), "time=-1"),
        (dict(slice="z=0", target_error=0.0), "target_error"),
        (dict(slice="z=0", weighting="sideways"), "sideways"),
        (dict(slice="z=0", weighting="importance"), "camera"),
        (dict(slice="z=0", tile="3"), "tile"),
        (dict(slice="z=0", window=(0.0, 0.0, 0.0, 0.0)), "window"),
        (dict(slice="z=0", separatrices=True, sep_scale=0.1), "scale"),
        (dict(slice="z=0", adaptive_cap=3, spp=4), "adaptive"),
        (dict(slice="z=0", spp=-1), "spp=-1"),
        (dict(slice="z=0", res=-5), "res=-5"),
        (dict(slice="z=0", max_bounces=-1), "max_bounces=-1"),
        (dict(slice="z=0", seed=-2), "seed=-2"),
        (dict(slice="z=0", pairs=(0, 1, 1, 1)), "kA"),
        (dict(slice="z=0", pairs=(1, 1, 1, -1)), "pairs"),
        (dict(slice="z=0", pairs="1,1,1"), "pairs"),
        (dict(slice="z=0", weighting="unweighted", guide=True), "guided"),
    ],
)
def test_bad_values_raise_value_errors(scene, kwargs, words):
    with pytest.raises(ValueError) as e:
        scene.slice(**kwargs, progress=False)
    assert isinstance(e.value, ftpd3d.Error)
    assert words in str(e.value), str(e.value)
    assert "--" not in str(e.value), "no flag names outside the command line"


def test_unknown_or_mistyped_keywords_raise_type_errors(scene):
    # As Python's own functions do: the method and the keyword are named.
    with pytest.raises(TypeError, match=r"slice\(\) got an unexpected keyword argument 'sp'"):
        scene.slice("z=0", sp=4)
    with pytest.raises(TypeError, match="volume"):
        scene.volume(4, spp=2, flatland=True)
    with pytest.raises(TypeError, match="'spp'"):
        scene.slice("z=0", spp="four")
    with pytest.raises(TypeError, match="'pairs'"):
        scene.camera(pairs=2.5)


def test_bad_lights_and_cameras_raise(scene, tmp_path):
    with pytest.raises(ftpd3d.ParameterError, match="direction"):
        ftpd3d.Scene(SCENE, sun=((0, 0, 0), (1, 1, 1)))
    with pytest.raises(ftpd3d.ParameterError, match="intensity"):
        ftpd3d.Scene(SCENE, point_lights=[((0, 1, 0), (-1, 1, 1))])
    with pytest.raises(ftpd3d.ParameterError, match="radiance"):
        ftpd3d.Scene(SCENE, sky=(1, -1, 1))
    with pytest.raises(FileNotFoundError):
        ftpd3d.Scene(SCENE, env=tmp_path / "sky.hdr")
    with pytest.raises(TypeError):
        ftpd3d.Scene(SCENE, no_such_option=1)
    with pytest.raises(ftpd3d.ParameterError, match="no camera"):
        scene.camera(spp=1)
    with pytest.raises(ftpd3d.ParameterError, match="target"):
        scene.camera(eye=(0, 1, 3), target=(0, 1, 3), spp=1)
    with pytest.raises(ftpd3d.ParameterError, match="importance"):
        scene.camera(eye=(0, 1, 3), target=(0, 1, 0), weighting="radiance", spp=1)
    with pytest.raises(ftpd3d.ParameterError):
        scene.volume(0, spp=1)


def test_reading_and_writing_errors(scene, tmp_path):
    with pytest.raises(FileNotFoundError) as e:
        ftpd3d.read(tmp_path / "none.exr")
    assert "none.exr" in str(e.value)
    junk = tmp_path / "junk.exr"
    junk.write_bytes(b"not an exr")
    with pytest.raises(ftpd3d.FormatError, match="junk.exr"):
        ftpd3d.read(junk)
    r = scene.slice("z=0", res=4, spp=1, progress=False)
    with pytest.raises(ValueError, match=r"\.exr"):
        r.write(tmp_path / "a.vti")
    # Missing folders are created (test_values.py); a file where a folder should be is an OSError.
    (tmp_path / "blocker").write_text("a file, not a folder")
    with pytest.raises(OSError) as e:
        r.write(tmp_path / "blocker" / "dir" / "a.exr")
    assert isinstance(e.value, ftpd3d.Error) and "blocker" in str(e.value)
    with pytest.raises(KeyError, match="ftpd"):
        r["no-such-channel"]


# Ctrl-C: KeyboardInterrupt soon after the signal, no file, the interpreter alive.


def test_ctrl_c_raises_keyboard_interrupt(scene, tmp_path):
    timer = threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            scene.slice("z=0", res=128, spp=1_000_000, pass_spp=2, progress=False)
    finally:
        timer.cancel()
    assert time.monotonic() - start < 30
    # The scene still runs afterwards.
    assert scene.slice("z=0", res=4, spp=1, progress=False)["ftpd"].shape == (4, 4)


def test_ctrl_c_in_a_script_writes_no_file(tmp_path):
    out = tmp_path / "never.exr"
    script = f"""
import sys, ftpd3d
scene = ftpd3d.Scene({SCENE!r})
print("running", flush=True)
try:
    r = scene.slice("z=0", res=128, spp=1_000_000, pass_spp=2, progress=False)
    r.write({str(out)!r})
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(3)
"""
    p = subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert p.stdout.readline().strip() == "running"
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    try:
        stdout, stderr = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        raise
    assert p.returncode == 3, stderr
    assert "interrupted" in stdout
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_help_and_stubs():
    assert "slice" in ftpd3d.Scene.slice.__doc__
    assert ftpd3d.read.__doc__
    pkg = pathlib.Path(ftpd3d.__file__).parent
    assert (pkg / "_native.pyi").is_file() and (pkg / "py.typed").is_file()


def test_tqdm_bar_when_asked(scene, capsys):
    pytest.importorskip("tqdm")
    r = scene.slice("z=0", res=8, spp=2, progress=True)
    assert r["ftpd"].shape == (8, 8)
    assert "sample" in capsys.readouterr().err


def test_separatrices_of_a_field_read_back(scene, tmp_path):
    # The same channels whether extracted during the run or from the field afterwards (read back).
    during = scene.slice("z=0", res=24, spp=8, seed=5, separatrices=True, progress=False)
    plain = scene.slice("z=0", res=24, spp=8, seed=5, progress=False)
    assert "separatrix" not in plain
    p = tmp_path / "plain.exr"
    plain.write(p)
    after = ftpd3d.read(p).separatrices()
    assert after.channels == during.channels
    for name in during.channels:
        assert np.array_equal(after[name], during[name]), name
    with pytest.raises(ftpd3d.ParameterError):
        plain.separatrices(scale=0.1)


def test_help_shows_the_defaults_a_run_uses(scene):
    import inspect

    sig = inspect.signature(ftpd3d.Scene.slice).parameters
    r = scene.slice(spp=1, progress=False)
    assert r.shape == [sig["res"].default] * 2
    assert r.meta["plane"] == sig["slice"].default
    assert r.meta["weighting"] == sig["weighting"].default
    assert int(r.meta["seed"]) == sig["seed"].default
    assert float(r.meta["angle_deg"]) == sig["angle"].default
    assert int(r.meta["max_bounces"]) == sig["max_bounces"].default
    assert int(r.meta["batches"]) == sig["batches"].default
    for method in ("flatland", "camera", "volume"):
        params = inspect.signature(getattr(ftpd3d.Scene, method)).parameters
        for k in ("seed", "angle", "max_bounces", "batches", "sep_threshold"):
            assert params[k].default == sig[k].default, (method, k)
    cam = inspect.signature(ftpd3d.Scene.camera).parameters
    assert cam["size"].default == (512, 512) and cam["fov"].default == 40.0
