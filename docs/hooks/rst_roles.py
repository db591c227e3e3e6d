"""Griffe extension for the API reference: the docstrings' reStructuredText roles (``:class:`X```) as code."""

from __future__ import annotations

import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:class|func|meth|mod|attr|data|exc):`~?([^`]+)`")


class RstRoles(griffe.Extension):
    """``:class:`fsm.runtime.composite.Composite``` -> ```fsm.runtime.composite.Composite```; ``~`` keeps the last
    name."""

    def on_instance(self, *, obj: Any, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _ROLE.sub(lambda m: f"`{m.group(1)}`", obj.docstring.value)
