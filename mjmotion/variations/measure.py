"""Measurements of a variant: style error, footskate, joint speeds, grip error, effector path length."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import kinematics, mjcf
from .. import rotations as rot
from ..errors import MjmotionError
from ..skeleton import Motion
from ..style import PoseSpace, rotation_flips, style_rmse
from .fixes import _source_at, grip_joints
from .paths import ScorePath

#: Median distance (m) between the hands under which a clip counts as two-handed (golf: 4–10 cm).
TWO_HANDED_M = 0.2


def first_hand_for(source: Motion) -> str | None:
    """The hand the other is held to: the club's hand when ``hitpoint.fit_club`` fits one, else left.

    ``None`` when the skeleton does not have two hands or they are not together (median distance
    over ``TWO_HANDED_M``): a walk or a kick has no grip to keep.
    """
    hands = source.skeleton.hands()
    if set(hands) != {"left", "right"}:
        return None
    p = kinematics.forward(mjcf.compile(source.skeleton), source).joint_positions
    if np.median(np.linalg.norm(p[:, hands["left"]] - p[:, hands["right"]], axis=-1)) > TWO_HANDED_M:
        return None  # the hands are not holding one thing
    from ..skeleton import side_of

    prop = fitted_club(source)
    return (side_of(prop.joint) if prop is not None else None) or "left"


def grip_error_m(source: Motion, motion: Motion, path: ScorePath, first_hand: str = "left") -> float:
    """METRICS.md ``grip_error_m``: distance of the second hand from where the source holds it
    relative to the first hand (at the source frames each frame stands for), max over frames."""
    skel = source.skeleton
    hands = grip_joints(skel)
    h1, h2 = hands[first_hand], hands["right" if first_hand == "left" else "left"]
    compiled = mjcf.compile(skel)
    src = kinematics.forward(compiled, source)
    var = kinematics.forward(compiled, motion)
    rel = rot.rotate(
        rot.conjugate(src.joint_rotations[:, h1]),
        src.joint_positions[:, h2] - src.joint_positions[:, h1],
    )
    want = var.joint_positions[:, h1] + rot.rotate(var.joint_rotations[:, h1], _source_at(rel, path))
    return float(np.max(np.linalg.norm(want - var.joint_positions[:, h2], axis=-1)))


def effector_path_length(
    motion: Motion,
    joint: int | None = None,
    frames: tuple[int, int] | None = None,
    prop: mjcf.Prop | None = None,
) -> float:
    """Length (m) of the path of ``joint`` — or of ``prop``'s sweet spot — over ``frames`` (half-open; all by default)."""
    if prop is not None:
        pose = kinematics.forward(mjcf.compile(motion.skeleton, (prop,)), motion)
        p = pose.site(f"{prop.name}/sweet_spot")
    elif joint is not None:
        p = kinematics.forward(mjcf.compile(motion.skeleton), motion).joint_positions[:, joint]
    else:
        raise MjmotionError("effector_path_length needs a joint or a prop")
    if frames is not None:
        p = p[frames[0] : frames[1]]
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=-1)))


def fitted_club(source: Motion) -> mjcf.Prop | None:
    """The club ``hitpoint.fit_club`` fits to a two-handed swing, or ``None`` (one hand, or no fit)."""
    if set(source.skeleton.hands()) != {"left", "right"}:
        return None
    from ..hitpoint import fit_club

    try:
        return fit_club(source)
    except MjmotionError:
        return None


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def planted_skates(source: Motion, results: dict[str, Motion]) -> dict[str, Any]:
    """The judge's headline footskate (docs/METRICS.md ``planted_skate_mm_per_s``) of ``source`` on its
    own and of each of ``results`` judged against it (its floor and soles, as ``evaluate --source``),
    with the thresholds used; ``None`` where a clip has no contact frame."""
    from .. import evaluate, feet

    compiled = evaluate.judge_model(source.skeleton)
    judged = [(source, kinematics.forward(compiled, source))]
    out: dict[str, Any] = {"source": _finite(evaluate.planted_skate_mm_per_s(feet.judged_feet(compiled, source, judged[0][1])[0]))}
    for name, m in results.items():
        track = feet.judged_feet(compiled, m, kinematics.forward(compiled, m), judged)[0]
        out[name] = _finite(evaluate.planted_skate_mm_per_s(track))
    out.update(h_c=evaluate.H_C, v_c=evaluate.V_C, hysteresis=evaluate.HYSTERESIS)
    return out


def report(
    source: Motion,
    raw: Motion,
    result: Motion,
    path: ScorePath,
    space: PoseSpace,
    first_hand: str | None = "left",
) -> dict[str, Any]:
    """Numbers for a variant: ``k``, variance explained, footskate (mm/s, METRICS.md) of source, raw
    and result, joint-speed ratios (whole-body and per joint) and pop frames, grip error and the
    first hand's path length."""
    from .. import evaluate

    out: dict[str, Any] = {
        "variant": path.label,
        "n_frames": result.n_frames,
        "k": path.k,
        "variance_explained": float(space.cumulative[path.k - 1]),
        "explained_per_component": [float(x) for x in space.explained[: max(path.k, 5)]],
    }
    flips = rotation_flips(source)
    if flips:
        out["warnings"] = [
            (
                f"local rotations jump by more than {np.degrees(2.5):.0f} degrees in one frame at {len(flips)} places "
                f"(first: frame {flips[0][0]}, {flips[0][1]}); the PCA mixes the two branches and variants may be distorted"
            )
        ]
    if result.n_frames == source.n_frames:
        rmse, k_style = style_rmse(source, result)
        out["style_rmse"] = {"rmse": rmse, "k": k_style}
    try:
        out["planted_skate_mm_per_s"] = planted_skates(source, {"raw": raw, "result": result})
    except MjmotionError as exc:  # no feet in the skeleton
        out["planted_skate_mm_per_s"] = {"source": None, "raw": None, "result": None, "note": str(exc)}
    out["max_joint_speed_ratio"] = {
        "raw": float(evaluate.max_joint_speed_ratio(raw, source)),
        "result": float(evaluate.max_joint_speed_ratio(result, source)),
    }
    # Per joint (docs/METRICS.md): what the whole-body ratio hides, a joint at several times its own speed.
    worst = {name: evaluate.worst_joint_speed_ratio(m, source) for name, m in (("raw", raw), ("result", result))}
    out["worst_joint_speed_ratio"] = {name: {"ratio": float(r), "joint": j} for name, (r, j) in worst.items()}
    out["pop_frames"] = {name: int(evaluate.pop_frames(m, source).sum()) for name, m in (("source", source), ("raw", raw), ("result", result))}
    if first_hand is not None:
        out["first_hand"] = first_hand
        out["grip_error_m"] = {
            "raw": grip_error_m(source, raw, path, first_hand),
            "result": grip_error_m(source, result, path, first_hand),
        }
        j = source.skeleton.hands()[first_hand]
        out["effector_path_m"] = {
            "effector": source.skeleton.names[j],
            "source": effector_path_length(source, j),
            "result": effector_path_length(result, j),
        }
        club = fitted_club(source)
        if club is not None:
            out["club_path_m"] = {
                "effector": f"{club.name}/sweet_spot",
                "source": effector_path_length(source, prop=club),
                "result": effector_path_length(result, prop=club),
            }
    return out
