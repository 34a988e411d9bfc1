"""The main IK: a CasADi nonlinear program solved by IPOPT (beyond seed 003: §1.10 made exact).

Per frame: minimise the stiffness-weighted deviation from the FK pose, ``Σ δᵢ² / wᵢ`` (Meredith &
Maddock weights: the weighted DLS step is this problem's linearisation), subject to the goal and
the limits; freedoms are the parametrisation itself (:mod:`mjmotion.ik.chains`). Over the whole
shot: the same deviation cost over every frame of the active window, plus a smoothness term on
the coordinates' second differences (joint accelerations), with the effector goal *and* the
second hand's pose relative to the first as constraints of one problem.

The chain's forward kinematics is written symbolically (:class:`SymbolicFK`) and checked against
MuJoCo in the tests. An unreachable goal is solved best-effort: when IPOPT finds the equality
infeasible, the goal becomes a heavy penalty instead and the result says how far it got.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import casadi as ca
import mujoco
import numpy as np
import scipy.sparse as sp

from .. import rotations as rot
from ..errors import MjmotionError
from ..mjcf import CompiledModel
from .chains import Chain, _coords
from .dls import ORIENTATION_SCALE, IKResult, rotation_error


@contextlib.contextmanager
def _keeping_interrupts() -> Iterator[None]:
    """Ctrl-C during an IPOPT solve, raised once the solve returns. CasADi catches the KeyboardInterrupt
    that Python raises inside IPOPT's callback, ends that solve (``NonIpopt_Exception_Thrown``) and
    returns: the interrupt was lost, and ``hit --solver nlp-shot`` ran on for 20 s and wrote its
    result. Only where Python's own handler is in place (a Dask worker ignores SIGINT; threads
    cannot set handlers)."""
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield
        return
    seen: list[int] = []

    def note(signum: int, frame: Any) -> None:
        seen.append(signum)
        previous(signum, frame)  # (Python's default raises KeyboardInterrupt, which CasADi swallows)

    signal.signal(signal.SIGINT, note)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if seen:
        raise KeyboardInterrupt


def _solve(solver: ca.Function, **args: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """``solver(**args)`` and its stats, a Ctrl-C during it raised (:func:`_keeping_interrupts`)."""
    with _keeping_interrupts():
        sol = solver(**args)
    return sol, solver.stats()


#: Penalty weight of the goal when it cannot be met exactly (per m²).
SOFT_WEIGHT = 1e6
#: IPOPT's options (the value types casadi's ``nlpsol`` takes).
_IPOPT: dict[str, bool | int | float | str | ca.Function] = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    "ipopt.tol": 1e-10,
    "ipopt.constr_viol_tol": 1e-9,
    "ipopt.max_iter": 200,
}


def _axis_matrix(axis: int, a: ca.SX) -> ca.SX:
    c, s = ca.cos(a), ca.sin(a)
    if axis == 0:
        return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))
    if axis == 1:
        return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


class SymbolicFK:
    """Forward kinematics of one or more disjoint chains as a CasADi expression.

    Joint ``j`` of a chain (:mod:`mjmotion.ik.chains`): its local rotation is
    ``L_j = M_j · R₁(c₁ + δ₁) ⋯ R_k(c_k + δ_k) · N_j`` over its ``k`` free angles, with
    ``M_j = R(q_ref) B`` and ``N_j`` the fixed angles' factors times ``Bᵀ`` (a locked joint:
    ``M_j = R_fk B``, ``N_j = Bᵀ``); ``R_j = R_parent · L_j`` and ``x_j = x_parent + R_parent t_j``.
    The numbers that change per frame — each joint's ``M``, ``N``, free angles ``c`` and local
    translation ``t``, and the world frame of every joint whose parent is not in the chains (a
    *base*) — form the parameter vector from :meth:`params`.

    Outputs of :attr:`function` ``(δ, p)``: for each chain, its tip position ``(3,)``, tip rotation
    ``(9,)`` column-major, and (if it has one) its effector position ``(3,)``. :attr:`traces` are
    the traces of the joints' local rotation matrices (``1 + 2 cos θ``, θ the rotation angle), for
    cone limits.
    """

    #: Parameters per chain joint: M (9), N (9), free angles c (3), translation t (3).
    PER_JOINT = 24

    def __init__(self, compiled: CompiledModel, chains: list[Chain]):
        self.compiled = compiled
        self.chains = chains
        self.joints = [cj for c in chains for cj in c.joints]
        self.index = {cj.joint: i for i, cj in enumerate(self.joints)}
        if len(self.index) != len(self.joints):
            raise MjmotionError("chains solved together must not share joints")
        skel = compiled.skeleton
        self.bases = sorted({int(skel.parents[cj.joint]) for cj in self.joints if int(skel.parents[cj.joint]) not in self.index})
        self.n_dof = sum(c.n_dof for c in chains)
        k = self.PER_JOINT
        self.n_params = k * len(self.joints) + 12 * len(self.bases)
        delta = ca.SX.sym("delta", self.n_dof)
        p = ca.SX.sym("p", self.n_params)
        frames: dict[int, tuple[ca.SX, ca.SX]] = {}
        off = k * len(self.joints)
        for b_i, b in enumerate(self.bases):
            x = p[off + 12 * b_i : off + 12 * b_i + 3]
            r = ca.reshape(p[off + 12 * b_i + 3 : off + 12 * b_i + 12], 3, 3)
            frames[b] = (x, r)
        a = 0
        traces = []
        for i, cj in enumerate(self.joints):
            px, pr = frames[int(skel.parents[cj.joint])]
            base = k * i
            m = ca.reshape(p[base : base + 9], 3, 3)
            n = ca.reshape(p[base + 9 : base + 18], 3, 3)
            c = p[base + 18 : base + 21]
            t = p[base + 21 : base + 24]
            e = m
            for f in range(cj.dof):
                e = e @ _axis_matrix(f, c[f] + delta[a + f])
            a += cj.dof
            local = e @ n
            traces.append(ca.trace(local))
            frames[cj.joint] = (px + pr @ t, pr @ local)
        outs = []
        for ch in chains:
            x, r = frames[ch.tip]
            outs += [x, ca.reshape(r, 9, 1)]
            if ch.effector is not None:
                outs.append(x + r @ ca.DM(np.asarray(ch.effector.offset, dtype=float)))
        self.delta, self.p = delta, p
        self.outputs = outs
        self.traces = traces
        self.function = ca.Function("chain_fk", [delta, p], outs)

    def params(self, qpos_fk: np.ndarray, xpos: np.ndarray, xmat: np.ndarray) -> np.ndarray:
        """Parameter vector ``(n_params,)``: joints' FK rotations from ``qpos_fk (nq,)``, base frames
        from MuJoCo's ``xpos (nbody, 3)`` and ``xmat (nbody, 9)`` of the current state."""
        c = self.compiled
        skel = c.skeleton
        k = self.PER_JOINT
        out = np.empty(self.n_params)
        for i, cj in enumerate(self.joints):
            a = c.qpos_adr[cj.joint]
            q = qpos_fk[a : a + 4]
            t = skel.offsets[cj.joint].copy()
            if c.slide_adr[cj.joint] >= 0:
                s = c.slide_adr[cj.joint]
                t = t + qpos_fk[s : s + 3]
            free = np.zeros(3)
            if cj.dof:
                angles = _coords(cj.basis, cj.q_ref, q[None])[0]
                m = rot.to_matrix(cj.q_ref) @ cj.basis
                n = np.eye(3)
                for f in range(cj.dof, 3):
                    n = n @ _axis(f, angles[f])
                n = n @ cj.basis.T
                free[: cj.dof] = angles[: cj.dof]
            else:
                m, n = rot.to_matrix(q) @ cj.basis, cj.basis.T
            out[k * i : k * i + 9] = m.ravel(order="F")
            out[k * i + 9 : k * i + 18] = n.ravel(order="F")
            out[k * i + 18 : k * i + 21] = free
            out[k * i + 21 : k * i + 24] = t
        off = k * len(self.joints)
        for b_i, b in enumerate(self.bases):
            body = c.body_ids[b]
            out[off + 12 * b_i : off + 12 * b_i + 3] = xpos[body]
            out[off + 12 * b_i + 3 : off + 12 * b_i + 12] = xmat[body].reshape(3, 3).ravel(order="F")
        return out

    def cone_rows(self) -> np.ndarray:
        """Indices (into :attr:`joints`) of the joints with a cone limit that can move."""
        return np.array([i for i, cj in enumerate(self.joints) if cj.dof and np.isfinite(cj.max_angle)], dtype=int)


