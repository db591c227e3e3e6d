"""Linting: ruff passes on the whole tree (pyflakes, import order, bugbear, lines of at most 120 characters; the
configuration is ``[tool.ruff]`` in pyproject.toml), so the README's test command fails when it does not."""

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
    ])
    (tmp_path / "bad.py").write_text(source)
    done = ruff("--config", str(ROOT / "pyproject.toml"), "--output-format", "concise", "bad.py", cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    codes = {line.split(" ")[1] for line in done.stdout.splitlines() if line.startswith("bad.py:")}
    assert codes == {"F401", "I001", "B905", "E501"}, done.stdout
