"""Hit-point grid: solvers × wrist freedom × a 3×3 target grid (seed 003 §2.5, Table 2.1, Figure 2.6).

Each shot is adapted (``hitpoint.adapt``) so its effector meets targets on 3×3 grids at ±10 and
±20 cm around the source hit point, in the plane across the swing (``hitpoint.target_grid``;
17 distinct targets, the centre once). Per shot × solver × lead-wrist freedom (locked, §2.3.3,
or a 2-DOF swing): hit error, reachable count, goal error over the clip, mean ``style_rmse``
(METRICS.md "Style"), grip error, solve time per frame, whether the first/last frames and the
untouched joints are the source's, and Figure 2.6's predictability: a ball at each target is
struck by the adapted effector in a MuJoCo impact simulation (``physics.launch_predictability``)
and the launch azimuth/elevation are rank-correlated with the hit point's offset (Spearman ρ).

Real data: the golf swings ``cmu_asfamc_converted/64_01..05`` (club fitted by
``hitpoint.fit_club``) and the soccer kicks ``10_01``/``10_02`` (right foot, ±10 cm grid).
Bundled: the cricket drive and pull (bat prop) and the front kick. ``nlp`` and ``dls`` run on
every shot; the whole-shot NLP on the first; CCD (a pure-Python loop, 0.1–1 s a frame) on the
first shot's ±10 cm grid only. ``quick``: the drive, DLS, the ±10 cm grid.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..skeleton import Motion
from . import Table, single_thread_blas

if TYPE_CHECKING:
    from ..executor import Executor
    from ..mjcf import Prop
    from ..physics import Predictability

#: Grid spacings (metres) of the 3×3 target grids (issue 5; seed §2.5 tests "left-to-right and low-to-high").
SPACINGS = (0.1, 0.2)
#: CCD's grid: one spacing on the first shot only (its per-frame cost is a Python loop).
CCD_SPACINGS = (0.1,)
#: Kicks: the ball moved ±10 cm (issue 5).
KICK_SPACINGS = (0.1,)
#: Reach tolerance (metres) for the "reached" count.
REACH_M = 1e-3
#: Frames either side of the hit given to the impact simulation.
LAUNCH_WINDOW = 3
#: The delivered ball of the cricket shots (seed §2.3.2): its pace, and the bowler's side of the
#: bundled batting stance (+Y).
DELIVERY = "medium"
BOWLER = (0.0, 1.0)

COLUMNS = (
    "shot", "solver", "wrist", "targets", "reached ≤1 mm", "hit err max mm", "hit err mean mm",
    "goal err max mm", "style_rmse mean", "style vs locked %", "grip err max mm", "ms/frame",
    "ends = source", "root/legs = source", "launch ρ azimuth", "launch ρ elevation",
    "delivered ρ azimuth", "delivered ρ elevation", "joint speed ratio max", "short max mm",
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class Ball:
    """The struck ball of a shot kind: radius (m), mass (kg), coefficient of restitution."""

    radius: float
    mass: float
    restitution: float


BALLS = {
    "golf": Ball(0.0214, 0.046, 0.8),
    "cricket": Ball(0.036, 0.16, 0.5),
    "soccer": Ball(0.11, 0.43, 0.7),
}


@dataclass(frozen=True, eq=False)
class Shot:
    """A source clip for the experiments.

    Attributes:
        name: label in tables and file names (``64_01``, ``drive``).
        motion: the clip.
        effector: ``hitpoint.adapt``'s effector (``club`` or ``right_foot``).
        prop: the club/bat (fitted or bundled), ``None`` for a kick.
        hit_frame: the impact frame (given for bundled clips; detected for captured ones).
        ball: the struck ball's kind (a key of :data:`BALLS`).
        first_hand: the hand the other is held to on the grip (``None``: one hand or a kick).
        captured: real mocap (``True``) or a bundled procedural clip.
    """

    name: str
    motion: Motion
    effector: str
    prop: Prop | None
    hit_frame: int
    ball: str
    first_hand: str | None
    captured: bool

    @property
    def two_handed(self) -> bool:
        return self.effector == "club"


def _kick_hit(motion: Motion, effector: str = "right_foot") -> int:
    """A front kick's impact: the frame the kicking foot is furthest (horizontally) from where it stood."""
    from .. import hitpoint

    p = hitpoint.setup(motion, offset=np.zeros(3), effector=effector)
    reach = np.linalg.norm((p.effector_fk - p.effector_fk[0])[:, :2], axis=1)
    return int(np.argmax(reach))


