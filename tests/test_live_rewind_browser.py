"""Rewind as a person uses it in Chromium (issues 33 and 37): a rewind further back than ``--rewind-horizon`` is
refused in the page with how far back the run can go, and one within it works; a rewind to before a hot reload
brings the old machine back and the page redraws its statechart (the edited file's new state is gone)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import test_live_browser as browser_tests
from live_helpers import REPO

DT, LAP = browser_tests.DT, browser_tests.LAP
chromium, browser = browser_tests.chromium, browser_tests.browser  # the fixtures: a Chromium, pages on live runs


def step_to(page: Any, tick: int) -> None:
    page.until("(window.tralLive.status() || {}).state === 'paused' && !document.getElementById('run-step-n')"
               ".disabled")
    now = page.status()["tick"]
    page.page.fill("#step-n", str(tick - now))
    page.page.click("#run-step-n")
    page.drawn_at(tick)


def test_a_rewind_past_the_horizon_is_refused_in_the_page_with_how_far_back(browser: Any, tmp_path: Path) -> None:
    live, page = browser(LAP, "--paused", "--rewind-horizon", "10")
    now = 12_000
    step_to(page, now)  # 150 s: the first 140 s are beyond a 10 s horizon (a snapshot at least every third of it)
    earliest = page.status()["rewind_from"]
    assert now - 800 - 2 * 256 <= earliest <= now - 800
    page.page.evaluate(f"window.tralReport.setTime({100 * DT})")
    page.page.click("#run-rewind")
    page.until("/beyond the rewind horizon/.test(document.getElementById('notice').textContent)")
    notice = page.page.text_content("#notice") or ""
    assert f"rewound to tick {earliest} " in notice and "--rewind-horizon 10 s" in notice
    assert page.status()["tick"] == now  # not rewound
    page.page.screenshot(path=str(tmp_path / "refused.png"))
    page.page.evaluate(f"window.tralReport.setTime({(earliest + 40) * DT})")
    page.page.click("#run-rewind")
    page.drawn_at(earliest + 40)
    assert f"Rewound to tick {earliest + 40}" in (page.page.text_content("#notice") or "")


def test_a_rewind_to_before_a_hot_reload_redraws_the_old_statechart(browser: Any, tmp_path: Path) -> None:
    machine = tmp_path / "hallway_lap.json"
    for included in ("lap.json", "turn_left.json"):  # what it includes
        (tmp_path / included).write_bytes((REPO / "diagrams" / included).read_bytes())
    document = json.loads((REPO / "diagrams" / "hallway_lap.json").read_text(encoding="utf-8"))
    machine.write_text(json.dumps(document), encoding="utf-8")
    live, page = browser(str(machine), "--paused", "--world", str(REPO / "diagrams" / "worlds" / "hallway.json"))
    step_to(page, 300)
    assert not page.page.query_selector('#chart [data-path="spare"]')
    document["states"].append({"id": "spare", "type": "Final", "outcome": "succeeded",
                               "layout": {"x": 220, "y": 940, "w": 170, "h": 90}})
    machine.write_text(json.dumps(document), encoding="utf-8")
    # the reload swaps the machine before the next tick and the page rebuilds itself with the new statechart
    page.until("document.querySelector('#chart [data-path=\"spare\"]')", seconds=30)
    page.until("window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0")
    step_to(page, 500)
    page.page.evaluate(f"window.tralReport.setTime({200 * DT})")
    page.page.click("#run-rewind")
    # back before the reload: the machine the run started with, and its statechart again
    page.until("window.tralLive && window.tralLive.status && (window.tralLive.status() || {}).tick === 200 && "
               "!document.querySelector('#chart [data-path=\"spare\"]') && "
               "/undid 1 later hot reload/.test(document.getElementById('reload').textContent)", seconds=30)
    page.page.screenshot(path=str(tmp_path / "rewound.png"))
