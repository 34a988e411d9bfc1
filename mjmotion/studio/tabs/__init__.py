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


#: Mean horizontal root speed (m/s) of a walk, and a run's least multiple of it, for clips whose names
#: say neither (the CMU trials are numbered): the Blend and Stream tabs open on a walk and a faster gait.
WALK_SPEED = (0.8, 1.8)
FASTER = 1.3
#: The largest turn (degrees) between a straight walk's first and last quarters.
STRAIGHT_DEG = 20.0


def travel(motion: Any) -> tuple[float, float]:
    """A clip's mean horizontal root speed (m/s, its path sampled every 0.25 s, so sway is not counted)
    and its heading change (degrees) from its first quarter's displacement to its last's."""
    xy = np.asarray(motion.root_positions)[:, :2]
    if len(xy) < 8:
        return 0.0, 180.0
    every = max(1, round(0.25 * motion.fps))
    path = xy[::every]
    if len(path) < 2:  # shorter than 0.25 s: no path to measure
        return 0.0, 180.0
    speed = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum() / (((len(path) - 1) * every) / motion.fps))
    q = len(xy) // 4
    a, b = xy[q] - xy[0], xy[-1] - xy[-1 - q]
    norms = float(np.linalg.norm(a) * np.linalg.norm(b))
    turn = math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b) / norms)))) if norms > 0 else 180.0
    return speed, turn


def walking(library: Any) -> str | None:
    """The first clip that walks straight (:data:`WALK_SPEED`, :data:`STRAIGHT_DEG`), or ``None``."""
    for n in library.names():
        speed, turn = travel(library.get(n).motion)
        if WALK_SPEED[0] <= speed <= WALK_SPEED[1] and turn <= STRAIGHT_DEG:
            return n
    return None


def faster(library: Any, first: str) -> str | None:
    """The fastest clip of ``first``'s skeleton topology moving at least :data:`FASTER` times its speed (a
    run to a walk, a fast walk to a slow one), or ``None``."""
    motion = library.get(first).motion
    base = travel(motion)[0]
    best: tuple[float, str] | None = None
    for n in library.names():
        other = library.get(n).motion
        if n != first and other.skeleton.same_topology(motion.skeleton):
            speed = travel(other)[0]
            if base > 0 and speed >= FASTER * base and (best is None or speed > best[0]):
                best = (speed, n)
    return best[1] if best else None


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
