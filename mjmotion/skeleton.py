"""The data model: :class:`Skeleton` and :class:`Motion`.

Conventions (the README's "Conventions"): metres, seconds, MuJoCo's Z-up world, unit
quaternions ``(w, x, y, z)``. The axis change and unit scale from the file happen once, at
the BVH boundary, and are remembered here (``Skeleton.scale``, ``Skeleton.up``) so that a
written BVH is back in the file's own units and axes.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import rotations as rot
from .caps import MAX_FPS, MIN_FPS, check_motion_size
from .errors import MjmotionError, SkeletonMismatchError

#: Known metres-per-unit scales, detected from a skeleton's rest extent (see ``detect_scale``).
CM = 0.01
METRE = 1.0
ASF_UNIT = 0.0254 / 0.45  # CMU's ASF length unit: 1/0.45 inch = 5.6444 cm
MM = 0.001

#: Channel names the BVH format defines.
POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")


def up_matrix(up: str) -> np.ndarray:
    """Rotation ``(3, 3)`` from a file's axes (``up`` = ``"y"`` or ``"z"``) to the Z-up world.

    Y-up files map cyclically, ``(x, y, z) → (z, x, y)``: up stays up and a character facing
    the file's +Z faces MuJoCo's +X.
    """
    if up == "y":
        return np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    if up == "z":
        return np.eye(3)
    raise MjmotionError(f"up axis must be 'y' or 'z', got {up!r}")


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy in the Z-up world, metres.

    Attributes:
        names: joint names ``(J,)``, unique, in file order.
        parents: ``(J,) int``; ``parents[0] == -1`` (the root) and ``parents[j] < j``.
        offsets: ``(J, 3)`` metres; each joint's rest translation from its parent (root: its
            own rest position).
        channels: per joint, the BVH channel names in file order (``"Zrotation"``, …).
        end_parents: ``(E,) int``, the joint each End Site hangs from.
        end_offsets: ``(E, 3)`` metres, End Site offsets (zero-length ones kept).
        scale: metres per file unit (``0.01`` for centimetres).
        up: the file's up axis, ``"y"`` or ``"z"``.

    The arrays are read-only copies: clips and the results made from them share a skeleton, so edit a
    copy (``skeleton.offsets.copy()``) and make a new one with ``dataclasses.replace``.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_parents: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    end_offsets: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    scale: float = 1.0
    up: str = "z"

    def __post_init__(self) -> None:
        parents = np.asarray(self.parents, dtype=int)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", np.asarray(self.offsets, dtype=float).reshape(-1, 3))
        object.__setattr__(self, "end_parents", np.asarray(self.end_parents, dtype=int).reshape(-1))
        object.__setattr__(self, "end_offsets", np.asarray(self.end_offsets, dtype=float).reshape(-1, 3))
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "channels", tuple(tuple(c) for c in self.channels))
        n = len(self.names)
        if n == 0:
            raise MjmotionError("a skeleton needs at least one joint")
        if parents.shape != (n,) or self.offsets.shape != (n, 3) or len(self.channels) != n:
            raise MjmotionError("skeleton arrays disagree on the number of joints")
        if parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, n)):
            raise MjmotionError("skeleton parents must be topologically ordered with one root first")
        if len(set(self.names)) != n:
            dup = sorted({x for x in self.names if self.names.count(x) > 1})
            raise MjmotionError(f"duplicate joint names: {', '.join(dup)}")
        # Read-only copies (small): clips and results share their skeleton, so an edit in place of one
        # clip's offsets changed a blend made from it earlier. Edit a copy and make a new skeleton.
        for key in ("parents", "offsets", "end_parents", "end_offsets"):
            a = np.array(getattr(self, key))
            a.flags.writeable = False
            object.__setattr__(self, key, a)

    def __repr__(self) -> str:
        """``Skeleton(31 joints, root 'root', 7 End Sites, 0.01 m per file unit, up y)``: no arrays."""
        return f"Skeleton({self.n_joints} joints, root {self.names[0]!r}, {len(self.end_parents)} End Sites, {self.scale:.6g} m per file unit, up {self.up})"

    # --- structure -------------------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        return len(self.names)

    @property
    def n_channels(self) -> int:
        return sum(len(c) for c in self.channels)

    def index(self, name: str) -> int:
        """Index of the joint called ``name``; a clear error lists near matches if absent."""
        try:
            return self.names.index(name)
        except ValueError:
            close = [n for n in self.names if name.lower() in n.lower()][:5]
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise MjmotionError(f"no joint named {name!r} in the skeleton{hint}") from None

    def children(self, j: int) -> list[int]:
        return [int(c) for c in np.flatnonzero(self.parents == j)]

    def has_positions(self, j: int) -> bool:
        """Whether joint ``j`` carries position channels (its translation varies per frame)."""
        return any(c in POSITION_CHANNELS for c in self.channels[j])

    def chain(self, start: int, end: int) -> list[int]:
        """Joint indices from ``start`` down to its descendant ``end`` inclusive."""
        path = [end]
        while path[-1] != start:
            p = int(self.parents[path[-1]])
            if p < 0:
                raise MjmotionError(f"{self.names[end]!r} is not below {self.names[start]!r}")
            path.append(p)
        return path[::-1]

    def same_topology(self, other: Skeleton) -> bool:
        """Same joint count, names and parents (bone lengths may differ)."""
        return self.names == other.names and np.array_equal(self.parents, other.parents)

    def require_same_topology(self, other: Skeleton, what: str = "clips") -> None:
        if not self.same_topology(other):
            if self.n_joints != other.n_joints:
                diff = f"{self.n_joints} joints vs {other.n_joints}"
            else:
                k = next(i for i in range(self.n_joints) if self.names[i] != other.names[i] or self.parents[i] != other.parents[i])
                diff = f"joint {k} is {self.names[k]!r} vs {other.names[k]!r}"
            raise SkeletonMismatchError(f"{what} have different skeleton topologies ({diff}); they cannot be combined")

    # --- rest pose -------------------------------------------------------------------------
    def rest_positions(self) -> np.ndarray:
        """World positions ``(J, 3)`` with every rotation at identity (the rest pose)."""
        pos = np.zeros((self.n_joints, 3))
        for j in range(self.n_joints):
            p = self.parents[j]
            pos[j] = self.offsets[j] + (pos[p] if p >= 0 else 0.0)
        return pos

    def rest_end_positions(self) -> np.ndarray:
        """World positions ``(E, 3)`` of the End Sites in the rest pose."""
        return self.rest_positions()[self.end_parents] + self.end_offsets

    def height(self) -> float:
        """Largest extent of the rest pose in metres (≈ stature or arm span for a T-pose)."""
        pts = np.vstack([self.rest_positions(), self.rest_end_positions()])
        return float(np.max(np.ptp(pts, axis=0)))

    def stature(self) -> float:
        """Standing height estimate in metres: head top to toe tip along the bones.

        The path runs through the lowest common ancestor of head and foot, so a separate
        "bone root" above the pelvis does not count. Falls back to :meth:`height` when no head
        or foot is found by name.
        """
        feet = self.feet()
        head = self.head()
        if head is None or not feet:
            return self.height()
        lengths = np.linalg.norm(self.offsets, axis=1)
        ankle, toe = next(iter(feet.values()))

        def tip_len(j: int) -> float:
            ends = np.flatnonzero(self.end_parents == j)
            return float(np.linalg.norm(self.end_offsets[ends[0]])) if len(ends) else 0.0

        def ancestors(j: int) -> list[int]:
            out = [j]
            while self.parents[out[-1]] >= 0:
                out.append(int(self.parents[out[-1]]))
            return out

        foot_tip = toe if toe is not None else ankle
        up_path, down_path = ancestors(head), ancestors(foot_tip)
        common = next(j for j in up_path if j in down_path)
        total = sum(lengths[j] for j in up_path[: up_path.index(common)])
        total += sum(lengths[j] for j in down_path[: down_path.index(common)])
        return float(total + tip_len(head) + 0.5 * tip_len(foot_tip))

    # --- named parts -----------------------------------------------------------------------
    def head(self) -> int | None:
        """The first joint named like a head (not an end bone such as iClone's ``HeadEnd``), or None."""
        return next((j for j, n in enumerate(self.names) if "head" in n.lower() and "end" not in n.lower()), None)

    def feet(self) -> dict[str, tuple[int, int | None]]:
        """``{"left": (ankle, toe or None), "right": (…)}`` found by name.

        Recognises CMU ASF (``lfoot``/``ltoes``), cgspeed (``LeftAnkle``/``LeftToe``,
        ``lFoot``), iClone (``CC_Base_L_Foot``/``CC_Base_L_ToeBase``) and the bundled
        skeleton (``LeftFoot``/``LeftToe``).
        """
        out: dict[str, tuple[int, int | None]] = {}
        for side in ("left", "right"):
            ankle = self._find_side(side, ("foot", "ankle"))
            if ankle is None:
                continue
            toe = None
            for c in self.descendants(ankle):
                name = self.names[c]
                # Helper bones (iClone's "ShareBone", twist bones) are not the toe.
                if re.search("toe|ball", name, re.IGNORECASE) and not re.search("share|twist", name, re.IGNORECASE):
                    toe = c
                    break
            out[side] = (ankle, toe)
        return out

    def hands(self) -> dict[str, int]:
        """``{"left": j, "right": j}``: the first joint of each hand segment, found by name.

        A joint named like a wrist wins over one named like a hand (CMU's ``lwrist`` over
        ``lhand``), so everything from it down is the hand; :func:`mjmotion.hitpoint.hand_joints`
        picks the joint that holds a club instead.
        """
        out: dict[str, int] = {}
        for side in ("left", "right"):
            j = self._find_side(side, ("wrist", "hand"))
            if j is not None:
                out[side] = j
        return out

    def descendants(self, j: int) -> list[int]:
        """Every joint below ``j`` (children, their children, …), in index order."""
        inside = {j}
        out = []
        for c in range(j + 1, self.n_joints):
            if int(self.parents[c]) in inside:
                inside.add(c)
                out.append(c)
        return out

    def _find_side(self, side: str, words: tuple[str, ...]) -> int | None:
        for word in words:
            for j, name in enumerate(self.names):
                if word in name.lower() and side_of(name) == side:
                    return j
        return None

    def replace_scale(self, scale: float) -> Skeleton:
        """The same skeleton written with ``scale`` metres per file unit (lengths in metres unchanged)."""
        if not (np.isfinite(scale) and scale > 0):
            raise MjmotionError(f"scale must be a positive number of metres per unit, got {scale}")
        return dataclasses.replace(self, scale=float(scale))

    def with_offsets(self, offsets: np.ndarray) -> Skeleton:
        return dataclasses.replace(self, offsets=np.asarray(offsets, dtype=float))


_PARTS = (
    "hip|femur|tibia|foot|toe|clavicle|humerus|radius|wrist|hand|finger|thumb|shldr|shoulder|forearm|"
    "arm|thigh|shin|leg|collar|knee|ankle|elbow|eye|index|mid|ring|pinky|buttock|upleg|ear|ball|up|low"
)
_SIDE_PATTERNS = {
    side: (
        re.compile(rf"{word}", re.IGNORECASE),
        re.compile(rf"(^|[_:.\s]){letter}([_:.\s]|$)", re.IGNORECASE),
        re.compile(rf"^{letter}_?({_PARTS})", re.IGNORECASE),
    )
    for side, word, letter in (("left", "left", "l"), ("right", "right", "r"))
}


def side_of(name: str) -> str | None:
    """``"left"``, ``"right"`` or ``None`` from a joint name.

    Understands ``LeftHand``, ``lhand``, ``lHand``, ``CC_Base_L_Hand``, ``l_hand``; a leading
    ``l``/``r`` counts only before a body-part word (so ``lowerback`` and ``root`` have no side).
    """
    for side, pats in _SIDE_PATTERNS.items():
        if pats[0].search(name) or pats[1].search(name):
            return side
    for side, pats in _SIDE_PATTERNS.items():
        if pats[2].match(name) and not re.match(r"^lower|^root|^ribs?", name, re.IGNORECASE):
            return side
    return None


def detect_scale(extent: float) -> float:
    """Metres per file unit from a skeleton's rest extent in file units (a human is 1.2–2.2 m).

    Ranges: metres 0.4–3; CMU ASF units 8–45; centimetres 45–300; millimetres 400–3000.
    """
    for lo, hi, s in ((0.4, 3.0, METRE), (8.0, 45.0, ASF_UNIT), (45.0, 300.0, CM), (400.0, 3000.0, MM)):
        if lo <= extent <= hi:
            return s
    raise MjmotionError(
        f"cannot tell the unit of a skeleton {extent:g} units across; give it with --units "
        "(m, cm, mm, asf, or metres per file unit, e.g. --units cm; scale= in mjmotion.read)"
    )


#: Relative difference under which two frame rates are one: a BVH keeps its Frame Time to a few digits
#: (cgspeed's ``.0083333`` is 120.0005 fps, iClone's ``0.016667`` 59.9988, ours 10 digits), so a clip
#: resampled to its source's rate reads a few millionths off it. 1e-4 drifts a tenth of a frame in 1,000.
RATE_TOLERANCE = 1e-4


def same_rate(a: float, b: float) -> bool:
    """Whether frame rates ``a`` and ``b`` (frames per second) are the same rate as files write it."""
    return abs(a - b) <= RATE_TOLERANCE * max(abs(a), abs(b))


#: How far from 1 a rotation quaternion's norm may be before a motion normalises it (operations write them to ~1e-15).
UNIT_TOLERANCE = 1e-6
#: A quaternion shorter than this is no rotation.
ZERO_QUATERNION = 1e-6


@dataclass(frozen=True, eq=False)
class Motion:
    """A clip: a skeleton animated over ``T`` frames.

    Attributes:
        skeleton: the :class:`Skeleton`.
        fps: frames per second.
        root_positions: ``(T, 3)`` metres, world position of the root joint.
        rotations: ``(T, J, 4)`` unit quaternions wxyz, each joint's rotation relative to its
            parent (the root's is its world orientation).
        translations: ``(T, J, 3)`` metres or ``None``; per-frame local translations for skeletons
            whose inner joints carry position channels (offset plus channel values). Row 0 is
            unused (the root's position is ``root_positions``). ``None`` means every joint sits
            at its offset.
        name: a label (the file stem for loaded clips).

    Values are checked when a motion is made (finite, no zero quaternion, at least one frame; an
    :class:`~mjmotion.errors.MjmotionError` names the frame and joint otherwise), and its arrays
    are read-only: results may share them with their inputs, so edit a copy (``m.rotations.copy()``)
    and make a new motion with :meth:`replace`.
    """

    skeleton: Skeleton
    fps: float
    root_positions: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray | None = None
    name: str = ""

    def __post_init__(self) -> None:
        rp = np.asarray(self.root_positions, dtype=float)
        q = np.asarray(self.rotations, dtype=float)
        object.__setattr__(self, "root_positions", rp)
        object.__setattr__(self, "rotations", q)
        t = q.shape[0] if q.ndim == 3 else -1
        if rp.shape != (t, 3) or q.shape != (t, self.skeleton.n_joints, 4):
            raise MjmotionError(
                f"motion arrays have shapes root {rp.shape}, rotations {q.shape}; expected (T, 3) and (T, {self.skeleton.n_joints}, 4)"
            )
        if self.translations is not None:
            tr = np.asarray(self.translations, dtype=float)
            if tr.shape != (t, self.skeleton.n_joints, 3):
                raise MjmotionError(f"translations have shape {tr.shape}, expected {(t, self.skeleton.n_joints, 3)}")
            object.__setattr__(self, "translations", tr)
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise MjmotionError(f"fps must be a positive number, got {self.fps}")
        object.__setattr__(self, "fps", float(self.fps))  # (a NumPy scalar would print as np.float64(…) in a file)
        if t < 1:
            raise MjmotionError("a motion needs at least one frame")
        self._check_values()
        # Read-only views: an operation's result may share arrays with its input (a blend with weight 1, an
        # adapted shot's untouched root), so writing into one must not silently change the other.
        for key in ("root_positions", "rotations", "translations"):
            a = getattr(self, key)
            if a is not None and a.flags.writeable:
                v = a.view()
                v.flags.writeable = False
                object.__setattr__(self, key, v)

    def _check_values(self) -> None:
        """Refuse a non-finite value or a zero quaternion, naming its frame and joint (a NaN would otherwise flow
        into every metric as ``nan``, or into a solver's raw traceback); normalise quaternions of other lengths."""
        names = self.skeleton.names
        for key, a in (("root_positions", self.root_positions), ("rotations", self.rotations), ("translations", self.translations)):
            if a is None:
                continue
            bad = ~np.isfinite(a)
            if bad.any():
                where = np.argwhere(bad)[0]
                joint = f", joint {names[where[1]]!r}" if a.ndim == 3 else ""
                raise MjmotionError(f"motion {self.name!r}: {key} at frame {where[0]}{joint} is {a[tuple(where)]}; expected finite numbers")
        norms = np.sqrt(np.einsum("tjk,tjk->tj", self.rotations, self.rotations))
        zero = norms < ZERO_QUATERNION
        if zero.any():
            f, j = np.argwhere(zero)[0]
            raise MjmotionError(
                f"motion {self.name!r}: the rotation at frame {f}, joint {names[j]!r} is a zero quaternion; expected a rotation (wxyz)"
            )
        if (np.abs(norms - 1.0) > UNIT_TOLERANCE).any():  # scaled quaternions stand for their rotation: stored as unit ones
            object.__setattr__(self, "rotations", self.rotations / norms[..., None])

    def __repr__(self) -> str:
        """``Motion('walk', 22 joints, 241 frames at 60 fps, 4 s)``: what the clip is, not its arrays."""
        from .summary import clip

        return clip("Motion", self.name, self.skeleton.n_joints, self.n_frames, self.fps)

    @property
    def n_frames(self) -> int:
        return int(self.rotations.shape[0])

    @property
    def duration(self) -> float:
        """Seconds from the first frame to the last."""
        return (self.n_frames - 1) / self.fps

    @property
    def times(self) -> np.ndarray:
        """``(T,)`` seconds of each frame."""
        return np.arange(self.n_frames) / self.fps

    def local_translations(self) -> np.ndarray:
        """``(T, J, 3)`` local translation of every joint, the root's being its world position."""
        if self.translations is None:
            out = np.broadcast_to(self.skeleton.offsets, (self.n_frames, self.skeleton.n_joints, 3)).copy()
        else:
            out = self.translations.copy()
        out[:, 0] = self.root_positions
        return out

    def replace(self, **changes: Any) -> Motion:
        """A new motion with some fields changed; the others share this one's (read-only) arrays."""
        return dataclasses.replace(self, **changes)

    def __getitem__(self, key: slice) -> Motion:
        """Frames ``key`` (a slice) as a new motion."""
        if not isinstance(key, slice):
            raise TypeError("index a Motion with a slice of frames")
        sl = self.rotations[key]
        if sl.shape[0] == 0:
            raise MjmotionError(f"frame range {key.start}:{key.stop} of a {self.n_frames}-frame clip is empty")
        step = key.step or 1
        return self.replace(
            root_positions=self.root_positions[key].copy(),
            rotations=sl.copy(),
            translations=None if self.translations is None else self.translations[key].copy(),
            fps=self.fps / abs(step),
        )

    def sample(self, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Pose at fractional frame indices ``frames: (N,)`` (clamped to the clip).

        Returns ``(root_positions (N, 3), rotations (N, J, 4), translations (N, J, 3) | None)``:
        linear interpolation of positions, slerp of rotations.
        """
        f = np.asarray(frames, dtype=float)
        if f.ndim != 1 or not np.isfinite(f).all():
            raise MjmotionError(f"sample: expected a list of finite frame numbers, got shape {f.shape}" + ("" if f.ndim != 1 else " with NaN or inf"))
        f = np.clip(f, 0.0, self.n_frames - 1)
        i0 = np.floor(f).astype(int)
        i1 = np.minimum(i0 + 1, self.n_frames - 1)
        a = (f - i0)[:, None]
        root = self.root_positions[i0] * (1 - a) + self.root_positions[i1] * a
        q = rot.slerp(self.rotations[i0], self.rotations[i1], np.broadcast_to(a, (len(f), self.skeleton.n_joints)))
        tr = None
        if self.translations is not None:
            tr = self.translations[i0] * (1 - a[:, :, None]) + self.translations[i1] * a[:, :, None]
        return root, q, tr

    def resample(self, fps: float) -> Motion:
        """The same motion at another frame rate (slerp of rotations, linear positions).

        Frame ``k`` is at ``k / fps`` seconds, up to the clip's last frame: the output is less than
        one output frame shorter than the clip, and a duration a hair short of a whole number of
        output frames — within 1e-4 of it, relative, the precision of a frame time written with
        six digits — counts as that number (its last frame the clip's last pose). So a file's
        rounded frame time keeps every frame at its own rate: 16_16's 0.00833333 s reads as
        120.00005 fps and its 510 frames resample to 510 at 120 fps, where flooring the duration
        dropped the last.
        """
        if not (MIN_FPS <= fps <= MAX_FPS):  # (NaN fails too)
            raise MjmotionError(f"fps {fps:g}: expected a frame rate from {MIN_FPS:g} to {MAX_FPS:g} frames per second")
        x = self.duration * fps  # output frame steps the clip spans
        steps = int(np.floor(x))
        if x - steps > 1.0 - 1e-4 * max(x, 1.0):
            steps += 1
        # Checked before anything is allocated: --fps 1e9 on a 2 s clip would ask for 2e9 frames.
        check_motion_size(steps + 1, self.skeleton.n_joints, f"resampling a {self.duration:.4g} s clip to {fps:g} fps")
        frames = np.minimum(np.arange(steps + 1) * (self.fps / fps), self.n_frames - 1)
        root, q, tr = self.sample(frames)
        return self.replace(root_positions=root, rotations=q, translations=tr, fps=float(fps))
