"""Every control of the live page used as a person uses it (issue 33, deliverable 1): Debian's Chromium, headless,
driven by Playwright on ``fsmctl run --live`` of the mission (a car, variables, a pause signal, a monitor). Each
button, key and field is clicked or typed into; after each, the page is compared with the status the server sent
and, at the end, with the trace the run wrote. Remove must remove; a refused injection points at its field; a
dropped WebSocket reconnects and the page is rebuilt from the trace; the end of the run is told by the server."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fsm.tools.cli.explain import explain_trace
from fsm.trace.replay import read_trace
from live_helpers import REPO
from test_live_browser import Browser, browser, chromium  # noqa: F401, F811 (the fixtures)

MISSION = str(REPO / "diagrams" / "mission.json")
WORLD = str(REPO / "diagrams" / "worlds" / "obstacle.json")
DRIVE = "mission/drive"


class Sockets:
    """The page's WebSockets, passed through to the server; :meth:`drop` cuts the current one as a network would."""

    def __init__(self) -> None:
        self.routes: list[Any] = []

    def __call__(self, route: Any) -> None:
        route.connect_to_server()
        self.routes.append(route)

    def drop(self) -> None:
        self.routes[-1].close(code=4000, reason="dropped")


def shows(page: Browser, status: dict[str, Any]) -> None:
    """The page shows the server's status: its tick line, the state, the breakpoints and the inputs."""
    p = page.page
    tick = p.get_attribute("#run-tick", "data-tick")
    assert tick == str(status["tick"]), (tick, status["tick"])
    assert p.text_content("#run-state", timeout=2000).startswith(status["state"])  # type: ignore[union-attr]
    rows = p.eval_on_selector_all("#breaks tbody tr", "rows => rows.map(r => Number(r.dataset.id))")
    assert rows == [bp["id"] for bp in status["breakpoints"]]
    inputs = p.eval_on_selector_all("#inputs tbody tr", "rows => rows.map(r => [Number(r.cells[0].textContent), "
                                                        "r.cells[1].textContent])")
    assert inputs[-len(status["inputs"]):] == status["inputs"] if status["inputs"] else True


def settled(page: Browser, script: str) -> dict[str, Any]:
    """Wait until the status satisfies ``script`` (``s``: the status) and the page has drawn it; the status."""
    page.until(f"(function (s) {{ return !!s && ({script}) && "
               "document.getElementById('run-tick').dataset.tick === String(s.tick) && "
               "window.tralReport.current().tick === s.tick; })(window.tralLive.status())")
    status = page.status()
    shows(page, status)
    return status


