"""The package's version (``fsm.__version__``), here so that the layers below the package's root can name it."""

from __future__ import annotations

#: The distribution's version, as pyproject.toml has it.
VERSION = "0.1.0"
