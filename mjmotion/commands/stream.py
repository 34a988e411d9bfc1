"""``mjmotion stream``: run a motion-stream script (locomotion blends, transitions) to one BVH."""

from __future__ import annotations

import argparse
import sys

from ..errors import MjmotionError
from ..outputs import json_text, together, write_text_atomic
from . import _joint_weights as joint_weights
from ._common import add_input_options, extra_output, load, output_path
from ._progress import steps

NAME = "stream"
HELP = "play a script of timed commands (blend weights, transitions to clips and back) into a BVH"
DESCRIPTION = """Run a motion-stream script (Macleod 2006, §3.3): a registered locomotion set blended with weights
that ramp on command, looped as long as needed, with transitions into other clips (a kick, a
punch) and back. The script is JSON; clip paths are relative to it:

  {"duration": 8.0,
   "clips": {"walk": {"file": "16_15.bvh"}, "fast": {"file": "16_24.bvh"},
             "kick": {"file": "10_01.bvh", "frames": "500:720"}},
   "locomotion": ["walk", "fast"],
   "commands": [{"time": 0, "weights": {"walk": 1}},
                {"time": 1.5, "weights": {"walk": 0.5, "fast": 0.5}, "ramp": 0.8},
                {"time": 3.5, "play": "kick", "blend": 0.3},
                {"time": 4.0, "weights": {"walk": 1}, "ramp": 0.5}]}

Optional: "fps" (default the first locomotion clip's), "loop_blend" seconds (0.4); a command
{"time": t, "return": true, "blend": b} ends a played clip early (it needs a play before it).

A blend is seconds of the first locomotion clip (the reference): fading from or back to a faster
mix takes longer, by the mix's pace relative to the reference (Macleod 2006, §3.3), and the played
clip's clock runs between the mix's pace and its own over the fade. --json writes, per played
clip, its start, fade-in, fade-out start, fade-out and end (frames and seconds), the nominal fades
(blend x fps) and the paces (rate_in, rate_out); and the locomotion's blendability.

examples:
  mjmotion stream kick_stream.json -o stream.bvh
  mjmotion stream kick_stream.json -o stream.bvh --json transitions.json
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("script", metavar="SCRIPT.json", help="the stream script")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the streamed clip")
    p.add_argument("--json", metavar="R.json", help="also write every transition's timing (see above)")
    p.add_argument("--force", action="store_true", help="replace outputs that exist")
    add_input_options(p)
    joint_weights.add_option(p)


def run(args: argparse.Namespace) -> int:
    from .. import bvh, stream
    from ..registration.grid import GridTooLarge

    out = output_path(args, args.script, *joint_weights.inputs(args), suffix=".bvh")

    def load_clip(path: str, frames: str | None, field: str):
        return load(path, args, frames, frames_option=field)

    report = extra_output(args.json, "--json", ".json", args.force, (args.script, *joint_weights.inputs(args)))
    if report is not None and report == out:
        raise MjmotionError("--json and -o name the same file")
    with steps("stream", ("read", "register", "stream", "write")) as step:
        step("read")
        script = stream.load_script(args.script, load_clip)
        step("register")
        try:
            controller = stream.MotionStream(script, joint_weights.load(args, script.clips[script.locomotion[0]].skeleton))
        except GridTooLarge as e:  # (its remedy names register's options)
            raise MjmotionError(
                f"{args.script}: registering its locomotion clips at {script.fps:g} fps needs a {e.cells:,}-cell grid, above the "
                f'{e.max_cells:,}-cell limit; lower the script\'s "fps" at least {e.factor}× or give the clips shorter "frames"'
            ) from None
        step("stream")
        result = controller.run(name=out.stem)
        registration = controller.registration
        blends = {script.locomotion[k]: b for k, b in enumerate(registration.blendability) if b is not None}
        step("write")
        with together():  # (the clip and its report appear together or not at all)
            bvh.write(result, out)
            if report is not None:
                data = {
                    "fps": script.fps,
                    "frames": result.n_frames,
                    "transitions": [t.to_json(script.fps) for t in controller.transitions],
                    "blendability": {name: b.to_json() for name, b in blends.items()},
                }
                write_text_atomic(report, json_text(data, indent=1))
    for name, b in blends.items():
        warning = b.warning(script.locomotion[registration.reference], name)
        if warning:
            sys.stderr.write(f"warning: {warning}\n")
    print(f"wrote {out}: {result.n_frames} frames at {result.fps:g} fps from {len(script.commands)} commands")
    if report is not None:
        print(f"wrote {report}: {len(controller.transitions)} transition(s)")
    return 0
