"""The lab's experiments: each module reproduces a table or figure of a seed on our data.

Every experiment is a function ``run(out_dir, data_dir=None, quick=False) -> Table``: with
``data_dir`` it reads real mocap (``MJMOTION_DATA``), without it the bundled procedural clips;
``quick`` is the short version ``mjmotion demo`` runs. Each writes ``out_dir/table.md`` plus
PNGs (and MP4s where it renders). The scripts in the repository's ``experiments/`` folder call
these with the real data.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import MjmotionError


@dataclass
class Table:
    """A results table: a title, column names, rows of values, and notes (parameters, sources)."""

    title: str
    columns: Sequence[str]
    rows: list[Sequence[object]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)

    def add(self, *values: object) -> None:
        if len(values) != len(self.columns):
            raise ValueError(f"row has {len(values)} values for {len(self.columns)} columns")
        self.rows.append(values)

    def markdown(self) -> str:
        def cell(v: object) -> str:
            if isinstance(v, float):
                if math.isnan(v):
                    return "–"
                return f"{v:.4g}" if abs(v) < 1e4 else f"{v:.3e}"
            if isinstance(v, bool):
                return "yes" if v else "no"
            return str(v)

        lines = [f"## {self.title}", "", "| " + " | ".join(self.columns) + " |", "|" + "---|" * len(self.columns)]
        lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in self.rows]
        if self.notes:
            lines += [""] + [f"- {n}" for n in self.notes]
        if self.files:
            lines += [""] + [
                f"![{Path(f).stem}]({Path(f).name})" if f.endswith(".png") else f"- [{Path(f).name}]({Path(f).name})" for f in self.files
            ]
        return "\n".join(lines) + "\n"

    def write(self, out_dir: Path) -> Path:
        out_dir.mkdir(parents=True, exist_ok=True)
        path = out_dir / "table.md"
        path.write_text(self.markdown(), encoding="utf-8")
        return path


def single_thread_blas():
    """A context in which BLAS uses one thread.

    The experiments' linear algebra is small (PCA of a few hundred frames): on a shared 2-core
    machine OpenBLAS's threads contend with each other and with a second worker process, and an
    SVD was measured 25× slower than on one thread.
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def data_dir(explicit: str | os.PathLike[str] | None = None, required: bool = True) -> Path | None:
    """The real mocap directory: ``explicit``, else ``MJMOTION_DATA``, else ``../shared/mocap``."""
    if explicit is not None:
        p = Path(explicit)
    elif os.environ.get("MJMOTION_DATA"):
        p = Path(os.environ["MJMOTION_DATA"])
    else:
        p = Path(__file__).resolve().parents[2].parent / "shared" / "mocap"
    if p.is_dir():
        return p
    if required:
        raise MjmotionError(f"{p}: mocap directory not found; set MJMOTION_DATA or pass --data DIR")
    return None


def results_dir(name: str, root: str | os.PathLike[str] = "results") -> Path:
    out = Path(root) / name
    out.mkdir(parents=True, exist_ok=True)
    return out


def script(name: str, doc: str | None, argv: list[str] | None = None) -> int:
    """The command line every ``experiments/<name>.py`` script shares.

    ``--data DIR`` (default ``MJMOTION_DATA`` or ``../shared/mocap``), ``--bundled`` (the procedural
    clips instead), ``--out DIR`` (default ``results/<name>``), ``--quick`` (the demo's version),
    ``--jobs N`` where the experiment runs work in parallel, and ``--workers N`` / ``--scheduler ADDRESS``
    (Dask, :mod:`mjmotion.executor`) where its ``run`` takes an ``executor``. Prints the table; an error a
    user can act on is one ``error:`` line and status 2.
    """
    import argparse
    import contextlib
    import importlib
    import inspect
    import sys
    import time

    module = importlib.import_module(f"{__name__}.{name}")
    takes_jobs = "jobs" in inspect.signature(module.run).parameters
    p = argparse.ArgumentParser(prog=f"experiments/{name}.py", description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", metavar="DIR", help="mocap directory (default: MJMOTION_DATA or ../shared/mocap)")
    p.add_argument("--bundled", action="store_true", help="use the bundled procedural clips instead of real mocap")
    p.add_argument("--out", default=f"results/{name}", metavar="DIR", help=f"output folder (default: results/{name})")
    p.add_argument("--quick", action="store_true", help="the short version `mjmotion demo` runs")
    if takes_jobs:
        p.add_argument("--jobs", type=int, default=None, metavar="N", help="worker processes (default 2)")
    takes_executor = "executor" in inspect.signature(module.run).parameters
    if takes_executor:
        from ..executor import add_options

        add_options(p, default="instead of --jobs")
    args = p.parse_args(argv)
    start = time.perf_counter()
    out = Path(args.out)
    try:
        source = None if args.bundled else data_dir(args.data)
        from ..outputs import check_folder

        check_folder(out, "--out")  # before the experiment runs: an --out that cannot be written ended in a traceback
        if takes_jobs and args.jobs is not None and args.jobs < 1:
            raise MjmotionError(f"--jobs {args.jobs}: expected at least 1")
        dask = takes_executor and (args.workers is not None or args.scheduler is not None)
        if dask and takes_jobs and args.jobs is not None:  # (it was taken and ignored)
            given = f"--workers {args.workers}" if args.workers is not None else f"--scheduler {args.scheduler}"
            raise MjmotionError(f"--jobs {args.jobs} with {given}: --jobs is the process pool used without Dask; give one of them")
        extra = {"jobs": 2 if args.jobs is None else args.jobs} if takes_jobs else {}
        with contextlib.ExitStack() as stack:
            if dask:
                from .. import executor

                extra["executor"] = stack.enter_context(executor.start(workers=args.workers, scheduler=args.scheduler))
            with single_thread_blas():
                table = module.run(out, source, quick=args.quick, **extra)
    except MjmotionError as e:
        sys.stderr.write(f"error: {e}\n")
        return 2
    print(table.markdown())
    print(f"wrote {out / 'table.md'} and {len(table.files)} more file(s) to {out}/ in {time.perf_counter() - start:.1f} s")
    return 0
