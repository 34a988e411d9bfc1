"""``mjmotion audit``: every clip of a folder through the judge on Dask, streamed, resumable."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from ..errors import MjmotionError, printable
from ._common import add_input_options
from ._options import number

NAME = "audit"
HELP = "judge every .bvh under a folder on Dask workers into one table (CSV + Parquet), resumable, with a summary"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
DESCRIPTION = """Evaluate every .bvh file under DIR (recursively; links out of DIR are not followed) with
the judge's defaults (the same one-file evaluation as 'mjmotion evaluate', so the numbers are the
same) and write to OUT_DIR:

  audit.csv      one row per file as it finishes (path, size, SHA-256, status ok/error, the error
                 message, frames, fps, skeleton flavour, every metric of the report), appended and
                 flushed row by row: a crash or Ctrl-C loses at most the clips in flight
  audit.parquet  the same table, rewritten atomically every few seconds and at the end
  summary.md     counts by flavour, the distribution of each metric (histograms.png), the clips
                 at both ends of each metric, the errors and the parameters used

Work runs on a Dask LocalCluster on this machine (--workers N, bound to 127.0.0.1) or on an existing
Dask cluster (--scheduler tcp://HOST:8786, started with 'dask scheduler' and 'dask worker'; its
workers need mjmotion installed, the same version as here, and DIR at the same path: a worker that
cannot import it, or runs another version, is refused before any clip is sent). A bad file is a
row with status=error and its message; a worker that dies is replaced by its nanny and its clips
rerun by Dask (a cluster left with no worker for 120 s, or a scheduler that goes away, ends the
audit with an error, the rows so far kept; a cluster that has had no worker yet is waited for, with
a note); a clip running longer than --timeout is an error row, and
so is a file that cannot be read and a name ending in .bvh that is no file to read (a dangling link,
a link loop, a pipe); a folder that cannot be listed is named in a note and in summary.md. Nothing in DIR is written; OUT_DIR is
locked while the audit runs (a second audit into it at once is refused). The exit status is 0 when
every file has its row, error rows included.

With --resume, rows whose file (SHA-256), judge options, sources, judge revision and mjmotion
version are unchanged are kept and not recomputed (errors that might go away -- a time limit, a
lost worker, a file that could not be read -- are retried); a file renamed, moved or copied keeps
the ok row of its bytes under its new path; a changed or new file is evaluated. When nothing is left to evaluate, no
workers are started (and no --scheduler contacted), and histograms.png is kept when what it draws is
unchanged (a digest of its values is stored in the PNG).

--source-map FILE is a JSON object from a clip's path under DIR to the clip (or list of clips) it
was made from, relative to FILE's folder: those rows add the source-relative measures
(vs_source.max_joint_speed_ratio, vs_source.root_jump_m) and a change to a source reruns them.

examples:
  mjmotion audit "$MJMOTION_DATA" -o results/audit
  mjmotion audit "$MJMOTION_DATA" -o results/audit --resume
  mjmotion audit grid/ -o results/grid_audit --source-map grid/sources.json --timeout 120
  mjmotion audit /data/cmu -o /data/cmu_audit --scheduler tcp://10.0.0.5:8786
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..executor import add_options  # here: listing the verbs (every command's start) does not load it

    p.add_argument("dir", metavar="DIR", help="folder of .bvh files (searched recursively)")
    p.add_argument("-o", "--output", required=True, metavar="OUT_DIR", help="folder for audit.csv, audit.parquet, summary.md (not inside DIR)")
    add_options(p, default="default: one per core of this machine")
    again = p.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true", help="continue an audit in OUT_DIR: keep the rows whose file and options are unchanged")
    again.add_argument("--force", action="store_true", help="start over in an existing OUT_DIR (its audit files are replaced)")
    p.add_argument("--source-map", metavar="FILE", help="JSON: clip path under DIR -> the source clip(s) it was made from")
    p.add_argument(
        "--dashboard",
        action="store_true",
        help="with --workers: run the LocalCluster's Dask dashboard on a free port of 127.0.0.1 and print its address (needs bokeh)",
    )
    p.add_argument(
        "--timeout",
        type=number(0, 1e6, lo_open=True, what="a number of seconds"),
        metavar="S",
        help="per-clip time limit in seconds: a clip still running after S is an error row",
    )
    p.add_argument(
        "--connect-timeout",
        type=number(0, 3600, lo_open=True, what="a number of seconds"),
        metavar="S",
        help="seconds to wait for --scheduler to answer (default 10)",
    )
    add_input_options(p)