def _axis(f: int, angle: float) -> np.ndarray:
    """``(3, 3)`` rotation by ``angle`` about coordinate axis ``f``."""
    c, s = np.cos(angle), np.sin(angle)
    if f == 0:
        return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])
    if f == 1:
        return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def trace_bounds(cones: np.ndarray) -> np.ndarray:
    """Lower bounds on local-rotation traces for cone limits ``cones`` (radians): ``1 + 2 cos θ``."""
    return 1.0 + 2.0 * np.cos(np.minimum(np.asarray(cones, dtype=float), np.pi))


def _cost(chain_weights: np.ndarray, delta: ca.SX) -> ca.SX:
    return ca.sumsqr(delta / ca.DM(np.sqrt(chain_weights)))


def _orientation_residual(r: ca.SX, goal: ca.SX) -> ca.SX:
    """``vee(skew(goalᵀ R))``: 3 equations, zero when ``R = goal`` (and smooth near it)."""
    m = goal.T @ r
    return ca.vertcat(m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]) * 0.5


class FrameSolver:
    """Per-frame IK of one chain by IPOPT: a position goal for its effector, or a 6-D goal for its tip.

    Build once per chain (symbolic set-up and solver creation take a fraction of a second), then
    call :meth:`solve` per frame. The box bounds on ``δ`` are the chain's exact limits; joints with
    a cone limit get one inequality each on the trace of their local rotation.
    """

    def __init__(self, compiled: CompiledModel, chain: Chain, six: bool = False):
        if not six and chain.effector is None:
            raise MjmotionError("a position goal needs a chain with an effector")
        self.chain = chain
        self.six = six
        self.fk = SymbolicFK(compiled, [chain])
        d, p = self.fk.delta, self.fk.p
        g = ca.SX.sym("goal", 12 if six else 3)
        pars = ca.vertcat(p, g)
        cost = _cost(np.maximum(chain.weights, 1e-9), d)
        if six:
            x, r = self.fk.outputs[0], ca.reshape(self.fk.outputs[1], 3, 3)
            res = ca.vertcat(x - g[:3], ORIENTATION_SCALE * _orientation_residual(r, ca.reshape(g[3:], 3, 3)))
        else:
            res = self.fk.outputs[-1] - g
        self.cone_rows = self.fk.cone_rows()
        cone = ca.vertcat(*[self.fk.traces[i] for i in self.cone_rows]) if len(self.cone_rows) else ca.SX(0, 1)
        self.hard = ca.nlpsol("ik_hard", "ipopt", {"x": d, "p": pars, "f": cost, "g": ca.vertcat(res, cone)}, _IPOPT)
        self._soft_nlp = {"x": d, "p": pars, "f": cost + SOFT_WEIGHT * ca.sumsqr(res), "g": cone}
        self._soft: ca.Function | None = None
        self.n_res = res.shape[0]
        self.data = mujoco.MjData(compiled.model)
        self.model = compiled.model

    @property
    def soft(self) -> ca.Function:
        """The best-effort problem (goal as a penalty), built only when the hard one fails."""
        if self._soft is None:
            self._soft = ca.nlpsol("ik_soft", "ipopt", self._soft_nlp, _IPOPT)
        return self._soft

    def solve(
        self,
        qpos_fk: np.ndarray,
        xpos: np.ndarray,
        xmat: np.ndarray,
        goal: np.ndarray,
        lower: np.ndarray,
        upper: np.ndarray,
        goal_rotation: np.ndarray | None = None,
        cones: np.ndarray | None = None,
    ) -> IKResult:
        """Solve one frame from ``δ = 0``.

        Args:
            qpos_fk: ``(nq,)`` the frame's FK pose (the chain joints' rotations are read here).
            xpos, xmat: MuJoCo body frames of the current state (for the chain's base).
            goal: ``(3,)`` metres; ``goal_rotation`` ``(3, 3)`` for a 6-D solver.
            lower, upper: ``(n_dof,)`` bounds on ``δ``.
            cones: ``(Jc,)`` this frame's cone limits (``Chain.cones``; default: each joint's
                ``max_angle``).
        """
        p = self.fk.params(qpos_fk, xpos, xmat)
        g = np.asarray(goal, dtype=float)
        goal_r = np.eye(3)  # used only when six
        if self.six:
            if goal_rotation is None:
                raise MjmotionError("a 6-D solver needs goal_rotation")
            goal_r = np.asarray(goal_rotation, dtype=float)
            g = np.concatenate([g, goal_r.ravel(order="F")])
        pars = np.concatenate([p, g])
        x0 = np.zeros(self.chain.n_dof)
        limit = np.array([j.max_angle for j in self.chain.joints]) if cones is None else np.asarray(cones, dtype=float)
        lo_cone = trace_bounds(limit[self.cone_rows])
        inf = np.full(len(self.cone_rows), np.inf)
        zeros = np.zeros(self.n_res)
        # More goal equations than free coordinates: IPOPT refuses (CasADi warns on every frame), the best effort it is.
        hard = np.count_nonzero(np.asarray(upper) > np.asarray(lower)) >= self.n_res
        if hard:
            sol, stats = _solve(
                self.hard, x0=x0, p=pars, lbx=lower, ubx=upper, lbg=np.concatenate([zeros, lo_cone]), ubg=np.concatenate([zeros, inf])
            )
        if not hard or not stats["success"]:
            sol, stats = _solve(self.soft, x0=x0, p=pars, lbx=lower, ubx=upper, lbg=lo_cone, ubg=inf)
        delta = np.clip(np.asarray(sol["x"]).ravel(), lower, upper)
        out = self.fk.function(delta, p)
        if self.six:
            x, r = np.asarray(out[0]).ravel(), np.asarray(out[1]).reshape(3, 3, order="F")
            return IKResult(delta, float(np.linalg.norm(x - goal)), float(np.linalg.norm(rotation_error(goal_r, r))), int(stats["iter_count"]))
        e = np.asarray(out[-1]).ravel()
        return IKResult(delta, float(np.linalg.norm(e - goal)), 0.0, int(stats["iter_count"]))


