"""Hit-point IK speed, accuracy and style against each other and the peer ``mink``, from one run (issue 5).

Problem: the golf swing ``cmu_asfamc_converted/64_01.bvh`` (448 frames) with the club fitted by
``hitpoint.fit_club``, the hit point moved 10 cm across and 10 cm up in the plane across the swing,
the default falloff (every frame the blend touches is solved), locked lead wrist.

1. Per frame, on the same goals and the same lead chain (lower spine → left hand), each from that
   frame's FK pose: CCD, DLS (MuJoCo Jacobians), NLP (CasADi/IPOPT), and ``mink`` (differential
   IK on MuJoCo with a QP; a frame task on the sweet spot, a posture task toward the FK pose weighted
   like our stiffness, the other DOFs frozen as constraints) on a copy of the model whose chain
   joints have our freedoms (hinges about our axes: a 1-DOF elbow, a locked wrist) and our per-frame
   limits (``mink.ConfigurationLimit``). The solvers run interleaved (every solver on frame t, the
   order alternating frame by frame), each to the same tolerance (1e-5 m). Time per frame (median and
   90th percentile) and final goal error (median, max).
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

# One BLAS thread (as the CLI runs): OpenBLAS threads contend on a shared 2-core machine, and
# mink's QP objective (products of ~100 × 100 matrices) then slows ~20x.
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import mujoco
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
    solvers: dict[str, object] = {}
    if with_ccd:
        solvers["ccd"] = lambda t: ccd.solve(kin, problem.qpos[t], problem.goals[t], lo[t], hi[t]).error
    solvers["dls"] = lambda t: dls.solve(kin, problem.qpos[t], problem.goals[t], lo[t], hi[t]).error
    fs = FrameSolver(c, lead)

    def nlp(t: int) -> float:
        kin.set_frame(problem.qpos[t])
        kin.set_delta(np.zeros(lead.n_dof))
        return fs.solve(problem.qpos[t], kin.data.xpos, kin.data.xmat, problem.goals[t], lo[t], hi[t]).error

    solvers["nlp"] = nlp
    mink_fn, why = mink_solver(problem)
    if mink_fn is not None:
        solvers["mink"] = mink_fn
    # interleaved: every solver on frame t (same input), alternating the order frame by frame
    rows: dict[str, tuple[list[float], list[float]]] = {name: ([], []) for name in solvers}
    order = list(solvers)
    for n, t in enumerate(frames):
        for name in order if n % 2 else order[::-1]:
            s = time.perf_counter()
            err = solvers[name](t)  # type: ignore[operator]
            rows[name][0].append(time.perf_counter() - s)
            rows[name][1].append(err)
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
        tol = 1e-5
        reached = {n: int(np.sum(np.asarray(v[1]) < tol * 1.0001)) for n, v in rows.items()}
        print(
            f"equal accuracy: every solver iterates to {tol * 1e3:g} mm; frames within it: "
            + ", ".join(f"{n} {k}/{len(frames)}" for n, k in reached.items())
            + "; mink has our freedoms (hinge elbow and forearm, locked wrist) and per-frame limits (ConfigurationLimit)"
        )


def mink_model(problem: hitpoint.HitProblem):
    """A copy of the character for mink with the lead chain's freedoms as ours: each chain joint's
    ball joint replaced by hinges about its free axes (the columns of its ``basis``, in order), so a
    hinge elbow is one DOF and a locked wrist none; limited, the ranges set per frame.

    Per frame the chain bodies' rest orientation becomes ``body_quat ⊗ q_fk`` (the frame's FK
    rotation), so hinge angles are exactly our coordinates ``δ`` (``q = q_fk ⊗ Rot(b₁, δ₁) ⊗ …``,
    MuJoCo composing a body's joints in order) and their box limits are our per-frame bounds.
    Returns ``(model, chain_bodies, hinge_qpos_adr, hinge_dof_adr, qpos_map)``: ``qpos_map[i]`` is the address in
    our model's ``qpos`` of the mink model's ``qpos[i]`` (``-1`` for a hinge).
    """
    c, lead = problem.compiled, problem.lead
    spec = c.spec.copy()
    names = [lead.skeleton.names[j.joint] for j in lead.joints]
    for name, j in zip(names, lead.joints):
        body = spec.body(name)
        spec.delete(spec.joint(name))
        for k in range(j.dof):
            body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, name=f"{name}/h{k}", axis=j.basis[:, k].tolist(), limited=1, range=[-1.0, 1.0])
    for jnt in spec.joints:  # only the chain's hinges are limited (the rest is frozen anyway)
        if "/h" not in jnt.name:
            jnt.limited = 0
    model = spec.compile()
    qmap = np.full(model.nq, -1, dtype=int)
    sizes = {
        int(mujoco.mjtJoint.mjJNT_FREE): 7,
        int(mujoco.mjtJoint.mjJNT_BALL): 4,
        int(mujoco.mjtJoint.mjJNT_HINGE): 1,
        int(mujoco.mjtJoint.mjJNT_SLIDE): 1,
    }
    hinge_adr, hinge_dof = [], []
    for jid in range(model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, jid)
        adr, size = int(model.jnt_qposadr[jid]), sizes[int(model.jnt_type[jid])]
        if model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_HINGE and "/h" in name:
            hinge_adr.append(adr)
            hinge_dof.append(int(model.jnt_dofadr[jid]))
            continue
        src = mujoco.mj_name2id(c.model, mujoco.mjtObj.mjOBJ_JOINT, name)
        qmap[adr : adr + size] = np.arange(c.model.jnt_qposadr[src], c.model.jnt_qposadr[src] + size)
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n) for n in names]
    return model, bodies, np.array(hinge_adr, dtype=int), np.array(hinge_dof, dtype=int), qmap


def mink_solver(problem: hitpoint.HitProblem, posture_scale: float = 1e-3, max_iter: int = 100, tol: float = 1e-5):
    """mink (differential IK as a QP) on the same chain freedoms and per-frame limits as ours.

    A frame task on the club's sweet spot, a posture task toward the FK pose weighted like our
    stiffness, every other DOF frozen by a constraint, ``ConfigurationLimit`` (gain 1: the box
    itself) on the hinges with our per-frame bounds; iterated to the same tolerance as DLS.
    """
    try:
        import mink
    except ImportError as exc:  # an optional peer
        return None, f"mink does not import ({exc}); pip install mink"
    c, lead = problem.compiled, problem.lead
    site = problem.prop.site if problem.prop is not None else None
    if site is None:
        return None, "the mink comparison needs a site effector (the club)"
    model, bodies, hinge_adr, hinge_dof, qmap = mink_model(problem)
    frozen = [i for i in range(model.nv) if i not in set(hinge_dof.tolist())]
    cost = np.zeros(model.nv)
    cost[hinge_dof] = posture_scale / np.sqrt(lead.weights)
    rest = model.body_quat[bodies].copy()
    task = mink.FrameTask(site, "site", position_cost=1.0, orientation_cost=0.0)
    posture = mink.PostureTask(model, cost=cost)
    freeze = mink.DofFreezingTask(model, dof_indices=frozen)
    limit = mink.ConfigurationLimit(model, gain=1.0)
    config = mink.Configuration(model)
    lo_all, hi_all = lead.bounds(problem.source)
    q_src = np.zeros(model.nq)

    def solve(t: int) -> float:
        qpos = problem.qpos[t]
        for b, j, r in zip(bodies, lead.joints, rest):
            model.body_quat[b] = rot.multiply(r, qpos[c.qpos_adr[j.joint] : c.qpos_adr[j.joint] + 4])
        keep = qmap >= 0
        q_src[keep] = qpos[qmap[keep]]
        q_src[hinge_adr] = 0.0
        limit.lower[hinge_adr] = lo_all[t]
        limit.upper[hinge_adr] = hi_all[t]
        config.update(q_src)
        posture.set_target(q_src)
        task.set_target(mink.SE3.from_translation(problem.goals[t]))
        for _ in range(max_iter):
            err = np.linalg.norm(config.get_transform_frame_to_world(site, "site").translation() - problem.goals[t])
            if err < tol:
                break
            v = mink.solve_ik(config, [task, posture], dt=1.0, solver="daqp", damping=1e-8, limits=[limit], constraints=[freeze])
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
