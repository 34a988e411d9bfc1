"""BVH reading and writing: format variants, validation, and lossless round trips."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import clip_params, random_motion, random_skeleton, require_data
from reference_fk import file_to_world, reference_fk

from mjmotion import bvh, compiled, kinematics, mjcf
from mjmotion import rotations as rot
from mjmotion.errors import BvhError, MjmotionError

SMALL = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 90 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0 20 0
\t\tCHANNELS 3 Zrotation Yrotation Xrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 0 0
\t\t}
\t}
\tJOINT Leg
\t{
\t\tOFFSET 10 -5 0
\t\tCHANNELS 6 Xrotation Yrotation Zrotation Xposition Yposition Zposition
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -40 0
\t\t}
\t}
}
MOTION
Frames:\t2
Frame Time: .0083333
1 2 3 10 20 30 5 6 7 8 9 10 1 2 3
4 5 6 -10 -20 -30 -5 -6 -7 -8 -9 -10 -1 -2 -3
"""


def _fk_world(motion):
    return kinematics.forward(mjcf.compile(motion.skeleton), motion).joint_positions


def test_small_file_reads_every_feature():
    m = bvh.parse(SMALL, "small.bvh")
    s = m.skeleton
    assert s.names == ("Hips", "Chest", "Leg")
    assert list(s.parents) == [-1, 0, 0]
    assert s.channels[2] == ("Xrotation", "Yrotation", "Zrotation", "Xposition", "Yposition", "Zposition")
    assert len(s.end_parents) == 2 and np.allclose(s.end_offsets[0], 0.0)  # zero-length End Site kept
    assert m.fps == pytest.approx(1 / 0.0083333)
    assert s.scale == 0.01  # 120-unit-tall skeleton: centimetres
    # Position channels add to OFFSET (seed 004 §6.3.5): root at (0+1, 90+2, 0+3) cm, Y up → world (z, x, y).
    assert np.allclose(m.root_positions[0], [0.03, 0.01, 0.92])
    # The inner 6-channel joint's translation is offset + channels.
    assert np.allclose(m.translations[0, 2], np.array([0 + 3, 10 + 1, -5 + 2]) * 0.01)
    names, ref = reference_fk(SMALL)
    assert np.abs(_fk_world(m) - file_to_world(ref, 0.01)).max() < 1e-12


@pytest.mark.parametrize(
    "variant",
    [
        lambda t: t.replace("\n", "\r\n"),
        lambda t: "\ufeff" + t,
        lambda t: t.replace("\t", "    "),
        lambda t: t.replace("\t", " \t "),
        lambda t: t.replace("Frames:\t2", "Frames: 2"),
        lambda t: t + "\n\n",
    ],
    ids=["crlf", "bom", "spaces", "mixed-whitespace", "frames-space", "trailing-blank-lines"],
)
def test_format_variants_read_the_same(variant):
    base = bvh.parse(SMALL, "a.bvh")
    other = bvh.parse(variant(SMALL).encode("utf-8"), "b.bvh")
    assert other.skeleton.names == base.skeleton.names
    assert np.allclose(_fk_world(other), _fk_world(base), atol=1e-12)


@pytest.mark.parametrize(
    "mutate, line, words",
    [
        (lambda t: t.replace("1 2 3 10 20 30 5 6 7 8 9 10 1 2 3", "1 2 3 10 20 30 5 6 7 8 9 10 1 2"), 28, "14 values"),
        (lambda t: t.replace("Frames:\t2", "Frames:\t3"), None, "Frames: 3"),
        (lambda t: t.replace("4 5 6 -10", "4 5 nan -10"), 29, "value 3 'nan' is not finite; expected a finite number"),
        (lambda t: t.replace("4 5 6 -10", "4 5 -1e400 -10"), 29, "value 3 '-1e400' is beyond the largest double (±1.797e308); expected a finite"),
        (lambda t: t.replace("4 5 6 -10", "4 5 x -10"), 29, "not a number"),
        (lambda t: t.replace("CHANNELS 3 Zrotation", "CHANNELS 4 Zrotation"), 9, "CHANNELS says 4"),
        (lambda t: t.replace("Yrotation Xrotation\n", "Yrotation Wrotation\n"), 9, "unknown channel"),
        (lambda t: t.replace("Frame Time: .0083333", "Frame Time: 0"), 27, "positive"),
        (lambda t: t.replace("JOINT Leg", "JOINT Chest"), 15, "duplicate joint name"),
        (lambda t: t.replace("MOTION", "MOTON"), 25, "unexpected"),
    ],
    ids=[
        "short-line",
        "frames-mismatch",
        "nan",
        "past-double",
        "non-numeric",
        "channel-count",
        "unknown-channel",
        "frame-time",
        "duplicate",
        "no-motion",
    ],
)
def test_errors_name_file_line_and_problem(mutate, line, words):
    with pytest.raises(BvhError) as e:
        bvh.parse(mutate(SMALL), "bad.bvh")
    msg = str(e.value)
    assert msg.startswith("bad.bvh:")
    if line is not None:
        assert e.value.line == line, msg
    assert words in msg


