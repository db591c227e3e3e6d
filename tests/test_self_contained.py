"""The repository is self-contained: code, tests and docs cite only files inside it, never the project's planning
documents kept elsewhere, never an absolute path of a machine. The one exception is the real UMLet corpus
(third-party files that tests read beside the checkout, ``tests/helpers.py``), named in two places."""

from __future__ import annotations

import os
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Text files that may cite something (code, docs, configuration); data such as diagrams and schemas cannot.
SUFFIXES = {".py", ".md", ".yml", ".yaml", ".toml", ".cfg", ".txt", ".sh", ".js", ".html", ".css"}
#: Folders that are not the project's own text (environments, caches, builds).
SKIPPED = {".git", ".venv", "venv", "site", "build", "dist", ".mypy_cache", "__pycache__", ".pytest_cache",
           ".hypothesis", "node_modules"}
#: What no file may cite (built from parts, so that this file does not match itself).
FORBIDDEN = re.compile("|".join([
    r"\bDESIGN" + r"\.md\b",  # the original design, kept outside the repository
    r"docs/" + r"notes/",  # the planning notes beside it
    r"(?<![\w.-])/(?:work|home|root|Users)/",  # a path of somebody's machine (not 'run/work/grip')
    r"\.\./" + r"shared\b",  # the workplace folder beside the checkout
]))
#: Where the corpus's location beside the checkout is named, on purpose.
CORPUS_MENTIONS = {"tests/helpers.py", "docs/architecture.md"}


def text_files() -> list[Path]:
    files = []
    for folder, subfolders, names in os.walk(ROOT):
        subfolders[:] = [d for d in subfolders if d not in SKIPPED and not d.endswith(".egg-info")]
        here = Path(folder)
        files += [here / n for n in names if Path(n).suffix in SUFFIXES or here.name == ".ci"]
    return files


def offences(path: Path) -> list[str]:
    """``file:line: text`` of each forbidden citation in ``path``."""
    rel = path.relative_to(ROOT).as_posix()
    out = []
    for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        if any(not (rel in CORPUS_MENTIONS and m.group(0).startswith("..")) for m in FORBIDDEN.finditer(line)):
            out.append(f"{rel}:{number}: {line.strip()}")
    return out


def test_nothing_cites_a_file_outside_the_repository() -> None:
    files = text_files()
    assert len(files) > 100 and ROOT / "README.md" in files and ROOT / "fsm" / "session" / "session.py" in files
    found = [o for path in files for o in offences(path)]
    assert found == [], "cites a file outside the repository or an absolute path:\n" + "\n".join(found)


def test_the_check_finds_what_it_forbids(tmp_path: Path) -> None:
    """The patterns match each kind of citation, and leave state paths and user examples alone."""
    for bad in ("see DESIGN" + ".md", "docs/" + "notes/sim-vision.md", 'Path("/' + 'work/shared")', "/" + "home/me/x",
                "../" + "shared/corpus"):
        assert FORBIDDEN.search(bad), bad
    for fine in ("run/work/grip/closing", "job/work", "--keep /tmp/worlds", "docs/architecture.md", "../state"):
        assert not FORBIDDEN.search(fine), fine
