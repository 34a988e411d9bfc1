"""Skinning speed: a 300-frame clip on a ~10k-vertex skin, LBS and DQS, against baselines.

Prints, from one run (rounds interleaved, median of rounds, one BLAS thread):
  * ``mjmotion.skin`` linear blend skinning (seed 000 Eq. 1) of all frames at once, positions
    only and with normals (inverse transpose), and dual-quaternion skinning with and without normals;
  * MuJoCo's own skin deformation of the same mesh and weights (``mjv_updateSkin``, C, float32,
    one frame at a time, normals from the faces), with the largest difference to our LBS;
  * a NumPy baseline written the obvious way: per frame, each vertex's four bone matrices
    gathered and blended (``einsum``);
  * a per-vertex Python loop of Eq. 1 (the textbook form), timed on a few frames and scaled to 300.

Bone frames come from MuJoCo's forward kinematics of the clip, timed separately. Goal (issue 15):
skinning a 300-frame clip of a 10k-vertex mesh well under a second.

    python benchmarks/bench_skin.py [--rounds 5] [--loop-frames 2]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

if __name__ == "__main__":  # BLAS threads must be fixed before NumPy loads
    for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_v, "1")

import mujoco
import numpy as np

from mjmotion import bvh, kinematics, mjcf, skin
from mjmotion import rotations as rot
from mjmotion.skin import deform

FRAMES = 300
#: Marching-cubes spacing (metres at 1.75 m) that gives this skeleton's skin about 10k vertices.
VOXEL = 0.0155


def data_dir() -> Path | None:
    env = os.environ.get("MJMOTION_DATA")
    cand = Path(env) if env else Path(__file__).resolve().parents[1].parent / "shared" / "mocap"
    return cand if cand.is_dir() else None


def gather_lbs(vertices: np.ndarray, bones: np.ndarray, values: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The obvious NumPy version: per frame, gather each vertex's bone matrices and blend them."""
    r = rot.to_matrix(q)  # (T, N, 3, 3)
    idx = np.maximum(bones, 0)
    out = np.empty((len(q), len(vertices), 3))
    for f in range(len(q)):
        a = np.einsum("vk,vkij->vij", values, r[f][idx])
        out[f] = np.einsum("vij,vj->vi", a, vertices) + np.einsum("vk,vki->vi", values, t[f][idx])
    return out


