"""A motion stream driven live, one output frame at a time (seed 000 §2.1, §3.3).

:class:`mjmotion.stream.MotionStream` plays a *script* whose commands are all known in advance;
the Studio's Stream tab needs the same controller fed by a user who moves weight sliders and
presses Kick whenever they like. :class:`LiveStream` is that controller, built on the batch
stream's public pieces: the locomotion registration and loop points of a
:class:`~mjmotion.stream.MotionStream`, :class:`~mjmotion.blend.WeightCurve` for weight ramps,
:func:`~mjmotion.blend.bezier_ease` for every fade and :func:`~mjmotion.blend.compose` for the
pose. Each :meth:`LiveStream.step` composes one new frame from the previous frame's floor
position and heading and the tracks' own one-frame increments, so the same rules hold as in the
batch stream: a loop crossfades to an earlier matching instant, an action fades in over its
blend window and back out, and no source track's time jump ever moves the character (seed 000
§4.1's time blip). Weight changes ramp from whatever the weights are at that instant, so
requests during a ramp or a transition never leave more than the requested clips weighted and
weights always sum to one (§4.1's weight bug).

Fed the commands of a script at their times, the frames equal those of
:func:`mjmotion.stream.stream` on that script (tests/test_studio_live.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import rotations as rot
from .. import stream as st
from ..blend import Track, WeightCurve, bezier_ease, check_weights, compose, yaw_of
from ..errors import MjmotionError
from ..skeleton import Motion, same_rate


@dataclass(frozen=True)
class StreamFrame:
    """One frame of the live stream.

    Attributes:
        index: output frame number (0 first).
        root_position: ``(3,)`` metres; ``rotations``: ``(J, 4)`` local wxyz; ``translations``:
            ``(J, 3)`` local translations or ``None``.
        weights: ``(n_loc,)`` locomotion weights at this frame (sum 1).
        action_weight: weight of the action layer (0 = pure locomotion, 1 = the action alone).
        action: name of the action carrying the most weight, or ``None``.
        heading: radians, the blend's heading about the vertical.
    """

    index: int
    root_position: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray | None
    weights: np.ndarray
    action_weight: float
    action: str | None
    heading: float


@dataclass
class _Cursor:
    tau: float
    dtau: float = 0.0
    fade: float = 1.0


@dataclass
class _Action:
    """One played clip: its fades in output frames, the reference frames each stands for (seed 000
    §3.3: a fade lasts ``nominal × pace`` output frames) and the clip time reached so far."""

    clip: str
    start: int
    fade_in: int
    nominal_in: int
    clock: np.ndarray  # (K,) clip time at frames start.. without a fade-out
    out_start: int = 0
    fade_out: int = 1
    nominal_out: int = 1
    t: float = 0.0
    cut: bool = False  # ended early by a return or another action
    finished: bool = field(default=False)


class LiveStream:
    """The live controller over a locomotion set and optional actions.

    Args:
        locomotion: clips registered and blended (the first is the reference); names must be unique.
        actions: clips played on request (:meth:`play`), by name.
        weights: initial locomotion weights (default: all on the first clip).
        loop_blend: seconds of each loop crossfade.
    """

    def __init__(
        self,
        locomotion: list[Motion],
        actions: dict[str, Motion] | None = None,
        weights: np.ndarray | None = None,
        loop_blend: float = 0.4,
    ):
        if not locomotion:
            raise MjmotionError("a stream needs at least one locomotion clip")
        names = [m.name for m in locomotion]
        actions = dict(actions or {})
        if len(set(names) | set(actions)) != len(names) + len(actions):
            raise MjmotionError(f"stream clip names must be unique, got {names + list(actions)}")
        fps = locomotion[0].fps
        clips = {m.name: _at_rate(m, fps) for m in locomotion} | {k: _at_rate(m.replace(name=k), fps) for k, m in actions.items()}
        w0 = np.eye(len(names))[0] if weights is None else check_weights(weights, len(names), "stream weights")
        script = st.Script(
            clips=clips,
            locomotion=tuple(names),
            commands=(st.Command(0.0, "weights", w0, ramp=0.0),),
            duration=1.0,
            fps=fps,
            loop_blend=loop_blend,
        )
        for m in clips.values():
            locomotion[0].skeleton.require_same_topology(m.skeleton, f"stream clips {names[0]!r} and {m.name!r}")
        self._engine = st.MotionStream(script)
        reg = self._engine.registration
        self.fps = float(fps)
        self.locomotion = tuple(names)
        self.actions = tuple(actions)
        self._clips = clips
        self._loco = [clips[n] for n in names]
        self._ref = reg.times[:, reg.reference]
        self._seg = np.diff(reg.times, axis=0)
        self._fade_n = max(1, int(round(loop_blend * fps)))
        self._keys: list[tuple[float, float, np.ndarray]] = [(0.0, 0.0, w0)]
        self._cursors = [_Cursor(float(self._ref[0]))]
        self._fading: tuple[_Cursor, _Cursor, int] | None = None
        self._actions: list[_Action] = []
        self._n = 0
        self._xy = np.zeros(2)
        self._heading = 0.0
        self._last_q: np.ndarray | None = None

    # --- commands ------------------------------------------------------------------------------
    @property
    def frame(self) -> int:
        """The number of the next frame :meth:`step` makes."""
        return self._n

    @property
    def target_weights(self) -> np.ndarray:
        """The weights the last request ramps to."""
        return self._keys[-1][2].copy()

    def set_weights(self, weights: np.ndarray | list[float], ramp: float = 0.5) -> None:
        """Ramp the locomotion weights (``(n_loc,)``, summing to 1) from their current value over ``ramp`` seconds,
        starting at the next frame."""
        w = check_weights(weights, len(self.locomotion), "stream weights")
        if not (np.isfinite(ramp) and ramp >= 0):
            raise MjmotionError(f"ramp must be a non-negative number of seconds, got {ramp}")
        t = self._n / self.fps
        # keys whose ramp has finished no longer matter: the curve equals their weights from then on
        done = [i for i, (k_t, k_r, _) in enumerate(self._keys) if k_t + k_r <= t]
        if done:
            self._keys = self._keys[done[-1] :]
        self._keys.append((t, float(ramp), w))
        for a in self._actions:  # a natural fade-out ahead takes its pace from the weights now requested
            if not a.finished and not a.cut and a.out_start > self._n:
                self._natural_end(a)

    def _weights_at(self, n: int) -> np.ndarray:
        """Locomotion weights at output frame ``n`` as the requests made so far set them."""
        return WeightCurve(tuple(self._keys))(np.array([n / self.fps]))[0]

    def _fade(self, nominal: int, n: int) -> int:
        """Output frames of a fade of ``nominal`` reference frames at frame ``n``'s locomotion pace
        (as :class:`mjmotion.stream.MotionStream`: longer from or back to a faster motion)."""
        return max(1, int(round(nominal * self._engine.rate(self._weights_at(n)))))

    def _natural_end(self, a: _Action) -> None:
        """Where ``a`` starts fading out on its own: the rest of the clip is what the fade covers,
        the fade's pace taken where the clip's clock reaches its last ``nominal`` frames."""
        last = self._clips[a.clip].n_frames - 1
        a.nominal_out = a.nominal_in
        a.fade_out = self._fade(a.nominal_out, a.start + int(np.searchsorted(a.clock, last - a.nominal_out)))
        out = 1.0 - bezier_ease(np.arange(1, a.fade_out + 1) / a.fade_out)
        covered = float(np.sum(out + (1.0 - out) * a.nominal_out / a.fade_out))
        a.out_start = a.start + int(np.searchsorted(a.clock, last - covered))

    def play(self, name: str, blend: float = 0.3) -> None:
        """Fade the action ``name`` in from the next frame over ``blend`` seconds of the reference clip, play it
        once and fade back out over its last ``blend`` seconds (each fade longer when the locomotion is faster
        than the reference, seed 000 §3.3). A request while another action plays ends that one from now, over
        this request's blend (as a script's later ``play`` does)."""
        if name not in self.actions:
            raise MjmotionError(f"no action named {name!r}; the stream has {', '.join(self.actions) or 'none'}")
        if not (np.isfinite(blend) and blend >= 0):
            raise MjmotionError(f"blend must be a non-negative number of seconds, got {blend}")
        n0 = self._n
        clip = self._clips[name]
        nominal = max(1, int(round(blend * self.fps)))
        fade_in = self._fade(nominal, n0)
        k = np.arange(clip.n_frames + 4 * fade_in + 2)
        ramp = bezier_ease(k / fade_in)
        ratio = np.where((k > 0) & (k <= fade_in), nominal / fade_in, 1.0)
        clock = np.cumsum(np.where(k > 0, ramp + (1.0 - ramp) * ratio, 0.0))
        a = _Action(name, n0, fade_in, nominal, clock)
        self._natural_end(a)
        if a.out_start <= n0:
            raise MjmotionError(f"{name} is {clip.n_frames / self.fps:.2f} s long, too short for a {blend:g} s blend in and out")
        self._end_actions(n0, nominal)
        self._actions.append(a)

    def _end_actions(self, n: int, nominal: int) -> None:
        for a in self._actions:
            if not a.finished and n < a.out_start:
                a.out_start, a.nominal_out, a.fade_out, a.cut = n, nominal, self._fade(nominal, n), True

    def stop_action(self, blend: float = 0.3) -> None:
        """Return to locomotion now, over ``blend`` seconds of the reference clip (a script's ``return``)."""
        self._end_actions(self._n, max(1, int(round(blend * self.fps))))

    # --- the clock -----------------------------------------------------------------------------
    def _advance(self, tau: float, w: np.ndarray) -> float:
        """Reference time one output frame after ``tau`` at weights ``w`` (each segment's frames are the
        weighted harmonic mean of the clips', as :func:`mjmotion.blend.segment_frames`)."""
        ref = self._ref
        m = min(int(np.searchsorted(ref, tau, side="right")) - 1, len(ref) - 2)
        remaining = 1.0
        while remaining > 1e-12 and m < len(ref) - 1:
            frames = 1.0 / float(np.sum(w / self._seg[m]))
            span = ref[m + 1] - ref[m]
            left = (ref[m + 1] - tau) / span * frames
            if left >= remaining:
                return tau + remaining / frames * span
            tau, remaining, m = ref[m + 1], remaining - left, m + 1
        return float(tau)

    def _move_cursors(self, n: int, w: np.ndarray) -> None:
        for c in self._cursors:
            new = self._advance(c.tau, w) if n > 0 else c.tau
            c.dtau, c.tau = new - c.tau, new
        if self._fading is None:
            head = self._cursors[-1]
            head.fade = 1.0
            if head.tau + 1.5 * self._fade_n * max(self._advance(head.tau, w) - head.tau, 1e-6) >= self._ref[-1]:
                new_c = _Cursor(self._engine.loop_point(head.tau), 0.0, 0.0)
                self._cursors.append(new_c)
                self._fading = (head, new_c, n)
        if self._fading is not None:
            old, new_c, n0 = self._fading
            s = float(bezier_ease(np.array((n - n0) / self._fade_n)))
            old.fade, new_c.fade = 1.0 - s, s
            if n - n0 >= self._fade_n:
                self._cursors.remove(old)
                self._fading = None

    def _action_tracks(self, n: int) -> tuple[float, list[tuple[str, float, float, float]]]:
        """The action layer's weight at frame ``n`` and ``(clip, time, step, weight)`` per weighted action.

        A clip's clock runs at its own rate blended with its fade's: over a fade of ``f`` output
        frames standing for ``nominal`` reference frames it advances ``w + (1 − w)·nominal/f``
        frames per output frame (``w`` its weight), as the batch stream's does."""
        out = []
        for a in self._actions:
            last = self._clips[a.clip].n_frames - 1
            ramp_in = float(bezier_ease(np.array((n - a.start) / a.fade_in)))
            ramp_out = 1.0 - float(bezier_ease(np.array((n - a.out_start) / a.fade_out)))
            wk = 0.0 if n < a.start else min(ramp_in, ramp_out)
            ratio = 1.0
            if a.start < n <= a.start + a.fade_in:
                ratio = a.nominal_in / a.fade_in
            if a.out_start < n <= a.out_start + a.fade_out:
                ratio = a.nominal_out / a.fade_out
            step = wk + (1.0 - wk) * ratio if a.start < n <= a.out_start + a.fade_out else 0.0
            t = min(a.t + step, last)  # a fade-out rounded past the clip's end holds its last frame
            step, a.t = t - a.t, t
            if n >= a.out_start + a.fade_out:
                a.finished = True
            if wk > 0:
                out.append((a.clip, t, step, wk))
        self._actions = [a for a in self._actions if not a.finished]
        layer = max((x[3] for x in out), default=0.0)
        total = sum(x[3] for x in out)
        return layer, [(c, t, s, wk * layer / total) for c, t, s, wk in out]

    # --- one frame -----------------------------------------------------------------------------
    def step(self) -> StreamFrame:
        """Compose the next output frame."""
        n = self._n
        w = self._weights_at(n)
        self._move_cursors(n, w)
        layer, acts = self._action_tracks(n)
        reg = self._engine.registration
        rows: list[tuple[Motion, float, float, float]] = []
        for c in self._cursors:
            now = reg.at(np.array([c.tau]))[0]
            before = reg.at(np.array([c.tau - c.dtau]))[0]
            for k, m in enumerate(self._loco):
                wk = (1.0 - layer) * c.fade * w[k]
                if wk > 0:
                    rows.append((m, float(now[k]), float(now[k] - before[k]), wk))
        rows += [(self._clips[name], t, s, wk) for name, t, s, wk in acts]
        if n == 0:
            m0, t0 = max(rows, key=lambda r: r[3])[:2]
            _, q0, _ = m0.sample(np.array([t0]))
            p0 = m0.sample(np.array([t0]))[0][0]
            self._xy, self._heading = p0[:2].copy(), float(yaw_of(q0[0, 0]))
        origin = (float(self._xy[0]), float(self._xy[1]), self._heading)
        tracks = [Track(m, np.array([t, t]), np.array([0.0, s]), np.array([wk, wk])) for m, t, s, wk in rows]
        out = compose(tracks, self.fps, "live", origin=origin)
        total = sum(r[3] for r in rows)
        d_yaw = 0.0
        for m, t, s, wk in rows:
            if s:
                _, q = m.sample(np.array([t, t - s]))[:2]
                d_yaw += wk / total * float(_wrap(yaw_of(q[0, 0]) - yaw_of(q[1, 0])))
        k = 0 if n == 0 else 1
        q = out.rotations[k].copy()
        if self._last_q is not None:
            flip = np.einsum("jc,jc->j", q, self._last_q) < 0
            q[flip] *= -1.0
        self._last_q = q
        self._heading += d_yaw if n > 0 else 0.0
        self._xy = out.root_positions[k, :2].copy()
        self._n += 1
        name = max(acts, key=lambda a: a[3])[0] if acts else None
        tr = None if out.translations is None else out.translations[k].copy()
        return StreamFrame(n, out.root_positions[k].copy(), q, tr, w, float(layer), name, self._heading)

    def run(self, n_frames: int, name: str = "live") -> Motion:
        """``n_frames`` more frames as a :class:`Motion` (for tests and saving)."""
        frames = [self.step() for _ in range(n_frames)]
        skel = self._loco[0].skeleton
        trans = None if frames[0].translations is None else np.stack([f.translations for f in frames])  # type: ignore[misc]
        q = rot.make_continuous(np.stack([f.rotations for f in frames]))
        return Motion(skel, self.fps, np.stack([f.root_position for f in frames]), q, trans, name)


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def _at_rate(m: Motion, fps: float) -> Motion:
    return m if same_rate(m.fps, fps) else m.resample(fps)
