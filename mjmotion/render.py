"""Offscreen video of one or more characters side by side, through MuJoCo's OpenGL renderer.

A :class:`Scene` is one MuJoCo model holding every character (each character's compiled
``MjSpec`` attached under a prefix, colour-coded), the checker floor and lights of
:mod:`mjmotion.mjcf`, props and balls, plus the per-frame ``qpos`` at the video frame rate and
a smoothed camera track. A :class:`Renderer` turns scene frames into RGB images with labels and
optional ghost trails of an effector; :func:`write_video` encodes MP4 (imageio-ffmpeg) or GIF
(Pillow).

Headless OpenGL: ``MUJOCO_GL=egl`` (Mesa's software EGL works on CPU-only machines) is the
default; the context is opened here, not by ``mujoco.Renderer``, because MuJoCo picks its
backend when ``mujoco`` is first imported, which other modules may already have done.
If EGL does not work, OSMesa is tried; if neither works a :class:`MjmotionError` says so.
"""

from __future__ import annotations

import math
import os

# Before anything imports PyOpenGL: pick the headless backend unless the user chose one.
os.environ.setdefault("MUJOCO_GL", "egl")

import importlib
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from . import kinematics, mjcf
from . import rotations as rot
from .caps import MAX_ACTORS, MAX_VIDEO_FPS, MIN_VIDEO_FPS
from .errors import MjmotionError, is_real, is_whole
from .outputs import atomic_path
from .skeleton import Motion

#: Character colours (RGB 0–1), in order: source, adapted, blend, … (no red: the ball is red).
PALETTE: tuple[tuple[float, float, float], ...] = (
    (0.30, 0.55, 0.85),  # blue
    (0.95, 0.60, 0.20),  # orange
    (0.35, 0.75, 0.35),  # green
    (0.70, 0.50, 0.85),  # purple
    (0.90, 0.85, 0.35),  # yellow
    (0.40, 0.80, 0.80),  # teal
)
BALL_RGBA = (0.85, 0.10, 0.10, 1.0)
#: Contact shadows: opacity of a shadow touching the floor, and the height (m) from which none is drawn.
CONTACT_SHADOW_ALPHA = 0.5
CONTACT_SHADOW_HEIGHT = 0.6
#: Backends tried, in order, when ``MUJOCO_GL`` is unset or not an offscreen one.
OFFSCREEN_BACKENDS = ("egl", "osmesa")


@dataclass(frozen=True)
class Actor:
    """One character in a scene.

    Attributes:
        motion: the clip (any frame rate; resampled to the video's).
        label: text drawn above the character ("" for none).
        color: RGB 0–1 of its bones (feet a darker shade); ``None`` = next in :data:`PALETTE`.
        props: sticks it holds (built for ``motion.skeleton``, see :func:`mjmotion.mjcf.default_prop`).
        trail: a site or joint name whose recent path is drawn as a fading ghost trail, or ``None``.
        skin: draw the character as a skinned surface (:mod:`mjmotion.skin`, deformed by MuJoCo's
            vertex blending) instead of its capsules; props are drawn either way.
    """

    motion: Motion
    label: str = ""
    color: tuple[float, float, float] | None = None
    props: tuple[mjcf.Prop, ...] = ()
    trail: str | None = None
    skin: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.motion, Motion):
            raise MjmotionError(f"Actor: expected a Motion, got {type(self.motion).__name__}")
        if not isinstance(self.label, str):
            raise MjmotionError(f"Actor label: expected text, got {self.label!r}")
        if self.color is not None:
            mjcf.check_vector("Actor color", self.color, 3, "RGB 0-1")
            if not all(0.0 <= float(c) <= 1.0 for c in self.color):
                raise MjmotionError(f"Actor color: expected 3 numbers from 0 to 1 (RGB), got {self.color!r}")
        if isinstance(self.props, mjcf.Prop) or not all(isinstance(pr, mjcf.Prop) for pr in self.props):
            raise MjmotionError(f"Actor props: expected a tuple of mjcf.Prop, got {self.props!r}")


@dataclass(frozen=True)
class View:
    """Camera settings. ``None`` fields are chosen from the characters' size and layout.

    Attributes:
        azimuth: world heading the camera looks along, degrees (MuJoCo's free-camera azimuth).
        elevation: degrees, negative looks down.
        distance: metres from the look-at point.
        smoothing: seconds; standard deviation of the zero-lag Gaussian smoothing of the look-at
            track (the whole clip is known, so no exponential lag is needed).
        fovy: vertical field of view, degrees.
    """

    azimuth: float | None = None
    elevation: float = -10.0
    distance: float | None = None
    smoothing: float = 0.5
    fovy: float = 45.0

    def __post_init__(self) -> None:
        # (a NaN distance or a zero field of view gave an all-black video; a smoothing of 1e9 s asked for 1.75 TiB)
        for label, value, low, high, optional in (
            ("azimuth", self.azimuth, -1e6, 1e6, True), ("elevation", self.elevation, -90.0, 90.0, False),
            ("distance", self.distance, 0.0, 1e6, True), ("smoothing", self.smoothing, 0.0, 60.0, False),
            ("fovy", self.fovy, 0.0, 180.0, False),
        ):  # fmt: skip
            if value is None and optional:
                continue
            ok = is_real(value)
            x = float(value) if ok else math.nan  # type: ignore[arg-type]
            above = low < x if label in ("distance", "fovy") else low <= x  # (a distance or field of view of 0 is none)
            below = x < high if label == "fovy" else x <= high
            if not (ok and above and below):
                raise MjmotionError(f"View {label}={value!r}: expected a finite number from {low:g} to {high:g}")


