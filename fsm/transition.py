"""Transition: the base class of every transition type: a condition checked on its source state each tick."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from .params import TransitionParams

if TYPE_CHECKING:
    from .context import Context
    from .state import State


class Transition:
    """A transition from ``source`` to ``target``. Subclass it, declare ``Params``, override ``check``.

    ``check(ctx)`` is called each tick while the source is active (after the source's tick, or before
    it for ``preempt: true``); the first transition whose check is true fires. ``on_source_enter`` is
    called whenever the source is entered (to take a reference value, e.g. the travelled distance).
    ``action`` runs while firing, between the source's exit and the target's entry.

    A document may add a ``guard`` (an expression or a condition, checked before ``check``: both must hold)
    and a ``set`` (assignments run after ``action``); the loader compiles them and calls :meth:`attach`.
    """

    __slots__ = ("params", "source", "target", "index", "always", "conditions", "_check", "_action",
                 "_source_hook", "_has_source_hook", "test", "count")

    Params: ClassVar[type[TransitionParams]] = TransitionParams
    #: Registered type name; set by the registry.
    type_name: ClassVar[str] = ""
    #: True for transitions that fire whenever checked (``Always``); the runtime then skips ``check``.
    unconditional: ClassVar[bool] = False
    #: True when the transition fires only on a finished source (the loader checks that it can finish).
    needs_finishing_source: ClassVar[bool] = False
    #: Transitions that read the plant (``ctx.car``); a machine with one cannot be built without a car.
    needs_car: ClassVar[bool] = False
    #: Names of parameters that hold state paths; the loader checks that they name existing states.
    state_refs: ClassVar[tuple[str, ...]] = ()
    #: Names of parameters that hold input signal names (``fsm.loader.signal_names`` collects them).
    signal_refs: ClassVar[tuple[str, ...]] = ()
    #: Names of parameters that hold blackboard variable names.
    variable_refs: ClassVar[tuple[str, ...]] = ()
    #: Names of parameters that hold condition objects; built instances are in ``self.conditions``.
    condition_fields: ClassVar[tuple[str, ...]] = ()

    def __init__(self, params: TransitionParams, source: State, target: State, index: int = 0) -> None:
        self.params = params
        self.source = source
        self.target = target
        self.index = index
        self.always = self.unconditional
        cls = type(self)
        self.conditions: dict[str, Any] = {}
        self._check: Any = self.check
        self._action: Any = self.action if cls.action is not Transition.action else None
        self._has_source_hook = cls.on_source_enter is not Transition.on_source_enter
        self._source_hook: Any = self.on_source_enter if self._has_source_hook else None
        #: ``(variable, operator, constant, read)`` when the whole check is a guard ``var OP constant``: the
        #: region runs it inline (a Python call costs as much as the comparison); ``_check`` stays equivalent.
        self.test: tuple[Any, ...] | None = None
        #: ``(target, variable, operator, constant, read)`` when the whole action is a ``set`` ``target = var OP
        #: constant`` (a counter): run inline by ``Region.fire``; ``_action`` stays equivalent.
        self.count: tuple[Any, ...] | None = None

    def attach(self, guard: Any = None, assign: Any = None, conditions: dict[str, Any] | None = None) -> None:
        """Add what the document gives on top of the type: ``guard(ctx) -> bool`` (checked first), ``assign(ctx)``
        (after ``action``) and condition instances by parameter name (``"guard"`` for a condition guard), which
        are reset each time the source is entered."""
        if conditions:
            self.conditions.update(conditions)
            resets = tuple(c.reset for c in conditions.values())
            own = self._source_hook

            def arm(ctx: Any) -> None:
                for reset in resets:
                    reset(ctx)
                if own is not None:
                    own(ctx)
            self._source_hook = arm
            self._has_source_hook = True
        if guard is not None:
            check = self.check
            if self.unconditional:
                self._check = guard
                self.test = getattr(guard, "test", None)
            else:
                self._check = lambda ctx: guard(ctx) and check(ctx)
            self.always = False
        if assign is not None:
            action = self._action
            if action is None:
                self._action = assign
                self.count = getattr(assign, "count", None)
            else:
                self.then(assign)

    def then(self, run: Any) -> None:
        """Run ``run(ctx)`` while firing, after what already runs there (the type's action, the ``set``)."""
        action = self._action
        if action is None:
            self._action = run
        else:
            def both(ctx: Any) -> None:
                action(ctx)
                run(ctx)
            self._action = both
        self.count = None

    @classmethod
    def check_document(cls, params: TransitionParams, variables: dict[str, Any]) -> tuple[str, str] | None:
        """A load-time check against the document's initial ``vars``: ``(pointer suffix, message)`` or ``None``."""
        return None

    @classmethod
    def variable_test(cls, params: TransitionParams) -> tuple[str, str, Any] | None:
        """``(variable, operator, value)`` when this transition compares a blackboard variable with a literal
        (``Var``): the loader checks that every comparison of a variable uses one kind of value."""
        return None

    def check(self, ctx: Context) -> bool:
        """True when the transition should fire now."""
        return False

    def on_source_enter(self, ctx: Context) -> None:
        """Called each time the source state is entered."""

    def action(self, ctx: Context) -> None:
        """Called while firing, after the source's exit and before the target's entry."""

    def bind(self, machine: Any) -> None:
        """Called once when the machine is built, to resolve references to other states (``InState``)."""

    def _bind_conditions(self, machine: Any) -> None:
        for condition in self.conditions.values():
            condition.bind(machine, self.source)

    def describe(self) -> str:
        """One line for traces and messages."""
        return f"{self.type_name} {self.source.id} -> {self.target.id}"

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.source.path!r} -> {self.target.path!r}>"
