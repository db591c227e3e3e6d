"""The cold load's shortcuts give what the long way gives: a level's elements validated in one pydantic-core call
(``fsm.loading.parsing.validated_together``) equal the elements validated one by one, a broken element still gets
its own located problem, and pydantic's plugin lookup is skipped only when no distribution declares a plugin (with
one installed, pydantic finds it and sees every validation)."""

from __future__ import annotations

import importlib.metadata
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

from fsm.loading.loader import check
from fsm.loading.parsing import validated_together
from fsm.loading.pydantic_plugins import declares_no_group
from fsm.loading.registry import default_registry

ROOT = Path(__file__).resolve().parent.parent

STATES: list[dict[str, Any]] = [
    {"id": "a", "type": "Idle", "description": "start", "set": {"on_enter": {"n": "n + 1"}}},
    {"id": "b", "type": "Wait", "seconds": 0.5, "until": "n > 2", "timeout": 3,
     "monitors": [{"condition": {"type": "SignalHigh", "signal": "stop"}, "behavior": "abortOwner"}]},
    {"id": "c", "type": "SetVar", "set": {"on_exit": {"m": 1}}, "assign": {"n": 0}},
    {"id": "d", "type": "Idle", "layout": {"x": 1, "y": 2.5}},
    {"id": "e", "type": "Final"},
]
TRANSITIONS: list[dict[str, Any]] = [
    {"type": "Always", "from": "a", "to": "b", "guard": "n >= 0", "set": {"n": "n + 1"}},
    {"type": "Finished", "from": "b", "to": "c", "priority": 2.0},
    {"type": "Timeout", "from": "c", "to": "d", "seconds": 1},
    {"type": "Signal", "from": "d", "to": "e", "signal": "go", "preempt": True},
    {"type": "Always", "from": "d", "to": "a", "guard": {"type": "Expr", "expr": "n > 5"}},
]


def one_by_one(table: Any, raws: list[dict[str, Any]]) -> list[tuple[type[Any], Any]]:
    return [(table[raw["type"]], table[raw["type"]].Params.model_validate(raw)) for raw in raws]


@pytest.mark.parametrize("kind", ["states", "transitions"])
def test_a_level_validated_together_equals_its_elements_validated_one_by_one(kind: str) -> None:
    registry = default_registry(())
    table = registry.states if kind == "states" else registry.transitions
    raws = STATES if kind == "states" else TRANSITIONS
    together = validated_together(table, raws)
    assert together is not None
    classes, params = together
    expected = one_by_one(table, raws)
    assert classes == [cls for cls, _ in expected]
    for got, (_, want) in zip(params, expected, strict=True):
        assert type(got) is type(want)
        assert got == want and got.model_fields_set == want.model_fields_set


@pytest.mark.parametrize("broken", [
    [{"id": "x", "type": "Idle"}, {"id": "y", "type": "Idle", "colour": "red"}],  # an unknown parameter
    [{"id": "x", "type": "Idle"}, {"id": "y", "type": "Nope"}],  # an unknown type
    [{"id": "x", "type": "Idle"}, {"id": "y"}],  # no type
    [{"id": "x", "type": "Idle"}, ["not", "an", "object"]],
    [{"id": "x", "type": "Idle"}, {"id": "y", "type": ["Idle"]}],  # an unhashable type
])
def test_a_level_with_a_broken_element_is_left_to_the_one_by_one_path(broken: list[Any]) -> None:
    assert validated_together(default_registry(()).states, broken) is None


def test_a_broken_element_among_valid_ones_is_found_at_its_place(tmp_path: Path) -> None:
    states = [{"id": f"s{i}", "type": "Idle"} for i in range(50)]
    states[37] = {"id": "s37", "type": "Wait", "seconds": "soon"}
    doc = {"initial": "s0", "states": states,
           "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % 50}"} for i in range(50)]}
    doc["transitions"][12]["priority"] = "high"
    path = tmp_path / "ring.json"
    path.write_text(json.dumps(doc, indent=1))
    _spec, problems = check(path)
    found = sorted((p.pointer, p.line, p.message) for p in problems if p.severity == "error")
    assert [(ptr, msg.split(":")[0]) for ptr, _line, msg in found] == [
        ("/states/37/seconds", "'seconds'"), ("/transitions/12/priority", "'priority'")]
    assert all(line is not None for _ptr, line, _msg in found)


@pytest.mark.parametrize("group", ["pydantic", "console_scripts", "pytest11", "fsm.states", "fsm.readers",
                                   "no.such.group"])
def test_the_entry_point_files_tell_what_importlib_metadata_finds(group: str) -> None:
    assert declares_no_group(group) == (len(importlib.metadata.entry_points(group=group)) == 0)


PLUGIN = '''
from pydantic.plugin import PydanticPluginProtocol, ValidatePythonHandlerProtocol

SEEN = []


class Counting(ValidatePythonHandlerProtocol):
    def __init__(self, name):
        self.name = name

    def on_enter(self, input, **kwargs):
        SEEN.append(self.name)


class Plugin(PydanticPluginProtocol):
    def new_schema_validator(self, schema, schema_type, schema_type_path, schema_kind, config, plugin_settings):
        return Counting(schema_type_path.name), None, None


plugin = Plugin()
'''


def test_an_installed_pydantic_plugin_is_found_and_sees_every_element(tmp_path: Path) -> None:
    """A pydantic plugin distribution (another project's, as pip installs one: its metadata folder and module on the
    path) is found by pydantic's own lookup, and with it installed each element is validated by its model's own
    validator, so the plugin sees every one."""
    (tmp_path / "countplug.py").write_text(PLUGIN)
    info = tmp_path / "countplug-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: countplug\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[pydantic]\ncounting = countplug:plugin\n")
    ring = tmp_path / "ring.json"
    ring.write_text(json.dumps({"initial": "s0", "states": [{"id": f"s{i}", "type": "Idle"} for i in range(4)],
                                "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % 4}"}
                                                for i in range(4)]}))
    code = textwrap.dedent('''
        import json, sys
        import fsm
        fsm.load(sys.argv[1])
        import countplug
        from fsm.loading.pydantic_plugins import declares_no_group
        print(json.dumps({"declared": not declares_no_group("pydantic"),
                          "states": countplug.SEEN.count("StateParams"),
                          "transitions": countplug.SEEN.count("TransitionParams")}))
    ''')
    env = {**os.environ, "FSM_NO_CACHE": "1", "PYTHONPATH": str(tmp_path)}
    done = subprocess.run([sys.executable, "-c", code, str(ring)], capture_output=True, text=True, timeout=120,
                          cwd=ROOT, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"declared": True, "states": 4, "transitions": 4}


def test_without_plugins_pydantic_is_told_so_before_its_first_validator() -> None:
    code = textwrap.dedent('''
        import json, sys
        import fsm
        fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Idle"}]})
        import pydantic.plugin._loader as loader
        print(json.dumps({"plugins": loader._plugins}))
    ''')
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT,
                          env={**os.environ, "FSM_NO_CACHE": "1"})
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"plugins": {}}
