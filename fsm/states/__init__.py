"""The library of state classes, installed as ``fsm.states``; importing it registers them."""

from __future__ import annotations

from .composites import FSMState, Parallel
from .driving import ApproachPoint, BasicFollowWall, FollowWall, FollowWallRamp, Motor, Stop
from .gate_driving import AlignHeading, ArucoGateCenter
from .generic import Final, Idle
from .plants import Button, Integrator, Queue, TimerSensor
from .sequence import Join, ResetTimeout, Sequence, SetVar, Step, Wait

__all__ = [
    "AlignHeading",
    "ApproachPoint",
    "ArucoGateCenter",
    "BasicFollowWall",
    "FSMState",
    "Final",
    "FollowWall",
    "FollowWallRamp",
    "Idle",
    "Motor",
    "Parallel",
    "Sequence",
    "SetVar",
    "Step",
    "Stop",
    "Wait",
    "Join",
    "ResetTimeout",
    "Button",
    "Integrator",
    "Queue",
    "TimerSensor",
]
