"""Cyclic coordinate descent (seed 003 §1.7.1, the seed's own choice in §2.2.1).

Sweeps from the chain's last coordinate up to its first; each coordinate turns its joint about
the coordinate's world axis by the angle that brings the effector closest to the goal (the
exact minimiser along that circle), scaled by the coordinate's stiffness weight relative to the
chain's largest (§1.10: stiffness in CCD as a limit on how far a joint turns per visit), capped
at ``max_step`` and clipped to the limits. Position goals only, as in the seed.
"""

from __future__ import annotations

import numpy as np

from .. import rotations as rot
from .chains import ChainKinematics, factor_rates
from .dls import IKResult


def solve(
    kin: ChainKinematics,
    qpos: np.ndarray,
    goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    tol: float = 1e-5,
    max_sweeps: int = 300,
    max_step: float = np.deg2rad(10.0),
) -> IKResult:
    """CCD from the FK pose ``qpos: (nq,)`` (``δ = 0``) toward ``goal: (3,)`` metres."""
    chain = kin.chain
    delta = np.zeros(chain.n_dof)
    w = chain.weights
    scale = w / w.max() if w.size and w.max() > 0 else w
    kin.set_frame(qpos)
    starts = np.cumsum([0] + [j.dof for j in chain.joints])
    bodies = kin.compiled.body_ids[chain.joint_indices]
    sweep = 0
    for sweep in range(max_sweeps + 1):
        kin.set_delta(delta)
        e = kin.effector().copy()
        if np.linalg.norm(goal - e) < tol or sweep == max_sweeps or chain.n_dof == 0:
            break
        # World axes of every coordinate, valid for the whole backward sweep (see module doc).
        omega = factor_rates(kin.axes, chain.padded(delta))
        frames = kin.data.xmat[bodies].reshape(-1, 3, 3)
        pivots = kin.data.xpos[bodies].copy()
        world = np.einsum("jab,jib->jia", frames, omega)
        for ci in range(len(chain.joints) - 1, -1, -1):
            p = pivots[ci]
            for k in range(chain.joints[ci].dof - 1, -1, -1):
                i = starts[ci] + k
                a = world[ci, k]
                u = e - p
                v = goal - p
                u_p = u - np.dot(u, a) * a
                v_p = v - np.dot(v, a) * a
                if np.linalg.norm(u_p) < 1e-9 or np.linalg.norm(v_p) < 1e-9:
                    continue
                theta = np.arctan2(np.dot(a, np.cross(u_p, v_p)), np.dot(u_p, v_p)) * scale[i]
                theta = float(np.clip(theta, -max_step, max_step))
                new = float(np.clip(delta[i] + theta, lower[i], upper[i]))
                theta = new - delta[i]
                delta[i] = new
                e = p + rot.rotate(rot.exp(a * theta), u)
    return IKResult(delta, float(np.linalg.norm(goal - kin.effector())), 0.0, sweep)
