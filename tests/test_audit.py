"""``mjmotion audit``: one row per file, errors as rows, the judge's numbers, resume, faults, bad input.

The corpus is small (short cuts of shared clips of every flavour, the bundled walk, hostile files
from tests/data/bad): the point is the machinery. Most cases run on one LocalCluster of two
workers shared by the module; one runs the CLI's own LocalCluster, one a real ``dask scheduler``
with two ``dask worker`` processes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from conftest import require_data, within

from mjmotion import audit, bvh, cli, executor, synth
from mjmotion import evaluate as ev
from mjmotion.commands._common import named
from mjmotion.commands.evaluate import evaluate_file
from mjmotion.errors import MjmotionError, printable
from mjmotion.inputs import find_bvh
from mjmotion.trim import leading_transient

BAD = Path(__file__).resolve().parent / "data" / "bad"
#: Shared clips cut short, one per flavour (path under the data folder, frames kept).
CUTS = (
    ("cmu_asfamc_converted/16_15.bvh", 90),
    ("cmu_cgspeed_daz/07_01.bvh", 90),
    ("cmu_cgspeed_max/131_01.bvh", 90),
    ("cmu_iclone_ccrig/002_01.bvh", 45),
)
HOSTILE = ("binary_garbage.bvh", "empty.bvh", "values_too_few.bvh", "frames_larger.bvh", "base.bvh", "single_frame.bvh")


def _snapshot(root: Path) -> dict[str, tuple[str, int]]:
    """Every entry under ``root`` (links not followed): content hash and mtime, to show nothing was written."""
    out = {}
    for dirpath, dirs, files in os.walk(root):
        for n in dirs + files:
            p = Path(dirpath) / n
            rel = str(p.relative_to(root))
            out[rel] = (hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() and not p.is_symlink() else "", p.lstat().st_mtime_ns)
    return out


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> Path:
    data = require_data()
    root = tmp_path_factory.mktemp("corpus") / "clips"
    for rel, n in CUTS:
        m = bvh.read(data / rel)
        out = root / Path(rel).parent.name / Path(rel).name
        out.parent.mkdir(parents=True, exist_ok=True)
        bvh.write(m[: n + 4], out)
    (root / "bundled").mkdir()
    assert cli.main(["synth", "walk", "--seconds", "0.8", "-o", str(root / "bundled" / "WALK.BVH")]) == 0
    (root / "hostile").mkdir()
    for name in HOSTILE:
        shutil.copy(BAD / name, root / "hostile" / name)
    (root / "notes.txt").write_text("not a clip")
    outside = tmp_path_factory.mktemp("outside")
    shutil.copy(BAD / "empty.bvh", outside / "elsewhere.bvh")
    (root / "linked_folder").symlink_to(outside, target_is_directory=True)  # not followed out of DIR
    (root / "linked_file.bvh").symlink_to(outside / "elsewhere.bvh")  # leads out of DIR: left out
    return root


@pytest.fixture(scope="module")
def dask2():
    ex = executor.start(workers=2, preload=audit.PRELOAD)
    yield ex
    ex.close()


def _listed(root: Path) -> list[str]:
    return sorted(p.relative_to(root).as_posix() for p in find_bvh(root))


def _rows(out: Path) -> dict[str, dict]:
    return {r["path"]: r for r in audit.Table.read(out / "audit.csv")}


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_the_listing_recurses_and_stays_inside(corpus):
    listed = _listed(corpus)
    assert "bundled/WALK.BVH" in listed and "hostile/empty.bvh" in listed
    assert not any(p.startswith("linked") for p in listed) and len(listed) == len(CUTS) + 1 + len(HOSTILE)


def test_audit_on_a_local_cluster_matches_evaluate(corpus, tmp_path, capsys):
    """The CLI with --workers 2: one row per file, hostile files as error rows, evaluate's numbers, DIR untouched."""
    before = _snapshot(corpus)
    out = tmp_path / "audit"
    assert cli.main(["audit", str(corpus), "-o", str(out), "--workers", "2", "--dashboard"]) == 0
    text = capsys.readouterr().out
    assert "LocalCluster, 2 worker processes" in text and f"{len(_listed(corpus))} clips: {len(CUTS) + 1} ok, {len(HOSTILE)} error" in text
    try:
        import bokeh  # noqa: F401

        assert "; dashboard http://127.0.0.1:" in text
    except ImportError:  # Dask runs no dashboard without Bokeh: said once, not a link to nothing
        assert "dashboard http" not in text and "Dask started no dashboard (it needs bokeh" in text
    assert _snapshot(corpus) == before
    rows = _rows(out)
    assert sorted(rows) == _listed(corpus)
    opts = audit.judge_options()
    for rel, row in rows.items():
        path = str(corpus / rel)
        assert row["sha256"] == hashlib.sha256(Path(path).read_bytes()).hexdigest() and row["size"] == os.path.getsize(path)
        if rel.startswith("hostile/"):
            assert row["status"] == "error" and row["error_kind"] == "input"
            try:
                evaluate_file(path, opts)
            except Exception as e:  # the message evaluate DIR gives for the same file (named), on one line
                assert row["error"] == executor.one_line(named(path, str(e))) and row["error"].startswith(path + ":")
            else:
                pytest.fail(f"{rel} evaluates")
            continue
        assert row["status"] == "ok" and row.get("error") is None
        want = evaluate_file(path, opts)
        metrics = audit.metric_columns(want["report"])
        assert metrics and all(_same(row.get(k), v) for k, v in metrics.items() if v is not None), rel
        assert row["frames"] == want["report"]["n_frames"] and row["skipped_frames"] == want["skipped_frames"]
    assert rows["cmu_asfamc_converted/16_15.bvh"]["flavour"] == "cmu-asf" and rows["cmu_iclone_ccrig/002_01.bvh"]["flavour"] == "cc-rig"
    assert rows["bundled/WALK.BVH"]["flavour"] == "mixamo-style" and rows["hostile/base.bvh"]["flavour"] == "Hips/5 joints"
    # The Parquet file holds the same table.
    table = pq.read_table(out / "audit.parquet").to_pylist()
    assert len(table) == len(rows)
    for r in table:
        assert all(_same(r.get(k), v) for k, v in rows[r["path"]].items()), r["path"]
    summary = (out / "summary.md").read_text()
    assert "| cmu-asf | 1 | 1 | 0 |" in summary and f"| {audit.NO_FLAVOUR} | {len(HOSTILE) - 2} | 0 | {len(HOSTILE) - 2} |" in summary
    assert "`hostile/empty.bvh`" in summary and "planted_skate_mm_per_s" in summary and (out / "histograms.png").stat().st_size > 0
    # The errors table names each file once, in its clip cell (the message said the full path again).
    errors = summary.split("## Errors")[1].split("## Parameters")[0]
    assert str(corpus) not in errors and errors.count("`hostile/") == len([r for r in rows if r.startswith("hostile/")])
    assert any(re.search(r"\| line \d+: ", line) for line in errors.splitlines()), errors


