"""Take the README's Studio screenshots: ``python docs/studio_screenshots.py [--out docs/images]``.

Starts a Studio on the bundled clips, opens it in headless Chromium (Debian's package, driven by
Playwright), runs each tab's main action and saves ``studio_<tab>.png``; ``studio_skin.png`` is
the Blend tab's result with the Character menu on ``skin (LBS)``. ``--only NAME …`` takes just
those (the others are still made, as the later ones follow from them, but not written).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def main() -> int:
    from playwright.sync_api import sync_playwright

    from mjmotion.studio.app import CHROMIUM_ARGS, Studio
    from mjmotion.studio.clips import ClipLibrary

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=str(REPO / "docs" / "images"))
    p.add_argument("--only", nargs="*", default=None, metavar="NAME", help="write only these (stream, blend, skin, hit, vary, evaluate)")
    args = p.parse_args()
    out = Path(args.out)
    studio = Studio(ClipLibrary.bundled(), port=0, out_dir="/tmp/mjmotion_studio_shots")
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=shutil.which("chromium"), headless=True, args=list(CHROMIUM_ARGS))
            page = browser.new_page(viewport={"width": 1280, "height": 760})
            page.goto(studio.url)
            page.get_by_role("tab", name="Stream").wait_for(timeout=60_000)
            session = next(iter(studio.sessions.values()))

            def idle(extra: float = 1.5) -> None:
                time.sleep(0.3)
                session.worker.wait_idle(120)
                time.sleep(extra)

            def shot(name: str) -> None:
                if args.only is not None and name not in args.only:
                    return
                for close in page.locator("button.mantine-Notification-closeButton").all():
                    close.click()
                time.sleep(0.5)
                page.screenshot(path=str(out / f"studio_{name}.png"))
                print(f"wrote {out / f'studio_{name}.png'}")

            def button(label: str) -> None:
                page.get_by_role("button", name=label, exact=True).click()

            idle(3.0)
            page.get_by_role("tab", name="Stream").click()
            button("Kick")
            time.sleep(1.2)
            shot("stream")
            page.get_by_role("tab", name="Blend").click()
            button("Blend")
            idle()
            shot("blend")
            with session.lock:
                session.player.playing = False
                session.player.seek(70)  # mid-stride, the knees and elbows bent
                session._draw(70)
            session.set_draw_mode("skin (LBS)")
            idle()
            shot("skin")
            session.set_draw_mode("capsules")
            idle(0.5)
            with session.lock:
                session.player.playing = True
            page.get_by_role("tab", name="Hit").click()
            button("Load shot")
            idle()
            hit = session.tabs["Hit"]
            hit.solve(hit.shot.source_point + [0.0, 0.08, 0.1], "dls", final=True)
            idle()
            shot("hit")
            page.get_by_role("tab", name="Vary").click()
            button("Make variant")
            idle()
            shot("vary")
            page.get_by_role("tab", name="Evaluate").click()
            page.get_by_role("tab", name="Blend").click()
            button("Blend")
            idle()
            page.get_by_role("tab", name="Evaluate").click()
            button("Evaluate shown clip")
            idle()
            shot("evaluate")
            browser.close()
    finally:
        studio.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
