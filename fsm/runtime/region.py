"""Region: one level of a machine (its states, initial state and active state) and the tick rule of a level, and the
wiring records the tick rule runs on.

A state's and a transition's runtime wiring (the links between them, the hooks the tick calls, the clock) is one
record per instance, :class:`StateWiring` and :class:`TransitionWiring`, kept in the instance's one slot ``_fsm``
(:func:`wiring`, :func:`transition_wiring`), so that a plugin author's namespace holds their own names. The records
live here, with the level that runs them, because they name each other (a state's level, a level's active state):
``fsm.runtime.state`` and ``fsm.runtime.transition`` name none of these classes. A level keeps its active state's
record (``current``) and a transition's record its target's, so that the tick reads no more attributes than it
would on the states themselves.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, overload

from fsm.model.errors import StateRuntimeError
from fsm.model.expr import VarOp
from fsm.model.plan import ActionKind, GuardKind
from fsm.runtime.state import Hook, Life, tick_hook, use_record
from fsm.runtime.transition import Link, use_link
from fsm.runtime.verdict import Verdict

if TYPE_CHECKING:
    from fsm.runtime.condition import Condition
    from fsm.runtime.context import Context
    from fsm.runtime.state import State
    from fsm.runtime.transition import Transition

_NUMERIC = (int, float)
_ALWAYS = GuardKind.ALWAYS
_CALL = GuardKind.CALL
_NO_ACTION = ActionKind.NONE
_COUNTER = ActionKind.COUNTER
_RUN = ActionKind.CALL
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


class Supervising(Protocol):
    """What a state's record and its level use of the state's supervisor (monitors, timeout, precondition): a
    :class:`fsm.runtime.supervisor.Supervisor` (above this module) is one."""

    halted: bool
    reset_at: float

    @property
    def level(self) -> Region | None:
        """The exception sequence's level running for the owner, or None."""
        ...

    def arm(self, ctx: Context) -> bool:
        """On each entry of the owner: False when its precondition is false."""
        ...

    def verdict(self, ctx: Context) -> Verdict:
        """Before the owner is ticked: what the monitors say."""
        ...


class Until(NamedTuple):
    """A state's exit condition, built: ``holds(ctx)`` and the condition objects to reset on each entry."""

    holds: Callable[[Context], bool]
    conditions: tuple[Condition[Any], ...]


def wiring(state: State[Any]) -> StateWiring:
    """The wiring record of ``state`` (made when first asked: the builder asks as it builds the state)."""
    record = state._fsm
    if isinstance(record, StateWiring):
        return record
    wired = state._fsm = StateWiring(state)
    wired.carry(record)
    return wired


def transition_wiring(transition: Transition[Any]) -> TransitionWiring:
    """The wiring record of ``transition`` (made when first asked, if the transition was made before this module was
    imported)."""
    record = transition._fsm
    if isinstance(record, TransitionWiring):
        return record
    wired = transition._fsm = TransitionWiring(transition, record.index)
    return wired


def new_state(cls: type[State[Any]], id: str, params: Any, path: str) -> StateWiring:
    """A state of type ``cls`` at ``path``, made for a machine: its record (the builder's one call per state)."""
    state = cls(id, params)
    state.path = path
    record = state._fsm
    return record if type(record) is StateWiring else wiring(state)


def new_transition(cls: type[Transition[Any]], params: Any, source: State[Any], target: State[Any],
                   index: int) -> TransitionWiring:
    """A transition of type ``cls`` made for a machine: its record (the builder's one call per transition)."""
    transition = cls(params, source, target, index)
    record = transition._fsm
    return record if type(record) is TransitionWiring else transition_wiring(transition)


