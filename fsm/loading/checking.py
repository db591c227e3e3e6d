"""Checking, the third load stage: the semantics of a parsed document. It reports problems and changes nothing.

Per level: duplicate ids, the initial state, transition endpoints, transitions out of final states, ``Finished``
out of states that can never finish (or on an outcome they never have), unreachable states (a warning). Over the
whole tree: state paths named by transitions and conditions, declared inputs, the sequencer's references, the
kinds of blackboard variables and every expression (``set``, guards, conditions, monitors), which are typed and
compiled here. What the later stages need of this work (the variables' kinds, the compiled expressions) is
handed on in an :class:`Analysis`.
"""

from __future__ import annotations

import difflib
import json
import operator
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from itertools import chain
from typing import Any

from fsm.loading.outcomes import can_finish, reachable, state_outcomes
from fsm.model import expr as E
from fsm.model.document import ConditionSpec, MachineSpec, Source, StateSpec, TransitionSpec, element_label
from fsm.model.jsonpos import escape
from fsm.model.paths import resolve_path
from fsm.model.problems import Problems
from fsm.runtime.transition import checks_document, tests_variables
from fsm.sequencer.checks import check_sequences


@dataclass(frozen=True)
class Analysis:
    """What checking found out about a document, for the compile stage: the kind of every blackboard variable
    (``number``, ``true/false``, ``text`` or ``any``) and each expression compiled, by ``(file, pointer)``."""

    kinds: Mapping[str, str]
    expressions: Mapping[tuple[str | None, str], E.Compiled]
    #: every state path of the machine
    paths: frozenset[str]
    #: the kind each expression was checked for (``E.BOOL``, ``E.NUMBER`` or None), by the same keys: with the
    #: text and ``kinds`` it compiles the expression again (how the plan cache stores an expression as data)
    wants: Mapping[tuple[str | None, str], str | None] = field(default_factory=dict)

    def expression(self, source: Source, pointer: str) -> E.Compiled:
        return self.expressions[(source.name, pointer)]


@dataclass(frozen=True)
class Assignment:
    """One ``variable = value`` a document writes: in a state's or transition's ``set`` or a SetVar's ``assign``."""

    target: str
    value: Any
    source: Source
    pointer: str
    element: str


def check(root: MachineSpec, problems: Problems) -> Analysis:
    """Check ``root`` and every level below it; problems go to ``problems``."""
    levels = list(root.levels())
    for level in levels:
        if level.written:
            check_level(level, problems)
    states, transitions, paths = root.scoped()
    variables: dict[str, Any] = {}
    for level in levels:
        for key, value in level.vars.items():
            variables.setdefault(key, value)
    check_sequences(root, problems, can_finish)
    exprs = _Expressions(states, transitions, variables, paths, problems)
    kinds, expressions = exprs.check()
    if root.inputs is not None:
        check_inputs(root, problems)
    classes = set(map(_CLS, map(_FIRST, transitions)))
    for tr in _of_classes(transitions, {cls for cls in classes if checks_document(cls)}):
        found = tr.cls.check_document(tr.params, variables)
        if found is not None:
            suffix, message = found
            problems.add(message, tr.source, tr.pointer + suffix, element=tr.label,
                         hint="change the value or the variable's initial value in 'vars'")
    check_variable_kinds(_of_classes(transitions, {cls for cls in classes if tests_variables(cls)}), variables,
                         problems)
    referring = {cls for cls in classes if cls.state_refs}
    for tr, scope in transitions if referring else ():
        for key in tr.cls.state_refs:
            value = getattr(tr.params, key)
            if resolve_path(value, scope, paths) is None:
                problems.add(f"'{key}' names no state: '{value}'", tr.source, f"{tr.pointer}/{key}",
                             element=tr.label, hint=PATH_HINT)
    return Analysis(kinds, expressions, paths, exprs.wants)


def _of_classes(scoped: list[tuple[TransitionSpec, str]], classes: set[type[Any]]) -> list[TransitionSpec]:
    """The transitions of ``scoped`` whose class is one of ``classes``, in order (none looked at when it is empty)."""
    return [tr for tr, _scope in scoped if tr.cls in classes] if classes else []


_FIRST = operator.itemgetter(0)
_ID = operator.attrgetter("id")


