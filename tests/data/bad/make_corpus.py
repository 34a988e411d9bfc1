"""Generate the bad-input corpus for the BVH reader (issue 9).

Every case is built from one small valid file (:data:`BASE`, a five-joint Y-up skeleton in
centimetres, three frames) by a single edit, so the expected error line is known from the edit,
not from the reader. Small cases are committed next to this script; large ones (a 50 MB clip, a
10,000-level hierarchy, a 100,000-frame clip) are built at test time by :func:`big_clip` and
:func:`deep_hierarchy` and never committed.

Run ``python tests/data/bad/make_corpus.py`` to rewrite the committed files and README.md;
``tests/test_bad_input.py`` checks that the committed files equal what this script makes.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent

BASE_LINES = [
    "HIERARCHY",
    "ROOT Hips",
    "{",
    "\tOFFSET 0.00 90.00 0.00",
    "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
    "\tJOINT Spine",
    "\t{",
    "\t\tOFFSET 0.00 10.00 0.00",
    "\t\tCHANNELS 3 Zrotation Xrotation Yrotation",
    "\t\tJOINT Head",
    "\t\t{",
    "\t\t\tOFFSET 0.00 60.00 0.00",
    "\t\t\tCHANNELS 3 Zrotation Xrotation Yrotation",
    "\t\t\tEnd Site",
    "\t\t\t{",
    "\t\t\t\tOFFSET 0.00 20.00 0.00",
    "\t\t\t}",
    "\t\t}",
    "\t}",
    "\tJOINT LeftUpLeg",
    "\t{",
    "\t\tOFFSET 10.00 0.00 0.00",
    "\t\tCHANNELS 3 Zrotation Xrotation Yrotation",
    "\t\tJOINT LeftLeg",
    "\t\t{",
    "\t\t\tOFFSET 0.00 -45.00 0.00",
    "\t\t\tCHANNELS 3 Zrotation Xrotation Yrotation",
    "\t\t\tEnd Site",
    "\t\t\t{",
    "\t\t\t\tOFFSET 0.00 -45.00 0.00",
    "\t\t\t}",
    "\t\t}",
    "\t}",
    "}",
    "MOTION",
    "Frames: 3",
    "Frame Time: 0.0333333",
    "1.0 90.5 -2.0 5.0 -10.0 30.0 1.5 2.5 -3.5 10.0 0.0 -5.0 20.0 -1.0 2.0 -30.0 4.0 1.0",
    "2.0 91.0 -1.5 6.0 -11.0 31.0 2.0 3.0 -4.0 11.0 0.5 -5.5 21.0 -1.5 2.5 -31.0 4.5 1.5",
    "3.0 91.5 -1.0 7.0 -12.0 32.0 2.5 3.5 -4.5 12.0 1.0 -6.0 22.0 -2.0 3.0 -32.0 5.0 2.0",
]
#: The valid file every case is derived from (18 channels: 6 + 4 × 3).
BASE = "\n".join(BASE_LINES) + "\n"
N_CHANNELS = 18


def find(prefix: str, nth: int = 0) -> int:
    """0-based index of the ``nth`` base line whose stripped text starts with ``prefix``."""
    hits = [i for i, s in enumerate(BASE_LINES) if s.strip().startswith(prefix)]
    return hits[nth]


MOTION = find("MOTION")
FRAMES = find("Frames:")
FRAME_TIME = find("Frame Time:")
DATA = FRAME_TIME + 1  # first data line (0-based)


@dataclass(frozen=True)
class Case:
    """One corpus file and what the reader must do with it.

    ``line`` is the 1-based line the error must name (``None``: no line, e.g. unit detection);
    ``match`` a lower-case phrase the message must contain. ``error=False`` means the file is
    unusual but valid: it loads, and with ``same=True`` it loads to exactly the base motion.
    """

    name: str
    what: str
    data: bytes
    error: bool = True
    line: int | None = None
    match: str = ""
    same: bool = False


def _edit(index: int, new: str | None) -> str:
    lines = list(BASE_LINES)
    if new is None:
        del lines[index]
    else:
        lines[index] = new
    return "\n".join(lines) + "\n"


def _insert(index: int, new: str) -> str:
    lines = list(BASE_LINES)
    lines.insert(index, new)
    return "\n".join(lines) + "\n"


def _data_line(k: int, f: Callable[[list[str]], list[str]]) -> str:
    toks = BASE_LINES[DATA + k].split()
    return _edit(DATA + k, " ".join(f(toks)))


def _set(toks: list[str], i: int, v: str) -> list[str]:
    toks = list(toks)
    toks[i] = v
    return toks


def _err(name: str, what: str, text: str | bytes, line: int | None, match: str) -> Case:
    data = text.encode("utf-8") if isinstance(text, str) else text
    return Case(name, what, data, True, line, match)


def _ok(name: str, what: str, text: str | bytes, same: bool = False) -> Case:
    data = text.encode("utf-8") if isinstance(text, str) else text
    return Case(name, what, data, False, None, "", same)


def cases() -> list[Case]:
    """Every committed corpus case, in README order."""
    spine_ch = find("CHANNELS", 1)
    head_off = find("OFFSET", 2)
    head_joint = find("JOINT Head")
    leg_joint = find("JOINT LeftLeg")
    last_close = len(BASE_LINES) - 1 - BASE_LINES[::-1].index("}")
    rng = random.Random(9)
    garbage = bytes(rng.randrange(256) for _ in range(4096))
    out = [
        # --- structure ---------------------------------------------------------------------
        _err("empty", "a 0-byte file", b"", 1, "empty"),
        _err("blank", "only whitespace and newlines", "  \n\t\n\n", 1, "empty"),
        _err("no_hierarchy", "starts with ROOT (no HIERARCHY keyword)", _edit(0, None), 1, "hierarchy"),
        _err("missing_motion", "hierarchy only, no MOTION section", "\n".join(BASE_LINES[:MOTION]) + "\n", MOTION + 1, "no motion"),  # fmt: skip
        _err(
            "truncated_hierarchy", "file ends inside the hierarchy", "\n".join(BASE_LINES[: head_off + 1]), head_off + 1, "never closed"
        ),  # fmt: skip
        _err("unbalanced_missing_brace", "one '}' removed: a joint is open at MOTION", _edit(last_close, None), MOTION, "unbalanced"),  # fmt: skip
        _err("unbalanced_extra_brace", "an extra '}' after the root closes", _insert(last_close + 1, "}"), last_close + 2, "unbalanced"),  # fmt: skip
        _err("brace_missing_after_joint", "JOINT not followed by '{'", _edit(head_joint + 1, None), head_joint + 2, "expected '{'"),  # fmt: skip
        _err(
            "two_roots",
            "a second ROOT after the first closes",
            _insert(MOTION, "ROOT Other\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Zrotation Xrotation Yrotation\n}"),
            MOTION + 1,
            "second root",
        ),  # fmt: skip
        _err("root_without_name", "ROOT with no name", _edit(1, "ROOT"), 2, "name"),
        _err(
            "motion_before_root", "HIERARCHY then straight to MOTION", "HIERARCHY\nMOTION\nFrames: 1\nFrame Time: 0.1\n\n", 2, "before any root"
        ),  # fmt: skip
        _err(
            "stray_token", "an unknown keyword in the hierarchy", _insert(spine_ch + 1, "\t\tSCALE 1 1 1"), spine_ch + 2, "unexpected 'scale'"
        ),  # fmt: skip
        _err(
            "end_site_channels",
            "an End Site with CHANNELS",
            _insert(find("End Site") + 3, "CHANNELS 3 Zrotation Xrotation Yrotation"),
            find("End Site") + 4,
            "end site cannot have channels",
        ),  # fmt: skip
        _err(
            "duplicate_joint_name", "two joints called Head", _edit(leg_joint, "\t\tJOINT Head"), leg_joint + 1, "duplicate joint name 'head'"
        ),  # fmt: skip
        _err(
            "missing_offset", "a joint without OFFSET", _edit(head_off, None), BASE_LINES.index("\t\t}"), "'head' (line 10) has no offset"
        ),  # fmt: skip
        # --- channels ----------------------------------------------------------------------
        _err(
            "channels_count_high",
            "CHANNELS 4 with three names",
            _edit(spine_ch, "\t\tCHANNELS 4 Zrotation Xrotation Yrotation"),
            spine_ch + 1,
            "says 4 but lists 3",
        ),  # fmt: skip
        _err(
            "channels_count_low",
            "CHANNELS 2 with three names",
            _edit(spine_ch, "\t\tCHANNELS 2 Zrotation Xrotation Yrotation"),
            spine_ch + 1,
            "says 2 but lists 3",
        ),  # fmt: skip
        _err(
            "channels_count_huge", "CHANNELS 999999999", _edit(spine_ch, "\t\tCHANNELS 999999999 Zrotation"), spine_ch + 1, "says 999999999"
        ),  # fmt: skip
        _err(
            "channels_count_word",
            "CHANNELS three",
            _edit(spine_ch, "\t\tCHANNELS three Zrotation Xrotation Yrotation"),
            spine_ch + 1,
            "not a whole number",
        ),  # fmt: skip
        _err(
            "channel_unknown",
            "a channel called Wrotation",
            _edit(spine_ch, "\t\tCHANNELS 3 Zrotation Wrotation Yrotation"),
            spine_ch + 1,
            "unknown channel 'wrotation'",
        ),  # fmt: skip
        _err(
            "channel_twice", "Zrotation listed twice", _edit(spine_ch, "\t\tCHANNELS 3 Zrotation Zrotation Yrotation"), spine_ch + 1, "listed twice"
        ),  # fmt: skip
        # --- numbers -----------------------------------------------------------------------
        _err("offset_word", "OFFSET with a word", _edit(head_off, "\t\t\tOFFSET 0.00 sixty 0.00"), head_off + 1, "not a number"),
        _err("offset_nan", "OFFSET with nan", _edit(head_off, "\t\t\tOFFSET 0.00 nan 0.00"), head_off + 1, "not a finite number"),
        _err("offset_short", "OFFSET with two numbers", _edit(head_off, "\t\t\tOFFSET 0.00 60.00"), head_off + 1, "needs 3 numbers"),
        _err(
            "value_word",
            "a word among the motion values (frame 2)",
            _data_line(1, lambda t: _set(t, 7, "abc")),
            DATA + 2,
            "value 8 'abc' is not a number",
        ),  # fmt: skip
        _err(
            "value_decimal_comma", "a decimal comma (frame 3)", _data_line(2, lambda t: _set(t, 0, "3,0")), DATA + 3, "value 1 '3,0' is not a number"
        ),  # fmt: skip
        _err(
            "value_nan", "nan among the values (frame 2)", _data_line(1, lambda t: _set(t, 4, "nan")), DATA + 2, "value 5 'nan' is not finite"
        ),  # fmt: skip
        _err(
            "value_inf", "-inf among the values (frame 3)", _data_line(2, lambda t: _set(t, 17, "-inf")), DATA + 3, "value 18 '-inf' is not finite"
        ),  # fmt: skip
        _err(
            "value_overflow",
            "1e999 (overflows to inf) in frame 1",
            _data_line(0, lambda t: _set(t, 3, "1e999")),
            DATA + 1,
            "value 4 '1e999' is beyond the largest double",
        ),  # fmt: skip
        _err(
            "values_too_few",
            "17 values on the second motion line",
            _data_line(1, lambda t: t[:-1]),
            DATA + 2,
            "17 values on a motion line; expected 18",
        ),  # fmt: skip
        _err(
            "values_too_many",
            "19 values on the third motion line",
            _data_line(2, lambda t: [*t, "0.0"]),
            DATA + 3,
            "19 values on a motion line; expected 18",
        ),  # fmt: skip
        _err(
            "values_all_lines_short",
            "every motion line one value short",
            "\n".join(BASE_LINES[:DATA] + [" ".join(s.split()[:-1]) for s in BASE_LINES[DATA:]]) + "\n",
            DATA + 1,
            "17 values on a motion line; expected 18",
        ),  # fmt: skip
        # --- motion header -----------------------------------------------------------------
        _err(
            "frames_larger", "Frames: 5 but three lines of values", _edit(FRAMES, "Frames: 5"), DATA + 4, "'frames: 5' but the motion section has 3"
        ),  # fmt: skip
        _err(
            "frames_smaller", "Frames: 2 but three lines of values", _edit(FRAMES, "Frames: 2"), DATA + 3, "'frames: 2' but the motion section has 3"
        ),  # fmt: skip
        _err(
            "frames_huge",
            "Frames: 10^13 (must not allocate for it)",
            _edit(FRAMES, "Frames: 10000000000000"),
            FRAMES + 1,
            "more than the limit of 1,000,000 frames",
        ),  # fmt: skip
        _err(
            "frames_zero",
            "Frames: 0 and no values",
            "\n".join(BASE_LINES[:DATA]).replace("Frames: 3", "Frames: 0") + "\n",
            FRAMES + 1,
            "expected at least one frame",
        ),  # fmt: skip
        _err("frames_negative", "Frames: -3", _edit(FRAMES, "Frames: -3"), FRAMES + 1, "expected at least one frame"),
        _err("frames_fraction", "Frames: 3.5", _edit(FRAMES, "Frames: 3.5"), FRAMES + 1, "not a whole number"),
        _err("frames_missing", "no Frames: line", _edit(FRAMES, None), FRAMES + 1, "expected 'frames: n'"),
        _err("frame_time_zero", "Frame Time: 0", _edit(FRAME_TIME, "Frame Time: 0"), FRAME_TIME + 1, "expected a positive"),
        _err(
            "frame_time_negative", "Frame Time: -0.0333333", _edit(FRAME_TIME, "Frame Time: -0.0333333"), FRAME_TIME + 1, "expected a positive"
        ),  # fmt: skip
        _err("frame_time_nan", "Frame Time: nan", _edit(FRAME_TIME, "Frame Time: nan"), FRAME_TIME + 1, "not a finite number"),
        _err("frame_time_word", "Frame Time: fast", _edit(FRAME_TIME, "Frame Time: fast"), FRAME_TIME + 1, "not a number"),
        # --- valid text, extreme values (issue 17) -------------------------------------------
        _err(
            "frame_time_tiny", "Frame Time: 1e-300 (10^300 fps)", _edit(FRAME_TIME, "Frame Time: 1e-300"), FRAME_TIME + 1, "seconds per frame"
        ),  # fmt: skip
        _err("frame_time_huge", "Frame Time: 1e300", _edit(FRAME_TIME, "Frame Time: 1e300"), FRAME_TIME + 1, "seconds per frame"),
        _err(
            "frame_time_denormal", "Frame Time: 5e-324 (1/x overflows)", _edit(FRAME_TIME, "Frame Time: 5e-324"), FRAME_TIME + 1, "seconds per frame"
        ),  # fmt: skip
        _err(
            "root_position_huge",
            "a root position of 1e308 (frame 2)",
            _data_line(1, lambda t: _set(t, 0, "1e308")),
            DATA + 2,
            "value 1 (hips xposition) is 1e+308",
        ),  # fmt: skip
        _err("offset_huge", "an OFFSET of 1e308", _edit(head_off, "\t\t\tOFFSET 0.00 1e308 0.00"), head_off + 1, "beyond the ±100000 m"),
        _err(
            "name_escape_sequence",
            "a joint name with a terminal escape sequence (ESC [2J)",
            _edit(head_joint, "\t\tJOINT Head\x1b[2J"),
            head_joint + 1,
            "control character (u+001b)",
        ),  # fmt: skip
        _err(
            "name_control_char",
            "a joint name with a C1 control character",
            _edit(head_joint, "\t\tJOINT He\x85ad\x9b"),
            head_joint + 1,
            "control character",
        ),  # fmt: skip
        # --- bytes -------------------------------------------------------------------------
        _err("binary_garbage", "4 KiB of random bytes", garbage, garbage.count(b"\n", 0, garbage.find(b"\x00")) + 1, "binary data"),
        _err("binary_png", "a PNG header", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", 3, "binary data"),
        _err(
            "invalid_utf8",
            "a Latin-1 byte in a joint name (line 10)",
            _edit(head_joint, "\t\tJOINT Kopf").encode().replace(b"Kopf", b"K\xf6pf"),
            head_joint + 1,
            "invalid utf-8",
        ),  # fmt: skip
        _err(
            "invalid_utf8_values",
            "a stray 0xff byte in the motion values",
            _edit(DATA + 1, BASE_LINES[DATA + 1] + " \udcff").encode("utf-8", "surrogateescape"),
            DATA + 2,
            "invalid utf-8",
        ),  # fmt: skip
        # --- unusual but valid -------------------------------------------------------------
        _ok("crlf", "Windows line ends", BASE.replace("\n", "\r\n"), same=True),
        _ok("cr_only", "classic Mac line ends (CR only)", BASE.replace("\n", "\r"), same=True),
        _ok("bom", "UTF-8 byte-order mark", b"\xef\xbb\xbf" + BASE.encode(), same=True),
        _ok("utf16", "UTF-16 with a byte-order mark (PowerShell '>')", BASE.encode("utf-16"), same=True),
        _ok(
            "spaces_and_tabs", "indentation with spaces, runs of blanks between values", BASE.replace("\t", "  ").replace(" ", " \t "), same=True
        ),  # fmt: skip
        _ok("frames_tab", "'Frames:' followed by a tab", BASE.replace("Frames: 3", "Frames:\t3"), same=True),
        _ok("no_final_newline", "no newline after the last frame", BASE.rstrip("\n"), same=True),
        _ok(
            "blank_lines",
            "blank lines between and after motion lines",
            "\n".join(BASE_LINES[:DATA] + [s + "\n" for s in BASE_LINES[DATA:]]) + "\n\n\n",
            same=True,
        ),  # fmt: skip
        _ok("brace_same_line", "'{' on the JOINT line", BASE.replace("JOINT Spine\n\t{", "JOINT Spine {"), same=True),
        _ok("lowercase_channels", "channel names in lower case", BASE.replace("Zrotation", "zrotation"), same=True),
        _ok(
            "number_forms",
            "+1, 1e0, .5e1 and 1.0E+0 number spellings",
            _data_line(0, lambda t: _set(_set(_set(t, 0, "+1"), 1, "0.905e2"), 2, "-.2E+1")),
            same=True,
        ),  # fmt: skip
        _ok("zero_length_end_site", "an End Site with OFFSET 0 0 0", _edit(find("OFFSET", 3), "\t\t\t\tOFFSET 0 0 0")),  # fmt: skip
        _ok(
            "xml_special_names",
            "joint names with < > & \" ' characters",
            BASE.replace("JOINT Head", 'JOINT <Head&"Neck">').replace("JOINT LeftLeg", "JOINT Left'Leg</body>"),
        ),  # fmt: skip
        _ok(
            "names_with_spaces_colons", "names like 'mixamorig:Left Up Leg'", BASE.replace("JOINT LeftUpLeg", "JOINT mixamorig:Left Up Leg")
        ),  # fmt: skip
        _ok("unicode_names", "non-ASCII joint names", BASE.replace("JOINT Head", "JOINT Kopf_頭")),
        _ok(
            "zero_channel_joint",
            "a joint with CHANNELS 0 (fixed)",
            _edit(spine_ch, "\t\tCHANNELS 0")
            .replace(BASE_LINES[DATA], " ".join(BASE_LINES[DATA].split()[:6] + BASE_LINES[DATA].split()[9:]))
            .replace(BASE_LINES[DATA + 1], " ".join(BASE_LINES[DATA + 1].split()[:6] + BASE_LINES[DATA + 1].split()[9:]))
            .replace(BASE_LINES[DATA + 2], " ".join(BASE_LINES[DATA + 2].split()[:6] + BASE_LINES[DATA + 2].split()[9:])),
        ),  # fmt: skip
        _ok("single_frame", "one frame", "\n".join(BASE_LINES[: DATA + 1]).replace("Frames: 3", "Frames: 1") + "\n"),
    ]
    names = [c.name for c in out]
    assert len(set(names)) == len(names), "case names must be unique"
    return out


# --- large cases, generated at test time ------------------------------------------------------
def big_clip(n_frames: int) -> bytes:
    """The base skeleton with ``n_frames`` frames of smooth motion (about 160 bytes per frame)."""
    import numpy as np

    t = np.arange(n_frames)[:, None] / 30.0
    phase = np.arange(N_CHANNELS)[None, :]
    vals = 20.0 * np.sin(0.7 * t + phase)
    head = "\n".join(BASE_LINES[:FRAMES]) + f"\nFrames: {n_frames}\nFrame Time: 0.0333333\n"
    import io

    buf = io.StringIO()
    np.savetxt(buf, vals, fmt="%.4f")
    return head.encode() + buf.getvalue().encode()


def big_clip_bytes(target_bytes: int) -> tuple[bytes, int]:
    """A valid clip of at least ``target_bytes`` bytes (within 1 %) and its frame count."""
    n = 1000
    data = big_clip(n)
    while len(data) < target_bytes:
        n = int(n * target_bytes / len(data) * 1.005) + 1
        data = big_clip(n)
    return data, n


def wide_hierarchy(width: int, frames: int = 2) -> bytes:
    """A root with ``width`` - 1 children (each with an End Site), 180 file units tall."""
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for i in range(1, width):
        lines += [f"JOINT j{i}", "{", "OFFSET 0 90 0", "CHANNELS 3 Zrotation Xrotation Yrotation", "End Site", "{", "OFFSET 0 90 0", "}", "}"]
    lines += ["}", "MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    n = 6 + 3 * (width - 1)
    lines += [" ".join(["0"] * n) for _ in range(frames)]
    return ("\n".join(lines) + "\n").encode()


def deep_hierarchy(depth: int, frames: int = 2) -> bytes:
    """A chain ``depth`` joints deep, 180 file units tall (so the unit detected is centimetres)."""
    bone = f"OFFSET 0 {180.0 / depth:.9g} 0"  # 180 units tall in all: read as centimetres
    lines = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0", "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for i in range(1, depth):
        lines += [f"JOINT j{i}", "{", bone, "CHANNELS 3 Zrotation Xrotation Yrotation"]
    lines += ["End Site", "{", bone, "}"]
    lines += ["}"] * depth
    n = 6 + 3 * (depth - 1)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    lines += [" ".join(["0"] * n) for _ in range(frames)]
    return ("\n".join(lines) + "\n").encode()


# --- stream scripts and score files (issue 17), made at test time -------------------------------
@dataclass(frozen=True)
class FileCase:
    """A hostile input that is not a BVH file: its bytes and a phrase the one error line must hold."""

    name: str
    what: str
    data: bytes
    match: str


def _script(**change) -> dict:
    data = {
        "duration": 0.2,
        "loop_blend": 0.05,
        "clips": {"a": {"file": "CLIP"}},
        "locomotion": ["a"],
        "commands": [{"time": 0, "weights": {"a": 1}}],
    }
    data.update(change)
    return data


def script_cases() -> list[FileCase]:
    """Stream scripts of the wrong shape; ``CLIP`` stands for a valid clip's path."""
    import json

    def case(name: str, what: str, match: str, text: str | None = None, **change) -> FileCase:
        return FileCase(name, what, (text if text is not None else json.dumps(_script(**change))).encode(), match)

    w = {"time": 0, "weights": {"a": 1}}
    return [
        case(
            "weights_word", 'weights {"a": "abc"}', "commands[0].weights.a: expected a finite number", commands=[{"time": 0, "weights": {"a": "abc"}}]
        ),
        case("weights_list", "weights [1]", "commands[0].weights: expected an object", commands=[{"time": 0, "weights": [1]}]),
        case("weights_null", "weights null", "commands[0].weights: expected an object", commands=[{"time": 0, "weights": None}]),
        case("frames_number", '"frames": 5', "clips.a.frames: expected a string", clips={"a": {"file": "CLIP", "frames": 5}}),
        case("frames_list", '"frames": [0, 10]', "clips.a.frames: expected a string", clips={"a": {"file": "CLIP", "frames": [0, 10]}}),
        case("play_list", '"play" as a list', "commands[1].play: expected a string", commands=[w, {"time": 0.1, "play": ["a"]}]),
        case("play_object", '"play" as an object', "commands[1].play: expected a string", commands=[w, {"time": 0.1, "play": {"a": 1}}]),
        case("commands_object", '"commands" as an object', "commands: expected a list", commands={"time": 0}),
        case("long_number", "a 5000-digit duration", "duration: expected a finite number", text='{"duration": ' + "9" * 5000 + "}"),
        case("nan", "duration NaN", "duration: expected a finite number", text='{"duration": NaN}'),
        case("overflow", "duration 1e999", "duration: expected a finite number", text='{"duration": 1e999}'),
        case("return_word", '"return": "yes"', "commands[1].return: expected true", commands=[w, {"time": 0.1, "return": "yes"}]),
        case("escape_name", "a clip name with a terminal escape", "is not 1 to 256 printable characters", clips={"a\x1b[2J": {"file": "CLIP"}}),
        case("deep", "JSON nested 100,000 deep", "nested too deeply", text="[" * 100_000),
        FileCase("binary", "every byte value", bytes(range(256)) * 4, "not a text file"),
    ]


