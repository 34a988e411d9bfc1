"""Skinning artefacts (seed 000 §1.1.2, Figs. 5–6): the candy-wrapper and the collapsing elbow.

The character's skin (:mod:`mjmotion.skin`) starts in its bind pose, a T-pose with the arms held
out sideways. Two motions of the left elbow:

* **twist** — the forearm (and hand) turned about the forearm's own axis, 0–180°: vertex
  blending averages points on opposite sides of the bone, so the skin at the elbow pinches in
  (the candy-wrapper, seed 000 Fig. 5; "twisting rotation on elbow causing collapse of elbow",
  Fig. 6 right);
* **bend** — the forearm swung forward in the horizontal plane, 0–150°: the inside of the elbow
  shrinks (Fig. 6 left).

For linear blend skinning (LBS, seed 000 Eq. 1) and dual-quaternion skinning (DQS), each pose is
measured against the bind pose by :mod:`mjmotion.skin.measure`: the cross-section area through
the elbow (the plane across the forearm for the twist, the plane bisecting the bend), and the
volume of skin within a ball around the elbow (radius 2 × the forearm's capsule radius).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import mjcf, plots, skin
from .. import rotations as rot
from ..errors import MjmotionError
from ..skeleton import Motion
from ..skin import bind, measure
from . import Table

COLUMNS = ("motion", "angle °", "LBS area %", "DQS area %", "LBS volume %", "DQS volume %")
TWISTS = np.arange(0.0, 181.0, 15.0)
BENDS = np.arange(0.0, 151.0, 15.0)
QUICK_TWISTS = np.array([0.0, 90.0, 135.0, 180.0])
QUICK_BENDS = np.array([0.0, 90.0, 150.0])
#: Past this bend the bisecting plane runs along both limbs rather than across the elbow.
MAX_SECTION_BEND = 90.0


@dataclass(frozen=True, eq=False)
class Arm:
    """The left elbow of a skinned character in its bind pose.

    Attributes:
        compiled, skin: the model and its skin.
        elbow: the forearm's first joint; wrist: the next joint toward the hand.
        radius: the forearm capsule's radius, metres.
    """

    compiled: mjcf.CompiledModel
    skin: skin.Skin
    elbow: int
    wrist: int
    radius: float


def left_arm(motion: Motion) -> Arm:
    """The left elbow of ``motion``'s character, its skin built in the bind pose."""
    skel = motion.skeleton
    hands = skel.hands()
    if "left" not in hands:
        raise MjmotionError("skinning experiment: no left hand found by joint name")
    seg = mjcf.segments(skel)
    chain = [hands["left"]]
    while chain[-1] > 0:
        chain.append(int(skel.parents[chain[-1]]))
    fore = [j for j in chain if seg[j] == "forearm"]
    if not fore:
        raise MjmotionError("skinning experiment: no forearm above the left hand")
    elbow = fore[-1]
    wrist = chain[chain.index(elbow) - 1]  # the next joint toward the hand
    compiled = mjcf.compile(skel)
    s = skin.build(compiled, reference=motion)
    radius = mjcf.SEGMENT_RADIUS["forearm"] * float(np.clip(skel.stature(), 0.3, 3.0)) / 1.75
    return Arm(compiled, s, elbow, wrist, radius)


def pose(arm: Arm, motion_kind: str, angle_deg: float) -> np.ndarray:
    """``(J, 4)`` local rotations: the bind pose with the elbow twisted or bent by ``angle_deg``."""
    skel = arm.compiled.skeleton
    local = arm.skin.bind_pose.copy()
    pos, world = bind.world_pose(skel, local)
    parent = world[int(skel.parents[arm.elbow])]
    axis_world = pos[arm.wrist] - pos[arm.elbow]
    axis_world /= np.linalg.norm(axis_world)
    if motion_kind == "twist":
        turn = rot.exp(axis_world * np.radians(angle_deg))
    elif motion_kind == "bend":
        # Forward (+x) in the horizontal plane: about the vertical, the sign that swings the arm forward.
        sign = 1.0 if np.cross([0.0, 0.0, 1.0], axis_world)[0] > 0 else -1.0
        turn = rot.exp(np.array([0.0, 0.0, sign]) * np.radians(angle_deg))
    else:
        raise ValueError(motion_kind)
    local[arm.elbow] = rot.multiply(rot.conjugate(parent), rot.multiply(turn, world[arm.elbow]))
    return local


def skin_at(arm: Arm, local: np.ndarray, method: str) -> np.ndarray:
    """``(V, 3)`` the skin in the pose ``local: (J, 4)`` (stood where the bind pose stands)."""
    pos, world = bind.world_pose(arm.compiled.skeleton, local, arm.skin.bind_root)
    v, _ = skin.deformed_frames(arm.skin, pos[None, arm.skin.joints], world[None, arm.skin.joints], method, normals=False)
    return v[0]