PATH_HINT = ("a path of ids joined by '/', relative to this machine or an enclosing one, or absolute with a "
             "leading '/'")


def path_of(st: StateSpec, prefix: str) -> str:
    return f"{prefix}/{st.id}" if prefix else st.id


# -- one level ------------------------------------------------------------------------------------------------
def check_level(spec: MachineSpec, problems: Problems) -> None:
    """Ids, initial state, endpoints, finishing, transitions out of final states, reachability.

    Ids and endpoints are checked on the elements as written, so an element with a bad parameter still gets
    its other errors reported in the same run.
    """
    first_at = _check_ids(spec, problems)
    states = spec.states
    by_id: dict[str, StateSpec]
    if len(first_at) == len(states) == len(spec.raw_states):  # every element parsed, no id twice: in order
        by_id = dict(zip(first_at, states, strict=True))
    else:
        by_id = {}
        for st in states:
            by_id.setdefault(st.id, st)
    if spec.envelope_ok and spec.initial not in first_at:
        problems.add(f"initial state '{spec.initial}' is not a state of this machine", spec.source,
                     spec.initial_pointer, hint=_choices(spec.initial, first_at))
    whole = _whole(spec, first_at)
    if not whole:
        _check_endpoints(spec, first_at, problems)
    # the transitions against their sources only where a type asks for it: set operations over the level's classes
    # first, not a loop over its transitions (a plain level has no final state with a way out and no Finished)
    if any(cls.is_final for cls in set(map(_CLS, states))) or \
            any(cls.needs_finishing_source for cls in set(map(_CLS, spec.transitions))):
        for tr in spec.transitions:
            source = by_id.get(tr.params.from_)
            if source is not None and (source.cls.is_final or tr.cls.needs_finishing_source):
                _check_source(tr, source, problems)
    # reachability along transitions as drawn; not where an arrow is broken (an end that names no state, or a
    # transition without two text ends): its error is the one to fix, and the states behind it would each be
    # reported unreachable as a consequence (a ring with one bad "to" gave 96 warnings after its one error)
    if spec.initial in by_id and whole:
        reached = reachable(spec)
        if not reached.issuperset(by_id):
            for st in states:
                if st.id not in reached and by_id.get(st.id) is st:
                    problems.add(f"unreachable from the initial state '{spec.initial}'", spec.source, st.pointer,
                                 element=st.label, severity="warning", hint="add a transition into it or remove it")


_CLS = operator.attrgetter("cls")


def _whole(spec: MachineSpec, first_at: dict[str, int]) -> bool:
    """Every transition element of the level has two text ends, each a state of the level."""
    return len(spec.edges) == len(spec.raw_transitions) and first_at.keys() >= set(chain.from_iterable(spec.edges))


def _check_ids(spec: MachineSpec, problems: Problems) -> dict[str, int]:
    """Duplicate ids among the state elements as written; each id with the index of its first element."""
    if len(spec.states) == len(spec.raw_states):  # every element parsed: each id is a string, its state's
        ids = list(map(_ID, spec.states))
        unique = dict(zip(ids, range(len(ids)), strict=True))
        if len(unique) == len(ids):
            return unique
    base = spec.pointer
    first_at: dict[str, int] = {}
    for i, raw in enumerate(spec.raw_states):
        sid = raw.get("id") if isinstance(raw, dict) else None
        if not isinstance(sid, str):
            continue
        if sid in first_at:
            problems.add(f"duplicate id '{sid}' (first used at {base}/states/{first_at[sid]})", spec.source,
                         f"{base}/states/{i}/id", element=f"state '{sid}'",
                         hint="ids must be unique within one machine level")
        else:
            first_at[sid] = i
    return first_at


def _check_endpoints(spec: MachineSpec, first_at: dict[str, int], problems: Problems) -> None:
    """Each transition element's ``from`` and ``to`` name a state of the level (called when :func:`_whole`, one
    set operation for the level, says that one may not)."""
    for i, raw in enumerate(spec.raw_transitions):
        if not isinstance(raw, dict):
            continue
        ends = raw.get("from"), raw.get("to")
        if type(ends[0]) is str and type(ends[1]) is str and ends[0] in first_at and ends[1] in first_at:
            continue  # both ends known (the usual case, answered without the loop below)
        for key in ("from", "to"):
            ref = raw.get(key)
            if isinstance(ref, str) and ref and ref not in first_at:
                problems.add(f"'{key}' names unknown state '{ref}'", spec.source,
                             f"{spec.pointer}/transitions/{i}/{key}", element=element_label("transition", raw),
                             hint=_choices(ref, first_at))


