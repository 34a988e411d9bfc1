"""Physics audit: every shared clip and every synthesized result through the evaluation report.

Captured clips (with ``data_dir``) are evaluated in parallel processes, each from its own
detected floor; the synthesized results are the bundled procedural clips and what the lab makes
from them: a linear and a registered blend of the bundled walk and run (judged against the walk
and run as sources), and the footskate cleanup of the linear blend. The notes add what cleanup
does to linear walk/run blends of the shared skeletons and to clean walks
(:func:`cleanup_of_blends`, judged against their inputs), with foot height and speed drawn
before and after, and the planted footskate of a few walks over the foot-flat middle of their
stances (:func:`mid_stance_skate`). Metric definitions: ``docs/METRICS.md`` (thresholds in the
table's notes).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import evaluate as ev
from ..cleanup import CleanupResult
from ..skeleton import Motion
from . import Table

if TYPE_CHECKING:
    from ..executor import Executor

COLUMNS = (
    "source", "clip", "frames", "fps", "planted skate mm/s", "weighted skate mm/s", "skating ratio", "flight frac",
    "penetrate mm", "float mm", "phys_err mm", "floor m", "floor from", "flight residual", "phys violation",
    "limit violation", "pop frames", "worst joint speed ratio",
)  # fmt: skip


def _row(source: str, name: str, r: dict) -> tuple:
    return (
        source, name, r["n_frames"], round(r["fps"], 1), r["planted_skate_mm_per_s"], r["skate_mm_per_s"],
        r["skating_ratio"], r["flight_fraction"], r["penetrate_mm"], r["float_mm"], r["phys_err_mm"],
        r["floor_m"], r["floor_from"], r["flight_residual"], r["physics_violation_ratio"], r["limit_violation_ratio"],
        r["pop_frames"], float("nan") if r["worst_joint_speed_ratio"] is None else r["worst_joint_speed_ratio"],
    )  # fmt: skip


def synthesized(quick: bool = False) -> dict[str, tuple[object, tuple, tuple]]:
    """Bundled clips and results made from them: ``{name: (motion, props, sources)}``."""
    from .. import blend, synth

    clips = synth.library()
    if quick:
        clips = {k: v for k, v in clips.items() if k in ("walk", "run", "drive", "kick")}
    out: dict[str, tuple[object, tuple, tuple]] = {name: (c.motion, (c.prop,) if c.prop is not None else (), ()) for name, c in clips.items()}
    (walk, run), lin, cleaned = _bundled_linear_blend()
    reg = blend.blend([walk, run], [0.5, 0.5], method="registered", name="registered_blend")
    out["linear blend walk/run .5"] = (lin, (), (walk, run))
    out["registered blend walk/run .5"] = (reg, (), (walk, run))
    out["cleanup of the linear blend"] = (cleaned.motion, (), (walk, run))
    return out


@functools.lru_cache(maxsize=1)
def _bundled_linear_blend() -> tuple[tuple[Motion, Motion], Motion, CleanupResult]:
    """The bundled walk and run (3 s each), their linear .5 blend and its cleanup: built once for
    the synthesized rows and the cleanup notes."""
    from .. import blend, cleanup, synth

    clips = (synth.walk(seconds=3.0).motion, synth.run(seconds=3.0).motion)
    lin = blend.blend(list(clips), [0.5, 0.5], method="linear", name="linear_blend")
    return clips, lin, cleanup.cleanup(lin, sources=clips)


#: Walk and run of one skeleton each, blended linearly (frame by frame, no timewarp) for the cleanup check.
BLEND_PAIRS = (
    ("cmu_cgspeed_daz/07_01.bvh", "cmu_cgspeed_daz/09_01.bvh"),
    ("cmu_iclone_ccrig/002_01.bvh", "cmu_iclone_ccrig/002_03.bvh"),
    ("cmu_cgspeed_max/131_01.bvh", "cmu_cgspeed_max/102_01.bvh"),
    ("cmu_cgspeed_daz/08_05.bvh", "cmu_cgspeed_daz/02_03.bvh"),  # one plant in 170 frames, the body jerking in it
    ("cmu_cgspeed_daz/08_01.bvh", "cmu_cgspeed_daz/09_11.bvh"),  # last: the one drawn
)

#: Clean captured walks, to show what cleanup does where there is little to fix.
CLEAN_WALKS = ("cmu_asfamc_converted/16_15.bvh", "cmu_iclone_ccrig/007_04.bvh", "cmu_cgspeed_daz/07_01.bvh")


def _judged(before, after, sources) -> tuple[ev.Report, ev.Report]:
    return ev.evaluate(before, sources=sources), ev.evaluate(after, sources=sources)


def cleanup_of_blends(
    data_dir: Path | None, out_dir: Path | None = None, cleaned: dict[str, dict[str, Any]] | None = None
) -> tuple[list[str], list[str]]:
    """What cleanup does, one line each, judged against its inputs (their floor and feet): to
    every :data:`CLEAN_WALKS` clip, and to the linear blend of the bundled walk and run and of
    every :data:`BLEND_PAIRS` pair found under ``data_dir`` (issue 13's bar: ≥ 80 % less planted
    skate, ``penetrate_mm`` ≤ 2, ``worst_joint_speed_ratio`` against the inputs ≤ 1.3). With
    ``out_dir``, foot height and speed before and after cleanup of the last pair are drawn
    there; ``cleaned``: :func:`cleanup_of_clip` rows by path already made (the clean walks are among
    them). Returns the lines and the figure files."""
    from .. import blend, cleanup

    pairs = [("bundled walk+run", *_bundled_linear_blend())]
    for a, b in BLEND_PAIRS if data_dir is not None else ():
        assert data_dir is not None  # (the loop runs only then)
        if (data_dir / a).is_file() and (data_dir / b).is_file():
            clips = (_read(data_dir / a), _read(data_dir / b))
            lin = blend.blend(list(clips), [0.5, 0.5], method="linear")
            pairs.append((f"{a.split('/')[0]} {Path(a).stem}+{Path(b).stem}", clips, lin, cleanup.cleanup(lin, sources=clips)))
    lines = []
    for rel in CLEAN_WALKS if data_dir is not None else ():
        assert data_dir is not None
        if (data_dir / rel).is_file():
            w = (cleaned or {}).get(str(data_dir / rel)) or cleanup_of_clip(str(data_dir / rel))
            lines.append(
                f"cleanup of the clean walk {rel}: planted skate {w['planted_skate_mm_per_s_before']:.0f} → {w['planted_skate_mm_per_s_after']:.0f} mm/s, "
                f"penetrate_mm {w['penetrate_mm_before']:.1f} → {w['penetrate_mm_after']:.1f}, float_mm {w['float_mm_before']:.1f} → {w['float_mm_after']:.1f}, "
                f"worst_joint_speed_ratio {w['worst_joint_speed_ratio']:.2f} "
                f"({w['worst_joint']}), pop_frames {w['pop_frames_before']} → {w['pop_frames_after']}"
            )
    for label, clips, lin, res in pairs:
        r0, r1 = _judged(lin, res.motion, list(clips))
        pl0, pl1 = r0.planted_skate_mm_per_s, r1.planted_skate_mm_per_s
        lines.append(
            f"cleanup of the linear blend of {label}: planted skate {pl0:.0f} → {pl1:.0f} mm/s ({100 * (1 - pl1 / pl0):.0f} % less), "
            f"penetrate_mm {r0.penetrate_mm:.1f} → {r1.penetrate_mm:.1f}, float_mm {r0.float_mm:.1f} → {r1.float_mm:.1f}, worst_joint_speed_ratio against the inputs "
            f"{r0.worst_joint_speed_ratio:.2f} → {r1.worst_joint_speed_ratio:.2f} ({r1.worst_joint}), pop_frames {r0.pop_frames} → {r1.pop_frames}, "
            f"physics violations {r0.physics_violation_ratio:.2f} → {r1.physics_violation_ratio:.2f}"
        )
    files = []
    if out_dir is not None:
        from .. import plots

        label, clips, lin, res = pairs[-1]
        out_dir.mkdir(parents=True, exist_ok=True)
        for tag, m in (("before", lin), ("after", res.motion)):
            r = ev.evaluate(m, sources=list(clips))
            tr = ev.foot_heights_speeds(None, m, floor=r.floor_m)
            f = plots.foot_contacts(
                np.arange(m.n_frames) / m.fps, tr.heights, tr.speeds, ev.contacts(tr), out_dir / f"cleanup_{tag}.png",
                title=f"linear blend {label}, {tag} cleanup: planted skate {r.planted_skate_mm_per_s:.0f} mm/s",
            )  # fmt: skip
            files.append(str(f))
    return lines, files


#: Walks whose planted footskate is compared over the foot-flat part of each stance: the same CMU
#: trial 07_04 in two conversions, and the clean walks of the other flavours.
MID_STANCE_WALKS = (
    "cmu_cgspeed_daz/07_04.bvh", "cmu_iclone_ccrig/007_04.bvh", "cmu_cgspeed_daz/07_01.bvh", "cmu_asfamc_converted/16_15.bvh",
    "cmu_iclone_ccrig/002_01.bvh", "cmu_cgspeed_max/131_02.bvh",
)  # fmt: skip


def mid_stance_skate(motion: Motion, params: ev.Params = ev.DEFAULTS) -> tuple[float, float, int]:
    """Planted footskate (mm/s) over every contact frame and over the middle third of each full
    stance (a contact run at least 0.3 s long, not cut by the clip's ends), where the foot lies
    flat: no heel strike or toe-off roll, so whatever point of the foot the soles model, a foot
    that does not slip reads ~0 there. Returns both and the number of full stances."""
    from .. import feet, kinematics, mjcf

    compiled = mjcf.compile(motion.skeleton)
    track = feet.judged_feet(compiled, motion, kinematics.forward(compiled, motion))[0]
    con = feet.contacts(track, params.h_c, params.v_c, params.hysteresis)
    speed = feet.planted_speeds(track, con)
    mids = []
    for f in range(con.shape[1]):
        edges = np.diff(np.concatenate([[0], con[:, f].astype(int), [0]]))
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            if b - a >= 0.3 * motion.fps and a > 0 and b < motion.n_frames:
                mids.append(speed[a + (b - a) // 3 : a + 2 * (b - a) // 3, f])
    mid = float(np.nanmean(np.concatenate(mids))) if mids else float("nan")
    return 1000 * float(np.nanmean(speed)), 1000 * mid, len(mids)


def mid_stance_lines(data_dir: Path | None) -> list[str]:
    """One note: :func:`mid_stance_skate` of every :data:`MID_STANCE_WALKS` clip found under ``data_dir``."""
    parts: list[str] = []
    if data_dir is None:
        return parts
    for rel in MID_STANCE_WALKS:
        if (data_dir / rel).is_file():
            whole, mid, n = mid_stance_skate(_read(data_dir / rel))
            parts.append(f"{rel.split('/')[0].removeprefix('cmu_')} {Path(rel).stem} {whole:.0f} → {mid:.0f} ({n} stances)")
    head = (
        "planted skate over all contact frames → over the middle third of each full stance (foot flat; mm/s, "
        "experiments.physics_audit.mid_stance_skate): "
    )
    return _note(head, parts, ", ")


#: The same CMU trials in two conversions (cgspeed daz and iClone): how hard each head sways.
SAME_TRIALS = (("cmu_cgspeed_daz/07_04.bvh", "cmu_iclone_ccrig/007_04.bvh"), ("cmu_cgspeed_daz/02_01.bvh", "cmu_iclone_ccrig/002_01.bvh"))


def head_sway(motion: Motion, cutoff_hz: float = 6.0) -> float:
    """RMS sideways acceleration (m/s²) of the head joint, low-pass filtered at ``cutoff_hz`` as the
    judge filters bodies, across the root's direction of travel, 0.15 s from each end left out:
    a proxy for the roll the upper body asks of the stance foot (docs/METRICS.md, physics residual)."""
    from .. import kinematics, mjcf
    from ..filters import lowpass

    names = [n.lower() for n in motion.skeleton.names]
    head = next((i for i, n in enumerate(names) if n.endswith("head") and "end" not in n), None)
    if head is None or motion.n_frames < 4:
        return float("nan")
    pos = lowpass(kinematics.forward(mjcf.compile(motion.skeleton), motion).joint_positions[:, [0, head]], motion.fps, cutoff_hz)
    heading = np.gradient(pos[:, 0, :2], axis=0)
    heading /= np.maximum(np.linalg.norm(heading, axis=1, keepdims=True), 1e-12)
    side = np.stack([-heading[:, 1], heading[:, 0]], axis=1)
    acc = np.gradient(np.gradient(pos[:, 1, :2], axis=0), axis=0) * motion.fps**2
    e = round(0.15 * motion.fps)
    lateral = np.einsum("ti,ti->t", acc, side)[e : motion.n_frames - e]
    return float(np.sqrt(np.mean(lateral**2))) if len(lateral) else float("nan")


def head_sway_lines(data_dir: Path | None) -> list[str]:
    """One note: :func:`head_sway` of the :data:`SAME_TRIALS` pairs found under ``data_dir``."""
    parts: list[str] = []
    for a, b in SAME_TRIALS if data_dir is not None else ():
        assert data_dir is not None
        if (data_dir / a).is_file() and (data_dir / b).is_file():
            parts.append(f"{Path(a).stem} {head_sway(_read(data_dir / a)):.2f} in daz vs {head_sway(_read(data_dir / b)):.2f} in iClone")
    head = "head sideways acceleration (RMS, 6 Hz, m/s², experiments.physics_audit.head_sway), the same CMU trial in two conversions: "
    return _note(head, parts, "; ")


#: Runs and a jump whose flights :func:`flight_falls` reports: the daz runs, and clips of other flavours with flights.
FLIGHT_CLIPS = (
    *(f"cmu_cgspeed_daz/{n}.bvh" for n in ("09_01", "09_02", "09_06", "09_11", "02_03")),
    "cmu_asfamc_converted/16_01.bvh",
    "cmu_cgspeed_max/102_01.bvh",
)


def flight_falls(motion: Motion, params: ev.Params = ev.DEFAULTS, root: bool = False) -> list[float]:
    """The vertical acceleration (in g; free fall reads −1) of the centre of mass over each airborne
    stretch the judge fits a parabola to (:func:`mjmotion.physics.ballistic_fits`), the clip judged
    as ``evaluate`` judges it: its own floor, levelled, its feet calibrated. ``root``: that of the
    root joint (the pelvis) over the same stretches instead — the capture's own point, no mass model."""
    return _flight_fits(motion, params)[1 if root else 0]


def _flight_fits(motion: Motion, params: ev.Params = ev.DEFAULTS) -> tuple[list[float], list[float]]:
    """:func:`flight_falls` of the centre of mass and of the root joint, from one judging of ``motion``."""
    from .. import feet, kinematics, physics

    compiled = ev.judge_model(motion.skeleton)
    pose = kinematics.forward(compiled, motion)
    track, _, fl = feet.judged_feet(compiled, motion, pose, [], None, params.speed_window)
    pose, motion = feet.level_pose(fl.level, pose), feet.level_motion(fl.level, motion)
    ground = feet.lowest_body_point(compiled, pose, track.heights.min(axis=1) + fl.height) - fl.height
    res = physics.residuals(compiled, motion, track, params, ground=ground, pose=pose)
    judged = res.ballistic if res.ballistic is not None else np.zeros(motion.n_frames, dtype=bool)
    pelvis = physics.ballistic_fits(pose.joint_positions[:, 0], judged, motion.fps)
    return [float(a[2] / physics.GRAVITY) for a in res.flight_accelerations], [float(a[2] / physics.GRAVITY) for _, _, a in pelvis]


def flight_fall_lines(data_dir: Path | None) -> list[str]:
    """One note: :func:`flight_falls` of the :data:`FLIGHT_CLIPS` found under ``data_dir``."""
    parts: list[str] = []
    for rel in FLIGHT_CLIPS if data_dir is not None else ():
        assert data_dir is not None
        if (data_dir / rel).is_file():
            falls, pelvis = _flight_fits(_read(data_dir / rel))
            shown = ", ".join(f"{a:.2f} ({b:.2f})".replace("-", "−") for a, b in zip(falls, pelvis)) if falls else "none fitted"
            parts.append(f"{rel.split('/')[0].removeprefix('cmu_')} {Path(rel).stem} {shown}")
    head = (
        "centre of mass's vertical acceleration over each flight the judge fits, in g, and in brackets the root joint's (the pelvis, "
        "the capture's own point) over the same stretch (free fall −1; experiments.physics_audit.flight_falls): "
    )
    return _note(head, parts, "; ")


#: The tolerances :func:`tolerance_lines` tries, the runs that fail at the judge's and the walks whose
#: speed-up it must still catch (docs/METRICS.md, "Physics residual").
SCAN_TOLS = (0.12, 0.16, 0.20, 0.25)
SCAN_RUNS = ("cmu_cgspeed_daz/09_01.bvh", "cmu_cgspeed_daz/02_03.bvh", "cmu_cgspeed_daz/09_02.bvh", "cmu_cgspeed_daz/09_06.bvh")
SCAN_WALKS = ("cmu_asfamc_converted/16_15.bvh", "cmu_cgspeed_max/131_02.bvh")


def tolerance_scan(path: str, sped_up: bool) -> list[float]:
    """``physics_violation_ratio`` of a clip judged against itself at each of :data:`SCAN_TOLS` (with
    ``sped_up``: of the clip played twice as fast, against the clip, minus the clip's own)."""
    from .corruption import sped_up as faster

    m = _read(Path(path))
    out = []
    for tol in SCAN_TOLS:
        p = ev.Params(residual_tol=tol)
        clean = ev.evaluate(m, params=p, sources=[m.replace()], launch=False).physics_violation_ratio
        out.append(ev.evaluate(faster(m), params=p, sources=[m], launch=False).physics_violation_ratio - clean if sped_up else clean)
    return out


def tolerance_lines(data_dir: Path | None, executor: Executor | None = None, jobs: int = 2) -> list[str]:
    """One note: what a looser ``residual_tol`` buys the daz runs that fail and costs the speed-up test
    on slow walks (:func:`tolerance_scan` of :data:`SCAN_RUNS` and :data:`SCAN_WALKS` found under ``data_dir``)."""
    from ..executor import in_order, using

    if data_dir is None:
        return []
    tasks = [(rel, (str(data_dir / rel), rel in SCAN_WALKS)) for rel in (*SCAN_RUNS, *SCAN_WALKS) if (data_dir / rel).is_file()]
    if not tasks:
        return []
    with using(executor, jobs) as ex:
        outcomes = in_order(ex.run(tolerance_scan, tasks, desc="tolerances", unit="clip"), [k for k, _ in tasks])
    show = lambda rel, o: f"{Path(rel).stem} " + " / ".join(f"{'+' if rel in SCAN_WALKS else ''}{v:.2f}" for v in o.unwrap())
    runs = [show(o.key, o) for o in outcomes if o.key in SCAN_RUNS]
    walks = [show(o.key, o) for o in outcomes if o.key in SCAN_WALKS]
    tols = " / ".join(f"{t:g}" for t in SCAN_TOLS)
    return [
        f"residual_tol {tols} (experiments.physics_audit.tolerance_scan): physics_violation_ratio of the daz runs "
        f"{', '.join(runs)}; what the walks played twice as fast add {', '.join(walks)}"
    ]


def _note(head: str, parts: list[str], sep: str) -> list[str]:
    """One note line, ``head`` then ``parts`` joined by ``sep`` (none without parts)."""
    return [head + sep.join(parts)] if parts else []


def cleanup_of_clip(path: str) -> dict[str, Any]:
    """What cleanup does to one captured clip judged against itself (its floor, its feet, its own
    joint speeds): the headline numbers before and after (runs in worker processes)."""
    from .. import cleanup

    m = _read(Path(path))
    done = cleanup.cleanup(m, sources=[m.replace()])
    r0, r1 = _judged(m, done.motion, [m.replace()])
    keys = ("planted_skate_mm_per_s", "penetrate_mm", "float_mm", "pop_frames")
    return {
        **{f"{k}_before": getattr(r0, k) for k in keys},
        **{f"{k}_after": getattr(r1, k) for k in keys},
        "worst_joint_speed_ratio": r1.worst_joint_speed_ratio,
        "worst_joint": r1.worst_joint,
    }


def cleanup_of_clips(files: list[str], executor: Executor | None = None, jobs: int = 2) -> tuple[dict[str, dict[str, Any]], dict[str, str]]:
    """:func:`cleanup_of_clip` over ``files`` on ``executor`` (else ``jobs`` processes): the rows and the
    errors, each by path."""
    from ..executor import in_order, using

    if not files:
        return {}, {}
    with using(executor, jobs) as ex:
        outcomes = in_order(ex.run(cleanup_of_clip, [(f, (f,)) for f in files], desc="cleanup", unit="clip"), files)
    return {o.key: o.unwrap() for o in outcomes if o.kind is None}, {o.key: str(o.error) for o in outcomes if o.kind is not None}


def cleanup_of_clips_line(files: list[str], executor: Executor | None = None, jobs: int = 2, done: tuple | None = None) -> list[str]:
    """One note: :func:`cleanup_of_clips` of ``files`` (or ``done``, its result already made), summarised,
    naming every clip that cleanup leaves with a joint over 1.3x its own peak (issue 13's bar for
    walks) or with new pop frames."""
    by_path, errors = done if done is not None else cleanup_of_clips(files, executor, jobs)
    name = lambda key: f"{Path(key).parent.name.removeprefix('cmu_')} {Path(key).stem}"
    rows = {name(k): r for k, r in by_path.items()}
    failed = [f"{name(k)}: {e}" for k, e in errors.items()]
    if not rows:
        return [f"cleanup failed on every clip: {'; '.join(failed)}"] if failed else []
    med = lambda k: float(np.median([r[k] for r in rows.values()]))
    fast = [f"{n} {r['worst_joint_speed_ratio']:.2f} ({r['worst_joint']})" for n, r in rows.items() if r["worst_joint_speed_ratio"] > 1.3]
    popped = [f"{n} {r['pop_frames_before']} → {r['pop_frames_after']}" for n, r in rows.items() if r["pop_frames_after"] > r["pop_frames_before"]]
    rise, risen = max((r["float_mm_after"] - r["float_mm_before"], n) for n, r in rows.items())
    top, topped = max((r["worst_joint_speed_ratio"], n) for n, r in rows.items())
    return [
        f"cleanup of each captured clip against itself ({len(rows)} clip{'s' * (len(rows) != 1)}, experiments.physics_audit.cleanup_of_clip): planted skate "
        f"median {med('planted_skate_mm_per_s_before'):.0f} → {med('planted_skate_mm_per_s_after'):.0f} mm/s, penetrate_mm at most "
        f"{max(r['penetrate_mm_after'] for r in rows.values()):.2f} after, float_mm up by at most {rise:.1f} mm ({risen}); worst_joint_speed_ratio "
        f"≤ 1.3 on {len(rows) - len(fast)} of {len(rows)} (largest {top:.2f}, {topped} {rows[topped]['worst_joint']})"
        + (f", above it: {', '.join(fast)}" if fast else "")
        + (f"; new pop frames: {', '.join(popped)}" if popped else "; no new pop frames")
        + (f"; failed: {'; '.join(failed)}" if failed else "")
    ]


def _read(path: Path) -> Motion:
    """A shared clip as every verb reads it: its leading T-pose or rest frame skipped (mjmotion/trim.py;
    cgspeed's frames 0–3, iClone 007_04's frame 0)."""
    from .. import bvh
    from ..trim import leading_transient

    m = bvh.read(path)
    return m[leading_transient(m) :].replace(name=path.stem)


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False, jobs: int = 2, executor: Executor | None = None) -> Table:
    """Evaluate everything and write ``out_dir/table.md``; captured clips run on ``executor`` (Dask,
    :mod:`mjmotion.executor`) if given, else in ``jobs`` processes."""
    params = ev.Params()
    table = Table(
        "Physics audit: captured and synthesized motion",
        COLUMNS,
        notes=[
            (
                f"thresholds (docs/METRICS.md): h_c = {params.h_c} m, v_c = {params.v_c} m/s, hysteresis {params.hysteresis}, "
                f"float tolerance {params.float_tol * 1000:.0f} mm, foot speeds over {params.speed_window} s, low-pass {params.cutoff_hz} Hz "
                f"before inverse dynamics, friction μ = {params.mu}, residual tolerance {params.residual_tol} m·g (a flight's: {params.flight_tol} g), "
                f"penetration tolerance {params.penetration_tol} m, pops at {params.pop_factor}x the reference's p{params.peak_percentile:g}"
            ),
            (
                "planted skate: mean foot speed over contact frames (height and speed, with hysteresis), the headline; "
                "weighted skate: speed × (2 − 2^(h/h_c)) over frames below h_c, for comparison with published numbers"
            ),
            "captured clips: a leading T-pose or transition (cgspeed's frames 0–3) is skipped; each from its own detected floor",
        ],
    )
    if data_dir is not None:
        from ..commands.evaluate import evaluate_file
        from ..executor import in_order, using

        files = sorted(str(p) for p in Path(data_dir).rglob("*.bvh"))
        if quick:
            files = files[:: max(1, len(files) // 6)]
        opts: dict[str, Any] = {
            "units": "auto", "up": "y", "frames": None, "keep_start": False, "prop": [], "ball": None, "frame": None,
            "ball_radius": 0.036, "ball_velocity": (0.0, 0.0, 0.0), "h_c": params.h_c, "v_c": params.v_c, "floor": None, "source": [],
        }  # fmt: skip
        with using(executor, jobs) as ex:
            outcomes = in_order(ex.run(evaluate_file, [(f, (f, opts)) for f in files], desc="evaluate", unit="clip"), files)
        for out in outcomes:
            label = f"{Path(out.key).parent.name}/{Path(out.key).stem}"
            if out.kind == "input":
                table.notes.append(f"{label}: {out.error}")
                continue
            table.add(*_row("captured", label, out.unwrap()["report"]))
    for name, (motion, props, sources) in synthesized(quick).items():
        rep = ev.evaluate(motion, props, params=params, sources=sources)  # type: ignore[arg-type]
        table.add(*_row("synthesized", name, rep.to_dict()))
    real = Path(data_dir) if data_dir is not None and not quick else None  # the notes' captured clips (none in the quick run)
    # Each captured clip cleaned once (in workers): the clean walks' lines and the all-clips note share it.
    cleaned = cleanup_of_clips(sorted(str(p) for p in real.rglob("*.bvh")), executor, jobs) if real is not None else None
    lines, files = cleanup_of_blends(real, out_dir, cleaned[0] if cleaned else None)
    table.notes.extend(mid_stance_lines(real))
    table.notes.extend(head_sway_lines(real))
    table.notes.extend(flight_fall_lines(real))
    table.notes.extend(tolerance_lines(real, executor, jobs))
    table.notes.extend(lines)
    if cleaned is not None:
        table.notes.extend(cleanup_of_clips_line([], done=cleaned))
    table.files.extend(files)
    table.write(out_dir)
    return table
