"""The bad-input corpus (issue 9): every hostile file gives a BvhError naming file, line and problem,
every merely unusual file loads correctly, large files stay within time and memory.

Cases come from ``tests/data/bad/make_corpus.py`` (one edit of a valid base file each, so the
expected line is known from the edit, not from the reader).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import time
import tracemalloc
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjmotion import bvh, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.errors import BvhError, MjmotionError

BAD = Path(__file__).resolve().parent / "data" / "bad"


def _load_corpus():
    spec = importlib.util.spec_from_file_location("make_corpus", BAD / "make_corpus.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_corpus"] = mod
    spec.loader.exec_module(mod)
    return mod


corpus = _load_corpus()
CASES = corpus.cases()
BY_NAME = {c.name: c for c in CASES}


@pytest.fixture(scope="module")
def base():
    return bvh.read(BAD / "base.bvh")


def test_committed_files_match_the_generator(tmp_path):
    corpus.write_all(tmp_path)
    made = sorted(p.name for p in tmp_path.iterdir())
    committed = sorted(p.name for p in BAD.iterdir() if p.suffix in (".bvh", ".md"))
    assert made == committed
    for name in made:
        assert (tmp_path / name).read_bytes() == (BAD / name).read_bytes(), f"{name} is stale: rerun make_corpus.py"


def test_readme_lists_every_case():
    text = (BAD / "README.md").read_text(encoding="utf-8")
    for c in CASES:
        assert f"`{c.name}.bvh`" in text
    assert text.count("| BvhError |") == sum(c.error for c in CASES)


@pytest.mark.parametrize("case", [c for c in CASES if c.error], ids=lambda c: c.name)
def test_error_names_file_line_and_problem(case):
    path = BAD / f"{case.name}.bvh"
    with pytest.raises(BvhError) as info:
        bvh.read(path)
    e = info.value
    assert e.line == case.line, f"{e}"
    assert str(e).startswith(f"{path}:{case.line}: ")
    assert case.match in e.message.lower(), f"{e}"
    assert "\n" not in str(e)  # one line for the CLI


@pytest.mark.parametrize("case", [c for c in CASES if not c.error], ids=lambda c: c.name)
def test_unusual_but_valid_loads(case, base):
    m = bvh.read(BAD / f"{case.name}.bvh")
    assert np.all(np.isfinite(m.rotations)) and np.all(np.isfinite(m.root_positions))
    assert np.allclose(np.linalg.norm(m.rotations, axis=-1), 1.0)
    if case.same:
        assert m.skeleton.names == base.skeleton.names
        assert m.skeleton.channels == base.skeleton.channels
        assert m.fps == base.fps
        assert np.array_equal(m.skeleton.offsets, base.skeleton.offsets)
        assert np.array_equal(m.root_positions, base.root_positions)
        assert np.array_equal(m.rotations, base.rotations)


def test_unusual_files_load_to_the_right_values(base):
    # A fixed joint (CHANNELS 0): identity rotation there, every other joint as in the base file.
    m = bvh.read(BAD / "zero_channel_joint.bvh")
    spine = m.skeleton.index("Spine")
    assert m.skeleton.channels[spine] == ()
    assert np.array_equal(m.rotations[:, spine], np.broadcast_to(rot.IDENTITY, (3, 4)))
    others = [j for j in range(5) if j != spine]
    assert np.allclose(m.rotations[:, others], base.rotations[:, others], atol=1e-15)
    # A zero-length End Site is kept, not dropped.
    m = bvh.read(BAD / "zero_length_end_site.bvh")
    assert len(m.skeleton.end_parents) == 2 and np.array_equal(m.skeleton.end_offsets[0], [0, 0, 0])
    # One frame.
    m = bvh.read(BAD / "single_frame.bvh")
    assert m.n_frames == 1 and np.array_equal(m.rotations[0], base.rotations[0])
    # Names with spaces, colons and non-ASCII letters are kept verbatim.
    assert "mixamorig:Left Up Leg" in bvh.read(BAD / "names_with_spaces_colons.bvh").skeleton.names
    assert "Kopf_頭" in bvh.read(BAD / "unicode_names.bvh").skeleton.names


def _body_positions(model: mujoco.MjModel, qpos: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    data = mujoco.MjData(model)
    out = []
    for q in qpos:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        out.append([data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n)].copy() for n in names])
    return np.array(out)


@pytest.mark.parametrize("name", ["xml_special_names", "names_with_spaces_colons", "unicode_names"])
def test_special_joint_names_compile_and_round_trip_through_xml(name, tmp_path):
    m = bvh.read(BAD / f"{name}.bvh")
    compiled = mjcf.compile(m.skeleton)
    xml = compiled.to_xml()
    reloaded = mujoco.MjModel.from_xml_string(xml)
    for n in m.skeleton.names:
        assert mujoco.mj_name2id(reloaded, mujoco.mjtObj.mjOBJ_BODY, n) >= 0, n
    q = kinematics.qpos(compiled, m)
    a = _body_positions(compiled.model, q, m.skeleton.names)
    b = _body_positions(reloaded, q, m.skeleton.names)
    assert np.abs(a - b).max() < 1e-9
    # The same model written to a file and loaded from the path.
    path = tmp_path / "model.xml"
    compiled.save_xml(path)
    assert np.abs(_body_positions(mujoco.MjModel.from_xml_path(str(path)), q, m.skeleton.names) - a).max() < 1e-9
    # And the BVH writer keeps the names through a round trip.
    bvh.write(m, tmp_path / "again.bvh")
    assert bvh.read(tmp_path / "again.bvh").skeleton.names == m.skeleton.names


def test_parse_of_str_and_bytes_agree_on_errors():
    """``parse`` takes text too; the line it names is the same."""
    for c in CASES:
        if not c.error or c.name.startswith(("binary", "invalid_utf8")):
            continue
        with pytest.raises(BvhError) as info:
            bvh.parse(c.data.decode("utf-8"), "s.bvh")
        assert info.value.line == c.line, c.name


# --- large files, made at test time -----------------------------------------------------------
def test_fifty_megabyte_clip_loads_and_can_be_refused(tmp_path):
    data, n = corpus.big_clip_bytes(50_000_000)
    path = tmp_path / "big.bvh"
    path.write_bytes(data)
    assert path.stat().st_size >= 50_000_000
    m = bvh.read(path)
    assert m.n_frames == n and m.skeleton.n_joints == 5
    # The last frame is the generator's, read back to the file's 4 decimals.
    last = 20.0 * np.sin(0.7 * (n - 1) / 30.0 + np.arange(3))
    assert np.allclose(m.root_positions[-1] / m.skeleton.scale, [last[2], last[0], last[1] + 90.0], atol=1e-4)
    with pytest.raises(BvhError, match=r"big\.bvh: file is \d+ bytes, larger than the limit of 1000000"):
        bvh.read(path, max_bytes=1_000_000)


def test_fifty_megabytes_of_garbage_on_one_line(tmp_path):
    path = tmp_path / "line.bvh"
    path.write_bytes(b"HIERARCHY " + b"7" * 50_000_000)
    t0 = time.perf_counter()
    with pytest.raises(BvhError) as info:
        bvh.read(path)
    assert info.value.line == 1 and "unexpected" in info.value.message
    assert len(str(info.value)) < 200  # the message quotes a little, not 50 MB
    assert time.perf_counter() - t0 < 30  # a bound against hangs, not a speed test


def test_hundred_thousand_frames_parse_in_a_small_multiple_of_their_arrays():
    data = corpus.big_clip(100_000)
    tracemalloc.start()
    try:
        m = bvh.parse(data, "long.bvh")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    arrays = m.rotations.nbytes + m.root_positions.nbytes  # 16 + 2.4 MB; the values are 14.4 MB
    assert m.n_frames == 100_000
    assert peak < 5 * arrays, f"peak {peak / 1e6:.0f} MB for {arrays / 1e6:.0f} MB of motion"


def test_ten_thousand_levels_load_write_and_refuse_to_compile(tmp_path):
    depth = 10_000
    path = tmp_path / "deep.bvh"
    path.write_bytes(corpus.deep_hierarchy(depth))
    m = bvh.read(path)  # no RecursionError
    s = m.skeleton
    assert s.n_joints == depth and s.parents[-1] == depth - 2 and s.scale == 0.01
    assert s.stature() == pytest.approx(1.8)
    # Writing is iterative too, and loses nothing.
    out = tmp_path / "deep_again.bvh"
    bvh.write(m, out)
    again = bvh.read(out)
    assert again.skeleton.names == s.names and np.array_equal(again.skeleton.parents, s.parents)
    assert np.allclose(again.skeleton.offsets, s.offsets, atol=1e-12)
    # MuJoCo cannot take it in reasonable time: a clear error, quickly, not a hang.
    t0 = time.perf_counter()
    with pytest.raises(MjmotionError, match=r"10000 joints deep.*limited to \d+ nested bodies"):
        mjcf.compile(s)
    assert time.perf_counter() - t0 < 10


def test_deepest_accepted_hierarchy_compiles():
    m = bvh.parse(corpus.deep_hierarchy(mjcf.MAX_DEPTH), "deep.bvh")
    compiled = mjcf.compile(m.skeleton)
    assert compiled.model.nbody == mjcf.MAX_DEPTH + 1
    with pytest.raises(MjmotionError, match="joints deep"):
        mjcf.compile(bvh.parse(corpus.deep_hierarchy(mjcf.MAX_DEPTH + 1), "deeper.bvh").skeleton)


# --- nothing lost ------------------------------------------------------------------------------
def test_failed_write_leaves_the_existing_file_alone(base, tmp_path):
    path = tmp_path / "keep.bvh"
    path.write_text("precious")
    far = base.replace(root_positions=base.root_positions + [1e12, 0.0, 0.0])  # (a NaN cannot even be a motion now)
    with pytest.raises(MjmotionError, match="positions within"):
        bvh.write(far, path)
    assert path.read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.bvh"]  # no temporary left behind


def test_reader_never_modifies_its_input(tmp_path):
    for c in CASES[:5] + CASES[-5:]:
        path = tmp_path / f"{c.name}.bvh"
        path.write_bytes(c.data)
        try:
            bvh.read(path)
        except BvhError:
            pass
        assert path.read_bytes() == c.data


# --- pipes, devices and other files that are not regular (issue 17) ----------------------------
@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom", "/dev/null"])
def test_devices_are_refused_before_they_are_read(device):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    t0 = time.perf_counter()
    with pytest.raises(BvhError, match="is a character device; expected a .bvh file") as info:
        bvh.read(device)
    assert info.value.path == device and info.value.line is None
    assert time.perf_counter() - t0 < 10


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_a_named_pipe_without_a_writer_is_refused_not_waited_on(tmp_path):
    fifo = tmp_path / "clip.bvh"
    os.mkfifo(fifo)
    from conftest import error_without_blocking

    assert "is a named pipe (FIFO)" in str(error_without_blocking(fifo, bvh.read, BvhError))


def test_a_sparse_two_gigabyte_file_is_refused_from_its_size(tmp_path):
    big = tmp_path / "sparse.bvh"
    with open(big, "wb") as fh:
        fh.truncate(2 << 30)  # sparse: no data blocks
    tracemalloc.start()
    try:
        with pytest.raises(BvhError, match=r"file is 2147483648 bytes, larger than the limit of 268435456 bytes"):
            bvh.read(big)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20, f"{peak} bytes allocated: the file was read"


def test_a_symlink_loop_is_a_bvh_error(tmp_path):
    a, b = tmp_path / "a.bvh", tmp_path / "b.bvh"
    a.symlink_to(b)
    b.symlink_to(a)
    with pytest.raises(BvhError, match="too many levels of symbolic links") as info:
        bvh.read(a)
    assert info.value.path == str(a)


def test_a_symlink_to_a_clip_is_read(tmp_path, base):
    link = tmp_path / "link.bvh"
    link.symlink_to(BAD / "base.bvh")
    assert np.array_equal(bvh.read(link).rotations, base.rotations)


# --- extreme but valid text (issue 17) ---------------------------------------------------------
def test_the_widest_skeleton_is_refused_at_its_line_in_seconds():
    from mjmotion.caps import MAX_JOINTS

    data = corpus.wide_hierarchy(MAX_JOINTS + 1)
    t0 = time.perf_counter()
    with pytest.raises(BvhError, match=f"more than {MAX_JOINTS} joints") as info:
        bvh.parse(data, "wide.bvh")
    assert info.value.line == 6 + 9 * (MAX_JOINTS - 1)  # the JOINT line of joint 10,001
    assert time.perf_counter() - t0 < 10


def test_a_skeleton_wider_than_a_model_loads_but_does_not_compile():
    from mjmotion.caps import MAX_MODEL_JOINTS

    m = bvh.parse(corpus.wide_hierarchy(MAX_MODEL_JOINTS + 1), "wide.bvh")
    assert m.skeleton.n_joints == MAX_MODEL_JOINTS + 1
    t0 = time.perf_counter()
    with pytest.raises(MjmotionError, match=f"{MAX_MODEL_JOINTS + 1} joints; MuJoCo models are limited to {MAX_MODEL_JOINTS}"):
        mjcf.compile(m.skeleton)
    assert time.perf_counter() - t0 < 1


def test_the_writer_indentation_stops_growing():
    """A 10,000-deep chain used to be written with 50 M tabs (depth squared): now linear in the joints."""
    m = bvh.parse(corpus.deep_hierarchy(10_000), "deep.bvh")
    text = bvh.format_motion(m)
    assert max(len(line) - len(line.lstrip("\t")) for line in text.splitlines()) == 33  # 32 levels + a joint's body
    assert len(text) < 200 * m.skeleton.n_joints + 100 * m.skeleton.n_channels
    again = bvh.parse(text, "again.bvh")
    assert np.array_equal(again.skeleton.parents, m.skeleton.parents)


def test_a_motion_that_overflows_in_file_units_is_not_written(base, tmp_path):
    """Finite in metres, infinite in the file's units: refused, nothing written."""
    tiny = base.replace(skeleton=base.skeleton.replace_scale(1e-310))  # metres per file unit
    with pytest.raises(MjmotionError, match="not finite in the file's units"):
        bvh.write(tiny, tmp_path / "out.bvh")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("units", [1e3, 1e-3])
