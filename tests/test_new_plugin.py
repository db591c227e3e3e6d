"""``fsmctl new plugin NAME``: the generated package installed editable into a fresh venv (no network), where its
README's five commands pass as written; the same types registered twice through that installed package are one
registration, two classes under one name stay an error naming both; bad names are refused before anything is
written."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from fsm.tools.cli.app import main
from fsm.tools.cli.new import plugin_files

REPO = Path(__file__).resolve().parents[1]
NAME = "lab_types"


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "FSM_NO_ENTRY_POINTS", "VIRTUAL_ENV")}
    return env


@pytest.fixture(scope="module")
def package(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """``(package folder, venv python)``: the package as ``fsmctl new plugin`` writes it, installed with
    ``pip install -e .`` into a fresh venv that sees this venv's packages (tral-fsm, mypy, pytest) through a
    ``.pth`` file, so nothing is downloaded."""
    work = tmp_path_factory.mktemp("newplugin")
    proc = subprocess.run([sys.executable, "-m", "fsm.tools.cli", "new", "plugin", NAME], cwd=work,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(f"wrote {NAME}/ ") and f"mypy --strict src/{NAME}" in proc.stdout
    env_dir = work / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    inner = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                           capture_output=True, text=True, timeout=60).stdout.strip()
    outer = sysconfig.get_paths()["purelib"]
    Path(inner, "_outer_venv.pth").write_text(f"import site; site.addsitedir({outer!r})\n")
    pip = subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-index", "--no-build-isolation", "-e", "."],
                         cwd=work / NAME, capture_output=True, text=True, timeout=300, env=_env())
    assert pip.returncode == 0, pip.stdout + pip.stderr
    return work / NAME, python


def _run(package: tuple[Path, Path], *argv: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    folder, python = package
    return subprocess.run([str(python), *argv], cwd=cwd or folder, capture_output=True, text=True, timeout=300,
                          env=_env())


def test_the_package_has_what_the_readme_lists(package: tuple[Path, Path]) -> None:
    folder, _ = package
    files = {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file() and "egg-info" not in str(p)}
    assert files >= {"pyproject.toml", "README.md", f"src/{NAME}/py.typed", f"src/{NAME}/states.py",
                     f"src/{NAME}/transitions.py", f"machines/{NAME}.json", f"scenarios/{NAME}.scenario.json",
                     f"tests/test_{NAME}.py"}
    pyproject = (folder / "pyproject.toml").read_text()
    assert f'[project.entry-points."fsm.states"]\n{NAME} = "{NAME}.states"' in pyproject
    readme = (folder / "README.md").read_text()
    for command in ("pip install -e .", f"mypy --strict src/{NAME}", f"fsmctl validate machines/{NAME}.json",
                    f"fsmctl test scenarios/{NAME}.scenario.json", "pytest"):
        assert command in readme


def test_mypy_strict_finds_fsm_from_the_editable_installs(package: tuple[Path, Path]) -> None:
    proc = _run(package, "-m", "mypy", "--strict", "--cache-dir", "/dev/null", f"src/{NAME}")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Success: no issues found in 3 source files" in proc.stdout


def test_mypy_strict_reports_a_misspelt_parameter(package: tuple[Path, Path], tmp_path: Path) -> None:
    folder, _ = package
    bad = tmp_path / "bad.py"
    bad.write_text((folder / "src" / NAME / "states.py").read_text().replace("self.params.rate", "self.params.rat"))
    proc = _run(package, "-m", "mypy", "--strict", "--cache-dir", "/dev/null", str(bad))
    assert proc.returncode == 1 and '"RampParams" has no attribute "rat"' in proc.stdout, proc.stdout


def test_validate_test_and_pytest_pass_as_written(package: tuple[Path, Path]) -> None:
    validate = _run(package, "-m", "fsm.tools.cli", "validate", f"machines/{NAME}.json")
    assert (validate.returncode, validate.stdout) == (0, f"machines/{NAME}.json: ok\n"), validate.stderr
    test = _run(package, "-m", "fsm.tools.cli", "test", f"scenarios/{NAME}.scenario.json")
    assert test.returncode == 0, test.stdout + test.stderr
    assert test.stdout.startswith(f"PASS {NAME} (") and test.stdout.endswith("1 passed, 0 failed\n")
    tests = _run(package, "-m", "pytest", "-q", "-p", "no:cacheprovider")
    assert tests.returncode == 0, tests.stdout + tests.stderr
    assert "4 passed" in tests.stdout


def test_the_same_types_loaded_again_are_one_registration(package: tuple[Path, Path], tmp_path: Path) -> None:
    """Installed (entry points) and named again: as a file with --plugin, as a module, in a scenario's
    ``plugins``, through ``MachineTest(plugins=...)`` and ``simulate(plugins=...)``."""
    folder, _ = package
    states = str(folder / "src" / NAME / "states.py")
    for plugin in (states, f"{NAME}.states", f"{NAME}.transitions"):
        proc = _run(package, "-m", "fsm.tools.cli", "--plugin", plugin, "validate", f"machines/{NAME}.json")
        assert proc.returncode == 0, proc.stderr
    scenario = folder / "scenarios" / f"{NAME}.scenario.json"
    text = scenario.read_text().replace('"duration"', f'"plugins": ["../src/{NAME}/states.py", '
                                                      f'"../src/{NAME}/transitions.py"],\n  "duration"')
    (tmp_path / "twice.scenario.json").write_text(text.replace("../machines/", f"{folder}/machines/")
                                                  .replace("../src/", f"{folder}/src/"))
    proc = _run(package, "-m", "fsm.tools.cli", "test", str(tmp_path / "twice.scenario.json"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    code = ("from fsm.testing import MachineTest\n"
            f"m = MachineTest('machines/{NAME}.json', plugins=({states!r},))\n"
            "m.run_for(1.0); m.expect({'outcome': 'succeeded'}); print('ok')")
    proc = _run(package, "-c", code)
    assert (proc.returncode, proc.stdout) == (0, "ok\n"), proc.stderr
    code = ("from fsm.sim import simulate\n"
            f"print(simulate('machines/{NAME}.json', plugins=({states!r},)).run().outcome)")
    proc = _run(package, "-c", code)
    assert (proc.returncode, proc.stdout) == (0, "succeeded\n"), proc.stderr


def test_another_class_under_an_installed_name_is_an_error_naming_both(package: tuple[Path, Path],
                                                                       tmp_path: Path) -> None:
    other = tmp_path / "copy_states.py"
    other.write_text((package[0] / "src" / NAME / "states.py").read_text())
    proc = _run(package, "-m", "fsm.tools.cli", "--plugin", str(other), "types")
    assert proc.returncode == 1
    assert (f"state type 'LabTypesRamp' is already registered by {NAME}.states.LabTypesRamp "
            f"({package[0] / 'src' / NAME / 'states.py'}:") in proc.stderr
    assert f"fsm_plugin_copy_states.LabTypesRamp ({other}:" in proc.stderr and "is another class" in proc.stderr


def test_validate_names_the_installed_plugin_a_palette_lacks(package: tuple[Path, Path]) -> None:
    palette = str(REPO / "diagrams" / "TRAL_State-Machine.uxf")
    proc = _run(package, "-m", "fsm.tools.cli", "validate", palette)
    assert proc.returncode == 0, proc.stderr
    assert ("warning: this UMLet palette holds every type but those of the installed plugin(s) lab-types"
            in proc.stdout)
    proc = _run(package, "-m", "fsm.tools.cli", "palette", "--check", "-o", palette)
    assert proc.returncode == 1
    assert proc.stderr == (f"{palette}: error: stale; regenerate it with `fsmctl palette -o {palette}` (it now has "
                           "the types of the installed plugin(s) lab-types; FSM_NO_ENTRY_POINTS=1 leaves them out)\n")


def test_the_projects_own_tests_pass_with_the_plugin_installed(package: tuple[Path, Path]) -> None:
    """Installed plugins cannot break the project's own tests: they check the committed palette and schema
    against the built-in types alone (tests/conftest.py sets FSM_NO_ENTRY_POINTS=1)."""
    proc = _run(package, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "0", "tests/test_palette.py",
                "tests/test_schema.py", "-k", "committed", cwd=REPO)
    assert proc.returncode == 0, proc.stdout + proc.stderr  # 5 if none had run
    assert proc.stdout.startswith("...")


# -- bad names: refused before anything is written ---------------------------------------------------------------
@pytest.mark.parametrize("name, words", [
    ("my-types", "'my-types': not a valid Python package name"),
    ("1types", "'1types': not a valid Python package name"),
    ("class", "'class': a Python keyword cannot be a package name"),
    ("json", "'json': a module of that name is already importable here"),
    ("_hidden", "'_hidden': a package name starting with _ is private"),
])
def test_a_bad_name_is_refused(name: str, words: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                               capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["new", "plugin", name]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"fsmctl: error: new plugin {words}") and err.count("\n") == 1, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("existing", ["folder", "file", "link"])
def test_nothing_is_written_over_what_exists(existing: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    target = tmp_path / "my_types"
    if existing == "folder":
        target.mkdir()
        (target / "keep.txt").write_text("mine")
    elif existing == "file":
        target.write_text("mine")
    else:
        target.symlink_to(tmp_path / "elsewhere")
    assert main(["new", "plugin", "my_types"]) == 2
    assert "fsmctl: error: new plugin my_types: already exists" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my_types"]
    if existing == "folder":
        assert [p.name for p in target.iterdir()] == ["keep.txt"]


def test_a_missing_directory_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["new", "plugin", "my_types", "-C", str(tmp_path / "nope")]) == 2
    assert "does not exist; create it first" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_the_type_names_carry_the_package_name() -> None:
    files = plugin_files("robot_arm")
    assert "class RobotArmRamp(State[RampParams])" in files["src/robot_arm/states.py"]
    assert "class RobotArmAbove(Transition[AboveParams])" in files["src/robot_arm/transitions.py"]
    assert '"type": "RobotArmRamp"' in files["machines/robot_arm.json"]


def test_an_installed_plugin_that_shadows_a_base_name_is_refused_when_registered(package: tuple[Path, Path]) -> None:
    """A module of the installed package (imported by name, as an entry point is) whose state assigns a name the
    base takes: ``fsmctl`` refuses it as the plugin registers, naming the class, the name and the line."""
    folder, _ = package
    module = folder / "src" / NAME / "clash.py"
    module.write_text("from fsm import Context, State, register_state\n\n\n@register_state\n"
                      "class LabClash(State):\n    def on_enter(self, ctx: Context) -> None:\n"
                      "        self.active = True\n", encoding="utf-8")
    try:
        proc = _run(package, "-m", "fsm.tools.cli", "--plugin", f"{NAME}.clash", "types")
    finally:
        module.unlink()
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert (f"{NAME}.clash.LabClash (type 'LabClash'): self.active = ... ({module}:7) shadows the base's 'active'"
            in proc.stderr), proc.stderr