def load_shots(data_dir: Path | None, quick: bool = False, kicks: bool = True, cricket: bool = True) -> list[Shot]:
    """The shots of the experiments: captured golf swings and kicks (and, with ``cricket``, the
    bundled cricket drive and pull, the seed's own kind of shot), or the bundled drive/pull/kick.

    ``quick`` keeps the first shot only.
    """
    from .. import bvh, hitpoint
    from ..skeleton import side_of

    out: list[Shot] = []
    if data_dir is not None:
        folder = Path(data_dir) / "cmu_asfamc_converted"
        names = [f"64_0{i}" for i in range(1, 6)]
        for name in names[:1] if quick else names:
            m = bvh.read(folder / f"{name}.bvh")
            prop = hitpoint.fit_club(m)
            hit = hitpoint.setup(m, offset=np.zeros(3), prop=prop).hit
            out.append(Shot(name, m, "club", prop, hit, "golf", side_of(prop.joint), True))
        if kicks and not quick:
            for name in ("10_01", "10_02"):
                m = bvh.read(folder / f"{name}.bvh")
                hit = hitpoint.setup(m, offset=np.zeros(3), effector="right_foot").hit
                out.append(Shot(name, m, "right_foot", None, hit, "soccer", None, True))
        if not (cricket and not quick):
            return out
    from .. import synth

    if data_dir is not None:
        for name in ("drive", "pull"):
            c = getattr(synth, name)()
            out.append(Shot(name, c.motion, "club", c.prop, int(c.hit_frame), "cricket", side_of(c.prop.joint), False))
        return out

    for name in ("drive",) if quick else ("drive", "pull"):
        c = getattr(synth, name)()
        out.append(Shot(name, c.motion, "club", c.prop, int(c.hit_frame), "cricket", side_of(c.prop.joint), False))
    if kicks and not quick:
        k = synth.kick()
        out.append(Shot("kick", k.motion, "right_foot", None, _kick_hit(k.motion), "soccer", None, False))
    return out


# --- one task: a shot, a solver, a wrist, its grid --------------------------------------------
@dataclass(frozen=True, eq=False)
class GridResult:
    """The adaptations of one shot × solver × wrist to every target of its grid.

    Attributes:
        shot, solver, wrist: what was run (``wrist`` is ``"–"`` for a kick).
        offsets: ``(N, 3)`` target offsets from the source hit point (metres).
        reports: ``hitpoint.adapt`` reports, one per target.
        first_last_equal, untouched_equal: ``(N,) bool`` (first/last frames; root and joints outside the chains).
        predictability: ``physics.Predictability`` of the launches of a ball at rest at each target,
            or ``None`` without a struck geom.
        delivered: the same for a delivered ball (cricket: :data:`DELIVERY` from the bowler's end,
            :mod:`mjmotion.delivery`), or ``None``.
        delivery: the incoming ball ``(3,)`` m/s and where it pitched ``(3,)`` (``None``: no bounce), or ``None``.
        seconds: wall time of the task.
    """

    shot: str
    solver: str
    wrist: str
    offsets: np.ndarray
    reports: list[dict]
    first_last_equal: np.ndarray
    untouched_equal: np.ndarray
    predictability: Predictability | None
    seconds: float
    delivered: Predictability | None = None
    delivery: tuple[np.ndarray, np.ndarray | None] | None = None


def grid_offsets(shot: Shot, spacings: Sequence[float]) -> np.ndarray:
    """``(N, 3)`` distinct target offsets: the centre, then the other points of each 3×3 grid."""
    from .. import hitpoint

    base = hitpoint.setup(shot.motion, offset=np.zeros(3), frame=shot.hit_frame, effector=shot.effector, prop=shot.prop)
    rows = [np.zeros(3)]
    for s in spacings:
        # (a grid raised off the floor shares points with the next one: each target once)
        rows += [o for o in hitpoint.target_grid(base, s) if min(np.linalg.norm(o - r) for r in rows) > 1e-9]
    return np.array(rows)


