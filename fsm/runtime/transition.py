"""Transition: the base class of every transition type: a condition checked on its source state each tick."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

from fsm.model.expr import VarOp
from fsm.model.params import TransitionParams, adopt_generic_params
from fsm.model.plan import ActionKind, GuardKind

if TYPE_CHECKING:
    from fsm.runtime.condition import Condition
    from fsm.runtime.context import Context, MachineView
    from fsm.runtime.state import State

P = TypeVar("P", bound=TransitionParams)
#: The conditions of a transition that has none (shared; ``apply_conditions`` makes a transition its own).
_NO_CONDITIONS: dict[str, Any] = {}


class Transition(Generic[P]):
    """A transition from ``source`` to ``target``. Subclass it, declare ``Params``, override ``holds``.

    ``holds(ctx)`` is called each tick while the source is active (after the source's tick, or before
    it for ``preempt: true``); the first transition whose check is true fires. ``on_source_enter`` is
    called whenever the source is entered (to take a reference value, e.g. the travelled distance).
    ``action`` runs while firing, between the source's exit and the target's entry.

    A document may add a ``guard`` (an expression or a condition, asked before ``holds``: both must hold)
    and a ``set`` (assignments run after ``action``); the build stage applies them with
    :meth:`apply_guard`, :meth:`apply_conditions` and :meth:`apply_set`.
    How the region decides and fires is explicit: ``kind`` (always, an inline ``variable OP constant``
    comparison, or a call of ``test``) and ``effect`` (nothing, an inline counter, or a call of ``run``).
    """

    __slots__ = ("params", "source", "target", "index", "kind", "compare", "test", "effect", "counter", "run",
                 "assign", "conditions", "arm")

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
    binds_references: ClassVar[bool] = False
    #: Whether the type has its own load-time checks (``check_document``, ``variable_test``): the checks call them
    #: only where it does.
    checks_document: ClassVar[bool] = False
    tests_variables: ClassVar[bool] = False
    #: Whether the class's ``holds`` is a ``check`` written under the old name (see :meth:`check`).
    _holds_is_check: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        _adopt_old_check(cls)
        adopt_generic_params(cls, TransitionParams)
        cls._overrides_action = cls.action is not Transition.action
        cls._overrides_source_enter = cls.on_source_enter is not Transition.on_source_enter
        cls.binds_references = cls.bind is not Transition.bind
        cls.checks_document = cls.check_document.__func__ is not Transition.check_document.__func__  # type: ignore[attr-defined]
        cls.tests_variables = cls.variable_test.__func__ is not Transition.variable_test.__func__  # type: ignore[attr-defined]

    def __init__(self, params: P, source: State[Any], target: State[Any], index: int = 0) -> None:
        self.params = params
        self.source = source
        self.target = target
        self.index = index
        cls = type(self)
        #: How the region decides: ALWAYS, COMPARE (``compare`` inline) or CALL (``test(ctx)``).
        if cls.unconditional:
            self.kind = GuardKind.ALWAYS
            self.test: Callable[[Context], bool] | None = None
        else:
            self.kind = GuardKind.CALL
            self.test = self.holds
        self.compare: VarOp | None = None
        #: What firing runs: NONE, COUNTER (``counter`` inline) or CALL (``run(ctx)``).
        if cls._overrides_action:
            self.effect = ActionKind.CALL
            self.run: Callable[[Context], None] | None = self.action
        else:
            self.effect = ActionKind.NONE
            self.run = None
        self.counter: tuple[str, VarOp] | None = None
        #: The document's ``set``, compiled (kept to combine it with further actions, see ``then``).
        self.assign: Callable[[Context], None] | None = None
        #: Condition objects by parameter name (a condition guard is ``"guard"``).
        self.conditions: dict[str, Condition[Any]] = _NO_CONDITIONS
        #: Run on each entry of the source: the type's ``on_source_enter`` and the conditions' resets.
        self.arm: Callable[[Context], None] | None = self.on_source_enter if cls._overrides_source_enter else None

    @property
    def type_name(self) -> str:
        """The registered type name this transition was built as (its document's ``type``)."""
        return self.params.type

    # -- built from the plan --------------------------------------------------------------------------
    def apply_guard(self, guard: Callable[[Context], bool] | None, compare: VarOp | None = None) -> None:
        """Add the document's guard: asked first, then the type's ``holds`` (an ``Always`` has none). With
        ``compare`` (a guard ``variable OP constant`` on an ``Always``) the region runs it inline."""
        if compare is not None and type(self).unconditional:
            self.kind = GuardKind.COMPARE
            self.compare = compare
        if guard is None:
            return
        check = self.test
        self.test = guard if check is None else (lambda ctx: guard(ctx) and check(ctx))
        if self.kind is GuardKind.ALWAYS:
            self.kind = GuardKind.CALL

    def apply_conditions(self, conditions: dict[str, Condition[Any]]) -> None:
        """Keep the condition objects, reset each time the source is entered."""
        self.conditions = {**self.conditions, **conditions}
        resets = tuple(c.reset for c in conditions.values())
        own = self.arm

        def arm(ctx: Context) -> None:
            for reset in resets:
                reset(ctx)
            if own is not None:
                own(ctx)
        self.arm = arm

    def apply_set(self, assign: Callable[[Context], None], counter: tuple[str, VarOp] | None = None) -> None:
        """Add the document's ``set`` (after the type's ``action``); a lone counter runs inline."""
        self.assign = assign
        if self.effect is ActionKind.NONE and counter is not None:
            self.effect = ActionKind.COUNTER
            self.counter = counter
            return
        self.then(assign)

    def then(self, run: Callable[[Context], None]) -> None:
        """Run ``run(ctx)`` while firing, after what already runs there (the type's action, the ``set``)."""
        before = self.run
        if self.effect is ActionKind.COUNTER:
            before = self.assign
        if before is None:
            self.run = run
        else:
            def both(ctx: Context) -> None:
                before(ctx)
                run(ctx)
            self.run = both
        self.effect = ActionKind.CALL
        self.counter = None

    def fires(self, ctx: Context) -> bool:
        """Whether the transition fires now, by its kind (the region runs the same inline)."""
        kind = self.kind
        if kind is GuardKind.ALWAYS:
            return True
        if kind is GuardKind.COMPARE:
            assert self.compare is not None
            name, op, const, _swapped, read = self.compare
            v = ctx.vars
            x = v[name] if name in v else read(v)
            return bool(op(x if type(x) in (int, float) else read(v), const))
        assert self.test is not None
        return bool(self.test(ctx))

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
        warnings.warn(f"{type(self).__qualname__}.check(ctx) is deprecated: call holds(ctx)", DeprecationWarning,
                      stacklevel=2)
        if type(self)._holds_is_check:  # reached by super().check(ctx) from an old-style check: the base's answer
            return False
        return self.holds(ctx)

    def on_source_enter(self, ctx: Context) -> None:
        """Called each time the source state is entered."""

    def action(self, ctx: Context) -> None:
        """Called while firing, after the source's exit and before the target's entry."""

    def bind(self, machine: MachineView) -> None:
        """Called once when the machine is built, to resolve references to other states (``InState``)."""

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
    warnings.warn(f"{cls.__module__}.{cls.__qualname__}: Transition.check(ctx) is renamed holds(ctx); rename the "
                  "method (check is the old name, accepted until the next release)", DeprecationWarning,
                  stacklevel=3)
    type.__setattr__(cls, "holds", old)  # the old name serves as the new (mypy refuses assigning a method)
    cls._holds_is_check = True
