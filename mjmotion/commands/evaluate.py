"""``mjmotion evaluate``: physics-checked metrics of one clip or a directory of clips."""

from __future__ import annotations

import argparse
import csv
import filecmp
import io
import math
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import MjmotionError, printable, require_number
from ..inputs import find_bvh
from ..outputs import json_text, write_text_atomic
from ._common import (
    add_bowler_option,
    add_input_options,
    check_bowler,
    check_same_file,
    extra_output,
    load,
    load_first,
    named,
    naming,
    prop_option,
    stature_note,
)
from ._options import CONTACT_HEIGHT, CONTACT_SPEED, COORD, FRAME, VELOCITY, Given, UniqueProps, integer, number

if TYPE_CHECKING:
    from ..evaluate import Report
    from ..skeleton import Motion

NAME = "evaluate"
HELP = "footskate, ground, inverse-dynamics, limit, pop and hitting metrics of a clip (or every clip in a folder)"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
DESCRIPTION = """Evaluate clips with the definitions of docs/METRICS.md (thresholds are options; the
report states them): foot contacts (with hysteresis) and planted footskate, the height-weighted
footskate and the h_c sensitivity table, ground penetration, float and PhysDiff error, MuJoCo
inverse-dynamics residuals (ground-reaction feasibility: can contact forces inside friction cones
at the feet supply the wrench the motion needs? in a flight, does the centre of mass fall as a
thrown body does?), joint-range violations, per-joint pops and, with a
ball, the hitting metrics and a simulated ball launch.

The floor every ground metric measures from is, in order: --floor METRES; the source clip(s) of a
result (--source, repeatable: the clips it was made from, same skeleton and frame rate); otherwise
the clip's own stance floor (a note is printed when it is more than 1 cm from z = 0). Unless
--floor is given, a stance floor that tilts 0.5-2 degrees (CMU subjects 07 and 08: ~1.1) is
levelled first and every metric measures the levelled clip (the floor_tilt column; floor_tilt_deg in --json). A result lifted or sunk
against its source reads as floating or penetrating only with --source. Sources
also calibrate the feet and give the per-joint speed and pop references (worst_joint_speed_ratio).

Leading T-pose/transition frames (cgspeed daz clips: 0-3) are detected and skipped (in sources too)
unless --frames or --keep-start is given.

examples:
  mjmotion evaluate walk.bvh
  mjmotion evaluate walk.bvh --json walk_report.json --csv
  mjmotion evaluate blend.bvh --source walk.bvh --source run.bvh
  mjmotion evaluate cleaned.bvh --source raw.bvh --floor 0
  mjmotion evaluate swing.bvh --prop club:rwrist --ball 0.6 0.1 0.03 --frame 212
  mjmotion evaluate drive.bvh --prop bat --ball 0.40 0.42 0.34 --frame 66 --delivery medium
  mjmotion evaluate "$MJMOTION_DATA" --json all.json
"""

