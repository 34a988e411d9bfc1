"""Whole-database audits: every clip of a folder through the judge, one row each, streamed to disk.

- :func:`find_clips` lists the ``.bvh`` files under a folder (recursively; links that lead out of it
  are not followed); :func:`sha256_file` hashes one.
- :func:`judge_options` are ``mjmotion evaluate``'s options with their defaults (the judge's own
  parser, so new judge options arrive by themselves); :func:`audit_clip` evaluates one clip on a
  worker through the same one-file evaluation as ``evaluate`` and returns its row.
- :func:`metric_columns` flattens a report's ``to_dict()`` into columns (nothing hard-coded: the
  columns are whatever the judge reports); :func:`flavour` names a skeleton's naming convention.
- :class:`Table` is the output: ``audit.csv`` appended and flushed row by row (the journal a resume
  reads) and ``audit.parquet`` rewritten atomically every few seconds and at the end, so a crash
  leaves a complete CSV up to its last line and a valid Parquet file at most
  :data:`PARQUET_EVERY` seconds old.
- :func:`run` is the whole audit (resume, fan-out on :mod:`mjmotion.executor`, summary).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from . import __version__
from .errors import MjmotionError
from .executor import one_line
from .outputs import write_text_atomic, write_with

#: Columns every row has, before the metrics (``status`` is ``ok`` or ``error``).
META = (
    "path", "size", "sha256", "status", "error", "error_kind", "frames", "fps", "flavour", "joints",
    "skipped_frames", "seconds", "source_files", "options", "mjmotion_version", "params",
)  # fmt: skip
_TYPES = {"size": int, "frames": int, "joints": int, "skipped_frames": int, "fps": float, "seconds": float}
#: Seconds between rewrites of ``audit.parquet`` while an audit runs.
PARQUET_EVERY = 10.0
#: Evaluate options that only shape the verb's own output (not the numbers).
_OUTPUT_OPTIONS = ("path", "json", "csv", "force", "jobs")
#: Error kinds whose rows a resume keeps (the same input gives the same error); others are retried.
_FINAL_ERRORS = ("input",)
#: The files an audit writes in its output folder.
OUTPUTS = ("audit.csv", "audit.parquet", "summary.md", "histograms.png")
#: Modules :func:`audit_clip` needs (imported once before local workers are forked).
PRELOAD = ("mjmotion.commands.evaluate", "mjmotion.evaluate", "mjmotion.physics")
#: Clips listed per metric among the worst in the summary.
WORST = 5
#: Naming conventions by joints that must all be present (lower case); the first match names the flavour.
FLAVOURS = (
    ("cmu-asf", ("root", "lfemur", "ltibia")),
    ("cgspeed-daz", ("hip", "abdomen", "lshin")),
    ("cgspeed-max", ("hips", "lhipjoint", "leftknee")),
    ("cc-rig", ("cc_base_hip",)),
    ("mixamo", ("mixamorig:hips",)),
    ("mixamo-style", ("hips", "spine1", "leftupleg")),
)


def flavour(names: Sequence[str]) -> str:
    """The skeleton's naming convention (:data:`FLAVOURS`), else ``ROOT/N joints``."""
    low = {n.lower() for n in names}
    for label, needed in FLAVOURS:
        if all(n in low for n in needed):
            return label
    return f"{names[0]}/{len(names)} joints"


def find_clips(root: str | os.PathLike[str]) -> list[Path]:
    """Every ``.bvh`` under ``root`` (any case), sorted; linked folders are not entered and linked
    files count only if they resolve inside ``root``."""
    base = Path(root).resolve()
    out = []
    for folder, dirs, files in os.walk(base, followlinks=False):
        dirs.sort()
        for name in files:
            p = Path(folder) / name
            if p.suffix.lower() != ".bvh":
                continue
            if p.is_symlink() and not p.resolve().is_relative_to(base):
                continue
            if p.is_file():
                out.append(p)
    return sorted(out)


def sha256_file(path: str | os.PathLike[str]) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def judge_options(**overrides: Any) -> dict[str, Any]:
    """``mjmotion evaluate``'s options with their defaults (read from its parser), minus those that only
    shape its output, with ``overrides`` applied."""
    import argparse

    from .commands import evaluate

    p = argparse.ArgumentParser()
    evaluate.add_arguments(p)
    opts = vars(p.parse_args(["-"]))
    for k in _OUTPUT_OPTIONS:
        opts.pop(k, None)
    unknown = set(overrides) - set(opts)
    if unknown:
        raise ValueError(f"not options of evaluate: {sorted(unknown)}")
    opts.update(overrides)
    return opts


