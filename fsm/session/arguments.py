"""The arguments a run is opened with, checked where the caller gives them (``fsm.run``, ``Session.open``): the
variables (names to JSON values) and the car (the car interface, found by its entry point).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from fsm.loading.installed import entry_points
from fsm.runtime.context import shown_value

#: The entry-point group that names the car interface (``car = "fsm.sim.io:CarIO"``) a ``car=`` must have.
INTERFACES = "fsm.interfaces"


def variables_argument(variables: object) -> dict[str, object] | None:
    """``variables`` checked: a mapping of names (strings) to JSON values (None, bool, int, a finite float, str, and
    lists and string-keyed dicts of them), as a document's ``vars`` holds; else a ``TypeError`` or ``ValueError``
    naming the argument and the entry."""
    if variables is None:
        return None
    if not isinstance(variables, Mapping):
        raise TypeError(f"variables must be a mapping of names to JSON values (a dict) or None, got "
                        f"{shown_value(variables)}")
    for name, value in variables.items():
        if not isinstance(name, str):
            raise TypeError(f"variables: each name must be a string, got {shown_value(name)}")
        _json_value(f"variables[{name!r}]", value)
    return dict(variables)


def _json_value(where: str, value: object, depth: int = 0) -> None:
    if value is None or isinstance(value, (bool, int, str)):
        return
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{where} must be a finite number, got {value!r}")
        return
    if depth > 100:
        raise ValueError(f"{where} is nested too deeply (more than 100 levels)")
    if isinstance(value, (list, tuple)):
        for k, item in enumerate(value):
            _json_value(f"{where}[{k}]", item, depth + 1)
        return
    if isinstance(value, Mapping):
        for key, item in value.items():
            if not isinstance(key, str):
                raise TypeError(f"{where}: each key must be a string, got {shown_value(key)}")
            _json_value(f"{where}[{key!r}]", item, depth + 1)
        return
    raise TypeError(f"{where} must be a JSON value (None, bool, int, float, str, or a list or dict of them), got "
                    f"{shown_value(value)}")


def car_argument(car: object) -> None:
    """A ``car=`` must have the car interface (``fsm.sim.io.CarIO``, found by its ``fsm.interfaces`` entry point, so
    that the core imports no simulator): else a ``TypeError`` naming what it lacks. A car may keep a value as a
    plain attribute, a property or a slot, or answer every name (``__getattr__``: a proxy or a mock)."""
    if car is None:
        return
    for point in entry_points(group=INTERFACES, name="car"):
        interface: type = point.load()
        cls = type(car)
        if hasattr(cls, "__getattr__"):
            return
        own = getattr(car, "__dict__", {})
        members = sorted({name for name in vars(interface) if not name.startswith("_")}
                         | set(getattr(interface, "__annotations__", {})))
        missing = [name for name in members if not hasattr(cls, name) and name not in own]
        if missing:
            raise TypeError(f"car must have the car interface ({interface.__module__}.{interface.__qualname__}): "
                            f"{shown_value(car)} lacks {', '.join(missing)}")
        return


__all__ = ["INTERFACES", "car_argument", "variables_argument"]
