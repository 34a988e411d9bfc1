"""A motion stream with weight ramps and transitions into kicks and punches (seed 000 §3.3).

The stream (:mod:`mjmotion.stream`) plays a registered walk/run set: walk, a Bezier ramp to a
walk/run blend, a transition into a kick and back, a ramp back to the walk, and a second action
(a punch in the bundled set; the second soccer kick on real mocap, whose only punch is on another
skeleton). Continuity is measured phase by phase:

* ``max_joint_speed_ratio`` and ``root_jump_m`` against the source clips (METRICS.md);
* the heading's largest change in one frame against the sources' — seed 000 §4.1's time blip
  "causes the character to rotate a large amount in one frame";
* the clocks: every source track's clock never steps backwards where it carries weight, never
  jumps other than by its own step (``hidden jump``), and the blended clock rate — the weighted
  mean of the tracks' frames per output frame — changes by at most ``max Δ rate`` per frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import bvh, plots
from .. import evaluate as ev
from .. import rotations as rot
from .. import stream as st
from ..blend import Track, compose, yaw_of
from ..errors import MjmotionError
from ..skeleton import Motion
from . import Table

COLUMNS = (
    "phase", "from s", "to s", "speed m/s", "max joint speed ratio", "per-joint speed ratio", "root jump m", "max heading step °/frame",
    "sources' max °/frame", "min clock step", "hidden jump frames", "max Δ rate frames/frame",
)  # fmt: skip
#: 10_01 and 10_02: approach, right-foot kick (peak toe speed near frames 596 and 349), recovery (SOURCES.md).
REAL_ACTIONS = {"kick": ("10_01", 500, 720), "kick2": ("10_02", 250, 470)}


@dataclass(frozen=True)
class StreamResult:
    """A streamed motion with the tracks it was composed of.

    Attributes:
        script: the script that was run.
        motion: the output, ``N`` frames.
        tracks: every source track (locomotion clips per playhead, actions), weights ``(N,)`` each.
        transitions: each played clip's fades (:class:`mjmotion.stream.Transition`).
    """

    script: st.Script
    motion: Motion
    tracks: tuple[Track, ...]
    transitions: tuple[st.Transition, ...] = ()

    def weights_by_clip(self) -> tuple[list[str], np.ndarray]:
        """Clip names and their normalised weights ``(N, C)`` (a clip's playheads summed)."""
        names = list(self.script.clips)
        w = np.zeros((self.motion.n_frames, len(names)))
        for tr in self.tracks:
            w[:, names.index(tr.motion.name)] += tr.weights
        total = w.sum(axis=1, keepdims=True)
        return names, np.divide(w, total, out=np.zeros_like(w), where=total > 0)


def absolute_compose(tracks: tuple[Track, ...], fps: float, name: str = "naive") -> Motion:
    """The naive baseline: the same tracks averaged in their clips' own coordinates (root positions
    and every rotation, root included, weighted as they are) instead of by root increments.

    Each clip is where it was captured, so a transition drags the character toward the other
    clip's place and heading and back — the jump-and-turn of seed 000 §4.1's blip, spread over
    the blend window. ``(N frames)`` on the first track's skeleton.
    """
    w = np.stack([tr.weights for tr in tracks], axis=1)
    w = w / np.maximum(w.sum(axis=1, keepdims=True), 1e-12)  # (N, E)
    samples = [tr.motion.sample(tr.times) for tr in tracks]
    root = np.einsum("ne,nec->nc", w, np.stack([s[0] for s in samples], axis=1))
    q = np.stack([s[1] for s in samples], axis=2)  # (N, J, E, 4)
    q_out = rot.make_continuous(rot.weighted_average(q, np.broadcast_to(w[:, None, :], q.shape[:3]), axis=2))
    skel = tracks[0].motion.skeleton
    translations = None
    if any(s[2] is not None for s in samples):
        offsets = np.broadcast_to(skel.offsets, q.shape[:2] + (3,))
        tr_all = np.stack([s[2] if s[2] is not None else offsets for s in samples], axis=1)
        translations = np.einsum("ne,nejc->njc", w, tr_all)
    return Motion(skel, fps, root, q_out, translations, name)


def run_stream(script: st.Script) -> StreamResult:
    """Run ``script`` and keep its tracks and transitions."""
    controller = st.MotionStream(script)
    tracks = controller.tracks()
    return StreamResult(script, compose(tracks, script.fps, "stream"), tuple(tracks), tuple(controller.transitions))


# --------------------------------------------------------------------------------------------
# scripts
# --------------------------------------------------------------------------------------------
def _script(clips: dict[str, Motion], actions: tuple[str, str], fps: float, blend: float = 0.3) -> st.Script:
    """walk → ramp to walk/run .5 → first action → ramp back to walk → second action → walk."""
    n_loc = 2
    first, second = actions
    t1 = 2.6
    t2 = t1 + clips[first].n_frames / fps + 1.0
    duration = t2 + clips[second].n_frames / fps + 1.0
    walk, mixed = np.eye(n_loc)[0], np.array([0.5, 0.5])
    commands = (
        st.Command(0.0, "weights", walk, ramp=0.0),
        st.Command(1.0, "weights", mixed, ramp=0.8),
        st.Command(t1, "play", clip=first, blend=blend),
        st.Command(t1 + 1.4, "weights", walk, ramp=0.5),
        st.Command(t2, "play", clip=second, blend=blend),
    )
    return st.Script(clips=clips, locomotion=("walk", "run"), commands=commands, duration=round(duration, 2), fps=fps)


def bundled_script() -> st.Script:
    """The bundled walk and run (locomotion), kick and punch, 60 fps."""
    from .. import synth

    clips = {
        "walk": synth.walk().motion.replace(name="walk"),
        "run": synth.run().motion.replace(name="run"),
        "kick": synth.kick().motion.replace(name="kick"),
        "punch": synth.punch().motion.replace(name="punch"),
    }
    return _script(clips, ("kick", "punch"), 60.0)


def real_script(data_dir: Path) -> st.Script:
    """ASF/AMC walks 16_15 (1.1 m/s) and 16_24 (1.6 m/s, the 'run' role: the flavour has no run)
    and the soccer kicks 10_01 and 10_02, 120 fps."""
    d = Path(data_dir) / "cmu_asfamc_converted"

    def clip(name: str, a: int, b: int | None, label: str) -> Motion:
        path = d / f"{name}.bvh"
        if not path.is_file():
            raise MjmotionError(f"{path}: missing; the experiment needs the CMU ASF/AMC walks and kicks (SOURCES.md)")
        return bvh.read(str(path))[a:b].replace(name=label)

    clips = {
        "walk": clip("16_15", 2, None, "walk"),  # frames 0–1: zeroed left arm (SOURCES.md)
        "run": clip("16_24", 0, None, "run"),
        **{label: clip(name, a, b, label) for label, (name, a, b) in REAL_ACTIONS.items()},
    }
    return _script(clips, ("kick", "kick2"), clips["walk"].fps)


# --------------------------------------------------------------------------------------------
# measures
# --------------------------------------------------------------------------------------------
def phases(script: st.Script, transitions: Sequence[st.Transition]) -> list[tuple[str, float, float]]:
    """``(name, start_s, end_s)`` of each phase of a :func:`_script` stream, its fades as ``transitions`` says."""
    c = script.commands
    ramp, act2 = c[1], c[4]
    fps = script.fps
    out = [("walk", 0.0, ramp.time), ("ramp to walk/run .5", ramp.time, ramp.time + ramp.ramp), ("walk/run .5", ramp.time + ramp.ramp, c[2].time)]
    for k, t in enumerate(transitions):
        out += [
            (f"into {t.clip}", t.start / fps, (t.start + t.fade_in) / fps),
            (t.clip, (t.start + t.fade_in) / fps, t.fade_out_start / fps),
            (f"{t.clip} back to locomotion", t.fade_out_start / fps, t.end / fps),
        ]
        if k == 0:
            out.append(("walk (ramped back)", t.end / fps, act2.time))
    out.append(("walk", out[-1][2], script.duration))
    out.append(("whole stream", 0.0, script.duration))
    return out


def heading_steps(motion: Motion) -> np.ndarray:
    """``(T-1,)`` absolute change of the root's heading per frame, degrees."""
    return np.degrees(np.abs(np.diff(np.unwrap(yaw_of(motion.rotations[:, 0])))))


def per_joint_speed_ratio(result: Motion, sources: list[Motion]) -> float:
    """Max over joints of the joint's peak angular speed in ``result`` over its peak in any source.

    Stricter than METRICS' ``max_joint_speed_ratio``, which one source's own spike (a kick's
    foot) can mask for every other joint; joints still in every source count only if they move.
    """
    res = ev.joint_angular_speeds(result).max(axis=0)
    src = np.max([ev.joint_angular_speeds(s).max(axis=0) for s in sources], axis=0)
    moving = src > 1e-6
    if np.any(res[~moving] > 1e-6):
        return float("inf")
    return float((res[moving] / src[moving]).max())


def clock_checks(result: StreamResult) -> dict[str, np.ndarray]:
    """Per output frame ``(N,)``: the smallest step of a weighted track (frames; < 0 would be time
    running backwards), the largest hidden jump (a weighted track's time changing by other than
    its step) and the blended clock rate (weighted mean step, frames of source per output frame)."""
    n = result.motion.n_frames
    min_step = np.full(n, np.inf)
    hidden = np.zeros(n)
    w_all = np.stack([tr.weights for tr in result.tracks], axis=1)
    w_all = w_all / np.maximum(w_all.sum(axis=1, keepdims=True), 1e-12)
    rate = np.zeros(n)
    for k, tr in enumerate(result.tracks):
        on = tr.weights > 0
        both = on & np.r_[False, on[:-1]]  # weighted now and in the frame before
        min_step = np.where(on, np.minimum(min_step, tr.steps), min_step)
        jump = np.abs(np.r_[0.0, np.diff(tr.times)] - tr.steps)
        hidden = np.where(both, np.maximum(hidden, jump), hidden)
        rate += w_all[:, k] * tr.steps
    rate[0] = rate[1] if n > 1 else rate[0]  # frame 0 has no step
    return {"min_step": min_step, "hidden": hidden, "rate": rate}


def phase_row(result: StreamResult, name: str, t0: float, t1: float, sources: list[Motion], checks: dict) -> tuple:
    """A row of :data:`COLUMNS` over output frames ``[t0, t1)`` seconds (plus the step into it)."""
    fps = result.motion.fps
    a = max(0, round(t0 * fps) - 1)
    b = min(result.motion.n_frames, max(a + 2, round(t1 * fps) + 1))
    seg = result.motion[a:b]
    src_heading = max(float(heading_steps(s).max()) for s in sources)
    per_joint = per_joint_speed_ratio(seg, sources)
    speed = float(np.linalg.norm(np.diff(seg.root_positions[:, :2], axis=0), axis=1).sum() / seg.duration)
    rate = checks["rate"][a + 1 : b]
    min_step = float(checks["min_step"][a + 1 : b].min())
    return (
        name, t0, t1, speed, ev.max_joint_speed_ratio(seg, sources), per_joint, ev.root_jump_m(seg, sources),
        float(heading_steps(seg).max()), src_heading, min_step, float(checks["hidden"][a + 1 : b].max()),
        float(np.abs(np.diff(rate)).max()) if len(rate) > 1 else 0.0,
    )  # fmt: skip


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False) -> Table:
    """Stream, measure and plot; writes ``out_dir/table.md``, ``weights.png`` and the stream's BVH."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    script = real_script(data_dir) if data_dir is not None else bundled_script()
    result = run_stream(script)
    sources = list(script.clips.values())
    checks = clock_checks(result)
    names = ", ".join(f"{k} {m.n_frames / m.fps:.2f} s" for k, m in script.clips.items())
    source = (
        "real mocap, CMU ASF/AMC at 120 fps: walk = 16_15, run = 16_24 (a fast walk; no run in this flavour), "
        "kick = 10_01[500:720], kick2 = 10_02[250:470]" if data_dir is not None
        else "bundled procedural clips (mjmotion.synth, 60 fps): walk, run, kick, punch"
    )  # fmt: skip
    table = Table(
        "Motion stream: walk → walk/run blend → kick → walk → second action → walk (seed 000 §3.3)",
        COLUMNS,
        notes=[
            f"source: {source} ({names}); output {result.motion.n_frames} frames",
            "commands: " + "; ".join(
                f"{c.time:g} s {c.kind}" + (f" {c.clip} (blend {c.blend:g} s)" if c.kind == "play" else f" {np.round(np.asarray(c.weights), 2).tolist()} (ramp {c.ramp:g} s)")
                for c in script.commands
            ),
            ("naive: the same tracks averaged in their clips' own coordinates (absolute roots and root rotations) "
             "instead of composed from root increments — the baseline that shows a blip"),
            ("max joint speed ratio, root jump: METRICS.md against every source clip (≤ 1.5 and ≤ 0 m: no pop, no jump); "
                "per-joint speed ratio: the same joint by joint (one source's spike cannot mask another joint's pop)"),
            ("heading step: the root's largest turn in one frame; seed 000 §4.1's time blip turned the character "
                "a large amount in one frame when returning from a transition clip"),
            ("min clock step: smallest clip-time step of any weighted track (< 0 = time running backwards); hidden jump: "
                "a weighted track's time changing by other than its step; max Δ rate: largest frame-to-frame change of the "
                "blended clock rate (weighted mean step, source frames per output frame)"),
        ],
    )  # fmt: skip
    for name, t0, t1 in phases(script, result.transitions):
        table.add(*phase_row(result, name, t0, t1, sources, checks))
    # the same tracks composed naively: the metrics must flag what the incremental root avoids
    naive = StreamResult(script, absolute_compose(result.tracks, script.fps), result.tracks)
    for name, t0, t1 in phases(script, result.transitions):
        if "back to locomotion" in name or name == "whole stream":
            table.add(*phase_row(naive, f"naive: {name}", t0, t1, sources, checks))
    clip_names, weights = result.weights_by_clip()
    t = np.arange(result.motion.n_frames) / result.motion.fps
    files = [plots.weight_curves(t, weights, out_dir / "weights.png", labels=clip_names, title="stream weights per source clip")]
    if not quick:
        path = out_dir / "stream.bvh"
        bvh.write(result.motion, path)
        files.append(path)
    fades = transitions_table(result)
    (out_dir / "transitions.md").write_text(fades.markdown(), encoding="utf-8")
    table.files = [str(out_dir / "transitions.md"), *(str(f) for f in files)]
    table.write(out_dir)
    with open(out_dir / "table.md", "a", encoding="utf-8") as f:
        f.write("\n" + fades.markdown())
    return table


TRANSITION_COLUMNS = (
    "clip", "start s", "locomotion pace r (in)", "fade-in frames", "blend·fps", "fade-out start s", "pace r (out)",
    "fade-out frames", "blend·fps (out)", "end s", "clip frames played", "clip's last frame",
)  # fmt: skip


def transitions_table(result: StreamResult) -> Table:
    """Each played clip's fades (seed 000 §3.3): their lengths against the nominal ``blend · fps`` and
    the locomotion's pace that scales them (:data:`TRANSITION_COLUMNS`)."""
    fps = result.script.fps
    table = Table(
        "Transition timing scaled by the locomotion's pace (seed 000 §3.3)",
        TRANSITION_COLUMNS,
        notes=[
            ("pace r: reference (walk) frames per output frame of the locomotion mix at the fade's start; a fade lasts "
                "blend·fps·r output frames (seed 000: 'if the motion has a shorter time span than the reference … the "
                "transition duration was lengthened'); over a fade the clip advances a + (1 − a)·blend·fps / fade frames "
                "per output frame (a its weight), so it covers its blend window and ends on its last frame"),
        ],
    )  # fmt: skip
    for t in result.transitions:
        clip = result.script.clips[t.clip]
        table.add(t.clip, t.start / fps, t.rate_in, t.fade_in, t.nominal_fade_in, t.fade_out_start / fps, t.rate_out,
                  t.fade_out, t.nominal_fade_out, t.end / fps, t.clip_frames, clip.n_frames - 1)  # fmt: skip
    return table
