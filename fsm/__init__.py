"""tral-fsm: declarative, tick-driven state machines for robots.

Load a machine document (JSON, or a UMLet diagram) and tick it::

    import fsm
    machine = fsm.load("diagrams/example.json")
    outcome = machine.run(duration=10.0)
"""

from __future__ import annotations

from .clock import DEFAULT_DT, RealTimeClock, SimulatedClock
from .composite import Composite
from .context import Context
from .errors import DiagramError, FsmError, Problem, RegistrationError, StateRuntimeError
from .loader import check, load
from .machine import Listener, Machine
from .params import StateParams, TransitionParams
from .registry import Registry, default_registry, register_state, register_transition
from .state import State
from .transition import Transition

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_DT",
    "Composite",
    "Context",
    "DiagramError",
    "FsmError",
    "Listener",
    "Machine",
    "Problem",
    "RealTimeClock",
    "Registry",
    "RegistrationError",
    "SimulatedClock",
    "State",
    "StateParams",
    "StateRuntimeError",
    "Transition",
    "TransitionParams",
    "check",
    "default_registry",
    "load",
    "register_state",
    "register_transition",
]
