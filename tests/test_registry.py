"""The registry: decorators, refusal of duplicates and bad classes, and third-party types from entry points."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from fsm import RegistrationError, Registry, State, StateParams, Transition
from fsm.loading.registry import register_state, using


def test_decorator_registers_into_the_active_registry_and_refuses_a_duplicate() -> None:
    reg = Registry()
    with using(reg):

        @register_state
        class Blink(State):
            """Blinks."""

        with pytest.raises(RegistrationError, match="already registered"):

            @register_state(name="Blink")
            class Other(State):
                """Another."""

    assert reg.states == {"Blink": Blink}
    assert reg.name_of(Blink) == "Blink" and "type_name" not in vars(Blink), "registering does not change the class"


def test_a_class_of_the_wrong_kind_or_with_a_bad_params_model_is_refused() -> None:
    reg = Registry()
    with pytest.raises(RegistrationError, match="not a subclass of fsm.State"):
        reg.add_state(Transition)  # type: ignore[arg-type]

    class Bad(State):
        Params = dict  # type: ignore[assignment]

    with pytest.raises(RegistrationError, match="Params must be a subclass"):
        reg.add_state(Bad)

    class Fine(State):
        class Params(StateParams):
            speed: float = 1.0

    with pytest.raises(RegistrationError, match="identifier"):
        reg.add_state(Fine, name="not a name")


def test_third_party_types_arrive_through_entry_points(tmp_path: Path) -> None:
    """A distribution that declares `fsm.states` / `fsm.transitions` entry points is picked up by
    `fsmctl` and `fsm.load` without the document naming any module."""
    (tmp_path / "beeper.py").write_text(textwrap.dedent('''
        from fsm import State, Transition

        class Beep(State):
            """Beeps (a third-party state)."""

        class Never(Transition):
            """Never fires (a third-party transition)."""
            def holds(self, ctx):
                return False
    '''))
    dist = tmp_path / "beeper-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: beeper\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[fsm.states]\nBeep = beeper:Beep\n\n"
                                           "[fsm.transitions]\nNever = beeper:Never\n")
    doc = {"initial": "a", "states": [{"id": "a", "type": "Beep"}, {"id": "b", "type": "Beep"}],
           "transitions": [{"type": "Never", "from": "a", "to": "b"}]}
    (tmp_path / "m.json").write_text(json.dumps(doc))
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "FSM_NO_ENTRY_POINTS": ""}
    types = subprocess.run([sys.executable, "-m", "fsm.tools.cli", "types", "Beep", "Never"], capture_output=True,
                           text=True, env=env, cwd=tmp_path, timeout=120)
    assert types.returncode == 0, types.stderr
    assert "Beep: Beeps (a third-party state)." in types.stdout and "Never" in types.stdout
    run = subprocess.run([sys.executable, "-m", "fsm.tools.cli", "run", "m.json", "--max-ticks", "5"],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert run.returncode == 0, run.stderr
    assert "not finished after 5 ticks" in run.stdout
