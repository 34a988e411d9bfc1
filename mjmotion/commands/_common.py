"""Options and loading shared by the verbs.

Only the standard library at import: the CLI imports every verb module to list the verbs, so
NumPy and the readers load when a verb runs (see :mod:`mjmotion.cli`).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import MjmotionError, OutputExistsError, printable
from ..outputs import check_output

if TYPE_CHECKING:
    from ..mjcf import Prop
    from ..skeleton import Motion


def add_input_options(p: argparse.ArgumentParser, trim: bool = True) -> None:
    """``--units`` and ``--up`` for verbs that read BVH files, and ``--keep-start`` for those that
    read their frames (``trim``; see :func:`load`)."""
    p.add_argument(
        "--units",
        default="auto",
        metavar="UNIT",
        help="file length unit: auto (detect from the skeleton's size), m, cm, mm, asf (CMU's 5.644 cm), "
        "or a number of metres per unit, 1e-6 to 1000 (default: auto)",
    )
    p.add_argument(
        "--up",
        choices=("y", "z"),
        default="y",
        help="the file's up axis (default: y, the BVH norm; mjmotion info shows the axis the body stands along)",
    )
    if trim:
        p.add_argument(
            "--keep-start",
            action="store_true",
            help="keep a leading T-pose/transition (cgspeed daz frames 0-3), which is skipped unless a frame range is given",
        )


def add_output_options(p: argparse.ArgumentParser, required: bool = True, help: str = "output file") -> None:
    p.add_argument("-o", "--output", required=required, metavar="OUT", help=help)
    p.add_argument("--force", action="store_true", help="replace OUT if it exists")


#: Metres per file unit ``--units`` takes (a number): the range a written clip's unit must stay in to be read.
UNITS_RANGE = (1e-6, 1e3)


def units_scale(text: str) -> float | None:
    """Metres per file unit from ``--units`` (``None`` = detect)."""
    from ..skeleton import ASF_UNIT, CM, METRE, MM

    if text == "auto":
        return None
    units = {"m": METRE, "cm": CM, "mm": MM, "asf": ASF_UNIT}
    if text in units:
        return units[text]
    try:
        value = float(text)
    except ValueError:
        raise MjmotionError(f"--units {text!r}: expected auto, m, cm, mm, asf or a number of metres per unit") from None
    if not (UNITS_RANGE[0] <= value <= UNITS_RANGE[1]):  # (NaN fails too)
        raise MjmotionError(f"--units {text!r}: expected a number of metres per unit from 1e-6 to 1000")
    return value


def read_motion(path: str, args: argparse.Namespace) -> Motion:
    """Read a BVH clip as the file holds it, with the verb's ``--units``/``--up``.

    Refuses a clip that is one of the verb's outputs (``-o``, ``--json``, ``--plot``): inputs named
    inside another input (a stream script's clips) escape the checks made before the work starts.
    """
    from .. import bvh

    for option in ("output", "json", "plot"):
        out = getattr(args, option, None)
        if isinstance(out, str) and out and check_same_file(out, path):
            raise OutputExistsError(f"{out}: is an input of this command ({path}); choose another output path")
    m = bvh.read(path, scale=units_scale(getattr(args, "units", "auto")), up=getattr(args, "up", "y"))
    check_prop_joints(m, args)
    return m


def check_model(m: Motion, path: str) -> None:
    """Refuse a clip whose skeleton no MuJoCo model takes (too deep, too many joints), naming its file (the
    model is compiled later, for every clip of a render at once: the message did not say which)."""
    from .. import mjcf

    try:
        mjcf.check_model_size(m.skeleton)
    except MjmotionError as e:
        raise naming(path, e) from None


def check_prop_joints(m: Motion, args: argparse.Namespace) -> None:
    """Refuse a ``--prop KIND:JOINT`` that names no joint of ``m`` as soon as the clip is read, before any
    ``note:`` line about it (a note, then the error, read as if the work had begun)."""
    props = getattr(args, "prop", None)
    for text in [props] if isinstance(props, str) else props or ():  # (hit's --prop is one value)
        if ":" in text:
            prop_option(m, text)


def load_first(
    path: str, args: argparse.Namespace, frames: str | None = None, *, trim: bool = True, note: bool = True, frames_option: str = "--frames"
) -> tuple[Motion, int]:
    """A clip as every verb reads it, and the file frame it starts at.

    ``frames`` (``A:B``, the file's frame numbers; its errors name ``frames_option``) selects frames; without it a leading T-pose
    or transition (:func:`mjmotion.trim.leading_transient`) is skipped unless ``--keep-start``
    (or ``trim=False``), with one note line on stderr naming the frames (``note``). With ``note``, a
    clip whose body stands along another axis than ``--up`` reads gets a note line too
    (:func:`mjmotion.upright.up_note`: a cleanup, render or blend of a body lying on its side).
    """
    m = read_motion(path, args)
    if note:
        note_up(m, path)
    if frames:
        sl = parse_frames(frames, m.n_frames, frames_option)
        return m[sl], sl.indices(m.n_frames)[0]
    if not trim:
        return m, 0
    return trim_start(m, path, args, note)


#: Statures (m) outside this range are no person's: the clip's units were read wrong (a note says so).
HUMAN_STATURE_M = (0.5, 3.0)


def stature_note(motion: Motion, units: str) -> list[str]:
    """A note when ``motion``'s stature is no person's: ``--units m`` on a centimetre clip read 178 m and
    every ground metric empty, without a word of why."""
    s = motion.skeleton.stature()
    lo, hi = HUMAN_STATURE_M
    if lo <= s <= hi:
        return []
    return [
        f"note: {motion.name}: stature {s:.3g} m, no person's ({lo:g}-{hi:g} m): its units are probably not what "
        f"--units {units} reads (mjmotion info shows the stature each --units gives)"
    ]


def note_up(m: Motion, path: str) -> None:
    """The ``note:`` line on stderr for a clip whose body stands along another file axis than ``--up``
    reads (:func:`mjmotion.upright.up_note`), if it does."""
    from ..upright import up_note

    for line in up_note(m, path):
        sys.stderr.write(printable(line) + "\n")


def trim_start(m: Motion, path: str, args: argparse.Namespace, note: bool = True) -> tuple[Motion, int]:
    """``m`` without a leading T-pose or transition (unless ``--keep-start``) and the frame it now starts
    at, with one note line on stderr naming the frames skipped (``note``)."""
    from ..trim import skip_leading_transient

    m, k = skip_leading_transient(m, getattr(args, "keep_start", False))
    if k and note:
        note_skipped(path, k)
    return m, k


def note_skipped(name: str, k: int) -> None:
    """The one note line on stderr for a clip whose first ``k`` frames were left out."""
    shown = "frame 0" if k == 1 else f"frames 0-{k - 1}"
    sys.stderr.write(printable(f"note: {name}: skipped {shown}, a leading T-pose, transition or glitch (--keep-start keeps them)") + "\n")


def load(
    path: str, args: argparse.Namespace, frames: str | None = None, *, trim: bool = True, note: bool = True, frames_option: str = "--frames"
) -> Motion:
    """:func:`load_first` without the start frame."""
    return load_first(path, args, frames, trim=trim, note=note, frames_option=frames_option)[0]


def clip_frame(frame: int, first: int, option: str, n_frames: int | None = None, *, inner: bool = False, why: str = "") -> int:
    """A file frame number given in ``option`` as a frame of the clip :func:`load_first` read
    starting at file frame ``first`` (negative numbers count from the end, unchanged).

    With ``n_frames`` (the clip's, as read) a frame outside it is refused in the file's numbers, as
    the user gave it; ``inner``: the clip's first and last frames are refused too (``why`` says why)."""
    if frame >= 0 and first and frame < first:
        raise MjmotionError(f"{option} {frame}: inside the skipped leading T-pose/transition (frames 0-{first - 1}); add --keep-start")
    k = frame - first if frame >= 0 else frame
    if n_frames is not None:
        lo, hi = (1, n_frames - 2) if inner else (0, n_frames - 1)
        at = k + n_frames if k < 0 else k
        if hi < lo:
            raise MjmotionError(f"{option} {frame}: a clip of {n_frames} frames has no frame {'inside it' if inner else ''}{why}".rstrip())
        if not lo <= at <= hi:
            shown = f"{first + lo}..{first + hi}" + (f" (or {lo - n_frames}..{hi - n_frames} from the end)" if frame < 0 else "")
            raise MjmotionError(f"{option} {frame}: outside the clip's {'inner ' if inner else ''}frames {shown}{why}")
    return k


def add_bowler_option(p: argparse.ArgumentParser) -> None:
    """``--bowler DX DY``: where a ``--delivery`` comes from (checked by :func:`check_bowler`)."""
    from ._options import COORD, Given

    p.add_argument(
        "--bowler",
        nargs=2,
        type=COORD,
        action=Given,
        default=(0.0, 1.0),
        metavar=("DX", "DY"),
        help="horizontal direction to the bowler, not 0 0 (with --delivery; default 0 1)",
    )


def check_bowler(args: argparse.Namespace) -> None:
    """``--bowler DX DY`` (a delivery's direction) is not 0 0 and comes with ``--delivery``: refused
    before any clip is read."""
    dx, dy = args.bowler
    if not math.hypot(dx, dy) > 1e-9:  # (1e-300 passed "not 0" and failed later, with no option named)
        raise MjmotionError(f"--bowler {dx:g} {dy:g}: expected a horizontal direction to the bowler, not 0 0 (at least 1e-9 long)")
    if getattr(args, "_bowler_given", False) and args.delivery is None:
        if getattr(args, "ball_release", None) is not None:  # that ball flies from where it is released
            raise MjmotionError(f"--bowler {dx:g} {dy:g}: only a --delivery uses it, not a --ball-release ball; leave --bowler out")
        raise MjmotionError(f"--bowler {dx:g} {dy:g}: the direction a --delivery comes from; give --delivery PACE too, or leave --bowler out")


def check_same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two paths name the same file (through links too)."""
    try:
        if os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b):
            return True
    except OSError:
        pass
    return os.path.realpath(a) == os.path.realpath(b)  # (a symlink loop is not an error here)


#: What each kind of output is written as, by the suffix its path must end in.
WRITTEN_AS = {".bvh": "a BVH clip", ".xml": "a MuJoCo model (MJCF XML)", ".npz": "a NumPy .npz archive", ".json": "JSON", ".png": "a PNG image"}


def check_suffix(path: str | os.PathLike[str], option: str, suffix: str) -> None:
    """Refuse an output path that does not end in ``suffix`` (any case): a model written to
    ``out.bvh`` or a clip to ``out.npz`` is a trap for the next command that reads it. The error
    names ``option`` (none for a positional argument)."""
    if Path(path).suffix.lower() != suffix:
        where = f"{option} {os.fspath(path)}" if option else os.fspath(path)
        raise MjmotionError(f"{where}: this is written as {WRITTEN_AS[suffix]}; expected a {suffix} path")


def extra_output(path: str | None, option: str, suffix: str, force: bool, inputs: Iterable[str | os.PathLike[str]]) -> Path | None:
    """A report or plot (``--json``, ``--plot``, ``--truth``) checked before the work as ``-o`` is
    (:func:`mjmotion.outputs.check_output`), then its suffix (:func:`check_suffix`); ``None`` when not given."""
    return _checked_output(path, option, suffix, force, inputs) if path else None


def output_path(args: argparse.Namespace, *inputs: str, suffix: str | None = None, option: str = "-o") -> Path:
    """Check ``args.output`` before the work starts (exists → needs --force; never an input; ends
    in ``suffix`` if one is given; errors name ``option``, "" for a positional argument)."""
    return _checked_output(args.output, option, suffix, bool(getattr(args, "force", False)), inputs)


def _checked_output(path: str, option: str, suffix: str | None, force: bool, inputs: Iterable[str | os.PathLike[str]]) -> Path:
    """An output path checked before the work (:func:`mjmotion.outputs.check_output`), then its suffix."""
    out = check_output(path, force=force, inputs=inputs)
    if suffix is not None:
        check_suffix(out, option, suffix)
    return out


def parse_frames(text: str, n_frames: int, option: str = "--frames") -> slice:
    """``A:B`` (Python-style, negatives allowed, either side optional) → a checked slice; errors name ``option``."""
    a, sep, b = text.partition(":")
    if not sep:
        raise MjmotionError(f"{option} {text!r}: expected A:B (e.g. 10:200)")
    try:
        start = int(a) if a.strip() else None
        stop = int(b) if b.strip() else None
    except ValueError:
        raise MjmotionError(f"{option} {text!r}: A and B must be whole numbers") from None
    sl = slice(start, stop)
    lo, hi, _ = sl.indices(n_frames)
    if hi <= lo:
        raise MjmotionError(f"{option} {text}: selects no frames of a {n_frames}-frame clip")
    return sl


def prop_option(motion: Motion, text: str) -> Prop:
    """The prop a ``--prop`` value names, the same in every verb (so ``evaluate`` measures the prop
    ``hit`` moved): ``KIND:JOINT`` is held by JOINT along its bone (:func:`mjcf.parse_prop_option`);
    ``KIND`` alone (``club``, ``bat``) is fitted to both hands at the clip's address frames
    (:func:`mjmotion.hitpoint.fit_club`), as ``hit --prop`` fits it."""
    from .. import mjcf

    kind, sep, _ = text.partition(":")
    if sep or kind not in mjcf.PROP_PRESETS:
        try:
            return mjcf.parse_prop_option(motion.skeleton, text)
        except MjmotionError as e:
            raise MjmotionError(str(e) if str(e).startswith("--prop") else f"--prop {text}: {e}") from None
    from ..hitpoint import fit_club

    return fit_club(motion, kind)


def named(path: str | Sequence[str], message: str) -> str:
    """``message`` with ``path`` in front, unless it already begins with the file or an option
    (the judge's own errors speak of "a clip": a user with many files needs to know which);
    ``path`` may be several files, named together ("A and B": a registration of two clips)."""
    paths = [path] if isinstance(path, str) else list(path)
    return message if message.startswith((*paths, "-")) else f"{' and '.join(paths)}: {message}"


def naming(path: str | Sequence[str], e: MjmotionError) -> MjmotionError:
    """``e`` as :func:`named` words it."""
    text = named(path, str(e))
    return e if text == str(e) else MjmotionError(text)