def _struck_geom(compiled, shot: Shot, q_hit: np.ndarray, point: np.ndarray) -> int:
    """The geom that strikes the ball: the prop's, else the character geom nearest the effector at the hit."""
    import mujoco

    m = compiled.model
    if shot.prop is not None:
        return int(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, shot.prop.name))
    d = mujoco.MjData(m)
    d.qpos[:] = q_hit
    mujoco.mj_kinematics(m, d)
    cands = np.asarray(compiled.body_geom_ids)
    return int(cands[int(np.argmin(np.linalg.norm(d.geom_xpos[cands] - point, axis=1)))])


def run_grid(shot: Shot, solver: str, wrist: str, spacings: Sequence[float], launch: bool = True) -> GridResult:
    """Adapt ``shot`` to every target of its grids with ``solver`` and ``wrist``; simulate the launches."""
    from .. import hitpoint, launchgrid, physics

    start = time.perf_counter()
    offsets = grid_offsets(shot, spacings)
    m = shot.motion
    reports, ends, still, paths = [], [], [], []
    geom = None
    h = 0
    for off in offsets:
        a = hitpoint.adapt(
            m, offset=off, frame=shot.hit_frame, effector=shot.effector, solver=solver,
            wrist=wrist if wrist != "–" else "locked", prop=shot.prop,
        )  # fmt: skip
        p = a.problem
        reports.append(a.report)
        first_last, untouched = hitpoint.source_kept(a)
        ends.append(first_last)
        still.append(untouched)
        if launch:
            if geom is None:
                geom = _struck_geom(p.compiled, shot, p.qpos[p.hit], p.effector_fk[p.hit])
            pos, quat, h = launchgrid.effector_path(p.compiled, a.motion, geom, p.hit, LAUNCH_WINDOW)
            paths.append((pos, quat))
    pred = delivered = delivery = None
    if launch and geom is not None:
        import mujoco  # noqa: F401  (the compiled model's geom type/size)

        model = p.compiled.model
        ball = BALLS[shot.ball]
        # the ball is where the adapted effector was sent (a target stopped short: the stopped one)
        targets = np.array([r["stopped_target"] for r in reports])
        args = (int(model.geom_type[geom]), model.geom_size[geom].tolist(), paths, m.fps, h, targets, ball.radius, ball.mass)
        pred = physics.launch_predictability(*args, restitution=ball.restitution)
        if shot.ball == "cricket":
            # seed §2.3.2: the incoming ball "as it bounces up from the floor", delivered at the source hit point
            from .. import delivery as dl

            flight = dl.fly(dl.aimed(reports[0]["source_effector"], bowler=BOWLER, preset=DELIVERY))
            incoming = flight.nearest(np.asarray(reports[0]["source_effector"]))[2]
            delivered = physics.launch_predictability(*args, ball_velocity=tuple(incoming), restitution=ball.restitution)
            delivery = (incoming, flight.bounce)
    return GridResult(
        shot.name, solver, wrist, offsets, reports, np.array(ends), np.array(still), pred, time.perf_counter() - start, delivered, delivery
    )


def _task(args: tuple) -> GridResult:
    with single_thread_blas():
        return run_grid(*args)


# --- the table ---------------------------------------------------------------------------------
def plan(shots: list[Shot], quick: bool) -> list[tuple[Shot, str, str, tuple[float, ...]]]:
    """The tasks: ``(shot, solver, wrist, spacings)``."""
    tasks: list[tuple[Shot, str, str, tuple[float, ...]]] = []
    for i, s in enumerate(shots):
        wrists = ("locked", "swing") if s.two_handed else ("–",)
        spacings: tuple[float, ...] = SPACINGS if s.two_handed else KICK_SPACINGS
        if quick:
            tasks += [(s, "dls", w, (0.1,)) for w in wrists]
            continue
        solvers = ["nlp", "dls"]
        if i == 0:
            solvers.append("nlp-shot")
        for solver in solvers:
            tasks += [(s, solver, w, spacings) for w in wrists]
        if i == 0:
            tasks += [(s, "ccd", w, CCD_SPACINGS) for w in wrists]
    return tasks


def _mm(x: float) -> float:
    return 1000.0 * float(x)


