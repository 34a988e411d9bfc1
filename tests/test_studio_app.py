"""The Studio in a real browser: headless Chromium (Debian's package) driven by Playwright.

One server and one browser serve every test (module fixtures); each test opens its own pages,
which are their own sessions. Skipped when Playwright or Chromium is missing, except in CI
(``CI`` set), where that is a failure.
"""

from __future__ import annotations

import io
import os
import shutil
import time

import numpy as np
import pytest

from mjmotion import bvh, kinematics, mjcf, synth
from mjmotion.studio.app import CHROMIUM_ARGS as ARGS

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _need(ok: bool, what: str) -> None:
    if not ok:
        if os.environ.get("CI"):
            pytest.fail(f"{what} is required in CI (.ci/run installs it)")
        pytest.skip(f"{what} not installed")


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    from mjmotion.studio.app import Studio
    from mjmotion.studio.clips import ClipLibrary

    s = Studio(ClipLibrary.bundled(), port=0, out_dir=tmp_path_factory.mktemp("studio_out"))
    yield s
    s.stop()


@pytest.fixture(scope="module")
def browser():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _need(False, "playwright")
    _need(CHROMIUM is not None, "chromium")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=list(ARGS))
        yield b
        b.close()


class Page:
    """A browser page on the studio and the server's session behind it."""

    def __init__(self, browser, studio):
        before = set(studio.sessions)
        self.context = browser.new_context(viewport={"width": 1100, "height": 720})
        self.page = self.context.new_page()
        self.page.goto(studio.url)
        self.page.get_by_role("tab", name="Stream").wait_for(timeout=30_000)
        end = time.monotonic() + 20
        while not (set(studio.sessions) - before) and time.monotonic() < end:
            time.sleep(0.05)
        (cid,) = set(studio.sessions) - before
        self.session = studio.sessions[cid]
        self.idle()

    def idle(self) -> None:
        time.sleep(0.2)
        assert self.session.worker.wait_idle(60)

    def tab(self, name: str) -> None:
        self.page.get_by_role("tab", name=name).click()

    def click(self, button: str) -> None:
        self.page.get_by_role("button", name=button, exact=True).click()

    def field(self, label: str, i: int = 0):
        """The ``i``-th input of the GUI row labelled ``label``."""
        row = self.page.locator(f"xpath=//label[normalize-space()='{label}']/ancestor::div[contains(@class,'mantine-Flex-root')][1]")
        return row.filter(visible=True).locator("input:not([type=hidden])").nth(i)  # tabs reuse labels: the open tab's

    def set_number(self, label: str, value: float, i: int = 0) -> None:
        f = self.field(label, i)
        f.fill(f"{value:g}")
        f.press("Enter")

    def wait_for(self, predicate, timeout: float = 15.0) -> None:
        end = time.monotonic() + timeout
        while not predicate():
            assert time.monotonic() < end, "timed out"
            time.sleep(0.05)

    def pause(self) -> None:
        """Stop the stream's clock (less for software WebGL to draw in tests that do not watch it)."""
        with self.session.lock:
            self.session.player.playing = False

    def close(self) -> None:
        self.context.close()


@pytest.fixture
def page(browser, studio):
    p = Page(browser, studio)
    yield p
    p.close()


def _speed(session, seconds: float = 1.0) -> float:
    """Floor speed (m/s) of the stream character the server computes, over ``seconds`` of stream time."""
    f0 = session.live_frame
    time.sleep(seconds)
    f1 = session.live_frame
    return float(np.linalg.norm(f1.root_position[:2] - f0.root_position[:2]) / ((f1.index - f0.index) / session.live.fps))


def _blue_pixels(page) -> tuple[float, int]:
    """Spread of the scene's pixels (left of the panel) and how many are the first character's blue."""
    import imageio.v3 as iio

    shot = iio.imread(io.BytesIO(page.page.screenshot()))[:, :680, :3].astype(int)
    # the floor and its grid are grey; the first character is blue (77, 140, 217), paler where lit
    blue = (shot[..., 2] - shot[..., 0] > 25) & (shot[..., 2] >= shot[..., 1])
    return float(shot.std()), int(blue.sum())


def test_page_loads_and_draws_a_non_blank_scene(page):
    page.wait_for(lambda: page.session.live_frame is not None and page.session.live_frame.index > 10)
    spread, blue = _blue_pixels(page)
    end = time.monotonic() + 20
    while blue < 300 and time.monotonic() < end:  # the client fades the scene in after loading
        time.sleep(1.0)
        spread, blue = _blue_pixels(page)
    assert spread > 10 and blue > 300, f"the character is not drawn (spread {spread:.1f}, {blue} blue pixels)"


