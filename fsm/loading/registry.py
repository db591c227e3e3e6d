"""Registry: type name -> class, for states and transitions; built-ins, entry-point plugins, ``--plugin`` modules.

A document names only registered types, never a Python module. Registration validates the class (a
``Params`` model of the right base, a unique name), like BehaviorTree.CPP's factory refuses duplicates.
"""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import inspect
import os
import sys
import traceback
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from fsm.model.errors import RegistrationError, UsageError
from fsm.model.params import ConditionParams, StateParams, TransitionParams
from fsm.runtime.condition import Condition
from fsm.runtime.namespace import check_namespace
from fsm.runtime.state import State
from fsm.runtime.transition import Transition

if TYPE_CHECKING:
    from _collections_abc import dict_items, dict_keys, dict_values

S = TypeVar("S", bound=type[State[Any]])
T = TypeVar("T", bound=type[Transition[Any]])
C = TypeVar("C", bound=type[Condition[Any]])
#: A registered class, of any kind.
K = TypeVar("K", bound=type)

STATE_GROUP = "fsm.states"
TRANSITION_GROUP = "fsm.transitions"
CONDITION_GROUP = "fsm.conditions"
PLANT_GROUP = "fsm.plants"

#: The built-in types by the module whose decorators register them: ``module -> {kind: names}``. A registry with the
#: built-ins knows these names at once and imports a module when one of its names is first looked up, so a document
#: pays only for the types it uses (the car's states, the marker transitions and their imports stay unloaded for a
#: ring of Idle states). ``tests/test_load_lazy.py`` checks it against what the modules really register.
BUILTIN_MODULES: dict[str, dict[str, tuple[str, ...]]] = {
    "fsm.states.generic": {"state": ("Idle", "Final")},
    "fsm.states.composites": {"state": ("FSMState", "Parallel")},
    "fsm.states.sequence": {"state": ("Sequence", "Step", "Wait", "SetVar", "ResetTimeout", "Join", "Call")},
    "fsm.states.driving": {"state": ("BasicFollowWall", "FollowWall", "FollowWallRamp", "ApproachPoint", "Motor",
                                     "Stop")},
    "fsm.states.gate_driving": {"state": ("ArucoGateApproach", "ArucoGateCenter", "AlignHeading")},
    "fsm.states.plants": {"plant": ("Integrator", "Queue", "Button", "TimerSensor")},
    "fsm.transitions.generic": {"transition": ("Always", "Finished", "Timeout")},
    "fsm.transitions.inputs": {"transition": ("Signal", "Var", "InState")},
    "fsm.transitions.car": {"transition": ("Distance", "SensorLevel", "PassPoint"),
                            "condition": ("Sensor", "Travelled")},
    "fsm.transitions.conditions": {"transition": ("Condition",),
                                   "condition": ("SignalHigh", "SignalLow", "SignalEdge", "Expr", "TimeSince",
                                                 "InState", "Outcome", "All", "Any", "Not")},
    "fsm.transitions.markers": {"transition": ("ArucoGateFound", "ArucoMarkerFound", "ArucoMarkerUnpaired")},
    "fsm.transitions.topics": {"condition": ("TopicQuiet",)},
}

V = TypeVar("V")


class TypeTable(dict[str, V], Generic[V]):
    """One name space of a :class:`Registry`: the registered classes by name, a ``dict`` to its users.

    Besides the classes registered, it may hold names whose class is not imported yet (a built-in type's module, see
    :data:`BUILTIN_MODULES`), and the registry may have installed plugins still to load: looking a name up imports
    what it needs (its module; the plugins when no built-in has that name), and listing the table (iterating, its
    length, comparing, copying) loads everything first, so every reader sees the full table."""

    __slots__ = ("_owner", "pending")

    def __init__(self, owner: Registry) -> None:
        super().__init__()
        self._owner = owner
        #: Names known but not imported yet: name -> the module that registers it.
        self.pending: dict[str, str] = {}

    # -- one name: what it needs, no more
    def get(self, name: str, default: Any = None) -> Any:
        found = dict.get(self, name)
        if found is None and self._owner.fill(self, name):
            found = dict.get(self, name)
        return default if found is None else found

    def __missing__(self, name: str) -> V:
        if self._owner.fill(self, name):
            return dict.__getitem__(self, name)
        raise KeyError(name)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and self.get(name) is not None

    def __setitem__(self, name: str, cls: V) -> None:
        self.pending.pop(name, None)
        dict.__setitem__(self, name, cls)

    def __delitem__(self, name: str) -> None:
        self.get(name)
        dict.__delitem__(self, name)

    def pop(self, name: str, *default: Any) -> Any:
        self.get(name)
        return dict.pop(self, name, *default)

    # -- the whole table: everything loaded first
    def complete(self) -> TypeTable[V]:
        """This table with every pending name imported and the registry's plugins loaded."""
        self._owner.complete()
        return self

    def __iter__(self) -> Iterator[str]:
        return dict.__iter__(self.complete())

    def __len__(self) -> int:
        return dict.__len__(self.complete())

    def keys(self) -> dict_keys[str, V]:
        return dict.keys(self.complete())

    def values(self) -> dict_values[str, V]:
        return dict.values(self.complete())

    def items(self) -> dict_items[str, V]:
        return dict.items(self.complete())

    def copy(self) -> dict[str, V]:
        return dict(dict.items(self.complete()))

    def __eq__(self, other: object) -> bool:
        if isinstance(other, TypeTable):
            other.complete()
        return dict.__eq__(self.complete(), other)

    def __ne__(self, other: object) -> bool:
        return not self == other

    __hash__ = None

    def __repr__(self) -> str:
        return dict.__repr__(self.complete())

    def __reduce__(self) -> Any:
        return (dict, (dict(self.items()),))


