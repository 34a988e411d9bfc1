"""Short text forms of the lab's values: one-line ``repr``s and Markdown tables.

``print(motion)`` or a report at the prompt shows what it is (name, joints, frames, rate,
headline numbers) rather than every array; ``to_markdown()`` on a report gives a two-column
table for a notebook or a pull request. Numbers are rounded for reading (four significant
digits); ``to_dict``/``to_json`` keep full precision. Only the standard library: the data model
imports this.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any


def number(value: object) -> str:
    """A value for people: floats to four significant digits (``–`` for NaN), booleans yes/no."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        return f"{value:.4g}" if abs(value) < 1e4 else f"{value:.3e}"
    if value is None:
        return "–"
    if isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) for v in value):
        return "(" + ", ".join(number(v) for v in value) + ")"
    return str(value)


def clip(kind: str, name: str, n_joints: int, n_frames: int, fps: float) -> str:
    """``Motion('walk', 22 joints, 241 frames at 60 fps, 4 s)``."""
    seconds = (n_frames - 1) / fps if n_frames > 0 else 0.0
    return f"{kind}({name!r}, {n_joints} joints, {n_frames} frames at {fps:.6g} fps, {seconds:.4g} s)"


def fields(kind: str, *parts: str, **values: object) -> str:
    """``Report('walk', planted_skate_mm_per_s=12.3, pop_frames=0)``: ``parts`` as written (a name's
    ``repr``, ``"240 × 180 grid"``), then a few headline values rounded for reading."""
    shown = [*parts, *(f"{k}={number(v)}" for k, v in values.items())]
    return f"{kind}({', '.join(shown)})"


def markdown_table(rows: Mapping[str, Any] | Iterable[tuple[str, Any]], header: tuple[str, str] = ("", "value")) -> str:
    """A two-column Markdown table of labelled values (a mapping or ``(label, value)`` pairs)."""
    items = rows.items() if isinstance(rows, Mapping) else rows
    lines = [f"| {header[0]} | {header[1]} |", "|---|---|"]
    lines += [f"| {label} | {number(value)} |" for label, value in items]
    return "\n".join(lines) + "\n"