@dataclass(frozen=True, eq=False)
class Scene:
    """Every character in one MuJoCo model, posed for each video frame.

    Attributes:
        model: the combined ``MjModel``.
        actors: the characters, in order.
        fps: video frame rate.
        qpos: ``(T, nq)`` model positions per video frame.
        offsets: ``(N, 3)`` metres, where each character was moved to lay them side by side.
        lookat: ``(T, 3)`` smoothed camera target per frame, metres.
        azimuth, elevation, distance: the camera (degrees, degrees, metres).
        fovy: vertical field of view, degrees.
        actor_bodies: per actor, the ids of its bodies (skeleton and props).
        trail_points: per actor, ``(T, 3)`` world positions of its trail effector, or ``None``.
        labels: per actor, its label.
    """

    model: mujoco.MjModel
    actors: tuple[Actor, ...]
    fps: float
    qpos: np.ndarray
    offsets: np.ndarray
    lookat: np.ndarray
    azimuth: float
    elevation: float
    distance: float
    fovy: float
    actor_bodies: tuple[np.ndarray, ...]
    trail_points: tuple[np.ndarray | None, ...] = field(default_factory=tuple)

    def __repr__(self) -> str:
        """``Scene(walk, jog, run; 121 frames at 30 fps)``: no arrays."""
        return f"Scene({', '.join(self.labels)}; {self.n_frames} frames at {self.fps:.6g} fps)"

    @property
    def n_frames(self) -> int:
        return int(self.qpos.shape[0])

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(a.label for a in self.actors)


@dataclass(frozen=True)
class CameraPose:
    """A pinhole camera as MuJoCo rendered it (the scene's OpenGL camera).

    Attributes:
        pos: ``(3,)`` eye position, metres. forward, up: ``(3,)`` unit axes.
        near: near-plane distance; left, right, bottom, top: frustum extent on the near plane.
        width, height: image size in pixels.
    """

    pos: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    near: float
    left: float
    right: float
    bottom: float
    top: float
    width: int
    height: int

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates of world points.

        Args:
            points: ``(N, 3)`` metres.
        Returns:
            ``(N, 2)`` pixel ``(column, row)`` (row 0 at the top, pixel centres at .5) and
            ``(N,)`` depth along ``forward`` (negative = behind the camera).
        """
        rel = np.atleast_2d(points) - self.pos
        right = np.cross(self.forward, self.up)
        z = rel @ self.forward
        x = self.near * (rel @ right) / z
        y = self.near * (rel @ self.up) / z
        col = (x - self.left) / (self.right - self.left) * self.width
        row = (self.top - y) / (self.top - self.bottom) * self.height
        return np.column_stack([col, row]), z


def travels(motion: Motion) -> bool:
    """Whether the clip goes somewhere (root moves ≥ 0.3 statures), rather than staying in place (a swing, a kick)."""
    d = motion.root_positions[-1, :2] - motion.root_positions[0, :2]
    return bool(np.linalg.norm(d) >= 0.3 * max(motion.skeleton.stature(), 0.3))


def travel_axes(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal unit vectors ``(forward, lateral)`` of a clip: where it travels, else where it faces."""
    d = motion.root_positions[-1, :2] - motion.root_positions[0, :2]
    if not travels(motion):
        # In place: the mean facing, +x of the root frame in the rest pose.
        d = rot.rotate(motion.rotations[:, 0], np.array([1.0, 0.0, 0.0]))[:, :2].mean(axis=0)
    n = float(np.linalg.norm(d))
    fwd = d / n if n > 1e-9 else np.array([1.0, 0.0])
    f3 = np.array([fwd[0], fwd[1], 0.0])
    return f3, np.array([-fwd[1], fwd[0], 0.0])


def layout_offsets(n: int, lateral: np.ndarray, spacing: float) -> np.ndarray:
    """``(n, 3)`` offsets putting ``n`` characters in a row along ``lateral``, centred, ``spacing`` apart."""
    return (np.arange(n) - (n - 1) / 2.0)[:, None] * spacing * np.asarray(lateral, dtype=float)[None, :]


def smooth_track(points: np.ndarray, fps: float, seconds: float) -> np.ndarray:
    """``(T, 3)`` zero-lag Gaussian smoothing of a camera target track (sigma = ``seconds``)."""
    from scipy.ndimage import gaussian_filter1d

    if seconds <= 0 or points.shape[0] < 2:
        return points.copy()
    return gaussian_filter1d(points, sigma=seconds * fps, axis=0, mode="nearest")


