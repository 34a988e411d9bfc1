"""Whole commands as a user runs them: every verb in a fresh process, against ``import numpy`` (issue 19).

Each row is one command line run in a new Python process (what a user waits for: interpreter
start, imports, reading, work, writing). The rows are interleaved: every round runs every row
once, alternately in forward and reverse order, after one untimed warm-up round (it fills the
OS file cache and the ``.pyc`` files); the table gives the median and 90th percentile of the wall
time, the median CPU time (user + system of the child) and both medians as ratios to the
baseline ``python -c "import numpy"`` measured in the same rounds.

Peers in the same rounds: a fresh-process read of the largest shared clip (3.4 MB) by
``bvh.read`` and by the ``bvh`` package (``Bvh(text)`` plus its frames as floats: the same
numbers), and ``mjmotion info`` of it.

Goals (issue 19): ``mjmotion --help`` and ``info`` of a small clip within 2x ``import numpy``;
the fresh read of the 3.4 MB clip faster than the ``bvh`` package's; ``register`` of two
600-frame clips within 0.3 s of ``info`` of one of them. ``evaluate`` of one clip against the
same with ``scipy.signal`` imported first (it loads ``scipy.optimize`` and ``scipy.linalg`` too:
the judge's filters and ground-reaction solves once came from them and now import no SciPy).
``evaluate`` of the shared folder with ``--jobs 1`` and ``2``, now and as the package was at
:data:`FILED` (exported from git, run by the same Python and libraries: the judge then had no
ground-reaction optimisation, filters or ballistic fits). ``audit`` of the shared folder with two
workers (``bench_audit.py`` sets it against ``evaluate --jobs 2``); the studio, a server, from its
launch until its page answers over HTTP (a wrapper process starts it on a free port of 127.0.0.1
and stops it), and with ``--check``. Verbs of ``mjmotion`` without a row here are listed at the
end (add a row to ``ROWS`` for them).

    python benchmarks/bench_commands.py [--rounds 7] [--only info register ...]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from mjmotion import bvh, cli

LARGE = Path("cmu_iclone_ccrig") / "002_07.bvh"
#: The commit issue 19 measured ("today" when it was filed: the first wave's last commit); its
#: package is exported from git into the temporary folder and run by the same Python.
FILED = "c21cd76"


def export_filed(tmp: Path) -> str | None:
    """The package as of :data:`FILED` under ``tmp/filed`` (its path), or None without git or that commit."""
    dest = tmp / "filed"
    dest.mkdir()
    try:
        archive = subprocess.run(["git", "-C", str(REPO), "archive", FILED, "mjmotion"], capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    except (OSError, subprocess.CalledProcessError):
        return None
    return str(dest)


def prepare(d: Path, tmp: Path) -> dict[str, str]:
    """Inputs in ``tmp``: the registration benchmark's two 600-frame clips and a stream script."""
    import bench_registration

    a, b, _ = bench_registration.clips()
    bvh.write(a, tmp / "a600.bvh")
    bvh.write(b, tmp / "b600.bvh")
    walk = d / "cmu_asfamc_converted" / "16_15.bvh"
    script = {
        "duration": 4.0,
        "clips": {"walk": {"file": str(walk)}, "fast": {"file": str(d / "cmu_asfamc_converted" / "16_24.bvh")}},
        "locomotion": ["walk", "fast"],
        "commands": [{"time": 0, "weights": {"walk": 1}}, {"time": 1.5, "weights": {"walk": 0.5, "fast": 0.5}, "ramp": 0.8}],
    }
    (tmp / "stream.json").write_text(json.dumps(script))
    (tmp / "studio_served.py").write_text(STUDIO_SERVED)
    return {
        "small": str(d / "cmu_cgspeed_daz" / "09_01.bvh"),  # 199 kB, 43 joints
        "large": str(d / LARGE),
        "walk": str(walk),
        "swing": str(d / "cmu_asfamc_converted" / "64_01.bvh"),
        "a600": str(tmp / "a600.bvh"),
        "b600": str(tmp / "b600.bvh"),
        "stream": str(tmp / "stream.json"),
        "studio_served": str(tmp / "studio_served.py"),
        "studio_out": str(tmp / "studio_out"),
        "out": str(tmp / "out"),
        "folder": str(d),
        "filed": export_filed(tmp) or "",
    }


