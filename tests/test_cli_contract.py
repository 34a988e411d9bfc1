"""The CLI contract (issue 9 item 3), for every verb ``mjmotion.cli`` discovers.

A mistake by the user — wrong arguments, a missing or unreadable file, a bad BVH file from the
corpus, a frame out of range, an output that exists or is an input — ends with exit status 2 and
exactly one ``error:`` line on stderr, no traceback (``--verbose`` adds it). Outputs are written
atomically: when the final rename fails nothing is left behind, and a verb that writes without
going through a temporary file is caught because it "succeeds" anyway.

Verbs are discovered, so a new verb is covered by the generic cases at once; the table ``VERBS``
gives a valid fast invocation and verb-specific bad arguments. A verb missing from the table gets
an invocation derived from its parser when it has no required options beyond ``-o``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from mjmotion import bvh, cli

BAD = Path(__file__).resolve().parent / "data" / "bad"
REPO = Path(__file__).resolve().parents[1]


def _corpus():
    spec = importlib.util.spec_from_file_location("make_corpus_cli", BAD / "make_corpus.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_corpus_cli"] = mod
    spec.loader.exec_module(mod)
    return mod


CASES = _corpus().cases()
ERROR_CASES = [c for c in CASES if c.error]
VALID_CASES = [c for c in CASES if not c.error]


@dataclass(frozen=True)
class Verb:
    """How to call a verb: ``argv(inp, out)`` is a valid, fast invocation (``out`` unused if it
    writes nothing); ``bad`` are extra arguments, each appended to it, that must be refused;
    ``humanoid``: needs a real human skeleton (feet, hands) rather than the corpus' base file;
    ``script``: the input is a stream script, so BVH inputs are wrapped in one."""

    argv: Callable[[str, str], list[str]]
    ext: str = ""
    bad: tuple[tuple[str, ...], ...] = ()
    humanoid: bool = False
    extra_outputs: Callable[[Path], list[str]] = field(default=lambda d: [])
    script: bool = False
    inputless: bool = False  # reads no file (synth): the input cases do not apply
    runs: bool = True  # False: never run it for real (demo: minutes); only refusals are tested
    verbose_bad: tuple[str, ...] = ()  # for inputless verbs: arguments that raise an MjmotionError
    folder: bool = False  # reads a folder and writes one (audit): a bad file is a row, not the exit status; tests/test_audit.py checks it


VERBS: dict[str, Verb] = {
    "info": Verb(lambda i, o: [i], bad=(("--units", "furlongs"), ("--units", "-1"), ("--up", "x"))),
    "convert": Verb(
        lambda i, o: [i, o],
        ".bvh",
        bad=(
            ("--frames", "500:600"),
            ("--frames", "2:1"),
            ("--frames", "a:b"),
            ("--frames", "7"),
            ("--fps", "0"),
            ("--fps", "nan"),
            ("--scale", "-1"),
            ("--scale", "inf"),
            ("--units", "0"),
        ),
    ),  # fmt: skip
    "compile": Verb(lambda i, o: [i, "-o", o], ".xml", bad=(("--prop", "club:NoSuchJoint"), ("--prop", "sword:Hips"))),
    "fk": Verb(lambda i, o: [i, "-o", o], ".npz", bad=(("--prop", "bat:NoSuchJoint"), ("--prop", "sword"))),
    "render": Verb(
        lambda i, o: [i, "-o", o, "--width", "64", "--height", "48", "--no-shadows"],
        ".mp4",
        bad=(
            ("--frames", "500:600"),
            ("--width", "0"),
            ("--fps", "-5"),
            ("--trail", "NoSuchJoint"),
            ("--labels", "a", "b"),
            ("--prop", "club:NoSuchJoint"),
            ("--hq", "--fast"),  # two looks at once (it drew --fast)
        ),
    ),  # fmt: skip
    "vary": Verb(
        lambda i, o: [i, "--scale", "1.2", "-o", o],
        ".bvh",
        bad=(("--segment", "500:600"), ("--rest-frame", "99999"), ("--pcs", "0"), ("--variance", "2")),
        humanoid=True,
        extra_outputs=lambda d: ["--json", str(d / "report.json"), "--plot", str(d / "plot.png")],
    ),
    "cleanup": Verb(
        lambda i, o: [i, "-o", o],
        ".bvh",
        bad=(("--h-c", "-1"), ("--v-c", "nan"), ("--blend", "-2")),
        humanoid=True,
        extra_outputs=lambda d: ["--json", str(d / "report.json")],
    ),
    "evaluate": Verb(
        lambda i, o: [i, "--json", o],
        ".json",
        bad=(("--frames", "500:600"), ("--h-c", "-1"), ("--ball", "0.5", "0", "0.03", "--frame", "99999")),
        humanoid=True,
    ),
    # serving runs until Ctrl-C: the contract is checked on --check (read and validate the clips, exit)
    "studio": Verb(lambda i, o: [i, "--check"], bad=(("--port", "70000"), ("--data", "/no/such/mocap"))),
    "blend": Verb(
        lambda i, o: [i, i, "--weights", "0.5,0.5", "-o", o],
        ".bvh",
        bad=(
            ("--weights", "0.5"),
            ("--weights", "0.7,0.7"),
            ("--weights=-1,2",),
            ("--weights", "a,b"),
            ("--frames", "500:600"),
            ("--frames", "0:5,"),
            ("--fps", "0"),
        ),
        humanoid=True,
    ),  # fmt: skip
    "register": Verb(
        lambda i, o: [i, i, "--json", o],
        ".json",
        bad=(
            ("--window", "4"),
            ("--window", "0"),
            ("--frames", "500:600"),
            ("--frames", ","),
            ("--slope-limit", "-1"),
            ("--fps", "-1"),
            ("--time-limit", "0"),
        ),
        humanoid=True,
        extra_outputs=lambda d: ["--plot", str(d / "grid.png")],
    ),
    "stream": Verb(lambda i, o: [i, "-o", o], ".bvh", humanoid=True, script=True, extra_outputs=lambda d: ["--json", str(d / "report.json")]),
    "hit": Verb(
        # A 5 mm move: reachable within the short clip's own joint ranges (an unreachable one exits 2 by design).
        lambda i, o: [i, "--effector", "right_foot", "--offset", "0", "0", "0.005", "-o", o],
        ".bvh",
        bad=(("--frame", "99999"), ("--effector", "NoSuchSite"), ("--falloff", "-1"), ("--lock", "NoSuchJoint")),
        humanoid=True,
        extra_outputs=lambda d: ["--json", str(d / "report.json")],
    ),
    "synth": Verb(
        lambda i, o: ["walk", "--seconds", "0.5", "-o", o],
        ".bvh",
        bad=(("--seconds", "-1"), ("--speed", "nan"), ("--seconds", "1e9")),
        inputless=True,
        extra_outputs=lambda d: ["--truth", str(d / "truth.json")],
    ),
    "audit": Verb(lambda i, o: [i, "-o", o], folder=True, bad=(("--timeout", "0"), ("--workers", "0"), ("--connect-timeout", "nan"))),
    "demo": Verb(
        lambda i, o: ["--out", o, "--only", "physics_audit", "--no-video"],
        bad=(("--data", "/no/such/mocap"), ("--only", "no_such_experiment")),
        inputless=True,
        runs=False,
        verbose_bad=("--data", "/no/such/mocap"),
    ),
}


def as_input(spec: Verb, clip: Path) -> Path:
    """The verb's input for a BVH clip: the clip, or a one-clip stream script beside it."""
    if not spec.script:
        return clip
    script = clip.with_name(clip.stem + "_script.json")
    script.write_text(json.dumps({
        "duration": 0.2,
        "loop_blend": 0.05,
        "clips": {"a": {"file": str(clip)}},
        "locomotion": ["a"],
        "commands": [{"time": 0, "weights": {"a": 1}}],
    }))  # fmt: skip
    return script


