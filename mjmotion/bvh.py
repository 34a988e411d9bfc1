"""Read and write BVH files (seed 004 §6.3.5; the Biovision format as exporters write it).

Reading accepts any number of joints; per joint any subset of the six channels in any order
(differing per joint); position channels add to ``OFFSET``; End Sites (zero-length too); any
whitespace, tabs, CRLF and a UTF-8 byte-order mark; ``Frame Time: .0083333``; ``Frames:``
followed by a tab. Every problem is a :class:`~mjmotion.errors.BvhError` naming the file, the
line and what was expected. The hierarchy is parsed without recursion, so deep files are fine.

Writing is lossless for forward kinematics: each joint keeps its channel order, offsets are
written with ten significant digits, angles with six decimals and positions to 5 nm.
"""

from __future__ import annotations

import functools
import io
import itertools
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import compiled
from . import rotations as rot
from .caps import MAX_COORD_M, MAX_FILE_BYTES, MAX_FPS, MAX_JOINTS, MIN_FPS, check_motion_size
from .errors import BvhError, MjmotionError
from .inputs import InputError, read_input
from .skeleton import (
    MM,
    POSITION_CHANNELS,
    ROTATION_CHANNELS,
    Motion,
    Skeleton,
    detect_scale,
    up_matrix,
)

_KNOWN_CHANNELS = set(POSITION_CHANNELS) | set(ROTATION_CHANNELS)
_CHANNEL_CASE = {c.lower(): c for c in _KNOWN_CHANNELS}
#: Tolerance (degrees, file units) below which a value a joint has no channel for counts as zero.
_WIDEN_TOL = 1e-6


@dataclass
class _Node:
    name: str
    parent: int
    line: int
    offset: np.ndarray | None = None
    channels: tuple[str, ...] | None = None
    is_end: bool = False
    offset_line: int = 0


def read(
    path: str | os.PathLike[str],
    scale: float | None = None,
    up: str = "y",
    max_bytes: int | None = None,
) -> Motion:
    """Load a BVH file into a :class:`Motion` in metres and the Z-up world.

    Args:
        path: the file.
        scale: metres per file unit; ``None`` detects it from the skeleton's extent
            (centimetres, metres, millimetres or CMU's ASF unit).
        up: the file's up axis, ``"y"`` (the BVH norm) or ``"z"``.
        max_bytes: refuse files larger than this (``None``: :data:`mjmotion.caps.MAX_FILE_BYTES`).

    Only a regular file is read (a FIFO, a device or a directory is refused before it is
    opened) and never more than ``max_bytes`` of it (:func:`mjmotion.inputs.read_input`).

    Every frame of the file is kept. The command-line verbs (and the Studio) also leave out a
    leading T-pose or transition (the cgspeed daz clips' frames 0-3); to get the frames they
    judge, use ``mjmotion.trim.skip_leading_transient(read(path))[0]``.
    """
    p = str(path)
    if scale is not None and (isinstance(scale, (str, bool)) or not isinstance(scale, (int, float, np.integer, np.floating))):
        # (scale="cm" was a TypeError; the unit error's own advice is "scale= in mjmotion.read")
        raise MjmotionError(f"scale={scale!r}: expected metres per file unit as a number (0.01 for centimetres), or None to detect it")
    try:
        raw = read_input(p, MAX_FILE_BYTES if max_bytes is None else max_bytes, "a .bvh file")
    except InputError as e:
        raise BvhError(p, None, e.message) from None
    motion = parse(raw, p, scale=scale, up=up)
    return motion.replace(name=Path(p).stem)


def parse(data: bytes | str, path: str = "<string>", scale: float | None = None, up: str = "y") -> Motion:
    """Parse BVH text (``bytes`` or ``str``); ``path`` only names the source in errors."""
    fast = _parse_fast(data, path, scale, up)
    if fast is not None:
        return fast
    lines = _decode(data, path).split("\n")  # the decoded text is not kept: memory is ~2x the file
    nodes, motion_line = _parse_hierarchy(lines, path)
    joints = [n for n in nodes if not n.is_end]
    frames, frame_time, first_data_line = _parse_motion_header(lines, motion_line, path, len(joints))
    n_channels = sum(len(n.channels or ()) for n in joints)
    values = _parse_values(lines, first_data_line, n_channels, frames, path)
    skel = _build_skeleton(nodes, path, scale, up)
    bad = _position_out_of_range(values, skel)
    if bad is not None:
        row, col, what = bad
        ln = first_data_line + 1 + _nonempty_line_offset(lines, first_data_line, row)
        raise BvhError(path, ln, f"value {col + 1} ({what}) is {values[row, col]:g} file units, {_coord_limit(skel)}")
    return _to_motion(skel, values, rate_of(frame_time), path)


def _coord_limit(skel: Skeleton) -> str:
    return f"beyond the ±{MAX_COORD_M:g} m a clip may span ({MAX_COORD_M / skel.scale:g} units of {skel.scale:g} m)"


