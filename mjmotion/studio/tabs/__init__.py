"""The Studio's tabs, one module each, and the widgets they share; :func:`mjmotion.studio.tabs.build.build_tabs`
adds them to a page in the issue's order (in a module of its own, so that this package, which every tab
imports, imports no tab)."""

from __future__ import annotations

import re
from typing import Any

NONE = "—"


def pick(names: list[str], pattern: str, exclude: str = r"$^", default: str | None = None) -> str:
    """The first name matching ``pattern`` (regex, case-insensitive) and not ``exclude``; else ``default`` or the first name."""
    for n in names:
        if re.search(pattern, n, re.IGNORECASE) and not re.search(exclude, n, re.IGNORECASE):
            return n
    return default if default is not None else names[0]


def refresh(dropdown: Any, names: list[str], optional: bool = False) -> None:
    """New options for a clip menu, keeping its choice when it still exists."""
    options = ([NONE] if optional else []) + list(names)
    keep = dropdown.value if dropdown.value in options else options[0]
    dropdown.options = tuple(options)
    dropdown.value = keep


def table(rows: list[tuple[str, Any]]) -> str:
    """A two-column Markdown table of labelled values."""
    lines = ["| | |", "|---|---|"]
    for k, v in rows:
        shown = f"{v:.4g}" if isinstance(v, float) else str(v)
        lines.append(f"| {k} | {shown} |")
    return "\n".join(lines)
