"""Options and loading shared by the verbs."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from .. import bvh
from ..errors import MjmotionError, OutputExistsError
from ..outputs import check_output
from ..skeleton import ASF_UNIT, CM, METRE, MM, Motion

_UNITS = {"m": METRE, "cm": CM, "mm": MM, "asf": ASF_UNIT}


def add_input_options(p: argparse.ArgumentParser) -> None:
    """``--units`` and ``--up`` for verbs that read BVH files."""
    p.add_argument(
        "--units",
        default="auto",
        metavar="UNIT",
        help="file length unit: auto (detect from the skeleton's size), m, cm, mm, asf (CMU's 5.644 cm), "
        "or a number of metres per unit, 1e-6 to 1000 (default: auto)",
    )
    p.add_argument("--up", choices=("y", "z"), default="y", help="the file's up axis (default: y, the BVH norm)")


def add_output_options(p: argparse.ArgumentParser, required: bool = True, help: str = "output file") -> None:
    p.add_argument("-o", "--output", required=required, metavar="OUT", help=help)
    p.add_argument("--force", action="store_true", help="replace OUT if it exists")


def units_scale(text: str) -> float | None:
    """Metres per file unit from ``--units`` (``None`` = detect)."""
    if text == "auto":
        return None
    if text in _UNITS:
        return _UNITS[text]
    try:
        value = float(text)
    except ValueError:
        raise MjmotionError(f"--units {text!r}: expected auto, m, cm, mm, asf or a number of metres per unit") from None
    if not (1e-6 <= value <= 1e3):  # (NaN fails too)
        raise MjmotionError(f"--units {text!r}: expected a number of metres per unit from 1e-6 to 1000")
    return value


def load(path: str, args: argparse.Namespace) -> Motion:
    """Read a BVH clip with the verb's ``--units``/``--up``.

    Refuses a clip that is the verb's ``-o`` output: inputs named inside another input (a
    stream script's clips) escape the check ``output_path`` makes before the work starts.
    """
    out = getattr(args, "output", None)
    if out and check_same_file(out, path):
        raise OutputExistsError(f"{out}: is an input of this command ({path}); choose another output path")
    return bvh.read(path, scale=units_scale(getattr(args, "units", "auto")), up=getattr(args, "up", "y"))


def check_same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two paths name the same file (through links too)."""
    try:
        if os.path.exists(a) and os.path.exists(b) and os.path.samefile(a, b):
            return True
    except OSError:
        pass
    return os.path.realpath(a) == os.path.realpath(b)  # (a symlink loop is not an error here)


def output_path(args: argparse.Namespace, *inputs: str) -> Path:
    """Check ``args.output`` before the work starts (exists → needs --force; never an input)."""
    return check_output(args.output, force=bool(getattr(args, "force", False)), inputs=inputs)


def parse_frames(text: str, n_frames: int) -> slice:
    """``A:B`` (Python-style, negatives allowed, either side optional) → a checked slice."""
    a, sep, b = text.partition(":")
    if not sep:
        raise MjmotionError(f"--frames {text!r}: expected A:B (e.g. 10:200)")
    try:
        start = int(a) if a.strip() else None
        stop = int(b) if b.strip() else None
    except ValueError:
        raise MjmotionError(f"--frames {text!r}: A and B must be whole numbers") from None
    sl = slice(start, stop)
    lo, hi, _ = sl.indices(n_frames)
    if hi <= lo:
        raise MjmotionError(f"--frames {text}: selects no frames of a {n_frames}-frame clip")
    return sl
