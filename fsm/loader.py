"""Loader: document -> Machine. Resolves includes, checks shape and semantics (reading files is
``fsm.reading``, building the objects ``fsm.build``).

Every problem of a document is collected (all at once, not only the first) with its file, JSON pointer,
line:column and element; only a document without errors is built.
"""

from __future__ import annotations

import difflib
import errno
import json
import os
import re
import stat
from collections import deque
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from .build import build
from .context import Context
from .document import (
    ConditionSpec,
    Include,
    MachineEnvelope,
    MachineSpec,
    Source,
    StateSpec,
    TransitionSpec,
    check_type,
    element_label,
    normalize_legacy,
    problems_from_validation,
)
from .errors import DiagramError, Problem
from .jsonpos import escape, pointer
from .machine import Machine
from .paths import resolve_path
from .reading import parse_json_bytes, place, read_file_bytes, read_json, reader_for, register_reader
from .registry import Registry, default_registry

#: Machines nested deeper than this are refused (a recursion guard, far beyond any real diagram).
MAX_MACHINE_DEPTH = 48
class Loader:
    """One load: the registry, the problems found so far, and the include bookkeeping."""

    def __init__(self, registry: Registry, base_dir: str | os.PathLike[str] | None = None) -> None:
        self.registry = registry
        self.base_dir = Path(base_dir) if base_dir is not None else None
        self.problems: list[Problem] = []
        self._cache: dict[Path, MachineSpec | None] = {}
        self._stack: list[Path] = []
        self._source_of: dict[int, Source] = {}

    # -- entry points ---------------------------------------------------------------------------
    def load(self, src: Any) -> MachineSpec | None:
        """Parse and check ``src`` (a path or a document dict); problems go to ``self.problems``."""
        try:
            if isinstance(src, (str, os.PathLike)):
                path = Path(src)
                try:
                    data, source = self._read(path)
                except DiagramError as exc:
                    self.problems.extend(exc.problems)
                    return None
                self._stack.append(Path(os.path.realpath(path)))
                spec = self.parse_machine(data, source, "", depth=0)
                self._stack.pop()
            else:
                source = Source(name=None, directory=self.base_dir or Path.cwd())
                spec = self.parse_machine(src, source, "", depth=0)
            if spec is not None:
                self.check_tree(spec)
        except RecursionError:
            name = str(src) if isinstance(src, (str, os.PathLike)) else None
            self.problems.append(Problem("document nested too deeply to check", name))
            return None
        self._fill_positions()
        return spec

    def _read(self, path: Path) -> tuple[Any, Source]:
        """A file's document by its reader; a JSON file's repeated keys join the other problems of the load."""
        reader = reader_for(path)
        if reader is not read_json:
            return reader(path)
        if not str(path) or str(path) == ".":
            return read_json(path)  # the "no file name" problem
        repeated: list[Problem] = []
        data, source = parse_json_bytes(read_file_bytes(path), str(path), path.parent, duplicates=repeated)
        self.problems.extend(repeated)
        return data, source

    # -- shape ----------------------------------------------------------------------------------
    def parse_machine(self, data: Any, source: Source, base: str, depth: int) -> MachineSpec | None:
        """Check one machine level and its sub-machines; returns ``None`` when its envelope is unusable."""
        if depth > MAX_MACHINE_DEPTH:
            self._add("machines nested more than %d levels deep" % MAX_MACHINE_DEPTH, source, base)
            return None
        if not isinstance(data, dict):
            kind = "array" if isinstance(data, list) else type(data).__name__
            self._add(f"a machine must be a JSON object with 'initial' and 'states', got {kind}", source, base,
                      hint='{"initial": "a", "states": [{"id": "a", "type": "Idle"}]}')
            return None
        data, legacy = normalize_legacy(data)
        rename = {"initial": "root"} if legacy else None
        envelope: MachineEnvelope | None
        try:
            envelope = MachineEnvelope.model_validate(data)
        except ValidationError as err:
            self._extend(problems_from_validation(
                err, source=source, base=base, element=None, model=MachineEnvelope, kind="key", rename=rename,
                data=data), source)
            envelope = None
        states_raw = data.get("states") if isinstance(data.get("states"), list) else []
        trans_raw = data.get("transitions") if isinstance(data.get("transitions"), list) else []
        states: list[StateSpec] = []
        for i, raw in enumerate(states_raw):
            spec = self._parse_state(raw, source, f"{base}/states/{i}", depth)
            if spec is not None:
                states.append(spec)
        transitions: list[TransitionSpec] = []
        for i, raw in enumerate(trans_raw):
            tspec = self._parse_transition(raw, source, f"{base}/transitions/{i}")
            if tspec is not None:
                transitions.append(tspec)
        initial = data.get("initial") if isinstance(data.get("initial"), str) else ""
        edges = [(t["from"], t["to"]) for t in trans_raw
                 if isinstance(t, dict) and isinstance(t.get("from"), str) and isinstance(t.get("to"), str)]
        complete = envelope is not None and len(states) == len(states_raw) and len(transitions) == len(trans_raw)
        spec = MachineSpec(
            source=source,
            pointer=base,
            name=envelope.name if envelope else (data.get("name") if isinstance(data.get("name"), str) else None),
            initial=initial,
            initial_pointer=base + ("/root" if legacy else "/initial"),
            states=states,
            transitions=transitions,
            vars=dict(envelope.vars) if envelope else {},
            edges=edges,
            complete=complete,
            inputs=list(envelope.inputs) if envelope and envelope.inputs is not None else None,
        )
        self.check_level(spec, envelope is not None, states_raw, trans_raw)
        return spec

    def _parse_element(self, kind: str, raw: Any, source: Source, ptr: str) -> tuple[type, Any] | None:
        """The class an element's ``type`` names and its validated parameters, or ``None`` (problems added)."""
        if not isinstance(raw, dict):
            return None  # the envelope reported it
        cls, problems = check_type(kind, raw, self.registry, source, ptr)
        if cls is None:
            self._extend(problems, source)
            return None
        try:
            return cls, cls.Params.model_validate(raw)
        except ValidationError as err:
            self._extend(problems_from_validation(
                err, source=source, base=ptr, element=element_label(kind, raw), model=cls.Params,
                kind="parameter", data=raw), source)
            return None

    def _parse_state(self, raw: Any, source: Source, ptr: str, depth: int) -> StateSpec | None:
        parsed = self._parse_element("state", raw, source, ptr)
        if parsed is None:
            return None
        cls, params = parsed
        spec = StateSpec(params.id, cls, params, ptr, source)
        if getattr(cls, "compiles_steps", False):
            from .sequencer.compile import parse_sequence

            parse_sequence(self, spec, source, ptr, depth)
        elif cls.is_composite:
            for default_name, sub, rel in cls.submachines(params):
                sub_spec = self.parse_sub(sub, source, ptr + rel, depth + 1)
                name = default_name
                if default_name is not None and sub_spec is not None and sub_spec.name:
                    name = sub_spec.name
                    if "/" in name or any(name == other for other, _, _ in spec.subs):
                        self._add(f"region name '{name}' is not usable as a path step (it contains '/' or "
                                  f"is used twice in '{spec.id}')", sub_spec.source, sub_spec.pointer + "/name",
                                  element=f"state '{spec.id}'", hint="give each region a unique name")
                spec.subs.append((name, sub_spec, ptr + rel))
        return spec

    def _parse_transition(self, raw: Any, source: Source, ptr: str) -> TransitionSpec | None:
        parsed = self._parse_element("transition", raw, source, ptr)
        return None if parsed is None else TransitionSpec(parsed[0], parsed[1], ptr, source)

    def parse_sub(self, data: Any, source: Source, ptr: str, depth: int) -> MachineSpec | None:
        """A sub-machine: inline, or ``{"file": ...}`` relative to the including file."""
        if isinstance(data, dict) and "file" in data:
            try:
                inc = Include.model_validate(data)
            except ValidationError as err:
                self._extend(problems_from_validation(
                    err, source=source, base=ptr, element="include", model=Include, kind="key", data=data), source)
                return None
            return self.include(inc.file, source, ptr, depth)
        return self.parse_machine(data, source, ptr, depth)

    def include(self, file: str, source: Source, ptr: str, depth: int) -> MachineSpec | None:
        directory = Path(source.directory) if source.directory is not None else (self.base_dir or Path.cwd())
        try:
            # realpath, not Path.resolve: on a symlink loop the latter raises RuntimeError (Python 3.11)
            path = Path(os.path.realpath(directory / file))
            mode = os.stat(path).st_mode
        except FileNotFoundError:
            mode = None
        except (OSError, ValueError) as exc:  # a symlink loop (ELOOP), no permission, a NUL byte, ...
            reason = getattr(exc, "strerror", None) or str(exc)
            hint = ("the path is a symlink that leads back to itself; point it at a machine file"
                    if getattr(exc, "errno", None) == errno.ELOOP else "check the path and its permissions")
            self._add(f"include file '{file}' cannot be read: {reason}", source, ptr + "/file",
                      element="include", hint=hint)
            return None
        if mode is not None and not stat.S_ISREG(mode):
            what = "a directory" if stat.S_ISDIR(mode) else "not a regular file"
            self._add(f"include file '{file}' is {what} ({path})", source, ptr + "/file", element="include",
                      hint="an include names a machine file (.json or .uxf), relative to the including file")
            return None
        if path in self._stack:
            cycle = self._stack[self._stack.index(path):] + [path]
            self._add("include cycle: " + " -> ".join(p.name for p in cycle), source, ptr + "/file",
                      element="include", hint="a machine may not include itself, directly or through others")
            return None
        if path in self._cache:
            return self._cache[path]
        if mode is None:
            self._add(f"include file '{file}' not found (looked for {path})", source, ptr + "/file",
                      element="include", hint="include paths are relative to the including file")
            return None
        try:
            data, inc_source = self._read(path)
        except DiagramError as exc:
            self.problems.extend(exc.problems)
            self._cache[path] = None
            return None
        self._stack.append(path)
        try:
            spec = self.parse_machine(data, inc_source, "", depth)
        finally:
            self._stack.pop()
        self._cache[path] = spec
        return spec

    # -- semantics ------------------------------------------------------------------------------
    def check_level(self, spec: MachineSpec, envelope_ok: bool,
                    states_raw: list[Any], trans_raw: list[Any]) -> None:
        """Ids, initial state, endpoints, finishing, transitions out of final states, reachability.

        Ids and endpoints are checked on the raw elements too, so an element with a bad parameter
        still gets its other errors reported in the same run.
        """
        src = spec.source
        base = spec.pointer
        first_at: dict[str, str] = {}
        for i, raw in enumerate(states_raw):
            sid = raw.get("id") if isinstance(raw, dict) else None
            if not isinstance(sid, str):
                continue
            ptr = f"{base}/states/{i}"
            if sid in first_at:
                self._add(f"duplicate id '{sid}' (first used at {first_at[sid]})", src, ptr + "/id",
                          element=f"state '{sid}'", hint="ids must be unique within one machine level")
            else:
                first_at[sid] = ptr
        by_id: dict[str, StateSpec] = {}
        for st in spec.states:
            by_id.setdefault(st.id, st)
        known = set(first_at)
        if envelope_ok and spec.initial not in known:
            self._add(f"initial state '{spec.initial}' is not a state of this machine", src, spec.initial_pointer,
                      hint=_choices(spec.initial, first_at))
        for i, raw in enumerate(trans_raw):
            if not isinstance(raw, dict):
                continue
            for key in ("from", "to"):
                ref = raw.get(key)
                if isinstance(ref, str) and ref and ref not in known:
                    self._add(f"'{key}' names unknown state '{ref}'", src, f"{base}/transitions/{i}/{key}",
                              element=element_label("transition", raw), hint=_choices(ref, first_at))
        for tr in spec.transitions:
            p = tr.params
            source = by_id.get(p.from_)
            if source is None:
                continue
            if source.cls.is_final:
                self._add(f"transition out of final state '{source.id}'", src, tr.pointer, element=tr.label,
                          hint="a final state ends its machine; remove the transition or the final state")
                continue
            if tr.cls.needs_finishing_source:
                outcomes = self.outcomes(source)
                if outcomes is not None and not outcomes:
                    self._add(f"'{source.id}' ({source.cls.type_name}) can never finish, so this "
                              f"{tr.cls.type_name} transition can never fire", src, tr.pointer, element=tr.label,
                              hint=_never_finishes_hint(source))
                    continue
                wanted = getattr(p, "outcome", None)
                if wanted is not None and outcomes is not None and wanted not in outcomes:
                    hint = "its outcomes: " + ", ".join(sorted(outcomes))
                    if source.cls.is_composite and len(source.subs) > 1:
                        hint += _join_hint(source)
                    self._add(f"'{source.id}' never finishes with outcome '{wanted}'", src, tr.pointer + "/outcome",
                              element=tr.label, hint=hint)
        if spec.initial in by_id:
            reached = _reachable(spec, by_id)
            for st in spec.states:
                if st.id not in reached and by_id.get(st.id) is st:
                    self._add(f"unreachable from the initial state '{spec.initial}'", src,
                              st.pointer, element=f"state '{st.id}'", severity="warning",
                              hint="add a transition into it or remove it")

    def outcomes(self, st: StateSpec) -> set[str] | None:
        """The outcomes a state can finish with (empty: never finishes; ``None``: any)."""
        from .sequencer.compile import child_outcomes, extra_outcomes

        cls = st.cls
        if cls.is_composite:
            region_outcomes = [None if sub is None else machine_outcomes(sub) for _, sub, _ in st.subs]
            out = cls.composite_outcomes(st.params, region_outcomes)  # type: ignore[attr-defined]
            return None if out is None else out | extra_outcomes(st.params) | child_outcomes(st)
        out = cls.possible_outcomes(st.params)
        return None if out is None else out | extra_outcomes(st.params)

    def check_tree(self, root: MachineSpec) -> None:
        """Checks that need the whole tree: state paths named by transitions (``InState``) exist, and
        transitions agree with the initial blackboard variables (``Var``)."""
        paths: set[str] = set()
        refs: list[tuple[TransitionSpec, str]] = []
        every: list[TransitionSpec] = []
        variables: dict[str, Any] = {}

        def walk(spec: MachineSpec, prefix: str) -> None:
            for st in spec.states:
                path = f"{prefix}/{st.id}" if prefix else st.id
                paths.add(path)
                for name, sub, _ in st.subs:
                    if sub is not None:
                        walk(sub, f"{path}/{name}" if name else path)
            for key, value in spec.vars.items():
                variables.setdefault(key, value)
            every.extend(spec.transitions)
            for tr in spec.transitions:
                if tr.cls.state_refs:
                    refs.append((tr, prefix))

        walk(root, "")
        from .sequencer.compile import check_tree as check_sequences

        check_sequences(self, root)
        self.check_actions(root, variables, paths)
        if root.inputs is not None:
            self.check_inputs(root)
        for tr in every:
            found = tr.cls.check_document(tr.params, variables)
            if found is not None:
                self._add(found[1], tr.source, tr.pointer + found[0], element=tr.label,
                          hint="change the value or the variable's initial value in 'vars'")
        self.check_variable_kinds(every, variables)
        seen: set[tuple[int, str]] = set()
        for tr, scope in refs:
            for key in tr.cls.state_refs:
                value = getattr(tr.params, key)
                if resolve_path(value, scope, paths) is None and (id(tr), key) not in seen:
                    seen.add((id(tr), key))
                    self._add(f"'{key}' names no state: '{value}'", tr.source, f"{tr.pointer}/{key}",
                              element=tr.label,
                              hint="a path of ids joined by '/', relative to this machine or an enclosing one, "
                                   "or absolute with a leading '/'")

    def check_inputs(self, root: MachineSpec) -> None:
        """With declared ``inputs``: every signal read (by a state, transition or condition) is one of them."""
        from .sequencer.compile import condition_specs

        declared = set(root.inputs or ())

        def check(kind: Any, params: Any, source: Source, ptr: str, element: str) -> None:
            for key in getattr(kind, "signal_refs", ()):
                value = getattr(params, key, None)
                if isinstance(value, str) and value not in declared:
                    what = "pause button" if key == "pause_signal" else "signal"
                    close = difflib.get_close_matches(value, sorted(declared), n=2)
                    self._add(f"{what} '{value}' is not one of the machine's inputs ({', '.join(sorted(declared)) or 'none'})",
                              source, f"{ptr}/{key}", element=element,
                              hint=("did you mean " + " or ".join(f"'{c}'" for c in close) + "?") if close else
                              f"add '{value}' to the top level's \"inputs\" if the machine's environment provides it")

        def conditions(specs: list[Any], source: Source, element: str) -> None:
            todo = list(specs)
            while todo:
                cs = todo.pop()
                check(cs.cls, cs.params, source, cs.pointer, element)
                todo.extend(cs.children)

        for level in root.levels():
            for st in level.states:
                check(st.cls, st.params, st.source, st.pointer, f"state '{st.id}'")
                conditions(condition_specs(st), st.source, f"state '{st.id}'")
            for tr in level.transitions:
                check(tr.cls, tr.params, tr.source, tr.pointer, tr.label)
                conditions(list(tr.conditions.values()), tr.source, tr.label)

    # -- guards, set and conditions ---------------------------------------------------------------
    def check_actions(self, root: MachineSpec, variables: dict[str, Any], paths: set[str]) -> None:
        """Parse, check and compile every ``set``, ``guard`` and condition of the tree (results on the specs).

        A variable is known when ``vars`` gives it or some ``set`` assigns it; its kind is that of its initial
        value, else of what the ``set`` expressions assign to it (``any`` where that cannot be decided)."""
        from . import expr as E

        from .sequencer.compile import assignments as set_vars, compile_watch

        states: list[StateSpec] = []
        scopes: list[tuple[StateSpec, str]] = []
        transitions: list[tuple[TransitionSpec, str]] = []

        def walk(spec: MachineSpec, prefix: str) -> None:
            for st in spec.states:
                states.append(st)
                scopes.append((st, prefix))
                path = f"{prefix}/{st.id}" if prefix else st.id
                for name, sub, _ in st.subs:
                    if sub is not None:
                        walk(sub, f"{path}/{name}" if name else path)
            transitions.extend((tr, prefix) for tr in spec.transitions)

        walk(root, "")
        # every assignment: (target, value, source, pointer, element)
        assignments: list[tuple[str, Any, Source, str, str]] = []
        for st in states:
            sets = st.params.set
            if sets is None:
                continue
            for hook in ("on_enter", "on_exit"):
                for name, value in (getattr(sets, hook) or {}).items():
                    assignments.append((name, value, st.source, f"{st.pointer}/set/{hook}/{escape(name)}",
                                        f"state '{st.id}'"))
        for st in states:
            for name, value, ptr in set_vars(st):
                assignments.append((name, value, st.source, ptr, f"state '{st.id}'"))
        for tr, _ in transitions:
            for name, value in (tr.params.set or {}).items():
                assignments.append((name, value, tr.source, f"{tr.pointer}/set/{escape(name)}", tr.label))
        watched = [(st, scope) for st, scope in scopes if any(
            getattr(st.params, key, None) is not None for key in ("precondition", "until", "monitors", "timeout"))]
        if not assignments and not watched and not any(tr.params.guard is not None or tr.cls.condition_fields
                                                       for tr, _ in transitions):
            return
        kinds: dict[str, str] = {name: E.kind_of(value) for name, value in variables.items()}
        declared = set(kinds)
        for name, *_ in assignments:
            if name in E.KEYWORDS:
                continue
            kinds.setdefault(name, E.ANY)
        for _ in range(3):  # infer the kinds of variables only ``set`` gives, from what is assigned
            changed = False
            for name, value, *_ in assignments:
                if name in declared or kinds.get(name) != E.ANY:
                    continue
                kind = self._kind_of_value(value, kinds)
                if kind != E.ANY:
                    kinds[name] = kind
                    changed = True
            if not changed:
                break
        compiled: dict[str, Any] = {}
        for name, value, source, ptr, element in assignments:
            if name in E.KEYWORDS:
                self._add(f"'{name}' is a keyword, not a variable name", source, ptr, element=element,
                          hint="rename the variable")
                continue
            c = self._compile(value, kinds, source, ptr, element, None)
            if c is None:
                continue
            want = kinds.get(name, E.ANY)
            if want != E.ANY and c.kind not in (want, E.ANY):
                origin = "its initial value in 'vars'" if name in declared else "another set assigns it"
                self._add(f"assigns {E._a(c.kind)} to variable '{name}', which holds {E._a(want)} ({origin})",
                          source, ptr, element=element,
                          hint="a variable keeps one kind: true/false, number or text")
                continue
            compiled[ptr] = c
        for st in states:
            sets = st.params.set
            extra = set_vars(st)
            if sets is None and not extra:
                continue
            hooks = []
            for hook in ("on_enter", "on_exit"):
                items = (getattr(sets, hook) or {}) if sets is not None else {}
                targets = [(n, compiled.get(f"{st.pointer}/set/{hook}/{escape(n)}")) for n in items]
                if hook == "on_enter":
                    targets += [(n, compiled.get(ptr)) for n, _, ptr in extra]
                hooks.append(E.assigner(targets) if targets and all(c is not None for _, c in targets) else None)
            st.actions = (hooks[0], hooks[1])
        for st, scope in watched:
            compile_watch(self, st, kinds, paths, scope)
        for tr, scope in transitions:
            items = tr.params.set or {}
            targets = [(n, compiled.get(f"{tr.pointer}/set/{escape(n)}")) for n in items]
            if targets and all(c is not None for _, c in targets):
                tr.assign = E.assigner(targets)
            guard = tr.params.guard
            if isinstance(guard, str):
                c = self._compile(guard, kinds, tr.source, tr.pointer + "/guard", tr.label, E.BOOL)
                if c is not None:
                    if c.constant and c.value is False:
                        self._add("the guard is always false, so the transition can never fire", tr.source,
                                  tr.pointer + "/guard", element=tr.label, severity="warning",
                                  hint="remove the transition or correct the guard")
                    tr.guard = E.on_context(c.fn)
            elif isinstance(guard, dict):
                cs = self._parse_condition(guard, tr.source, tr.pointer + "/guard", tr.label, kinds, paths, scope, 0)
                if cs is not None:
                    tr.conditions["guard"] = cs
            for key in tr.cls.condition_fields:
                raw = getattr(tr.params, key, None)
                if isinstance(raw, dict):
                    cs = self._parse_condition(raw, tr.source, f"{tr.pointer}/{key}", tr.label, kinds, paths,
                                               scope, 0)
                    if cs is not None:
                        tr.conditions[key] = cs

    @staticmethod
    def _kind_of_value(value: Any, kinds: dict[str, str]) -> str:
        from . import expr as E

        if not isinstance(value, str):
            return E.kind_of(value)
        try:
            return E.compile_expr(value, kinds).kind
        except E.ExprError:
            return E.ANY

    def _compile(self, value: Any, kinds: dict[str, str], source: Source, ptr: str, element: str,
                 want: str | None) -> Any:
        """A compiled expression (a constant for a number or true/false), or None with a located problem."""
        from . import expr as E

        if not isinstance(value, str):
            return E.Compiled(lambda v, value=value: value, E.kind_of(value), repr(value), True, value)
        try:
            return E.compile_expr(value, kinds, want)
        except E.ExprError as exc:
            hint = None
            if exc.message.startswith("unknown variable"):
                known = sorted(kinds)
                import difflib

                name = exc.message.split("'")[1]
                close = difflib.get_close_matches(name, known, n=2)
                hint = ("did you mean " + " or ".join(f"'{c}'" for c in close) + "?" if close else
                        "give it an initial value in the machine's 'vars' (or assign it in a set)")
            problem = Problem(f"{str(exc)}: {value if len(value) <= 60 else value[:57] + '...'}", source.name,
                              ptr, element=element, hint=hint)
            problem.expr_column = exc.column  # type: ignore[attr-defined]
            self._extend([problem], source)
            return None

    def _parse_condition(self, raw: Any, source: Source, ptr: str, element: str, kinds: dict[str, str],
                         paths: set[str], scope: str, depth: int) -> ConditionSpec | None:
        """A condition object: its type and parameters, nested conditions, expressions and state paths."""
        if depth > MAX_MACHINE_DEPTH:
            self._add("conditions nested too deeply", source, ptr, element=element)
            return None
        parsed = self._parse_element("condition", raw, source, ptr)
        if parsed is None:
            return None
        cls, params = parsed
        spec = ConditionSpec(cls, params, ptr)
        ok = True
        for key in cls.condition_fields:
            value = getattr(params, key)
            items = list(enumerate(value)) if isinstance(value, list) else [(None, value)]
            for i, item in items:
                sub_ptr = f"{ptr}/{key}" + (f"/{i}" if i is not None else "")
                child = self._parse_condition(item, source, sub_ptr, element, kinds, paths, scope, depth + 1)
                if child is None:
                    ok = False
                else:
                    spec.children.append(child)
        for key in cls.expr_fields:
            c = self._compile(getattr(params, key), kinds, source, f"{ptr}/{key}", element, "true/false")
            if c is None:
                ok = False
            else:
                spec.exprs[key] = c
        for key in cls.state_refs:
            value = getattr(params, key)
            if resolve_path(value, scope, paths) is None:
                ok = False
                self._add(f"'{key}' names no state: '{value}'", source, f"{ptr}/{key}", element=element,
                          hint="a path of ids joined by '/', relative to this machine or an enclosing one, "
                               "or absolute with a leading '/'")
        return spec if ok else None

    def check_variable_kinds(self, transitions: list[TransitionSpec], variables: dict[str, Any]) -> None:
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
                self._add(f"'{op}' on true/false: true/false values are only equal or not", tr.source,
                          tr.pointer + "/op", element=tr.label, hint="use == or !=")
                continue
            known = first.get(name)
            if known is None:
                first[name] = (kind, f"{tr.label} at {tr.pointer or '/'} compares it with {json.dumps(value)}")
                continue
            if known[0] != kind:
                self._add(f"cannot compare variable '{name}' with {json.dumps(value)} ({_a(kind)}): it holds "
                          f"{_a(known[0])} ({known[1]})", tr.source, tr.pointer + "/value", element=tr.label,
                          hint=f"compare with {_a(known[0])} (true/false is not a number, \"5\" is not 5), "
                               "or change the variable's initial value")

    # -- bookkeeping ----------------------------------------------------------------------------
    def _add(self, message: str, source: Source, ptr: str, element: str | None = None, hint: str | None = None,
             severity: str = "error") -> None:
        self._extend([Problem(message, source.name, ptr, element=element, hint=hint, severity=severity)], source)

    def _extend(self, problems: list[Problem], source: Source) -> None:
        for p in problems:
            self._source_of[id(p)] = source
            self.problems.append(p)

    def _fill_positions(self) -> None:
        """Line and column for every problem whose file text is known (one scan per file)."""
        by_source: dict[int, tuple[Source, list[Problem]]] = {}
        for p in self.problems:
            src = self._source_of.get(id(p))
            if src is None or src.locator is None or p.line is not None:
                continue
            by_source.setdefault(id(src), (src, []))[1].append(p)
        for src, problems in by_source.values():
            place(problems, src.locator)
            if src.text is not None:
                for p in problems:
                    _expression_column(p, src.text)