def test_each_tab_opens_by_name(page):
    page.pause()
    unique = {"Blend": "Blend", "Stream": "Kick", "Hit": "Load shot", "Vary": "Make variant", "Evaluate": "Evaluate shown clip"}
    for tab, button in unique.items():
        page.tab(tab)
        page.page.get_by_role("button", name=button, exact=True).wait_for(state="visible", timeout=5_000)


def test_weight_slider_changes_the_pose_the_server_computes(page):
    page.tab("Stream")
    page.wait_for(lambda: page.session.live_frame is not None)
    walk_speed = _speed(page.session)
    q_before = page.session.live_qpos()
    page.set_number("Ramp (s)", 0.2)
    page.set_number("Weight 2", 1.0)
    page.set_number("Weight 1", 0.0)
    page.wait_for(lambda: page.session.live_frame.weights[1] > 0.999)
    run_speed = _speed(page.session)
    # the bundled walk is 1.3 m/s, the run 3.2 m/s
    assert walk_speed == pytest.approx(1.3, rel=0.15) and run_speed == pytest.approx(3.2, rel=0.15)
    assert not np.allclose(q_before, page.session.live_qpos())


def test_kick_starts_a_transition_and_the_stream_returns_to_locomotion(page):
    page.tab("Stream")
    page.wait_for(lambda: page.session.live_frame is not None)
    page.click("Kick")
    page.wait_for(lambda: page.session.live_frame.action == "kick" and page.session.live_frame.action_weight > 0.99, timeout=10)
    page.wait_for(lambda: page.session.live_frame.action is None, timeout=15)
    n = page.session.live_frame.index
    assert _speed(page.session) == pytest.approx(1.3, rel=0.15)  # walking again, and the clock runs on
    assert page.session.live_frame.index > n


def test_setting_the_ball_in_the_gui_gives_an_adapted_shot_that_reaches_it(page):
    page.pause()
    page.tab("Hit")
    page.click("Load shot")
    page.idle()
    hit = page.session.tabs["Hit"]
    source = hit.shot.source_point
    page.wait_for(lambda: abs(float(page.field("Ball", 2).input_value() or 0) - source[2]) < 0.01)  # the server set the field
    z = float(page.field("Ball", 2).input_value())
    page.set_number("Ball", z + 0.1, i=2)
    page.idle()
    target = np.array(hit.ball.value)
    assert target[2] == pytest.approx(z + 0.1) and hit.result is not None
    # the shown character's bat meets the ball at the hit frame (FK of what the page shows)
    actor = page.session.shown
    spot = kinematics.forward(mjcf.compile(actor.motion.skeleton, actor.props), actor.motion).site("bat/sweet_spot")[hit.shot.hit_frame]
    assert np.linalg.norm(spot - target) < 1e-3
    assert "reached | True" in hit.report.content and "launch speed" in hit.report.content


def test_bad_upload_shows_an_error_and_the_app_keeps_serving(page, tmp_path):
    page.pause()
    page.page.get_by_text("Files", exact=True).click()
    upload = page.page.locator("input[type=file]")
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    upload.set_input_files(str(bad))
    page.wait_for(lambda: "error" in page.session.status.content)
    assert "broken.bvh:4" in page.session.status.content
    page.page.get_by_text("broken.bvh:4", exact=False).first.wait_for(timeout=5_000)  # shown in the page
    good = tmp_path / "mywalk.bvh"
    bvh.write(synth.walk(speed=1.1).motion, good)
    upload.set_input_files(str(good))
    page.wait_for(lambda: "loaded mywalk" in page.session.status.content)
    assert "mywalk" in page.session.library.names()
    n = page.session.live_frame.index
    page.click("Play")
    page.wait_for(lambda: page.session.live_frame.index > n + 10)  # still streaming


def test_two_pages_at_once_keep_separate_state(browser, studio, tmp_path):
    a, b = Page(browser, studio), Page(browser, studio)
    try:
        assert a.session is not b.session and a.session.live is not b.session.live
        b.tab("Stream")
        b.click("Kick")
        a.tab("Stream")
        a.set_number("Weight 2", 1.0)
        a.wait_for(lambda: a.session.live.target_weights[1] > 0.4)
        b.wait_for(lambda: any(f.action == "kick" for f in list(b.session.live_record)), timeout=10)
        assert not any(f.action for f in list(a.session.live_record)) and a.session.live.target_weights[1] == pytest.approx(0.5)
        assert b.session.live.target_weights[0] == pytest.approx(1.0)
        good = tmp_path / "only_b.bvh"
        bvh.write(synth.walk(speed=1.0).motion, good)
        b.page.get_by_text("Files", exact=True).click()
        b.page.locator("input[type=file]").set_input_files(str(good))
        b.wait_for(lambda: "only_b" in b.session.library.names())
        assert "only_b" not in a.session.library.names() and "only_b" not in studio.library.names()
    finally:
        a.close()
        b.close()
