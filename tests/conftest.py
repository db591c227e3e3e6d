"""Test configuration: in CI (``CI`` set) hypothesis runs derandomized, so a run is reproducible and a red
CI means a real regression, not a newly drawn example; locally it keeps exploring new examples."""

from __future__ import annotations

import atexit
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator

import pytest
from hypothesis import settings

# The built-in types alone: a plugin installed next to tral-fsm (its entry points) cannot change what the tests check
# (the committed palette and schema, `fsmctl types`); subprocesses inherit it. Tests of entry points unset it.
os.environ["FSM_NO_ENTRY_POINTS"] = "1"

# Loads keep their plans in a cache (fsm.loading.cache): the tests' cache is a folder of their own (one per xdist
# worker, removed at the end), never the user's; subprocesses inherit it.
if not os.environ.get("FSM_CACHE_DIR"):
    os.environ["FSM_CACHE_DIR"] = tempfile.mkdtemp(prefix="tral-fsm-test-cache-")
    atexit.register(shutil.rmtree, os.environ["FSM_CACHE_DIR"], True)

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

#: Under pytest-xdist each worker (gw0, gw1, ...) talks DDS on a domain of its own, so two workers' ROS 2 nodes never
#: see each other's topics: the domain the run was given (0 by default) plus the worker's number. Set before any
#: test starts an rclpy node or an ``fsmctl`` process, which inherit it.
_WORKER = os.environ.get("PYTEST_XDIST_WORKER", "")
if _WORKER.startswith("gw") and _WORKER[2:].isdigit():
    os.environ["ROS_DOMAIN_ID"] = str((int(os.environ.get("ROS_DOMAIN_ID") or 0) + int(_WORKER[2:])) % 102)


@pytest.fixture(autouse=True)
def _no_plugin_leaks() -> Iterator[None]:
    """A test that loads a plugin (``--plugin``, a scenario's ``plugins``) registers its types into the process's
    registry, as a one-shot ``fsmctl`` process does; undo that after the test, so later tests (the committed
    schema and palette, ``fsmctl types``) see the built-in types only."""
    from fsm.loading.registry import default_registry

    registry = default_registry()
    tables = (registry.states, registry.transitions, registry.conditions, registry.plants)
    saved = [dict(t) for t in tables]
    loaded = set(registry._loaded_plugins)
    modules = set(sys.modules)
    yield
    added: set[str] = set()
    for table, before in zip(tables, saved, strict=True):
        if table != before:
            added |= {cls.__module__ for name, cls in table.items() if before.get(name) is not cls}
            table.clear()
            table.update(before)
    registry._loaded_plugins.intersection_update(loaded)
    for name in added - modules:  # imported by this test only to register: imported afresh when needed again
        sys.modules.pop(name, None)


def pytest_configure(config: pytest.Config) -> None:
    """Skipped tests say why without ``-rs``: a skip is a reason to read (no browser, no corpus, a server)."""
    if "s" not in config.option.reportchars and "a" not in config.option.reportchars:
        config.option.reportchars += "s"
