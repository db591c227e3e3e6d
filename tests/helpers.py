"""Helpers shared by several test modules (importable because pytest puts tests/ on sys.path)."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def without_layout(d: Any) -> Any:
    """A document with every ``layout`` key removed, at any depth: what may differ after a diagram round trip."""
    if isinstance(d, dict):
        return {k: without_layout(v) for k, v in d.items() if k != "layout"}
    if isinstance(d, list):
        return [without_layout(x) for x in d]
    return d


def _corpus() -> Path:
    """The real UMLet files: ``../shared/corpus/uxf`` beside the checkout (as on CI), else the workplace copy."""
    beside = Path(__file__).resolve().parents[2] / "shared" / "corpus" / "uxf"
    return beside if beside.is_dir() else Path("/work/shared/corpus/uxf")


#: The corpus of real-world UMLet diagrams (read from there, never copied into the project).
CORPUS = _corpus()