@dataclass(frozen=True)
class ShotResult:
    """Whole-shot solution over a window of frames.

    Attributes:
        lead: ``(N, n_lead)`` coordinates of the lead chain per window frame.
        second: ``(N, n_second)`` of the second chain (empty columns without one).
        goal_error: ``(N,)`` metres, effector distance to its goal.
        grip_error: ``(N,)`` metres, second tip's distance to its goal (0 without one).
        success: IPOPT's verdict on the hard-constrained problem.
        iterations: IPOPT iterations.
    """

    lead: np.ndarray
    second: np.ndarray
    goal_error: np.ndarray
    grip_error: np.ndarray
    success: bool
    iterations: int


def _time_hessian(frames: np.ndarray, inv_w: np.ndarray, smoothness: float) -> sp.csc_matrix:
    """Constant Hessian ``(N·nd, N·nd)`` of the whole-shot cost over the solved ``frames (N,)``.

    Cost ``Σₜ δₜᵀW⁻¹δₜ + smoothness · Σₜ aₜᵀW⁻¹aₜ`` with ``aₜ = δₜ₋₁ − 2δₜ + δₜ₊₁``, a neighbour that
    is not solved counting as ``δ = 0`` (the source pose). Variables are frame-major.
    """
    n = len(frames)
    pos = {int(f): i for i, f in enumerate(frames)}
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    for i, f in enumerate(frames):
        rows.append(i)
        cols.append(i)
        vals.append(-2.0)
        for nb in (int(f) - 1, int(f) + 1):
            if nb in pos:
                rows.append(i)
                cols.append(pos[nb])
                vals.append(1.0)
    d = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    t = sp.identity(n) + smoothness * (d.T @ d)
    return (2.0 * sp.kron(t, sp.diags(inv_w))).tocsc()


