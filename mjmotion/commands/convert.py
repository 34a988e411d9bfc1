"""``mjmotion convert``: rescale, resample or cut a BVH file."""

from __future__ import annotations

import argparse

from ..errors import MjmotionError
from ._common import UNITS_RANGE, add_input_options, load, output_path
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
    p.add_argument(
        "--scale",
        type=number(1e-6, 1e6, what="a length factor"),
        metavar="S",
        help="multiply written lengths by S (1e-6 to 1e6, and the written file's unit, metres per unit read over S, within --units's 1e-6 to 1000)",
    )
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
            unit = m.skeleton.scale / args.scale  # metres per unit of the written file
            if not UNITS_RANGE[0] <= unit <= UNITS_RANGE[1]:
                # (--scale 1e6 of a CMU ASF file wrote one no --units reads at its size: 2.5e-8 m per unit)
                raise MjmotionError(
                    f"--scale {args.scale:g}: the written file's unit would be {unit:.3g} m ({m.skeleton.scale:.4g} m per unit read, "
                    f"over {args.scale:g}); --units reads {UNITS_RANGE[0]:g} to {UNITS_RANGE[1]:g} m per unit, so no reader would take "
                    f"it at its size: give a factor from {m.skeleton.scale / UNITS_RANGE[1]:.3g} to {m.skeleton.scale / UNITS_RANGE[0]:.3g}"
                )
            m = m.replace(skeleton=m.skeleton.replace_scale(unit))
        step("write")
        bvh.write(m, out)
    print(f"wrote {out} ({m.n_frames} frames at {m.fps:.4g} fps)")
    return 0
