"""The stream script's schema (issue 17): wrong types, ranges and lengths are refused naming the key
path; properties over random JSON put anywhere in a valid script."""

from __future__ import annotations

import copy
import json
import os

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mjmotion import script as S
from mjmotion.errors import MjmotionError

PROPS = settings(max_examples=400, derandomize=True, database=None, deadline=None)

VALID = {
    "duration": 8.0,
    "fps": 120,
    "loop_blend": 0.4,
    "clips": {"walk": {"file": "16_15.bvh"}, "fast": {"file": "16_24.bvh"}, "kick": {"file": "10_01.bvh", "frames": "500:720"}},
    "locomotion": ["walk", "fast"],
    "commands": [
        {"time": 0, "weights": {"walk": 1}},
        {"time": 1.5, "weights": {"walk": 0.5, "fast": 0.5}, "ramp": 0.8},
        {"time": 3.5, "play": "kick", "blend": 0.3},
        {"time": 4.0, "return": True, "blend": 0.2},
    ],
}


def test_a_valid_script_passes_unchanged():
    assert S.validate(copy.deepcopy(VALID)) == VALID


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["commands"][1]["weights"].update(walk="abc"), 'script.commands[1].weights.walk: expected a finite number ≥ 0, got "abc"'),
        (lambda d: d["commands"][1].update(weights=[1]), "script.commands[1].weights: expected an object of 1 to 64 named entries, got a list"),
        (lambda d: d["commands"][1].update(weights=None), "script.commands[1].weights: expected an object of 1 to 64 named entries, got null"),
        (lambda d: d["clips"]["kick"].update(frames=5), "script.clips.kick.frames: expected a string of 1 to 64 printable characters, got 5"),
        (lambda d: d["clips"]["kick"].update(frames=[0, 10]), "script.clips.kick.frames: expected a string"),
        (
            lambda d: d["commands"][2].update(play=["kick"]),
            'script.commands[2].play: expected a string of 1 to 256 printable characters, got ["kick"]',
        ),
        (lambda d: d["commands"][2].update(play={"clip": "kick"}), "script.commands[2].play: expected a string"),
        (lambda d: d.update(commands={"time": 0}), "script.commands: expected a list of 1 to 10000 items, got an object"),
        (lambda d: d.update(duration=float("nan")), "script.duration: expected a finite number > 0, got NaN"),
        (lambda d: d.update(duration=True), "script.duration: expected a finite number > 0, got true"),
        (lambda d: d["commands"][3].update({"return": "yes"}), 'script.commands[3].return: expected true, got "yes"'),
        (lambda d: d["commands"][0].update(blend=0.3), 'script.commands[0]: unknown field(s) "blend"; expected time, weights, ramp'),
        (lambda d: d["commands"].append({"time": 5}), "script.commands[4]: expected one of weights, play, return"),
        (lambda d: d["commands"][0].pop("time"), "script.commands[0]: missing field 'time'"),
        (lambda d: d["clips"].update({"a\x1b[2J": {"file": "x.bvh"}}), r'script.clips: the name "a\u001b[2J" is not 1 to 256 printable characters'),
        (lambda d: d["clips"]["walk"].update(file="x" * 5000), "script.clips.walk.file: expected a string of 1 to 4096"),
        (lambda d: d.update(locomotion=[]), "script.locomotion: expected a list of 1 to 64 items, got 0 items"),
        (lambda d: d.update(speed=2), 'script: unknown field(s) "speed"'),
        (
            lambda d: d.update(commands=[{"time": 0, "weights": {"walk": 1}}] * 10_001),
            "script.commands: expected a list of 1 to 10000 items, got 10001 items",
        ),
    ],
)
def test_wrong_types_name_the_key_path(edit, message):
    data = copy.deepcopy(VALID)
    edit(data)
    with pytest.raises(MjmotionError) as info:
        S.validate(data)
    assert str(info.value).startswith(message), str(info.value)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"duration": ' + "9" * 5000 + "}", "script.duration: expected a finite number > 0, got Infinity"),
        ('{"duration": 1e999}', "script.duration: expected a finite number > 0, got Infinity"),
        ('{"duration": NaN}', "script.duration: expected a finite number > 0, got NaN"),
        ('{"duration": -Infinity}', "script.duration"),
        ("[]", "script: expected an object, got a list"),
        ('{"duration": 1,', "not valid JSON"),
        ('{"duration": 3.0, "duration": 2.0}', "'duration' is given twice in one object"),  # (JSON kept the last: 2 s)
        ('{"commands": [{"at": 0, "at": 1}]}', "'at' is given twice"),
    ],
)
def test_files_name_the_file_and_the_key(tmp_path, text, message):
    p = tmp_path / "s.json"
    p.write_text(text)
    with pytest.raises(MjmotionError) as info:
        S.load(p)
    assert str(info.value).startswith(str(p)) and message in str(info.value), str(info.value)


@pytest.mark.parametrize("path", ["/dev/zero", "fifo", "big"])
def test_scripts_that_are_not_small_regular_files_are_refused_unread(tmp_path, path):
    if path == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no named pipes")
        os.mkfifo(tmp_path / "fifo")
        path, phrase = str(tmp_path / "fifo"), "is a named pipe"
    elif path == "big":
        with open(tmp_path / "big", "wb") as fh:
            fh.truncate(2 << 30)
        path, phrase = str(tmp_path / "big"), "larger than the limit of 1048576 bytes for a JSON stream script"
    else:
        if not os.path.exists(path):
            pytest.skip("no /dev/zero")
        phrase = "is a character device"
    with pytest.raises(MjmotionError, match=phrase):
        S.load(path)


# --- properties -----------------------------------------------------------------------------------
JSON = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers(-(10**40), 10**40) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


def _paths(node, where="script", keys=()):
    """Every (key path, keys) in a JSON document, as :func:`mjmotion.script.validate` names them."""
    out = [(where, keys)]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, S._key(where, k), (*keys, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, f"{where}[{i}]", (*keys, i))
    return out


PATHS = _paths(VALID)[1:]


@PROPS
@given(index=st.integers(0, len(PATHS) - 1), value=JSON)
def test_any_value_anywhere_is_accepted_or_refused_at_its_own_path(index, value):
    where, keys = PATHS[index]
    data = copy.deepcopy(VALID)
    node = data
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    try:
        S.validate(data)
    except MjmotionError as e:
        text = str(e)
        assert text.startswith(where + ":") or text.startswith(where + ".") or text.startswith(where + "["), (where, text)
        assert "\n" not in text and "\x1b" not in text  # quoted values are escaped JSON


@PROPS
@given(data=st.binary(max_size=200) | JSON.map(lambda v: json.dumps(v).encode()))
def test_any_file_is_a_script_or_one_error(tmp_path_factory, data):
    p = tmp_path_factory.mktemp("s") / "s.json"
    p.write_bytes(data)
    try:
        S.load(p)
    except MjmotionError as e:
        assert str(e).startswith(str(p))
