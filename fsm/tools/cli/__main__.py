"""``python -m fsm.tools.cli``: the same as ``fsmctl``."""

from __future__ import annotations

import sys

from .app import main

sys.exit(main())
