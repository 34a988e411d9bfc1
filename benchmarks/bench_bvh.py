"""BVH reading and writing speed against the PyPI peers, from one run (issue 2's benchmark).

Reads the largest shared clip (``cmu_iclone_ccrig/002_07.bvh``, found through ``MJMOTION_DATA``
or ``../shared/mocap``) with

- mjmotion: ``bvh.read`` — parse, validate, and convert to unit quaternions in the Z-up world,
  in a process that has loaded the compiled kernels (``mjmotion/_fast.py``; a fresh process
  takes the NumPy path unless a file is huge, see ``mjmotion/compiled.py``); also timed: the
  same read forced onto the NumPy path;
- mjmotion's like-for-like stage: text to a validated ``(T, C)`` float array (no rotations);
- ``bvh`` (PyPI): ``Bvh(text)`` plus every channel value as a float, ``np.asarray(frames, float)``
  (what a user needs: the package keeps values as strings; this is its fastest path — checked to
  give exactly mjmotion's numbers), and through its own ``frames_joint_channels`` API for every
  joint (one run, about a minute; ``--no-bvh-api`` skips it);
- ``bvhio`` (PyPI), if it installs: ``readAsBvh(path)`` (joints with per-frame poses);

and prints the times and the ratios (goal: mjmotion ≥ 20× faster than ``bvh``). Then the cost
of the first read in a fresh process (``python -c "import mjmotion.bvh as b; b.read(f)"``, wall
and CPU seconds, minus the bare import): with Numba's cache cold (a fresh ``NUMBA_CACHE_DIR``:
compiling, once per machine), with it warm, and on the NumPy path. Then the writer: ``bvh.write``
time, and the round trip ``read(write(read(f)))`` checked by forward kinematics against
``read(f)`` (max joint position difference relative to the stature; must be < 1e-6).

Usage: ``python benchmarks/bench_bvh.py [--file PATH] [--repeat N] [--no-bvh-api]``. Times are
medians of N runs (peers: of ``min(N, 3)`` runs, they are slow), in CPU seconds: the machine
is shared, so ratios are what to compare.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mjmotion import bvh, compiled, kinematics

CLIP = Path("cmu_iclone_ccrig") / "002_07.bvh"


def find_clip() -> Path:
    env = os.environ.get("MJMOTION_DATA")
    root = Path(env) if env else REPO.parent / "shared" / "mocap"
    path = root / CLIP
    if not path.is_file():
        raise SystemExit(f"error: {path} not found; set MJMOTION_DATA to the shared mocap folder")
    return path


def median_time(fn, repeat: int) -> tuple[float, float, object]:
    """Median wall and median CPU (process) seconds over ``repeat`` runs, and the last result.

    CPU time is what the ratios use: the machine is shared (load often above its 2 cores), and
    process time is far less disturbed by other jobs than wall time.
    """
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        cpus.append(time.process_time() - c0)
        walls.append(time.perf_counter() - w0)
    return statistics.median(walls), statistics.median(cpus), out


def values_only(path: Path) -> np.ndarray:
    """mjmotion's like-for-like stage: text to a validated (T, C) float array, no rotations.

    Uses the reader's internal steps (this is a benchmark, not an API): the compiled path when
    ``bvh.read`` would take it, else the NumPy path.
    """
    data = path.read_bytes()
    fast = bvh._parse_values_fast(data, str(path))
    if fast is not None:
        return fast[2]
    lines = bvh._decode(data, str(path)).split("\n")
    nodes, motion_line = bvh._parse_hierarchy(lines, str(path))
    frames, _, first = bvh._parse_motion_header(lines, motion_line, str(path))
    n_channels = sum(len(n.channels or ()) for n in nodes if not n.is_end)
    return bvh._parse_values(lines, first, n_channels, frames, str(path))


def read_numpy_path(path: Path):
    """``bvh.read`` forced onto the NumPy path (what files below ``FAST_MIN_BYTES`` take)."""
    saved = bvh.FAST_MIN_BYTES
    bvh.FAST_MIN_BYTES = 1 << 62
    try:
        return bvh.read(path)
    finally:
        bvh.FAST_MIN_BYTES = saved


def fresh_process(code: str, env: dict[str, str] | None = None) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -c code`` in a new process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, env={**os.environ, **(env or {})}, cwd=REPO)
    wall = time.perf_counter() - w0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def cold_start(path: Path, runs: int = 5) -> None:
    """First read in a fresh process: Numba cache cold / warm, NumPy path; minus the bare import."""
    read = f"import mjmotion.bvh as b, mjmotion.compiled as c; c.COLD_START_S = 0.0; b.read({str(path)!r})"  # compiled, forced
    numpy_read = f"import mjmotion.bvh as b; b.FAST_MIN_BYTES = 1 << 62; b.read({str(path)!r})"

    def med(code: str, env=None) -> tuple[float, float]:
        times = [fresh_process(code, env) for _ in range(runs)]
        return statistics.median(t[0] for t in times), statistics.median(t[1] for t in times)

    imp_w, imp_c = med("import mjmotion.bvh")
    with tempfile.TemporaryDirectory() as cache:
        env = {"NUMBA_CACHE_DIR": cache}
        compile_w, compile_c = fresh_process(read, env)  # compiles and fills the fresh cache (one run)
        warm_w, warm_c = med(read, env)
    np_w, np_c = med(numpy_read)
    print(f"fresh process, 'import mjmotion.bvh' alone: {imp_w:.2f} s wall, {imp_c:.2f} s CPU (median of {runs}); "
          "then the first read of the clip costs")  # fmt: skip
    rows = [
        ("compiled path, Numba cache cold (compiles; once per machine)", compile_w, compile_c),
        ("compiled path, Numba cache warm (every later process)", warm_w, warm_c),
        ("NumPy path (what a fresh process takes: mjmotion.compiled)", np_w, np_c),
    ]
    for label, w, c in rows:
        print(f"  {label:<66}{w - imp_w:+6.2f} s wall {c - imp_c:+6.2f} s CPU")


def read_bvh_package_api(path: Path) -> list:
    """Every channel of every joint through the package's own API (``frames_joint_channels``)."""
    from bvh import Bvh

    with open(path) as fh:
        mocap = Bvh(fh.read())
    return [mocap.frames_joint_channels(j, mocap.joint_channels(j)) for j in mocap.get_joints_names()]


