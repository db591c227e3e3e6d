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

from fsm.session.inputs import recorded_inputs
from fsm.session.session import Session
from fsm.trace.replay import read_trace
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

    def __init__(self, chromium: Any, live: Live, size: tuple[int, int] = (1400, 1000),
                 sockets: Any = None) -> None:
        self.context = chromium.new_context(viewport={"width": size[0], "height": size[1]})
        self.page = self.context.new_page()
        if sockets is not None:  # the page's WebSockets through the test (which can drop them)
            self.page.route_web_socket("**/ws*", sockets)
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
            try:
                value = self.page.evaluate(script)
            except Exception as exc:  # the page between two states (a status not there yet, a reload): look again
                if "TypeError" not in str(exc) and "context was destroyed" not in str(exc):
                    raise
                value = None
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

    def open_run(*args: str, command: str = "run", **options: Any) -> tuple[Live, Browser]:
        live = Live(*args, command=command)
        opened.append((live, Browser(chromium, live, **options)))
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
    for _ in range(2):
        page.page.click("#run-step")
    page.drawn_at(tick + 2)
    # a person presses the key once the button is enabled again (the page ignores keys of disabled buttons)
    page.until("!document.getElementById('run-step').disabled")
    page.page.keyboard.press("s")  # the key the button's title names
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
    # the rewound run's trace, streamed afresh, up to tick 400 (samples at 20 Hz: 101 rows), and the cursor follows
    # the run there by itself (the orders a busy machine delivers it in: the two tests after the last)
    page.until(f"(window.tralLive.status() || {{}}).tick === 400 && {model}.rows === 101")
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
    assert page.page.is_hidden("#notice")  # "Rewound to tick 400" went when the run was resumed
    assert page.page.text_content("#hit") == (
        f"Breakpoint 1 (entering lap1/bottom_turn/*): entered lap1/bottom_turn/arc at tick {hit['tick']} "
        f"({hit['time']:.4f} s)")
    # the toolbar, the status and the banner say the tick's time alike (0.0125 s ticks: four decimals)
    assert page.page.text_content("#time") == f"{hit['time']:.4f} s · tick {hit['tick']}"
    assert f"({hit['time']:.4f} s)" in (page.page.text_content("#run-tick") or "")
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
    assert view.page.is_hidden("#run-step") and view.page.is_hidden("#run-speed")  # nothing to steer, not greyed
    assert "nothing to steer" in (view.page.text_content("#run-state") or "")


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
    assert page.page.text_content("#run-state") == "ended: finished, outcome over"
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
    # the page rebuilds itself from the page the server now serves: the new statechart, no reload by hand
    page.until("(document.getElementById('reload').textContent || '').indexOf('was redrawn') >= 0 && "
               "document.getElementById('chart').textContent.indexOf('n >= 7') >= 0")
    assert page.page.text_content("#reload") == (
        f"Reloaded {machine} before tick 42: kept count. The statechart was redrawn.")
    page.until("window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0 && window.tralLive.status()")
    page.page.select_option("#run-speed", "max")
    page.page.click("#run-resume")
    page.until("(window.tralLive.status() || {}).state === 'ended'")
    assert page.page.text_content("#run-state") == "ended: finished, outcome done"
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


# -- a rewind's race, played on purpose ---------------------------------------------------------------------------
#: Two states taking turns every second: its trace has a line every 80 ticks and none in between.
TURNS = """{"name": "turns", "initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
 "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 1.0},
                 {"type": "Timeout", "from": "b", "to": "a", "seconds": 1.0}]}
"""