_MEMBER_VALUE = re.compile(r'"(?:[^"\\]|\\.)*"\s*:\s*"')


def _expression_column(problem: Problem, text: str) -> None:
    """Move a problem in an expression from its key to the character in the JSON string (when it has no
    escapes before that character, so file columns and expression columns agree)."""
    col = getattr(problem, "expr_column", None)
    if col is None or problem.line is None or problem.column is None or problem.where is not None:
        return
    lines = text.split("\n", problem.line)
    if len(lines) < problem.line:
        return
    line = lines[problem.line - 1]
    m = _MEMBER_VALUE.match(line, problem.column - 1)
    if m is None:
        return
    value = line[m.end():m.end() + col - 1]
    if "\\" in value or '"' in value or len(value) < col - 1:
        return
    problem.column = m.end() + col


def _a(kind: str) -> str:
    """A kind with its article: "a number", "text", "an object"."""
    return {"true/false": "a true/false value", "number": "a number", "text": "text", "null": "null",
            "list": "a list", "object": "an object"}.get(kind, f"a {kind}")


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


def _choices(name: str, by_id: dict[str, Any]) -> str:
    import difflib

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
    return f"{st.cls.type_name} states never finish; use another transition type (Timeout, Signal, ...)"


def _reachable(spec: MachineSpec, by_id: dict[str, StateSpec]) -> set[str]:
    edges: dict[str, list[str]] = {}
    for src, dst in spec.edges:
        edges.setdefault(src, []).append(dst)
    seen = {spec.initial}
    todo = deque([spec.initial])
    while todo:
        for nxt in edges.get(todo.popleft(), ()):
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