#: Contract breaks found in verbs this file does not own, reported to the lead. Each is a strict
#: xfail: when the verb is fixed the test passes, pytest reports XPASS as a failure, and the
#: entry must be removed here.
KNOWN_BREAKS: dict[str, str] = {}


def _known(key: str) -> tuple:
    """A strict xfail mark if ``key`` is a known break."""
    reason = KNOWN_BREAKS.get(key)
    return (pytest.mark.xfail(reason=reason, strict=True),) if reason else ()


def _verb_params(test: str) -> list:
    return [pytest.param(n, id=n, marks=_known(f"{n} {test}")) for n in VERB_NAMES]


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


SUBPARSERS = _subparsers()
VERB_NAMES = sorted(SUBPARSERS)


def _auto_verb(name: str) -> Verb | None:
    """An invocation from the parser alone: inputs for positionals, ``-o`` for the output."""
    p = SUBPARSERS[name]
    if any(g.required for g in p._mutually_exclusive_groups):
        return None
    parts: list[tuple[str, ...]] = []
    ext = ""
    for a in p._actions:
        if a.option_strings:
            if not a.required:
                continue
            if a.dest != "output":
                return None
            parts.append((a.option_strings[0], "OUT"))
            mv = str(a.metavar or "")
            ext = "." + mv.split(".", 1)[1].split("|")[0] if "." in mv else ".out"
        elif "out" in a.dest:
            parts.append(("OUT",))
            ext = ext or ".bvh"
        else:
            n = a.nargs if isinstance(a.nargs, int) else 1
            parts.append(("IN",) * n)
    flat = [x for part in parts for x in part]
    if "IN" not in flat:  # reads no file: running it blind could start a long job
        return None
    return Verb(lambda i, o: [i if x == "IN" else o if x == "OUT" else x for x in flat], ext)


def verb(name: str, reads: bool = False) -> Verb:
    """The verb's table entry (skips when there is none, or when ``reads`` and it reads no file)."""
    spec = VERBS.get(name) or _auto_verb(name)
    if spec is None:
        pytest.skip(f"verb {name!r} has required options: add it to VERBS in tests/test_cli_contract.py")
    if reads and spec.inputless:
        pytest.skip(f"{name} reads no input file")
    return spec


def writes(spec: Verb) -> bool:
    """Whether the verb writes a file the output contract applies to (and may be run for it)."""
    return spec.runs and not spec.folder and "OUT" in spec.argv("IN", "OUT")


# --- running ---------------------------------------------------------------------------------
def run(argv: list[str], capsys) -> tuple[int, str, str]:
    """``mjmotion ARGV`` in this process: (status, stdout, stderr)."""
    try:
        rc = cli.main(argv)
    except SystemExit as e:  # argparse's usage errors
        rc = e.code if isinstance(e.code, int) else 1
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def refused(rc: int, err: str, *phrases: str) -> str:
    """Assert the contract for a refused command; returns the error line."""
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert rc == 2, f"exit status {rc}, stderr:\n{err}"
    assert len(lines) == 1, f"expected one error line, stderr:\n{err}"
    assert "Traceback" not in err, err
    assert "internal error" not in lines[0], lines[0]
    for p in phrases:
        assert p in lines[0], f"{p!r} not in {lines[0]!r}"
    return lines[0]


def works_or_refuses(spec: Verb, rc: int, err: str, out: Path) -> None:
    """Exit 0 with the output written and no error line, or the contract of a refusal with
    nothing written (hit writes its best effort by design, and says so)."""
    if rc == 0:
        assert "Traceback" not in err and not any(ln.startswith("error:") for ln in err.splitlines()), err
        assert not writes(spec) or out.exists()
    else:
        line = refused(rc, err)
        assert not out.exists() or "best effort written" in line


@pytest.fixture(scope="module")
def clip(tmp_path_factory) -> Path:
    """A small valid clip (the corpus' base file: five joints, three frames)."""
    d = tmp_path_factory.mktemp("in")
    p = d / "clip.bvh"
    p.write_bytes((BAD / "base.bvh").read_bytes())
    return p


@pytest.fixture(scope="module")
def human(tmp_path_factory) -> Path | None:
    """A short real clip (30 frames of a CMU walk) for verbs that need feet and hands; None without the mocap."""
    from conftest import data_dir

    root = data_dir()
    if root is None or not (root / "cmu_cgspeed_daz" / "09_06.bvh").is_file():
        return None
    p = tmp_path_factory.mktemp("human") / "walk.bvh"
    assert cli.main(["convert", str(root / "cmu_cgspeed_daz" / "09_06.bvh"), str(p), "--frames", "0:30"]) == 0
    return p


def _human(human: Path | None) -> Path:
    """The real clip, or skip (fail when ``MJMOTION_REQUIRE_DATA=1``) without the shared mocap."""
    if human is None:
        from conftest import require_data

        require_data()
        pytest.fail("the shared mocap has no cmu_cgspeed_daz/09_06.bvh")
    return human


def _input(spec: Verb, clip: Path, human: Path | None) -> Path:
    return as_input(spec, _human(human) if spec.humanoid else clip)


# --- every verb ------------------------------------------------------------------------------
def test_every_verb_is_discovered():
    assert {"info", "convert", "compile", "fk"} <= set(VERB_NAMES)


@pytest.mark.parametrize("name", VERB_NAMES)
def test_help_teaches_with_examples(name, capsys):
    rc, out, _ = run([name, "--help"], capsys)
    assert rc == 0 and "examples:" in out and f"mjmotion {name}" in out


@pytest.mark.parametrize("name", VERB_NAMES)
def test_wrong_arguments(name, capsys):
    required = [a for a in SUBPARSERS[name]._actions if a.required]
    if required:
        refused(*run([name], capsys)[::2], "required")
    spec = VERBS.get(name) or _auto_verb(name)
    argv = spec.argv("in.bvh", "out") if spec else []
    refused(*run([name, *argv, "--no-such-option"], capsys)[::2], "--no-such-option")


def _text_options(name: str) -> list[str]:
    """The verb's options that take free text (paths, names, ranges): no type, no choices."""
    return [
        max(a.option_strings, key=len)
        for a in SUBPARSERS[name]._actions
        if a.option_strings and a.type is None and a.nargs != 0 and a.choices is None and not isinstance(a.default, str)
    ]


@pytest.mark.parametrize("name", VERB_NAMES)
def test_an_empty_text_option_is_refused(name, capsys):
    """``--json ""`` was skipped as if not given, ``audit -o ""`` became the current folder."""
    spec = VERBS.get(name) or _auto_verb(name)
    argv = spec.argv("in.bvh", "out") if spec else []
    for option in _text_options(name):
        line = refused(*run([name, *argv, option, ""], capsys)[::2])
        # (--prop's own check says what a prop is; vary's --scores cannot join the example's --scale)
        assert option in line and ("expected" in line or "not allowed with" in line), line


def test_negative_numbers_in_any_spelling_are_values_not_options(tmp_path, human, capsys):
    """argparse took ``--floor -0.001`` but read ``-1e-3``, ``-inf`` and ``-nan`` as options ("expected one argument")."""
    walk = _human(human)
    rep = tmp_path / "r.json"
    rc, _, err = run(["evaluate", str(walk), "--floor", "-1e-3", "--json", str(rep)], capsys)
    assert rc == 0, err
    assert json.loads(rep.read_text())[0]["report"]["floor_m"] == pytest.approx(-0.001)
    for word in ("-inf", "-NaN", "-1e400"):
        refused(*run(["evaluate", str(walk), "--floor", word], capsys)[::2], f"--floor {word}: expected a floor height in metres")