def loop_lbs(vertices: np.ndarray, bones: np.ndarray, values: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Eq. 1 vertex by vertex: v' = (Σ wᵢ Mᵢ Bᵢ⁻¹) v with 4×4 matrices."""
    r = rot.to_matrix(q)
    out = np.empty((len(q), len(vertices), 3))
    for f in range(len(q)):
        mats = np.zeros((q.shape[1], 4, 4))
        mats[:, :3, :3], mats[:, :3, 3], mats[:, 3, 3] = r[f], t[f], 1.0
        for i, v in enumerate(vertices):
            blend = np.zeros((4, 4))
            for b, w in zip(bones[i], values[i]):
                if b >= 0:
                    blend += w * mats[b]
            out[f, i] = (blend @ np.append(v, 1.0))[:3]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--loop-frames", type=int, default=2, help="frames the per-vertex loop is timed on (scaled to 300)")
    args = ap.parse_args()
    d = data_dir()
    if d is None:
        sys.exit("real mocap not found: set MJMOTION_DATA to the shared/mocap directory")
    clip = bvh.read(str(d / "cmu_asfamc_converted" / "16_15.bvh"))[2 : 2 + FRAMES]
    compiled = mjcf.compile(clip.skeleton)
    t0 = time.perf_counter()
    s = skin.build(compiled, reference=clip, settings=skin.Settings(voxel=VOXEL))
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    pose = kinematics.forward(compiled, clip)
    t_fk = time.perf_counter() - t0
    q, t = deform.bone_transforms(pose.joint_positions[:, s.joints], pose.joint_rotations[:, s.joints], s.bind_positions, s.bind_rotations)
    dense = s.weights.dense(len(s.joints))
    bones, values = s.weights.bones, s.weights.values

    attached = skin.attach(compiled, s)
    m = attached.model
    data = mujoco.MjData(m)
    scn = mujoco.MjvScene(m, maxgeom=m.ngeom + 10)
    qpos = kinematics.qpos(attached, clip)
    kin = []
    for row in qpos:  # the MuJoCo baseline skins from kinematics already done, as ours does
        data.qpos[:] = row
        mujoco.mj_kinematics(m, data)
        kin.append((data.xpos.copy(), data.xquat.copy()))
    mj_out = np.empty((FRAMES, s.n_vertices, 3))

    def mujoco_skin():
        for f, (xpos, xquat) in enumerate(kin):
            data.xpos[:] = xpos
            data.xquat[:] = xquat
            mujoco.mjv_updateSkin(m, data, scn)
            mj_out[f] = np.asarray(scn.skinvert).reshape(-1, 3)[: s.n_vertices]

    methods = {
        "LBS, positions": lambda: deform.lbs(s.vertices, dense, q, t),
        "LBS + normals": lambda: deform.lbs(s.vertices, dense, q, t, s.normals),
        "DQS, positions": lambda: deform.dqs(s.vertices, bones, values, q, t, None, s.parents),
        "DQS + normals": lambda: deform.dqs(s.vertices, bones, values, q, t, s.normals, s.parents),
        "MuJoCo mjv_updateSkin (C, + normals)": mujoco_skin,
        "NumPy gather-and-blend baseline": lambda: gather_lbs(s.vertices, bones, values, q, t),
    }
    times: dict[str, list[float]] = {k: [] for k in methods}
    results: dict[str, object] = {}
    # MuJoCo 4 warns on every mjv_updateSkin call (deprecated for mjv_updateActiveSkin, not bound in
    # Python) to stdout and MUJOCO_LOG.TXT: thousands of lines; its handler is swapped out meanwhile.
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        for _ in range(args.rounds):
            for name, fn in methods.items():
                start = time.perf_counter()
                results[name] = fn()
                times[name].append(time.perf_counter() - start)
    finally:
        mujoco.set_mju_user_warning(previous)
    med = {k: statistics.median(v) for k, v in times.items()}
    n = args.loop_frames
    start = time.perf_counter()
    loop = loop_lbs(s.vertices, bones, values, q[:n], t[:n])
    t_loop = (time.perf_counter() - start) * FRAMES / n

    ours = results["LBS, positions"][0]  # type: ignore[index]
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; one BLAS thread; median of {args.rounds} interleaved rounds")
    print(
        f"clip cmu_asfamc_converted/16_15, {FRAMES} frames; skin of {s.n_vertices} vertices, {len(s.faces)} faces, "
        f"{len(s.joints)} bones, ≤ 4 weights per vertex (built in {t_build:.2f} s; FK of the clip {t_fk * 1e3:.1f} ms)"
    )
    base = med["LBS, positions"]
    for name, sec in med.items():
        print(f"  {name:38s} {sec * 1e3:8.1f} ms  {sec / base:6.2f}× LBS positions")
    print(f"  {'per-vertex Python loop of Eq. 1':38s} {t_loop * 1e3:8.0f} ms  (timed on {n} frames, scaled to {FRAMES})")
    print(f"  speed-up of LBS over the per-vertex loop   {t_loop / base:8.0f}×")
    print(f"  speed-up of LBS over the gather baseline   {med['NumPy gather-and-blend baseline'] / base:8.1f}×")
    print(f"  MuJoCo's C skin / our LBS (+ normals)      {med['MuJoCo mjv_updateSkin (C, + normals)'] / med['LBS + normals']:8.2f}")
    print(
        f"  max |ours − MuJoCo| {np.abs(ours - mj_out).max():.1e} m; |ours − loop| {np.abs(ours[:n] - loop).max():.1e} m; "
        f"|ours − gather| {np.abs(ours - results['NumPy gather-and-blend baseline']).max():.1e} m"  # type: ignore[operator]
    )
    print(f"  goal: {FRAMES} frames × {s.n_vertices} vertices well under 1 s — LBS {base:.3f} s, DQS {med['DQS, positions']:.3f} s")


if __name__ == "__main__":
    main()
