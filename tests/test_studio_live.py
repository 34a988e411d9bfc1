"""The live stream (mjmotion.studio.live): frame-by-frame control agrees with the batch stream and never jumps."""

from __future__ import annotations

import numpy as np
import pytest

from mjmotion import stream as st
from mjmotion import synth
from mjmotion.blend import yaw_of
from mjmotion.errors import MjmotionError
from mjmotion.studio.live import LiveStream

FPS = 60.0


@pytest.fixture(scope="module")
def clips():
    return {
        "walk": synth.walk().motion.replace(name="walk"),
        "run": synth.run().motion.replace(name="run"),
        "kick": synth.kick().motion.replace(name="kick"),
        "punch": synth.punch().motion.replace(name="punch"),
    }


def _live(clips, weights=None) -> LiveStream:
    return LiveStream([clips["walk"], clips["run"]], {"kick": clips["kick"], "punch": clips["punch"]}, weights=weights)


def test_live_stream_equals_the_batch_stream_fed_the_same_commands(clips):
    # weight ramps (one requested during another), loops, a punch cutting a kick short, an early return
    commands = (
        st.Command(0.0, "weights", np.array([1.0, 0.0]), ramp=0.0),
        st.Command(1.0, "weights", np.array([0.5, 0.5]), ramp=0.8),
        st.Command(1.5, "weights", np.array([0.2, 0.8]), ramp=0.6),
        st.Command(2.5, "play", clip="kick", blend=0.3),
        st.Command(3.5, "play", clip="punch", blend=0.25),
        st.Command(4.0, "weights", np.array([1.0, 0.0]), ramp=0.5),
        st.Command(4.8, "return", blend=0.2),
        st.Command(6.5, "play", clip="kick", blend=0.3),
    )
    script = st.Script(clips=clips, locomotion=("walk", "run"), commands=commands, duration=10.0, fps=FPS)
    batch = st.stream(script)
    live = _live(clips)
    frames = []
    todo = list(commands[1:])
    for n in range(batch.n_frames):
        while todo and round(todo[0].time * FPS) == n:
            c = todo.pop(0)
            if c.kind == "weights":
                live.set_weights(c.weights, c.ramp)
            elif c.kind == "play":
                live.play(c.clip, c.blend)
            else:
                live.stop_action(c.blend)
        frames.append(live.step())
    root = np.stack([f.root_position for f in frames])
    q = np.stack([f.rotations for f in frames])
    assert np.max(np.abs(root - batch.root_positions)) < 1e-9
    # quaternions are equal up to sign
    assert np.max(1.0 - np.abs(np.einsum("tjc,tjc->tj", q, batch.rotations))) < 1e-9
    # the stream looped (the walk is 4 s long) and both actions carried the layer
    assert max(f.action_weight for f in frames) > 0.99
    assert {f.action for f in frames} >= {"kick", "punch", None}


def test_presses_at_any_time_never_jump_or_spin(clips):
    # seed 000 §4.1: no time blip (a large turn in one frame) and weights always a proper blend
    rng = np.random.default_rng(3)
    live = _live(clips)
    src_step = max(float(np.max(np.linalg.norm(np.diff(m.root_positions[:, :2], axis=0), axis=1))) for m in clips.values())
    src_turn = max(float(np.max(np.abs(np.diff(np.unwrap(yaw_of(m.rotations[:, 0])))))) for m in clips.values())
    prev = None
    for _ in range(900):
        r = rng.random()
        if r < 0.02:
            w = rng.dirichlet([1.0, 1.0])
            live.set_weights(w, float(rng.choice([0.0, 0.2, 0.8])))
        elif r < 0.03:
            live.play(str(rng.choice(["kick", "punch"])), float(rng.choice([0.1, 0.3])))
        elif r < 0.035:
            live.stop_action(0.2)
        f = live.step()
        assert np.all(np.isfinite(f.root_position)) and np.all(np.isfinite(f.rotations))
        assert np.all(f.weights >= -1e-12) and abs(f.weights.sum() - 1.0) < 1e-9
        assert 0.0 <= f.action_weight <= 1.0
        if prev is not None:
            assert np.linalg.norm(f.root_position[:2] - prev.root_position[:2]) <= 1.05 * src_step
            assert abs(f.heading - prev.heading) <= 1.05 * src_turn + 1e-9
        prev = f


def test_kick_starts_and_returns_to_locomotion(clips):
    live = _live(clips)
    for _ in range(30):
        live.step()
    live.play("kick", 0.3)
    layer = [live.step().action_weight for _ in range(clips["kick"].n_frames + 30)]
    assert layer[0] == 0.0 and max(layer) == pytest.approx(1.0) and layer[-1] == 0.0
    assert live.step().action is None


def test_bad_requests_are_refused(clips):
    live = _live(clips)
    with pytest.raises(MjmotionError, match="sum to"):
        live.set_weights([0.5, 0.6])
    with pytest.raises(MjmotionError, match="no action named"):
        live.play("dance")
    with pytest.raises(MjmotionError, match="too short"):
        live.play("kick", blend=10.0)