@pytest.mark.parametrize("path", clip_params())
def test_round_trip_every_shared_clip(path, tmp_path):
    if path is None:
        require_data()
    m = bvh.read(path)
    out = tmp_path / "rt.bvh"
    bvh.write(m, out)
    back = bvh.read(out)
    s, b = m.skeleton, back.skeleton
    assert b.names == s.names and np.array_equal(b.parents, s.parents)
    assert b.channels == s.channels
    assert b.scale == s.scale and b.up == s.up
    assert np.allclose(b.offsets, s.offsets, atol=1e-12)
    assert np.allclose(b.end_offsets, s.end_offsets, atol=1e-12)
    assert back.fps == m.fps  # the frame time is written so that it reads back exactly
    # FK of write(read(f)) against the independent FK of f itself.
    _, ref = reference_fk(path.read_text())
    err = np.abs(_fk_world(back) - file_to_world(ref, s.scale)).max()
    assert err < 1e-6 * s.stature(), f"round-trip FK error {err} m"


@pytest.mark.parametrize("seed", range(8))
def test_round_trip_random_skeletons(seed, tmp_path):
    rng = np.random.default_rng(100 + seed)
    skel = random_skeleton(rng, int(rng.integers(1, 30)))
    m = random_motion(rng, skel, int(rng.integers(1, 12)))
    text = bvh.format_motion(m)
    back = bvh.parse(text, "r.bvh", scale=1.0, up="z")
    assert back.skeleton.channels == skel.channels
    err = np.abs(_fk_world(back) - _fk_world(m)).max()
    assert err < 1e-6 * max(skel.height(), 1e-3)
    # Writing again is a fixed point of the text.
    assert bvh.format_motion(back) == text


def test_new_rotations_write_with_original_channel_order(mocap):
    m = bvh.read(mocap / "cmu_cgspeed_daz" / "07_01.bvh")[4:40]
    # An operation: rotate every joint a little more about a random axis.
    extra = rot.exp(np.random.default_rng(0).normal(0, 0.2, m.rotations.shape[:-1] + (3,)))
    changed = m.replace(rotations=rot.multiply(m.rotations, extra))
    text = bvh.format_motion(changed)
    back = bvh.parse(text, "x.bvh")
    assert back.skeleton.channels == m.skeleton.channels  # mixed ZYX root / ZXY joints kept
    assert np.abs(_fk_world(back) - _fk_world(changed)).max() < 1e-6 * m.skeleton.stature()


def test_writer_widens_channels_it_needs():
    # A joint with only a Z rotation channel that is given a rotation about X gets the missing channels.
    text = SMALL.replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 1 Zrotation")
    text = text.replace("5 6 7 8 9 10 1 2 3", "5 8 9 10 1 2 3").replace("-5 -6 -7 -8", "-5 -8")
    m = bvh.parse(text, "z.bvh")
    assert m.skeleton.channels[1] == ("Zrotation",)
    assert bvh.format_motion(m).count("CHANNELS 1 Zrotation") == 1  # representable: kept
    tilt = rot.exp(np.array([0.0, 0.3, 0.0]))  # about world y = the file's X axis
    q = m.rotations.copy()
    q[:, 1] = rot.multiply(q[:, 1], tilt)
    changed = m.replace(rotations=q)
    back = bvh.parse(bvh.format_motion(changed), "w.bvh")
    assert back.skeleton.channels[1][0] == "Zrotation" and len(back.skeleton.channels[1]) == 3
    assert np.abs(_fk_world(back) - _fk_world(changed)).max() < 1e-8