_COLUMNS = (
    ("clip", 18, "s"),
    ("frames", 6, "d"),
    ("fps", 5, ".0f"),
    ("planted_mm_s", 12, ".0f"),
    ("skate_mm_s", 10, ".0f"),
    ("skating_ratio", 13, ".3f"),
    ("flight", 6, ".2f"),
    ("penetrate_mm", 12, ".1f"),
    ("float_mm", 8, ".1f"),
    ("phys_err_mm", 11, ".1f"),
    ("floor_m", 7, "+.3f"),
    ("floor_from", 10, "s"),
    ("floor_tilt", 10, ".2f"),
    ("flight_resid", 12, ".2f"),
    ("phys_viol", 9, ".2f"),
    ("limit_viol", 10, ".2f"),
    ("pops", 4, "d"),
)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("path", help="a .bvh file, or a folder (searched recursively for .bvh files)")
    p.add_argument(
        "--prop",
        action=UniqueProps,
        default=[],
        metavar="KIND[:JOINT]",
        help="attach a prop (club, bat): held by JOINT along its bone, or without :JOINT fitted to both hands as hit --prop fits it; the first is the effector",
    )
    p.add_argument(
        "--ball", nargs=3, type=COORD, metavar=("X", "Y", "Z"), help="ball centre (m, world Z-up, each within ±1000) for the hitting metrics"
    )
    p.add_argument(
        "--ball-radius",
        type=number(0.001, 1, what="a ball radius in metres"),
        default=0.036,
        action=Given,
        metavar="R",
        help="with --ball or --hit-grid: the ball's radius in m, 0.001 to 1 (default 0.036, cricket)",
    )
    p.add_argument(
        "--ball-velocity",
        nargs=3,
        type=VELOCITY,
        default=(0.0, 0.0, 0.0),
        action=Given,
        metavar=("VX", "VY", "VZ"),
        help="incoming ball velocity at impact, m/s (each within ±1000), for --ball or --hit-grid (default 0 0 0)",
    )
    p.add_argument("--frame", type=FRAME, metavar="H", help="hit frame (0-based, of the file) for --ball")
    p.add_argument(
        "--ball-release",
        nargs=3,
        type=COORD,
        metavar=("X", "Y", "Z"),
        help=f"--ball is a delivered ball released here (m, each within ±1000; Hicks 2010, §2.3.2); its path must pass within {DELIVERY_MISS:g} m of --ball",
    )
    p.add_argument("--release-velocity", nargs=3, type=VELOCITY, metavar=("VX", "VY", "VZ"), help="its release velocity (m/s, each within ±1000)")
    p.add_argument("--delivery", choices=("fast", "medium", "slow"), help="--ball is a ball delivered at it at this pace, from --bowler's end")
    add_bowler_option(p)
    p.add_argument(
        "--hit-grid",
        type=integer(2, 9, what="a grid size"),
        metavar="N",
        help="Hicks 2010, Figure 2.6: adapt the shot to an N x N grid of hit points around "
        "the sweet spot at --frame (arm IK, wrist locked vs club orientation kept), launch a ball from each and print "
        "the rank correlation of launch direction with hit point (needs --prop and --frame; N from 2 to 9)",
    )
    p.add_argument(
        "--grid-step",
        type=number(0.001, 1, what="a spacing in metres"),
        default=0.05,
        action=Given,
        metavar="M",
        help="with --hit-grid: its spacing in m, 0.001 to 1 (default 0.05; a finer grid's launches differ by nothing)",
    )
    p.add_argument("--frames", metavar="A:B", help="evaluate only these frames")
    add_judge_options(p)
    p.add_argument("--h-c", type=CONTACT_HEIGHT, default=0.05, metavar="M", help="contact height threshold, at most 1 m (default 0.05 m)")
    p.add_argument("--v-c", type=CONTACT_SPEED, default=0.5, metavar="M/S", help="contact speed threshold, at most 100 m/s (default 0.5 m/s)")
    p.add_argument("--json", metavar="OUT.json", help="write every metric (and the parameters, and each clip's notes) as JSON")
    p.add_argument("--csv", action="store_true", help="print the table as CSV instead of aligned text")
    p.add_argument("--force", action="store_true", help="replace OUT.json if it exists")
    p.add_argument(
        "--jobs",
        type=integer(1, 64, what="a number of processes"),
        default=2,
        metavar="N",
        help="parallel processes for a folder, 1 to 64 (default 2)",
    )
    add_input_options(p)


FLOOR_HELP = "the floor height (world z, m, within ±100) every ground metric measures from, level (default: from --source, else detected; a tilted stance floor is levelled first, docs/METRICS.md)"
SOURCE_HELP = (
    "a clip the input was made from (repeatable; same skeleton and frame rate, at least 1/6 s long, one period "
    "of the judge's low-pass): gives the floor, calibrates the feet, and is the reference of the per-joint speed ratio and pops"
)


def add_judge_options(p: argparse.ArgumentParser, floor_help: str = FLOOR_HELP, source_help: str = SOURCE_HELP) -> None:
    """``--floor`` and ``--source``: where the judge's floor and references come from (evaluate,
    cleanup, render: each says in its help what it uses them for)."""
    p.add_argument("--floor", type=number(-100, 100, what="a floor height in metres"), metavar="METRES", help=floor_help)
    p.add_argument("--source", action="append", default=[], metavar="SRC.bvh", help=source_help)


def check_floor(args: argparse.Namespace) -> None:
    floor = getattr(args, "floor", None)
    if floor is not None and not math.isfinite(floor):
        raise MjmotionError(f"--floor {floor:g}: expected a finite floor height in metres (world z)")