def _npy_header(shape: tuple[int, ...], descr: str = "<f8") -> bytes:
    """An .npy version 1.0 header, as numpy.save writes it (padded to 64 bytes)."""
    head = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}"
    pad = 64 - (10 + len(head) + 1) % 64
    text = (head + " " * pad + "\n").encode("latin-1")
    return b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text


def score_cases() -> list[FileCase]:
    """Score files for ``vary --scores`` (the name's suffix is the case's: .npy or .csv)."""
    import io

    import numpy as np

    def npy(arr: np.ndarray) -> bytes:
        buf = io.BytesIO()
        np.save(buf, arr, allow_pickle=True)
        return buf.getvalue()

    npz = io.BytesIO()
    np.savez(npz, scores=np.zeros((10, 2)))
    good = np.zeros((10, 2))
    return [
        FileCase("npz.npy", "an .npz archive named .npy", npz.getvalue(), "zip archive"),
        FileCase("strings.npy", "an array of strings", npy(np.array([["a", "b"], ["c", "d"]])), "expected real numbers"),
        FileCase("objects.npy", "an object array (pickled)", npy(np.array([[None, 1], [2, 3]], dtype=object)), "expected real numbers"),
        FileCase("huge_values.npy", "scores of 1e300", npy(np.full((10, 2), 1e300)), "expected a finite score within"),
        FileCase("nan.npy", "a NaN score", npy(np.where(np.eye(10, 2) > 0, np.nan, good)), "expected a finite score"),
        FileCase("rows_1e11.npy", "a header claiming 10^11 rows", _npy_header((10**11, 2)) + b"\x00" * 160, "at most 1,000,000 frames"),
        FileCase("truncated.npy", "a header for 1000 rows, data for 10", _npy_header((1000, 2)) + b"\x00" * 160, "truncated"),
        FileCase("one_row.npy", "one frame", npy(np.zeros((1, 2))), "at least 2 rows"),
        FileCase("3d.npy", "a 3-D array", npy(np.zeros((4, 2, 2))), "at least 2 rows"),
        FileCase("not_npy.npy", "text named .npy", b"1,2\n3,4\n", "not an .npy file"),
        FileCase("word.csv", "a word among the scores", b"0,0\n0,abc\n0,0\n", "cannot read scores"),
        FileCase("ragged.csv", "rows of different lengths", b"0,0\n0,0,0\n0,0\n", "expected 2 like the first row"),
        FileCase("huge.csv", "1e300 in a CSV", b"0,0\n0,1e300\n0,0\n", "expected a finite score within"),
        FileCase("binary.csv", "binary data", bytes(range(256)), "not a text file"),
    ]