def machine_outcomes(spec: MachineSpec) -> set[str] | None:
    """Outcomes of the ``Final`` states reachable in one machine level (``None``: unknown, the level is broken)."""
    if not spec.complete:
        return None
    by_id = {st.id: st for st in spec.states}
    if spec.initial not in by_id:
        return set()
    out: set[str] = set()
    for sid in _reachable(spec, by_id):
        st = by_id.get(sid)
        if st is not None and st.cls.is_final:
            out.update(st.cls.possible_outcomes(st.params) or ())
    return out


def uses_car(spec: MachineSpec | None) -> bool:
    """True when any state or transition type of the checked machine (sub-machines included) needs a car."""
    from .sequencer.compile import condition_specs

    def car_condition(specs: list[Any]) -> bool:
        todo = list(specs)
        while todo:
            cs = todo.pop()
            if getattr(cs.cls, "needs_car", False):
                return True
            todo.extend(cs.children)
        return False

    return spec is not None and any(
        any(st.cls.needs_car or car_condition(condition_specs(st)) for st in level.states)
        or any(tr.cls.needs_car or car_condition(list(tr.conditions.values())) for tr in level.transitions)
        for level in spec.levels())


def machine_files(spec: MachineSpec | None) -> list[str]:
    """Every file a checked machine was read from: its own and its includes, any depth (each once)."""
    names = (getattr(level.source, "name", None) for level in spec.levels()) if spec is not None else ()
    return list(dict.fromkeys(n for n in names if n))


