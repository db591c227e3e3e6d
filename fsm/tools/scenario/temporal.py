"""The scenario's temporal language: expectations over time (``always``, ``never``, ``eventually``, ``until``,
``after`` ... ``ticks``) whose formulas are expressions of the document language (:mod:`fsm.model.expr`) with a
few more functions:

- state predicates, true/false at a tick: ``active(X)``, ``paused(X)``, ``suspended(X)``, ``entered(X)`` (entered
  and run at this tick), ``skipped(X)`` (entered and skipped by its precondition at this tick), ``fired(X)`` (a
  monitor or timeout of X fired at this tick); ``outcome(X)`` is text: the outcome X last finished with by this
  tick ('' before it ever finished). X is a state's id or the end of its path (``grip``, ``run/work/grip`` or
  ``'run/work/grip'``); ``'X/*'`` is any state below X.
- terms over time: ``prev(e)`` (e's value at the tick before; at the first tick its own), ``rose(b)``, ``fell(b)``
  (b became true, false at this tick), ``changed(e)``, ``start(e)`` (e's value at the start of the window, or at the
  tick the ``after`` trigger held).

A formula is parsed with these functions, each call is replaced by a name of its own whose value the watch computes
each tick (inner calls first), and the tree is compiled by the document language's compiler: kinds, columns and
messages are the language's own. Everything is checked when the scenario is loaded (:func:`compile_formula`).
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from fsm.model.expr import (
    ANY,
    BOOL,
    FUNCTIONS,
    TEXT,
    ExprError,
    ExprRuntimeError,
    Node,
    compile_tree,
    parse,
    unparse,
)
from fsm.runtime.region import wiring

from .. import did_you_mean
from .paths import first_few, state_matches

#: State predicates (true/false) and the text term ``outcome``.
STATE_TERMS = ("active", "paused", "suspended", "entered", "skipped", "fired", "outcome")
#: Terms over the values of ticks.
TIME_TERMS = ("prev", "rose", "fell", "changed", "start")
TEMPORAL_FUNCTIONS: dict[str, tuple[int, int | None]] = {**FUNCTIONS, **{n: (1, 1) for n in STATE_TERMS + TIME_TERMS}}
_PREFIX = "__term"
#: Names of the terms: unique in a process, since the watches of a run share one dict of values per tick.
_NAMES = itertools.count()


#: The kind of event a state term's value changes with (see ``TemporalRun.step`` in the runner).
_EVENTS = {"active": {"@active"}, "entered": {"@entries"}, "skipped": {"@entries"}, "fired": {"@fired"},
           "outcome": {"@outcome"}, "paused": {"@paused", "@active"}, "suspended": {"@active", "@fired"}}


class FormulaError(ExprError):
    """A formula that cannot be used: the language's error, with a hint (did you mean ...)."""

    def __init__(self, message: str, column: int, hint: str | None = None) -> None:
        super().__init__(message, column)
        self.hint = hint


@dataclass
class Tick:
    """What the terms of one tick read: the tick, the active states (every prefix of an active leaf), the states
    entered (and run), skipped, whose monitor fired at it, and the last outcomes."""

    tick: int = 0
    active: frozenset[str] = frozenset()
    entered: frozenset[str] = frozenset()
    skipped: frozenset[str] = frozenset()
    fired: frozenset[str] = frozenset()
    #: path -> (tick it finished, outcome)
    outcomes: dict[str, tuple[int, str]] = field(default_factory=dict)


