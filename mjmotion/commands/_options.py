"""Option domains: every numeric option of every verb is checked here, once, before any work.

Use the factories as argparse ``type=`` (a value outside its domain is a usage error: one
``error: --fps 1e308: expected …`` line, exit status 2, before any file is read)::

    p.add_argument("--fps", type=FPS, help=...)
    p.add_argument("--falloff", type=number(0, 100, lo_open=True, what="a distance in metres"))
    p.add_argument("--jobs", type=integer(1, 64, what="a number of processes"))
    p.add_argument("--labels", nargs="+", type=label())
    p.add_argument("--prop", action=UniqueProps, default=[])

A domain is finite and bounded: NaN, infinities and absurd magnitudes (1e308) never reach NumPy
or MuJoCo. What an option implies once the clips are known (frames a resample makes, frames a
window spans) is checked by the helpers below before anything is allocated, with a message that
names the option. The caps are :mod:`mjmotion.caps` (the README's "Limits" paragraph).
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from typing import Any

from ..caps import MAX_ACTORS, MAX_FPS, MAX_FRAMES, MAX_VIDEO_FPS, MIN_FPS, MIN_VIDEO_FPS, check_motion_size
from ..errors import MjmotionError
from ..skeleton import Motion

#: Most characters of one ``int()``: Python refuses longer digit strings (4300) with a ValueError.
_MAX_DIGITS = 30


def _fmt(x: float) -> str:
    return f"{x:g}" if isinstance(x, float) else f"{x:,}" if abs(x) >= 10_000 else str(x)


def _shown(text: str) -> str:
    """The value as the user typed it, shortened and escaped (it is quoted in the error line)."""
    t = text if len(text) <= 40 else text[:40] + "…"
    return t if t.isprintable() else repr(t)  # quoted: a blank or a line break shows


def _range_text(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    if lo is not None and hi is not None:
        if not lo_open and not hi_open:
            return f"from {_fmt(lo)} to {_fmt(hi)}"
        return f"in {'(' if lo_open else '['}{_fmt(lo)}, {_fmt(hi)}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '≥'} {_fmt(lo)}"
    if hi is not None:
        return f"{'<' if hi_open else '≤'} {_fmt(hi)}"
    return "(any finite value)"


def number(
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    what: str = "a number",
) -> Callable[[str], float]:
    """An argparse ``type``: a finite float in ``[lo, hi]`` (``lo_open``/``hi_open``: exclusive)."""
    domain = _range_text(lo, hi, lo_open, hi_open)

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{_shown(text)}: expected {what}, a number {domain}") from None
        ok = math.isfinite(value)
        ok = ok and (lo is None or (value > lo if lo_open else value >= lo))
        ok = ok and (hi is None or (value < hi if hi_open else value <= hi))
        if not ok:
            raise argparse.ArgumentTypeError(f"{_shown(text)}: expected {what}, a finite number {domain}")
        return value

    parse.__name__ = "number"
    parse.option_domain = True  # type: ignore[attr-defined]
    parse.domain = domain  # type: ignore[attr-defined]  # (the help states it: cli.state_ranges)
    parse.bounds = (lo, hi)  # type: ignore[attr-defined]
    return parse


def integer(lo: int | None = None, hi: int | None = None, *, what: str = "a whole number") -> Callable[[str], int]:
    """An argparse ``type``: a whole number in ``[lo, hi]``."""
    domain = _range_text(lo, hi, False, False)

    def parse(text: str) -> int:
        digits = text.strip().lstrip("+-")
        if not digits.isdigit() or not digits.isascii():
            raise argparse.ArgumentTypeError(f"{_shown(text)}: expected {what}, a whole number {domain}")
        if len(digits) > _MAX_DIGITS:
            raise argparse.ArgumentTypeError(f"{_shown(text)}: expected {what}, a whole number {domain} ({len(digits)} digits)")
        value = int(text)
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{_shown(text)}: expected {what}, a whole number {domain}")
        return value

    parse.__name__ = "integer"
    parse.option_domain = True  # type: ignore[attr-defined]
    parse.domain = domain  # type: ignore[attr-defined]
    parse.bounds = (lo, hi)  # type: ignore[attr-defined]
    return parse


def states_range(help_text: str, lo: float | None, hi: float | None) -> bool:
    """Whether an option's help already gives both ends of its range (as the errors write them, or plain)."""

    def said(x: float | None) -> bool:  # (as a whole number: the 0 of "0.05" is not a bound of 0)
        if x is None:
            return True
        spelled = {_fmt(x), _fmt(abs(x)), str(x), f"{x:g}"}
        spelled |= {re.sub(r"e\+?(-?)0*(\d)", r"e\1\2", t) for t in spelled}  # 1e-06 as 1e-6, 1e+06 as 1e6
        return any(re.search(rf"(?<![\w.]){re.escape(t)}(?![\w.])", help_text) for t in spelled)

    return said(lo) and said(hi)


def state_ranges(parser: argparse.ArgumentParser) -> None:
    """Add its range to the help of every option of ``parser`` with a domain whose help does not give it
    (the README's limits: each option's help gives its range; the errors already name it)."""
    for a in parser._actions:
        domain, bounds = getattr(a.type, "domain", None), getattr(a.type, "bounds", None)
        if domain and bounds and a.help and a.help != argparse.SUPPRESS and not states_range(a.help, *bounds):
            a.help = f"{a.help}; range: {domain}"


