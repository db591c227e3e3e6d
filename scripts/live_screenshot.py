"""Regenerate docs/img/live.png, the live page's screenshot in docs/live.md: the gate run started with
`fsmctl run diagrams/gate_run.uxf --world diagrams/worlds/gates.json --live --paused --speed max` (paths relative to
the repository, run from it, so the page shows none of this machine's paths), opened in headless Chromium (Debian's,
driven by Playwright from the test extra) at 1,600 x 1,000, a breakpoint on entering ``*/through`` added in the
page with two watch expressions, Resume clicked, and "Why" opened where the run stopped.

    .venv/bin/python scripts/live_screenshot.py [--out docs/img/live.png]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
COMMAND = ["run", "diagrams/gate_run.uxf", "--world", "diagrams/worlds/gates.json", "--live", "--paused",
           "--speed", "max", "--port", "0"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "img" / "live.png"))
    args = parser.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("live_screenshot: Chromium is not installed (apt-get install chromium)", file=sys.stderr)
        return 1
    fsmctl = Path(sys.executable).with_name("fsmctl")
    proc = subprocess.Popen([str(fsmctl), *COMMAND], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        if not line.startswith("live: "):
            print(f"live_screenshot: the run printed no URL: {line!r}", file=sys.stderr)
            return 1
        shoot(line.split(" ", 1)[1].strip(), chromium, args.out)
    finally:
        proc.terminate()
        proc.communicate(timeout=30)
    print(f"wrote {args.out}")
    return 0


def shoot(url: str, chromium: str, out: str) -> None:
    """The page at ``url`` paused at the breakpoint, with watches, saved as ``out``."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        page = browser.new_context(viewport={"width": 1600, "height": 1000}, device_scale_factor=1).new_page()
        page.goto(url)
        page.wait_for_selector("#conn.up", timeout=20_000)
        page.select_option("#break-kind", "enter")
        page.fill("#break-a", "*/through")
        page.click("#break-form button")
        page.wait_for_selector("#breaks tr", timeout=10_000)
        for expr in ("car_front", "car_speed"):
            page.fill("#watch-expr", expr)
            page.click("#watch-form button")
            page.wait_for_selector("#watch-expr:placeholder-shown", timeout=10_000)  # the server took it
        page.click("#run-resume")
        page.wait_for_selector("#hit:not([hidden])", timeout=60_000)
        page.click("#why-box summary")
        page.wait_for_selector("#why tbody tr", timeout=10_000)
        page.wait_for_selector("#watches tr:nth-child(2)", timeout=10_000)
        page.wait_for_timeout(500)  # the plots and the chart settle
        page.screenshot(path=out)
        browser.close()


if __name__ == "__main__":
    sys.exit(main())