def _check_source(tr: TransitionSpec, source: StateSpec, problems: Problems) -> None:
    """A transition against its source: not out of a final state; a ``Finished`` only out of a state that can
    finish with the outcome it names."""
    if source.cls.is_final:
        problems.add(f"transition out of final state '{source.id}'", tr.source, tr.pointer, element=tr.label,
                     hint="a final state ends its machine; remove the transition or the final state")
        return
    if not tr.cls.needs_finishing_source:
        return
    outcomes = state_outcomes(source)
    if outcomes is not None and not outcomes:
        problems.add(f"'{source.id}' ({source.type}) can never finish, so this {tr.type} transition can never fire",
                     tr.source, tr.pointer, element=tr.label, hint=_never_finishes_hint(source))
        return
    wanted = getattr(tr.params, "outcome", None)
    if wanted is not None and outcomes is not None and wanted not in outcomes:
        hint = "its outcomes: " + ", ".join(sorted(outcomes))
        if source.cls.is_composite and len(source.subs) > 1:
            hint += _join_hint(source)
        problems.add(f"'{source.id}' never finishes with outcome '{wanted}'", tr.source, tr.pointer + "/outcome",
                     element=tr.label, hint=hint)


# -- the whole tree -------------------------------------------------------------------------------------------
def check_inputs(root: MachineSpec, problems: Problems) -> None:
    """With declared ``inputs``: every signal read (by a state, transition or condition) is one of them."""
    declared = set(root.inputs or ())
    for kind, params, source, ptr, owner in signal_readers(root):
        element = owner.label
        for key in getattr(kind, "signal_refs", ()):
            value = getattr(params, key, None)
            if isinstance(value, str) and value not in declared:
                what = "pause button" if key == "pause_signal" else "signal"
                close = difflib.get_close_matches(value, sorted(declared), n=2)
                problems.add(f"{what} '{value}' is not one of the machine's inputs "
                             f"({', '.join(sorted(declared)) or 'none'})", source, f"{ptr}/{key}", element=element,
                             hint=("did you mean " + " or ".join(f"'{c}'" for c in close) + "?") if close else
                             f"add '{value}' to the top level's \"inputs\" if the machine's environment provides it")


def signal_readers(root: MachineSpec) -> Iterator[tuple[type[Any], Any, Source, str, StateSpec | TransitionSpec]]:
    """``(class, params, source, pointer, element)`` of every state, transition and condition of the tree; the
    element is the state or transition (a condition's: the one it belongs to)."""
    for level in root.levels():
        for st in level.states:
            yield st.cls, st.params, st.source, st.pointer, st
            if st.conditions:
                for cs in conditions_of(st.conditions):
                    yield cs.cls, cs.params, st.source, cs.pointer, st
        for tr in level.transitions:
            yield tr.cls, tr.params, tr.source, tr.pointer, tr
            if tr.conditions:
                for cs in conditions_of(tr.conditions):
                    yield cs.cls, cs.params, tr.source, cs.pointer, tr


def signal_names(spec: MachineSpec | None) -> set[str]:
    """The input signal names a checked machine reads, at every level: the parameters its transition (and state
    and condition) types declare in ``signal_refs`` (``Signal.signal``, a Sequence's ``pause_signal``). ``fsmctl run
    --signal`` warns about a name outside this set; a plugin type that reads signals declares its parameter there."""
    names: set[str] = set()
    if spec is None:
        return names
    # each element's class is looked at directly, not through signal_readers: its tuple and generator step per
    # element are about 1 % of a cold load of the 1000-state ring, and a plain ring reads no signal at all
    for level in spec.levels():
        for elements in (level.states, level.transitions):
            for el in elements:
                if el.cls.signal_refs:
                    _signals_of(el.cls, el.params, names)
                if el.conditions:
                    for cs in conditions_of(el.conditions):
                        if cs.cls.signal_refs:
                            _signals_of(cs.cls, cs.params, names)
    return names


