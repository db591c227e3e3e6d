"""Regenerate docs/img/report.png, the report screenshot at the top of the README: the hallway lap run with
`fsmctl run --world diagrams/worlds/hallway.json --report` (paths relative to the repository, so the page shows
none of this machine's), opened in headless Chromium (Debian's, driven by Playwright from the test extra), the
cursor put in the second lap's first turn.

    .venv/bin/python scripts/report_screenshot.py [--out docs/img/report.png]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "img" / "report.png"))
    parser.add_argument("--time", type=float, default=84.0, help="cursor time, s (default 84)")
    args = parser.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("report_screenshot: Chromium is not installed (apt-get install chromium)", file=sys.stderr)
        return 1
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp:
        html = Path(tmp) / "lap.html"
        # The world is named relative to the repository, so the page's header shows no path of this machine.
        subprocess.run([sys.executable, "-m", "fsm.tools.cli", "run", "diagrams/hallway_lap.uxf",
                        "--world", "diagrams/worlds/hallway.json", "--report", str(html), "-q"], check=True, cwd=REPO)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
            page = browser.new_context(offline=True, viewport={"width": 1280, "height": 860},
                                       device_scale_factor=1).new_page()
            page.goto(html.as_uri())
            page.wait_for_function("window.tralReport !== undefined")
            page.evaluate(f"window.tralReport.setTime({args.time})")
            page.screenshot(path=args.out)
            browser.close()
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
