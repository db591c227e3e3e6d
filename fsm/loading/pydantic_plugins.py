"""pydantic's plugins, looked up without reading every installed distribution's metadata when none is installed.

pydantic looks its plugins up (``importlib.metadata.entry_points(group="pydantic")``, which reads the metadata of
every installed distribution) when it builds its first validator of a process: about 50M instructions in a test
environment, a sixth of a process's first load of the 1000-state ring, for the parameter models are built on first
use (:class:`fsm.model.params.ParamsBase`). Reading the entry point files alone for a ``[pydantic]`` section is a few
hundred file opens.
"""

from __future__ import annotations

import importlib.machinery
import os
import re
import sys


def spare_pydantic_plugin_scan() -> None:
    """Tell pydantic it has no plugins when no distribution declares one (:func:`declares_no_group`), as its own
    scan would have found; when one does, or should pydantic keep its plugins elsewhere, nothing changes."""
    import pydantic.plugin._loader as plugin_loader  # pydantic's own cache of its plugins: no public name for it

    if getattr(plugin_loader, "_plugins", ()) is None and declares_no_group("pydantic"):
        plugin_loader._plugins = {}


_FINDER = importlib.machinery.PathFinder


def declares_no_group(group: str) -> bool:
    """True when no distribution ``importlib.metadata`` would find declares entry points of ``group``; False also
    when that cannot be told from folders alone (a zip or an egg on ``sys.path``, a finder of distributions of its
    own on ``sys.meta_path``)."""
    if any(getattr(f, "find_distributions", None) is not None and f is not _FINDER for f in sys.meta_path):
        return False
    header = re.compile(r"^\s*\[\s*" + re.escape(group) + r"\s*\]\s*$", re.M)
    for entry in sys.path:
        root = entry or "."
        if not os.path.isdir(root):
            if os.path.exists(root):
                return False  # a zip file: its distributions are read through zipfile
            continue
        if root.lower().endswith(".egg"):
            return False
        try:
            names = os.listdir(root)
        except OSError:
            continue
        for name in names:
            if name.lower().endswith((".dist-info", ".egg-info")) and _declares(os.path.join(root, name), header):
                return False
    return True


def _declares(info: str, header: re.Pattern[str]) -> bool:
    """Whether the distribution whose metadata folder is ``info`` has an entry point section ``header``."""
    try:
        with open(os.path.join(info, "entry_points.txt"), encoding="utf-8") as fh:
            return header.search(fh.read()) is not None
    except (OSError, UnicodeDecodeError):
        return False


__all__ = ["declares_no_group", "spare_pydantic_plugin_scan"]
