"""Linting: ruff passes on the whole tree (pyflakes, import order, bugbear, lines of at most 120 characters, no
function over cyclomatic complexity 15; the configuration is ``[tool.ruff]`` in pyproject.toml), so the README's test
command fails when it does not."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def ruff(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    """``python -m ruff check`` with ``args`` in ``cwd``, without a cache (nothing is left in the checkout)."""
    return subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=120)


def test_ruff_passes_on_the_tree() -> None:
    done = ruff(".")
    assert done.returncode == 0, f"ruff found problems (`ruff check --fix .` fixes some):\n{done.stdout}{done.stderr}"


def test_the_configuration_catches_what_it_should(tmp_path: Path) -> None:
    """The rules the tree is held to are the ones configured: a file breaking each is reported by its code."""
    source = "\n".join([
        "import sys",  # F401: unused
        "import os",  # I001: unsorted
        "",
        "",
        "def pairs(a: list[int], b: list[int]) -> list[tuple[int, int]]:",
        "    return list(zip(a, b))",  # B905: zip without strict=
        "",
        "",
        f"LONG = {'x' * 120!r}",  # E501
        "",
        "",
        "def branchy(x: int) -> int:",  # C901: complexity 16
        *[f"    if x == {n}:\n        return {n}" for n in range(15)],
        "    return -1",
        "",
    ])
    (tmp_path / "bad.py").write_text(source)
    done = ruff("--config", str(ROOT / "pyproject.toml"), "--output-format", "concise", "bad.py", cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    codes = {line.split(" ")[1] for line in done.stdout.splitlines() if line.startswith("bad.py:")}
    assert codes == {"F401", "I001", "B905", "E501", "C901"}, done.stdout
    assert "`branchy` is too complex (16 > 15)" in done.stdout


def test_complexity_exceptions_are_only_the_temporary_ones() -> None:
    """No file is let off C901 but the modules other branches are splitting in this round (issue 31: the list only
    shrinks, and goes at the merge)."""
    import tomllib

    lint = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["ruff"]["lint"]
    assert "C901" in lint["select"] and lint["mccabe"]["max-complexity"] == 15
    let_off = {path for path, codes in lint.get("per-file-ignores", {}).items() if "C901" in codes}
    assert let_off <= {"fsm/loading/checking.py", "fsm/model/expr.py", "fsm/runtime/region.py", "fsm/sim/car.py",
                       "fsm/trace/recorder.py", "fsm/tools/graph/*"}
    assert not [p for p in let_off if p.startswith(("fsm/tools/cli", "fsm/tools/scenario", "fsm/tools/umlet",
                                                    "fsm/tools/sweep", "fsm/tools/recording", "fsm/tools/report",
                                                    "fsm/tools/runs", "fsm/tools/files", "fsm/testing"))]