def check_paths(args: argparse.Namespace) -> tuple[Path, Path, list[Path], list[tuple[Path, str]], list[str]]:
    """DIR, OUT_DIR, DIR's :func:`~mjmotion.audit.listing`, the names in it that are no file to read (each an
    error row) and the folders that cannot be listed, checked before any work (each error names the path)."""
    from ..audit import listing

    if not args.dir:  # (Path("") is the current folder)
        raise MjmotionError("DIR '': an empty path; give the folder to audit")
    root = Path(args.dir)
    if not root.is_dir():
        raise MjmotionError(f"{root}: no such folder" if not root.exists() else f"{root}: not a folder; audit takes a folder of .bvh files")
    out = Path(args.output)
    if out.is_symlink() and not out.exists():  # (a loop raised RuntimeError, a dangling link read "File exists")
        raise MjmotionError(f"-o {out}: a symbolic link to nothing (or a link loop); give a folder")
    try:
        inside = out.resolve() == root.resolve() or out.resolve().is_relative_to(root.resolve())
    except (OSError, RuntimeError) as e:
        raise MjmotionError(f"-o {out}: cannot be resolved ({e})") from None
    if inside:
        raise MjmotionError(f"-o {out}: is inside {root}; nothing is written in the audited folder, choose an output folder outside it")
    if out.exists() and not out.is_dir():
        raise MjmotionError(f"-o {out}: exists and is not a folder; an audit writes a folder of results")
    if not out.exists() and out.suffix.lower() in (".csv", ".parquet", ".md"):
        # (`-o audit.csv` made a folder of that name with audit.csv inside)
        raise MjmotionError(f"-o {out}: names a {out.suffix} file; an audit writes a folder (audit.csv, audit.parquet, summary.md), give its name")
    # Missing folders on the way are made (as `mkdir -p`, like demo's --out); one that is a file is refused.
    above = next(a for a in (out, *out.parents) if a.exists())
    if above != out and not above.is_dir():
        raise MjmotionError(f"-o {out}: {above} is not a folder")
    if out.exists() and any(out.iterdir()) and not (args.resume or args.force):
        raise MjmotionError(f"-o {out}: already exists; pass --resume to continue its audit or --force to start over")
    if args.resume and out.exists() and any(out.iterdir()) and not (out / "audit.csv").exists():
        raise MjmotionError(f"-o {out}: holds no audit.csv to resume; give an audit's folder, a new one, or --force to start an audit here")
    if args.resume and (out / "audit.csv").exists() and not (out / "audit.csv").is_file():
        raise MjmotionError(f"-o {out}: its audit.csv is not a file; use --force to start over")
    unreadable: list[str] = []
    skipped: list[tuple[Path, str]] = []
    files = listing(root, unreadable, skipped)
    if not files:
        raise MjmotionError(f"{root}: no .bvh files found (searched recursively)" + (f"; cannot list {unreadable[0]}" if unreadable else ""))
    for folder in unreadable:  # (a name's line breaks and terminal escapes written out, as in error lines)
        sys.stderr.write(f"note: {printable(folder)}; the .bvh files in it are not audited (summary.md lists it)\n")
    return root, out, files, skipped, unreadable


def run(args: argparse.Namespace) -> int:
    from .. import audit
    from ..errors import require_number
    from ..executor import check_options
    from ._common import units_scale

    if args.timeout is not None:
        require_number("--timeout", args.timeout, what="a time limit in seconds")
    if args.connect_timeout is not None:
        require_number("--connect-timeout", args.connect_timeout, what="seconds")
        if args.scheduler is None:
            raise MjmotionError(f"--connect-timeout {args.connect_timeout:g}: is the wait for --scheduler ADDRESS; there is none to wait for")
    units_scale(args.units)
    check_options(args.workers, args.scheduler)
    if args.dashboard and args.scheduler is not None:
        raise MjmotionError(
            f"--dashboard with --scheduler {args.scheduler}: the cluster's scheduler runs its own dashboard (if any); --dashboard is for --workers"
        )
    root, out, files, skipped, unlisted = check_paths(args)
    if args.source_map:
        from ._common import check_same_file

        # (--force removes the outputs, a run writes them: a map kept there under their name was replaced)
        taken = next((name for name in audit.OUTPUTS if check_same_file(args.source_map, out / name)), None)
        if taken:
            raise MjmotionError(f"--source-map {args.source_map}: is the audit's own {taken} in -o {out}; keep the map outside the output folder")
    made = [d for d in (out, *out.parents) if not d.exists()]  # (deepest first)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise MjmotionError(f"-o {out}: cannot make the folder ({e.strerror or e})") from None
    with audit.holding(out):
        try:
            return _audit(args, root, out, files, skipped, unlisted)
        finally:
            # A start refused before anything was written leaves no folder behind (removed while this
            # audit still holds it: another one refused the lock removes nothing).
            for d in made:
                with contextlib.suppress(OSError):
                    d.rmdir()  # (only when empty)


