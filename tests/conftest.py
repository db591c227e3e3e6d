"""Test configuration: in CI (``CI`` set) hypothesis runs derandomized, so a run is reproducible and a red
CI means a real regression, not a newly drawn example; locally it keeps exploring new examples."""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