class StateWiring(Life):
    """What the runtime keeps of a state in a machine: its level and sub-levels, its transitions (``preempt`` and
    ``regular`` as records, in the order they are checked; ``transitions`` as the transitions, in document order),
    its supervisor, exit condition and ``set`` actions, and the hooks the tick calls (fixed by :meth:`seal`)."""

    __slots__ = ("region", "regions", "transitions", "preempt", "regular", "supervisor", "until", "entry_action",
                 "exit_action", "complete_action", "tick_hook", "enter_hook", "exit_hook", "arms", "watched",
                 "resets", "is_final")

    def __init__(self, state: State[Any]) -> None:
        # Made once per state of every load (1,000 for the ring): the clock's fields of ``Life`` are written here,
        # not by ``Life.__init__`` (a frame less)
        self.state = state
        self.entered_at = 0.0
        self.paused = False
        self.frozen_since: float | None = None
        self.completed = False
        self.completion_ran = False
        self.region: Region | None = None
        self.regions: tuple[Region, ...] = ()
        #: The transitions out of this state, in document order (shared empty tuple where there are none).
        self.transitions: tuple[Transition[Any], ...] = ()
        self.preempt: tuple[TransitionWiring, ...] = ()
        self.regular: tuple[TransitionWiring, ...] = ()
        #: Monitors, timeout and precondition (:class:`fsm.runtime.supervisor.Supervisor`), or None.
        self.supervisor: Supervising | None = None
        #: The exit condition (``until``), or None.
        self.until: Until | None = None
        #: The document's ``set`` of this state, compiled, or None.
        self.entry_action: Hook | None = None
        self.exit_action: Hook | None = None
        #: The document's ``set.on_complete``, compiled, or None; run when the state is left after it finished
        #: by itself (``completed``: it called ``finish``), not when aborted, timed out, skipped or restarted.
        self.complete_action: Hook | None = None
        #: Condition objects of the state's predicates to reset on each entry.
        self.resets: tuple[Condition[Any], ...] = ()
        # Fixed by ``seal`` once the machine is built; made as ``seal`` fixes them for a plain state (see
        # :func:`sealed_as_made`), whose record the builder then need not seal:
        #: What the runtime calls: None where the base does nothing.
        self.tick_hook: Hook | None = None
        self.enter_hook: Hook | None = None
        self.exit_hook: Hook | None = None
        #: The outgoing transitions' hooks run on each entry (their references, their conditions' resets).
        self.arms: tuple[Hook, ...] = ()
        #: Whether anything is checked before the tick: a supervisor or preemptive transitions.
        self.watched = False
        self.is_final = False

    @property
    def active(self) -> bool:
        """True while the state and all its ancestors are active."""
        record = self
        while True:
            region = record.region
            if region is None:
                return True
            if region.current is not record or not region.started:
                return False
            owner = region.owner
            if owner is None:
                return True
            record = wiring(owner)

    # -- fixed when the machine is built ----------------------------------------------------------------------
    def seal(self) -> None:
        """Fix the hooks the runtime calls, once the machine is built: ``None`` where there is nothing to do, so
        a plain state costs the tick loop one test per hook."""
        state = self.state
        cls = type(state)
        self.is_final = cls.is_final
        self.arms = ()
        if self.preempt or len(self.regular) > 1:
            links = sorted(self.preempt + self.regular, key=_index)  # in document order, as ``transitions``
            self.arms = tuple([arm for t in links if (arm := t.arm) is not None])
        elif self.regular:  # one transition: the usual case, without a comprehension
            arm = self.regular[0].arm
            if arm is not None:
                self.arms = (arm,)
        supervised = self.supervisor is not None
        self.watched = supervised or bool(self.preempt)
        tick = tick_hook(state) if cls._overrides_tick or self.regions else None
        self.tick_hook = tick if self.until is None else self._until_tick(tick, self.until.holds)
        if self.complete_action is not None:
            self.tick_hook = self._completing_tick(self.tick_hook, self.complete_action)
        plain_enter = not (cls._overrides_enter or self.regions or self.arms or cls.can_finish or self.resets
                           or self.entry_action is not None or supervised or self.until is not None)
        self.enter_hook = None if plain_enter else self._enter
        self.exit_hook = self._exit if (cls._overrides_exit or self.regions or self.exit_action is not None) else None

    # -- the runtime ------------------------------------------------------------------------------------------
    def leave(self, ctx: Context) -> None:
        """Exit as a transition or an outer level does, and drop a pause or suspension it was held in."""
        if self.exit_hook is not None:
            self.exit_hook(ctx)
        self.release()

    def release(self) -> None:
        """No longer paused or frozen (the state was left while held)."""
        self.paused = False
        self.frozen_since = None

    def take_over(self, ctx: Context, old: StateWiring) -> None:
        """Become active in place of ``old``, the state at the same path in the machine a hot reload replaces
        (:mod:`fsm.debug.reload`), between two ticks. Carried over: its clock (entry time, pause, freeze), whether it
        finished and with which outcome, its timeout's reset; armed afresh: its outgoing transitions and its
        conditions; run: the type's ``on_enter`` with the new parameters, unless it had finished. The document's
        ``set`` actions are not run (the variables stay as they are). Its sub-levels are the caller's."""
        state, before = self.state, old.state
        self.entered_at = old.entered_at
        self.paused = old.paused
        self.frozen_since = old.frozen_since
        state.finished, state.outcome = before.finished, before.outcome
        self.completed, self.completion_ran = old.completed, old.completion_ran
        phase = "until"
        try:
            for condition in self.resets:
                condition.reset(ctx)
            if self.until is not None:
                for condition in self.until.conditions:
                    condition.reset(ctx)
            supervisor = self.supervisor
            if supervisor is not None:
                phase = "precondition"
                supervisor.arm(ctx)
                was = old.supervisor
                supervisor.halted = was.halted if was is not None else False
                supervisor.reset_at = was.reset_at if was is not None else 0.0
            phase = "on_source_enter"
            for arm in self.arms:
                arm(ctx)
            if not before.finished:
                phase = "on_enter"
                state.on_enter(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state, phase, ctx, exc) from exc

    def _enter(self, ctx: Context) -> None:
        """Enter: reset finishing, arm the outgoing transitions, ``on_enter``, then the sub-machines."""
        state = self.state
        state.finished = False
        state.outcome = None
        self.completed = self.completion_ran = False
        phase = "set on_enter"
        try:
            for condition in self.resets:
                condition.reset(ctx)
            if self.until is not None:
                phase = "until"
                for condition in self.until.conditions:
                    condition.reset(ctx)
            if self.supervisor is not None:
                phase = "precondition"
                if not self.supervisor.arm(ctx):
                    state.finished = True
                    state.outcome = "precondition_failed"
                    machine = ctx.machine
                    if machine is not None and machine.listeners:
                        machine.notify_skipped(state)
                    return
                phase = "set on_enter"
            if self.entry_action is not None:
                self.entry_action(ctx)
            phase = "on_source_enter"
            for arm in self.arms:
                arm(ctx)
            phase = "on_enter"
            state.on_enter(ctx)
            if self.completed and self.complete_action is not None:  # finished on entry (a Final, a SetVar)
                phase = "set on_complete"
                self.completion_ran = True
                self.complete_action(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state, phase, ctx, exc) from exc
        for region in self.regions:
            region.start(ctx)

    def _until_tick(self, tick: Hook | None, until: Callable[[Context], bool]) -> Hook:
        """The tick with the exit condition checked after it: the state finishes when ``until`` holds."""
        state = self.state
        if tick is None:
            def check(ctx: Context) -> None:
                if not state.finished and until(ctx):
                    state.finish("succeeded")
            return check

        def tick_then_check(ctx: Context) -> None:
            tick(ctx)
            if not state.finished and until(ctx):
                state.finish("succeeded")
        return tick_then_check

    def _completing_tick(self, tick: Hook | None, complete: Hook) -> Hook:
        """The tick followed by ``set.on_complete`` in the tick the state finishes by itself (once per entry)."""
        def tick_then_complete(ctx: Context) -> None:
            if tick is not None:
                tick(ctx)
            if self.completed and not self.completion_ran:
                self.completion_ran = True
                try:
                    complete(ctx)
                except StateRuntimeError:
                    raise
                except Exception as exc:
                    raise StateRuntimeError.of(self.state, "set on_complete", ctx, exc) from exc
        return tick_then_complete

    def _exit(self, ctx: Context) -> None:
        """Exit: sub-machines first (innermost first; parallel regions in reverse order), then ``on_exit``."""
        for region in reversed(self.regions):
            region.stop(ctx)
        state = self.state
        supervisor = self.supervisor
        if supervisor is not None and supervisor.halted and state.outcome == "precondition_failed":
            return  # skipped by its precondition: it was never entered, so it is not exited either
        phase = "on_exit"
        try:
            state.on_exit(ctx)
            if self.exit_action is not None:
                phase = "set on_exit"
                self.exit_action(ctx)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state, phase, ctx, exc) from exc

    def __repr__(self) -> str:
        return f"<wiring of {self.state!r}>"


