"""Transitions on inputs: ``Signal`` (edges and levels), ``Var`` (blackboard comparisons), ``InState`` (sync)."""

from __future__ import annotations

import operator
from typing import TYPE_CHECKING, Any, Literal

from pydantic import Field

from fsm.params import TransitionParams
from fsm.registry import register_transition
from fsm.transition import Transition

if TYPE_CHECKING:
    from fsm.context import Context
    from fsm.machine import Machine
    from fsm.state import State


@register_transition
class Signal(Transition):
    """Fires on an input signal: its rising or falling edge, or while it is high or low."""

    __slots__ = ("signal", "edge")

    class Params(TransitionParams):
        signal: str = Field(min_length=1, description="Name of the input signal (a button, a switch).")
        edge: Literal["rising", "falling", "high", "low"] = Field(
            default="rising", description="rising/falling: the one tick after the change; high/low: while so.")
        label: str | None = Field(default=None, description="The UML label this transition was drawn with.")

    def __init__(self, params: TransitionParams, source, target, index: int = 0) -> None:  # type: ignore[no-untyped-def]
        super().__init__(params, source, target, index)
        self.signal = params.signal  # type: ignore[attr-defined]
        self.edge = params.edge  # type: ignore[attr-defined]

    def check(self, ctx: Context) -> bool:
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


@register_transition
class Var(Transition):
    """Fires when blackboard variable `var` compares true with `value` (false while the variable is unset)."""

    __slots__ = ("var", "op", "value")

    class Params(TransitionParams):
        var: str = Field(min_length=1, description="Name of the blackboard variable.")
        op: Literal["==", "!=", "<", "<=", ">", ">="] = Field(default="==", description="Comparison.")
        value: bool | int | float | str | None = Field(description="Value to compare with.")

    def __init__(self, params: TransitionParams, source, target, index: int = 0) -> None:  # type: ignore[no-untyped-def]
        super().__init__(params, source, target, index)
        self.var = params.var  # type: ignore[attr-defined]
        self.op = _OPS[params.op]  # type: ignore[attr-defined]
        self.value = params.value  # type: ignore[attr-defined]

    @classmethod
    def check_document(cls, params: TransitionParams, variables: dict[str, Any]) -> tuple[str, str] | None:
        name, value = params.var, params.value  # type: ignore[attr-defined]
        if name not in variables:
            return None
        try:
            _OPS[params.op](variables[name], value)  # type: ignore[attr-defined]
        except TypeError:
            return "/value", (f"cannot compare variable '{name}' (initially {variables[name]!r}) "
                              f"{params.op} {value!r}")  # type: ignore[attr-defined]
        return None

    def check(self, ctx: Context) -> bool:
        current = ctx.vars.get(self.var, _UNSET)
        if current is _UNSET:
            return False
        try:
            return bool(self.op(current, self.value))
        except TypeError as exc:
            raise TypeError(
                f"cannot compare variable '{self.var}' = {current!r} with {self.value!r}: {exc}"
            ) from None


_UNSET: Any = object()


@register_transition
class InState(Transition):
    """Fires while the state at path `state` is active (to synchronise parallel regions)."""

    __slots__ = ("_other",)
    state_refs = ("state",)

    class Params(TransitionParams):
        state: str = Field(min_length=1, description="Path of the state, relative to this machine or an "
                                                     "enclosing one ('other/wait'), or absolute ('/a/b').")

    def __init__(self, params: TransitionParams, source, target, index: int = 0) -> None:  # type: ignore[no-untyped-def]
        super().__init__(params, source, target, index)
        self._other: State | None = None

    def bind(self, machine: Machine) -> None:
        scope = self.source.region.path if self.source.region is not None else ""
        self._other = machine.resolve(self.params.state, scope)  # type: ignore[attr-defined]

    def check(self, ctx: Context) -> bool:
        other = self._other
        return other is not None and other.active