def metric_columns(report: Mapping[str, Any]) -> dict[str, Any]:
    """A report's ``to_dict()`` as flat columns: scalars by name, dicts as ``name.key``, lists of dicts as
    ``name[first=value].key`` (labelled by each entry's first item, e.g. ``sensitivity[h_c=0.03].skate_mm_per_s``).
    ``name``, ``n_frames``, ``fps`` (row columns of their own), ``params`` (a column of its own) and ``None``
    values (a metric that does not apply) are left out."""
    out: dict[str, Any] = {}

    def put(prefix: str, value: Any) -> None:
        if isinstance(value, Mapping):
            for k, v in value.items():
                put(f"{prefix}.{k}", v)
        elif isinstance(value, (list, tuple)) and value and all(isinstance(v, Mapping) and v for v in value):
            for entry in value:
                (k0, v0), *rest = entry.items()
                for k, v in rest:
                    put(f"{prefix}[{k0}={v0}].{k}", v)
        elif isinstance(value, (list, tuple)):
            out[prefix] = json.dumps(list(value))
        elif value is None:
            pass  # a metric that does not apply (``hit`` without a ball): no cell
        elif isinstance(value, (bool, int, float, str)):
            out[prefix] = value
        else:
            out[prefix] = float(value)  # NumPy scalars

    for k, v in report.items():
        if k not in ("name", "n_frames", "fps", "params"):
            put(k, v)
    return out


def audit_clip(path: str, sha256: str, opts: dict[str, Any], sources: tuple[str, ...] = ()) -> dict[str, Any]:
    """One clip, on a worker: its row's frames, fps, flavour, metrics (or ``error``). The file is hashed
    again here, so the row is of exactly the bytes listed (a worker elsewhere must see the same file)."""
    from . import bvh
    from . import evaluate as ev
    from .commands._common import load
    from .commands.evaluate import evaluate_one

    try:
        seen = sha256_file(path)
    except OSError as e:  # a worker on another machine without the file at this path
        raise MjmotionError(f"{path}: cannot be read on this worker ({e.strerror or e})") from None
    if seen != sha256:
        raise MjmotionError(f"{path}: not the file that was listed (changed since, or this worker sees another file at the path)")
    import argparse

    if sources and "source" in opts:  # a judge that takes --source SRC.bvh judges the clip against them too
        opts = {**opts, "source": list(sources)}
    try:
        motion, offset, report = evaluate_one(path, opts)
    except MjmotionError as e:
        row: dict[str, Any] = {"error": one_line(str(e))}
        try:  # the flavour of a clip that reads but cannot be judged
            m = bvh.read(path)
            row.update(frames=m.n_frames, fps=float(m.fps), flavour=flavour(m.skeleton.names), joints=m.skeleton.n_joints)
        except MjmotionError:
            pass
        return row
    d = report.to_dict()
    row = {
        "frames": motion.n_frames,
        "fps": float(motion.fps),
        "flavour": flavour(motion.skeleton.names),
        "joints": motion.skeleton.n_joints,
        "skipped_frames": offset,
        "params": json.dumps(d.get("params"), sort_keys=True, default=float),
        **metric_columns(d),
    }
    if sources:
        # Against the clips this one was made from (--source-map): the judge's source-relative measures.
        src = [load(s, argparse.Namespace(**opts)) for s in sources]
        row["vs_source.max_joint_speed_ratio"] = ev.max_joint_speed_ratio(motion, src)
        row["vs_source.root_jump_m"] = ev.root_jump_m(motion, src)
    return row


# --------------------------------------------------------------------------- the table on disk


def _cell(v: Any) -> Any:
    return "" if v is None else v


def _parse(column: str, text: str) -> Any:
    """A CSV cell back to its value (metrics: bool, int, float or text)."""
    if text == "":
        return None
    if column in _TYPES:
        return _TYPES[column](float(text)) if _TYPES[column] is int else float(text)
    if column in META:
        return text
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


