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


def test_complexity_exceptions_are_only_the_one_hot_path() -> None:
    """No file is let off C901 (issue 31); one function carries a ``noqa: C901`` with its reason: Region.tick, the
    hot path of every tick, where each split measured costs a call per tick (docs/performance.md)."""
    import tomllib

    lint = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["ruff"]["lint"]
    assert "C901" in lint["select"] and lint["mccabe"]["max-complexity"] == 15
    assert not [path for path, codes in lint.get("per-file-ignores", {}).items() if "C901" in codes]
    noqa = [f"{path.relative_to(ROOT)}:{n}" for folder in ("fsm", "benchmarks", "scripts")
            for path in sorted((ROOT / folder).rglob("*.py"))
            for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if "noqa: C901" in line]
    assert len(noqa) == 1 and noqa[0].startswith("fsm/runtime/region.py:"), noqa


#: Imports inside functions (ruff's PLC0415) are kept for these libraries and adapters only: the optional extras and
#: heavy libraries no command line or validation may load (tests/test_startup.py's HEAVY), and the adapters that
#: load them (fsm.sim: pymunk; fsm.vision: OpenCV; fsm.ros: the ROS 2 extras).
LAZY_MODULES = ("cv2", "numpy", "pymunk", "lxml", "jsonschema", "aiohttp", "zenoh", "ray", "mcap", "rosbags", "rclpy",
                "imageio_ffmpeg", "hypothesis", "pytest", "fsm.sim", "fsm.vision", "fsm.ros")
#: ... and anywhere in these files, for the reason given.
LAZY_FILES = {
    "fsm/tools/cli/": "start-up: `fsmctl --help` builds every command's parser, and each command imports what it "
                      "runs only when it runs (tests/test_startup.py counts the modules)",
    "fsm/tools/runs/": "start-up: every command imports runs.args (through cli/common) to parse its command line",
    "fsm/tools/sweep/backends.py": "the Ray extra, and the process pool, only for the backend the sweep uses",
    "fsm/tools/sweep/worker.py": "imported by each pool process as it starts: a run's machinery loads with its first "
                                 "job",
    "fsm/testing/": "the pytest plugin is imported by every pytest run once tral-fsm is installed: the scenario "
                    "runner loads only when a test uses it",
    "fsm/tools/live/": "the live extra (aiohttp), and start-up: fsmctl's parser takes `run --live`'s and the "
                       "sweep's options from live/runner.py, whose commands load the server and the debugger when run",
    "fsm/tools/ros/": "the ROS 2 extras (rclpy, zenoh, rosbags through fsm.ros), and start-up: fsmctl's parser takes "
                      "the endpoint options from ros/common.py; `run --ros`, `sim --ros` and `replay` load their "
                      "machinery when run",
}


def test_imports_inside_functions_only_for_optional_extras() -> None:
    """In fsm/tools and fsm/testing an import sits at the top of its module unless it loads an optional extra or a
    heavy library (:data:`LAZY_MODULES`) or its file is on the short list :data:`LAZY_FILES`, which says why."""
    import json
    import re

    done = ruff("--select", "PLC0415", "--output-format", "json", "fsm/tools", "fsm/testing")
    found = json.loads(done.stdout)
    assert found, done.stderr  # the rule runs (the lists below are in use)
    statement = re.compile(r"^\s*(?:from\s+(\S+)\s+import|import\s+(\S+))")
    offenders = []
    for item in found:
        path = Path(item["filename"]).resolve().relative_to(ROOT).as_posix()
        if path.startswith(tuple(LAZY_FILES)):
            continue
        line = Path(item["filename"]).read_text(encoding="utf-8").splitlines()[item["location"]["row"] - 1]
        match = statement.match(line)
        module = (match.group(1) or match.group(2)) if match else ""
        if not any(module == m or module.startswith(m + ".") for m in LAZY_MODULES):
            offenders.append(f"{path}:{item['location']['row']}: {line.strip()}")
    assert offenders == [], "import these at the top of the module:\n" + "\n".join(offenders)
