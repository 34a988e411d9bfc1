"""The Studio's tabs on a page, in the issue's order."""

from __future__ import annotations

from typing import Any


def build_tabs(session: Any, group: Any) -> dict[str, Any]:
    """One tab of each kind in ``group`` (a viser tab group) for ``session``: ``{title: tab}``."""
    from . import blend, evaluate, hit, stream, vary

    out: dict[str, Any] = {}
    for name, cls in (
        ("Blend", blend.BlendTab),
        ("Stream", stream.StreamTab),
        ("Hit", hit.HitTab),
        ("Vary", vary.VaryTab),
        ("Evaluate", evaluate.EvaluateTab),
    ):
        with group.add_tab(name):
            out[name] = cls(session)
    return out
