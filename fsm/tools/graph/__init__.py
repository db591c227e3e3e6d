"""Drawings of machines with their nesting: Mermaid, Graphviz DOT, and SVG drawn here (no Graphviz needed).

Holds the layered layout (:mod:`~fsm.tools.graph.layout`, also used by the UMLet writer to place boxes),
labels and text measurement (:mod:`~fsm.tools.graph.labels`), the text formats
(:mod:`~fsm.tools.graph.text`), include expansion (:mod:`~fsm.tools.graph.includes`), the SVG renderer
(:mod:`~fsm.tools.graph.drawing`), what overlaps in its drawings (:mod:`~fsm.tools.graph.quality`) and the plane
geometry these share (:mod:`~fsm.tools.graph.geometry`). May import the ``fsm`` core; never the CLI, UMLet or the car.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["FONT", "dot", "edge_label", "mermaid", "state_label", "svg", "text_width"]
_HOMES = {"svg": "drawing", "FONT": "labels", "edge_label": "labels", "state_label": "labels", "text_width": "labels",
          "dot": "text", "mermaid": "text"}


def __getattr__(name: str) -> Any:
    """The drawing modules load when first used: a run that traces imports only ``includes`` from here."""
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value
    return value
