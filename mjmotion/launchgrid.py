"""Launch grids (seed 003 §2.3.2, Figure 2.6): a shot adapted to a grid of hit points, a ball
launched from each.

This is an *operation* (it makes new motion: the arm re-aimed with analytic two-bone IK), so it
lives outside the judge; the judge's part — simulating each launch and rank-correlating launch
direction with the hit point — is :func:`mjmotion.physics.launch_predictability`.

- :func:`arm_chain` ``(skeleton, joint) -> (shoulder, elbow, wrist)``
- :func:`reach_hit_point` ``(motion, prop, hit_frame, target) -> Motion``
- :func:`effector_path` ``(compiled, motion, geom, hit_frame) -> (pos, quat, hit_index)``
- :func:`grid_offsets` ``(motion, prop, hit_frame, n, step) -> (n², 3)``
- :func:`hit_grid` ``(motion, prop, hit_frame, offsets) -> physics.Predictability``
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from . import kinematics, mjcf, physics
from . import rotations as rot
from .errors import MjmotionError
from .ik import analytic
from .kinematics import Pose
from .mjcf import CompiledModel, Prop
from .skeleton import Motion, Skeleton


def arm_chain(skeleton: Skeleton, joint: int, min_bone: float = 0.08) -> tuple[int, int, int]:
    """``(shoulder, elbow, wrist)`` above ``joint``: the first two long bones up the chain
    (bones shorter than ``min_bone`` × stature, like a hand or a clavicle stub, are skipped)."""
    short = min_bone * skeleton.stature()

    def up_to_long(j: int) -> int:
        while j > 0 and np.linalg.norm(skeleton.offsets[j]) < short:
            j = int(skeleton.parents[j])
        return j

    wrist = up_to_long(joint)
    elbow = up_to_long(int(skeleton.parents[wrist]))
    shoulder = int(skeleton.parents[elbow])
    if wrist <= 0 or elbow <= 0 or shoulder < 0:
        raise MjmotionError(f"{skeleton.names[joint]!r}: no shoulder-elbow-wrist chain above it")
    return shoulder, elbow, wrist


def reach_hit_point(
    motion: Motion,
    prop: Prop,
    hit_frame: int,
    target: Sequence[float],
    falloff: float = 0.25,
    wrist: str = "locked",
    pose: Pose | None = None,
) -> Motion:
    """The shot adapted so ``prop``'s sweet spot meets ``target`` at ``hit_frame`` (seed 003 §2.2).

    The arm (shoulder, elbow, wrist) is solved with analytic two-bone IK, the offset blended in and
    out with a smoothstep over ``falloff`` seconds each side of the hit. ``wrist="locked"`` keeps
    the wrist's local rotation from the source (seed 003 §2.3.3: the club turns with the forearm);
    ``wrist="world"`` keeps the club's world orientation (the wrist absorbs the change).
    ``pose``: ``motion``'s forward kinematics with ``prop`` (computed when not given; a grid of
    targets on one shot passes it once).
    """
    if wrist not in ("locked", "world"):
        raise MjmotionError(f"wrist={wrist!r}: expected 'locked' or 'world'")
    skel = motion.skeleton
    sh, el, wr = arm_chain(skel, skel.index(prop.joint))
    n = max(1, round(falloff * motion.fps))
    t = np.arange(motion.n_frames)
    x = np.clip(1.0 - np.abs(t - hit_frame) / (n + 1), 0.0, 1.0)
    weight = x * x * (3 - 2 * x)
    act = weight > 0
    pose = pose if pose is not None else kinematics.forward(mjcf.compile(skel, (prop,)), motion)
    delta = np.asarray(target, dtype=float) - pose.site(prop.site)[hit_frame]
    jp, jr = pose.joint_positions, pose.joint_rotations
    if wrist == "locked":
        # Forearm and club are one rigid link from the elbow to the sweet spot: solve that chain.
        end = pose.site(prop.site)[act]
    else:
        end = jp[act, wr]
    r_sh, r_el, _ = analytic.two_bone_ik(jp[act, sh], jp[act, el], end, end + weight[act, None] * delta)
    w_sh = rot.multiply(r_sh, jr[act, sh])
    w_el = rot.multiply(r_sh, rot.multiply(r_el, jr[act, el]))
    rots = motion.rotations.copy()
    rots[act, sh] = rot.multiply(rot.conjugate(jr[act, int(skel.parents[sh])]), w_sh)
    rots[act, el] = rot.multiply(rot.conjugate(w_sh), w_el)
    if wrist == "world":
        rots[act, wr] = rot.multiply(rot.conjugate(w_el), jr[act, wr])
    return motion.replace(rotations=rot.normalize(rots))


def effector_path(compiled: CompiledModel, motion: Motion, geom: int, hit_frame: int, window: int = 3) -> tuple[np.ndarray, np.ndarray, int]:
    """World poses ``(pos (n, 3), quat (n, 4))`` of ``geom`` over ``hit_frame ± window`` and the hit's index."""
    m = compiled.model
    q = kinematics.qpos(compiled, motion)
    lo, hi = max(0, hit_frame - window), min(motion.n_frames, hit_frame + window + 1)
    d = mujoco.MjData(m)
    pos = np.empty((hi - lo, 3))
    mats = np.empty((hi - lo, 3, 3))
    for i, f in enumerate(range(lo, hi)):
        d.qpos[:] = q[f]
        mujoco.mj_kinematics(m, d)
        pos[i] = d.geom_xpos[geom]
        mats[i] = d.geom_xmat[geom].reshape(3, 3)
    return pos, rot.make_continuous(rot.from_matrix(mats)), hit_frame - lo


