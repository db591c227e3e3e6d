"""tral-fsm: declarative, tick-driven state machines for robots.

Load a machine document (JSON, or a UMLet diagram) and tick it::

    import fsm
    machine = fsm.load("diagrams/example.json")
    outcome = machine.run(duration=10.0)
"""

from __future__ import annotations

from .clock import DEFAULT_DT, Clock, RealTimeClock, SimulatedClock
from .composite import Composite
from .condition import Condition
from .context import Context
from .errors import DiagramError, FsmError, Problem, RegistrationError, StateRuntimeError
from .loader import check, load
from .machine import Listener, Machine
from .params import ConditionParams, StateParams, TransitionParams
from .plant import Plant, PlantParams
from .registry import (
    Registry,
    default_registry,
    register_condition,
    register_plant,
    register_state,
    register_transition,
)
from .session import Session, StopRules
from .state import State
from .transition import Transition

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_DT",
    "Clock",
    "Composite",
    "Condition",
    "ConditionParams",
    "Context",
    "DiagramError",
    "FsmError",
    "Listener",
    "Machine",
    "Plant",
    "PlantParams",
    "Problem",
    "RealTimeClock",
    "Registry",
    "RegistrationError",
    "Session",
    "SimulatedClock",
    "State",
    "StateParams",
    "StateRuntimeError",
    "StopRules",
    "Transition",
    "TransitionParams",
    "check",
    "default_registry",
    "load",
    "register_condition",
    "register_plant",
    "register_state",
    "register_transition",
]