class Term:
    """One temporal call of a formula, replaced by the name ``name``; ``update`` (chosen for its ``op`` when the term
    is made) computes its value at a tick."""

    __slots__ = ("name", "text", "op", "paths", "fn", "last", "begun", "start_value", "kind", "states", "update",
                 "edge")

    def __init__(self, name: str, text: str, op: str, kind: str, paths: frozenset[str] = frozenset(),
                 fn: Callable[[dict[str, Any]], Any] | None = None) -> None:
        self.name = name
        self.text = text
        self.op = op
        self.kind = kind
        self.paths = paths
        self.fn = fn
        self.last: Any = None
        self.begun = False
        self.start_value: Any = None
        #: paused, suspended: the states it names (bound to the run's machine by :meth:`Formula.bind`)
        self.states: list[Any] = []
        #: prev, rose, fell, changed: the term's value from the value now and the value at the tick before
        self.edge = _EDGES.get(op)
        self.update: Callable[[Tick, dict[str, Any]], None] = getattr(self, _UPDATES.get(op, "_event"))

    def _event(self, now: Tick, values: dict[str, Any]) -> None:
        """active, entered, skipped, fired: one of the paths is in the tick's set of that name."""
        values[self.name] = not self.paths.isdisjoint(getattr(now, self.op))

    def _hold(self, now: Tick, values: dict[str, Any]) -> None:
        """paused, suspended: an active state it names is held so."""
        paused = self.op == "paused"
        values[self.name] = any(_held(st, paused) for st in self.states if st.path in now.active)

    def _outcome(self, now: Tick, values: dict[str, Any]) -> None:
        """outcome: the outcome its states last finished with ('' before one finished)."""
        got = [now.outcomes[p] for p in self.paths if p in now.outcomes]
        # the latest finish; of two at one tick, the last looked at
        values[self.name] = max(reversed(got), key=lambda o: o[0])[1] if got else ""

    def _start(self, now: Tick, values: dict[str, Any]) -> None:
        """start: the value at the first tick (or the tick :meth:`anchor` set)."""
        assert self.fn is not None
        current = self.fn(values)
        if not self.begun:
            self.begun, self.start_value = True, current
        values[self.name] = self.start_value

    def _over_time(self, now: Tick, values: dict[str, Any]) -> None:
        """prev, rose, fell, changed: from the value now and the one at the tick before (at the first, its own)."""
        assert self.fn is not None and self.edge is not None
        current = self.fn(values)
        previous = self.last if self.begun else current
        self.last, self.begun = current, True
        values[self.name] = self.edge(current, previous)

    def anchor(self, values: dict[str, Any]) -> None:
        """``start(e)``: from this tick on, e's value at this tick (called after the terms of the tick)."""
        if self.op == "start" and self.fn is not None:
            self.start_value = self.fn(values)
            values[self.name] = self.start_value


#: The method of :class:`Term` that updates each kind of term (the others: ``_event``).
_UPDATES = {"paused": "_hold", "suspended": "_hold", "outcome": "_outcome", "start": "_start", "prev": "_over_time",
            "rose": "_over_time", "fell": "_over_time", "changed": "_over_time"}
#: A term over time from (the value now, the value at the tick before).
_EDGES: dict[str, Callable[[Any, Any], Any]] = {
    "prev": lambda current, previous: previous,
    "rose": lambda current, previous: current is True and previous is not True,
    "fell": lambda current, previous: current is False and previous is not False,
    "changed": lambda current, previous: current != previous or type(current) is not type(previous),
}


def _held(state: Any, paused: bool) -> bool:
    """An active state held by a pause (its own or an ancestor's), or (``paused`` false) suspended: frozen while an
    exception sequence runs, and not by a pause."""
    s = state
    while s is not None:
        record = wiring(s)
        if record.paused:
            return paused
        s = record.region.owner if record.region is not None else None
    return False if paused else wiring(state).frozen_since is not None


