"""``mjmotion hit``: adapt a swing or kick so it meets a ball somewhere else (seed 003 §2)."""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from .. import bvh
from ..errors import MjmotionError
from ..outputs import write_text_atomic
from ._common import add_input_options, load, output_path

NAME = "hit"
HELP = "move a swing's hit point (IK with importance-based blending, keeping the style)"
DESCRIPTION = """Adapt SHOT.bvh so its effector (a club's sweet spot, a foot, a fist, or a site) meets a new
ball position at the hit frame, blending IK in and out by the effector's distance to the hit
point (seed 003 §2.2.5). Coordinates are metres in the model's world frame (Z up).
The hit frame is the moment of contact: the effector's lowest pass in the downswing (a ball on
the ground or a tee), or with --source-ball the downswing frame nearest the source's ball; the
report gives the rule and the effector's height there above the floor the feet stand on
(measured, not z = 0: CMU subject 64's floor is 2-4 cm below it).
An unreachable target is solved best-effort: the clip and report are written (with
"reachable": false), one error line says so, and the exit status is 2.
The report's hit_error_m is the effector's distance to the target point at the hit frame
(`mjmotion evaluate --ball` measures METRICS' hit_error_m, to a ball's surface).

examples:
  mjmotion hit 64_01.bvh --offset 0 0.1 0.1 -o swing_hit.bvh --json report.json
  mjmotion hit 64_01.bvh --target 0.62 0.54 0.47 --solver dls --falloff 0.4 -o out.bvh
  mjmotion hit 10_01.bvh --effector right_foot --offset 0.1 0 0 -o kick.bvh
  mjmotion hit 64_01.bvh --offset 0 0 0.2 --wrist swing --lock lclavicle -o out.bvh
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="SHOT.bvh", help="the source clip")
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--target", nargs=3, type=float, metavar=("X", "Y", "Z"), help="new hit point (metres, world)")
    g.add_argument("--offset", nargs=3, type=float, metavar=("DX", "DY", "DZ"), help="move the hit point by this (metres)")
    p.add_argument(
        "--frame", type=int, default=None, metavar="H", help="hit frame (default: the moment of contact, the effector's lowest pass in the downswing)"
    )
    p.add_argument(
        "--source-ball",
        nargs=3,
        type=float,
        default=None,
        metavar=("X", "Y", "Z"),
        help="where the ball was in the source (m): the hit frame is the downswing frame where the effector comes nearest to it",
    )
    p.add_argument("--effector", default="club", metavar="NAME", help="club|left_foot|right_foot|left_fist|right_fist|SITE (default: club)")
    p.add_argument("--solver", default="nlp", choices=("nlp", "nlp-shot", "dls", "ccd"), help="IK solver (default: nlp)")
    p.add_argument("--falloff", type=float, default=None, metavar="D", help="importance falloff distance in metres (default: 0.6)")
    p.add_argument("--wrist", default="locked", choices=("locked", "swing", "ball"), help="freedom of the effector's wrist (default: locked)")
    p.add_argument("--lock", nargs="+", default=[], metavar="JOINT", help="joints to lock in the chain")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the adapted clip")
    p.add_argument("--json", default=None, metavar="REPORT.json", help="also write the report here")
    p.add_argument("--force", action="store_true", help="replace existing outputs")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    from .. import hitpoint

    out = output_path(args, args.file)
    report_path = None
    if args.json:
        report_path = output_path(argparse.Namespace(output=args.json, force=args.force), args.file)
        if report_path == out:
            raise MjmotionError("--json and -o name the same file")
    falloff = hitpoint.DEFAULT_FALLOFF if args.falloff is None else args.falloff
    m = load(args.file, args)
    result = hitpoint.adapt(
        m,
        target=None if args.target is None else np.array(args.target),
        offset=None if args.offset is None else np.array(args.offset),
        frame=args.frame,
        effector=args.effector,
        solver=args.solver,
        falloff=falloff,
        wrist=args.wrist,
        lock=tuple(args.lock),
        source_ball=None if args.source_ball is None else np.array(args.source_ball),
    )
    bvh.write(result.motion, out)
    text = json.dumps(result.report, indent=2)
    if report_path is not None:
        write_text_atomic(report_path, text + "\n")
    r = result.report
    print(
        f"wrote {out}: hit frame {r['hit_frame']} ({r['hit_rule']}; effector {r['source_effector_height_m']:.3f} m above the floor "
        f"at {r['floor_m']:.3f} m), hit error {r['hit_error_m'] * 1000:.3f} mm, "
        f"grip error {r['grip_error_m'] * 1000:.3f} mm, style_rmse {r['style_rmse']}, solver {r['solver']}"
    )
    if not r["reachable"]:
        # Best effort is written and reported (issue 5); the exit status says the request failed (issue 9).
        sys.stderr.write(f"error: {r['message']}; best effort written to {out}\n")
        return 2
    return 0
