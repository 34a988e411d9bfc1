"""Whole-database audits: every clip of a folder through the judge, one row each, streamed to disk.

- :func:`list_clips` lists the ``.bvh`` files under a folder (:func:`mjmotion.inputs.find_bvh`:
  recursively; links that lead out of it are not followed) with their hashes (:func:`fingerprint`).
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

import contextlib
import csv
import hashlib
import json
import math
import os
import re
import socket
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import __version__
from .caps import MAX_JSON_BYTES
from .errors import MjmotionError, printable
from .executor import Aside, one_line
from .inputs import DuplicateKey, InputError, find_bvh, once, read_text
from .outputs import write_text_atomic, write_with
from .thresholds import JUDGE_REVISION

#: Columns every row has, before the metrics (``status`` is ``ok`` or ``error``).
META = (
    "path", "size", "sha256", "status", "error", "error_kind", "frames", "fps", "flavour", "joints",
    "standing_axis", "skipped_frames", "seconds", "source_files", "options", "mjmotion_version", "params",
)  # fmt: skip
_TYPES = {"size": int, "frames": int, "joints": int, "skipped_frames": int, "fps": float, "seconds": float}
#: Seconds between rewrites of ``audit.parquet`` while an audit runs.
PARQUET_EVERY = 10.0
#: A file changed less than this many seconds before it was hashed is hashed again by its worker: Linux
#: stamps files from a clock of a few milliseconds' resolution (some file systems keep whole seconds).
RACY = 3.0
#: Evaluate options that only shape the verb's own output (not the numbers).
_OUTPUT_OPTIONS = ("path", "json", "csv", "force", "jobs")
#: Error kinds whose rows a resume keeps (the same input gives the same error); others are retried.
_FINAL_ERRORS = ("input",)
#: The files an audit writes in its output folder.
OUTPUTS = ("audit.csv", "audit.parquet", "summary.md", "histograms.png")
#: The PNG text entry holding :func:`histograms_digest` of what ``histograms.png`` draws.
HISTOGRAMS_KEY = "mjmotion-histograms"
#: Clips listed per metric among the worst in the summary.
WORST = 5
#: The flavour column of the summary's count for the rows with no skeleton read (every error but a late one).
NO_FLAVOUR = "no skeleton read"
#: The headline metrics drawn as histograms in the summary (docs/METRICS.md; every metric is in its tables).
HEADLINE = (
    "planted_skate_mm_per_s", "skate_mm_per_s", "penetrate_mm", "float_mm", "flight_fraction", "contact_fraction",
    "physics_violation_ratio", "ground_residual_mean", "limit_violation_ratio", "pop_frames", "worst_joint_speed_ratio",
    "max_joint_speed_ratio", "floor_m",
)  # fmt: skip
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


def sha256_file(path: str | os.PathLike[str]) -> str:
    return fingerprint(path)[0]


@dataclass(frozen=True)
class Listed:
    """How a file looked while it was hashed: ``stat`` (device, inode, size, modification and change
    times in ns), the ``host`` and when hashing began (``hashed_at``, seconds since the epoch)."""

    stat: tuple[int, int, int, int, int]
    host: str
    hashed_at: float


def _signature(st: os.stat_result) -> tuple[int, int, int, int, int]:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def fingerprint(path: str | os.PathLike[str]) -> tuple[str, Listed]:
    """The SHA-256 of a file and how it looked while read (the same before and after; a file written to
    meanwhile is read again, up to three times)."""
    for _ in range(3):
        began = time.time()
        h = hashlib.sha256()
        with open(path, "rb") as f:
            before = _signature(os.fstat(f.fileno()))
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
            after = _signature(os.fstat(f.fileno()))
        if before == after:
            break
    return h.hexdigest(), Listed(after, socket.gethostname(), began)


def unchanged(path: str | os.PathLike[str], listed: Listed) -> bool:
    """Whether ``path`` is beyond doubt still the file hashed as ``listed``: on the same host, with the same
    device, inode, size and modification and change times (no write or rename leaves those as they were:
    writing sets both times, and the change time cannot be set back), last changed more than
    :data:`RACY` seconds before it was hashed (a write within the same clock tick would keep the times)."""
    if listed.host != socket.gethostname():
        return False
    try:
        st = os.stat(path)
    except OSError:
        return False
    return _signature(st) == listed.stat and max(st.st_mtime_ns, st.st_ctime_ns) < (listed.hashed_at - RACY) * 1e9


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


def audit_clip(path: str, sha256: str, opts: dict[str, Any], sources: tuple[str, ...] = (), listed: Listed | None = None) -> dict[str, Any]:
    """One clip, on a worker: its row's frames, fps, flavour, metrics (or ``error``), of exactly the bytes
    listed. The worker hashes the file again unless it is :func:`unchanged` since it was ``listed`` (the
    same file on the same host, so hashing it again would read the same bytes); after the evaluation the
    file must still look as it did before (a file written to meanwhile is an error row)."""
    from . import bvh
    from . import evaluate as ev
    from .commands._common import load, named
    from .commands.evaluate import evaluate_one
    from .upright import standing_axis

    if listed is not None and unchanged(path, listed):
        looked = listed.stat
    else:
        try:
            seen, here = fingerprint(path)
        except OSError as e:  # unreadable, or a worker on another machine without the file at this path
            # not the file's fault: kind "unreadable", which a resume tries again
            return {"error": one_line(f"{path}: cannot be read on this worker ({e.strerror or e})"), "error_kind": "unreadable"}
        if seen != sha256:
            raise MjmotionError(f"{path}: not the file that was listed (changed since, or this worker sees another file at the path)")
        looked = here.stat

    def same_file(row: dict[str, Any]) -> dict[str, Any]:
        try:
            still = _signature(os.stat(path)) == looked
        except OSError:
            still = False
        if not still:
            raise MjmotionError(f"{path}: changed while it was evaluated (the row would not be of the bytes listed)")
        return row

    import argparse

    if sources and "source" in opts:  # a judge that takes --source SRC.bvh judges the clip against them too
        opts = {**opts, "source": list(sources)}
    try:
        motion, offset, report = evaluate_one(path, opts)
    except MjmotionError as e:
        # Named as evaluate DIR names it: the judge's own errors speak of "a clip".
        row: dict[str, Any] = {"error": one_line(named(path, str(e)))}
        try:  # the flavour of a clip that reads but cannot be judged
            m = bvh.read(path)
            row.update(frames=m.n_frames, fps=float(m.fps), flavour=flavour(m.skeleton.names), joints=m.skeleton.n_joints)
        except MjmotionError:
            pass
        return same_file(row)
    d = report.to_dict()
    row = {
        "frames": motion.n_frames,
        "fps": float(motion.fps),
        "flavour": flavour(motion.skeleton.names),
        "joints": motion.skeleton.n_joints,
        # The file axis the body stands along (mjmotion/upright.py): a folder read with the wrong --up shows here.
        "standing_axis": None if (standing := standing_axis(motion)) is None else standing.axis,
        "skipped_frames": offset,
        "params": json.dumps(d.get("params"), sort_keys=True, default=float),
        **metric_columns(d),
    }
    if sources:
        # Against the clips this one was made from (--source-map): the judge's source-relative measures.
        src = [load(s, argparse.Namespace(**opts)) for s in sources]
        row["vs_source.max_joint_speed_ratio"] = ev.max_joint_speed_ratio(motion, src)
        row["vs_source.root_jump_m"] = ev.root_jump_m(motion, src)
    return same_file(row)


def _standing_bvh(frames: int = 60, fps: float = 120.0) -> str:
    """A small biped (hips, spine, head, legs with feet and toes; centimetres, Y up) standing and
    swaying its hips a centimetre, as BVH text: the warm-up's clip. Written out here rather than
    synthesized: the synthesizer's frame maths would load SciPy's spatial package (0.3 s) into a
    process that, forked, becomes every worker."""
    joints = []

    def joint(name: str, offset: tuple[float, float, float], children: str, end: tuple[float, float, float] | None = None) -> str:
        joints.append(name)
        inner = f"End Site\n{{\nOFFSET {end[0]} {end[1]} {end[2]}\n}}\n" if end is not None else children
        return f"JOINT {name}\n{{\nOFFSET {offset[0]} {offset[1]} {offset[2]}\nCHANNELS 3 Zrotation Xrotation Yrotation\n{inner}}}\n"

    legs = ""
    for side, x in (("Left", 9.0), ("Right", -9.0)):
        toe = joint(f"{side}ToeBase", (0.0, -6.0, 12.0), "", end=(0.0, 0.0, 5.0))
        legs += joint(f"{side}UpLeg", (x, 0.0, 0.0), joint(f"{side}Leg", (0.0, -42.0, 0.0), joint(f"{side}Foot", (0.0, -40.0, 0.0), toe)))
    spine = joint("Spine", (0.0, 10.0, 0.0), joint("Head", (0.0, 50.0, 0.0), "", end=(0.0, 15.0, 0.0)))
    head = f"HIERARCHY\nROOT Hips\n{{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n{legs}{spine}}}\n"
    rows = []
    for t in range(frames):
        sway = math.sin(2.0 * math.pi * t / frames)
        rows.append(" ".join(f"{v:.4f}" for v in [sway, 88.0, 0.0, 0.0, 0.0, 0.0] + [0.0] * (3 * len(joints))))
    return head + f"MOTION\nFrames: {frames}\nFrame Time: {1.0 / fps:.8f}\n" + "\n".join(rows) + "\n"


def warm_up() -> None:
    """Evaluate a short standing clip in this process through the tasks' own one-file evaluation,
    so that whatever the judge loads on first use (MuJoCo, its modules, the first compile) is
    loaded once here, before local workers are forked, instead of once in every worker."""
    import tempfile

    from .commands.evaluate import evaluate_one

    with tempfile.TemporaryDirectory(prefix="mjmotion-warm-up-") as tmp:
        path = Path(tmp) / "standing.bvh"
        path.write_text(_standing_bvh())
        evaluate_one(str(path), judge_options())


#: What local workers share from the moment they are forked (:func:`mjmotion.executor.load`).
PRELOAD = (warm_up,)


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


def _kind(value: Any) -> str:
    """A cell's Parquet kind: ``bool``, ``int``, ``float`` or ``str``."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "int"
    if isinstance(value, float):
        return "float"
    return "str"


