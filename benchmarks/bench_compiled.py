"""Compiled (Numba) kernels against their NumPy paths end to end, in fresh processes (issue 19).

For each kernel family — the BVH reader (``mjmotion/_fast.py``: values and rotations) and the
registration DP (``registration.paths``) — and a few call sizes, one fresh Python process per
run does the imports, the first call and nothing else; it prints its own seconds from just before
the work's imports to the end of the call (so interpreter and NumPy start-up, the same for all,
are left out). Paths, run interleaved (alternating order each round):

- NumPy: the NumPy path forced;
- compiled, cache warm: the Numba kernel, its cache filled by an untimed run first;
- compiled, cache cold: the Numba kernel with an empty ``NUMBA_CACHE_DIR`` (the first call on
  a machine: it compiles), one run per size;
- auto: what ``mjmotion`` chooses (:mod:`mjmotion.compiled`).

Then the speeds the rule uses to predict NumPy's time (``bvh.NUMPY_SECONDS_PER_BYTE``,
``paths.NUMPY_SECONDS_PER_CELL``) and its cold-start constant (``compiled.COLD_START_S``) next to
the values measured here, and per size whether "auto" took the path that was fastest including
the first call on a machine (goal: always).

    python benchmarks/bench_compiled.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mjmotion import bvh, compiled
from mjmotion.registration import paths

BVH_CODE = """
import time, sys
t = time.perf_counter()
import mjmotion.bvh as b
mode = {mode!r}
if mode == "numpy":
    b.FAST_MIN_BYTES = 1 << 62
elif mode == "numba":
    import mjmotion.compiled as c
    b.FAST_MIN_BYTES, c.COLD_START_S = 0, 0.0
