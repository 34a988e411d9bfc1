"""CLI manners (issue 20): summaries name every file written, numbers are shown for people and
kept exact for programs, a closed pipe ends quietly, slow verbs show progress on a terminal."""

from __future__ import annotations

import io
import json
import subprocess
import sys

import pytest
import test_cli_contract as contract
from test_cli_contract import VERBS, _input, run, writes

from mjmotion import cli
from mjmotion.commands import _progress

clip, human = contract.clip, contract.human  # the contract's fixtures: a small clip, a short real walk

#: Verbs whose summary line another branch is changing (the judge: evaluate, cleanup, render):
#: their files are checked there.
NOT_HERE = {"evaluate", "cleanup", "render"}


@pytest.mark.parametrize("name", sorted(n for n, v in VERBS.items() if writes(v) and n not in NOT_HERE))
def test_the_summary_names_every_file_written(name, tmp_path, clip, human, capsys):
    spec = VERBS[name]
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    inp = _input(spec, clip, human)
    rc, out, err = run([name, *spec.argv(str(inp), str(out_dir / f"out{spec.ext}")), *spec.extra_outputs(out_dir)], capsys)
    assert rc == 0, err
    written = sorted(p for p in out_dir.rglob("*") if p.is_file())
    assert written, f"{name} wrote nothing"
    for p in written:
        assert str(p) in out or (p.parent != out_dir and str(p.parent) in out), f"{name}: {p} is not named in {out!r}"