def test_a_nan_never_reaches_a_file(tmp_path):
    """A NaN rotation is refused when the motion is made, naming its frame and joint (it went on into every metric as nan)."""
    m = bvh.parse(SMALL, "s.bvh")
    q = m.rotations.copy()
    q[1, 1, 0] = np.nan
    with pytest.raises(MjmotionError, match=r"rotations at frame 1, joint 'Chest' is nan; expected finite numbers"):
        bvh.write(m.replace(rotations=q), tmp_path / "nan.bvh")
    assert not (tmp_path / "nan.bvh").exists()


def test_explicit_scale_and_up_override():
    m = bvh.parse(SMALL, "s.bvh", scale=0.02, up="z")
    assert m.skeleton.scale == 0.02 and m.skeleton.up == "z"
    # Z up: file Y stays world Y.
    assert np.allclose(m.root_positions[0], np.array([1, 92, 3]) * 0.02)


# --- the compiled path for long clips (mjmotion._fast) ----------------------------------------
def _same_motion(a, b):
    assert a.skeleton.names == b.skeleton.names and a.skeleton.channels == b.skeleton.channels
    assert np.array_equal(a.skeleton.offsets, b.skeleton.offsets) and a.fps == b.fps
    assert np.array_equal(a.rotations, b.rotations)  # bit for bit (== also equates ±0)
    assert np.array_equal(a.root_positions, b.root_positions)
    assert (a.translations is None) == (b.translations is None)
    if a.translations is not None:
        assert np.array_equal(a.translations, b.translations)


@pytest.mark.parametrize("path", clip_params())
def test_compiled_reader_gives_the_numpy_readers_floats_on_every_shared_clip(path, monkeypatch):
    if path is None:
        require_data()
    data = path.read_bytes()
    # The values themselves: the kernel's parse against np.loadtxt's, bit for bit.
    lines = bvh._decode(data, str(path)).split("\n")
    nodes, motion_line = bvh._parse_hierarchy(lines, str(path))
    frames, _, first = bvh._parse_motion_header(lines, motion_line, str(path))
    n_channels = sum(len(n.channels or ()) for n in nodes if not n.is_end)
    expect = bvh._parse_values(lines, first, n_channels, frames, str(path))
    monkeypatch.setattr(bvh, "FAST_MIN_BYTES", 0)
    monkeypatch.setattr(compiled, "COLD_START_S", 0.0)  # the compiled path even where it does not pay
    seen = {}
    real = bvh._to_motion

    def spy(skel, values, fps, p, kernels=None):
        seen["values"], seen["kernels"] = values, kernels
        return real(skel, values, fps, p, kernels)

    monkeypatch.setattr(bvh, "_to_motion", spy)
    fast = bvh.parse(data, str(path))
    assert seen["kernels"] is not None, "the compiled path refused a shared clip"
    assert seen["values"].shape == expect.shape
    assert np.array_equal(seen["values"], expect)
    assert np.array_equal(np.signbit(seen["values"]), np.signbit(expect))  # -0.0 stays -0.0
    monkeypatch.setattr(bvh, "FAST_MIN_BYTES", 1 << 62)
    _same_motion(fast, bvh.parse(data, str(path)))


