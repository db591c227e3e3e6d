"""Docs that cannot drift: every command in a ``sh`` block of README.md and docs/getting-started.md runs here, and
the ``text`` block that follows one is compared with what it prints.

- A ``text`` block is the command's whole output, line by line. ``...`` stands for any text. Figures are exact,
  unless the block follows a ``<!-- output: approximate -->`` line: then each figure may differ by 2 % (or by one
  unit of its last shown digit, whichever is more).
- ``python3 -m venv .venv && .venv/bin/pip install ... && COMMAND``: COMMAND runs here; the set-up is checked
  against ``.ci/run`` (installing is what this checkout's venv already did).
- Commands are run from a scratch folder that links every file of the checkout (so outputs land there), with
  ``.venv`` linked to the venv running the tests.
- What cannot run inside the test suite is skipped with its reason (pytest prints it: ``-rs`` is on by default).
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = ("README.md", "docs/getting-started.md")
APPROXIMATE = "<!-- output: approximate -->"
#: 2 % or one unit of the last digit shown, whichever is more.
TOLERANCE = 0.02
SETUP = re.compile(r"^python3 -m venv \.venv && \.venv/bin/pip install (?:-q )?-e (?:\.|'\.\[\w+\]') && ")

#: Commands the suite cannot run, with why (a skip says it).
SKIPPED = {
    r"mkdocs serve": "serves the site until stopped; tests/test_docs.py builds it with mkdocs build --strict",
    r"^\.venv/bin/pytest$": "the test suite itself: this test is part of it",
    r"^\.venv/bin/pip install ": "installs an extra: the test extra this venv was made with holds every extra",
}
#: Options left out of a command here, with why: the run and its printed figures are the same without them.
LEFT_OUT = {
    "--video lap.mp4": "encoding the 202 s lap's video takes half a minute on a shared machine; tests/test_outputs.py "
                       "and test_examples_run.py write videos",
}


@dataclass
class Shown:
    page: str
    line: int
    command: str
    output: list[str] | None = None
    approximate: bool = False

    def __str__(self) -> str:
        return f"{self.page}:{self.line}: {self.command[:70]}"


def shown(page: str) -> list[Shown]:
    """The commands of the page's ``sh`` blocks, each with the ``text`` block after it (its output), if any."""
    lines = (ROOT / page).read_text(encoding="utf-8").splitlines()
    found: list[Shown] = []
    i = 0
    while i < len(lines):
        if lines[i].strip() != "```sh":
            i += 1
            continue
        i += 1
        block: list[Shown] = []
        pending = ""
        while lines[i].strip() != "```":
            text = lines[i].rstrip()
            if text.endswith("\\"):
                pending += text[:-1].rstrip() + " "
            else:
                command = (pending + text.strip()).strip()
                pending = ""
                if command and not command.startswith("#"):
                    block.append(Shown(page, i + 1, re.sub(r"\s+#.*$", "", command)))
            i += 1
        i += 1
        found.extend(block)
        # a ```text block right after (blank lines, one sentence ending with ':' and the marker between) is the
        # last command's output
        j, approximate = i, False
        while j < len(lines) and (not lines[j].strip() or lines[j].strip() == APPROXIMATE
                                  or (lines[j].rstrip().endswith(":") and not lines[j].startswith("```"))
                                  or (j + 1 < len(lines) and lines[j + 1].rstrip().endswith(":")
                                      and lines[j].strip() and not lines[j].startswith(("```", "#")))):
            approximate = approximate or lines[j].strip() == APPROXIMATE
            j += 1
        if block and j < len(lines) and lines[j].strip() == "```text":
            end = lines.index("```", j + 1)
            block[-1].output = lines[j + 1:end]
            block[-1].approximate = approximate
            i = end + 1
    return found


def _once(commands: list[Shown]) -> list[Shown]:
    """Each command once: the same command shown on two pages runs once, where its output is shown."""
    kept: dict[str, Shown] = {}
    for c in commands:
        if c.command not in kept or (c.output is not None and kept[c.command].output is None):
            kept[c.command] = c
    return [c for c in commands if kept[c.command] is c]


COMMANDS = _once([c for page in PAGES for c in shown(page)])


def test_the_pages_show_commands_and_outputs() -> None:
    assert len(COMMANDS) >= 12, [str(c) for c in COMMANDS]
    assert sum(c.output is not None for c in COMMANDS) >= 2
    assert all(len(c.command) < 300 for c in COMMANDS)


