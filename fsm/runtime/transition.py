"""Transition: the base class of every transition type: a condition checked on its source state each tick."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

from fsm.model.params import TransitionParams, adopt_generic_params
from fsm.runtime.deprecation import Renamed, warn_deprecated

if TYPE_CHECKING:
    from fsm.runtime.condition import Condition
    from fsm.runtime.context import Context
    from fsm.runtime.state import State

P = TypeVar("P", bound=TransitionParams)
#: The conditions of a transition that has none (shared; ``apply_conditions`` makes a transition its own).
_NO_CONDITIONS: dict[str, Any] = {}


class Link:
    """The part of a transition's wiring record this module knows: the transition and its place among its source's
    transitions (document order). A transition is made with the full record, a
    :class:`fsm.runtime.region.TransitionWiring`, once the runtime's region module is imported (:func:`use_link`)."""

    __slots__ = ("transition", "index")

    def __init__(self, transition: Transition[Any], index: int) -> None:
        self.transition = transition
        self.index = index


#: The class of the record a transition is made with (see :class:`Link`).
_link: type[Link] = Link


def _link_of(transition: Transition[Any]) -> Link:
    return transition._fsm


def fired_index(fired: object) -> int:
    """The place among its source's transitions of what a listener saw fire (``Listener.on_transition``): a
    transition's (the trace's ``#index``), -1 for anything else (a monitor's restart)."""
    return fired._fsm.index if isinstance(fired, Transition) else -1


def transition_binds_references(transition: Transition[Any]) -> bool:
    """Whether the class of ``transition`` overrides ``bind`` (the builder calls it only then)."""
    return type(transition)._binds_references


def checks_document(cls: type[Transition[Any]]) -> bool:
    """Whether the transition type has a load-time check of its own (``check_document``)."""
    return cls._checks_document


def tests_variables(cls: type[Transition[Any]]) -> bool:
    """Whether the transition type compares a variable with a literal (``variable_test``)."""
    return cls._tests_variables


def use_link(link: type[Link]) -> None:
    """Make transitions with ``link`` from now on (the runtime's region module gives its full record when imported)."""
    global _link
    _link = link