def load_sources(args: argparse.Namespace, result_path: str, result, what: str = "the result", speed_reference: bool = True) -> list:
    """The ``--source`` clips, checked against the result (``result_path``, motion ``result``):
    same skeleton and frame rate, not the result itself, long enough (``speed_reference``: as the
    joints' speed reference, :func:`mjmotion.feet.min_source_frames`; else as a floor); leading
    transients cut like the result's. ``what``: how the messages call the clip judged against them
    (``cleanup``: "the input")."""
    from ..feet import source_too_short
    from ..skeleton import same_rate

    out = []
    for src in args.source:
        if not os.path.isfile(src):
            raise MjmotionError(f"--source {src}: " + ("not a file (a .bvh clip is expected)" if os.path.exists(src) else "no such file"))
        if check_same_file(src, result_path):
            raise MjmotionError(f"--source {src}: is {what} itself ({result_path}); give the clip(s) {what} was made from")
        if filecmp.cmp(src, result_path, shallow=False):  # (judged against itself, every source-relative measure reads "no change")
            raise MjmotionError(f"--source {src}: holds the same bytes as {what} ({result_path}), a copy; give the clip(s) {what} was made from")
        try:
            m = load(src, args, note=False)  # its leading transient skipped like the result's
        except MjmotionError as e:  # named as the option it came from (it read as an error of the judged clip)
            text = str(e)
            raise MjmotionError(f"--source {text}" if text.startswith(src) else f"--source {src}: {text}") from None
        if not m.skeleton.same_topology(result.skeleton):
            raise MjmotionError(
                f"--source {src}: another skeleton ({m.skeleton.n_joints} joints, root {m.skeleton.names[0]!r}) than "
                f"{result_path} ({result.skeleton.n_joints} joints, root {result.skeleton.names[0]!r}); a source must share {what}'s skeleton"
            )
        if not same_rate(m.fps, result.fps):
            raise MjmotionError(f"--source {src}: {m.fps:g} fps, {result_path} {result.fps:g} fps; resample one first (mjmotion convert --fps)")
        if (short := source_too_short(m, speed_reference)) is not None:
            raise MjmotionError(f"--source {src}: {short}")
        out.append(m)
    return out


#: A delivered ball (--ball-release) must pass within this many metres of --ball, where it meets the bat.
DELIVERY_MISS = 0.5


def evaluate_file(path: str, opts: dict[str, Any]) -> dict[str, Any]:
    """Evaluate one file; returns ``{"file", "skipped_frames", "report", "row", "notes"}`` (runs in worker processes)."""
    motion, offset, rep = evaluate_one(path, opts)
    from ..upright import up_note

    notes = up_note(motion) + stature_note(motion, opts.get("units", "auto")) + rep.notes()
    return {"file": path, "skipped_frames": offset, "report": rep.to_dict(), "row": rep.row(), "notes": notes}


def evaluate_one(path: str, opts: dict[str, Any]) -> tuple[Motion, int, Report]:
    """The one-file evaluation ``evaluate`` and ``audit`` share: the clip as evaluated (leading
    transient or ``--frames`` cut off), the frames skipped, and its report. ``opts`` holds this
    verb's options by their ``argparse`` names."""
    import numpy as np

    from .. import evaluate as ev
    from .. import mjcf

    args = argparse.Namespace(**opts)
    m, offset = load_first(path, args, args.frames, note=False)  # the skipped frames are listed once, after the table
    if args.frames is not None and m.n_frames < ev.MIN_FRAMES:
        raise MjmotionError(f"--frames {args.frames}: {m.n_frames} frame(s) of {path}; the judge needs at least {ev.MIN_FRAMES}")
    sources = load_sources(args, path, m) if getattr(args, "source", None) else []
    props = tuple(prop_option(m, t) for t in args.prop)
    ball = None
    hit = None
    if args.ball is not None:
        if args.frame is None:
            raise MjmotionError("--ball needs --frame H (the hit frame)")
        ball = mjcf.Ball(position=tuple(args.ball), radius=args.ball_radius)
        hit = args.frame - offset
        if not 0 <= hit < m.n_frames:
            raise MjmotionError(f"--frame {args.frame}: outside the evaluated frames {offset}..{offset + m.n_frames - 1}")
    params = ev.Params(h_c=args.h_c, v_c=args.v_c)
    ball_velocity = tuple(args.ball_velocity)
    release, pace = getattr(args, "ball_release", None), getattr(args, "delivery", None)  # audit's options have no delivery
    if ball is not None and (release is not None or pace is not None):
        from .. import delivery

        # a delivered ball (released, pitching on the floor): its velocity where it passes the ball's position
        dv = (
            delivery.Delivery(tuple(args.ball_release), tuple(args.release_velocity), radius=args.ball_radius)
            if release is not None
            else delivery.aimed(np.asarray(args.ball), bowler=np.asarray(args.bowler), preset=args.delivery)
        )
        _, _, velocity, miss = delivery.fly(dv).nearest(np.asarray(args.ball))
        if miss > DELIVERY_MISS:  # its velocity there would be a ball that never came near the bat (exit 0, "contact")
            raise MjmotionError(
                f"--ball-release/--release-velocity: the delivered ball passes {miss:.2f} m from --ball at its nearest; "
                f"expected a delivery that reaches the ball (within {DELIVERY_MISS:g} m)"
            )
        ball_velocity = tuple(velocity)
    m = m.replace(name=Path(path).stem)
    return (
        m,
        offset,
        ev.evaluate(m, props, ball, hit, params, ball_velocity=ball_velocity, sources=sources, floor=getattr(args, "floor", None)),
    )