def _position_out_of_range(values: np.ndarray, skel: Skeleton) -> tuple[int, int, str] | None:
    """``(row, column, channel)`` of the first position value beyond :data:`MAX_COORD_M` in metres, or ``None``."""
    cols = [
        (c, f"{skel.names[j]} {ch}")
        for j, c0 in enumerate(np.cumsum([0, *map(len, skel.channels)])[:-1])
        for c, ch in enumerate(skel.channels[j], int(c0))
        if ch in POSITION_CHANNELS
    ]
    if not cols:
        return None
    idx = np.array([c for c, _ in cols])
    big = np.abs(values[:, idx]) > MAX_COORD_M / skel.scale
    if not big.any():
        return None
    row, k = map(int, np.argwhere(big)[0])
    return row, int(idx[k]), cols[k][1]


# --- the compiled path for long clips --------------------------------------------------------
#: Motion sections from this many bytes up may take the compiled path (``mjmotion._fast``), when
#: it pays end to end (:mod:`mjmotion.compiled`): the kernels are loaded in this process already,
#: or the NumPy path would take longer than their first call on a machine.
FAST_MIN_BYTES = 1 << 20
#: The NumPy path's speed, to predict its time (``benchmarks/bench_compiled.py``: 9–12 ns per byte).
NUMPY_SECONDS_PER_BYTE = 1.2e-8
#: At most this many numbers per file are converted by Python for the compiled path.
_MAX_DEFERRED = 1 << 16


def _compiled_pays(n_bytes: int) -> bool:
    """Whether a motion section of ``n_bytes`` takes the compiled path (see :data:`FAST_MIN_BYTES`)."""
    if n_bytes < FAST_MIN_BYTES:
        return False
    fast = sys.modules.get(f"{__package__}._fast")
    loaded = fast is not None and compiled.ready(fast.parse_values, fast.euler_quats)
    return compiled.pays(n_bytes * NUMPY_SECONDS_PER_BYTE, loaded)


@functools.lru_cache(maxsize=1)
def _fast_kernels():
    """``mjmotion._fast``, or ``None`` without a working Numba (then everything takes the NumPy path)."""
    try:
        from . import _fast
    except ImportError:  # pragma: no cover - numba is a dependency
        return None
    return _fast


def _parse_fast(data: bytes | str, path: str, scale: float | None, up: str) -> Motion | None:
    """:func:`parse` for a long, regular file without splitting it into lines, or ``None``.

    Only the head (hierarchy and motion header) is decoded and parsed as text; the values are
    parsed from the bytes by a compiled kernel. On anything irregular (an error anywhere, a
    number format the kernel does not take) this returns ``None`` and :func:`parse` starts over
    on the NumPy path, so error messages and values are exactly the NumPy path's.
    """
    head = _parse_values_fast(data, path)
    if head is None:
        return None
    nodes, frame_time, values, kernels = head
    skel = _build_skeleton(nodes, path, scale, up)
    if _position_out_of_range(values, skel) is not None:
        return None  # the NumPy path names the line
    return _to_motion(skel, values, rate_of(frame_time), path, kernels)


def _parse_values_fast(data: bytes | str, path: str):
    """``(nodes, frame_time, values (T, C), kernels)`` by the compiled path, or ``None``."""
    if len(data) < FAST_MIN_BYTES:
        return None
    if isinstance(data, str):
        try:
            data = data.encode("utf-8")
        except UnicodeEncodeError:
            return None
    if data.startswith((b"\xff\xfe", b"\xfe\xff")) or data.find(b"\x00") >= 0:
        return None
    cut = _motion_values_start(data)
    if cut is None or not _compiled_pays(len(data) - cut):
        return None
    kernels = _fast_kernels()
    if kernels is None:
        return None
    try:
        lines = _decode(data[:cut], path).split("\n")
        nodes, motion_line = _parse_hierarchy(lines, path)
        frames, frame_time, first_data_line = _parse_motion_header(lines, motion_line, path, sum(not n.is_end for n in nodes))
    except BvhError:
        return None
    n_channels = sum(len(n.channels or ()) for n in nodes if not n.is_end)
    if first_data_line != len(lines) - 1 or n_channels == 0:
        return None  # the head is not what the NumPy path would read as the header
    if frames * n_channels > (len(data) - cut + 1) // 2:
        return None  # too few bytes for 'Frames:' (a value and its separator take two): an error
    values = np.empty((frames, n_channels))
    deferred = np.empty((min(values.size, _MAX_DEFERRED), 4), dtype=np.int64)
    n_deferred = kernels.parse_values(np.frombuffer(data, np.uint8), cut, values, deferred)
    if n_deferred < 0:
        return None
    for a, b, row, col in deferred[:n_deferred].tolist():
        # Numbers beyond the kernel's exact fast path: Python's correctly rounded conversion,
        # the one np.loadtxt uses (the kernel checked their syntax: no '_', no 'inf').
        values[row, col] = float(data[a:b])
    if n_deferred and not np.isfinite(values).all():
        return None
    return nodes, frame_time, values, kernels


