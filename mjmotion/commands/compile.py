"""``mjmotion compile``: a BVH skeleton as a MuJoCo MJCF file."""

from __future__ import annotations

import argparse

from ._common import add_input_options, check_model, note_up, output_path, prop_option, read_motion, trim_start
from ._options import UniqueProps
from ._progress import steps

NAME = "compile"
HELP = "compile a BVH skeleton to a MuJoCo model (.xml)"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
DESCRIPTION = """Compile the skeleton of a BVH file to MJCF: a free root, a ball joint per BVH joint,
capsules along the bones, foot boxes, masses for the character's size, a floor, lights and a
tracking camera. The file loads with mujoco.MjModel.from_xml_path to the same kinematics.

Its initial pose (qpos0) is the rest pose standing on the floor, and it carries a keyframe
"first_frame": the clip's first frame after a leading T-pose or transition (--keep-start: the
file's first frame), moved so its lowest geom touches the floor (load it in MuJoCo's viewer with
the Key slider, or mujoco.mj_resetDataKeyframe). A one-word --prop is fitted to the hands on the
same frames.

--skin adds the character's skinned surface (a MuJoCo <skin>: a closed mesh around the geoms
in a standing T-pose, up to four bone weights per vertex by bind-pose distance; MuJoCo deforms
it by vertex blending when it draws); the capsules and foot boxes stay the collision and mass
geometry but move to geom group 3, which viewers hide unless asked (key 3 in MuJoCo's viewer). --actuators adds a position servo per joint degree of
freedom (three per ball joint, on the rotation away from the T-pose; gains scaled by the inertia
each joint moves), and the keyframe's controls hold its pose: python -m mujoco.viewer --mjcf=X.xml.

examples:
  mjmotion compile swing.bvh -o swing.xml
  mjmotion compile swing.bvh -o swing.xml --prop club:rwrist --ball
  mjmotion compile walk.bvh -o walk.xml --skin --actuators
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="a .bvh file")
    p.add_argument("-o", "--output", required=True, metavar="MODEL.xml", help="the MJCF file to write")
    p.add_argument("--force", action="store_true", help="replace the output if it exists")
    p.add_argument(
        "--prop",
        action=UniqueProps,
        default=[],
        metavar="KIND[:JOINT]",
        help="attach a prop (club or bat) held by JOINT along its bone, or without :JOINT fitted to both hands as hit --prop fits it; repeatable, each kind once",
    )
    p.add_argument("--ball", action="store_true", help="add a free ball (cricket-ball size)")
    p.add_argument("--skin", action="store_true", help="add the character's skinned surface (a MuJoCo <skin>)")
    p.add_argument("--actuators", action="store_true", help="add a position servo per joint degree of freedom")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    from .. import kinematics, mjcf
    from ..errors import MjmotionError

    out = output_path(args, args.file, suffix=".xml")
    names = ("read", "compile", *(("bind pose",) if args.skin or args.actuators else ()), *(("skin",) if args.skin else ()), "write")
    with steps("compile", names) as step:
        step("read")
        m = read_motion(args.file, args)
        check_model(m, args.file)
        note_up(m, args.file)
        clip = trim_start(m, args.file, args)[0]  # the frames a pose is taken from (the skin binds on the whole file)
        step("compile")
        props = tuple(prop_option(clip, text) for text in args.prop)
        compiled = mjcf.compile(m.skeleton, props, mjcf.Ball() if args.ball else None)
        try:
            if args.skin or args.actuators:
                from ..skin import attach, bind, build

                step("bind pose")
                neutral = bind.bind_rotations(m.skeleton, m)
                if args.actuators:
                    compiled = mjcf.add_actuators(compiled, neutral)
            compiled = mjcf.add_keyframe(compiled, kinematics.qpos(compiled, clip[:1])[0], name="first_frame")
            if args.skin:
                step("skin")
                compiled = attach(compiled, build(compiled, reference=m))
        except MjmotionError as e:
            raise MjmotionError(f"{args.file}: {e}") from None
        step("write")
        compiled.save_xml(out)
    model = compiled.model
    extra = "".join(
        [
            f", a skin of {model.nskinvert} vertices" if model.nskin else "",
            f", {model.nu} actuators" if model.nu else "",
        ]
    )
    print(f"wrote {out}: {model.nbody - 1} bodies, nq={model.nq}, nv={model.nv}, mass {model.body_mass.sum():.1f} kg{extra}, keyframe first_frame")
    return 0
