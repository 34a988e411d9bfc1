"""Hit-point grid: solvers × wrist × 3×3 targets on the golf swings and kicks (seed 003 §2.5, Table 2.1, Fig. 2.6; issue 8).

    python experiments/hitpoint_grid.py [--data DIR] [--out results/hitpoint_grid] [--quick] [--jobs N]
"""

from __future__ import annotations

import os

# Small matrices in two worker processes: one BLAS thread each (set before NumPy loads).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import time
from pathlib import Path

from mjmotion.experiments import data_dir, hitpoint_grid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="mocap directory (default: MJMOTION_DATA or ../shared/mocap)")
    p.add_argument("--out", default="results/hitpoint_grid", help="output folder")
    p.add_argument("--quick", action="store_true", help="a short version (one clip, DLS, the ±10 cm grid)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    args = p.parse_args()
    start = time.perf_counter()
    table = hitpoint_grid.run(Path(args.out), data_dir(args.data), quick=args.quick, jobs=args.jobs)
    print(table.markdown())
    print(f"wrote {Path(args.out) / 'table.md'} in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