def rows(f: dict[str, str]) -> dict[str, list[str]]:
    """Row label → argv. ``mjmotion`` rows run the installed entry point's module with this Python."""
    py = sys.executable
    mj = [py, "-m", "mjmotion.cli"]
    o = f["out"]
    return {
        "python -c pass": [py, "-c", "pass"],
        "python -c 'import numpy' (baseline)": [py, "-c", "import numpy"],
        "mjmotion --help": [*mj, "--help"],
        "mjmotion info --help": [*mj, "info", "--help"],
        "info SMALL (199 kB)": [*mj, "info", f["small"]],
        "info a600 (0.76 MB)": [*mj, "info", f["a600"]],
        "info LARGE (3.4 MB)": [*mj, "info", f["large"]],
        "bvh.read LARGE (mjmotion)": [py, "-c", f"import mjmotion.bvh as b; b.read({f['large']!r})"],
        "bvh package: parse LARGE + floats": [
            py,
            "-c",
            f"import numpy as np; from bvh import Bvh; m = Bvh(open({f['large']!r}).read()); np.asarray(m.frames, dtype=float)",
        ],
        "convert walk --fps 30": [*mj, "convert", f["walk"], o + ".bvh", "--fps", "30", "--force"],
        "compile walk": [*mj, "compile", f["walk"], "-o", o + ".xml", "--force"],
        "fk walk": [*mj, "fk", f["walk"], "-o", o + ".npz", "--force"],
        "synth walk": [*mj, "synth", "walk", "-o", o + ".bvh", "--force"],
        "register a600 b600": [*mj, "register", f["a600"], f["b600"], "--json", o + ".json", "--force"],
        "blend a600 b600": [*mj, "blend", f["a600"], f["b600"], "--weights", "0.5,0.5", "-o", o + ".bvh", "--force"],
        "stream (2 walks, 4 s)": [*mj, "stream", f["stream"], "-o", o + ".bvh", "--force"],
        "hit swing (nlp)": [*mj, "hit", f["swing"], "--offset", "0", "0.1", "0.1", "-o", o + ".bvh", "--force"],
        "vary swing --scale 1.3": [*mj, "vary", f["swing"], "--scale", "1.3", "-o", o + ".bvh", "--force"],
        "evaluate walk": [*mj, "evaluate", f["walk"]],
        # The judge's filters once came from scipy.signal (butter, filtfilt, savgol_filter) and its NNLS from
        # scipy.optimize: scipy.signal's import loads both (and scipy.linalg), timed as it was paid.
        "evaluate walk + import scipy.signal": [
            py,
            "-c",
            f"import sys, scipy.signal; from mjmotion.cli import main; sys.exit(main(['evaluate', {f['walk']!r}]))",
        ],
        # issue 19.3: the whole shared folder, one process against two
        "evaluate FOLDER --jobs 1": [*mj, "evaluate", f["folder"], "--jobs", "1"],
        "evaluate FOLDER --jobs 2": [*mj, "evaluate", f["folder"], "--jobs", "2"],
        # ... and as the judge was when issue 19 was filed (its goal: today's at least 2x faster)
        **{
            f"evaluate FOLDER --jobs {j} (as filed, {FILED})": [
                py,
                "-c",
                f"import sys; sys.path.insert(0, {f['filed']!r}); from mjmotion.cli import main; sys.exit(main(['evaluate', {f['folder']!r}, '--jobs', '{j}']))",
            ]
            for j in (1, 2)
            if f["filed"]
        },
        "cleanup walk": [*mj, "cleanup", f["walk"], "-o", o + ".bvh", "--force"],
        # issue 16's verb on the shared folder (bench_audit.py sets it against evaluate --jobs 2)
        "audit FOLDER --workers 2": [*mj, "audit", f["folder"], "-o", o + "_audit", "--workers", "2", "--force"],
        # a server: from its launch until its page answers over HTTP, then stopped (a wrapper process starts it)
        "studio walk swing, until its page answers": [py, f["studio_served"], f["walk"], f["swing"], "--out", f["studio_out"]],
        "studio walk swing --check": [*mj, "studio", f["walk"], f["swing"], "--check", "--out", f["studio_out"]],
        "render walk (60 frames, 640x360)": [
            *mj,
            "render",
            f["walk"],
            "--frames",
            "0:240",
            "--width",
            "640",
            "--height",
            "360",
            "-o",
            o + ".mp4",
            "--force",
        ],
    }


#: The studio row's wrapper: starts ``mjmotion studio ARGS`` on a free port of 127.0.0.1, polls its
#: page until it answers, stops it (its wall and CPU, the wrapper's ~0.04 s start included).
STUDIO_SERVED = """\
import socket, subprocess, sys, time, urllib.request
s = socket.socket()
s.bind(("127.0.0.1", 0))
port = s.getsockname()[1]
s.close()
cmd = [sys.executable, "-m", "mjmotion.cli", "studio", *sys.argv[1:], "--port", str(port)]
p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
try:
    deadline = time.monotonic() + 120
    while True:
        if p.poll() is not None:
            sys.exit(f"studio exited ({p.returncode}): {p.stderr.read().decode()[-500:]}")
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2).read()
            break
        except OSError:
            if time.monotonic() > deadline:
                sys.exit("studio did not answer within 120 s")
            time.sleep(0.02)
finally:
    p.terminate()
    p.wait(30)
"""

#: Verbs timed elsewhere or not at all, and why (printed with the table).
NOT_TIMED = {"demo": "runs every experiment (minutes); its parts are the rows above"}