def test_frame_ranges_counted_from_the_end_are_values_not_options(tmp_path, human, capsys):
    """``--frames -100:`` read as an option ("expected one argument"), though negatives are documented."""
    walk = _human(human)
    n = bvh.read(walk).n_frames
    for text, frames in (("-20:", 20), ("-20:-5", 15)):
        rep = tmp_path / f"{text}.json"
        rc, _, err = run(["evaluate", str(walk), "--frames", text, "--json", str(rep)], capsys)
        assert rc == 0, err
        got = json.loads(rep.read_text())[0]
        assert got["report"]["n_frames"] == frames and got["skipped_frames"] == n - 20
    refused(*run(["evaluate", str(walk), "--frames", f"-{n + 5}:-{n + 1}"], capsys)[::2], "selects no frames")
    # A list led by a negative number reaches its option's own check (was "expected one argument").
    refused(*run(["blend", str(walk), str(walk), "--weights", "-0.2,1.2", "-o", str(tmp_path / "b.bvh")], capsys)[::2], "--weights", "non-negative")


def test_an_option_that_would_do_nothing_is_refused(tmp_path, human, capsys):
    """evaluate --ball-velocity without --ball exited 0 and the velocity went nowhere (a review)."""
    walk = str(_human(human))
    refused(*run(["evaluate", walk, "--ball-velocity", "1", "1", "1"], capsys)[::2], "--ball-velocity is the velocity of --ball")
    refused(
        *run(["evaluate", walk, "--ball", "0", "0", "1", "--frame", "10", "--delivery", "fast", "--ball-velocity", "1", "1", "1"], capsys)[::2],
        "--ball-velocity with a delivered ball",
    )
    # Its default given explicitly without a ball is refused alike (the option was given), and a ball takes it.
    refused(*run(["evaluate", walk, "--ball-velocity", "0", "0", "0"], capsys)[::2], "--ball-velocity")
    rep = tmp_path / "r.json"
    rc, _, err = run(["evaluate", walk, "--ball", "0", "0", "1", "--frame", "10", "--ball-velocity", "1", "1", "1", "--json", str(rep)], capsys)
    assert rc == 0, err
    # --bowler without --delivery, --plot-dims without --plot: the same (a hostile-input sweep).
    for argv in (
        ["evaluate", walk, "--ball", "0", "0", "1", "--bowler", "1", "0"],
        ["hit", walk, "--offset", "0", "0", "0.1", "--bowler", "1", "0", "-o", str(tmp_path / "h.bvh")],
    ):
        refused(*run(argv, capsys)[::2], "--bowler 1 0: the direction a --delivery comes from")
    released = ["--ball-release", "0", "18", "2", "--release-velocity", "0", "-30", "0", "--bowler", "1", "0"]
    refused(
        *run(["hit", walk, "--offset", "0", "0", "0.1", *released, "-o", str(tmp_path / "h.bvh")], capsys)[::2],
        "--bowler 1 0: only a --delivery uses it",
    )
    refused(
        *run(["vary", walk, "--scale", "1.2", "--plot-dims", "3", "-o", str(tmp_path / "v.bvh")], capsys)[::2],
        "--plot-dims 3: the components --plot draws",
    )
    assert not (tmp_path / "h.bvh").exists() and not (tmp_path / "v.bvh").exists()
    hit = ["hit", walk, "--offset", "0.05", "0", "0", "-o", str(tmp_path / "h.bvh")]
    refused(*run([*hit, "--effector", "right_foot", "--prop", "bat"], capsys)[::2], "--prop bat: the prop of --effector club")
    refused(*run([*hit, "--source-ball", "0", "0", "0", "--frame", "5"], capsys)[::2], "--source-ball with --frame 5")
    # a foot's chain has no wrist and no arm joint: --wrist and --lock gave the result of leaving them out
    kick = [*hit, "--effector", "right_foot"]
    refused(*run([*kick, "--wrist", "swing"], capsys)[::2], "--wrist swing: the chain rButtock → rFoot (rButtock, rThigh, rShin, rFoot) has no wrist")
    refused(*run([*kick, "--lock", "lShldr"], capsys)[::2], "--lock lShldr: not a joint of the chain rButtock → rFoot")
    # a hit's options with no ball to hit (they changed nothing), and a grid finer than launches can tell apart
    refused(*run(["evaluate", walk, "--grid-step", "0.1"], capsys)[::2], "--grid-step 0.1: the spacing of --hit-grid")
    refused(*run(["evaluate", walk, "--ball-radius", "0.5"], capsys)[::2], "--ball-radius 0.5: the radius of --ball")
    refused(*run(["evaluate", walk, "--grid-step", "1e-12"], capsys)[::2], "--grid-step 1e-12: expected a spacing in metres")
    # more dimensions than the variation has components: refused before the clip is written (it was
    # written, then the plot failed with "score_paths: 3-D plot needs at least 3 components")
    plotted = ["--plot", str(tmp_path / "v.png"), "--json", str(tmp_path / "v.json"), "-o", str(tmp_path / "v.bvh")]
    refused(
        *run(["vary", walk, "--scale", "1.2", "--pcs", "2", "--plot-dims", "3", *plotted], capsys)[::2],
        "--plot-dims 3: this variation has 2 principal component(s) to draw; use --plot-dims 2",
    )
    assert not any(tmp_path.glob("v.*"))


def test_an_option_of_one_value_given_twice_is_refused(tmp_path, human, capsys):
    """`convert --fps 30 --fps 60` kept the last and wrote 60 fps, silently (a hostile-input sweep);
    the spelled `--fps=60` counts too, and so does an abbreviation argparse takes for it (`--fp 30`);
    repeatable options (`--source`, `--prop`) still append."""
    walk = str(_human(human))
    for extra in (["--fps", "30", "--fps", "60"], ["--fps", "30", "--fps=60"], ["--fp", "30", "--fps", "60"], ["--fp=30", "--fps", "60"]):
        refused(*run(["convert", walk, str(tmp_path / "c.bvh"), *extra], capsys)[::2], "--fps is given 2 times")
    refused(
        *run(["blend", walk, walk, "--weights", "0.5,0.5", "-o", str(tmp_path / "a.bvh"), "-o", str(tmp_path / "b.bvh")], capsys)[::2],
        "--output is given 2 times",
    )
    refused(
        *run(["blend", walk, walk, "--weights", "0.5,0.5", "--out", str(tmp_path / "a.bvh"), "-o", str(tmp_path / "b.bvh")], capsys)[::2],
        "--output is given 2 times",
    )
    assert sorted(os.listdir(tmp_path)) == []
    rc, _, err = run(["compile", walk, "-o", str(tmp_path / "m.xml"), "--prop", "club:rwrist", "--prop", "bat:lwrist"], capsys)
    assert rc != 2 or "given 2 times" not in err, err


