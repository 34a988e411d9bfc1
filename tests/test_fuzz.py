"""Fuzzing the BVH reader (issue 9 item 2): valid random skeletons and motions, written by
``bvh.format_motion`` and mutated. The reader either loads or raises ``BvhError`` — never another
exception, never a hang (a hard alarm per file on top of hypothesis' deadline).

Bounded for CI (150 examples, derandomised so CI is reproducible); set
``MJMOTION_FUZZ_EXAMPLES=5000`` for a long local run with fresh random examples.
"""

from __future__ import annotations

import io
import os
from contextlib import redirect_stderr, redirect_stdout
from datetime import timedelta

import numpy as np
from conftest import random_motion, random_skeleton, within
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mjmotion import bvh
from mjmotion import rotations as rot
from mjmotion.cli import main
from mjmotion.errors import BvhError
from mjmotion.skeleton import Motion

LONG = int(os.environ.get("MJMOTION_FUZZ_EXAMPLES", "0"))
FUZZ = settings(
    max_examples=LONG or 150,
    deadline=timedelta(seconds=3),
    derandomize=not LONG,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)
#: Seconds after which one parse counts as a hang.
HANG_S = 10

HOSTILE = [
    "", "nan", "inf", "-inf", "1e999", "1e-400", "abc", "{", "}", "{ }", "ROOT", "JOINT", "End", "Site",
    "End Site", "MOTION", "HIERARCHY", "Frames:", "Frame Time:", "CHANNELS", "OFFSET", "-1", "0", "3",
    "99999999999999999999", "1_0", "１２", "٣", "\x00", "\ufeff", "0x10", "Xposition", "Wrotation",
    "CHANNELS 7", "CHANNELS -1", "\t", "\r", "\x0b", "\u2028", "\xa0", "1,5", ".", "-", "+", "e5",
]  # fmt: skip


def no_hang(seconds: int = HANG_S):
    """Fail (not hang) if the block runs longer than ``seconds``."""
    return within(seconds, "parse")


@st.composite
def clips(draw) -> tuple[Motion, str]:
    """A valid random clip and its BVH text (random tree, channel orders, 6-channel inner joints)."""
    seed = draw(st.integers(0, 2**32 - 1))
    n_joints = draw(st.integers(1, 9))
    n_frames = draw(st.integers(1, 6))
    rng = np.random.default_rng(seed)
    skel = random_skeleton(rng, n_joints, inner_positions=draw(st.booleans()))
    m = random_motion(rng, skel, n_frames)
    return m, bvh.format_motion(m)


def _mutate_lines(draw, lines: list[str]) -> list[str]:
    lines = list(lines)
    kind = draw(st.sampled_from(["delete", "duplicate", "swap", "token", "insert", "number", "join", "split"]))
    i = draw(st.integers(0, len(lines) - 1))
    if kind == "delete":
        del lines[i]
    elif kind == "duplicate":
        lines.insert(i, lines[i])
    elif kind == "swap":
        j = draw(st.integers(0, len(lines) - 1))
        lines[i], lines[j] = lines[j], lines[i]
    elif kind in ("token", "number"):
        toks = lines[i].split(" ") or [""]
        k = draw(st.integers(0, len(toks) - 1))
        if kind == "token":
            toks[k] = draw(st.sampled_from(HOSTILE) | st.text(max_size=6))
        else:
            toks[k] = repr(draw(st.floats(allow_nan=True, allow_infinity=True) | st.integers(-(10**20), 10**20)))
        lines[i] = " ".join(toks)
    elif kind == "insert":
        lines.insert(i, draw(st.sampled_from(HOSTILE) | st.text(max_size=20)))
    elif kind == "join" and i + 1 < len(lines):
        lines[i : i + 2] = [lines[i] + " " + lines[i + 1]]
    elif kind == "split":
        toks = lines[i].split(" ")
        k = draw(st.integers(0, len(toks)))
        lines[i : i + 1] = [" ".join(toks[:k]), " ".join(toks[k:])]
    return lines


@st.composite
def mutated(draw) -> bytes:
    """A valid clip's text after one to three line edits, then maybe raw byte damage."""
    _, text = draw(clips())
    lines = text.split("\n")
    for _ in range(draw(st.integers(1, 3))):
        if lines:
            lines = _mutate_lines(draw, lines)
    data = "\n".join(lines).encode("utf-8", "surrogatepass")
    damage = draw(st.sampled_from(["none", "none", "truncate", "bytes", "crlf", "bom"]))
    if damage == "truncate" and data:
        data = data[: draw(st.integers(0, len(data) - 1))]
    elif damage == "bytes":
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(min_size=1, max_size=8)) + data[at:]
    elif damage == "crlf":
        data = data.replace(b"\n", b"\r\n")
    elif damage == "bom":
        data = b"\xef\xbb\xbf" + data
    return data


def check_outcome(data: bytes, **kw) -> Motion | None:
    """Parse ``data``: a sane Motion, or a BvhError naming the file and a real line."""
    n_lines = data.count(b"\n") + data.count(b"\r") + 2
    try:
        with no_hang():
            m = bvh.parse(data, "fuzz.bvh", **kw)
    except BvhError as e:
        assert e.path == "fuzz.bvh" and str(e).startswith("fuzz.bvh")
        assert e.line is None or 1 <= e.line <= n_lines, (e.line, n_lines)
        assert e.message and "\n" not in str(e)
        return None
    assert m.n_frames >= 1 and np.isfinite(m.fps) and m.fps > 0
    assert np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.root_positions))
    assert np.allclose(np.linalg.norm(m.rotations, axis=-1), 1.0)
    assert np.all(np.isfinite(m.skeleton.offsets))
    return m


@FUZZ
@given(mutated())
def test_mutated_files_load_or_raise_bvh_error(data):
    check_outcome(data, scale=1.0, up="z")
    check_outcome(data)  # unit detection too: its failure must be a BvhError as well


@settings(FUZZ, max_examples=(LONG or 150) // 3)
@given(clips())
def test_unmutated_files_round_trip(clip):
    m, text = clip
    again = check_outcome(text.encode(), scale=1.0, up="z")
    assert again is not None
    assert again.skeleton.names == m.skeleton.names and np.array_equal(again.skeleton.parents, m.skeleton.parents)
    assert np.allclose(again.skeleton.offsets, m.skeleton.offsets, atol=1e-9)
    assert np.allclose(again.root_positions, m.root_positions, atol=1e-6)
    assert np.all(rot.angle_between(again.rotations, m.rotations) < 1e-6)


@settings(FUZZ, max_examples=(LONG or 150) // 5)
@given(mutated())
def test_mutated_files_through_the_cli(tmp_path_factory, data):
    """``mjmotion info`` on a damaged file: exit 0 or a single error line with status 2."""
    path = tmp_path_factory.mktemp("fuzz") / "clip.bvh"
    path.write_bytes(data)
    err, out = io.StringIO(), io.StringIO()
    with redirect_stderr(err), redirect_stdout(out), no_hang():
        rc = main(["info", str(path), "--units", "m", "--up", "z"])
    lines = [ln for ln in err.getvalue().splitlines() if ln.startswith("error:")]
    assert "Traceback" not in err.getvalue()
    if rc == 0:
        assert not lines
    else:
        assert rc == 2 and len(lines) == 1 and str(path) in lines[0], err.getvalue()
