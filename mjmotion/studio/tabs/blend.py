"""Blend tab (seed 004 §6.3-6.4, the Motion Blender): clips, method, path search, weights; the grid
with its path and timewarp curve; the result played beside its inputs at corresponding frames."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..engine import BLEND_METHODS, PATH_METHODS, blend_weights, grid_image, make_blend
from . import NONE, clamp, faster, partner, pick, refresh, walking, weights_of

N_SLOTS = 3


class BlendTab:
    def __init__(self, session: Any):
        self.s = session
        gui = session.client.gui
        names = session.library.names()
        first = pick(names, "walk", "turn|warp", default=walking(session.library))
        second = partner(session.library, first, "run", "turn", default=faster(session.library, first)) or names[min(1, len(names) - 1)]
        self.clips = [
            gui.add_dropdown("Clip 1", tuple(names), initial_value=first),
            gui.add_dropdown("Clip 2", tuple(names), initial_value=second),
            gui.add_dropdown("Clip 3", (NONE, *names), initial_value=NONE),
        ]
        self.method = gui.add_dropdown("Method", BLEND_METHODS, initial_value=BLEND_METHODS[0])
        self.path = gui.add_dropdown("Path search", PATH_METHODS, initial_value="dp")
        self.threshold = gui.add_slider(
            "Threshold", 0.05, 1.0, 0.05, 0.35, hint="threshold search: cells above this fraction of the largest cost are never entered"
        )
        self.weights_kind = gui.add_dropdown("Weights", ("constant", "curve"), initial_value="constant")
        self.w_start = [gui.add_slider(f"Weight {k + 1}", 0.0, 1.0, 0.05, 0.5 if k < 2 else 0.0) for k in range(N_SLOTS)]
        self.w_end = [gui.add_slider(f"End weight {k + 1}", 0.0, 1.0, 0.05, (0.0, 1.0, 0.0)[k], visible=False) for k in range(N_SLOTS)]
        self.button = gui.add_button("Blend")
        self.note = gui.add_markdown("")
        self.grid = gui.add_image(np.zeros((2, 2, 3), np.uint8), label="grid", visible=False)
        self.weights_kind.on_update(lambda e: self._show_end_weights())
        self.button.on_click(lambda e: self.run())
        session.on_library(self._refresh)

    def _show_end_weights(self) -> None:
        for h in self.w_end:
            h.visible = self.weights_kind.value == "curve"

    def _refresh(self, names: list[str]) -> None:
        for k, d in enumerate(self.clips):
            refresh(d, names, optional=k == 2)

    def run(self) -> None:
        names = [d.value for d in self.clips if d.value != NONE]
        lib = self.s.library
        motions = [lib.get(n).motion for n in names]
        n = len(motions)
        w0, scaled = weights_of(self.w_start[:n])
        curve = self.weights_kind.value == "curve"
        if curve:
            w1, scaled_end = weights_of(self.w_end[:n])
            weights, scaled = blend_weights(w0, w1, motions[0].duration), scaled or scaled_end
        else:
            weights = w0
        shown_weights = f" Weights scaled to sum to 1: {', '.join(f'{x:.3g}' for x in w0)}." if scaled else ""
        method, path, thr = self.method.value, self.path.value, clamp(self.threshold)

        def job(progress):
            return make_blend(motions, weights, method, path, thr, progress), names, method, shown_weights

        self.s.submit("blend", job, self._done, label="Blend")

    def _done(self, out: Any) -> None:
        result, names, method, shown_weights = out
        lib = self.s.library
        shown = [("blend", result.motion, ())]
        for k, name in enumerate(names):
            m = lib.get(name).motion
            root, q, tr = m.sample(result.input_frames[:, k])
            shown.append((name, m.replace(root_positions=root, rotations=q, translations=tr, name=name), ()))
        self.s.show(shown)
        img = grid_image(result, (names[0], names[1]))
        if img is not None:
            self.grid.image = img
        self.grid.visible = img is not None
        at = "the same frame numbers" if method == "linear" else "their registered frames"
        self.note.content = f"{result.note}; {result.motion.n_frames} frames. Blend (blue) beside {', '.join(names)} at {at}.{shown_weights}"
        self.s.set_status(f"blended {' + '.join(names)}")
