"""The models in ``models/``: each loads, steps for 2 s without instability, and is what the script makes."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjmotion import mjcf, models
from mjmotion import rotations as rot

MODELS = Path(__file__).resolve().parents[1] / "models"
FILES = ("bat.xml", "club.xml", "ball.xml", "humanoid.xml")


@pytest.mark.parametrize("name", FILES)
def test_model_loads_and_steps_two_seconds(name):
    m = mujoco.MjModel.from_xml_path(str(MODELS / name))
    d = mujoco.MjData(m)
    if m.nkey:
        mujoco.mj_resetDataKeyframe(m, d, 0)
    for _ in range(int(round(2.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
    assert np.all(np.isfinite(d.qpos)) and all(w.number == 0 for w in d.warning)
    assert d.qpos[2] > 0.0  # on the floor, not through it


@pytest.mark.parametrize("kind", ["bat", "club"])
def test_props_have_the_lab_dimensions(kind):
    p = mjcf.PROP_PRESETS[kind]
    m = mujoco.MjModel.from_xml_path(str(MODELS / f"{kind}.xml"))
    assert float(m.body_mass[1]) == pytest.approx(p["mass"], rel=1e-6)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    site = {n: d.site_xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"{kind}/{n}")] for n in ("grip", "sweet_spot", "tip")}
    assert np.linalg.norm(site["tip"] - site["grip"]) == pytest.approx(p["length"])
    assert np.linalg.norm(site["sweet_spot"] - site["grip"]) == pytest.approx(p["sweet_spot"])


def test_humanoid_has_its_skin_servos_and_keyframes_that_hold():
    m = mujoco.MjModel.from_xml_path(str(MODELS / "humanoid.xml"))
    assert m.nskin == 1 and m.nu > 0 and m.nkey == len(models.KEYFRAMES)
    assert [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_KEY, k) for k in range(m.nkey)] == list(models.KEYFRAMES)
    balls = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, models.KEYFRAMES.index("drive"))
    start = d.qpos.copy()
    for _ in range(1000):
        mujoco.mj_step(m, d)
    dev = max(float(np.degrees(rot.angle_between(d.qpos[a : a + 4], start[a : a + 4]))) for a in m.jnt_qposadr[balls])
    assert dev < 25.0


def test_models_are_what_the_script_makes(tmp_path):
    written = models.write(tmp_path)
    assert sorted(p.name for p in written) == sorted(FILES)
    for p in written:
        assert p.read_text() == (MODELS / p.name).read_text(), f"models/{p.name} is stale: run python models/make_models.py"


def test_the_script_shows_its_help_without_writing(tmp_path):
    """`python models/make_models.py --help` rewrote the four models (the script gave main a fixed argv)."""
    import subprocess
    import sys

    before = {name: (MODELS / name).stat().st_mtime_ns for name in FILES}
    done = subprocess.run([sys.executable, str(MODELS / "make_models.py"), "--help"], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0 and done.stdout.startswith("usage: python models/make_models.py") and "--out DIR" in done.stdout
    assert {name: (MODELS / name).stat().st_mtime_ns for name in FILES} == before
    # --out is taken (the default is this folder)
    assert subprocess.run([sys.executable, str(MODELS / "make_models.py"), "--out", str(tmp_path / "m")], capture_output=True).returncode == 0
    assert sorted(p.name for p in (tmp_path / "m").iterdir()) == sorted(FILES)
    assert {name: (MODELS / name).stat().st_mtime_ns for name in FILES} == before
