"""Studio interactive speed (issue 14), from one run.

1. **Stream per-frame update**: the Stream tab's work for one output frame — the live stream's
   blend (:meth:`mjmotion.studio.live.LiveStream.step`), FK (``qpos`` + ``mj_kinematics`` +
   geom frames) and the scene update (primitive instances + the three batched-mesh updates sent
   to a real viser server) — over 20 s of the bundled walk/run set with weight ramps, a kick and a
   punch. Median and 95th percentile, against the frame budget at the clip's rate and against the
   batch stream's cost per frame (``mjmotion.stream.stream`` on the same commands; it composes all
   frames at once). Goal: ≤ 5 ms per frame.
2. **The skin's cost per drawn frame** (issue 15 in the Studio): the same stream drawn as capsules,
   ``skin (LBS)`` and ``skin (DQS)``, interleaved in rounds, each paced at the page's draw rate
   (``session.TICK_HZ``) with a websocket client connected in another process, so viser really
   serialises and sends every frame. Rows: the deformation (``FrameSkinner``), the draw
   (deformation + assigning the mesh handles' vertices), this process's CPU per drawn frame
   (stream, FK, draw and viser's sending thread) and the bytes the client received per frame.
3. **Ball drag → adapted shot**: a 300-frame shot (the bundled drive resampled to 300 frames; with
   ``MJMOTION_DATA``, also CMU 64_01 cut to 300 frames around its hit) set up once when loaded
   (``engine.shot``), then, for 5 dragged ball positions, interleaved: *before*, what a drag ran
   until now (``hitpoint.adapt`` with DLS: set-up, PCA and every frame the blend touches); *now*,
   the drag's preview from the set-up (``engine.adapt(..., preview=True)``: about
   ``engine.PREVIEW_FRAMES`` frames) plus the page's posing of the result; the release's exact
   DLS from the set-up (checked equal to ``hitpoint.adapt``, bit for bit) and the NLP ("Adapt
   with NLP"); how far the preview's effector path is from the exact one. Goal: a drag answered
   within 0.5 s. Then where the verb's DLS adapt goes (cProfile: ``hitpoint.setup`` and its PCA,
   the per-frame solve, the report), the release's style error and the launch simulation.

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


DRAIN = """
import sys, websockets.sync.client as c
n = 0
with c.connect(sys.argv[1], subprotocols=[sys.argv[2]], max_size=None) as ws:
    print("connected", flush=True)
    try:
        for m in ws:
            n += len(m)
            if sys.stdin.closed:
                break
    except Exception:
        pass