def _signals_of(cls: type[Any], params: Any, names: set[str]) -> None:
    """Adds the signal names ``params`` gives in the parameters ``cls.signal_refs`` names."""
    for key in cls.signal_refs:
        value = getattr(params, key, None)
        if isinstance(value, str):
            names.add(value)


def conditions_of(conditions: Mapping[str, ConditionSpec]) -> Iterator[ConditionSpec]:
    """Every condition object in ``conditions`` and nested in them."""
    for cs in conditions.values():
        yield from cs.walk()


def check_variable_kinds(transitions: list[TransitionSpec], variables: dict[str, Any], problems: Problems) -> None:
    """Every comparison of a blackboard variable uses one kind of value (true/false, number or text),
    the kind of its initial value in ``vars`` or else of the first comparison: ``true == 1`` or
    ``5 == "5"`` would silently be true or false forever. true/false are compared with == and != only."""
    first: dict[str, tuple[str, str]] = {}  # variable -> (kind, where that kind comes from)
    for name, value in variables.items():
        first[name] = (value_kind(value), f"its initial value in 'vars' is {json.dumps(value)[:40]}")
    for tr in transitions:
        test = tr.cls.variable_test(tr.params)
        if test is None:
            continue
        name, op, value = test
        kind = value_kind(value)
        if kind == "true/false" and op not in ("==", "!="):
            problems.add(f"'{op}' on true/false: true/false values are only equal or not", tr.source,
                         tr.pointer + "/op", element=tr.label, hint="use == or !=")
            continue
        known = first.get(name)
        if known is None:
            first[name] = (kind, f"{tr.label} at {tr.pointer or '/'} compares it with {json.dumps(value)}")
            continue
        held, origin = known
        if held != kind:
            problems.add(f"cannot compare variable '{name}' with {json.dumps(value)} ({_a(kind)}): it holds "
                         f"{_a(held)} ({origin})", tr.source, tr.pointer + "/value", element=tr.label,
                         hint=f"compare with {_a(held)} (true/false is not a number, \"5\" is not 5), "
                              "or change the variable's initial value")


