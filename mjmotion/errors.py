"""Errors a user can act on. The CLI prints them as one ``error:`` line and exits with status 2."""

from __future__ import annotations

import math
import numbers


class MjmotionError(Exception):
    """Base of every error caused by input (a file, an argument, an impossible request)."""


class BvhError(MjmotionError):
    """A BVH file that cannot be read: names the file, the line and what was expected."""

    def __init__(self, path: str, line: int | None, message: str):
        self.path = path
        self.line = line
        self.message = message
        where = f"{path}:{line}" if line is not None else path
        super().__init__(f"{where}: {message}")


class SkeletonMismatchError(MjmotionError):
    """Clips whose skeleton topologies differ where one topology is required."""


class OutputExistsError(MjmotionError):
    """An output path exists (and ``--force`` was not given) or names an input."""


class AlreadyExistsError(OutputExistsError):
    """An output path is an existing file that ``--force`` would replace (not an input, not a folder)."""


def is_real(value: object) -> bool:
    """Whether ``value`` is a finite real number (Python's or NumPy's; ``True`` is not one)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def is_whole(value: object) -> bool:
    """Whether ``value`` is a whole number (Python's or NumPy's; ``True`` is not one, nor ``3.0``)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def require_number(label: str, value: object, low: float = 0.0, strict: bool = True, high: float | None = None, what: str = "") -> None:
    """Refuse anything but a finite real number above ``low`` (``strict``) or at least ``low``, and at
    most ``high``; the message names ``label`` (an option or a field) and, if given, ``what`` it is."""
    ok = is_real(value)
    ok = ok and (value > low if strict else value >= low) and (high is None or value <= high)  # type: ignore[operator]
    if not ok:
        bound = f"in ({low:g}, {high:g}]" if high is not None else f"{'>' if strict else '≥'} {low:g}"
        shown = f"{value:g}" if isinstance(value, numbers.Real) and not isinstance(value, bool) else repr(value)
        raise MjmotionError(f"{label} {shown}: expected {what + ', ' if what else ''}a finite number {bound}")


def printable(text: object) -> str:
    """``text`` with every non-printable character (line breaks, terminal escapes, bidi controls)
    escaped as Python writes it: safe to print whatever a file or a user's argument holds. A byte of a
    file name that is not UTF-8 (held as a lone surrogate by Python) is written ``\\xNN``, the byte."""
    s = str(text)
    return s if s.isprintable() else "".join(ch if ch.isprintable() else _escaped(ch) for ch in s)


def _escaped(ch: str) -> str:
    return f"\\x{ord(ch) - 0xDC00:02x}" if "\udc80" <= ch <= "\udcff" else repr(ch)[1:-1]