def _join(kind: str | None, value: Any) -> str | None:
    """The kind of a column of ``kind`` after one more cell: ints and floats make floats; any other mix is text."""
    if value is None:
        return kind
    k = _kind(value)
    if kind is None or kind == k:
        return k
    return "float" if {kind, k} == {"int", "float"} else "str"


class Table:
    """``audit.csv`` (appended and flushed per row) and ``audit.parquet`` (rewritten atomically from it).

    Each column's Parquet type follows its values (``META`` columns have fixed types): all booleans →
    bool, all integers → int64, numbers → float64, anything else (or nothing yet) → string.
    """

    def __init__(self, out_dir: Path, rows: Iterable[dict[str, Any]] = ()):
        self.csv = out_dir / "audit.csv"
        self.parquet = out_dir / "audit.parquet"
        self.rows: list[dict[str, Any]] = []
        self.columns: list[str] = list(META)
        self.kinds: dict[str, str | None] = {c: None for c in META}
        for r in rows:
            self._take(r)
        self._rewrite_csv()
        self.written = time.monotonic()

    def _take(self, row: dict[str, Any]) -> bool:
        new = [k for k in row if k not in self.kinds]
        self.columns += new
        for k, v in row.items():
            self.kinds[k] = _join(self.kinds.get(k), v)
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
        """``audit.parquet`` from ``audit.csv`` (flushed up to its last row), read by Arrow's CSV reader with
        every column's type given (building Arrow arrays from Python lists would import pandas: a third of a second)."""
        import pyarrow as pa
        import pyarrow.csv as pc
        import pyarrow.parquet as pq

        self._file.flush()
        arrow = {"bool": pa.bool_(), "int": pa.int64(), "float": pa.float64(), "str": pa.string()}
        types = {c: arrow[("int" if _TYPES[c] is int else "float") if c in _TYPES else (self.kinds[c] or "str")] for c in self.columns}
        table = pc.read_csv(
            self.csv,
            read_options=pc.ReadOptions(block_size=max(1 << 20, self.csv.stat().st_size + 1)),  # one block: no type guessed per block
            parse_options=pc.ParseOptions(newlines_in_values=True),  # a path may hold a line break (quoted by the csv module)
            convert_options=pc.ConvertOptions(
                column_types=types, null_values=[""], strings_can_be_null=True, true_values=["True"], false_values=["False"]
            ),
        )
        write_with(self.parquet, lambda tmp: pq.write_table(table, tmp))
        self.written = time.monotonic()

    def close(self) -> None:
        self.write_parquet()
        self._file.close()

    @staticmethod
    def read(path: Path) -> list[dict[str, Any]]:
        """Rows of an ``audit.csv``; a last line cut short by a crash is dropped."""
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise MjmotionError(f"{path}: cannot be read as an audit table ({one_line(str(e))}); use --force to start over") from None
        records = list(csv.reader(text.splitlines(keepends=True)))
        if not records:
            return []
        if not text.endswith("\n"):
            records = records[:-1]
        if not records:  # only a header cut short by a crash: no row was written
            return []
        header, body = records[0], records[1:]
        if header[: len(META)] != list(META):
            raise MjmotionError(f"{path}: not an audit table of this version (columns {header[:4]}…); use --force to start over")
        rows = []
        for n, rec in enumerate(body, 2):
            if len(rec) != len(header):
                continue
            row = {}
            for c, v in zip(header, rec):
                try:
                    row[c] = _parse(c, v)
                except ValueError:  # (an edited or damaged cell was an internal error)
                    raise MjmotionError(f"{path}: line {n}, column {c}: {printable(v)!r} is not a number; use --force to start over") from None
            rows.append(row)
        return rows


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
    listed: Listed | None = None