class Formula:
    """A compiled formula: its terms (inner first) and the function of the rewritten tree."""

    __slots__ = ("text", "terms", "fn", "names", "deps", "transient", "every_tick")

    def __init__(self, text: str, terms: list[Term], fn: Callable[[dict[str, Any]], Any],
                 names: list[tuple[str, str]]) -> None:
        self.text = text
        self.terms = terms
        self.fn = fn
        #: the variables, signals and terms it reads, for messages: (shown name, value name)
        self.names = names
        #: what its value can change with: the names it reads and the kinds of events its state terms look at
        #: (``@entries``, ``@active``, ``@fired``, ``@outcome``, ``@paused``); a tick where none changed leaves it
        #: as it was
        self.deps = frozenset(formula_names(text)).union(*(_EVENTS[t.op] for t in terms if t.op in _EVENTS))
        #: it reads a value of one tick only (an edge, prev, an entry): the tick after a change is looked at too
        self.transient = any(t.op not in ("active", "outcome", "start", "paused", "suspended") for t in terms)
        #: car readings move every tick; a suspension ends with no event to see: both are looked at each tick
        self.every_tick = any(t.op == "suspended" for t in terms) or any(n.startswith("car_") for n in self.deps)

    def fresh(self) -> Formula:
        """A copy for a new run: the same compiled functions, terms with no history (compiled once, at load)."""
        copy = object.__new__(Formula)
        copy.text, copy.fn, copy.names = self.text, self.fn, self.names
        copy.deps, copy.transient, copy.every_tick = self.deps, self.transient, self.every_tick
        copy.terms = [Term(t.name, t.text, t.op, t.kind, t.paths, t.fn) for t in self.terms]
        return copy

    def bind(self, states_by_path: dict[str, Any]) -> None:
        """The states ``paused`` and ``suspended`` look at, in the run's machine."""
        for t in self.terms:
            if t.op in ("paused", "suspended"):
                t.states = [states_by_path[p] for p in sorted(t.paths) if p in states_by_path]

    def step(self, now: Tick, values: dict[str, Any]) -> Any:
        """The formula's value at this tick (its terms updated first)."""
        for term in self.terms:
            term.update(now, values)
        return self.fn(values)

    def anchor(self, values: dict[str, Any]) -> None:
        for term in self.terms:
            if term.op == "start":
                term.anchor(values)

    def shown(self, values: dict[str, Any]) -> str:
        """``name = value`` of what the formula reads (terms by their text)."""
        parts = []
        for shown, key in self.names:
            value = values.get(key, "unset")
            try:
                text = json.dumps(value, ensure_ascii=False) if key in values else "unset"
            except (TypeError, ValueError):
                text = repr(value)
            parts.append(f"{shown} = {text}")
        return ", ".join(parts)

    def state_paths(self) -> set[str]:
        return {p for t in self.terms if t.op == "outcome" for p in t.paths}


def state_argument(node: Node) -> str | None:
    """The state a predicate names: ``grip``, ``run/work/grip`` (parsed as a division of names) or a quoted string."""
    if node.op == "var":
        return str(node.args[0])
    if node.op == "const" and isinstance(node.args[0], str):
        return node.args[0]
    if node.op == "/" and node.args[1].op == "var":
        left = state_argument(node.args[0])
        return None if left is None else f"{left}/{node.args[1].args[0]}"
    return None


def matching_paths(name: str, paths: list[str]) -> list[str]:
    """The state paths ``name`` matches: by id or the end of the path; ``X/*`` every state below X."""
    if name.endswith("/*"):
        bases = [p for p in paths if state_matches(name[:-2], p)]
        return [p for p in paths if any(p.startswith(b + "/") for b in bases)]
    return [p for p in paths if state_matches(name, p)]


def compile_formula(text: str, kinds: dict[str, str], paths: list[str], want: str | None = BOOL) -> Formula:
    """Parse, check and compile ``text``; :class:`FormulaError` (or the language's :class:`ExprError`) when it cannot
    be used: a state no path matches, a temporal term over the wrong kind, an unknown variable (with suggestions)."""
    tree = parse(text, TEMPORAL_FUNCTIONS)
    terms: list[Term] = []
    extra: dict[str, str] = {}
    ids = sorted({p.rsplit("/", 1)[-1] for p in paths} | set(paths))

    def rewrite(node: Node) -> Node:
        if node.op == "call" and node.args[0] in STATE_TERMS + TIME_TERMS:
            fname, arg = node.args[0], node.args[1]
            name = f"{_PREFIX}{next(_NAMES)}"
            shown = unparse(node)
            if fname in STATE_TERMS:
                state = state_argument(arg)
                if state is None:
                    raise FormulaError(f"{fname}() takes a state: an id, a path (run/work) or a quoted name "
                                       f"('cycle/*' for any state below cycle)", arg.column)
                found = matching_paths(state.strip(), paths)
                if not found:
                    hint = did_you_mean(state, ids, n=3) or "states: " + first_few(paths, 12)
                    raise FormulaError(f"the machine has no state '{state}'", arg.column, hint)
                kind = TEXT if fname == "outcome" else BOOL
                terms.append(Term(name, shown, fname, kind, frozenset(found)))
            else:
                inner = rewrite(arg)
                part = compile_tree(inner, text, {**kinds, **extra})
                if fname in ("rose", "fell") and part.kind not in (BOOL, ANY):
                    raise FormulaError(f"{fname}() takes a true/false value, this is {part.kind}", arg.column,
                                       f"for a number write changed(...) or e.g. {fname}(x > 0)")
                kind = part.kind if fname in ("prev", "start") else BOOL
                terms.append(Term(name, shown, fname, kind, fn=part.fn))
            extra[name] = terms[-1].kind
            return Node("var", (name,), node.column)
        if node.op in ("const", "var"):
            return node
        return Node(node.op, tuple(rewrite(a) if isinstance(a, Node) else a for a in node.args), node.column)

    rewritten = rewrite(tree)
    try:
        compiled = compile_tree(rewritten, text, {**kinds, **extra}, want)
    except ExprError as exc:
        if exc.message.startswith("unknown variable"):
            raise FormulaError(exc.message, exc.column, _unknown_name_hint(exc.message.split("'")[1], kinds, ids)) \
                from None
        raise
    return Formula(text, terms, compiled.fn, _names_written(rewritten, terms))