# --- writing the committed corpus ---------------------------------------------------------------
def readme(all_cases: list[Case]) -> str:
    rows = [
        "# Bad-input corpus for the BVH reader",
        "",
        "Generated by `python tests/data/bad/make_corpus.py` (do not edit by hand); checked by",
        "`tests/test_bad_input.py`. `tests/test_cli_contract.py` runs every error case through every",
        "CLI verb that reads a BVH file (exit status 2, one `error:` line naming `FILE:LINE:`, no",
        "traceback, nothing written) and the valid cases whose skeleton or motion differs from the base",
        "(exit 0, or 2 with one `error:` line — never a traceback).",
        "",
        "Each case is one edit of a valid five-joint file (`base.bvh`), so the line an error must name",
        "is known from the edit. An error case must raise `BvhError` whose message starts `FILE:LINE:`",
        'and contains the phrase; a valid case must load ("same": to exactly the motion of',
        "`base.bvh`). When `Frames:` promises more frames than there are, the line named is the one",
        "after the last line of values (where the data runs out).",
        "",
        "| case | what | outcome | line | message contains |",
        "|---|---|---|---|---|",
    ]
    for c in all_cases:
        outcome = "BvhError" if c.error else ("loads (same as base)" if c.same else "loads")
        line = "" if c.line is None else str(c.line)
        rows.append(f"| `{c.name}.bvh` | {c.what} | {outcome} | {line} | {c.match.replace('|', '/')} |")
    rows += [
        "",
        "Generated at test time (never committed):",
        "",
        "| case | what | outcome |",
        "|---|---|---|",
        "| 50 MB clip | the base skeleton, ~330,000 frames | loads; `read(max_bytes=…)` refuses it with a BvhError |",
        "| 100,000-frame clip | memory | loads with a tracemalloc peak under 5x the motion arrays (3.5x measured) |",
        "| 10,000-level hierarchy | a chain 10,000 joints deep | loads and writes (no RecursionError); `mjcf.compile` raises a clear MjmotionError above `mjcf.MAX_DEPTH` = 256 nested joints (MuJoCo's compile time grows with the cube of the depth: 1,000 deep takes 21 s) |",
        "| 50 MB on one line | a single line of garbage | BvhError on line 1 |",
        "| 10,001 joints | a skeleton one joint wider than `caps.MAX_JOINTS` (one root with 10,000 children) | BvhError on the line of joint 10,001, in seconds |",
        "| 1,001 joints | a skeleton one joint wider than `caps.MAX_MODEL_JOINTS` | loads; `mjcf.compile` (compile, fk, render, …) refuses it at once |",
        "| 100,000-deep chain | the hierarchy that made `convert` use 7 GB (indentation growing with depth²) | BvhError (more than 10,000 joints); the writer's indentation stops at 32 levels |",
        "| a FIFO with no writer, `/dev/zero`, a folder | not regular files | refused before they are opened (`mjmotion.inputs`), every verb |",
        "| a 2 GB sparse file | larger than `caps.MAX_FILE_BYTES` | refused from its size, nothing read |",
        "| a symbolic-link loop | `a.bvh -> b.bvh -> a.bvh` | BvhError: too many levels of symbolic links, every verb |",
        "| random mutations | hypothesis (`tests/test_fuzz.py`) | loads or BvhError, never another exception |",
        "",
        "Stream scripts (`script_cases()`, run through `mjmotion stream` by `tests/test_cli_contract.py`;",
        "each gives one `error:` line naming the script and the key path; `tests/test_script.py` has more):",
        "",
        "| case | what | message contains |",
        "|---|---|---|",
        *(f"| `{c.name}` | {c.what} | {c.match} |" for c in script_cases()),
        "",
        "Score files for `vary --scores` (`score_cases()`; each refused naming the file, before its data is read):",
        "",
        "| case | what | message contains |",
        "|---|---|---|",
        *(f"| `{c.name}` | {c.what} | {c.match} |" for c in score_cases()),
        "",
    ]
    return "\n".join(rows)


def write_all(folder: Path = HERE) -> list[Path]:
    all_cases = cases()
    paths = []
    (folder / "base.bvh").write_bytes(BASE.encode())
    for c in all_cases:
        p = folder / f"{c.name}.bvh"
        p.write_bytes(c.data)
        paths.append(p)
    (folder / "README.md").write_text(readme(all_cases), encoding="utf-8")
    return paths


if __name__ == "__main__":
    written = write_all()
    print(f"wrote {len(written)} cases and README.md to {HERE}")
