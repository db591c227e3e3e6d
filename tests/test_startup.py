"""Start-up: what ``import fsm``, ``fsmctl --version``, ``import fsm.tools.cli``, ``fsmctl --help`` and ``fsmctl
validate`` import, read from ``python -X importtime`` in a fresh interpreter. Modules are counted, and the one
figure in microseconds is a ratio to the standard library's ``asyncio`` imported in the same process, never a
wall-clock limit (the machine is shared): the figures in milliseconds are in docs/performance.md (issue 36)."""

from __future__ import annotations

import importlib.util
import re
import statistics
import subprocess
import sys
from pathlib import Path

import fsm

ROOT = Path(__file__).resolve().parent.parent

#: Libraries only some commands need: none of them is imported to parse a command line or validate a document.
HEAVY = {"numpy", "cv2", "pymunk", "lxml", "jsonschema", "aiohttp", "zenoh", "ray", "mcap", "rosbags", "imageio_ffmpeg",
         "hypothesis", "pytest"}
#: What validating a JSON document may import beyond the standard library.
VALIDATE_THIRD_PARTY = {"pydantic", "pydantic_core", "annotated_types", "typing_extensions", "typing_inspection"}


def importtime(code: str, *args: str) -> tuple[list[tuple[str, int]], str]:
    """What a fresh interpreter imports running ``code``: ``(module, cumulative microseconds)`` in import order, and
    its standard output."""
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", code, *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    rows = re.findall(r"^import time:\s+\d+ \|\s+(\d+) \|\s*(\S+)$", done.stderr, re.M)
    assert rows, done.stderr[-500:]
    return [(name, int(micros)) for micros, name in rows], done.stdout


def imported(code: str, *args: str) -> tuple[list[str], str]:
    """The modules a fresh interpreter imports running ``code`` (in import order), and its standard output."""
    rows, out = importtime(code, *args)
    return [name for name, _ in rows], out


def beyond_start(code: str, *args: str) -> list[str]:
    """The modules ``code`` imports beyond those of the interpreter's own start (site, .pth files)."""
    start = set(imported("pass")[0])
    return [n for n in imported(code, *args)[0] if n not in start]


def roots(names: list[str]) -> set[str]:
    return {n.split(".")[0] for n in names}


def installed(name: str) -> bool:
    """Whether top-level module ``name`` comes from an installed distribution (site-packages), not the standard
    library, the interpreter's start or this checkout."""
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return False
    where = [spec.origin or ""] + list(spec.submodule_search_locations or []) if spec is not None else []
    return any("site-packages" in w or "dist-packages" in w for w in where) and not name.startswith("_")


def test_fsmctl_version_imports_nothing_of_the_package() -> None:
    names, out = imported("import sys, fsmctl_entry; sys.argv = ['fsmctl', '--version']; sys.exit(fsmctl_entry.main())")
    assert out == f"fsmctl {fsm.__version__}\n"
    assert not roots(names) & ({"fsm", "pydantic"} | HEAVY), sorted(roots(names))


def test_importing_fsm_imports_names_on_first_use() -> None:
    names = beyond_start("import fsm; assert fsm.__version__")
    assert {n for n in names if n.startswith("fsm")} == {"fsm", "fsm.model", "fsm.model.version"}, names
    assert "pydantic" not in names


def test_importing_the_cli_loads_no_command_and_no_library() -> None:
    names = beyond_start("import fsm.tools.cli")
    assert not roots(names) & (HEAVY | {"pydantic", "asyncio"}), sorted(roots(names))
    # 33 today (argparse, dataclasses and inspect for the errors, the CLI's app and common): a bound that an import
    # of the loader, of pydantic or of a command's modules breaks
    assert len(names) <= 45, names


def test_help_builds_the_parser_without_the_commands_libraries() -> None:
    """Every command's module is imported to build the parser; what they need to run is not (the live page's
    asyncio, the sweep file's pydantic models, the loader)."""
    names = beyond_start("import sys; from fsm.tools.cli import main; sys.exit(main(sys.argv[1:]))", "--help")
    assert not roots(names) & (HEAVY | {"pydantic", "asyncio"}), sorted(roots(names))
    assert not {n for n in names if n.startswith(("fsm.loading", "fsm.runtime.machine", "fsm.session"))}, names
    # 75 today
    assert len(names) <= 100, names