def _unknown_name_hint(unknown: str, kinds: dict[str, str], ids: list[str]) -> str:
    """What to write instead of a name a formula reads that is no variable: a state's term, a name spelt alike, or
    the names there are."""
    if unknown in ids:
        return f"'{unknown}' is a state: write active({unknown}) or entered({unknown})"
    known = sorted(kinds) + list(TEMPORAL_FUNCTIONS)
    return did_you_mean(unknown, known, n=3) or "names: " + (", ".join(sorted(kinds)[:12]) or "none")


def _names_written(tree: Node, terms: list[Term]) -> list[tuple[str, str]]:
    """What a rewritten formula reads, in the order it is written (depth first, left to right): (shown name, value
    name), a term shown by its text."""
    by_name = {t.name: t.text for t in terms}
    names: list[tuple[str, str]] = []
    todo = [tree]
    while todo:
        node = todo.pop()
        if node.op == "var":
            key = node.args[0]
            shown = by_name.get(key, key)
            if (shown, key) not in names:
                names.append((shown, key))
        todo += [a for a in reversed(node.args) if isinstance(a, Node)]
    return names


def tree_names(tree: Node, skip: tuple[str, ...] = ()) -> list[str]:
    """The variable names an expression tree reads, in order of first use; not those inside calls of ``skip``."""
    out: list[str] = []
    todo = [tree]
    while todo:
        node = todo.pop(0)
        if node.op == "var" and node.args[0] not in out:
            out.append(node.args[0])
        if node.op == "call" and node.args[0] in skip:
            continue
        todo += [a for a in node.args if isinstance(a, Node)]
    return out


def formula_names(text: str) -> list[str]:
    """The variable names a formula reads (not the states its state terms name), in order of first use."""
    return tree_names(parse(text, TEMPORAL_FUNCTIONS), STATE_TERMS)


# -- the watches: one per temporal expectation ---------------------------------------------------------------
@dataclass
class Verdict:
    """Why a watch failed: the message and the tick it diverged at."""

    message: str
    tick: int