data = open({path!r}, "rb").read()
m = b.parse(data, "x")
took = "numba" if "mjmotion._fast" in sys.modules else "numpy"  # imported only by the compiled path
print(time.perf_counter() - t, took if mode == "auto" else mode)
"""

DP_CODE = """
import time, sys
import numpy as np
c = np.random.default_rng(0).random(({n}, {n}))
t = time.perf_counter()
from mjmotion.registration import paths
p = paths.dp_path(c, paths.SlopeLimit(2, 2), backend={mode!r})
took = "numba" if paths._dp_tables_numba.cache_info().currsize else "numpy"
print(time.perf_counter() - t, took)
"""


def fresh(code: str, env: dict[str, str]) -> tuple[float, str]:
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=REPO, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(out.stderr[-2000:])
    secs, took = out.stdout.split()
    return float(secs), took


def big_bvh(src: Path, factor: int, tmp: Path) -> Path:
    """``src`` with its motion repeated ``factor`` times (a longer clip of the same skeleton)."""
    text = src.read_text()
    head, body = text.split("Frame Time:", 1)
    ft, values = body.split("\n", 1)
    lines = [ln for ln in values.splitlines() if ln.strip()]
    head = head.replace(f"Frames: {len(lines)}", f"Frames: {len(lines) * factor}")
    out = tmp / f"{src.stem}_x{factor}.bvh"
    out.write_text(head + "Frame Time:" + ft + "\n" + "\n".join(lines * factor) + "\n")
    return out


def family(name: str, cases: list[tuple[str, str]], make, rounds: int, env: dict[str, str], tmp: Path) -> list[tuple[str, dict]]:
    """``cases``: (label, argument for ``make``); ``make(arg, mode)`` → the code of one run."""
    results = []
    for label, arg in cases:
        warm_dir = tempfile.mkdtemp(dir=tmp)
        warm_env = {**env, "NUMBA_CACHE_DIR": warm_dir}
        fresh(make(arg, "numba"), warm_env)  # fills the warm cache (untimed)
        runs: dict[str, list[float]] = {"numpy": [], "numba warm": [], "auto": []}
        took = ""
        for r in range(rounds):
            items = [("numpy", make(arg, "numpy"), env), ("numba warm", make(arg, "numba"), warm_env), ("auto", make(arg, "auto"), warm_env)]
            for key, code, e in items if r % 2 else items[::-1]:
                secs, t = fresh(code, e)
                runs[key].append(secs)
                if key == "auto":
                    took = t
        cold, _ = fresh(make(arg, "numba"), {**env, "NUMBA_CACHE_DIR": tempfile.mkdtemp(dir=tmp)})
        med = {k: statistics.median(v) for k, v in runs.items()}
        med["numba cold"] = cold
        med["took"] = took
        results.append((label, med))
    print(f"{name}: seconds from the imports to the end of the first call, fresh process, median of {rounds} (cold: 1 run)")
    print(f"  {'size':<28}{'NumPy':>8}{'warm':>8}{'cold':>8}{'auto':>8}  auto took   best incl. first call   ok")
    for label, m in results:
        # "best including the first call": NumPy vs the compiled kernel's first call on a machine
        best = "numpy" if m["numpy"] <= m["numba cold"] else "numba"
        print(
            f"  {label:<28}{m['numpy']:8.3f}{m['numba warm']:8.3f}{m['numba cold']:8.3f}{m['auto']:8.3f}  {m['took']:<10} {best:<23} "
            f"{'yes' if m['took'] == best else 'NO'}"
        )
    return results


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    env_dir = os.environ.get("MJMOTION_DATA")
    d = Path(env_dir) if env_dir else REPO.parent / "shared" / "mocap"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        large = d / "cmu_iclone_ccrig" / "002_07.bvh"
        x10 = big_bvh(large, 10, tmp)
        size_big = x10.stat().st_size
        bvh_cases = [(f"{p.name} ({p.stat().st_size / 1e6:.1f} MB)", str(p)) for p in (d / "cmu_cgspeed_daz" / "05_01.bvh", large, x10)]
        res_b = family("BVH read (bvh.parse)", bvh_cases, lambda p, mode: BVH_CODE.format(path=p, mode=mode), args.rounds, env, tmp)
        dp_cases = [(f"{n} x {n} grid ({n * n / 1e6:.2f} M cells)", str(n)) for n in (600, 2000)]
        res_d = family("registration DP (dp_path)", dp_cases, lambda n, mode: DP_CODE.format(n=n, mode=mode), args.rounds, env, tmp)
    # the rule's constants against this run; speeds as marginal costs between sizes (start-up cancels)
    (_, m_small), (lab, m), (_, m_big) = res_b
    size = large.stat().st_size
    (_, md_small), (lab_d, md) = res_d
    per_byte = (m_big["numpy"] - m["numpy"]) / (size_big - size)
    per_cell = (md["numpy"] - md_small["numpy"]) / (2000**2 - 600**2)
    print("rule constants (mjmotion.compiled) against this run:")
    print(f"  COLD_START_S = {compiled.COLD_START_S} s; measured first call on a cold cache minus NumPy's: "
          f"BVH {m['numba cold'] - m['numpy']:.2f} s ({lab}), DP {md['numba cold'] - md['numpy']:.2f} s ({lab_d})")  # fmt: skip
    print(f"  bvh.NUMPY_SECONDS_PER_BYTE = {bvh.NUMPY_SECONDS_PER_BYTE:.1e}; measured (3.4 → 33.5 MB) {per_byte:.1e} s/byte")
    print(f"  paths.NUMPY_SECONDS_PER_CELL = {paths.NUMPY_SECONDS_PER_CELL:.1e}; measured (600² → 2000²) {per_cell:.1e} s/cell; "
          f"so Numba from {paths.NUMBA_MIN_CELLS:,} cells in a fresh process")  # fmt: skip
    ok = all(m["took"] == ("numpy" if m["numpy"] <= m["numba cold"] else "numba") for _, m in res_b + res_d)
    print(f"goal: 'auto' takes the path that wins end to end, first call on a machine included: {'met' if ok else 'NOT met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
