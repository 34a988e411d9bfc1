"""Thin adapters from the Studio's tabs to the lab's operations and its judge.

Each tab calls only these functions, so a change in another module's API is one edit here.
They take plain values and a ``progress(fraction, text)`` checkpoint (``mjmotion.studio.jobs``),
and return frozen results with everything the tab draws.
"""

from __future__ import annotations

import tempfile
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import mjcf
from ..errors import MjmotionError
from ..skeleton import Motion

if TYPE_CHECKING:
    from ..hitpoint import HitProblem

ProgressFn = Callable[[float, str], None]


def _no_progress(fraction: float, text: str = "") -> None:
    return None


def png(plot: Callable[[Path], object]) -> np.ndarray:
    """``(H, W, 3|4)`` uint8 pixels of a figure that ``plot(path)`` writes as PNG (``mjmotion.plots``)."""
    import imageio.v3 as iio

    with tempfile.TemporaryDirectory(prefix="mjmotion-studio-") as d:
        path = Path(d) / "plot.png"
        plot(path)
        return np.asarray(iio.imread(path))


# --------------------------------------------------------------------------------------------
# Blend (seed 004 §6.3-6.4)
# --------------------------------------------------------------------------------------------
BLEND_METHODS = ("B-spline timewarp", "discrete timewarp", "linear")
PATH_METHODS = ("dp", "greedy", "threshold")


@dataclass(frozen=True, eq=False)
class BlendResult:
    """A blend and what its registration found.

    Attributes:
        motion: the blend (``N`` frames).
        input_frames: ``(N, n)`` fractional frame of each input shown at each output frame.
        grid, path, curve: clip 1 × clip 2 distance grid ``(nA, nB)``, path cells ``(P, 2)``,
            timewarp samples ``(M, 2)``; ``None`` for a linear blend.
        note: what was done, one line.
    """

    motion: Motion
    input_frames: np.ndarray
    grid: np.ndarray | None
    path: np.ndarray | None
    curve: np.ndarray | None
    note: str


def blend_weights(start: np.ndarray, end: np.ndarray | None, seconds: float):
    """Constant weights ``start``, or a Bezier ramp from ``start`` to ``end`` over ``seconds`` (a :class:`~mjmotion.blend.WeightCurve`)."""
    from ..blend import WeightCurve, check_weights

    w0 = check_weights(start, len(start), "weights")
    if end is None:
        return WeightCurve.constant(w0)
    return WeightCurve(((0.0, 0.0, w0), (0.0, max(seconds, 1e-6), check_weights(end, len(end), "end weights"))))


def make_blend(
    motions: list[Motion],
    weights: Any,
    method: str = "B-spline timewarp",
    path_method: str = "dp",
    threshold: float = 0.35,
    progress: ProgressFn = _no_progress,
) -> BlendResult:
    """Blend ``motions`` (seed 004's Motion Blender). Two clips: the grid, the chosen path search and
    timewarp; more: :func:`mjmotion.registration.register_many` (DP, B-spline) to the first."""
    from .. import blend, registration

    if len(motions) < 2:
        raise MjmotionError("pick at least two clips to blend")
    if method not in BLEND_METHODS:
        raise MjmotionError(f"unknown blend method {method!r}")
    motions = blend.common_rate(list(motions))
    if method == "linear":
        progress(0.5, "linear blend")
        out = blend.blend(motions, weights, method="linear", name="blend")
        frames = np.repeat(np.arange(out.n_frames, dtype=float)[:, None], len(motions), axis=1)
        return BlendResult(out, frames, None, None, None, f"linear blend of {len(motions)} clips, frame n of each")
    progress(0.05, "forward kinematics")
    pos = [registration.positions_of(m) for m in motions]
    progress(0.2, "distance grid")
    if len(motions) == 2:
        progress(0.4, f"grid and path search ({path_method})")
        options = {"area_threshold": threshold} if path_method == "threshold" else None
        curve_kind = "discrete" if method == "discrete timewarp" else "bspline"
        pr = registration.register(motions[0], motions[1], method=path_method, curve=curve_kind, positions=(pos[0], pos[1]), path_options=options)
        progress(0.6, "timewarp curve")
        # as the blend verb registers (register_many): one n-dimensional B-spline; a discrete timewarp stays discrete
        reg = registration.combine([None, pr], 0, motions[0].n_frames, None if curve_kind == "discrete" else registration.nway.SAMPLE_EVERY)
        grid, path, curve = pr.grid, pr.path, pr.curve
        note = f"{method}, {path_method} path ({len(path.cells)} cells, mean cost {path.mean_cost:.4f} m²)"
        cells: np.ndarray | None = path.cells
        samples: np.ndarray | None = curve.samples
    else:
        progress(0.4, "n-way registration")
        reg = registration.register_many(motions, reference=0, positions=pos)
        grid = registration.distance_grid(pos[0], pos[1], registration.joint_weights(motions[0].skeleton))
        cells = samples = None
        note = f"{len(motions)} clips registered to {motions[0].name} (DP path, B-spline timewarp)"
    progress(0.8, "blending")
    curve_w = weights if isinstance(weights, blend.WeightCurve) else blend.WeightCurve.constant(np.asarray(weights))
    out = blend.blend(motions, curve_w, registration=reg, name="blend")
    tau = blend.registered_clock(reg, curve_w, motions[0].fps)
    return BlendResult(out, reg.at(tau), grid.cost, cells, samples, note)


