"""What the plugin bases put in a plugin author's ``self.``, and the check that a registered class keeps it.

Each base (:class:`~fsm.runtime.state.State`, :class:`~fsm.runtime.transition.Transition`,
:class:`~fsm.runtime.condition.Condition`) takes a few names; every other name is the author's. The taken names are
of three kinds (docs/extending.md lists them):

- *hooks*: methods the runtime calls, which a subclass overrides with a method of its own (``tick``, ``holds``);
- *settings*: class attributes a subclass sets in its class body (``can_finish = True``, ``Params``);
- *the base's own*: what the runtime reads or keeps (``params``, ``finish``, ``active``, ``type_name``), which a
  subclass never defines.

Registering a class that shadows one (a hook or one of the base's own with a plain class attribute, one of the
base's own with anything, or a hook, setting or method of the base's by ``self.NAME = ...`` in its code) is a
:class:`~fsm.model.errors.RegistrationError` naming the class and the name: at registration, not at tick 1. The
runtime's wiring (a state's level, transitions, supervisor, clock; a transition's place) is kept in one record in
one slot, ``_fsm`` (:mod:`fsm.runtime.region`), so it takes no name of the author's.
"""

from __future__ import annotations

import ast
import inspect
import linecache
from typing import NamedTuple

from fsm.model.errors import RegistrationError
from fsm.runtime.condition import Condition
from fsm.runtime.context import shown_value
from fsm.runtime.state import State
from fsm.runtime.transition import Transition


class Taken(NamedTuple):
    """The names one base takes in its subclasses' namespace."""

    #: methods the runtime calls: a subclass overrides them with methods
    hooks: frozenset[str]
    #: class attributes a subclass sets in its class body (never on ``self``)
    settings: frozenset[str]
    #: the base's own attributes, properties and methods: a subclass reads or calls them, never defines them
    own: frozenset[str]
    #: deprecated names, read for one release with a ``DeprecationWarning``: a subclass may take them for its own
    deprecated: frozenset[str]


def _names(text: str) -> frozenset[str]:
    return frozenset(text.split())


#: What each base takes, by base.
TAKEN: dict[type, Taken] = {
    State: Taken(
        hooks=_names("on_enter tick on_exit on_pause on_resume bind possible_outcomes"),
        settings=_names("Params can_finish outcomes is_final is_composite needs_car signal_refs assignment_fields "
                        "condition_fields params_argument"),
        own=_names("id path params finished outcome predicates finish time_in_state active paused type_name"),
        deprecated=_names("checks region regions transitions supervisor tick_method binds_references"),
    ),
    Transition: Taken(
        hooks=_names("holds on_source_enter action bind check_document variable_test describe"),
        settings=_names("Params unconditional needs_finishing_source needs_car state_refs signal_refs "
                        "condition_fields params_argument"),
        own=_names("params source target conditions type_name"),
        deprecated=_names("check index binds_references checks_document tests_variables"),
    ),
    Condition: Taken(
        hooks=_names("holds reset bind"),
        settings=_names("Params condition_fields expr_fields state_refs signal_refs params_argument"),
        own=_names("params owner children exprs type_name"),
        deprecated=frozenset(),
    ),
}


def taken_by(cls: type) -> tuple[type, Taken] | None:
    """The plugin base ``cls`` derives from and what it takes, or None for another class."""
    for base, taken in TAKEN.items():
        if issubclass(cls, base):
            return base, taken
    return None


def check_namespace(cls: type, name: str, *, read_source: bool | None = None) -> None:
    """Raise :class:`RegistrationError` naming ``cls`` (registered as ``name``) and the name when the class, or a
    base of it between it and tral-fsm's classes, shadows a name its plugin base takes. ``read_source`` (default: for
    classes outside tral-fsm) also reads the classes' code for ``self.NAME = ...`` of a taken name."""
    found = taken_by(cls)
    if found is None:
        return
    base, taken = found
    assignable = frozenset(getattr(base, "__slots__", ()))
    problems: list[str] = []
    for klass in cls.__mro__:
        if klass is base:
            break
        module = getattr(klass, "__module__", "") or ""
        if read_source is None and (module == "fsm" or module.startswith("fsm.")):
            break  # tral-fsm's own classes (the built-in types) are checked by its tests
        problems += _in_class_body(klass, taken)
        if read_source is not False:
            problems += _in_code(klass, taken, assignable)
    if problems:  # every one at once, as a document's problems are
        raise RegistrationError(f"{cls.__module__}.{cls.__qualname__} (type {name!r}): " + "; and ".join(problems))


