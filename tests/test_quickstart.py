"""The README's "Quick start" runs as written: its shell line, then its Python block, in a fresh folder."""

from __future__ import annotations

import contextlib
import io
import re
import shlex
import subprocess
import sys
from pathlib import Path

from mjmotion import bvh, cli

README = Path(__file__).resolve().parents[1] / "README.md"


def quick_start() -> tuple[str, str]:
    """``(shell, python)``: the fenced blocks of the README's Quick start section."""
    text = README.read_text(encoding="utf-8")
    section = text.split("\n## Quick start\n", 1)[1].split("\n## ", 1)[0]
    blocks = dict(re.findall(r"```(bash|python)\n(.*?)```", section, re.S))
    return blocks["bash"], blocks["python"]


def test_the_quick_start_runs_as_written(tmp_path, monkeypatch):
    shell, code = quick_start()
    monkeypatch.chdir(tmp_path)
    for command in shell.strip().split("&&"):
        argv = shlex.split(command)
        assert argv[0] == "mjmotion", command
        assert cli.main(argv[1:]) == 0, command
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, str(README) + ":quick-start", "exec"), {"__name__": "__quickstart__"})
    lines = out.getvalue().splitlines()
    # What the comment says the first print shows is what it shows.
    shown = re.search(r"print\(walk\)  # (Motion\(.*?\))", code).group(1)
    assert lines[0] == shown
    # The judge's table, then cleanup lowering the planted footskate it reported.
    assert lines[1] == "| metric | jog |" and any(ln.startswith("| planted_mm_s |") for ln in lines)
    before, after = map(float, re.search(r"planted footskate (\S+) -> (\S+) mm/s", out.getvalue()).groups())
    assert after < before
    written = bvh.read(tmp_path / "jog.bvh")
    assert written.skeleton.n_joints == 22 and written.n_frames > 30
    assert (tmp_path / "jog.mp4").stat().st_size > 10_000


def test_import_mjmotion_stays_light():
    """The quick start's names load on first use: importing the package loads neither NumPy nor MuJoCo."""
    code = (
        "import sys, mjmotion\n"
        "heavy = sorted({m.split('.')[0] for m in sys.modules} & {'numpy', 'mujoco', 'scipy', 'casadi', 'matplotlib'})\n"
        "assert heavy == [], heavy\n"
        "assert mjmotion.read.__module__ == 'mjmotion.bvh' and mjmotion.blend.__name__ == 'mjmotion.blend'\n"
        "assert mjmotion.Motion.__module__ == 'mjmotion.skeleton' and 'numpy' in sys.modules\n"
        "assert set(mjmotion.__all__) <= set(dir(mjmotion))\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