#: Edits of a valid file's motion section: formats the kernel must read exactly like np.loadtxt,
#: and faults whose errors must be the NumPy path's (same line, same message).
MOTION_EDITS = {
    "crlf": lambda h, rows: h.replace("\n", "\r\n") + "\r\n".join(" ".join(r) for r in rows) + "\r\n",
    "cr": lambda h, rows: h + "\r".join(" ".join(r) for r in rows),
    "tabs-blank-lines": lambda h, rows: h + "\n\n".join("\t".join(r) + " \t" for r in rows) + "\n\n  \n",
    "signs-and-exponents": lambda h, rows: h + "\n".join(" ".join(f"{float(x):+.6e}" for x in r) for r in rows) + "\n",
    "short-forms": lambda h, rows: h + "\n".join(" ".join(("." + x.split(".")[1]) if x.startswith("0.") else x.rstrip("0") for x in r) for r in rows),
    "long-mantissas": lambda h, rows: h + "\n".join(" ".join(repr(float(x) / 3.0) + "1234" for x in r) for r in rows) + "\n",
    "tiny-and-huge": lambda h, rows: (
        h + "\n".join(" ".join(f"{float(x)}e-30" if i % 2 else f"{float(x)}E+25" for i, x in enumerate(r)) for r in rows) + "\n"
    ),
    "missing-value": lambda h, rows: h + "\n".join(" ".join(r[:-1] if i == 3 else r) for i, r in enumerate(rows)) + "\n",
    "extra-line": lambda h, rows: h + "\n".join(" ".join(r) for r in rows + [rows[0]]) + "\n",
    "missing-line": lambda h, rows: h + "\n".join(" ".join(r) for r in rows[:-1]) + "\n",
    "word": lambda h, rows: h + "\n".join(" ".join(["abc" if (i, j) == (2, 1) else x for j, x in enumerate(r)]) for i, r in enumerate(rows)),
    "nan": lambda h, rows: h + "\n".join(" ".join(["nan" if (i, j) == (4, 0) else x for j, x in enumerate(r)]) for i, r in enumerate(rows)),
    "overflow": lambda h, rows: h + "\n".join(" ".join(["1e999" if (i, j) == (1, 2) else x for j, x in enumerate(r)]) for i, r in enumerate(rows)),
    "underscore": lambda h, rows: h + "\n".join(" ".join(["1_0" if (i, j) == (1, 2) else x for j, x in enumerate(r)]) for i, r in enumerate(rows)),
    "glued": lambda h, rows: h + "\n".join(" ".join(["1.5-2" if (i, j) == (1, 2) else x for j, x in enumerate(r)]) for i, r in enumerate(rows)),
    "bare-sign": lambda h, rows: h + "\n".join(" ".join(["-" if (i, j) == (1, 2) else x for j, x in enumerate(r)]) for i, r in enumerate(rows)),
    "comma": lambda h, rows: h + "\n".join(",".join(r) for r in rows),
    "vertical-tab": lambda h, rows: h + "\n".join("\x0b".join(r) for r in rows),
    "nul": lambda h, rows: h + "\n".join(" ".join(r) for r in rows) + "\x00",
    "bom": lambda h, rows: "\ufeff" + h + "\n".join(" ".join(r) for r in rows),
    "frames-huge": lambda h, rows: h.replace("Frames: 12", "Frames: 999999999999") + "\n".join(" ".join(r) for r in rows),
    "frames-tab-header-blank": lambda h, rows: h.replace("Frames: ", "\nFrames:\t") + "\n".join(" ".join(r) for r in rows),
}


@pytest.mark.parametrize("edit", list(MOTION_EDITS))
@pytest.mark.parametrize("as_bytes", [False, True], ids=["str", "bytes"])
def test_compiled_path_reads_or_refuses_exactly_as_the_numpy_path(edit, as_bytes, monkeypatch):
    rng = np.random.default_rng(len(edit))
    m = random_motion(rng, random_skeleton(rng, 7, inner_positions=True), 12)
    text = bvh.format_motion(m)
    scale = m.skeleton.scale  # random skeletons are too small for unit detection
    if edit == "tiny-and-huge":
        scale *= 1e-25  # positions of 1e25 file units stay within caps.MAX_COORD_M metres
    head, body = text.split("Frame Time:", 1)
    ft_line, values = body.split("\n", 1)
    rows = [line.split() for line in values.splitlines() if line.strip()]
    data = MOTION_EDITS[edit](head + "Frame Time:" + ft_line + "\n", rows)
    if as_bytes:
        data = data.encode("utf-8")

    monkeypatch.setattr(compiled, "COLD_START_S", 0.0)  # the compiled path even where it does not pay

    def run(min_bytes):
        monkeypatch.setattr(bvh, "FAST_MIN_BYTES", min_bytes)
        try:
            return bvh.parse(data, "e.bvh", scale=scale)
        except BvhError as e:
            return (e.line, e.message)

    fast, slow = run(0), run(1 << 62)
    if isinstance(slow, tuple):
        assert fast == slow
    else:
        _same_motion(fast, slow)
    if edit in ("crlf", "cr", "tabs-blank-lines", "signs-and-exponents", "short-forms", "long-mantissas", "tiny-and-huge", "bom"):
        monkeypatch.setattr(bvh, "FAST_MIN_BYTES", 0)
        assert not isinstance(slow, tuple) and bvh._parse_fast(data, "e.bvh", scale, "y") is not None, "valid: compiled path"