def test_error_cells_drop_the_path_the_clip_cell_names():
    clip = Path("/data/run/a.bvh")
    assert audit._message_in_row("/data/run/a.bvh:12: expected a number", clip) == "line 12: expected a number"
    assert audit._message_in_row("/data/run/a.bvh: too few frames (3)", clip) == "too few frames (3)"
    # A message about another file (its source, or a file whose name extends this one's) stays whole.
    for other in ("/data/run/src.bvh:4: bad", "/data/run/a.bvh.bak:4: bad"):
        assert audit._message_in_row(other, clip) == other


def test_a_worker_trusts_a_file_only_while_it_is_unchanged(tmp_path):
    """Same host, device, inode, size and times, last changed well before it was hashed: no second hash."""
    clip = tmp_path / "a.bvh"
    shutil.copy(BAD / "base.bvh", clip)
    sha, listed = audit.fingerprint(clip)
    assert sha == hashlib.sha256(clip.read_bytes()).hexdigest() and listed.stat[2] == clip.stat().st_size
    assert not audit.unchanged(clip, listed)  # just written: a write in the same clock tick would keep its times
    later = dataclasses.replace(listed, hashed_at=time.time() + 2 * audit.RACY)  # as if hashed long after it was written
    assert audit.unchanged(clip, later)
    assert not audit.unchanged(clip, dataclasses.replace(later, host="another-host"))
    time.sleep(0.05)
    text = clip.read_bytes()
    clip.write_bytes(text.replace(b"Hips", b"Hipz"))  # same size, other bytes
    assert not audit.unchanged(clip, later)
    os.replace(tmp_path / "a.bvh", tmp_path / "b.bvh")
    assert not audit.unchanged(clip, later)  # gone (another file at the path would have another inode)


def test_rows_are_of_the_bytes_listed(tmp_path, dask2, monkeypatch):
    root = tmp_path / "clips"
    root.mkdir()
    for name in ("one.bvh", "two.bvh"):
        assert cli.main(["synth", "walk", "--seconds", "0.5", "--seed", str(len(name)), "-o", str(root / name)]) == 0
    planned = audit.plan(root, tmp_path / "audit")
    # Listed long after they were written (so a worker would trust them), then one is rewritten: the worker sees it.
    planned = dataclasses.replace(
        planned, todo=[dataclasses.replace(c, listed=dataclasses.replace(c.listed, hashed_at=time.time() + 2 * audit.RACY)) for c in planned.todo]
    )
    m = bvh.read(root / "two.bvh")
    bvh.write(m.replace(root_positions=m.root_positions + [0.0, 0.0, 0.01]), root / "two.bvh")
    res = audit.run(root, tmp_path / "audit", dask2, planned=planned, progress=False)
    by = {r["path"]: r for r in res.rows}
    assert by["one.bvh"]["status"] == "ok"
    assert by["two.bvh"]["status"] == "error" and "not the file that was listed" in by["two.bvh"]["error"]
    # A file written to while it is evaluated: an error row, not numbers of bytes nobody listed.
    from mjmotion.commands import evaluate as cmd

    real = cmd.evaluate_one

    def writes_meanwhile(path, opts):
        out = real(path, opts)
        with open(path, "a") as f:
            f.write("\n")
        return out

    monkeypatch.setattr(cmd, "evaluate_one", writes_meanwhile)
    clip = next(c for c in audit.plan(root, tmp_path / "audit").clips if c.rel == "one.bvh")
    with pytest.raises(MjmotionError, match="changed while it was evaluated"):
        audit.audit_clip(clip.path, clip.sha256, audit.judge_options(), (), clip.listed)


