"""Shot variations in PCA space: exaggerated, muted, aborted (seed 003 §3, Figures 3.1, 3.4, 3.7).

Figure 3.1: the shots that share a skeleton, in one PCA space (:func:`shared_space`).

For each shot: the PCA space of the clip (``style.PoseSpace``, root translation and every
joint's quaternion, standardised), its own score path with ``k`` controlled components (the
fewest explaining ``variations.DEFAULT_VARIANCE`` of the motion), and three new paths:
``variations.scaled_path`` by 1.3 (exaggerated) and 0.7 (muted) about the path's centre, and
``variations.aborted_path`` at a mid-backswing frame back to the rest pose (§3.2.3). Each is
rebuilt (``variations.synthesise``) and cleaned up (``variations.clean_up``: feet on the source's
footprints, the second hand back on the grip, §3.3). Measured (METRICS.md): the effector's
path length in the swing segment against the source's, the largest joint speed against the
source's (``max_joint_speed_ratio``, whole-body, and ``worst_joint_speed_ratio``, per joint), pop
frames (``pop_frames`` against the source), footskate (``skate_mm_per_s``, ``planted_skate_mm_per_s``)
before and after cleanup, grip error, and for the abort how exactly it follows the source up
to the abort frame and ends at the rest pose.

The swing phases come from the effector's speed (:func:`phases`): the impact's speed peak, the
top of the backswing (the last slow frame before it), the start of the backswing and the end
of the follow-through; the abort frame is the middle of the backswing.

Real data: the golf swings ``64_01..05`` (the fitted club's head) and the kicks ``10_01``/``10_02``
(the right foot). Bundled: drive, pull (bat) and the front kick. ``quick``: the drive.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import Table, single_thread_blas
from .hitpoint_grid import Shot, load_shots

if TYPE_CHECKING:
    from ..executor import Executor
    from ..skeleton import Motion

#: Scale factors of the exaggerated and muted variants (§3.2.3, Figure 3.7 red/green).
EXAGGERATE, MUTE = 1.3, 0.7
#: Threshold (fraction of a speed peak) under which the effector counts as still.
STILL = 0.1
#: Fraction of the impact speed under which the top of the backswing is searched.
TOP = 0.2

COLUMNS = (
    "shot", "variant", "k", "var. expl.", "path src m", "path m", "path ratio", "speed ratio raw",
    "speed ratio clean", "worst joint raw", "worst joint clean", "pops src", "pops raw", "pops clean",
    "skate src", "skate raw", "skate clean", "planted src", "planted raw",
    "planted clean", "grip raw mm", "grip clean mm", "style_rmse", "prefix dev mm", "end dev mm", "first/last dev mm",
)  # fmt: skip


@dataclass(frozen=True)
class Phases:
    """Frames of a swing, from the effector's speed.

    Attributes:
        start: the backswing starts (the effector leaves rest).
        top: top of the backswing (the slowest frame before the downswing).
        impact: the impact's speed peak.
        end: the follow-through ends (the effector back under ``STILL`` of the impact speed).
        abort: the middle of the backswing (of the wind-up from ``top`` to ``impact`` when the
            effector hardly moves before ``top``, as in a front kick).
    """

    start: int
    top: int
    impact: int
    end: int
    abort: int

    @property
    def segment(self) -> tuple[int, int]:
        """The swing segment, half-open: backswing start to follow-through end."""
        return self.start, self.end + 1


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    """Hann-window smoothing of ``x: (T, 3)`` over ``2n + 1`` frames, ends padded with the edge value."""
    k = np.hanning(2 * n + 3)[1:-1]
    k /= k.sum()
    xp = np.pad(x, ((n, n), (0, 0)), mode="edge")
    return np.stack([np.convolve(xp[:, i], k, mode="valid") for i in range(x.shape[1])], axis=1)


def phases(effector: np.ndarray, fps: float, hit: int) -> Phases:
    """The swing's :class:`Phases` from ``effector: (T, 3)`` metres and the hit frame.

    Speeds are smoothed over ~0.1 s. The impact peak is the fastest frame within 0.15 s before
    and 0.05 s after ``hit``; the top is the last frame before it slower than ``TOP`` × that speed,
    walked back to the local minimum; the backswing's own peak is the fastest frame in the
    three downswing-durations before the top, and its start the last frame before that peak
    slower than ``STILL`` × its speed. The follow-through ends at the first frame after the impact
    slower than ``STILL`` × the impact speed, but not before one downswing-duration after it.
    """
    t_n = len(effector)
    v = np.linalg.norm(np.gradient(_smooth(effector, max(1, round(0.05 * fps))), axis=0), axis=1) * fps
    a, b = max(0, hit - int(0.15 * fps)), min(t_n, hit + int(0.05 * fps) + 1)
    impact = a + int(np.argmax(v[a:b]))
    low = np.flatnonzero(v[:impact] < TOP * v[impact])
    top = int(low[-1]) if low.size else 0
    while top > 0 and v[top - 1] <= v[top]:
        top -= 1
    w0 = max(0, top - 3 * (impact - top))
    peak = w0 + int(np.argmax(v[w0 : top + 1]))
    if v[peak] >= STILL * v[impact]:
        low = np.flatnonzero(v[:peak] < STILL * v[peak])
        start = int(low[-1]) if low.size else 0
        abort = (start + top) // 2
    else:  # no backswing before the top (a front kick's chamber): abort in the wind-up
        start = top
        abort = (top + impact) // 2
    low = np.flatnonzero(v[impact:] < STILL * v[impact])
    end = impact + int(low[0]) if low.size else t_n - 1
    end = min(max(end, impact + (impact - top)), t_n - 1)
    abort = int(np.clip(abort, 1, t_n - 2))
    return Phases(start, top, impact, end, abort)


def _effector(shot: Shot) -> tuple[np.ndarray, object | None, int | None]:
    """The source effector ``(T, 3)`` and what measures it in a variant: ``(positions, prop, joint)``."""
    from .. import hitpoint

    p = hitpoint.setup(shot.motion, offset=np.zeros(3), frame=shot.hit_frame, effector=shot.effector, prop=shot.prop)  # type: ignore[arg-type]
    if shot.prop is not None:
        return p.effector_fk, shot.prop, None
    return p.effector_fk, None, p.effector.joint


@dataclass(frozen=True, eq=False)
class ShotResult:
    """Everything measured on one shot: its phases, ``k``, the rows and the score paths for the plots."""

    shot: str
    phases: Phases
    k: int
    explained: float
    rows: list[tuple]
    paths: dict[str, np.ndarray]
    marks: dict[str, int]


def run_shot(shot: Shot) -> ShotResult:
    """The three variants of ``shot``, raw and cleaned up, measured (see the module doc)."""
    from .. import evaluate as ev
    from .. import kinematics, mjcf
    from .. import variations as V
    from ..style import PoseSpace, style_rmse

    src = shot.motion
    eff, prop, joint = _effector(shot)
    ph = phases(eff, src.fps, shot.hit_frame)
    # inner-joint translations are parameters too (as ``mjmotion vary``), so nothing is lost
    space = PoseSpace.fit(src, translations=True)
    k = space.components_for(V.DEFAULT_VARIANCE)
    base = V.source_path(space, k)
    variants = {
        f"exaggerated ×{EXAGGERATE:g}": V.scaled_path(base, EXAGGERATE, fps=src.fps),
        f"muted ×{MUTE:g}": V.scaled_path(base, MUTE, fps=src.fps),
        f"aborted at {ph.abort}": V.aborted_path(base, ph.abort, fps=src.fps, space=space),
    }
    compiled = mjcf.compile(src.skeleton)
    ref = kinematics.forward(compiled, src).joint_positions
    seg = ph.segment

    def path_len(m) -> float:
        a, b = seg[0], min(seg[1], m.n_frames)
        return V.effector_path_length(m, joint, (a, b), prop)  # type: ignore[arg-type]

    base_len = path_len(src)
    # one compiled model for every clip's foot track (the metrics would each compile and run FK)
    track_src = ev.foot_heights_speeds(compiled, src)
    skate_src, planted_src = ev.skate_mm_per_s(track_src), ev.planted_skate_mm_per_s(track_src)
    rows = []
    paths = {"source": space.source_scores}
    marks = {"source": shot.hit_frame}
    for label, p in variants.items():
        raw = V.synthesise(space, p)
        clean, _ = V.clean_up(src, raw, p, first_hand=shot.first_hand)
        pose_clean = kinematics.forward(compiled, clean)
        track_raw = ev.foot_heights_speeds(compiled, raw)
        track_clean = ev.foot_heights_speeds(compiled, clean, pose_clean)
        length = path_len(clean)
        grip = (
            (1000 * V.grip_error_m(src, raw, p, shot.first_hand), 1000 * V.grip_error_m(src, clean, p, shot.first_hand))
            if shot.first_hand is not None
            else (float("nan"), float("nan"))
        )
        style = style_rmse(src, clean)[0] if clean.n_frames == src.n_frames else float("nan")
        prefix = end = float("nan")
        # seed §2.2.5: the shots' common start and end poses (an abort ends at the rest pose where it stands)
        got_fk = pose_clean.joint_positions
        ends = [0] if label.startswith("aborted") else [0, -1]
        first_last = 1000 * max(float(np.max(np.linalg.norm(got_fk[i] - ref[i], axis=-1))) for i in ends)
        if label.startswith("aborted"):
            got = pose_clean.joint_positions
            f = ph.abort
            prefix = 1000 * float(np.max(np.linalg.norm(got[: f + 1] - ref[: f + 1], axis=-1)))
            # the rest pose where the character stands: the source's last frame moved by the path's shift
            end = 1000 * float(np.max(np.linalg.norm(got[-1] - (ref[-1] + p.shift_b), axis=-1)))
            marks[label] = f
        else:
            marks[label] = shot.hit_frame
        rows.append((
            shot.name, label, k, float(space.cumulative[k - 1]), base_len, length, length / base_len if base_len > 0 else float("nan"),
            ev.max_joint_speed_ratio(raw, src), ev.max_joint_speed_ratio(clean, src),
            _worst(raw, src), _worst(clean, src),
            int(ev.pop_frames(src, src).sum()), int(ev.pop_frames(raw, src).sum()), int(ev.pop_frames(clean, src).sum()),
            skate_src, ev.skate_mm_per_s(track_raw), ev.skate_mm_per_s(track_clean),
            planted_src, ev.planted_skate_mm_per_s(track_raw), ev.planted_skate_mm_per_s(track_clean),
            grip[0], grip[1], style, prefix, end, first_last,
        ))  # fmt: skip
        paths[label] = p.scores
    return ShotResult(shot.name, ph, k, float(space.cumulative[k - 1]), rows, paths, marks)


def _worst(m: Motion, src: Motion) -> str:
    """``worst_joint_speed_ratio`` of ``m`` against ``src`` and its joint, as a table cell ("2.78 rradius")."""
    from .. import evaluate as ev

    ratio, joint = ev.worst_joint_speed_ratio(m, src)
    return f"{ratio:.2f} {joint}"


def _task(shot: Shot) -> ShotResult:
    with single_thread_blas():
        return run_shot(shot)


def plot(result: ShotResult, out_dir: Path) -> list[Path]:
    """Figure 3.7 (the source and its variants in PC1–PC2, PC3–PC4) and Figures 3.1/3.4 (the
    source's path in 3-D, split into preparation, shot and return)."""
    from .. import plots

    ph = result.phases
    src = result.paths["source"]
    a, b = ph.start, ph.end
    sections = {"preparation": src[: a + 1], "shot (backswing to follow-through)": src[a : b + 1], "return to rest": src[b:]}
    sections = {n: s for n, s in sections.items() if len(s) >= 2}
    hl = {"shot (backswing to follow-through)": ph.impact - a} if "shot (backswing to follow-through)" in sections else None
    f1 = plots.score_paths(
        sections, out_dir / f"sections_{result.shot}.png", dims=3, highlight=hl,
        title=f"{result.shot}: the source's path in its PC space (★ impact)",
    )  # fmt: skip
    f2 = plots.score_paths(
        result.paths, out_dir / f"variants_{result.shot}.png", dims=2, highlight=result.marks,
        title=f"{result.shot}: source and variants (★ impact / abort frame)",
    )  # fmt: skip
    return [f1, f2]


def shared_space(shots: list[Shot], out_dir: Path) -> list[Path]:
    """Seed Figure 3.1: several shots plotted in one 3-D principal-component space.

    Shots of one subject (the five golf swings, the two kicks, the bundled drive, pull and kick)
    are pooled, each with its root moved so it starts over the origin, into one PCA space
    (``style.PoseSpace`` of their frames together); each shot's path is drawn in its first three
    components with its impact marked. A group of one shot is skipped.
    """
    from .. import plots
    from ..style import PoseSpace

    groups: dict[tuple, list[Shot]] = {}
    for sh in shots:
        sk = sh.motion.skeleton
        # one subject: the same joints with the same bones (CMU's subjects share joint names)
        groups.setdefault((sk.names, tuple(np.round(sk.offsets, 3).ravel())), []).append(sh)
    out = []
    for members in groups.values():
        if len(members) < 2:
            continue
        moved = [sh.motion.replace(root_positions=sh.motion.root_positions - np.array([*sh.motion.root_positions[0, :2], 0.0])) for sh in members]
        first = moved[0]
        pooled = first.replace(
            root_positions=np.concatenate([m.root_positions for m in moved]),
            rotations=np.concatenate([m.rotations for m in moved]),
            translations=None if first.translations is None else np.concatenate([m.translations for m in moved]),
        )
        space = PoseSpace.fit(pooled)
        paths = {sh.name: space.scores(m, 3) for sh, m in zip(members, moved)}
        name = "_".join(sh.name for sh in members) if len(members) <= 3 else f"{members[0].name}-{members[-1].name}"
        out.append(
            plots.score_paths(
                paths,
                out_dir / f"shared_space_{name}.png",
                dims=3,
                highlight={sh.name: sh.hit_frame for sh in members},
                title=f"{len(members)} shots in one PC space ({100 * space.cumulative[2]:.0f} % of their variance; ★ impact)",
            )  # fmt: skip
        )
    return out


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False, jobs: int = 2, executor: Executor | None = None) -> Table:
    """Make, clean and measure the variants; write ``out_dir/table.md`` and the score-path PNGs. Shots
    run on ``executor`` (Dask, :mod:`mjmotion.executor`) if given, else in ``jobs`` processes."""
    from .. import evaluate as ev
    from .. import variations as V
    from ..executor import in_order, using

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    shots = load_shots(data_dir, quick)
    order = sorted(range(len(shots)), key=lambda i: -shots[i].motion.n_frames)  # the longest clips first
    with using(executor, jobs if len(shots) > 1 else 1) as pool:
        outcomes = pool.run(_task, [(i, (shots[i],)) for i in order], desc="variations", unit="shot", progress=not quick)
        results: list[ShotResult] = [out.unwrap() for out in in_order(outcomes, list(range(len(shots))))]

    table = Table("Shot variations in PCA space (seed 003 §3)" + (" — quick" if quick else ""), COLUMNS)
    with single_thread_blas():
        for r in results:
            for row in r.rows:
                table.add(*row)
            table.files += [str(p) for p in plot(r, out_dir)]
        table.files += [str(p) for p in shared_space(shots, out_dir)]
    table.notes += [
        (
            f"k: controlled components, the fewest explaining {V.DEFAULT_VARIANCE:.0%} of the clip's variance (var. expl.); "
            "the components beyond k keep the source's detail; exaggerated/muted scale the whole path about its centre"
        ),
        "phases (frames: backswing start, top, impact, follow-through end, abort): "
        + ", ".join(f"{r.shot} {r.phases.start}/{r.phases.top}/{r.phases.impact}/{r.phases.end}/{r.phases.abort}" for r in results),
        (
            "path: length (m) of the effector (golf: the fitted club's sweet spot; cricket: the bat's; kick: the kicking "
            "foot's ankle) over the swing segment, backswing start to follow-through end (an abort: up to its last frame), "
            "after cleanup"
        ),
        (
            "speed ratio: max_joint_speed_ratio, the variant's largest joint angular speed over the source's (raw: the "
            "reconstruction; clean: after cleanup)"
        ),
        (
            "worst joint: worst_joint_speed_ratio, the largest over joints of a joint's peak speed over its peak in the "
            "source (docs/METRICS.md; what the whole-body speed ratio hides: a knee at 3x its own speed under a fast wrist); "
            "pops: pop_frames against the source (a joint's angular acceleration over 4x its p99 in the source)"
        ),
        (
            f"skate: skate_mm_per_s (docs/METRICS.md, height-weighted below h_c = {ev.H_C} m); planted: planted_skate_mm_per_s "
            f"(contact by height and speed v_c = {ev.V_C} m/s, with hysteresis); src / raw / clean"
        ),
        (
            "grip: second hand from its source placement relative to the first hand on the club/bat, max over frames "
            "(– for a kick); style_rmse: against the source (same length only)"
        ),
        (
            "first/last dev: largest joint-position difference from the source at the first and last frames (an abort: "
            "the first; seed §2.2.5's common start and end poses: the scaling fades to none there, variations.end_weights)"
        ),
        (
            "abort: prefix dev = largest joint-position difference from the source up to the abort frame; end dev = "
            "the last frame against the source's rest pose moved to where the character stands (legs included)"
        ),
        "shots: " + ", ".join(f"{s.name} ({s.motion.n_frames} frames @ {s.motion.fps:g} fps, hit {s.hit_frame})" for s in shots),
    ]
    checks = []
    for r in results:
        by = {row[1].split()[0]: row for row in r.rows}
        ex, mu, ab = by["exaggerated"], by["muted"], by["aborted"]
        c = {name: i for i, name in enumerate(COLUMNS)}
        skate_ok = all(row[c["skate clean"]] <= 2 * row[c["skate src"]] + 1e-9 for row in r.rows)
        grip_ok = all(not (row[c["grip clean mm"]] >= 5.0) for row in r.rows)
        path, src_path = c["path m"], c["path src m"]
        checks.append(
            f"{r.shot}: exaggerated path longer {'yes' if ex[path] > ex[src_path] else 'NO'}, "
            f"muted shorter {'yes' if mu[path] < mu[src_path] else 'NO'}, "
            f"abort speed ratio ≤ 1.5 {'yes' if ab[c['speed ratio clean']] <= 1.5 else 'NO'}, "
            f"cleaned skate ≤ 2× source {'yes' if skate_ok else 'NO'}, "
            f"grip < 5 mm {'yes' if grip_ok else 'NO'}"
        )
    table.notes += ["issue 6 checks — " + "; ".join(checks)]
    table.write(out_dir)
    return table
