"""Which file axis a clip's body stands along, and the ``--up`` note when it is not the one read."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from mjmotion import bvh, synth, upright
from mjmotion import rotations as rot
from mjmotion.cli import main


@pytest.fixture(scope="module")
def walk():
    return synth.walk(seconds=2.0).motion


def _z_up(m):
    """``m`` as a Z-up file would hold it (the same world motion; the writer turns it to the file's axes)."""
    return m.replace(skeleton=dataclasses.replace(m.skeleton, up="z"))


def _turned(m, axis, degrees, frames=slice(None)):
    """``m`` with its root turned ``degrees`` about the world ``axis`` in ``frames`` (the body lies or stands on its head)."""
    q = rot.exp(np.asarray(axis, float) * np.deg2rad(degrees))
    r = m.rotations.copy()
    r[frames, 0] = rot.multiply(np.broadcast_to(q, r[frames, 0].shape), r[frames, 0])
    return m.replace(rotations=r)


def test_a_walk_stands_along_its_up_axis(walk):
    for m in (walk, _z_up(walk)):
        s = upright.standing_axis(m)
        assert s is not None and s.axis == "+" + m.skeleton.up and s.share == 1.0
        assert upright.up_note(m) == []


def test_a_z_up_file_read_as_y_up_is_named_with_the_option_that_reads_it(walk, tmp_path):
    path = tmp_path / "zup.bvh"
    bvh.write(_z_up(walk), path)
    lying = bvh.read(path, up="y")
    assert upright.standing_axis(lying).axis == "+z"
    (note,) = upright.up_note(lying)
    assert "head is above its feet along the file's +Z axis in 100% of the frames, not +Y as --up y reads them" in note
    assert note.endswith("unless the body lies down in this clip, read it with --up z")
    assert upright.up_note(bvh.read(path, up="z")) == []


def test_a_y_up_file_read_as_z_up_is_named(mocap):
    m = bvh.read(mocap / "cmu_cgspeed_daz" / "07_01.bvh", up="z")
    (note,) = upright.up_note(m)
    assert note.endswith("not +Z as --up z reads them: unless the body lies down in this clip, read it with --up y")
    assert upright.up_note(bvh.read(mocap / "cmu_cgspeed_daz" / "07_01.bvh")) == []


def test_upside_down_and_lying_bodies(walk):
    down = _turned(walk, (1.0, 0.0, 0.0), 180.0)
    assert upright.standing_axis(down).axis == "-y"  # (a Y-up file)
    assert upright.up_note(down)[0].endswith("no --up reads it upright (y and z only)")
    sideways = _turned(walk, (1.0, 0.0, 0.0), 90.0)
    assert upright.standing_axis(sideways).axis == "-x"  # world -y is the Y-up file's -X
    assert upright.up_note(sideways)[0].endswith("no --up reads it upright (y and z only)")
    # Half the clip lying down: no axis holds a majority, and no note.
    half = _turned(walk, (1.0, 0.0, 0.0), 90.0, slice(walk.n_frames // 2, None))
    assert upright.standing_axis(half) is None and upright.up_note(half) == []
    # A body lying along the horizontal axis the other --up would call up reads like a standing body
    # read with the wrong axis (poses alone cannot tell them apart): the note says so in its advice.
    along_z = _turned(walk, (0.0, 1.0, 0.0), 90.0)  # head to world +x: the Y-up file's +Z
    assert upright.standing_axis(along_z).axis == "+z"
    assert "unless the body lies down in this clip, read it with --up z" in upright.up_note(along_z)[0]


def test_a_clip_without_a_head_has_no_standing_axis_and_info_says_why(walk, tmp_path, capsys):
    path = tmp_path / "nohead.bvh"
    bvh.write(_z_up(walk), path)
    path.write_text(path.read_text().replace("JOINT Head", "JOINT Skull"))
    m = bvh.read(path)
    assert m.skeleton.head() is None and upright.standing_axis(m) is None and upright.up_note(m) == []
    assert main(["info", str(path)]) == 0
    assert "(no head or feet found by name: which axis the body stands along is not known)" in capsys.readouterr().out
    assert main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["head"] is None and d["standing_axis"] is None


def test_info_and_evaluate_print_the_note(walk, tmp_path, capsys):
    path = tmp_path / "zup.bvh"
    bvh.write(_z_up(walk), path)
    assert main(["info", str(path), "--json"]) == 0
    out = capsys.readouterr()
    d = json.loads(out.out)
    assert d["up"] == "y" and d["standing_axis"] == "+z" and d["standing_share"] == 1.0 and d["head"] == "Head"
    assert "read it with --up z" in out.err
    assert main(["info", str(path), "--up", "z"]) == 0
    out = capsys.readouterr()
    assert "up axis z (the body stands along +Z in 100% of frames)" in out.out and out.err == ""
    assert main(["evaluate", str(path), "--json", str(tmp_path / "r.json")]) == 0
    assert "read it with --up z" in capsys.readouterr().out  # (evaluate prints its notes under the table)
    (clip,) = json.loads((tmp_path / "r.json").read_text())
    assert any("read it with --up z" in n for n in clip["notes"])


def test_every_verb_that_loads_a_clip_notes_the_wrong_up(walk, tmp_path, capsys):
    """cleanup (and render, blend, … through the same loader) of a Z-up file read as Y-up: the note
    comes before the work (a cleanup of a body lying on its side moved its root 2.6 m)."""
    path = tmp_path / "zup.bvh"
    bvh.write(_z_up(walk), path)
    assert main(["cleanup", str(path), "-o", str(tmp_path / "out.bvh")]) == 0
    assert "read it with --up z" in capsys.readouterr().err
    assert main(["cleanup", str(path), "-o", str(tmp_path / "out_z.bvh"), "--up", "z"]) == 0
    assert "--up" not in capsys.readouterr().err
    assert main(["compile", str(path), "-o", str(tmp_path / "out.xml")]) == 0  # (reads frames its own way)
    assert "read it with --up z" in capsys.readouterr().err