def read_source_map(path: str | os.PathLike[str], clips: Iterable[str], root: Path | None = None) -> dict[str, tuple[str, ...]]:
    """``--source-map FILE``: a JSON object from a clip's path under DIR to the clip (or list of clips) it
    was made from; sources are relative to the map file's folder unless absolute. With ``root`` (DIR), a
    clip given as its own source is refused too (the judge refuses it for each clip, after the listing)."""
    p = Path(path)

    try:
        # A regular file of at most caps.MAX_JSON_BYTES: a FIFO or /dev/zero was read without end.
        text = read_text(p, MAX_JSON_BYTES, "a JSON source map")
    except InputError as e:
        raise MjmotionError(f"--source-map {e}") from None
    try:
        data = json.loads(text, object_pairs_hook=once)
    except DuplicateKey as e:  # (JSON would keep the last silently)
        raise MjmotionError(f"--source-map {p}: {e.key!r} is given more than once; expected one entry per clip") from None
    except json.JSONDecodeError as e:
        raise MjmotionError(f"--source-map {p}: not JSON ({e})") from None
    except RecursionError:
        raise MjmotionError(f"--source-map {p}: JSON nested too deeply; expected one object of clip -> source(s)") from None
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
            if not n.strip():
                raise MjmotionError(f"--source-map {p}: {key!r}: an empty source path; expected the path of a .bvh file")
            s = Path(n) if Path(n).is_absolute() else p.parent / n
            if s.is_dir():
                raise MjmotionError(f"--source-map {p}: {key!r}: source {n} is a folder (looked at {s}); expected a .bvh file")
            if not s.is_file():
                raise MjmotionError(f"--source-map {p}: {key!r}: source {n} not found (looked for {s})")
            if root is not None and _same_file(s, root / key):
                raise MjmotionError(f"--source-map {p}: {key!r}: source {n} is the clip itself; expected the clip(s) it was made from")
            resolved.append(str(s.resolve()))
        out[key] = tuple(resolved)
    return out


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # (a key whose name is not UTF-8 is held as text with escapes: no such path)
        return False


