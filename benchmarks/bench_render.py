"""Render speed per frame at 640×360: what MuJoCo's renderer spends, by quality setting (issue 19).

One scene (``cmu_asfamc_converted/16_15``, 8 s of walking at 30 fps, one labelled character),
one ``Renderer`` (one GL context, reused) per setting; the settings are interleaved frame by
frame (every frame index is drawn by every setting, alternately forward and reverse), so they
see the same poses and the same machine load. Per setting: the median and 90th percentile of a
whole ``Renderer.frame`` (scene update, GL render, pixel read-back, flip, labels), its frames
per second, and the parts: ``mjv_updateScene`` + extra geoms, ``mjr_render``, ``mjr_readPixels``
(in software GL this waits for the render to finish) and the labels. Settings:

- default: contact shadows (one translucent ellipse per body part), labels;
- hq: MuJoCo's shadow-mapped key light and the floor reflection (the old default), labels;
- hq without reflection, and fast (no shadows of any kind).

Goal: >= 25 frames/s at 640×360 with the default quality. Also the whole ``render.render`` to
MP4 (encoding included) with the default quality, in frames per second.

    python benchmarks/bench_render.py [--frames 60]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mjmotion import bvh, render

W, H = 640, 360
SETTINGS = {
    "default (contact shadows)": {},
    "hq (shadow map + reflection)": {"shadows": True, "reflections": True},
    "shadow map, no reflection": {"shadows": True},
    "fast (no shadows)": {"contact_shadows": False},
}


def parts(r: render.Renderer, i: int) -> tuple[float, float, float, float]:
    """Seconds of the parts of ``r.frame(i)``: scene update (with added geoms), render, read-back, flip + labels."""
    s = r.scene
    d = r.pose(i)
    cam = r._cam
    cam.lookat[:] = s.lookat[i]
    cam.azimuth, cam.elevation, cam.distance = s.azimuth, s.elevation, s.distance
    t0 = time.perf_counter()
    mujoco.mjv_updateScene(s.model, d, r.option, None, cam, mujoco.mjtCatBit.mjCAT_ALL, r._scn)
    r._add_contact_shadows(d)
    r._add_trails(i)
    t1 = time.perf_counter()
    r._gl.make_current()
    mujoco.mjr_render(r._rect, r._scn, r._mjr)
    t2 = time.perf_counter()
    mujoco.mjr_readPixels(r._rgb, None, r._rect, r._mjr)
    t3 = time.perf_counter()
    r.camera = r._camera_pose()
    img = np.flipud(r._rgb).copy()
    r._draw_labels(img, d)
    t4 = time.perf_counter()
    return t1 - t0, t2 - t1, t3 - t2, t4 - t3


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60, help="frames timed per setting (default 60)")
    args = ap.parse_args()
    env = os.environ.get("MJMOTION_DATA")
    d = Path(env) if env else REPO.parent / "shared" / "mocap"
    m = bvh.read(d / "cmu_asfamc_converted" / "16_15.bvh")
    scene = render.build_scene([render.Actor(m, label="16_15")], fps=30)
    n = min(args.frames, scene.n_frames - 1)
    renderers = {k: render.Renderer(scene, W, H, **opts) for k, opts in SETTINGS.items()}
    whole: dict[str, list[float]] = {k: [] for k in renderers}
    split: dict[str, list[tuple[float, ...]]] = {k: [] for k in renderers}
    try:
        for r in renderers.values():
            r.frame(0)  # first frame: textures uploaded, not timed
        order = list(renderers)
        for i in range(1, n + 1):
            for k in order if i % 2 else order[::-1]:
                t = time.perf_counter()
                renderers[k].frame(i)
                whole[k].append(time.perf_counter() - t)
                split[k].append(parts(renderers[k], i))
    finally:
        for r in renderers.values():
            r.close()
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        render.render(scene, Path(tmp) / "walk.mp4", W, H, frames=slice(0, n), progress=False)
        mp4_fps = n / (time.perf_counter() - t)
    print(f"{W}x{H}, {n} frames per setting, interleaved; one GL context per setting (MUJOCO_GL={os.environ['MUJOCO_GL']}); "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")  # fmt: skip
    print(f"{'setting':<30}{'ms med':>8}{'ms p90':>8}{'fps':>7}{'vs default':>11}   parts, ms median: update render read labels")
    base = statistics.median(whole[order[0]])
    for k in order:
        med = statistics.median(whole[k])
        p = np.median(np.array(split[k]), axis=0) * 1e3
        print(
            f"{k:<30}{med * 1e3:8.1f}{np.percentile(whole[k], 90) * 1e3:8.1f}{1 / med:7.1f}{med / base:10.2f}x   "
            f"{p[0]:6.1f} {p[1]:6.1f} {p[2]:5.1f} {p[3]:6.1f}"
        )
    fps = 1 / base
    print(f"whole render.render to MP4 (default quality, encoding included): {mp4_fps:.1f} frames/s")
    print(f"goal: >= 25 frames/s at {W}x{H} with the default quality: {'met' if fps >= 25 else 'NOT met'} ({fps:.1f} frames/s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
