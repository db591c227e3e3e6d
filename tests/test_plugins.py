"""``--plugin``: a module in the current folder (as ``python -m`` finds it) or a ``.py`` file; a plugin that fails
says which plugin and where (``FILE:LINE: error: ...``, exit 1); a missing plugin is a usage error (exit 2).
Each case runs in a subprocess, so this session's process-wide registry stays untouched."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

FSMCTL = str(Path(sys.executable).parent / "fsmctl")

GOOD = textwrap.dedent('''\
    from fsm import State, StateParams, register_state


    @register_state
    class Hover(State):
        """Hovers in place."""

        class Params(StateParams):
            pass
''')

PLUGINS = {
    "syntax_plugin.py": "x = 1\ndef f(:\n    pass\n",
    "boom_plugin.py": "import os\n\nraise RuntimeError('no robot\\nattached')\n",
    "bad_plugin.py": "from fsm import register_state\n\n\n@register_state\nclass NotAState:\n    pass\n",
    "dep_plugin.py": "import os\nimport no_such_dependency_for_fsm_tests\n",
}


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "hover_plugin.py").write_text(GOOD)
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "hover_file.py").write_text(GOOD)
    for name, text in PLUGINS.items():
        (tmp_path / name).write_text(text)
    return tmp_path


def fsmctl(cwd: Path, *argv: str) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run([FSMCTL, *argv], cwd=cwd, capture_output=True, text=True, timeout=60)
    assert "Traceback" not in proc.stderr + proc.stdout, proc.stderr
    return proc


def test_module_in_the_current_folder(folder: Path) -> None:
    proc = fsmctl(folder, "--plugin", "hover_plugin", "types", "Hover")
    assert proc.returncode == 0 and "Hover: Hovers in place." in proc.stdout


@pytest.mark.parametrize("spec", ["lib/hover_file.py", "./lib/hover_file.py", "{abs}"])
def test_python_file(folder: Path, spec: str) -> None:
    spec = spec.format(abs=folder / "lib" / "hover_file.py")
    proc = fsmctl(folder, "--plugin", spec, "types", "Hover")
    assert proc.returncode == 0 and "Hover" in proc.stdout


def test_plugin_types_run(folder: Path) -> None:
    (folder / "m.json").write_text('{"initial": "h", "states": [{"id": "h", "type": "Hover"}]}')
    proc = fsmctl(folder, "--plugin", "lib/hover_file.py", "run", "m.json", "--max-ticks", "3")
    assert proc.returncode == 0 and "not finished after 3 ticks" in proc.stdout


@pytest.mark.parametrize("spec, line, words", [
    ("syntax_plugin", 2, "SyntaxError"),
    ("syntax_plugin.py", 2, "SyntaxError"),
    ("boom_plugin", 3, "RuntimeError: no robot attached"),
    ("bad_plugin", 4, "registration failed: <class 'bad_plugin.NotAState'> is not a subclass of fsm.State"),
    ("dep_plugin", 2, "ModuleNotFoundError: No module named 'no_such_dependency_for_fsm_tests'"),
])
def test_failing_plugin_says_which_and_where(folder: Path, spec: str, line: int, words: str) -> None:
    proc = fsmctl(folder, "--plugin", spec, "types")
    assert proc.returncode == 1
    file = spec if spec.endswith(".py") else spec + ".py"
    assert proc.stderr.startswith(f"{folder / file}:{line}: error: plugin {spec}: ")
    assert words in proc.stderr and proc.stderr.count("\n") == 1


def test_duplicate_type_from_two_plugins(folder: Path) -> None:
    proc = fsmctl(folder, "--plugin", "hover_plugin", "--plugin", "lib/hover_file.py", "types")
    assert proc.returncode == 1
    assert "already registered" in proc.stderr and "hover_file.py:" in proc.stderr


@pytest.mark.parametrize("spec, words", [
    ("no_such_plugin_xyz", "no module named 'no_such_plugin_xyz'"),
    ("missing.py", "no such file"),
    ("lib", "no such file"),
    ("1bad-name", "not a module name"),
])
def test_missing_plugin_is_a_usage_error(folder: Path, spec: str, words: str) -> None:
    if spec == "lib":
        spec = "lib/"
    proc = fsmctl(folder, "--plugin", spec, "types")
    assert proc.returncode == 2 and words in proc.stderr
    assert proc.stderr.startswith("fsmctl: error: --plugin")
