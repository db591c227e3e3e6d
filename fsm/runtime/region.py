"""Region: one level of a machine (its states, initial state and active state) and the tick rule of a level."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol

from fsm.model.errors import StateRuntimeError
from fsm.model.plan import ActionKind, GuardKind
from fsm.runtime.verdict import Verdict

if TYPE_CHECKING:
    from fsm.runtime.context import Context
    from fsm.runtime.state import State
    from fsm.runtime.transition import Transition

_NUMERIC = (int, float)
_ALWAYS = GuardKind.ALWAYS
_CALL = GuardKind.CALL
_NO_ACTION = ActionKind.NONE
_COUNTER = ActionKind.COUNTER
_PROCEED = Verdict.PROCEED
_HALTED = Verdict.HALTED
#: What ``Region._before_tick`` returns when nothing more happens at this level in this tick.
_USED_UP: Any = object()


class EntryListener(Protocol):
    """What a level tells of each entry: a :class:`fsm.runtime.machine.Listener` (above this module) is one.
    ``transition`` is the transition that fired, a monitor's restart record, or ``None`` for an initial entry."""

    def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any], transition: Any) -> None:
        """``target`` was entered."""
        ...


class Region:
    """A machine level. The root machine has one; a composite state owns one (``FSMState``) or several
    (``Parallel``).

    One tick of a level whose active state is S (docs/semantics.md, "One tick"): S's supervisor (monitors,
    timeout), S's preemptive transitions (the caller's level was checked before, so outermost first); S's tick
    (which steps S's sub-levels by the same rule); S's regular transitions in priority/declaration order. At most
    one transition fires per level per tick.

    Whether a transition fires is decided by its ``kind``: ``ALWAYS`` fires, ``COMPARE`` runs the comparison
    ``variable OP constant`` inline, ``CALL`` calls ``test(ctx)``. Firing runs its ``effect`` the same way.
    """

    __slots__ = ("name", "path", "states", "initial", "active", "owner", "started", "fired", "listeners")

    def __init__(self, name: str, path: str, states: dict[str, State[Any]], initial: State[Any]) -> None:
        self.name = name
        self.path = path
        self.states = states
        self.initial = initial
        self.active: State[Any] = initial
        self.owner: State[Any] | None = None
        self.started = False
        self.fired = 0
        #: the machine's listeners (its own list, shared by every level)
        self.listeners: Sequence[EntryListener] = ()

    def start(self, ctx: Context) -> None:
        """Enter the initial state (and down into its initial sub-states)."""
        state = self.initial
        self.active = state
        self.started = True
        state.entered_at = ctx._now  # the machine's time slot: a property costs a call
        if self.listeners:
            for listener in self.listeners:
                listener.on_transition(ctx, None, state, None)
        if state.enter_hook is not None:
            state.enter_hook(ctx)

    def stop(self, ctx: Context) -> None:
        """Exit the active state (innermost first); a pause or suspension it was held in ends with it."""
        if self.started:
            state = self.active
            if state.exit_hook is not None:
                state.exit_hook(ctx)
            if state.frozen_since is not None:
                state.release()
        self.started = False

    def tick(self, ctx: Context) -> None:  # noqa: C901 - the hot path: each split costs a call a tick (+13.6 %)
        """One tick of this level: choose the transition that fires (if any), then fire it.

        Choosing: the supervisor first (it may use up the tick, or halt the state so that only its transitions
        are checked), then the preemptive transitions, the state's tick, the regular transitions in order.
        Firing: exit (innermost first), the transition's action, entry of the target (and down into its initial
        sub-states). Both are written out here, in one function, because this is the loop every tick runs (a
        transition fires every tick in the flat ring: a call to a firing method costs it 13 %); one ``try`` (free
        unless something raises) per half names what failed.
        """
        state = self.active
        if state.paused:
            return
        # the transition chosen (a ``Transition``), or what ``_before_tick`` answered; None while the state's tick
        # runs, so that a failure names the tick or the transition being checked
        tr: Any = None
        try:
            if state.watched:  # a supervisor or preemptive transitions: checked before the tick
                tr = self._before_tick(state, ctx)
                if tr is _USED_UP:
                    return
            if tr is None:
                tick = state.tick_hook
                if tick is not None:
                    tick(ctx)
                    if state.paused:  # paused during its own tick (by a child or a listener): no transition
                        return
                for tr in state.regular:
                    kind = tr.kind
                    if kind is _ALWAYS:
                        break
                    if kind is _CALL:
                        if tr.test(ctx):
                            break
                    else:  # COMPARE: the guard ``variable OP constant``, inline
                        name, op, const, _swapped, read = tr.compare
                        v = ctx.vars
                        x = v[name] if name in v else read(v)
                        if op(x if type(x) in _NUMERIC else read(v), const):
                            break
                else:
                    return
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state, "tick" if tr is None else f"check of transition {tr.describe()}", ctx,
                                       exc) from exc
        # -- firing ``tr`` --
        if state.exit_hook is not None:
            state.exit_hook(ctx)
        try:
            effect = tr.effect
            if effect is not _NO_ACTION:
                if effect is _COUNTER:  # a set ``target = variable OP constant`` and nothing else, inline
                    to, (name, op, const, _swapped, read) = tr.counter
                    v = ctx.vars
                    x = v[name] if name in v else read(v)
                    v[to] = op(x if type(x) in _NUMERIC else read(v), const)
                else:
                    tr.run(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state, f"action of transition {tr.describe()}", ctx, exc) from exc
        target = tr.target
        self.active = target
        target.entered_at = ctx._now  # the machine's time slot: the property costs a call on this path
        self.fired += 1
        if self.listeners:
            self._tell(ctx, state, target, tr)
        if target.enter_hook is not None:
            target.enter_hook(ctx)

    def _tell(self, ctx: Context, state: State[Any], target: State[Any], tr: Transition[Any]) -> None:
        """Tell the listeners that ``tr`` fired (a call only where listeners are attached)."""
        try:
            for listener in self.listeners:
                listener.on_transition(ctx, state, target, tr)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state, f"firing of transition {tr.describe()}", ctx, exc) from exc

    def _before_tick(self, state: State[Any], ctx: Context) -> Any:
        """The supervisor and the preemptive transitions: the transition that fires, None (go on with the tick),
        or ``_USED_UP`` (the supervisor used the tick up, or the state is halted and none of its transitions
        fires)."""
        candidates: tuple[Transition[Any], ...] = state.preempt
        halted = False
        supervisor = state.supervisor
        if supervisor is not None:
            try:
                verdict = supervisor.verdict(ctx)
            except StateRuntimeError:
                raise
            except Exception as exc:
                raise StateRuntimeError.of(state, "monitors", ctx, exc) from exc
            if verdict is not _PROCEED:
                if verdict is not _HALTED:
                    return _USED_UP
                # halted: not ticked, its transitions checked. A flag, not ``candidates is not state.preempt``: with
                # no transitions at all (a non-blocking sequence's region) ``() + ()`` is ``()`` itself
                halted = True
                candidates = state.preempt + state.regular
        tr = None
        try:
            for tr in candidates:
                if tr.fires(ctx):
                    return tr
        except StateRuntimeError:
            raise
        except Exception as exc:
            assert tr is not None
            raise StateRuntimeError.of(state, f"check of transition {tr.describe()}", ctx, exc) from exc
        return _USED_UP if halted else None

    def leaf_paths(self) -> list[str]:
        """Paths of the active leaf states below this level (several under a parallel state)."""
        state = self.active
        supervisor = state.supervisor
        if supervisor is not None and supervisor.running is not None:  # suspended for an exception sequence
            inner = [p for r in state.regions if r.started for p in r.leaf_paths()] or [state.path]
            return inner + supervisor.running.region.leaf_paths()
        if not state.regions:
            return [state.path]
        paths: list[str] = []
        for region in state.regions:
            if region.started:  # an aborted (halted) composite has left its sub-states: it is the leaf
                paths.extend(region.leaf_paths())
        return paths or [state.path]

    def __repr__(self) -> str:
        return f"<Region {self.path!r} active={self.active.id!r}>"
