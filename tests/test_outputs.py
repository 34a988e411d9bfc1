"""Publishing outputs (issue 17): never over an existing file without ``force``, never over anything
but a regular file or a link, never half-written."""

from __future__ import annotations

import errno
import os
import re
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from mjmotion import outputs
from mjmotion.errors import MjmotionError, OutputExistsError
from mjmotion.outputs import atomic_path, check_output, rename_noreplace, staged_folder, write_text_atomic

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _fresh_claims():
    outputs.reset_claims()
    yield
    outputs.reset_claims()


def test_trailing_slash_is_a_folder_not_a_file(tmp_path):
    for raw in (f"{tmp_path}/out.bvh/", f"{tmp_path}/.", f"{tmp_path}/.."):
        with pytest.raises(OutputExistsError, match="names a folder"):
            check_output(raw)
    assert list(tmp_path.iterdir()) == []


def test_an_empty_output_path_is_called_empty_not_a_folder():
    for raw in ("", "  "):
        with pytest.raises(OutputExistsError, match=r"an empty output path; expected a file path, not an empty value"):
            check_output(raw)


def test_a_dangling_symlink_exists(tmp_path):
    link = tmp_path / "out.bvh"
    link.symlink_to(tmp_path / "nowhere.bvh")
    with pytest.raises(OutputExistsError, match=r"already exists \(a symbolic link\); pass --force"):
        check_output(link)
    check_output(link, force=True)
    write_text_atomic(link, "new")
    assert not link.is_symlink() and link.read_text() == "new"  # the link replaced, nothing made where it pointed
    assert not (tmp_path / "nowhere.bvh").exists()


def test_force_replaces_a_link_never_its_target(tmp_path):
    target = tmp_path / "precious.bvh"
    target.write_text("precious")
    link = tmp_path / "out.bvh"
    link.symlink_to(target)
    check_output(link, force=True)
    write_text_atomic(link, "new")
    assert target.read_text() == "precious" and link.read_text() == "new" and not link.is_symlink()


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
@pytest.mark.parametrize("force", [False, True])
def test_a_fifo_or_device_is_never_replaced(tmp_path, force):
    fifo = tmp_path / "out.bvh"
    os.mkfifo(fifo)
    with pytest.raises(OutputExistsError, match=r"is a named pipe \(FIFO\); an output must be a new file \(--force replaces only a regular file\)"):
        check_output(fifo, force=force)
    with pytest.raises(OutputExistsError, match="is a character device"):
        check_output("/dev/null", force=force)
    # Not even through the write step on its own (a path nobody claimed).
    with pytest.raises(OutputExistsError, match="is a named pipe"):
        write_text_atomic(fifo, "x")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and sorted(os.listdir(tmp_path)) == ["out.bvh"]
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_a_link_to_a_folder_is_refused(tmp_path):
    (tmp_path / "d").mkdir()
    (tmp_path / "l").symlink_to(tmp_path / "d")
    for p in (tmp_path / "d", tmp_path / "l"):
        with pytest.raises(OutputExistsError, match="is a directory"):
            check_output(p, force=True)


def test_a_file_that_appears_during_the_run_is_never_replaced(tmp_path):
    out = tmp_path / "out.json"
    check_output(out)  # nothing there before the work

    out.write_text("written by someone else meanwhile")
    with pytest.raises(OutputExistsError, match="appeared while this command ran"):
        write_text_atomic(out, "ours")
    assert out.read_text() == "written by someone else meanwhile"
    assert sorted(os.listdir(tmp_path)) == ["out.json"]  # no temporary left


def test_with_force_it_is_replaced(tmp_path):
    out = tmp_path / "out.json"
    out.write_text("old")
    check_output(out, force=True)
    write_text_atomic(out, "new")
    assert out.read_text() == "new"


def test_unclaimed_paths_are_replaced_as_library_code_expects(tmp_path):
    out = tmp_path / "table.md"
    out.write_text("old")
    write_text_atomic(out, "new")
    assert out.read_text() == "new"


@pytest.mark.parametrize("how", ["renameat2", "link", "exclusive-create"])
def test_every_no_replace_strategy_refuses_an_existing_target(tmp_path, monkeypatch, how):
    if how != "renameat2":
        monkeypatch.setattr(outputs, "_renameat2", lambda: None)
    elif outputs._renameat2() is None:
        pytest.skip("no renameat2 here")
    if how == "exclusive-create":

        def no_links(*a, **k):
            raise OSError(errno.EPERM, "Operation not permitted")

        monkeypatch.setattr(os, "link", no_links)
    src, dst = tmp_path / "src", tmp_path / "dst"
    src.write_text("new")
    dst.write_text("old")
    with pytest.raises(FileExistsError):
        rename_noreplace(src, dst)
    assert dst.read_text() == "old" and src.read_text() == "new"
    dst.unlink()
    rename_noreplace(src, dst)
    assert dst.read_text() == "new" and not src.exists()


