"""The examples for control developers (examples/) run as documented, so they cannot rot: a custom transition,
the Listener API, and a plugin package installed for real so that its entry points are discovered."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"


def python(*argv: str, env: dict[str, str] | None = None, cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, *argv], capture_output=True, text=True, timeout=120, cwd=cwd,
                          env={**os.environ, **(env or {})})


def test_custom_transition_fires_after_the_hysteresis_and_its_samples() -> None:
    proc = python(str(EXAMPLES / "custom_transition.py"))
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "outcome: docked"
    # The voltage ripples across 11.0 V from tick 30 on; only four low samples in a row (from tick 36) fire.
    assert re.fullmatch(r"docked at t=0\.5000 s \(tick 40\), battery 10\.\d+ V", lines[1]), lines[1]


def test_custom_transition_never_arms_when_the_battery_starts_low() -> None:
    """Hysteresis: a level that was never seen above `below + hysteresis` since entering the source never fires."""
    code = ("import sys; sys.path.insert(0, 'examples'); import fsm, custom_transition as ct\n"
            "m = fsm.load(dict(ct.MACHINE, vars={'battery': 10.0, 'low_at': -1.0}))\n"
            "print(fsm.run(m, duration=1.0).outcome, m.active_path, m.ctx.vars['low_at'])")
    proc = python("-c", code)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["None", "work", "-1.0"]


def test_listener_logs_transitions_and_dwell_times() -> None:
    proc = python(str(EXAMPLES / "listener.py"))
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "  0.500 s  wait_start -> run  (Signal)" in out
    assert "  3.000 s  run/work/grip -> run/work/retreat  (Finished)" in out
    assert "outcome: succeeded at 4.000 s" in out
    dwell = dict(re.findall(r"^  (\S+)\s+([\d.]+) s$", out, re.M))
    assert dwell["wait_start"] == "0.500" and dwell["run"] == "3.500" and dwell["run/work/approach"] == "2.000"


@pytest.fixture(scope="module")
def installed_plugin(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The plugin package installed with pip into a folder of its own (no network, the test venv untouched)."""
    work = tmp_path_factory.mktemp("plugin")
    source = work / "src"
    shutil.copytree(EXAMPLES / "plugin", source)  # the build writes egg-info next to the sources
    target = work / "site"
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                           "--no-index", "--target", str(target), str(source)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (target / "tral_fsm_blink").is_dir() and list(target.glob("tral_fsm_blink-*.dist-info"))
    return target


def test_installed_plugin_types_reach_fsmctl_through_entry_points(installed_plugin: Path) -> None:
    env = {"PYTHONPATH": str(installed_plugin), "FSM_NO_ENTRY_POINTS": ""}
    types = python("-m", "fsm.tools.cli", "types", "Blink", "Counted", env=env, cwd=installed_plugin.parent)
    assert types.returncode == 0, types.stderr
    assert "Blink: Toggles blackboard variable" in types.stdout
    assert "Counted: Fires when blackboard variable" in types.stdout
    run = python("-m", "fsm.tools.cli", "run", str(EXAMPLES / "plugin" / "blink.json"), env=env,
                 cwd=installed_plugin.parent)
    assert run.returncode == 0, run.stderr
    assert "outcome succeeded after 100 ticks (1.250 s)" in run.stdout


def test_without_the_plugin_its_types_are_unknown() -> None:
    run = python("-m", "fsm.tools.cli", "run", str(EXAMPLES / "plugin" / "blink.json"))
    assert run.returncode == 1 and "unknown state type 'Blink'" in run.stderr


def test_plugin_module_file_with_the_plugin_option() -> None:
    states = EXAMPLES / "plugin" / "src" / "tral_fsm_blink" / "states.py"
    proc = python("-m", "fsm.tools.cli", "--plugin", str(states), "types", "Blink")
    assert proc.returncode == 0, proc.stderr
    assert "period: number > 0 (default 0.5)" in proc.stdout