def test_table_types_follow_the_values_and_parquet_needs_no_pandas(tmp_path):
    """Run in a fresh interpreter: writing the Parquet file must not import pandas (a third of a second)."""
    code = f"""
import math, sys
from pathlib import Path
import pyarrow.parquet as pq
from mjmotion import audit
rows = [
    {{"path": "odd\\npath, \\"quoted\\".bvh", "status": "error", "error": "bad, \\"quoted\\"", "size": 3, "m_num": 1, "m_bool": True, "m_mix": "True", "m_nan": float("nan")}},
    {{"path": "b.bvh", "status": "ok", "size": 4, "frames": 10, "m_num": 2.5, "m_bool": False, "m_mix": 3, "m_nan": float("-inf")}},
]
out = Path({str(tmp_path)!r})
t = audit.Table(out, rows[:1])
t.add(rows[1])
t.close()
assert "pandas" not in sys.modules
table = pq.read_table(out / "audit.parquet")
types = {{f.name: str(f.type) for f in table.schema}}
assert types["m_num"] == "double" and types["m_bool"] == "bool" and types["m_mix"] == "string" and types["size"] == "int64", types
assert types["error_kind"] == "string" and types["frames"] == "int64", types  # no value yet: the column's fixed type
got = table.to_pylist()
assert got[0]["path"] == rows[0]["path"] and got[0]["error"] == rows[0]["error"] and got[0]["frames"] is None
assert got[0]["m_num"] == 1.0 and got[1]["m_mix"] == "3" and math.isnan(got[0]["m_nan"]) and got[1]["m_nan"] == -math.inf
assert [r["path"] for r in audit.Table.read(out / "audit.csv")] == [r["path"] for r in rows]
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_plan_only_reads(corpus, tmp_path, dask2):
    out = tmp_path / "audit"
    audit.run(corpus, out, dask2, progress=False)
    before, outputs = _snapshot(corpus), _snapshot(out)
    planned = audit.plan(corpus, out, resume=True)
    assert not planned.todo and len(planned.kept) == len(planned.clips) == len(_listed(corpus))
    assert _snapshot(corpus) == before and _snapshot(out) == outputs


def test_clips_read_with_the_wrong_up_axis_are_named_in_the_summary(tmp_path, dask2):
    """A Z-up file audited with the default --up y lies on its side: its row's standing_axis says +z,
    and summary.md names it (the judge's numbers alone looked ordinary: a floor 0.2 m down)."""
    import dataclasses

    root = tmp_path / "clips"
    root.mkdir()
    walk = synth.walk(seconds=1.0).motion
    bvh.write(walk, root / "yup.bvh")
    bvh.write(walk.replace(skeleton=dataclasses.replace(walk.skeleton, up="z")), root / "zup.bvh")
    res = audit.run(root, tmp_path / "out", dask2, progress=False)
    axes = {r["path"]: r["standing_axis"] for r in res.rows}
    assert axes == {"yup.bvh": "+y", "zup.bvh": "+z"} and _rows(tmp_path / "out")["zup.bvh"]["standing_axis"] == "+z"
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert "**1 clip stands along another file axis than `--up y` reads**" in summary and "`zup.bvh` +Z." in summary
    res = audit.run(root, tmp_path / "out_z", dask2, opts=audit.judge_options(up="z"), progress=False)
    assert "`yup.bvh` +Y." in (tmp_path / "out_z" / "summary.md").read_text()


def test_resume_recomputes_only_what_changed(corpus, tmp_path, dask2):
    root = tmp_path / "clips"
    shutil.copytree(corpus, root, symlinks=True)
    out = tmp_path / "audit"
    first = audit.run(root, out, dask2, progress=False)
    assert first.computed == len(first.rows) == len(_listed(root))
    again = audit.run(root, out, dask2, resume=True, progress=False)
    assert again.computed == 0
    assert [r["path"] for r in again.rows] == [r["path"] for r in first.rows]
    for a, b in zip(again.rows, first.rows):  # kept exactly as they were (run times included)
        assert all(_same(a.get(k), b.get(k)) for k in a.keys() | b.keys()), a["path"]
    # A changed file is evaluated again, and only it.
    walk = root / "bundled" / "WALK.BVH"
    m = bvh.read(walk)
    bvh.write(m[: m.n_frames // 2], walk)
    changed = audit.run(root, out, dask2, resume=True, progress=False)
    assert changed.computed == 1
    new = {r["path"]: r for r in changed.rows}["bundled/WALK.BVH"]
    assert new["frames"] == m.n_frames // 2 and new["sha256"] == audit.sha256_file(walk)
    # A crash in the middle of writing a row: the cut line is dropped and that clip evaluated again.
    csv_path = out / "audit.csv"
    text = csv_path.read_text()
    csv_path.write_text(text[: len(text) - len(text.splitlines()[-1]) // 2 - 1])
    cut = audit.run(root, out, dask2, resume=True, progress=False)
    assert cut.computed == 1 and len(cut.rows) == len(first.rows)
    assert sorted(_rows(out)) == _listed(root)
    # Files moved and copied keep their rows by their bytes (all were evaluated again); a moved error row
    # is evaluated again (its message names the old path).
    before = _rows(out)
    (root / "moved").mkdir()
    shutil.move(root / "bundled" / "WALK.BVH", root / "moved" / "walk.bvh")
    shutil.copy(root / "moved" / "walk.bvh", root / "moved" / "copy.bvh")
    errors = [p for p, r in before.items() if r["status"] == "error" and (root / p).is_file() and not (root / p).is_symlink()]
    shutil.move(root / errors[0], root / "moved" / "bad.bvh")
    moved = audit.run(root, out, dask2, resume=True, progress=False)
    assert moved.computed == 1, [r["path"] for r in moved.rows]
    after = _rows(out)
    assert sorted(after) == _listed(root) and "bundled/WALK.BVH" not in after
    for name in ("moved/walk.bvh", "moved/copy.bvh"):
        assert after[name]["sha256"] == before["bundled/WALK.BVH"]["sha256"]
        assert after[name]["planted_skate_mm_per_s"] == before["bundled/WALK.BVH"]["planted_skate_mm_per_s"]
    assert "moved/bad.bvh" in after["moved/bad.bvh"]["error"]


def test_resume_recomputes_rows_of_another_judge_revision(tmp_path, dask2, monkeypatch):
    root = tmp_path / "clips"
    root.mkdir()
    assert cli.main(["synth", "walk", "--seconds", "0.5", "-o", str(root / "walk.bvh")]) == 0
    out = tmp_path / "audit"
    first = audit.run(root, out, dask2, progress=False)
    assert first.computed == 1 and json.loads(first.rows[0]["options"])["judge_revision"] == audit.JUDGE_REVISION
    assert audit.run(root, out, dask2, resume=True, progress=False).computed == 0
    # A table an older judge wrote (same bytes, options and package version) is not reused.
    monkeypatch.setattr(audit, "JUDGE_REVISION", audit.JUDGE_REVISION + 1)
    newer = audit.run(root, out, dask2, resume=True, progress=False)
    assert newer.computed == 1 and json.loads(newer.rows[0]["options"])["judge_revision"] == audit.JUDGE_REVISION


def test_a_changed_row_value_comes_with_a_new_judge_revision():
    """Resume keys on the revision, so a row value (or column) that moves for the same file and options
    without ``JUDGE_REVISION`` being raised would mix two judges in one table: the record says."""
    import judge_record

    data = require_data()
    record = json.loads(judge_record.RECORD.read_text())
    fresh = judge_record.rows(data)
    changed = judge_record.differences(record["rows"], fresh)
    how = "then rewrite the record: MJMOTION_DATA=../shared/mocap python tests/judge_record.py"
    if record["judge_revision"] == audit.JUDGE_REVISION:
        assert not changed, (
            f"row values changed under judge revision {audit.JUDGE_REVISION}: raise mjmotion.thresholds.JUDGE_REVISION, {how}:\n" + "\n".join(changed)
        )
    else:
        pytest.fail(f"the record is of judge revision {record['judge_revision']}, the judge's is {audit.JUDGE_REVISION}: {how}")
    # The comparison is not blind: a value off by more than its tolerance, or a new column, is found.
    clip = next(iter(fresh))
    moved = {**fresh, clip: {**fresh[clip], "penetrate_mm": fresh[clip]["penetrate_mm"] * (1 + 3 * judge_record.RTOL) + 1e-6}}
    assert judge_record.differences(record["rows"], moved) == [
        f"{clip}: penetrate_mm was {record['rows'][clip]['penetrate_mm']!r}, now {moved[clip]['penetrate_mm']!r}"
    ]
    assert judge_record.differences(record["rows"], {**fresh, clip: {**fresh[clip], "new_metric": 1.0}}) == [f"{clip}: column new_metric new"]


def test_a_worker_killed_mid_run_still_gives_every_file_once(corpus, tmp_path, dask2):
    root = tmp_path / "clips"
    shutil.copytree(corpus, root, symlinks=True)
    for i in range(4):  # more work, so the kill lands while clips are running
        shutil.copy(corpus / "cmu_cgspeed_daz" / "07_01.bvh", root / f"copy_{i}.bvh")
    out = tmp_path / "audit"
    result: dict = {}
    runner = threading.Thread(target=lambda: result.update(res=audit.run(root, out, dask2, progress=False)))
    pids = dask2.client.run(os.getpid)
    runner.start()
    killed = None
    deadline = time.time() + 60
    while killed is None and runner.is_alive() and time.time() < deadline:
        busy = [a for a, keys in dask2.client.run(executor._executing, on_error="return").items() if isinstance(keys, dict) and keys]
        if busy:
            killed = pids[busy[0]]
            os.kill(killed, signal.SIGKILL)
        time.sleep(0.02)
    runner.join(120)
    assert killed is not None, "the audit ended before a worker could be killed"
    rows = result["res"].rows
    assert sorted(r["path"] for r in rows) == _listed(root)  # every file exactly once
    assert all(r["status"] == "ok" for r in rows if not r["path"].startswith("hostile/"))
    assert sorted(_rows(out)) == _listed(root)
    dask2.client.wait_for_workers(2, timeout=60)


def test_time_limit_turns_a_pathological_clip_into_an_error_row(tmp_path, dask2):
    root = tmp_path / "clips"
    root.mkdir()
    assert cli.main(["synth", "walk", "--seconds", "0.5", "-o", str(root / "short.bvh")]) == 0
    m = bvh.read(root / "short.bvh")
    text = (root / "short.bvh").read_text().splitlines()
    k = next(i for i, ln in enumerate(text) if ln.startswith("Frame Time"))
    body = text[k + 1 :] * 1600  # 49,600 frames of the same walk, 32 MB (the clip a stuck export might produce): several s
    (root / "long.bvh").write_text("\n".join([*text[: k - 1], f"Frames: {len(body)}", text[k], *body]) + "\n")
    res = audit.run(root, tmp_path / "audit", dask2, timeout=1.0, progress=False)
    by = {r["path"]: r for r in res.rows}
    assert by["long.bvh"]["status"] == "error" and by["long.bvh"]["error_kind"] == "timeout"
    assert "time limit of 1 s" in by["long.bvh"]["error"]
    assert by["short.bvh"]["status"] == "ok" and by["short.bvh"]["frames"] == m.n_frames, by["short.bvh"]
    # A timed-out row is not final: a resume without the limit tries it again.
    assert not audit.reusable(by["long.bvh"], audit.list_clips(root)[0], by["long.bvh"]["options"])
    dask2.client.wait_for_workers(2, timeout=60)


def test_source_map_adds_source_measures_and_reruns_on_a_source_change(tmp_path, dask2):
    root, src = tmp_path / "results", tmp_path / "sources"
    root.mkdir()
    src.mkdir()
    assert cli.main(["synth", "walk", "--seconds", "0.6", "-o", str(src / "walk.bvh")]) == 0
    m = bvh.read(src / "walk.bvh")
    bvh.write(m.replace(root_positions=m.root_positions * [1.0, 1.0, 1.02]), root / "lifted.bvh")
    bvh.write(m, root / "plain.bvh")
    smap = tmp_path / "map.json"
    smap.write_text(json.dumps({"lifted.bvh": "sources/walk.bvh"}))
    source_map = audit.read_source_map(smap, _listed(root))
    out = tmp_path / "audit"
    res = audit.run(root, out, dask2, source_map=source_map, progress=False)
    by = {r["path"]: r for r in res.rows}
    lifted = bvh.read(root / "lifted.bvh")
    start = leading_transient(lifted)
    assert by["lifted.bvh"]["vs_source.max_joint_speed_ratio"] == ev.max_joint_speed_ratio(lifted[start:], [m])
    assert by["lifted.bvh"]["vs_source.root_jump_m"] == ev.root_jump_m(lifted[start:], [m])
    assert by["plain.bvh"].get("vs_source.root_jump_m") is None
    bvh.write(m[: m.n_frames - 5], src / "walk.bvh")  # the source changed: the mapped clip is judged again
    again = audit.run(root, out, dask2, resume=True, source_map=audit.read_source_map(smap, _listed(root)), progress=False)
    assert again.computed == 1


def test_the_cli_walks_the_folder_once(tmp_path, monkeypatch):
    """DIR was walked three times with --source-map (the check for .bvh files, the map's keys, the plan): a
    database on a network file system paid each walk. The rows name the files under DIR as given."""
    root, src = tmp_path / "results", tmp_path / "sources"
    (root / "deep").mkdir(parents=True)
    src.mkdir()
    walk = synth.walk(seconds=0.8).motion
    bvh.write(walk, src / "walk.bvh")
    bvh.write(walk.replace(root_positions=walk.root_positions * [1.0, 1.0, 1.02]), root / "deep" / "lifted.bvh")
    bvh.write(walk, root / "plain.bvh")
    (root / "deep" / "broken.bvh").write_text("garbage\n")
    (tmp_path / "map.json").write_text(json.dumps({"deep/lifted.bvh": "sources/walk.bvh"}))
    walks = []
    counted = lambda *a, **k: walks.append(a[0]) or find_bvh(*a, **k)
    monkeypatch.setattr(audit, "find_bvh", counted)
    monkeypatch.setattr("mjmotion.inputs.find_bvh", counted)
    monkeypatch.chdir(tmp_path)  # DIR given relative: the workers still get whole paths
    assert cli.main(["audit", "results", "-o", "out", "--workers", "1", "--source-map", "map.json"]) == 0
    assert len(walks) == 1
    rows = _rows(tmp_path / "out")
    assert sorted(rows) == ["deep/broken.bvh", "deep/lifted.bvh", "plain.bvh"]
    assert rows["deep/broken.bvh"]["status"] == "error" and rows["plain.bvh"]["status"] == rows["deep/lifted.bvh"]["status"] == "ok"
    # summary.md names the broken file once (its message, with the whole path, had it again)
    errors = (tmp_path / "out" / "summary.md").read_text().split("## Errors")[1].split("## Parameters")[0]
    assert "| `deep/broken.bvh` | input | line 1: expected 'HIERARCHY'" in errors and str(tmp_path) not in errors, errors
    assert rows["deep/lifted.bvh"].get("vs_source.root_jump_m") is not None and rows["plain.bvh"].get("vs_source.root_jump_m") is None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def dask_processes(tmp_path):
    """A real ``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1 (nanny on, no dashboards)."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "dask"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    log = open(tmp_path / "dask.log", "w")
    procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], stdout=log, stderr=log, env=env)]
    try:
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [*dask, "worker", address, "--nthreads", "1", "--host", "127.0.0.1", "--no-dashboard", "--nanny"], stdout=log, stderr=log, env=env
                )
            )
        from distributed import Client

        with Client(address, timeout=60) as c:
            c.wait_for_workers(2, timeout=120)
        yield address
    finally:
        try:  # the scheduler closes its workers and itself
            with Client(address, timeout=10) as c:
                c.shutdown()
        except Exception:
            for p in procs:
                p.send_signal(signal.SIGINT)
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        log.close()


def test_audit_on_a_dask_scheduler_and_workers_gives_the_same_table(corpus, tmp_path, dask_processes, dask2, capsys):
    out_remote, out_local = tmp_path / "remote", tmp_path / "local"
    assert cli.main(["audit", str(corpus), "-o", str(out_remote), "--scheduler", dask_processes]) == 0
    printed = capsys.readouterr().out
    assert f"the scheduler at {dask_processes}, 2 worker threads" in printed
    assert "dashboard" not in printed  # started with --no-dashboard: its web server's address is no dashboard
    audit.run(corpus, out_local, dask2, progress=False)
    remote, local = _rows(out_remote), _rows(out_local)
    assert sorted(remote) == sorted(local) == _listed(corpus)
    for k in local:
        a = {c: v for c, v in remote[k].items() if c != "seconds"}
        b = {c: v for c, v in local[k].items() if c != "seconds"}
        assert all(_same(a.get(c), b.get(c)) for c in a.keys() | b.keys()), k


def _refused(argv: list[str], capsys, *phrases: str) -> None:
    rc = None
    try:
        rc = cli.main(argv)
    except SystemExit as e:
        rc = e.code
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert rc == 2 and len(lines) == 1 and "Traceback" not in err, err
    for p in phrases:
        assert p in lines[0], lines[0]


def test_bad_input_is_one_error_line(corpus, tmp_path, capsys):
    before = _snapshot(corpus)
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("no clips")
    _refused(["audit", str(tmp_path / "missing"), "-o", str(tmp_path / "o1")], capsys, "missing: no such folder")
    _refused(["audit", str(empty), "-o", str(tmp_path / "o2")], capsys, f"{empty}: no .bvh files")
    _refused(["audit", str(corpus), "-o", str(corpus / "results")], capsys, "is inside", str(corpus))
    _refused(["audit", str(corpus), "-o", str(corpus)], capsys, "is inside")
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "audit.csv").write_text("precious")
    _refused(["audit", str(corpus), "-o", str(taken)], capsys, str(taken), "--resume", "--force")
    assert (taken / "audit.csv").read_text() == "precious"
    _refused(["audit", str(corpus), "-o", str(taken), "--resume", "--force"], capsys, "not allowed with")
    port = _free_port()
    _refused(
        ["audit", str(corpus), "-o", str(taken), "--force", "--scheduler", f"tcp://127.0.0.1:{port}", "--connect-timeout", "1"],
        capsys,
        f"--scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered within 1 s",
    )
    assert (taken / "audit.csv").read_text() == "precious"  # --force replaces only once the workers answer
    for address, why in (
        ("notanaddress", "missing port"),
        ("http://127.0.0.1:1", "unknown scheme 'http'"),
        ("tcp://127.0.0.1:99999", "port 99999 is not a TCP port"),  # (waited out the connect timeout)
        ("tcp://127.0.0.1:-1", "port -1 is not a TCP port"),
        ("inproc://x", "an in-process scheduler"),
    ):
        t0 = time.perf_counter()  # refused as written, not after waiting out a connection (twice, with a traceback)
        _refused(["audit", str(corpus), "-o", str(taken), "--force", "--scheduler", address], capsys, "not a Dask scheduler address", why)
        assert time.perf_counter() - t0 < 5.0
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o3"), "--timeout", "-5"], capsys, "--timeout -5")
    (tmp_path / "loop").symlink_to(tmp_path / "loop")  # an internal error (RuntimeError: Symlink loop)
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")  # it read "File exists"
    for link in ("loop", "dangling"):
        _refused(["audit", str(corpus), "-o", str(tmp_path / link)], capsys, f"-o {tmp_path / link}: a symbolic link to nothing")
    _refused(["audit", "", "-o", str(tmp_path / "o7")], capsys, "DIR '': an empty path")  # (it audited the current folder)
    _refused(["audit", str(corpus), "-o", "/proc/mjmotion_audit"], capsys, "-o /proc/mjmotion_audit: cannot make the folder")
    for name in ("out.csv", "out.PARQUET", "summary.md"):  # a file's name made a folder of that name
        _refused(["audit", str(corpus), "-o", str(tmp_path / name)], capsys, f"-o {tmp_path / name}: names a", "file; an audit writes a folder")
        assert not (tmp_path / name).exists()
    (tmp_path / "o6").write_text("a file")
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o6" / "sub" / "out")], capsys, f"{tmp_path / 'o6'} is not a folder")
    assert (tmp_path / "o6").read_text() == "a file"
    bad_map = tmp_path / "map.json"
    bad_map.write_text(json.dumps({"nope.bvh": "x.bvh"}))
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o4"), "--source-map", str(bad_map)], capsys, "'nope.bvh' is not a .bvh file")
    bad_map.write_text(json.dumps({"bundled/WALK.BVH": "missing_source.bvh"}))
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(bad_map)], capsys, "missing_source.bvh not found")
    # A clip as its own source (was an error row per clip, after the listing and hashing).
    bad_map.write_text(json.dumps({"bundled/WALK.BVH": str(corpus / "bundled" / "WALK.BVH")}))
    _refused(
        ["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(bad_map)], capsys, "'bundled/WALK.BVH': source", "is the clip itself"
    )
    # --resume into a folder that was never an audit wrote an audit among its files; 256 local workers on a
    # few cores started no clip in 90 s; --dashboard with --scheduler waited for the scheduler first.
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("mine")
    _refused(["audit", str(corpus), "-o", str(tmp_path / "mine"), "--resume"], capsys, "holds no audit.csv to resume")
    assert [f.name for f in (tmp_path / "mine").iterdir()] == ["notes.txt"]
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--workers", "4097"], capsys, "--workers 4097")
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--workers", str(8 * executor.cores() + 4)], capsys, "local worker processes")
    _refused(
        ["audit", str(corpus), "-o", str(tmp_path / "o5"), "--scheduler", "tcp://127.0.0.1:1", "--dashboard"], capsys, "--dashboard with --scheduler"
    )
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--connect-timeout", "5"], capsys, "--connect-timeout 5: is the wait for --scheduler")
    # A key given twice (JSON keeps the last silently) and a folder for a map (was "d: Is a directory").
    bad_map.write_text('{"bundled/WALK.BVH": "walk_src.bvh", "bundled/WALK.BVH": "run_src.bvh"}')
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(bad_map)], capsys, "'bundled/WALK.BVH' is given more than once")
    _refused(
        ["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(tmp_path)],
        capsys,
        "--source-map",
        "is a directory; expected a JSON source map",
    )
    # Read as every small input is (a review): a pipe was waited on for good, /dev/zero read until memory
    # ran out, a file over the JSON limit read whole, JSON nested 100,000 deep an internal error.
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(fifo)], capsys, f"--source-map {fifo}: is a named pipe")
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", "/dev/zero"], capsys, "--source-map /dev/zero: is a character device")
    bad_map.write_text(" " * (2**20 + 1))
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(bad_map)], capsys, "larger than the limit of 1048576 bytes")
    bad_map.write_text("[" * 100_000)
    _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(bad_map)], capsys, "JSON nested too deeply")
    for source, why in (("", "an empty source path"), (".", "is a folder")):
        bad_map.write_text(json.dumps({"bundled/WALK.BVH": source}))
        _refused(["audit", str(corpus), "-o", str(tmp_path / "o5"), "--source-map", str(bad_map)], capsys, why)
    # A map kept in the output folder under an output's name was replaced by that output (with --force).
    (tmp_path / "o7").mkdir()
    (tmp_path / "o7" / "summary.md").write_text("{}")
    _refused(
        ["audit", str(corpus), "-o", str(tmp_path / "o7"), "--force", "--source-map", str(tmp_path / "o7" / "summary.md")],
        capsys,
        "is the audit's own summary.md",
    )
    assert (tmp_path / "o7" / "summary.md").read_text() == "{}"
    assert _snapshot(corpus) == before
    assert not any((tmp_path / f"o{i}").exists() for i in range(1, 6))


def test_a_table_cut_short_in_its_header_has_no_rows(tmp_path):
    """A crash while the header was written left one unterminated line; reading it for --resume raised
    IndexError (an internal error, exit 1). Nothing was written after it: no rows, the audit starts afresh."""
    csv_path = tmp_path / "audit.csv"
    for text in ("path,size,sha", "x"):
        csv_path.write_text(text)
        assert audit.Table.read(csv_path) == []


def test_the_summary_draws_the_headline_metrics_that_vary(tmp_path, monkeypatch):
    """summary.md's histograms are the headline metrics (audit.HEADLINE) that vary across the ok rows;
    a constant one and a breakdown column are left to the tables."""
    from mjmotion import plots

    drawn = {}

    def capture(values, out, **kw):
        drawn.update(values)
        Path(out).write_bytes(b"png")
        return Path(out)

    monkeypatch.setattr(plots, "histograms", capture)
    rows = [
        {"path": f"c{i}.bvh", "status": "ok", "planted_skate_mm_per_s": 10.0 * i, "penetrate_mm": 1.0, "sensitivity[h_c=0.03].skate_mm_per_s": float(i),
         "max_root_step_m": 0.01 * i}
        for i in range(4)
    ]  # fmt: skip
    files, unchanged = audit.write_summary(tmp_path, rows, root=tmp_path, executor="serial", computed=4, seconds=1.0, timeout=None)
    assert set(drawn) == {"planted_skate_mm_per_s"} and str(tmp_path / "histograms.png") in files and not unchanged
    text = (tmp_path / "summary.md").read_text()
    assert "max_root_step_m" in text and "sensitivity[h_c=0.03].skate_mm_per_s" in text  # still in the tables
    # Both ends of each metric: a low contact_fraction or a floor far below says as much as a high skate.
    row = [line for line in text.splitlines() if line.startswith("| planted_skate_mm_per_s |")][-1]  # (the first: its distribution)
    assert row == "| planted_skate_mm_per_s | `c3.bvh` 30; `c2.bvh` 20; `c1.bvh` 10; `c0.bvh` 0 | `c0.bvh` 0; `c1.bvh` 10; `c2.bvh` 20; `c3.bvh` 30 |"


def test_the_histograms_are_drawn_again_only_when_what_they_draw_changes(tmp_path, monkeypatch):
    """histograms.png carries the digest of what it draws: the same rows keep the picture (Matplotlib is
    not called), a changed value, title or a picture without the digest draws it again; a table with
    nothing that varies removes an older picture (summary.md no longer shows one)."""
    from mjmotion import plots

    rows = [{"path": f"c{i}.bvh", "status": "ok", "planted_skate_mm_per_s": 10.0 * i, "float_mm": 0.5 * i} for i in range(5)]
    png = tmp_path / "histograms.png"
    summary = dict(root=tmp_path, executor="serial", computed=5, seconds=1.0, timeout=None)
    files, unchanged = audit.write_summary(tmp_path, rows, **summary)
    first = png.read_bytes()
    assert str(png) in files and not unchanged
    assert plots.png_text(png)[audit.HISTOGRAMS_KEY] == audit.histograms_digest(
        {"planted_skate_mm_per_s": [10.0 * i for i in range(5)], "float_mm": [0.5 * i for i in range(5)]}, f"5 clips of {tmp_path.name}"
    )
    calls = []
    real = plots.histograms
    monkeypatch.setattr(plots, "histograms", lambda *a, **kw: calls.append(1) or real(*a, **kw))
    files, unchanged = audit.write_summary(tmp_path, [dict(r) for r in rows], **summary)
    assert not calls and unchanged == (str(png),) and str(png) not in files and png.read_bytes() == first
    rows[3]["float_mm"] = 7.0  # one value moved: drawn again, with the new digest
    files, unchanged = audit.write_summary(tmp_path, rows, **summary)
    assert calls == [1] and str(png) in files and not unchanged and png.read_bytes() != first
    png.write_bytes(first[:100])  # a cut or foreign picture has no readable digest: drawn again
    audit.write_summary(tmp_path, rows, **summary)
    drawn = {"planted_skate_mm_per_s": [r["planted_skate_mm_per_s"] for r in rows], "float_mm": [r["float_mm"] for r in rows]}
    assert calls == [1, 1] and plots.png_text(png)[audit.HISTOGRAMS_KEY] == audit.histograms_digest(drawn, f"5 clips of {tmp_path.name}")
    constant = [{**r, "planted_skate_mm_per_s": 1.0, "float_mm": 0.0} for r in rows]
    files, unchanged = audit.write_summary(tmp_path, constant, **summary)
    assert not png.exists() and not unchanged and "histograms.png" not in (tmp_path / "summary.md").read_text()


def test_resuming_an_unchanged_folder_starts_no_workers(tmp_path, capsys, monkeypatch):
    """`audit --resume` of a folder whose rows all answer: no cluster started, no scheduler contacted, the
    rows and the picture kept; a changed file starts the workers again and is evaluated."""
    from mjmotion import executor as ex_module

    root = tmp_path / "clips"
    root.mkdir()
    for i in range(2):
        assert cli.main(["synth", "walk", "--seconds", "0.5", "--seed", str(i), "-o", str(root / f"walk{i}.bvh")]) == 0
    out = tmp_path / "results" / "audit"  # its folder missing too: made, as `mkdir -p`
    assert cli.main(["audit", str(root), "-o", str(out), "--workers", "1"]) == 0
    capsys.readouterr()
    before = _snapshot(out)

    def refuse(*a, **kw):
        raise AssertionError("no workers should be started for an unchanged folder")

    monkeypatch.setattr(ex_module, "start", refuse)
    # Even a scheduler that answers nothing is not contacted: there is nothing to send it.
    assert cli.main(["audit", str(root), "-o", str(out), "--resume", "--scheduler", "tcp://127.0.0.1:9"]) == 0
    text = capsys.readouterr().out
    assert "no workers started" in text and "2 clips: 2 ok, 0 error; 0 evaluated" in text
    assert f"unchanged: {out / 'histograms.png'}" in text
    after = _snapshot(out)
    assert after["histograms.png"] == before["histograms.png"] and _rows(out).keys() == {"walk0.bvh", "walk1.bvh"}
    assert "0 evaluated in this run (2 kept" in (out / "summary.md").read_text()
    monkeypatch.undo()
    m = bvh.read(root / "walk1.bvh")
    bvh.write(m[: m.n_frames // 2], root / "walk1.bvh")
    assert cli.main(["audit", str(root), "-o", str(out), "--resume", "--workers", "1"]) == 0
    text = capsys.readouterr().out
    assert "LocalCluster" in text and "1 evaluated" in text and _rows(out)["walk1.bvh"]["frames"] == m.n_frames // 2


def test_awkward_folders_names_and_options(tmp_path, capsys):
    """Found by a review: a name that is not UTF-8 crashed the table (every resume too), a link loop
    named *.bvh crashed the listing, --keep-start was taken and ignored, and a corrupt audit.csv was
    an internal error on --resume."""
    data = require_data()
    root = tmp_path / "clips"
    root.mkdir()
    daz = bvh.read(data / "cmu_cgspeed_daz/07_01.bvh")[:40]  # opens with the daz T-pose
    bvh.write(daz, root / "walk.bvh")
    odd = os.fsdecode(b"caf\xe9.bvh")
    shutil.copy(root / "walk.bvh", root / odd)
    shutil.copy(root / "walk.bvh", root / "caf\\xe9.bvh")  # spelled as the byte's escape: the same row key, the run stopped
    (root / "a.bvh").symlink_to(root / "b.bvh")
    (root / "b.bvh").symlink_to(root / "a.bvh")
    os.mkfifo(root / "pipe.bvh")
    (root / "gone.bvh").symlink_to(root / "nothing")
    (root / "\x1b[2Jclear.bvh").symlink_to(root / "nothing")  # a note printed the escape (it cleared the screen)
    assert _listed(root) == sorted(["walk.bvh", odd, "caf\\xe9.bvh"])
    out = tmp_path / "audit"
    assert cli.main(["audit", str(root), "-o", str(out), "--workers", "1", "--keep-start"]) == 0
    # Names that are no file to read are error rows (they were dropped without a word, then only noted),
    # and evaluate DIR notes them; a name's escapes are written out.
    dangling = "a link to nothing (or a link loop)"
    odd_names = (("\\x1b[2Jclear.bvh", dangling), ("a.bvh", dangling), ("b.bvh", dangling), ("gone.bvh", dangling),
                 ("pipe.bvh", "not a regular file"))  # fmt: skip
    assert not [line for line in capsys.readouterr().err.splitlines() if line.startswith("note:")]
    assert cli.main(["evaluate", str(root), "--keep-start"]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if line.startswith("note:")]
    assert notes == [f"note: {root}/{name}: {why}; not evaluated" for name, why in odd_names]
    rows = _rows(out)
    ok = {"walk.bvh", "caf\\xe9.bvh", "caf\\\\xe9.bvh"}
    assert set(rows) == ok | {"\x1b[2Jclear.bvh", "a.bvh", "b.bvh", "gone.bvh", "pipe.bvh"}
    assert all(rows[p]["status"] == "ok" for p in ok)
    for name, why in odd_names:
        row = rows[name.replace("\\x1b", "\x1b")]
        assert row["status"] == "error" and row["error_kind"] == "unreadable" and row["error"].endswith(f"{name}: {why}"), row
    summary = (out / "summary.md").read_text()
    assert "| `\\x1b[2Jclear.bvh` | unreadable |" in summary
    # (a first audit said "5 kept from the previous table" of them)
    assert "3 evaluated in this run (0 kept from the previous table, 5 names ending in .bvh that are no file to read)" in summary
    rows = {p: r for p, r in rows.items() if p in ok}
    want = evaluate_file(str(root / "walk.bvh"), audit.judge_options(keep_start=True))
    assert rows["walk.bvh"]["skipped_frames"] == want["skipped_frames"] == 0
    assert rows["walk.bvh"]["planted_skate_mm_per_s"] == want["report"]["planted_skate_mm_per_s"]
    assert len(pq.read_table(out / "audit.parquet").to_pylist()) == 8
    assert cli.main(["audit", str(root), "-o", str(out), "--resume", "--keep-start"]) == 0  # every row kept, nothing crashes
    assert "every file's row is kept" in capsys.readouterr().out
    table = (out / "audit.csv").read_text()
    lines = table.splitlines(keepends=True)
    size = lines[0].split(",").index("size")
    cells = lines[1].split(",")
    cells[size] = "abc"  # an edited cell was an internal error (ValueError: could not convert string to float)
    (out / "audit.csv").write_text(lines[0] + ",".join(cells) + "".join(lines[2:]))
    _refused(["audit", str(root), "-o", str(out), "--resume"], capsys, "audit.csv: line 2, column size: 'abc' is not a number", "--force")
    (out / "audit.csv").unlink()
    (out / "audit.csv").mkdir()  # refused before a cluster starts
    _refused(["audit", str(root), "-o", str(out), "--resume"], capsys, "its audit.csv is not a file", "--force")
    (out / "audit.csv").rmdir()
    (out / "audit.csv").write_bytes(b"\xff\xfe")
    _refused(["audit", str(root), "-o", str(out), "--resume"], capsys, "cannot be read as an audit table", "--force")


def test_a_file_that_cannot_be_read_is_an_error_row_a_resume_tries_again(tmp_path, monkeypatch):
    """An unreadable file stopped the whole audit (hashed in the main process), and read errors on a
    worker were kept for good by --resume as if the file were bad."""
    data = require_data()
    clip = tmp_path / "walk.bvh"
    bvh.write(bvh.read(data / "cmu_asfamc_converted/16_15.bvh")[:30], clip)
    real = audit.fingerprint

    def refuse(path):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(audit, "fingerprint", refuse)
    (listed,) = audit.list_clips(tmp_path)
    assert listed.sha256 == "" and listed.rel == "walk.bvh" and listed.size == clip.stat().st_size  # (it read 0)
    row = audit.audit_clip(listed.path, listed.sha256, audit.judge_options())
    assert row["error_kind"] == "unreadable" and "cannot be read" in row["error"] and "Permission denied" in row["error"]
    monkeypatch.setattr(audit, "fingerprint", real)
    readable = audit.list_clips(tmp_path)[0]
    options = audit.options_text(audit.judge_options(), readable)
    kept = {"sha256": "", "options": options, "mjmotion_version": audit.__version__, "status": "error", "error_kind": "unreadable"}
    assert not audit.reusable(kept, readable, options)
    assert not audit.reusable({**kept, "sha256": readable.sha256}, readable, options)  # read later: tried again


def test_a_summary_of_the_current_folder_names_it_even_when_every_clip_fails(tmp_path, monkeypatch, capsys):
    """`audit .` wrote "# Audit of ." and a histogram of "12 clips of "; an audit where every file failed
    wrote "report thresholds: None"."""
    root = tmp_path / "broken"
    root.mkdir()
    (root / "bad.bvh").write_text("HIERARCHY\n")
    monkeypatch.chdir(root)
    assert cli.main(["audit", ".", "-o", str(tmp_path / "out"), "--workers", "1"]) == 0
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert summary.startswith(f"# Audit of {root.resolve()}\n"), summary[:80]
    assert "- report thresholds: none (no clip was judged)" in summary and "None" not in summary


def test_a_port_that_never_speaks_dask_is_one_error_line(tmp_path, capsys):
    """A scheduler address whose port accepts and never answers (another server) held audit for good:
    Dask's timeout bounds only the TCP connect."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    port = server.getsockname()[1]
    held: list = []
    threading.Thread(target=lambda: [held.append(server.accept()) for _ in range(8)], daemon=True).start()
    clips = tmp_path / "clips"
    clips.mkdir()
    shutil.copy(BAD / "empty.bvh", clips / "x.bvh")
    t0 = time.perf_counter()
    with within(30, "audit against a silent port"):
        _refused(
            ["audit", str(clips), "-o", str(tmp_path / "o"), "--scheduler", f"tcp://127.0.0.1:{port}", "--connect-timeout", "1"],
            capsys,
            f"--scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered within 1 s",
        )
    assert time.perf_counter() - t0 < 10.0
    server.close()


def test_a_port_that_answers_garbage_is_named_as_such_and_the_exit_is_prompt(tmp_path):
    """A web server's reply read as a Dask frame (a MemoryError) was reported as "no Dask scheduler answered
    within 5 s", and the process then took 11 s to exit (Dask's clean-up of the client that never connected)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    port = server.getsockname()[1]

    def reply() -> None:
        for _ in range(8):
            conn, _ = server.accept()
            with contextlib.suppress(OSError):
                conn.recv(100)
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 50)

    threading.Thread(target=reply, daemon=True).start()
    clips = tmp_path / "clips"
    clips.mkdir()
    shutil.copy(BAD / "empty.bvh", clips / "x.bvh")
    t0 = time.perf_counter()
    argv = ["audit", str(clips), "-o", str(tmp_path / "o"), "--scheduler", f"tcp://127.0.0.1:{port}", "--connect-timeout", "5"]
    proc = subprocess.run([sys.executable, "-m", "mjmotion.cli", *argv], capture_output=True, text=True, timeout=60)
    took = time.perf_counter() - t0
    server.close()
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert f"--scheduler tcp://127.0.0.1:{port}: something answered there, not a Dask scheduler" in proc.stderr
    assert took < 8.0, took  # (a hang check: the clean-up waited twice the connect timeout, 10 s)


def test_summary_cells_hold_any_path():
    """summary.md's tables broke on paths holding a pipe, a backtick or a line break (found by a review)."""
    assert audit._md_code("a|b.bvh") == "`a\\|b.bvh`"
    assert audit._md_code("tick`x.bvh") == "`` tick`x.bvh ``"
    assert audit._md_code("new\nline.bvh") == "`new\\nline.bvh`" and audit._md_cell("bad | x\ny") == "bad \\| x\\ny"
    # A name's terminal escape is written, not sent to the terminal that shows summary.md (a review)
    assert audit._md_code("\x1b[31mred.bvh") == "`\\x1b[31mred.bvh`"
    assert executor.one_line("x.bvh\x1b[2J: bad\n value") == "x.bvh\\x1b[2J: bad value"
    # a byte of a name that is not UTF-8 is written as the byte, as in the table (it read \udce9)
    assert printable(os.fsdecode(b"caf\xe9.bvh")) == "caf\\xe9.bvh"


def test_ctrl_c_at_a_terminal_is_one_line_and_leaves_a_table_to_resume(tmp_path):
    """Ctrl-C reaches the terminal's whole process group: every Dask worker and the side process printed
    the traceback of its interrupted loop (5 of them) under the audit's own ``error: interrupted``."""
    data = require_data()
    out = tmp_path / "out"
    env = {**os.environ, "MUJOCO_GL": "egl"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "mjmotion.cli", "audit", str(data), "-o", str(out), "--workers", "2"],
        start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        csv_path = out / "audit.csv"
        if csv_path.exists() and csv_path.read_text(errors="replace").count("\n") >= 4:  # the header and 3 rows
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the audit finished before the interrupt")
    assert proc.returncode == 130 and err.strip().endswith("error: interrupted"), err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    rows = audit.Table.read(out / "audit.csv")
    assert 3 <= len(rows) < 42
    with contextlib.suppress(ProcessLookupError):  # nothing of the group is left running
        for _ in range(100):
            os.killpg(proc.pid, 0)
            time.sleep(0.1)
        pytest.fail("processes of the interrupted audit are still running")


def test_a_second_audit_into_the_same_folder_at_once_is_refused(tmp_path, capsys):
    """A --resume started while the first audit still writes would append to the same audit.csv: refused
    while the folder is held, accepted once it is released; a refused start leaves no folder behind."""
    root = tmp_path / "clips"
    root.mkdir()
    bvh.write(synth.walk(seconds=0.8).motion, root / "walk.bvh")
    out = tmp_path / "out"
    out.mkdir()
    with audit.holding(out):
        _refused(["audit", str(root), "-o", str(out), "--resume", "--workers", "1"], capsys, f"-o {out}: another audit is writing there now")
        assert not any(out.iterdir())
    assert cli.main(["audit", str(root), "-o", str(out), "--resume", "--workers", "1"]) == 0
    assert len(_rows(out)) == 1
    # A start refused after the folder was made (a source map that does not parse) leaves none, nor the
    # folders made above it; a start refused the lock removes nothing (the holder's folder stays).
    (tmp_path / "map.json").write_text("{")
    _refused(["audit", str(root), "-o", str(tmp_path / "new" / "a" / "b"), "--source-map", str(tmp_path / "map.json")], capsys, "not JSON")
    assert not (tmp_path / "new").exists()
    empty = tmp_path / "empty"
    empty.mkdir()
    with audit.holding(empty):
        _refused(["audit", str(root), "-o", str(empty), "--workers", "1"], capsys, "another audit is writing there now")
        assert empty.is_dir()


def test_the_folder_lock_is_not_inherited_by_forked_processes(tmp_path):
    """A side process or worker forked while an audit holds its folder, left behind by a killed audit,
    kept the folder locked for good: the lock is closed in every forked child."""
    import multiprocessing

    out = tmp_path / "out"
    out.mkdir()
    ctx = multiprocessing.get_context("fork")
    with audit.holding(out):
        ready, stop = ctx.Event(), ctx.Event()
        child = ctx.Process(target=_hold_until, args=(ready, stop))
        child.start()
        assert ready.wait(30)
    try:
        with audit.holding(out):  # the parent let go; the child still runs and holds nothing
            assert child.is_alive()
    finally:
        stop.set()
        child.join(30)


def _hold_until(ready, stop) -> None:
    ready.set()
    stop.wait(60)


def test_a_folder_that_cannot_be_listed_is_named_in_a_note_and_the_summary(tmp_path, monkeypatch, capsys):
    """A folder that could not be listed was said only in a note: summary.md said "15 clips" with nothing
    about the clips that might be in it."""
    root = tmp_path / "clips"
    (root / "locked").mkdir(parents=True)
    bvh.write(synth.walk(seconds=0.8).motion, root / "walk.bvh")
    bvh.write(synth.walk(seconds=0.8).motion, root / "locked" / "hidden.bvh")
    real = os.scandir

    def scandir(path="."):
        if not isinstance(path, int) and os.fspath(path).endswith("locked"):
            raise PermissionError(13, "Permission denied", os.fspath(path))
        return real(path)

    monkeypatch.setattr(os, "scandir", scandir)
    assert cli.main(["audit", str(root), "-o", str(tmp_path / "out"), "--workers", "1"]) == 0
    err = capsys.readouterr().err
    assert f"note: {root / 'locked'}: Permission denied; the .bvh files in it are not audited (summary.md lists it)" in err
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert "## Folders not listed" in summary and f"- {root / 'locked'}: Permission denied" in summary
    assert list(_rows(tmp_path / "out")) == ["walk.bvh"]