# -- expressions ----------------------------------------------------------------------------------------------
class _Expressions:
    """Every ``set``, guard, condition expression and step condition of a tree, typed against the variables'
    kinds and compiled. A variable is known when ``vars`` gives it or some ``set`` assigns it; its kind is that
    of its initial value, else of what the assignments give it (``any`` where that cannot be decided)."""

    def __init__(self, states: list[tuple[StateSpec, str]], transitions: list[tuple[TransitionSpec, str]],
                 variables: dict[str, Any], paths: frozenset[str], problems: Problems) -> None:
        self.states = states
        self.transitions = transitions
        self.variables = variables
        self.paths = paths
        self.problems = problems
        self.compiled: dict[tuple[str | None, str], E.Compiled] = {}
        self.wants: dict[tuple[str | None, str], str | None] = {}
        self.kinds: dict[str, str] = {}
        #: the states' and transitions' specs without their scopes (for the passes over all of them)
        self.state_specs: list[StateSpec] = list(map(_FIRST, states))
        self.transition_specs: list[TransitionSpec] = list(map(_FIRST, transitions))

    def check(self) -> tuple[dict[str, str], dict[tuple[str | None, str], E.Compiled]]:
        assignments = list(self.assignments())
        self.kinds = self.infer_kinds(assignments)
        for a in assignments:
            self.assignment(a)
        for st, scope in self.states if _any_step_expressions(self.state_specs) else ():
            p = st.params
            if p.precondition is not None or p.until is not None or p.monitors is not None \
                    or st.cls.condition_fields:
                self.step_conditions(st, scope)
            if isinstance(p.timeout, str):
                self.compile(p.timeout, st.source, st.pointer + "/timeout", st.label, E.NUMBER)
        for tr, scope in self.transitions if _any_guards(self.transition_specs) else ():
            guard = tr.params.guard
            if guard is None and not tr.conditions:
                continue
            if isinstance(guard, str):
                c = self.compile(guard, tr.source, tr.pointer + "/guard", tr.label, E.BOOL)
                if c is not None and c.constant and c.value is False:
                    self.problems.add("the guard is always false, so the transition can never fire", tr.source,
                                      tr.pointer + "/guard", element=tr.label, severity="warning",
                                      hint="remove the transition or correct the guard")
            for cs in conditions_of(tr.conditions):
                self.condition(cs, tr.source, tr.label, scope)
        return self.kinds, self.compiled

    def assignments(self) -> Iterator[Assignment]:
        """Every assignment of the tree: states' ``set``, assignment parameters (SetVar), transitions' ``set``."""
        states = self.state_specs
        params = list(map(_PARAMS, states))
        for st in states if list(map(_SET, params)).count(None) != len(params) else ():
            sets = st.params.set
            if sets is None:
                continue
            for hook in ("on_enter", "on_exit", "on_complete"):
                for name, value in (getattr(sets, hook) or {}).items():
                    yield Assignment(name, value, st.source, f"{st.pointer}/set/{hook}/{escape(name)}", st.label)
        for st in states if any(cls.assignment_fields for cls in set(map(_CLS, states))) else ():
            for key in st.cls.assignment_fields:
                for name, value in getattr(st.params, key).items():
                    yield Assignment(name, value, st.source, f"{st.pointer}/{key}/{escape(name)}", st.label)
        transitions = self.transition_specs
        for tr in transitions if list(map(_SET, map(_PARAMS, transitions))).count(None) != len(transitions) else ():
            if tr.params.set is None:
                continue
            for name, value in tr.params.set.items():
                yield Assignment(name, value, tr.source, f"{tr.pointer}/set/{escape(name)}", tr.label)

    def infer_kinds(self, assignments: list[Assignment]) -> dict[str, str]:
        kinds = {name: E.kind_of(value) for name, value in self.variables.items()}
        declared = set(kinds)
        for a in assignments:
            if a.target not in E.KEYWORDS:
                kinds.setdefault(a.target, E.ANY)
        for _ in range(3):  # infer the kinds of variables only ``set`` gives, from what is assigned
            changed = False
            for a in assignments:
                if a.target in declared or kinds.get(a.target) != E.ANY:
                    continue
                kind = _kind_of_value(a.value, kinds)
                if kind != E.ANY:
                    kinds[a.target] = kind
                    changed = True
            if not changed:
                break
        self.declared = declared
        return kinds

    def assignment(self, a: Assignment) -> None:
        if a.target in E.KEYWORDS:
            self.problems.add(f"'{a.target}' is a keyword, not a variable name", a.source, a.pointer,
                              element=a.element, hint="rename the variable")
            return
        c = self.compile(a.value, a.source, a.pointer, a.element, None)
        if c is None:
            return
        want = self.kinds.get(a.target, E.ANY)
        if want != E.ANY and c.kind not in (want, E.ANY):
            origin = "its initial value in 'vars'" if a.target in self.declared else "another set assigns it"
            self.problems.add(f"assigns {E.kind_phrase(c.kind)} to variable '{a.target}', which holds "
                              f"{E.kind_phrase(want)} ({origin})", a.source, a.pointer, element=a.element,
                              hint="a variable keeps one kind: true/false, number or text")
            del self.compiled[(a.source.name, a.pointer)]

    def step_conditions(self, st: StateSpec, scope: str) -> None:
        """A state's precondition, until and monitor conditions: expressions or condition objects."""
        p = st.params
        keys: list[tuple[str, Any]] = [("precondition", p.precondition), ("until", p.until)]
        keys += [(f"monitors/{i}/condition", m.condition) for i, m in enumerate(p.monitors or ())]
        keys += [(key, getattr(p, key, None)) for key in st.cls.condition_fields]
        for key, raw in keys:
            ptr = f"{st.pointer}/{key}"
            if isinstance(raw, str):
                c = self.compile(raw, st.source, ptr, st.label, E.BOOL)
                if c is not None and c.constant and c.value is False and key == "until":
                    self.problems.add("the exit condition is always false, so the state can never finish",
                                      st.source, ptr, element=st.label, hint="correct the condition")
            elif key in st.conditions:
                for cs in st.conditions[key].walk():
                    self.condition(cs, st.source, st.label, scope)

    def condition(self, cs: ConditionSpec, source: Source, element: str, scope: str) -> None:
        """One condition object (not its children): its expressions and the state paths it names."""
        for key in cs.cls.expr_fields:
            self.compile(getattr(cs.params, key), source, f"{cs.pointer}/{key}", element, E.BOOL)
        for key in cs.cls.state_refs:
            value = getattr(cs.params, key)
            if resolve_path(value, scope, self.paths) is None:
                self.problems.add(f"'{key}' names no state: '{value}'", source, f"{cs.pointer}/{key}",
                                  element=element, hint=PATH_HINT)

    def compile(self, value: Any, source: Source, ptr: str, element: str, want: str | None) -> E.Compiled | None:
        """A compiled expression (a constant for a number or true/false), or None with a located problem."""
        try:
            c = E.constant(value) if not isinstance(value, str) else E.compile_expr(value, self.kinds, want)
        except E.ExprError as exc:
            hint = None
            if exc.message.startswith("unknown variable"):
                name = exc.message.split("'")[1]
                close = difflib.get_close_matches(name, sorted(self.kinds), n=2)
                hint = ("did you mean " + " or ".join(f"'{c}'" for c in close) + "?" if close else
                        "give it an initial value in the machine's 'vars' (or assign it in a set)")
            shown = value if len(value) <= 60 else value[:57] + "..."
            self.problems.add(f"{exc}: {shown}", source, ptr, element=element, hint=hint, expr_column=exc.column)
            return None
        self.compiled[(source.name, ptr)] = c
        self.wants[(source.name, ptr)] = want
        return c


