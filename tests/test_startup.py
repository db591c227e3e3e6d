"""Start-up: what ``fsmctl --version``, ``import fsm.tools.cli`` and ``fsmctl validate`` import, read from
``python -X importtime`` in a fresh interpreter. Modules are counted, not timed (the machine is shared): the
figures in milliseconds are in docs/performance.md (issue 36)."""

from __future__ import annotations

import importlib.util
import re
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


def imported(code: str, *args: str) -> tuple[list[str], str]:
    """The modules a fresh interpreter imports running ``code`` (in import order), and its standard output."""
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", code, *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    names = re.findall(r"^import time:\s+\d+ \|\s+\d+ \|\s*(\S+)$", done.stderr, re.M)
    assert names, done.stderr[-500:]
    return names, done.stdout


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


def test_importing_the_cli_loads_no_heavy_library_and_few_modules() -> None:
    names, _ = imported("import fsm.tools.cli")
    assert not roots(names) & HEAVY, sorted(roots(names) & HEAVY)
    # 221 lines today, the interpreter's start included (the core and pydantic): a bound that a new top-level import
    # of a library or of a command's modules breaks
    assert len(names) <= 260, len(names)


def test_validate_imports_no_library_beyond_pydantic() -> None:
    names, out = imported("import sys; from fsm.tools.cli import main; sys.exit(main(sys.argv[1:]))",
                          "validate", str(ROOT / "diagrams" / "hallway_lap.json"))
    # what the interpreter's start imports (site's .pth files: the ROS 2 wheels' bootstrapper) is not validate's
    at_start = roots(imported("pass")[0])
    third_party = {r for r in roots(names) - at_start if installed(r)}
    assert third_party <= VALIDATE_THIRD_PARTY, sorted(third_party - VALIDATE_THIRD_PARTY)
