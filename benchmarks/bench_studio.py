"""Studio interactive speed (issue 14), from one run.

1. **Stream per-frame update**: the Stream tab's work for one output frame — the live stream's
   blend (:meth:`mjmotion.studio.live.LiveStream.step`), FK (``qpos`` + ``mj_kinematics`` +
   geom frames) and the scene update (primitive instances + the three batched-mesh updates sent
   to a real viser server) — over 20 s of the bundled walk/run set with weight ramps, a kick and a
   punch. Median and 95th percentile, against the frame budget at the clip's rate and against the
   batch stream's cost per frame (``mjmotion.stream.stream`` on the same commands; it composes all
   frames at once). Goal: ≤ 5 ms per frame.
2. **Ball drag → adapted shot**: a 300-frame shot (the bundled drive resampled to 300 frames; with
   ``MJMOTION_DATA``, also CMU 64_01 cut to 300 frames around its hit) set up once when loaded, then
   adapted to 5 dragged ball positions with the fast solver (DLS, what a drag runs) and, for the
   ratio, the NLP (what "Adapt with NLP" runs). Goal: DLS ≤ 0.5 s.

Usage: ``python benchmarks/bench_studio.py``. Numbers on a shared machine are noisy: compare ratios.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mjmotion import bvh, kinematics, mjcf, synth
from mjmotion import stream as st
from mjmotion.studio import engine
from mjmotion.studio.live import LiveStream
from mjmotion.studio.scene import PrimitiveDrawing


def stream_bench() -> None:
    import viser

    clips = {n: getattr(synth, n)().motion.replace(name=n) for n in ("walk", "run", "kick", "punch")}
    fps = clips["walk"].fps
    live = LiveStream([clips["walk"], clips["run"]], {"kick": clips["kick"], "punch": clips["punch"]})
    compiled = mjcf.compile(clips["walk"].skeleton)
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    drawing = PrimitiveDrawing(server.scene, "/bench", compiled, (77, 140, 217))
    from mjmotion.studio.scene import Kinematics

    kin = Kinematics(compiled)
    n_frames = int(20 * fps)
    events = {
        int(2 * fps): ("w", [0.5, 0.5]),
        int(5 * fps): ("play", "kick"),
        int(9 * fps): ("w", [0.0, 1.0]),
        int(12 * fps): ("play", "punch"),
        int(15 * fps): ("w", [1.0, 0.0]),
    }
    t_blend, t_fk, t_scene = [], [], []
    for n in range(n_frames):
        ev = events.get(n)
        if ev and ev[0] == "w":
            live.set_weights(ev[1], 0.8)
        elif ev:
            live.play(ev[1], 0.3)
        a = time.perf_counter()
        f = live.step()
        b = time.perf_counter()
        m = clips["walk"].replace(root_positions=f.root_position[None], rotations=f.rotations[None], translations=None)
        pose = kin.pose(kinematics.qpos(compiled, m)[0])
        c = time.perf_counter()
        drawing.update(pose)
        d = time.perf_counter()
        t_blend.append(b - a)
        t_fk.append(c - b)
        t_scene.append(d - c)
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()
    total = np.array(t_blend) + np.array(t_fk) + np.array(t_scene)
    commands = [st.Command(0.0, "weights", np.array([1.0, 0.0]), ramp=0.0)]
    for k, ev in sorted(events.items()):
        commands.append(
            st.Command(k / fps, "weights", np.array(ev[1]), ramp=0.8) if ev[0] == "w" else st.Command(k / fps, "play", clip=ev[1], blend=0.3)
        )
    script = st.Script(clips=clips, locomotion=("walk", "run"), commands=tuple(commands), duration=n_frames / fps, fps=fps)
    a = time.perf_counter()
    st.stream(script)
    batch = (time.perf_counter() - a) / n_frames
    budget = 1.0 / fps
    ms = lambda x: f"{1000 * x:.2f}"
    print(f"stream per-frame update, {n_frames} frames of the bundled walk/run + kick, punch ({fps:g} fps)")
    print("| part | median ms | p95 ms |")
    print("|---|---|---|")
    for name, t in (
        ("blend (LiveStream.step)", t_blend),
        ("FK (qpos, mj_kinematics, geom frames)", t_fk),
        ("scene update (instances, 3 batched meshes)", t_scene),
        ("total", total),
    ):
        print(f"| {name} | {ms(np.median(t))} | {ms(np.percentile(t, 95))} |")
    print(
        f"goal ≤ 5 ms: {'met' if np.median(total) <= 0.005 else 'NOT met'} (median); frame budget at {fps:g} fps {ms(budget)} ms = {budget / np.median(total):.1f}× the median"
    )
    print(f"batch stream (stream.stream, all frames at once): {ms(batch)} ms/frame; live/batch = {np.median(t_blend) / batch:.1f}×")


def drag_bench() -> None:
    shots = []
    drive = synth.drive()
    m = drive.motion.resample(drive.motion.fps * 299 / (drive.motion.n_frames - 1))[:300]
    shots.append(("bundled drive, resampled", engine.shot(m.replace(name="drive300"), drive.prop)))
    data = os.environ.get("MJMOTION_DATA")
    p = Path(data) / "cmu_asfamc_converted" / "64_01.bvh" if data else None
    if p is not None and p.is_file():
        g = bvh.read(p)
        s0 = engine.shot(g)
        a = int(np.clip(s0.hit_frame - 180, 0, g.n_frames - 300))
        shots.append(("CMU 64_01, 300 frames", engine.shot(g[a : a + 300].replace(name="64_01"), s0.prop)))
    print()
    print("ball drag → adapted 300-frame shot (setup done once at load; 5 ball positions)")
    print("| shot | frames | DLS median s | DLS max s | NLP median s | NLP/DLS | max hit error mm (DLS) |")
    print("|---|---|---|---|---|---|---|")
    offsets = [np.array(o) for o in ((0, 0.05, 0), (0, 0, 0.05), (0.05, 0, 0.05), (0, -0.05, 0.03), (0.03, 0.03, -0.03))]
    for label, s in shots:
        t_dls, t_nlp, err = [], [], []
        for k, off in enumerate(offsets):
            target = s.source_point + off
            a = time.perf_counter()
            r = engine.adapt(s, target, "dls")
            t_dls.append(time.perf_counter() - a)
            err.append(r.report["hit_error_m"])
            if k < 2:
                a = time.perf_counter()
                engine.adapt(s, target, "nlp")
                t_nlp.append(time.perf_counter() - a)
        print(
            f"| {label} | {s.motion.n_frames} | {np.median(t_dls):.3f} | {max(t_dls):.3f} | {np.median(t_nlp):.3f} | "
            f"{np.median(t_nlp) / np.median(t_dls):.1f}× | {1000 * max(err):.3f} |"
        )
    print("goal: DLS ≤ 0.5 s")


if __name__ == "__main__":
    stream_bench()
    drag_bench()