def test_errors_name_the_option_they_are_about(tmp_path, human, capsys):
    """Library messages reached the user without the option they concern ("no joint named 'x'",
    "trail: no site…", "segment 0:1 must select…"); --bowler 0 0 was refused only after the clip was read."""
    walk = str(_human(human))
    out = str(tmp_path / "o.bvh")
    cases = (
        (["hit", walk, "--offset", "0", "0", "0.1", "--lock", "nosuch", "-o", out], "--lock nosuch: no joint"),
        (["evaluate", walk, "--prop", "club:nosuch"], "--prop club:nosuch: no joint named 'nosuch'"),
        (["evaluate", "missing.bvh", "--bowler", "0", "0"], "--bowler 0 0: expected a horizontal direction"),
        (["hit", "missing.bvh", "--offset", "0", "0", "0.1", "--bowler", "0", "0", "-o", out], "--bowler 0 0"),
        (["vary", walk, "--scale", "1.2", "--segment", "0:1", "-o", out], "--segment 0:1: selects 1 frame(s); expected at least 3"),
        (["render", walk, "--trail", "nosuch", "-o", str(tmp_path / "r.gif")], "--trail nosuch: no site or joint"),
        (["hit", walk, "--effector", "nosite", "--offset", "0", "0", "0.1", "-o", out], "--effector nosite: expected club, left_foot"),
        (["hit", walk, "--offset", "0", "0", "0.1", "--delivery", "fast", "--bowler", "1e-300", "0", "-o", out], "--bowler 1e-300 0: expected"),
        (
            ["hit", walk, "--offset", "0", "0", "0.1", "--ball-release", "0", "0", "0", "--release-velocity", "0", "0", "0", "-o", out],
            "--ball-release 0 0 0: the ball is released 0.000 m above the floor",
        ),
    )
    for argv, phrase in cases:
        refused(*run(argv, capsys)[::2], phrase)
    # two clips the registration cannot blend: which two (it said "the registered clips")
    from mjmotion import bvh

    short = tmp_path / "two_frames.bvh"
    bvh.write(bvh.read(walk)[:2], short)
    refused(*run(["blend", str(short), walk, "--weights", "0.5,0.5", "-o", out], capsys)[::2], f"{short} and {walk}: the registered clips")


def test_error_is_one_line_even_for_names_with_line_breaks(tmp_path, capsys):
    odd = tmp_path / "two\nlines\r.bvh"
    line = refused(*run(["convert", str(odd), str(tmp_path / "out.bvh")], capsys)[::2], "no such file")
    assert "two\\nlines\\r.bvh" in line
    refused(*run(["info", str(odd), "--up", "x\ny"], capsys)[::2], "invalid choice")


def test_no_verb_and_unknown_verb(capsys):
    rc, out, err = run([], capsys)
    assert rc == 2 and out == "" and "mjmotion VERB --help" in err and err.endswith("error: expected a VERB (listed above)\n")
    refused(*run(["no-such-verb"], capsys)[::2], "no-such-verb")


@pytest.mark.parametrize("name", VERB_NAMES)
def test_missing_input(name, tmp_path, capsys):
    spec = verb(name, reads=True)
    missing = tmp_path / "missing.bvh"
    out = tmp_path / f"out{spec.ext}"
    refused(*run([name, *spec.argv(str(missing), str(out))], capsys)[::2], str(missing))
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.parametrize("name", VERB_NAMES)
def test_input_is_a_directory_or_under_a_file(name, tmp_path, clip, capsys):
    spec = verb(name, reads=True)
    folder = tmp_path / "folder.bvh"
    folder.mkdir()
    out = tmp_path / f"out{spec.ext}"
    refused(*run([name, *spec.argv(str(folder), str(out))], capsys)[::2], str(folder))
    under_file = clip / "x.bvh"  # a path through a regular file: NotADirectoryError
    refused(*run([name, *spec.argv(str(under_file), str(out))], capsys)[::2], str(under_file))
    assert not out.exists()


@pytest.mark.parametrize("name", VERB_NAMES)
def test_unreadable_directory(name, tmp_path, clip, capsys):
    spec = verb(name, reads=True)
    locked = tmp_path / "locked"
    locked.mkdir()
    inp = locked / "clip.bvh"
    inp.write_bytes(clip.read_bytes())
    locked.chmod(0)
    if os.access(inp, os.R_OK):  # root (with CAP_DAC_OVERRIDE) reads it anyway
        locked.chmod(0o755)
        pytest.skip("this user can read unreadable folders (root)")
    try:
        refused(*run([name, *spec.argv(str(inp), str(tmp_path / f"out{spec.ext}"))], capsys)[::2], str(inp))
        if writes(spec):
            out = locked / f"out{spec.ext}"
            refused(*run([name, *spec.argv(str(clip), str(out))], capsys)[::2])
    finally:
        locked.chmod(0o755)


@pytest.mark.parametrize("name", VERB_NAMES)
def test_corpus_file_is_one_error_line_with_file_and_line(name, tmp_path, capsys):
    """Every error case of the corpus (one loop per verb: cheap, and a failure lists every case)."""
    spec = verb(name, reads=True)
    if spec.folder:
        pytest.skip(f"{name} reads folders: a corpus file is a row of its table")
    out = tmp_path / "out" / f"out{spec.ext}"
    out.parent.mkdir()
    failures = []
    for case in ERROR_CASES:
        inp = tmp_path / f"{case.name}.bvh"
        inp.write_bytes(case.data)
        rc, _, err = run([name, *spec.argv(str(as_input(spec, inp)), str(out))], capsys)
        try:
            refused(rc, err, f"{inp}:{case.line}:")
            assert os.listdir(out.parent) == [], os.listdir(out.parent)
        except AssertionError as e:
            failures.append(f"{case.name}: {str(e).splitlines()[0]}")
    assert not failures, f"{name}: " + "; ".join(failures)


#: Valid corpus files that load to the base motion exactly ("same") are equivalent for a verb;
#: one stands for them all (UTF-16), with the files whose skeleton or motion differs (names with
#: spaces or non-ASCII letters are covered by the XML-special ones).
VALID_FOR_VERBS = [c for c in VALID_CASES if c.name in ("utf16", "zero_length_end_site", "xml_special_names", "zero_channel_joint", "single_frame")]


@pytest.mark.parametrize("name", _verb_params("valid-corpus"))
def test_valid_corpus_file_never_gives_a_traceback(name, tmp_path, capsys):
    """Unusual but valid files: the verb works or refuses cleanly (exit 0 or 2), never a bug."""
    spec = verb(name, reads=True)
    if spec.folder:
        pytest.skip(f"{name} reads folders: a corpus file is a row of its table")
    failures = []
    for case in VALID_FOR_VERBS:
        inp = tmp_path / f"{case.name}.bvh"
        inp.write_bytes(case.data)
        out = tmp_path / f"out_{case.name}{spec.ext}"
        rc, _, err = run([name, *spec.argv(str(as_input(spec, inp)), str(out))], capsys)
        try:
            works_or_refuses(spec, rc, err, out)
        except AssertionError as e:
            failures.append(f"{case.name}: {str(e).splitlines()[0]}")
    assert not failures, f"{name}: " + "; ".join(failures)


@pytest.mark.parametrize("name", VERB_NAMES)
def test_existing_output_needs_force(name, tmp_path, clip, human, capsys):
    spec = verb(name)
    if not writes(spec):
        pytest.skip(f"{name} writes no file")
    out = tmp_path / f"out{spec.ext}"
    out.write_bytes(b"precious")
    refused(*run([name, *spec.argv(str(_input(spec, clip, human)), str(out))], capsys)[::2], str(out), "--force")
    assert out.read_bytes() == b"precious"
    assert sorted(os.listdir(tmp_path)) == [out.name]


