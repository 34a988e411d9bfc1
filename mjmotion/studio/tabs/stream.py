"""Stream tab (seed 000 §2.1, §3.3): a live motion stream; weight sliders, Kick and Punch buttons and keys."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..live import LiveStream
from . import NONE, clamp, faster, partner, pick, refresh, walking, weights_of

N_SLOTS = 3


class StreamTab:
    def __init__(self, session: Any):
        self.s = session
        gui = session.client.gui
        names = session.library.names()
        first = pick(names, "walk", "turn|warp|fast", default=walking(session.library))
        loco = [first, partner(session.library, first, "run", "turn", default=faster(session.library, first) or NONE)]
        self.loco = [
            gui.add_dropdown("Locomotion 1", tuple(names), initial_value=loco[0]),
            gui.add_dropdown("Locomotion 2", (NONE, *names), initial_value=loco[1]),
            gui.add_dropdown("Locomotion 3", (NONE, *names), initial_value=NONE),
        ]
        self.kick_clip = gui.add_dropdown("Kick clip", (NONE, *names), initial_value=pick(names, "kick", default=NONE))
        self.punch_clip = gui.add_dropdown("Punch clip", (NONE, *names), initial_value=pick(names, "punch", default=NONE))
        self.start = gui.add_button("Start stream")
        self.weights = [gui.add_slider(f"Weight {k + 1}", 0.0, 1.0, 0.05, 1.0 if k == 0 else 0.0) for k in range(N_SLOTS)]
        self.ramp = gui.add_slider("Ramp (s)", 0.0, 2.0, 0.05, 0.5)
        self.blend = gui.add_slider("Blend (s)", 0.05, 1.0, 0.05, 0.3)
        self.kick = gui.add_button("Kick", hint="key K")
        self.punch = gui.add_button("Punch", hint="key P")
        self.back = gui.add_button("Return", hint="key R: back to locomotion now")
        self.readout = gui.add_markdown("")
        self.start.on_click(lambda e: self.run())
        for h in self.weights:
            h.on_update(self._on_weight)
        self.kick.on_click(lambda e: self.play("kick"))
        self.punch.on_click(lambda e: self.play("punch"))
        self.back.on_click(lambda e: self._command(lambda live: live.stop_action(clamp(self.blend))))
        for label, key, fn in (("Kick", "K", lambda: self.play("kick")), ("Punch", "P", lambda: self.play("punch")), ("Return", "R", self._return)):
            cmd = gui.add_command(label, hotkey=key)
            cmd.on_trigger(lambda e, fn=fn: fn())
        for k in range(N_SLOTS):
            cmd = gui.add_command(f"All weight on locomotion {k + 1}", hotkey=str(k + 1))  # type: ignore[arg-type]
            cmd.on_trigger(lambda e, k=k: self._solo(k))
        session.on_library(self._refresh)
        self._names: list[str] = []

    def _refresh(self, names: list[str]) -> None:
        for k, d in enumerate(self.loco):
            refresh(d, names, optional=k > 0)
        refresh(self.kick_clip, names, optional=True)
        refresh(self.punch_clip, names, optional=True)

    def run(self) -> None:
        lib = self.s.library
        names = [d.value for d in self.loco if d.value != NONE]
        loco = [lib.get(n).motion.replace(name=n) for n in dict.fromkeys(names)]
        actions = {k: lib.get(d.value).motion for k, d in (("kick", self.kick_clip), ("punch", self.punch_clip)) if d.value != NONE}
        w = self._slider_weights(len(loco))

        def job(progress):
            progress(0.3, "registering the locomotion set")
            return LiveStream(loco, actions, weights=w)

        self._names = list(dict.fromkeys(names))
        self.s.submit("stream", job, self._started, label="Stream")

    def _started(self, live: LiveStream) -> None:
        self.s.start_live(live)
        acts = ", ".join(live.actions) or "none"
        self.s.set_status(f"streaming {' + '.join(live.locomotion)} (actions: {acts}); move the weights, press Kick or Punch (keys K, P)")

    def _slider_weights(self, n: int) -> np.ndarray:
        return weights_of(self.weights[:n])[0]

    def _command(self, fn: Any) -> None:
        with self.s.lock:
            live = self.s.live
            if live is None:
                self.s.set_status("start the stream first", error=True)
                return
            try:
                fn(live)
            except Exception as e:
                self.s.set_status(str(e), error=True)

    def _on_weight(self, event: Any) -> None:
        if event.client is None:
            return
        self._command(lambda live: live.set_weights(self._slider_weights(len(live.locomotion)), clamp(self.ramp)))

    def _solo(self, k: int) -> None:
        def go(live: LiveStream) -> None:
            if k < len(live.locomotion):
                live.set_weights(np.eye(len(live.locomotion))[k], clamp(self.ramp))
                for j, h in enumerate(self.weights):  # the sliders show what the stream now blends toward
                    h.value = 1.0 if j == k else 0.0

        self._command(go)

    def _return(self) -> None:
        self._command(lambda live: live.stop_action(clamp(self.blend)))

    def play(self, action: str) -> None:
        self._command(lambda live: live.play(action, clamp(self.blend)))

    def on_live(self, frame: Any) -> None:
        """Called by the page a few times a second with the stream's current frame."""
        w = ", ".join(f"{n} {x:.2f}" for n, x in zip(self.s.live.locomotion, frame.weights))
        act = f"{frame.action} {frame.action_weight:.2f}" if frame.action else "locomotion"
        self.readout.content = f"frame {frame.index} · weights {w} · {act}"