def rel_text(path: Path, base: Path) -> str:
    """A file's path under ``base`` with ``/``, as the table's text: bytes of a name that are not
    UTF-8 written as ``\\xNN`` and a backslash in a name doubled, so that no two files share a text (the
    byte 0xFF and a name spelling ``\\xff`` were one row key, and the run stopped on it). The CSV and
    Parquet hold text; the file itself is read by its real path."""
    raw = os.fsencode(path.relative_to(base).as_posix()).replace(b"\\", b"\\\\")
    return raw.decode("utf-8", "backslashreplace")


def list_clips(root: Path, source_map: Mapping[str, tuple[str, ...]] | None = None, files: Sequence[Path] | None = None) -> list[Clip]:
    """The clips under ``root`` with sizes and hashes (and their sources' hashes); ``files``: the folder's
    :func:`listing` if the caller has it already (a database on a network file system is walked once)."""
    out = []
    base = root.resolve()
    for p in listing(root) if files is None else files:
        rel = rel_text(p, base)
        src = tuple(source_map.get(rel, ())) if source_map else ()
        try:
            sha, listed = fingerprint(p)
        except OSError:  # unreadable here: listed without a hash, its worker's row says why (a resume tries it again)
            out.append(Clip(rel, str(p), _size(p, os.stat), "", src, ()))  # (a size needs no read permission: it read 0)
            continue
        out.append(Clip(rel, str(p), listed.stat[2], sha, src, tuple(sha256_file(s) for s in src), listed))
    return out


def listing(root: Path, unreadable: list[str] | None = None, skipped: list[tuple[Path, str]] | None = None) -> list[Path]:
    """The ``.bvh`` files under ``root`` (:func:`mjmotion.inputs.find_bvh`, which notes the folders it cannot
    list and the names it skips, with why), under its resolved path: the paths the workers open, wherever they run."""
    base = root.resolve()  # (once: a realpath per file walked the path's links again for each)
    names: list[tuple[Path, str]] = []
    files = [base / p.relative_to(root) for p in find_bvh(root, unreadable, names)]
    if skipped is not None:
        skipped += [(base / p.relative_to(root), why) for p, why in names]
    return files


