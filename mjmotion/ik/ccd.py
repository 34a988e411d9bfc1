"""Cyclic coordinate descent (seed 003 §1.7.1, the seed's own choice in §2.2.1).

Sweeps from the chain's last coordinate up to its first; each coordinate turns its joint about
the coordinate's world axis by the angle that brings the effector closest to the goal (the
exact minimiser along that circle), scaled by the coordinate's stiffness weight relative to the
chain's largest (§1.10: stiffness in CCD as a limit on how far a joint turns per visit), capped
at ``max_step`` and clipped to the limits (exact: the coordinates are the joints' own limit
angles) and to a joint's cone limit, if it has one. Position goals only, as in the seed.
"""

from __future__ import annotations

import math

import numpy as np

from .chains import ChainKinematics, cone_step, factor_rates
from .dls import IKResult


def solve(
    kin: ChainKinematics,
    qpos: np.ndarray,
    goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    tol: float = 1e-5,
    max_sweeps: int = 1000,
    max_step: float = np.deg2rad(10.0),
    stiffness: bool = False,
    cones: np.ndarray | None = None,
) -> IKResult:
    """CCD from the FK pose ``qpos: (nq,)`` (``δ = 0``) toward ``goal: (3,)`` metres.

    ``stiffness``: scale each turn by the coordinate's weight relative to the largest (§1.10);
    off by default, as in the seed's solver (§2.2.1 relies on CCD's own lower-joint bias) — with
    the clip's weights the spine turns so little per visit that CCD needs thousands of sweeps.
    ``cones``: ``(Jc,)`` this frame's cone limits (``Chain.cones``; default: each joint's ``max_angle``).
    """
    chain = kin.chain
    delta = [0.0] * chain.n_dof
    w = chain.weights
    scale = (w / w.max() if stiffness and w.size and w.max() > 0 else np.ones(chain.n_dof)).tolist()
    kin.set_frame(qpos)
    starts = np.cumsum([0] + [j.dof for j in chain.joints])
    bodies = kin.compiled.body_ids[chain.joint_indices]
    sweep = 0
    lower, upper = np.asarray(lower, dtype=float).tolist(), np.asarray(upper, dtype=float).tolist()
    limit = np.array([j.max_angle for j in chain.joints]) if cones is None else np.asarray(cones, dtype=float)
    coned = {ci for ci, j in enumerate(chain.joints) if j.dof and np.isfinite(limit[ci])}
    for sweep in range(max_sweeps + 1):
        kin.set_delta(np.asarray(delta))
        e = kin.effector().copy()
        if np.linalg.norm(goal - e) < tol or sweep == max_sweeps or chain.n_dof == 0:
            break
        # World axes of every coordinate, valid for the whole backward sweep (see module doc).
        omega = factor_rates(kin.axes, kin.c_fk + chain.padded(np.asarray(delta)))
        frames = kin.data.xmat[bodies].reshape(-1, 3, 3)
        pivots = kin.data.xpos[bodies].copy()
        world = np.einsum("jab,jib->jia", frames, omega)
        ex, ey, ez = (float(x) for x in e)
        gx, gy, gz = (float(x) for x in goal)
        for ci in range(len(chain.joints) - 1, -1, -1):
            px, py, pz = (float(x) for x in pivots[ci])
            for k in range(chain.joints[ci].dof - 1, -1, -1):
                i = starts[ci] + k
                ax, ay, az = (float(x) for x in world[ci, k])
                # Plain-float arithmetic: this loop is the cost of CCD in Python.
                ux, uy, uz = ex - px, ey - py, ez - pz
                vx, vy, vz = gx - px, gy - py, gz - pz
                ua = ux * ax + uy * ay + uz * az
                va = vx * ax + vy * ay + vz * az
                upx, upy, upz = ux - ua * ax, uy - ua * ay, uz - ua * az
                vpx, vpy, vpz = vx - va * ax, vy - va * ay, vz - va * az
                if upx * upx + upy * upy + upz * upz < 1e-18 or vpx * vpx + vpy * vpy + vpz * vpz < 1e-18:
                    continue
                cx, cy, cz = upy * vpz - upz * vpy, upz * vpx - upx * vpz, upx * vpy - upy * vpx
                theta = math.atan2(ax * cx + ay * cy + az * cz, upx * vpx + upy * vpy + upz * vpz) * scale[i]
                theta = min(max(theta, -max_step), max_step)
                new = min(max(delta[i] + theta, lower[i]), upper[i])
                if ci in coned and new != delta[i]:
                    start = kin.c_fk[ci] + chain.padded(np.asarray(delta))[ci]
                    along = np.zeros(3)
                    along[k] = new - delta[i]
                    new = delta[i] + cone_step(kin.q_ref[ci], kin.axes[ci], start, along, float(limit[ci])) * (new - delta[i])
                theta = new - delta[i]
                delta[i] = new
                # Rodrigues: turn the effector about the axis through the pivot.
                c, s_ = math.cos(theta), math.sin(theta)
                wx, wy, wz = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
                ex = px + ux * c + wx * s_ + ax * ua * (1 - c)
                ey = py + uy * c + wy * s_ + ay * ua * (1 - c)
                ez = pz + uz * c + wz * s_ + az * ua * (1 - c)
    d = np.asarray(delta)
    return IKResult(d, float(np.linalg.norm(goal - kin.effector())), 0.0, sweep)