@pytest.mark.parametrize("name", _verb_params("input-is-output"))
def test_input_is_never_the_output(name, tmp_path, clip, capsys):
    spec = verb(name, reads=True)
    if not writes(spec):
        pytest.skip(f"{name} writes no file")
    clip_copy = tmp_path / "clip.bvh"
    data = clip.read_bytes()
    clip_copy.write_bytes(data)
    inp = as_input(spec, clip_copy)
    data = inp.read_bytes()
    for target in (inp, inp.parent / "." / inp.name):
        refused(*run([name, *spec.argv(str(inp), str(target)), "--force"], capsys)[::2], "input")
    link = tmp_path / f"link{spec.ext}"
    link.symlink_to(inp)
    refused(*run([name, *spec.argv(str(inp), str(link)), "--force"], capsys)[::2], "input")
    assert inp.read_bytes() == data
    if spec.script:  # a clip the script reads is an input too, for the report as for -o
        refused(*run([name, *spec.argv(str(inp), str(clip_copy)), "--force"], capsys)[::2], "input")
        assert clip_copy.read_bytes() == clip.read_bytes()
        main_out = tmp_path / f"out{spec.ext}"
        refused(*run([name, *spec.argv(str(inp), str(main_out)), "--json", str(clip_copy), "--force"], capsys)[::2], "input")
        assert clip_copy.read_bytes() == clip.read_bytes() and not main_out.exists()


def test_blend_refuses_incompatible_skeletons(tmp_path, clip, human, capsys):
    if "blend" not in SUBPARSERS:
        pytest.skip("no blend verb yet")
    human = _human(human)
    out = tmp_path / "blend.bvh"
    refused(*run(["blend", str(clip), str(human), "--weights", "0.5,0.5", "-o", str(out)], capsys)[::2], "topolog")
    assert not out.exists()


@pytest.mark.parametrize("name", _verb_params("extra-outputs"))
def test_extra_outputs_follow_the_contract(name, tmp_path, clip, human, capsys):
    """Reports and plots (--json, --plot, --truth): an existing one needs --force, an input never is one."""
    spec = verb(name)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    extra = spec.extra_outputs(out_dir)
    if not writes(spec) or not extra:
        pytest.skip(f"{name} has no extra outputs")
    inp = _input(spec, clip, human)
    data = inp.read_bytes()
    main_out = str(out_dir / f"out{spec.ext}")
    for k in range(1, len(extra), 2):
        existing = Path(extra[k])
        existing.write_bytes(b"precious")
        refused(*run([name, *spec.argv(str(inp), main_out), *extra], capsys)[::2], "--force")
        assert existing.read_bytes() == b"precious" and not Path(main_out).exists()
        existing.unlink()
        if spec.inputless:
            continue
        as_input_args = list(extra)
        as_input_args[k] = str(inp)
        refused(*run([name, *spec.argv(str(inp), main_out), *as_input_args, "--force"], capsys)[::2], "input")
        assert inp.read_bytes() == data and not Path(main_out).exists()


def _writer(name: str, tmp_path: Path, clip: Path, human: Path | None) -> tuple[Verb, str, Path]:
    """A verb that writes a file (else the test is skipped), its input, and an empty output folder."""
    spec = verb(name)
    if not writes(spec):
        pytest.skip(f"{name} writes no file")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    return spec, str(_input(spec, clip, human)), out_dir


@pytest.mark.parametrize("name", VERB_NAMES)
def test_every_output_must_end_in_the_suffix_of_what_is_written(name, tmp_path, clip, human, capsys):
    """`compile -o model.bvh` wrote XML into a .bvh file and `fk -o pos.bvh` an .npz archive:
    the next command that reads them fails far from the cause. Refused before any work, for the
    main output and for every report and plot."""
    spec, inp, out_dir = _writer(name, tmp_path, clip, human)
    wrong = ".npz" if spec.ext != ".npz" else ".bvh"
    argv = spec.argv(inp, str(out_dir / f"out{wrong}"))
    err = refused(*run([name, *argv], capsys)[::2], f"out{wrong}", "expected a")
    before = argv[argv.index(str(out_dir / f"out{wrong}")) - 1]  # the option that names it, if any
    named_as = f"{before} " if before.startswith("-") else ""
    assert err.startswith(f"error: {named_as}{out_dir / f'out{wrong}'}:"), err  # (convert's output is positional: no "-o")
    extra = spec.extra_outputs(out_dir)
    for k in range(1, len(extra), 2):
        bad = list(extra)
        bad[k] = str(Path(extra[k]).with_suffix(".bvh"))
        refused(*run([name, *spec.argv(inp, str(out_dir / f"out{spec.ext}")), *bad], capsys)[::2], extra[k - 1], "expected a")
    assert os.listdir(out_dir) == []


@pytest.mark.parametrize("name", VERB_NAMES)
def test_output_folder_must_exist(name, tmp_path, clip, capsys):
    spec = verb(name)
    if not writes(spec):
        pytest.skip(f"{name} writes no file")
    out = tmp_path / "no" / "such" / f"out{spec.ext}"
    refused(*run([name, *spec.argv(str(clip), str(out))], capsys)[::2], "does not exist")
    directory = tmp_path / f"dir{spec.ext}"
    directory.mkdir()
    refused(*run([name, *spec.argv(str(clip), str(directory)), "--force"], capsys)[::2], "directory")


def _bad_params():
    out = []
    for name in VERB_NAMES:
        for extra in VERBS[name].bad if name in VERBS else ():
            pid = f"{name} {' '.join(extra)}"
            out.append(pytest.param(name, extra, id=pid, marks=_known(pid)))
    return out


@pytest.mark.parametrize(("name", "extra"), _bad_params())
def test_verb_specific_bad_arguments(name, extra, tmp_path, clip, human, capsys):
    spec = verb(name)
    out = tmp_path / f"out{spec.ext}"
    refused(*run([name, *spec.argv(str(_input(spec, clip, human)), str(out)), *extra], capsys)[::2])
    assert not out.exists(), f"{name} {' '.join(extra)} left {out.name}"


@pytest.mark.parametrize("name", VERB_NAMES)
def test_verbose_shows_the_traceback(name, tmp_path, capsys):
    spec = verb(name)
    missing = str(tmp_path / "missing.bvh")
    argv = spec.argv(missing, str(tmp_path / f"out{spec.ext}"))
    if spec.inputless:  # no input to miss: an output folder that does not exist, or a bad option
        argv = (
            [*spec.argv(missing, str(tmp_path / "out")), *spec.verbose_bad] if spec.verbose_bad else spec.argv(missing, missing + f"/out{spec.ext}")
        )
    for full in ([name, "--verbose", *argv], ["--verbose", name, *argv]):
        rc, _, err = run(full, capsys)
        assert rc == 2 and "Traceback" in err
        named = spec.verbose_bad[-1] if spec.inputless and spec.verbose_bad else missing
        assert err.rstrip().splitlines()[-1].startswith("error:") and named in err


@pytest.mark.parametrize("name", _verb_params("atomic"))
def test_outputs_are_written_atomically(name, tmp_path, clip, human, capsys, monkeypatch):
    """Flushing the written file fails (a full disk): the verb refuses, and nothing is left behind."""
    spec = verb(name)
    if not writes(spec):
        pytest.skip(f"{name} writes no file")
    inp = _input(spec, clip, human)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    argv = [name, *spec.argv(str(inp), str(out_dir / f"out{spec.ext}")), *spec.extra_outputs(out_dir)]
    # First the verb works, and leaves only its outputs (no temporaries).
    rc, _, err = run(argv, capsys)
    assert rc == 0, err
    made = sorted(os.listdir(out_dir))
    assert all(not n.startswith(".") for n in made), made
    for n in made:
        (out_dir / n).unlink()

    def full_disk(fd):  # where a full disk shows with delayed allocation: flushing the written file
        raise OSError(28, "No space left on device (simulated)")

    monkeypatch.setattr(os, "fsync", full_disk)
    rc, _, err = run(argv, capsys)
    monkeypatch.undo()
    refused(rc, err, "No space left on device")
    assert os.listdir(out_dir) == [], f"{name} wrote {os.listdir(out_dir)} without a temporary file and rename"


