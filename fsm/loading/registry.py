"""Registry: type name -> class, for states and transitions; built-ins, entry-point plugins, ``--plugin`` modules.

A document names only registered types, never a Python module. Registration validates the class (a
``Params`` model of the right base, a unique name), like BehaviorTree.CPP's factory refuses duplicates.
"""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import os
import sys
import traceback
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

from fsm.model.errors import RegistrationError, UsageError
from fsm.model.params import ConditionParams, StateParams, TransitionParams
from fsm.runtime.condition import Condition
from fsm.runtime.state import State
from fsm.runtime.transition import Transition

S = TypeVar("S", bound=type[State[Any]])
T = TypeVar("T", bound=type[Transition[Any]])
C = TypeVar("C", bound=type[Condition[Any]])
#: A registered class, of any kind.
K = TypeVar("K", bound=type)

STATE_GROUP = "fsm.states"
TRANSITION_GROUP = "fsm.transitions"
CONDITION_GROUP = "fsm.conditions"
PLANT_GROUP = "fsm.plants"


class Registry:
    """Name spaces of types: states, transitions, conditions and plants; a name may not be registered twice in one.

    A registry is a value: ``Registry()`` is empty, :meth:`with_builtins` a fresh one with the built-in types, and
    :func:`default_registry` the process's (built-ins, installed plugins, ``--plugin`` modules). Registering
    changes the registry only, never the class: one class may be registered under different names in different
    registries, and an element knows its type's name from its document (``params.type``).
    """

    def __init__(self) -> None:
        self.states: dict[str, type[State[Any]]] = {}
        self.transitions: dict[str, type[Transition[Any]]] = {}
        self.conditions: dict[str, type[Condition[Any]]] = {}
        self.plants: dict[str, type[Any]] = {}
        self._loaded_plugins: set[str] = set()
        #: (kind, name) -> the installed distribution whose entry point registered the type
        self.installed_by: dict[tuple[str, str], str] = {}

    # -- registration ---------------------------------------------------------------------------
    def add_state(self, cls: type[State[Any]], name: str | None = None) -> type[State[Any]]:
        return self._add(self.states, State, StateParams, cls, name, "state")

    def add_transition(self, cls: type[Transition[Any]], name: str | None = None) -> type[Transition[Any]]:
        return self._add(self.transitions, Transition, TransitionParams, cls, name, "transition")

    def add_condition(self, cls: type[Condition[Any]], name: str | None = None) -> type[Condition[Any]]:
        return self._add(self.conditions, Condition, ConditionParams, cls, name, "condition")

    def add_plant(self, cls: type[Any], name: str | None = None) -> type[Any]:
        from fsm.runtime.plant import Plant, PlantParams

        return self._add(self.plants, Plant, PlantParams, cls, name, "plant")

    def _add(self, table: dict[str, K], base: type, params_base: type, cls: K, name: str | None, kind: str) -> K:
        name = name or cls.__name__
        if not (isinstance(cls, type) and issubclass(cls, base)):
            raise RegistrationError(f"{cls!r} is not a subclass of fsm.{base.__name__}")
        self._check_params(cls, name, params_base)
        if self._check_free(table, name, cls, kind):
            table[name] = cls
        return cls

    @classmethod
    def with_builtins(cls) -> Registry:
        """A fresh registry holding the built-in state, transition and condition types (no plugins)."""
        registry = cls()
        for kind, name, type_ in builtin_types():
            {"state": registry.add_state, "transition": registry.add_transition,
             "condition": registry.add_condition, "plant": registry.add_plant}[kind](type_, name)
        return registry

    def name_of(self, cls: type) -> str | None:
        """The name ``cls`` is registered under here (states, transitions, conditions, plants), or None."""
        for table in (self.states, self.transitions, self.conditions, self.plants):
            for name, registered in table.items():
                if registered is cls:
                    return name
        return None

    @staticmethod
    def _check_params(cls: type, name: str, base: type) -> None:
        params = getattr(cls, "Params", None)
        if not (isinstance(params, type) and issubclass(params, base)):
            raise RegistrationError(
                f"{name}: Params must be a subclass of {base.__module__}.{base.__name__}, got {params!r}"
            )
        if not name.isidentifier():
            raise RegistrationError(f"type name {name!r} must be an identifier (letters, digits, _)")
        argument = getattr(cls, "params_argument", None)
        if isinstance(argument, type) and not issubclass(params, argument):
            raise RegistrationError(
                f"{cls.__module__}.{cls.__qualname__} (type {name!r}): Params = {params.__qualname__} disagrees with "
                f"its generic argument {argument.__qualname__}, which types self.params; drop the Params line "
                f"(the generic argument is the Params), or make Params a subclass of {argument.__qualname__}"
            )

    @staticmethod
    def _check_free(table: dict[str, Any], name: str, cls: type, kind: str) -> bool:
        """True when ``name`` is free; False when it holds ``cls`` already (the same class, or the same definition
        imported again under another module name: an entry point's module and ``--plugin`` its file); a
        :class:`RegistrationError` naming both classes when it holds another one."""
        other = table.get(name)
        if other is None:
            return True
        if same_definition(other, cls):
            return False
        raise RegistrationError(
            f"{kind} type {name!r} is already registered by {_described(other)}; {_described(cls)} is another "
            f"class and needs another name (register it with name=...)"
        )

    # -- lookup ---------------------------------------------------------------------------------
    def table(self, kind: str) -> dict[str, Any]:
        """The name space of ``kind``: "state", "transition" or "condition"."""
        tables: dict[str, dict[str, Any]] = {"state": self.states, "transition": self.transitions,
                                             "condition": self.conditions}
        return tables[kind]

    def suggest(self, name: str, kind: str) -> list[str]:
        """Registered names close to ``name`` (for "did you mean" hints)."""
        table = self.table(kind)
        by_lower = {n.lower(): n for n in table}
        close = difflib.get_close_matches(name.lower(), list(by_lower), n=3, cutoff=0.6)
        return [by_lower[c] for c in close]

    def __iter__(self) -> Iterator[tuple[str, str, type]]:
        """``(kind, name, class)`` of the state and transition types (the types a diagram draws)."""
        for name, cls in sorted(self.states.items()):
            yield "state", name, cls
        for name, tcls in sorted(self.transitions.items()):
            yield "transition", name, tcls

    def every(self) -> Iterator[tuple[str, str, type]]:
        """``(kind, name, class)`` of every registered type: states, transitions, then conditions."""
        yield from self
        for name, ccls in sorted(self.conditions.items()):
            yield "condition", name, ccls

    # -- plugins --------------------------------------------------------------------------------
    def load_module(self, module: str) -> None:
        """Import a plugin so its decorators register its types into this registry (``--plugin``).

        ``module`` is a module name, found among the installed packages and in the current folder (as
        ``python -m`` finds it), or the path of a ``.py`` file. A plugin that does not exist raises
        :class:`UsageError`; one that fails while importing or registering raises :class:`PluginError`
        naming the plugin and the file and line where it failed.
        """
        if module in self._loaded_plugins:
            return
        with using(self):
            _import_plugin(module)
        self._loaded_plugins.add(module)

    def load_entry_points(self) -> None:
        """Load third-party types from the entry-point groups ``fsm.states``, ``fsm.transitions`` and
        ``fsm.conditions``.

        An entry point names a module (its decorators register) or a class (registered under its name).
        """
        from fsm.loading.installed import entry_points

        adders: tuple[tuple[str, Callable[[Any, str], object]], ...] = (
            (STATE_GROUP, self.add_state), (TRANSITION_GROUP, self.add_transition),
            (CONDITION_GROUP, self.add_condition), (PLANT_GROUP, self.add_plant))
        for group, add in adders:
            for ep in entry_points(group=group):
                key = f"{group}:{ep.name}={ep.value}"
                if key in self._loaded_plugins:
                    continue
                before = {(kind, name) for kind, name, _ in self.every()}
                try:
                    with using(self):
                        obj = ep.load()
                except Exception as exc:  # an installed plugin that is broken: say which one and where
                    raise _plugin_error(f"entry point {ep.name} = {ep.value} ({group})", exc, None) from None
                if isinstance(obj, type):
                    tables: dict[str, dict[str, Any]] = {STATE_GROUP: self.states, TRANSITION_GROUP: self.transitions,
                                                         PLANT_GROUP: self.plants}
                    table = tables.get(group, self.conditions)
                    if table.get(ep.name) is not obj and table.get(obj.__name__) is not obj:
                        add(obj, ep.name)
                self._loaded_plugins.add(key)
                dist = getattr(getattr(ep, "dist", None), "name", None) or ep.value
                for added in {(kind, name) for kind, name, _ in self.every()} - before:
                    self.installed_by[added] = dist

    def without_installed(self) -> Registry:
        """A copy without the types installed plugins (entry points) registered: what a palette holds when it
        was generated without them."""
        copy = Registry()
        for kind, table in (("state", self.states), ("transition", self.transitions),
                            ("condition", self.conditions), ("plant", self.plants)):
            getattr(copy, kind + "s").update({n: c for n, c in table.items() if (kind, n) not in self.installed_by})
        return copy


