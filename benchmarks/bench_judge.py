"""The judge's hand-written numerics against SciPy, on the inputs ``evaluate`` gives them.

The judge imports no SciPy (``tests/test_cli.py::test_the_judge_loads_no_scipy``; a fresh
``evaluate`` of one clip saves the 0.3-0.5 s import of ``scipy.optimize``, ``scipy.linalg`` and
``scipy.signal``; the fresh-process row is in ``bench_commands.py``). What it runs instead, and
what it replaces:

- the ground-reaction feasibility solves: :func:`mjmotion.nnls.solve` (batched Lawson-Hanson,
  every frame of a clip at once) against ``scipy.optimize.nnls`` called frame by frame;
- the Butterworth passes of :func:`mjmotion.filters.lowpass` (an FFT convolution with the impulse
  response for a few columns, blocked matrix products for many) against the same ``lowpass`` with each
  pass run by ``scipy.signal.lfilter`` from the steady state of the first sample (what
  ``filtfilt`` does): the same padding, only the passes differ.

Inputs: every call the judge makes while evaluating the shared clips (recorded once, then
replayed), rounds interleaved; the table gives the median over rounds of the time of all calls,
the ratio, and the largest difference between the answers.

    python benchmarks/bench_judge.py [--rounds 7]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mjmotion import filters, nnls


def record(data: Path) -> tuple[list, list]:
    """The ``nnls.solve`` and ``filters.lowpass`` calls of ``mjmotion evaluate DATA --jobs 1``."""
    from mjmotion import feet, physics
    from mjmotion.cli import main

    solves, passes = [], []
    solve, lowpass = nnls.solve, filters.lowpass

    def rec_solve(a, b, allowed=None, max_iter=None):
        solves.append((a, b, allowed))
        return solve(a, b, allowed, max_iter)

    def rec_lowpass(x, fps, cutoff_hz, axis=0):
        passes.append((np.asarray(x), fps, cutoff_hz, axis))
        return lowpass(x, fps, cutoff_hz, axis)

    nnls.solve, filters.lowpass, physics.lowpass, feet.lowpass = rec_solve, rec_lowpass, rec_lowpass, rec_lowpass
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            main(["evaluate", str(data), "--jobs", "1"])
    finally:
        nnls.solve, filters.lowpass, physics.lowpass, feet.lowpass = solve, lowpass, lowpass, lowpass
    return solves, passes


def scipy_nnls(calls):
    from scipy.optimize import nnls as one

    return [np.array([one(a[i][:, al[i]], b[i])[1] if al[i].any() else np.linalg.norm(b[i]) for i in range(len(a))]) for a, b, al in calls]


def ours_nnls(calls):
    return [nnls.solve(a, b, al).residual for a, b, al in calls]


def scipy_lowpass(calls):
    from scipy.signal import lfilter, lfilter_zi

    def scipy_pass(b, a, x):
        flat = x.reshape(x.shape[0], -1)
        return lfilter(b, a, flat, axis=0, zi=lfilter_zi(b, a)[:, None] * flat[0])[0].reshape(x.shape)

    ours = filters._iir_pass
    filters._iir_pass = scipy_pass
    try:
        return ours_lowpass(calls)
    finally:
        filters._iir_pass = ours


def ours_lowpass(calls):
    return [filters.lowpass(x, fps, cut, axis) for x, fps, cut, axis in calls]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rounds", type=int, default=7, help="timed rounds (default 7)")
    args = p.parse_args()
    data = Path(os.environ.get("MJMOTION_DATA", Path(__file__).resolve().parents[2] / "shared" / "mocap"))
    if not data.is_dir():
        print(f"no shared clips at {data} (set MJMOTION_DATA)")
        return 0
    solves, passes = record(data)
    pairs = {
        "ground-reaction NNLS": (ours_nnls, scipy_nnls, solves, f"{len(solves)} calls, {sum(len(a) for a, _, _ in solves)} frames"),
        "Butterworth low-pass": (ours_lowpass, scipy_lowpass, passes, f"{len(passes)} calls, {sum(x.size for x, *_ in passes) / 1e6:.1f} M values"),
    }
    print(f"the judge's calls while evaluating {data} ({args.rounds} interleaved rounds, median of each round's total)")
    print(f"{'work':24} {'inputs':30} {'ours s':>8} {'SciPy s':>8} {'SciPy/ours':>11} {'max |diff|':>11}")
    for label, (ours, theirs, calls, what) in pairs.items():
        t_ours, t_theirs = [], []
        for r in range(args.rounds + 1):
            for f, acc in ((ours, t_ours), (theirs, t_theirs)) if r % 2 == 0 else ((theirs, t_theirs), (ours, t_ours)):
                start = time.perf_counter()
                f(calls)
                if r:  # the first round warms caches and imports
                    acc.append(time.perf_counter() - start)
        diff = max(float(np.abs(np.asarray(u) - np.asarray(v)).max(initial=0.0)) for u, v in zip(ours(calls), theirs(calls)))
        mo, mt = statistics.median(t_ours), statistics.median(t_theirs)
        print(f"{label:24} {what:30} {mo:8.3f} {mt:8.3f} {mt / mo:10.2f}x {diff:11.1e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
