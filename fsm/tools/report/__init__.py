"""The run report: one self-contained HTML file that replays a trace (statechart with the active path, state lanes,
map, plots, camera, variables, visits). Works offline: the page makes no request (a Content-Security-Policy
forbids any), its only library (uPlot, MIT) is vendored in ``assets/`` with its licence.

:func:`report_html` builds the page from a :class:`fsm.trace.replay.Trace`; :mod:`~fsm.tools.report.model` computes
what it shows. May import the core, the graph drawing and the simulator's world model; never the CLI.
"""

from __future__ import annotations

import json
from collections import Counter
from html import escape
from importlib import resources
from typing import Any

import fsm
from fsm import __version__
from fsm.loading.loader import uses_car
from fsm.runtime.region import transition_wiring, wiring
from fsm.trace.replay import Trace

from ..graph import svg
from ..scenario.coverage import Coverage
from .model import build_model

__all__ = ["build_model", "report_html"]


def _asset(name: str) -> str:
    return (resources.files(__package__) / "assets" / name).read_text(encoding="utf-8")


def _embedded_json(data: Any) -> str:
    """JSON that cannot end its ``<script>`` element (nor open a comment) whatever strings it holds."""
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return (text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
            .replace("\u2028", "\\u2028").replace("\u2029", "\\u2029"))


def chart_svg(trace: Trace, warnings: list[str]) -> str:
    """The statechart as the user drew it (the header's document and its layout), or ``""`` with a warning."""
    doc = trace.header.get("machine")
    if not isinstance(doc, dict):
        if trace.version >= 2:
            warnings.append("the trace carries no machine document: no statechart")
        return ""

    try:
        drawing: str = svg(doc)
        return drawing
    except Exception as exc:  # a document that no longer draws: the rest of the report still stands
        warnings.append(f"the machine in the trace cannot be drawn ({type(exc).__name__}: {exc}): no statechart")
        return ""


def coverage_of(trace: Trace, warnings: list[str]) -> Any:
    """The run's coverage (:class:`fsm.tools.scenario.coverage.Coverage`) of the machine in the trace's header:
    states entered, transitions and monitors fired; ``None`` with a warning when the machine cannot be built."""
    doc = trace.header.get("machine")
    machine = _structure(doc, warnings) if isinstance(doc, dict) else None
    if machine is None:
        return None
    events = trace.events
    entries = Counter(str(tr.get("to")) for e in events for tr in e.get("transitions", ()))
    skips = Counter(str(path) for e in events for path in e.get("skipped", ()))
    fired = {hit for e in events for tr in e.get("transitions", ()) for hit in _fired(machine, tr)}
    monitors = {(str(m.get("owner")), str(m.get("monitor")), str(m.get("kind")))
                for e in events for m in e.get("monitors", ())}
    cov = Coverage()
    ran = {p for p, n in entries.items() if n > skips.get(p, 0)}  # a skipped entry ran nothing
    cov.add_reached(machine, ran, set(skips) - ran, fired, monitors, key=str(trace.name))
    return cov


def _structure(doc: dict[str, Any], warnings: list[str]) -> Any:
    """The machine of a trace's header, built for its structure (a car machine on a car with nothing behind it),
    or ``None`` with a warning."""
    try:
        car = None
        if uses_car(fsm.check(doc)[0]):
            from fsm.sim.fake import FakeCar

            car = FakeCar()
        return fsm.load(doc, car=car)
    except Exception as exc:  # a type from a plugin this process does not have: the rest of the report stands
        warnings.append(f"the machine in the trace cannot be built ({type(exc).__name__}): no coverage")
        return None


def _fired(machine: Any, tr: dict[str, Any]) -> list[tuple[str, int]]:
    """(source path, index) of the machine's transitions a trace line's transition ``tr`` can be."""
    src = tr.get("from")
    state = machine.states_by_path.get(src) if isinstance(src, str) else None
    out = wiring(state).transitions if state is not None else ()
    return [(t.source.path, transition_wiring(t).index) for t in out
            if t.target.path == tr.get("to") and t.type_name == tr.get("type")]


#: The coverage summary's titles (``MachineCoverage.missed``) as the report words them, where it says more.
_COVERAGE_TITLES = {"only skipped": "only skipped (precondition false)", "never fired": "transitions never fired"}


def coverage_section(cov: Any) -> str:
    """The report's coverage section (HTML; every name escaped), or ``""``."""
    if cov is None or not cov.machines:
        return ""
    (m,) = cov.machines.values()
    counts = ", ".join(f"{kind} {hit}/{total}" for kind, (hit, total) in m.counts().items())
    body = "".join(f"<tr><th>{escape(_COVERAGE_TITLES.get(title, title))}</th>"
                   f"<td>{escape(', '.join(items)) or 'none'}</td></tr>" for title, items in m.missed())
    return (f'<section id="coverage-box"><h2>Coverage of this run</h2><p id="coverage-sum">{escape(counts)} '
            f"({cov.percent():.1f}&#8201;%)</p><table id=\"coverage\"><tbody>{body}</tbody></table></section>")


def report_html(trace: Trace) -> str:
    """The report page of ``trace``, as text (UTF-8 when written)."""
    model = build_model(trace)
    chart = chart_svg(trace, model["meta"]["warnings"])
    coverage = coverage_section(coverage_of(trace, model["meta"]["warnings"]))
    page = _asset("report.html")
    parts = {
        "__TITLE__": escape(f"{model['meta']['name']} — tral-fsm report"),
        "__VERSION__": escape(__version__),
        "__UPLOT_CSS__": _asset("uPlot.min.css"),
        "__CSS__": _asset("report.css"),
        "__SVG__": chart,
        "__COVERAGE__": coverage,
        "__DATA__": _embedded_json(model),
        "__UPLOT_JS__": _asset("uPlot.iife.min.js").replace("</script", "<\\/script"),
        "__JS__": _asset("report.js"),
    }
    return fill_template(page, parts)


def fill_template(page: str, parts: dict[str, str]) -> str:
    """``page`` with each key of ``parts`` replaced, in one pass in the template's order, so text put in by one
    part is never searched for the next (the report's and the live page's templates)."""
    out = []
    rest = page
    while True:
        hits = [(rest.find(k), k) for k in parts if rest.find(k) >= 0]
        if not hits:
            out.append(rest)
            break
        at, key = min(hits)
        out.append(rest[:at])
        out.append(parts[key])
        rest = rest[at + len(key):]
    return "".join(out)
