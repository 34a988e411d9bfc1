"""``mjmotion stream``: run a motion-stream script (locomotion blends, transitions) to one BVH."""

from __future__ import annotations

import argparse

from ._common import add_input_options, load, output_path

NAME = "stream"
HELP = "play a script of timed commands (blend weights, transitions to clips and back) into a BVH"
DESCRIPTION = """Run a motion-stream script (seed 000 §3.3): a registered locomotion set blended with weights
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
{"time": t, "return": true, "blend": b} ends a played clip early.

examples:
  mjmotion stream kick_stream.json -o stream.bvh
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("script", metavar="SCRIPT.json", help="the stream script")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the streamed clip")
    p.add_argument("--force", action="store_true", help="replace OUT if it exists")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    from .. import bvh, stream

    out = output_path(args, args.script)

    def load_clip(path: str, frames: str | None):
        return load(path, args, frames)

    script = stream.load_script(args.script, load_clip)
    result = stream.stream(script, name=out.stem)
    bvh.write(result, out)
    print(f"wrote {out}: {result.n_frames} frames at {result.fps:g} fps from {len(script.commands)} commands")
    return 0