# --- through a real process --------------------------------------------------------------------
def _mjmotion(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "mjmotion.cli", *args], cwd=cwd, capture_output=True, text=True, timeout=120, env=env)


def test_subprocess_missing_file_and_bad_file(tmp_path):
    p = _mjmotion("info", "missing.bvh", cwd=tmp_path)
    refused(p.returncode, p.stderr, "missing.bvh")
    bad = tmp_path / "bad.bvh"
    bad.write_bytes(next(c for c in ERROR_CASES if c.name == "values_too_few").data)
    p = _mjmotion("convert", "bad.bvh", "out.bvh", cwd=tmp_path)
    case = next(c for c in ERROR_CASES if c.name == "values_too_few")
    refused(p.returncode, p.stderr, f"bad.bvh:{case.line}:", "17 values")
    assert not (tmp_path / "out.bvh").exists()


def test_subprocess_verbose(tmp_path):
    p = _mjmotion("--verbose", "compile", "missing.bvh", "-o", "m.xml", cwd=tmp_path)
    assert p.returncode == 2 and "Traceback" in p.stderr and p.stderr.rstrip().splitlines()[-1].startswith("error:")
    assert not (tmp_path / "m.xml").exists()


STREAM_SCRIPTS = {
    "truncated-json": b'{"duration": 1,\n "clips": {',
    "not-an-object": b"[]",
    "negative-duration": b'{"duration": -1, "clips": {"a": {"file": "CLIP"}}, "locomotion": ["a"], "commands": [{"time": 0, "weights": {"a": 1}}]}',
    "huge-duration": b'{"duration": 1e9, "clips": {"a": {"file": "CLIP"}}, "locomotion": ["a"], "commands": [{"time": 0, "weights": {"a": 1}}]}',
    "unknown-clip": b'{"duration": 0.2, "clips": {"a": {"file": "CLIP"}}, "locomotion": ["b"], "commands": [{"time": 0, "weights": {"a": 1}}]}',
    "missing-clip-file": b'{"duration": 0.2, "clips": {"a": {"file": "nosuch.bvh"}}, "locomotion": ["a"], "commands": [{"time": 0, "weights": {"a": 1}}]}',
    "binary": bytes(range(256)) * 4,
}


@pytest.mark.parametrize(
    "kind", [pytest.param(k, marks=_known(f"stream script {k}")) for k in STREAM_SCRIPTS]
)  # fmt: skip
def test_stream_refuses_bad_scripts(kind, tmp_path, human, capsys):
    if "stream" not in SUBPARSERS:
        pytest.skip("no stream verb yet")
    script = tmp_path / "script.json"
    script.write_bytes(STREAM_SCRIPTS[kind].replace(b"CLIP", str(_human(human)).encode()))
    out = tmp_path / "out.bvh"
    refused(*run(["stream", str(script), "-o", str(out)], capsys)[::2])
    assert not out.exists()


def test_hit_unreachable_target_is_reported_not_crashed(tmp_path, human, capsys):
    """hit solves an unreachable target best-effort: the clip and report are written with
    ``reachable: false``, one ``error:`` line says so, and the exit status is 2."""
    if "hit" not in SUBPARSERS:
        pytest.skip("no hit verb yet")
    out, report = tmp_path / "hit.bvh", tmp_path / "hit.json"
    argv = ["hit", str(_human(human)), "--effector", "right_foot", "--target", "100", "0", "1", "-o", str(out), "--json", str(report)]
    rc, _, err = run(argv, capsys)
    refused(rc, err, "reach")
    assert json.loads(report.read_text())["reachable"] is False
    assert out.exists()


def test_deep_hierarchy_through_the_cli(tmp_path, capsys):
    deep = tmp_path / "deep.bvh"
    deep.write_bytes(_corpus().deep_hierarchy(10_000))
    rc, out, err = run(["info", str(deep)], capsys)
    assert rc == 0 and "10000" in out, err
    refused(*run(["compile", str(deep), "-o", str(tmp_path / "deep.xml")], capsys)[::2], f"{deep}: skeleton is 10000 joints deep")
    assert not (tmp_path / "deep.xml").exists()


def test_a_render_names_the_clip_no_model_takes(tmp_path, human, capsys):
    """`render walk.bvh deep.bvh` said "skeleton is 500 joints deep" without saying which clip (every clip
    is compiled at once, after all are read); each clip is checked as it is read, naming its file."""
    deep = tmp_path / "deep.bvh"
    deep.write_bytes(_corpus().deep_hierarchy(500))
    walk = str(_human(human))
    refused(*run(["render", walk, str(deep), "-o", str(tmp_path / "r.gif")], capsys)[::2], f"{deep}: skeleton is 500 joints deep")
    for verb in (["fk", str(deep), "-o", str(tmp_path / "p.npz")], ["vary", str(deep), "--scale", "1.2", "-o", str(tmp_path / "v.bvh")]):
        refused(*run(verb, capsys)[::2], f"{deep}: skeleton is 500 joints deep")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deep.bvh"]


# --- issue 17: hostile options, files and faults, for every verb ---------------------------------
import signal  # noqa: E402
import stat  # noqa: E402
import tracemalloc  # noqa: E402

from conftest import within  # noqa: E402

from mjmotion import outputs  # noqa: E402
from mjmotion.caps import MAX_JOINTS, MAX_MODEL_JOINTS  # noqa: E402

HOSTILE_VALUES = ("nan", "inf", "-inf", "1e308", "-1e308", "abc")


def _numeric_actions(name: str) -> list[argparse.Action]:
    return [a for a in SUBPARSERS[name]._actions if a.type is not None and a.option_strings and not isinstance(a.type, argparse.FileType)]


@pytest.mark.parametrize("name", VERB_NAMES)
def test_every_numeric_option_has_a_domain(name):
    """No plain float/int reaches a verb: each numeric option goes through mjmotion.commands._options."""
    plain = [a.option_strings[0] for a in _numeric_actions(name) if a.type in (float, int) and not a.choices]  # choices are a domain
    assert not plain, f"{name}: {plain} use type=float/int; use a domain from mjmotion/commands/_options.py"


@pytest.mark.parametrize("name", VERB_NAMES)
def test_hostile_option_values_are_refused_before_any_file_is_read(name, tmp_path, capsys):
    """NaN, infinities, 1e308 and words, for every numeric option: one error line naming the option
    and the value; the input does not exist, so an error about it would mean work started first."""
    spec = verb(name)
    missing = str(tmp_path / "missing.bvh")
    failures = []
    for action in _numeric_actions(name):
        if getattr(action.type, "__name__", "") not in ("number", "integer") or not getattr(action.type, "option_domain", False):
            continue
        option = max(action.option_strings, key=len)
        n = action.nargs if isinstance(action.nargs, int) else 1
        for value in HOSTILE_VALUES:
            # OPTION=VALUE: argparse reads a lone "-inf" as an option, not a value. With several
            # values it cannot tell either: then the refusal is argparse's ("expected 3 arguments").
            argv = [
                name,
                *spec.argv(missing, str(tmp_path / f"out{spec.ext}")),
                *([f"{option}={value}"] if n == 1 else [option, value, *["0"] * (n - 1)]),
            ]
            rc, _, err = run(argv, capsys)
            try:
                refused(rc, err, f"error: {option} {value}: expected" if n == 1 or not value.startswith("-") else option)
            except AssertionError as e:
                failures.append(f"{option} {value}: {str(e).splitlines()[0]}")
    assert not failures, "; ".join(failures)
    assert sorted(os.listdir(tmp_path)) == []