def _motion_values_start(data: bytes) -> int | None:
    """Byte offset after ``MOTION`` and the two non-blank lines after it, or ``None``."""
    pos = data.find(b"MOTION")
    if pos < 0:
        return None
    pos = _next_line(data, pos)
    found = 0
    while found < 2:
        if pos >= len(data):
            return None
        end = _next_line(data, pos)
        if data[pos:end].strip():
            found += 1
        pos = end
    return pos if pos <= len(data) else None


def _next_line(data: bytes, pos: int) -> int:
    """Start of the line after the one holding ``pos`` (LF, CRLF or CR); ``len + 1`` at the end."""
    lf = data.find(b"\n", pos)
    if lf < 0:
        lf = len(data)
    cr = data.find(b"\r", pos, lf)
    if cr >= 0:
        return cr + 2 if data[cr + 1 : cr + 2] == b"\n" else cr + 1
    return lf + 1


# --- decoding ------------------------------------------------------------------------------
def _decode(data: bytes | str, path: str) -> str:
    if isinstance(data, str):
        text = data
    else:
        if data.startswith(b"\xef\xbb\xbf"):
            data = data[3:]
        elif data.startswith((b"\xff\xfe", b"\xfe\xff")):
            # UTF-16 with a byte-order mark (Windows tools, PowerShell '>'): text, not binary.
            try:
                return _decode(data.decode("utf-16"), path)
            except UnicodeDecodeError as e:
                raise BvhError(path, None, f"invalid UTF-16 at byte {e.start}; expected a text BVH file") from None
        nul = data.find(b"\x00")
        if nul >= 0:
            raise BvhError(path, data.count(b"\n", 0, nul) + 1, "binary data (a NUL byte); expected a text BVH file")
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as e:
            line = data.count(b"\n", 0, e.start) + 1
            raise BvhError(path, line, f"invalid UTF-8 (byte 0x{data[e.start]:02x}); expected a text BVH file") from None
    if text.startswith("\ufeff"):
        text = text[1:]
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    if not text.strip():
        raise BvhError(path, 1, "file is empty; expected 'HIERARCHY'")
    return text


# --- hierarchy -----------------------------------------------------------------------------
def _q(text: str, n: int = 40) -> str:
    """``repr`` of text from the file, shortened: a message stays one readable line whatever the file holds."""
    return repr(text if len(text) <= n else text[:n] + "…")


def _strict_float(tok: str) -> float:
    """``float(tok)`` accepting only what the motion-section parser (``np.loadtxt``) accepts.

    Python's ``float`` also takes ``1_000`` and non-ASCII digits; refusing them here keeps the
    hierarchy and the motion section consistent and lets a bad value be found by line.
    """
    if not tok.isascii() or "_" in tok:
        raise ValueError(tok)
    return float(tok)


def _parse_float(tok: str, path: str, line: int, what: str) -> float:
    try:
        v = _strict_float(tok)
    except ValueError:
        raise BvhError(path, line, f"{what}: {_q(tok)} is not a number") from None
    if not np.isfinite(v):
        raise BvhError(path, line, f"{what}: {_q(tok)} is not a finite number")
    return v


