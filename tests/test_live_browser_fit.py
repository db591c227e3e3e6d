""""Fit" in the live page as a person uses it (issue 33, legibility): Debian's Chromium, headless, at 1,600 x 1,000,
on ``fsmctl run --live``. Measured on the rendered page (client rectangles of the SVG's boxes and labels against the
chart panel's):

* a machine that is readable whole is shown whole: every box and label inside the panel, clear of its sides by the
  margin, and the drawing centred;
* the gate run, which is not readable whole in the panel, shows the largest readable part around the active state
  (a composite, or the state with the states its arrows join and their labels): every box and label of that part
  inside the panel with the margin, its text at least 9 px, and no side of the panel empty while the opposite side
  cuts the drawing off (the "empty left third" of the last round);
* "whole" shows every box and label of the drawing inside the panel, centred, however small;
* the part follows the active state through steps and a rewind, a drag unticks "fit" and ticking it fits again,
  and after a hot reload (which reloads the page) the page is fitted again, or keeps the view the user left.
"""

from __future__ import annotations

import json
import shutil
from itertools import pairwise
from pathlib import Path
from typing import Any

from live_helpers import COUNTER, REPO
from test_live_browser import browser, chromium  # noqa: F401 (the fixtures)
from test_live_rewind_browser import step_to

SIZE = (1600, 1000)
MARGIN = 16
#: Where each box and label of the part "fit" shows stands in the chart panel: its path (or the arrow's ends) and its
#: distances from the panel's left, top, right and bottom sides, in screen px; with the drawing's own rectangle
#: (the white background) and the smallest text shown in the panel.
PLACES = """(function () {
  var c = document.getElementById('chart'), b = c.getBoundingClientRect(), svg = c.querySelector('svg');
  var part = c.dataset.fit, kind = c.dataset.fitKind, k = svg.getScreenCTM().a;
  var all = kind === 'all' || kind === 'whole';
  function inPart(p) { return all || p === part || (kind === 'composite' && p.indexOf(part + '/') === 0); }
  var ends = {}, out = [];
  svg.querySelectorAll('polyline.edge').forEach(function (e) {
    if (kind !== 'around') return;
    var f = e.getAttribute('data-from'), t = e.getAttribute('data-to');
    if (f === part) ends[t] = true; else if (t === part) ends[f] = true;
  });
  function add(name, el) {
    if (el.closest('.hidden')) return;
    var r = el.getBoundingClientRect();
    if (r.width) out.push([name, r.left - b.left, r.top - b.top, b.right - r.right, b.bottom - r.bottom]);
  }
  svg.querySelectorAll('g[data-path]').forEach(function (g) {
    var p = g.dataset.path, shape = g.querySelector('rect') || g.querySelector('circle');
    if (!shape) return;
    if (inPart(p) || (ends[p] && !g.classList.contains('composite'))) add(p, shape);
  });
  svg.querySelectorAll('g.label').forEach(function (g) {
    var f = g.getAttribute('data-from'), t = g.getAttribute('data-to'), within = g.getAttribute('data-in');
    var mine = all || (kind === 'composite' && (within === part || within.indexOf(part + '/') === 0)) ||
      (kind === 'around' && (f === part || t === part));
    if (mine) add(f + ' -> ' + t, g.querySelector('rect'));
  });
  var bg = svg.querySelector(':scope > rect').getBoundingClientRect();
  var sizes = Array.from(svg.querySelectorAll('text')).filter(function (t) {
    var r = t.getBoundingClientRect();
    return r.width > 0 && !t.closest('.hidden') && r.bottom > b.top && r.top < b.bottom && r.right > b.left &&
      r.left < b.right;
  }).map(function (t) { return parseFloat(getComputedStyle(t).fontSize) * k; });
  return { part: part, kind: kind, places: out, panel: [b.left, b.top, b.width, b.height],
           drawing: [bg.left - b.left, bg.top - b.top, b.right - bg.right, b.bottom - bg.bottom],
           smallest: Math.min.apply(null, sizes), shown: sizes.length, fit: document.getElementById('fit').checked,
           pageWide: document.documentElement.scrollWidth };
})()"""