def row(g: GridResult, locked_style: float | None) -> tuple:
    r = g.reports
    hit = np.array([x["hit_error_m"] for x in r])
    style = float(np.mean([x["style_rmse"] for x in r]))
    rel = 100.0 * (style - locked_style) / locked_style if locked_style else float("nan")
    pred, dlv = g.predictability, g.delivered
    return (
        g.shot, g.solver, g.wrist, len(r), int(np.sum(hit <= REACH_M)), _mm(hit.max()), _mm(hit.mean()),
        _mm(max(x["max_goal_error_m"] for x in r)), style, rel, _mm(max(x["grip_error_m"] for x in r)),
        1000.0 * float(np.mean([x["solve_s_per_frame"] for x in r])),
        f"{int(g.first_last_equal.sum())}/{len(r)}", f"{int(g.untouched_equal.sum())}/{len(r)}",
        float(pred.rho_azimuth) if pred is not None else float("nan"),
        float(pred.rho_elevation) if pred is not None else float("nan"),
        float(dlv.rho_azimuth) if dlv is not None else float("nan"),
        float(dlv.rho_elevation) if dlv is not None else float("nan"),
        max(x["joint_speed_ratio"] for x in r), _mm(max(x["short_by_m"] for x in r)),
    )  # fmt: skip


def table_2_1(results: list[GridResult]) -> dict[str, tuple[float, float, int]]:
    """Per solver: mean style_rmse of the locked and the 2-DOF wrist over the shots where both ran
    on the same targets, and the number of such shots (seed Table 2.1's comparison)."""
    by = {(g.shot, g.solver, g.wrist): g for g in results}
    out: dict[str, tuple[float, float, int]] = {}
    for solver in dict.fromkeys(g.solver for g in results):
        pairs = [
            (
                np.mean([x["style_rmse"] for x in by[(s, solver, "locked")].reports]),
                np.mean([x["style_rmse"] for x in by[(s, solver, "swing")].reports]),
            )
            for s in dict.fromkeys(g.shot for g in results)
            if (s, solver, "locked") in by and (s, solver, "swing") in by
        ]
        if pairs:
            a = np.array(pairs)
            out[solver] = (float(a[:, 0].mean()), float(a[:, 1].mean()), len(pairs))
    return out


def _blend_png(shot: Shot, out: Path) -> Path:
    """Seed Figure 2.3: the importance-based IK blend of ``shot`` against a time-based one (0 at
    the ends, 1 at the hit, raised cosines between), with the effector's distance to the hit point."""
    from .. import hitpoint, plots

    p = hitpoint.setup(shot.motion, offset=np.zeros(3), frame=shot.hit_frame, effector=shot.effector, prop=shot.prop, weights="clip")
    n, h = shot.motion.n_frames, p.hit
    t = np.arange(n)
    time_based = np.where(t <= h, 0.5 * (1 - np.cos(np.pi * t / max(h, 1))), 0.5 * (1 + np.cos(np.pi * (t - h) / max(n - 1 - h, 1))))
    d = np.linalg.norm(p.effector_fk - p.effector_fk[h], axis=1)
    return plots.ik_blend(
        t / shot.motion.fps, {"time-based": time_based, f"importance-based (falloff {p.falloff:g} m)": p.blend}, h / shot.motion.fps, out,
        distance=d, title=f"{shot.name}: IK blend over the shot (seed Fig. 2.3)",
    )  # fmt: skip


#: Falloff distances (m) of the seed's Figure 2.7 comparison (its 70 and 110 units, in our metres).
FALLOFFS = (0.35, 0.9)