def _parse_hierarchy(lines: list[str], path: str) -> tuple[list[_Node], int]:
    """Nodes in file order (joints and End Sites) and the 0-based index of the MOTION line."""
    nodes: list[_Node] = []
    stack: list[int] = []  # open braces: node indices
    pending: int | None = None  # node declared, its '{' not seen yet
    seen_header = False
    seen_root = False
    names: dict[str, int] = {}
    i = 0
    n_lines = len(lines)
    while i < n_lines:
        toks = lines[i].split()
        ln = i + 1
        i += 1
        k = 0
        while k < len(toks):
            t = toks[k]
            if not seen_header:
                if t != "HIERARCHY":
                    raise BvhError(path, ln, f"expected 'HIERARCHY' at the start of the file, found {_q(t)}")
                seen_header = True
                k += 1
                continue
            if t in ("ROOT", "JOINT"):
                if pending is not None:
                    raise BvhError(path, ln, f"expected '{{' after {_q(nodes[pending].name)}, found {_q(t)}")
                rest = toks[k + 1 :]
                brace = bool(rest) and rest[-1] == "{"
                name = " ".join(rest[:-1] if brace else rest)
                if not name:
                    raise BvhError(path, ln, f"{t} needs a joint name")
                if not name.isprintable():
                    bad = next(ch for ch in name if not ch.isprintable())
                    raise BvhError(path, ln, f"joint name {_q(name)} has a control character (U+{ord(bad):04X}); expected printable text")
                if len(names) >= MAX_JOINTS:
                    raise BvhError(path, ln, f"more than {MAX_JOINTS} joints; the limit for one skeleton (is this a character?)")
                if t == "ROOT":
                    if seen_root:
                        raise BvhError(path, ln, "a second ROOT; expected one hierarchy per file")
                    if stack:
                        raise BvhError(path, ln, "ROOT inside another joint; expected 'JOINT'")
                    parent = -1
                    seen_root = True
                else:
                    if not stack or nodes[stack[-1]].is_end:
                        raise BvhError(path, ln, "JOINT outside a joint's braces")
                    parent = stack[-1]
                if name in names:
                    raise BvhError(path, ln, f"duplicate joint name {_q(name)} (first on line {names[name]})")
                names[name] = ln
                nodes.append(_Node(name, parent, ln))
                pending = len(nodes) - 1
                if brace:
                    stack.append(pending)
                    pending = None
                k = len(toks)
            elif t == "End":
                if pending is not None:
                    raise BvhError(path, ln, f"expected '{{' after {_q(nodes[pending].name)}, found 'End'")
                if k + 1 >= len(toks) or toks[k + 1] != "Site":
                    raise BvhError(path, ln, "expected 'End Site'")
                if not stack or nodes[stack[-1]].is_end:
                    raise BvhError(path, ln, "End Site outside a joint's braces")
                nodes.append(_Node(f"{nodes[stack[-1]].name}/End", stack[-1], ln, is_end=True))
                pending = len(nodes) - 1
                k += 2
            elif t == "{":
                if pending is None:
                    raise BvhError(path, ln, "unexpected '{' (expected it after ROOT, JOINT or End Site)")
                stack.append(pending)
                pending = None
                k += 1
            elif t == "}":
                if pending is not None:
                    raise BvhError(path, ln, f"expected '{{' after {_q(nodes[pending].name)}, found '}}'")
                if not stack:
                    raise BvhError(path, ln, "unbalanced '}': no open brace to close")
                node = nodes[stack.pop()]
                if node.offset is None:
                    raise BvhError(path, ln, f"{_q(node.name)} (line {node.line}) has no OFFSET")
                if node.channels is None and not node.is_end:
                    raise BvhError(path, ln, f"joint {_q(node.name)} (line {node.line}) has no CHANNELS")
                k += 1
            elif t == "OFFSET":
                cur = _current(nodes, stack, pending, path, ln, "OFFSET")
                if len(toks) - k - 1 < 3:
                    raise BvhError(path, ln, f"OFFSET needs 3 numbers, found {len(toks) - k - 1}")
                if cur.offset is not None:
                    raise BvhError(path, ln, f"a second OFFSET for {_q(cur.name)}")
                cur.offset = np.array([_parse_float(x, path, ln, "OFFSET") for x in toks[k + 1 : k + 4]])
                cur.offset_line = ln
                k += 4
            elif t == "CHANNELS":
                cur = _current(nodes, stack, pending, path, ln, "CHANNELS")
                if cur.is_end:
                    raise BvhError(path, ln, "an End Site cannot have CHANNELS")
                if cur.channels is not None:
                    raise BvhError(path, ln, f"a second CHANNELS for {_q(cur.name)}")
                if k + 1 >= len(toks):
                    raise BvhError(path, ln, "CHANNELS needs a count")
                try:
                    count = int(toks[k + 1])
                except ValueError:
                    raise BvhError(path, ln, f"CHANNELS count {_q(toks[k + 1])} is not a whole number") from None
                names_ = toks[k + 2 :]
                if count < 0 or count > 6 or len(names_) != count:
                    raise BvhError(path, ln, f"CHANNELS says {count} but lists {len(names_)} channel names; expected 0 to 6 matching names")
                chans = []
                for c in names_:
                    canon = _CHANNEL_CASE.get(c.lower())
                    if canon is None:
                        raise BvhError(path, ln, f"unknown channel {_q(c)}; expected X/Y/Z position or rotation")
                    chans.append(canon)
                if len(set(chans)) != len(chans):
                    raise BvhError(path, ln, "a channel is listed twice")
                cur.channels = tuple(chans)
                k = len(toks)
            elif t == "MOTION":
                if pending is not None or stack:
                    open_ = nodes[stack[-1]] if stack else nodes[pending]  # type: ignore[index]
                    raise BvhError(path, ln, f"unbalanced braces: {_q(open_.name)} (line {open_.line}) is not closed before MOTION")
                if not seen_root:
                    raise BvhError(path, ln, "MOTION before any ROOT joint")
                return nodes, i - 1
            else:
                raise BvhError(path, ln, f"unexpected {_q(t)} in the HIERARCHY section")
    if not seen_header:
        raise BvhError(path, 1, "expected 'HIERARCHY'")
    if stack:
        node = nodes[stack[-1]]
        raise BvhError(path, n_lines, f"unbalanced braces: {_q(node.name)} (line {node.line}) is never closed")
    raise BvhError(path, n_lines, "no MOTION section; expected 'MOTION' after the hierarchy")


