"""The live page: the report's front end (its template's parts, styles, uPlot and report.js) with the live parts
added (model.js builds the report's model from trace lines in the browser, live.js streams and steers), built
once per run from the trace's header: the statechart as drawn, the map of the world."""

from __future__ import annotations

import json
from html import escape
from importlib import resources
from typing import Any

from fsm.trace.replay import Trace

from ..report import build_model, chart_svg, fill_template


def _asset(package: str, name: str) -> str:
    return (resources.files(package) / "assets" / name).read_text(encoding="utf-8")


def _embedded_json(data: Any) -> str:
    """JSON that cannot end its ``<script>`` element whatever strings it holds."""
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return (text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
            .replace("\u2028", "\\u2028").replace("\u2029", "\\u2029"))


def live_page(header: dict[str, Any], name: str) -> str:
    """The page for a run whose trace begins with ``header`` (``name``: what the run is called on the page)."""
    from fsm import __version__

    trace = Trace(name, int(header.get("version", 3)), header)
    trace.index()
    model = build_model(trace)  # of the header alone: the map and what the page starts with
    warnings = [w for w in model["meta"]["warnings"] if "no samples" not in w]
    chart = chart_svg(trace, warnings)
    model["meta"]["warnings"] = warnings
    base = {"map": model["map"], "warnings": warnings, "name": model["meta"]["name"], "trace": name}
    report = "fsm.tools.report"
    parts = {
        "__TITLE__": escape(f"{model['meta']['name']} — tral-fsm live"),
        "__VERSION__": escape(__version__),
        "__UPLOT_CSS__": _asset(report, "uPlot.min.css"),
        "__CSS__": _asset(report, "report.css") + _asset(__package__, "live.css"),
        "__SVG__": chart,
        "__DATA__": _embedded_json(model),
        "__BASE__": _embedded_json(base),
        "__UPLOT_JS__": _asset(report, "uPlot.iife.min.js").replace("</script", "<\\/script"),
        "__JS__": _asset(report, "report.js"),
        "__MODEL_JS__": _asset(__package__, "model.js"),
        "__LIVE_JS__": _asset(__package__, "live.js"),
    }
    page: str = fill_template(_asset(__package__, "live.html"), parts)
    return page