def grid_image(result: BlendResult, labels: tuple[str, str]) -> np.ndarray | None:
    """The distance grid with the path and timewarp curve (seed 004 §6.3.2's "grid with optimal path")."""
    if result.grid is None:
        return None
    from .. import plots

    grid = result.grid
    return png(lambda p: plots.distance_grid(grid, result.path, result.curve, p, labels=labels, figsize=(4.2, 3.4), dpi=80))


# --------------------------------------------------------------------------------------------
# Hit (seed 003 §2)
# --------------------------------------------------------------------------------------------
#: Adaptations a shot remembers (the latest few ball positions).
MEMO_SIZE = 8
#: Frames a drag's preview solves (:func:`mjmotion.hitpoint.preview_frames`): about 0.1 s of DLS.
PREVIEW_FRAMES = 24


@dataclass(frozen=True, eq=False)
class Shot:
    """A clip set up for adaptation: the effector, its prop and hit frame, the source hit point ``(3,)``.

    ``problem`` is the shot's :class:`~mjmotion.hitpoint.HitProblem` (model, FK, chains, the PCA
    of the style weights), built once when the shot is loaded and aimed at each ball position
    (:func:`mjmotion.hitpoint.aim`). ``memo`` keeps the latest adaptations by (solver, frames
    previewed, ball position), so a release at the spot the last drag solved reuses that solve (:func:`adapt`).
    """

    motion: Motion
    effector: str
    prop: mjcf.Prop | None
    hit_frame: int
    source_point: np.ndarray
    problem: HitProblem = field(repr=False)
    memo: OrderedDict[tuple[str, int, tuple[float, ...]], Any] = field(default_factory=OrderedDict, repr=False)


def shot(motion: Motion, prop: mjcf.Prop | None = None, hit_frame: int | None = None) -> Shot:
    """The effector a clip hits with: its prop's sweet spot, a fitted club for a two-handed swing,
    else the foot or fist its name says (kick → right foot, punch → right fist)."""
    from .. import hitpoint, variations

    name = motion.name.lower()
    if prop is not None:
        effector = "club"
    elif "kick" in name:
        effector = "right_foot"
    elif "punch" in name:
        effector = "right_fist"
    elif variations.first_hand_for(motion) is not None:
        effector, prop = "club", hitpoint.fit_club(motion)
    else:
        raise MjmotionError(f"{motion.name}: no prop and not a two-handed swing, kick or punch by name; nothing to hit with")
    # the defaults of `mjmotion hit` (falloff, wrist, weights, edge): the verb's answer for each ball position
    problem = hitpoint.setup(motion, offset=np.zeros(3), frame=hit_frame, effector=effector, prop=prop)
    return Shot(motion, effector, prop, int(problem.hit), problem.effector_fk[problem.hit].copy(), problem)


