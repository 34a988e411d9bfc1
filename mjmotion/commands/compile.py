"""``mjmotion compile``: a BVH skeleton as a MuJoCo MJCF file."""

from __future__ import annotations

import argparse

from .. import mjcf
from ._common import add_input_options, load, output_path
from ._options import UniqueProps

NAME = "compile"
HELP = "compile a BVH skeleton to a MuJoCo model (.xml)"
DESCRIPTION = """Compile the skeleton of a BVH file to MJCF: a free root, a ball joint per BVH joint,
capsules along the bones, foot boxes, masses for the character's size, a floor, lights and a
tracking camera. The file loads with mujoco.MjModel.from_xml_path to the same kinematics.

examples:
  mjmotion compile swing.bvh -o swing.xml
  mjmotion compile swing.bvh -o swing.xml --prop club:rwrist --ball
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
        help="attach a prop (club or bat) to JOINT (default: the right hand); repeatable, each kind once",
    )
    p.add_argument("--ball", action="store_true", help="add a free ball (cricket-ball size)")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    out = output_path(args, args.file)
    m = load(args.file, args)
    props = tuple(mjcf.parse_prop_option(m.skeleton, text) for text in args.prop)
    compiled = mjcf.compile(m.skeleton, props, mjcf.Ball() if args.ball else None)
    compiled.save_xml(out)
    model = compiled.model
    print(f"wrote {out}: {model.nbody - 1} bodies, nq={model.nq}, nv={model.nv}, mass {model.body_mass.sum():.1f} kg")
    return 0