def signal_names(spec: MachineSpec | None) -> set[str]:
    """The input signal names a checked machine reads, at every level: the parameters its transition (and
    state) types declare in ``signal_refs`` (``Signal.signal``). ``fsmctl run --signal`` warns about a
    name outside this set; a plugin type that reads signals declares its parameter there to be counted."""
    names: set[str] = set()
    from .sequencer.compile import condition_specs

    def add(kind: Any, params: Any) -> None:
        for key in getattr(kind, "signal_refs", ()):
            value = getattr(params, key, None)
            if isinstance(value, str):
                names.add(value)

    for level in spec.levels() if spec is not None else ():
        elements = [(st.cls, st.params, condition_specs(st)) for st in level.states]
        elements += [(tr.cls, tr.params, list(tr.conditions.values())) for tr in level.transitions]
        for kind, params, conditions in elements:
            add(kind, params)
            while conditions:
                cs = conditions.pop()
                add(cs.cls, cs.params)
                conditions.extend(cs.children)
    return names


# -- public API -------------------------------------------------------------------------------------
def check(src: Any, *, registry: Registry | None = None, plugins: tuple[str, ...] = (),
          base_dir: str | os.PathLike[str] | None = None) -> tuple[MachineSpec | None, list[Problem]]:
    """Validate ``src`` without building: the checked spec (``None`` if unusable) and every problem found."""
    loader = Loader(registry or default_registry(plugins), base_dir)
    spec = loader.load(src)
    problems = sorted(loader.problems, key=lambda p: (p.file or "", p.line or 0, p.column or 0))
    return spec, problems


def load(src: Any, *, registry: Registry | None = None, plugins: tuple[str, ...] = (), clock: Any = None,
         car: Any = None, context: Context | None = None, dt: float | None = None,
         base_dir: str | os.PathLike[str] | None = None) -> Machine:
    """Load a machine from a file path (``.json``, or ``.uxf`` with the UMLet reader) or a document dict.

    Raises :class:`DiagramError` with every error found; warnings (unreachable states) do not stop the load.
    """
    spec, problems = check(src, registry=registry, plugins=plugins, base_dir=base_dir)
    if spec is None or any(p.severity == "error" for p in problems):
        raise DiagramError([p for p in problems if p.severity == "error"] or problems)
    if clock is None and dt is not None:
        from .clock import SimulatedClock

        clock = SimulatedClock(dt)
    return build(spec, clock=clock, car=car, context=context)


__all__ = ["Loader", "build", "check", "load", "machine_outcomes", "read_json", "register_reader", "pointer",
           "signal_names", "value_kind"]
