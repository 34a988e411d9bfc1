"""docs/make_images.py: every README picture has exactly one command that makes it, each maker's
file is one its experiment writes, and the script writes whole pictures or says why it cannot."""

from __future__ import annotations

import fnmatch
import importlib
import importlib.util
import inspect
import re
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPO
from PIL import Image

SCRIPT = REPO / "docs" / "make_images.py"


def _script():
    spec = importlib.util.spec_from_file_location("make_images", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["make_images"] = module  # (its dataclasses look their module up)
    spec.loader.exec_module(module)
    return module


mi = _script()


def readme_pictures() -> list[str]:
    return re.findall(r"\]\(docs/images/([^)\s]+\.png)\)", (REPO / "README.md").read_text(encoding="utf-8"))


def makers_of(png: str) -> list[str]:
    found = [f"make_images {name}" for name in mi.PICTURES if png == f"{name}.png"]
    return found + [command for pattern, command in mi.ELSEWHERE.items() if fnmatch.fnmatch(png, pattern)]


def test_every_readme_picture_is_made_by_exactly_one_command():
    pictures = readme_pictures()
    assert len(pictures) >= 15, pictures
    for png in pictures:
        assert len(makers_of(png)) == 1, (png, makers_of(png))
    # and every maker here makes a picture the README shows
    assert {f"{n}.png" for n in mi.PICTURES} <= set(pictures)


def test_the_pictures_made_elsewhere_are_written_by_their_commands():
    shown = [p for p in readme_pictures() if p.startswith("studio_")]
    screenshot = (REPO / "docs" / "studio_screenshots.py").read_text(encoding="utf-8")
    taken = {f"studio_{n}.png" for n in re.findall(r'\bshot\("(\w+)"\)', screenshot)}
    assert shown and set(shown) <= taken, (shown, taken)
    assert '"demo_frames.png"' in (REPO / "mjmotion" / "demo.py").read_text(encoding="utf-8")


def _written_names(source: str) -> list[re.Pattern]:
    """The PNG names a module's source writes: its string literals ending in .png, f-string fields as wildcards."""
    names = re.findall(r"""f?["']([\w{}.'\[\]!= –-]*\.png)["']""", source)
    return [re.compile(re.sub(r"\\\{.*?\\\}", ".+", re.escape(n))) for n in names]


@pytest.mark.parametrize("name", list(mi.PICTURES))
def test_each_picture_is_a_file_its_run_writes(name):
    pic = mi.PICTURES[name]
    assert pic.run in mi.RUNS and pic.run in mi.RUN_TEXT
    if pic.run == "render":
        source = inspect.getsource(mi._skin_vs_capsules)
    else:
        source = inspect.getsource(importlib.import_module(f"mjmotion.experiments.{pic.run}"))
    assert any(p.fullmatch(pic.source) for p in _written_names(source)), (name, pic.source)


def test_the_launch_picture_is_the_full_grids_task():
    # 64_01 is the grid's first shot and nlp its main solver: the figure the full run draws for the golf swings' locked wrist
    from mjmotion.experiments import hitpoint_grid as hg

    source = inspect.getsource(hg._tabulate)
    assert 'main_solver = "dls" if quick else "nlp"' in source and "launch_figures(g, out_dir)" in source
    assert inspect.getsource(hg.load_shots).count('f"64_0{i}" for i in range(1, 6)') == 1


def run_script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(
    "args",
    [
        ["--only", "no_such_picture"],
        ["--only"],
        ["--from", "/nonexistent/results"],
        ["--out", "/nonexistent/images"],
        ["--bogus"],
    ],
)
def test_bad_options_are_one_error_line(args, tmp_path):
    r = run_script(*args) if "--out" in args else run_script(*args, "--out", str(tmp_path))
    assert r.returncode == 2, r
    assert r.stdout == "" and r.stderr.startswith("error: ") and r.stderr.count("\n") == 1, r.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_failed_run_leaves_no_picture(tmp_path, monkeypatch, capsys):
    from mjmotion.errors import MjmotionError

    def broken(out, data):
        (out / "skin_vs_capsules.png").write_bytes(b"\x89PNG half")
        raise MjmotionError("the renderer broke")

    monkeypatch.setitem(mi.RUNS, "render", broken)
    assert mi.main(["--only", "skin_vs_capsules", "--out", str(tmp_path), "--data", str(tmp_path)]) == 2
    assert capsys.readouterr().err == "error: the renderer broke\n"
    monkeypatch.setitem(mi.RUNS, "render", lambda out, data: None)
    assert mi.main(["--only", "skin_vs_capsules", "--out", str(tmp_path), "--data", str(tmp_path)]) == 2
    assert "wrote no skin_vs_capsules.png" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_from_copies_a_full_grids_launch_picture(tmp_path, capsys):
    grid, out = tmp_path / "hitpoint_grid", tmp_path / "images"
    grid.mkdir()
    out.mkdir()
    Image.new("RGB", (1100, 480), "white").save(grid / "launch_64_01_locked.png")
    assert mi.main(["--only", "launch_64_01", "--from", str(grid), "--out", str(out), "--data", str(tmp_path)]) == 0
    assert (out / "launch_64_01.png").read_bytes() == (grid / "launch_64_01_locked.png").read_bytes()
    assert [p.name for p in out.iterdir()] == ["launch_64_01.png"]
    assert f"copied from {grid}" in capsys.readouterr().out


def test_the_skin_picture_is_made_for_real(mocap, tmp_path, capsys):
    # the cheapest maker (a few seconds): two rendered frames side by side
    assert mi.main(["--only", "skin_vs_capsules", "--out", str(tmp_path), "--data", str(mocap)]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["skin_vs_capsules.png"]
    with Image.open(tmp_path / "skin_vs_capsules.png") as im:
        im.verify()
    with Image.open(tmp_path / "skin_vs_capsules.png") as im:
        assert im.size == (2 * mi.SKIN_PANEL[0], mi.SKIN_PANEL[1]) and im.mode == "RGB"
        assert len(np.unique(np.asarray(im.convert("L").resize((64, 20))))) > 20  # a picture, not a blank
    line = capsys.readouterr().out.strip()
    assert line.startswith("skin_vs_capsules.png: ") and line.endswith(str(tmp_path / "skin_vs_capsules.png"))


@pytest.mark.slow
def test_the_skinning_picture_is_made_for_real(mocap, tmp_path):
    assert mi.main(["--only", "skinning", "--out", str(tmp_path), "--data", str(mocap)]) == 0
    with Image.open(tmp_path / "skinning.png") as im:
        assert im.size[0] >= 600 and im.size[1] >= 400
