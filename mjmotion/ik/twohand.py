"""Per-frame IK of a shot held in one or two hands (seed 003 §2.2.2).

Each frame: the lead chain takes its effector to the goal (``nlp``, ``dls`` or ``ccd``), then the
second hand, if there is one, goes back to its source placement relative to the first hand's new
frame (6-D IK on its arm: IPOPT, or DLS). A frame's :class:`FrameSolution` also says how low the
effector (a club: its shaft, radius included) went, so a caller can keep it off the floor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mjcf import CompiledModel
from . import ccd, dls
from .chains import Chain, ChainKinematics

SOLVERS = ("nlp", "dls", "ccd")
#: Second-hand error (metres) above which a per-frame NLP result is retried with DLS.
GRIP_TOLERANCE = 1e-5


@dataclass(frozen=True)
class FrameSolution:
    """One frame's IK.

    Attributes:
        lead, second: ``(n_dof,)`` coordinates ``δ`` of the lead and the second chain.
        error: metres from the effector to its goal.
        grip_error: metres from the second hand to its placement (0 without a second hand).
        lowest: world height (m) of the effector's lowest point (:class:`TwoHandIK` ``points``).
    """

    lead: np.ndarray
    second: np.ndarray
    error: float
    grip_error: float
    lowest: float


class TwoHandIK:
    """The per-frame solve of a lead chain and an optional second hand on the same model.

    Args:
        compiled: the model (with the prop, if any).
        lead, second: the chains (``second`` may be ``None``).
        qpos: ``(T, nq)`` the source's FK poses.
        lead_bounds, second_bounds: ``(lower, upper)`` per-frame ``(T, n_dof)`` bounds (``Chain.bounds``).
        lead_cones, second_cones: ``(T, Jc)`` per-frame cone limits (``Chain.cones``).
        second_relative: ``(T, 4, 4)`` the second tip's source pose in the lead tip's frame.
        solver: ``nlp``, ``dls`` or ``ccd`` (the second hand: IPOPT with ``nlp``, else DLS).
        points: ``(P, 3)`` points in the lead tip's frame whose lowest height is reported, less ``radius``.
    """

    def __init__(
        self,
        compiled: CompiledModel,
        lead: Chain,
        second: Chain | None,
        qpos: np.ndarray,
        lead_bounds: tuple[np.ndarray, np.ndarray],
        second_bounds: tuple[np.ndarray, np.ndarray] | None,
        lead_cones: np.ndarray,
        second_cones: np.ndarray | None,
        second_relative: np.ndarray | None,
        solver: str,
        points: np.ndarray,
        radius: float = 0.0,
    ):
        self.compiled, self.lead, self.second, self.qpos, self.solver = compiled, lead, second, qpos, solver
        self.lo1, self.hi1 = lead_bounds
        self.cones1, self.cones2 = lead_cones, second_cones
        self.rel = second_relative
        self.points, self.radius = np.asarray(points, dtype=float).reshape(-1, 3), float(radius)
        self.kin1 = ChainKinematics(compiled, lead)
        self.fs1 = self.fs2 = None
        if second is not None:
            assert second_bounds is not None and second_cones is not None and second_relative is not None
            self.lo2, self.hi2 = second_bounds
            self.kin2 = ChainKinematics(compiled, second)
        if solver == "nlp":
            from .nlp import FrameSolver

            self.fs1 = FrameSolver(compiled, lead)
            self.fs2 = FrameSolver(compiled, second, six=True) if second is not None else None

    def solve(self, t: int, goal: np.ndarray) -> FrameSolution:
        """Solve frame ``t`` for the effector goal ``goal (3,)`` (metres, world)."""
        q = self.qpos[t]
        kin1 = self.kin1
        if self.solver == "nlp":
            kin1.set_frame(q)
            kin1.set_delta(np.zeros(self.lead.n_dof))
            r = self.fs1.solve(q, kin1.data.xpos, kin1.data.xmat, goal, self.lo1[t], self.hi1[t], cones=self.cones1[t])  # type: ignore[union-attr]
        elif self.solver == "dls":
            r = dls.solve(kin1, q, goal, self.lo1[t], self.hi1[t], cones=self.cones1[t])
        else:
            r = ccd.solve(kin1, q, goal, self.lo1[t], self.hi1[t], cones=self.cones1[t])
        return self.hold(t, r.delta, r.error)

    def hold(
        self, t: int, lead_delta: np.ndarray, error: float = float("nan"), dls_only: bool = False, start: np.ndarray | None = None
    ) -> FrameSolution:
        """Frame ``t`` with the lead chain at ``lead_delta``: the second hand put back on the grip.

        ``error``: the lead's goal error, passed through to the solution. ``dls_only``: the second
        hand by DLS whatever the solver (it moves continuously with the lead, where IPOPT may
        land on another of two nearly equal solutions from one frame to the next); ``start``: the
        second chain's ``δ`` DLS starts from (a neighbouring frame's, to stay on its branch).
        """
        q = self.qpos[t]
        kin1 = self.kin1
        kin1.set_frame(q)
        kin1.set_delta(lead_delta)
        p, rm = kin1.tip_frame()
        lowest = float(np.min(p[2] + self.points @ rm[2])) - self.radius
        if self.second is None:
            return FrameSolution(lead_delta, np.zeros(0), error, 0.0, lowest)
        # §2.2.2: the second hand returns to its source placement relative to the (new) first hand.
        lead_new = np.eye(4)
        lead_new[:3, :3], lead_new[:3, 3] = rm, p
        want = lead_new @ self.rel[t]  # type: ignore[index]
        q2 = kin1.data.qpos.copy()
        lo2, hi2, c2 = self.lo2[t], self.hi2[t], self.cones2[t]  # type: ignore[index]
        if self.solver == "nlp" and not dls_only:
            r2 = self.fs2.solve(q, kin1.data.xpos, kin1.data.xmat, want[:3, 3], lo2, hi2, goal_rotation=want[:3, :3], cones=c2)  # type: ignore[union-attr]
            if r2.error > GRIP_TOLERANCE:
                # IPOPT gave up on the equality (a local infeasibility near a limit): DLS may still get there.
                r3 = dls.solve(self.kin2, q2, want[:3, 3], lo2, hi2, goal_rotation=want[:3, :3], cones=c2)
                r2 = r3 if r3.error < r2.error else r2
        else:
            r2 = dls.solve(self.kin2, q2, want[:3, 3], lo2, hi2, goal_rotation=want[:3, :3], cones=c2, start=start)
        return FrameSolution(lead_delta, r2.delta, error, r2.error, lowest)
