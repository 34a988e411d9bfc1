"""Reading inputs (issue 17): regular files only, measured before reading, read no further than a limit."""

from __future__ import annotations

import os

import pytest

from mjmotion import inputs
from mjmotion.inputs import InputError, read_input, read_text


def test_a_regular_file_is_read_whole(tmp_path):
    p = tmp_path / "a.txt"
    p.write_bytes(b"x" * 100_000)
    assert read_input(p, limit=100_000) == b"x" * 100_000


def test_a_file_over_the_limit_is_refused_before_it_is_read(tmp_path, monkeypatch):
    p = tmp_path / "big.bin"
    p.write_bytes(b"x" * 1001)

    def no_read(*a, **k):
        raise AssertionError("read a file that its size already refused")

    monkeypatch.setattr(os, "open", no_read)
    with pytest.raises(InputError, match=r"big.bin: file is 1001 bytes, larger than the limit of 1000 bytes for a thing"):
        read_input(p, limit=1000, what="a thing")


def test_a_file_that_grows_past_the_limit_while_read_is_refused(tmp_path, monkeypatch):
    p = tmp_path / "grows.bin"
    p.write_bytes(b"x" * 5000)
    real_stat, real_fstat = os.stat, os.fstat

    def measured_small(st: os.stat_result) -> os.stat_result:  # the size before the file grew
        return os.stat_result((*st[:6], 10, *st[7:10]))

    monkeypatch.setattr(os, "stat", lambda path, *a, **k: measured_small(real_stat(path, *a, **k)))
    monkeypatch.setattr(os, "fstat", lambda fd: measured_small(real_fstat(fd)))
    with pytest.raises(InputError, match="more than the limit of 1000 bytes"):
        read_input(p, limit=1000)
    assert read_input(p, limit=5000) == b"x" * 5000  # under the limit: read whole, past the stale size


def test_a_file_of_unknown_size_is_read_up_to_the_limit():
    """/proc files report a size of 0: read in chunks, still capped."""
    if not os.path.exists("/proc/self/status"):
        pytest.skip("no /proc")
    assert b"Name:" in read_input("/proc/self/status", limit=1 << 20)
    with pytest.raises(InputError, match="more than the limit of 10 bytes"):
        read_input("/proc/self/status", limit=10)


@pytest.mark.parametrize(
    ("make", "phrase"),
    [
        (lambda d: d, "is a directory"),
        (lambda d: d / "missing", "no such file"),
        (lambda d: (d / "f").write_bytes(b"") or d / "f" / "under", "a part of the path is not a directory"),
    ],
    ids=["directory", "missing", "under-a-file"],
)
def test_paths_that_are_not_files(tmp_path, make, phrase):
    p = make(tmp_path)
    with pytest.raises(InputError, match=phrase) as info:
        read_input(p, what="a clip")
    assert info.value.path == str(p)


def test_devices_and_symlink_loops(tmp_path):
    if os.path.exists("/dev/zero"):
        with pytest.raises(InputError, match=r"/dev/zero: is a character device; expected a clip \(a regular file\)"):
            read_input("/dev/zero", what="a clip")
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    with pytest.raises(InputError, match="too many levels of symbolic links"):
        read_input(loop)
    dangling = tmp_path / "dangling"
    dangling.symlink_to(tmp_path / "nowhere")
    with pytest.raises(InputError, match="no such file"):
        read_input(dangling)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_a_fifo_swapped_in_after_the_check_does_not_block(tmp_path, monkeypatch):
    """The check is made on the opened file too, and opening cannot block (O_NONBLOCK)."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    real_stat = os.stat
    regular = tmp_path / "regular"
    regular.write_bytes(b"")
    monkeypatch.setattr(os, "stat", lambda p, **k: real_stat(regular) if str(p) == str(fifo) else real_stat(p, **k))
    from conftest import error_without_blocking

    assert "is a named pipe (FIFO)" in str(error_without_blocking(fifo, read_input, InputError))


def test_text_is_utf8_without_nul_bytes(tmp_path):
    p = tmp_path / "t.json"
    p.write_bytes(b"\xef\xbb\xbf{}")
    assert read_text(p) == "{}"
    p.write_bytes(b"{\x00}")
    with pytest.raises(InputError, match="binary data"):
        read_text(p)
    p.write_bytes(b"{\xff}")
    with pytest.raises(InputError, match="invalid UTF-8 at byte 1"):
        read_text(p)


def test_every_error_is_an_mjmotion_error():
    from mjmotion.errors import MjmotionError

    assert issubclass(inputs.InputError, MjmotionError)


def _folder_with_links(tmp_path):
    """DIR with a clip, an upper-case one in a subfolder, a link to a clip inside, and links leading out."""
    root, outside = tmp_path / "dir", tmp_path / "outside"
    (root / "sub").mkdir(parents=True)
    outside.mkdir()
    from mjmotion.audit import _standing_bvh

    for p in (root / "a.bvh", root / "sub" / "B.BVH", outside / "far.bvh"):
        p.write_text(_standing_bvh(frames=5))
    (root / "notes.txt").write_text("x")
    (root / "inside.bvh").symlink_to(root / "a.bvh")
    (root / "out.bvh").symlink_to(outside / "far.bvh")
    (root / "linked").symlink_to(outside, target_is_directory=True)
    return root


def test_find_bvh_lists_the_folder_and_nothing_a_link_leads_out_to(tmp_path):
    root = _folder_with_links(tmp_path)
    assert [p.relative_to(root).as_posix() for p in inputs.find_bvh(root)] == ["a.bvh", "inside.bvh", "sub/B.BVH"]
    assert all(str(p).startswith(str(root)) for p in inputs.find_bvh(root))  # paths as the folder was named
    assert inputs.find_bvh(tmp_path / "outside") == [tmp_path / "outside" / "far.bvh"]


def test_every_folder_reader_lists_through_find_bvh(tmp_path, monkeypatch):
    """evaluate's folder walk and the studio's --data list what find_bvh lists (both followed links out before)."""
    from mjmotion.cli import main
    from mjmotion.commands import evaluate
    from mjmotion.studio.clips import ClipLibrary

    root = _folder_with_links(tmp_path)
    seen = []
    monkeypatch.setattr(evaluate, "evaluate_files", lambda files, opts, jobs: seen.extend(files) or [])
    main(["evaluate", str(root)])
    assert [os.path.relpath(f, root) for f in seen] == ["a.bvh", "inside.bvh", os.path.join("sub", "B.BVH")]
    names = ClipLibrary.from_paths([], str(root)).names()
    assert len(names) == 3 and not any("far" in n for n in names), names
