"""Whole-database audit throughput: serial, process pool, Dask LocalCluster with 1 and 2 workers (issue 16).

Builds a corpus of >= 500 BVH files in a temporary folder (never committed) from the shared clips
(``MJMOTION_DATA`` or ``../shared/mocap``): each clip as is, cut in halves and thirds, resampled to
60 and 30 fps, and mirrored (reflected across the character's side-to-side plane: a left-handed
copy), plus synthesized variants (the bundled gaits at three speeds and ten seeds, the shots and
strikes at two seeds). Then, in interleaved rounds:

- ``audit.run`` of the whole corpus on each backend of ``mjmotion.executor`` (clips/s, wall time,
  CSV + Parquet + summary included; the same rows from every backend are checked);
- the per-task overhead: 400 trivial tasks through each backend (wall time per task), and each
  backend's start and shut-down time;
- the acceptance check on the 42 shared clips: ``mjmotion audit DIR -o OUT --workers 2`` against
  ``mjmotion evaluate DIR --jobs 2``, each as a fresh process, in interleaved rounds (wall and CPU
  seconds of the command and every process it waited for: median and p90, and audit/evaluate ratios);
- a projection for the full CMU database (about 2,500 clips the size of the shared ones) on this
  machine's 2 cores and on a 64-core Dask cluster, from the measured per-clip cost (a + b·frames,
  least squares over the serial run) and the measured overheads.

Usage: ``python benchmarks/bench_audit.py [--rounds N] [--accept-rounds N] [--only scale|accept] [--quick]``
(``--quick``: a 120-file corpus, one round of each, for checking the script; ``--only accept``: just the
acceptance check). Timings on a shared 2-core machine are noisy.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mjmotion import audit, bvh, executor, synth
from mjmotion.skeleton import Motion

#: Clips of the full CMU database the projection is for.
CMU_CLIPS = 2500
#: Workers of the projected cluster.
CLUSTER_CORES = 64
TRIVIAL_TASKS = 400


def data_dir() -> Path:
    env = os.environ.get("MJMOTION_DATA")
    root = Path(env) if env else REPO.parent / "shared" / "mocap"
    if not root.is_dir():
        raise SystemExit(f"error: {root} not found; set MJMOTION_DATA to the shared mocap folder")
    return root


def mirrored(m: Motion) -> Motion:
    """The mirror image across the world's y = 0 plane (x forward, z up): positions y → −y, every
    rotation R → M R M with M = diag(1, −1, 1), i.e. quaternion (w, x, y, z) → (w, −x, y, −z)."""
    flip = np.array([1.0, -1.0, 1.0])
    skel = dataclasses.replace(m.skeleton, offsets=m.skeleton.offsets * flip, end_offsets=m.skeleton.end_offsets * flip)
    q = m.rotations * np.array([1.0, -1.0, 1.0, -1.0])
    tr = m.translations * flip if m.translations is not None else None
    return Motion(skel, m.fps, m.root_positions * flip, q, tr, name=f"{m.name}_mirrored")


def build_corpus(root: Path, quick: bool = False) -> dict[str, int]:
    """Write the corpus under ``root``; returns how many files of each kind."""
    counts: dict[str, int] = {}

    def put(kind: str, rel: str, m: Motion) -> None:
        out = root / kind / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        bvh.write(m, out)
        counts[kind] = counts.get(kind, 0) + 1

    clips = sorted(data_dir().glob("*/*.bvh"))
    if quick:
        clips = clips[::4]
    for path in clips:
        m = bvh.read(path)
        rel = f"{path.parent.name}/{path.stem}"
        put("orig", f"{rel}.bvh", m)
        n = m.n_frames
        for k in (2, 3):
            for i in range(k):
                put("cut", f"{rel}_{i + 1}of{k}.bvh", m[i * n // k : (i + 1) * n // k])
        for fps in (60.0, 30.0):
            if fps < m.fps:
                put("resampled", f"{rel}_{fps:.0f}fps.bvh", m.resample(fps))
        put("mirrored", f"{rel}_mirrored.bvh", mirrored(m))
    seeds = range(3) if quick else range(10)
    for kind, speeds in (("walk", (1.0, 1.3, 1.6)), ("run", (2.5, 3.0, 3.5)), ("sneak", (0.5, 0.7, 0.9)), ("limp", (0.6, 0.8, 1.0))):
        for v in speeds:
            for s in seeds:
                put("synth", f"{kind}_{v:.1f}_{s}.bvh", getattr(synth, kind)(speed=v, seed=s).motion)
    for kind in ("drive", "pull", "kick", "punch"):
        for s in range(2):
            put("synth", f"{kind}_{s}.bvh", getattr(synth, kind)(seed=s).motion)
    return counts


def backends() -> dict[str, dict]:
    return {"serial": {}, "process pool (2)": {"jobs": 2}, "LocalCluster (1 worker)": {"workers": 1}, "LocalCluster (2 workers)": {"workers": 2}}


def timed_start(kw: dict) -> tuple[executor.Executor, float]:
    t = time.perf_counter()
    ex = executor.start(**kw, preload=audit.PRELOAD)
    return ex, time.perf_counter() - t


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q))


def acceptance(tmp: str, rounds: int) -> None:
    """``audit --workers 2`` against ``evaluate --jobs 2`` on the shared clips: fresh processes, interleaved;
    and ``audit --resume`` of each audit's unchanged folder right after it (a fraction of the first run)."""
    cli = [sys.executable, "-m", "mjmotion.cli"]
    runs: dict[str, list[tuple[float, float]]] = {"evaluate": [], "audit": [], "resume": [], "python": [], "dask": []}
    for i in range(rounds):
        # What importing Dask costs a fresh process beyond the judge (the audit pays it; evaluate's pool does not).
        runs["python"].append(wall_and_cpu([sys.executable, "-c", "import mjmotion.evaluate"]))
        runs["dask"].append(wall_and_cpu([sys.executable, "-c", "import mjmotion.evaluate, dask, distributed"]))
        # Alternate which goes first, so neither always runs right after the other's page-cache and CPU state.
        order = ("evaluate", "audit") if i % 2 == 0 else ("audit", "evaluate")
        for name in order:
            args = (
                ["evaluate", str(data_dir()), "--jobs", "2"]
                if name == "evaluate"
                else ["audit", str(data_dir()), "-o", f"{tmp}/accept_{i}", "--workers", "2"]
            )
            runs[name].append(wall_and_cpu([*cli, *args]))
            if name == "audit":
                runs["resume"].append(wall_and_cpu([*cli, "audit", str(data_dir()), "-o", f"{tmp}/accept_{i}", "--workers", "2", "--resume"]))
    print(f"\n## The 42 shared clips, whole commands (fresh processes, {rounds} interleaved rounds)\n")
    print(f"{'command':60s} {'wall median':>11s} {'wall p90':>9s} {'CPU median':>10s} {'CPU p90':>8s}")
    stats = {}
    for name, label in (
        ("evaluate", f"mjmotion evaluate {data_dir()} --jobs 2"),
        ("audit", f"mjmotion audit {data_dir()} -o OUT --workers 2"),
        ("resume", "the same audit again with --resume (nothing changed)"),
    ):
        walls, cpus = [w for w, _ in runs[name]], [c for _, c in runs[name]]
        stats[name] = (statistics.median(walls), percentile(walls, 90), statistics.median(cpus), percentile(cpus, 90))
        print(f"{label:60s} {stats[name][0]:10.2f}s {stats[name][1]:8.2f}s {stats[name][2]:9.2f}s {stats[name][3]:7.2f}s")
    for a, b in (("audit", "evaluate"), ("resume", "audit")):
        ratios = [x / y for x, y in zip(stats[a], stats[b])]
        print(f"{a + ' / ' + b:60s} {ratios[0]:10.2f}x {ratios[1]:8.2f}x {ratios[2]:9.2f}x {ratios[3]:7.2f}x")
    per_round = [a[0] / e[0] for a, e in zip(runs["audit"], runs["evaluate"])]
    print(f"audit/evaluate wall per round: {', '.join(f'{r:.2f}' for r in per_round)} (median {statistics.median(per_round):.2f})")
    dask_import = statistics.median(d[0] - p[0] for d, p in zip(runs["dask"], runs["python"]))
    print(
        f"importing Dask beside the judge in a fresh process (python -c 'import mjmotion.evaluate, dask, distributed' minus without Dask): {dask_import:.2f} s wall"
    )