_PARAMS = operator.attrgetter("params")
_SET = operator.attrgetter("set")
_STEP_EXPRESSIONS = operator.attrgetter("precondition", "until", "monitors", "timeout")


def _any_step_expressions(elements: list[StateSpec]) -> bool:
    """Whether a state has a precondition, until, monitors, a timeout or a type's condition parameters (one C-speed
    pass over them all: most have none)."""
    return any(cls.condition_fields for cls in set(map(_CLS, elements))) or \
        list(map(_STEP_EXPRESSIONS, map(_PARAMS, elements))).count((None, None, None, None)) != len(elements)


def _any_guards(elements: list[TransitionSpec]) -> bool:
    """Whether a transition has a guard or condition objects (as :func:`_any_step_expressions`)."""
    return list(map(_GUARD, elements)).count(None) != len(elements) or any(map(_CONDITIONS, elements))


_GUARD = operator.attrgetter("params.guard")
_CONDITIONS = operator.attrgetter("conditions")


def _kind_of_value(value: Any, kinds: dict[str, str]) -> str:
    if not isinstance(value, str):
        return E.kind_of(value)
    try:
        return E.compile_expr(value, kinds).kind
    except E.ExprError:
        return E.ANY


# -- words ----------------------------------------------------------------------------------------------------
def value_kind(value: Any) -> str:
    """The kind of a value as documents see it (JSON's types; a bool is not a number)."""
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, (int, float)):
        return "number"
    if isinstance(value, str):
        return "text"
    if value is None:
        return "null"
    return "list" if isinstance(value, (list, tuple)) else "object" if isinstance(value, dict) else type(value).__name__


def _a(kind: str) -> str:
    """A kind with its article: "a number", "text", "an object"."""
    return {"true/false": "a true/false value", "number": "a number", "text": "text", "null": "null",
            "list": "a list", "object": "an object"}.get(kind, f"a {kind}")


def _choices(name: str, by_id: dict[str, Any]) -> str:
    close = difflib.get_close_matches(name, list(by_id), n=3)
    if close:
        return "did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
    ids = list(by_id)
    shown = ", ".join(ids[:10]) + (", ..." if len(ids) > 10 else "")
    return f"states here: {shown}" if ids else "this machine has no valid states"


def _join_hint(st: StateSpec) -> str:
    if getattr(st.params, "join", "all") == "any":
        return " (join=any: the outcome of the first region to finish)"
    return (" (join=all: 'succeeded' when every region ends in 'succeeded', else the first other outcome "
            "in region order; a region that cannot succeed hides the outcomes of the regions after it)")


def _never_finishes_hint(st: StateSpec) -> str:
    if st.cls.is_composite:
        return "its sub-machine reaches no Final state; add one, or use another transition type"
    return f"{st.type} states never finish; use another transition type (Timeout, Signal, ...)"


__all__ = ["Analysis", "check", "check_level", "conditions_of", "path_of", "signal_names", "signal_readers",
           "value_kind"]