def adapt(s: Shot, target: np.ndarray, solver: str = "dls", style: bool = False, preview: bool = False, progress: ProgressFn = _no_progress) -> Any:
    """The shot adapted to ``target`` (an ``Adaptation``): what ``mjmotion hit``
    (:func:`mjmotion.hitpoint.adapt`) answers with the same solver and the shot's hit frame, from
    the shot's set-up; with ``preview``, a coarse preview of it that solves :data:`PREVIEW_FRAMES`
    frames (:func:`mjmotion.hitpoint.solve`; the same answer when the blend touches no more).

    ``progress`` is called every few frames' solves (a cancel checkpoint). The same ball
    position, solver and preview again (a release where the last drag was solved) reuses the
    remembered solve; ``style`` then only adds the style error (:func:`mjmotion.style.style_rmse`
    with the PCA the solve fitted, as ``hitpoint.adapt`` computes it).
    """
    from dataclasses import replace

    from .. import hitpoint
    from ..style import style_rmse

    target = np.asarray(target, float)
    n = PREVIEW_FRAMES if preview and int((s.problem.blend > 0).sum()) > PREVIEW_FRAMES else 0
    key = (solver, n, tuple(np.round(target, 6).tolist()))
    a = s.memo.get(key)
    if a is None:
        what = f"adapting ({solver}{f', preview of {n} frames' if n else ''})"

        def on_frame(i: int, count: int) -> None:
            if i % 8 == 0:  # a checkpoint every few frames (each report is a message to the page)
                progress(0.1 + 0.7 * i / count, what)

        a = hitpoint.solve(hitpoint.aim(s.problem, target), solver, style=style, preview=n, on_frame=on_frame)
    elif style and a.report["style_rmse"] is None:
        rmse, k = style_rmse(a.problem.source, a.motion, space=a.problem.space)
        a = replace(a, report={**a.report, "style_rmse": float(rmse), "k": int(k)})
    s.memo[key] = a
    s.memo.move_to_end(key)
    while len(s.memo) > MEMO_SIZE:
        s.memo.popitem(last=False)
    return a


@dataclass(frozen=True, eq=False)
class Flight:
    """The ball after the hit: the launch metrics and its flight ``(K, 3)`` simulated in MuJoCo until it rests or 2 s pass."""

    metrics: dict[str, Any]
    path: np.ndarray


def launch(s: Shot, motion: Motion, target: np.ndarray, radius: float = 0.036) -> Flight:
    """Simulate the impact (:func:`mjmotion.physics.hit_metrics`) and then the ball's flight under gravity."""
    import mujoco

    from .. import physics

    ball = mjcf.Ball(position=tuple(float(x) for x in target), radius=radius)  # type: ignore[arg-type]
    props = (s.prop,) if s.prop is not None else ()
    metrics = physics.hit_metrics(motion, ball, s.hit_frame, props=props)
    v = np.zeros(3)
    if "launch_speed" in metrics:
        az, el = np.radians(metrics["launch_azimuth_deg"]), np.radians(metrics["launch_elevation_deg"])
        v = metrics["launch_speed"] * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1])
    b = spec.worldbody.add_body(pos=list(ball.position))
    b.add_freejoint()
    b.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], mass=0.16)
    m = spec.compile()
    d = mujoco.MjData(m)
    d.qvel[:3] = v
    path = [d.qpos[:3].copy()]
    for k in range(1000):
        mujoco.mj_step(m, d)
        if k % 10 == 9:
            path.append(d.qpos[:3].copy())
            if np.linalg.norm(d.qvel[:3]) < 0.05:
                break
    return Flight(metrics, np.array(path))


# --------------------------------------------------------------------------------------------
# Vary (seed 003 §3)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Variant:
    """A variant of a shot: the motion, the source's and the variant's score paths ``(T, k)``, the report."""

    motion: Motion
    source_scores: np.ndarray
    scores: np.ndarray
    report: dict[str, Any]


def vary(
    source: Motion, scale: float | None = None, abort_at: int | None = None, cleanup: bool = True, progress: ProgressFn = _no_progress
) -> Variant:
    """Exaggerate/mute by ``scale`` or abort at frame ``abort_at`` along the shot's PCA path (``mjmotion vary``)."""
    from .. import variations
    from ..style import PoseSpace

    if (scale is None) == (abort_at is None):
        raise MjmotionError("give a scale or an abort frame")
    progress(0.1, "PCA of the shot")
    space = PoseSpace.fit(source, translations=True)
    k = space.components_for(variations.DEFAULT_VARIANCE)
    base = variations.source_path(space, k)
    if scale is not None:
        path = variations.scaled_path(base, scale, fps=source.fps)
    else:
        if not 0 <= int(abort_at) < source.n_frames - 1:  # type: ignore[arg-type]
            raise MjmotionError(f"abort frame {abort_at}: the shot has frames 0..{source.n_frames - 2}")
        path = variations.aborted_path(base, int(abort_at), None, -1, source.fps, space=space)  # type: ignore[arg-type]
    progress(0.4, "synthesis")
    raw = variations.synthesise(space, path)
    first = variations.first_hand_for(source)
    result = raw
    if cleanup:
        progress(0.6, "cleanup (feet, grip)")
        result, _ = variations.clean_up(source, raw, path, first_hand=first)
    progress(0.8, "report")
    report = variations.report(source, raw, result, path, space, first_hand=first)
    return Variant(result.replace(name=f"{source.name} {path.label}"), space.source_scores[:, :k], path.scores[:, :k], report)


