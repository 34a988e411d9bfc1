"""The Studio's tabs, one module each, and the widgets they share; :func:`mjmotion.studio.tabs.build.build_tabs`
adds them to a page in the issue's order (in a module of its own, so that this package, which every tab
imports, imports no tab)."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

NONE = "—"


def pick(names: list[str], pattern: str, exclude: str = r"$^", default: str | None = None) -> str:
    """The first name matching ``pattern`` (regex, case-insensitive) and not ``exclude``; else ``default`` or the first name."""
    for n in names:
        if re.search(pattern, n, re.IGNORECASE) and not re.search(exclude, n, re.IGNORECASE):
            return n
    return default if default is not None else names[0]


def partner(library: Any, first: str, pattern: str, exclude: str = r"$^", default: str | None = None) -> str | None:
    """Like :func:`pick`, among the clips of ``first``'s skeleton topology other than ``first`` (clips of two
    skeletons cannot be blended or streamed together); ``default`` when there is none."""
    skeleton = library.get(first).motion.skeleton
    kin = [n for n in library.names() if n != first and library.get(n).motion.skeleton.same_topology(skeleton)]
    if not kin:
        return default
    return pick(kin, pattern, exclude, default=kin[0] if default is None else default)


def refresh(dropdown: Any, names: list[str], optional: bool = False) -> None:
    """New options for a clip menu, keeping its choice when it still exists."""
    options = ([NONE] if optional else []) + list(names)
    keep = dropdown.value if dropdown.value in options else options[0]
    dropdown.options = tuple(options)
    dropdown.value = keep


def clamp(slider: Any) -> float:
    """A slider's value within its range: a number typed into its box is not held to the range by the page
    (a Speed of -3 ran the playhead backwards for good), so one outside is put back in and shown."""
    v = float(slider.value)
    lo, hi = float(slider.min), float(slider.max)
    inside = min(max(v, lo), hi) if math.isfinite(v) else lo
    if inside != v:
        slider.value = inside
    return inside


def weights_of(sliders: list[Any]) -> tuple[np.ndarray, bool]:
    """Weights from sliders (each held to its range), scaled to sum to 1 (all on the first when all are 0),
    and whether they had to be scaled (the page says so: the ``blend`` verb refuses weights that do not sum to 1)."""
    v = np.array([clamp(h) for h in sliders])
    if v.sum() <= 0:
        return np.eye(len(v))[0], True
    return v / v.sum(), not math.isclose(float(v.sum()), 1.0, abs_tol=1e-9)


def table(rows: list[tuple[str, Any]]) -> str:
    """A two-column Markdown table of labelled values."""
    lines = ["| | |", "|---|---|"]
    for k, v in rows:
        shown = f"{v:.4g}" if isinstance(v, float) else str(v)
        lines.append(f"| {k} | {shown} |")
    return "\n".join(lines)