class Transition(Generic[P]):
    """A transition from ``source`` to ``target``. Subclass it, declare ``Params``, override ``holds``.

    ``holds(ctx)`` is called each tick while the source is active (after the source's tick, or before
    it for ``preempt: true``); the first transition whose check is true fires. ``on_source_enter`` is
    called whenever the source is entered (to take a reference value, e.g. the travelled distance).
    ``action`` runs while firing, between the source's exit and the target's entry.

    A document may add a ``guard`` (an expression or a condition, asked before ``holds``: both must hold)
    and a ``set`` (assignments run after ``action``); the build stage applies them to the transition's wiring
    record (:class:`fsm.runtime.region.TransitionWiring`), which says how the region decides and fires it.
    What an instance holds of the base: ``params``, ``source``, ``target``, ``conditions`` and that record
    (``_fsm``: its place, ``transition_wiring(t).index``, is there). The names the base takes are listed in
    :data:`fsm.runtime.namespace.TAKEN`; a class that shadows one is refused when registered. Every other name is the
    subclass's.
    """

    __slots__ = ("params", "source", "target", "conditions", "_fsm")

    #: The parameters' model: the generic argument (``class Near(Transition[NearParams])``) unless declared.
    Params: ClassVar[type[TransitionParams]] = TransitionParams
    #: The generic argument the class (or its nearest base that names one) gives; ``Params`` must agree with it.
    params_argument: ClassVar[type[TransitionParams] | None] = None
    #: True for transitions that fire whenever asked (``Always``); the runtime then skips ``holds``.
    unconditional: ClassVar[bool] = False
    #: True when the transition fires only on a finished source (the loader checks that it can finish).
    needs_finishing_source: ClassVar[bool] = False
    #: Transitions that read the plant (``ctx.car``); a machine with one cannot be built without a car.
    needs_car: ClassVar[bool] = False
    #: Names of parameters that hold state paths; the loader checks that they name existing states.
    state_refs: ClassVar[tuple[str, ...]] = ()
    #: Names of parameters that hold input signal names (collected for ``fsmctl run --signal`` and ``inputs``).
    signal_refs: ClassVar[tuple[str, ...]] = ()
    #: Names of parameters that hold condition objects; built instances are in ``self.conditions``.
    condition_fields: ClassVar[tuple[str, ...]] = ()
    # Which hooks a class overrides, found once per class (``__init_subclass__``) rather than per transition built.
    _overrides_action: ClassVar[bool] = False
    _overrides_source_enter: ClassVar[bool] = False
    #: Whether the class overrides ``bind`` (the builder calls it only then).
    _binds_references: ClassVar[bool] = False
    #: Whether the type has its own load-time checks (``check_document``, ``variable_test``): the checks call them
    #: only where it does.
    _checks_document: ClassVar[bool] = False
    _tests_variables: ClassVar[bool] = False
    #: Whether the class's ``holds`` is a ``check`` written under the old name (see :meth:`check`).
    _holds_is_check: ClassVar[bool] = False

    if not TYPE_CHECKING:  # hidden from type checkers: a plugin's own attribute of one of these names type-checks
        #: Deprecated names, read for one release with a ``DeprecationWarning``: the runtime's, not the author's.
        index = Renamed("index", "index", record=_link_of, where="fsm.runtime.region.transition_wiring(transition)")
        binds_references = Renamed("binds_references", "_binds_references", on_class=True,
                                   read="fsm.runtime.transition.transition_binds_references(transition)")
        checks_document = Renamed("checks_document", "_checks_document", on_class=True,
                                  read="fsm.runtime.transition.checks_document(type(transition))")
        tests_variables = Renamed("tests_variables", "_tests_variables", on_class=True,
                                  read="fsm.runtime.transition.tests_variables(type(transition))")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        _adopt_old_check(cls)
        adopt_generic_params(cls, TransitionParams)
        cls._overrides_action = cls.action is not Transition.action
        cls._overrides_source_enter = cls.on_source_enter is not Transition.on_source_enter
        cls._binds_references = cls.bind is not Transition.bind
        cls._checks_document = cls.check_document.__func__ is not Transition.check_document.__func__  # type: ignore[attr-defined]
        cls._tests_variables = cls.variable_test.__func__ is not Transition.variable_test.__func__  # type: ignore[attr-defined]

    def __init__(self, params: P, source: State[Any], target: State[Any], index: int = 0) -> None:
        self.params = params
        self.source = source
        self.target = target
        #: Condition objects by parameter name (a condition guard is ``"guard"``), bound when the machine is built.
        self.conditions: dict[str, Condition[Any]] = _NO_CONDITIONS
        #: The runtime's record of this transition: its place among its source's transitions here, and how the
        #: region decides and fires it once the machine is built (a :class:`fsm.runtime.region.TransitionWiring`).
        self._fsm: Link = _link(self, index)

    @property
    def type_name(self) -> str:
        """The registered type name this transition was built as (its document's ``type``)."""
        return self.params.type

    # -- hooks for subclasses ---------------------------------------------------------------------------
    @classmethod
    def check_document(cls, params: P, variables: dict[str, Any]) -> tuple[str, str] | None:
        """A load-time check against the document's initial ``vars``: ``(pointer suffix, message)`` or ``None``."""
        return None

    @classmethod
    def variable_test(cls, params: P) -> tuple[str, str, Any] | None:
        """``(variable, operator, value)`` when this transition compares a blackboard variable with a literal
        (``Var``): the loader checks that every comparison of a variable uses one kind of value."""
        return None

    def holds(self, ctx: Context) -> bool:
        """True when the transition should fire now (asked each tick while the source is active)."""
        return False

    def check(self, ctx: Context) -> bool:
        """Deprecated: the old name of :meth:`holds` (``check`` now means only the document check), removed in the
        next release. A class that still defines ``check`` works: it is its ``holds``, with a ``DeprecationWarning``
        when the class is defined, before it is registered (docs/extending.md)."""
        warn_deprecated(f"{type(self).__qualname__}.check(ctx) is deprecated: call holds(ctx)")
        if type(self)._holds_is_check:  # reached by super().check(ctx) from an old-style check: the base's answer
            return False
        return self.holds(ctx)

    def on_source_enter(self, ctx: Context) -> None:
        """Called each time the source state is entered."""

    def action(self, ctx: Context) -> None:
        """Called while firing, after the source's exit and before the target's entry."""

    def bind(self, machine: Any) -> None:
        """Called once when the machine is built, to resolve references to other states (``InState``); ``machine``
        is the :class:`fsm.Machine`, annotated ``Machine`` or ``MachineView`` in an override (see ``State.bind``)."""

    def describe(self) -> str:
        """One line for traces and messages."""
        return f"{self.type_name} {self.source.id} -> {self.target.id}"

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.source.path!r} -> {self.target.path!r}>"


def _adopt_old_check(cls: type[Transition[Any]]) -> None:
    """A class that defines ``check`` (the old name of ``holds``) and no ``holds`` of its own: its ``check`` becomes
    its ``holds``, with a ``DeprecationWarning`` naming the new name (once, where the class is defined)."""
    old = cls.__dict__.get("check")
    if old is None or "holds" in cls.__dict__:
        cls._holds_is_check = cls._holds_is_check and "holds" not in cls.__dict__
        return
    warn_deprecated(f"{cls.__module__}.{cls.__qualname__}: Transition.check(ctx) is renamed holds(ctx); rename the "
                    "method (check is the old name, accepted until the next release)", stacklevel=3)
    type.__setattr__(cls, "holds", old)  # the old name serves as the new (mypy refuses assigning a method)
    cls._holds_is_check = True
