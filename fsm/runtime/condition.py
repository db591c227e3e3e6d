"""Condition: a registered predicate with its own parameters (a guard, a monitor's or a step's condition).

A condition belongs to an *owner* state (the source of the transition that uses it): ``reset(ctx)`` is
called each time the owner is entered, ``holds(ctx)`` when the transition is checked. State is kept per
instance, so two transitions using the same kind of condition never share a debounce filter or a timer.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

from fsm.model.params import ConditionParams, adopt_generic_params

if TYPE_CHECKING:
    from fsm.model.expr import Compiled
    from fsm.runtime.context import Context
    from fsm.runtime.state import State

P = TypeVar("P", bound=ConditionParams)


class Condition(Generic[P]):
    """Subclass it, declare ``Params`` (a :class:`fsm.model.params.ConditionParams`), override ``holds`` (and
    ``reset`` when it keeps state), and register it with :func:`fsm.register_condition`.

    ``Condition`` is generic over its parameters, as states are: ``class Hot(Condition[HotParams])`` types
    ``self.params.limit`` and makes ``HotParams`` its ``Params``."""

    __slots__ = ("params", "owner", "children", "exprs")

    #: The parameters' model: the generic argument (``class Hot(Condition[HotParams])``) unless declared.
    Params: ClassVar[type[ConditionParams]] = ConditionParams
    #: The generic argument the class (or its nearest base that names one) gives; ``Params`` must agree with it.
    params_argument: ClassVar[type[ConditionParams] | None] = None
    #: Parameters that hold nested conditions: one condition object, or a list of them.
    condition_fields: ClassVar[tuple[str, ...]] = ()
    #: Parameters that hold expressions (checked and compiled by the loader, passed in ``exprs``).
    expr_fields: ClassVar[tuple[str, ...]] = ()
    #: Parameters that hold state paths (the loader checks them; ``bind`` resolves them).
    state_refs: ClassVar[tuple[str, ...]] = ()
    #: Parameters that hold input signal names.
    signal_refs: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        adopt_generic_params(cls, ConditionParams)

    def __init__(self, params: P, children: list[Condition[Any]] | None = None,
                 exprs: dict[str, Compiled] | None = None) -> None:
        self.params = params
        self.owner: State[Any] | None = None
        self.children = tuple(children or ())
        self.exprs = exprs or {}

    def bind(self, machine: Any, owner: State[Any]) -> None:
        """Called once when the machine is built; resolve references here. Binds the children too. ``machine`` is the
        :class:`fsm.Machine`, annotated ``Machine`` or ``MachineView`` in an override (see ``State.bind``)."""
        self.owner = owner
        for child in self.children:
            child.bind(machine, owner)

    def reset(self, ctx: Context) -> None:
        """Called each time the owner is entered (restart timers, forget edges). Resets the children too."""
        for child in self.children:
            child.reset(ctx)

    def holds(self, ctx: Context) -> bool:
        """True when the condition is met now."""
        raise NotImplementedError

    @property
    def type_name(self) -> str:
        """The registered type name this condition was built as (its document's ``type``)."""
        return self.params.type

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.type_name}>"