print(n, flush=True)
"""


def skin_bench(rounds: int = 3, draws: int = 60) -> None:
    """The stream drawn as capsules, skin (LBS) and skin (DQS), paced at the page's draw rate, a client draining the socket."""
    import subprocess

    import viser

    from mjmotion.studio.scene import Kinematics
    from mjmotion.studio.session import TICK_HZ
    from mjmotion.studio.skinned import SkinDrawing

    clips = {n: getattr(synth, n)().motion.replace(name=n) for n in ("walk", "run", "kick")}
    compiled = mjcf.compile(clips["walk"].skeleton)
    kin = Kinematics(compiled)
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    drain = subprocess.Popen(
        [sys.executable, "-c", DRAIN, f"ws://127.0.0.1:{server.get_port()}", f"viser-v{viser.__version__}"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert drain.stdout is not None and drain.stdout.readline().strip() == "connected"
    time.sleep(0.5)  # the new client's backlog
    modes = {
        "capsules": lambda name: PrimitiveDrawing(server.scene, name, compiled, (77, 140, 217)),
        "skin (LBS)": lambda name: SkinDrawing(server.scene, name, compiled, (77, 140, 217), clips["walk"], "lbs"),
        "skin (DQS)": lambda name: SkinDrawing(server.scene, name, compiled, (77, 140, 217), clips["walk"], "dqs"),
    }
    rows: dict[str, dict[str, list[float]]] = {m: {"deform": [], "draw": [], "cpu": [], "bytes": []} for m in modes}
    n_vertices = 0
    live = LiveStream([clips["walk"], clips["run"]], {"kick": clips["kick"]}, weights=[0.5, 0.5])
    step = max(1, round(live.fps / TICK_HZ))  # stream frames per drawn frame
    for r in range(rounds):
        for mode, make in modes.items():
            d = make(f"/bench/{mode.replace(' ', '_')}/{r}")
            skinner = getattr(d, "skinner", None)
            if skinner is not None:
                n_vertices = skinner.skin.n_vertices
                bones = np.asarray(compiled.body_ids)[skinner.skin.joints]
            live.play("kick", 0.3)
            cpu0, start = time.process_time(), time.perf_counter()
            for k in range(draws):
                for _ in range(step):
                    f = live.step()
                m = clips["walk"].replace(root_positions=f.root_position[None], rotations=f.rotations[None], translations=None)
                pose = kin.pose(kinematics.qpos(compiled, m)[0])
                if skinner is not None:
                    a = time.perf_counter()
                    skinner(pose.body_pos[bones], pose.body_quat[bones])
                    rows[mode]["deform"].append(time.perf_counter() - a)
                a = time.perf_counter()
                with server.atomic():  # as the page's ticker draws: one wake-up of viser's sender per frame
                    d.update(pose)
                rows[mode]["draw"].append(time.perf_counter() - a)
                wait = start + (k + 1) / TICK_HZ - time.perf_counter()
                if wait > 0:
                    time.sleep(wait)
            time.sleep(0.3)  # let the sender finish this mode's frames
            rows[mode]["cpu"].append((time.process_time() - cpu0) / draws)
            d.remove()
    drain.stdin.close()
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()
    total_bytes = int(drain.stdout.read().split()[-1]) if drain.wait(10) == 0 else 0
    ms = lambda x: f"{1000 * float(np.median(x)):.2f}" if len(x) else "–"
    print()
    print(f"the skin per drawn frame ({n_vertices} vertices; {rounds} interleaved rounds of {draws} draws at {TICK_HZ:g} Hz, a client connected)")
    print("| character | deform median ms | draw (deform + upload) median ms | draw p95 ms | process CPU per drawn frame ms |")
    print("|---|---|---|---|---|")
    for mode, t in rows.items():
        p95 = f"{1000 * np.percentile(t['draw'], 95):.2f}"
        print(f"| {mode} | {ms(t['deform'])} | {ms(t['draw'])} | {p95} | {ms(t['cpu'])} |")
    print(f"the client received {total_bytes / (rounds * draws * len(modes)) / 1024:.0f} KiB per drawn frame on average over all modes")
    budget = 0.005 * step  # the stream's 5 ms per frame, with one draw every `step` stream frames
    worst = max(np.median(rows[m]["cpu"]) for m in ("skin (LBS)", "skin (DQS)"))
    print(
        f"stream budget: 5 ms per stream frame at {live.fps:g} fps with a draw every {step} frames = {1000 * budget:.0f} ms per drawn frame; "
        f"the skin's worst CPU per drawn frame {1000 * worst:.2f} ms: {'within' if worst <= budget else 'OVER'} budget"
    )


def adapt_breakdown(s: engine.Shot, target: np.ndarray) -> dict[str, float]:
    """Seconds of the verb's DLS adapt (what a drag ran before the preview) by phase (cProfile, cumulative per function; ``nan`` if a function is renamed)."""
    import cProfile
    import pstats

    from mjmotion import hitpoint

    prof = cProfile.Profile()
    prof.runcall(hitpoint.adapt, s.motion, target=target, frame=s.hit_frame, effector=s.effector, solver="dls", prop=s.prop, style=False)
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    want = {
        "adapt": ("hitpoint.py", "adapt"),
        "setup": ("hitpoint.py", "setup"),
        "PCA (PoseSpace.fit)": ("style.py", "fit"),
        "per-frame solve": ("hitpoint.py", "_solve_frames"),
        "report": ("hitpoint.py", "_report"),
    }
    out = {}
    for label, (file, fn) in want.items():
        hits = [v[3] for k, v in stats.items() if k[0].endswith(file) and k[2] == fn]
        out[label] = max(hits) if hits else float("nan")
    return out


def drag_bench() -> None:
    """Before/after in one run, interleaved per ball position: the verb's ``hitpoint.adapt`` (set-up and
    every frame: what a drag ran before), the drag's preview from the shot's set-up (what it runs
    now) and the exact solve from the set-up (the release: the verb's answer bit for bit)."""
    from mjmotion import hitpoint
    from mjmotion.studio.scene import Kinematics

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
    offsets = [np.array(o) for o in ((0, 0.05, 0), (0, 0, 0.05), (0.05, 0, 0.05), (0, -0.05, 0.03), (0.03, 0.03, -0.03))]
    rows, later = [], []
    for label, s in shots:
        compiled = mjcf.compile(s.motion.skeleton, (s.prop,) if s.prop is not None else ())
        kin = Kinematics(compiled)
        t: dict[str, list[float]] = {"before": [], "preview": [], "show": [], "exact": [], "nlp": []}
        dev, err, same = [], [], True
        for k, off in enumerate(offsets):
            target = s.source_point + off
            order = ("before", "preview", "exact") if k % 2 == 0 else ("exact", "preview", "before")
            res = {}
            for what in order:
                s.memo.clear()  # a fresh solve each time (with few frames the preview is the exact solve, remembered)
                a = time.perf_counter()
                if what == "before":
                    res[what] = hitpoint.adapt(
                        s.motion, target=target, frame=s.hit_frame, effector=s.effector, solver="dls", prop=s.prop, style=False
                    )
                else:
                    res[what] = engine.adapt(s, target, "dls", preview=what == "preview")
                t[what].append(time.perf_counter() - a)
            a = time.perf_counter()
            kin.poses(kinematics.qpos(compiled, res["preview"].motion))  # what the page does with it (session.show)
            t["show"].append(time.perf_counter() - a)
            same &= bool(np.array_equal(res["exact"].motion.rotations, res["before"].motion.rotations))
            d = np.linalg.norm(res["preview"].achieved - res["exact"].achieved, axis=1)
            dev.append((float(d.max()), float(np.median(d[s.problem.blend > 0]))))
            err.append(res["preview"].report["hit_error_m"])
            if k < 2:
                s.memo.clear()
                a = time.perf_counter()
                engine.adapt(s, target, "nlp")
                t["nlp"].append(time.perf_counter() - a)
        n_prev = res["preview"].report.get("preview_frames", int((s.problem.blend > 0).sum()))
        rows.append((label, s, t, dev, err, same, n_prev))
        target = s.source_point + offsets[0]
        phases = adapt_breakdown(s, target)
        s.memo.clear()
        engine.adapt(s, target, "dls")
        a = time.perf_counter()
        released = engine.adapt(s, target, "dls", style=True)  # the memo: the exact solve of this spot, plus the style error
        t_release = time.perf_counter() - a
        a = time.perf_counter()
        engine.launch(s, released.motion, target)
        t_launch = time.perf_counter() - a
        later.append((label, int((s.problem.blend > 0).sum()), phases, t_release, t_launch))
    med = lambda x: float(np.median(x))
    print()
    print(f"ball drag → adapted 300-frame shot, DLS (5 ball positions, interleaved; preview of {engine.PREVIEW_FRAMES} frames)")
    print(
        "| shot | frames the blend touches | before: hitpoint.adapt s | drag now: preview + show s | preview frames | before / now | "
        "release: exact from set-up s | exact = hitpoint.adapt | NLP from set-up s | preview vs exact max / median mm | preview hit error mm |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, s, t, dev, err, same, n_prev in rows:
        now = np.array(t["preview"]) + np.array(t["show"])
        print(
            f"| {label} | {int((s.problem.blend > 0).sum())} | {med(t['before']):.3f} | {med(now):.3f} (max {max(now):.3f}) | {n_prev} | "
            f"{med(t['before']) / med(now):.1f}× | {med(t['exact']):.3f} | {'yes' if same else 'NO'} | {med(t['nlp']):.3f} | "
            f"{1000 * max(d[0] for d in dev):.1f} / {1000 * max(d[1] for d in dev):.2f} | {1000 * max(err):.3f} |"
        )
    print("goal: a drag answered within 0.5 s (median of 'drag now')")
    print()
    print("where the verb's DLS adapt goes (cProfile, seconds; profiling adds overhead) and what a release adds")
    print("| shot | frames solved | hitpoint.adapt | setup | of it PCA | per-frame solve | report | release: style error (memo) | launch |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, n, ph, rel, lau in later:
        cells = " | ".join(f"{ph[k]:.3f}" for k in ("adapt", "setup", "PCA (PoseSpace.fit)", "per-frame solve", "report"))
        print(f"| {label} | {n} | {cells} | {rel:.3f} | {lau:.3f} |")


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()  # --help, and no stray arguments
    stream_bench()
    skin_bench()
    drag_bench()
