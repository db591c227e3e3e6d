"""The HTML report in a real browser (issue 11): Debian's Chromium, headless, driven by Playwright (which downloads
no browser of its own here). The page is loaded with the network off and every request intercepted: only the file
itself may be fetched, and nothing may be logged as an error. The cursor is dragged on the state lanes and moved
with the keyboard, and what the page highlights and lists is compared with the trace read in Python.

`.ci/run` installs Chromium when it is missing, so in CI (``CI`` set) these tests never skip; elsewhere they skip
when Chromium or Playwright is not there, saying which."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import pytest

from fsm.trace.replay import read_trace
from helpers import cli

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _need_browser() -> None:
    why = None
    if CHROMIUM is None:
        why = "Chromium is not installed (apt-get install chromium; .ci/run does)"
    else:
        try:
            import playwright.sync_api  # noqa: F401
        except ImportError:
            why = "playwright is not installed (pip install -e '.[test]')"
    if why is not None:
        if os.environ.get("CI"):
            pytest.fail(f"browser tests must run in CI: {why}")
        pytest.skip(why)


class Page:
    """One headless Chromium page with the network off; what it requested and logged."""

    def __init__(self, pw: Any, path: Path) -> None:
        self.browser = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        self.context = self.browser.new_context(offline=True, viewport={"width": 1400, "height": 1000})
        self.page = self.context.new_page()
        self.url = path.resolve().as_uri()
        self.requests: list[str] = []
        self.errors: list[str] = []
        self.dialogs: list[str] = []
        self.context.route("**/*", self._route)
        self.page.on("console", lambda m: self.errors.append(m.text) if m.type in ("error", "warning") else None)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("dialog", lambda d: (self.dialogs.append(d.message), d.dismiss()))
        self.page.goto(self.url)
        self.page.wait_for_function("window.tralReport !== undefined")

    def _route(self, route: Any) -> None:
        self.requests.append(route.request.url)
        if route.request.url == self.url:
            route.continue_()
        else:
            route.abort()

    def current(self) -> dict[str, Any]:
        return self.page.evaluate("window.tralReport.current()")

    def highlighted(self) -> set[str]:
        return set(self.page.eval_on_selector_all("#chart g.active[data-path]",
                                                  "els => els.map(e => e.getAttribute('data-path'))"))

    def variables(self) -> dict[str, Any]:
        rows = self.page.eval_on_selector_all(
            "#vars tr[data-name]", "rows => rows.map(r => [r.dataset.name, r.cells[1].dataset.value])")
        return {name: json.loads(value) for name, value in rows}

    def close(self) -> None:
        self.browser.close()


@pytest.fixture(scope="module")
def mission_report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    from fsm.tools.cli import main

    out = tmp_path_factory.mktemp("report")
    code = main(["run", str(REPO / "diagrams" / "mission.json"), "--world", str(REPO / "diagrams" / "worlds" /
                 "obstacle.json"), "--signal", "pause@5", "--signal", "pause=0@5.1", "--signal", "pause@8",
                 "--signal", "pause=0@8.1", "--duration", "60", "--expect", "succeeded",
                 "--trace", str(out / "t.jsonl"), "--report", str(out / "r.html"), "-q"])
    assert code == 0
    return out / "t.jsonl", out / "r.html"


def _expected_highlight(active: list[str], drawn: set[str]) -> set[str]:
    out = set()
    for leaf in active:
        parts = leaf.split("/")
        out |= {"/".join(parts[:n]) for n in range(1, len(parts) + 1)} & drawn
    return out


def test_the_report_replays_the_trace_at_the_dragged_cursor(mission_report: tuple[Path, Path],
                                                           tmp_path: Path) -> None:
    _need_browser()
    from playwright.sync_api import sync_playwright

    trace_file, html = mission_report
    trace = read_trace(trace_file)
    with sync_playwright() as pw:
        p = Page(pw, html)
        try:
            drawn = set(p.page.eval_on_selector_all("#chart g[data-path]", "els => els.map(e => e.dataset.path)"))
            assert {"mission", "mission/drive"} <= drawn
            box = p.page.locator("#lanes").bounding_box()
            assert box is not None
            y = box["y"] + 9
            checked = 0
            p.page.mouse.move(box["x"] + 200, y)
            p.page.mouse.down()
            for frac in (0.05, 0.2, 0.35, 0.5, 0.65, 0.8, 0.95):  # a drag across the whole run
                p.page.mouse.move(box["x"] + 170 + (box["width"] - 178) * frac, y, steps=3)
                now = p.current()
                active, variables = trace.at(now["tick"])
                assert now["active"] == active and now["vars"] == variables
                assert p.highlighted() == _expected_highlight(active, drawn)
                assert p.variables() == variables
                assert p.page.inner_text("#active") == ", ".join(active)
                checked += 1
            p.page.mouse.up()
            assert checked == 7 and p.current()["time"] > 0.9 * trace.end["time"]
            # each plot's cursor line runs from the top of its plot area to its x axis, at the cursor's time (it
            # once started over the title and stopped short of the axis)
            for line, area in p.page.eval_on_selector_all(".plot", """plots => plots.map(d => {
                const l = d.querySelector('.cursor').getBoundingClientRect();
                const a = d.querySelector('.u-over').getBoundingClientRect();
                return [[l.top, l.bottom, l.left], [a.top, a.bottom, a.left, a.right]];
            })"""):
                assert line[:2] == pytest.approx(area[:2], abs=1), (line, area)
                assert area[2] <= line[2] <= area[3]

            # Home, then Right: the first transition after the initial entries; Left goes back
            p.page.keyboard.press("Home")
            p.page.keyboard.press("ArrowRight")
            times = sorted({tr["time"] for e in trace.events for tr in e["transitions"] if tr["from"] is not None})
            assert p.current()["time"] == pytest.approx(times[0])
            p.page.keyboard.press("ArrowRight")
            assert p.current()["time"] == pytest.approx(times[1])
            p.page.keyboard.press("ArrowLeft")
            assert p.current()["time"] == pytest.approx(times[0])
            # Space plays and pauses
            start = p.current()["time"]
            p.page.keyboard.press("Space")
            p.page.wait_for_timeout(400)
            p.page.keyboard.press("Space")
            later = p.current()["time"]
            p.page.wait_for_timeout(200)
            assert later > start and p.current()["time"] == later

            # a state's visits; folding a composite hides what is inside it (the chart is seen through a zoomable
            # window, which a click cannot scroll, and "fit" shows the part around the active state that is
            # readable: the clicks go to the elements wherever the view is)
            p.page.check("#fit")
            p.page.locator('#chart g[data-path="mission/drive"] > rect').first.dispatch_event("click")
            visits = p.page.eval_on_selector_all("#visits tbody tr", "rows => rows.length")
            lanes = json.loads(p.page.evaluate("JSON.stringify(window.tralReport.stateAt(0))"))
            assert visits >= 1 and lanes["active"]
            inner = '#chart g[data-path^="mission/drive/"]'
            assert p.page.locator(inner).count() > 0
            p.page.locator('#chart g[data-path="mission/drive"] > text').first.dispatch_event("click")
            classes = p.page.eval_on_selector_all(inner, "els => els.map(e => e.className.baseVal)")
            assert all("hidden" in (c or "") for c in classes)

            p.page.evaluate(f"window.tralReport.setTime({trace.end['time'] / 3})")
            p.page.screenshot(path=str(tmp_path / "report.png"), full_page=True)
            assert (tmp_path / "report.png").stat().st_size > 20_000
            assert p.requests == [p.url], p.requests  # the file itself, nothing else
            assert p.errors == [] and p.dialogs == []
        finally:
            p.close()


def test_machine_strings_render_as_text_in_the_browser(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    _need_browser()
    from playwright.sync_api import sync_playwright

    doc = {"name": "</script><script>alert('name')</script>", "initial": "<img src=x onerror=alert('id')>",
           "vars": {"v": "<script>alert('var')</script>"},
           "states": [{"id": "<img src=x onerror=alert('id')>", "type": "Idle"}, {"id": "b & <c>", "type": "Final"}],
           "transitions": [{"type": "Timeout", "from": "<img src=x onerror=alert('id')>", "to": "b & <c>",
                            "seconds": 0.2}]}
    (tmp_path / "evil.json").write_text(json.dumps(doc))
    code, _, err = cli(capsys, "run", str(tmp_path / "evil.json"), "--report", str(tmp_path / "r.html"), "-q")
    assert code == 0, err
    with sync_playwright() as pw:
        p = Page(pw, tmp_path / "r.html")
        try:
            assert p.page.inner_text("#title") == doc["name"]
            p.page.evaluate("window.tralReport.setTime(0.05)")
            assert p.variables() == {"v": doc["vars"]["v"]}
            assert p.page.inner_text("#active") == doc["initial"]
            assert p.page.locator("img[src='x']").count() == 0
            assert p.dialogs == [] and p.errors == [] and p.requests == [p.url]
        finally:
            p.close()


def test_the_report_at_800_px_keys_values_steering_and_lane_names(mission_report: tuple[Path, Path],
                                                                  capsys: pytest.CaptureFixture[str],
                                                                  tmp_path: Path) -> None:
    """The report fixes of issue 24 item 7: at 800 px nothing overflows (the camera box included), End moves the
    cursor and not the page, the steering plot shows the command as recorded (-1 to 1, not converted as radians),
    long floats print short (the full value in the cell's title), lanes are named by their composites."""
    _need_browser()
    from playwright.sync_api import sync_playwright

    trace_file, html = mission_report
    trace = read_trace(trace_file)
    doc = {"name": "floats", "initial": "a", "vars": {"x": 0.1},
           "states": [{"id": "a", "type": "Idle", "set": {"on_enter": {"x": "x + 0.2"}}}, {"id": "b", "type": "Final"}],
           "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.1}]}
    (tmp_path / "floats.json").write_text(json.dumps(doc))
    code, _, err = cli(capsys, "run", str(tmp_path / "floats.json"), "--report", str(tmp_path / "f.html"), "-q")
    assert code == 0, err
    with sync_playwright() as pw:
        p = Page(pw, html)
        try:
            p.page.set_viewport_size({"width": 800, "height": 900})
            p.page.reload()
            p.page.wait_for_function("window.tralReport !== undefined")
            p.page.evaluate("document.getElementById('camera-box').style.display = ''")
            width = p.page.evaluate("document.documentElement.scrollWidth")
            camera = p.page.evaluate("document.getElementById('camera').getBoundingClientRect().right")
            assert width <= 800 and camera <= 800
            p.page.screenshot(path=str(tmp_path / "report-800.png"), full_page=True)
            p.page.evaluate("window.scrollTo(0, 0)")
            p.page.focus("#lanes")
            p.page.keyboard.press("End")
            assert p.page.evaluate("window.scrollY") == 0
            assert p.current()["time"] == pytest.approx(p.page.evaluate("window.tralReport.end()"))
            steering = [s["car"]["steering"] for s in trace.samples if "car" in s]
            shown = p.page.evaluate("JSON.parse(document.getElementById('data').textContent).samples['car.steering']")
            assert shown == pytest.approx(steering, abs=6e-4) and max(abs(v) for v in shown) <= 1
            titles = p.page.eval_on_selector_all(".plot .u-title", "els => els.map(e => e.textContent)")
            assert "Steering (-1 to 1)" in titles
            labels = p.page.evaluate("JSON.parse(document.getElementById('data').textContent).lanes.map(l => l.label)")
            assert labels and not [label for label in labels if label.startswith("level ")], labels
            assert p.errors == [] and p.dialogs == []
        finally:
            p.close()
        p = Page(pw, tmp_path / "f.html")
        try:
            p.page.evaluate("window.tralReport.setTime(0.05)")
            cell = p.page.locator("#vars tr[data-name='x'] td").nth(1)
            assert cell.text_content() == "0.3" and cell.get_attribute("title") == "0.30000000000000004"
        finally:
            p.close()


def test_the_statechart_folds_all_but_the_active_path_zooms_pans_and_finds(capsys: pytest.CaptureFixture[str],
                                                                          tmp_path: Path) -> None:
    """Issue 24 item 7: the hallway lap's tall drawing seen through a window: the wheel zooms, a drag pans (and is no
    click on a state), "fold all but the active path" folds every other composite, a search finds states by name
    and Enter shows the next; the wheel over the lanes zooms time, a double click shows the whole run."""
    _need_browser()
    from playwright.sync_api import sync_playwright

    code, _, err = cli(capsys, "run", str(REPO / "diagrams" / "hallway_lap.json"), "--duration", "80",
                       "--report", str(tmp_path / "r.html"), "-q")
    assert code in (0, 1), err
    view = "(() => { const v = document.querySelector('#chart svg').viewBox.baseVal; return [v.x, v.y, v.width]; })()"
    with sync_playwright() as pw:
        p = Page(pw, tmp_path / "r.html")
        try:
            p.page.evaluate("window.tralReport.setTime(70)")
            active = p.current()["active"]
            assert active and active[0].startswith("lap2/")
            p.page.check("#fold-rest")
            folded = set(p.page.eval_on_selector_all("#chart g.composite.folded",
                                                     "els => els.map(e => e.dataset.path)"))
            assert "lap1" in folded and "lap3" in folded and "lap2" not in folded
            assert p.page.locator('#chart g[data-path="lap1/bottom"]').first.get_attribute("class").count("hidden") == 1
            assert p.page.locator('#chart g[data-path="lap2/bottom"]').first.get_attribute("class").count("hidden") == 0
            # a folded composite is its title band and what is below it moves up; unfolded, the drawing as it was
            lap2_y = 'document.querySelector(\'#chart g[data-path="lap2"] rect\').getAttribute("y")'
            lap1_h = 'document.querySelector(\'#chart g[data-path="lap1"] rect\').getAttribute("height")'
            # (issue 33: the laps now stand side by side, so a folded lap shrinks only where nothing stands beside it)
            height = "parseFloat(document.querySelector('#chart svg').dataset.height)"
            folded_h, folded_lap1, folded_y = (float(p.page.evaluate(js)) for js in (height, lap1_h, lap2_y))
            p.page.uncheck("#fold-rest")
            full_h = float(p.page.evaluate(height))
            assert full_h < 6000 and folded_h <= full_h
            assert float(p.page.evaluate(lap1_h)) >= folded_lap1 and float(p.page.evaluate(lap2_y)) >= folded_y
            p.page.check("#fold-rest")
            # wheel: zoom in about the pointer; drag: pan, and no state's visits open
            box = p.page.locator("#chart").bounding_box()
            x0, y0, w0 = p.page.evaluate(view)
            p.page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
            p.page.mouse.wheel(0, -400)
            x1, y1, w1 = p.page.evaluate(view)
            assert w1 < w0 * 0.7
            p.page.mouse.down()
            p.page.mouse.move(box["x"] + box["width"] / 2 + 120, box["y"] + box["height"] / 2 + 80, steps=4)
            p.page.mouse.up()
            x2, y2, w2 = p.page.evaluate(view)
            assert w2 == w1 and x2 < x1 and y2 < y1
            assert p.page.text_content("#visits-of") == ""
            # search: the matches marked, Enter brings the next into view
            p.page.fill("#chart-search", "bottom_turn/arc")
            assert p.page.text_content("#chart-found") == "3 found"
            p.page.press("#chart-search", "Enter")
            assert p.page.text_content("#chart-found") == "1 of 3: lap1/bottom_turn/arc"
            inside = p.page.evaluate("""(() => {
                const g = document.querySelector('#chart g[data-path="lap1/bottom_turn/arc"]'), r = g.getBBox();
                const v = document.querySelector('#chart svg').viewBox.baseVal;
                return r.x >= v.x && r.y >= v.y && r.x + r.width <= v.x + v.width && r.y + r.height <= v.y + v.height;
            })()""")
            assert inside
            p.page.screenshot(path=str(tmp_path / "chart.png"))
            # time zoom on the lanes; a double click shows the whole run again
            lanes = p.page.locator("#lanes").bounding_box()
            p.page.mouse.move(lanes["x"] + lanes["width"] * 0.6, lanes["y"] + 10)
            p.page.mouse.wheel(0, -600)
            window = p.page.evaluate("document.getElementById('lanes').dataset.window").split()
            assert 0 < float(window[0]) < float(window[1]) < 80 and float(window[1]) - float(window[0]) < 40
            p.page.mouse.dblclick(lanes["x"] + lanes["width"] * 0.6, lanes["y"] + 10)
            assert p.page.evaluate("document.getElementById('lanes').dataset.window") == ""
            assert p.errors == [] and p.dialogs == []
        finally:
            p.close()
