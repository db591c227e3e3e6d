"""Typing: mypy in strict mode passes on the package (``[tool.mypy]`` in pyproject.toml, run by
``scripts/typecheck.py``), and a plugin author's state gets its parameters typed from ``State[Params]``.

mypy keeps its cache in ``.mypy_cache/``: the first run in a fresh checkout takes about 8 s, later ones about a
second."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import textwrap
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "scripts" / "typecheck.py"


def typecheck(*args: str) -> subprocess.CompletedProcess[str]:
    """``scripts/typecheck.py`` (``python -m mypy`` on the installed layout) with ``args``."""
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)


def script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("typecheck_script", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_mypy_strict_passes_on_the_package() -> None:
    done = typecheck()
    assert done.returncode == 0, f"mypy found problems:\n{done.stdout}{done.stderr}"
    assert "Success: no issues found" in done.stdout


def test_parameters_are_typed_for_plugin_authors(tmp_path: Path) -> None:
    """A state and a condition declared the documented way type ``self.params``: a misspelt parameter and a
    wrong type are mypy errors, the right ones are not; the built-in clocks are ``Clock``s."""
    source = textwrap.dedent('''
        from fsm import Clock, Context, RealTimeClock, SimulatedClock, State, StateParams
        from fsm.condition import Condition
        from fsm.params import ConditionParams
        from fsm.sequencer.steps import Wait
        from fsm.transitions.car import Distance


        class BlinkParams(StateParams):
            period: float = 0.5


        class Blink(State[BlinkParams]):
            Params = BlinkParams

            def tick(self, ctx: Context) -> None:
                half: float = self.params.period / 2
                self.params.perod  # error: misspelt
                name: int = self.params.id  # error: a str


        class HotParams(ConditionParams):
            limit: float


        class Hot(Condition[HotParams]):
            Params = HotParams

            def holds(self, ctx: Context) -> bool:
                return self.params.limit > 0


        def builtins(wait: Wait, distance: Distance) -> None:
            total: float = wait.params.seconds + distance.params.distance
            wait.params.nope  # error: no such parameter


        clocks: list[Clock] = [SimulatedClock(), RealTimeClock()]
        not_a_clock: Clock = object()  # error: not a clock
    ''')
    plugin = tmp_path / "blink_plugin.py"
    plugin.write_text(source)
    expected = [n for n, line in enumerate(source.splitlines(), 1) if "# error" in line]
    done = typecheck(str(plugin))
    errors = sorted({int(line.split(":")[1]) for line in done.stdout.splitlines() if ": error:" in line})
    assert errors == expected, done.stdout + done.stderr
    assert '"BlinkParams" has no attribute "perod"' in done.stdout
    assert '"WaitParams" has no attribute "nope"' in done.stdout


def test_no_type_ignore_in_states_and_transitions() -> None:
    """Parameter access needs no ``# type: ignore`` any more; the library of types has none at all."""
    found = [f"{path.relative_to(ROOT)}:{n}" for folder in ("states", "transitions")
             for path in sorted((ROOT / folder).rglob("*.py"))
             for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if "type: ignore" in line]
    assert found == []


def test_messages_name_files_in_the_repository(tmp_path: Path) -> None:
    """mypy checks the linked layout; its messages are printed with the paths of the checkout."""
    mod = script()
    layout = tmp_path / "layout"
    root = tmp_path / "repo"
    for folder in ("fsm", "states", "transitions"):
        (root / folder).mkdir(parents=True)
    (root / "fsm" / "state.py").write_text("")
    (root / "fsm" / "stale.py").write_text("")
    mod.link_layout(root, layout)
    (root / "fsm" / "stale.py").unlink()
    mod.link_layout(root, layout)
    assert sorted(p.name for p in (layout / "fsm").iterdir()) == ["state.py", "states", "transitions"]
    assert (layout / "fsm" / "states").resolve() == (root / "states").resolve()
    sep = "/" if sys.platform != "win32" else "\\"
    for line, want in ((f"{layout}{sep}fsm{sep}states{sep}driving.py:3: error: x", f"states{sep}driving.py:3: error: x"),
                       (f"{layout}{sep}fsm{sep}sequencer{sep}steps.py:1: note", f"fsm{sep}sequencer{sep}steps.py:1: note"),
                       (f"{layout}{sep}fsm{sep}state.py:9: error", f"fsm{sep}state.py:9: error"),
                       ("Found 2 errors in 1 file", "Found 2 errors in 1 file")):
        assert mod.repository_path(line, root, layout) == want
