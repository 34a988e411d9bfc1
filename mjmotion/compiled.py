"""When a compiled (Numba) kernel pays for itself end to end, and when NumPy's path is quicker.

A process pays for a Numba kernel before its first call returns: importing Numba (~0.2 s),
then loading the kernel from Numba's on-disk cache (~0.3 s), or, on a machine whose cache is
cold, compiling it (~2 s per kernel family). A kernel saves only its per-call time over the
NumPy path (for a 3.4 MB BVH file 30 ms; for a 600 × 600 registration grid 28 ms), so one call
in a fresh process, which is what a CLI verb makes, almost never earns that back
(``benchmarks/bench_compiled.py`` measures each kernel in fresh processes: NumPy, cache warm,
cache cold).

The rule every ``backend="auto"`` follows: take the compiled kernel when

* it is already loaded in this process (the start-up is paid: every later call wins), or
* the NumPy path's predicted time for this call exceeds :data:`COLD_START_S`, what the
  kernel's first call on a machine costs: then even that first call wins.

Otherwise the NumPy path runs, so no call is slower end to end than NumPy's. Each caller
predicts its NumPy time from the call's size with a speed measured by the benchmark.
"""

from __future__ import annotations

from typing import Any

#: Seconds a kernel's first call costs in a fresh process on a machine whose Numba cache is cold
#: (import + compile; ``benchmarks/bench_compiled.py`` measured 1.8–2.4 s on the 2-core machine).
COLD_START_S = 2.5


def ready(*kernels: Any) -> bool:
    """Whether every Numba dispatcher in ``kernels`` is compiled or loaded in this process."""
    return bool(kernels) and all(getattr(k, "signatures", None) for k in kernels)


def pays(numpy_seconds: float, loaded: bool) -> bool:
    """Whether a compiled kernel beats a NumPy path predicted to take ``numpy_seconds`` (see the module doc)."""
    return loaded or numpy_seconds > COLD_START_S