def lazy_exports(package: str, names: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for a type library's package (``fsm.states``) that offers its modules' classes
    by name, each module imported when one of its names is first asked for (PEP 562): ``names`` maps a class's name
    to its module in the package."""

    def get(name: str) -> Any:
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{names[name]}"), name)
        setattr(sys.modules[package], name, value)  # asked once: later look-ups find it without this function
        return value

    def listing() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return get, listing

class Registry:
    """Name spaces of types: states, transitions, conditions and plants; a name may not be registered twice in one.

    A registry is a value: ``Registry()`` is empty, :meth:`with_builtins` a fresh one with the built-in types, and
    :func:`default_registry` the process's (built-ins, installed plugins, ``--plugin`` modules). Registering
    changes the registry only, never the class: one class may be registered under different names in different
    registries, and an element knows its type's name from its document (``params.type``).
    """

    def __init__(self) -> None:
        self.states: TypeTable[type[State[Any]]] = TypeTable(self)
        self.transitions: TypeTable[type[Transition[Any]]] = TypeTable(self)
        self.conditions: TypeTable[type[Condition[Any]]] = TypeTable(self)
        self.plants: TypeTable[type[Any]] = TypeTable(self)
        self._loaded_plugins: set[str] = set()
        #: (kind, name) -> the installed distribution whose entry point registered the type
        self.installed_by: dict[tuple[str, str], str] = {}
        #: Whether the installed plugins (entry points) are still to be loaded, on the first name no table knows.
        self._entry_points_due = False

    def _tables(self) -> dict[str, TypeTable[Any]]:
        return {"state": self.states, "transition": self.transitions, "condition": self.conditions,
                "plant": self.plants}

    # -- what is loaded when ----------------------------------------------------------------------
    def add_builtins(self) -> None:
        """Know the built-in types (:data:`BUILTIN_MODULES`) by name; each module is imported when one of its names
        is first looked up. A name registered already keeps its class."""
        tables = self._tables()
        for module, kinds in BUILTIN_MODULES.items():
            for kind, names in kinds.items():
                table = tables[kind]
                for name in names:
                    if not dict.__contains__(table, name):
                        table.pending[name] = module

    def defer_entry_points(self) -> None:
        """Load the installed plugins (:meth:`load_entry_points`) only when needed: at the first name no table
        knows, or when a table is listed. A document of built-in types then imports no plugin."""
        self._entry_points_due = True

    def fill(self, table: TypeTable[Any], name: str) -> bool:
        """Load what ``name`` needs in ``table``: its built-in module, else the deferred plugins; whether it is
        there now."""
        module = table.pending.get(name)
        if module is not None:
            self._import_builtin(module)
        else:
            self.load_due_plugins()
        return dict.__contains__(table, name)

    def plugins_due(self) -> bool:
        """Whether the installed plugins are still to be loaded (on the first name no table knows)."""
        return self._entry_points_due

    def load_due_plugins(self) -> None:
        """Load the installed plugins now if they are still to be loaded."""
        if self._entry_points_due:
            self._entry_points_due = False
            self.load_entry_points()

    def complete(self) -> None:
        """Every pending built-in module imported and the deferred plugins loaded (a table is listed)."""
        for table in self._tables().values():
            while table.pending:
                self._import_builtin(next(iter(table.pending.values())))
        self.load_due_plugins()

    def _import_builtin(self, module: str) -> None:
        """Import a built-in module into this registry: its decorators register here, and when it was imported
        before (for another registry) the classes it declared then are added."""
        tables = self._tables()
        names = [(kind, name) for kind, table in tables.items() for name, mod in table.pending.items() if mod == module]
        for kind, name in names:
            del tables[kind].pending[name]
        if module not in sys.modules:
            with using(self):
                importlib.import_module(module)
        for kind, name, cls, by in _DECLARED:
            if by == module and (kind, name) in names and not dict.__contains__(tables[kind], name):
                dict.__setitem__(tables[kind], name, cls)

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
        check_namespace(cls, name)  # a hook, setting or base name shadowed: refused here, not at tick 1
        pending = table.pending.get(name) if isinstance(table, TypeTable) else None
        if pending is not None:  # a built-in of that name: its class first, then the check below sees a clash
            self._import_builtin(pending)
        if self._check_free(table, name, cls, kind):
            dict.__setitem__(table, name, cls)
        return cls

    @classmethod
    def with_builtins(cls) -> Registry:
        """A fresh registry holding the built-in state, transition and condition types (no plugins); each type's
        module is imported when the type is first looked up."""
        registry = cls()
        registry.add_builtins()
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
        other = dict.get(table, name)
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
        self.load_due_plugins()  # the installed plugins first: a --plugin type clashing with one is the error
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
                before = self._registered()
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
                for added in self._registered() - before:
                    self.installed_by[added] = dist

    def _registered(self) -> set[tuple[str, str]]:
        """``(kind, name)`` of the types registered so far (imported, not pending)."""
        return {(kind, name) for kind, table in self._tables().items() for name in dict.keys(table)}

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


#: True while the Python API (``plugins=`` of ``fsm.load``, ``fsm.check``, ``fsm.run``) loads plugins: the messages
#: of a plugin that cannot be found then name it ``plugins=['X']``, not the command line's ``--plugin X``.
PLUGINS_FROM_PYTHON: ContextVar[bool] = ContextVar("PLUGINS_FROM_PYTHON", default=False)


def _named(plugin: str, quoted: bool = False) -> str:
    if PLUGINS_FROM_PYTHON.get():
        return f"plugins=[{plugin!r}]"
    return f"--plugin {plugin!r}" if quoted else f"--plugin {plugin}"


def _import_plugin(plugin: str) -> None:
    """Import a ``--plugin`` module name or ``.py`` file (see :meth:`Registry.load_module`)."""
    if plugin.endswith(".py") or os.sep in plugin or "/" in plugin:
        path = os.path.abspath(plugin)
        if not os.path.isfile(path):
            raise UsageError(f"{_named(plugin)}: no such file" + (" (a folder)" if os.path.isdir(path) else "")
                             + "; give a .py file or a module name")
        stem = "".join(c if c.isalnum() or c == "_" else "_" for c in os.path.splitext(os.path.basename(path))[0])
        name = f"fsm_plugin_{stem}"
        if sys.modules.get(name) is not None and getattr(sys.modules[name], "__file__", None) == path:
            return
        try:
            spec = importlib.util.spec_from_file_location(name, path)
        except (ValueError, OSError) as exc:
            raise UsageError(f"{_named(plugin)}: cannot load it: {exc}") from None
        if spec is None or spec.loader is None:
            raise UsageError(f"{_named(plugin)}: not a Python file")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except (Exception, SystemExit) as exc:
            del sys.modules[name]
            raise _plugin_error(plugin, exc, path) from None
        return
    if not all(part.isidentifier() for part in plugin.split(".")):
        raise UsageError(f"{_named(plugin, quoted=True)}: not a module name or a .py file")
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
        raise UsageError(f"{_named(plugin)}: no module named {plugin!r} (looked in the current folder and the "
                         "installed packages); give a module name or the path of a .py file")
    origin = os.path.abspath(found.origin) if found.origin and os.path.exists(found.origin) else None
    try:
        importlib.import_module(plugin)
    except (Exception, SystemExit) as exc:
        raise _plugin_error(plugin, exc, origin) from None


# -- the process-wide registry and its decorators ---------------------------------------------------
_current: list[Registry] = [Registry()]
_builtins_loaded = False
#: Every registration a decorator made in this process: (kind, name, class, the module whose code registered it).
_DECLARED: list[tuple[str, str, type, str]] = []


def builtin_types() -> list[tuple[str, str, type]]:
    """``(kind, name, class)`` of the built-in types: those tral-fsm's own modules register (all imported)."""
    for module in BUILTIN_MODULES:
        importlib.import_module(module)
    return [(kind, name, cls) for kind, name, cls, by in _DECLARED if by in BUILTIN_MODULES]


def _declare(kind: str, name: str | None, cls: type) -> None:
    _DECLARED.append((kind, name or cls.__name__, cls, _registering_module()))


def _registering_module() -> str:
    """The module whose code called the decorator (the first frame outside this module)."""
    frame = inspect.currentframe()
    while frame is not None and frame.f_globals.get("__name__") == __name__:
        frame = frame.f_back
    return str(frame.f_globals.get("__name__", "")) if frame is not None else ""


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
        registry.add_builtins()
    if entry_points and not _entry_points_loaded:
        _load_entry_points(registry)
    for module in plugins:
        registry.load_module(module)
    return registry


_entry_points_loaded = False


def _load_entry_points(registry: Registry) -> None:
    """The installed plugins, loaded when a document names a type no built-in has or the types are listed."""
    global _entry_points_loaded
    _entry_points_loaded = True
    registry.defer_entry_points()


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