def test_the_readmes_set_up_is_what_ci_runs() -> None:
    """The README's test command is ``.ci/run``'s last line (which also installs Chromium first)."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    tests = [c.command for c in COMMANDS if c.command.endswith("&& .venv/bin/pytest")]
    assert tests and all(c in ci for c in tests), tests
    assert "apt-get install" in ci and "chromium" in ci


def test_the_readme_is_a_landing_page() -> None:
    assert len((ROOT / "README.md").read_bytes()) <= 12 * 1024


@pytest.fixture
def scratch(tmp_path: Path) -> Path:
    for entry in ROOT.iterdir():
        if entry.name not in (".venv", ".git"):
            (tmp_path / entry.name).symlink_to(entry)
    (tmp_path / ".venv").symlink_to(Path(sys.prefix))
    return tmp_path


def _figures(expected: str, approximate: bool) -> tuple[re.Pattern[str], list[str]]:
    """A pattern for one line of output: ``...`` any text; with ``approximate``, each figure a group."""
    number = r"(?<![\w/.])-?\d[\d,]*(?:\.\d+)?"
    parts = re.split(rf"(\.\.\.|{number})", expected)
    pattern, figures = "", []
    for k, part in enumerate(parts):
        if k % 2 == 0:
            pattern += re.escape(part)
        elif part == "...":
            pattern += ".*?"
        elif approximate:
            pattern += r"(-?\d[\d,]*(?:\.\d+)?)"
            figures.append(part)
        else:
            pattern += re.escape(part)
    return re.compile(pattern), figures


def _close(shown_figure: str, printed: str) -> bool:
    want, got = float(shown_figure.replace(",", "")), float(printed.replace(",", ""))
    decimals = len(shown_figure.partition(".")[2])
    return abs(got - want) <= max(TOLERANCE * abs(want), 10.0 ** -decimals) + 1e-9


def compare(cmd: Shown, printed: str) -> None:
    assert cmd.output is not None
    got = printed.rstrip("\n").splitlines()
    assert len(got) == len(cmd.output), f"{cmd}: shows {len(cmd.output)} lines, prints {len(got)}:\n{printed}"
    for want, line in zip(cmd.output, got, strict=True):
        pattern, figures = _figures(want, cmd.approximate)
        m = pattern.fullmatch(line)
        assert m is not None, f"{cmd}:\n  shown:   {want}\n  printed: {line}"
        for figure, value in zip(figures, m.groups(), strict=True):
            assert _close(figure, value), f"{cmd}: shows {figure}, prints {value}:\n  {line}"


def _runnable(cmd: Shown) -> str:
    command = SETUP.sub("", cmd.command)
    for pattern, reason in SKIPPED.items():
        if re.search(pattern, command):
            pytest.skip(f"{cmd.page}:{cmd.line}: {reason}")
    for option in LEFT_OUT:
        command = command.replace(" " + option, "")
    return command


@pytest.mark.parametrize("cmd", COMMANDS, ids=[f"{c.page}:{c.line}" for c in COMMANDS])
def test_a_shown_command_runs_and_prints_what_is_shown(cmd: Shown, scratch: Path) -> None:
    command = _runnable(cmd)
    if " --live" in command:
        _serves(command, scratch)
        return
    proc = subprocess.run(["bash", "-c", command], cwd=scratch, capture_output=True, text=True, timeout=240,
                          env={**os.environ, "COLUMNS": "120"})
    assert proc.returncode == 0, f"{cmd}\n{proc.stdout}\n{proc.stderr}"
    assert "Traceback" not in proc.stderr
    if cmd.output is not None:
        compare(cmd, proc.stdout)


def _serves(command: str, folder: Path) -> None:
    """A live run: it prints the page's address and serves it; stopped here with Ctrl-C."""
    proc = subprocess.Popen(["bash", "-c", f"exec {command}"], cwd=folder, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + 60
        seen = ""
        while time.monotonic() < deadline and "http://127.0.0.1:" not in seen:
            line = proc.stdout.readline()
            if not line:
                break
            seen += line
        assert "http://127.0.0.1:" in seen, seen
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


# -- the comparison itself --------------------------------------------------------------------------------------------
def test_an_approximate_figure_is_matched_with_its_tolerance() -> None:
    cmd = Shown("p", 1, "c", ["car: 164.02 m, 0 collisions, wall error 1.4 cm RMS; ...x real time"], True)
    compare(cmd, "car: 165.10 m, 0 collisions, wall error 1.5 cm RMS; 381.2x real time\n")
    with pytest.raises(AssertionError, match="shows 164.02, prints 170.00"):
        compare(cmd, "car: 170.00 m, 0 collisions, wall error 1.4 cm RMS; 1x real time\n")
    with pytest.raises(AssertionError, match="shows 1.4, prints 1.6"):
        compare(cmd, "car: 164.02 m, 0 collisions, wall error 1.6 cm RMS; 1x real time\n")


def test_an_exact_block_differs_in_one_figure() -> None:
    cmd = Shown("p", 1, "c", ["outcome succeeded after 320 ticks (4.000 s)", "visited: a -> ... -> z"])
    compare(cmd, "outcome succeeded after 320 ticks (4.000 s)\nvisited: a -> b -> c -> z\n")
    with pytest.raises(AssertionError, match="printed: outcome succeeded after 321 ticks"):
        compare(cmd, "outcome succeeded after 321 ticks (4.000 s)\nvisited: a -> z\n")
    with pytest.raises(AssertionError, match="shows 2 lines, prints 1"):
        compare(cmd, "outcome succeeded after 320 ticks (4.000 s)\n")