def _falloff_png(shot: Shot, solver: str, offset: np.ndarray, out: Path) -> Path:
    """Seed Figure 2.7: the prop at the two frames before the hit and the one after it, for the
    source and for the shot adapted to a higher hit point with two falloff distances (the hit is
    the same, the path to it is not)."""
    from .. import hitpoint, kinematics, plots

    if shot.prop is None:
        raise ValueError(f"{shot.name}: Figure 2.7 draws a prop; this shot has none")
    name = shot.prop.name
    p = hitpoint.setup(shot.motion, offset=offset, frame=shot.hit_frame, effector=shot.effector, prop=shot.prop, weights="clip")
    frames = [p.hit - 2, p.hit - 1, p.hit + 1]
    segs: dict[str, np.ndarray] = {}
    for falloff in (None, *FALLOFFS):
        if falloff is None:
            motion, label = shot.motion, "source"
        else:
            a = hitpoint.adapt(
                shot.motion, offset=offset, frame=shot.hit_frame, effector=shot.effector, solver=solver, prop=shot.prop,
                falloff=falloff, style=False,
            )  # fmt: skip
            motion, label = a.motion, f"falloff {falloff:g} m"
        pose = kinematics.forward(p.compiled, motion)
        segs[label] = np.stack([pose.site(f"{name}/grip")[frames], pose.site(f"{name}/tip")[frames]], axis=1)
    v = p.effector_fk[p.hit + 1] - p.effector_fk[p.hit - 1]
    along = v - v[2] * np.array([0.0, 0.0, 1.0])
    view = np.stack([along / np.linalg.norm(along), np.array([0.0, 0.0, 1.0])])
    return plots.prop_frames(
        segs, [f"hit − 2 (frame {p.hit - 2})", f"hit − 1 (frame {p.hit - 1})", f"hit + 1 (frame {p.hit + 1})"], out, ball=p.target, axes=view,
        title=f"{shot.name}: a hit point {100 * np.linalg.norm(offset):.0f} cm higher, two falloffs ({solver}; seed Fig. 2.7)",
    )  # fmt: skip


def _style_paths_png(shot: Shot, solver: str, offset: np.ndarray, out: Path) -> Path:
    """Seed Figure 2.12: the source and its two adaptations (locked, 2-DOF wrist) in the source's PC space."""
    from .. import hitpoint, plots
    from ..style import PoseSpace

    space = PoseSpace.fit(shot.motion)
    k = max(space.components_for(0.7), 4)
    paths = {"source": space.source_scores[:, :k]}
    for wrist, label in (("locked", "locked wrist"), ("swing", "2-DOF wrist")):
        a = hitpoint.adapt(
            shot.motion, offset=offset, frame=shot.hit_frame, effector=shot.effector, solver=solver, wrist=wrist, prop=shot.prop, style=False
        )
        paths[label] = space.scores(a.motion, k)
    return plots.score_paths(
        paths, out, dims=2, highlight=shot.hit_frame,
        title=f"{shot.name}: hit point moved {100 * np.linalg.norm(offset):.0f} cm ({solver}), ★ = hit frame",
    )  # fmt: skip


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False, jobs: int = 2, executor: Executor | None = None) -> Table:
    """Run the grid and write ``out_dir/table.md`` with the launch plots (see the module doc); the
    tasks run on ``executor`` (Dask, :mod:`mjmotion.executor`) if given, else in ``jobs`` processes."""
    from ..executor import using

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    shots = load_shots(data_dir, quick)
    tasks = plan(shots, quick)
    # the longest first (CCD, the whole-shot NLP), so two workers finish together
    weight = {"ccd": 40.0, "nlp-shot": 3.0, "nlp": 1.5, "dls": 1.0}
    order = sorted(range(len(tasks)), key=lambda i: -weight[tasks[i][1]] * tasks[i][0].motion.n_frames * (len(tasks[i][3]) * 8 + 1))
    results: list[GridResult | None] = [None] * len(tasks)
    with using(executor, jobs if len(tasks) > 1 else 1) as ex:
        for out in ex.run(_task, [(i, (tasks[i],)) for i in order], desc="hitpoint grid", unit="task", progress=not quick):
            results[out.key] = out.unwrap()
    with single_thread_blas():
        return _tabulate(out_dir, shots, [g for g in results if g is not None], quick)


def _first_per_shot(done: list[GridResult]) -> list[GridResult]:
    """The first task of each shot."""
    seen: dict[str, GridResult] = {}
    for g in done:
        seen.setdefault(g.shot, g)
    return list(seen.values())


