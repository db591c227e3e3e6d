"""The library of transition classes, installed as ``fsm.transitions``; importing it registers them."""

from __future__ import annotations

from .car import Distance, SensorLevel
from .conditions import ConditionTransition
from .generic import Always, Finished, Timeout
from .inputs import InState, Signal, Var

__all__ = ["Always", "ConditionTransition", "Distance", "Finished", "InState", "SensorLevel", "Signal", "Timeout", "Var"]