def build_scene(
    actors: Sequence[Actor],
    fps: float = 30.0,
    ball: mjcf.Ball | None = None,
    spacing: float = 1.2,
    view: View = View(),
    floor: float | None = 0.0,
) -> Scene:
    """Put ``actors`` side by side in one model and pose them for every video frame.

    Args:
        actors: the characters (at least one). Clips shorter than the longest hold their last pose.
        fps: video frame rate; each clip is resampled to it (slerp).
        ball: a ball placed at ``ball.position`` in each character's own frame (one per
            character, moved with it), or ``None``.
        spacing: metres between neighbouring characters, across the first clip's travel
            direction; 0 overlays them.
        view: camera settings.
        floor: the floor height (m, world z) of the clips, drawn at the checker floor (default
            z = 0, as captured); None: the first clip's stance floor, as ``mjmotion evaluate``
            detects it (:func:`mjmotion.feet.judged_floor`, docs/METRICS.md; a tilted stance floor is
            levelled, every character with it). Every character moves by the same amount, so one
            floating over another's floor still shows.
    """
    if isinstance(actors, Actor) or not all(isinstance(a, Actor) for a in actors):
        raise MjmotionError("render: expected a list of render.Actor (e.g. [Actor(walk, 'walk')])")
    if not actors:
        raise MjmotionError("render: no characters to render")
    if len(actors) > MAX_ACTORS:
        raise MjmotionError(f"render: {len(actors)} characters; at most {MAX_ACTORS} in one video")
    if not (np.isfinite(fps) and MIN_VIDEO_FPS <= fps <= MAX_VIDEO_FPS):
        raise MjmotionError(f"render: fps {fps}: expected a video frame rate from {MIN_VIDEO_FPS:g} to {MAX_VIDEO_FPS:g}")
    if not isinstance(view, View):
        raise MjmotionError(f"render: view: expected a render.View, got {view!r}")
    if not (np.isfinite(spacing) and spacing >= 0):
        raise MjmotionError(f"render: spacing must be a non-negative number of metres, got {spacing}")
    if floor is None:
        from .feet import judged_floor

        first = actors[0].motion
        judged = judged_floor(first) if first.skeleton.feet() and first.n_frames > 1 else None
        floor = judged.height if judged is not None else 0.0
        if judged is not None and not judged.level.flat:
            from dataclasses import replace

            from .feet import level_motion

            actors = [replace(a, motion=level_motion(judged.level, a.motion)) for a in actors]  # drawn levelled, as judged
            if ball is not None:  # given in the captured frame: levelled with the characters
                ball = replace(ball, position=_xyz(judged.level.positions(np.asarray(ball.position))))
    if not np.isfinite(floor):
        raise MjmotionError(f"render: floor must be a finite height in metres, got {floor}")
    motions = [a.motion.resample(fps) for a in actors]
    n = len(actors)
    forward, lateral = travel_axes(motions[0])
    offsets = layout_offsets(n, lateral, spacing)

    spec = mujoco.MjSpec()
    spec.modelname = "mjmotion_render"
    mjcf.add_world(spec)
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.45, 0.55, 0.65],
        rgb2=[0.12, 0.14, 0.17],
        width=256,
        height=1536,
    )
    spec.visual.global_.fovy = view.fovy
    spec.visual.rgba.haze = [0.12, 0.14, 0.17, 1.0]  # the horizon fades into the sky's lower colour
    compiled: list[mjcf.CompiledModel] = []
    from .feet import judged_model

    for i, actor in enumerate(actors):
        # The feet drawn on the judge's soles, so a foot it finds on its floor touches the floor drawn.
        c = judged_model(actor.motion, actor.props)
        compiled.append(c)
        child = c.spec.copy()  # attach moves elements; keep the compiled model's spec intact
        _paint(child, actor.color or PALETTE[i % len(PALETTE)], {p.name for p in actor.props})
        if actor.skin:
            _skin_instead_of_capsules(spec, child, c, actor, PALETTE[i % len(PALETTE)], _prefix(i))
        spec.worldbody.add_frame().attach_body(child.worldbody.first_body(), prefix=_prefix(i))
    ball_offsets = offsets if spacing > 0 else offsets[:1]
    if ball is not None:
        for k in range(len(ball_offsets)):
            body = spec.worldbody.add_body(name=f"ball{k}", pos=list(np.add(ball.position, ball_offsets[k]) - [0.0, 0.0, floor]))
            body.add_geom(
                name=f"ball{k}",
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                size=[ball.radius, 0, 0],
                rgba=list(BALL_RGBA),
                contype=0,
                conaffinity=0,
            )
    model = spec.compile()

    t = max(m.n_frames for m in motions)
    q = np.tile(model.qpos0, (t, 1))
    actor_bodies: list[np.ndarray] = []
    root_tracks: list[np.ndarray] = []
    for i, (c, m) in enumerate(zip(compiled, motions)):
        qi = kinematics.qpos(c, m)
        qi[:, 0:3] += offsets[i] - [0.0, 0.0, floor]  # the root's free joint is world position; the floor at z = 0
        idx = _qpos_map(c.model, model, _prefix(i))
        hold = np.minimum(np.arange(t), m.n_frames - 1)
        q[:, idx] = qi[hold]
        root_tracks.append(q[:, idx[0:3]])
        root_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, _prefix(i) + c.skeleton.names[0])
        actor_bodies.append(np.flatnonzero(model.body_rootid == root_id))

    roots = np.stack(root_tracks)  # (N, T, 3)
    stature = float(np.mean([max(m.skeleton.stature(), 0.3) for m in motions]))
    centre = roots.mean(axis=0)
    centre[:, 2] = 0.5 * stature  # a steady height: no bobbing with the pelvis
    lookat = smooth_track(centre, fps, view.smoothing)
    heading = np.degrees(np.arctan2(forward[1], forward[0]))
    # In place: face-on (the row spreads fully across the image). Travelling: one character from
    # the side; a row three-quarter front, so neither the row nor the walk hides anyone.
    turn = 180.0 if not travels(motions[0]) else 90.0 if n == 1 else 145.0
    azimuth = view.azimuth if view.azimuth is not None else heading + turn
    # A swung club rarely points straight up: 60% of its length above the head is enough room.
    reach = stature + 0.6 * max((p.length for a in actors for p in a.props), default=0.0)
    distance = view.distance if view.distance is not None else _auto_distance(roots, lookat, reach, view.fovy)
    trails = tuple(_trail_points(model, q, _prefix(i), a.trail, c) if a.trail else None for i, (a, c) in enumerate(zip(actors, compiled)))
    return Scene(
        model=model,
        actors=tuple(actors),
        fps=float(fps),
        qpos=q,
        offsets=offsets,
        lookat=lookat,
        azimuth=float(azimuth),
        elevation=float(view.elevation),
        distance=float(distance),
        fovy=float(view.fovy),
        actor_bodies=tuple(actor_bodies),
        trail_points=trails,
    )