def launch_figures(g: GridResult, out_dir: Path) -> list[Path]:
    """Figure 2.6 of one task: its launch directions over its hit points, ``launch_<shot>_<wrist>.png``
    (``foot`` for a kick), and for a delivered ball ``launch_<shot>_<wrist>_delivered.png``; nothing
    without launches. Each depends on this task alone (``docs/make_images.py`` draws 64_01's so)."""
    from .. import plots

    if g.predictability is None:
        return []
    pr = g.predictability
    dirs = np.array([[ln.azimuth_deg, ln.elevation_deg] for ln in pr.launches])
    wrist = {"locked": "locked wrist", "swing": "2-DOF wrist"}.get(g.wrist, "kick")
    files = [
        plots.hitpoint_grid(
            pr.hit_points, dirs, out_dir / f"launch_{g.shot}_{g.wrist if g.wrist != '–' else 'foot'}.png",
            title=f"{g.shot} ({g.solver}, {wrist}): ρ az {pr.rho_azimuth:.2f}, ρ el {pr.rho_elevation:.2f}",
        )
    ]  # fmt: skip
    if g.delivered is not None:
        dv = g.delivered
        dirs = np.array([[ln.azimuth_deg, ln.elevation_deg] for ln in dv.launches])
        files.append(
            plots.hitpoint_grid(
                dv.hit_points, dirs, out_dir / f"launch_{g.shot}_{g.wrist}_delivered.png",
                title=f"{g.shot} ({g.solver}, {wrist}), a delivered ball: ρ az {dv.rho_azimuth:.2f}, ρ el {dv.rho_elevation:.2f}",
            )
        )  # fmt: skip
    return [Path(f) for f in files]


def delivery_speed() -> float:
    """Release speed (m/s) of :data:`DELIVERY`."""
    from ..delivery import PRESETS

    return PRESETS[DELIVERY]["speed"]


