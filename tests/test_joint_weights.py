"""``--joint-weights FILE`` for register, blend and stream (seed 000 §3.1; issue 18.3)."""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest

from mjmotion import bvh
from mjmotion import registration as R
from mjmotion.caps import MAX_JSON_BYTES
from mjmotion.cli import main
from mjmotion.errors import MjmotionError
from mjmotion.inputs import read_text

DAZ = "cmu_cgspeed_daz"
LEGS = ("lThigh", "lShin", "lFoot", "rThigh", "rShin", "rFoot")


@pytest.fixture
def clips(mocap):
    walk, run = (bvh.read(str(mocap / DAZ / f"{n}.bvh"))[4:] for n in ("07_01", "09_01"))
    return mocap / DAZ / "07_01.bvh", mocap / DAZ / "09_01.bvh", walk, run


def _legs_only(skeleton) -> dict[str, float]:
    return {n: (1.0 if n in LEGS else 0.0) for n in skeleton.names}


def test_register_weighs_the_distance_by_the_file(clips, tmp_path, capsys):
    path_a, path_b, walk, run = clips
    weights = _legs_only(walk.skeleton)
    (tmp_path / "legs.json").write_text(json.dumps(weights))
    toml = "\n".join(f'"{k}" = {v}' for k, v in weights.items())
    (tmp_path / "legs.toml").write_text(toml)
    out = {}
    for ext in ("json", "toml"):
        argv = ["register", str(path_a), str(path_b), "--json", str(tmp_path / f"r_{ext}.json"), "--joint-weights", str(tmp_path / f"legs.{ext}")]
        assert main(argv) == 0
        out[ext] = json.loads((tmp_path / f"r_{ext}.json").read_text())
    assert main(["register", str(path_a), str(path_b), "--json", str(tmp_path / "r_plain.json")]) == 0
    plain = json.loads((tmp_path / "r_plain.json").read_text())
    assert out["json"]["path"] == out["toml"]["path"] and out["json"]["mean_cost"] == out["toml"]["mean_cost"]
    assert out["json"]["mean_cost"] != plain["mean_cost"]
    # the legs' weights alone: the grid is the distance of the six leg joints' point clouds, unweighted
    pa, pb = R.positions_of(walk), R.positions_of(run)
    legs = [walk.skeleton.index(n) for n in LEGS]
    pr = R.register(walk, run, weights=weights, positions=(pa, pb))
    np.testing.assert_allclose(pr.grid.cost, R.distance_grid(pa[:, legs], pb[:, legs]).cost, rtol=1e-10, atol=1e-14)
    assert out["json"]["mean_cost"] == pytest.approx(pr.path.mean_cost, rel=1e-12)