def test_every_control_as_a_person_uses_it(browser: Any, tmp_path: Path) -> None:  # noqa: F811
    sockets = Sockets()
    trace_file = tmp_path / "t.jsonl"
    live, page = browser(MISSION, "--world", WORLD, "--paused", "--speed", "max", "--trace", str(trace_file),
                         size=(1600, 1000), sockets=sockets)
    p = page.page
    wide = "document.documentElement.scrollWidth <= window.innerWidth"
    # -- steps: the button, the key, N ticks -----------------------------------------------------------------------
    p.click("#run-step")
    settled(page, "s.tick === 1 && s.state === 'paused'")
    p.keyboard.press("s")
    settled(page, "s.tick === 2")
    p.fill("#step-n", "30")
    p.click("#run-step-n")
    status = settled(page, "s.tick === 32 && s.state === 'paused'")
    assert status["active"] == [f"{DRIVE}/right_lane"]
    # -- pace, resume and pause (buttons and keys) -------------------------------------------------------------------
    p.select_option("#run-speed", "4")
    settled(page, "s.speed === 4")
    p.select_option("#run-speed", "1")
    settled(page, "s.speed === 1")
    p.click("#run-resume")
    page.until("window.tralLive.status().state === 'running'")
    p.click("#run-pause")
    paused = settled(page, "s.state === 'paused'")
    p.keyboard.press("r")
    page.until("window.tralLive.status().state === 'running'")
    p.keyboard.press("p")
    paused = settled(page, f"s.state === 'paused' && s.tick > {paused['tick']}")
    p.select_option("#run-speed", "max")
    settled(page, "s.speed === null")
    # -- to the next transition (button, key) ------------------------------------------------------------------------
    hits = []
    for how in ("button", "key"):
        p.click("#run-step-tr") if how == "button" else p.keyboard.press("t")
        status = settled(page, f"s.hit && s.hit.text === 'step to the next transition' && s.tick > {paused['tick']}")
        hits.append(status["hit"])
        assert "step to the next transition" in (p.text_content("#hit") or "")
        paused = status
    # -- injections: each kind, and the refusals pointing at their field ---------------------------------------------
    accepted: list[str] = []

    def inject(kind: str, a: str = "", b: str = "", c: str = "", refused: str | None = None) -> None:
        p.select_option("#inject-kind", kind)
        for field, text in (("#inject-a", a), ("#inject-b", b), ("#inject-c", c)):
            if p.is_visible(field):
                p.fill(field, text)
        before = len(page.status()["inputs"])
        p.click("#inject-form button")
        if refused is not None:
            error = page.until("!document.getElementById('inject-error').hidden && "
                               "document.getElementById('inject-error').textContent")
            assert refused in error, error
            field = p.get_attribute("#inject-error", "data-field")
            assert p.eval_on_selector(".wrong", "e => e.id") == {"name": "inject-a", "value": "inject-b"}[field or ""]
            assert len(page.status()["inputs"]) == before
            return
        status = settled(page, f"s.inputs.length === {before + 1}")
        assert p.is_hidden("#inject-error") and p.eval_on_selector_all(".wrong", "es => es.length") == 0
        accepted.append(status["inputs"][-1][1])

    inject("set", "evasions", "many", refused="'evasions' holds a whole number (0); 'many' is a text")
    inject("set", "lanes", "left", refused="no variable 'lanes' (did you mean 'lane'?)")
    inject("signal", "paws", "1", refused="no condition of the machine reads it (did you mean 'pause'?)")
    inject("finish", "mission/nowhere", refused="nowhere")
    inject("set", "evasions", "3")
    inject("signal", "pause", "1")
    inject("signal", "pause", "0")
    inject("force", "front", "2.5", "5")
    inject("pause", DRIVE)
    inject("resume", DRIVE)
    inject("monitor", DRIVE, "0")
    assert accepted == ["set evasions = 3", "signal pause high", "signal pause low", "force front = 2.5 for 5 ticks",
                        f"pause {DRIVE}", f"resume {DRIVE}", f"fire monitor 0 of {DRIVE}"]
    p.click("#run-step")
    fired = settled(page, f"s.tick === {paused['tick'] + 1}")
    inject("finish", fired["active"][-1], "succeeded")
    # -- breakpoints: each kind added and removed; one fires, and once removed it fires no more -----------------------
    kinds = {"enter": ("*/right_lane", ""), "leave": ("*", ""), "transition": ("*", "*"), "monitor": (DRIVE, "*"),
             "exception": ("*", ""), "timeout": ("*", ""), "expr": ("evasions > 3", "")}
    for kind, (a, b) in kinds.items():
        p.select_option("#break-kind", kind)
        p.fill("#break-a", a)
        if b:
            p.fill("#break-b", b)
        p.click("#break-form button")
        status = settled(page, "s.breakpoints.length === 1")
        assert status["breakpoints"][0]["text"] in (p.text_content("#breaks") or "")
        if kind == "expr":  # it fires at the tick after the injection that makes it true
            inject("set", "evasions", "4")
            p.click("#run-resume")
            status = settled(page, "s.hit && s.hit.breakpoint !== null")
            assert status["hit"]["text"] == "evasions > 3 becomes true" and status["breakpoints"][0]["hits"] == 1
            assert (p.text_content("#hit") or "").startswith(f"Breakpoint {status['hit']['breakpoint']} (evasions")
        p.click("#breaks tbody button")  # Remove
        settled(page, "s.breakpoints.length === 0")
    inject("set", "evasions", "0")
    inject("set", "evasions", "5")  # true again: the removed breakpoint would fire here
    p.fill("#step-n", "5")
    p.click("#run-step-n")
    status = settled(page, "s.state === 'paused' && !s.hit")
    assert status["hit"] is None
    assert page.until(wide)
    # -- the statechart: search, fold, fit, zoom, follow -------------------------------------------------------------
    p.fill("#chart-search", "right_lane")
    assert page.until("document.getElementById('chart-found').textContent") == "1 found"
    assert p.eval_on_selector_all("#chart g.found", "gs => gs.map(g => g.dataset.path)") == [f"{DRIVE}/right_lane"]
    folded = "Array.from(document.querySelectorAll('#chart g.folded')).map(g => g.dataset.path)"
    p.check("#fold-rest")  # every composite is on the active paths here: none folds
    active = page.status()["active"]
    assert not any(a.startswith(path) for path in p.evaluate(folded) for a in active)
    p.uncheck("#fold-rest")
    view = "document.querySelector('#chart svg').getAttribute('viewBox')"
    p.check("#fit")
    fitted = p.evaluate(view)
    part = p.get_attribute("#chart", "data-fit") or ""  # the largest readable part around the active state
    assert any(a == part or a.startswith(part + "/") for a in page.status()["active"]), part
    title = "#chart g.composite[data-path='mission/back_off'] > text >> nth=0"
    p.dispatch_event(title, "click")  # a composite's title folds it (wherever the view is), and unfolds it again
    assert "mission/back_off" in page.until(f"{folded}.length && {folded}")
    p.dispatch_event(title, "click")
    assert page.until(f"{folded}.length === 0")
    p.hover("#chart")
    p.mouse.wheel(0, -400)
    zoomed = p.evaluate(view)
    assert zoomed != fitted and not p.is_checked("#fit")
    assert float(zoomed.split()[2]) < float(fitted.split()[2])
    p.uncheck("#follow")
    p.check("#follow")
    assert p.is_checked("#follow")
    # -- rewind to the cursor (the report's keys move it) ---------------------------------------------------------
    before = page.status()
    p.focus("#lanes")
    p.keyboard.press("Home")
    p.keyboard.press("ArrowRight")
    cursor = p.evaluate("window.tralReport.current().tick")
    assert 0 < cursor < before["tick"]
    p.click("#run-rewind")
    status = settled(page, f"s.tick === {cursor} && s.state === 'paused'")
    dropped = sum(1 for t, _ in before["inputs"] if t > cursor)
    assert status["inputs"] == [i for i in before["inputs"] if i[0] <= cursor]
    assert f"Rewound to tick {cursor}" in (p.text_content("#notice") or "")
    said = f"{dropped} later input{'s' if dropped != 1 else ''} dropped"
    assert (said in (p.text_content("#notice") or "")) == (dropped > 0)
    inject("set", "evasions", "2")
    # -- a dropped connection: reconnecting, then the page rebuilt from the trace --------------------------------------
    rows = page.page.evaluate("window.tralLive.model.rows")
    sockets.drop()
    page.until("document.getElementById('conn').textContent === 'reconnecting…'")
    assert "reconnecting" in (p.text_content("#notice") or "")
    page.until("document.getElementById('conn').textContent === 'connected'")
    status = settled(page, f"s.tick === {cursor} && s.inputs.length === {len(status['inputs']) + 1}")
    assert page.page.evaluate("window.tralLive.model.rows") == rows
    assert p.is_enabled("#run-step") and p.is_enabled("#inject-form button")
    p.click("#run-step")
    last = settled(page, f"s.tick === {cursor + 1}")
    # -- a watch expression: its value at the cursor, after every tick; the log: filter, click to jump ----------
    p.fill("#watch-expr", "evasions * 10")
    p.click("#watch-form button")
    settled(page, "s.watches.length === 1")
    p.fill("#step-n", "3")
    p.click("#run-step-n")
    stepped = settled(page, f"s.tick === {last['tick'] + 3}")
    value = page.until(f"document.querySelector('#watches td.value').dataset.tick === '{stepped['tick']}' && "
                       "document.querySelector('#watches td.value').textContent")
    assert value == str(2 * 10)  # evasions was set to 2 before the drop
    assert p.is_checked("#watches input[type=checkbox]")
    assert p.eval_on_selector_all("#watch-plot canvas", "c => c.length")
    p.fill("#watch-expr", "evasions <")
    p.click("#watch-form button")
    assert "column" in page.until("!document.getElementById('watch-error').hidden && "
                                  "document.getElementById('watch-error').textContent")
    kinds = p.eval_on_selector_all("#log tbody tr", "rows => rows.map(r => r.dataset.kind)")
    assert "transition" in kinds and "input" in kinds
    p.uncheck("#log-filter input[value=transition]")
    rows = "Array.from(document.querySelectorAll('#log tbody tr'))"
    kinds = page.until(f"{rows}.every(r => r.dataset.kind !== 'transition') && {rows}.map(r => r.dataset.kind)")
    assert set(kinds) <= {"input", "monitor", "reload", "breakpoint", "warning"}
    p.check("#log-filter input[value=transition]")
    row = p.query_selector("#log tbody tr[data-kind=input]")
    assert row is not None
    row.click()
    assert p.evaluate("window.tralReport.current().tick") == int(row.get_attribute("data-tick") or -1)
    last = stepped
    # -- why: the panel, opened while paused, says what the last tick did (compared with explain below) ------------
    p.click("#why-box summary")
    page.until(f"document.getElementById('why-box').dataset.tick === '{last['tick']}'")
    # while the run goes on, the panel says that what it shows is an earlier tick's; at the next pause, this one's
    # (the cursor stays where the log line put it: the statuses are waited for, not the cursor)
    p.select_option("#run-speed", "1")
    page.until("window.tralLive.status().speed === 1")
    p.click("#run-resume")
    page.until("document.getElementById('why').classList.contains('stale')")
    assert f"below is tick {last['tick']}" in (p.text_content("#why-info") or "")
    p.click("#run-pause")
    page.until(f"window.tralLive.status().state === 'paused' && window.tralLive.status().tick > {last['tick']}")
    last = page.status()
    page.until(f"document.getElementById('why-box').dataset.tick === '{last['tick']}' && "
               "!document.getElementById('why').classList.contains('stale')")
    why_rows = p.eval_on_selector_all("#why tbody tr:not(.state)", "rows => rows.map(r => r.dataset.verdict)")
    p.screenshot(path=str(tmp_path / "controls.png"))
    assert page.until(wide)  # after breakpoints, rewinds and a reconnect, the page is no wider than the window
    # -- stop: the server says the run is over; the trace is what the page showed ------------------------------------
    p.click("#run-stop")
    code, _out, err = live.wait()
    assert code == 0, err
    page.until("document.getElementById('conn').textContent === 'disconnected'")
    assert "stopped from the page" in (p.text_content("#notice") or "")
    assert p.is_disabled("#run-step")
    trace = read_trace(trace_file)
    assert trace.last_tick == last["tick"]
    assert [[i["tick"], i["text"]] for i in trace.inputs] == last["inputs"]
    assert trace.at(last["tick"])[0] == last["active"]
    explained = explain_trace(trace, last["tick"])
    assert why_rows == [c.verdict for _s, checks in explained.states for c in checks] and why_rows


