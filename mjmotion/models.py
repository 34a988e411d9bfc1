"""The MuJoCo models in the repository's ``models/`` folder, and the command that regenerates them.

    python -m mjmotion.models [--out models]

* ``humanoid.xml`` — the bundled humanoid (:func:`mjmotion.synth.skeleton`) with its skin, a
  position servo per joint degree of freedom and keyframes of the bundled clips' first frames;
* ``bat.xml``, ``club.xml``, ``ball.xml`` — a cricket bat, a golf club and a cricket ball, each a
  free body over the floor, with the lab's grip, sweet-spot and tip sites.

Each opens with ``python -m mujoco.viewer --mjcf=models/<file>`` and is made by our own code from
the lab's dimensions (:data:`mjmotion.mjcf.PROP_PRESETS`, :class:`mjmotion.mjcf.Ball`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mujoco
import numpy as np

from . import mjcf
from .errors import MjmotionError

#: The keyframes of ``humanoid.xml``: bundled clips whose first frame is stored.
KEYFRAMES = ("walk", "run", "drive", "kick", "punch")
#: Cricket bat: handle length and radius, blade width and thickness (metres; Law 5 limits 10.8 × 6.7 cm).
BAT_HANDLE = (0.30, 0.016)
BAT_BLADE = (0.108, 0.045)
#: Golf club: grip length and radius, shaft radius, head size (metres) and mass share.
CLUB_GRIP = (0.27, 0.012)
CLUB_SHAFT_RADIUS = 0.005
CLUB_HEAD = (0.11, 0.045, 0.06)
CLUB_HEAD_MASS = 0.2


def _stage(name: str) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.option.timestep = 0.002
    mjcf.add_world(spec)
    return spec


def _sites(body: mujoco.MjsBody, name: str, length: float, sweet_spot: float) -> None:
    for label, z in (("grip", 0.0), ("sweet_spot", sweet_spot), ("tip", length)):
        body.add_site(name=f"{name}/{label}", pos=[0.0, 0.0, z], size=[0.012, 0, 0], rgba=[1, 0.9, 0.1, 1])


def _lying(spec: mujoco.MjSpec, name: str, height: float) -> mujoco.MjsBody:
    """A free body whose +z (grip to tip) lies along the world's +x, ``height`` above the floor."""
    body = spec.worldbody.add_body(name=name, pos=[0.0, 0.0, height], quat=[np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0])
    body.add_freejoint(name=name)
    return body


def bat() -> mujoco.MjSpec:
    """A cricket bat: a round handle and a flat blade, the lab's length, mass and sweet spot."""
    p = mjcf.PROP_PRESETS["bat"]
    spec = _stage("bat")
    body = _lying(spec, "bat", 0.2)
    handle_len, handle_r = BAT_HANDLE
    width, thick = BAT_BLADE
    blade_len = p["length"] - handle_len
    handle_vol = np.pi * handle_r**2 * handle_len + 4.0 / 3.0 * np.pi * handle_r**3
    blade_vol = width * thick * blade_len
    density = p["mass"] / (handle_vol + blade_vol)  # one wood density: the blade carries most of the mass
    body.add_geom(
        name="bat/handle",
        type=mujoco.mjtGeom.mjGEOM_CAPSULE,
        fromto=[0, 0, 0, 0, 0, handle_len],
        size=[handle_r, 0, 0],
        density=density,
        rgba=[0.25, 0.2, 0.15, 1],
    )
    body.add_geom(
        name="bat/blade",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=[0.0, 0.0, handle_len + blade_len / 2],
        size=[thick / 2, width / 2, blade_len / 2],
        density=density,
        rgba=[0.85, 0.72, 0.5, 1],
    )
    _sites(body, "bat", p["length"], p["sweet_spot"])
    return spec


def club() -> mujoco.MjSpec:
    """A golf club (a driver): grip, shaft and head, the lab's length, mass and sweet spot."""
    p = mjcf.PROP_PRESETS["club"]
    spec = _stage("club")
    body = _lying(spec, "club", 0.1)
    grip_len, grip_r = CLUB_GRIP
    head_x, head_y, head_z = CLUB_HEAD
    shaft_end = p["length"] - head_z / 2
    body.add_geom(
        name="club/grip",
        type=mujoco.mjtGeom.mjGEOM_CAPSULE,
        fromto=[0, 0, 0, 0, 0, grip_len],
        size=[grip_r, 0, 0],
        mass=0.05,
        rgba=[0.1, 0.1, 0.1, 1],
    )
    body.add_geom(
        name="club/shaft",
        type=mujoco.mjtGeom.mjGEOM_CAPSULE,
        fromto=[0, 0, grip_len, 0, 0, shaft_end],
        size=[CLUB_SHAFT_RADIUS, 0, 0],
        mass=p["mass"] - 0.05 - CLUB_HEAD_MASS,
        rgba=[0.7, 0.7, 0.75, 1],
    )
    # The head sits on the shaft's end with its face (+x) forward; the sweet spot is its centre.
    body.add_geom(
        name="club/head",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=[0.0, 0.0, p["sweet_spot"]],
        size=[head_y / 2, head_x / 2, head_z / 2],
        mass=CLUB_HEAD_MASS,
        rgba=[0.2, 0.2, 0.25, 1],
    )
    _sites(body, "club", p["length"], p["sweet_spot"])
    return spec


def ball() -> mujoco.MjSpec:
    """A cricket ball (the lab's :class:`mjmotion.mjcf.Ball`), dropped from 1 m."""
    b = mjcf.Ball()
    spec = _stage("ball")
    body = spec.worldbody.add_body(name=mjcf.BALL, pos=[0.0, 0.0, 1.0])
    body.add_freejoint(name=mjcf.BALL)
    body.add_geom(name=mjcf.BALL, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[b.radius, 0, 0], mass=b.mass, rgba=[0.85, 0.1, 0.1, 1])
    return spec


def humanoid() -> mjcf.CompiledModel:
    """The bundled humanoid with its skin, servos and a keyframe per bundled clip."""
    from . import kinematics, skin, synth

    clips = {name: synth.GENERATORS[name][0]().motion for name in KEYFRAMES}
    skel = synth.skeleton()
    compiled = mjcf.compile(skel)
    compiled = mjcf.add_actuators(compiled, skin.bind.bind_rotations(skel, clips["walk"]))
    for name, motion in clips.items():
        compiled = mjcf.add_keyframe(compiled, kinematics.qpos(compiled, motion[:1])[0], name=name)
    compiled = skin.attach(compiled, skin.build(compiled, reference=clips["walk"]))
    compiled.spec.modelname = "humanoid"
    return compiled


def write(out_dir: str | Path) -> list[Path]:
    """Write every model into ``out_dir`` (replacing what is there); returns the paths."""
    from .outputs import write_text_atomic

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("bat", bat), ("club", club), ("ball", ball)):
        spec = make()
        spec.compile()
        path = out / f"{name}.xml"
        write_text_atomic(path, spec.to_xml())
        paths.append(path)
    path = out / "humanoid.xml"
    humanoid().save_xml(path)
    paths.append(path)
    return paths


def main(argv: list[str] | None = None, *, prog: str = "python -m mjmotion.models", out: str = "models") -> int:
    """The command line: ``argv`` (default ``sys.argv[1:]``), ``--out`` defaulting to ``out``."""
    p = argparse.ArgumentParser(prog=prog, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=out, metavar="DIR", help=f"the folder to write (default: {out})")
    args = p.parse_args(argv)
    try:
        for path in write(args.out):
            print(f"wrote {path}")
    except MjmotionError as e:
        sys.stderr.write(f"error: {e}\n")
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
