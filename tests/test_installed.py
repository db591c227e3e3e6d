"""The installed distributions' entry points are read once per process: the registry's four groups and the
reading rule's readers are looked up in one scan of importlib.metadata, with what it finds."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path
from typing import Any

import pytest

from fsm.loading import installed
from fsm.loading.reading import reader_for
from fsm.loading.registry import Registry


@pytest.fixture
def scans(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Counts the scans of the installed distributions (from a fresh index)."""
    count: list[int] = []
    real = importlib.metadata.entry_points

    def counting(**kwargs: Any) -> Any:
        count.append(1)
        return real(**kwargs)

    installed.forget()
    monkeypatch.setattr(importlib.metadata, "entry_points", counting)
    yield count
    installed.forget()


def test_one_scan_serves_the_registry_and_the_readers(scans: list[int]) -> None:
    Registry().load_entry_points()
    reader = reader_for(Path("drawing.i36-no-such-suffix"))
    assert reader.__name__ == "read_json" and len(scans) == 1
    assert installed.entry_points(group="fsm.readers", name="uxf")
    assert len(scans) == 1
    installed.forget()
    installed.entry_points(group="fsm.states")
    assert len(scans) == 2


def test_the_index_finds_what_importlib_metadata_finds() -> None:
    for group in ("fsm.readers", "fsm.states", "pytest11", "console_scripts"):
        ours = {(ep.name, ep.value) for ep in installed.entry_points(group=group)}
        assert ours == {(ep.name, ep.value) for ep in importlib.metadata.entry_points(group=group)}
    assert ("uxf", "fsm.tools.umlet.reader:read_uxf") in {
        (ep.name, ep.value) for ep in installed.entry_points(group="fsm.readers")}