def _in_class_body(klass: type, taken: Taken) -> list[str]:
    found = []
    for attr, value in vars(klass).items():
        if attr in taken.own:
            found.append(f"{klass.__name__}.{attr} shadows the base's {attr!r}, which the runtime reads or keeps; "
                         f"choose another name")
        elif attr in taken.hooks and not _is_method(value):
            found.append(f"{klass.__name__}.{attr} = {shown_value(value)} shadows the hook {attr}() with a plain "
                         f"attribute; define it as a method, or choose another name")
    return found


def _is_method(value: object) -> bool:
    return callable(value) or isinstance(value, (classmethod, staticmethod, property))


def _in_code(klass: type, taken: Taken, assignable: frozenset[str]) -> list[str]:
    """``self.NAME = ...`` (or ``+=``, or annotated) of a taken name in the class's own methods, with its line; the
    base's slots (``params``, ``finished``, ``outcome``, ...) may be assigned."""
    node, file = _class_node(klass)
    if node is None:
        return []
    found: set[tuple[int, str]] = set()
    forbidden = taken.hooks | taken.settings | (taken.own - assignable)
    for item in ast.walk(node):
        targets: list[ast.expr] = []
        if isinstance(item, ast.Assign):
            targets = item.targets
        elif isinstance(item, (ast.AugAssign, ast.AnnAssign)):
            targets = [item.target]
        for target in targets:
            for sub in ast.walk(target):
                if (isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name) and sub.value.id == "self"
                        and sub.attr in forbidden):
                    kind = ("the hook" if sub.attr in taken.hooks else "the setting" if sub.attr in taken.settings
                            else "the base's")
                    fix = ("set it in the class body" if sub.attr in taken.settings else "choose another name")
                    found.add((sub.lineno, f"self.{sub.attr} = ... ({file}:{sub.lineno}) shadows {kind} "
                                           f"{sub.attr!r}; {fix}"))
    return [text for _line, text in sorted(found)]  # in the order of the file


def _class_node(klass: type) -> tuple[ast.ClassDef | None, str]:
    """The class statement of ``klass`` in its module's source (None when the source cannot be read: a class made
    in the interpreter or by ``type()``)."""
    try:
        file = inspect.getsourcefile(klass)
    except TypeError:
        return None, ""
    if not file:
        return None, ""
    linecache.checkcache(file)  # a plugin edited since it was first read (a live run's reload): its text now
    lines = linecache.getlines(file)
    if not lines:
        return None, file
    tree = _parsed(file, "".join(lines))
    if tree is None:
        return None, file
    named = [n for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and n.name == klass.__name__]
    if len(named) > 1:  # several classes of that name (in functions): the one that holds the class's methods
        lines_of = {v.__code__.co_firstlineno for v in vars(klass).values() if hasattr(v, "__code__")}
        named = [n for n in named if any(n.lineno <= line <= (n.end_lineno or n.lineno) for line in lines_of)]
    return (named[0] if len(named) == 1 else None), file


#: Per source file, the hash of the text last parsed and its tree (None: it does not parse): a file's classes are
#: checked one after the other, and a hot-reloaded plugin replaces its file's entry instead of adding one.
_TREES: dict[str, tuple[int, ast.Module | None]] = {}


def _parsed(file: str, text: str) -> ast.Module | None:
    digest = hash(text)
    kept = _TREES.get(file)
    if kept is not None and kept[0] == digest:
        return kept[1]
    try:
        tree: ast.Module | None = ast.parse(text, file)
    except (SyntaxError, ValueError):
        tree = None
    _TREES[file] = (digest, tree)
    return tree


__all__ = ["TAKEN", "Taken", "check_namespace", "taken_by"]