class ScriptedRun:
    """A live server in its own thread whose run is this test's script: the trace buffer and the controller's
    snapshot are set by hand, so the order in which a page gets them can be the one a busy machine gives."""

    def __init__(self, tmp_path: Path, first: list[str]) -> None:
        import asyncio
        import threading
        from collections import deque

        from fsm.tools.live.page import live_page
        from fsm.tools.live.server import LiveServer, Source
        from fsm.tools.live.stream import LineBuffer

        self.seq = 0
        self.messages: deque[dict[str, Any]] = deque()
        self.notify: Any = None
        self.snapshot: dict[str, Any] = {}
        self.source = Source(LineBuffer(), self)  # type: ignore[arg-type]  # this object stands for the controller
        for line in first:
            self.source.buffer.write(line)
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        header = __import__("json").loads(first[0])
        self.server = LiveServer(self.source, live_page(header, "turns"), None)
        port = asyncio.run_coroutine_threadsafe(self.server.start("127.0.0.1", 0), self.loop).result(10)
        self.url = self.base = f"http://127.0.0.1:{port}"

    def publish(self, tick: int, lines: list[str] | None = None) -> None:
        """The run paused at ``tick``; with ``lines``, a new trace (a rewind's) from the same instant on."""
        from fsm.tools.live.stream import LineBuffer

        if lines is not None:
            buffer = LineBuffer()
            for line in lines:
                buffer.write(line)
            self.source.buffer = buffer
        self.seq += 1
        self.snapshot = {"seq": self.seq, "tick": tick, "time": round(tick * DT, 9), "state": "paused",
                         "ended": None, "error": None, "outcome": None, "speed": 1.0, "active": [], "hit": None,
                         "end_tick": None, "breakpoints": [], "inputs": [], "can_rewind": True}
        if self.notify is not None:
            self.notify()

    def send(self, name: str, args: Any, reply: Any) -> None:  # the page's commands: none in this script
        self.messages.append({"kind": "reply", "id": reply, "command": name, "ok": False, "error": "scripted"})

    def close(self) -> None:
        import asyncio

        asyncio.run_coroutine_threadsafe(self.server.close(), self.loop).result(10)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)


def _trace_lines(tmp_path: Path, ticks: int) -> list[str]:
    """The trace of ``TURNS`` run for ``ticks`` ticks as a live run streams it: without its end line."""
    from fsm.tools.cli import main

    machine = tmp_path / "turns.json"
    machine.write_text(TURNS)
    out = tmp_path / f"turns{ticks}.jsonl"
    assert main(["run", str(machine), "--trace", str(out), "--max-ticks", str(ticks), "-q"]) == 0
    lines = [line + "\n" for line in out.read_text().splitlines()]
    assert '"end"' in lines[-1]
    return lines[:-1]


@pytest.fixture
def scripted(chromium: Any, tmp_path: Path) -> Iterator[tuple[ScriptedRun, Browser]]:
    run = ScriptedRun(tmp_path, _trace_lines(tmp_path, 700))
    run.publish(700)
    page = Browser(chromium, run)  # type: ignore[arg-type]  # it has the url and base a Live has
    yield run, page
    page.close()
    run.close()


def test_a_status_from_before_a_rewind_does_not_hold_the_cursor(scripted: tuple[ScriptedRun, Browser],
                                                                 tmp_path: Path) -> None:
    """A rewind to tick 390 as a busy machine can deliver it: the server read the snapshot of the paused run (tick
    700, published again while it idled) just before the rewind swapped the trace, so the page gets the reset, the
    rewound lines (the last one at tick 320: nothing happens after it), a status saying 700, then one saying 390.
    The page's cursor follows the run to tick 390, not to the stale 700 (CI saw it stay there)."""
    run, page = scripted
    page.drawn_at(700)
    page.page.evaluate(f"window.tralReport.setTime({390 * DT})")  # as the user does before clicking Rewind
    rewound = _trace_lines(tmp_path, 390)
    assert '"tick":320' in rewound[-1].replace(" ", "")
    run.publish(700, rewound)  # the stale status comes after the reset
    events = sum('"type":"event"' in line.replace(" ", "") for line in rewound)
    assert events == 5  # ticks 0, 80, ..., 320; the first run had 9
    page.until(f"window.tralLive.model.events.length === {events} && (window.tralLive.status() || {{}}).tick === 700")
    run.publish(390)
    assert page.drawn_at(390)["tick"] == 390
    assert page.page.text_content("#run-tick").startswith("tick 390 ")  # type: ignore[union-attr]


