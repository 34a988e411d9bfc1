"""``mjmotion blend``: blend clips of one skeleton (registered, or linear as the baseline)."""

from __future__ import annotations

import argparse
import sys

from ..errors import MjmotionError
from . import _joint_weights as joint_weights
from ._common import naming, output_path
from ._progress import steps
from .register import add_clip_options, load_clips

NAME = "blend"
HELP = "blend two or more clips with weights (registration curves, or frame-by-frame linear)"
DESCRIPTION = """Blend clips of the same skeleton topology (bone lengths may differ: the result uses the first
clip's skeleton). registered (default): the clips are registered (timewarp + alignment), sampled
at corresponding times, their joint rotations averaged as quaternions and the root built from
the weighted per-frame steps, so the blend walks one continuous path at an in-between pace.
linear: frame n of every clip averaged (the Sako 2008 baseline). Weights are non-negative and
must sum to 1. A clip at another frame rate is resampled to the first clip's (slerp), as
`convert --fps` would.

examples:
  mjmotion blend walk.bvh run.bvh --weights 0.5,0.5 -o jog.bvh
  mjmotion blend 07_01.bvh 09_01.bvh --frames 4: --weights 0.75,0.25 -o brisk.bvh
  mjmotion blend walk.bvh run.bvh --weights 0.5,0.5 --method linear -o linear.bvh
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="CLIP.bvh", help="two or more clips")
    p.add_argument("--weights", required=True, metavar="W1,W2[,...]", help="one weight per clip, summing to 1")
    p.add_argument("--method", choices=("registered", "linear"), default="registered", help="default: registered")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the blended clip")
    p.add_argument("--force", action="store_true", help="replace OUT if it exists")
    add_clip_options(p)


def run(args: argparse.Namespace) -> int:
    from .. import blend, bvh

    out = output_path(args, *args.files, *joint_weights.inputs(args), suffix=".bvh")
    if len(args.files) < 2:
        raise MjmotionError("blend needs at least two clips")
    try:
        weights = [float(x) for x in args.weights.split(",")]
    except ValueError:
        raise MjmotionError(f"--weights {args.weights!r}: expected numbers separated by commas") from None
    blend.check_weights(weights, len(args.files), "--weights")
    if args.joint_weights and args.method == "linear":
        raise MjmotionError("--joint-weights weighs the registration's distance; a linear blend has none (use --method registered)")
    warnings = []
    with steps("blend", ("read", "register", "blend", "write") if args.method == "registered" else ("read", "blend", "write")) as step:
        step("read")
        clips = blend.common_rate(load_clips(args.files, args))
        registration = None
        if args.method == "registered":
            from ..registration import register_many

            step("register")
            try:
                registration = register_many(clips, reference=0 if len(clips) <= 2 else None, weights=joint_weights.load(args, clips[0].skeleton))
            except MjmotionError as e:  # (the registration speaks of "the clips": say which)
                raise naming(args.files, e) from None
            for k, b in enumerate(registration.blendability):
                warning = b.warning(clips[registration.reference].name, clips[k].name) if b is not None else None
                if warning:
                    warnings.append(warning)
        step("blend")
        result = blend.blend(clips, weights, method=args.method, name=out.stem, registration=registration)
        step("write")
        bvh.write(result, out)
    for warning in warnings:  # after the progress bar, which they would break
        sys.stderr.write(f"warning: {warning}\n")
    travel = float(((result.root_positions[-1, :2] - result.root_positions[0, :2]) ** 2).sum()) ** 0.5
    print(f"wrote {out}: {result.n_frames} frames at {result.fps:g} fps ({args.method}), net floor travel {travel:.2f} m")
    return 0
