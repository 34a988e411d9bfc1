"""Option domains (issue 17): every value is either inside its domain or refused with a message
that quotes it; nothing else ever comes out (properties over random text and numbers)."""

from __future__ import annotations

import argparse
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mjmotion.caps import MAX_FRAMES
from mjmotion.commands import _options as O
from mjmotion.errors import MjmotionError

PROPS = settings(max_examples=300, derandomize=True, database=None, deadline=None)

#: Text a user can type for a number: decimal spellings, specials, junk, huge digit strings.
NUMBER_TEXT = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**40), 10**40).map(str),
    st.sampled_from(["nan", "-nan", "inf", "-inf", "Infinity", "1e308", "-1e308", "5e-324", "1e999", "0x10", "1_000", "", " ", "١٢", "9" * 5000]),
    st.text(max_size=20),
)


def _parse_or_refuse(fn, text):
    try:
        return fn(text), None
    except argparse.ArgumentTypeError as e:
        return None, str(e)


@PROPS
@given(text=NUMBER_TEXT, lo=st.floats(-1e6, 1e6), span=st.floats(0, 1e6), lo_open=st.booleans(), hi_open=st.booleans())
def test_number_is_in_its_domain_or_refused_quoting_the_value(text, lo, span, lo_open, hi_open):
    hi = lo + span
    value, error = _parse_or_refuse(O.number(lo, hi, lo_open=lo_open, hi_open=hi_open, what="a thing"), text)
    if error is None:
        assert math.isfinite(value)
        assert (value > lo if lo_open else value >= lo) and (value < hi if hi_open else value <= hi)
        assert value == float(text)
    else:
        assert "expected a thing" in error and len(error) < 200 and error.isprintable()
        shown = text if len(text) <= 40 else text[:40]
        assert shown[:10] in error or repr(shown)[1:10] in error


@PROPS
@given(text=NUMBER_TEXT, lo=st.integers(-1000, 1000), span=st.integers(0, 10**6))
def test_integer_is_in_its_domain_or_refused(text, lo, span):
    value, error = _parse_or_refuse(O.integer(lo, lo + span, what="a count"), text)
    if error is None:
        assert isinstance(value, int) and lo <= value <= lo + span and value == int(text)
    else:
        assert "expected a count" in error and len(error) < 200


@PROPS
@given(text=st.text(max_size=100))
def test_label_is_printable_one_line_text(text):
    value, error = _parse_or_refuse(O.label(80), text)
    if error is None:
        assert value == text and text.isprintable() and len(text) <= 80
    else:
        assert error.isprintable()  # the control character is shown escaped, never raw


@pytest.mark.parametrize("text", ["nan", "inf", "-inf", "1e308", "-1e308", "5e-324", "0"])
def test_frame_rates_refuse_what_would_overflow(text):
    with pytest.raises(argparse.ArgumentTypeError, match="frame rate"):
        O.FPS(text)


def test_resample_checks_the_frames_before_allocating():
    import numpy as np
    from conftest import random_motion, random_skeleton

    rng = np.random.default_rng(0)
    m = random_motion(rng, random_skeleton(rng, 5), 121).replace(fps=120.0)  # 1 s
    assert O.resample(m, 60.0).n_frames == 61
    long = m.replace(fps=0.1)  # 1200 s
    assert 1200 * 10_000 + 1 > MAX_FRAMES
    with pytest.raises(MjmotionError, match=r"--fps 10000: a 1200 s clip at 10000 fps: 12,000,001 frames, more than the limit"):
        O.resample(long, 10_000.0)


def test_props_are_each_given_once():
    p = argparse.ArgumentParser(exit_on_error=False)
    p.add_argument("--prop", action=O.UniqueProps)
    assert p.parse_args(["--prop", "club", "--prop", "bat:rwrist"]).prop == ["club", "bat:rwrist"]
    for argv in (["--prop", "club:hip", "--prop", "club:hip"], ["--prop", "bat", "--prop", "bat:lwrist"], ["--prop", ":hip"], ["--prop", "bat:"]):
        with pytest.raises((argparse.ArgumentError, SystemExit)):
            p.parse_args(argv)


