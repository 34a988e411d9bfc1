"""``mjmotion convert``: rescale, resample or cut a BVH file."""

from __future__ import annotations

import argparse

from ._common import add_input_options, load, output_path
from ._options import FPS, number, resample
from ._progress import steps

NAME = "convert"
HELP = "write a BVH file again, optionally rescaled, resampled or cut"
DESCRIPTION = """Write a clip again with the same skeleton, channel orders and units, optionally changed.

--scale S multiplies every written length by S (0.01 turns a centimetre file into metres);
--fps F resamples (slerp of rotations); --frames A:B keeps frames A..B-1 (before resampling).

examples:
  mjmotion convert walk.bvh walk_30fps.bvh --fps 30
  mjmotion convert walk.bvh walk_m.bvh --scale 0.01 --frames 100:400
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", help="the .bvh file to read")
    p.add_argument("output", help="the .bvh file to write")
    p.add_argument("--scale", type=number(1e-6, 1e6, what="a length factor"), metavar="S", help="multiply written lengths by S (1e-6 to 1e6)")
    p.add_argument("--fps", type=FPS, metavar="F", help="resample to F frames per second (0.1 to 10000; at most 1,000,000 frames)")
    p.add_argument("--frames", metavar="A:B", help="keep frames A to B-1 (Python slice, negatives allowed)")
    p.add_argument("--force", action="store_true", help="replace OUTPUT if it exists")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    from .. import bvh

    out = output_path(args, args.input, suffix=".bvh", option="")
    with steps("convert", ("read", *(("resample",) if args.fps is not None else ()), "write")) as step:
        step("read")
        m = load(args.input, args, args.frames)
        if args.fps is not None:
            step("resample")
            m = resample(m, args.fps)
        if args.scale is not None:
            m = m.replace(skeleton=m.skeleton.replace_scale(m.skeleton.scale / args.scale))
        step("write")
        bvh.write(m, out)
    print(f"wrote {out} ({m.n_frames} frames at {m.fps:.4g} fps)")
    return 0