def _not_regular_inputs(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    cases = {}
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "fifo.bvh")
        cases["fifo"] = (tmp_path / "fifo.bvh", "is a named pipe (FIFO)")
    if os.path.exists("/dev/zero"):
        cases["dev-zero"] = (Path("/dev/zero"), "is a character device")
    (tmp_path / "loop_a.bvh").symlink_to(tmp_path / "loop_b.bvh")
    (tmp_path / "loop_b.bvh").symlink_to(tmp_path / "loop_a.bvh")
    cases["symlink-loop"] = (tmp_path / "loop_a.bvh", "too many levels of symbolic links")
    with open(tmp_path / "sparse.bvh", "wb") as fh:
        fh.truncate(2 << 30)
    cases["sparse-2GB"] = (tmp_path / "sparse.bvh", "larger than the limit of")  # 256 MiB (mjmotion.caps); the studio's uploads 32 MiB
    return cases


@pytest.mark.parametrize("name", VERB_NAMES)
def test_inputs_that_are_not_regular_files_are_refused_unread(name, tmp_path, capsys):
    """A FIFO with no writer, /dev/zero, a symlink loop, a 2 GB sparse file: refused in seconds,
    with little memory (nothing read), naming the file; nothing written."""
    spec = verb(name, reads=True)
    if spec.folder:
        pytest.skip(f"{name} reads folders: such a file is an error row of its table (tests/test_audit.py)")
    inputs_dir = tmp_path / "in"
    inputs_dir.mkdir()
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    failures = []
    for kind, (path, phrase) in _not_regular_inputs(inputs_dir).items():
        tracemalloc.start()
        try:
            with within(20, f"{name} on {kind}"):
                rc, _, err = run([name, *spec.argv(str(as_input(spec, path) if spec.script else path), str(out_dir / f"out{spec.ext}"))], capsys)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        try:
            refused(rc, err, str(path), phrase)
            assert peak < 256 << 20, f"peak {peak >> 20} MB"
            assert os.listdir(out_dir) == [], os.listdir(out_dir)
        except AssertionError as e:
            failures.append(f"{kind}: {str(e).splitlines()[0]}")
        for p in inputs_dir.glob("*_script.json"):
            p.unlink()
    assert not failures, f"{name}: " + "; ".join(failures)


def test_not_regular_files_under_a_real_memory_limit(tmp_path):
    """The same through a process whose address space is capped at 1 GiB: reading the sparse
    2 GB file or /dev/zero would fail with MemoryError, not a clean refusal."""
    import resource

    sparse = tmp_path / "sparse.bvh"
    with open(sparse, "wb") as fh:
        fh.truncate(2 << 30)
    script = tmp_path / "zero_script.json"
    script.write_text(
        json.dumps({"duration": 1, "clips": {"a": {"file": "/dev/zero"}}, "locomotion": ["a"], "commands": [{"time": 0, "weights": {"a": 1}}]})
    )

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))

    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for argv, phrase in (
        (["info", str(sparse)], "larger than the limit"),
        (["convert", "/dev/zero", str(tmp_path / "o.bvh")], "is a character device"),
        (["stream", "/dev/zero", "-o", str(tmp_path / "o.bvh")], "is a character device"),
        (["stream", str(script), "-o", str(tmp_path / "o.bvh")], "/dev/zero: is a character device"),
    ):
        p = subprocess.run([sys.executable, "-m", "mjmotion.cli", *argv], capture_output=True, text=True, timeout=60, env=env, preexec_fn=cap)
        refused(p.returncode, p.stderr, phrase)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["sparse.bvh", "zero_script.json"]


@pytest.mark.parametrize("name", VERB_NAMES)
def test_extreme_skeletons_are_refused_or_handled_in_seconds(name, tmp_path, capsys):
    """10,001 joints wide and 100,000 deep: a BvhError naming the line (the reader's cap); 1,001
    joints wide: loads, and every verb that builds a MuJoCo model refuses it at once."""
    spec = verb(name, reads=True)
    if spec.folder:
        pytest.skip(f"{name} reads folders: such a file is an error row of its table (tests/test_audit.py)")
    cases = {
        "wide": (_corpus().wide_hierarchy(MAX_JOINTS + 1), f"more than {MAX_JOINTS} joints"),
        "deep": (_corpus().deep_hierarchy(100_000), f"more than {MAX_JOINTS} joints"),
        "model-wide": (_corpus().wide_hierarchy(MAX_MODEL_JOINTS + 1), None),
    }
    failures = []
    for kind, (data, phrase) in cases.items():
        inp = tmp_path / f"{kind}.bvh"
        inp.write_bytes(data)
        out = tmp_path / f"out_{kind}{spec.ext}"
        with within(60, f"{name} on {kind}"):
            rc, _, err = run([name, *spec.argv(str(as_input(spec, inp)), str(out))], capsys)
        try:
            if phrase is not None:
                refused(rc, err, f"{inp}:", phrase)
                assert not out.exists()
            elif rc != 0:
                refused(rc, err)
        except AssertionError as e:
            failures.append(f"{kind}: {str(e).splitlines()[0]}")
    assert not failures, f"{name}: " + "; ".join(failures)


@pytest.mark.parametrize("name", VERB_NAMES)
def test_one_two_and_three_frame_clips(name, tmp_path, human, capsys):
    """The shortest clips of a real skeleton (vary on 2 frames used to crash): work or one error line."""
    spec = verb(name, reads=True)
    src = _human(human)
    failures = []
    for n in (1, 2, 3):
        short = tmp_path / f"short{n}.bvh"
        assert cli.main(["convert", str(src), str(short), "--frames", f"0:{n}"]) == 0
        out = tmp_path / f"out{n}{spec.ext}"
        with within(60, f"{name} on {n} frames"):
            rc, _, err = run([name, *spec.argv(str(as_input(spec, short)), str(out))], capsys)
        try:
            works_or_refuses(spec, rc, err, out)
        except AssertionError as e:
            failures.append(f"{n} frames: {str(e).splitlines()[0]}")
    assert not failures, f"{name}: " + "; ".join(failures)


@pytest.mark.parametrize("name", VERB_NAMES)
def test_hostile_output_paths(name, tmp_path, clip, human, capsys):
    """A dangling symlink exists; 'out.bvh/' names a folder; a FIFO or /dev/null is never replaced, --force or not."""
    spec, inp, out_dir = _writer(name, tmp_path, clip, human)
    dangling = out_dir / f"out{spec.ext}"
    dangling.symlink_to(out_dir / "nowhere")
    refused(*run([name, *spec.argv(inp, str(dangling))], capsys)[::2], "already exists (a symbolic link)", "--force")
    assert dangling.is_symlink() and not (out_dir / "nowhere").exists()
    dangling.unlink()
    slash = f"{out_dir}/out{spec.ext}/"
    refused(*run([name, *spec.argv(inp, slash)], capsys)[::2], "names a folder")
    targets = ["/dev/null"]
    if hasattr(os, "mkfifo"):
        os.mkfifo(out_dir / f"fifo{spec.ext}")
        targets.append(str(out_dir / f"fifo{spec.ext}"))
    for target in targets:
        for force in ([], ["--force"]):
            refused(*run([name, *spec.argv(inp, target), *force], capsys)[::2], target, "--force replaces only a regular file")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert sorted(os.listdir(out_dir)) == ([f"fifo{spec.ext}"] if hasattr(os, "mkfifo") else [])