class Table:
    """``audit.csv`` (appended and flushed per row) and ``audit.parquet`` (rewritten atomically)."""

    def __init__(self, out_dir: Path, rows: Iterable[dict[str, Any]] = ()):
        self.csv = out_dir / "audit.csv"
        self.parquet = out_dir / "audit.parquet"
        self.rows: list[dict[str, Any]] = []
        self.columns: list[str] = list(META)
        for r in rows:
            self._take(r)
        self._rewrite_csv()
        self.written = time.monotonic()
        self.write_parquet()

    def _take(self, row: dict[str, Any]) -> bool:
        new = [k for k in row if k not in self.columns]
        self.columns += new
        self.rows.append(row)
        return bool(new)

    def _rewrite_csv(self) -> None:
        def write(tmp: Path) -> None:
            with open(tmp, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f)
                w.writerow(self.columns)
                for r in self.rows:
                    w.writerow([_cell(r.get(c)) for c in self.columns])

        write_with(self.csv, write)
        self._file = open(self.csv, "a", newline="", encoding="utf-8")
        self._writer = csv.writer(self._file)

    def add(self, row: dict[str, Any]) -> None:
        if self._take(row):
            self._file.close()
            self._rewrite_csv()  # a new column (the first metrics after only errors): the header grows
        else:
            self._writer.writerow([_cell(row.get(c)) for c in self.columns])
            self._file.flush()
        if time.monotonic() - self.written >= PARQUET_EVERY:
            self.write_parquet()

    def write_parquet(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        arrays = {c: _arrow_column([r.get(c) for r in self.rows], c) for c in self.columns}
        table = pa.table(arrays)
        write_with(self.parquet, lambda tmp: pq.write_table(table, tmp))
        self.written = time.monotonic()

    def close(self) -> None:
        self._file.close()
        self.write_parquet()

    @staticmethod
    def read(path: Path) -> list[dict[str, Any]]:
        """Rows of an ``audit.csv``; a last line cut short by a crash is dropped."""
        text = path.read_text(encoding="utf-8")
        records = list(csv.reader(text.splitlines(keepends=True)))
        if not records:
            return []
        if not text.endswith("\n"):
            records = records[:-1]
        header, body = records[0], records[1:]
        if header[: len(META)] != list(META):
            raise MjmotionError(f"{path}: not an audit table of this version (columns {header[:4]}…); use --force to start over")
        return [{c: _parse(c, v) for c, v in zip(header, rec)} for rec in body if len(rec) == len(header)]


def _arrow_column(values: list[Any], name: str) -> Any:
    import pyarrow as pa

    present = [v for v in values if v is not None]
    if name in _TYPES:
        kind = pa.int64() if _TYPES[name] is int else pa.float64()
    elif present and all(isinstance(v, bool) for v in present):
        kind = pa.bool_()
    elif present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        kind = pa.int64()
    elif present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        kind = pa.float64()
        values = [None if v is None else float(v) for v in values]
    else:
        kind = pa.string()
        values = [None if v is None else str(v) for v in values]
    return pa.array(values, type=kind)


# --------------------------------------------------------------------------- the audit


@dataclass(frozen=True)
class Clip:
    """A file to audit: ``rel`` (its path under the folder, with ``/``), the absolute ``path``, ``size``
    in bytes, ``sha256``, and the ``sources`` it was made from (absolute paths, with their hashes)."""

    rel: str
    path: str
    size: int
    sha256: str
    sources: tuple[str, ...] = ()
    source_sha256: tuple[str, ...] = ()


def read_source_map(path: str | os.PathLike[str], clips: Iterable[str]) -> dict[str, tuple[str, ...]]:
    """``--source-map FILE``: a JSON object from a clip's path under DIR to the clip (or list of clips) it
    was made from; sources are relative to the map file's folder unless absolute."""
    p = Path(path)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MjmotionError(f"--source-map {p}: no such file") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise MjmotionError(f"--source-map {p}: not JSON ({e})") from None
    if not isinstance(data, dict):
        raise MjmotionError(f'--source-map {p}: expected a JSON object {{"clip.bvh": "source.bvh" or [sources]}}')
    known = set(clips)
    out = {}
    for key, value in data.items():
        if key not in known:
            raise MjmotionError(f"--source-map {p}: {key!r} is not a .bvh file under the audited folder")
        names = [value] if isinstance(value, str) else value
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            raise MjmotionError(f"--source-map {p}: {key!r}: expected a source path or a non-empty list of them")
        resolved = []
        for n in names:
            s = Path(n) if Path(n).is_absolute() else p.parent / n
            if not s.is_file():
                raise MjmotionError(f"--source-map {p}: {key!r}: source {n} not found (looked for {s})")
            resolved.append(str(s.resolve()))
        out[key] = tuple(resolved)
    return out


def list_clips(root: Path, source_map: Mapping[str, tuple[str, ...]] | None = None) -> list[Clip]:
    """The clips under ``root`` with sizes and hashes (and their sources' hashes)."""
    out = []
    for p in find_clips(root):
        rel = p.relative_to(root.resolve()).as_posix()
        src = tuple(source_map.get(rel, ())) if source_map else ()
        out.append(Clip(rel, str(p), p.stat().st_size, sha256_file(p), src, tuple(sha256_file(s) for s in src)))
    return out


def options_text(opts: Mapping[str, Any], clip: Clip) -> str:
    """What a row's numbers depend on besides the file: the judge's options and the sources' hashes."""
    d = {k: v for k, v in sorted(opts.items())}
    if clip.sources:
        d["source_sha256"] = list(clip.source_sha256)
    return json.dumps(d, sort_keys=True, default=list, separators=(",", ":"))


def reusable(row: Mapping[str, Any], clip: Clip, options: str) -> bool:
    """Whether a resumed row already answers for this clip: same bytes, options and version, and not an
    error that might go away (a time limit, a worker lost, an internal error)."""
    return (
        row.get("sha256") == clip.sha256
        and row.get("options") == options
        and row.get("mjmotion_version") == __version__
        and (row.get("status") == "ok" or row.get("error_kind") in _FINAL_ERRORS)
    )


@dataclass(frozen=True)
class Result:
    """What :func:`run` did: every row (one per clip, in path order), how many were computed now, the
    wall time, the executor's description and the files written."""

    rows: list[dict[str, Any]]
    computed: int
    seconds: float
    executor: str
    files: list[str]


def run(
    root: Path,
    out_dir: Path,
    ex: Any,
    *,
    resume: bool = False,
    timeout: float | None = None,
    source_map: Mapping[str, tuple[str, ...]] | None = None,
    opts: dict[str, Any] | None = None,
    progress: bool = True,
) -> Result:
    """Audit every clip under ``root`` into ``out_dir`` on the executor ``ex`` (see the module doc)."""
    start = time.perf_counter()
    opts = opts if opts is not None else judge_options()
    clips = list_clips(root, source_map)
    out_dir.mkdir(exist_ok=True)
    previous = {r["path"]: r for r in Table.read(out_dir / "audit.csv")} if resume and (out_dir / "audit.csv").is_file() else {}
    options = {c.rel: options_text(opts, c) for c in clips}
    kept = [previous[c.rel] for c in clips if c.rel in previous and reusable(previous[c.rel], c, options[c.rel])]
    done = {r["path"] for r in kept}
    todo = [c for c in clips if c.rel not in done]
    table = Table(out_dir, kept)
    # The largest files first: the long clips do not all end up at the tail of the run.
    todo.sort(key=lambda c: -c.size)
    by_rel = {c.rel: c for c in todo}
    tasks = [(c.rel, (c.path, c.sha256, opts, c.sources)) for c in todo]
    try:
        for out in ex.run(audit_clip, tasks, timeout=timeout, desc="audit", unit="clip", progress=progress):
            c = by_rel[out.key]
            value = out.value if out.ok else {"error": out.error}
            err = value.get("error")
            kind = (out.kind or "input") if err is not None else None
            table.add(
                {
                    "path": c.rel, "size": c.size, "sha256": c.sha256, "status": "ok" if err is None else "error",
                    "error": err, "error_kind": kind, "seconds": out.seconds if math.isfinite(out.seconds) else None,
                    "source_files": json.dumps(list(c.sources)) if c.sources else None, "options": options[c.rel],
                    "mjmotion_version": __version__, **{k: v for k, v in value.items() if k != "error"},
                }
            )  # fmt: skip
    finally:
        table.close()
    rows = sorted(table.rows, key=lambda r: r["path"])
    seconds = time.perf_counter() - start
    files = [str(table.csv), str(table.parquet)]
    files += write_summary(out_dir, rows, root=root, executor=ex.describe(), computed=len(todo), seconds=seconds, timeout=timeout)
    return Result(rows, len(todo), seconds, ex.describe(), files)


# --------------------------------------------------------------------------- the summary


def numeric_metrics(rows: Sequence[Mapping[str, Any]]) -> dict[str, list[tuple[float, str]]]:
    """Every metric column with numbers: ``{column: [(value, path), ...]}`` over the ok rows (finite values)."""
    cols: dict[str, list[tuple[float, str]]] = {}
    for r in rows:
        if r.get("status") != "ok":
            continue
        for k, v in r.items():
            if k in META or isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                continue
            cols.setdefault(k, []).append((float(v), r["path"]))
    return cols


def write_summary(
    out_dir: Path, rows: Sequence[Mapping[str, Any]], *, root: Path, executor: str, computed: int, seconds: float, timeout: float | None
) -> list[str]:
    """``summary.md`` and ``histograms.png``: counts by flavour, distributions, worst clips, errors, parameters."""
    import numpy as np

    from . import plots

    ok = [r for r in rows if r.get("status") == "ok"]
    lines = [
        f"# Audit of {root}",
        "",
        f"{len(rows)} clips: {len(ok)} ok, {len(rows) - len(ok)} error; {computed} evaluated in this run "
        f"({len(rows) - computed} kept from the previous table) in {seconds:.1f} s on {executor}.",
        "",
        "## Clips by skeleton flavour",
        "",
        "| flavour | clips | ok | error |",
        "|---|---|---|---|",
    ]
    by: dict[str, list[int]] = {}
    for r in rows:
        n = by.setdefault(str(r.get("flavour") or "unreadable"), [0, 0])
        n[0 if r.get("status") == "ok" else 1] += 1
    lines += [f"| {f} | {a + b} | {a} | {b} |" for f, (a, b) in sorted(by.items())]
    metrics = numeric_metrics(rows)
    files = []
    varying = {k: [v for v, _ in vals] for k, vals in metrics.items() if len({v for v, _ in vals}) > 1}
    # Histograms of the report's own fields (a breakdown like sensitivity[h_c=…].x or hit.x is in the tables).
    headline = {k: v for k, v in varying.items() if not any(c in k for c in ".[")}
    if headline:
        png = out_dir / "histograms.png"
        plots.histograms(headline, png, title=f"{len(ok)} clips of {root.name}")
        files.append(str(png))
    if metrics:
        lines += [
            "",
            "## Distributions (ok clips, finite values)",
            "",
            "![histograms of the report's metrics that vary](histograms.png)" if headline else "",
            "",
            "| metric | clips | min | median | p90 | max |",
            "|---|---|---|---|---|---|",
        ]
        for k, vals in metrics.items():
            a = np.array([v for v, _ in vals])
            lines.append(f"| {k} | {a.size} | {a.min():.4g} | {np.median(a):.4g} | {np.percentile(a, 90):.4g} | {a.max():.4g} |")
        lines += ["", f"## Worst clips per metric (the {WORST} highest values)", "", "| metric | clips |", "|---|---|"]
        for k, vals in metrics.items():
            if k in varying:
                worst = sorted(vals, key=lambda t: -t[0])[:WORST]
                lines.append(f"| {k} | " + "; ".join(f"`{p}` {v:.4g}" for v, p in worst) + " |")
    errors = [r for r in rows if r.get("status") != "ok"]
    if errors:
        lines += ["", "## Errors", "", "| clip | kind | message |", "|---|---|---|"]
        lines += [f"| `{r['path']}` | {r.get('error_kind')} | {str(r.get('error')).replace('|', '/')} |" for r in errors]
    params = next((r["params"] for r in ok if r.get("params")), None)
    opts = next((r["options"] for r in rows if r.get("options")), None)
    lines += [
        "",
        "## Parameters",
        "",
        f"- mjmotion {__version__}; per-clip time limit: {f'{timeout:g} s' if timeout else 'none'}",
        f"- judge options (`mjmotion evaluate`'s defaults unless given): `{opts}`",
        f"- report thresholds: `{params}`",
        "- metric definitions: the report fields of mjmotion/evaluate.py (see `mjmotion evaluate --help`)",
    ]
    write_text_atomic(out_dir / "summary.md", "\n".join(lines) + "\n")
    return [str(out_dir / "summary.md"), *files]
