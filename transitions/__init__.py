"""The library of transition classes, installed as ``fsm.transitions``; importing it registers them."""

from __future__ import annotations

from .generic import Always, Finished, Timeout
from .inputs import InState, Signal, Var

__all__ = ["Always", "Finished", "InState", "Signal", "Timeout", "Var"]
