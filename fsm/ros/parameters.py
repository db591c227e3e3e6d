"""The parameters of a machine's states as ROS 2 parameters (over rclpy): what the bridge's node declares and what
a set from outside does. Built by the command (:mod:`fsm.tools.ros.parameters`, which knows the document);
declared by :meth:`fsm.ros.rclpy_link.RclpyLink.expose_parameters`; applied by the driver between two ticks."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Tunable:
    """One parameter of one state: ``states.<path with dots>.<parameter>`` on the node."""

    #: the ROS 2 parameter's name
    name: str
    #: the state's path in the machine, and the parameter's name there
    path: str
    param: str
    #: the value the run starts with (bool, int, float or str; lists and objects as JSON text)
    value: Any
    description: str
    #: settable from outside (``--tunable``); read-only otherwise
    writable: bool
    #: the state's new parameters for a value set from outside; ValueError with the reason when it is not valid
    validate: Callable[[Any], Any]


def apply_tunable(machine: Any, tunable: Tunable, checked: Any) -> Any:
    """The state at ``tunable.path`` takes the parameter's value from ``checked`` (parameters :attr:`Tunable.validate`
    made), its other parameters kept as they are now (another may have been set since); between two ticks. A state
    reads its parameters when it runs, most of them when it is entered, so a change shows from its next entry (at
    once for what it reads every tick). The state's new parameters."""
    state = machine.state(tunable.path)
    data = state.params.model_dump(by_alias=True, exclude_unset=True)
    data[tunable.param] = checked.model_dump(by_alias=True)[tunable.param]
    state.params = type(state.params).model_validate(data)
    return state.params
