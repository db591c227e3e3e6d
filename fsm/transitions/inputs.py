"""Transitions on inputs: ``Signal`` (edges and levels), ``Var`` (blackboard comparisons), ``InState`` (sync)."""

from __future__ import annotations

import operator
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field

from fsm.loading.checking import value_kind
from fsm.loading.registry import register_transition
from fsm.model.params import TransitionParams
from fsm.runtime.region import wiring
from fsm.runtime.transition import Transition

if TYPE_CHECKING:
    from fsm.runtime.context import Context, MachineView, StateView
    from fsm.runtime.state import State


class SignalTransitionParams(TransitionParams):
    signal: str = Field(min_length=1, description="Name of the input signal (a button, a switch).")
    edge: Literal["rising", "falling", "high", "low"] = Field(
        default="rising", description="rising/falling: the one tick after the change; high/low: while so.")
    label: str | None = Field(default=None, description="The UML label this transition was drawn with.")


@register_transition
class Signal(Transition[SignalTransitionParams]):
    """Fires on an input signal: its rising or falling edge, or while it is high or low."""

    __slots__ = ("signal", "edge")
    signal_refs = ("signal",)
    Params = SignalTransitionParams

    def __init__(self, params: SignalTransitionParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self.signal = params.signal
        self.edge = params.edge

    def holds(self, ctx: Context) -> bool:
        edge = self.edge
        if edge == "rising":
            return ctx.rising(self.signal)
        if edge == "falling":
            return ctx.falling(self.signal)
        level = ctx.signal(self.signal)
        return level if edge == "high" else not level


_OPS = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}


class VarParams(TransitionParams):
    var: str = Field(min_length=1, description="Name of the blackboard variable.")
    op: Literal["==", "!=", "<", "<=", ">", ">="] = Field(default="==", description="Comparison.")
    value: bool | int | float | str = Field(description="Value to compare with.")


@register_transition
class Var(Transition[VarParams]):
    """Fires when blackboard variable `var` compares true with `value` (false while the variable is unset).

    Both sides must be of one kind: true/false, number or text (``true == 1`` and ``5 == "5"`` are errors, at
    load time against ``vars`` and the other Var transitions on the variable, at run time against the value
    a state stored); true/false compare with ``==`` and ``!=`` only.
    """

    __slots__ = ("var", "op", "value", "_type", "_kind")
    variable_refs = ("var",)
    Params = VarParams

    def __init__(self, params: VarParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self.var = params.var
        self.op = _OPS[params.op]
        self.value = params.value
        self._type = type(self.value)
        self._kind = value_kind(self.value)

    @classmethod
    def variable_test(cls, params: VarParams) -> tuple[str, str, Any] | None:
        return params.var, params.op, params.value

    def holds(self, ctx: Context) -> bool:
        current = ctx.vars.get(self.var, _UNSET)
        if current is _UNSET:
            return False
        if type(current) is not self._type and value_kind(current) != self._kind:
            raise TypeError(f"cannot compare variable '{self.var}' = {current!r} ({value_kind(current)}) with "
                            f"{self.value!r} ({self._kind}): a Var compares values of one kind (true/false is "
                            f"not a number); store a value of kind {self._kind}")
        return bool(self.op(current, self.value))


_UNSET: Any = object()


class InStateParams(TransitionParams):
    state: str = Field(min_length=1, description="Path of the state, relative to this machine or an "
                                                 "enclosing one ('other/wait'), or absolute ('/a/b').")


@register_transition
class InState(Transition[InStateParams]):
    """Fires while the state at path `state` is active (to synchronise parallel regions)."""

    __slots__ = ("_other",)
    state_refs = ("state",)
    Params = InStateParams

    def __init__(self, params: InStateParams, source: State[Any], target: State[Any], index: int = 0) -> None:
        super().__init__(params, source, target, index)
        self._other: StateView | None = None

    def bind(self, machine: MachineView) -> None:
        region = wiring(self.source).region
        scope = region.path if region is not None else ""
        self._other = machine.resolve(self.params.state, scope)

    def holds(self, ctx: Context) -> bool:
        other = self._other
        return other is not None and other.active
