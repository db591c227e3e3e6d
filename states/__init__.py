"""The library of state classes, installed as ``fsm.states``; importing it registers them."""

from __future__ import annotations

from .composites import FSMState, Parallel
from .generic import Final, Idle

__all__ = ["FSMState", "Final", "Idle", "Parallel"]
