"""``mjmotion cleanup``: remove footskate (Kovar, Schreiner & Gleicher 2002)."""

from __future__ import annotations

import argparse
import json
import math

from .. import bvh
from ..outputs import check_output, write_text_atomic
from ._common import add_input_options, load, output_path
from ._options import CONTACT_HEIGHT, CONTACT_SPEED, number
from .evaluate import _finite, _nan_to_none

NAME = "cleanup"
HELP = "remove footskate: pin foot plants, two-bone leg IK, root adjustment, smooth blending"
DESCRIPTION = """Find foot plants (METRICS contact: foot within --h-c of the floor at two adjacent frames and
slower than --v-c), pin each plant's ankle and foot orientation, solve the legs with analytic
two-bone IK (bone lengths unchanged), lower/move the root where a leg cannot reach, and blend
every adjustment in and out over --blend seconds. METRICS' skate_mm_per_s counts any foot
moving within --h-c of the floor, planted or swinging, so a foot that moves faster than --v-c
that low outside a plant is lifted to --clearance (default --h-c; --clearance 0 keeps swings as
captured); a plant's foot rises in place over its last frames before it swings. Only hips,
knees, ankles and the root change, and only near plants or where a foot is lifted. Prints
footskate and penetration before and after.

examples:
  mjmotion cleanup blend.bvh -o blend_clean.bvh
  mjmotion cleanup blend.bvh -o blend_clean.bvh --json cleanup_report.json --force
  mjmotion cleanup walk.bvh -o walk_clean.bvh --clearance 0     # pin plants only; swings as captured
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="a .bvh file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the cleaned clip")
    p.add_argument("--json", metavar="REPORT.json", help="write the plants and before/after metrics")
    p.add_argument("--force", action="store_true", help="replace outputs that exist")
    p.add_argument("--h-c", type=CONTACT_HEIGHT, default=0.05, metavar="M", help="contact height, at most 1 m (default 0.05 m)")
    p.add_argument("--v-c", type=CONTACT_SPEED, default=0.5, metavar="M/S", help="contact speed, at most 100 m/s (default 0.5 m/s)")
    p.add_argument(
        "--blend", type=number(0, 10, what="a time in seconds"), default=0.2, metavar="S", help="blend-in/out time, at most 10 s (default 0.2 s)"
    )
    p.add_argument(
        "--clearance",
        type=number(0, 1, what="a height in metres"),
        default=None,
        metavar="M",
        help="lift a foot moving faster than --v-c to this height outside plants, at most 1 m (default: --h-c; 0 keeps swings as captured)",
    )
    add_input_options(p)


def _metrics(c, motion, params) -> dict[str, float]:
    """Footskate and penetration of ``motion`` under ``c`` (its skeleton's compiled model)."""
    from .. import evaluate as ev
    from .. import kinematics

    pose = kinematics.forward(c, motion)
    tr = ev.foot_heights_speeds(c, motion, pose)
    g = ev.ground_metrics(ev.lowest_body_point(c, pose), tr, params.h_c, params.v_c)
    return {
        "skate_mm_per_s": ev.skate_mm_per_s(tr, params.h_c),
        "planted_skate_mm_per_s": ev.planted_skate_mm_per_s(tr, params.h_c, params.v_c),
        "skating_ratio": ev.skating_ratio(tr, params.h_c, params.v_c),
        "penetrate_mm": g.penetrate_mm,
        "max_penetrate_mm": g.max_penetrate_mm,
    }


def run(args: argparse.Namespace) -> int:
    from .. import cleanup as cl
    from .. import evaluate as ev
    from .. import mjcf

    _finite(args.h_c, "--h-c", "a contact height in metres")
    _finite(args.v_c, "--v-c", "a contact speed in m/s")
    _finite(args.blend, "--blend", "a blend time in seconds", strict=False)
    if args.clearance is not None:
        _finite(args.clearance, "--clearance", "a height in metres", strict=False)
    out = output_path(args, args.file)
    rep_path = check_output(args.json, force=args.force, inputs=(args.file, str(out))) if args.json else None
    m = load(args.file, args)
    params = cl.CleanupParams(h_c=args.h_c, v_c=args.v_c, blend=args.blend, clearance=args.clearance)
    res = cl.cleanup(m, params)
    # The cleaned clip keeps the source's skeleton (cleanup changes rotations and the root): one model for both.
    c = mjcf.compile(m.skeleton)
    c_after = c if res.motion.skeleton is m.skeleton else mjcf.compile(res.motion.skeleton)
    before, after = _metrics(c, m, params), _metrics(c_after, res.motion, params)
    speed_ratio = ev.max_joint_speed_ratio(res.motion, m)
    bvh.write(res.motion, out)
    info = res.to_dict()
    print(
        f"wrote {out}: {len(res.plants)} plants, {int(res.changed_frames.sum())}/{m.n_frames} frames changed, "
        f"root moved ≤ {res.max_root_shift_m * 1000:.1f} mm, {info['lifted_frames']} swing frames lifted ≤ {info['max_lift_m'] * 1000:.1f} mm"
    )
    print(f"{'metric':24s} {'before':>10s} {'after':>10s}")
    for k in before:
        b, a = before[k], after[k]
        print(f"{k:24s} {_f(b):>10s} {_f(a):>10s}")
    print(f"{'max_joint_speed_ratio':24s} {'':>10s} {speed_ratio:10.3f}")
    print(
        f"parameters: h_c={params.h_c} m, v_c={params.v_c} m/s, blend={params.blend} s, "
        f"clearance={params.swing_clearance} m, min plant={params.min_plant} s, gap closed ≤ {params.max_gap} s"
    )
    if rep_path is not None:
        doc = dict(input=args.file, output=str(out), before=before, after=after, max_joint_speed_ratio=speed_ratio, **info)
        write_text_atomic(rep_path, json.dumps(_nan_to_none(doc), indent=1, default=float, allow_nan=False))
        print(f"wrote {rep_path}")
    return 0


def _f(v: float) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.2f}"