@pytest.mark.parametrize(
    ("text", "name", "message"),
    [
        ('{"lThigh": 2, "knee": 1}', "w.json", r"w\.json: no joint named 'knee'"),
        ('{"lThigh": -1}', "w.json", r"w\.json: joint 'lThigh': expected a number from 0 to 1e\+06 \(weights are relative\), got -1"),
        ('{"lThigh": true}', "w.json", r"joint 'lThigh': expected a number from 0 to 1e\+06 .*got True"),
        ('{"lThigh": 1e308}', "w.json", r"joint 'lThigh': expected a number from 0 to 1e\+06 .*got 1e\+308"),
        ("[1, 2]", "w.json", r"w\.json: expected a table of joint name -> non-negative weight"),
        ("{nope", "w.json", r"w\.json:1: not valid JSON"),
        ('{"lThigh": 2, "lThigh": 3}', "w.json", r"w\.json: joint 'lThigh' is given twice"),  # (JSON kept the last)
        ("lThigh = [", "w.toml", r"w\.toml: not valid TOML"),
    ],
)
def test_bad_weight_files_are_refused_naming_the_file(clips, tmp_path, capsys, text, name, message):
    import re

    path_a, path_b, _, _ = clips
    (tmp_path / name).write_text(text)
    assert main(["register", str(path_a), str(path_b), "--json", str(tmp_path / "r.json"), "--joint-weights", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("error:") and re.search(message, err[-1]), err
    assert not (tmp_path / "r.json").exists()


def test_weight_file_reader_refuses_fifos_big_and_binary_files(tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)  # nobody writes: opening it must not block
    with pytest.raises(MjmotionError, match="is a named pipe"):
        read_text(str(fifo), MAX_JSON_BYTES, "a joint-weight table")
    big = tmp_path / "big.json"
    big.write_bytes(b" " * (MAX_JSON_BYTES + 1))
    with pytest.raises(MjmotionError, match="larger than the limit of 1048576 bytes"):
        read_text(str(big), MAX_JSON_BYTES, "a joint-weight table")
    # A folder: the message named a file descriptor ("3: Is a directory").
    with pytest.raises(MjmotionError, match=f"^{re.escape(str(tmp_path))}: is a directory; expected a joint-weight table"):
        read_text(str(tmp_path), MAX_JSON_BYTES, "a joint-weight table")
    binary = tmp_path / "bin.json"
    binary.write_bytes(bytes(range(256)))
    with pytest.raises(MjmotionError, match=r"invalid UTF-8 at byte 128"):
        read_text(str(binary), MAX_JSON_BYTES, "a joint-weight table")
    with pytest.raises(MjmotionError, match="no such file"):
        read_text(str(tmp_path / "missing.json"), MAX_JSON_BYTES, "a joint-weight table")


def test_no_output_replaces_the_weight_file(clips, tmp_path, capsys):
    """blend -o W --force with --joint-weights W wrote the blend over the user's weight table."""
    path_a, path_b, walk, _ = clips
    table = tmp_path / "w.json"
    text = json.dumps(_legs_only(walk.skeleton))
    table.write_text(text)
    argv = ["--joint-weights", str(table), "--force"]
    for verb in (
        ["blend", str(path_a), str(path_b), "--weights", "0.5,0.5", "-o", str(table)],
        ["register", str(path_a), str(path_b), "--json", str(table)],
        ["register", str(path_a), str(path_b), "--json", str(tmp_path / "r.json"), "--plot", str(table)],
        ["stream", str(tmp_path / "script.json"), "-o", str(table)],
        ["stream", str(tmp_path / "script.json"), "-o", str(tmp_path / "s.bvh"), "--json", str(table)],
    ):
        assert main(verb + argv) == 2, verb
        assert "is an input of this command" in capsys.readouterr().err
        assert table.read_text() == text


def test_blend_and_stream_use_the_weights(clips, tmp_path, capsys):
    from mjmotion import blend
    from mjmotion import stream as S

    path_a, path_b, walk, run = clips
    weights = _legs_only(walk.skeleton)
    (tmp_path / "legs.json").write_text(json.dumps(weights))
    out = tmp_path / "b.bvh"
    assert main(["blend", str(path_a), str(path_b), "--weights", "0.5,0.5", "-o", str(out), "--joint-weights", str(tmp_path / "legs.json")]) == 0
    expected = blend.blend([walk, run], [0.5, 0.5], joint_weights=weights)
    plain = blend.blend([walk, run], [0.5, 0.5])
    got = bvh.read(str(out))
    assert got.n_frames == expected.n_frames != plain.n_frames
    assert (
        main(
            [
                "blend",
                str(path_a),
                str(path_b),
                "--weights",
                "0.5,0.5",
                "--method",
                "linear",
                "-o",
                str(tmp_path / "l.bvh"),
                "--joint-weights",
                str(tmp_path / "legs.json"),
            ]
        )
        == 2
    )
    assert "a linear blend has none" in capsys.readouterr().err
    script = {
        "duration": 1.0,
        "clips": {"walk": {"file": str(path_a), "frames": "4:"}, "run": {"file": str(path_b), "frames": "4:"}},
        "locomotion": ["walk", "run"],
        "commands": [{"time": 0, "weights": {"walk": 0.5, "run": 0.5}}],
    }
    (tmp_path / "s.json").write_text(json.dumps(script))
    assert main(["stream", str(tmp_path / "s.json"), "-o", str(tmp_path / "s.bvh"), "--joint-weights", str(tmp_path / "legs.json")]) == 0
    parsed = S.parse_script(script, tmp_path, lambda p, f, field: bvh.read(p)[4:])
    weighted, unweighted = S.MotionStream(parsed, weights), S.MotionStream(parsed)
    assert not np.array_equal(weighted.registration.times, unweighted.registration.times)
    np.testing.assert_allclose(bvh.read(str(tmp_path / "s.bvh")).root_positions, weighted.run().root_positions, atol=1e-4)
