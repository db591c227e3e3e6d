"""Type-check the package with mypy in strict mode (the configuration is ``[tool.mypy]`` in pyproject.toml).

mypy names a module by its place on disk, but ``states/`` and ``transitions/`` install as ``fsm.states`` and
``fsm.transitions`` (setuptools ``package-dir``), and an editable install maps them with an import hook that mypy
does not follow. So this lays out the installed package as links in ``.mypy_cache/layout/fsm`` (each entry of
``fsm/``, ``states`` -> ``states/``, ``transitions`` -> ``transitions/``), which the configuration's
``mypy_path`` names, runs ``python -m mypy`` on it and prints its messages with the repository's paths.

Usage: ``python scripts/typecheck.py [mypy options]``; the exit status is mypy's.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Where the installed layout is linked (the configuration's ``mypy_path``); beside mypy's own cache.
LAYOUT = ROOT / ".mypy_cache" / "layout"
#: Subpackages that live outside ``fsm/`` in the repository: installed name under fsm -> folder.
MAPPED = {"states": "states", "transitions": "transitions", "testing": "testing"}


def link_layout(root: Path = ROOT, layout: Path = LAYOUT) -> Path:
    """Make ``layout/fsm`` the package as installed: a link per entry of ``fsm/`` and one per mapped folder.

    Links are made again each time, so modules added or removed since the last run are seen."""
    package = layout / "fsm"
    package.mkdir(parents=True, exist_ok=True)
    wanted = {entry.name: entry for entry in (root / "fsm").iterdir() if entry.name != "__pycache__"}
    wanted.update({name: root / folder for name, folder in MAPPED.items()})
    for link in package.iterdir():
        if link.name not in wanted or not link.is_symlink() or Path(os.readlink(link)) != wanted[link.name]:
            link.unlink()
    for name, target in wanted.items():
        link = package / name
        if not link.is_symlink():
            link.symlink_to(target, target_is_directory=target.is_dir())
    return layout


def repository_path(line: str, root: Path = ROOT, layout: Path = LAYOUT) -> str:
    """One line of mypy's output with a path in the layout replaced by the file's path in the repository."""
    for prefix in (str(layout / "fsm") + os.sep, os.path.relpath(layout / "fsm", root) + os.sep):
        if line.startswith(prefix):
            rest = line[len(prefix):]
            head, _, tail = rest.partition(os.sep)
            folder = MAPPED.get(head)
            return (f"{folder}{os.sep}{tail}" if folder is not None and tail else f"fsm{os.sep}{rest}")
    return line


def main(argv: list[str]) -> int:
    """Link the layout, run mypy with ``argv`` (none: the configuration's packages) and print what it says."""
    link_layout()
    done = subprocess.run([sys.executable, "-m", "mypy", *argv], cwd=ROOT, capture_output=True, text=True)
    for line in done.stdout.splitlines():
        print(repository_path(line))
    sys.stderr.write(done.stderr)
    return done.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