def _audit(args: argparse.Namespace, root: Path, out: Path, files: list[Path], skipped: list[tuple[Path, str]], unlisted: list[str]) -> int:
    import atexit
    import gc
    from concurrent.futures import ThreadPoolExecutor

    from .. import audit
    from ..executor import CONNECT_TIMEOUT, Aside, Executor, cores, start

    opts = audit.judge_options(units=args.units, up=args.up, keep_start=args.keep_start)
    source_map = None
    if args.source_map:
        base = root.resolve()
        source_map = audit.read_source_map(args.source_map, [audit.rel_text(p, base) for p in files], base)
    workers = args.workers if args.workers is not None or args.scheduler is not None else cores()
    # Forked before Dask loads: the histograms' Matplotlib loads there meanwhile, off the workers' cores.
    # A resume may have nothing to draw (and should exit at once), so it draws in this process.
    aside = Aside(preload=(audit.warm_drawing,)) if not args.resume else None
    # The files are listed and hashed (and a resumed table read) in a thread while the workers start:
    # hashing and reading release the interpreter's lock, the start-up is mostly imports and forks.
    try:
        with ThreadPoolExecutor(1, thread_name_prefix="audit-plan") as pool:
            planned = pool.submit(audit.plan, root, out, resume=args.resume, source_map=source_map, opts=opts, files=files, skipped=skipped)
            # A resume first learns whether anything is left to evaluate: an unchanged folder starts no workers
            # (and contacts no scheduler), so it costs a fraction of the first run.
            idle = args.resume and not planned.result().todo
            where = dict(workers=workers, scheduler=args.scheduler, connect_timeout=args.connect_timeout or CONNECT_TIMEOUT, dashboard=args.dashboard)
            ex = Executor() if idle else start(**where, preload=audit.PRELOAD)
            with ex:
                if args.force:  # only once the workers answer: a refused start leaves the old audit as it was
                    for name in audit.OUTPUTS:
                        (out / name).unlink(missing_ok=True)
                if idle:
                    print(f"auditing {root}: every file's row is kept (nothing new or changed); no workers started", flush=True)
                else:
                    print(f"auditing {root} on {ex.describe()}" + (f"; dashboard {ex.dashboard}" if ex.dashboard else ""), flush=True)
                if args.dashboard and ex.dashboard is None and args.scheduler is None and not idle:
                    print("note: --dashboard: Dask started no dashboard (it needs bokeh: pip install bokeh)", flush=True)
                res = audit.run(root, out, ex, timeout=args.timeout, opts=opts, planned=planned.result(), aside=aside, unlisted=unlisted)
    finally:
        if aside is not None:
            aside.close()
    n_err = sum(r["status"] != "ok" for r in res.rows)
    rate = f" ({res.computed / res.seconds:.2f} clips/s)" if res.computed and res.seconds > 0 else ""
    print(f"{len(res.rows)} clips: {len(res.rows) - n_err} ok, {n_err} error; {res.computed} evaluated in {res.seconds:.1f} s{rate}")
    print("wrote " + ", ".join(res.files) + (f"; unchanged: {', '.join(res.unchanged)}" if res.unchanged else ""))
    odd = len(audit.misread(res.rows))
    if odd:
        print(f"note: {odd} clip{'s' * (odd != 1)} stand{'s' * (odd == 1)} along another file axis than --up {args.up} reads (summary.md)")
    # At exit the interpreter's last garbage collection walks every object Dask, Matplotlib, Arrow and the
    # judge left (a second or more on the shared clips, longer than the evaluation of many of them);
    # everything is written and closed by now, so that walk is skipped (in-process callers exit later).
    atexit.register(gc.freeze)
    return 0
