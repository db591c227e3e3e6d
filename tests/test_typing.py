"""Typing: mypy in strict mode passes on the package (``[tool.mypy]`` in pyproject.toml, run by
``scripts/typecheck.py``), and a plugin author's state gets its parameters typed from ``State[Params]``.

mypy keeps its cache in ``.mypy_cache/``: the first run in a fresh checkout takes about 8 s, later ones about a
second."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "scripts" / "typecheck.py"
#: What control developers copy: the examples, written the typed way (checked with the documented ones).
EXAMPLES = ["examples/listener.py", "examples/custom_transition.py", "examples/eeros/eeros_plant.py",
            "examples/plugin/src/tral_fsm_blink/states.py", "examples/plugin/src/tral_fsm_blink/transitions.py"]


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
        from fsm.runtime.condition import Condition
        from fsm.model.params import ConditionParams
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


def errors_where_marked(path: Path, source: str) -> subprocess.CompletedProcess[str]:
    """Write ``source`` to ``path``, run mypy strict on it and check that it reports errors on exactly the lines
    marked ``# error``; mypy's run, for what else a test reads of it."""
    path.write_text(source)
    done = typecheck(str(path))
    expected = [n for n, line in enumerate(source.splitlines(), 1) if "# error" in line]
    found = sorted({int(line.split(":")[1]) for line in done.stdout.splitlines() if ": error:" in line})
    assert found == expected, done.stdout + done.stderr
    return done


def test_listeners_and_clocks_are_typed(tmp_path: Path) -> None:
    """A listener gets what the machine passes: a Transition, a monitor's Restart or None; one that takes only a
    Transition is refused, as is an object without the methods; the optional hooks have their Protocols."""
    source = textwrap.dedent('''
        from typing import Any

        from fsm import Context, Listener, Machine, State, Transition
        from fsm.runtime.machine import Fired, MonitorListener
        from fsm.runtime.supervisor import Monitor, Restart


        class Ticks(Listener):
            def on_tick(self, machine: Machine) -> None:
                pass


        class ByMethods:
            def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                              transition: Fired | None) -> None:
                if isinstance(transition, Restart):
                    monitor: Monitor | None = transition.monitor
                elif transition is not None:
                    fired: Transition[Any] = transition
                    name: str = transition.type_name

            def on_tick(self, machine: Machine) -> None:
                pass


        class OnlyTransitions(Listener):
            def on_transition(self, ctx: Context, source: State[Any] | None, target: State[Any],
                              transition: Transition[Any] | None) -> None:  # error: a restart is no Transition
                pass


        class Monitors(Listener):
            def on_monitor(self, ctx: Context, owner: State[Any], monitor: Monitor) -> None:
                label: str = monitor.label


        def attach(machine: Machine) -> None:
            ticks: Ticks = machine.add_listener(Ticks())
            machine.add_listener(ByMethods())
            machine.add_listener(object())  # error: not a listener
            watching: MonitorListener = Monitors()
            deaf: MonitorListener = Ticks()  # error: no on_monitor
            due: float = machine.clock.time_at(3)
            period: int = machine.clock.dt  # error: a float
    ''')
    done = errors_where_marked(tmp_path / "listening.py", source)
    assert 'Argument 4 of "on_transition" is incompatible with supertype' in done.stdout


def python_blocks(page: Path) -> str:
    return "\n".join(re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), flags=re.M | re.S))


def test_examples_and_documented_types_pass_mypy_strict(tmp_path: Path) -> None:
    """The examples and the code of the pages on writing types and plugins type-check in strict mode, with no
    ``type: ignore``: what plugin authors copy is the typed way."""
    pages = []
    for name in ("extending", "plugins"):
        page = tmp_path / f"{name}_page.py"
        page.write_text(python_blocks(ROOT / "docs" / f"{name}.md"), encoding="utf-8")
        pages.append(str(page))
    done = typecheck(*EXAMPLES, *pages)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"Success: no issues found in {len(EXAMPLES) + len(pages)} source files" in done.stdout
    ignored = [f"{name}:{n}" for name in EXAMPLES
               for n, line in enumerate((ROOT / name).read_text(encoding="utf-8").splitlines(), 1)
               if "type: ignore" in line]
    assert ignored == []


def test_no_type_ignore_in_states_and_transitions() -> None:
    """Parameter access needs no ``# type: ignore`` any more; the library of types has none at all."""
    found = [f"{path.relative_to(ROOT)}:{n}" for folder in ("states", "transitions")
             for path in sorted((ROOT / "fsm" / folder).rglob("*.py"))
             for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if "type: ignore" in line]
    assert found == []


def _type_ignores() -> list[tuple[str, str]]:
    return [(f"{path.relative_to(ROOT)}:{n}", line) for path in sorted((ROOT / "fsm").rglob("*.py"))
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if "type: ignore" in line]


def test_strict_mode_covers_the_whole_package() -> None:
    """mypy checks all of fsm/ (tools and testing included): nothing is excluded, skipped or let off its errors, and
    at most 10 ``type: ignore`` stand in the whole package (issue 31)."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["mypy"]
    assert config["strict"] is True and config["packages"] == ["fsm"]
    assert "exclude" not in config
    overrides = config.get("overrides", [])
    assert not [o for o in overrides if o.get("follow_imports") == "skip"]
    ignored = [m for o in overrides if o.get("ignore_errors") for m in o["module"]]
    assert ignored == []
    found = _type_ignores()
    assert len(found) <= 10, "\n".join(where for where, _ in found)


def test_type_ignores_in_tools_and_testing_say_why() -> None:
    """A ``type: ignore`` in tools/ or testing/ names its error code and, in a comment after it, the reason."""
    reason = re.compile(r"#\s*type:\s*ignore\[[a-z-]+(,\s*[a-z-]+)*\]\s+#\s*\S")
    bare = [where for where, line in _type_ignores()
            if where.startswith(("fsm/tools/", "fsm/testing/")) and not reason.search(line)]
    assert bare == []