def test_a_full_disk_leaves_nothing(tmp_path, monkeypatch):
    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    check_output(tmp_path / "out.bvh")
    # Named by the output (it read "error: No space left on device": write() and fsync() name no file).
    with pytest.raises(MjmotionError, match=rf"^{re.escape(str(tmp_path / 'out.bvh'))}: cannot be written \(No space left on device\)"):
        write_text_atomic(tmp_path / "out.bvh", "x" * 1000)
    assert list(tmp_path.iterdir()) == []


def test_a_staged_folder_appears_whole_or_not_at_all(tmp_path):
    out = tmp_path / "lib"
    with pytest.raises(RuntimeError), staged_folder(out) as tmp:
        (tmp / "a.bvh").write_text("a")
        raise RuntimeError("disk full halfway")
    assert list(tmp_path.iterdir()) == []
    with staged_folder(out) as tmp:
        (tmp / "a.bvh").write_text("a")
    assert sorted(os.listdir(out)) == ["a.bvh"]
    with pytest.raises(OutputExistsError, match="appeared while this command ran"), staged_folder(out) as tmp:
        (tmp / "b.bvh").write_text("b")
    assert sorted(os.listdir(out)) == ["a.bvh"] and sorted(os.listdir(tmp_path)) == ["lib"]


def test_the_block_failing_leaves_the_old_file(tmp_path):
    out = tmp_path / "keep.txt"
    out.write_text("precious")
    check_output(out, force=True)
    with pytest.raises(MjmotionError), atomic_path(out) as tmp:
        tmp.write_text("half")
        raise MjmotionError("failed")
    assert out.read_text() == "precious" and sorted(os.listdir(tmp_path)) == ["keep.txt"]


def test_outputs_written_together_appear_together_or_not_at_all(tmp_path):
    """vary wrote its clip, then measured and drew for seconds: an interrupt left the clip without its
    report or plot. Written together, none appears until the block ends, and none if it fails."""
    clip, report = tmp_path / "v.bvh", tmp_path / "v.json"
    with pytest.raises(KeyboardInterrupt), outputs.together():
        write_text_atomic(clip, "clip")
        assert not clip.exists()  # held until the block ends
        raise KeyboardInterrupt
    assert sorted(os.listdir(tmp_path)) == []  # (temporaries removed too)
    with outputs.together():
        write_text_atomic(clip, "clip")
        with outputs.together():  # an inner block publishes at its own end
            write_text_atomic(report, "report")
        assert report.exists() and not clip.exists()
    assert clip.read_text() == "clip" and report.read_text() == "report"
    # a file that appeared meanwhile is not replaced, and the outputs after it are not published
    check_output(tmp_path / "a.txt", force=False)
    with pytest.raises(OutputExistsError), outputs.together():
        write_text_atomic(tmp_path / "a.txt", "a")
        write_text_atomic(tmp_path / "b.txt", "b")
        (tmp_path / "a.txt").write_text("theirs")
    assert (tmp_path / "a.txt").read_text() == "theirs" and sorted(os.listdir(tmp_path)) == ["a.txt", "v.bvh", "v.json"]
    write_text_atomic(clip, "again")  # outside a block: published at once, as before
    assert clip.read_text() == "again"


_WRITER = textwrap.dedent(
    """
    import os, sys, time
    from mjmotion import cli, outputs
    me, other = sys.argv[1], sys.argv[2]
    real = outputs._fsync

    def both_ready(path):  # each run waits, after its work and before publishing, for the other
        real(path)
        open(me, "w").close()
        deadline = time.monotonic() + 60
        while not os.path.exists(other) and time.monotonic() < deadline:
            time.sleep(0.01)

    outputs._fsync = both_ready
    sys.exit(cli.main(sys.argv[3:]))
    """
)


def test_two_concurrent_writers_one_wins_the_other_exits_2(tmp_path):
    """Both runs pass the "exists?" check before either writes; exactly one publishes."""
    src = REPO / "tests" / "data" / "bad" / "base.bvh"
    out = tmp_path / "out.bvh"
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _WRITER, str(tmp_path / f"ready{i}"), str(tmp_path / f"ready{1 - i}"), "convert", str(src), str(out), *extra],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        for i, extra in enumerate(([], ["--scale", "2"]))
    ]
    results = [(p.wait(timeout=120), p.stderr.read()) for p in procs]
    for p in procs:
        p.stdout.close()
        p.stderr.close()
    codes = sorted(rc for rc, _ in results)
    assert codes == [0, 2], results
    loser = next(err for rc, err in results if rc == 2)
    assert loser.count("error:") == 1 and "appeared while this command ran" in loser and "Traceback" not in loser
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("ready")) == ["out.bvh"]
    assert out.read_text().startswith("HIERARCHY")