def fitted(page: Any) -> dict[str, Any]:
    """What "fit" shows, checked: the part's boxes and labels inside the panel, clear by the margin; text readable;
    no side of the panel empty while the opposite one cuts the drawing off; the page no wider than the window."""
    got: dict[str, Any] = page.page.evaluate(PLACES)
    assert got["fit"] and got["places"], got
    outside = [p for p in got["places"] if min(p[1:]) < MARGIN - 1.5]
    assert not outside, (got["part"], got["kind"], outside)
    assert got["smallest"] >= 9 and got["shown"] >= 3, got
    left, top, right, bottom = got["drawing"]
    assert not (left > 1 and right < -1) and not (right > 1 and left < -1), got["drawing"]  # blank beside, cut off
    assert not (top > 1 and bottom < -1) and not (bottom > 1 and top < -1), got["drawing"]
    assert got["pageWide"] <= SIZE[0]
    return got


def part_of(got: dict[str, Any], active: str) -> bool:
    part = got["part"]
    return bool(part == "all" or part == active or (got["kind"] == "composite" and active.startswith(part + "/")))


def test_fit_shows_a_small_machine_whole_centred_with_margins(browser: Any, tmp_path: Path) -> None:  # noqa: F811
    machine = tmp_path / "counter.json"
    machine.write_text(COUNTER)
    _live, page = browser(str(machine), "--paused", size=SIZE)
    got = fitted(page)
    assert got["kind"] == "all" and len(got["places"]) >= 3  # three states and the labels of their arrows
    left, top, right, bottom = got["drawing"]
    assert left >= MARGIN - 1 and top >= MARGIN - 1 and right >= MARGIN - 1 and bottom >= MARGIN - 1
    assert abs(left - right) <= 1.5 and abs(top - bottom) <= 1.5, got["drawing"]  # centred both ways
    page.page.screenshot(path=str(tmp_path / "fit-counter.png"))


def test_fit_grows_the_panel_for_a_tall_machine_up_to_the_window(browser: Any, tmp_path: Path) -> None:  # noqa: F811
    """A column of seven states (about 220 x 870) is not readable in the panel's own 66 % of the window: the panel
    grows (no taller than the window holds below the sticky bars) and shows it whole, centred, readable."""
    states = [{"id": f"step{i}", "type": "Idle"} for i in range(6)] + [{"id": "end", "type": "Final"}]
    ids = [st["id"] for st in states]
    transitions = [{"type": "Timeout", "from": a, "to": b, "seconds": 1} for a, b in pairwise(ids)]
    machine = tmp_path / "column.json"
    machine.write_text(json.dumps({"name": "column", "initial": "step0", "states": states,
                                   "transitions": transitions}))
    _live, page = browser(str(machine), "--paused", size=SIZE)
    got = fitted(page)
    assert got["kind"] == "all" and len(got["places"]) == 7 + 6, got
    assert got["panel"][3] > 0.66 * SIZE[1] + 20, got["panel"]
    # scrolled up to the sticky bars (as a click on a found state or a focused field scrolls), all of it is seen
    page.page.evaluate("document.getElementById('chart').scrollIntoView()")
    box = page.page.evaluate("(function (r) { return [r.top, r.bottom]; })("
                             "document.getElementById('chart').getBoundingClientRect())")
    bars = page.page.evaluate("document.getElementById('toolbar').offsetHeight + "
                              "document.getElementById('live-bar').offsetHeight")
    assert bars <= box[0] and box[1] <= SIZE[1], (bars, box)
    left, top, right, bottom = got["drawing"]
    assert abs(left - right) <= 1.5 and abs(top - bottom) <= 1.5 and min(top, bottom) >= MARGIN - 1, got["drawing"]
    page.page.screenshot(path=str(tmp_path / "fit-column.png"))


