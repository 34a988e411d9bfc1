"""Prop sites of a bundled clip by NumPy forward kinematics: where the bat's grip, sweet spot and
tip are, and which way its face points, without compiling a MuJoCo model."""

from __future__ import annotations

import numpy as np

from .. import mjcf
from .. import rotations as rot
from ..skeleton import Motion
from .body import forward_kinematics


def _holding_joint(motion: Motion, prop: mjcf.Prop, frame: int) -> tuple[np.ndarray, np.ndarray]:
    """World position ``(3,)`` and rotation ``(4,)`` of the joint holding ``prop`` at ``frame`` (NumPy FK)."""
    pos, wq = forward_kinematics(motion.root_positions[frame : frame + 1], motion.rotations[frame : frame + 1], motion.skeleton)
    j = motion.skeleton.index(prop.joint)
    return pos[0, j], wq[0, j]


def _site_from(p: np.ndarray, q: np.ndarray, prop: mjcf.Prop, site: str) -> np.ndarray:
    along = {"grip": 0.0, "sweet_spot": prop.sweet_spot, "tip": prop.length}[site]
    local = np.asarray(prop.pos) + rot.rotate(np.asarray(prop.quat), np.array([0.0, 0.0, along]))
    return p + rot.rotate(q, local)


def prop_site(motion: Motion, prop: mjcf.Prop, frame: int, site: str = "sweet_spot") -> np.ndarray:
    """World position ``(3,)`` of a prop site (``grip``, ``sweet_spot``, ``tip``) at ``frame`` (NumPy FK)."""
    return _site_from(*_holding_joint(motion, prop, frame), prop, site)


def prop_frame(motion: Motion, prop: mjcf.Prop, frame: int) -> tuple[np.ndarray, np.ndarray]:
    """Sweet-spot position ``(3,)`` and face normal ``(3,)`` (the prop frame's -x) at ``frame``."""
    p, wq = _holding_joint(motion, prop, frame)
    q = rot.multiply(wq, np.asarray(prop.quat))
    return _site_from(p, wq, prop, "sweet_spot"), rot.rotate(q, np.array([-1.0, 0.0, 0.0]))
