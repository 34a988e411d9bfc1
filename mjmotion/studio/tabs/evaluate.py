"""Evaluate tab (docs METRICS.md): the metrics of the clip on screen; contact frames coloured on the
feet as it plays; penetration and skate frames marked on the timeline."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import engine
from ..scene import CONTACT_RGB
from . import table


class EvaluateTab:
    def __init__(self, session: Any):
        self.s = session
        gui = session.client.gui
        self.button = gui.add_button("Evaluate shown clip")
        self.strip = gui.add_image(np.zeros((2, 2, 3), np.uint8), label="timeline", visible=False)
        self.legend = gui.add_markdown("")
        self.report = gui.add_markdown("")
        self.result: engine.Evaluation | None = None
        self._actor: Any = None
        self._last_colors: tuple[Any, dict[int, tuple[int, int, int]]] | None = None
        self.button.on_click(lambda e: self.run())

    def run(self) -> None:
        a = self.s.shown
        if a is None or a.motion is None:
            self.s.set_status("show a clip first (the live stream is measured once saved and loaded)", error=True)
            return
        motion, props = a.motion, a.props

        def job(progress):
            e = engine.evaluate(motion, props, progress)
            return e, engine.timeline_image(e, motion.fps)

        self.s.submit("evaluate", job, lambda out: self._done(out, a), label="Evaluate")

    def _done(self, out: Any, actor: Any) -> None:
        e, img = out
        if actor is not self.s.shown:  # another clip was shown while it ran: its report would be of the wrong clip
            self.s.set_status(f"evaluated {actor.label}, which is no longer shown; press Evaluate again", error=True)
            return
        self.result, self._actor = e, actor
        self.strip.image = img
        self.strip.visible = True
        runs = _run_starts(e.penetrating | e.skating)
        self.s.timeline.marks = tuple((int(f), "!") for f in runs[:20]) or None
        pen, sk = int(e.penetrating.sum()), int(e.skating.sum())
        self.legend.content = f"green: foot in contact · red: penetration ({pen} frames) · orange: skate ({sk} frames); marks on the Frame slider"
        self.report.content = table(e.rows)
        self.s.set_status(f"evaluated {actor.label}")

    def clear(self) -> None:
        """Forget the report: it measured a clip no longer shown (its marks would sit on another timeline)."""
        if self.result is None:
            return
        last = self._last_colors
        if last is not None and last[1]:
            last[0].set_geom_colors({})  # the feet untinted (a drag keeps the same drawings)
        self.result, self._actor, self._last_colors = None, None, None
        self.strip.visible = False
        self.legend.content = self.report.content = ""
        self.s.timeline.marks = None

    def on_frame(self, frame: int) -> None:
        e, a = self.result, self._actor
        if e is None or a is None or a not in self.s.cast:
            return
        f = min(frame, len(e.contacts) - 1)
        colors = {int(g): CONTACT_RGB for i, side in enumerate(e.sides) if e.contacts[f, i] for g in e.foot_geoms.get(side, ())}
        last = self._last_colors
        if last is None or last[0] is not a.drawing or last[1] != colors:  # a new drawing (Character menu) starts untinted
            a.drawing.set_geom_colors(colors)
            self._last_colors = (a.drawing, colors)


def _run_starts(mask: np.ndarray) -> np.ndarray:
    m = np.asarray(mask, dtype=bool)
    return np.flatnonzero(m & ~np.r_[False, m[:-1]])
