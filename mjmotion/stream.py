"""A motion stream (seed 000 §3.3): a blended locomotion set driven by timed commands.

The controller plays a registered set of locomotion clips (walks, runs) with weights that change
on command along cubic-Bezier ramps, loops the set by crossfading to an earlier matching instant
when it runs out, and transitions into a non-registered clip (a kick, a punch) over a blend
window and back. Every source is a :class:`mjmotion.blend.Track` that keeps its own clock; the
root is built from per-track increments (:func:`mjmotion.blend.compose`), so neither a loop nor
a return from a transition can make the character jump or spin (seed 000 §4.1's time blip).

A script (JSON) names the clips and the commands::

    {
      "fps": 120,                                  # optional: default the first clip's rate
      "duration": 8.0,                             # seconds of output
      "clips": {
        "walk": {"file": "16_15.bvh"},             # paths relative to the script
        "fast": {"file": "16_24.bvh", "frames": "0:290"},
        "kick": {"file": "10_01.bvh", "frames": "500:720"}
      },
      "locomotion": ["walk", "fast"],              # registered and blended
      "loop_blend": 0.4,                           # optional: seconds of each loop crossfade
      "commands": [
        {"time": 0.0, "weights": {"walk": 1}},
        {"time": 1.5, "weights": {"walk": 0.5, "fast": 0.5}, "ramp": 0.8},
        {"time": 3.5, "play": "kick", "blend": 0.3},
        {"time": 4.0, "weights": {"walk": 1}, "ramp": 0.5}
      ]
    }

``weights`` (locomotion clip → weight, missing names 0, summing to 1) start a ramp of ``ramp``
seconds. ``play`` fades the named clip in over ``blend`` seconds, plays it once and fades back
to the locomotion over its last ``blend`` seconds; ``{"time": t, "return": true, "blend": b}``
returns earlier (a return needs a play before it).

Transition timing follows seed 000 §3.3. A ``blend`` is seconds of the reference clip (the first
locomotion clip): a fade lasts ``blend · fps · r`` output frames, ``r`` the locomotion's pace
relative to the reference at the current weights (reference frames per output frame over the
registration: 1 for the reference alone, more for a run, whose matched spans are shorter), so a
fade from or back to a run is longer. Over a fade the played clip covers its ``blend · fps``-frame
window: each output frame it advances ``a + (1 − a) · blend · fps / fade`` frames, ``a`` its
current weight (the seed's linear blend of the clip's own rate and the window's), so it starts at
the locomotion's pace and ends at its own. :attr:`MotionStream.transitions` reports every fade.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal, overload

import numpy as np

from . import registration as reg
from . import script as script_schema
from .blend import Track, WeightCurve, bezier_ease, check_weights, compose
from .errors import MjmotionError, is_real
from .skeleton import Motion, same_rate


@dataclass(frozen=True)
class Command:
    """One timed command: ``kind`` is ``"weights"``, ``"play"`` or ``"return"``."""

    time: float
    kind: str
    weights: np.ndarray | None = None
    ramp: float = 0.5
    clip: str | None = None
    blend: float = 0.3


@dataclass(frozen=True)
class Script:
    """A parsed stream script (see the module docstring). Made directly (the Studio, the experiments), its
    values are checked as :func:`parse_script` checks a file's, and clips at another rate than ``fps``
    are resampled to it (a 60 fps walk in a 30 fps script walked at half its speed)."""

    clips: dict[str, Motion]
    locomotion: tuple[str, ...]
    commands: tuple[Command, ...]
    duration: float
    fps: float
    loop_blend: float = 0.4

    def __post_init__(self) -> None:
        for label, value in (("fps", self.fps), ("duration", self.duration), ("loop_blend", self.loop_blend)):
            if not is_real(value):
                raise MjmotionError(f"Script.{label}: expected a finite number, got {value!r}")
        if not 1.0 <= self.fps <= 10_000.0:
            raise MjmotionError(f"Script.fps {self.fps:g}: expected 1 to 10000 frames per second")
        if self.duration < 1.0 / self.fps or self.loop_blend < 0:
            raise MjmotionError(f"Script.duration {self.duration:g}, loop_blend {self.loop_blend:g}: expected at least one frame and a blend ≥ 0")
        if not isinstance(self.clips, dict) or not self.clips or not all(isinstance(m, Motion) for m in self.clips.values()):
            raise MjmotionError("Script.clips: expected a dict of name → Motion")
        loco = tuple(self.locomotion)
        if not loco or any(n not in self.clips for n in loco):
            raise MjmotionError(f"Script.locomotion {loco!r}: expected clip names of Script.clips ({', '.join(self.clips)})")
        for k, c in enumerate(self.commands):
            if c.kind == "play" and c.clip not in self.clips:
                raise MjmotionError(f"Script.commands[{k}]: plays {c.clip!r}, no clip of Script.clips")
            if c.weights is not None and (np.shape(c.weights) != (len(loco),) or not np.all(np.isfinite(c.weights))):
                raise MjmotionError(f"Script.commands[{k}].weights: expected {len(loco)} finite weights, one per locomotion clip")
        object.__setattr__(self, "locomotion", loco)
        object.__setattr__(self, "commands", tuple(self.commands))
        object.__setattr__(self, "clips", {k: (m if same_rate(m.fps, self.fps) else m.resample(self.fps)) for k, m in self.clips.items()})


@dataclass(frozen=True)
class Transition:
    """One played clip's transitions (output frames; seconds are frames / fps).

    Attributes:
        clip: the played clip's name.
        start: output frame its fade-in starts (the play command).
        fade_in: output frames of the fade-in; ``nominal_fade_in`` = ``blend · fps``.
        rate_in: the locomotion's pace there (reference frames per output frame).
        fade_out_start: output frame its fade back to the locomotion starts.
        fade_out, nominal_fade_out, rate_out: the same for the fade-out.
        end: output frame the fade-out ends (the clip's weight is 0 from there).
        clip_frames: frames of the clip played (its last frame is ``clip.n_frames − 1``).
    """

    clip: str
    start: int
    fade_in: int
    nominal_fade_in: int
    rate_in: float
    fade_out_start: int
    fade_out: int
    nominal_fade_out: int
    rate_out: float
    end: int
    clip_frames: float

    def to_json(self, fps: float) -> dict:
        """Frames and seconds of every field (``mjmotion stream --json``)."""
        out: dict = {"clip": self.clip}
        for key in ("start", "fade_in", "nominal_fade_in", "fade_out_start", "fade_out", "nominal_fade_out", "end"):
            frames = getattr(self, key)
            out[f"{key}_frames"] = frames
            out[f"{key}_s"] = frames / fps
        out.update(rate_in=self.rate_in, rate_out=self.rate_out, clip_frames=self.clip_frames)
        return out


#: Memory a stream may use to compose its output. Composing holds, for every source track (each
#: locomotion clip per loop playhead, each played clip), about this many bytes per output frame and
#: joint (sampled and previous-frame quaternions, their stack and the weighted mean: measured on
#: 09_06 looped for 60 s, 2.5 GB for 60 tracks × 7200 frames × 43 joints).
MEMORY_LIMIT_BYTES = 2 * 2**30
BYTES_PER_TRACK_FRAME_JOINT = 128


def max_frames(n_joints: int, n_tracks: int = 1) -> int:
    """The longest stream (output frames) that composes ``n_tracks`` tracks within
    :data:`MEMORY_LIMIT_BYTES` on a skeleton of ``n_joints`` joints."""
    return MEMORY_LIMIT_BYTES // (BYTES_PER_TRACK_FRAME_JOINT * max(1, n_joints) * max(1, n_tracks))


def _number(value: object, where: str, minimum: float = 0.0, maximum: float = float("inf"), why: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value < minimum:
        raise MjmotionError(f"{where}: expected a number ≥ {minimum:g}, got {value!r}")
    if value > maximum:
        raise MjmotionError(f"{where}: {value:g} is more than the limit {maximum:g}{why}")
    return float(value)


def parse_script(data: dict, base: Path, load) -> Script:
    """A :class:`Script` from JSON ``data``; ``load(path, frames_text, field)`` reads a clip (frame-range errors name ``field``).

    Every mistake is an :class:`MjmotionError` naming the field.
    """
    data = script_schema.validate(data)  # types, ranges, lengths and keys (mjmotion.script)
    if not isinstance(data, dict):
        raise MjmotionError("script: expected a JSON object with clips, locomotion, commands, duration")
    for key in ("clips", "locomotion", "commands", "duration"):
        if key not in data:
            raise MjmotionError(f"script: missing field {key!r}")
    unknown = set(data) - {"clips", "locomotion", "commands", "duration", "fps", "loop_blend"}
    if unknown:
        raise MjmotionError(f"script: unknown field(s) {', '.join(sorted(unknown))}")
    if not isinstance(data["clips"], dict) or not data["clips"]:
        raise MjmotionError('script.clips: expected an object of name → {"file": …, "frames": "A:B"}')
    clips: dict[str, Motion] = {}
    for name, spec in data["clips"].items():
        if not isinstance(spec, dict) or not isinstance(spec.get("file"), str):
            raise MjmotionError(f'script.clips.{name}: expected {{"file": PATH, "frames": "A:B" (optional)}}')
        path = Path(spec["file"])
        path = path if path.is_absolute() else base / path
        clips[name] = load(str(path), spec.get("frames"), f"script.clips.{name}.frames").replace(name=name)
    loco = data["locomotion"]
    if not isinstance(loco, list) or not loco or not all(isinstance(x, str) for x in loco):
        raise MjmotionError("script.locomotion: expected a list of clip names")
    for name in loco:
        if name not in clips:
            raise MjmotionError(f"script.locomotion: no clip named {name!r} in script.clips")
    first = clips[loco[0]]
    for name, m in clips.items():
        first.skeleton.require_same_topology(m.skeleton, f"clips {loco[0]!r} and {name!r}")
    fps = _number(data.get("fps", first.fps), "script.fps", 1.0, 10_000.0, " frames per second")
    # Checked before anything is allocated: every time, ramp and blend within the longest stream
    # one composing track allows (54 min at 120 fps for a 43-joint skeleton).
    n_joints = first.skeleton.n_joints
    limit_s = max_frames(n_joints) / fps
    why = (
        f" s (the longest stream that composes in {MEMORY_LIMIT_BYTES / 2**30:g} GiB: {max_frames(n_joints)} frames "
        f"× {n_joints} joints × {BYTES_PER_TRACK_FRAME_JOINT} bytes per track at {fps:g} fps)"
    )
    duration = _number(data["duration"], "script.duration", 1.0 / fps, limit_s, why)
    commands = []
    if not isinstance(data["commands"], list) or not data["commands"]:
        raise MjmotionError("script.commands: expected a non-empty list")
    for k, c in enumerate(data["commands"]):
        where = f"script.commands[{k}]"
        if not isinstance(c, dict) or "time" not in c:
            raise MjmotionError(f"{where}: expected an object with a time")
        t = _number(c["time"], f"{where}.time", 0.0, limit_s, why)
        if t >= duration:  # it would never act (a stream of script.duration seconds)
            raise MjmotionError(f"{where}.time {t:g}: at or after the stream's end (script.duration {duration:g} s)")
        if "weights" in c:
            wd = c["weights"]
            if not isinstance(wd, dict) or any(n not in loco for n in wd):
                raise MjmotionError(f"{where}.weights: expected {{locomotion clip: weight}} over {', '.join(loco)}")
            w = check_weights([float(wd.get(n, 0.0)) for n in loco], len(loco), f"{where}.weights")
            commands.append(Command(t, "weights", w, ramp=_number(c.get("ramp", 0.5), f"{where}.ramp", 0.0, limit_s, why)))
        elif "play" in c:
            if c["play"] not in clips:
                raise MjmotionError(f"{where}.play: no clip named {c['play']!r} in script.clips")
            commands.append(Command(t, "play", clip=c["play"], blend=_number(c.get("blend", 0.3), f"{where}.blend", 0.0, limit_s, why)))
        elif c.get("return"):
            commands.append(Command(t, "return", blend=_number(c.get("blend", 0.3), f"{where}.blend", 0.0, limit_s, why)))
        else:
            raise MjmotionError(f"{where}: expected one of weights, play or return")
    order = sorted(range(len(commands)), key=lambda k: commands[k].time)
    playing = False
    for k in order:  # a return ends the action a play started; with none started it would never act
        if commands[k].kind == "return" and not playing:
            raise MjmotionError(f"script.commands[{k}]: a return at {commands[k].time:g} s with no play before it (nothing to return from)")
        playing = commands[k].kind == "play" or (playing and commands[k].kind == "weights")
    commands = [commands[k] for k in order]
    if commands[0].kind != "weights" or commands[0].time > 0:
        commands.insert(0, Command(0.0, "weights", np.eye(len(loco))[0], ramp=0.0))
    return Script(
        clips=clips,
        locomotion=tuple(loco),
        commands=tuple(commands),
        duration=duration,
        fps=fps,
        loop_blend=_number(data.get("loop_blend", 0.4), "script.loop_blend", 1.0 / fps, limit_s, why),
    )


def load_script(path: str, load) -> Script:
    """Read a stream script; ``load(path, frames_text, field)`` reads a clip, its frame-range errors naming
    ``field`` (the CLI passes its loader).

    The file is read and checked by :func:`mjmotion.script.load` (a regular file, safe JSON, the schema)."""
    data = script_schema.load(path)
    try:
        return parse_script(data, Path(path).resolve().parent, load)
    except MjmotionError as e:
        if str(e).startswith("script"):  # the script's own fields (not a clip's error): name the file
            raise MjmotionError(f"{path}: {e}") from None
        raise


class _Cursor:
    """One playhead on the locomotion registration (reference time ``tau``)."""

    def __init__(self, tau: float, n_frames: int):
        self.tau = tau
        self.taus = np.zeros(n_frames)
        self.dtaus = np.zeros(n_frames)
        self.fade = np.zeros(n_frames)


class MotionStream:
    """The stream controller: build once per script, then :meth:`run` it.

    Attributes:
        script: the parsed script.
        registration: the locomotion set's n-way :class:`mjmotion.registration.Registration`.
        transitions: one :class:`Transition` per played clip, filled by :meth:`tracks`.
    """

    def __init__(self, script: Script, joint_weights: dict[str, float] | None = None):
        """``joint_weights``: joint name → weight of the registration distance (seed 000 §3.1)."""
        self.script = script
        loco = [script.clips[n] for n in script.locomotion]
        positions = [reg.positions_of(m) for m in loco]
        self.registration = reg.register_many(loco, reference=0, positions=positions, weights=joint_weights)
        r = self.registration
        self._ref = r.times[:, r.reference]
        self._seg = np.diff(r.times, axis=0)  # (M-1, n) frames of each clip per segment
        # self-distances of the reference clip, for loop points (seed 000 loops its clips)
        w = reg.joint_weights(loco[0].skeleton, joint_weights)
        self._self_cost = reg.distance_grid(positions[r.reference], positions[r.reference], w).cost
        self.transitions: list[Transition] = []

    def rate(self, w: np.ndarray) -> float:
        """The locomotion's pace at clip weights ``w``: reference frames per output frame over the
        whole registration (:func:`mjmotion.blend.segment_frames`); 1 with the reference alone."""
        frames = np.sum(1.0 / np.sum(np.asarray(w) / self._seg, axis=1))
        return float((self._ref[-1] - self._ref[0]) / frames)

    def _advance(self, tau: float, w: np.ndarray) -> float:
        """``τ`` one output frame later at clip weights ``w`` (exact per segment, as
        :func:`mjmotion.blend.segment_frames`); stops at the end of the registration."""
        ref = self._ref
        m = min(int(np.searchsorted(ref, tau, side="right")) - 1, len(ref) - 2)
        remaining = 1.0
        while remaining > 1e-12 and m < len(ref) - 1:
            frames = 1.0 / float(np.sum(w / self._seg[m]))  # output frames across segment m
            span = ref[m + 1] - ref[m]
            left = (ref[m + 1] - tau) / span * frames
            if left >= remaining:
                return tau + remaining / frames * span
            tau, remaining, m = ref[m + 1], remaining - left, m + 1
        return float(tau)  # the end of the curve, or a round-off short of a segment boundary

    def loop_point(self, tau: float) -> float:
        """An earlier reference time whose pose best matches ``tau`` (at least a third of the span back)."""
        lo, hi = self._ref[0], self._ref[-1]
        cand = np.arange(int(np.ceil(lo)), int(np.floor(tau - (hi - lo) / 3.0)) + 1)
        if len(cand) == 0:
            raise MjmotionError(
                "the locomotion clips are too short to loop (their registered span is "
                f"{(hi - lo) / self.script.fps:.2f} s); use longer clips or a shorter loop_blend"
            )
        row = self._self_cost[int(round(tau)), cand]
        return float(cand[int(np.argmin(row))])

    def run(self, name: str = "stream") -> Motion:
        """The streamed motion, ``duration × fps`` frames on the first locomotion clip's skeleton."""
        return compose(self.tracks(), self.script.fps, name)

    def tracks(self) -> list[Track]:
        """The source tracks the stream composes (each locomotion clip per loop playhead, then each
        played clip), weights ``(N,)`` each, ``N = duration × fps``.

        Refuses (before composing) a stream whose tracks would not compose within
        :data:`MEMORY_LIMIT_BYTES`: short locomotion clips loop often, and every loop adds tracks.
        """
        s = self.script
        fps = s.fps
        n_out = int(round(s.duration * fps))
        times = np.arange(n_out) / fps
        keys = tuple((c.time, c.ramp, c.weights) for c in s.commands if c.kind == "weights" and c.weights is not None)
        loc_w = WeightCurve(keys)(times)  # (N, n_loc)
        action_w, action_tracks = self._actions(n_out, loc_w)
        fade_n = max(1, int(round(s.loop_blend * fps)))
        cursors = [_Cursor(float(self._ref[0]), n_out)]
        done: list[_Cursor] = []
        fading: tuple[_Cursor, _Cursor, int] | None = None
        for n in range(n_out):
            w = loc_w[n]
            for c in cursors:
                new_tau = self._advance(c.tau, w) if n > 0 else c.tau  # never past the curve's end
                c.taus[n], c.dtaus[n] = new_tau, new_tau - c.tau
                c.tau = new_tau
            if fading is None:
                cursors[-1].fade[n] = 1.0
                head = cursors[-1]
                if head.tau + 1.5 * fade_n * max(self._advance(head.tau, w) - head.tau, 1e-6) >= self._ref[-1]:
                    # every playhead adds at least one track: stop before they outgrow memory
                    self._check_memory(n_out, len(done) + len(cursors) + 1 + len(action_tracks), at_least=True)
                    new = _Cursor(self.loop_point(head.tau), n_out)
                    new.taus[n] = new.tau
                    cursors.append(new)
                    fading = (head, new, n)
            if fading is not None:
                old, new, n0 = fading
                s_f = float(bezier_ease(np.array((n - n0) / fade_n)))
                old.fade[n], new.fade[n] = 1.0 - s_f, s_f
                if n - n0 >= fade_n:
                    cursors.remove(old)
                    done.append(old)
                    fading = None
        tracks: list[Track] = []
        loco_clips = [s.clips[k] for k in s.locomotion]
        for c in done + cursors:
            active = c.fade > 0
            clip_t = self.registration.at(c.taus)
            prev_t = self.registration.at(c.taus - c.dtaus)
            for k, m in enumerate(loco_clips):
                w = (1.0 - action_w) * c.fade * loc_w[:, k]
                if np.any(w[active] > 0):
                    tracks.append(Track(m, clip_t[:, k], clip_t[:, k] - prev_t[:, k], w))
        tracks.extend(action_tracks)
        self._check_memory(n_out, len(tracks))
        return tracks

    def _check_memory(self, n_out: int, n_tracks: int, at_least: bool = False) -> None:
        """Refuse a stream of ``n_out`` frames and ``n_tracks`` source tracks that would not
        compose within :data:`MEMORY_LIMIT_BYTES`."""
        s = self.script
        n_joints = s.clips[s.locomotion[0]].skeleton.n_joints
        if n_out <= max_frames(n_joints, n_tracks):
            return
        need = n_tracks * n_out * n_joints * BYTES_PER_TRACK_FRAME_JOINT
        raise MjmotionError(
            f"script.duration {s.duration:g} s: composing it needs {'over' if at_least else 'about'} {need / 2**30:.3g} GiB "
            f"({'at least ' if at_least else ''}{n_tracks} source tracks × {n_out} frames × {n_joints} joints × "
            f"{BYTES_PER_TRACK_FRAME_JOINT} bytes; every loop of the locomotion adds tracks), over the "
            f"{MEMORY_LIMIT_BYTES / 2**30:g} GiB limit; use a shorter duration or longer locomotion clips"
        )

    def _fade(self, nominal: int, w: np.ndarray) -> tuple[float, int]:
        """The locomotion's pace at clip weights ``w`` and the output frames of a fade of
        ``nominal`` reference frames (seed 000 §3.3: longer from or back to a faster motion)."""
        r = self.rate(w)
        return r, max(1, int(round(nominal * r)))

    def _actions(self, n_out: int, loc_w: np.ndarray) -> tuple[np.ndarray, list[Track]]:
        """Weight ``(N,)`` of the action layer and one track per played clip; fills :attr:`transitions`.

        ``loc_w: (N, n_loc)`` the locomotion weights, whose pace sets each fade's length (module
        docstring, seed 000 §3.3).
        """
        s = self.script
        fps = s.fps
        layer = np.zeros(n_out)
        tracks = []
        self.transitions = []
        cmds = list(s.commands)
        n = np.arange(n_out)
        for k, c in enumerate(cmds):
            if c.kind != "play" or c.clip is None:
                continue
            clip = s.clips[c.clip]
            n0 = int(round(c.time * fps))
            if n0 >= n_out:
                continue
            last = clip.n_frames - 1

            nominal_in = max(1, int(round(c.blend * fps)))
            rate_in, fade_in = self._fade(nominal_in, loc_w[min(n0, n_out - 1)])
            ramp_in = np.where(n < n0, 0.0, bezier_ease((n - n0) / fade_in))
            ratio = np.where((n > n0) & (n <= n0 + fade_in), nominal_in / fade_in, 1.0)
            # the clip's clock without a fade-out: its own rate blended with the window's
            clock = np.cumsum(np.where(n > n0, ramp_in + (1.0 - ramp_in) * ratio, 0.0))
            # the fade back starts where the rest of the clip is what the fade-out covers ...
            nominal_out = nominal_in
            rate_out, fade_out = self._fade(nominal_out, loc_w[min(int(np.searchsorted(clock, last - nominal_out)), n_out - 1)])
            a_out = 1.0 - bezier_ease(np.arange(1, fade_out + 1) / fade_out)
            covered = float(np.sum(a_out + (1.0 - a_out) * nominal_out / fade_out))
            out_start = int(np.searchsorted(clock, last - covered))
            for later in cmds[k + 1 :]:  # ... or at the next return (or action), if that is earlier
                if later.kind in ("return", "play"):
                    n_ret = int(round(later.time * fps))
                    if n_ret < out_start:
                        nominal_out, out_start = max(1, int(round(later.blend * fps))), n_ret
                        rate_out, fade_out = self._fade(nominal_out, loc_w[min(n_ret, n_out - 1)])
                    break
            if out_start <= n0:
                raise MjmotionError(
                    f"script: play {c.clip!r} at {c.time:g} s would fade out before it starts (clip {clip.n_frames / fps:.2f} s, "
                    f"blend {c.blend:g} s); use a longer clip, a shorter blend or a later return"
                )
            ramp_out = 1.0 - bezier_ease((n - out_start) / fade_out)
            wk = np.where(n < n0, 0.0, np.minimum(ramp_in, ramp_out))
            ratio = np.where((n > out_start) & (n <= out_start + fade_out), nominal_out / fade_out, ratio)
            step = np.where((n > n0) & (n <= out_start + fade_out), wk + (1.0 - wk) * ratio, 0.0)
            t = np.minimum(np.cumsum(step), last)  # a fade-out rounded past the clip's end holds its last frame
            layer = np.maximum(layer, wk)
            tracks.append(Track(clip, t, np.r_[0.0, np.diff(t)], wk))
            end = min(out_start + fade_out, n_out - 1)
            self.transitions.append(
                Transition(c.clip, n0, fade_in, nominal_in, rate_in, out_start, fade_out, nominal_out, rate_out, end, float(t[end]))
            )
        # several actions: their own weights share the action layer
        if tracks:
            total = np.sum([tr.weights for tr in tracks], axis=0)
            scale = np.divide(layer, total, out=np.zeros(n_out), where=total > 0)
            tracks = [Track(tr.motion, tr.times, tr.steps, tr.weights * scale) for tr in tracks]
        return layer, tracks


@overload
def stream(script: Script, name: str = ..., with_tracks: Literal[False] = ...) -> Motion: ...
@overload
def stream(script: Script, name: str = ..., *, with_tracks: Literal[True]) -> tuple[Motion, tuple[Track, ...]]: ...
def stream(script: Script, name: str = "stream", with_tracks: bool = False) -> Motion | tuple[Motion, tuple[Track, ...]]:
    """Run ``script`` through a :class:`MotionStream`; with ``with_tracks`` also the source
    tracks it composed (see :meth:`MotionStream.tracks`), as ``(motion, tracks)``."""
    tracks = MotionStream(script).tracks()
    motion = compose(tracks, script.fps, name)
    return (motion, tuple(tracks)) if with_tracks else motion