def score_image(v: Variant, label: str) -> np.ndarray:
    from .. import plots

    return png(lambda p: plots.score_paths({"source": v.source_scores, label: v.scores}, p, figsize=(4.2, 3.4), dpi=80))


# --------------------------------------------------------------------------------------------
# Evaluate (docs METRICS.md)
# --------------------------------------------------------------------------------------------
#: Depth (m) below the floor from which a frame is marked as penetrating on the timeline.
PENETRATION_TOL = 0.001


@dataclass(frozen=True, eq=False)
class Evaluation:
    """The judge's numbers for a clip and the frames to highlight.

    Attributes:
        rows: ``(label, value)`` of every scalar the report has.
        foot_geoms: ``{side: geom ids}``; ``contacts``: ``(T, F)`` bool per side in ``sides``.
        penetrating: ``(T,)`` the body more than :data:`PENETRATION_TOL` below the judge's floor
            (:func:`mjmotion.feet.judged_feet`, as ``penetrate_mm``); ``skating``: ``(T,)`` a low foot moving faster than ``v_c``.
    """

    rows: list[tuple[str, Any]]
    sides: tuple[str, ...]
    foot_geoms: dict[str, tuple[int, ...]]
    contacts: np.ndarray
    penetrating: np.ndarray
    skating: np.ndarray


def floor_height(motion: Motion) -> float:
    """The height (m) the scene's floor grid is drawn at for ``motion``: the judge's floor
    (:func:`mjmotion.feet.judged_floor`, detected from its stance, as ``evaluate`` and ``render``
    use), or 0 for a clip without feet or of one frame."""
    from ..feet import judged_floor

    if not motion.skeleton.feet() or motion.n_frames < 2:
        return 0.0
    try:
        return float(judged_floor(motion).height)
    except MjmotionError:
        return 0.0


def evaluate(motion: Motion, props: tuple[mjcf.Prop, ...] = (), progress: ProgressFn = _no_progress) -> Evaluation:
    """:func:`mjmotion.evaluate.evaluate` plus the per-frame contacts, penetration and skate."""
    from .. import evaluate as ev
    from .. import kinematics
    from ..feet import judged_feet, level_pose

    progress(0.1, "report")
    report = ev.evaluate(motion, props)
    rows = [(k, v) for k, v in report.to_dict().items() if isinstance(v, (int, float, str)) and k != "name"]
    progress(0.7, "per-frame contacts")
    compiled = ev.judge_model(motion.skeleton, props)
    pose = kinematics.forward(compiled, motion)
    # The judge's feet and floor (levelled where it tilts), so the marks agree with the report's rows.
    track, _, fl = judged_feet(compiled, motion, pose)
    contacts = ev.contacts(track)
    skating = np.asarray((ev.low_both(track) & (track.speeds > ev.V_C)).any(axis=1))
    low = ev.lowest_body_point(compiled, level_pose(fl.level, pose), track.heights.min(axis=1) + fl.height) - fl.height
    penetrating = np.asarray(low < -PENETRATION_TOL)
    return Evaluation(rows, track.sides, dict(compiled.foot_geoms), contacts, penetrating, skating)


def timeline_image(e: Evaluation, fps: float) -> np.ndarray:
    """A strip over the clip's time: each foot's contact frames, penetration (red) and skate (orange)."""
    from matplotlib.figure import Figure

    t = np.arange(len(e.penetrating)) / fps
    rows = [(f"{s} contact", e.contacts[:, i], "#28c85a") for i, s in enumerate(e.sides)]
    rows += [("penetration", e.penetrating, "#d94040"), ("skate", e.skating, "#f29933")]
    fig = Figure(figsize=(4.2, 0.3 + 0.25 * len(rows)), layout="constrained")
    ax = fig.subplots()
    for i, (_, mask, color) in enumerate(rows):
        ax.fill_between(t, i, i + 0.8, where=mask, step="mid", color=color, lw=0)
    ax.set_yticks(np.arange(len(rows)) + 0.4, [r[0] for r in rows], fontsize=7)
    ax.set_xlim(t[0], t[-1] if len(t) > 1 else 1.0)
    ax.set_ylim(0, len(rows))
    ax.tick_params(axis="x", labelsize=7)
    ax.set_xlabel("time (s)", fontsize=7)
    return png(lambda p: fig.savefig(p, format="png", dpi=80))
