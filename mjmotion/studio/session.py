"""One browser page: its own clips, characters, playhead, live stream, worker and GUI.

Everything a page shows is built on that page's ``client.gui`` / ``client.scene``, so two pages
never share state. Three threads touch a session: viser's callback pool (GUI events), the
page's worker (:mod:`.jobs`) and its ticker (playback at :data:`TICK_HZ`); :attr:`Session.lock`
guards the cast of characters and the playhead.
"""

from __future__ import annotations

import re
import threading
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from .. import kinematics, mjcf
from .. import rotations as rot
from ..errors import AlreadyExistsError, MjmotionError, OutputExistsError
from ..feet import judged_model
from ..skeleton import Motion
from . import engine
from .clips import MAX_CLIP_BYTES, ClipLibrary
from .jobs import Job, Worker
from .player import SPEEDS, Player
from .scene import DRAW_MODES, PALETTE, Kinematics, Pose, PrimitiveDrawing
from .skinned import register_skin_modes
from .tabs import clamp

register_skin_modes()  # the Character menu: capsules, skin (LBS), skin (DQS), both

if TYPE_CHECKING:
    from .live import StreamFrame


class Host(Protocol):
    """What a session needs of the server that opened it (:class:`~.app.Studio`): its clips and output folder."""

    library: ClipLibrary
    out_dir: Path


#: Playback ticks per second (each tick draws the current frame; the stream may advance several).
TICK_HZ = 30.0
#: Sideways spacing (metres) of characters shown side by side.
SPACING = 1.4
TAB_NAMES = ("Blend", "Stream", "Hit", "Vary", "Evaluate")
# A page may close between a tick's check and its draw; viser then warns that the update is dropped.
warnings.filterwarnings("ignore", message="Queued a .* on a closed connection")
#: Seconds of the live stream kept for saving.
RECORD_S = 60.0


@dataclass(eq=False)
class Actor:
    """A character on stage: its drawing and either precomputed poses (a clip) or live poses (the stream)."""

    label: str
    motion: Motion | None
    props: tuple[mjcf.Prop, ...]
    compiled: mjcf.CompiledModel
    kin: Kinematics
    drawing: Any
    poses: list[Pose] | None
    reference: Motion | None = None  # a clip of the character (the skin's bind pose needs one for some rigs)


