"""``mjmotion demo``: the README's main job."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..errors import MjmotionError
from ..inputs import find_bvh
from ..outputs import check_folder

NAME = "demo"
HELP = "run a short version of every experiment with plots and videos (bundled clips, or --data DIR)"
DESCRIPTION = """Run a short version of every experiment and write tables, plots and videos.

By default on the bundled procedural clips (no mocap needed); with --data on real mocap
(the shared CMU clips). Results go to results/demo/ (summary.md links everything); a results
folder that exists and is not empty is refused unless --force (its files are then replaced).
Takes about 40 s on a lightly loaded 2-core machine (measured with `time mjmotion demo`: 36 s
wall and 49 s of CPU; 28 s wall and 38 s of CPU with --no-video) and longer on a busy one (90 s
at load average 7). Progress goes to stderr.

examples:
  mjmotion demo
  mjmotion demo --data "$MJMOTION_DATA" -o results/demo_real
  mjmotion demo --only physics_audit path_search --no-video
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..demo import EXPERIMENTS

    p.add_argument("--data", metavar="DIR", help="real mocap directory (the shared CMU clips) instead of the bundled clips")
    p.add_argument("-o", "--output", "--out", dest="out", default="results/demo", metavar="DIR", help="output folder (default: results/demo)")
    p.add_argument("--force", action="store_true", help="write into DIR even if it holds results (replacing them)")
    p.add_argument("--only", nargs="+", metavar="NAME", choices=EXPERIMENTS, help=f"run only these experiments ({', '.join(EXPERIMENTS)})")
    p.add_argument("--no-video", action="store_true", help="skip the videos")


def run(args: argparse.Namespace) -> int:
    from .. import demo

    data = None
    if args.data:
        data = Path(args.data)
        if not data.is_dir():
            raise MjmotionError(f"--data {args.data}: not a directory")
        if not find_bvh(data):  # before any work or folder is made
            raise MjmotionError(f"--data {args.data}: no .bvh files in it; expected the shared CMU clips (its flavour folders)")
    out = Path(args.out)
    if data is not None:  # results never go among the user's clips (realpath: a link loop is no error here)
        o, dd = Path(os.path.realpath(out)), Path(os.path.realpath(data))
        if o.is_relative_to(dd) or dd.is_relative_to(o):
            where = "inside" if o.is_relative_to(dd) else "holds"
            raise MjmotionError(f"-o {args.out}: {where} --data {args.data}; choose an output folder apart from the mocap folder")
    check_folder(out, "-o")  # before the first experiment runs (a file in the way is refused here too)
    if out.is_dir() and any(out.iterdir()) and not args.force:
        raise MjmotionError(f"-o {args.out}: the folder exists and holds files; pass --force to replace its results, or choose another folder")
    names = tuple(args.only) if args.only else demo.EXPERIMENTS
    path = demo.run(out, data, videos=not args.no_video, names=names)
    from collections import Counter

    files = sorted(p for p in out.rglob("*") if p.is_file())
    kinds = ", ".join(f"{n} {ext}" for ext, n in sorted(Counter(p.suffix.lstrip(".") or "other" for p in files).items()))
    print(f"wrote {path} and {len(files) - 1} more files under {out} ({kinds}; summary.md links each)")
    return 0
