"""Vary tab (seed 003 §3): exaggerate or mute a shot with a scale, or abort it at a frame; the PCA score paths plotted."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import engine
from . import clamp, pick, refresh, table


class VaryTab:
    def __init__(self, session: Any):
        self.s = session
        gui = session.client.gui
        shots = session.library.shots() or session.library.names()
        self.clip = gui.add_dropdown("Shot", tuple(shots), initial_value=pick(shots, "drive|swing|golf"))
        self.mode = gui.add_dropdown("Variant", ("scale", "abort"), initial_value="scale")
        self.scale = gui.add_slider("Scale", 0.3, 2.0, 0.05, 1.3, hint="> 1 exaggerates, < 1 mutes (seed 003 §3.2.3)")
        self.abort = gui.add_slider("Abort frame", 1, 1000, 1, 60, hint="follow the shot to this frame, then return to the rest pose")
        self.cleanup = gui.add_checkbox("Clean up feet and grip", True)
        self.button = gui.add_button("Make variant")
        self.plot = gui.add_image(np.zeros((2, 2, 3), np.uint8), label="scores", visible=False)
        self.report = gui.add_markdown("")
        self.button.on_click(lambda e: self.run())
        self.clip.on_update(lambda e: self._fit_abort())
        self._fit_abort()
        session.on_library(lambda n: refresh(self.clip, session.library.shots() or n))

    def _fit_abort(self) -> None:
        """The Abort frame slider spans the chosen shot (1 to its second-to-last frame)."""
        if self.clip.value in self.s.library.names():
            n = self.s.library.get(self.clip.value).motion.n_frames
            self.abort.max = max(n - 2, 2)
            if float(self.abort.value) > self.abort.max:
                self.abort.value = self.abort.max

    def run(self) -> None:
        c = self.s.library.get(self.clip.value)
        scale = clamp(self.scale) if self.mode.value == "scale" else None
        abort = int(float(self.abort.value)) if self.mode.value == "abort" else None
        if abort is not None and not 1 <= abort <= c.motion.n_frames - 2:
            # as `vary --abort-at` refuses it (a frame past the shot's end would silently become its last)
            self.s.set_status(f"Abort frame {abort}: {c.name} has {c.motion.n_frames} frames; expected 1 to {c.motion.n_frames - 2}", error=True)
            return
        cleanup = bool(self.cleanup.value)

        def job(progress):
            v = engine.vary(c.motion, scale, abort, cleanup, progress)
            return v, engine.score_image(v, v.report["variant"])

        self.s.submit("vary", job, lambda out: self._done(out, c), label="Vary")

    def _done(self, out: Any, clip: Any) -> None:
        v, img = out
        props = (clip.prop,) if clip.prop is not None else ()
        self.s.show([(v.motion.name, v.motion, props), (clip.name, clip.motion, props)])
        self.plot.image = img
        self.plot.visible = True
        r = v.report
        rows: list[tuple[str, Any]] = [("variant", r["variant"]), ("frames", r["n_frames"]), ("k (components)", r["k"])]
        rows.append(("variance explained", r["variance_explained"]))
        if "style_rmse" in r:
            rows.append(("style error", r["style_rmse"]["rmse"]))
        fs = r.get("planted_skate_mm_per_s", {})
        if fs.get("result") is not None and fs.get("source") is not None:
            rows.append(("planted footskate (mm/s) source / variant", f"{fs['source']:.1f} / {fs['result']:.1f}"))
        rows.append(("max joint speed ratio", r["max_joint_speed_ratio"]["result"]))
        worst = r["worst_joint_speed_ratio"]["result"]
        rows.append(("worst joint speed ratio", f"{worst['ratio']:.2f} ({worst['joint']})"))
        rows.append(("pop frames source / variant", f"{r['pop_frames']['source']} / {r['pop_frames']['result']}"))
        if "club_path_m" in r:
            rows.append(("club path (m) source / variant", f"{r['club_path_m']['source']:.2f} / {r['club_path_m']['result']:.2f}"))
        self.report.content = table(rows)
        self.s.set_status(f"{v.motion.name}: variant (blue) beside the source")