def _tabulate(out_dir: Path, shots: list[Shot], done: list[GridResult], quick: bool) -> Table:
    from .. import hitpoint

    table = Table(
        "Hit-point adaptation: solvers × wrist × target grid (seed 003 §2.5, Table 2.1, Fig. 2.6)" + (" — quick" if quick else ""),
        COLUMNS,
    )
    locked = {(g.shot, g.solver): float(np.mean([x["style_rmse"] for x in g.reports])) for g in done if g.wrist == "locked"}
    for g in done:
        table.add(*row(g, locked.get((g.shot, g.solver))))

    main_solver = "dls" if quick else "nlp"
    for solver, (lk, sw, n) in table_2_1(done).items():
        verdict = "yes" if lk < sw else "no"
        table.notes.append(
            f"Table 2.1 direction ({solver}, mean over {n} shot(s) × grid): locked {lk:.4f} vs 2-DOF {sw:.4f} "
            f"({100 * (sw - lk) / lk:+.1f} % for 2-DOF; seed: +29.3 %) — locked lower: **{verdict}**"
        )
    k = {g.shot: g.reports[0]["k"] for g in done}
    table.notes += [
        "targets: the source hit point and the 8 outer points of 3×3 grids at "
        + " and ".join(f"±{100 * s:.0f} cm" for s in (SPACINGS if not quick else (0.1,)))
        + " in the plane across the swing at the hit (hitpoint.target_grid: ±s across; up {0, s, 2s} where the hit is the "
        + "effector's lowest pass, a ball on the ground or a tee, else ±s); kicks ±10 cm; "
        + ("CCD on the first shot's ±10 cm grid only; " if not quick else "")
        + "wrist: the club hand's wrist locked (seed §2.3.3) or a 2-DOF swing; a kick's chain has no wrist (–)",
        (
            f"style_rmse: PCA of the source, k for 70 % variance ({', '.join(f'{s}: k={v}' for s, v in k.items())}); "
            "'style vs locked %' is the seed's '% difference' column: (this − locked) / locked"
        ),
        (
            "hit err: effector at the hit frame vs the target; goal err: max over frames vs the blended goal; "
            "grip err: second hand vs its source placement on the club (max over frames); ms/frame: solve time "
            "per solved frame (nlp-shot: the whole-shot problem's time divided by its frames); 'ends = source': "
            "first and last frames bit-identical; 'root/legs = source': root and every joint outside the two "
            "arm chains (a kick: outside the kicking leg chain) bit-identical"
        ),
        "launch ρ: Spearman rank correlation, over the targets, of the hit point's offset across the mean launch "
        "direction with the launch azimuth, and of its height with the elevation (seed Fig. 2.6; "
        "physics.launch_predictability: the adapted effector geom drives a free ball in MuJoCo, "
        + ", ".join(f"{k_} ball r={b.radius} m, e={b.restitution}" for k_, b in BALLS.items())
        + "); |ρ| near 1 = the launch follows the hit point predictably (the targets share heights, so "
        + "a perfectly monotone order gives less than 1: 0.949 on a 3×3 grid)",
        (
            "hit frames: the moment of contact — given for the bundled cricket shots, else the effector's lowest pass in "
            "the downswing (hitpoint.detect_hit_frame); source effector height above the floor the feet stand on at it: "
            + ", ".join(f"{g.shot} {100 * g.reports[0]['source_effector_height_m']:.1f} cm" for g in _first_per_shot(done))
        ),
        (
            "unreachable targets (reached < targets) stop short along the offset where the chains reach them with the "
            "second hand on the grip and the club off the floor ('short max mm': the largest shortfall); limits hold "
            "exactly on the joints' own angles; joints the source never turns (CMU clavicles, hip joints) are locked; "
            f"'joint speed ratio max': the largest chain joint's peak speed over its own source peak (bound "
            f"{hitpoint.JOINT_SPEED_BOUND:g}: the deviation ramps in and out at that pace around the hit, so goal err is "
            "the lag of those frames behind the importance blend's goals)"
        ),
        (
            f"delivered ρ (cricket): the same launches for a ball delivered at the source hit point ({DELIVERY} pace, "
            f"{delivery_speed():g} m/s from the bowler's end, pitching on the floor with restitution "
            f"{BALLS['cricket'].restitution}, mjmotion.delivery) instead of a ball at rest"
            + "".join(
                f"; {g.shot}: met at {np.linalg.norm(g.delivery[0]):.1f} m/s, pitched "
                f"{np.linalg.norm((np.asarray(g.delivery[1]) - np.asarray(g.reports[0]['source_effector']))[:2]):.2f} m in front"
                for g in _first_per_shot(done)
                if g.delivery is not None
            )
        ),
        "shots: "
        + ", ".join(f"{s.name} ({s.motion.n_frames} frames @ {s.motion.fps:g} fps, hit {s.hit_frame}, effector {s.effector})" for s in shots),
        "wall time per task (s): " + ", ".join(f"{g.shot}/{g.solver}/{g.wrist} {g.seconds:.1f}" for g in done),
    ]
    # Figure 2.6: launch directions from the hit points, locked vs 2-DOF wrist, for the first shot of each kind
    seen: set[str] = set()
    for g in done:
        s = next(x for x in shots if x.name == g.shot)
        key = f"{s.ball}/{g.wrist}"
        if g.solver != main_solver or g.predictability is None or key in seen:
            continue
        seen.add(key)
        table.files += [str(f) for f in launch_figures(g, out_dir)]
    # Figure 2.3: importance- against time-based blending, on the first shot of each kind
    kinds: dict[str, Shot] = {}
    for sh in shots:
        kinds.setdefault(sh.ball, sh)
    for sh in kinds.values():
        table.files.append(str(_blend_png(sh, out_dir / f"blend_{sh.name}.png")))
    for sh in kinds.values():
        if sh.two_handed:
            # Figure 2.7: two falloffs to the same hit point 10 cm higher
            axes = hitpoint.swing_plane_axes(hitpoint.setup(sh.motion, offset=np.zeros(3), frame=sh.hit_frame, prop=sh.prop, weights="clip"))
            table.files.append(str(_falloff_png(sh, main_solver, 0.1 * axes[1], out_dir / f"falloff_{sh.name}.png")))
    # Figure 2.12: the source and the two wrist setups in the source's principal-component space
    first = shots[0]
    if first.two_handed:
        offs = grid_offsets(first, (0.1,))
        axes = hitpoint.swing_plane_axes(hitpoint.setup(first.motion, offset=np.zeros(3), frame=first.hit_frame, prop=first.prop, weights="clip"))
        # (−s across, +s up): "slightly higher and to the left" (seed Fig. 2.5)
        corner = offs[int(np.argmin(np.linalg.norm(offs - 0.1 * (axes[1] - axes[0]), axis=1)))]
        table.files.append(str(_style_paths_png(first, main_solver, corner, out_dir / f"style_paths_{first.name}.png")))
    table.write(out_dir)
    return table
