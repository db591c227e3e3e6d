"""Helpers shared by several test modules (importable because pytest puts tests/ on sys.path)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest


def without_layout(d: Any) -> Any:
    """A document with every ``layout`` key removed, at any depth: what may differ after a diagram round trip."""
    if isinstance(d, dict):
        return {k: without_layout(v) for k, v in d.items() if k != "layout"}
    if isinstance(d, list):
        return [without_layout(x) for x in d]
    return d


def plain_document(d: Any) -> Any:
    """A document without ``layout``, ``$schema`` and empty lists at any depth: what a UMLet round trip may change
    (``"transitions": []`` and a missing ``transitions`` say the same)."""
    if isinstance(d, dict):
        return {k: plain_document(v) for k, v in d.items() if k not in ("layout", "$schema") and v != []}
    if isinstance(d, list):
        return [plain_document(x) for x in d]
    return d


#: Names the folder of the real UMLet corpus when it is not at ``../shared/corpus/uxf`` beside the checkout.
CORPUS_ENV = "TRAL_UXF_CORPUS"


def _corpus() -> Path:
    """The real UMLet files: the folder ``$TRAL_UXF_CORPUS`` names, else ``../shared/corpus/uxf`` beside the
    checkout (where CI puts it). They are third-party diagrams under their authors' licences: read where they are,
    never copied into the project."""
    given = os.environ.get(CORPUS_ENV)
    if given:
        return Path(given)
    return Path(__file__).resolve().parents[2] / "shared" / "corpus" / "uxf"


#: The corpus of real-world UMLet diagrams.
CORPUS = _corpus()

#: Marks a test that reads the corpus: skipped, saying why, when the corpus is not there and no folder was named
#: (a folder named in ``$TRAL_UXF_CORPUS`` that does not exist fails the tests instead of skipping them).
needs_corpus = pytest.mark.skipif(
    not CORPUS.is_dir() and not os.environ.get(CORPUS_ENV),
    reason=f"the real UMLet corpus is not at {CORPUS}: put it at ../shared/corpus/uxf beside the checkout "
           f"(as CI does) or set {CORPUS_ENV} to its folder")


def cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """Run ``fsmctl argv`` in-process: (exit status, stdout, stderr); a traceback is never acceptable."""
    from fsm.tools.cli import main

    try:
        code = main(list(argv))
    except SystemExit as exc:  # argparse usage errors and --help/--version
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    out, err = capsys.readouterr()
    assert "Traceback" not in out and "Traceback" not in err, err
    return code, out, err


def trace_events(text: str) -> list[dict[str, Any]]:
    """The event lines of a JSONL trace (``fsm.trace.recorder``): one per tick in which something happened."""
    import json

    return [line for line in map(json.loads, text.splitlines()) if line.get("type") == "event"]


def finish(proc: Any, timeout: float = 120) -> tuple[int, str, str]:
    """Wait for a ``subprocess.Popen`` (text mode, pipes): (exit status, stdout, stderr); killed and failed when it
    hangs longer than ``timeout`` seconds."""
    import subprocess

    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        raise AssertionError(f"hung: {' '.join(str(a) for a in proc.args)}\n{err}") from None
    return int(proc.returncode), out, err