class Watch:
    """A temporal expectation checked online.

    ``mode`` is ``always``, ``never``, ``eventually`` or ``at`` (one tick: ``first``); ``body`` the formula;
    ``until`` (with ``always``) the formula whose first holding tick ends the obligation (it must hold at some tick);
    ``after`` the trigger: from each tick it holds (or only its ``nth`` time), the body is checked over the next
    ``span`` ticks (the trigger's tick included; to the end of the window without ``span``). ``first`` and ``last``
    bound the ticks looked at. ``eventually`` counts the ticks the body holds at: an entry or an edge is one tick, a
    level (``paused(X)``) as many ticks as it lasts (count its ``rose``).

    The run steps a watch only at the ticks where something its formulas read changed (their ``deps``), the tick
    after such a change when they read one tick's values (edges, ``prev``, entries), its window's first tick, and
    every tick when they read car readings or held states: between two of those its formulas keep their values, so
    what holds at the last tick looked at holds until the next.
    """

    def __init__(self, index: int, mode: str, body: Formula, first: int, last: int, *,
                 until: Formula | None = None, after: Formula | None = None, span: int | None = None,
                 nth: int | None = None, count: Count | None = None,
                 at: list[int] | None = None, label: str | None = None) -> None:
        self.index = index
        self.mode = mode
        self.body = body
        self.first = first
        self.last = last
        self.until = until
        self.after = after
        self.span = span
        self.nth = nth
        self.count = count or Count()
        self.at = at
        self.label = label or mode
        self.verdict: Verdict | None = None
        self.done = False
        #: eventually: the runs of ticks it held at (first, last), and the first tick of the run going on (-1: none)
        self.runs: list[tuple[int, int]] = []
        self.holding = -1
        #: eventually after a trigger: the ticks it held at
        self.hits: list[int] = []
        self.triggers = 0
        #: open obligations of an ``after``: (trigger tick, last tick)
        self.open: list[tuple[int, int]] = []
        #: the window began: the body was looked at (and its start() anchored)
        self.checked = False
        #: mode "at": (tick, held, values shown) at the last tick looked at up to ``first``
        self.seen: tuple[int, bool, str] | None = None
        self.formulas = [f for f in (body, until, after) if f is not None]
        self.deps = frozenset().union(*(f.deps for f in self.formulas))
        self.force = True
        self.every_tick = any(f.every_tick for f in self.formulas)
        #: with ``after`` and nothing open, the body is not looked at: only the trigger (and a body that reads one
        #: tick's values, which needs every tick it changes); ``until`` never comes with ``after``
        idle: Watch | Formula = self if after is None or body.transient else after
        self.idle_deps, self.idle_every = idle.deps, idle.every_tick
        #: the first tick looked at: ``at`` looks at every tick up to its own, to know the machine as it ended
        self.begin = 0 if mode == "at" else first
        #: the check of each tick of the window, for the mode
        self._check: Callable[[int, Any, Any, Any, dict[str, Any], Callable[[int], str]], None] = getattr(
            self, "_step_after" if after is not None else "_step_until" if until is not None else f"_step_{mode}")
        #: what it is stepped for now: with an ``after`` and nothing open, the idle ones
        self.live_deps = self.idle_deps
        self.live_every = self.idle_every
        self.transient = any(f.transient for f in self.formulas)
        #: the last values shown for a failure found later (an ``after`` whose span ran out between two ticks)
        self._shown = ""

    def fail(self, message: str, tick: int, values: dict[str, Any] | None = None) -> None:
        shown = self.body.shown(values) if values is not None else self._shown
        self.verdict = Verdict(message + (f" ({shown})" if shown else ""), tick)
        self.done = True

    def step(self, tick: int, now: Tick, values: dict[str, Any], at: Callable[[int], str]) -> None:
        """Update the terms at this tick and check the expectation (``at`` formats a tick for messages)."""
        try:
            f = self.body.step(now, values)
            g = self.until.step(now, values) if self.until is not None else None
            trig = self.after.step(now, values) if self.after is not None else None
        except (ExprRuntimeError, TypeError, ValueError, ArithmeticError, KeyError) as exc:
            if self.begin <= tick <= self.last:
                self.fail(f"'{self.body.text}' could not be evaluated at {at(tick)}: {exc}", tick)
            return
        if self.begin <= tick <= self.last:
            if not self.checked:  # the window's first tick: start() reads its values
                self.checked = True
                self.body.anchor(values)
                f = self.body.fn(values)
            self._check(tick, f, g, trig, values, at)

    def _step_at(self, tick: int, f: Any, g: Any, trig: Any, values: dict[str, Any],
                 at: Callable[[int], str]) -> None:
        """``at``: the formula at its tick; if the run ends before it, the machine as it ended."""
        self.seen = (tick, f is True, "" if f is True else self.body.shown(values))

    def _step_until(self, tick: int, f: Any, g: Any, trig: Any, values: dict[str, Any],
                    at: Callable[[int], str]) -> None:
        """``always`` ... ``until``: done when ``until`` holds, failed when the body is false before."""
        if g is True:
            self.done = True
        elif f is not True:
            assert self.until is not None
            self.fail(f"'{self.body.text}' is false at {at(tick)}, before '{self.until.text}' held", tick, values)

    def _step_always(self, tick: int, f: Any, g: Any, trig: Any, values: dict[str, Any],
                     at: Callable[[int], str]) -> None:
        if f is not True:
            self.fail(f"'{self.body.text}' is false at {at(tick)}", tick, values)

    def _step_never(self, tick: int, f: Any, g: Any, trig: Any, values: dict[str, Any],
                    at: Callable[[int], str]) -> None:
        if f is True:
            self.fail(f"'{self.body.text}' holds at {at(tick)}", tick, values)

    def _step_eventually(self, tick: int, f: Any, g: Any, trig: Any, values: dict[str, Any],
                         at: Callable[[int], str]) -> None:
        """``eventually``: the runs of ticks it holds at."""
        if f is True:
            if self.holding < 0:
                self.holding = tick
        elif self.holding >= 0:
            self.runs.append((self.holding, tick - 1))  # it held up to the tick before this one
            self.holding = -1

    def _step_after(self, tick: int, f: Any, g: Any, trig: Any, values: dict[str, Any],
                    at: Callable[[int], str]) -> None:
        """A step with a trigger (``after``): open a span where it holds, check the body in the open spans."""
        if self.open and self.mode == "eventually" and self.open[0][1] < tick:  # its span ran out since the last look
            self.fail(self._ran_out(self.open[0], at), self.open[0][1])
            return
        self.open = [o for o in self.open if o[1] >= tick]
        if trig is True:
            f = self._triggered(tick, f, values)
        if self.open:
            self._check_span(tick, f, values, at)
        self.live_deps, self.live_every = (self.deps, self.every_tick) if self.open else \
            (self.idle_deps, self.idle_every)

    def _triggered(self, tick: int, f: Any, values: dict[str, Any]) -> Any:
        """The trigger held: counted, and (each time, or its ``nth`` time) a span opens at this tick, with the
        body's ``start()`` anchored at it; the body's value."""
        self.triggers += 1
        if self.nth is not None and self.triggers != self.nth:
            return f
        self.body.anchor(values)
        self.open.append((tick, self.last if self.span is None else tick + self.span))
        return self.body.fn(values)

    def _check_span(self, tick: int, f: Any, values: dict[str, Any], at: Callable[[int], str]) -> None:
        """The body at a tick of the open span that began first."""
        assert self.after is not None
        since = self.open[0][0]
        mode = self.mode
        if mode == "eventually":
            if f is True:
                self.hits.append(tick)
                self.open = []
            elif self.open[0][1] == tick:
                self.fail(self._ran_out((since, tick), at), tick, values)
            else:
                self._shown = self.body.shown(values)
        elif (f is True) is (mode == "never"):  # always: false breaks it; never: true does
            self.fail(f"'{self.body.text}' {'holds' if f is True else 'is false'} at {at(tick)}, {tick - since} "
                      f"tick(s) after '{self.after.text}' held at {at(since)}", tick, values)

    def _ran_out(self, span: tuple[int, int], at: Callable[[int], str]) -> str:
        """An ``eventually`` whose span ended with the body never true."""
        assert self.after is not None
        return (f"'{self.body.text}' did not hold within {self.span} tick(s) after '{self.after.text}' held at "
                f"{at(span[0])}; at {at(span[1])}")

    def _after_verdict(self, end: int, last: int, at: Callable[[int], str]) -> Verdict | None:
        """The verdict of a triggered expectation: its trigger never held (enough), or its last span ran out."""
        assert self.after is not None
        text = self.body.text
        if self.triggers < (self.nth or 1):  # fewer times than the nth (or than once)
            need = "at all" if self.nth is None else f"{self.nth} times (it held {self.triggers} times)"
            return Verdict(f"'{self.after.text}' never held {need}, so '{text}' was never checked after it", last)
        if self.mode == "eventually" and self.open:
            since, until = self.open[0]
            if until <= last:
                return Verdict(self._ran_out(self.open[0], at) + (f" ({self._shown})" if self._shown else ""), until)
            return Verdict(f"'{text}' did not hold after '{self.after.text}' held at {at(since)}; the run "
                           f"ended at {at(end)}", last)
        return None

    def finish(self, end: int, at: Callable[[int], str], times: Callable[[int], str]) -> Verdict | None:
        """The verdict once the run has ended at tick ``end``."""
        if self.verdict is not None or (self.done and self.until is not None):
            return self.verdict
        last = min(self.last, end)
        if self.mode == "at":
            return self._at_verdict(end, at)
        if not self.checked:
            return Verdict(f"the run ended at {at(end)}, before the window started: '{self.body.text}' was never "
                           "checked", end)
        if self.until is not None:
            return Verdict(f"'{self.until.text}' never held (until it does, '{self.body.text}' must hold); the run "
                           f"ended at {at(end)}" if self.last >= end else
                           f"'{self.until.text}' never held by the end of the window at {at(last)}", last)
        if self.after is not None:
            return self._after_verdict(end, last, at)
        if self.mode != "eventually":
            return None
        return self._eventually_verdict(last, at, times)

    def _at_verdict(self, end: int, at: Callable[[int], str]) -> Verdict | None:
        """Mode ``at``: the formula at its tick (or, if the run ended before, at the last tick)."""
        if self.seen is None or self.seen[1]:
            return None
        tick = min(self.first, end)
        ended = "" if self.first <= end else f" (the run ended before, at {at(end)})"
        shown = self.seen[2]
        return Verdict(f"'{self.body.text}' is false at {at(tick)}{ended}" + (f" ({shown})" if shown else ""), tick)

    def _eventually_verdict(self, last: int, at: Callable[[int], str], times: Callable[[int], str]) -> Verdict | None:
        """``eventually``: the ticks it held at, against ``at`` (exactly those), a count, or at least one."""
        runs = self.runs + ([(self.holding, last)] if self.holding >= 0 else [])
        n = sum(b - a + 1 for a, b in runs)
        hits = [t for a, b in runs for t in range(a, min(b, a + 100) + 1)][:100]
        shown = first_few([times(t) for t in hits[:7]], 6)  # the seventh only says there are more
        if self.at is not None:
            return None if hits == self.at else self._exact_ticks_verdict(hits, shown, last, times)
        if self.count == Count():
            return None if n else Verdict(f"'{self.body.text}' never held (up to {at(last)})", last)
        return None if within(n, self.count) else self._count_verdict(n, hits, shown, last)

    def _count_verdict(self, n: int, hits: list[int], shown: str, last: int) -> Verdict:
        """``eventually`` held at ``n`` ticks, not as many as its count wants; the verdict at the tick one too many
        (or at the end)."""
        c = self.count
        limit = c.count if c.count is not None else c.max
        tick = hits[limit] if limit is not None and n > limit and limit < len(hits) else last
        return Verdict(f"expected '{self.body.text}' to hold at {bounds(c, _ticks)}, it held at {_ticks(n)}"
                       + (f" (at {shown} s)" if n else ""), tick)

    def _exact_ticks_verdict(self, hits: list[int], shown: str, last: int, times: Callable[[int], str]) -> Verdict:
        """``eventually`` with ``at``: it held at other ticks than those listed; the verdict at the first that
        differs."""
        assert self.at is not None
        differs = next((a for a, b in zip(hits, self.at, strict=False) if a != b),
                       hits[len(self.at)] if len(hits) > len(self.at) else last)
        return Verdict(f"expected '{self.body.text}' to hold at {', '.join(times(t) for t in self.at)} s, it "
                       f"held at {shown or 'no tick'}" + (" s" if hits else ""), min(differs, last))