#: The font size (screen px) of every statechart text shown in the chart's box.
SHOWN_TEXT = """(function () {
  var svg = document.querySelector('#chart svg'), b = document.getElementById('chart').getBoundingClientRect();
  var k = svg.getScreenCTM().a;
  return Array.from(svg.querySelectorAll('text')).filter(function (t) {
    var r = t.getBoundingClientRect();
    return r.width > 0 && !t.closest('.hidden') && r.bottom > b.top && r.top < b.bottom && r.right > b.left &&
      r.left < b.right;
  }).map(function (t) { return parseFloat(getComputedStyle(t).fontSize) * k; });
})()"""


def test_fit_is_readable_for_the_lap_and_the_gate_run(browser: Any) -> None:  # noqa: F811
    """At 1,600 x 1,000, "fit" shows text of at least 9 px (measured on the rendered SVG): the whole chart when it
    is readable so, else the largest composite around the active state that is; the page is never wider than the
    window."""
    gate = (str(REPO / "diagrams" / "gate_run.json"), "--world", str(REPO / "diagrams" / "worlds" / "gates.json"))
    for args in ((str(REPO / "diagrams" / "hallway_lap.json"),), gate):
        live, page = browser(*args, "--paused", "--speed", "max", size=(1600, 1000))
        p = page.page
        p.uncheck("#fit")
        p.check("#fit")
        sizes = p.evaluate(SHOWN_TEXT)
        assert len(sizes) >= 5 and min(sizes) >= 9, (args[0], sorted(sizes)[:5])
        fitted = p.get_attribute("#chart", "data-fit")
        assert fitted is not None and any(fitted == a or a.startswith(fitted + "/") or fitted == "all"
                                          for a in page.status()["active"])
        p.fill("#step-n", "120")
        p.click("#run-step-n")
        settled(page, "s.tick === 120")
        sizes = p.evaluate(SHOWN_TEXT)
        assert len(sizes) >= 5 and min(sizes) >= 9, (args[0], sorted(sizes)[:5])
        assert page.until("document.documentElement.scrollWidth <= window.innerWidth")