def _fmt(v: Any, spec: str) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if spec == "s":
        return printable(v)  # a clip's name comes from a file name: no raw escapes
    text = format(v, spec)
    # A value that rounds to zero prints as zero ("-0.000" read as a floor just below z = 0).
    return format(0.0, spec) if isinstance(v, float) and text.lstrip("+-").strip("0.") == "" else text


def format_table(rows: list[dict[str, Any]], as_csv: bool = False) -> str:
    """Rows as aligned text (fixed columns first, then any extra keys) or CSV."""
    keys = [c for c, _, _ in _COLUMNS]
    extra = [k for r in rows for k in r if k not in keys]
    extra = list(dict.fromkeys(extra))
    if as_csv:
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=keys + extra, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)
        return buf.getvalue()
    widths = {c: max(w, len(c)) for c, w, _ in _COLUMNS}
    specs = {c: s for c, _, s in _COLUMNS}
    for k in extra:
        widths[k] = max(len(k), 8)
        specs[k] = ".3f"
    lines = ["  ".join(k.rjust(widths[k]) if k != "clip" else k.ljust(widths[k]) for k in keys + extra)]
    for r in rows:
        cells = []
        for k in keys + extra:
            v = r.get(k)
            spec = specs[k] if not isinstance(v, (bool, str)) else "s"
            text = _fmt(v, spec)
            cells.append(text.ljust(widths[k]) if k == "clip" else text.rjust(widths[k]))
        lines.append("  ".join(cells))
    return "\n".join(lines) + "\n"


def _params_line(report: dict[str, Any]) -> str:
    p = report["params"]
    return (
        f"parameters: h_c={p['h_c']} m, v_c={p['v_c']} m/s, hysteresis={p['hysteresis']}, skating window={p['skate_window']} frames, "
        f"float tolerance={p['float_tol']} m, low-pass {p['cutoff_hz']} Hz before differentiating, mu={p['mu']}, "
        f"ground-reaction residual>{p['residual_tol']} m·g, a flight>{p['flight_tol']} g from free fall or deeper than {p['penetration_tol']} m fails, "
        f"pops: angular acceleration>{p['pop_factor']}x the reference's p{p['peak_percentile']:g} (docs/METRICS.md)"
    )


def _finite(value: float, option: str, what: str, strict: bool = True) -> None:
    """Refuse a non-finite or negative (``strict``: non-positive) option before any work."""
    require_number(option, value, strict=strict, what=what)


