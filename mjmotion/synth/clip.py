"""A generated clip with its ground truth, the known warps, and the manifest that stores them."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .. import mjcf
from ..errors import MjmotionError
from ..skeleton import Motion
from ..transform import floor_transform, timewarp
from .gait import Footprint
from .props import prop_frame

MANIFEST_VERSION = 1


@dataclass(frozen=True)
class Warp:
    """A known re-timing and rigid floor move: result frame ``i`` shows the source at fractional
    frame ``source_frames[i]``, then every point ``p`` goes to ``Rz(rotation) p + (tx, ty, 0)``.

    Attributes:
        source: name of the unwarped clip.
        source_frames: ``(n,)`` strictly increasing fractional source frames.
        rotation: radians about the vertical through the world origin.
        translation: ``(tx, ty)`` metres.
    """

    source: str
    source_frames: np.ndarray
    rotation: float
    translation: tuple[float, float]

    def apply_xy(self, xy: np.ndarray) -> np.ndarray:
        """Floor points ``(..., 2)`` of the source moved like the clip."""
        c, s = np.cos(self.rotation), np.sin(self.rotation)
        xy = np.asarray(xy, dtype=float)
        return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1) + np.asarray(self.translation)


@dataclass(frozen=True, eq=False)
class SynthClip:
    """A bundled clip and everything known about it by construction.

    Attributes:
        name: the clip's name (``walk``, ``drive``, ``walk_warped``…).
        kind: the generator (``walk``, ``run``, ``sneak``, ``limp``, ``drive``, ``pull``, ``kick``, ``punch``).
        motion: the :class:`~mjmotion.skeleton.Motion` (bundled skeleton, 60 fps).
        contacts: ``(T, 2)`` bool, left and right foot planted (ball of the foot on its footprint).
        footprints: the planned stances (:class:`~mjmotion.synth.gait.Footprint`), by start frame.
        hit_frame: the impact frame of a shot, else ``None``.
        sweet_spot: ``(3,)`` world position (metres) of the prop's sweet spot at ``hit_frame``.
        hit_normal: ``(3,)`` unit vector, where the blade's face looks at ``hit_frame`` (the
            prop frame's -x axis): the ball is struck along it.
        prop: the held prop (:class:`~mjmotion.mjcf.Prop`) or ``None``.
        warp: the :class:`Warp` that made this clip from another, or ``None``.
        params: the generator's arguments (for the manifest).
    """

    name: str
    kind: str
    motion: Motion
    contacts: np.ndarray
    footprints: tuple[Footprint, ...] = ()
    hit_frame: int | None = None
    sweet_spot: np.ndarray | None = None
    hit_normal: np.ndarray | None = None
    prop: mjcf.Prop | None = None
    warp: Warp | None = None
    params: tuple[tuple[str, float], ...] = ()

    def __repr__(self) -> str:
        """``SynthClip('drive', kind='drive', frames=166, hit_frame=66, prop='bat')``: what it is, not its arrays."""
        from ..summary import fields

        prop = self.prop.name if self.prop is not None else None
        return fields("SynthClip", repr(self.name), f"kind={self.kind}", frames=self.motion.n_frames, hit_frame=self.hit_frame, prop=prop)

    def hit_ball(self, radius: float = 0.036, mass: float = 0.16) -> mjcf.Ball:
        """A ball just touching the sweet spot at the hit frame, on the face side: METRICS.md
        ``hit_error_m`` is 0 for it (cricket ball: radius 0.036 m, 0.16 kg)."""
        if self.sweet_spot is None or self.hit_normal is None:
            raise MjmotionError(f"clip {self.name!r} has no hit frame")
        pos = self.sweet_spot + radius * self.hit_normal
        return mjcf.Ball(position=(float(pos[0]), float(pos[1]), float(pos[2])), radius=radius, mass=mass)

    def compile(self, ball: mjcf.Ball | None = None) -> mjcf.CompiledModel:
        """The MuJoCo model of the clip's skeleton with its prop (and an optional ball)."""
        return mjcf.compile(self.motion.skeleton, () if self.prop is None else (self.prop,), ball)

    def to_manifest(self, file: str) -> dict[str, Any]:
        """JSON-ready ground truth; ``file`` is the BVH file name it goes with."""
        out: dict[str, Any] = {
            "file": file,
            "kind": self.kind,
            "fps": self.motion.fps,
            "n_frames": self.motion.n_frames,
            "params": dict(self.params),
            "contacts": {side: _runs(self.contacts[:, i]) for i, side in enumerate(("left", "right"))},
            "footprints": [
                {
                    "side": f.side,
                    "start": f.start,
                    "end": f.end,
                    "flat_end": f.flat_end,
                    "position": list(f.position),
                    "heading": f.heading,
                }
                for f in self.footprints
            ],
            "hit_frame": self.hit_frame,
            "sweet_spot": None if self.sweet_spot is None else [float(x) for x in self.sweet_spot],
            "hit_normal": None if self.hit_normal is None else [float(x) for x in self.hit_normal],
            "prop": None if self.prop is None else _prop_dict(self.prop),
            "warp": None
            if self.warp is None
            else {
                "source": self.warp.source,
                "source_frames": [float(x) for x in self.warp.source_frames],
                "rotation": self.warp.rotation,
                "translation": list(self.warp.translation),
            },
        }
        return out

    @classmethod
    def from_manifest(cls, name: str, entry: dict[str, Any], motion: Motion) -> SynthClip:
        """The clip from its manifest ``entry`` and its (read back) ``motion``."""
        try:
            t = motion.n_frames
            if int(entry["n_frames"]) != t:
                raise MjmotionError(f"manifest: clip {name!r} has {entry['n_frames']} frames but its BVH has {t}")
            fps = float(entry["fps"])
            if abs(fps - motion.fps) > 1e-6 * fps:
                raise MjmotionError(f"manifest: clip {name!r} is at {fps:g} fps but its BVH at {motion.fps:g}")
            # BVH keeps the frame time to 10 digits; the manifest has the exact rate.
            motion = motion.replace(fps=fps)
            contacts = np.zeros((t, 2), dtype=bool)
            for i, side in enumerate(("left", "right")):
                for a, b in entry["contacts"][side]:
                    contacts[int(a) : int(b) + 1, i] = True
            fps_ = tuple(
                Footprint(
                    side=str(f["side"]),
                    start=int(f["start"]),
                    end=int(f["end"]),
                    flat_end=int(f["flat_end"]),
                    position=tuple(float(x) for x in f["position"]),  # type: ignore[arg-type]
                    heading=float(f["heading"]),
                )
                for f in entry["footprints"]
            )
            w = entry.get("warp")
            warp = (
                None
                if w is None
                else Warp(
                    str(w["source"]),
                    np.asarray(w["source_frames"], dtype=float),
                    float(w["rotation"]),
                    (float(w["translation"][0]), float(w["translation"][1])),
                )
            )
            p = entry.get("prop")
            prop = None if p is None else mjcf.Prop(**{**p, "pos": tuple(p["pos"]), "quat": tuple(p["quat"])})
            sweet = entry.get("sweet_spot")
            normal = entry.get("hit_normal")
            return cls(
                name=name,
                kind=str(entry["kind"]),
                motion=motion.replace(name=name),
                contacts=contacts,
                footprints=fps_,
                hit_frame=None if entry.get("hit_frame") is None else int(entry["hit_frame"]),
                sweet_spot=None if sweet is None else np.asarray(sweet, dtype=float),
                hit_normal=None if normal is None else np.asarray(normal, dtype=float),
                prop=prop,
                warp=warp,
                params=tuple((str(k), float(v)) for k, v in entry.get("params", {}).items()),
            )
        except (KeyError, TypeError, ValueError) as e:
            raise MjmotionError(f"manifest: clip {name!r} has a missing or malformed field ({e})") from None