def run_once(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds of one fresh-process run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    proc = subprocess.run(argv, env=env, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({proc.returncode}): {proc.stderr[-1000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def measure(table: dict[str, list[str]], rounds: int, env: dict[str, str]) -> dict[str, tuple[list[float], list[float]]]:
    """Interleaved rounds after one warm-up round: ``label → (walls, cpus)``."""
    out: dict[str, tuple[list[float], list[float]]] = {k: ([], []) for k in table}
    labels = list(table)
    for r in range(rounds + 1):
        for label in labels if r % 2 else labels[::-1]:
            wall, cpu = run_once(table[label], env)
            if r:
                out[label][0].append(wall)
                out[label][1].append(cpu)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7, help="timed rounds (default 7)")
    ap.add_argument("--only", nargs="+", metavar="WORD", help="only rows whose label contains one of these words (and the baseline)")
    args = ap.parse_args()
    import bench_registration

    d = bench_registration.data_dir()
    if d is None:
        sys.exit("real mocap not found: set MJMOTION_DATA to the shared/mocap directory")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "MPLBACKEND": "Agg"}
    tmp = Path(tempfile.mkdtemp(prefix="bench_commands_"))
    try:
        files = prepare(d, tmp)
        table = rows(files)
        if args.only:
            table = {k: v for k, v in table.items() if "baseline" in k or any(w in k for w in args.only)}
        t0 = time.perf_counter()
        res = measure(table, args.rounds, env)
        spent = time.perf_counter() - t0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    base_label = "python -c 'import numpy' (baseline)"
    med = {k: (statistics.median(w), float(np.percentile(w, 90)), statistics.median(c)) for k, (w, c) in res.items()}
    bw, _, bc = med[base_label]
    load = os.getloadavg()
    print(
        f"fresh processes, {args.rounds} interleaved rounds after a warm-up round ({spent:.0f} s); load average {load[0]:.1f} on {os.cpu_count()} cores"
    )
    width = max(40, *(len(k) + 2 for k in med))
    print(f"{'command':<{width}}{'wall med s':>11}{'p90 s':>8}{'CPU med s':>10}{'wall/numpy':>11}{'CPU/numpy':>10}")
    for k, (w, p90, c) in med.items():
        print(f"{k:<{width}}{w:11.3f}{p90:8.3f}{c:10.3f}{w / bw:10.2f}x{c / bc:9.2f}x")
    verbs = {m.NAME for m in cli._verbs()}
    timed = {argv[3] for argv in table.values() if argv[1:3] == ["-m", "mjmotion.cli"] and len(argv) > 3 and not argv[3].startswith("-")}
    missing = sorted(verbs - timed - set(NOT_TIMED))
    for verb, why in NOT_TIMED.items():
        print(f"not timed: {verb} ({why})")
    if missing and not args.only:
        print(f"verbs without a row: {', '.join(missing)} (add one to ROWS in benchmarks/bench_commands.py)")

    def goal(label: str, ok: bool, text: str) -> None:
        print(f"goal: {label}: {'met' if ok else 'NOT met'} ({text})")

    for k in ("mjmotion --help", "info SMALL (199 kB)"):
        if k in med:
            goal(f"{k} within 2x import numpy", med[k][0] <= 2 * bw, f"{med[k][0] / bw:.2f}x wall, {med[k][2] / bc:.2f}x CPU")
    ours, peer = "bvh.read LARGE (mjmotion)", "bvh package: parse LARGE + floats"
    if ours in med and peer in med:
        goal(
            "fresh read of the 3.4 MB clip faster than the bvh package's",
            med[ours][0] < med[peer][0],
            f"{med[ours][0]:.3f} s vs {med[peer][0]:.3f} s wall: {med[peer][0] / med[ours][0]:.2f}x faster; CPU {med[peer][2] / med[ours][2]:.2f}x",
        )
    reg, info = "register a600 b600", "info a600 (0.76 MB)"
    if reg in med and info in med:
        dw, dc = med[reg][0] - med[info][0], med[reg][2] - med[info][2]
        goal("register of two 600-frame clips within 0.3 s of info of one", dw <= 0.3, f"+{dw:.3f} s wall, +{dc:.3f} s CPU")
    ev, old = "evaluate walk", "evaluate walk + import scipy.signal"
    if ev in med and old in med:
        goal(
            "evaluate of one clip without SciPy's import (the judge's own Butterworth and Savitzky-Golay filters and NNLS)",
            med[ev][0] < med[old][0],
            f"{med[old][0] / med[ev][0]:.2f}x faster wall, {med[old][2] / med[ev][2]:.2f}x CPU",
        )
    one, two = "evaluate FOLDER --jobs 1", "evaluate FOLDER --jobs 2"
    if one in med and two in med:
        goal(
            "evaluate of the shared folder faster with --jobs 2 than --jobs 1",
            med[two][0] < med[one][0],
            f"{med[one][0] / med[two][0]:.2f}x faster wall",
        )
    for j in (1, 2):
        now, then = f"evaluate FOLDER --jobs {j}", f"evaluate FOLDER --jobs {j} (as filed, {FILED})"
        if now in med and then in med:
            goal(
                f"evaluate of the shared folder --jobs {j} at least 2x faster than when issue 19 was filed",
                med[then][0] >= 2 * med[now][0],
                f"{med[then][0] / med[now][0]:.2f}x faster wall, {med[then][2] / med[now][2]:.2f}x CPU",
            )
    if not files["filed"]:
        print(f"not timed: evaluate as filed ({FILED} is not in this clone's git history)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
