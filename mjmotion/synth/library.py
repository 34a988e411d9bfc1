"""The public generators and the bundled library (BVH files plus ``manifest.json``)."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .. import bvh
from ..errors import MjmotionError
from ..outputs import check_output, staged_folder, write_text_atomic
from ..skeleton import CM
from . import actions
from .clip import MANIFEST_VERSION, SynthClip, smooth_warp, warp
from .gait import generate


def _gait_clip(
    kind: str, speed: float | None, seconds: float, turn_deg_per_s: float, seed: int, name: str | None, step_length: float | None
) -> SynthClip:
    g = generate(kind, speed=speed, seconds=seconds, turn_deg_per_s=turn_deg_per_s, seed=seed, step_length=step_length)
    label = name or kind
    return SynthClip(
        name=label,
        kind=kind,
        motion=g.motion.replace(name=label),
        contacts=g.contacts,
        footprints=g.footprints,
        params=(
            ("speed", g.style.speed),
            ("step_length", g.style.step_length),
            ("seconds", float(seconds)),
            ("turn_deg_per_s", float(turn_deg_per_s)),
            ("seed", float(seed)),
        ),
    )


def walk(
    speed: float = 1.3,
    seconds: float = 4.0,
    turn_deg_per_s: float = 0.0,
    seed: int = 0,
    name: str | None = None,
    step_length: float | None = None,
) -> SynthClip:
    """A walk along +X from the origin, 60 fps.

    Args:
        speed: m/s along the path.
        seconds: duration.
        turn_deg_per_s: turning rate, positive to the left (turning radius ≥ 1 m).
        seed: small deterministic variations (0 = the nominal gait).
        name: the clip's name (default: the gait's).
        step_length: metres per step (default: 0.70 m at 1.3 m/s, scaled with sqrt(speed)).
    """
    return _gait_clip("walk", speed, seconds, turn_deg_per_s, seed, name, step_length)


def run(
    speed: float = 3.2,
    seconds: float = 3.0,
    turn_deg_per_s: float = 0.0,
    seed: int = 0,
    name: str | None = None,
    step_length: float | None = None,
) -> SynthClip:
    """A run with a flight phase (both feet off the ground between stances); arguments as :func:`walk`."""
    return _gait_clip("run", speed, seconds, turn_deg_per_s, seed, name, step_length)


def sneak(
    speed: float = 0.6,
    seconds: float = 4.0,
    turn_deg_per_s: float = 0.0,
    seed: int = 0,
    name: str | None = None,
    step_length: float | None = None,
) -> SynthClip:
    """A crouched, slow, leaning walk with long double support; arguments as :func:`walk`."""
    return _gait_clip("sneak", speed, seconds, turn_deg_per_s, seed, name, step_length)


def limp(
    speed: float = 0.9,
    seconds: float = 4.0,
    turn_deg_per_s: float = 0.0,
    seed: int = 0,
    name: str | None = None,
    step_length: float | None = None,
) -> SynthClip:
    """An asymmetric walk favouring the right leg (short right stance, pelvis drop and trunk lean
    over it); arguments as :func:`walk`."""
    return _gait_clip("limp", speed, seconds, turn_deg_per_s, seed, name, step_length)


def drive(seed: int = 0) -> SynthClip:
    """A cricket front-foot drive with a bat in the right hand (stance → backlift → downswing →
    impact → follow-through → the same stance). ``hit_frame``/``sweet_spot`` give the impact."""
    return actions.shot("drive", seed)


def pull(seed: int = 0) -> SynthClip:
    """A cricket pull shot (back foot back and across, horizontal bat), same stance as :func:`drive`."""
    return actions.shot("pull", seed)


def kick(seed: int = 0) -> SynthClip:
    """A front kick with the right leg, from and back to the standing pose."""
    return actions.kick(seed)


def punch(seed: int = 0) -> SynthClip:
    """A right straight punch from a guard, from and back to the standing pose."""
    return actions.punch(seed)


#: The CLI's generators: name → (function, whether it takes speed/turn/seconds).
GENERATORS: dict[str, tuple[Callable[..., SynthClip], bool]] = {
    "walk": (walk, True),
    "run": (run, True),
    "sneak": (sneak, True),
    "limp": (limp, True),
    "drive": (drive, False),
    "pull": (pull, False),
    "kick": (kick, False),
    "punch": (punch, False),
}


def library() -> dict[str, SynthClip]:
    """The bundled set by name: gaits (straight and turning, a faster walk), the two shots,
    kick, punch, and ``walk_warped``: the walk re-timed by a known smooth warp and moved on
    the floor (registration's ground truth)."""
    clips = [
        walk(),
        walk(speed=1.7, name="walk_fast"),
        walk(speed=1.2, turn_deg_per_s=25.0, name="walk_turn_left"),
        run(),
        run(speed=3.0, turn_deg_per_s=-30.0, name="run_turn_right"),
        sneak(),
        limp(),
        drive(),
        pull(),
        kick(),
        punch(),
    ]
    out = {c.name: c for c in clips}
    base = out["walk"]
    n = round(base.motion.n_frames * 0.85)
    out["walk_warped"] = warp(base, smooth_warp(base.motion.n_frames, n, strength=0.35, seed=7), 0.6, (1.5, -0.8))
    return out


def write_library(directory: str | os.PathLike[str], force: bool = False, clips: dict[str, SynthClip] | None = None) -> dict[str, SynthClip]:
    """Write every clip as ``NAME.bvh`` and the ground truth as ``manifest.json`` into ``directory``
    (created if missing). Existing files are refused unless ``force``. Returns the clips.

    A new folder is written under a temporary name and renamed when complete, so a failure (a
    full disk) leaves no folder behind; into an existing folder each file is published on its own.
    """
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise MjmotionError(f"{d}: exists and is not a directory")
    clips = library() if clips is None else clips
    files = [*(f"{name}.bvh" for name in clips), "manifest.json"]
    if d.is_dir():
        for f in files:
            check_output(d / f, force=force)
        _write_library_files(d, clips)
        return clips
    made = [p for p in reversed(d.parents) if not p.exists()]
    d.parent.mkdir(parents=True, exist_ok=True)
    try:
        with staged_folder(d) as tmp:
            _write_library_files(tmp, clips)
    except BaseException:
        for p in reversed(made):  # folders made for it, innermost first, if still empty
            with contextlib.suppress(OSError):
                p.rmdir()
        raise
    return clips


def _write_library_files(d: Path, clips: dict[str, SynthClip]) -> None:
    entries: dict[str, Any] = {}
    for name, clip in clips.items():
        write_text_atomic(d / f"{name}.bvh", bvh.format_motion(clip.motion))
        entries[name] = clip.to_manifest(f"{name}.bvh")
    manifest = {
        "version": MANIFEST_VERSION,
        "generator": "mjmotion.synth",
        "units": "BVH files: centimetres, Y up. Ground truth: MuJoCo world (Z up), metres, radians, frame indices.",
        "clips": entries,
    }
    write_text_atomic(d / "manifest.json", json.dumps(manifest, indent=1) + "\n")


def load_library(directory: str | os.PathLike[str]) -> dict[str, SynthClip]:
    """Read a directory written by :func:`write_library` back into clips."""
    d = Path(directory)
    mpath = d / "manifest.json"
    try:
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MjmotionError(f"{mpath}: no manifest (write one with `mjmotion synth library {d}`)") from None
    except json.JSONDecodeError as e:
        raise MjmotionError(f"{mpath}: not valid JSON ({e})") from None
    if not isinstance(manifest, dict) or manifest.get("version") != MANIFEST_VERSION or not isinstance(manifest.get("clips"), dict):
        raise MjmotionError(f"{mpath}: expected a version {MANIFEST_VERSION} manifest with a 'clips' object")
    out = {}
    for name, entry in manifest["clips"].items():
        motion = bvh.read(d / str(entry.get("file", f"{name}.bvh")), scale=CM, up="y")
        out[name] = SynthClip.from_manifest(name, entry, motion)
    return out


def same_ground_truth(a: SynthClip, b: SynthClip) -> bool:
    """Whether two clips carry the same ground truth (contacts, footprints, hit, prop, warp)."""

    def close(x: np.ndarray | None, y: np.ndarray | None) -> bool:
        return (x is None and y is None) or (x is not None and y is not None and np.allclose(x, y, atol=1e-12))

    return (
        np.array_equal(a.contacts, b.contacts)
        and a.footprints == b.footprints
        and a.hit_frame == b.hit_frame
        and close(a.sweet_spot, b.sweet_spot)
        and close(a.hit_normal, b.hit_normal)
        and a.prop == b.prop
        and (
            (a.warp is None and b.warp is None)
            or (
                a.warp is not None
                and b.warp is not None
                and close(a.warp.source_frames, b.warp.source_frames)
                and a.warp.rotation == b.warp.rotation
                and a.warp.translation == b.warp.translation
            )
        )
    )