def _size(path: Path, look: Callable[[Path], os.stat_result]) -> int:
    """``path``'s size by ``look`` (``os.stat``, or ``os.lstat`` for a link itself), 0 when it cannot be had."""
    try:
        return look(path).st_size
    except OSError:
        return 0


def no_file_row(path: Path, why: str, base: Path, opts: Mapping[str, Any]) -> dict[str, Any]:
    """The error row of a name ending in ``.bvh`` under ``base`` that is no file to read (a pipe, a
    dangling link, a link loop): the table has a row for every such name, as for a file that cannot be read."""
    size = _size(path, os.lstat)
    clip = Clip(rel_text(path, base), str(path), size, "", (), ())
    return {
        "path": clip.rel, "size": size, "sha256": "", "status": "error", "error": one_line(f"{path}: {why}"), "error_kind": "unreadable",
        "options": options_text(opts, clip), "mjmotion_version": __version__,
    }  # fmt: skip


def options_text(opts: Mapping[str, Any], clip: Clip) -> str:
    """What a row's numbers depend on besides the file: the judge's options and revision
    (:data:`mjmotion.thresholds.JUDGE_REVISION`) and the sources' hashes."""
    d = {k: v for k, v in sorted(opts.items())}
    d["judge_revision"] = JUDGE_REVISION
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
class Plan:
    """What an audit of a folder will do, decided before any work: every clip (path order), each one's
    options text, the rows of a previous table that are kept, and the clips to evaluate (largest first:
    the long clips do not all end up at the tail of the run). ``started`` is when planning began."""

    clips: list[Clip]
    options: dict[str, str]
    kept: list[dict[str, Any]]
    todo: list[Clip]
    started: float
    no_files: list[dict[str, Any]] = field(default_factory=list)


def plan(
    root: Path,
    out_dir: Path,
    *,
    resume: bool = False,
    source_map: Mapping[str, tuple[str, ...]] | None = None,
    opts: dict[str, Any] | None = None,
    files: Sequence[Path] | None = None,
    skipped: Sequence[tuple[Path, str]] = (),
) -> Plan:
    """List (unless given the :func:`listing` as ``files``) and hash the clips under ``root`` and, with
    ``resume``, read ``out_dir/audit.csv`` to keep the rows that still answer: a clip's own row, or for a
    file renamed or moved (or copied), an ok row of the same bytes and options under another path. Reads
    only (so it can run while the workers start). ``skipped``: names that are no file to read, with why
    (:func:`listing`; without ``files`` they are found here), each an error row (:func:`no_file_row`)."""
    started = time.perf_counter()
    opts = opts if opts is not None else judge_options()
    if files is None:
        found: list[tuple[Path, str]] = []
        files, skipped = listing(root, skipped=found), found
    clips = list_clips(root, source_map, files)
    previous = {r["path"]: r for r in Table.read(out_dir / "audit.csv")} if resume and (out_dir / "audit.csv").is_file() else {}
    options = {c.rel: options_text(opts, c) for c in clips}
    # A file renamed or moved is found by its bytes (an ok row: an error's message names the old path).
    by_content = {(r.get("sha256"), r.get("options")): r for r in previous.values() if r.get("status") == "ok" and r.get("sha256")}
    kept = []
    for c in clips:
        row = previous.get(c.rel)
        if row is not None and reusable(row, c, options[c.rel]):
            kept.append(row)
            continue
        moved = by_content.get((c.sha256, options[c.rel])) if c.sha256 else None
        if moved is not None and reusable(moved, c, options[c.rel]):
            kept.append({**moved, "path": c.rel, "size": c.size, "source_files": json.dumps(list(c.sources)) if c.sources else None})
    done = {r["path"] for r in kept}
    todo = sorted((c for c in clips if c.rel not in done), key=lambda c: -c.size)
    base = root.resolve()
    return Plan(clips, options, kept, todo, started, [no_file_row(p, why, base, opts) for p, why in skipped])


@dataclass(frozen=True)
class Result:
    """What :func:`run` did: every row (one per clip, in path order), how many were computed now, the
    wall time, the executor's description, the files written and the files kept as they were (the
    histograms of a resumed audit whose drawn values did not change)."""

    rows: list[dict[str, Any]]
    computed: int
    seconds: float
    executor: str
    files: list[str]
    unchanged: tuple[str, ...] = ()


