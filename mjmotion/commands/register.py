"""``mjmotion register``: the registration curve of two clips (Macleod 2006, §3.1; Sako 2008, §4–5)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..caps import MAX_WINDOW
from ..errors import MjmotionError
from ..outputs import check_output, json_text, together, write_text_atomic
from . import _joint_weights as joint_weights
from ._common import add_input_options, check_suffix, extra_output, load, naming
from ._options import FPS, Given, integer, number, resample
from ._progress import steps

NAME = "register"
HELP = "timewarp and alignment curves between two clips (distance grid + minimal-cost path)"
DESCRIPTION = """Register clip B to clip A: a distance grid between all frame pairs (joint point clouds over
a window of frames, best floor rotation and translation), a minimal-cost path through it, a
strictly increasing timewarp curve and the floor alignment along it.

JSON keys: frames [nA, nB]; path [[i, j], ...]; path_cost, mean_cost (m², weighted mean squared
point distance per cell); method; timewarp [[tA, tB], ...] fractional frames, strictly increasing
in both; alignment [[theta_rad, tx_m, ty_m], ...] one per timewarp sample, the floor transform
that moves B onto A (rotate by theta about the vertical axis through the origin, then translate);
timing_s {grid, path, curve, blendability} seconds; blendability {score, threshold, blendable,
mean_cost, self_similarity [A, B]}: mean_cost over the smaller self-similarity (mean distance
between two frames of one clip), above threshold (0.9) the pair looks unblendable (Sako 2008, §7.2).

