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

from mjmotion import cli

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
    "blend": Verb(
        lambda i, o: [i, i, "--weights", "0.5,0.5", "-o", o],
        ".bvh",
        bad=(("--weights", "0.5"), ("--weights", "0.7,0.7"), ("--weights=-1,2",), ("--weights", "a,b"), ("--frames", "500:600"), ("--fps", "0")),
        humanoid=True,
    ),  # fmt: skip
    "register": Verb(
        lambda i, o: [i, i, "--json", o],
        ".json",
        bad=(("--window", "4"), ("--window", "0"), ("--frames", "500:600"), ("--slope-limit", "-1"), ("--fps", "-1")),
        humanoid=True,
        extra_outputs=lambda d: ["--plot", str(d / "grid.png")],
    ),
    "stream": Verb(lambda i, o: [i, "-o", o], ".bvh", humanoid=True, script=True),
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
    return spec.runs and "OUT" in spec.argv("IN", "OUT")


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


def test_error_is_one_line_even_for_names_with_line_breaks(tmp_path, capsys):
    odd = tmp_path / "two\nlines\r.bvh"
    line = refused(*run(["convert", str(odd), str(tmp_path / "out.bvh")], capsys)[::2], "no such file")
    assert "two\\nlines\\r.bvh" in line
    refused(*run(["info", str(odd), "--up", "x\ny"], capsys)[::2], "invalid choice")


def test_no_verb_and_unknown_verb(capsys):
    assert run([], capsys)[0] == 2
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
    failures = []
    for case in VALID_FOR_VERBS:
        inp = tmp_path / f"{case.name}.bvh"
        inp.write_bytes(case.data)
        out = tmp_path / f"out_{case.name}{spec.ext}"
        rc, _, err = run([name, *spec.argv(str(as_input(spec, inp)), str(out))], capsys)
        try:
            if rc == 0:
                assert "Traceback" not in err and not any(ln.startswith("error:") for ln in err.splitlines()), err
                assert not writes(spec) or out.exists()
            else:
                refused(rc, err)
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
    if spec.script:  # a clip the script reads is an input too
        refused(*run([name, *spec.argv(str(inp), str(clip_copy)), "--force"], capsys)[::2], "input")
        assert clip_copy.read_bytes() == clip.read_bytes()


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
    refused(*run(["compile", str(deep), "-o", str(tmp_path / "deep.xml")], capsys)[::2], "joints deep")
    assert not (tmp_path / "deep.xml").exists()