def grid_offsets(motion: Motion, prop: Prop, hit_frame: int, n: int = 3, step: float = 0.05) -> np.ndarray:
    """``(n², 3)`` offsets on an ``n × n`` grid (spacing ``step`` m) across the sweet spot's path at
    the hit: one axis horizontal and perpendicular to its velocity, the other vertical."""
    compiled = mjcf.compile(motion.skeleton, (prop,))
    spot = kinematics.forward(compiled, motion).site(prop.site)
    v = np.gradient(spot, axis=0)[hit_frame]
    lat = np.cross([0.0, 0.0, 1.0], v)
    lat = lat / np.linalg.norm(lat) if np.linalg.norm(lat) > 1e-12 else np.array([0.0, 1.0, 0.0])
    ticks = (np.arange(n) - (n - 1) / 2) * step
    return np.array([a * lat + b * np.array([0.0, 0.0, 1.0]) for b in ticks for a in ticks])


def hit_grid(
    motion: Motion,
    prop: Prop,
    hit_frame: int,
    offsets: np.ndarray,
    wrist: str = "locked",
    ball_radius: float = 0.0214,
    ball_mass: float = 0.046,
    ball_velocity: Sequence[float] = (0.0, 0.0, 0.0),
    restitution: float = 0.8,
    falloff: float = 0.25,
) -> physics.Predictability:
    """Seed 003 Figure 2.6: adapt the shot to hit points at the source hit point + ``offsets (N, 3)``
    (:func:`reach_hit_point`), launch the ball from each (club and golf ball by default) and
    rank-correlate launch direction with the hit point."""
    compiled = mjcf.compile(motion.skeleton, (prop,))
    geom = mujoco.mj_name2id(compiled.model, mujoco.mjtObj.mjOBJ_GEOM, prop.name)
    # One model and one FK of the source shot serve every grid point.
    pose = kinematics.forward(compiled, motion)
    base = pose.site(prop.site)[hit_frame]
    points = base + np.asarray(offsets, dtype=float)
    paths = []
    h = 0
    for p in points:
        adapted = reach_hit_point(motion, prop, hit_frame, p, falloff, wrist, pose)
        pos, quat, h = effector_path(compiled, adapted, geom, hit_frame)
        paths.append((pos, quat))
    size = compiled.model.geom_size[geom].tolist()
    # The ball sits one radius off the club's axis, in front of the face along the club's motion.
    return physics.launch_predictability(
        int(compiled.model.geom_type[geom]), size, paths, motion.fps, h, points, ball_radius, ball_mass, ball_velocity, restitution
    )