def _current(nodes: list[_Node], stack: list[int], pending: int | None, path: str, ln: int, what: str) -> _Node:
    if pending is not None:
        raise BvhError(path, ln, f"expected '{{' before {what}")
    if not stack:
        raise BvhError(path, ln, f"{what} outside a joint's braces")
    return nodes[stack[-1]]


def _parse_motion_header(lines: list[str], motion_idx: int, path: str, n_joints: int = 1) -> tuple[int, float, int]:
    """``(frames, frame_time, 0-based index of the first data line)``; refuses a clip over the
    size limits (:func:`mjmotion.caps.check_motion_size`) before its values are read."""
    toks_after = lines[motion_idx].split()
    if toks_after != ["MOTION"]:
        raise BvhError(path, motion_idx + 1, "expected 'MOTION' alone on its line")
    i = motion_idx + 1
    header: list[tuple[int, str]] = []
    while i < len(lines) and len(header) < 2:
        s = " ".join(lines[i].split())  # any run of blanks counts as one ("Frame \t Time:")
        if s:
            header.append((i + 1, s))
        i += 1
    if len(header) < 1:
        raise BvhError(path, motion_idx + 1, "MOTION is not followed by 'Frames: N'")
    ln, s = header[0]
    if not s.startswith("Frames:"):
        raise BvhError(path, ln, f"expected 'Frames: N', found {_q(s)}")
    val = s[len("Frames:") :].strip()
    try:
        frames = int(val)
    except ValueError:
        what = "is too large" if val.lstrip("+-").isdigit() else "is not a whole number"
        raise BvhError(path, ln, f"Frames: {_q(val)} {what}") from None
    if frames < 1:
        raise BvhError(path, ln, f"Frames: {frames}; expected at least one frame")
    try:
        check_motion_size(frames, n_joints, "Frames")
    except MjmotionError as e:
        raise BvhError(path, ln, str(e)) from None
    if len(header) < 2:
        raise BvhError(path, ln + 1, "expected 'Frame Time: SECONDS'")
    ln, s = header[1]
    if not s.startswith("Frame Time:"):
        raise BvhError(path, ln, f"expected 'Frame Time: SECONDS', found {_q(s)}")
    val = s[len("Frame Time:") :].strip()
    ft = _parse_float(val, path, ln, "Frame Time")
    if ft <= 0:
        raise BvhError(path, ln, f"Frame Time {_q(val)}; expected a positive number of seconds")
    if not 1.0 / MAX_FPS <= ft <= 1.0 / MIN_FPS:
        raise BvhError(
            path,
            ln,
            f"Frame Time {_q(val)}: expected {1.0 / MAX_FPS:g} to {1.0 / MIN_FPS:g} seconds per frame ({MIN_FPS:g} to {MAX_FPS:g} frames per second)",
        )
    return frames, ft, i


def _parse_values(lines: list[str], start: int, n_channels: int, frames: int, path: str) -> np.ndarray:
    """Motion values ``(frames, n_channels)``; checked: counts per line, numbers, finiteness."""
    if n_channels == 0:
        rows = sum(1 for line in lines[start:] if line.strip())
        if rows:
            raise BvhError(path, start + 1, "the skeleton declares no channels but the motion section has values")
        return np.zeros((frames, 0))
    if not any(line.strip() for line in itertools.islice(lines, start, None)):
        raise BvhError(path, start + 1, f"'Frames: {frames}' but the motion section has no values")
    try:
        # loadtxt over the list of lines: no joined copy of the text (4x less memory, faster).
        values = np.loadtxt(itertools.islice(lines, start, None), dtype=float, comments=None, ndmin=2)
    except ValueError:
        values = None  # the slow path below finds the line and says what is wrong
    if values is None or values.shape[1] != n_channels:
        _diagnose_values(lines, start, n_channels, path)
        raise BvhError(path, start + 1, "motion values could not be read")  # pragma: no cover
    if values.shape[0] != frames:
        where = start + 1 + _nonempty_line_offset(lines, start, min(values.shape[0], frames))
        raise BvhError(
            path,
            where,
            f"'Frames: {frames}' but the motion section has {values.shape[0]} lines of values",
        )
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = map(int, np.argwhere(bad)[0])
        ln = start + 1 + _nonempty_line_offset(lines, start, row)
        fields = lines[ln - 1].split() if 0 < ln <= len(lines) else []
        text = fields[col] if col < len(fields) else str(values[row, col])
        # A number past a double's range (1e400) reads as inf: say what the file holds, and why.
        what = "not finite" if text.lower().lstrip("+-") in ("inf", "infinity", "nan") else "beyond the largest double (±1.797e308)"
        raise BvhError(path, ln, f"value {col + 1} {_q(text)} is {what}; expected a finite number")
    return values


