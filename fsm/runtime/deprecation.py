"""Deprecated names of the plugin bases, and warnings their users see.

Python shows a ``DeprecationWarning`` by default only when the code that triggers it is ``__main__``: a plugin
author's module, imported by ``fsmctl --plugin``, an entry point or a script, would never hear of it.
:func:`warn_deprecated` names the author's line (the caller's frame) and, unless the user chose warning filters
themselves (``-W``, ``PYTHONWARNINGS``), shows ``DeprecationWarning`` of that module once per line, as Python does
for ``__main__``. tral-fsm's own modules are left to Python's defaults.
"""

from __future__ import annotations

import re
import sys
import warnings
from collections.abc import Callable
from typing import Any


def warn_deprecated(message: str, stacklevel: int = 2) -> None:
    """Warn ``message`` as a ``DeprecationWarning`` of the line ``stacklevel`` frames up (2: the caller's caller, as
    :func:`warnings.warn` counts), shown once per line when that line is not tral-fsm's own."""
    frame = sys._getframe(stacklevel)
    module = str(frame.f_globals.get("__name__", ""))
    if module and not sys.warnoptions and module != "fsm" and not module.startswith("fsm."):
        shown = ("default", None, DeprecationWarning, re.compile(re.escape(module) + r"\Z"), 0)
        if shown not in warnings.filters:  # added once: adding again would show every line again
            warnings.filterwarnings("default", category=DeprecationWarning, module=re.escape(module) + r"\Z")
    warnings.warn(message, DeprecationWarning, stacklevel=stacklevel + 1)


class Renamed:
    """A deprecated name of an attribute: reading it warns (:func:`warn_deprecated`) and reads ``new`` of the object
    (or of ``record(obj)``, its wiring record, ``default`` where that lacks it; with ``on_class``, of the class, for a
    name read from the class). A non-data descriptor: a subclass or an instance that assigns the old name for its
    own use owns it, and the runtime never reads it."""

    def __init__(self, old: str, new: str, *, record: Callable[[Any], Any] | None = None, default: Any = None,
                 on_class: bool = False, where: str | None = None, read: str | None = None,
                 until: str = "the next release") -> None:
        self.old, self.new, self.record, self.default, self.on_class = old, new, record, default, on_class
        #: what the warning says to read instead: ``read``, else ``where.new`` (``where``: the class by default)
        self.where, self.read, self.until = where, read, until

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None and not self.on_class:
            return self
        cls = owner if obj is None else type(obj)
        instead = self.read or f"{self.where or getattr(cls, '__qualname__', '')}.{self.new}"
        warn_deprecated(f"{getattr(cls, '__qualname__', '')}.{self.old} is deprecated (removed in {self.until}): "
                        f"read {instead}")
        if self.record is not None:
            return getattr(self.record(obj), self.new, self.default)
        return getattr(obj if obj is not None else owner, self.new)


__all__ = ["Renamed", "warn_deprecated"]