def same_definition(a: type, b: type) -> bool:
    """Whether two classes are one definition: the same object, or the same qualified name in the same source file
    (a module imported twice, e.g. ``my_plugin.states`` through its entry point and ``--plugin states.py``)."""
    if a is b:
        return True
    file_a, file_b = _source_file(a), _source_file(b)
    return a.__qualname__ == b.__qualname__ and file_a is not None and file_a == file_b


def _source_file(cls: type) -> str | None:
    module = sys.modules.get(cls.__module__)
    file = getattr(module, "__file__", None)
    return os.path.realpath(file) if isinstance(file, str) else None


def _described(cls: type) -> str:
    """``module.Class (file:line)`` for a message naming a class."""
    import inspect

    where = ""
    try:
        file = inspect.getsourcefile(cls)
        line = inspect.getsourcelines(cls)[1]
        where = f" ({file}:{line})" if file else ""
    except (OSError, TypeError):
        pass
    return f"{cls.__module__}.{cls.__qualname__}{where}"


# -- plugins -----------------------------------------------------------------------------------------
class PluginError(RegistrationError):
    """A plugin that failed while importing or registering; ``file``/``line`` say where (when known)."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.file = file
        self.line = line

    def located(self) -> str:
        """One line: ``FILE:LINE: error: MESSAGE`` (or ``fsmctl: error: MESSAGE`` without a place)."""
        where = f"{self.file}:{self.line}" if self.file and self.line else self.file
        return f"{where}: error: {self}" if where else f"fsmctl: error: {self}"


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _plugin_error(plugin: str, exc: BaseException, origin: str | None) -> PluginError:
    """Where ``exc`` happened: for a syntax error its own place, else the innermost frame in the plugin's
    file (``origin``), else the innermost frame outside tral-fsm, else the innermost one."""
    if isinstance(exc, SyntaxError) and exc.filename:
        return PluginError(f"plugin {plugin}: SyntaxError: {_one_line(exc.msg)}", exc.filename, exc.lineno)
    frames = traceback.extract_tb(exc.__traceback__)
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    chosen = None
    if origin is not None:
        chosen = next((f for f in reversed(frames) if os.path.abspath(f.filename) == origin), None)
    if chosen is None:
        chosen = next((f for f in reversed(frames) if not os.path.abspath(f.filename).startswith(here)
                       and "importlib" not in f.filename), None)
    if chosen is None and frames:
        chosen = frames[-1]
    kind = "registration failed" if isinstance(exc, RegistrationError) else f"{type(exc).__name__}"
    return PluginError(f"plugin {plugin}: {kind}: {_one_line(str(exc))}",
                       chosen.filename if chosen else origin, chosen.lineno if chosen else None)


def _import_plugin(plugin: str) -> None:
    """Import a ``--plugin`` module name or ``.py`` file (see :meth:`Registry.load_module`)."""
    if plugin.endswith(".py") or os.sep in plugin or "/" in plugin:
        path = os.path.abspath(plugin)
        if not os.path.isfile(path):
            raise UsageError(f"--plugin {plugin}: no such file" + (" (a folder)" if os.path.isdir(path) else "")
                             + "; give a .py file or a module name")
        stem = "".join(c if c.isalnum() or c == "_" else "_" for c in os.path.splitext(os.path.basename(path))[0])
        name = f"fsm_plugin_{stem}"
        if sys.modules.get(name) is not None and getattr(sys.modules[name], "__file__", None) == path:
            return
        try:
            spec = importlib.util.spec_from_file_location(name, path)
        except (ValueError, OSError) as exc:
            raise UsageError(f"--plugin {plugin}: cannot load it: {exc}") from None
        if spec is None or spec.loader is None:
            raise UsageError(f"--plugin {plugin}: not a Python file")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except (Exception, SystemExit) as exc:
            del sys.modules[name]
            raise _plugin_error(plugin, exc, path) from None
        return
    if not all(part.isidentifier() for part in plugin.split(".")):
        raise UsageError(f"--plugin {plugin!r}: not a module name or a .py file")
    cwd = os.getcwd()
    if cwd not in sys.path and "" not in sys.path:
        sys.path.append(cwd)  # as `python -m` does; after the installed packages, so it shadows none
    importlib.invalidate_caches()
    try:
        found = importlib.util.find_spec(plugin)
    except (ImportError, ValueError):
        found = None
    except Exception as exc:  # a parent package that fails to import
        raise _plugin_error(plugin, exc, None) from None
    if found is None:
        raise UsageError(f"--plugin {plugin}: no module named {plugin!r} (looked in the current folder and the "
                         "installed packages); give a module name or the path of a .py file")
    origin = os.path.abspath(found.origin) if found.origin and os.path.exists(found.origin) else None
    try:
        importlib.import_module(plugin)
    except (Exception, SystemExit) as exc:
        raise _plugin_error(plugin, exc, origin) from None


# -- the process-wide registry and its decorators ---------------------------------------------------
_current: list[Registry] = [Registry()]
_builtins_loaded = False
#: Every registration a decorator made in this process: (kind, name, class).
_DECLARED: list[tuple[str, str, type]] = []


def builtin_types() -> list[tuple[str, str, type]]:
    """``(kind, name, class)`` of the built-in types: those tral-fsm's own modules register."""
    importlib.import_module("fsm.states")
    importlib.import_module("fsm.transitions")
    return [(kind, name, cls) for kind, name, cls in _DECLARED if cls.__module__.startswith("fsm.")]


