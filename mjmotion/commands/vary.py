"""``mjmotion vary``: a new version of a shot along a new path through its PCA space (Hicks 2010, §3)."""

from __future__ import annotations

import argparse
import dataclasses
import itertools

from ..caps import MAX_COMPONENTS, MAX_FRAMES, check_motion_size
from ..errors import MjmotionError
from ..outputs import check_output, json_text, together, write_text_atomic
from ._common import add_input_options, check_model, check_suffix, clip_frame, load_first, output_path, parse_frames
from ._options import INNER_FRAME, Given, integer, number
from ._progress import steps

NAME = "vary"
HELP = "exaggerate, mute or abort a shot by moving along its PCA score path"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
DESCRIPTION = """Build the principal-component space of a shot (root translation and every joint's
quaternion, standardised), take the shot's own path of scores through it and change the path:
  --scale F        exaggerate (F > 1) or mute (F < 1) about the path's centre, fading to none
                   at the first and last frames (the shot keeps its start and end poses; no
                   faster than over 0.25 s), or about the centre of --segment A:B (tapered at
                   the segment's ends); what it adds is low-passed at 6 Hz, so the capture's
                   one-frame glitches stay as captured instead of being scaled with the motion
  --abort-at F     follow the shot to frame F, then head for the rest pose's scores over
                   --abort-frames N frames (default: at the shot's own pace); the rest pose is
                   the last frame unless --rest-frame says otherwise
  --scores P       an explicit path, .npy or .csv, one row per frame, one column per component
Then rebuild poses (P = (L S)^T * D + M, quaternions renormalised) and clean up the artefacts:
feet held on the source's footprints with leg IK (--feet plants: the general footskate cleanup
instead; both: one then the other), the second hand put back on the grip relative to the first
hand. --no-cleanup writes the raw reconstruction. --pcs K sets the controlled
components (default: the fewest explaining --variance of the motion, 0.9; the style error's k
uses 0.7 and is reported as style_rmse.k); components beyond K
keep the source's detail unless --no-detail (the seed's pure K-component reconstruction).
The JSON report has k, variance explained, reconstruction error by number of components,
planted_skate_mm_per_s of source, raw and cleaned variant (the judge's, against the source: docs/METRICS.md),
grip error, joint-speed ratios and pop frames.

examples:
  mjmotion vary 64_01.bvh --scale 1.3 -o big.bvh --plot big.png --json big.json
  mjmotion vary 64_01.bvh --scale 0.7 --segment 160:440 -o small.bvh
  mjmotion vary 64_01.bvh --abort-at 280 --abort-frames 90 -o abort.bvh
  mjmotion vary 64_01.bvh --scores path.npy --no-cleanup -o mine.bvh
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="the source shot, a .bvh file")
    how = p.add_mutually_exclusive_group(required=True)
    how.add_argument(
        "--scale",
        type=number(0, 10, lo_open=True, what="a positive factor"),
        metavar="F",
        help="scale the score path about its centre by F (0 < F ≤ 10)",
    )
    how.add_argument(
        "--abort-at",
        type=INNER_FRAME,
        metavar="FRAME",
        help="abandon the shot at FRAME (a file frame inside the clip, not its first or last) and return to the rest pose",
    )
    how.add_argument(
        "--scores",
        metavar="PATH",
        help="an explicit score path (.npy or .csv, frames × components)",
    )
    p.add_argument(
        "--abort-frames",
        type=integer(1, MAX_FRAMES, what="a number of frames"),
        metavar="N",
        help="frames from the abort to the rest pose (the whole variant at most 1,000,000 frames)",
    )
    p.add_argument(
        "--rest-frame",
        type=integer(-MAX_FRAMES, MAX_FRAMES - 1, what="a frame index"),
        default=None,
        metavar="F",
        help="the rest pose's frame within the clip, negative from the end (default: the last)",
    )
    p.add_argument(
        "--pcs", type=integer(1, MAX_COMPONENTS, what="a number of components"), metavar="K", help="number of controlled principal components"
    )
    p.add_argument(
        "--variance",
        type=number(0, 1, lo_open=True, what="a fraction of the variance"),
        default=0.9,
        metavar="V",
        help="variance fraction that picks K when --pcs is not given (default 0.9)",
    )
    p.add_argument(
        "--segment",
        metavar="A:B",
        help="with --scale: scale only this frame range (tapered ends)",
    )
    p.add_argument(
        "--no-cleanup",
        action="store_true",
        help="write the raw reconstruction (no foot or grip repair)",
    )
    p.add_argument(
        "--feet",
        choices=("source", "plants", "both"),
        default="source",
        help="foot repair: hold the source's footprints (default), the footskate cleanup's plants, or both",
    )
    p.add_argument(
        "--no-detail",
        action="store_true",
        help="drop the components beyond K (the seed's pure reconstruction)",
    )
    p.add_argument(
        "--first-hand",
        choices=("auto", "left", "right", "none"),
        default="auto",
        help="the hand the second one is held to (auto: the club's hand when a club is fitted, else left; none: no grip repair)",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the variant to write")
    p.add_argument(
        "--plot",
        metavar="OUT.png",
        help="plot the source and variant score paths (PNG)",
    )
    p.add_argument(
        "--plot-dims",
        type=int,
        action=Given,
        choices=(2, 3),
        default=2,
        help="components in the plot (with --plot; default 2)",
    )
    p.add_argument("--json", metavar="REPORT.json", help="write the report as JSON")
    p.add_argument("--force", action="store_true", help="replace outputs that exist")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    from .. import bvh, plots, variations
    from ..style import PoseSpace, reconstruction_errors

    inputs = [args.file] + ([args.scores] if args.scores else [])
    out = output_path(args, *inputs, suffix=".bvh")
    extra = [x for x in (args.plot, args.json) if x]
    for x in extra:
        check_output(x, force=args.force, inputs=[*inputs, str(out)])
    if len(set(map(str, [out, *extra]))) != 1 + len(extra):
        raise MjmotionError("-o, --plot and --json must name different files")
    if args.plot:  # before any work: a late refusal would leave -o written
        check_suffix(args.plot, "--plot", ".png")
    elif getattr(args, "_plot_dims_given", False):
        raise MjmotionError(f"--plot-dims {args.plot_dims}: the components --plot draws; give --plot OUT.png too, or leave --plot-dims out")
    if args.json:
        check_suffix(args.json, "--json", ".json")
    if args.segment and args.scale is None:
        raise MjmotionError("--segment goes with --scale")
    if args.abort_frames is not None and args.abort_at is None:
        raise MjmotionError("--abort-frames goes with --abort-at")
    if args.rest_frame is not None and args.abort_at is None:
        raise MjmotionError("--rest-frame goes with --abort-at")
    if args.scores and args.pcs is not None:
        raise MjmotionError("--pcs is set by the number of columns of --scores; drop --pcs")

    names = ["read", "pose space", "synthesise", *([] if args.no_cleanup else ["clean up"]), "write", "measure", *(["plot"] if args.plot else [])]
    with steps("vary", names) as step:
        step("read")
        source, first = load_first(args.file, args)
        check_model(source, args.file)
        step("pose space")
        # inner-joint translations (some rigs animate them) are parameters too, so nothing is lost
        space = PoseSpace.fit(source, translations=True)
        if args.scores:
            scores = variations.read_scores(args.scores)
            cols = scores.shape[1] if scores.ndim == 2 else 1
            if cols > space.n_components:
                raise MjmotionError(f"{args.scores}: {cols} columns of scores; this clip's pose space has {space.n_components} components")
            path = variations.explicit_path(space, scores, detail=not args.no_detail)
        else:
            if args.pcs is not None and args.pcs > space.n_components:
                raise MjmotionError(
                    f"--pcs {args.pcs}: this clip's pose space has {space.n_components} components; expected 1 to {space.n_components}"
                )
            k = args.pcs if args.pcs is not None else space.components_for(args.variance)
            base = variations.source_path(space, k, detail=not args.no_detail)
            if args.scale is not None:
                seg = None
                if args.segment:
                    a, b, _ = parse_frames(args.segment, source.n_frames + first, "--segment").indices(source.n_frames + first)  # file frames
                    seg = (max(a - first, 0), b - first)
                    if seg[1] <= seg[0]:
                        raise MjmotionError(
                            f"--segment {args.segment}: inside the skipped leading T-pose/transition (frames 0-{first - 1}); add --keep-start"
                        )
                    if seg[1] - seg[0] < 3:  # (scaled_path's own check counts from the clip as read)
                        raise MjmotionError(f"--segment {args.segment}: selects {seg[1] - seg[0]} frame(s); expected at least 3")
                path = variations.scaled_path(base, args.scale, seg, fps=source.fps)
            else:
                n_out = args.abort_at + 1 + (args.abort_frames or 0)
                check_motion_size(n_out, source.skeleton.n_joints, f"--abort-at {args.abort_at} --abort-frames {args.abort_frames}")
                path = variations.aborted_path(
                    base,
                    clip_frame(
                        args.abort_at, first, "--abort-at", source.n_frames, inner=True, why="; the shot is followed up to it, then heads for rest"
                    ),
                    args.abort_frames,
                    -1 if args.rest_frame is None else clip_frame(args.rest_frame, first, "--rest-frame", source.n_frames),
                    source.fps,
                    space=space,
                )
                if first:  # its label counts from the clip as read; the user's frame is the file's
                    path = dataclasses.replace(path, label=f"abort at {args.abort_at}")
        k = path.k
        if args.plot and k < args.plot_dims:  # (before anything is written: the plot came last)
            given = f"--plot-dims {args.plot_dims}" if getattr(args, "_plot_dims_given", False) else f"--plot {args.plot}"
            raise MjmotionError(
                f"{given}: this variation has {k} principal component(s) to draw" + ("; use --plot-dims 2" if k >= 2 else "; a plot needs 2")
            )

        step("synthesise")
        raw = variations.synthesise(space, path)
        hand = variations.first_hand_for(source) if args.first_hand == "auto" else args.first_hand
        hand = None if hand == "none" else hand
        if args.no_cleanup:
            result, cleanup = raw, None
        else:
            step("clean up")
            result, cleanup = variations.clean_up(source, raw, path, first_hand=hand, feet=args.feet)
        with together():  # (a clip, its report and its plot appear together or not at all)
            step("write")
            bvh.write(result, out)

            step("measure")
            report = variations.report(source, raw, result, path, space, first_hand=hand)
            report["cleanup"] = (
                None
                if cleanup is None
                else {
                    "held_frames": cleanup.held_frames,
                    "foot_reach_error_m": cleanup.foot_reach_error_m,
                    "grip_hands": cleanup.grip_hands,
                    "grip_reach_error_m": cleanup.grip_reach_error_m,
                }
            )
            errs = reconstruction_errors(
                source,
                sorted({1, 2, 3, 5, 10, k, space.n_components} & set(range(1, space.n_components + 1))),
            )
            report["reconstruction_error_m"] = {str(kk): v for kk, v in errs.items()}
            vals = list(errs.values())
            report["reconstruction_error_falls_with_k"] = bool(all(b <= a + 1e-9 for a, b in itertools.pairwise(vals)))
            report.update(source=args.file, output=str(out))

            if args.plot:
                step("plot")
                src_path = space.source_scores
                plots.score_paths(
                    {"source": src_path, path.label: path.scores},
                    args.plot,
                    dims=args.plot_dims,
                )
            if args.json:
                write_text_atomic(args.json, json_text(report, indent=2) + "\n")

    written = ", ".join(str(x) for x in (out, args.json, args.plot) if x)
    print(f"wrote {written}: {path.label}, {result.n_frames} frames, k={k} ({100 * report['variance_explained']:.1f}% of the variance)")
    fs = report["planted_skate_mm_per_s"]
    if fs["source"] is not None:
        print(f"planted_skate_mm_per_s (against the source): source {fs['source']:.1f}, raw {_mm(fs['raw'])}, cleaned {_mm(fs['result'])}")
    wj, pops = report["worst_joint_speed_ratio"], report["pop_frames"]
    print(
        f"joints against the source (docs/METRICS.md): worst_joint_speed_ratio raw {wj['raw']['ratio']:.2f} ({wj['raw']['joint']}), "
        f"cleaned {wj['result']['ratio']:.2f} ({wj['result']['joint']}); pop_frames source {pops['source']}, raw {pops['raw']}, "
        f"cleaned {pops['result']}"
    )
    if report.get("grip_error_m") is not None:
        g = report["grip_error_m"]
        print(f"grip error: raw {1000 * g['raw']:.1f} mm, cleaned {1000 * g['result']:.1f} mm")
    print(
        "reconstruction error falls with k: "
        + ("yes" if report["reconstruction_error_falls_with_k"] else "NO")
        + " "
        + ", ".join(f"k={kk}: {1000 * v:.1f} mm" for kk, v in errs.items())
    )
    return 0


def _mm(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.1f}"
