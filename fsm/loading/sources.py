"""What a machine is loaded from: the one rule ``fsm.load``, ``fsm.check`` and ``fsm.run`` share.

A *source* is a path to a document file (``.json``, or ``.uxf`` with the UMLet reader), the JSON text itself (a
string whose first character past white space is ``{``), the document as a dict, a spec parsed before
(:class:`~fsm.model.document.MachineSpec`) or a plan compiled before (:class:`~fsm.model.plan.MachinePlan`).
JSON text is read as the file ``<text>.json`` is, so that its problems carry ``<text>.json:line:column``.
Anything else is a ``TypeError`` saying what a source may be.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Union

from fsm.loading.reading import preloaded
from fsm.model.document import MachineSpec
from fsm.model.plan import MachinePlan
from fsm.runtime.context import shown_value

#: A document to read, parse and check: a path, JSON text, the document as a dict, or a spec parsed before.
DocumentSource = Union[str, "os.PathLike[str]", Mapping[str, object], MachineSpec]
#: What ``fsm.load`` and ``fsm.check`` start from: a document, or a plan compiled before.
Source = Union[DocumentSource, MachinePlan]
#: The name JSON text given as the source goes by in problems (``<text>.json:3:12: error: ...``).
TEXT_NAME = "<text>.json"
#: What a source may be, as the ``TypeError`` of a wrong one says it.
KINDS = "a path, JSON text, a document dict, a spec or a plan"


def is_text(source: object) -> bool:
    """True when ``source`` is JSON text rather than a path: a string that starts with ``{`` (past white space and
    a byte order mark). No file name starts so, and a document is an object."""
    return isinstance(source, str) and source.lstrip("\ufeff \t\r\n").startswith("{")


def checked_source(source: object, name: str = "source", kinds: str = KINDS) -> Source:
    """``source`` if it is of a kind a machine is loaded from, else a ``TypeError`` naming ``name`` and the kinds."""
    if isinstance(source, (str, os.PathLike, Mapping, MachineSpec, MachinePlan)):
        return source
    raise TypeError(f"{name} must be {kinds}; got {shown_value(source)}")


@contextmanager
def document_read(source: DocumentSource, base_dir: str | os.PathLike[str] | None = None
                  ) -> Iterator[DocumentSource]:
    """``source`` as the stages read it: JSON text becomes the file ``<text>.json`` (its text preloaded, read as a
    file is, so that problems get line:column), in ``base_dir`` when given (its includes are found there, as a
    dict's are; else in the working directory); any other document stays what it is."""
    if isinstance(source, str) and is_text(source):
        name = TEXT_NAME if base_dir is None else os.path.join(os.fspath(base_dir), TEXT_NAME)
        with preloaded({name: source.encode("utf-8", "surrogatepass")}):
            yield name
        return
    yield source


__all__ = ["KINDS", "TEXT_NAME", "DocumentSource", "Source", "checked_source", "document_read", "is_text"]