def test_info_shows_numbers_for_people_and_keeps_the_files_rate_exact(mocap, capsys):
    walk = mocap / "cmu_asfamc_converted" / "16_15.bvh"
    text = walk.read_text()
    frame_time = next(ln for ln in text.splitlines() if ln.startswith("Frame Time:")).split(":")[1].strip()
    assert cli.main(["info", str(walk), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["frame_time_s"] == float(frame_time) == 0.00833333  # as the file writes it
    assert d["fps"] == 120.0  # the shortest rate whose frame time, to the file's digits, is the file's
    assert f"{1 / d['fps']:.6g}" == frame_time
    assert d["feet"]["left"] == {"ankle": "lfoot", "toe": "ltoes"}
    assert cli.main(["info", str(walk)]) == 0
    table = capsys.readouterr().out
    assert "471 at 120 fps (Frame Time 0.00833333 s)" in table
    assert "left lfoot → ltoes" in table and "left lwrist" in table
    for python_repr in ("[", "{", "None", "'"):  # no lists, dicts or quoted strings
        assert python_repr not in table.split("channel layouts")[0], table


def test_info_rate_of_a_long_frame_time_is_exact(tmp_path, capsys):
    """A frame time written to 17 digits (our writer's 1/60) reads back as exactly 60 fps."""
    out = tmp_path / "walk.bvh"
    assert cli.main(["synth", "walk", "--seconds", "0.5", "-o", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["info", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["fps"] == 60.0 and d["frame_time_s"] == 1 / 60


def test_a_register_plot_must_be_png_and_is_refused_before_any_work(tmp_path, clip, capsys):
    rc, _, err = run(["register", str(clip), str(clip), "--json", str(tmp_path / "r.json"), "--plot", str(tmp_path / "g.jpg")], capsys)
    assert rc == 2 and "expected a .png path" in err
    assert not list(tmp_path.iterdir())


def test_a_vary_plot_must_be_png_and_is_refused_before_any_work(tmp_path, clip, human, capsys):
    """vary checked the plot's extension only when it drew it: the refused variant stayed behind at -o."""
    spec = VERBS["vary"]
    out = tmp_path / "v.bvh"
    rc, _, err = run(["vary", *spec.argv(str(_input(spec, clip, human)), str(out)), "--plot", str(tmp_path / "p.pdf")], capsys)
    assert rc == 2 and "--plot" in err and "expected a .png path" in err
    assert not list(tmp_path.iterdir())


def _closed_pipe(argv: list[str]) -> subprocess.CompletedProcess:
    """Run ``mjmotion ARGV`` with its stdout a pipe whose reader is gone before it writes."""
    proc = subprocess.Popen([sys.executable, "-m", "mjmotion.cli", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader leaves at once, as `head -1` does after its line
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    return subprocess.CompletedProcess(argv, proc.returncode, "", err)


@pytest.mark.parametrize("argv", [["--help"], ["info", "--help"], ["info", "{clip}", "--json"]], ids=["help", "verb-help", "info-json"])
def test_a_closed_pipe_ends_quietly(argv, clip):
    r = _closed_pipe([a.format(clip=clip) for a in argv])
    assert r.stderr == "", r.stderr
    assert r.returncode in (0, 141)  # 141 = 128 + SIGPIPE, as a tool killed by the signal reports


def test_a_broken_pipe_that_is_not_stdout_is_still_an_error(monkeypatch, capsys):
    def verb(args):
        raise BrokenPipeError(32, "Broken pipe")  # ffmpeg gone while a video is written

    monkeypatch.setattr(cli, "_stdout_closed", lambda: False)
    parser = cli.build_parser(["info"])
    args = parser.parse_args(["info", "x.bvh"])
    args._run = verb
    assert cli._run(args) == 2
    assert capsys.readouterr().err.startswith("error: broken pipe")


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_shows_the_steps_on_a_terminal_only(monkeypatch):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    with _progress.steps("blend", ("read", "register", "write")) as step:
        step("read")
        sys.stderr.write("note: a note while the bar shows\n")
        step("register")
        step("write")
    assert sys.stderr is term  # restored
    shown = term.getvalue()
    assert "blend: 0/3, read" in shown and "blend: 1/3, register" in shown and "blend: 2/3, write" in shown
    assert "note: a note while the bar shows\n" in shown
    assert shown.endswith("\r")  # the bar is erased at the end: the summary line stays alone

    piped = io.StringIO()
    monkeypatch.setattr(sys, "stderr", piped)
    with _progress.steps("blend", ("read", "write")) as step:
        step("read")
        step("write")
    assert piped.getvalue() == ""


def test_a_slow_verb_shows_progress_on_a_terminal(monkeypatch, tmp_path, capsys):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    out = tmp_path / "lib"
    assert cli.main(["synth", "library", str(out)]) == 0
    assert "synth library: 1/2, write" in term.getvalue()
    summary = capsys.readouterr().out
    assert all(f"{p.name}" in summary for p in out.iterdir() if p.suffix in (".bvh", ".json"))


@pytest.mark.parametrize("name", ["hit", "vary"])
def test_hit_and_vary_show_their_steps_on_a_terminal(name, monkeypatch, tmp_path, clip, human, capsys):
    spec = VERBS[name]
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    assert cli.main([name, *spec.argv(str(_input(spec, clip, human)), str(tmp_path / "out.bvh"))]) == 0
    shown = term.getvalue()
    # the long steps are named while they run (hit: the IK solve; vary: the synthesis and its cleanup)
    want = ("hit: 0/3, read", "hit: 1/3, solve", "hit: 2/3, write") if name == "hit" else ("vary: 2/6, synthesise", "vary: 3/6, clean up")
    assert all(w in shown for w in want), shown
    assert str(tmp_path / "out.bvh") in capsys.readouterr().out


def test_hit_summary_is_rounded_and_names_a_grip_only_for_two_hands(tmp_path, capsys):
    """Issue 20: ``hit`` printed 16 decimals and a "grip error" for a kick."""
    import re

    from mjmotion import bvh, synth

    kick = tmp_path / "kick.bvh"
    bvh.write(synth.kick().motion, kick)
    assert (
        cli.main(["hit", str(kick), "--effector", "right_foot", "--offset", "0", "0.05", "0", "--solver", "dls", "-o", str(tmp_path / "k.bvh")]) == 0
    )
    line = capsys.readouterr().out
    assert "grip" not in line and "style_rmse" in line, line
    assert not re.search(r"\d\.\d{5,}", line), line  # no number to more than 4 decimals
    drive = tmp_path / "drive.bvh"
    bvh.write(synth.drive().motion, drive)
    assert cli.main(["hit", str(drive), "--offset", "0", "0.05", "0.05", "--solver", "dls", "-o", str(tmp_path / "d.bvh")]) == 0
    line = capsys.readouterr().out
    assert "grip error" in line and not re.search(r"\d\.\d{5,}", line), line


def test_render_shows_its_frame_bar_on_a_terminal_only(monkeypatch, tmp_path, clip, human, capsys):
    """`render … 2> log` leaves the log empty (it wrote a tqdm bar with carriage returns there)."""
    spec = VERBS["render"]
    argv = ["render", *spec.argv(str(_input(spec, clip, human)), str(tmp_path / "a.gif")), "--fast"]  # (the spec's size: 64x48)
    for stream, bar in ((io.StringIO(), False), (_Terminal(), True)):
        monkeypatch.setattr(sys, "stderr", stream)
        assert cli.main([*argv, "--force"]) == 0
        shown = stream.getvalue()
        assert ("frame" in shown and "\r" in shown) == bar, shown
        assert shown if bar else all(line.startswith("note:") for line in shown.splitlines()), shown
