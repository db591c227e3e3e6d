"""The library of transition classes, installed as ``fsm.transitions``; importing it registers them."""

from __future__ import annotations

from .car import Distance, PassPoint, SensorLevel
from .conditions import ConditionTransition
from .generic import Always, Finished, Timeout
from .inputs import InState, Signal, Var
from .markers import ArucoGateFound, ArucoMarkerFound, ArucoMarkerUnpaired
from .topics import TopicQuiet

__all__ = ["Always", "ArucoGateFound", "ArucoMarkerFound", "ArucoMarkerUnpaired", "ConditionTransition", "Distance",
           "Finished", "InState", "PassPoint", "SensorLevel", "Signal", "Timeout", "TopicQuiet", "Var"]