def sealed_as_made(cls: type[State[Any]]) -> bool:
    """Whether the record of a state of class ``cls`` is made sealed (``seal`` would fix what it is made with) when
    the state has nothing more: no regions, supervisor, exit condition, ``set`` actions or resets, no preemptive
    transition and at most one regular one with nothing to arm. The class overrides no hook and no ``bind``, cannot
    finish and is not final. The builder seals only the other records (the ring's 1,000 states need no call)."""
    return not (cls._overrides_enter or cls._overrides_exit or cls._overrides_tick or cls.can_finish or cls.is_final
                or cls._binds_references)


class TransitionWiring(Link):
    """What the runtime keeps of a transition in a machine: how the region decides whether it fires (``kind``:
    ALWAYS, COMPARE runs ``compare`` inline, CALL calls ``test(ctx)``) and what firing runs (``effect``: NONE,
    COUNTER runs ``counter`` inline, CALL calls ``run(ctx)``), its target's record, and ``arm``, run on each entry of
    its source. The build stage adds the document's guard, conditions and ``set`` (:meth:`apply_guard`,
    :meth:`apply_conditions`, :meth:`apply_set`)."""

    __slots__ = ("target", "kind", "compare", "test", "effect", "counter", "run", "assign", "arm")

    def __init__(self, transition: Transition[Any], index: int) -> None:
        self.transition = transition  # Link's fields, written here: a call less per transition of a load
        self.index = index
        target = transition.target._fsm
        self.target = target if type(target) is StateWiring else wiring(transition.target)
        cls = type(transition)
        if cls.unconditional:
            self.kind = _ALWAYS
            self.test: Callable[[Context], bool] | None = None
        else:
            self.kind = _CALL
            self.test = transition.holds
        self.compare: VarOp | None = None
        if cls._overrides_action:
            self.effect = _RUN
            self.run: Callable[[Context], None] | None = transition.action
        else:
            self.effect = _NO_ACTION
            self.run = None
        self.counter: tuple[str, VarOp] | None = None
        #: The document's ``set``, compiled (kept to combine it with further actions, see ``then``).
        self.assign: Callable[[Context], None] | None = None
        #: Run on each entry of the source: the type's ``on_source_enter`` and the conditions' resets.
        self.arm: Callable[[Context], None] | None = \
            transition.on_source_enter if cls._overrides_source_enter else None

    # -- built from the plan --------------------------------------------------------------------------
    def apply_guard(self, guard: Callable[[Context], bool] | None, compare: VarOp | None = None) -> None:
        """Add the document's guard: asked first, then the type's ``holds`` (an ``Always`` has none). With
        ``compare`` (a guard ``variable OP constant`` on an ``Always``) the region runs it inline."""
        if compare is not None and type(self.transition).unconditional:
            self.kind = GuardKind.COMPARE
            self.compare = compare
        if guard is None:
            return
        check = self.test
        self.test = guard if check is None else (lambda ctx: guard(ctx) and check(ctx))
        if self.kind is GuardKind.ALWAYS:
            self.kind = GuardKind.CALL

    def apply_conditions(self, conditions: dict[str, Condition[Any]]) -> None:
        """Keep the condition objects (the transition's ``conditions``), reset each time the source is entered."""
        transition = self.transition
        transition.conditions = {**transition.conditions, **conditions}
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


    def describe(self) -> str:
        """The transition's line for traces and messages."""
        return self.transition.describe()

    def __repr__(self) -> str:
        return f"<wiring of {self.transition!r}>"


