"""What users run, installed as ``fsm.tools``; one subpackage per concern.

- :mod:`fsm.tools.cli`: ``fsmctl``, the entry point and one module per command.
- :mod:`fsm.tools.umlet`: the ``.uxf`` reader pipeline, the writer and the palette.
- :mod:`fsm.tools.graph`: the layered layout and the SVG, Mermaid and DOT drawings.
- :mod:`fsm.tools.files`: reading and writing the files users name, shared by all of them.
- :mod:`fsm.tools.runs`: what the commands that run a machine share (arguments, the end of a run), below the CLI,
  the live debugger and the ROS 2 bridge.

Only the CLI imports the other packages' commands; the UMLet and graph packages never import the CLI. The one
helper all of them share, :func:`did_you_mean`, lives here, below every subpackage.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(word: str, known: Iterable[str], n: int = 2) -> str | None:
    """"did you mean 'a' or 'b'?" for the (at most ``n``) known words close to ``word``, or ``None``; callers add
    what to say when nothing is close (``did_you_mean(w, known) or "states: ..."``)."""
    close = difflib.get_close_matches(word, list(known), n=n)
    return "did you mean " + " or ".join(repr(c) for c in close) + "?" if close else None