def label(max_length: int = 80) -> Callable[[str], str]:
    """An argparse ``type``: printable text on one line (no control characters), at most ``max_length``."""

    def parse(text: str) -> str:
        if not text.isprintable():
            bad = next(ch for ch in text if not ch.isprintable())
            raise argparse.ArgumentTypeError(f"{_shown(text)}: expected printable text on one line (found U+{ord(bad):04X})")
        if len(text) > max_length:
            raise argparse.ArgumentTypeError(f"{_shown(text)}: expected at most {max_length} characters, got {len(text)}")
        return text

    parse.__name__ = "label"
    parse.option_domain = True  # type: ignore[attr-defined]
    return parse


class Given(argparse.Action):
    """Store the value and note that it was given (``_DEST_given``): a default that is also a valid value
    cannot tell an option given without effect from one left alone. (The note starts with ``_``: not a
    judge option, so audit rows and their resume keys are the same.)"""

    holds_one_value = True  # given twice is a usage error (mjmotion.cli), as for a plain store

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any, option_string: str | None = None) -> None:
        setattr(namespace, self.dest, values)
        setattr(namespace, f"_{self.dest}_given", True)


#: The prop kinds (``mjmotion.mjcf.PROP_PRESETS``, named here so a wrong one is refused before MuJoCo loads or a clip is read).
PROP_KINDS = ("club", "bat")


def prop_text(text: str) -> str:
    """An argparse ``type``: one ``--prop`` value, ``KIND`` or ``KIND:JOINT`` of a known kind (the joint is
    checked once the clip is read: ``mjmotion.commands._common.check_prop_joints``)."""
    kind, _, joint = text.partition(":")
    if not kind or not text.isprintable() or (":" in text and not joint):
        raise argparse.ArgumentTypeError(f"{_shown(text)}: expected KIND or KIND:JOINT (e.g. club or club:rwrist)")
    if kind not in PROP_KINDS:
        raise argparse.ArgumentTypeError(f"{_shown(text)}: unknown prop {kind!r}; expected {' or '.join(PROP_KINDS)} (KIND or KIND:JOINT)")
    return text


prop_text.option_domain = True  # type: ignore[attr-defined]  # (its errors name the option: mjmotion.cli)


class UniqueProps(argparse.Action):
    """``--prop KIND[:JOINT]``, repeatable, each kind once (two props of one kind share a name in the model)."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs: Any):
        kwargs.setdefault("default", [])
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any, option_string: str | None = None) -> None:
        text = str(values)
        try:
            prop_text(text)
        except argparse.ArgumentTypeError as e:
            raise argparse.ArgumentError(None, f"{option_string} {e}") from None
        kind = text.partition(":")[0]
        items = list(getattr(namespace, self.dest, None) or [])
        if any(str(v).partition(":")[0] == kind for v in items):
            raise argparse.ArgumentError(None, f"{option_string} {_shown(text)}: a {kind} is given twice; give each kind of prop once")
        setattr(namespace, self.dest, [*items, text])


# --- domains shared by several verbs -------------------------------------------------------------
#: A clip frame rate (resampling): the frame rates a BVH file may declare.
FPS = number(MIN_FPS, MAX_FPS, what="a frame rate in frames per second")
#: A video frame rate.
VIDEO_FPS = number(MIN_VIDEO_FPS, MAX_VIDEO_FPS, what="a video frame rate in frames per second")
#: A world coordinate in metres (balls, hit targets and offsets).
COORD = number(-1000.0, 1000.0, what="a coordinate in metres")
#: A velocity component in m/s (a ball: a fast bowl is 45 m/s).
VELOCITY = number(-1000.0, 1000.0, what="a velocity in m/s")
#: A frame index of a clip (its range is checked once the clip is read).
FRAME = integer(0, MAX_FRAMES - 1, what="a frame index")
#: A frame inside a clip, neither its first nor its last (a hit or an abort needs a frame either side).
INNER_FRAME = integer(1, MAX_FRAMES - 2, what="a frame index inside the clip (not its first or last)")
#: A contact height threshold (metres) and speed threshold (m/s).
CONTACT_HEIGHT = number(0.0, 1.0, lo_open=True, what="a contact height in metres")
CONTACT_SPEED = number(0.0, 100.0, lo_open=True, what="a contact speed in m/s")


# --- what an option implies for the clips it applies to -------------------------------------------
def resample(motion: Motion, fps: float, option: str = "--fps") -> Motion:
    """``motion`` at ``fps``; the frames it would make are checked first (caps.MAX_FRAMES,
    MAX_JOINT_FRAMES), and the message names ``option``."""
    check_resample(motion, fps, option)
    return motion.resample(fps)


def check_resample(motion: Motion, fps: float, option: str = "--fps") -> None:
    frames = math.floor(motion.duration * fps + 1e-9) + 1  # as Motion.resample counts them
    try:
        check_motion_size(frames, motion.skeleton.n_joints, f"a {motion.duration:.4g} s clip at {fps:g} fps")
    except MjmotionError as e:
        raise MjmotionError(f"{option} {fps:g}: {e}") from None


def check_frame(frame: int, n_frames: int, option: str, allow_negative: bool = False) -> int:
    """A frame index within a clip of ``n_frames`` frames (negative from the end if allowed); returns it as ≥ 0."""
    lo = -n_frames if allow_negative else 0
    if not lo <= frame < n_frames:
        raise MjmotionError(f"{option} {frame}: outside the clip's frames 0..{n_frames - 1}" + (" (or -1 for the last)" if allow_negative else ""))
    return frame % n_frames


def check_actors(n: int, option: str = "the clips to render") -> None:
    """At most :data:`mjmotion.caps.MAX_ACTORS` characters in one scene."""
    if n > MAX_ACTORS:
        raise MjmotionError(f"{option}: {n} characters, more than the limit of {MAX_ACTORS} in one render")