def check_options(args: argparse.Namespace) -> None:
    """Every numeric option checked before any clip is read (each error names its option)."""
    _finite(args.h_c, "--h-c", "a contact height in metres")
    _finite(args.v_c, "--v-c", "a contact speed in m/s")
    _finite(args.ball_radius, "--ball-radius", "a ball radius in metres")
    _finite(args.grid_step, "--grid-step", "a hit-grid spacing in metres")
    for option, values in (("--ball", args.ball), ("--ball-velocity", args.ball_velocity)):
        if values is not None and not all(math.isfinite(v) for v in values):
            raise MjmotionError(f"{option} {' '.join(f'{v:g}' for v in values)}: expected three finite numbers")
    if (args.ball_release is None) != (args.release_velocity is None):
        raise MjmotionError("--ball-release and --release-velocity go together")
    if (args.ball_release is not None or args.delivery is not None) and args.ball is None:
        raise MjmotionError("a delivered ball (--ball-release or --delivery) needs --ball X Y Z, where it meets the bat")
    if args.ball_release is not None and args.delivery is not None:
        raise MjmotionError("give --ball-release or --delivery, not both")
    if getattr(args, "_ball_velocity_given", False):
        if args.ball is None and args.hit_grid is None:
            raise MjmotionError("--ball-velocity is the velocity of --ball (or of --hit-grid's launches); give --ball X Y Z, where the ball is met")
        if args.ball_release is not None or args.delivery is not None:
            raise MjmotionError("--ball-velocity with a delivered ball: its velocity is where the delivery meets --ball; give one or the other")
    # (options of a hit that no --ball or --hit-grid asks for were ignored: the report came back the same)
    if getattr(args, "_grid_step_given", False) and args.hit_grid is None:
        raise MjmotionError(f"--grid-step {args.grid_step:g}: the spacing of --hit-grid; give --hit-grid N too, or leave it out")
    if getattr(args, "_ball_radius_given", False) and args.ball is None and args.hit_grid is None:
        raise MjmotionError(
            f"--ball-radius {args.ball_radius:g}: the radius of --ball (or --hit-grid's ball); give --ball X Y Z too, or leave it out"
        )
    if args.jobs < 1:
        raise MjmotionError(f"--jobs {args.jobs}: expected a number of processes ≥ 1")
    if args.hit_grid is not None and args.hit_grid < 2:
        raise MjmotionError(f"--hit-grid {args.hit_grid}: expected a grid size N ≥ 2 (a rank correlation needs several hit points)")
    if args.hit_grid is not None and (os.path.isdir(args.path) or not args.prop or args.frame is None):
        raise MjmotionError("--hit-grid needs one clip, --prop and --frame")
    if args.frame is not None and args.frame < 0:
        raise MjmotionError(f"--frame {args.frame}: expected a frame index ≥ 0")
    if args.frame is not None and args.ball is None and args.hit_grid is None:
        raise MjmotionError(f"--frame {args.frame}: the hit frame of --ball (or --hit-grid); give --ball X Y Z, where the ball is met")
    check_floor(args)
    check_bowler(args)
    if args.source and os.path.isdir(args.path):
        raise MjmotionError("--source applies to one result clip; give a file, not a folder")


def run(args: argparse.Namespace) -> int:
    check_options(args)
    opts = {k: v for k, v in vars(args).items() if not k.startswith("_")}
    if os.path.isdir(args.path):
        no_files: list[tuple[Path, str]] = []
        files = [str(p) for p in find_bvh(args.path, skipped=no_files)]
        for path, why in no_files:
            sys.stderr.write(f"note: {printable(path)}: {why}; not evaluated\n")
        if not files:
            raise MjmotionError(f"{args.path}: no .bvh files found (searched recursively)")
        if args.ball is not None:
            raise MjmotionError("--ball applies to one clip; give a file, not a folder")
    else:
        if not os.path.lexists(args.path):
            raise MjmotionError(f"{args.path}: no such file or folder")  # anything else: the reader says what it is
        files = [args.path]
    # Checked before any work: the report may never replace one of the clips it reads.
    out = extra_output(args.json, "--json", ".json", args.force, [*files, *args.source])
    if os.path.isdir(args.path):
        results = evaluate_files(files, opts, args.jobs)
    else:
        try:
            results = [evaluate_file(args.path, opts)]
        except MjmotionError as e:
            raise naming(args.path, e) from None
    if args.hit_grid is not None:
        grid = _hit_grid(args, opts)
        for r in results:
            r["hit_grid"] = grid
    ok = [r for r in results if "error" not in r]
    rows = [r["row"] for r in ok]
    sys.stdout.write(format_table(rows, args.csv))
    if ok and not args.csv:
        print(_params_line(ok[0]["report"]))
        skipped = [f"{printable(Path(r['file']).stem)}:{r['skipped_frames']}" for r in ok if r["skipped_frames"]]
        if skipped:
            print("leading frames skipped: " + ", ".join(skipped))
        for r in ok:
            for note in r.get("notes", ()):
                print(printable(note))
        if len(ok) == 1:
            rep = ok[0]["report"]
            print(
                "h_c sensitivity: "
                + "; ".join(
                    f"h_c={s['h_c']}: planted {_fmt(s['planted_skate_mm_per_s'], '.0f')} mm/s, weighted {_fmt(s['skate_mm_per_s'], '.0f')} mm/s, "
                    f"ratio {s['skating_ratio']:.3f}"
                    for s in rep["sensitivity"]
                )
            )
            if rep["sources"]:
                print(
                    f"against {rep['sources']} source(s): worst_joint_speed_ratio {rep['worst_joint_speed_ratio']:.2f} ({rep['worst_joint']}), "
                    f"max_joint_speed_ratio (whole body) {rep['max_joint_speed_ratio']:.2f}, root_jump_m {rep['root_jump_m']:+.4f}, "
                    f"pop_frames {rep['pop_frames']}"
                )
            if rep.get("hit"):
                print("hit: " + ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in rep["hit"].items()))
            for mode, g in (ok[0].get("hit_grid") or {}).items():
                print(
                    f"hit grid, wrist {mode}: Spearman rho(lateral, azimuth) = {g['rho_azimuth']:.3f}, "
                    f"rho(vertical, elevation) = {g['rho_elevation']:.3f}, azimuth slope {g['slope_deg_per_m']:.1f} deg/m"
                )
                for row in g["rows"]:
                    print("   " + "  ".join(f"{k}={v:8.3f}" for k, v in row.items()))
    for r in results:
        if "error" in r:
            sys.stderr.write(f"error: {printable(named(r['file'], r['error']))}\n")
    if out is not None:
        write_text_atomic(
            out,
            json_text(
                [
                    {
                        "file": r["file"],
                        "skipped_frames": r.get("skipped_frames"),
                        **({"report": r["report"]} if "report" in r else {"error": r["error"]}),
                        **({"notes": list(r["notes"])} if "report" in r else {}),  # what the table's note: lines say
                        **({"hit_grid": r["hit_grid"]} if "hit_grid" in r else {}),
                    }
                    for r in results
                ],
                indent=1,
            ),
        )
        print(f"wrote {out}")
    return 0 if len(ok) == len(results) else 2


