"""``mjmotion info``: what a BVH file holds."""

from __future__ import annotations

import argparse
import json
import sys

from ..errors import printable as _shown
from ._common import add_input_options, read_motion


def _shortest_rate(frame_time: str) -> float:
    """The shortest decimal rate whose frame time, to the digits of ``frame_time``, is ``frame_time``."""
    digits = len(frame_time.lower().split("e")[0].replace(".", "").replace("-", "").lstrip("0")) or 1
    fps = 1.0 / float(frame_time)
    for d in range(1, 18):
        r = float(f"{fps:.{d}g}")
        if f"{1.0 / r:.{digits}g}" == f"{float(frame_time):.{digits}g}":
            return r
    return fps


NAME = "info"
HELP = "joints, frames, fps, duration, channel layout, detected scale and standing axis of a BVH file"
DESCRIPTION = """Describe a BVH file.

The units line names the file axis the body stands along (its head above its feet in most frames);
a clip read with --up y whose body stands along +Z (or the other way round) gets a note on stderr
naming the --up that reads it upright (unless the clip is of a body lying down).

The table is rounded for reading; --json keeps every number at full precision, except the rate:
frame_time_s is the file's Frame Time as written, and fps the shortest rate whose frame time,
written to as many digits, is the file's (a Frame Time of 0.00833333 gives fps 120, not
1/0.00833333 = 120.0000480000192). Every verb runs the clip at 1 / frame_time_s.

examples:
  mjmotion info walk.bvh
  mjmotion info walk.bvh --json > walk.json
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="a .bvh file")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    add_input_options(p, trim=False)


def describe(path: str, args: argparse.Namespace, notes: list[str] | None = None) -> dict:
    """What ``path`` holds, as ``run`` prints it; ``notes`` gets the ``--up`` note (:func:`mjmotion.upright.up_note`)."""
    from ..bvh import frame_time_text
    from ..trim import leading_transient
    from ..upright import standing_axis, up_note

    m = read_motion(path, args)
    s = m.skeleton
    frame_time = frame_time_text(m.fps)
    standing = standing_axis(m)
    if notes is not None:
        notes += up_note(m, _shown(path), standing)
    return {
        "file": path,
        "joints": s.n_joints,
        "end_sites": int(len(s.end_parents)),
        "channels": s.n_channels,
        "frames": m.n_frames,
        "fps": _shortest_rate(frame_time),
        "frame_time_s": float(frame_time),
        "duration_s": m.duration,
        "leading_transient_frames": leading_transient(m),
        "scale_m_per_unit": s.scale,
        "up": s.up,
        "standing_axis": None if standing is None else standing.axis,
        "standing_share": None if standing is None else standing.share,
        "stature_m": s.stature(),
        "head": None if (head := s.head()) is None else s.names[head],
        "feet": {k: {"ankle": s.names[a], "toe": None if t is None else s.names[t]} for k, (a, t) in s.feet().items()},
        "hands": {k: s.names[v] for k, v in s.hands().items()},
        "joint_list": [
            {"name": n, "parent": None if p < 0 else s.names[p], "channels": list(c)} for n, p, c in zip(s.names, s.parents.tolist(), s.channels)
        ],
    }


def run(args: argparse.Namespace) -> int:
    notes: list[str] = []
    d = describe(args.file, args, notes)
    for line in notes:
        sys.stderr.write(_shown(line) + "\n")
    axis = d["standing_axis"]
    if args.json:
        print(json.dumps(d, indent=2))  # (JSON escapes control characters itself)
        return 0
    print(_shown(d["file"]))
    print(f"  joints      {d['joints']} (+{d['end_sites']} End Sites), {d['channels']} channels")
    print(f"  frames      {d['frames']} at {d['fps']:.6g} fps (Frame Time {d['frame_time_s']:g} s), {d['duration_s']:.3f} s")
    if d["leading_transient_frames"]:
        k = d["leading_transient_frames"]
        print(f"  start       frames 0-{k - 1} are a leading T-pose/transition: the other verbs skip them unless --keep-start")
    if axis is not None:
        stands = f"the body stands along {axis.upper()} in {d['standing_share']:.0%} of frames"
    elif d["head"] is None or not d["feet"]:
        stands = "no head or feet found by name: which axis the body stands along is not known"
    else:
        stands = "the body stands along no one axis in most frames"
    print(f"  units       {d['scale_m_per_unit']:.6g} m per file unit, up axis {d['up']} ({stands}); stature ≈ {d['stature_m']:.2f} m")
    print(f"  head        {_shown(d['head'] or 'none found by name')}")
    feet = [f"{side} {f['ankle']}" + (f" → {f['toe']}" if f["toe"] else " (no toe)") for side, f in d["feet"].items()]
    print(f"  feet        {_shown(', '.join(feet) or 'none found by name')}")
    hands = [f"{side} {name}" for side, name in d["hands"].items()]
    print(f"  hands       {_shown(', '.join(hands) or 'none found by name')}")
    layouts: dict[tuple[str, ...], list[str]] = {}
    for j in d["joint_list"]:
        layouts.setdefault(tuple(j["channels"]), []).append(j["name"])
    print("  channel layouts:")
    for chans, names in layouts.items():
        shown = ", ".join(names[:6]) + (f", … ({len(names)} joints)" if len(names) > 6 else "")
        print(f"    {' '.join(chans) or '(none)'}: {_shown(shown)}")
    return 0