By default the path starts at the best cell of the first third of the first row or column and
ends on the last frame of either clip (--free-end): per-end (default; Kovar & Gleicher, in Sako 2008,
§4.3) takes the least-total path to each end cell, then the one of least average cost; mean the
least average cost over every path (Dinkelbach's parametric search over DP passes). --method dp
solves either exactly, as brute does by enumerating every path (within --time-limit). --loop pins
the path to both corners (looping clips, Macleod 2006) and minimises its total.

examples:
  mjmotion register walk.bvh run.bvh --json reg.json --plot grid.png
  mjmotion register 07_01.bvh 09_01.bvh --frames 4: --json reg.json
  mjmotion register a.bvh b.bvh --loop --slope-limit 3 --method greedy --json reg.json
  mjmotion register walk.bvh run.bvh --joint-weights legs.json --json reg.json
"""


def add_clip_options(p: argparse.ArgumentParser) -> None:
    """``--frames`` and ``--fps``, shared by register and blend."""
    p.add_argument(
        "--frames",
        metavar="A:B[,A:B...]",
        help="frame range of every clip (the file's frames), or one range per clip separated by commas; without one a leading T-pose is skipped",
    )
    p.add_argument("--fps", type=FPS, metavar="F", help="resample every clip to F frames per second first (0.1 to 10000)")
    add_input_options(p)
    joint_weights.add_option(p)


def load_clips(files: list[str], args: argparse.Namespace) -> list:
    """Read the clips with ``--frames``/``--fps`` applied."""
    ranges = (args.frames or "").split(",") if args.frames else [None] * len(files)
    if len(ranges) == 1 and len(files) > 1:
        ranges = ranges * len(files)
    if len(ranges) != len(files):
        raise MjmotionError(f"--frames: give one range for all clips or one per clip ({len(files)}), got {len(ranges)}")
    if args.frames and not all((r or "").strip() for r in ranges):  # ("0:5," read as "all of B"; "," as all of both)
        raise MjmotionError(f"--frames {args.frames!r}: a range is empty; expected A:B for each clip (':' for a whole clip)")
    clips = []
    for f, r in zip(files, ranges, strict=True):
        m = load(f, args, r or None)
        if args.fps is not None:
            m = resample(m, args.fps)
        clips.append(m)
    return clips


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("a", metavar="A.bvh", help="the first clip (rows of the grid)")
    p.add_argument("b", metavar="B.bvh", help="the second clip (columns)")
    p.add_argument("--json", required=True, metavar="OUT.json", help="where to write the registration")
    p.add_argument("--plot", metavar="GRID.png", help="also draw the grid (A along x, B along y; dark = similar) with the path and the curve, as PNG")
    p.add_argument(
        "--window",
        type=integer(1, MAX_WINDOW, what="an odd number of frames"),
        default=5,
        metavar="N",
        help="frames per point cloud, odd, at most the shorter clip's frames (default 5)",
    )
    p.add_argument(
        "--slope-limit",
        type=integer(0, 100, what="a number of steps"),
        metavar="W",
        help="most consecutive steps along one clip only, 0 to 100 (default: Macleod 2006, Eq. 6)",
    )
    p.add_argument("--loop", action="store_true", help="fixed corners: the path joins (0,0) and (nA-1,nB-1)")
    p.add_argument(
        "--method",
        choices=("dp", "greedy", "threshold", "brute"),
        default="dp",
        help="path search (default dp: exact for --free-end and --loop; brute: exact by enumeration, slow)",
    )
    p.add_argument(
        "--free-end",
        choices=("per-end", "mean"),
        default="per-end",
        action=Given,
        help="free-end objective of dp, threshold and brute (default per-end, see above; not with --loop)",
    )
    p.add_argument(
        "--time-limit",
        type=number(0, 86400, lo_open=True, what="a number of seconds"),
        default=60.0,
        action=Given,
        metavar="S",
        help="with --method brute: give up after S seconds (default 60)",
    )
    p.add_argument(
        "--area-threshold",
        type=number(0, 1e6, lo_open=True, what="a fraction of the largest cost"),
        default=0.35,
        action=Given,
        metavar="F",
        help="with --method threshold: cells costing more than F × the grid's largest cost are never entered "
        "(default 0.35, Sako 2008 found 0.30-0.35 best; 1 or more prunes nothing)",
    )
    p.add_argument("--curve", choices=("bspline", "discrete"), default="bspline", help="timewarp fit (default bspline)")
    p.add_argument("--force", action="store_true", help="replace outputs that exist")
    add_clip_options(p)


def run(args: argparse.Namespace) -> int:
    from .. import registration

    out = check_output(args.json, args.force, (args.a, args.b, *joint_weights.inputs(args)))  # (required)
    check_suffix(out, "--json", ".json")
    plot = extra_output(
        args.plot, "--plot", ".png", args.force, (args.a, args.b, args.json, *joint_weights.inputs(args))
    )  # (not the JSON's path either)
    if args.window < 1 or args.window % 2 == 0:
        raise MjmotionError(f"--window {args.window}: expected an odd number of frames ≥ 1 (2L+1)")
    if not 0 < args.time_limit < float("inf"):
        raise MjmotionError(f"--time-limit {args.time_limit}: expected a positive number of seconds")
    # (an option of another method was ignored: the same path came back)
    for option, method in (("time_limit", "brute"), ("area_threshold", "threshold")):
        if getattr(args, f"_{option}_given", False) and args.method != method:
            flag = "--" + option.replace("_", "-")
            raise MjmotionError(f"{flag} {getattr(args, option):g}: bounds the {method} search; give it with --method {method}")
    if getattr(args, "_free_end_given", False) and (args.loop or args.method == "greedy"):
        why = "--loop fixes both ends" if args.loop else "greedy takes the cheapest next cell and has no objective to choose"
        raise MjmotionError(f"--free-end {args.free_end}: {why}; leave it out")
    with steps("register", ("read", "register", "write")) as step:
        step("read")
        a, b = load_clips([args.a, args.b], args)
        if args.window > min(a.n_frames, b.n_frames):
            raise MjmotionError(
                f"--window {args.window}: longer than the shorter clip ({min(a.n_frames, b.n_frames)} frames); use a smaller odd window"
            )
        step("grid, path and curve" + (f" (brute force, at most {args.time_limit:g} s)" if args.method == "brute" else ""))
        try:
            pr = _register(registration, a, b, args)
        except MjmotionError as e:  # (the search's own words speak of "the grid": say whose)
            raise naming([args.a, args.b], e) from None
        step("write")
        written = _write(pr, out, plot, a.name, b.name)
    t = pr.timing_s
    assert pr.blendability is not None  # register() always scores it
    print(
        f"wrote {written}: {len(pr.path.cells)}-cell path, mean cost {pr.path.mean_cost:.4g} m², "
        f"{len(pr.curve.samples)} timewarp samples; grid {t['grid'] * 1e3:.1f} ms, path {t['path'] * 1e3:.1f} ms, "
        f"curve {t['curve'] * 1e3:.1f} ms; blendability {pr.blendability.score:.2f}"
    )
    warning = pr.blendability.warning(a.name or args.a, b.name or args.b)
    if warning:
        sys.stderr.write(f"warning: {warning}\n")
    return 0


def _register(registration, a, b, args: argparse.Namespace):
    return registration.register(
        a,
        b,
        window=args.window // 2,
        slope_limit=args.slope_limit,
        loop=args.loop,
        method=args.method,
        curve=args.curve,
        weights=joint_weights.load(args, a.skeleton),
        rule=args.free_end,
        path_options={"time_limit_s": args.time_limit}
        if args.method == "brute"
        else {"area_threshold": args.area_threshold}
        if args.method == "threshold"
        else None,
    )


def _write(pr, out: Path, plot: Path | None, name_a: str, name_b: str) -> str:
    """Write the registration's JSON (and the grid's plot); the files written, for the summary line."""
    with together():  # (the registration and its plot appear together or not at all)
        write_text_atomic(out, json_text(pr.to_json()))
        if plot is None:
            return str(out)
        from .. import plots

        a, b = name_a or "A", name_b or "B"
        plots.distance_grid(pr.grid.cost, pr.path.cells, pr.curve.samples, plot, labels=(f"frame of {a}", f"frame of {b}"), title=f"{a} / {b}")
    return f"{out} and {plot}"