def _dm(m: sp.csc_matrix) -> ca.DM:
    m = m.tocsc()
    m.sort_indices()
    return ca.DM(ca.Sparsity(m.shape[0], m.shape[1], m.indptr.tolist(), m.indices.tolist()), m.data.tolist())


class ShotSolver:
    """Whole-shot IK: the solved frames of a shot in one IPOPT problem, with both hands as constraints.

    Variables: ``δ`` of the lead chain and of the second chain at each of ``N`` frames. Cost:
    ``Σₜ Σᵢ δᵢ,ₜ²/wᵢ + smoothness · Σₜ Σᵢ (δᵢ,ₜ₋₁ − 2δᵢ,ₜ + δᵢ,ₜ₊₁)²/wᵢ``, a frame outside the
    solved set counting as ``δ = 0`` (the FK pose). Constraints per frame: the effector at its goal
    and the second chain's tip at its source pose relative to the lead chain's tip (position and
    orientation). The Hessian of the Lagrangian is given to IPOPT by structure — the cost's constant
    banded part plus one small symbolic block per frame — instead of being differentiated through
    the whole problem (20× faster to build and to evaluate).
    """

    def __init__(self, compiled: CompiledModel, lead: Chain, second: Chain | None, frames: np.ndarray, smoothness: float = 100.0):
        chains = [lead] + ([second] if second is not None else [])
        self.fk = SymbolicFK(compiled, chains)
        frames = np.asarray(frames, dtype=int)
        n_frames = len(frames)
        self.lead, self.second, self.n = lead, second, n_frames
        n1 = lead.n_dof
        n2 = second.n_dof if second is not None else 0
        nd = n1 + n2
        n_goal = 3 + (12 if second is not None else 0)
        f = self.fk.function
        ds, ps, gs = ca.SX.sym("d", nd), ca.SX.sym("p", self.fk.n_params), ca.SX.sym("g", n_goal)
        outs = f(ds, ps)
        res = [outs[2] - gs[:3]]
        if second is not None:
            # The second tip's goal is its source pose relative to the lead tip, composed with the new lead tip.
            x1, r1 = outs[0], ca.reshape(outs[1], 3, 3)
            x2, r2 = outs[3], ca.reshape(outs[4], 3, 3)
            res += [x2 - (x1 + r1 @ gs[3:6]), ORIENTATION_SCALE * _orientation_residual(r2, r1 @ ca.reshape(gs[6:15], 3, 3))]
        res_sx = ca.vertcat(*res)
        n_res = res_sx.shape[0]
        # cone limits: the traces of the coned joints' local rotations, from the same parameters
        self.cone_rows = self.fk.cone_rows()
        trace_fn = ca.Function(
            "traces", [self.fk.delta, self.fk.p], [ca.vertcat(*[self.fk.traces[i] for i in self.cone_rows])] if len(self.cone_rows) else [ca.SX(0, 1)]
        )
        cone_sx = trace_fn(ds, ps)
        n_cone = len(self.cone_rows)
        lam = ca.SX.sym("lam", n_res + n_cone)
        frame_res = ca.Function("frame_res", [ds, ps, gs], [ca.vertcat(res_sx, cone_sx)])
        lagr = ca.dot(lam, ca.vertcat(res_sx, cone_sx))
        frame_hess = ca.Function("frame_hess", [ds, ps, gs, lam], [ca.densify(ca.hessian(lagr, ds)[0])])
        w = np.concatenate([lead.weights] + ([second.weights] if second is not None else []))
        q = _dm(_time_hessian(frames, 1.0 / np.maximum(w, 1e-9), smoothness))
        x = ca.MX.sym("x", nd * n_frames)
        pars = ca.MX.sym("pars", (self.fk.n_params + n_goal) * n_frames)
        p = ca.reshape(pars[: self.fk.n_params * n_frames], self.fk.n_params, n_frames)
        g = ca.reshape(pars[self.fk.n_params * n_frames :], n_goal, n_frames)
        d = ca.reshape(x, nd, n_frames)
        residuals = ca.vec(frame_res.map(n_frames)(d, p, g))  # per frame: goal residuals, then cone traces
        cost = 0.5 * ca.bilin(q, x, x)
        n_con = n_res + n_cone
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", n_con * n_frames)
        blocks = frame_hess.map(n_frames)(d, p, g, ca.reshape(lam_g, n_con, n_frames))
        hess = lam_f * 0.5 * (q + q.T) + ca.diagcat(*ca.horzsplit(blocks, nd))
        hess_lag = ca.Function("hess_lag", [x, pars, lam_f, lam_g], [ca.triu(hess)], ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
        opts = dict(_IPOPT)
        opts["ipopt.max_iter"] = 300
        opts["hess_lag"] = hess_lag
        self.nd, self.n_goal, self.n_res, self.n_cone = nd, n_goal, n_res, n_cone
        all_con = ca.reshape(residuals, n_con, n_frames)
        goal_res = ca.vec(all_con[:n_res, :])
        cone_g = ca.vec(all_con[n_res:, :])
        self._nlp = {"x": x, "p": pars, "f": cost, "g": residuals}
        self._soft_nlp = {"x": x, "p": pars, "f": cost + SOFT_WEIGHT * ca.sumsqr(goal_res), "g": cone_g}
        self.hard = ca.nlpsol("shot_hard", "ipopt", self._nlp, opts)
        self._soft: ca.Function | None = None
        self.residual = ca.Function("res", [x, pars], [all_con[:n_res, :]])

    @property
    def soft(self) -> ca.Function:
        """The best-effort problem (goal as a penalty), built only when the hard one fails."""
        if self._soft is None:
            opts = dict(_IPOPT)
            opts["ipopt.max_iter"] = 300
            self._soft = ca.nlpsol("shot_soft", "ipopt", self._soft_nlp, opts)
        return self._soft

    def solve(self, params: np.ndarray, goals: np.ndarray, lower: np.ndarray, upper: np.ndarray, cones: np.ndarray | None = None) -> ShotResult:
        """Solve the shot.

        Args:
            params: ``(N, n_params)`` from :meth:`SymbolicFK.params` per frame (base frames of the
                source: the lead chain's base is never moved, and the second chain's base is in it).
            goals: ``(N, 3)`` effector goals, or ``(N, 15)`` adding the second tip's source pose in
                the lead tip's frame: position ``(3,)`` and rotation ``(9,)`` column-major.
            lower, upper: ``(N, nd)`` bounds on ``δ``.
            cones: ``(N, Jc)`` per-frame cone limits of the joints of both chains (``Chain.cones``,
                lead then second; default: each joint's ``max_angle``).
        """
        pars = np.concatenate([params.ravel(), goals.ravel()])
        x0 = np.zeros(self.nd * self.n)
        lbx, ubx = lower.ravel(), upper.ravel()
        limit = np.broadcast_to([j.max_angle for j in self.fk.joints], (self.n, len(self.fk.joints))) if cones is None else np.asarray(cones, float)
        lo_cone = trace_bounds(limit[:, self.cone_rows])  # (N, n_cone)
        lbg = np.hstack([np.zeros((self.n, self.n_res)), lo_cone]).ravel()
        ubg = np.hstack([np.zeros((self.n, self.n_res)), np.full(lo_cone.shape, np.inf)]).ravel()
        ok = bool(np.count_nonzero(ubx > lbx) >= self.n_res * self.n)  # else overconstrained: straight to the best effort
        if ok:
            sol, stats = _solve(self.hard, x0=x0, p=pars, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
            ok = bool(stats["success"])
        if not ok:
            sol, stats = _solve(self.soft, x0=x0, p=pars, lbx=lbx, ubx=ubx, lbg=lo_cone.ravel(), ubg=np.inf)
        xs = np.clip(np.asarray(sol["x"]).ravel(), lbx, ubx)
        res = np.asarray(self.residual(xs, pars))
        d = xs.reshape(self.n, self.nd)
        n1 = self.lead.n_dof
        goal_err = np.linalg.norm(res[:3], axis=0)
        grip_err = np.linalg.norm(res[3:6], axis=0) if self.second is not None else np.zeros(self.n)
        return ShotResult(d[:, :n1], d[:, n1:], goal_err, grip_err, ok, int(stats["iter_count"]))
