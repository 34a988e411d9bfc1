"""The judge's record: what ``audit`` writes for a few shared clips, with the revision that wrote it.

``tests/test_audit.py::test_a_changed_row_value_comes_with_a_new_judge_revision`` compares a fresh
audit row of each clip below with ``tests/data/judge_record.json``: a value, or the set of columns,
that moved without :data:`mjmotion.thresholds.JUDGE_REVISION` being raised would let
``audit --resume`` keep old rows beside new ones. After raising the revision, write the record
again (from the repository, with the shared clips)::

    MJMOTION_DATA=../shared/mocap python tests/judge_record.py
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

RECORD = Path(__file__).resolve().parent / "data" / "judge_record.json"

#: ``(clip, sources)`` under the shared data folder: one clip per skeleton flavour (walks and a run,
#: tilted floors, daz's leading T-pose), and one judged against another take of the same subject (``--source-map``).
CLIPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("cmu_asfamc_converted/16_15.bvh", ()),
    ("cmu_cgspeed_daz/09_01.bvh", ()),
    ("cmu_cgspeed_daz/07_04.bvh", ("cmu_cgspeed_daz/07_01.bvh",)),
    ("cmu_iclone_ccrig/007_04.bvh", ()),
    ("cmu_cgspeed_max/131_02.bvh", ()),
)

#: Relative tolerance of a float: well above what another NumPy or BLAS build moves, well below
#: what a changed definition or bound does.
RTOL = 1e-4
ATOL = 1e-9


def rows(data: Path) -> dict[str, dict[str, Any]]:
    """A fresh audit row (its metric columns and frames) of every clip in :data:`CLIPS`."""
    from mjmotion import audit

    opts = audit.judge_options()
    out = {}
    for rel, sources in CLIPS:
        path = data / rel
        sha, listed = audit.fingerprint(path)  # listed: the row's worker trusts the bytes hashed here, as audit's own do
        row = audit.audit_clip(str(path), sha, opts, tuple(str(data / s) for s in sources), listed)
        out[rel] = {k: row[k] for k in sorted(row) if k != "params"}  # params: the options, recorded beside
    return out


def differences(recorded: dict[str, dict[str, Any]], fresh: dict[str, dict[str, Any]]) -> list[str]:
    """One line per clip or column whose value (``RTOL``), presence or type differs."""
    out = []
    for clip in sorted(set(recorded) | set(fresh)):
        a, b = recorded.get(clip), fresh.get(clip)
        if a is None or b is None:
            out.append(f"{clip}: {'not recorded' if a is None else 'not computed'}")
            continue
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{clip}: column {k} {'new' if k not in a else 'gone'}")
            elif not _same(a[k], b[k]):
                out.append(f"{clip}: {k} was {a[k]!r}, now {b[k]!r}")
    return out


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, str) and isinstance(b, str) and a.startswith("[") and b.startswith("["):  # a list column (JSON)
        x, y = json.loads(a), json.loads(b)
        return len(x) == len(y) and all(_same(u, v) for u, v in zip(x, y))
    if isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or isinstance(b, str):
        return type(a) is type(b) and a == b
    if isinstance(a, int) and isinstance(b, int):
        return a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(float(a), float(b), rel_tol=RTOL, abs_tol=ATOL) or (math.isnan(a) and math.isnan(b))
    return bool(a == b)


def main() -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from conftest import data_dir

    from mjmotion.thresholds import JUDGE_REVISION

    data = data_dir()
    if data is None:
        print("error: the shared clips were not found: set MJMOTION_DATA", file=sys.stderr)
        return 2
    RECORD.write_text(json.dumps({"judge_revision": JUDGE_REVISION, "rows": rows(data)}, indent=1, sort_keys=True) + "\n")
    print(f"wrote {RECORD} (judge revision {JUDGE_REVISION}, {len(CLIPS)} clips)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