def _prefix(i: int) -> str:
    return f"c{i}/"


def _paint(spec: mujoco.MjSpec, color: Sequence[float], prop_names: set[str]) -> None:
    """Colour a character's geoms: bones ``color``, feet a darker shade, props untouched."""
    rgb = np.clip(np.asarray(color, dtype=float), 0.0, 1.0)
    for g in spec.geoms:
        if g.name in prop_names:
            continue
        shade = 0.8 if g.name.startswith(("foot/", "toe/")) else 1.0
        g.rgba = [*(rgb * shade), 1.0]


def _skin_instead_of_capsules(
    spec: mujoco.MjSpec, child: mujoco.MjSpec, compiled: mjcf.CompiledModel, actor: Actor, default: Sequence[float], prefix: str
) -> None:
    """Hide ``child``'s body geoms and give ``spec`` the character's skin, bound to the prefixed bodies."""
    from . import skin

    s = skin.build(compiled, reference=actor.motion)
    props = {p.name for p in actor.props}
    for g in child.geoms:
        if g.name not in props:
            g.group = skin.HIDDEN_GROUP
    rgb = np.clip(np.asarray(actor.color or default, dtype=float), 0.0, 1.0)
    mjcf.add_skin(spec, **skin.skin_arguments(s, prefix=prefix, name=f"{prefix}skin", rgba=(*rgb, 1.0)))  # type: ignore[arg-type]


def _qpos_map(child: mujoco.MjModel, combined: mujoco.MjModel, prefix: str) -> np.ndarray:
    """``(child.nq,)`` index of each of the child model's ``qpos`` entries in the combined model."""
    idx = np.empty(child.nq, dtype=int)
    sizes = {int(mujoco.mjtJoint.mjJNT_FREE): 7, int(mujoco.mjtJoint.mjJNT_BALL): 4}
    for j in range(child.njnt):
        name = mujoco.mj_id2name(child, mujoco.mjtObj.mjOBJ_JOINT, j)
        k = mujoco.mj_name2id(combined, mujoco.mjtObj.mjOBJ_JOINT, prefix + name)
        size = sizes.get(int(child.jnt_type[j]), 1)
        a, b = int(child.jnt_qposadr[j]), int(combined.jnt_qposadr[k])
        idx[a : a + size] = np.arange(b, b + size)
    return idx


def _auto_distance(roots: np.ndarray, lookat: np.ndarray, stature: float, fovy: float) -> float:
    """A distance that keeps the whole row and the character's height in a 16:9 frame.

    ``roots``: ``(N, T, 3)``; ``lookat``: ``(T, 3)``. A character up to ``spread`` nearer the
    camera than the look-at point looks bigger, so the height fit starts that much further back.
    """
    spread = float(np.max(np.linalg.norm(roots[:, :, :2] - lookat[None, :, :2], axis=2)))
    tan_v = np.tan(np.radians(fovy) / 2)
    need_h = 1.5 * stature / (2 * tan_v) + spread  # the full height with margins
    need_w = (2 * spread + 0.8 * stature) / (2 * tan_v * 16 / 9)
    return float(max(need_h, need_w, 2.0))