def test_a_folder_that_takes_no_files_is_named_with_the_users_path():
    """/proc takes no new files: the error named the hidden temporary (`/proc/.x.txt.2eq_psj0.txt`)."""
    from mjmotion.outputs import staged_folder, write_text_atomic

    with pytest.raises(MjmotionError) as e:
        write_text_atomic("/proc/mjmotion-out.txt", "x")
    assert str(e.value).startswith("/proc/mjmotion-out.txt: cannot write in /proc (") and ".mjmotion-out.txt." not in str(e.value)
    with pytest.raises(MjmotionError, match=r"^/proc/mjmotion-lib: cannot write in /proc \("), staged_folder("/proc/mjmotion-lib"):
        pass


def test_a_folder_that_takes_no_files_is_refused_before_the_work(tmp_path):
    """`-o /sys/x.bvh` was found only when the result was written, after the work."""
    with pytest.raises(MjmotionError, match=r"^/proc/mjmotion-out\.bvh: cannot write in /proc \("):
        check_output("/proc/mjmotion-out.bvh")
    assert check_output(tmp_path / "out.bvh") == tmp_path / "out.bvh"
    assert list(tmp_path.iterdir()) == []  # the probe leaves nothing behind
    # The probe is named as the real temporary is: a name long enough for the write fits the probe.
    long = tmp_path / ("a" * 236 + ".bvh")
    assert check_output(long) == long
    write_text_atomic(long, "x")
    assert long.read_text() == "x"


def test_an_output_folder_is_checked_before_the_work(tmp_path, monkeypatch, capsys):
    """`synth library /proc/x` made every clip (1.3 s) and only then failed; `demo -o /proc/x` ran its
    first experiment. The folder, or its nearest existing ancestor, is probed first."""
    from mjmotion import synth
    from mjmotion.cli import main
    from mjmotion.outputs import check_folder

    assert check_folder(tmp_path / "a" / "b") == tmp_path / "a" / "b" and list(tmp_path.iterdir()) == []
    with pytest.raises(MjmotionError, match=r"^/proc/mjmotion-x: cannot write in /proc \("):
        check_folder("/proc/mjmotion-x")
    (tmp_path / "f.bvh").write_text("x")
    with pytest.raises(MjmotionError, match="f.bvh exists and is not a folder"):
        check_folder(tmp_path / "f.bvh" / "sub")
    monkeypatch.setattr(synth, "library", lambda: pytest.fail("the clips were made before the folder was checked"))
    assert main(["synth", "library", "/proc/mjmotion-lib"]) == 2
    assert capsys.readouterr().err.startswith("error: /proc/mjmotion-lib: cannot write in /proc")
    assert main(["demo", "-o", "/proc/mjmotion-demo", "--only", "path_search", "--no-video"]) == 2
    assert capsys.readouterr().err.startswith("error: -o /proc/mjmotion-demo: cannot write in /proc")
    from mjmotion import experiments

    assert experiments.script("skinning", None, ["--bundled", "--out", "/proc/mjmotion-exp"]) == 2
    assert capsys.readouterr().err.startswith("error: --out /proc/mjmotion-exp: cannot write in /proc")
    assert main(["studio", "--out", "/proc/mjmotion-studio", "--check"]) == 2
    assert capsys.readouterr().err.startswith("error: --out /proc/mjmotion-studio: cannot write in /proc")


def test_json_text_is_standard_json_with_null_for_non_finite_numbers():
    import json as _json

    import numpy as np

    from mjmotion.outputs import json_text

    def strict(text: str):
        return _json.loads(text, parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c}"))

    value = {"score": float("inf"), "ratio": np.float32("nan"), "speeds": np.array([1.5, -np.inf]), "n": np.int64(3), "rows": ({"x": float("-inf")},)}
    assert strict(json_text(value)) == {"score": None, "ratio": None, "speeds": [1.5, None], "n": 3, "rows": [{"x": None}]}
    assert strict(json_text({"a": 1.25}, indent=1)) == {"a": 1.25}
    odd = {"long": np.longdouble(1.5), np.int64(7): np.array(2.0), "grid": np.array([[1, np.nan]], dtype=np.float32), "yes": np.bool_(True)}
    assert strict(json_text(odd)) == {"long": 1.5, "7": 2.0, "grid": [[1.0, None]], "yes": True}  # (a longdouble recursed for ever)
    with pytest.raises(TypeError):
        json_text({"a": object()})