def _hit_grid(args: argparse.Namespace, opts: dict[str, Any]) -> dict[str, Any]:
    """Seed 003 §2.3.2 on this clip: launch predictability for both wrist treatments."""
    from .. import launchgrid

    m, first = load_first(args.path, argparse.Namespace(**opts), args.frames, note=False)
    prop = prop_option(m, args.prop[0])
    frame = args.frame - first
    if not 0 <= frame < m.n_frames:
        raise MjmotionError(f"--frame {args.frame}: outside the evaluated frames {first}..{first + m.n_frames - 1}")
    offsets = launchgrid.grid_offsets(m, prop, frame, args.hit_grid, args.grid_step)
    out = {}
    for mode in ("locked", "world"):
        p = launchgrid.hit_grid(m, prop, frame, offsets, wrist=mode, ball_radius=args.ball_radius, ball_velocity=tuple(args.ball_velocity))
        out[mode] = {"rho_azimuth": p.rho_azimuth, "rho_elevation": p.rho_elevation, "slope_deg_per_m": p.slope_deg_per_m, "rows": p.rows()}
    return out


def _safe(path: str, opts: dict[str, Any]) -> dict[str, Any]:
    try:
        return evaluate_file(path, opts)
    except MjmotionError as e:
        return {"file": path, "error": str(e)}


def evaluate_files(files: list[str], opts: dict[str, Any], jobs: int) -> list[dict[str, Any]]:
    """Evaluate many files in ``jobs`` processes (:mod:`mjmotion.executor`'s process pool) with a progress
    bar on a terminal; a bad file gives ``{"file", "error"}``.

    Results come back in ``files`` order; the largest files are started first so that no worker
    is left with a long clip at the end, and the judge is imported before the workers fork, so
    each of them starts with MuJoCo and SciPy loaded.
    """
    from .. import evaluate as _judge  # noqa: F401  (loaded once, inherited by forked workers)
    from ..executor import in_order, start

    order = sorted(range(len(files)), key=lambda i: -os.path.getsize(files[i])) if jobs > 1 else list(range(len(files)))
    with start(jobs=jobs if len(files) > 1 else 1) as ex:
        # A bar on a terminal only: piped or redirected, the table is all this verb prints.
        outcomes = ex.run(_safe, [(i, (files[i], opts)) for i in order], desc="evaluate", unit="clip", progress=sys.stderr.isatty())
        return [out.unwrap() for out in in_order(outcomes, list(range(len(files))))]
