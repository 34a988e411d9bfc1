"""The clips a Studio may show: files named on the command line, BVH files under ``--data``, the
bundled procedural library when neither is given, and BVH files a page uploads.

Files are read only from those places. Every file goes through :func:`mjmotion.bvh.read` /
:func:`mjmotion.bvh.parse` (the validating reader) and a size limit; an upload that fails is an
:class:`~mjmotion.errors.MjmotionError` naming it, shown in the page, and nothing else changes.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from .. import bvh, mjcf
from ..errors import MjmotionError
from ..inputs import find_bvh
from ..skeleton import Motion
from ..trim import skip_leading_transient

#: Largest BVH file (bytes) a Studio reads or accepts as an upload (the largest shared clip is 3.4 MB).
MAX_CLIP_BYTES = 32 * 2**20
#: At most this many clips are listed from ``--data`` (a folder of thousands would swamp the menus).
MAX_DATA_CLIPS = 500


@dataclass(frozen=True)
class Clip:
    """A clip the Studio can show.

    Attributes:
        name: unique label in the menus.
        motion: the clip.
        source: the file it was read from (``None`` for bundled clips and uploads).
        prop: the prop it holds (the bundled shots' bat), or ``None``.
        hit_frame: the known impact frame (bundled shots), or ``None``.
        skipped: leading file frames left out (a T-pose or transition, as every verb skips them).
    """

    name: str
    motion: Motion
    source: Path | None = None
    prop: mjcf.Prop | None = None
    hit_frame: int | None = None
    skipped: int = 0


class ClipLibrary:
    """An ordered set of clips by name; :meth:`with_upload` returns a new library (pages keep their own)."""

    def __init__(self, clips: list[Clip], keep_start: bool = False, scale: float | None = None, up: str = "y"):
        self.keep_start = keep_start
        self.scale, self.up = scale, up  # (how files are read: --units, --up; uploads too)
        self._clips = {c.name: c for c in clips}
        if len(self._clips) != len(clips):
            raise MjmotionError("clip names must be unique")

    @classmethod
    def bundled(cls) -> ClipLibrary:
        """The bundled procedural library (:func:`mjmotion.synth.library`)."""
        from .. import synth

        return cls([Clip(name, c.motion.replace(name=name), None, c.prop, c.hit_frame) for name, c in synth.library().items()])

    @classmethod
    def from_paths(
        cls, files: list[str], data: str | None = None, keep_start: bool = False, scale: float | None = None, up: str = "y"
    ) -> ClipLibrary:
        """Clips from ``files`` and the ``.bvh`` files under ``data`` (sorted); the bundled library when both are empty.
        A file's leading T-pose or transition is left out, as the verbs do, unless ``keep_start``; ``scale``
        (metres per file unit, ``None``: detected) and ``up`` read the files as ``--units`` and ``--up`` do."""
        paths = [Path(f) for f in files]
        if data is not None:
            root = Path(data)
            if not root.is_dir():
                raise MjmotionError(f"--data {data}: not a folder")
            found = find_bvh(root)
            if not found:
                raise MjmotionError(f"--data {data}: no .bvh files in it")
            paths += found[:MAX_DATA_CLIPS]
        if not paths:
            return cls.bundled()
        clips: list[Clip] = []
        names: set[str] = set()
        for p in paths:
            motion, skipped = skip_leading_transient(bvh.read(p, scale=scale, up=up, max_bytes=MAX_CLIP_BYTES), keep_start)
            name = _unique(p.stem, names)
            clips.append(Clip(name, motion.replace(name=name), p.resolve(), skipped=skipped))
        return cls(clips, keep_start, scale, up)

    def names(self) -> list[str]:
        return list(self._clips)

    def get(self, name: str) -> Clip:
        try:
            return self._clips[name]
        except KeyError:
            raise MjmotionError(f"no clip named {name!r}") from None

    def inputs(self) -> list[Path]:
        """The files the clips were read from (a save never writes over one)."""
        return [c.source for c in self._clips.values() if c.source is not None]

    def with_upload(self, filename: str, content: bytes) -> tuple[ClipLibrary, Clip]:
        """This library plus the uploaded BVH ``content`` (validated, at most :data:`MAX_CLIP_BYTES`)."""
        shown = os.path.basename(filename) or "upload.bvh"
        if len(content) > MAX_CLIP_BYTES:
            raise MjmotionError(f"{shown}: {len(content)} bytes is more than the {MAX_CLIP_BYTES // 2**20} MiB limit for a clip")
        motion, skipped = skip_leading_transient(bvh.parse(content, path=shown, scale=self.scale, up=self.up), self.keep_start)
        name = _unique(Path(shown).stem, set(self._clips))
        clip = Clip(name, motion.replace(name=name), skipped=skipped)
        return ClipLibrary([*self._clips.values(), clip], self.keep_start, self.scale, self.up), clip

    def shots(self) -> list[str]:
        """Clips that can be adapted to a ball: those holding a prop, two-handed swings, kicks and punches by name."""
        keys = re.compile(r"kick|punch|drive|pull|swing|golf|bat|shot", re.IGNORECASE)
        return [c.name for c in self._clips.values() if c.prop is not None or keys.search(c.name)]


def _unique(stem: str, taken: set[str]) -> str:
    name, k = stem, 2
    while name in taken:
        name, k = f"{stem}_{k}", k + 1
    taken.add(name)
    return name