def test_value_kernel_rounds_every_number_as_python_does():
    """Random decimal numbers of 1–20 digits and exponents to ±40: the kernel's floats (fast or
    deferred to ``float``) equal Python's correctly rounded ones bit for bit."""
    from mjmotion import _fast

    rng = np.random.default_rng(7)
    n = 20_000
    tokens = []
    for _ in range(n):
        digits = "".join(map(str, rng.integers(0, 10, int(rng.integers(1, 21)))))
        point = int(rng.integers(0, len(digits) + 1))
        tok = (rng.choice(["", "-", "+"])) + digits[:point] + "." + digits[point:]
        if rng.random() < 0.4:
            tok += f"{rng.choice(['e', 'E'])}{int(rng.integers(-40, 41)):+d}"
        tokens.append(tok if tok.strip("+-.") else "0")
    text = ("\n".join(" ".join(tokens[i : i + 100]) for i in range(0, n, 100)) + "\n").encode()
    out = np.empty((n // 100, 100))
    deferred = np.empty((n, 4), dtype=np.int64)
    k = _fast.parse_values(np.frombuffer(text, np.uint8), 0, out, deferred)
    assert 0 < k < n  # both the exact fast path and the deferred conversion are exercised
    for a, b, row, col in deferred[:k].tolist():
        out[row, col] = float(text[a:b])
    expect = np.array([float(t) for t in tokens]).reshape(out.shape)
    assert np.array_equal(out.view(np.int64), expect.view(np.int64))


def test_compiled_rotations_equal_rotations_euler_to_quat():
    """Every channel layout (0–3 rotation channels, any order, repeats), large angles and ±0:
    the kernel's quaternions are rotations.euler_to_quat's with the axis change, bit for bit."""
    from mjmotion import _fast

    rng = np.random.default_rng(3)
    t, layouts = 50, ["", "X", "ZY", "ZXY", "YXZ", "XZX", "ZYX", "YZX"]
    values = rng.uniform(-720, 720, (t, 3 * len(layouts)))
    values[::7] = values[1]  # repeated frames: the kernel reuses its sines and cosines
    values[5, :4] = [0.0, -0.0, 180.0, -90.0]
    cols = np.full((len(layouts), 3), -1, dtype=np.int64)
    axes = np.full_like(cols, -1)
    for j, lay in enumerate(layouts):
        cols[j, : len(lay)] = 3 * j + np.arange(len(lay))
        axes[j, : len(lay)] = ["XYZ".index(a) for a in lay]
    perm = np.argmax(bvh.up_matrix("y"), axis=1)
    out = np.empty((t, len(layouts), 4))
    _fast.euler_quats(values, cols, axes, perm, out)
    for j, lay in enumerate(layouts):
        q = rot.euler_to_quat(values[:, 3 * j : 3 * j + len(lay)], lay) if lay else np.tile(rot.IDENTITY, (t, 1))
        assert np.array_equal(out[:, j, 0], q[:, 0]) and np.array_equal(out[:, j, 1:], q[:, 1 + perm]), lay
        ref = rot.from_scipy(rot.to_scipy(q)) if lay else q  # and they are the rotations SciPy composes
        assert np.allclose(np.abs(np.sum(q * ref, -1)), 1.0)


def test_the_compiled_path_is_taken_only_where_it_pays(monkeypatch):
    """Fresh process (kernels not loaded): NumPy unless its predicted time exceeds the kernels'
    first call on a machine; kernels loaded: every section from FAST_MIN_BYTES."""
    monkeypatch.delitem(sys.modules, "mjmotion._fast", raising=False)
    cold = int(compiled.COLD_START_S / bvh.NUMPY_SECONDS_PER_BYTE)
    assert not bvh._compiled_pays(bvh.FAST_MIN_BYTES) and not bvh._compiled_pays(3_400_000)
    assert bvh._compiled_pays(cold + 1) and not bvh._compiled_pays(cold - 1)
    from mjmotion import _fast

    monkeypatch.setitem(sys.modules, "mjmotion._fast", _fast)
    values, deferred = np.empty((1, 1)), np.empty((1, 4), dtype=np.int64)
    assert _fast.parse_values(np.frombuffer(b"1.5\n", np.uint8), 0, values, deferred) == 0 and values[0, 0] == 1.5
    _fast.euler_quats(values, np.full((1, 3), -1, np.int64), np.full((1, 3), -1, np.int64), np.arange(3), np.empty((1, 1, 4)))
    assert bvh._compiled_pays(bvh.FAST_MIN_BYTES) and not bvh._compiled_pays(bvh.FAST_MIN_BYTES - 1)


def test_large_files_take_the_compiled_path_and_small_ones_do_not(monkeypatch):
    monkeypatch.setattr(compiled, "COLD_START_S", 0.0)
    rng = np.random.default_rng(11)
    m = random_motion(rng, random_skeleton(rng, 4), 3)
    assert m.skeleton.scale == 1.0
    small = bvh.format_motion(m)
    assert bvh._parse_fast(small, "s.bvh", 1.0, "y") is None  # below FAST_MIN_BYTES: no Numba import
    frames = int(np.ceil(bvh.FAST_MIN_BYTES / (len(small.split("Frame Time:")[1]) / 3))) + 3
    big_motion = random_motion(rng, m.skeleton, frames)
    big = bvh.format_motion(big_motion)
    fast = bvh._parse_fast(big, "b.bvh", 1.0, "y")
    assert fast is not None and fast.n_frames == frames
    fast_z = bvh._parse_fast(big, "b.bvh", 1.0, "z")  # a Z-up file: the identity permutation
    monkeypatch.setattr(bvh, "FAST_MIN_BYTES", 1 << 62)
    _same_motion(fast, bvh.parse(big, "b.bvh", scale=1.0))
    _same_motion(fast_z, bvh.parse(big, "b.bvh", scale=1.0, up="z"))


@pytest.mark.parametrize("fps", [29.97, 59.94, 119.88, 30000 / 1001, 23.976, 24.0, 7.3, 120.0])
def test_common_rates_read_back_exactly(tmp_path, fps):
    """1/(1/29.97) is 29.969999999999995: the rate is found again from the frame time written (a NumPy
    scalar rate was written as 'np.float64(…)', a file the reader refused)."""
    m = bvh.parse(SMALL, "s.bvh").replace(fps=np.float64(fps))
    bvh.write(m, tmp_path / "r.bvh")
    assert "np." not in (tmp_path / "r.bvh").read_text()
    assert bvh.read(tmp_path / "r.bvh").fps == fps


def test_the_3dsmax_frame_time_reads_as_written(mocap):
    """A frame time we did not write (.0083333) keeps its plain reciprocal."""
    assert bvh.read(mocap / "cmu_cgspeed_max" / "131_02.bvh").fps == pytest.approx(1 / 0.0083333, rel=1e-15)


def test_write_refuses_what_read_would_refuse(tmp_path):
    m = bvh.parse(SMALL, "s.bvh")
    with pytest.raises(MjmotionError, match="1e\\+09 fps; a BVH file holds 0.1 to 10000 frames per second"):
        bvh.write(m.replace(fps=1e9), tmp_path / "f.bvh")
    far = m.replace(root_positions=m.root_positions + [1e12, 0.0, 0.0])
    with pytest.raises(MjmotionError, match="positions within ±100000 m"):
        bvh.write(far, tmp_path / "f.bvh")
    assert not (tmp_path / "f.bvh").exists()