def test_a_rewind_that_publishes_nothing_new_is_still_told_its_status(scripted: tuple[ScriptedRun, Browser],
                                                                        tmp_path: Path) -> None:
    """The other order: the server sent the rewound run's status before it noticed the new trace. After the reset
    (which forgets the status) it sends the status again, or the page would know of no status until the next."""
    run, page = scripted
    page.drawn_at(700)
    rewound = _trace_lines(tmp_path, 390)
    run.publish(390)
    page.until("(window.tralLive.status() || {}).tick === 390")
    run.source.buffer = run.source.buffer.__class__()
    for line in rewound:
        run.source.buffer.write(line)
    run.notify()  # a new trace, no new snapshot
    assert page.drawn_at(390)["tick"] == 390
    assert page.until("window.tralLive.status() && window.tralLive.status().tick === 390")


def test_the_sticky_bars_never_cover_what_the_page_brings_into_view(browser: Any) -> None:
    """Issue 33: scrolled down, a field of the side panels that gets the focus (a click on its label, Tab, a search
    in the page) comes into view below the toolbar and the live bar, not under them."""
    live, page = browser(LAP, "--paused", size=(1280, 560))
    p = page.page
    p.wait_for_selector("#conn.up")
    bars = p.evaluate("document.getElementById('toolbar').offsetHeight + document.getElementById('live-bar')"
                      ".offsetHeight")
    p.evaluate("window.scrollTo(0, document.documentElement.scrollHeight)")
    assert p.evaluate("document.getElementById('live-bar').getBoundingClientRect().top") == \
        p.evaluate("document.getElementById('toolbar').offsetHeight")  # stuck right below the toolbar
    for field in ("#watch-expr", "#break-a", "#inject-a"):
        p.evaluate("window.scrollTo(0, document.documentElement.scrollHeight)")
        p.focus(field)
        top = p.evaluate(f"document.querySelector('{field}').getBoundingClientRect().top")
        assert top >= bars, (field, top, bars)


def test_a_step_adds_to_the_map_track_and_the_map_is_the_one_drawn_whole(browser: Any) -> None:
    """Issue 33 (click to redraw): a step of a live run draws its new samples onto the map's track instead of the
    whole track again (which grew with the tick), and the map it gives is pixel for pixel the one drawn whole."""
    live, page = browser(LAP, "--paused", "--speed", "max", size=(1400, 1000))
    p = page.page
    p.wait_for_selector("#conn.up")
    shown = "document.body.dataset.tick"
    redrawn = "+document.getElementById('map').dataset.redrawn"
    track = "+document.getElementById('map').dataset.track"
    p.fill("#step-n", "1500")
    p.click("#run-step-n")
    page.until(f"{shown} === '1500'")
    p.fill("#step-n", "40")
    added_to = 0
    for k in range(1, 9):  # steps of 40 ticks: those with no transition only add to the track
        before, samples = p.evaluate(redrawn), p.evaluate(track)
        p.click("#run-step-n")
        page.until(f"{shown} === '{1500 + 40 * k}'")
        if p.evaluate(redrawn) == before and p.evaluate(track) > samples:
            added_to += 1
            break
    assert added_to, "no step only added to the track"
    pixels = "document.getElementById('map').toDataURL()"
    added = p.evaluate(pixels)
    p.set_viewport_size({"width": 1401, "height": 1000})  # a resize draws the map whole
    page.until(f"{redrawn} > {p.evaluate(redrawn)}")
    p.set_viewport_size({"width": 1400, "height": 1000})
    whole = p.evaluate(redrawn)
    page.until(f"{redrawn} > {whole}")
    assert _pixels_apart(p.evaluate(pixels), added) <= 5, "the track added to differs from the one drawn whole"


def _pixels_apart(a: str, b: str) -> int:
    """How many pixels differ by more than a shade between two PNG data URLs of one size (the joints where a path
    was continued are anti-aliased a shade differently from one drawn in one go; a missing piece of track is
    tens of pixels)."""
    import base64

    import cv2
    import numpy as np

    def decode(url: str) -> Any:
        return cv2.imdecode(np.frombuffer(base64.b64decode(url.split(",", 1)[1]), np.uint8), cv2.IMREAD_UNCHANGED)

    x, y = decode(a).astype(int), decode(b).astype(int)
    assert x.shape == y.shape
    return int((np.abs(x - y).max(axis=2) > 48).sum())
