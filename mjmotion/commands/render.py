"""``mjmotion render``: an MP4 or GIF of one or more clips side by side."""

from __future__ import annotations

import os

# Before anything loads PyOpenGL: the headless backend, unless the user chose one.
os.environ.setdefault("MUJOCO_GL", "egl")

import argparse
from typing import Any

from ..caps import MAX_MODEL_JOINTS, check_motion_size
from ..errors import MjmotionError, printable
from ..floor import Floor
from ._common import add_input_options, check_model, load, output_path, parse_frames, prop_option
from ._options import COORD, VIDEO_FPS, UniqueProps, check_actors, integer, number
from ._options import label as label_text
from .evaluate import add_judge_options, check_floor, load_sources

PIXELS = integer(16, 4096, what="pixels")

NAME = "render"
HELP = "render BVH clips side by side to an MP4 or GIF (offscreen MuJoCo)"
DESCRIPTION = """Render one or more clips into one scene, side by side, each in its own colour with a
label, on a checker floor with soft contact shadows, with a camera that follows them (--hq: MuJoCo's
shadow-mapped light and the floor reflection, about 2.5x slower in software GL). Clips are resampled to --fps;
shorter clips hold their last pose. The video is MP4 (H.264) or GIF, chosen by the OUT suffix.

examples:
  mjmotion render walk.bvh -o walk.mp4
  mjmotion render source.bvh adapted.bvh blend.bvh --labels source adapted blend -o compare.mp4
  mjmotion render swing.bvh --prop club --ball 0.5 0.1 0.02 --trail -o swing.gif --width 640 --height 360
  mjmotion render kick.bvh --trail rtoes --frames 100:400 --fps 25 --fast -o kick.mp4
  mjmotion render walk.bvh --skin -o walk_skin.mp4
  mjmotion render walk.bvh --skin both -o skin_vs_capsules.mp4
  mjmotion render cleaned.bvh raw.bvh --source raw.bvh -o compare.mp4

The checker floor is drawn at the floor the judge uses (docs/METRICS.md "The floor"), as `mjmotion
evaluate` finds it for the first clip: --floor METRES (--floor 0: z = 0 as captured), else its
--source clip(s), else the first clip's own stance floor. Every character moves by the same
amount, so a clip floating over (or sunk into) another's floor still shows. Each foot is drawn on
the sole points the judge calibrates on its clip (docs/METRICS.md "Feet"), so a foot the judge
finds on the floor touches the floor drawn.

--skin draws each character as its skinned surface (the mesh and weights `mjmotion compile --skin`
writes, deformed by MuJoCo's vertex blending) instead of capsules; --skin both draws every clip
twice, skinned and as capsules, side by side in one colour (so at most 8 clips: a video holds 16
characters). Either works with --fast.
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="FILE.bvh", help="clips to render, left to right")
    p.add_argument("-o", "--output", required=True, metavar="OUT.mp4|OUT.gif", help="the video to write")
    p.add_argument("--force", action="store_true", help="replace the output if it exists")
    p.add_argument(
        "--labels", nargs="+", type=label_text(), metavar="LABEL", help="one label per clip, printable, at most 80 characters (default: file names)"
    )
    p.add_argument(
        "--prop",
        action=UniqueProps,
        default=[],
        metavar="KIND[:JOINT]",
        help="give every character a prop: club or bat, held by JOINT along its bone, or without :JOINT fitted to both hands at the clip's address frames (as hit --prop)",
    )
    p.add_argument(
        "--ball", nargs=3, type=COORD, metavar=("X", "Y", "Z"), help="a ball at X Y Z metres (Z up, each within ±1000) beside each character"
    )
    p.add_argument(
        "--trail",
        nargs="?",
        const="auto",
        metavar="SITE|JOINT",
        help="draw a ghost trail of an effector (default with no name: the prop's sweet spot, else the right hand)",
    )
    p.add_argument("--width", type=PIXELS, default=960, help="image width in pixels, 16 to 4096, even for MP4 (default 960)")
    p.add_argument("--height", type=PIXELS, default=540, help="image height in pixels, 16 to 4096, even for MP4 (default 540)")
    p.add_argument("--fps", type=VIDEO_FPS, default=30.0, help="video frame rate, 1 to 240; clips are resampled to it (default 30)")
    p.add_argument("--frames", metavar="A:B", help="render only frames A:B of each clip (its own frame numbers)")
    p.add_argument(
        "--spacing",
        type=number(0, 100, what="a distance in metres"),
        default=1.2,
        help="metres between characters, at most 100 (default 1.2; 0 overlays them)",
    )
    p.add_argument(
        "--azimuth",
        type=number(-360, 360, what="an angle in degrees"),
        help="camera heading in degrees, ±360 (default: from the clips' travel direction)",
    )
    p.add_argument(
        "--elevation", type=number(-90, 90, what="an angle in degrees"), default=-10.0, help="camera elevation in degrees, ±90 (default -10)"
    )
    p.add_argument(
        "--distance",
        type=number(0, 1000, lo_open=True, what="a distance in metres"),
        help="camera distance in metres, at most 1000 (default: fit the characters)",
    )
    p.add_argument("--no-shadows", action="store_true", help="no contact shadows under the characters")
    look = p.add_mutually_exclusive_group()  # one look: --hq with --fast asked for both and silently got --fast
    look.add_argument("--fast", action="store_true", help="the quickest frames: no shadows of any kind, no floor reflection")
    look.add_argument(
        "--hq",
        action="store_true",
        help="MuJoCo's shadow-mapped key light and the floor reflection instead of contact shadows (about 2.5x slower in software GL)",
    )
    p.add_argument(
        "--skin",
        nargs="?",
        const="only",
        choices=("only", "both"),
        help="draw the skinned character instead of capsules; 'both': each clip skinned and as capsules, side by side",
    )
    add_judge_options(
        p,
        floor_help="the floor height (world z, m, within ±100) drawn at the checker floor (default: from --source, else detected on the first clip)",
        source_help="a clip the first one was made from (repeatable; same skeleton and frame rate): its stance floor is the one drawn",
    )
    add_input_options(p)


def scene_floor(args: argparse.Namespace, first) -> Floor | None:
    """The floor the scene is drawn at: ``mjmotion evaluate``'s for the first clip ``first``
    (as rendered), from ``--floor``, its ``--source`` clips, or its own stance; None (z = 0)
    for a skeleton without feet and no ``--floor``."""
    from ..feet import judged_floor

    check_floor(args)
    sources = load_sources(args, args.files[0], first, speed_reference=False) if args.source else []  # (a floor only)
    if not first.skeleton.feet() or first.n_frames < 2:
        if args.source:
            raise MjmotionError(f"--source: {args.files[0]} has no feet found by name (or one frame); its floor cannot be judged")
        return None if args.floor is None else Floor(float(args.floor), "given")
    return judged_floor(first, sources, args.floor)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from .. import mjcf, render

    out = output_path(args, *args.files)
    if out.suffix.lower() not in (".mp4", ".gif"):
        raise MjmotionError(f"-o {out}: this is written as a video (MP4 or GIF, by the suffix); expected an .mp4 or .gif path")
    if out.suffix.lower() == ".mp4" and (args.width % 2 or args.height % 2):
        raise MjmotionError(f"--width {args.width} --height {args.height}: MP4 (yuv420p) needs an even width and height")
    if args.labels is not None and len(args.labels) != len(args.files):
        raise MjmotionError(f"--labels: got {len(args.labels)} labels for {len(args.files)} clips; give one per clip")
    if args.skin == "both":  # each clip drawn twice, skinned and as capsules: refused before any clip is read
        check_actors(2 * len(args.files), f"--skin both of {len(args.files)} clips (2 characters each)")
    else:
        check_actors(len(args.files))
    labels = args.labels or [printable(os.path.splitext(os.path.basename(f))[0]) for f in args.files]  # drawn: one printable line
    actors = []
    for i, (path, label) in enumerate(zip(args.files, labels)):
        m = load(path, args, trim=not args.frames)  # --frames: the file's own frame numbers
        check_model(m, path)
        props = tuple(prop_option(m, text) for text in args.prop)  # fitted on the whole clip (a swing's address frames)
        if args.frames:
            m = m[parse_frames(args.frames, m.n_frames)]
        trail = _trail(m, props, args.trail)
        if args.skin == "both":
            colour = render.PALETTE[i % len(render.PALETTE)]
            for skinned, kind in ((True, "skin"), (False, "capsules")):
                actors.append(render.Actor(m, label=f"{label} {kind}".strip(), color=colour, props=props, trail=trail, skin=skinned))
        else:
            actors.append(render.Actor(m, label=label, props=props, trail=trail, skin=args.skin == "only"))
    _check_scene([a.motion for a in actors], args.fps)
    floor = scene_floor(args, actors[0].motion)
    if floor is not None and not floor.level.flat:
        from dataclasses import replace

        from ..feet import level_motion

        # A tilted captured floor is drawn as the judge measures it: every character levelled with the first clip's floor.
        actors = [replace(a, motion=level_motion(floor.level, a.motion)) for a in actors]
    ball = mjcf.Ball(position=tuple(args.ball)) if args.ball else None
    if ball is not None and floor is not None and not floor.level.flat:
        from dataclasses import replace

        ball = replace(ball, position=_xyz(floor.level.positions(np.asarray(ball.position))))  # levelled with the characters
    view = render.View(azimuth=args.azimuth, elevation=args.elevation, distance=args.distance)
    try:
        scene = render.build_scene(actors, fps=args.fps, ball=ball, spacing=args.spacing, view=view, floor=0.0 if floor is None else floor.height)
    except MjmotionError as e:
        if not args.skin:
            raise
        raise MjmotionError(f"--skin: {e} ({', '.join(args.files)})") from None
    contact_shadows = not (args.hq or args.fast or args.no_shadows)
    render.render(
        scene,
        out,
        width=args.width,
        height=args.height,
        contact_shadows=contact_shadows,
        shadows=args.hq and not args.no_shadows,
        reflections=args.hq,
    )
    print(
        f"wrote {out}: {scene.n_frames} frames, {args.width}x{args.height} at {args.fps:g} fps, {len(actors)} character(s), "
        f"floor {'z = 0 (no feet to find one on)' if floor is None else floor.text()}"
        + (f", levelled from a {floor.level.tilt_deg:.1f}° tilt" if floor is not None and not floor.level.flat else "")
    )
    return 0


def _check_scene(motions: list, fps: float) -> None:
    """The scene's size before it is built: one model of every character, every clip at ``fps``."""
    joints = sum(m.skeleton.n_joints for m in motions)
    if joints > MAX_MODEL_JOINTS:
        raise MjmotionError(
            f"the clips to render: {len(motions)} characters with {joints} joints in all; one render holds at most {MAX_MODEL_JOINTS}"
        )
    longest = max(motions, key=lambda m: m.duration)
    try:
        check_motion_size(longest.duration * fps + 1, joints, f"{len(motions)} character(s), {longest.duration:.4g} s at {fps:g} fps")
    except MjmotionError as e:
        raise MjmotionError(f"--fps {fps:g}: {e}") from None


def _trail(motion, props, text: str | None) -> str | None:
    """The trail effector: the named site/joint, or for ``auto`` the first prop's sweet spot, else the right hand."""
    if text is None:
        return None
    if text != "auto":
        return text
    if props:
        return props[0].site
    hands = motion.skeleton.hands()
    if "right" not in hands:
        raise MjmotionError("--trail: no prop and no right hand found by name; say which joint, e.g. --trail rwrist")
    return motion.skeleton.names[hands["right"]]


def _xyz(p: Any) -> tuple[float, float, float]:
    """A point ``(3,)`` as a tuple of three floats."""
    return (float(p[0]), float(p[1]), float(p[2]))
