"""Deprecated names of the plugin bases, and warnings their users see.

Python shows a ``DeprecationWarning`` by default only when the code that triggers it is ``__main__``: a plugin
author's module, imported by ``fsmctl --plugin``, an entry point or a script, would never hear of it.
:func:`warn_deprecated` names the author's line (the caller's frame) and, where only Python's default filter would
hide it (not where the user chose filters: ``-W``, ``PYTHONWARNINGS``, pytest's ``filterwarnings``), shows
``DeprecationWarning`` of that module once per line, as Python does for ``__main__``. tral-fsm's own modules are
left to Python's defaults.
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
    if module and not sys.warnoptions and module != "fsm" and not module.startswith("fsm.") \
            and _hidden_by_python(module, message):  # once: then ours is the first
        warnings.filterwarnings("default", category=DeprecationWarning, module=re.escape(module) + r"\Z")
    warnings.warn(message, DeprecationWarning, stacklevel=stacklevel + 1)


#: Python's own filters: it shows ``DeprecationWarning`` in ``__main__`` and hides it elsewhere (the second follows
#: the first; a user's ``simplefilter("ignore", DeprecationWarning)`` is the second alone, and is theirs).
_PYTHONS_MAIN = ("default", None, DeprecationWarning, "__main__", 0)
_PYTHONS_IGNORE = ("ignore", None, DeprecationWarning, None, 0)


def _hidden_by_python(module: str, message: str) -> bool:
    """True when the warning filter that decides a ``DeprecationWarning`` of ``module`` with ``message`` (the first
    that matches, as :mod:`warnings` looks) is Python's default hiding, not one the user chose."""
    filters = warnings.filters
    for k, item in enumerate(filters):
        _action, text, category, where, line = item
        if issubclass(DeprecationWarning, category) and line == 0 and _matches(text, message) \
                and _matches(where, module):
            return tuple(item) == _PYTHONS_IGNORE and k > 0 and tuple(filters[k - 1]) == _PYTHONS_MAIN
    return False


def _matches(pattern: Any, text: str) -> bool:
    """A filter's message or module: None matches anything, a compiled pattern by ``match``, and a string (Python's
    own default filters hold ``"__main__"``) by equality, as :mod:`warnings` reads them."""
    if pattern is None:
        return True
    return bool(pattern.match(text)) if hasattr(pattern, "match") else pattern == text


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