def wall_and_cpu(cmd: list[str]) -> tuple[float, float]:
    """Wall seconds of a command and CPU seconds of it and every process it waited for (its workers)."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rounds", type=int, default=1, help="interleaved rounds over the backends (default 1)")
    p.add_argument("--accept-rounds", type=int, default=7, help="interleaved rounds of the acceptance check (default 7)")
    p.add_argument("--only", choices=("scale", "accept"), help="run only the corpus measurements or only the acceptance check")
    p.add_argument("--quick", action="store_true", help="a small corpus and one round, to check the script runs")
    args = p.parse_args()
    if args.only == "accept":
        with tempfile.TemporaryDirectory(prefix="bench_audit_") as tmp:
            print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start")
            acceptance(tmp, 1 if args.quick else args.accept_rounds)
        return 0
    opts = audit.judge_options()
    with tempfile.TemporaryDirectory(prefix="bench_audit_") as tmp:
        corpus = Path(tmp) / "corpus"
        t = time.perf_counter()
        counts = build_corpus(corpus, args.quick)
        n_files = sum(counts.values())
        size = sum(p.stat().st_size for p in corpus.rglob("*.bvh"))
        print(
            f"corpus: {n_files} files, {size / 1e6:.0f} MB ({', '.join(f'{k} {v}' for k, v in counts.items())}), built in {time.perf_counter() - t:.0f} s"
        )
        print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start\n")

        runs: dict[str, list[float]] = {b: [] for b in backends()}
        starts: dict[str, list[float]] = {b: [] for b in backends()}
        closes: dict[str, list[float]] = {b: [] for b in backends()}
        per_task: dict[str, list[float]] = {b: [] for b in backends()}
        tables: dict[str, list[dict]] = {}
        for r in range(1 if args.quick else args.rounds):
            for name, kw in backends().items():
                ex, started = timed_start(kw)
                try:
                    res = audit.run(corpus, Path(tmp) / f"out_{r}_{len(tables)}", ex, opts=opts, progress=False)
                    t = time.perf_counter()
                    list(ex.run(executor.one_line, [(i, ("x",)) for i in range(TRIVIAL_TASKS)], progress=False))
                    per_task[name].append((time.perf_counter() - t) / TRIVIAL_TASKS)
                finally:
                    t = time.perf_counter()
                    ex.close()
                    closes[name].append(time.perf_counter() - t)
                starts[name].append(started)
                runs[name].append(res.seconds)
                tables[name] = res.rows
        ref = {r["path"]: r for r in tables["serial"]}
        for name, rows in tables.items():
            same = all(r.get(k) == ref[r["path"]].get(k) or r.get(k) != r.get(k) for r in rows for k in r if k != "seconds")
            assert len(rows) == n_files and same, f"{name}: its table differs from the serial one"

        print(f"## Audit of the corpus ({n_files} files; median of {len(runs['serial'])} round(s), interleaved)\n")
        print(f"{'backend':26s} {'wall s':>8s} {'clips/s':>8s} {'vs serial':>9s} {'start s':>8s} {'close s':>8s} {'ms/trivial task':>16s}")
        base = statistics.median(runs["serial"])
        for name in runs:
            w = statistics.median(runs[name])
            print(
                f"{name:26s} {w:8.1f} {n_files / w:8.2f} {base / w:8.2f}x {statistics.median(starts[name]):8.2f} "
                f"{statistics.median(closes[name]):8.2f} {1000 * statistics.median(per_task[name]):16.3f}"
            )
        # Per-clip cost on one busy core of this machine: the task times of the two-worker run (both cores in use).
        two = "LocalCluster (2 workers)"
        ok = [r for r in tables[two] if r["status"] == "ok" and r.get("seconds")]
        frames = np.array([r["frames"] for r in ok], dtype=float)
        secs = np.array([r["seconds"] for r in ok])
        a, b = np.linalg.lstsq(np.stack([np.ones_like(frames), frames], 1), secs, rcond=None)[0]
        orig = [r for r in ok if r["path"].startswith("orig/")]
        mean_frames = float(np.mean([r["frames"] for r in orig]))
        clip_s = a + b * mean_frames
        print(
            f"\nper-clip cost (task seconds in the two-worker run, least squares over {len(ok)} ok clips): "
            f"{1000 * a:.1f} ms + {1000 * b:.4f} ms/frame; {clip_s:.3f} s for a clip of {mean_frames:.0f} frames "
            f"(the mean of the {len(orig)} shared clips); tasks sum to {secs.sum():.0f} s against 2 × "
            f"{statistics.median(runs[two]):.0f} s of wall time"
        )

        if args.only != "scale":
            acceptance(tmp, 1 if args.quick else args.accept_rounds)

        # Projection for the whole CMU database from the measured cost and overheads.
        o = statistics.median(per_task[two])
        start2 = statistics.median(starts[two])
        t2 = start2 + CMU_CLIPS * (clip_s + o) / 2
        t64 = CMU_CLIPS * clip_s / CLUSTER_CORES
        sched = CMU_CLIPS * o
        print(f"\n## Projection: the full CMU database ({CMU_CLIPS} clips of {mean_frames:.0f} frames on average)\n")
        print(
            f"this machine, LocalCluster of 2 workers: {start2:.1f} s start + {CMU_CLIPS} × ({clip_s:.3f} s + "
            f"{1000 * o:.2f} ms per task) / 2 = {t2 / 60:.1f} min"
        )
        print(
            f"a {CLUSTER_CORES}-core Dask cluster (one-thread workers, each core as fast as one here): {CMU_CLIPS} × {clip_s:.3f} s / "
            f"{CLUSTER_CORES} = {t64:.0f} s of evaluation; the scheduler's per-task cost ({1000 * o:.2f} ms measured here, "
            f"{sched:.0f} s for all tasks) overlaps with it, so about {max(t64, sched) + start2:.0f} s "
            "(plus reading the files over the cluster's file system)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
