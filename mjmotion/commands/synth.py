"""``mjmotion synth``: the bundled procedural clips, one at a time or the whole library."""

from __future__ import annotations

import argparse

from ..errors import MjmotionError
from ..outputs import check_folder, json_text, together, write_text_atomic
from ._common import extra_output, output_path
from ._options import integer, number
from ._progress import steps

NAME = "synth"
HELP = "generate a bundled clip (walk, run, sneak, limp, drive, pull, kick, punch) or the whole library"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
KINDS = ("walk", "run", "sneak", "limp", "drive", "pull", "kick", "punch")
DESCRIPTION = """Generate clean procedural motion on the bundled 22-joint humanoid (Y-up BVH, centimetres,
60 fps), deterministic for the same arguments. Gaits follow a footstep plan along +X from the
origin with planted feet, leaning into turns; drive and pull swing a bat in the right hand and
start and end in one batting stance; kick and punch start and end standing. Gaits, kick and
punch sway their pelvis so that the ground can carry the motion (the centre of pressure it
needs stays under the standing feet).

`synth library DIR` writes every bundled clip as DIR/NAME.bvh plus DIR/manifest.json with the
ground truth (per-foot contact frames, footprints, hit frame, sweet-spot position, the prop
and its attachment, known warps), in MuJoCo world metres (Z up).

examples:
  mjmotion synth walk -o walk.bvh
  mjmotion synth run --speed 4 --turn -20 --seconds 6 -o run.bvh --truth run.json
  mjmotion synth walk --speed 1.0 --step-length 0.5 --seed 3 -o short_steps.bvh
  mjmotion synth drive -o drive.bvh
  mjmotion synth library clips/
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("kind", choices=(*KINDS, "library"), help="what to generate")
    p.add_argument("directory", nargs="?", help="for `library`: the folder to write (created if missing)")
    p.add_argument("-o", "--output", metavar="OUT.bvh", help="the BVH file to write (not for `library`)")
    p.add_argument("--speed", type=number(0, 20, lo_open=True, what="a speed in m/s"), metavar="V", help="gaits: speed in m/s (default per gait)")
    p.add_argument(
        "--turn",
        type=number(-90, 90, what="a turning rate in degrees per second"),
        default=0.0,
        metavar="DEG_PER_S",
        help="gaits: turning rate, + to the left, at most ±90 (default 0)",
    )
    p.add_argument(
        "--seconds", type=number(0.5, 120, what="a duration in seconds"), metavar="S", help="gaits: duration, 0.5 to 120 s (default 4 s; run 3 s)"
    )
    p.add_argument(
        "--step-length",
        type=number(0, 10, lo_open=True, what="metres per step"),
        metavar="M",
        help="gaits: metres per step (default per gait, scaled with speed)",
    )
    p.add_argument(
        "--seed",
        type=integer(0, 2**32 - 1, what="a seed"),
        default=0,
        metavar="N",
        help="small deterministic variations (default 0: the nominal clip)",
    )
    p.add_argument("--truth", metavar="OUT.json", help="also write the clip's ground truth as JSON")
    p.add_argument("--force", action="store_true", help="replace existing outputs")


def run(args: argparse.Namespace) -> int:
    from .. import bvh, synth

    if args.kind == "library":
        if not args.directory:
            raise MjmotionError("synth library: give the folder to write, e.g. `mjmotion synth library clips/`")
        if args.output or args.truth or args.speed is not None or args.seconds is not None or args.turn or args.step_length is not None:
            raise MjmotionError("synth library: takes only DIR (and --force); the set is fixed")
        check_folder(args.directory)  # before the clips are made
        with steps("synth library", ("make clips", "write")) as step:
            step("make clips")
            made = synth.library()
            step("write")
            clips = synth.write_library(args.directory, force=args.force, clips=made)
        print(f"wrote {len(clips)} clips ({', '.join(f'{n}.bvh' for n in clips)}) and manifest.json to {args.directory}")
        return 0
    if args.directory:
        raise MjmotionError(f"synth {args.kind}: unexpected argument {args.directory!r}; write with -o OUT.bvh")
    if not args.output:
        raise MjmotionError(f"synth {args.kind}: give the output file with -o OUT.bvh")
    out = output_path(args, suffix=".bvh")
    truth = extra_output(args.truth, "--truth", ".json", args.force, (args.output,))
    fn, is_gait = synth.GENERATORS[args.kind]
    if is_gait:
        kw = {"turn_deg_per_s": args.turn, "seed": args.seed}
        if args.speed is not None:
            kw["speed"] = args.speed
        if args.seconds is not None:
            kw["seconds"] = args.seconds
        if args.step_length is not None:
            kw["step_length"] = args.step_length
        clip = fn(**kw)
    else:
        if args.speed is not None or args.seconds is not None or args.turn or args.step_length is not None:
            raise MjmotionError(f"synth {args.kind}: --speed, --turn, --seconds and --step-length apply to gaits only")
        clip = fn(seed=args.seed)
    with together():  # (the clip and its ground truth appear together or not at all)
        bvh.write(clip.motion, out)
        if truth is not None:
            write_text_atomic(truth, json_text(clip.to_manifest(out.name), indent=1) + "\n")
    extra = f", hit frame {clip.hit_frame}" if clip.hit_frame is not None else ""
    written = f"{out} and {truth}" if truth is not None else str(out)
    print(f"wrote {written}: {args.kind}, {clip.motion.n_frames} frames at {clip.motion.fps:g} fps{extra}")
    return 0
