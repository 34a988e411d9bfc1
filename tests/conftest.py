"""Shared fixtures: the real-mocap directory (``MJMOTION_DATA``) and small random skeletons."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from mjmotion import rotations as rot
from mjmotion.skeleton import Motion, Skeleton

REPO = Path(__file__).resolve().parents[1]


def data_dir() -> Path | None:
    """The real mocap directory: ``MJMOTION_DATA``, else ``../shared/mocap`` beside the repo."""
    env = os.environ.get("MJMOTION_DATA")
    cand = Path(env) if env else REPO.parent / "shared" / "mocap"
    return cand if cand.is_dir() else None


@pytest.fixture
def ctrl_c() -> Iterator[None]:
    """Python's own Ctrl-C handler in place for the test, as in a terminal. A test run started in the
    background of a shell script (`pytest &`) inherits SIGINT ignored, and Python then keeps it ignored:
    the tests that send themselves a Ctrl-C failed with "DID NOT RAISE KeyboardInterrupt"."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def require_data() -> Path:
    """The data directory, or skip (fail when ``MJMOTION_REQUIRE_DATA=1``, as in CI)."""
    d = data_dir()
    if d is None:
        msg = "real mocap not found: set MJMOTION_DATA to the shared/mocap directory"
        if os.environ.get("MJMOTION_REQUIRE_DATA") == "1":
            pytest.fail(msg)
        pytest.skip(msg)
    return d


def all_clips() -> list[Path]:
    d = data_dir()
    return sorted(d.glob("*/*.bvh")) if d else []


@pytest.fixture
def mocap() -> Path:
    """Path of the real mocap directory (skips or fails per ``MJMOTION_REQUIRE_DATA``)."""
    return require_data()


def clip_params():
    """``pytest.mark.parametrize`` values over every shared clip (one 'missing' case if none)."""
    clips = all_clips()
    if not clips:
        return [pytest.param(None, id="no-data")]
    return [pytest.param(c, id=f"{c.parent.name}/{c.stem}") for c in clips]


def random_skeleton(rng: np.random.Generator, n_joints: int = 12, inner_positions: bool = True) -> Skeleton:
    """A random tree in depth-first order (as BVH files are), random channel orders per joint,
    some inner joints with 6 channels."""
    parents = [-1]
    path = [0]
    for j in range(1, n_joints):
        depth = int(rng.integers(0, len(path)))
        parents.append(path[depth])
        path = path[: depth + 1] + [j]
    offsets = rng.normal(0.0, 0.15, (n_joints, 3))
    offsets[0] = [0.0, 0.0, 0.9]
    channels = []
    for j in range(n_joints):
        rots = [f"{a}rotation" for a in rng.permutation(list("XYZ"))]
        pos = [f"{a}position" for a in rng.permutation(list("XYZ"))]
        if j == 0 or (inner_positions and rng.random() < 0.25):
            chans = pos + rots if rng.random() < 0.7 else rots + pos
        else:
            chans = rots
        channels.append(tuple(chans))
    leaves = [j for j in range(n_joints) if j not in parents]
    return Skeleton(
        names=tuple(f"j{j}" for j in range(n_joints)),
        parents=np.array(parents),
        offsets=offsets,
        channels=tuple(channels),
        end_parents=np.array(leaves),
        end_offsets=rng.normal(0.0, 0.1, (len(leaves), 3)),
        scale=1.0,
        up="z",
    )


def random_motion(rng: np.random.Generator, skeleton: Skeleton, n_frames: int = 20) -> Motion:
    j = skeleton.n_joints
    q = rot.normalize(rng.normal(size=(n_frames, j, 4)))
    root = rng.normal(0.0, 0.3, (n_frames, 3)) + [0.0, 0.0, 1.0]
    tr = None
    if any(skeleton.has_positions(k) for k in range(1, j)):
        tr = np.broadcast_to(skeleton.offsets, (n_frames, j, 3)).copy()
        for k in range(1, j):
            if skeleton.has_positions(k):
                tr[:, k] += rng.normal(0.0, 0.05, (n_frames, 3))
    return Motion(skeleton, 60.0, root, q, tr, name="random")


def linear_blend(a: Motion, b: Motion, w: float = 0.5) -> Motion:
    """A test-side frame-by-frame blend on ``a``'s skeleton (averaged roots and quaternions, no
    alignment): the sliding baseline the footskate metrics and cleanup are checked against."""
    n = min(a.n_frames, b.n_frames)
    a, b = a[:n], b[:n]
    qb = np.where((np.sum(a.rotations * b.rotations, axis=-1) < 0)[..., None], -b.rotations, b.rotations)
    q = rot.normalize((1 - w) * a.rotations + w * qb)
    return a.replace(root_positions=(1 - w) * a.root_positions + w * b.root_positions, rotations=q, name="blend")


def shared_clip(rel: str, start: int = 0) -> Motion:
    """A shared clip by its path under the data directory, from frame ``start``."""
    from mjmotion import bvh

    return bvh.read(require_data() / rel)[start:]


@contextlib.contextmanager
def within(seconds: int, what: str) -> Iterator[None]:
    """Fail (not hang) if the block runs longer than ``seconds`` (SIGALRM: the main thread only)."""

    def alarm(signum, frame):
        raise AssertionError(f"{what} took more than {seconds} s: a hang")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def error_without_blocking(fifo: Path, read: Callable[[Path], object], error: type[BaseException]) -> BaseException:
    """The ``error`` that ``read(fifo)`` raises; fails (after unblocking it) if opening the FIFO blocks."""
    result: list[BaseException] = []
    reader = threading.Thread(target=lambda: result.append(pytest.raises(error, read, fifo).value))
    reader.start()
    reader.join(timeout=10)
    if reader.is_alive():  # unblock the reader before failing, or the test run would hang
        with open(fifo, "wb"):
            pass
        reader.join()
        pytest.fail(f"reading the FIFO {fifo} blocked")
    return result[0]