@pytest.mark.parametrize("name", VERB_NAMES)
def test_a_file_appearing_at_the_output_during_the_run_is_kept(name, tmp_path, clip, human, capsys, monkeypatch):
    """Checked free before the work, taken by someone else before the result is published: the
    verb exits 2 and the other file is untouched (it used to be silently replaced)."""
    spec = verb(name)
    if not writes(spec):
        pytest.skip(f"{name} writes no file")
    inp = str(_input(spec, clip, human))
    out = tmp_path / "out" / f"out{spec.ext}"
    out.parent.mkdir()
    real = outputs._fsync

    def someone_else_writes(path):
        real(path)
        if not out.exists():
            out.write_bytes(b"theirs")

    monkeypatch.setattr(outputs, "_fsync", someone_else_writes)
    refused(*run([name, *spec.argv(inp, str(out))], capsys)[::2], "appeared while this command ran")
    assert out.read_bytes() == b"theirs"
    assert all(not n.startswith(".") for n in os.listdir(out.parent)), os.listdir(out.parent)


def _with_file_size_limit(limit: int):
    import resource

    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes past the limit fail (EFBIG), as on a full disk
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


@pytest.mark.parametrize(
    ("argv", "limit"),
    [
        (["render", "CLIP", "-o", "OUT/v.mp4", "--width", "320", "--height", "240", "--fast"], 6000),
        (["render", "CLIP", "-o", "OUT/v.gif", "--width", "64", "--height", "48", "--fast"], 2000),
        (["convert", "CLIP", "OUT/c.bvh"], 2000),
        (["synth", "library", "OUT/lib"], 100_000),
    ],
    ids=["render-mp4", "render-gif", "convert", "synth-library"],
)
def test_a_full_disk_is_an_error_and_leaves_nothing(argv, limit, tmp_path, human):
    """Writes fail part-way (a file-size limit stands in for a full disk, for ffmpeg too): one
    error line, exit 2, no output, no temporary file, no half-written folder."""
    out = tmp_path / "out"
    out.mkdir()
    argv = [str(_human(human)) if a == "CLIP" else a.replace("OUT", str(out)) for a in argv]
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run(
        [sys.executable, "-m", "mjmotion.cli", *argv], capture_output=True, text=True, timeout=300, env=env, preexec_fn=_with_file_size_limit(limit)
    )
    line = refused(p.returncode, p.stderr)
    assert "wrote" not in p.stdout, p.stdout
    assert "File too large" in line or "incomplete" in line or "encoder" in line, line
    assert os.listdir(out) == [], os.listdir(out)


def test_stream_scripts_of_the_wrong_shape(tmp_path, human, capsys):
    """tests/data/bad's script cases: one error line naming the script and the key path."""
    clip = str(_human(human))
    failures = []
    for case in _corpus().script_cases():
        script = tmp_path / f"{case.name}.json"
        script.write_bytes(case.data.replace(b"CLIP", json.dumps(clip)[1:-1].encode()))
        out = tmp_path / "out.bvh"
        with within(30, f"stream {case.name}"):
            rc, _, err = run(["stream", str(script), "-o", str(out)], capsys)
        try:
            refused(rc, err, str(script), case.match)
            assert "\x1b" not in err
            assert not out.exists()
        except AssertionError as e:
            failures.append(f"{case.name}: {str(e).splitlines()[0]}")
    assert not failures, "; ".join(failures)


def test_score_files_of_the_wrong_kind(tmp_path, human, capsys):
    """tests/data/bad's score cases through vary --scores, and scores that are not regular files."""
    src = str(_human(human))
    cases = [(tmp_path / c.name, c.match, c.data) for c in _corpus().score_cases()]
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "fifo.npy")
        cases.append((tmp_path / "fifo.npy", "is a named pipe", None))
    (tmp_path / "zero.npy").symlink_to("/dev/zero")
    cases.append((tmp_path / "zero.npy", "is a character device", None))
    failures = []
    for path, match, data in cases:
        if data is not None:
            path.write_bytes(data)
        out = tmp_path / "out.bvh"
        with within(30, f"vary --scores {path.name}"):
            rc, _, err = run(["vary", src, "--scores", str(path), "-o", str(out)], capsys)
        try:
            refused(rc, err, str(path), match)
            assert not out.exists()
        except AssertionError as e:
            failures.append(f"{path.name}: {str(e).splitlines()[0]}")
    assert not failures, "; ".join(failures)


def test_render_refuses_before_the_progress_bar(tmp_path, human, capsys):
    """An odd MP4 size, too many characters, a label with a line break: refused before any work."""
    src = str(_human(human))
    for extra, phrase in (
        (["--width", "641", "--height", "360"], "even width and height"),
        (["--labels", "a\nb"], "expected printable text"),
        (["--prop", "club", "--prop", "club:rwrist"], "given twice"),
    ):
        rc, out, err = run(["render", src, "-o", str(tmp_path / "v.mp4"), *extra], capsys)
        refused(rc, err, phrase)
        assert "frame/s" not in err and "%|" not in err, err  # no progress bar: nothing was rendered
    rc, _, err = run(["render", *[src] * 17, "-o", str(tmp_path / "v.mp4")], capsys)
    refused(rc, err, "17 characters, more than the limit of 16")
    assert "frame/s" not in err and os.listdir(tmp_path) == []
    # --skin both draws each clip twice: 9 clips are 18 characters, refused before any clip is read
    # (the scene refused them after reading every clip, naming --skin)
    rc, _, err = run(["render", *[src] * 9, "--skin", "both", "-o", str(tmp_path / "v.mp4")], capsys)
    refused(rc, err, "--skin both of 9 clips (2 characters each): 18 characters, more than the limit of 16")
    assert os.listdir(tmp_path) == []


def test_demo_keeps_an_existing_results_folder(tmp_path, capsys):
    folder = tmp_path / "results"
    folder.mkdir()
    (folder / "summary.md").write_text("precious")
    for flag in ("-o", "--output", "--out"):
        refused(*run(["demo", flag, str(folder), "--only", "path_search", "--no-video"], capsys)[::2], "--force")
    assert (folder / "summary.md").read_text() == "precious"
    # a file where the folder would go, or on its way, is refused and kept
    for out in (folder / "summary.md", folder / "summary.md" / "deeper"):
        refused(*run(["demo", "-o", str(out), "--only", "path_search", "--no-video"], capsys)[::2], "summary.md exists and is not a folder")
    assert (folder / "summary.md").read_text() == "precious"


def test_info_prints_no_terminal_escapes(tmp_path, clip, capsys):
    """A path holding an escape sequence is printed escaped (joint names with one are refused by the reader)."""
    folder = tmp_path / "a\x1b[2Jb"
    folder.mkdir()
    inp = folder / "clip.bvh"
    inp.write_bytes(clip.read_bytes())
    rc, out, err = run(["info", str(inp)], capsys)
    assert rc == 0 and "\x1b" not in out and "a\\x1b[2Jb" in out, err


def test_file_names_with_escapes_are_printed_and_drawn_escaped(tmp_path, human, capsys):
    """evaluate DIR prints clip names it found, render draws file names as labels: neither raw."""
    folder = tmp_path / "clips"
    folder.mkdir()
    odd = folder / "a\x1b[2J\nb.bvh"
    odd.write_bytes(_human(human).read_bytes())
    rc, out, err = run(["evaluate", str(folder), "--jobs", "1"], capsys)
    assert rc == 0 and "\x1b" not in out + err and "a\\x1b[2J\\nb" in out, err
    rc, out, err = run(["render", str(odd), "-o", str(tmp_path / "v.gif"), "--width", "64", "--height", "48", "--fast"], capsys)
    assert rc == 0 and (tmp_path / "v.gif").exists(), err