def _declare(kind: str, name: str | None, cls: type) -> None:
    _DECLARED.append((kind, name or cls.__name__, cls))


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
        _declare("state", name, c)
        return c

    return deco(cls) if cls is not None else deco


def register_transition(cls: T | None = None, *, name: str | None = None) -> Any:
    """Class decorator: register a Transition subclass under its class name (or ``name``)."""

    def deco(c: T) -> T:
        current().add_transition(c, name)
        _declare("transition", name, c)
        return c

    return deco(cls) if cls is not None else deco


def register_condition(cls: C | None = None, *, name: str | None = None) -> Any:
    """Class decorator: register a Condition subclass under its class name (or ``name``)."""

    def deco(c: C) -> C:
        current().add_condition(c, name)
        _declare("condition", name, c)
        return c

    return deco(cls) if cls is not None else deco


#: Set to 1 to load no installed plugins (entry points): the built-in types and ``--plugin`` modules only (the
#: project's own tests set it, so that a plugin installed next to tral-fsm cannot change what they check).
NO_ENTRY_POINTS = "FSM_NO_ENTRY_POINTS"


def default_registry(plugins: list[str] | tuple[str, ...] = (), entry_points: bool = True) -> Registry:
    """The process registry with the built-in types, installed plugins (unless ``FSM_NO_ENTRY_POINTS=1``) and
    the ``plugins`` modules loaded."""
    global _builtins_loaded
    entry_points = entry_points and os.environ.get(NO_ENTRY_POINTS, "") in ("", "0")
    registry = _current[0]
    if not _builtins_loaded:
        _builtins_loaded = True
        with using(registry):
            importlib.import_module("fsm.states")
            importlib.import_module("fsm.transitions")
    if entry_points and not _entry_points_loaded:
        _load_entry_points(registry)
    for module in plugins:
        registry.load_module(module)
    return registry


_entry_points_loaded = False


def _load_entry_points(registry: Registry) -> None:
    global _entry_points_loaded
    _entry_points_loaded = True
    registry.load_entry_points()


def register_plant(cls: Any = None, *, name: str | None = None) -> Any:
    """Class decorator: register a Plant subclass (``fsm.runtime.plant``) under its class name (or ``name``)."""

    def deco(c: Any) -> Any:
        current().add_plant(c, name)
        _declare("plant", name, c)
        return c

    return deco(cls) if cls is not None else deco


def builder(kind: str) -> Callable[..., Any]:
    """``register_state``, ``register_transition`` or ``register_condition`` by kind name."""
    return {"state": register_state, "condition": register_condition}.get(kind, register_transition)
