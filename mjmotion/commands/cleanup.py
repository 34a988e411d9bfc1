"""``mjmotion cleanup``: remove footskate (Kovar, Schreiner & Gleicher 2002)."""

from __future__ import annotations

import argparse
import math

from ..errors import MjmotionError
from ..outputs import json_text, together, write_text_atomic
from ._common import add_input_options, extra_output, load, naming, output_path
from ._options import CONTACT_HEIGHT, CONTACT_SPEED, number
from .evaluate import _finite, add_judge_options, check_floor, load_sources

NAME = "cleanup"
HELP = "remove footskate: hold foot plants on the floor, two-bone leg IK, root adjustment, smooth blending"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
DESCRIPTION = """Find foot plants with the judge's contact labels (docs/METRICS.md: sole within --h-c of the
floor and slower than --v-c, with hysteresis), hold the point each plant touches the floor with
still while the foot turns as captured (low-passed at 6 Hz, so a one-frame jerk of the body does
not jerk the held foot), raise a plant that stands below the floor onto it (by the median depth
of its lowest sole point over the plant), lift any foot still in the floor, solve the legs with
analytic two-bone IK (bone lengths unchanged; a leg held past its reach slows to its limit rather
than snapping straight), move the root where a leg cannot reach (by at most 10 % of the leg's
length: past that the foot stops short and slides), and ease every adjustment in
and out (--blend seconds) so no joint pops. Only hips, knees, ankles, toes and the root change,
and only near plants.

The floor is --floor METRES, else that of the --source clip(s) the input was made from (the clips
of a blend; repeatable), else the input's own stance floor; at most a quarter of the leg above the
input's own stance floor (plants are raised onto it by bending the legs). --source clips also calibrate the
feet, and the report gives worst_joint_speed_ratio and pop_frames against them (against the
input without them). Lifting swing feet clear of the floor is an option (--clearance M), off by
default. Prints footskate, ground and pops before and after, as `mjmotion evaluate --source`
reads them.

examples:
  mjmotion cleanup blend.bvh -o blend_clean.bvh --source walk.bvh --source run.bvh
  mjmotion cleanup walk.bvh -o walk_clean.bvh --json cleanup_report.json --force
  mjmotion cleanup walk.bvh -o walk_clean.bvh --floor 0 --clearance 0.05   # and lift swings to 5 cm
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="a .bvh file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the cleaned clip")
    p.add_argument("--json", metavar="REPORT.json", help="write the plants and before/after metrics")
    p.add_argument("--force", action="store_true", help="replace outputs that exist")
    p.add_argument("--h-c", type=CONTACT_HEIGHT, default=0.05, metavar="M", help="contact height, at most 1 m (default 0.05 m)")
    p.add_argument("--v-c", type=CONTACT_SPEED, default=0.5, metavar="M/S", help="contact speed, at most 100 m/s (default 0.5 m/s)")
    p.add_argument(
        "--blend",
        type=number(0, 10, what="a time in seconds"),
        default=0.2,
        metavar="S",
        help="blend-in/out time, at most 10 s (default 0.2 s); a plant held far from the capture fades longer (0.1 m/s, up to 1 s)",
    )
    p.add_argument(
        "--clearance",
        type=number(0, 1, what="a height in metres"),
        default=0.0,
        metavar="M",
        help="lift a foot moving faster than --v-c within M of the floor outside plants up to M, at most 1 m (default 0: swings stay as captured)",
    )
    p.add_argument("--hold-orientation", action="store_true", help="hold each plant's foot at one orientation (stiller feet, knee pops at toe-off)")
    add_judge_options(p)
    add_input_options(p)


def _metrics(motion, sources, floor, params) -> dict[str, float]:
    """What the judge says of ``motion`` against ``sources`` (the floor given or theirs)."""
    from .. import evaluate as ev

    r = ev.evaluate(motion, params=ev.Params(h_c=params.h_c, v_c=params.v_c, hysteresis=params.hysteresis), sources=sources, floor=floor)
    return {
        "planted_skate_mm_per_s": r.planted_skate_mm_per_s,
        "skate_mm_per_s": r.skate_mm_per_s,
        "skating_ratio": r.skating_ratio,
        "penetrate_mm": r.penetrate_mm,
        "max_penetrate_mm": r.max_penetrate_mm,
        "float_mm": r.float_mm,
        "physics_violation_ratio": r.physics_violation_ratio,
        "pop_frames": float(r.pop_frames),
        "worst_joint_speed_ratio": float("nan") if r.worst_joint_speed_ratio is None else r.worst_joint_speed_ratio,
        "max_joint_speed_ratio": float("nan") if r.max_joint_speed_ratio is None else r.max_joint_speed_ratio,
    }


def run(args: argparse.Namespace) -> int:
    from .. import bvh
    from .. import cleanup as cl
    from .. import evaluate as ev

    _finite(args.h_c, "--h-c", "a contact height in metres")
    _finite(args.v_c, "--v-c", "a contact speed in m/s")
    _finite(args.blend, "--blend", "a blend time in seconds", strict=False)
    _finite(args.clearance, "--clearance", "a height in metres", strict=False)
    check_floor(args)
    out = output_path(args, args.file, *args.source, suffix=".bvh")
    rep_path = extra_output(args.json, "--json", ".json", args.force, (args.file, str(out), *args.source))
    m = load(args.file, args)
    try:
        ev.require_frames(m.n_frames)  # the table judges it before and after
    except MjmotionError as e:
        raise naming(args.file, e) from None
    sources = load_sources(args, args.file, m, what="the input") if args.source else []  # leading T-poses cut like the input's, as evaluate cuts them
    params = cl.CleanupParams(
        h_c=args.h_c, v_c=args.v_c, blend=args.blend, clearance=args.clearance, floor=args.floor, hold_orientation=args.hold_orientation
    )
    try:
        res = cl.cleanup(m, params, sources=sources)
        # Judged as `evaluate --source` judges: against the sources (or the input itself), which give the
        # floor the cleanup used, levelled as it was (a floor passed as given is never levelled: the table
        # read a cleaned blend on a 1.1° floor 2.1 mm into it where the judge reads 0).
        refs = sources or [m]
        before = _metrics(m, refs if sources else [m.replace()], args.floor, params)
        after = _metrics(res.motion, refs, args.floor, params)
    except cl.FloorTooHighError as e:
        if e.from_ == "given" and args.floor is not None:
            raise MjmotionError(f"--floor {args.floor:g}: {e.why}") from None
        raise MjmotionError(f"--source {', '.join(args.source)}: their floor ({e.height:.3f} m) is {e.why}") from None
    except MjmotionError as e:
        raise naming(args.file, e) from None
    info = res.to_dict()
    with together():  # (the clip and its report appear together or not at all)
        bvh.write(res.motion, out)
        if rep_path is not None:
            doc = dict(input=args.file, output=str(out), sources=list(args.source), before=before, after=after, **info)
            write_text_atomic(rep_path, json_text(doc, indent=1))
    print(
        f"wrote {out}: {len(res.plants)} plants ({info['raised_plants']} raised onto the floor), "
        f"{int(res.changed_frames.sum())}/{m.n_frames} frames changed, root moved ≤ {res.max_root_shift_m * 1000:.1f} mm"
        + (f", {info['lifted_frames']} swing frames lifted ≤ {float(res.lift.max()) * 1000:.1f} mm" if params.swing_clearance > 0 else "")
    )
    print(
        f"floor {res.floor.text()}"
        + (f", levelled from a {res.floor.level.tilt_deg:.1f}° tilt (the result stands on the tilted floor)" if not res.floor.level.flat else "")
        + f"; judged against {'the ' + str(len(sources)) + ' source(s)' if sources else 'the input'}"
    )
    print(f"{'metric':24s} {'before':>10s} {'after':>10s}")
    for k in before:
        print(f"{k:24s} {_f(before[k]):>10s} {_f(after[k]):>10s}")
    print(
        f"parameters: h_c={params.h_c} m, v_c={params.v_c} m/s, hysteresis={params.hysteresis}, blend={params.blend} s, "
        f"clearance={params.swing_clearance} m, min plant={params.min_plant} s, gap closed ≤ {params.max_gap} s (docs/METRICS.md)"
    )
    if rep_path is not None:
        print(f"wrote {rep_path}")
    return 0


def _f(v: float) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.2f}"
