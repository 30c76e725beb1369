"""What a notebook user meets: typed descriptions and statistics, messages that name the keyword
and its form, a folder created for a new file, paths in any script, and never a PanicException."""

import shutil
import sys

import pytest

import ftpd3d
from conftest import ROOT, SCENE


@pytest.fixture(scope="module")
def run():
    return ftpd3d.Scene(SCENE).slice("z=0", res=4, spp=4, progress=False)


def test_meta_holds_numbers_tuples_and_flags(run):
    m = run.meta
    assert m["spp"] == 4 and type(m["spp"]) is int
    assert type(m["seed"]) is int and type(m["samples"]) is int
    assert type(m["t1"]) is float and type(m["angle_deg"]) is float
    origin = m["plane.origin"]
    assert type(origin) is tuple and len(origin) == 3
    assert all(type(x) is float for x in origin)
    assert type(m["plane.size"]) is tuple and len(m["plane.size"]) == 2
    assert m["flatland"] is False and m["partial"] is False
    # Text stays text, even where it reads as a number.
    assert m["plane"] == "z=0" and type(m["scene"]) is str and type(m["tool"]) is str
    # The header's own text is still there, exactly as the file holds it.
    assert run.header["spp"] == "4" and float(run.header["t1"]) == m["t1"]


def test_stats_hold_numbers(run):
    s = run.stats
    assert s["samples"] == 4 * 4 * 4 and type(s["samples"]) is int
    for k in ("rays", "passes", "capped", "clamped"):
        assert type(s[k]) is int, k
    assert type(s["seconds"]) is float and s["seconds"] >= 0
    assert type(s["stop"]) is str


def test_a_sun_of_the_wrong_form_names_sun_and_its_form():
    with pytest.raises(TypeError) as e:
        ftpd3d.Scene(SCENE, sun=(0, 1, 0))
    text = str(e.value)
    assert "sun" in text and "(x, y, z), (r, g, b)" in text, text
    assert "Suns" not in text and "extract" not in text, text


def test_progress_true_without_tqdm_says_what_to_do(monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)  # import tqdm fails as if not installed
    with pytest.raises(ImportError) as e:
        ftpd3d.Scene(SCENE).slice("z=0", res=2, spp=1, progress=True)
    text = str(e.value)
    assert "pip install tqdm" in text and "callable" in text, text


def test_write_creates_missing_folders(run, tmp_path):
    target = tmp_path / "new" / "deeper" / "f.exr"
    run.write(target, png=True)
    assert target.is_file() and target.with_suffix(".png").is_file()
    assert ftpd3d.read(target).meta["spp"] == 4


@pytest.mark.parametrize("folder", ["scène", "目录", "🎉"])
def test_a_scene_path_in_any_script_is_written_and_read_back(tmp_path, folder):
    d = tmp_path / folder
    d.mkdir()
    shutil.copy(SCENE, d / "場景.obj")
    shutil.copy(ROOT / "scenes" / "cornell_mirror.mtl", d)
    scene = str(d / "場景.obj")
    r = ftpd3d.Scene(scene).slice("z=0", res=4, spp=1, progress=False)
    out = d / "café.exr"
    r.write(out)  # was a PanicException, which `except Exception` does not catch
    assert ftpd3d.read(out).meta["scene"] == scene
    try:
        import OpenEXR
    except ImportError:
        return
    with OpenEXR.File(str(out), separate_channels=True) as f:
        v = f.parts[0].header["ftpd3d.scene"]
    assert (v.decode() if isinstance(v, bytes) else v) == scene


def test_write_onto_a_fifo_is_an_error_not_a_replacement(run, tmp_path):
    import os
    import stat

    fifo = tmp_path / "f.exr"
    os.mkfifo(fifo)
    with pytest.raises(ftpd3d.FileError) as e:
        run.write(fifo)
    assert str(fifo) in str(e.value) and "FIFO" in str(e.value)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
