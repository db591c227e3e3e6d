"""The entry points of the installed distributions, read once per process.

``importlib.metadata.entry_points(group=...)`` reads the metadata of every installed distribution on each call: the
registry asks for four groups and the reading rule for readers, five scans of a hundred distributions (a test
environment's) before the first load, about a third of it. One scan serves them all; :func:`forget` makes the next
lookup scan again (after installing a distribution into the running process).
"""

from __future__ import annotations

import importlib.metadata
import threading
from typing import Any

#: The scan, once made: an ``EntryPoints`` (Python 3.12+) or Python 3.11's ``SelectableGroups``, both selectable.
_INDEX: list[Any] = []
_LOCK = threading.Lock()


def entry_points(*, group: str, name: str | None = None) -> importlib.metadata.EntryPoints:
    """The installed entry points of ``group`` (named ``name`` when given), as ``importlib.metadata`` finds them."""
    with _LOCK:
        if not _INDEX:
            _INDEX.append(importlib.metadata.entry_points())
        index = _INDEX[0]
    found: importlib.metadata.EntryPoints = (index.select(group=group) if name is None
                                             else index.select(group=group, name=name))
    return found


def forget() -> None:
    """Read the installed distributions again at the next lookup."""
    with _LOCK:
        _INDEX.clear()


__all__ = ["entry_points", "forget"]