class RecordOf:
    """A level's state that the level keeps as its record, in the slot ``slot``: read, the state; set to a state,
    its record."""

    def __init__(self, slot: str) -> None:
        self.slot = slot

    @overload
    def __get__(self, level: None, owner: type) -> RecordOf: ...
    @overload
    def __get__(self, level: Region, owner: type) -> State[Any]: ...

    def __get__(self, level: Region | None, owner: type) -> RecordOf | State[Any]:
        if level is None:
            return self
        record: StateWiring = getattr(level, self.slot)
        return record.state

    def __set__(self, level: Region, state: State[Any]) -> None:
        setattr(level, self.slot, wiring(state))


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

    __slots__ = ("name", "path", "states", "first", "current", "owner", "started", "fired", "listeners")

    def __init__(self, name: str, path: str, states: dict[str, State[Any]], initial: State[Any]) -> None:
        self.name = name
        self.path = path
        self.states = states
        #: the initial state's record, and the active state's (see :attr:`initial`, :attr:`active`): what the tick
        #: runs on
        self.first = wiring(initial)
        self.current = self.first
        self.owner: State[Any] | None = None
        self.started = False
        self.fired = 0
        #: the machine's listeners (its own list, shared by every level)
        self.listeners: Sequence[EntryListener] = ()
        for state in states.values():
            record = state._fsm  # made by the state (use_record below): wiring() only for one made before
            (record if type(record) is StateWiring else wiring(state)).region = self

    #: The state a start enters.
    initial = RecordOf("first")
    #: The active state (the last one entered, once the level has started).
    active = RecordOf("current")

    def start(self, ctx: Context) -> None:
        """Enter the initial state (and down into its initial sub-states)."""
        state = self.first
        self.current = state
        self.started = True
        state.entered_at = ctx._now  # the machine's time slot: a property costs a call
        if self.listeners:
            for listener in self.listeners:
                listener.on_transition(ctx, None, state.state, None)
        if state.enter_hook is not None:
            state.enter_hook(ctx)

    def stop(self, ctx: Context) -> None:
        """Exit the active state (innermost first); a pause or suspension it was held in ends with it."""
        if self.started:
            state = self.current
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
        unless something raises) per half names what failed. It runs on the records (``state`` is the active state's
        :class:`StateWiring`, ``tr`` a :class:`TransitionWiring`), which hold what it reads.
        """
        state = self.current
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
            raise StateRuntimeError.of(state.state, "tick" if tr is None else f"check of transition {tr.describe()}",
                                       ctx, exc) from exc
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
            raise StateRuntimeError.of(state.state, f"action of transition {tr.describe()}", ctx, exc) from exc
        target = tr.target
        self.current = target
        target.entered_at = ctx._now  # the machine's time slot: the property costs a call on this path
        self.fired += 1
        if self.listeners:
            self._tell(ctx, state, target, tr)
        if target.enter_hook is not None:
            target.enter_hook(ctx)

    def _tell(self, ctx: Context, state: StateWiring, target: StateWiring, tr: TransitionWiring) -> None:
        """Tell the listeners that ``tr`` fired (a call only where listeners are attached)."""
        try:
            for listener in self.listeners:
                listener.on_transition(ctx, state.state, target.state, tr.transition)
        except StateRuntimeError:
            raise
        except Exception as exc:
            raise StateRuntimeError.of(state.state, f"firing of transition {tr.describe()}", ctx, exc) from exc

    def _before_tick(self, state: StateWiring, ctx: Context) -> Any:
        """The supervisor and the preemptive transitions: the transition that fires, None (go on with the tick),
        or ``_USED_UP`` (the supervisor used the tick up, or the state is halted and none of its transitions
        fires)."""
        candidates: tuple[TransitionWiring, ...] = state.preempt
        halted = False
        supervisor = state.supervisor
        if supervisor is not None:
            try:
                verdict = supervisor.verdict(ctx)
            except StateRuntimeError:
                raise
            except Exception as exc:
                raise StateRuntimeError.of(state.state, "monitors", ctx, exc) from exc
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
            raise StateRuntimeError.of(state.state, f"check of transition {tr.describe()}", ctx, exc) from exc
        return _USED_UP if halted else None

    def terminal_states(self) -> list[State[Any]]:
        """The states of this level without outgoing transitions that are not final (one that finishes ends a root
        level), in one pass over the records (made by ``__init__``)."""
        terminal = []
        for state in self.states.values():
            record = state._fsm
            assert type(record) is StateWiring  # given by __init__
            if not record.transitions and not record.state.is_final:
                terminal.append(state)
        return terminal

    def leaf_paths(self) -> list[str]:
        """Paths of the active leaf states below this level (several under a parallel state)."""
        state = self.current
        path = state.state.path
        supervisor = state.supervisor
        running = supervisor.level if supervisor is not None else None
        if running is not None:  # suspended for an exception sequence
            inner = [p for r in state.regions if r.started for p in r.leaf_paths()] or [path]
            return inner + running.leaf_paths()
        if not state.regions:
            return [path]
        paths: list[str] = []
        for region in state.regions:
            if region.started:  # an aborted (halted) composite has left its sub-states: it is the leaf
                paths.extend(region.leaf_paths())
        return paths or [path]

    def __repr__(self) -> str:
        return f"<Region {self.path!r} active={self.current.state.id!r}>"


def _index(link: Link) -> int:
    return link.index


use_record(StateWiring)
use_link(TransitionWiring)