def test_positions_are_checked_in_metres_after_the_unit_conversion(units):
    """1e7 file units: 10,000 km in kilometres (refused), 10 km in millimetres (loaded)."""
    data = corpus.BASE.replace("1.0 90.5 -2.0", "1e7 90.5 -2.0")
    if units == 1e3:
        with pytest.raises(BvhError, match="beyond the ±100000 m"):
            bvh.parse(data, "far.bvh", scale=units)
    else:
        assert bvh.parse(data, "far.bvh", scale=units).root_positions[0, 1] == pytest.approx(1e4)


@pytest.mark.parametrize(
    "edit",
    [
        lambda name: (
            corpus.BASE.replace("JOINT LeftLeg", "JOINT Head").replace("JOINT Head\n", f"JOINT {name}\n", 1).replace("JOINT Head", f"JOINT {name}")
        ),
        lambda name: corpus.BASE.replace("Zrotation Xrotation Yrotation\n\t\tJOINT Head", f"Zrotation {name} Yrotation\n\t\tJOINT Head"),
        lambda name: corpus.BASE.replace("OFFSET 0.00 60.00 0.00", f"OFFSET 0.00 {name} 0.00"),
        lambda name: corpus.BASE.replace("Frame Time: 0.0333333", f"Frame Time: -{'3' * 100_000}"),
        lambda name: corpus.BASE.replace("Frames: 3", f"Frames: {'9' * 100_000}"),
        lambda name: corpus.BASE.replace("MOTION", f"{name}\nMOTION"),
    ],
    ids=["duplicate-name", "channel-name", "offset", "frame-time", "frames", "stray-token"],
)
def test_messages_stay_short_whatever_the_file_holds(edit):
    """A megabyte-long name or token is quoted in a few dozen characters, not in full."""
    with pytest.raises(BvhError) as info:
        bvh.parse(edit("x" * 1_000_000), "long.bvh")
    assert len(str(info.value)) < 250, str(info.value)[:300]
