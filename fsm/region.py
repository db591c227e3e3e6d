"""Region: one level of a machine (its states, initial state and active state) and the tick rule of a level."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .errors import StateRuntimeError

if TYPE_CHECKING:
    from .context import Context
    from .state import State
    from .transition import Transition


_NUMERIC = (int, float)


class Region:
    """A machine level. The root machine has one; a composite state owns one (``FSMState``) or several
    (``Parallel``).

    One tick of a level whose active state is S (DESIGN.md, Tick semantics): S's preemptive
    transitions (the caller's level was checked before, so outermost first); S's tick (which steps
    S's sub-levels by the same rule); S's regular transitions in priority/declaration order. At most
    one transition fires per level per tick.
    """

    __slots__ = ("name", "path", "states", "initial", "active", "owner", "started", "fired", "listeners")

    def __init__(self, name: str, path: str, states: dict[str, State], initial: State) -> None:
        self.name = name
        self.path = path
        self.states = states
        self.initial = initial
        self.active: State = initial
        self.owner: State | None = None
        self.started = False
        self.fired = 0
        self.listeners: list[Any] = []

    def start(self, ctx: Context) -> None:
        """Enter the initial state (and down into its initial sub-states)."""
        state = self.initial
        self.active = state
        self.started = True
        state.entered_at = ctx._now
        if self.listeners:
            for listener in self.listeners:
                listener.on_transition(ctx, None, state, None)
        if state._enter is not None:
            state._enter(ctx)

    def stop(self, ctx: Context) -> None:
        """Exit the active state (innermost first)."""
        state = self.active
        if self.started and state._exit is not None:
            state._exit(ctx)
        self.started = False

    def step(self, ctx: Context) -> None:
        """One tick of this level."""
        state = self.active
        if state.paused:
            return
        if state._watch is not None:
            try:
                verdict = state._watch(ctx)
            except StateRuntimeError:
                raise
            except Exception as exc:
                raise ctx.machine._runtime_error(state, "monitors", exc) from exc  # type: ignore[union-attr]
            if verdict is not None:
                if not verdict:
                    self._transitions_only(state, ctx)
                return
        phase = "check"
        tr: Transition | None = None
        try:
            if state.preempt:
                for tr in state.preempt:
                    if tr.always or tr._check(ctx):
                        phase = "firing"
                        self.fire(state, tr, ctx)
                        return
            if state._tick is not None:
                phase = "tick"
                state._tick(ctx)
                if state.paused:  # paused during its own tick (by a child or a listener): no transition
                    return
                phase = "check"
            for tr in state.regular:
                if tr.always:
                    phase = "firing"
                    self.fire(state, tr, ctx)
                    return
                test = tr.test
                if test is None:
                    if not tr._check(ctx):
                        continue
                else:  # a guard ``var OP constant`` and nothing else, inline (see Transition.test)
                    name, op, const, read = test
                    v = ctx.vars
                    x = v[name] if name in v else read(v)
                    if not op(x if type(x) in _NUMERIC else read(v), const):
                        continue
                phase = "firing"
                self.fire(state, tr, ctx)
                return
        except StateRuntimeError:
            raise
        except Exception as exc:
            if phase in ("check", "firing") and tr is not None:
                phase = f"{phase} of transition {tr.describe()}"
            raise ctx.machine._runtime_error(state, phase, exc) from exc  # type: ignore[union-attr]

    def _transitions_only(self, state: State, ctx: Context) -> None:
        """A halted state (aborted, or skipped by its precondition): not ticked, its transitions checked."""
        tr: Transition | None = None
        try:
            for tr in state.preempt + state.regular:
                if tr.always or tr._check(ctx):
                    self.fire(state, tr, ctx)
                    return
        except StateRuntimeError:
            raise
        except Exception as exc:
            phase = f"check of transition {tr.describe()}" if tr is not None else "check"
            raise ctx.machine._runtime_error(state, phase, exc) from exc  # type: ignore[union-attr]

    def fire(self, state: State, tr: Transition, ctx: Context) -> None:
        """Leave ``state`` by ``tr``: exit innermost first, the transition's action, enter the target."""
        if state._exit is not None:
            state._exit(ctx)
        count = tr.count
        if count is not None or tr._action is not None:
            try:
                if count is not None:  # a set ``target = var OP constant`` and nothing else, inline
                    to, name, op, const, read = count
                    v = ctx.vars
                    x = v[name] if name in v else read(v)
                    v[to] = op(x if type(x) in _NUMERIC else read(v), const)
                else:
                    tr._action(ctx)
            except Exception as exc:
                raise ctx.machine._runtime_error(state, f"action of transition {tr.describe()}", exc) from exc  # type: ignore[union-attr]
        target = tr.target
        self.active = target
        target.entered_at = ctx._now
        self.fired += 1
        if self.listeners:
            for listener in self.listeners:
                listener.on_transition(ctx, state, target, tr)
        if target._enter is not None:
            target._enter(ctx)

    def leaf_paths(self) -> list[str]:
        """Paths of the active leaf states below this level (several under a parallel state)."""
        state = self.active
        w = state._watcher
        if w is not None and w.running is not None:  # suspended for an exception sequence: both are shown
            inner = [p for r in state.regions if r.started for p in r.leaf_paths()] or [state.path]
            return inner + w.running[1].leaf_paths()
        if not state.regions:
            return [state.path]
        paths: list[str] = []
        for region in state.regions:
            if region.started:  # an aborted (halted) composite has left its sub-states: it is the leaf
                paths.extend(region.leaf_paths())
        return paths or [state.path]

    def __repr__(self) -> str:
        return f"<Region {self.path!r} active={self.active.id!r}>"