def read_with_bvh_package(path: Path) -> np.ndarray:
    from bvh import Bvh

    with open(path) as fh:
        mocap = Bvh(fh.read())
    return np.asarray(mocap.frames, dtype=float)


def read_with_bvhio(path: Path):
    import bvhio

    return bvhio.readAsBvh(str(path))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", type=Path, help="a BVH file (default: the largest shared clip)")
    ap.add_argument("--repeat", type=int, default=15, help="runs per reader (the median is kept)")
    ap.add_argument("--no-bvh-api", action="store_true", help="skip timing bvh's frames_joint_channels API (about a minute)")
    args = ap.parse_args()
    path = args.file or find_clip()
    size_mb = path.stat().st_size / 1e6

    # Load (or compile) the kernels once, not timed: from then on this process's bvh.read takes
    # the compiled path (mjmotion.compiled: kernels loaded). A fresh process takes the NumPy path.
    saved = compiled.COLD_START_S
    compiled.COLD_START_S = 0.0
    bvh.read(path)
    compiled.COLD_START_S = saved
    w_ours, t_ours, motion = median_time(lambda: bvh.read(path), args.repeat)
    w_vals, t_vals, values = median_time(lambda: values_only(path), args.repeat)
    w_np, t_np, motion_np = median_time(lambda: read_numpy_path(path), max(3, args.repeat // 3))
    same = np.array_equal(motion.rotations, motion_np.rotations) and np.array_equal(motion.root_positions, motion_np.root_positions)
    s = motion.skeleton
    took_compiled = bvh._parse_values_fast(path.read_bytes(), str(path)) is not None
    print(f"file: {path} ({size_mb:.2f} MB, {motion.n_frames} frames, {s.n_joints} joints, {s.n_channels} channels)")
    print(f"bvh.read takes the {'compiled' if took_compiled else 'NumPy'} path here (kernels loaded); "
          f"compiled and NumPy paths give {'identical floats' if same else 'DIFFERENT floats'}")  # fmt: skip
    print("times: median of runs, CPU seconds (wall in brackets); ratios from CPU time")
    header = f"{'reader':<50}{'CPU s':>8}{'(wall s)':>10}{'MB/s':>8}{'vs bvh.read':>13}{'vs values':>11}"
    print(header)

    def row(label: str, cpu: float, wall: float) -> None:
        print(f"{label:<50}{cpu:8.4f}{f'({wall:.4f})':>10}{size_mb / cpu:8.1f}{cpu / t_ours:12.1f}x{cpu / t_vals:10.1f}x")

    row("mjmotion bvh.read (validated, to quaternions)", t_ours, w_ours)
    row("mjmotion text to validated float array", t_vals, w_vals)
    row("mjmotion bvh.read forced onto the NumPy path", t_np, w_np)

    peer_repeat = max(1, min(args.repeat, 3))
    ratios = {}
    try:
        w_bvh, t_bvh, peer = median_time(lambda: read_with_bvh_package(path), peer_repeat)
        assert peer.shape == values.shape, (peer.shape, values.shape)
        assert np.array_equal(peer, values), "bvh and mjmotion read different numbers"
        ratios["bvh"] = t_bvh / t_ours
        ratios["bvh_values"] = t_bvh / t_vals
        row("bvh 0.3: Bvh(text) + np.asarray(frames, float)", t_bvh, w_bvh)
        if not args.no_bvh_api:
            w_api, t_api, _ = median_time(lambda: read_bvh_package_api(path), 1)
            ratios["bvh_api"] = t_api / t_ours
            row("bvh 0.3: frames_joint_channels, every joint (1 run)", t_api, w_api)
    except ImportError as e:
        print(f"bvh (PyPI) not installed: {e}; pip install bvh")
    try:
        import bvhio  # noqa: F401

        w_io, t_io, container = median_time(lambda: read_with_bvhio(path), peer_repeat)
        assert container.FrameCount == motion.n_frames
        ratios["bvhio"] = t_io / t_ours
        row("bvhio 1.5: readAsBvh (per-joint poses)", t_io, w_io)
    except ImportError as e:
        print(f"bvhio not available ({e}); 'pip install bvhio' failed or was not run")

    if "bvh" in ratios:
        goal = "met" if ratios["bvh"] >= 20 else "NOT met"
        print(
            f"goal: bvh.read >= 20x faster than bvh's fastest path: {goal} ({ratios['bvh']:.1f}x; "
            f"like for like, text to floats: {ratios['bvh_values']:.1f}x"
            + (f"; through bvh's API: {ratios['bvh_api']:.0f}x" if "bvh_api" in ratios else "")
            + (f"; vs bvhio: {ratios['bvhio']:.1f}x" if "bvhio" in ratios else "")
            + ")"
        )
    cold_start(path)

    # Writer and round trip.
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "again.bvh"
        _, t_fmt, text = median_time(lambda: bvh.format_motion(motion), max(3, args.repeat // 3))
        w_write, t_write, _ = median_time(lambda: bvh.write(motion, out), max(3, args.repeat // 3))
        written_mb = out.stat().st_size / 1e6
        again = bvh.read(out)
    print(f"writer: format_motion {t_fmt:.4f} CPU s, write (atomic, to disk) {t_write:.4f} CPU s "
          f"({w_write:.4f} wall), {written_mb:.2f} MB at {written_mb / t_write:.1f} MB/s; "
          f"reading is {t_write / t_ours:.1f}x faster than writing")  # fmt: skip
    a = kinematics.joint_positions(motion)
    b = kinematics.joint_positions(again)
    rel = float(np.abs(a - b).max()) / s.stature()
    kept = again.skeleton.names == s.names and again.skeleton.channels == s.channels and again.fps == motion.fps
    print(f"round trip read(write(read(f))): FK max error {rel:.2e} of stature "
          f"({'ok' if rel < 1e-6 else 'TOO LARGE'}); names, channel orders and fps {'kept' if kept else 'CHANGED'}")  # fmt: skip
    return 0 if rel < 1e-6 and kept and same else 1


if __name__ == "__main__":
    raise SystemExit(main())
