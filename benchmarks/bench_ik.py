"""Hit-point IK speed, accuracy and style against each other and the peer ``mink``, from one run (issue 5).

Problem: the golf swing ``cmu_asfamc_converted/64_01.bvh`` (448 frames) with the club fitted by
``hitpoint.fit_club``, the hit point moved 10 cm across and 10 cm up in the plane across the swing,
the default falloff (every frame the blend touches is solved), locked lead wrist.

1. Per frame, on the same goals and the same lead chain (lower spine → left hand), each from that
   frame's FK pose: CCD, DLS (MuJoCo Jacobians), NLP (CasADi/IPOPT), and ``mink`` (differential
   IK on MuJoCo with a QP; a frame task on the sweet spot, a posture task toward the FK pose weighted
   like our stiffness, the other DOFs frozen as constraints; mink cannot restrict a ball joint to a
   hinge, so its elbow/forearm keep 3 DOF). Time per frame (median and 90th percentile) and final
   goal error (median, max).
2. Whole-shot NLP (both hands as constraints, smoothness term): wall time including the build.
3. Style error (``style.style_rmse``) of the full adaptation with each solver, and how smoothly
   the IK deviation from the source varies (RMS second difference of ``log(q_src⁻¹ q)``, rad/s²:
   what the whole-shot form's smoothness term buys).

Goals: DLS < 1 ms/frame, NLP < 20 ms/frame, whole-shot NLP < 2 s, style NLP ≤ DLS ≤ CCD.

With ``--grid``: the done-when experiment — all five swings × 3×3 targets at ±10 and ±20 cm for
``nlp`` and ``dls`` (locked wrist) and ``dls`` with a 2-DOF wrist: max hit error, max goal error,
max grip error, first/last frames and the untouched joints equal to the source, mean style error
(seed Table 2.1: locked should beat 2-DOF).

Usage: ``python benchmarks/bench_ik.py [--grid] [--no-ccd]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mjmotion import bvh, hitpoint
from mjmotion import rotations as rot
from mjmotion.ik import ccd, dls
from mjmotion.ik.chains import ChainKinematics
from mjmotion.ik.nlp import FrameSolver

SWINGS = [f"64_0{i}" for i in range(1, 6)]


def data_dir() -> Path:
    env = os.environ.get("MJMOTION_DATA")
    d = Path(env) if env else REPO.parent / "shared" / "mocap"
    if not d.is_dir():
        sys.exit(f"real mocap not found at {d}: set MJMOTION_DATA")
    return d


def stats(times: list[float], errors: list[float]) -> str:
    t = np.asarray(times) * 1000
    e = np.asarray(errors) * 1000
    return f"{np.median(t):9.3f} {np.percentile(t, 90):9.3f} {np.median(e):12.2e} {e.max():12.2e}"


def per_frame(problem: hitpoint.HitProblem, with_ccd: bool) -> None:
    c, lead = problem.compiled, problem.lead
    frames = np.flatnonzero(problem.blend > 0)
    lo, hi = lead.bounds(problem.source)
    kin = ChainKinematics(c, lead)
    rows: dict[str, tuple[list[float], list[float]]] = {}

    def run(name: str, fn) -> None:
        ts, es = [], []
        for t in frames:
            s = time.perf_counter()
            err = fn(t)
            ts.append(time.perf_counter() - s)
            es.append(err)
        rows[name] = (ts, es)

    if with_ccd:
        run("ccd", lambda t: ccd.solve(kin, problem.qpos[t], problem.goals[t], lo[t], hi[t]).error)
    run("dls", lambda t: dls.solve(kin, problem.qpos[t], problem.goals[t], lo[t], hi[t]).error)
    fs = FrameSolver(c, lead)

    def nlp(t: int) -> float:
        kin.set_frame(problem.qpos[t])
        kin.set_delta(np.zeros(lead.n_dof))
        return fs.solve(problem.qpos[t], kin.data.xpos, kin.data.xmat, problem.goals[t], lo[t], hi[t]).error

    run("nlp", nlp)
    mink_fn, why = mink_solver(problem)
    if mink_fn is not None:
        run("mink", mink_fn)
    print(
        f"\nper-frame lead-chain IK over {len(frames)} frames ({lead.n_dof} DOF: {', '.join(f'{n}:{j.dof}' for n, j in zip(lead.names, lead.joints))})"
    )
    print(f"{'solver':8s} {'ms median':>9s} {'ms p90':>9s} {'err mm med':>12s} {'err mm max':>12s}")
    for name, (ts, es) in rows.items():
        print(f"{name:8s} {stats(ts, es)}")
    if mink_fn is None:
        print(f"mink     not run: {why}")
    else:
        base = np.median(rows["mink"][0])
        print("time ratio to mink (median): " + ", ".join(f"{n} {np.median(v[0]) / base:.2f}x" for n, v in rows.items()))


def mink_solver(problem: hitpoint.HitProblem, posture_scale: float = 1e-3, max_iter: int = 50, tol: float = 1e-5):
    try:
        import mink
    except ImportError as exc:  # an optional peer
        return None, f"mink does not import ({exc}); pip install mink"
    c, lead = problem.compiled, problem.lead
    model = c.model
    chain_dofs = set()
    for j in lead.joints:
        if j.dof:
            chain_dofs.update(range(c.dof_adr[j.joint], c.dof_adr[j.joint] + 3))
    frozen = [i for i in range(model.nv) if i not in chain_dofs]
    cost = np.zeros(model.nv)
    for j in lead.joints:
        if j.dof:
            cost[c.dof_adr[j.joint] : c.dof_adr[j.joint] + 3] = posture_scale / np.sqrt(j.weight.mean())
    site = problem.prop.site if problem.prop is not None else None
    if site is None:
        return None, "the mink comparison needs a site effector (the club)"
    task = mink.FrameTask(site, "site", position_cost=1.0, orientation_cost=0.0)
    posture = mink.PostureTask(model, cost=cost)
    freeze = mink.DofFreezingTask(model, dof_indices=frozen)
    config = mink.Configuration(model)

    def solve(t: int) -> float:
        q = problem.qpos[t]
        config.update(q)
        posture.set_target(q)
        task.set_target(mink.SE3.from_translation(problem.goals[t]))
        for _ in range(max_iter):
            err = np.linalg.norm(config.get_transform_frame_to_world(site, "site").translation() - problem.goals[t])
            if err < tol:
                break
            v = mink.solve_ik(config, [task, posture], dt=1.0, solver="daqp", damping=1e-8, limits=[], constraints=[freeze])
            config.integrate_inplace(v, 1.0)
        return float(np.linalg.norm(config.get_transform_frame_to_world(site, "site").translation() - problem.goals[t]))

    return solve, ""


def deviation_acceleration(source, adapted) -> float:
    """RMS over frames and joints of the second time difference of the IK deviation ``log(q_src⁻¹ q)`` (rad/s²)."""
    dev = rot.log(rot.multiply(rot.conjugate(source.rotations), adapted.rotations))
    moved = np.flatnonzero(np.abs(dev).max(axis=(0, 2)) > 0)
    acc = np.diff(dev[:, moved], n=2, axis=0) * source.fps**2
    return float(np.sqrt(np.mean(np.sum(acc**2, axis=-1))))


def whole_shot_and_style(m, prop, offset: np.ndarray, with_ccd: bool) -> None:
    print(f"\nfull adaptation of {m.name} ({m.n_frames} frames), both hands:")
    print(f"{'solver':9s} {'wall s':>8s} {'solve s/frame':>14s} {'hit err mm':>11s} {'grip err mm':>12s} {'style_rmse':>11s} {'dev acc rad/s2':>14s}")
    results = {}
    for solver in ["nlp-shot", "nlp", "dls"] + (["ccd"] if with_ccd else []):
        s = time.perf_counter()
        a = hitpoint.adapt(m, offset=offset, prop=prop, solver=solver)
        wall = time.perf_counter() - s
        r = a.report
        results[solver] = r["style_rmse"]
        print(
            f"{solver:9s} {wall:8.2f} {r['solve_s_per_frame']:14.5f} {r['hit_error_m'] * 1000:11.2e} {r['grip_error_m'] * 1000:12.2e} {r['style_rmse']:11.4f} {deviation_acceleration(m, a.motion):14.1f}"
        )
        if solver == "nlp-shot":
            n = int((a.problem.blend > 0).sum())
            print(
                f"          whole-shot NLP: {r['solve_s_per_frame'] * n:.2f} s for {n} solved frames of a {m.n_frames}-frame swing (build + solve; goal < 2 s)"
            )
    order = " ≤ ".join(sorted(results, key=results.get))
    print(f"style order (best first): {order}   goal: nlp ≤ dls ≤ ccd")


def grid(with_solvers: tuple[str, ...] = ("nlp", "dls")) -> None:
    d = data_dir()
    print("\n5 swings × 3×3 targets at ±10 and ±20 cm across the swing (done-when experiment)")
    print(
        f"{'clip':6s} {'solver':8s} {'n':>3s} {'max hit mm':>10s} {'max goal mm':>11s} {'max grip mm':>11s} {'ends==src':>9s} {'legs==src':>9s} {'mean style':>10s} {'s/frame':>8s}"
    )
    for clip in SWINGS:
        m = bvh.read(d / "cmu_asfamc_converted" / f"{clip}.bvh")
        prop = hitpoint.fit_club(m)
        for solver, wrist in [(s, "locked") for s in with_solvers] + [("dls", "swing")]:
            rs = hitpoint.grid_reports(m, prop=prop, solver=solver, wrist=wrist)
            label = solver if wrist == "locked" else f"{solver}/2dof"
            print(
                f"{clip:6s} {label:8s} {len(rs):3d} {max(r['hit_error_m'] for r in rs) * 1000:10.2e} "
                f"{max(r['max_goal_error_m'] for r in rs) * 1000:11.2e} {max(r['grip_error_m'] for r in rs) * 1000:11.2e} "
                f"{all(r['first_last_equal'] for r in rs)!s:>9s} {all(r['untouched_equal'] for r in rs)!s:>9s} "
                f"{np.mean([r['style_rmse'] for r in rs]):10.4f} {np.mean([r['solve_s_per_frame'] for r in rs]):8.4f}",
                flush=True,
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--grid", action="store_true", help="also run the 5-swing target grid for nlp and dls")
    ap.add_argument("--no-ccd", action="store_true", help="skip CCD (about 0.5 s per frame)")
    args = ap.parse_args()
    m = bvh.read(data_dir() / "cmu_asfamc_converted" / "64_01.bvh")
    prop = hitpoint.fit_club(m)
    base = hitpoint.setup(m, offset=np.zeros(3), prop=prop)
    axes = hitpoint.swing_plane_axes(base)
    offset = 0.1 * axes[0] + 0.1 * axes[1]
    problem = hitpoint.setup(m, offset=offset, prop=prop)
    print(f"64_01: hit frame {problem.hit}, offset {np.round(offset, 3).tolist()} m, falloff {problem.falloff} m")
    per_frame(problem, not args.no_ccd)
    whole_shot_and_style(m, prop, offset, not args.no_ccd)
    if args.grid:
        grid()


if __name__ == "__main__":
    main()