def _runs(mask: np.ndarray) -> list[list[int]]:
    """Inclusive ``[start, end]`` frame ranges where ``mask`` is true."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(int)))
    return [[int(a), int(b) - 1] for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _prop_dict(p: mjcf.Prop) -> dict[str, Any]:
    return {
        "name": p.name,
        "joint": p.joint,
        "pos": [float(x) for x in p.pos],
        "quat": [float(x) for x in p.quat],
        "length": p.length,
        "radius": p.radius,
        "sweet_spot": p.sweet_spot,
        "mass": p.mass,
    }


def warp(
    clip: SynthClip,
    w: Callable[[np.ndarray], np.ndarray] | np.ndarray,
    rotation: float = 0.0,
    translation: tuple[float, float] = (0.0, 0.0),
    n_frames: int | None = None,
    name: str | None = None,
) -> SynthClip:
    """``clip`` re-timed by ``w`` and moved rigidly on the floor, with its ground truth carried over.

    Args:
        w: a strictly increasing function from result frame indices ``(n,)`` to fractional source
            frames, or those source frames ``(n,)`` directly.
        rotation: radians about the vertical through the world origin.
        translation: ``(tx, ty)`` metres, applied after the rotation.
        n_frames: result length (needed when ``w`` is a function; default: the source's).

    Contacts and footprints keep their meaning: a result frame is in contact when the source
    frame it shows lies inside a contact (both neighbouring source frames in contact); a shot's
    hit frame is the result frame showing the source time nearest the source hit, and the sweet
    spot is recomputed there by forward kinematics.
    """
    if callable(w):
        n = clip.motion.n_frames if n_frames is None else int(n_frames)
        src = np.asarray(w(np.arange(n, dtype=float)), dtype=float)
    else:
        src = np.asarray(w, dtype=float)
        n = len(src)
    moved = floor_transform(timewarp(clip.motion, lambda i: src, n), float(rotation), translation)
    info = Warp(clip.name, src.copy(), float(rotation), (float(translation[0]), float(translation[1])))
    lo, hi = np.floor(src).astype(int), np.ceil(src).astype(int)
    contacts = clip.contacts[lo] & clip.contacts[hi]
    prints = []
    for f in clip.footprints:
        inside = np.flatnonzero((src >= f.start) & (src <= f.end))
        if len(inside) == 0:
            continue
        flat = np.flatnonzero((src >= f.start) & (src <= f.flat_end))
        xy = info.apply_xy(np.array(f.position[:2]))
        prints.append(
            replace(
                f,
                start=int(inside[0]),
                end=int(inside[-1]),
                flat_end=int(flat[-1]) if len(flat) else int(inside[0]) - 1,
                position=(float(xy[0]), float(xy[1]), f.position[2]),
                heading=float(f.heading + rotation),
            )
        )
    hit, sweet, normal = None, None, None
    if clip.hit_frame is not None:
        hit = int(np.argmin(np.abs(src - clip.hit_frame)))
        sweet, normal = _sweet_spot(moved, clip.prop, hit)
    return replace(
        clip,
        name=name or f"{clip.name}_warped",
        motion=moved.replace(name=name or f"{clip.name}_warped"),
        contacts=contacts,
        footprints=tuple(prints),
        hit_frame=hit,
        sweet_spot=sweet,
        hit_normal=normal,
        warp=info,
    )


def smooth_warp(n_source: int, n_frames: int, strength: float = 0.25, seed: int = 0) -> np.ndarray:
    """A smooth, strictly increasing map ``(n_frames,)`` from result frames onto ``[0, n_source-1]``.

    ``strength`` in [0, 0.9): how far the local rate departs from uniform (0 = a linear map).
    """
    if not (0.0 <= strength < 0.9):
        raise MjmotionError(f"warp strength {strength}: expected 0 ≤ strength < 0.9")
    rng = np.random.default_rng(seed)
    u = np.linspace(0.0, 1.0, n_frames)
    k = np.arange(1, 4)
    amp = rng.uniform(-1.0, 1.0, 3) / k
    phase = rng.uniform(0.0, 2 * np.pi, 3)
    rate = 1.0 + strength * np.sin(2 * np.pi * np.outer(u, k) + phase) @ amp / np.sum(np.abs(amp))
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]))])
    return cum / cum[-1] * (n_source - 1)


def _sweet_spot(motion: Motion, prop: mjcf.Prop | None, frame: int) -> tuple[np.ndarray, np.ndarray]:
    if prop is None:
        raise MjmotionError("a clip with a hit frame needs a prop")
    return prop_frame(motion, prop, frame)