def _nonempty_line_offset(lines: list[str], start: int, row: int) -> int:
    """Offset from ``start`` of the ``row``-th non-empty line (or the line after the last one)."""
    seen = 0
    last = -1
    for off, line in enumerate(lines[start:]):
        if line.strip():
            if seen == row:
                return off
            seen += 1
            last = off
    return last + 1


def _diagnose_values(lines: list[str], start: int, n_channels: int, path: str) -> None:
    for off, line in enumerate(lines[start:]):
        toks = line.split()
        if not toks:
            continue
        ln = start + off + 1
        if len(toks) != n_channels:
            raise BvhError(path, ln, f"{len(toks)} values on a motion line; expected {n_channels} (one per channel)")
        for c, tok in enumerate(toks):
            try:
                _strict_float(tok)
            except ValueError:
                raise BvhError(path, ln, f"value {c + 1} {_q(tok)} is not a number") from None


# --- building the data model ----------------------------------------------------------------
def _build_skeleton(nodes: list[_Node], path: str, scale: float | None, up: str) -> Skeleton:
    index: dict[int, int] = {}
    names: list[str] = []
    parents: list[int] = []
    offsets: list[np.ndarray] = []
    channels: list[tuple[str, ...]] = []
    end_parents: list[int] = []
    end_offsets: list[np.ndarray] = []
    for i, n in enumerate(nodes):
        off = n.offset if n.offset is not None else np.zeros(3)
        if n.is_end:
            end_parents.append(index[n.parent])
            end_offsets.append(off)
            continue
        index[i] = len(names)
        names.append(n.name)
        parents.append(index[n.parent] if n.parent >= 0 else -1)
        offsets.append(off)
        channels.append(n.channels or ())
    c = up_matrix(up)
    offs = np.asarray(offsets)
    ends = np.asarray(end_offsets).reshape(-1, 3)
    # Before unit detection, which would only say it cannot tell the unit: with no scale given,
    # the limit in file units is the one for millimetres, the smallest unit detected.
    unit = MM if scale is None or not (np.isfinite(scale) and scale > 0) else scale
    for n in nodes:
        if n.offset is not None and np.abs(n.offset).max() * unit > MAX_COORD_M:
            where = f"the End Site of {_q(n.name[:-4])}" if n.is_end else _q(n.name)
            raise BvhError(
                path, n.offset_line, f"OFFSET of {where} is {np.abs(n.offset).max():g} file units, beyond the ±{MAX_COORD_M:g} m a skeleton may span"
            )
    if scale is None:
        file_skel = Skeleton(tuple(names), np.asarray(parents), offs, tuple(channels), np.asarray(end_parents, dtype=int), ends)
        try:
            scale = detect_scale(file_skel.height())
        except MjmotionError as e:
            raise BvhError(path, None, str(e)) from None
    elif not (np.isfinite(scale) and scale > 0):
        raise BvhError(path, None, f"scale must be a positive number of metres per unit, got {scale}")
    return Skeleton(
        tuple(names),
        np.asarray(parents),
        offs @ c.T * scale,
        tuple(channels),
        np.asarray(end_parents, dtype=int),
        ends @ c.T * scale,
        scale=float(scale),
        up=up,
    )


def _rotation_axes(channels: tuple[str, ...]) -> str:
    return "".join(c[0] for c in channels if c in ROTATION_CHANNELS)


#: Frames converted per block: bounds the temporaries of long clips to a few MB.
_BLOCK = 8192


def _to_motion(skel: Skeleton, values: np.ndarray, fps: float, path: str, kernels=None) -> Motion:
    """The motion of ``values: (T, C)`` (file units, degrees) on ``skel``; ``kernels`` is
    ``mjmotion._fast`` for the compiled rotation kernel, ``None`` for NumPy (identical floats)."""
    t = values.shape[0]
    j_count = skel.n_joints
    c = up_matrix(skel.up)
    # The axis change is a permutation: world component i is file component perm[i], so for a
    # quaternion R_world = C R_file Cᵀ is (w, v) → (w, C v) = (w, v[perm]) — no arithmetic.
    perm = np.argmax(c, axis=1)
    file_offsets = skel.offsets @ c / skel.scale  # back to file axes and units (C is orthonormal)
    inner_pos = any(skel.has_positions(j) for j in range(1, j_count))
    pos_joints = range(j_count) if inner_pos else range(1)
    local_file = np.empty((t, len(pos_joints), 3))  # only the root's unless inner joints move
    local_file[:] = file_offsets[: len(pos_joints)]
    rot_cols = np.full((j_count, 3), -1, dtype=np.int64)
    rot_axes = np.full((j_count, 3), -1, dtype=np.int64)
    col = 0
    for j, chans in enumerate(skel.channels):
        r = 0
        for ch in chans:
            if ch in POSITION_CHANNELS:
                local_file[:, j, "XYZ".index(ch[0])] += values[:, col]
            else:
                rot_cols[j, r] = col
                rot_axes[j, r] = "XYZ".index(ch[0])
                r += 1
            col += 1
    quats = np.empty((t, j_count, 4))
    if kernels is not None:
        kernels.euler_quats(np.ascontiguousarray(values), rot_cols, rot_axes, perm.astype(np.int64), quats)
    else:
        _euler_quats_numpy(values, skel, rot_cols, perm, quats)
    local = local_file[..., perm]
    local *= skel.scale
    return Motion(
        skeleton=skel,
        fps=fps,
        root_positions=local[:, 0].copy(),
        rotations=quats,
        translations=local if inner_pos else None,
    )


