"""Drawings of machines with their nesting: Mermaid, Graphviz DOT, and SVG drawn here (no Graphviz needed).

Holds the layered layout (:mod:`~fsm.tools.graph.layout`, also used by the UMLet writer to place boxes),
labels and text measurement (:mod:`~fsm.tools.graph.labels`), the text formats
(:mod:`~fsm.tools.graph.text`), include expansion (:mod:`~fsm.tools.graph.includes`) and the SVG renderer
(:mod:`~fsm.tools.graph.drawing`). May import the ``fsm`` core; never the CLI, UMLet or the car.
"""

from __future__ import annotations

from .drawing import svg
from .labels import FONT, edge_label, state_label, text_width
from .text import dot, mermaid

__all__ = ["FONT", "dot", "edge_label", "mermaid", "state_label", "svg", "text_width"]