def _trail_points(model: mujoco.MjModel, q: np.ndarray, prefix: str, name: str, c: mjcf.CompiledModel) -> np.ndarray:
    """``(T, 3)`` world positions of the site or joint body ``name`` of one character."""
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, prefix + name)
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, prefix + name)
    if sid < 0 and bid < 0:
        raise MjmotionError(
            f"--trail {name}: no site or joint named {name!r}; sites are {', '.join(c.site_names[:8])}…, joints {', '.join(c.skeleton.names[:8])}…"
        )
    d = mujoco.MjData(model)
    out = np.empty((q.shape[0], 3))
    for i in range(q.shape[0]):
        d.qpos[:] = q[i]
        mujoco.mj_kinematics(model, d)
        out[i] = d.site_xpos[sid] if sid >= 0 else d.xpos[bid]
    return out


def open_gl_context(width: int, height: int, backends: Sequence[str] | None = None):
    """An offscreen OpenGL context (made current) from the first backend that works.

    ``backends`` default: ``MUJOCO_GL`` if it names ``egl`` or ``osmesa``, then the others of
    :data:`OFFSCREEN_BACKENDS`. PyOpenGL binds one platform per process, so once one backend has
    loaded it another cannot be tried here; a fresh process is then asked whether it would work,
    and the error says which ``MUJOCO_GL`` to run with. Raises :class:`MjmotionError` listing why
    each backend failed.
    """
    if backends is None:
        env = os.environ.get("MUJOCO_GL", "").lower().strip()
        backends = ([env] if env in OFFSCREEN_BACKENDS else []) + [b for b in OFFSCREEN_BACKENDS if b != env]
    failures, locked = [], []
    for name in backends:
        saved = os.environ.get("PYOPENGL_PLATFORM")
        try:
            module = importlib.import_module(f"mujoco.{name}")
            ctx = module.GLContext(width, height)
            ctx.make_current()
            return ctx
        except Exception as exc:
            text = str(exc).splitlines()[0] if str(exc) else ""
            failures.append(f"{name}: {type(exc).__name__}: {text}")
            if "PYOPENGL_PLATFORM" in text:
                locked.append(name)
            if "OpenGL" not in sys.modules:  # PyOpenGL not loaded yet: the next backend may still set its platform
                if saved is None:
                    os.environ.pop("PYOPENGL_PLATFORM", None)
                else:
                    os.environ["PYOPENGL_PLATFORM"] = saved
    hint = next((f" {b} works in a fresh process: run with MUJOCO_GL={b}." for b in locked if _backend_works(b)), "")
    raise MjmotionError(
        "no offscreen OpenGL backend works ("
        + "; ".join(failures)
        + ")."
        + hint
        + (" Otherwise install" if hint else " Install")
        + " Mesa's EGL (libegl1, libegl-mesa0) or OSMesa (libosmesa6)."
    )


def _backend_works(name: str) -> bool:
    """Whether a fresh Python process can open a ``name`` (egl/osmesa) context."""
    import subprocess

    env = {k: v for k, v in os.environ.items() if k != "PYOPENGL_PLATFORM"}
    env["MUJOCO_GL"] = name
    code = f"import mujoco.{name} as b; c = b.GLContext(16, 16); c.make_current(); c.free()"
    try:
        return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, timeout=60).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