def _euler_quats_numpy(values: np.ndarray, skel: Skeleton, rot_cols: np.ndarray, perm: np.ndarray, quats: np.ndarray) -> None:
    """NumPy twin of ``_fast.euler_quats``: joints grouped by channel order, converted per block."""
    t = values.shape[0]
    groups: dict[str, list[int]] = {}
    for j, chans in enumerate(skel.channels):
        groups.setdefault(_rotation_axes(chans), []).append(j)
    for axes, js in groups.items():
        if not axes:
            quats[:, js] = rot.IDENTITY
            continue
        cols = rot_cols[js, : len(axes)]  # (n, k)
        for a in range(0, t, _BLOCK):
            b = min(t, a + _BLOCK)
            ang = values[a:b, cols].reshape(-1, len(axes))  # (block*n, k)
            q = rot.euler_to_quat(ang, axes).reshape(b - a, len(js), 4)
            quats[a:b, js, 0] = q[..., 0]
            quats[a:b, js, 1:] = q[..., 1 + perm]


# --- writing -------------------------------------------------------------------------------
def format_motion(motion: Motion) -> str:
    """BVH text for ``motion`` in its skeleton's file units and axes.

    Each joint keeps its channel order. Where a joint's motion cannot be expressed by its
    channels (a rotation about an axis it has no channel for, or a translation of a joint
    without position channels), the missing channels are appended to that joint so nothing is
    lost.
    """
    if not isinstance(motion, Motion):
        raise MjmotionError(f"expected a Motion to write, got {type(motion).__name__}")
    skel = motion.skeleton
    # (a Motion's values are finite: skeleton.Motion checks them) What the reader would refuse is not written.
    if not MIN_FPS <= motion.fps <= MAX_FPS:
        raise MjmotionError(f"motion {motion.name!r}: {motion.fps:g} fps; a BVH file holds {MIN_FPS:g} to {MAX_FPS:g} frames per second")
    far = np.abs(motion.local_translations()).max() if motion.n_frames else 0.0
    if far > MAX_COORD_M:
        raise MjmotionError(f"motion {motion.name!r}: a position {far:g} m from the origin; a BVH file holds positions within ±{MAX_COORD_M:g} m")
    c = up_matrix(skel.up)
    q_c = rot.from_matrix(c)
    t = motion.n_frames
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is refused below, not warned about
        file_offsets = skel.offsets @ c / skel.scale
        file_ends = skel.end_offsets @ c / skel.scale
        local_file = motion.local_translations() @ c / skel.scale  # (T, J, 3)
        disps = local_file - file_offsets
    if not (np.isfinite(file_offsets).all() and np.isfinite(file_ends).all() and np.isfinite(disps).all()):
        # e.g. a position of 1e306 m written in units of 1e-5 m: the file would hold 'inf'
        raise MjmotionError(f"motion is not finite in the file's units ({skel.scale:g} m per unit); refusing to write it")
    q_file = rot.multiply(rot.multiply(rot.conjugate(q_c), motion.rotations), q_c)
    columns: list[np.ndarray] = []
    # Decimals per column: 6 for degrees; positions fine enough for 5 nm in metres (≥ 6).
    pos_decimals = max(6, int(np.ceil(8 + np.log10(skel.scale))))
    decimals: list[int] = []
    channels_out: list[tuple[str, ...]] = []
    for j, file_chans in enumerate(skel.channels):
        chans = list(file_chans)
        disp = disps[:, j]
        pos_axes = [ch[0] for ch in chans if ch in POSITION_CHANNELS]
        missing_pos = [a for a in "XYZ" if a not in pos_axes]
        if missing_pos and np.max(np.abs(disp[:, ["XYZ".index(a) for a in missing_pos]]), initial=0.0) > _WIDEN_TOL:
            chans = [f"{a}position" for a in missing_pos] + chans
        rot_axes = _rotation_axes(tuple(chans))
        euler: dict[str, np.ndarray] = {}
        if rot_axes or not np.allclose(rot.angle_between(q_file[:, j], rot.IDENTITY), 0.0, atol=1e-9):
            full = rot_axes + "".join(a for a in "XYZ" if a not in rot_axes)
            ang = rot.quat_to_euler(q_file[:, j], full)
            extra = ang[:, len(rot_axes) :]
            if extra.size and np.max(np.abs(_wrap_degrees(extra))) > _WIDEN_TOL:
                chans = chans + [f"{a}rotation" for a in full[len(rot_axes) :]]
                rot_axes = full
            euler = {a: ang[:, i] for i, a in enumerate(full)}
        for ch in chans:
            if ch in POSITION_CHANNELS:
                columns.append(disp[:, "XYZ".index(ch[0])])
                decimals.append(pos_decimals)
            else:
                columns.append(euler[ch[0]])
                decimals.append(6)
        channels_out.append(tuple(chans))
    out = io.StringIO()
    out.write("HIERARCHY\n")
    _write_hierarchy(out, skel, channels_out, file_offsets, file_ends)
    out.write("MOTION\n")
    out.write(f"Frames: {t}\n")
    out.write(f"Frame Time: {frame_time_text(motion.fps)}\n")
    if columns:
        data = np.column_stack(columns)
        dec = np.array(decimals)
        data = np.where(np.abs(data) < 0.5 * 10.0 ** (-dec), 0.0, data)  # no "-0.000000"
        np.savetxt(out, data, fmt=[f"%.{d}f" for d in decimals], delimiter=" ")
    else:
        out.write("\n" * t)
    return out.getvalue()