def test_fit_on_the_gate_run_follows_the_run_a_rewind_and_a_hot_reload(browser: Any,  # noqa: F811
                                                                       tmp_path: Path) -> None:
    for name in ("gate_run.json", "gate_side.json", "gate_home.json"):
        shutil.copy(REPO / "diagrams" / name, tmp_path / name)
    machine = tmp_path / "gate_run.json"
    live, page = browser(str(machine), "--paused", "--world", str(REPO / "diagrams" / "worlds" / "gates.json"),
                         size=SIZE)
    p = page.page
    first = fitted(page)  # fitted from the start
    assert part_of(first, page.status()["active"][0]), first["part"]
    # "whole": every box and label of the drawing in the panel, centred, however small (and "fit" unticked)
    p.click("#fit-whole")
    whole = p.evaluate(PLACES)
    assert whole["kind"] == "whole" and not whole["fit"] and len(whole["places"]) >= 30 + 40, whole["kind"]
    outside = [place for place in whole["places"] if min(place[1:]) < MARGIN - 1.5]
    assert not outside, outside
    left, top, right, bottom = whole["drawing"]
    assert abs(left - right) <= 1.5 and abs(top - bottom) <= 1.5 and min(whole["drawing"]) >= MARGIN - 1, whole
    p.screenshot(path=str(tmp_path / "whole.png"))
    p.check("#fit")
    assert fitted(page)["places"] == first["places"]
    step_to(page, 600)
    at600 = fitted(page)
    active = page.status()["active"][0]
    assert active.startswith("side1/") and part_of(at600, active), (active, at600["part"])
    p.screenshot(path=str(tmp_path / "fit-600.png"))
    # a drag pans and unticks "fit"; ticking it fits again, as before the drag
    box = p.locator("#chart").bounding_box()
    assert box is not None
    p.mouse.move(box["x"] + 300, box["y"] + 300)
    p.mouse.down()
    p.mouse.move(box["x"] + 500, box["y"] + 380, steps=5)
    p.mouse.up()
    assert not p.is_checked("#fit")
    p.check("#fit")
    assert fitted(page)["places"] == at600["places"]
    # a rewind: the part follows the state the run is back in
    p.evaluate("window.tralReport.setTime(30 * 0.0125)")
    p.click("#run-rewind")
    page.until("(window.tralLive.status() || {}).tick === 30 && window.tralReport.current().tick === 30")
    back = page.status()["active"][0]
    rewound = page.until(f"(function () {{ var c = document.getElementById('chart'); "
                         f"return c.dataset.fit !== {json.dumps(at600['part'])} && c.dataset.fit; }})()")
    got = fitted(page)
    assert part_of(got, back) and rewound == got["part"], (back, got["part"])
    # a hot reload (the page reloads itself with the new chart): fitted again around the active state
    document = json.loads(machine.read_text(encoding="utf-8"))
    document["states"].append({"id": "spare", "type": "Final", "outcome": "succeeded",
                               "layout": {"x": 220, "y": 1240, "w": 170, "h": 90}})
    machine.write_text(json.dumps(document), encoding="utf-8")
    page.until("document.querySelector('#chart [data-path=\"spare\"]')", seconds=30)
    page.until("window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0 && window.tralLive.status()")
    got = fitted(page)
    assert part_of(got, page.status()["active"][0]), got["part"]
    # a view the user chose (zoomed in, "fit" off) is kept through the next reload
    p.hover("#chart")
    p.mouse.wheel(0, -300)
    assert not p.is_checked("#fit")
    chosen = p.evaluate("document.querySelector('#chart svg').getAttribute('viewBox')")
    document["states"][-1]["outcome"] = "failed"
    machine.write_text(json.dumps(document), encoding="utf-8")
    page.until("(document.getElementById('reload').textContent || '').indexOf('was redrawn') >= 0", seconds=30)
    page.until("window.tralLive && window.tralLive.drawn && window.tralLive.drawn() > 0 && window.tralLive.status()")
    assert not p.is_checked("#fit")
    kept = p.evaluate("document.querySelector('#chart svg').getAttribute('viewBox')")
    assert [round(float(v), 3) for v in kept.split()] == [round(float(v), 3) for v in chosen.split()]
    p.screenshot(path=str(tmp_path / "fit-kept.png"))
    live.close()