def measures(arm: Arm, motion_kind: str, angle_deg: float, method: str) -> tuple[float, float]:
    """``(area m², volume m³)`` at the elbow after the twist or bend."""
    local = pose(arm, motion_kind, angle_deg)
    verts = skin_at(arm, local, method)
    skel = arm.compiled.skeleton
    pos, _ = bind.world_pose(skel, local, arm.skin.bind_root)
    centre = pos[arm.elbow]
    upper = centre - pos[int(skel.parents[arm.elbow])]
    fore = pos[arm.wrist] - centre
    upper, fore = upper / np.linalg.norm(upper), fore / np.linalg.norm(fore)
    normal = fore if motion_kind == "twist" else upper + fore  # the bisecting plane of a bend
    reach = 2.0 * arm.radius
    if motion_kind == "bend" and angle_deg > MAX_SECTION_BEND:
        area = float("nan")
    else:
        area = measure.section_area(verts, arm.skin.faces, centre, normal, 1.5 * reach)
    volume = measure.volume_in_ball(verts, arm.skin.faces, centre, reach, spacing=reach / 30)
    return area, volume


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False) -> Table:
    """Twist and bend the elbow for LBS and DQS; writes ``table.md`` and ``skinning.png``."""
    from .. import bvh, synth

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if data_dir is not None:
        path = Path(data_dir) / "cmu_asfamc_converted" / "16_15.bvh"
        if not path.is_file():
            raise MjmotionError(f"{path}: missing; the experiment skins the CMU ASF skeleton of 16_15 (SOURCES.md)")
        motion = bvh.read(str(path))
        source = "CMU ASF/AMC skeleton of 16_15 (subject 16)"
    else:
        motion = synth.walk().motion
        source = "the bundled humanoid (mjmotion.synth)"
    arm = left_arm(motion)
    names = motion.skeleton.names
    table = Table(
        "Skinning artefacts at the elbow: linear blend vs dual-quaternion skinning (seed 000 §1.1.2, Figs. 5–6)",
        COLUMNS,
        notes=[
            f"character: {source}; skin of {arm.skin.n_vertices} vertices, {len(arm.skin.faces)} faces, "
            f"≤ {arm.skin.weights.bones.shape[1]} bone weights per vertex; joint {names[arm.elbow]!r} (left elbow)",
            "twist: forearm and hand turned about the forearm's axis; bend: forearm swung forward in the horizontal plane",
            "area: cross-section through the elbow (across the forearm for the twist, the bisecting plane for the bend); "
            f"volume: skin inside a ball of radius {200 * arm.radius:.1f} cm (2 × the forearm radius) at the elbow; "
            f"both as % of the bind pose; past a {MAX_SECTION_BEND:.0f}° bend the bisecting plane runs along the limbs, "
            "so only the volume is given",
        ],
    )
    twists, bends = (QUICK_TWISTS, QUICK_BENDS) if quick else (TWISTS, BENDS)
    series: dict[str, dict[str, np.ndarray]] = {}
    for kind, angles in (("twist", twists), ("bend", bends)):
        vals = {m: np.array([measures(arm, kind, a, m) for a in angles]) for m in ("lbs", "dqs")}
        base = vals["lbs"][0]
        pct = {m: 100.0 * v / base for m, v in vals.items()}
        for i, a in enumerate(angles):
            table.add(kind, float(a), pct["lbs"][i, 0], pct["dqs"][i, 0], pct["lbs"][i, 1], pct["dqs"][i, 1])
        series[kind] = {"angles": angles, **{f"{m}_{q}": pct[m][:, k] for m in ("lbs", "dqs") for k, q in enumerate(("area", "volume"))}}
    last = series["twist"]
    table.notes.append(
        f"at a {last['angles'][-1]:.0f}° twist LBS keeps {last['lbs_area'][-1]:.0f} % of the elbow's cross-section and "
        f"{last['lbs_volume'][-1]:.0f} % of its volume, DQS {last['dqs_area'][-1]:.0f} % and {last['dqs_volume'][-1]:.0f} %"
    )
    local = pose(arm, "twist", 180.0)
    views = {m: skin_at(arm, local, m) for m in ("lbs", "dqs")}
    centre = bind.world_pose(motion.skeleton, local, arm.skin.bind_root)[0][arm.elbow]
    png = plots.skinning_artefacts(
        series, {m.upper(): v for m, v in views.items()}, arm.skin.faces, centre, 4.0 * arm.radius, out_dir / "skinning.png"
    )
    table.files = [str(png)]
    table.write(out_dir)
    return table