class Renderer:
    """Offscreen frames of a :class:`Scene` (an OpenGL context, a ``MjvScene``, a ``MjrContext``).

    Use as a context manager, or call :meth:`close`.

    Args:
        scene: what to draw.
        width, height: image size, pixels.
        labels: draw each character's label above its head.
        contact_shadows: a soft shadow on the floor under every body part, fading with its
            height (light from straight above): shows where the feet meet the floor at almost
            no cost. ``None`` (default): drawn unless ``shadows`` is on.
        shadows, reflections: MuJoCo's shadow-mapped key light and the floor reflection; in
            software GL (Mesa llvmpipe) each about doubles a frame's time
            (``benchmarks/bench_render.py``).
        samples: multisampling (MSAA) samples; 0 is fastest in software GL.
        shadow_size: shadow map size, pixels.
        trail_seconds: length of the effector ghost trails.
    """

    def __init__(
        self,
        scene: Scene,
        width: int = 960,
        height: int = 540,
        *,
        labels: bool = True,
        contact_shadows: bool | None = None,
        shadows: bool = False,
        reflections: bool = False,
        samples: int = 0,
        shadow_size: int = 1024,
        trail_seconds: float = 0.6,
    ) -> None:
        for label, value in (("width", width), ("height", height), ("samples", samples), ("shadow_size", shadow_size)):
            if not is_whole(value):
                raise MjmotionError(f"render: {label} {value!r}: expected a whole number")
        if width < 16 or height < 16 or width > 4096 or height > 4096:
            raise MjmotionError(f"render: image size {width}x{height} out of range (16–4096 pixels)")
        if not 0 <= samples <= 16 or not 16 <= shadow_size <= 8192:
            raise MjmotionError(f"render: samples {samples} (expected 0 to 16) or shadow_size {shadow_size} (16 to 8192) out of range")
        if not (is_real(trail_seconds) and 0 <= trail_seconds <= 60):
            raise MjmotionError(f"render: trail_seconds {trail_seconds!r}: expected a number of seconds from 0 to 60")
        self.scene = scene
        self.width, self.height = int(width), int(height)
        self.draw_labels = labels
        self.trail_frames = max(int(round(trail_seconds * scene.fps)), 0)
        model = scene.model
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, self.width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, self.height)
        # Software GL (Mesa llvmpipe) spends most of a frame on MSAA and the shadow map: measured
        # 7 → 25 frames/s at 640×360 going from 4 samples / 4096² to 0 / 1024².
        model.vis.quality.offsamples = int(samples)
        model.vis.quality.shadowsize = int(shadow_size)
        self._gl = open_gl_context(self.width, self.height)
        self._mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        n_trail = sum(1 for p in scene.trail_points if p is not None) * (self.trail_frames + 1)
        #: geoms that cast a contact shadow: every character's and prop's (not the floor's)
        contact = not shadows if contact_shadows is None else contact_shadows
        self._casters = np.flatnonzero(model.geom_bodyid > 0) if contact else np.zeros(0, dtype=int)
        self._scn = mujoco.MjvScene(model, maxgeom=model.ngeom + n_trail + len(self._casters) + 100)
        self._scn.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
        self._scn.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = reflections
        #: MuJoCo's visibility options (``geomgroup``, ``sitegroup``, ``flags``), applied to every frame.
        self.option = mujoco.MjvOption()
        self._cam = mujoco.MjvCamera()
        self._cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._data = mujoco.MjData(model)
        self._rect = mujoco.MjrRect(0, 0, self.width, self.height)
        self._rgb = np.empty((self.height, self.width, 3), dtype=np.uint8)
        self._font: Any = None  # a PIL font, loaded with the first label
        #: the camera of the last rendered frame (for projecting world points to pixels).
        self.camera: CameraPose | None = None

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._gl is not None:
            self._gl.make_current()
            self._mjr.free()
            self._gl.free()
            self._gl = None

    def pose(self, i: int) -> mujoco.MjData:
        """Set the model to video frame ``i`` (kinematics only) and return its ``MjData``."""
        self._data.qpos[:] = self.scene.qpos[i]
        mujoco.mj_kinematics(self.scene.model, self._data)
        return self._data

    def frame(self, i: int) -> np.ndarray:
        """``(H, W, 3) uint8`` RGB image of video frame ``i``; :attr:`camera` is set to its camera."""
        if self._gl is None:
            raise MjmotionError("render: the renderer is closed")
        s = self.scene
        d = self.pose(i)
        cam = self._cam
        cam.lookat[:] = s.lookat[i]
        cam.azimuth, cam.elevation, cam.distance = s.azimuth, s.elevation, s.distance
        mujoco.mjv_updateScene(s.model, d, self.option, None, cam, mujoco.mjtCatBit.mjCAT_ALL, self._scn)
        self._add_contact_shadows(d)
        self._add_trails(i)
        self._gl.make_current()
        mujoco.mjr_render(self._rect, self._scn, self._mjr)
        mujoco.mjr_readPixels(self._rgb, None, self._rect, self._mjr)
        self.camera = self._camera_pose()
        img = np.flipud(self._rgb).copy()  # OpenGL rows start at the bottom
        if self.draw_labels and any(s.labels):
            img = self._draw_labels(img, d)
        return img

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[np.ndarray]:
        for i in range(self.scene.n_frames) if indices is None else indices:
            yield self.frame(i)

    def _camera_pose(self) -> CameraPose:
        c = mujoco.mjv_averageCamera(self._scn.camera[0], self._scn.camera[1])
        half = c.frustum_width / 2 if c.frustum_width > 0 else 0.5 * (c.frustum_top - c.frustum_bottom) * self.width / self.height
        return CameraPose(
            pos=np.array(c.pos, dtype=float),
            forward=np.array(c.forward, dtype=float),
            up=np.array(c.up, dtype=float),
            near=float(c.frustum_near),
            left=float(c.frustum_center - half),
            right=float(c.frustum_center + half),
            bottom=float(c.frustum_bottom),
            top=float(c.frustum_top),
            width=self.width,
            height=self.height,
        )

    def _add_contact_shadows(self, d: mujoco.MjData) -> None:
        """A flat, translucent ellipse on the floor under each caster geom (added to the MjvScene).

        Each geom is taken as the ellipsoid through its extent (capsules: radius and half-length
        plus radius); its vertical projection is the ellipse, darker the nearer the geom's lowest
        point is to the floor (none from :data:`CONTACT_SHADOW_HEIGHT` up).
        """
        g = self._casters
        if len(g) == 0:
            return
        model = self.scene.model
        size = model.geom_size[g]
        kind = model.geom_type[g]
        semi = size.copy()  # semi-axes along the geom's own x, y, z
        cap = (kind == mujoco.mjtGeom.mjGEOM_CAPSULE) | (kind == mujoco.mjtGeom.mjGEOM_CYLINDER)
        semi[cap] = np.column_stack([size[cap, 0], size[cap, 0], size[cap, 1] + size[cap, 0]])
        sph = kind == mujoco.mjtGeom.mjGEOM_SPHERE
        semi[sph] = size[sph, :1]
        axes = d.geom_xmat[g].reshape(-1, 3, 3) * semi[:, None, :]  # (G, 3, 3) columns: semi-axes in the world
        shape = axes @ axes.transpose(0, 2, 1)  # the ellipsoid's shape matrix; its xy block is the shadow's
        a, b, c = shape[:, 0, 0], shape[:, 0, 1], shape[:, 1, 1]
        half, diff = 0.5 * (a + c), np.hypot(0.5 * (a - c), b)
        major, minor = np.sqrt(half + diff), np.sqrt(np.maximum(half - diff, 0.0))
        yaw = 0.5 * np.arctan2(2 * b, a - c)
        low = d.geom_xpos[g, 2] - np.sqrt(shape[:, 2, 2])
        alpha = CONTACT_SHADOW_ALPHA * np.clip(1.0 - low / CONTACT_SHADOW_HEIGHT, 0.0, 1.0)
        scn = self._scn
        for k in np.flatnonzero((alpha > 0.01) & (major > 1e-4)):
            if scn.ngeom >= scn.maxgeom:
                return
            cz, sz = np.cos(yaw[k]), np.sin(yaw[k])
            geom = scn.geoms[scn.ngeom]
            mujoco.mjv_initGeom(
                geom,
                mujoco.mjtGeom.mjGEOM_ELLIPSOID,
                np.array([major[k], max(minor[k], 0.2 * major[k]), 5e-4]),
                np.array([d.geom_xpos[g[k], 0], d.geom_xpos[g[k], 1], 2e-3]),
                np.array([cz, -sz, 0.0, sz, cz, 0.0, 0.0, 0.0, 1.0]),
                np.array([0.0, 0.0, 0.0, alpha[k]], dtype=np.float32),
            )
            geom.category = mujoco.mjtCatBit.mjCAT_DECOR
            scn.ngeom += 1

    def _add_trails(self, i: int) -> None:
        """Fading spheres at the effector's last ``trail_frames`` positions (added to the MjvScene)."""
        if self.trail_frames == 0:
            return
        scn = self._scn
        eye = np.eye(3).ravel()
        for a, (actor, pts) in enumerate(zip(self.scene.actors, self.scene.trail_points)):
            if pts is None:
                continue
            rgb = np.asarray(actor.color or PALETTE[a % len(PALETTE)])
            lo = max(0, i - self.trail_frames)
            for k in range(lo, i):
                if scn.ngeom >= scn.maxgeom:
                    return
                age = (i - k) / (self.trail_frames + 1)
                g = scn.geoms[scn.ngeom]
                mujoco.mjv_initGeom(
                    g,
                    mujoco.mjtGeom.mjGEOM_SPHERE,
                    np.array([0.025 * (1.0 - 0.5 * age), 0, 0]),
                    pts[k],
                    eye,
                    np.array([*(0.4 + 0.6 * rgb), 0.9 * (1.0 - 0.8 * age)], dtype=np.float32),
                )
                g.category = mujoco.mjtCatBit.mjCAT_DECOR
                scn.ngeom += 1

    def _draw_labels(self, img: np.ndarray, d: mujoco.MjData) -> np.ndarray:
        """Each character's label above its head, in its colour, with a dark outline."""
        from PIL import Image, ImageDraw, ImageFont

        if self._font is None:
            self._font = ImageFont.load_default(size=max(12, self.height // 24))
        s, cam = self.scene, self.camera
        assert cam is not None
        pil = Image.fromarray(img)
        draw = ImageDraw.Draw(pil)
        for a, (actor, bodies) in enumerate(zip(s.actors, s.actor_bodies)):
            if not actor.label:
                continue
            xpos = d.xpos[bodies]
            top = xpos[int(np.argmax(xpos[:, 2]))] + np.array([0.0, 0.0, 0.25])
            (px, z) = cam.project(top[None])
            if z[0] <= 0:
                continue
            rgb = np.asarray(actor.color or PALETTE[a % len(PALETTE)])
            fill = tuple(int(v) for v in np.clip(rgb * 255 * 1.1, 0, 255))
            draw.text(
                (float(px[0, 0]), float(px[0, 1])),
                actor.label,
                fill=fill,
                font=self._font,
                anchor="mb",
                stroke_width=2,
                stroke_fill=(20, 20, 20),
            )
        return np.asarray(pil)


def write_video(
    frames: Iterable[np.ndarray],
    path: str | os.PathLike[str],
    fps: float,
    size: tuple[int, int],
    progress: Callable[[int], None] | None = None,
) -> Path:
    """Encode ``frames`` (each ``(H, W, 3) uint8``) to ``path`` atomically: ``.mp4`` (H.264) or ``.gif``.

    Args:
        size: ``(width, height)`` pixels; MP4 needs both even (yuv420p).
        progress: called with 1 after each frame.
    """
    out = Path(path)
    suffix = out.suffix.lower()
    width, height = size
    if suffix not in (".mp4", ".gif"):
        raise MjmotionError(f"{out}: unknown video format {suffix or '(none)'}; expected .mp4 or .gif")
    if suffix == ".mp4" and (width % 2 or height % 2):
        raise MjmotionError(f"{out}: MP4 (yuv420p) needs an even width and height, got {width}x{height}")
    with atomic_path(out) as tmp:
        try:
            if suffix == ".mp4":
                _write_mp4(frames, tmp, fps, size, progress)
            else:
                _write_gif(frames, tmp, fps, progress)
        except MjmotionError as e:  # name the output, not its temporary file
            raise MjmotionError(f"{out}: {str(e).replace(f'{tmp}: ', '')}") from None
        check_video_file(tmp, suffix, shown=out)  # a full disk truncates quietly: never "wrote" a broken video
    return out


def check_video_file(path: str | os.PathLike[str], suffix: str, shown: str | os.PathLike[str] | None = None) -> None:
    """Refuse a video file that is not complete: an MP4 whose top-level boxes do not add up to
    the file (or lack ``ftyp``, ``mdat`` or ``moov``, which ffmpeg writes last), a GIF without
    its header or trailer byte."""
    name = shown or path
    data_size = os.path.getsize(path)
    with open(path, "rb") as fh:
        if suffix == ".gif":
            head = fh.read(6)
            fh.seek(max(0, data_size - 1))
            if head not in (b"GIF87a", b"GIF89a") or fh.read(1) != b";":
                raise MjmotionError(f"{name}: the GIF written is incomplete ({data_size} bytes; a full disk?)")
            return
        kinds, pos = set(), 0
        while pos < data_size:
            fh.seek(pos)
            head = fh.read(16)
            if len(head) < 8:
                break
            size, kind = int.from_bytes(head[:4], "big"), head[4:8]
            if size == 1 and len(head) == 16:
                size = int.from_bytes(head[8:16], "big")
            elif size == 0:
                size = data_size - pos
            if size < 8:
                break
            kinds.add(kind)
            pos += size
    if pos != data_size or not {b"ftyp", b"mdat", b"moov"} <= kinds:
        raise MjmotionError(
            f"{name}: the MP4 written is incomplete ({data_size} bytes, boxes {sorted(k.decode('latin-1') for k in kinds)}; a full disk?)"
        )


def _write_mp4(frames: Iterable[np.ndarray], path: Path, fps: float, size: tuple[int, int], progress) -> None:
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(
        str(path),
        size,
        fps=fps,
        codec="libx264",
        pix_fmt_in="rgb24",
        pix_fmt_out="yuv420p",
        quality=7,
        macro_block_size=2,
        ffmpeg_log_level="error",
    )
    writer.send(None)
    try:
        for img in frames:
            try:
                writer.send(np.ascontiguousarray(img))
            except OSError as e:  # ffmpeg stopped (a full disk, a write error): its message, on one line
                raise MjmotionError(f"the video encoder (ffmpeg) failed: {str(e).splitlines()[0]}") from None
            if progress:
                progress(1)
    finally:
        writer.close()


def _write_gif(frames: Iterable[np.ndarray], path: Path, fps: float, progress) -> None:
    from PIL import Image

    images = []
    for img in frames:
        # One adaptive palette per frame: the scene's colours change little, octree is fast.
        images.append(Image.fromarray(img).quantize(colors=256, method=Image.Quantize.FASTOCTREE))
        if progress:
            progress(1)
    if not images:
        raise MjmotionError(f"{path}: no frames to write")
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:], duration=int(round(1000 / fps)), loop=0)


