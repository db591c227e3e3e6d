"""The first load imports only what the document uses: the built-in types' modules by a static table
(``fsm.loading.registry.BUILTIN_MODULES``, checked here against what the modules really register, so it cannot go
stale), the installed plugins only when a document names a type no built-in has, and no entry-point scan for a
``.json`` file."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.loading import registry as R
from fsm.loading.registry import BUILTIN_MODULES, RegistrationError, Registry, builtin_types, using

ROOT = Path(__file__).resolve().parent.parent


def fresh(code: str, *args: str) -> Any:
    """Run ``code`` in a fresh interpreter (the plan cache off) and return the JSON of its last line."""
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args], capture_output=True, text=True,
                          timeout=120, cwd=ROOT, env={**os.environ, "FSM_NO_CACHE": "1"})
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_table_names_every_builtin_type_by_the_module_that_registers_it() -> None:
    """Every type tral-fsm's own modules register is in the table under the module whose code registered it, and
    the table names nothing else: a type added, moved or renamed without the table fails here."""
    builtin_types()  # every built-in module imported
    declared = {(kind, name, by) for kind, name, _cls, by in R._DECLARED if by.startswith("fsm.")}
    table = {(kind, name, module) for module, kinds in BUILTIN_MODULES.items() for kind, names in kinds.items()
             for name in names}
    assert declared == table
    assert all(module.startswith(("fsm.states.", "fsm.transitions.")) for module in BUILTIN_MODULES)


def test_every_type_of_the_table_resolves_to_the_class_its_module_registered() -> None:
    classes = {(kind, name): cls for kind, name, cls in builtin_types()}
    registry = Registry.with_builtins()
    for (kind, name), cls in classes.items():
        table = {"state": registry.states, "transition": registry.transitions, "condition": registry.conditions,
                 "plant": registry.plants}[kind]
        assert table[name] is cls, (kind, name)


def test_a_ring_of_idle_states_imports_only_the_generic_types_and_scans_no_plugins(tmp_path: Path) -> None:
    ring = tmp_path / "ring.json"
    ring.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}],
                                "transitions": [{"type": "Always", "from": "a", "to": "b"},
                                                {"type": "Always", "from": "b", "to": "a"}]}))
    got = fresh('''
        import json, sys
        import fsm
        fsm.load(sys.argv[1]).tick()
        print(json.dumps(sorted(m for m in sys.modules if m.startswith(("fsm.states.", "fsm.transitions.",
                                                                       "fsm.loading.installed", "numpy")))))
    ''', str(ring))
    assert got == ["fsm.states.generic", "fsm.transitions.generic"]


def test_a_type_of_another_module_imports_that_module_on_first_use(tmp_path: Path) -> None:
    doc = tmp_path / "m.json"
    doc.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                               "transitions": [{"type": "Signal", "from": "a", "to": "b", "signal": "go"}]}))
    got = fresh('''
        import json, sys
        import fsm
        spec, problems = fsm.check(sys.argv[1])
        print(json.dumps([spec is not None, [str(p) for p in problems],
                          sorted(m for m in sys.modules if m.startswith(("fsm.states.", "fsm.transitions.")))]))
    ''', str(doc))
    assert got == [True, [], ["fsm.states.generic", "fsm.transitions.inputs"]]


def test_an_unknown_type_still_gets_its_close_names_from_every_module() -> None:
    spec, problems = fsm.check({"initial": "a", "states": [{"id": "a", "type": "FollowWal"}]},
                               registry=Registry.with_builtins())
    assert spec is None or problems
    assert any("unknown state type 'FollowWal'" in p.message and "FollowWall" in (p.hint or "") for p in problems)


def test_a_table_reads_as_the_whole_dict() -> None:
    registry = Registry.with_builtins()
    names = {name for module, kinds in BUILTIN_MODULES.items() for name in kinds.get("state", ())}
    assert "Idle" in registry.states and "Nope" not in registry.states
    assert set(registry.states) == names and len(registry.states) == len(names)
    copy = dict(registry.states)
    assert copy == registry.states and registry.states == Registry.with_builtins().states
    other = Registry()
    other.states.update(registry.transitions)
    assert set(other.states) == set(registry.transitions)
    assert registry.states.pop("Idle") is copy["Idle"] and "Idle" not in registry.states
    assert registry.states.get("Idle") is None


def test_a_plugin_may_not_take_the_name_of_a_builtin_not_imported_yet() -> None:
    registry = Registry.with_builtins()

    class Idle(fsm.State[fsm.StateParams]):
        """Another class of a built-in's name."""

    with using(registry), pytest.raises(RegistrationError, match="already registered by fsm.states.generic.Idle"):
        fsm.register_state(Idle)
    assert registry.states["Idle"].__module__ == "fsm.states.generic"


def test_installed_plugins_load_when_a_document_names_a_type_no_builtin_has() -> None:
    """The default registry defers its entry points: a load of built-in types reads no distribution's metadata; a
    name no table knows loads them (and a listing does)."""
    registry = Registry.with_builtins()
    calls: list[str] = []
    registry.load_entry_points = lambda: calls.append("loaded")  # type: ignore[method-assign]
    registry.defer_entry_points()
    assert registry.states["Idle"] and calls == []
    assert registry.transitions.get("Beam") is None and calls == ["loaded"]
    assert registry.states.get("Nope") is None and calls == ["loaded"], "loaded once"


def test_null_is_refused_by_pydantic_core_with_one_problem_per_field() -> None:
    """No field takes null: refused by the validator's types (no Python validator per field), worded once per field,
    also for a field of several types."""
    _spec, problems = fsm.check({"initial": "a", "states": [
        {"id": "a", "type": "Idle", "description": None, "until": None},
        {"id": "b", "type": "Idle"}],
        "transitions": [{"type": "Always", "from": "a", "to": "b", "priority": None, "guard": None}]})
    got = sorted((p.pointer, p.message, p.hint) for p in problems)
    assert got == [
        ("/states/0/description", "'description' may not be null", "leave the key out to get its default"),
        ("/states/0/until", "'until' may not be null", "leave the key out to get its default"),
        ("/transitions/0/guard", "'guard' may not be null", "leave the key out to get its default"),
        ("/transitions/0/priority", "'priority' may not be null", "leave the key out to get its default: 0")]


def test_validating_an_element_runs_no_python_code() -> None:
    registry = Registry.with_builtins()
    idle, always = registry.states["Idle"].Params, registry.transitions["Always"].Params
    idle.model_validate({"id": "x", "type": "Idle"})
    always.model_validate({"type": "Always", "from": "a", "to": "b"})  # the validators built
    calls: list[str] = []

    def profile(frame: Any, event: str, arg: Any) -> None:
        if event == "call" and "/fsm/" in frame.f_code.co_filename:
            calls.append(f"{frame.f_code.co_filename}:{frame.f_code.co_name}")

    sys.setprofile(profile)
    try:
        idle.__pydantic_validator__.validate_python({"id": "x", "type": "Idle", "description": "d"})
        always.__pydantic_validator__.validate_python({"type": "Always", "from": "a", "to": "b", "preempt": True})
    finally:
        sys.setprofile(None)
    assert calls == []
