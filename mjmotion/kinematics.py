"""Forward kinematics and Jacobians through MuJoCo (``mj_kinematics``, ``mj_jacSite``).

MuJoCo is the one source of forward kinematics at run time; the tests check it against an
independent NumPy implementation.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from .errors import MjmotionError
from .mjcf import CompiledModel, compile
from .skeleton import Motion


@dataclass(frozen=True, eq=False)
class Pose:
    """World-frame kinematics of a clip.

    Attributes:
        joint_positions: ``(T, J, 3)`` metres.
        joint_rotations: ``(T, J, 4)`` wxyz, each joint's world orientation.
        site_positions: ``(T, S, 3)`` metres, for ``site_names``.
        site_rotations: ``(T, S, 3, 3)`` site frames (columns are the site's axes).
        site_names: ``(S,)``.
    """

    joint_positions: np.ndarray
    joint_rotations: np.ndarray
    site_positions: np.ndarray
    site_rotations: np.ndarray
    site_names: tuple[str, ...]

    def site(self, name: str) -> np.ndarray:
        """``(T, 3)`` world positions of the site ``name``."""
        try:
            return self.site_positions[:, self.site_names.index(name)]
        except ValueError:
            raise MjmotionError(f"no site named {name!r}") from None


def qpos(compiled: CompiledModel, motion: Motion, ball_position: np.ndarray | None = None) -> np.ndarray:
    """``(T, nq)`` MuJoCo positions of ``motion`` on ``compiled`` (its skeleton topology).

    The ball, if the model has one, rests at ``ball_position`` (default: where it was compiled).
    """
    skel = compiled.skeleton
    if not skel.same_topology(motion.skeleton):
        motion.skeleton.require_same_topology(skel, "the motion and the model")
    t = motion.n_frames
    q = np.zeros((t, compiled.model.nq))
    q[:] = compiled.model.qpos0
    q[:, 0:3] = motion.root_positions
    for j in range(skel.n_joints):
        a = compiled.qpos_adr[j]
        q[:, a : a + 4] = motion.rotations[:, j]
    if motion.translations is not None:
        for j in np.flatnonzero(compiled.slide_adr >= 0).tolist():
            a = int(compiled.slide_adr[j])
            q[:, a : a + 3] = motion.translations[:, j] - skel.offsets[j]
    if compiled.ball is not None:
        a = compiled.ball_qpos_adr
        pos = compiled.ball.position if ball_position is None else ball_position
        q[:, a : a + 3] = pos
        q[:, a + 3 : a + 7] = (1.0, 0.0, 0.0, 0.0)
    return q


def forward(compiled: CompiledModel, motion_or_qpos: Motion | np.ndarray) -> Pose:
    """Batch forward kinematics: one ``mj_kinematics`` per frame.

    ``motion_or_qpos``: a :class:`Motion` or ``(T, nq)``.
    """
    q = qpos(compiled, motion_or_qpos) if isinstance(motion_or_qpos, Motion) else np.atleast_2d(motion_or_qpos)
    m = compiled.model
    d = mujoco.MjData(m)
    t = q.shape[0]
    xpos = np.empty((t, m.nbody, 3))
    xquat = np.empty((t, m.nbody, 4))
    spos = np.empty((t, m.nsite, 3))
    smat = np.empty((t, m.nsite, 9))
    # MjData's arrays are views of its buffers: taken once, not per frame (attribute access is ~1 µs each).
    d_qpos, d_xpos, d_xquat, d_spos, d_smat = d.qpos, d.xpos, d.xquat, d.site_xpos, d.site_xmat
    for i in range(t):
        d_qpos[:] = q[i]
        mujoco.mj_kinematics(m, d)
        xpos[i] = d_xpos
        xquat[i] = d_xquat
        spos[i] = d_spos
        smat[i] = d_smat
    names = tuple(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, s) or f"site{s}" for s in range(m.nsite))
    ids = compiled.body_ids
    return Pose(
        joint_positions=xpos[:, ids],
        joint_rotations=xquat[:, ids],
        site_positions=spos,
        site_rotations=smat.reshape(t, m.nsite, 3, 3),
        site_names=names,
    )


def joint_positions(motion: Motion) -> np.ndarray:
    """``(T, J, 3)`` world joint positions of ``motion`` (compiles its skeleton without props)."""
    return forward(compile(motion.skeleton), motion).joint_positions


def site_jacobian(compiled: CompiledModel, q: np.ndarray, site: str | int) -> tuple[np.ndarray, np.ndarray]:
    """Translational and rotational Jacobians ``(3, nv)`` of a site at configuration ``q: (nq,)``."""
    m = compiled.model
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    sid = compiled.site_id(site) if isinstance(site, str) else int(site)
    jacp = np.zeros((3, m.nv))
    jacr = np.zeros((3, m.nv))
    mujoco.mj_jacSite(m, d, jacp, jacr, sid)
    return jacp, jacr
