"""tral-fsm: declarative, tick-driven state machines for robots.

Load a machine document (JSON, or a UMLet diagram) and tick it::

    import fsm
    machine = fsm.load("diagrams/example.json")
    outcome = machine.run(duration=10.0)
"""

from __future__ import annotations

from fsm.loading.loader import check, load
from fsm.loading.registry import (
    Registry,
    default_registry,
    register_condition,
    register_plant,
    register_state,
    register_transition,
)
from fsm.model.errors import DiagramError, FsmError, Problem, RegistrationError, StateRuntimeError
from fsm.model.params import ConditionParams, StateParams, TransitionParams
from fsm.runtime.clock import DEFAULT_DT, Clock, RealTimeClock, SimulatedClock
from fsm.runtime.composite import Composite
from fsm.runtime.condition import Condition
from fsm.runtime.context import Context
from fsm.runtime.machine import Listener, Machine
from fsm.runtime.plant import Plant, PlantParams
from fsm.runtime.state import State
from fsm.runtime.transition import Transition
from fsm.session.session import Session, StopRules

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