def test_importing_the_cli_costs_less_than_asyncio_times_2_5() -> None:
    """``-X importtime``'s cumulative microseconds of ``fsm.tools.cli`` against the standard library's ``asyncio``
    imported right after it in the same process, median of three processes: about 0.4-0.9 today, 9-10 when
    ``import fsm`` imported the loader and the runtime eagerly. A ratio, so the machine's load cancels out."""
    ratios = []
    for _ in range(3):
        rows, _ = importtime("import fsm.tools.cli; import asyncio")
        cumulative = dict(rows)
        ratios.append(cumulative["fsm.tools.cli"] / cumulative["asyncio"])
    assert statistics.median(ratios) < 2.5, ratios


def test_validate_imports_no_library_beyond_pydantic() -> None:
    names = beyond_start("import sys; from fsm.tools.cli import main; sys.exit(main(sys.argv[1:]))",
                         "validate", str(ROOT / "diagrams" / "hallway_lap.json"))
    third_party = {r for r in roots(names) if installed(r)}
    assert third_party <= VALIDATE_THIRD_PARTY, sorted(third_party - VALIDATE_THIRD_PARTY)
    assert "asyncio" not in names
    # 234 today, most of them the loader, the built-in types' pydantic models and pydantic itself
    assert len(names) <= 300, len(names)


def test_a_command_named_plainly_builds_its_own_parser_only() -> None:
    """``fsmctl validate FILE`` imports the validate command's module, not the other commands' (a run's options
    import the live page's, the robot's and the simulator's modules); an unknown word still gets every command's
    name in its message."""
    # the modules at exit (importlib.import_module's imports are not in -X importtime's lines)
    code = ("import atexit, sys; atexit.register(lambda: print(' '.join(sorted(sys.modules)), file=sys.stderr)); "
            "from fsm.tools.cli import main; sys.exit(main(sys.argv[1:]))")
    done = subprocess.run([sys.executable, "-c", code, "--no-cache", "validate",
                           str(ROOT / "diagrams" / "hallway_lap.json")], capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 0 and done.stdout.endswith(": ok\n"), done.stderr
    names = done.stderr.split()
    commands = {n for n in names if n.startswith("fsm.tools.cli.") and n.count(".") == 3}
    assert commands == {"fsm.tools.cli.app", "fsm.tools.cli.common", "fsm.tools.cli.validate"}, sorted(commands)
    assert not {n for n in names if n.startswith(("fsm.tools.live", "fsm.tools.ros", "fsm.sim"))}, names
    done = subprocess.run([sys.executable, "-c", "import sys; from fsm.tools.cli import main; "
                           "sys.exit(main(sys.argv[1:]))", "validat", "x.json"], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 2 and "validate" in done.stderr and "sweep" in done.stderr, done.stderr


def test_lazy_names_match_the_imports_type_checkers_read() -> None:
    """fsm/__init__.py names each export twice, in the table ``__getattr__`` imports from and in the imports under
    ``TYPE_CHECKING`` (mypy, editors): both say the same, and every name resolves to that module's object."""
    import ast
    import importlib

    tree = ast.parse((ROOT / "fsm" / "__init__.py").read_text(encoding="utf-8"))
    typed = {alias.asname or alias.name: node.module for block in tree.body if isinstance(block, ast.If)
             and "TYPE_CHECKING" in ast.unparse(block.test) for node in block.body
             if isinstance(node, ast.ImportFrom) for alias in node.names}
    table: dict[str, str] = fsm._NAMES
    assert typed == table
    assert set(fsm.__all__) <= set(table)
    assert set(fsm.__all__) | set(table) <= set(dir(fsm))
    for name, module in table.items():
        assert getattr(fsm, name) is getattr(importlib.import_module(module), name)
    star: dict[str, object] = {}
    exec("from fsm import *", star)  # what star-importing code gets
    assert set(fsm.__all__) <= set(star)
