"""Linear vs registered blending of walks and runs, and discrete vs B-spline timewarp (seed 004 §5.3–5.4, Table 5).

    python experiments/timewarp_blend.py [--data DIR] [--out results/timewarp_blend] [--quick]

Without --data the real mocap is MJMOTION_DATA or ../shared/mocap; --bundled uses the procedural
clips of mjmotion.synth instead (what `mjmotion demo` runs).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from mjmotion.errors import MjmotionError
from mjmotion.experiments import data_dir, timewarp_blend


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="mocap directory (default: MJMOTION_DATA or ../shared/mocap)")
    p.add_argument("--bundled", action="store_true", help="use the bundled procedural clips instead of real mocap")
    p.add_argument("--out", default="results/timewarp_blend", help="output folder (default: results/timewarp_blend)")
    p.add_argument("--quick", action="store_true", help="the short version the demo runs")
    args = p.parse_args()
    start = time.perf_counter()
    try:
        table = timewarp_blend.run(Path(args.out), None if args.bundled else data_dir(args.data), quick=args.quick)
    except MjmotionError as e:
        sys.exit(f"error: {e}")
    print(table.markdown())
    print(f"wrote {Path(args.out) / 'table.md'} and {len(table.files)} more file(s) to {args.out}/ in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
