"""A motion stream with weight ramps, kicks and returns (seed 000 §3.3): continuity metrics and the time-blip check (§4.1).

    python experiments/transitions.py [--data DIR] [--out results/transitions] [--quick]

Without --data the real mocap is MJMOTION_DATA or ../shared/mocap; --bundled uses the procedural
clips of mjmotion.synth instead (what `mjmotion demo` runs).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from mjmotion.errors import MjmotionError
from mjmotion.experiments import data_dir, transitions


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="mocap directory (default: MJMOTION_DATA or ../shared/mocap)")
    p.add_argument("--bundled", action="store_true", help="use the bundled procedural clips instead of real mocap")
    p.add_argument("--out", default="results/transitions", help="output folder (default: results/transitions)")
    p.add_argument("--quick", action="store_true", help="the short version the demo runs")
    args = p.parse_args()
    start = time.perf_counter()
    try:
        table = transitions.run(Path(args.out), None if args.bundled else data_dir(args.data), quick=args.quick)
    except MjmotionError as e:
        sys.exit(f"error: {e}")
    print(table.markdown())
    print(f"wrote {Path(args.out) / 'table.md'} and {len(table.files)} more file(s) to {args.out}/ in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
