"""Watch expressions in the live page as a person uses them (issue 33, item 3), in Debian's Chromium driven by
Playwright: a watch added, the run stepped and paused, a click on a plot moves the cursor to a tick the server never
sent a value for, and the cell then shows the exact value at that tick; the watch's plot has a point for every tick
of the run so far. Both are compared with a plain run of the same document, read directly after every tick."""

from __future__ import annotations

import json
from typing import Any

from fsm.session.session import StopRules
from live_helpers import REPO
from test_live_browser import browser, chromium  # noqa: F401 (the fixtures)

LAP = str(REPO / "diagrams" / "hallway_lap.json")
TICKS = 600


class Commands:
    """The page's WebSocket through the test: the commands the page sends, in order."""

    def __init__(self) -> None:
        self.sent: list[dict[str, Any]] = []

    def __call__(self, route: Any) -> None:
        server = route.connect_to_server()

        def from_page(message: Any) -> None:
            if isinstance(message, str):
                self.sent.append(json.loads(message))
            server.send(message)

        route.on_message(from_page)


def _plain() -> dict[int, tuple[float, float]]:
    from fsm.sim import simulate

    session = simulate(LAP, world=REPO / "diagrams" / "worlds" / "hallway.json")
    session.start()
    out = {0: (session.car.front, session.car.distance * 2)}
    while session.ticks < TICKS:
        session.run(stop_rules=StopRules(max_ticks=1))
        out[session.ticks] = (session.car.front, session.car.distance * 2)
    return out


def test_the_cell_shows_the_exact_value_at_a_clicked_tick_and_the_plot_every_tick(browser: Any,  # noqa: F811
                                                                                    tmp_path: Any) -> None:
    commands = Commands()
    live, page = browser(LAP, "--paused", "--speed", "max", size=(1600, 1000), sockets=commands)
    p = page.page
    for text in ("car_front", "car_distance * 2"):
        p.fill("#watch-expr", text)
        p.click("#watch-form button")
        page.until(f"(window.tralLive.status() || {{}}).watches.length === {1 if text == 'car_front' else 2}")
    p.fill("#step-n", str(TICKS))
    p.click("#run-step-n")
    page.drawn_at(TICKS)
    assert p.is_checked("#watches tr:first-child input[type=checkbox]")  # a new watch is plotted
    # a click on the run's steering plot, at a third of its width: the cursor goes to that tick
    over = p.query_selector("#plots .u-over")
    assert over is not None
    box = over.bounding_box()
    assert box is not None
    over.click(position={"x": box["width"] * 0.33, "y": box["height"] / 2})  # scrolled into view, as a person does
    tick = page.until("window.tralReport.current().tick !== 600 && window.tralReport.current().tick")
    sent = [row[0] for row in p.evaluate("window.tralLive.watchRows()")]
    assert tick not in sent and 0 < tick < TICKS  # no value was sent for it: the server computes it
    page.until(f"document.getElementById('watch-at').dataset.exact === '1' && "
               f"document.getElementById('watch-at').dataset.tick === '{tick}'")
    cells = p.eval_on_selector_all("#watches td.value", "cs => cs.map(c => [c.dataset.tick, c.dataset.exact, "
                                                        "JSON.parse(c.dataset.value)])")
    plain = _plain()
    assert cells == [[str(tick), "1", plain[tick][0]], [str(tick), "1", plain[tick][1]]]
    assert p.text_content("#watch-at") == f"Values after tick {tick} (exact)."
    # the plot: the value at every tick of the run so far (601 ticks fit the panel's width: not reduced)
    page.until(f"document.getElementById('watch-plot').dataset.to === '{TICKS}'")
    data = p.evaluate("window.tralLive.watchPlot()")
    assert data["reduced"] is False and data["ticks"] == list(range(TICKS + 1))
    assert p.get_attribute("#watch-plot", "data-points") == str(TICKS + 1)
    assert [(a, b) for a, b in zip(*data["series"], strict=True)] == [plain[t] for t in range(TICKS + 1)]
    assert p.eval_on_selector_all("#watch-plot canvas", "c => c.length")
    assert "the value at each of 601 ticks (0 to 600)" in (p.text_content("#watch-plot-note") or "")
    p.screenshot(path=str(tmp_path / "watch.png"))
    p.locator("#watch-box").screenshot(path=str(tmp_path / "watch-box.png"))
    # the run resumed to its end: nothing is asked while it runs; when it has ended, the plot asks once, for every
    # tick of the run (more than the plot's columns: each column's least and greatest value)
    before = len(commands.sent)
    p.click("#run-resume")
    end = page.until("(window.tralLive.status() || {}).state === 'ended' && window.tralLive.status().tick", 60)
    page.until(f"document.getElementById('watch-plot').dataset.to === '{end}'")
    asked = [c for c in commands.sent[before:] if c["cmd"] != "resume"]
    assert [(c["cmd"], c["from"], c["to"]) for c in asked] == [("watch_values", 0, end)], asked
    data = p.evaluate("window.tralLive.watchPlot()")
    assert data["reduced"] is True and data["computed"] == end + 1 and data["ticks"][-1] == end
    assert p.get_attribute("#watch-plot", "data-points") == str(2 * asked[0]["width"])
    # a drag across the watch plot: every tick of that range, not reduced
    over = p.query_selector("#watch-plot .u-over")
    assert over is not None
    over.scroll_into_view_if_needed()
    box = over.bounding_box()
    assert box is not None
    y = box["y"] + box["height"] / 2
    p.mouse.move(box["x"] + box["width"] * 0.40, y)
    p.mouse.down()
    p.mouse.move(box["x"] + box["width"] * 0.44, y, steps=4)
    p.mouse.up()
    page.until("document.getElementById('watch-plot').dataset.reduced === '0' && "
               "document.getElementById('watch-plot').dataset.state === 'drawn'")
    data = p.evaluate("window.tralLive.watchPlot()")
    first, last = data["from"], data["to"]
    assert 0.35 * end < first < last < 0.5 * end and data["ticks"] == list(range(first, last + 1))
    assert "double-click for the whole run" in (p.text_content("#watch-plot-note") or "")
    p.locator("#watch-box").screenshot(path=str(tmp_path / "watch-range.png"))
    p.click("#run-stop")
    code, _out, err = live.wait()
    assert code == 0, err