def frame_time_text(fps: float) -> str:
    """The shortest frame time (≥ 6 significant digits) whose reciprocal is ``fps``, else ``1/fps`` in full (:func:`rate_of`
    reads either back as ``fps``)."""
    fps = float(fps)  # (a NumPy scalar's repr is not a number a reader takes)
    ft = 1.0 / fps
    for digits in range(6, 18):
        text = f"{ft:.{digits}g}"
        if 1.0 / float(text) == fps:
            return text
    return repr(ft)  # no frame time inverts to fps (29.97): rate_of finds fps again from this one


def rate_of(frame_time: float) -> float:
    """The frame rate of a file's frame time: the shortest rate whose
    :func:`frame_time_text` is this frame time, else ``1 / frame_time``. A rate with no frame time that
    inverts to it exactly (29.97: 1 / (1/29.97) = 29.969999999999995) still reads back as written."""
    raw = 1.0 / frame_time
    for digits in range(6, 18):
        c = float(f"{raw:.{digits}g}")
        if float(frame_time_text(c)) == frame_time:
            return c
    return raw


def _wrap_degrees(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


#: Deepest indentation written (tabs); whitespace means nothing to a BVH reader.
_MAX_INDENT = 32


def _write_hierarchy(
    out: io.StringIO,
    skel: Skeleton,
    channels: list[tuple[str, ...]],
    offsets: np.ndarray,
    ends: np.ndarray,
) -> None:
    children: list[list[int]] = [[] for _ in range(skel.n_joints)]
    for j in range(1, skel.n_joints):
        children[int(skel.parents[j])].append(j)
    end_of: list[list[int]] = [[] for _ in range(skel.n_joints)]
    for e, p in enumerate(skel.end_parents):
        end_of[int(p)].append(e)

    def fmt(v: np.ndarray) -> str:
        return " ".join(f"{0.0 if abs(x) < 1e-12 else x:.10g}" for x in v)

    # Iterative depth-first walk (deep hierarchies would overflow recursion); the indentation
    # stops growing at _MAX_INDENT levels, or a deep chain's file grows with its depth squared.
    stack: list[tuple[str, int, int]] = [("open", 0, 0)]
    while stack:
        kind, j, depth = stack.pop()
        ind = "\t" * min(depth, _MAX_INDENT)
        if kind == "close":
            out.write(f"{ind}}}\n")
            continue
        if kind == "end":
            out.write(f"{ind}End Site\n{ind}{{\n{ind}\tOFFSET {fmt(ends[j])}\n{ind}}}\n")
            continue
        word = "ROOT" if j == 0 else "JOINT"
        out.write(f"{ind}{word} {skel.names[j]}\n{ind}{{\n")
        out.write(f"{ind}\tOFFSET {fmt(offsets[j])}\n")
        out.write(f"{ind}\tCHANNELS {len(channels[j])}{''.join(' ' + c for c in channels[j])}\n")
        stack.append(("close", j, depth))
        for e in reversed(end_of[j]):
            stack.append(("end", e, depth + 1))
        for c in reversed(children[j]):
            stack.append(("open", c, depth + 1))


def write(motion: Motion, path: str | os.PathLike[str]) -> None:
    """Write ``motion`` as BVH to ``path`` (atomically: a temporary file renamed into place). An existing
    file at ``path`` is replaced, as ``os.replace`` would (never a folder, FIFO or device:
    :mod:`mjmotion.outputs`); the verbs refuse that without ``--force``."""
    from .outputs import write_text_atomic

    write_text_atomic(path, format_motion(motion))
