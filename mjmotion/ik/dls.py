"""Damped least squares IK with MuJoCo Jacobians (seed 003 §1.7.2, weighted as in §1.10).

Each iteration takes the Meredith & Maddock weighted, damped step
``Δδ = W Jᵀ (J W Jᵀ + λ² I)⁻¹ e`` (``W`` the stiffness weights, ``J`` from ``mujoco.mj_jac``), then
clips ``δ`` to the limits; a coordinate at a limit that the step would push further out gets
weight 0 for that step (the clamping loop), so the others finish the job.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import rotations as rot
from .chains import ChainKinematics

#: Length that makes one radian of orientation error count like this many metres (6-D goals).
ORIENTATION_SCALE = 0.1


@dataclass(frozen=True)
class IKResult:
    """Outcome of one frame's IK.

    Attributes:
        delta: ``(n_dof,)`` the chain coordinates found.
        error: metres from the goal (for 6-D goals: position error; see ``rotation_error``).
        rotation_error: radians (0 for position goals).
        iterations: iterations used.
    """

    delta: np.ndarray
    error: float
    rotation_error: float
    iterations: int


def rotation_error(goal: np.ndarray, current: np.ndarray) -> np.ndarray:
    """World rotation vector ``(3,)`` taking frame ``current (3, 3)`` to ``goal (3, 3)``."""
    return rot.log(rot.from_matrix(goal @ current.T))


def solve(
    kin: ChainKinematics,
    qpos: np.ndarray,
    goal: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    goal_rotation: np.ndarray | None = None,
    tol: float = 1e-5,
    max_iter: int = 100,
    damping: float = 1e-3,
) -> IKResult:
    """DLS from the FK pose ``qpos: (nq,)`` (``δ = 0``) to ``goal: (3,)`` metres.

    Args:
        kin: the chain's MuJoCo evaluator.
        lower, upper: ``(n_dof,)`` bounds on ``δ`` for this frame.
        goal_rotation: ``(3, 3)``: also reach this orientation of the chain tip (6-D goal; the
            position is then the tip joint's).
        tol: stop when the error is below this (metres; radians × ``ORIENTATION_SCALE`` for 6-D).
        damping: ``λ`` in metres.
    """
    chain = kin.chain
    n = chain.n_dof
    delta = np.zeros(n)
    w0 = chain.weights
    kin.set_frame(qpos)
    six = goal_rotation is not None
    it = 0
    while True:
        kin.set_delta(delta)
        if goal_rotation is not None:
            p, r = kin.tip_frame()
            e = np.concatenate([goal - p, ORIENTATION_SCALE * rotation_error(goal_rotation, r)])
        else:
            e = goal - kin.effector()
        if np.linalg.norm(e) < tol or it >= max_iter or n == 0:
            break
        jac = kin.jacobian(rotation=six)
        if six:
            jac[3:] *= ORIENTATION_SCALE
        w = w0.copy()
        for _ in range(4):
            jw = jac * w
            step = w * (jac.T @ np.linalg.solve(jw @ jac.T + damping**2 * np.eye(len(e)), e))
            # Clamping loop: a coordinate at a limit that the step pushes outward sits out this step.
            out = ((delta <= lower + 1e-12) & (step < 0)) | ((delta >= upper - 1e-12) & (step > 0))
            if not np.any(out & (w > 0)):
                break
            w = np.where(out, 0.0, w)
        delta = np.clip(delta + step, lower, upper)
        it += 1
    if goal_rotation is not None:
        p, r = kin.tip_frame()
        return IKResult(delta, float(np.linalg.norm(goal - p)), float(np.linalg.norm(rotation_error(goal_rotation, r))), it)
    return IKResult(delta, float(np.linalg.norm(e)), 0.0, it)