def test_frames_and_actors_are_checked_against_the_clip():
    assert O.check_frame(-1, 10, "--rest-frame", allow_negative=True) == 9
    with pytest.raises(MjmotionError, match=r"--frame 10: outside the clip's frames 0..9"):
        O.check_frame(10, 10, "--frame")
    with pytest.raises(MjmotionError, match="17 characters, more than the limit of 16"):
        O.check_actors(17)


def test_an_unknown_prop_kind_is_refused_before_the_clip_is_read(capsys):
    """`compile CLIP --prop sword` read the clip first, so a `note:` line (its skipped T-pose) came
    before the `error:` line; the kinds are named where the options are parsed, as mjcf has them."""
    from conftest import require_data

    from mjmotion import mjcf
    from mjmotion.cli import main
    from mjmotion.commands._options import PROP_KINDS

    assert set(PROP_KINDS) == set(mjcf.PROP_PRESETS)
    daz = require_data() / "cmu_cgspeed_daz" / "07_01.bvh"  # its frames 0-3 are skipped with a note
    for verb in (["compile", str(daz), "-o", "/nonexistent/m.xml"], ["evaluate", str(daz)], ["fk", str(daz), "-o", "/nonexistent/p.npz"]):
        assert main([*verb, "--prop", "sword:Hips"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: --prop sword:Hips: unknown prop 'sword'; expected club or bat") and err.count("\n") == 1, err


def test_a_prop_joint_the_clip_lacks_is_refused_before_any_note(tmp_path, capsys):
    """`render CLIP --prop club:NoSuchJoint` printed the clip's skipped-T-pose note, then the error: the
    joint is checked as soon as the skeleton is read, in every verb that takes --prop KIND:JOINT."""
    from conftest import require_data

    from mjmotion.cli import main

    daz = str(require_data() / "cmu_cgspeed_daz" / "07_01.bvh")  # its frames 0-3 are skipped with a note
    for verb in (
        ["compile", daz, "-o", str(tmp_path / "m.xml")],
        ["render", daz, "-o", str(tmp_path / "r.mp4")],
        ["fk", daz, "-o", str(tmp_path / "p.npz")],
        ["evaluate", daz],
        ["hit", daz, "--offset", "0", "0", "0.1", "-o", str(tmp_path / "h.bvh")],
    ):
        assert main([*verb, "--prop", "club:NoSuchJoint"]) == 2
        err = capsys.readouterr().err
        assert err == "error: --prop club:NoSuchJoint: no joint named 'NoSuchJoint' in the skeleton\n", (verb[0], err)
    assert not list(tmp_path.iterdir())


def test_every_option_help_gives_its_range():
    """The README's limits say each option's help gives its range; `synth --speed`, `vary --pcs`,
    `audit --connect-timeout` and others refused values outside a range their help never named."""
    from mjmotion import cli

    parser = cli.build_parser()
    verbs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    checked, missing = 0, []
    for name, p in verbs.items():
        text = " ".join(p.format_help().split())  # (the help wraps lines)
        for a in p._actions:
            if getattr(a.type, "domain", None):
                checked += 1
                if not O.states_range(" ".join(a.help.split()), *a.type.bounds) or " ".join(a.help.split()) not in text:
                    missing.append(f"{name} {max(a.option_strings, key=len)}")
    assert checked > 40 and not missing, missing
    # bounds count as whole numbers: the 0 and 1 inside "0.15" state neither end; 1e-06 reads as written
    assert not O.states_range("(default 0.15)", 0, 1) and O.states_range("0 to 1", 0, 1) and O.states_range("(1e-6 to 1e6)", 1e-6, 1e6)
    # an option whose help already says it gets nothing added
    port = next(a for a in verbs["studio"]._actions if "--port" in a.option_strings)
    assert port.help.count("65535") == 1 and "range:" not in port.help