@dataclass(frozen=True)
class Count:
    """How often something is expected: exactly ``count`` times, at least ``min``, at most ``max`` (``None``: no
    bound)."""

    count: int | None = None
    min: int | None = None
    max: int | None = None


def unbounded(c: Any) -> bool:
    """``c`` gives none of ``count``, ``min`` and ``max`` (an event expected at least once)."""
    return (c.count, c.min, c.max) == (None, None, None)


def within(n: int, c: Any) -> bool:
    """Whether ``n`` meets ``c``'s ``count``, ``min`` and ``max`` (each ``None``: no bound)."""
    return (c.count is None or n == c.count) and (c.min is None or n >= c.min) and (c.max is None or n <= c.max)


def bounds(c: Any, words: Callable[[int], str]) -> str:
    """``c``'s bounds in words: "exactly N", or "at least A and at most B" (a number in ``words``)."""
    if c.count is not None:
        return f"exactly {words(c.count)}"
    return " and ".join(x for x in (f"at least {words(c.min)}" if c.min is not None else "",
                                    f"at most {words(c.max)}" if c.max is not None else "") if x)


def _ticks(n: int) -> str:
    return "1 tick" if n == 1 else f"{n} ticks"


__all__ = ["STATE_TERMS", "TEMPORAL_FUNCTIONS", "TIME_TERMS", "Count", "Formula", "FormulaError", "Term", "Tick",
           "Verdict", "Watch", "bounds", "compile_formula", "formula_names", "matching_paths", "state_argument",
           "unbounded", "within"]
