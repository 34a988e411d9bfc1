"""Damped least squares IK with MuJoCo Jacobians (seed 003 §1.7.2, weighted as in §1.10).

Each iteration takes the Meredith & Maddock weighted, damped step
``Δδ = W Jᵀ (J W Jᵀ + λ² I)⁻¹ e`` (``W`` the stiffness weights, ``J`` from ``mujoco.mj_jac``),
capped at ``max_step`` radians, then clips ``δ`` to the limits (exact: the coordinates are the
joints' own limit angles); a coordinate at a limit that the step would push further out gets
weight 0 for that step (the clamping loop), so the others finish the job. A joint with a cone
limit on its rotation angle has the outward part of its step removed when it is on the cone,
and a step that would leave the cone is shortened to it. A step that does not reduce the error is
halved until it does (no divergence near singular poses); none that does, or five iterations
that each gain less than ``STALL`` of the error, end the solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import rotations as rot
from .chains import ChainKinematics, cone_step, perturbation

#: Relative error reduction per iteration under which, three times running, the solve has stalled.
STALL = 1e-4
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
    cones: np.ndarray | None = None,
    max_step: float = 0.3,
    start: np.ndarray | None = None,
) -> IKResult:
    """DLS from the FK pose ``qpos: (nq,)`` (``δ = 0``) to ``goal: (3,)`` metres.

    Args:
        kin: the chain's MuJoCo evaluator.
        lower, upper: ``(n_dof,)`` bounds on ``δ`` for this frame.
        goal_rotation: ``(3, 3)``: also reach this orientation of the chain tip (6-D goal; the
            position is then the tip joint's).
        tol: stop when the error is below this (metres; radians × ``ORIENTATION_SCALE`` for 6-D).
        damping: ``λ`` in metres.
        cones: ``(Jc,)`` this frame's cone limits (``Chain.cones``; default: each joint's ``max_angle``).
        max_step: radians, the largest change of one coordinate in one iteration.
        start: ``(n_dof,)`` the ``δ`` to start from (default 0, the FK pose; a neighbouring frame's
            solution keeps a sequence of solves on one branch). It is clipped to the limits.
    """
    chain = kin.chain
    n = chain.n_dof
    delta = np.zeros(n) if start is None else np.clip(np.asarray(start, dtype=float), lower, upper)
    w0 = chain.weights
    kin.set_frame(qpos)
    six = goal_rotation is not None
    goal_r = np.eye(3) if goal_rotation is None else np.asarray(goal_rotation, dtype=float)  # used only when six
    limit = np.array([j.max_angle for j in chain.joints]) if cones is None else np.asarray(cones, dtype=float)
    coned = [(i, sl) for i, (j, sl) in enumerate(zip(chain.joints, chain.slices)) if j.dof and np.isfinite(limit[i])]

    def error(d: np.ndarray) -> np.ndarray:
        kin.set_delta(d)
        if six:
            p, r = kin.tip_frame()
            return np.concatenate([goal - p, ORIENTATION_SCALE * rotation_error(goal_r, r)])
        return goal - kin.effector()

    e = error(delta)
    it = stalled = 0
    while np.linalg.norm(e) >= tol and it < max_iter and n > 0:
        kin.set_delta(delta)
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
        big = float(np.max(np.abs(step), initial=0.0))
        if big > max_step:
            step *= max_step / big
        if coned:
            step = _cone_project(kin, delta, step, coned, limit)
        e_norm = float(np.linalg.norm(e))
        for _ in range(12):
            new = np.clip(delta + step, lower, upper)
            if coned:
                new = _cone_clip(kin, delta, new, coned, limit)
            e_new = error(new)
            if np.linalg.norm(e_new) < e_norm:
                break
            step *= 0.5
        else:
            break  # no step reduces the error: as close as the limits allow
        gain = e_norm - float(np.linalg.norm(e_new))
        delta, e = new, e_new
        it += 1
        stalled = stalled + 1 if gain < STALL * e_norm else 0
        if stalled >= 5:
            break  # creeping along a limit toward an unreachable goal
    kin.set_delta(delta)
    if six:
        p, r = kin.tip_frame()
        return IKResult(delta, float(np.linalg.norm(goal - p)), float(np.linalg.norm(rotation_error(goal_r, r))), it)
    return IKResult(delta, float(np.linalg.norm(e)), 0.0, it)


def _joint_angles(kin: ChainKinematics, delta: np.ndarray) -> np.ndarray:
    """``(Jc, 3)`` every chain joint's limit angles at ``δ``."""
    return kin.c_fk + kin.chain.padded(delta)


def _cone_clip(kin: ChainKinematics, delta: np.ndarray, new: np.ndarray, coned: list, limit: np.ndarray) -> np.ndarray:
    """``new`` with each coned joint's change from ``delta`` shortened to stay within its cone."""
    a0, a1 = _joint_angles(kin, delta), _joint_angles(kin, new)
    out = new.copy()
    for i, sl in coned:
        s = cone_step(kin.q_ref[i], kin.axes[i], a0[i], a1[i] - a0[i], float(limit[i]))
        out[sl] = delta[sl] + s * (new[sl] - delta[sl])
    return out


def _cone_project(kin: ChainKinematics, delta: np.ndarray, step: np.ndarray, coned: list, limit: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """``step`` with the outward part removed for joints on their cone (so they slide along it)."""
    a = _joint_angles(kin, delta)
    out = step.copy()
    for i, sl in coned:
        dof = kin.chain.joints[i].dof

        def cos_half(x: np.ndarray, i: int = i) -> float:
            q = rot.multiply(kin.q_ref[i], perturbation(kin.axes[i][None], x[None])[0])
            return float(abs(q[0]))

        c0 = cos_half(a[i])
        if 2.0 * np.arccos(min(c0, 1.0)) < float(limit[i]) - 1e-9:
            continue
        grad = np.array([(cos_half(a[i] + h * np.eye(3)[k]) - c0) / h for k in range(dof)])  # inward = increasing cos
        g2 = float(grad @ grad)
        if g2 > 0 and float(grad @ out[sl]) < 0:
            out[sl] = out[sl] - (grad @ out[sl]) / g2 * grad
    return out
