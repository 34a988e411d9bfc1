"""Hit tab (seed 003 §2): a swing or kick with its prop; drag the ball (or type it); while dragging
the shot is previewed (DLS on a few frames, :data:`~mjmotion.studio.engine.PREVIEW_FRAMES`), on
release adapted exactly as ``mjmotion hit --solver dls`` does, with the NLP on demand; the ball's
launch is simulated in MuJoCo and its flight drawn; the report shown.

Two kinds of job: ``hit`` (a drag's preview: short, a newer one waits for it rather than throwing
it away, so a steady drag keeps showing answers) and ``hit-exact`` (the release, a typed ball, the
NLP: cancelled at its next checkpoint, every few frames, by any newer request: a drag makes it stale)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .. import engine
from . import pick, refresh, table

#: Seconds between drag updates sent to the solver (the worker keeps only the latest).
DRAG_INTERVAL = 0.1


class HitTab:
    def __init__(self, session: Any):
        self.s = session
        gui = session.client.gui
        shots = session.library.shots() or session.library.names()
        self.clip = gui.add_dropdown("Shot", tuple(shots), initial_value=pick(shots, "drive|swing|golf"))
        self.load = gui.add_button("Load shot")
        self.ball = gui.add_vector3("Ball", (0.0, 0.0, 0.0), step=0.0001, hint="the ball's centre, metres (Z up); drag the gizmo or type")
        self.solver = gui.add_dropdown("Solver", ("dls", "nlp"), initial_value="dls", hint="dls: fast, used while dragging; nlp: CasADi/IPOPT")
        self.adapt_nlp = gui.add_button("Adapt with NLP")
        self.to_hit = gui.add_button("Go to hit frame")
        self.report = gui.add_markdown("Load a shot, then drag the ball.")
        self.shot: engine.Shot | None = None
        self.result: Any = None
        self._gizmo: Any = None
        self._marks: dict[str, Any] = {}
        self._last_drag = 0.0
        self.load.on_click(lambda e: self.open())
        self.ball.on_update(self._on_ball_field)
        self.adapt_nlp.on_click(lambda e: self.solve(np.array(self.ball.value), "nlp", final=True))
        self.to_hit.on_click(lambda e: self._go_to_hit())
        session.on_library(lambda n: refresh(self.clip, session.library.shots() or n))

    def open(self) -> None:
        c = self.s.library.get(self.clip.value)

        def job(progress):
            progress(0.2, "finding the effector and hit frame")
            return engine.shot(c.motion, c.prop, c.hit_frame)

        self.s.submit("hit", job, self._opened, label="Hit")

    def _opened(self, shot: engine.Shot) -> None:
        self.shot = shot
        props = (shot.prop,) if shot.prop is not None else ()
        self.s.show([(shot.motion.name, shot.motion, props)])
        self.clear_marks()
        scene = self.s.client.scene
        p = tuple(float(x) for x in shot.source_point)
        self._marks["source"] = scene.add_icosphere("/hit/source_point", radius=0.02, color=(250, 220, 30), position=p)
        self._marks["ball"] = scene.add_icosphere("/hit/ball", radius=0.036, color=(217, 26, 26), position=p)
        self._gizmo = scene.add_transform_controls("/hit/gizmo", scale=0.35, disable_rotations=True, position=p, depth_test=False)
        self._gizmo.on_update(self._on_drag)
        self._gizmo.on_update(self._on_release)
        self.ball.value = p
        self.report.content = f"{shot.motion.name}: effector {shot.effector}, hit frame {shot.hit_frame}; drag the gizmo to move the ball."
        self.s.set_status(f"loaded {shot.motion.name} at its hit frame; drag the ball or type its position")
        self._go_to_hit()

    def clear_marks(self) -> None:
        """Remove the ball, the source hit point, the gizmo and the flight from the scene."""
        for h in self._marks.values():
            h.remove()
        self._marks.clear()
        if self._gizmo is not None:
            self._gizmo.remove()
            self._gizmo = None

    def _go_to_hit(self) -> None:
        if self.shot is not None:
            with self.s.lock:
                self.s.player.seek(self.shot.hit_frame)
                self.s.player.playing = False
                self.s.play_button.label = "Play"
                self.s._draw(self.shot.hit_frame)
                self.s._dirty = True  # the next tick moves the Frame slider there too

    def _on_release(self, event: Any) -> None:
        if getattr(event, "phase", None) == "end" and self._gizmo is not None:
            self.solve(np.array(self._gizmo.position), "dls", final=True)

    def _on_drag(self, event: Any) -> None:
        if getattr(event, "phase", None) == "end":
            return
        now = time.perf_counter()
        if now - self._last_drag < DRAG_INTERVAL:
            return
        self._last_drag = now
        self.solve(np.array(self._gizmo.position), "dls", final=False)

    def _on_ball_field(self, event: Any) -> None:
        if event.client is None or self.shot is None:
            return
        p = np.array(self.ball.value, dtype=float)
        if self._gizmo is not None:
            self._gizmo.position = p
        self.solve(p, self.solver.value, final=True)

    def solve(self, target: np.ndarray, solver: str, final: bool) -> None:
        """Adapt the shot to ``target``: a preview (``final`` false, while dragging) or the exact
        answer, which also simulates the launch and measures the style."""
        shot = self.shot
        if shot is None:
            self.s.set_status("load a shot first", error=True)
            return
        if "ball" in self._marks:
            self._marks["ball"].position = tuple(float(x) for x in target)
        shown = tuple(round(float(x), 4) for x in target)
        if tuple(round(float(x), 4) for x in self.ball.value) != shown:
            self.ball.value = shown  # a server-side set: _on_ball_field ignores it

        def job(progress):
            t0 = time.perf_counter()
            progress(0.05, f"adapting ({solver})")
            a = engine.adapt(shot, target, solver, style=final, preview=not final, progress=progress)
            latency = time.perf_counter() - t0
            flight = None
            if final:
                progress(0.8, "simulating the launch")
                flight = engine.launch(shot, a.motion, target)
            return a, flight, latency

        done = lambda out: self._solved(out, target, solver)
        if final:
            self.s.worker.cancel("hit")  # previews of the drag that ended: this answer replaces them
            self.s.submit("hit-exact", job, done, label="Hit")
        else:
            self.s.worker.cancel("hit-exact")  # an exact solve for an earlier ball position is stale
            self.s.submit("hit", job, done, label="Hit", keep_running=True)

    def _solved(self, out: Any, target: np.ndarray, solver: str) -> None:
        a, flight, latency = out
        self.result = a
        shot = self.shot
        props = (shot.prop,) if shot is not None and shot.prop is not None else ()
        with self.s.lock:
            frame = self.s.player.index
            self.s.show([(a.motion.name, a.motion, props)], keep_marks=True)
            self.s.player.seek(frame)
            self.s.player.playing = False
            self.s.play_button.label = "Play"
            self.s._draw(frame)
        r = a.report
        preview = f" preview ({r['preview_frames']} frames; exact on release)" if "preview_frames" in r else ""
        rows = [
            ("reached", r["reachable"]),
            ("hit error (mm)", 1000 * r["hit_error_m"]),
            ("grip error (mm)", 1000 * r["grip_error_m"]),
            ("style error", r["style_rmse"] if r["style_rmse"] is not None else "on release"),
            ("solver", f"{solver}{preview}, {latency:.2f} s"),
        ]
        if flight is None and "flight" in self._marks:
            self._marks.pop("flight").remove()  # it was the launch from an earlier ball position
        if flight is not None:
            m = flight.metrics
            rows += [("contact", m.get("contact")), ("launch speed (m/s)", m.get("launch_speed", float("nan")))]
            rows += [
                ("azimuth / elevation (°)", f"{m.get('launch_azimuth_deg', float('nan')):.1f} / {m.get('launch_elevation_deg', float('nan')):.1f}")
            ]
            scene = self.s.client.scene
            if len(flight.path) > 1:
                self._marks["flight"] = scene.add_spline_catmull_rom("/hit/flight", flight.path, color=(217, 26, 26))
        self.report.content = table(rows) + ("" if r["reachable"] else f"\n\n{r.get('message', '')}")
        what = "previewed" if preview else "adapted"
        self.s.set_status(f"{what} {a.motion.name} to the ball ({'reached' if r['reachable'] else 'not reached'})")
