"""Registry: type name -> class, for states and transitions; built-ins, entry-point plugins, ``--plugin`` modules.

A document names only registered types, never a Python module. Registration validates the class (a
``Params`` model of the right base, a unique name), like BehaviorTree.CPP's factory refuses duplicates.
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

from .errors import RegistrationError
from .params import StateParams, TransitionParams
from .state import State
from .transition import Transition

S = TypeVar("S", bound=type[State])
T = TypeVar("T", bound=type[Transition])

STATE_GROUP = "fsm.states"
TRANSITION_GROUP = "fsm.transitions"


class Registry:
    """Two name spaces, states and transitions; a name may not be registered twice in one of them."""

    def __init__(self) -> None:
        self.states: dict[str, type[State]] = {}
        self.transitions: dict[str, type[Transition]] = {}
        self._loaded_plugins: set[str] = set()

    # -- registration ---------------------------------------------------------------------------
    def add_state(self, cls: type[State], name: str | None = None) -> type[State]:
        return self._add(self.states, State, StateParams, cls, name, "state")

    def add_transition(self, cls: type[Transition], name: str | None = None) -> type[Transition]:
        return self._add(self.transitions, Transition, TransitionParams, cls, name, "transition")

    def _add(self, table: dict[str, Any], base: type, params_base: type, cls: Any, name: str | None,
             kind: str) -> Any:
        name = name or cls.__name__
        if not (isinstance(cls, type) and issubclass(cls, base)):
            raise RegistrationError(f"{cls!r} is not a subclass of fsm.{base.__name__}")
        self._check_params(cls, name, params_base)
        self._check_free(table, name, cls, kind)
        cls.type_name = name
        table[name] = cls
        return cls

    @staticmethod
    def _check_params(cls: type, name: str, base: type) -> None:
        params = getattr(cls, "Params", None)
        if not (isinstance(params, type) and issubclass(params, base)):
            raise RegistrationError(
                f"{name}: Params must be a subclass of {base.__module__}.{base.__name__}, got {params!r}"
            )
        if not name.isidentifier():
            raise RegistrationError(f"type name {name!r} must be an identifier (letters, digits, _)")

    @staticmethod
    def _check_free(table: dict[str, Any], name: str, cls: type, kind: str) -> None:
        other = table.get(name)
        if other is not None:
            raise RegistrationError(
                f"{kind} type {name!r} is already registered by {other.__module__}.{other.__qualname__}; "
                f"{cls.__module__}.{cls.__qualname__} needs another name"
            )

    # -- lookup ---------------------------------------------------------------------------------
    def state_class(self, name: str) -> type[State] | None:
        return self.states.get(name)

    def transition_class(self, name: str) -> type[Transition] | None:
        return self.transitions.get(name)

    def suggest(self, name: str, kind: str) -> list[str]:
        """Registered names close to ``name`` (for "did you mean" hints)."""
        table = self.states if kind == "state" else self.transitions
        by_lower = {n.lower(): n for n in table}
        close = difflib.get_close_matches(name.lower(), list(by_lower), n=3, cutoff=0.6)
        return [by_lower[c] for c in close]

    def __iter__(self) -> Iterator[tuple[str, str, type]]:
        for name, cls in sorted(self.states.items()):
            yield "state", name, cls
        for name, tcls in sorted(self.transitions.items()):
            yield "transition", name, tcls

    # -- plugins --------------------------------------------------------------------------------
    def load_module(self, module: str) -> None:
        """Import ``module`` so its decorators register its types into this registry (``--plugin``)."""
        if module in self._loaded_plugins:
            return
        with using(self):
            importlib.import_module(module)
        self._loaded_plugins.add(module)

    def load_entry_points(self) -> None:
        """Load third-party types from the entry-point groups ``fsm.states`` and ``fsm.transitions``.

        An entry point names a module (its decorators register) or a class (registered under its name).
        """
        from importlib.metadata import entry_points

        for group, add in ((STATE_GROUP, self.add_state), (TRANSITION_GROUP, self.add_transition)):
            for ep in entry_points(group=group):
                key = f"{group}:{ep.name}={ep.value}"
                if key in self._loaded_plugins:
                    continue
                with using(self):
                    obj = ep.load()
                if isinstance(obj, type):
                    table = self.states if group == STATE_GROUP else self.transitions
                    if table.get(ep.name) is not obj and table.get(obj.__name__) is not obj:
                        add(obj, ep.name)  # type: ignore[arg-type]
                self._loaded_plugins.add(key)


# -- the process-wide registry and its decorators ---------------------------------------------------
_current: list[Registry] = [Registry()]
_builtins_loaded = False


class using:
    """Context manager: decorators register into ``registry`` while it is active (plugins, tests)."""

    def __init__(self, registry: Registry) -> None:
        self.registry = registry

    def __enter__(self) -> Registry:
        _current.append(self.registry)
        return self.registry

    def __exit__(self, *exc: object) -> None:
        _current.pop()


def current() -> Registry:
    """The registry decorators write to now (the default one unless inside ``using``)."""
    return _current[-1]


def register_state(cls: S | None = None, *, name: str | None = None) -> Any:
    """Class decorator: register a State subclass under its class name (or ``name``)."""

    def deco(c: S) -> S:
        current().add_state(c, name)
        return c

    return deco(cls) if cls is not None else deco


def register_transition(cls: T | None = None, *, name: str | None = None) -> Any:
    """Class decorator: register a Transition subclass under its class name (or ``name``)."""

    def deco(c: T) -> T:
        current().add_transition(c, name)
        return c

    return deco(cls) if cls is not None else deco


def default_registry(plugins: list[str] | tuple[str, ...] = (), entry_points: bool = True) -> Registry:
    """The process registry with the built-in types, installed plugins and the ``plugins`` modules loaded."""
    global _builtins_loaded
    registry = _current[0]
    if not _builtins_loaded:
        _builtins_loaded = True
        with using(registry):
            importlib.import_module("fsm.states")
            importlib.import_module("fsm.transitions")
        if entry_points:
            registry.load_entry_points()
    for module in plugins:
        registry.load_module(module)
    return registry


def builder(kind: str) -> Callable[..., Any]:
    """``register_state`` or ``register_transition`` by kind name."""
    return register_state if kind == "state" else register_transition
