"""Physics audit of every shared clip and every synthesized result (issue 8; METRICS.md).

    python experiments/physics_audit.py [--data DIR] [--out results/physics_audit] [--quick]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from mjmotion.experiments import data_dir, physics_audit


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="mocap directory (default: MJMOTION_DATA or ../shared/mocap)")
    p.add_argument("--out", default="results/physics_audit", help="output folder")
    p.add_argument("--quick", action="store_true", help="a short version (a sample of clips)")
    args = p.parse_args()
    start = time.perf_counter()
    table = physics_audit.run(Path(args.out), data_dir(args.data), quick=args.quick)
    print(table.markdown())
    print(f"wrote {Path(args.out) / 'table.md'} in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