def render(
    scene: Scene,
    path: str | os.PathLike[str],
    width: int = 960,
    height: int = 540,
    frames: slice | None = None,
    progress: bool = True,
    **renderer_options: object,
) -> Path:
    """Render ``scene`` (video frames ``frames``, default all) to an MP4 or GIF at ``path``, replacing a file
    there (as :func:`mjmotion.bvh.write` does; the verbs refuse that without ``--force``); ``progress``: a
    frame bar on standard error when it is a terminal (never in a pipe or a log)."""
    indices = range(scene.n_frames)[frames or slice(None)]
    if len(indices) == 0:
        raise MjmotionError("render: no frames selected")
    try:
        progress = progress and sys.stderr.isatty()
    except (AttributeError, ValueError):  # (a replaced or closed stream)
        progress = False
    with Renderer(scene, width, height, **renderer_options) as r:  # type: ignore[arg-type]
        if not progress:
            return write_video(r.frames(indices), path, scene.fps, (width, height))
        from tqdm import tqdm

        with tqdm(total=len(indices), unit="frame", desc=f"render {Path(path).name}", file=sys.stderr) as bar:
            return write_video(r.frames(indices), path, scene.fps, (width, height), bar.update)


def _xyz(p: np.ndarray) -> tuple[float, float, float]:
    """A point ``(3,)`` as a tuple of three floats."""
    return (float(p[0]), float(p[1]), float(p[2]))
