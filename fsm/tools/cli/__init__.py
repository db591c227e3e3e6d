"""``fsmctl``: the command line. :mod:`~fsm.tools.cli.app` builds the parser and maps errors to exit statuses
(0 success, 1 a document or run failed, 2 usage); each command is one module here with a ``register``
function (:mod:`~fsm.tools.cli.validate`, :mod:`~fsm.tools.cli.run`, ...); :mod:`~fsm.tools.cli.common` holds
what they share. The CLI may import everything; nothing imports the CLI.
"""

from __future__ import annotations

from .app import build_parser, main

__all__ = ["build_parser", "main"]