def load_drawing(warm: bool = False) -> None:
    """Import what the summary's histograms need (Matplotlib's figure and its Agg canvas: half a second);
    ``warm``: also draw a small histogram (to a temporary file: the first drawing loads fonts and caches, a
    tenth of a second that a side process spends before the last row rather than after it)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.backends.backend_agg
    import matplotlib.figure

    if warm:
        import tempfile

        from . import plots

        with tempfile.TemporaryDirectory(prefix="mjmotion-warm-up-") as tmp:
            plots.histograms({"warm-up": [0.0, 1.0, 1.0]}, Path(tmp) / "warm-up.png", title="warm-up")


def warm_drawing() -> None:
    """:func:`load_drawing` with a first drawing (the preload of the audit's side process)."""
    load_drawing(warm=True)


#: Folder locks this process holds (:func:`holding`): closed in every process it forks, so a side process
#: or worker left behind by a killed audit does not keep the folder locked.
_HELD: set[int] = set()


def _close_held() -> None:
    for fd in _HELD:
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_held)


@contextlib.contextmanager
def holding(out_dir: Path) -> Iterator[None]:
    """``out_dir`` for this audit alone while it runs: a second audit into the same folder at once (a
    ``--resume`` started in another terminal) would append its rows to the same ``audit.csv`` and
    rewrite the same Parquet file; it is refused instead. An advisory lock on the folder itself
    (``flock``), held by this process only (closed in the processes it forks) and released when it
    ends, however it ends; none where there is no ``fcntl``, or where the file system keeps no locks."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover (not POSIX)
        yield
        return
    fd = os.open(out_dir, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise MjmotionError(f"-o {out_dir}: another audit is writing there now; wait for it to end, or choose another folder") from None
        except OSError:
            pass  # a file system that keeps no locks: the audit runs unguarded, as it always did
        _HELD.add(fd)
        yield
    finally:
        _HELD.discard(fd)
        os.close(fd)


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
    planned: Plan | None = None,
    aside: Aside | None = None,
    unlisted: Sequence[str] = (),
) -> Result:
    """Audit every clip under ``root`` into ``out_dir`` on the executor ``ex`` (see the module doc);
    ``planned``: the :func:`plan` of the same arguments, made already (e.g. while the workers started);
    ``aside``: a side process that draws the histograms (made with :func:`warm_drawing` as its preload);
    ``unlisted``: folders under ``root`` that could not be listed (each with why), named in the summary."""
    opts = opts if opts is not None else judge_options()
    work = planned if planned is not None else plan(root, out_dir, resume=resume, source_map=source_map, opts=opts)
    out_dir.mkdir(parents=True, exist_ok=True)
    table = Table(out_dir, work.kept + work.no_files)
    todo, options = work.todo, work.options
    by_rel = {c.rel: c for c in todo}
    tasks = [(c.rel, (c.path, c.sha256, opts, c.sources, c.listed)) for c in todo]

    def meanwhile() -> None:
        # While the first clips run, this process is idle: the Parquet writer and the summary's
        # Matplotlib are loaded now rather than after the last row (where nothing runs beside them).
        table.write_parquet()
        if aside is None:
            load_drawing()

    # A resumed audit with nothing new to evaluate sends nothing out (``ex`` may be a bare Executor).
    outcomes = ex.run(audit_clip, tasks, timeout=timeout, desc="audit", unit="clip", progress=progress, meanwhile=meanwhile) if tasks else ()
    try:
        for out in outcomes:
            c = by_rel[out.key]
            value = out.value if out.ok else {"error": out.error}
            err = value.get("error")
            kind = (value.get("error_kind") or out.kind or "input") if err is not None else None
            table.add(
                {
                    "path": c.rel, "size": c.size, "sha256": c.sha256, "status": "ok" if err is None else "error",
                    "error": err, "error_kind": kind, "seconds": out.seconds if math.isfinite(out.seconds) else None,
                    "source_files": json.dumps(list(c.sources)) if c.sources else None, "options": options[c.rel],
                    "mjmotion_version": __version__, **{k: v for k, v in value.items() if k not in ("error", "error_kind")},
                }
            )  # fmt: skip
    finally:
        table.close()
    rows = sorted(table.rows, key=lambda r: r["path"])
    seconds = time.perf_counter() - work.started
    where = ex.describe() if todo else "no workers (nothing new to evaluate)"
    files = [str(table.csv), str(table.parquet)]
    written, unchanged = write_summary(
        out_dir, rows, root=root, executor=where, computed=len(todo), seconds=seconds, timeout=timeout, aside=aside, unlisted=unlisted,
        no_files=len(work.no_files),
    )  # fmt: skip
    return Result(rows, len(todo), seconds, where, files + written, unchanged)


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


def histograms_digest(headline: Mapping[str, Sequence[float]], title: str) -> str:
    """What ``histograms.png`` draws, as a SHA-256: the headline values, the title and the mjmotion version
    (stored in the PNG, so a resumed audit whose values did not change keeps the picture it has)."""
    drawn = {"version": __version__, "title": title, "series": {k: [float(v) for v in vals] for k, vals in headline.items()}}
    return hashlib.sha256(json.dumps(drawn, sort_keys=True).encode()).hexdigest()


def _md_cell(text: str) -> str:
    """``text`` safe in a Markdown table cell: one printable line (line breaks and terminal escapes of a
    file's name written as ``\\n``, ``\\x1b``: :func:`mjmotion.errors.printable`), its pipes escaped."""
    return printable(text).replace("|", "\\|")


def _message_in_row(message: str, path: Path) -> str:
    """An error message without the file's path in front (the table's clip cell names it): ``P:12: x`` reads
    ``line 12: x``, ``P: x`` reads ``x``; a message naming another file (a source) is kept whole."""
    head = f"{path}:"
    if not message.startswith(head):
        return message
    rest = message[len(head) :]
    line = re.match(r"(\d+): ", rest)
    return f"line {line.group(1)}: {rest[line.end() :]}" if line else rest.strip()


def _md_code(path: str) -> str:
    """A path as inline code in a table cell, whatever it holds (backticks, pipes, line breaks)."""
    text = _md_cell(path)
    fence = "``" if "`" in text else "`"
    return f"{fence} {text} {fence}" if fence == "``" else f"`{text}`"


def misread(rows: Sequence[Mapping[str, Any]]) -> list[tuple[str, str, str]]:
    """``(path, standing axis, up axis read)`` of the rows whose body stands along another file axis than
    the ``--up`` they were read with (their ``standing_axis`` column against their options)."""
    odd = []
    for r in rows:
        axis = r.get("standing_axis")
        try:
            up = json.loads(r.get("options") or "{}").get("up", "y")
        except (ValueError, AttributeError):
            up = "y"
        if isinstance(axis, str) and axis != f"+{up}":
            odd.append((r["path"], axis, up))
    return odd


def _misread(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The summary's lines on the :func:`misread` clips (nothing when there are none)."""
    odd = misread(rows)
    if not odd:
        return []
    shown = "; ".join(f"{_md_code(p)} {a.upper()}" for p, a, _ in odd[:WORST]) + (f"; and {len(odd) - WORST} more" if len(odd) > WORST else "")
    ups = sorted({u for _, _, u in odd})
    return [
        "",
        f"**{len(odd)} clip{'s' * (len(odd) != 1)} stand{'s' * (len(odd) == 1)} along another file axis than `--up {'/'.join(ups)}` reads** "
        f"(the `standing_axis` column: the head above the feet in most frames): {shown}. Their ground metrics measure a body "
        "lying down; unless they are of a body lying down, audit them again with the other `--up` (see `mjmotion info CLIP`).",
    ]


def write_summary(
    out_dir: Path,
    rows: Sequence[Mapping[str, Any]],
    *,
    root: Path,
    executor: str,
    computed: int,
    seconds: float,
    timeout: float | None,
    aside: Aside | None = None,
    unlisted: Sequence[str] = (),
    no_files: int = 0,
) -> tuple[list[str], tuple[str, ...]]:
    """``summary.md`` and ``histograms.png``: counts by flavour, distributions, worst clips, errors, parameters.
    Returns the files written and the files kept: ``histograms.png`` is drawn again only when what it
    draws changed (:func:`histograms_digest`, stored in the PNG; Matplotlib is not even loaded otherwise), in
    the side process ``aside`` if given, while the rest is written."""
    import numpy as np

    from . import plots
    from .executor import here

    ok = [r for r in rows if r.get("status") == "ok"]
    named = root if root.name not in ("", "..") else root.resolve()  # (`audit .` read "Audit of ." and "12 clips of ")
    lines = [
        f"# Audit of {printable(named)}",
        "",
        f"{len(rows)} clips: {len(ok)} ok, {len(rows) - len(ok)} error; {computed} evaluated in this run "
        f"({len(rows) - computed - no_files} kept from the previous table"
        + (f", {no_files} name{'s' * (no_files != 1)} ending in .bvh that {'are' if no_files != 1 else 'is'} no file to read" if no_files else "")
        + f") in {seconds:.1f} s on {executor}.",
        "",
        "## Clips by skeleton flavour",
        "",
        "| flavour | clips | ok | error |",
        "|---|---|---|---|",
    ]
    by: dict[str, list[int]] = {}
    for r in rows:
        # (not "unreadable": that is one error kind; a file refused as input has no skeleton read either)
        n = by.setdefault(str(r.get("flavour") or NO_FLAVOUR), [0, 0])
        n[0 if r.get("status") == "ok" else 1] += 1
    lines += [f"| {f} | {a + b} | {a} | {b} |" for f, (a, b) in sorted(by.items())]
    lines += _misread(rows)
    metrics = numeric_metrics(rows)
    files: list[str] = []
    unchanged: tuple[str, ...] = ()
    varying = {k: [v for v, _ in vals] for k, vals in metrics.items() if len({v for v, _ in vals}) > 1}
    # Histograms of the headline metrics that vary (a breakdown like sensitivity[h_c=…].x, hit.x and the rest are in the tables).
    headline = {k: varying[k] for k in HEADLINE if k in varying}
    png = out_dir / "histograms.png"
    drawn: Callable[[], object] = lambda: None
    if headline:
        title = f"{len(ok)} clips of {printable(named.name or named)}"
        digest = histograms_digest(headline, title)
        if plots.png_text(png).get(HISTOGRAMS_KEY) == digest:
            unchanged = (str(png),)
        else:
            draw = aside.call if aside is not None else here
            drawn = draw(plots.histograms, headline, png, title=title, metadata={HISTOGRAMS_KEY: digest})
            files.append(str(png))
    else:
        png.unlink(missing_ok=True)  # an older table's picture would no longer match summary.md
    if metrics:
        lines += [
            "",
            "## Distributions (ok clips, finite values)",
            "",
            "![histograms of the headline metrics that vary](histograms.png)" if headline else "",
            "",
            "| metric | clips | min | median | p90 | max |",
            "|---|---|---|---|---|---|",
        ]
        for k, vals in metrics.items():
            a = np.array([v for v, _ in vals])
            lines.append(f"| {k} | {a.size} | {a.min():.4g} | {np.median(a):.4g} | {np.percentile(a, 90):.4g} | {a.max():.4g} |")
        # Both ends: which is worse depends on the metric (a high skate, a low contact_fraction, a floor far either way).
        lines += [
            "",
            f"## Worst clips per metric (the {WORST} highest and the {WORST} lowest values)",
            "",
            "| metric | highest | lowest |",
            "|---|---|---|",
        ]
        for k, vals in metrics.items():
            if k in varying:
                ranked = sorted(vals, key=lambda t: (-t[0], t[1]))
                ends = (ranked[:WORST], ranked[::-1][:WORST])
                lines.append(f"| {k} | " + " | ".join("; ".join(f"{_md_code(p)} {v:.4g}" for v, p in end) for end in ends) + " |")
    errors = [r for r in rows if r.get("status") != "ok"]
    if errors:
        base = root.resolve()  # (the workers' messages name the resolved path)
        lines += ["", "## Errors", "", "| clip | kind | message |", "|---|---|---|"]
        lines += [
            f"| {_md_code(r['path'])} | {r.get('error_kind')} | {_md_cell(_message_in_row(str(r.get('error')), base / r['path']))} |" for r in errors
        ]
    if unlisted:
        lines += ["", "## Folders not listed", "", "Their .bvh files, if any, are not in the table:", ""]
        lines += [f"- {_md_cell(folder)}" for folder in unlisted]
    params = next((r["params"] for r in ok if r.get("params")), None)
    opts = next((r["options"] for r in rows if r.get("options")), None)
    lines += [
        "",
        "## Parameters",
        "",
        f"- mjmotion {__version__}; per-clip time limit: {f'{timeout:g} s' if timeout else 'none'}",
        f"- judge options (`mjmotion evaluate`'s defaults unless given): `{opts}`",
        f"- report thresholds: `{params}`" if params else "- report thresholds: none (no clip was judged)",
        "- metric definitions: docs/METRICS.md in mjmotion's repository (`mjmotion evaluate --help` names each option)",
    ]
    drawn()  # the picture first: summary.md shows it
    write_text_atomic(out_dir / "summary.md", "\n".join(lines) + "\n")
    return [str(out_dir / "summary.md"), *files], unchanged