class Session:
    """The state and GUI of one page."""

    def __init__(self, studio: Host, client: Any):
        self.studio = studio
        self.client = client
        self.library: ClipLibrary = studio.library
        self.lock = threading.RLock()
        self.cast: list[Actor] = []
        self.player = Player(1, 60.0)
        self.live: Any = None  # the Stream tab's LiveStream while it plays
        self.live_frame: StreamFrame | None = None
        self.live_record: list[StreamFrame] = []
        self.last_pose: Pose | None = None
        self.draw_mode = next(iter(DRAW_MODES))
        self._listeners: list[Any] = []
        self._closed = threading.Event()
        self._stream_debt = 0.0
        self._follow_xy: np.ndarray | None = None
        self._readout_at = 0.0
        self._dirty = True  # draw on the next tick even if the frame did not change
        self.worker = Worker(self._on_progress, self._on_error)
        self._build_gui()
        self.scene_floor = client.scene.add_grid("/floor", width=40.0, height=40.0, cell_size=0.5, section_size=2.0, position=(0.0, 0.0, 0.0))
        from .tabs.build import build_tabs

        self.tabs = build_tabs(self, self._tab_group)
        self._ticker = threading.Thread(target=self._tick_loop, name="studio-ticker", daemon=True)
        self._ticker.start()

    # --- GUI ------------------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.client.gui
        self.status = gui.add_markdown("Pick a tab; clips: " + ", ".join(self.library.names()[:8]) + ("…" if len(self.library.names()) > 8 else ""))
        self.progress = gui.add_progress_bar(0.0, visible=False, animated=True)
        self.cancel_button = gui.add_button("Cancel", visible=False, color="red")
        self.cancel_button.on_click(lambda e: self.worker.cancel())
        self.character = gui.add_dropdown(
            "Character",
            tuple(DRAW_MODES),
            initial_value=self.draw_mode,
            hint="how every tab draws its characters: capsules, skin (LBS or DQS), or both",
        )
        self._tab_group = gui.add_tab_group()
        with gui.add_folder("Playback"):
            self.play_button = gui.add_button("Pause")
            self.step_buttons = gui.add_button_group("Step", ("|<", "<", ">", ">|"))
            self.timeline = gui.add_slider("Frame", 0, 1, 1, 0)
            self.speed = gui.add_slider("Speed", SPEEDS[0], SPEEDS[1], 0.05, 1.0)
            self.loop = gui.add_checkbox("Loop", True)
            self.follow = gui.add_checkbox("Follow camera", True)
        with gui.add_folder("Files", expand_by_default=False):
            self.upload = gui.add_upload_button("Load BVH", mime_type="*/*", hint=f"a .bvh file (validated; at most {MAX_CLIP_BYTES // 2**20} MiB)")
            self.save_name = gui.add_text("Save as", "result.bvh")
            self.save_button = gui.add_button("Save shown clip")
        self.play_button.on_click(lambda e: self.toggle_play())
        self.step_buttons.on_click(lambda e: self._step(self.step_buttons.value))
        self.timeline.on_update(self._on_timeline)
        self.speed.on_update(lambda e: self._set_player(speed=clamp(self.speed)))
        self.loop.on_update(lambda e: self._set_player(loop=bool(self.loop.value)))
        self.upload.on_upload(self._on_upload)
        self.save_button.on_click(lambda e: self.save(self.save_name.value))
        self.character.on_update(lambda e: self.set_draw_mode(self.character.value) if self.character.value != self.draw_mode else None)

    def set_status(self, text: str, error: bool = False) -> None:
        self.status.content = f"**error:** {text}" if error else text
        if error:
            self.client.add_notification("error", text, color="red", auto_close_seconds=8.0)

    def _on_progress(self, job: Job, fraction: float, text: str) -> None:
        running = fraction < 1.0
        self.progress.visible = running
        self.cancel_button.visible = running
        self.progress.value = 100.0 * fraction
        if running and text:
            self.status.content = f"{job.label}: {text}…"

    def _on_error(self, job: Job, message: str) -> None:
        self.set_status(f"{job.label}: {message}", error=True)

    def submit(self, kind: str, run: Any, done: Any, label: str = "", keep_running: bool = False) -> Job:
        """Run ``run(progress)`` on the page's worker and ``done(result)`` after it (:meth:`.jobs.Worker.submit`)."""
        return self.worker.submit(kind, run, done, label, keep_running)

    def on_library(self, callback: Any) -> None:
        """Call ``callback(names)`` whenever the page's clip list changes (tabs refresh their menus)."""
        self._listeners.append(callback)

    def _on_upload(self, event: Any) -> None:
        f = self.upload.value
        try:
            self.library, clip = self.library.with_upload(f.name, f.content)
        except MjmotionError as e:
            self.set_status(str(e), error=True)
            return
        for cb in self._listeners:
            cb(self.library.names())
        skipped = f" (its first {clip.skipped} frames, a T-pose or transition, left out)" if clip.skipped else ""
        self.set_status(
            f"loaded {clip.name}: {clip.motion.n_frames} frames at {clip.motion.fps:g} fps, {clip.motion.skeleton.n_joints} joints{skipped}"
        )

    # --- characters -----------------------------------------------------------------------------
    def clear_cast(self) -> None:
        with self.lock:
            for a in self.cast:
                a.drawing.remove()
            self.cast = []
            self.live = None
            self.live_frame = None
            self.live_record = []

    def add_actor(self, label: str, skeleton_motion: Motion, props: tuple[mjcf.Prop, ...] = (), precompute: bool = True) -> Actor:
        """A character for ``skeleton_motion`` (its poses precomputed unless it is a live stream)."""
        with self.lock:
            k = len(self.cast)
            # A clip's feet on the soles the judge finds (the grid is at its floor), as render draws them;
            # the stream's on the plain boxes its gaits are planned with (the grid at z = 0).
            compiled = judged_model(skeleton_motion, props) if precompute else mjcf.compile(skeleton_motion.skeleton, props)
            kin = Kinematics(compiled)
            poses = kin.poses(kinematics.qpos(compiled, skeleton_motion)) if precompute else None
            drawing = self._drawing(k, compiled, skeleton_motion)
            actor = Actor(label, skeleton_motion if precompute else None, props, compiled, kin, drawing, poses, skeleton_motion)
            self.cast.append(actor)
            return actor

    def show(self, motions: list[tuple[str, Motion, tuple[mjcf.Prop, ...]]], main: int = 0, keep_marks: bool = False) -> None:
        """Show clips side by side (the first at its place, the others ``SPACING`` apart) on one timeline;
        the Hit tab's ball, gizmo and flight go unless ``keep_marks``."""
        with self.lock:
            if not keep_marks and "Hit" in getattr(self, "tabs", {}):
                self.tabs["Hit"].clear_marks()
            if "Evaluate" in getattr(self, "tabs", {}):
                self.tabs["Evaluate"].clear()  # its report and marks were of the clip shown before
            placed = [
                (label, m if not k else m.replace(root_positions=m.root_positions + np.array([0.0, SPACING * k, 0.0])), props)
                for k, (label, m, props) in enumerate(motions)
            ]
            if self._same_cast(placed):
                # the same characters in new poses (a Hit tab drag): new actors on the same models and drawings
                self.cast = [
                    replace(a, label=label, motion=m, reference=m, poses=a.kin.poses(kinematics.qpos(a.compiled, m)))
                    for a, (label, m, _) in zip(self.cast, placed)
                ]
            else:
                self.clear_cast()
                for label, m, props in placed:
                    self.add_actor(label, m, props)
                # The grid at the main clip's floor as the judge finds it (a daz clip's stands 3 cm up).
                self.scene_floor.position = (0.0, 0.0, engine.floor_height(motions[main][1]))
            n = max(m.n_frames for _, m, _ in motions)
            self.player = Player(n, motions[main][1].fps, speed=clamp(self.speed), loop=bool(self.loop.value))
            self.timeline.max = max(n - 1, 1)
            self.timeline.value = 0
            self.play_button.label = "Pause"
            self._draw(0)
            self._dirty = True

    def _same_cast(self, placed: list[tuple[str, Motion, tuple[mjcf.Prop, ...]]]) -> bool:
        """Whether the clips on stage are the same characters (skeleton objects and props) as ``placed``."""
        return (
            self.live is None
            and len(self.cast) == len(placed)
            and all(a.motion is not None and a.motion.skeleton is m.skeleton and a.props == props for a, (_, m, props) in zip(self.cast, placed))
        )

    @property
    def shown(self) -> Actor | None:
        """The main character on screen (what Evaluate measures and Save writes)."""
        with self.lock:
            return self.cast[0] if self.cast else None

    def _drawing(self, k: int, compiled: mjcf.CompiledModel, reference: Motion | None) -> Any:
        """Character ``k`` drawn in the current mode; capsules (and a note) if its skeleton cannot carry a skin."""
        try:
            return DRAW_MODES[self.draw_mode](self.client.scene, f"/cast/{k}", compiled, PALETTE[k % len(PALETTE)], reference)
        except MjmotionError as e:
            self.set_status(f"{self.draw_mode}: {e}; drawn as capsules", error=True)
            return PrimitiveDrawing(self.client.scene, f"/cast/{k}", compiled, PALETTE[k % len(PALETTE)])

    def set_draw_mode(self, mode: str) -> None:
        """Draw every character (now and from now on) in ``mode`` (:data:`~.scene.DRAW_MODES`); the skins are made on the worker."""
        if mode not in DRAW_MODES:
            raise MjmotionError(f"unknown character mode {mode!r}; expected one of {', '.join(DRAW_MODES)}")
        with self.lock:
            self.draw_mode = mode
            cast = [(a.compiled, a.reference) for a in self.cast]
        if self.character.value != mode:
            self.character.value = mode  # chosen in code (tests, screenshots): the menu shows it

        def job(progress: Any) -> str:
            if mode != "capsules":
                from ..skin import build

                for i, (compiled, reference) in enumerate(cast):
                    progress(i / max(len(cast), 1), "making the skin")
                    try:
                        build(compiled, reference=reference)  # cached: the swap below reuses it
                    except MjmotionError:
                        pass  # the swap draws this one as capsules and says why
            return mode

        self.submit("draw", job, self._redraw, label="Character")

    def _redraw(self, mode: str) -> None:
        with self.lock:
            if mode != self.draw_mode:
                return  # a newer choice is on its way
            for k, a in enumerate(self.cast):
                a.drawing.remove()
                a.drawing = self._drawing(k, a.compiled, a.reference)
            self._dirty = True
            self._draw(self.player.index)
            self.set_status(f"characters drawn as {mode}")

    def start_live(self, live: Any, props: tuple[mjcf.Prop, ...] = ()) -> None:
        """Play a :class:`~mjmotion.studio.live.LiveStream` (the Stream tab)."""
        with self.lock:
            if "Hit" in getattr(self, "tabs", {}):
                self.tabs["Hit"].clear_marks()
            self.clear_cast()
            first = live._loco[0]
            self.add_actor("stream", first, props, precompute=False)
            self.scene_floor.position = (0.0, 0.0, 0.0)  # the stream's gaits are planned on z = 0
            self.live = live
            self.live_record = []
            self._stream_debt = 0.0
            self.player = Player(1, live.fps)
            self.play_button.label = "Pause"
            self._dirty = True

    # --- playback ---------------------------------------------------------------------------------
    def toggle_play(self) -> None:
        with self.lock:
            self.player.playing = not self.player.playing
            self.play_button.label = "Pause" if self.player.playing else "Play"

    def _set_player(self, **changes: Any) -> None:
        with self.lock:
            for k, v in changes.items():
                setattr(self.player, k, v)

    def _step(self, which: str) -> None:
        with self.lock:
            p = self.player
            f = {"|<": lambda: p.seek(0), "<": lambda: p.step(-1), ">": lambda: p.step(1), ">|": lambda: p.seek(p.n_frames - 1)}[which]()
            p.playing = False
            self.play_button.label = "Play"
            if self.live is not None and which == ">":
                self._advance_live(1)
            self._draw(f)
            self._dirty = True  # the next tick moves the Frame slider there too

    def _on_timeline(self, event: Any) -> None:
        if event.client is None:  # the ticker moving the slider
            return
        with self.lock:
            self.player.seek(int(self.timeline.value))
            self._draw(self.player.index)

    def _advance_live(self, n: int) -> None:
        for _ in range(n):
            self.live_frame = self.live.step()
            self.live_record.append(self.live_frame)
        if len(self.live_record) > RECORD_S * self.live.fps:
            del self.live_record[: len(self.live_record) - int(RECORD_S * self.live.fps)]

    def recorded_stream(self) -> Motion:
        """The stream's last :data:`RECORD_S` seconds as a clip."""
        with self.lock:
            fr = list(self.live_record)
        if len(fr) < 2:
            raise MjmotionError("nothing to save: the stream has not played yet")
        skel = self.cast[0].compiled.skeleton
        trans = None if fr[0].translations is None else np.stack([f.translations for f in fr if f.translations is not None])
        q = rot.make_continuous(np.stack([f.rotations for f in fr]))
        return Motion(skel, self.live.fps, np.stack([f.root_position for f in fr]), q, trans, "stream")

    def live_qpos(self) -> np.ndarray | None:
        """``(nq,)`` the stream character's current ``qpos`` (what the server computed last)."""
        f = self.live_frame
        if f is None or not self.cast:
            return None
        live_motion = Motion(
            self.cast[0].compiled.skeleton,
            self.live.fps,
            f.root_position[None],
            f.rotations[None],
            None if f.translations is None else f.translations[None],
        )
        return kinematics.qpos(self.cast[0].compiled, live_motion)[0]

    def _draw(self, frame: int) -> None:
        with self.lock:
            if self.live is not None:
                q = self.live_qpos()
                if q is None:
                    return
                pose = self.cast[0].kin.pose(q)
                self.cast[0].drawing.update(pose)
                self.last_pose = pose
                return
            for a in self.cast:
                if a.poses:
                    a.drawing.update(a.poses[min(frame, len(a.poses) - 1)])
            if self.cast and self.cast[0].poses:
                self.last_pose = self.cast[0].poses[min(frame, len(self.cast[0].poses) - 1)]
            for t in self.tabs.values():
                hook = getattr(t, "on_frame", None)
                if hook is not None:
                    hook(frame)

    def tick(self, seconds: float) -> None:
        """Advance playback by ``seconds`` of wall time and draw what changed (the ticker calls this)."""
        with self.lock:
            if not self.cast:
                return
            if self.live is not None:
                n = 0
                if self.player.playing:
                    self._stream_debt += seconds * self.live.fps * self.player.speed
                    n = int(self._stream_debt)
                    self._stream_debt -= n
                    self._advance_live(n)
                if self.live_frame is None:
                    n = 1
                    self._advance_live(1)
                if n or self._dirty:
                    with self.client.atomic():
                        self._draw(0)
                now = time.perf_counter()
                if now - self._readout_at > 0.3 and self.live_frame is not None:
                    self._readout_at = now
                    self.tabs["Stream"].on_live(self.live_frame)
            else:
                before = self.player.index
                f = self.player.tick(seconds)
                if f != before or self._dirty:
                    with self.client.atomic():
                        self._draw(f)
                        self.timeline.value = f
            self._dirty = False
            if not self.player.playing and self.play_button.label != "Play":
                self.play_button.label = "Play"
        self._follow()

    def _follow(self) -> None:
        if not self.follow.value or self.last_pose is None:
            return
        target = self.last_pose.body_pos[self.cast[0].compiled.body_ids[0], :2] if self.cast else None
        if target is None:
            return
        self._follow_xy = target if self._follow_xy is None else 0.8 * self._follow_xy + 0.2 * target
        try:
            cam = self.client.camera
            delta = np.r_[self._follow_xy - cam.look_at[:2], 0.0]
            if np.linalg.norm(delta) > 0.02:
                cam.position = cam.position + delta
        except (AssertionError, ValueError):
            pass  # the page has not sent its camera yet

    def _tick_loop(self) -> None:
        last = time.perf_counter()
        while not self._closed.wait(1.0 / TICK_HZ):
            now = time.perf_counter()
            try:
                self.tick(now - last)
            except Exception as e:  # a drawing bug must not kill the page's playback
                self.set_status(f"playback: {type(e).__name__}: {e}", error=True)
                time.sleep(0.5)
            last = now

    # --- saving ---------------------------------------------------------------------------------
    def save(self, filename: str) -> Path | None:
        """Write the main character's clip (or the stream's last minute) as ``filename`` inside the Studio's output folder."""
        from .. import bvh

        a = self.shown
        try:
            if a is None or (a.motion is None and not self.live_record):
                raise MjmotionError("nothing to save: show a clip first")
            path = save_path(self.studio.out_dir, filename, self.library.inputs())
            bvh.write(a.motion if a.motion is not None else self.recorded_stream(), path)
        except MjmotionError as e:
            self.set_status(str(e), error=True)
            return None
        self.set_status(f"wrote {path}")
        return path

    def close(self) -> None:
        self._closed.set()
        self.worker.stop(timeout=3.0)
        self._ticker.join(timeout=3.0)


def save_path(folder: Path, filename: str, inputs: list[Path]) -> Path:
    """Where a save goes: a plain ``NAME.bvh`` inside ``folder`` (created), never over a file or an input."""
    from ..outputs import check_output

    if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*\.bvh", filename or ""):
        raise MjmotionError(f"save as {filename!r}: expected a plain file name ending in .bvh (letters, digits, _ . -)")
    folder = Path(folder).resolve()
    folder.mkdir(parents=True, exist_ok=True)
    path = (folder / filename).resolve()
    if path.parent != folder:
        raise MjmotionError(f"save as {filename!r}: must stay inside {folder}")
    try:
        return check_output(path, force=False, inputs=inputs)
    except AlreadyExistsError as e:  # (an input of the studio is said as check_output says it)
        raise OutputExistsError(f"save as {filename!r}: {path} already exists; the studio never replaces a file, choose another name") from e
