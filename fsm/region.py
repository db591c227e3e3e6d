"""Region: one level of a machine (its states, initial state and active state) and the tick rule of a level."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .errors import StateRuntimeError
from .plan import ActionKind, GuardKind
from .sequencer.verdict import Verdict

if TYPE_CHECKING:
    from .context import Context
    from .machine import Listener
    from .state import State
    from .transition import Transition

_NUMERIC = (int, float)
_ALWAYS = GuardKind.ALWAYS
_COMPARE = GuardKind.COMPARE
_NO_ACTION = ActionKind.NONE
_COUNTER = ActionKind.COUNTER
_PROCEED = Verdict.PROCEED
_HALTED = Verdict.HALTED


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
        self.listeners: list[Listener] = []

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
        """Exit the active state (innermost first)."""
        if self.started:
            self.active.leave(ctx)
        self.started = False

    def step(self, ctx: Context) -> None:
        """One tick of this level."""
        state = self.active
        if state.paused:
            return
        if state.supervisor is not None:
            try:
                verdict = state.supervisor.check(ctx)
            except StateRuntimeError:
                raise
            except Exception as exc:
                raise StateRuntimeError.of(state, "monitors", ctx, exc) from exc
            if verdict is not _PROCEED:
                if verdict is _HALTED:
                    self._transitions_only(state, ctx)
                return
        phase = "check"
        tr: Transition[Any] | None = None
        try:
            if state.preempt:
                for tr in state.preempt:
                    if tr.fires(ctx):
                        phase = "firing"
                        self.fire(state, tr, ctx)
                        return
            tick = state.tick_hook
            if tick is not None:
                phase = "tick"
                tick(ctx)
                if state.paused:  # paused during its own tick (by a child or a listener): no transition
                    return
                phase = "check"
            for tr in state.regular:
                kind = tr.kind
                if kind is not _ALWAYS:
                    if kind is _COMPARE:  # the guard ``variable OP constant``, inline
                        name, op, const, _swapped, read = tr.compare  # type: ignore[misc]
                        v = ctx.vars
                        x = v[name] if name in v else read(v)
                        if not op(x if type(x) in _NUMERIC else read(v), const):
                            continue
                    elif not tr.test(ctx):  # type: ignore[misc]
                        continue
                phase = "firing"
                self.fire(state, tr, ctx)
                return
        except StateRuntimeError:
            raise
        except Exception as exc:
            if phase in ("check", "firing") and tr is not None:
                phase = f"{phase} of transition {tr.describe()}"
            raise StateRuntimeError.of(state, phase, ctx, exc) from exc

    def _transitions_only(self, state: State[Any], ctx: Context) -> None:
        """A halted state (aborted, or skipped by its precondition): not ticked, its transitions checked."""
        tr: Transition[Any] | None = None
        try:
            for tr in state.preempt + state.regular:
                if tr.fires(ctx):
                    self.fire(state, tr, ctx)
                    return
        except StateRuntimeError:
            raise
        except Exception as exc:
            phase = f"check of transition {tr.describe()}" if tr is not None else "check"
            raise StateRuntimeError.of(state, phase, ctx, exc) from exc

    def fire(self, state: State[Any], tr: Transition[Any], ctx: Context) -> None:
        """Leave ``state`` by ``tr``: exit innermost first, the transition's action, enter the target."""
        if state.exit_hook is not None:
            state.exit_hook(ctx)
        effect = tr.effect
        if effect is not _NO_ACTION:
            try:
                if effect is _COUNTER:  # a set ``target = variable OP constant`` and nothing else, inline
                    to, (name, op, const, _swapped, read) = tr.counter  # type: ignore[misc]
                    v = ctx.vars
                    x = v[name] if name in v else read(v)
                    v[to] = op(x if type(x) in _NUMERIC else read(v), const)
                else:
                    tr.run(ctx)  # type: ignore[misc]
            except StateRuntimeError:
                raise
            except Exception as exc:
                raise StateRuntimeError.of(state, f"action of transition {tr.describe()}", ctx, exc) from exc
        target = tr.target
        self.active = target
        target.entered_at = ctx._now
        self.fired += 1
        if self.listeners:
            for listener in self.listeners:
                listener.on_transition(ctx, state, target, tr)
        if target.enter_hook is not None:
            target.enter_hook(ctx)

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
