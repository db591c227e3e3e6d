"""Loading a machine: the stages put together, and the facts runners ask of a checked document.

    read (fsm.loading.reading) -> parse (fsm.loading.parsing) -> check (fsm.loading.checking)
    -> compile (fsm.loading.compiling) -> build (fsm.loading.building)

Each stage is a module with one job. Every problem of a document is collected (all at once, not only the first)
with its file, JSON pointer, line:column and element; only a document without errors is compiled and built.
"""

from __future__ import annotations

import gc
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from fsm.loading import cache
from fsm.loading.building import build
from fsm.loading.checking import Analysis, conditions_of, signal_names, signal_readers, value_kind
from fsm.loading.checking import check as check_spec
from fsm.loading.compiling import compile_machine
from fsm.loading.parsing import parse
from fsm.loading.reading import preloaded, read_json, register_reader
from fsm.loading.registry import PLUGINS_FROM_PYTHON, Registry, default_registry
from fsm.loading.sources import DocumentSource, Source, checked_source, document_read
from fsm.model.document import MachineSpec
from fsm.model.errors import DiagramError, Problem, UsageError
from fsm.model.jsonpos import pointer
from fsm.model.plan import MachinePlan
from fsm.model.problems import Problems
from fsm.runtime.clock import Clock, SimulatedClock
from fsm.runtime.context import Context
from fsm.runtime.machine import Machine


def analyse(src: DocumentSource, *, registry: Registry | None = None, plugins: tuple[str, ...] = (),
            base_dir: str | os.PathLike[str] | None = None
            ) -> tuple[MachineSpec | None, Analysis | None, list[Problem]]:
    """Parse and check ``src`` (a path, JSON text, a document dict, or an already parsed spec: the one rule of
    :mod:`fsm.loading.sources`): the spec (``None`` if unusable), what checking found out (``None`` then too) and
    every problem, located and sorted."""
    if registry is not None and not isinstance(registry, Registry):
        raise TypeError(f"registry must be an fsm.Registry or None, got {type(registry).__name__}")
    with document_read(src, base_dir) as src:
        if isinstance(src, (str, os.PathLike)) and cache.enabled():
            return _analyse_file(str(Path(src)), registry or registry_of(plugins))
        return _analyse(src, registry, plugins, base_dir)


def _analyse(src: DocumentSource, registry: Registry | None, plugins: tuple[str, ...],
             base_dir: str | os.PathLike[str] | None) -> tuple[MachineSpec | None, Analysis | None, list[Problem]]:
    problems = Problems()
    if isinstance(src, MachineSpec):
        spec: MachineSpec | None = src
    else:
        spec = parse(src, registry or registry_of(plugins), problems, base_dir)
    analysis = None
    if spec is not None:
        try:
            analysis = check_spec(spec, problems)
        except RecursionError:  # a value nested deeper than the checks can walk (a variable holding a deep list)
            problems.add("document nested too deeply to check", spec.source, "")
            spec = None
    return spec, analysis, problems.located()


def _analyse_file(name: str, registry: Registry) -> tuple[MachineSpec | None, Analysis | None, list[Problem]]:
    """:func:`analyse` of a file through the plan cache (:mod:`fsm.loading.cache`): the cached result when the
    document, its includes, the registry's types and the loader are what they were; else checked, and when it has
    no errors compiled and cached."""
    with collection_paused():
        doc = cache.document(name)
        if doc is not None:
            entry = cache.lookup(name, registry, doc)
            if entry is not None:
                _LAST[:] = [entry]
                return entry.spec, entry.analysis, list(entry.problems)
        with preloaded({name: doc.raw} if doc is not None and doc.raw is not None else {}):
            spec, analysis, problems = _analyse(name, registry, (), None)
        if doc is None or spec is None or analysis is None or any(p.severity == "error" for p in problems):
            return spec, analysis, problems
        entry = cache.Entry(spec, analysis, list(problems), compile_machine(spec, analysis))
        cache.store(name, registry, entry, doc.token)
        _LAST[:] = [entry]
        return spec, analysis, problems


#: The last file analysed through the cache, with its plan: compiling that spec again takes the plan.
_LAST: list[cache.Entry] = []


def _plan_of(spec: MachineSpec, analysis: Analysis) -> MachinePlan:
    last = _LAST[0] if _LAST else None
    if last is not None and last.spec is spec and last.analysis is analysis:
        return last.plan
    return compile_machine(spec, analysis)


def check(src: Source, *, registry: Registry | None = None, plugins: tuple[str, ...] = (),
          base_dir: str | os.PathLike[str] | None = None) -> tuple[MachineSpec | None, list[Problem]]:
    """Validate ``src`` (see :mod:`fsm.loading.sources`) without building: the checked spec (``None`` if unusable)
    and every problem found (a plan was checked when it was compiled: its spec, and no problem)."""
    src = checked_source(src, "src")
    if isinstance(src, MachinePlan):
        return src.spec, []
    spec, _analysis, problems = analyse(src, registry=registry, plugins=plugins, base_dir=base_dir)
    return spec, problems


def compile(src: Source, *, registry: Registry | None = None, plugins: tuple[str, ...] = (),  # noqa: A001
            base_dir: str | os.PathLike[str] | None = None) -> MachinePlan:
    """The plan of ``src`` (see :mod:`fsm.loading.sources`; a plan is its own); raises :class:`DiagramError` with
    every error found. A plan builds any number of machines (:func:`fsm.loading.building.build`)."""
    src = checked_source(src, "src")
    if isinstance(src, MachinePlan):
        return src
    with collection_paused():
        spec, analysis, problems = analyse(src, registry=registry, plugins=plugins, base_dir=base_dir)
        errors = [p for p in problems if p.severity == "error"]
        if spec is None or analysis is None or errors:
            raise DiagramError(errors or problems)
        return _plan_of(spec, analysis)


def load(src: Source, *, registry: Registry | None = None, plugins: tuple[str, ...] = (),
         clock: Clock | None = None, car: object | None = None, context: Context | None = None, dt: float | None = None,
         base_dir: str | os.PathLike[str] | None = None) -> Machine:
    """Load a machine from a file path (``.json``, or ``.uxf`` with the UMLet reader), JSON text, a document dict,
    a spec or a plan (the one rule of :mod:`fsm.loading.sources`).

    Raises :class:`DiagramError` with every error found; warnings (unreachable states) do not stop the load.
    A wrong argument raises ``TypeError`` or ``ValueError`` naming it.
    """
    _check_arguments(src, clock, context, dt)
    if clock is None and dt is not None:
        clock = SimulatedClock(dt)
    with collection_paused():
        plan = compile(src, registry=registry, plugins=plugins, base_dir=base_dir)
        machine = build(plan, clock=clock, car=car, context=context)
        del plan
    return machine


#: Loads in progress (in any thread) and whether the collector was on before the first of them.
_PAUSE_LOCK = threading.Lock()
_PAUSES = {"loads": 0, "was_on": False}


@contextmanager
def collection_paused() -> Iterator[None]:
    """Python's cycle collector paused while a machine loads, resumed afterwards (unless it was off already).

    A load makes tens of thousands of objects that all live on (specs, parameters, the plan, the machine): the
    collector, run every few hundred new objects, would walk them again and again, about a tenth of the load.
    Nothing of a load is cyclic garbage; the collector's next run after the load sees them all once. The collector
    is one per process: loads in several threads (a live run's reload beside a user's own) share one pause, and
    the last to finish resumes it."""
    with _PAUSE_LOCK:
        if _PAUSES["loads"] == 0:
            _PAUSES["was_on"] = gc.isenabled()
            gc.disable()
        _PAUSES["loads"] += 1
    try:
        yield
    finally:
        with _PAUSE_LOCK:
            _PAUSES["loads"] -= 1
            if _PAUSES["loads"] == 0 and _PAUSES["was_on"]:
                gc.enable()


def compile_checked(spec: MachineSpec, analysis: Analysis) -> MachinePlan:
    """The plan of a spec :func:`analyse` found without errors, from its analysis: the document is not checked a
    second time (``fsmctl run`` checks once, then compiles)."""
    with collection_paused():
        return _plan_of(spec, analysis)


def registry_of(plugins: Any) -> Registry:
    """The process registry with ``plugins`` (the Python API's argument) loaded: a plugin that cannot be found is a
    ``ValueError`` naming ``plugins=[...]``, not the command line's ``--plugin``."""
    token = PLUGINS_FROM_PYTHON.set(True)
    try:
        return default_registry(_plugins(plugins))
    except UsageError as exc:
        raise ValueError(str(exc)) from None
    finally:
        PLUGINS_FROM_PYTHON.reset(token)


def _plugins(plugins: Any) -> tuple[str, ...]:
    """``plugins`` as a tuple of module names (a lone string would be read letter by letter)."""
    if isinstance(plugins, str):
        raise TypeError(f"plugins must be a list or tuple of module names, not the string {plugins!r} "
                        f"(write plugins=[{plugins!r}])")
    if not isinstance(plugins, (list, tuple)) or not all(isinstance(p, str) for p in plugins):
        raise TypeError(f"plugins must be a list or tuple of module names, got {plugins!r}")
    return tuple(plugins)


def _check_arguments(src: object, clock: object, context: object, dt: object) -> None:
    if clock is not None and not (callable(getattr(clock, "time_at", None)) and hasattr(clock, "dt")):
        raise TypeError(f"clock must be a clock (fsm.SimulatedClock or fsm.RealTimeClock), got {clock!r}")
    if context is not None and not isinstance(context, Context):
        raise TypeError(f"context must be an fsm.Context or None, got {type(context).__name__}")
    if dt is not None and (isinstance(dt, bool) or not isinstance(dt, (int, float))):
        raise TypeError(f"dt must be a number of seconds or None, got {type(dt).__name__}")


# -- facts of a checked document ---------------------------------------------------------------------------
def uses_car(spec: MachineSpec | None) -> bool:
    """True when any state, transition or condition type of the checked machine (at any level) needs a car."""
    if spec is None:
        return False
    return any(getattr(cls, "needs_car", False) for cls, *_rest in signal_readers(spec))


def machine_files(spec: MachineSpec | None) -> list[str]:
    """Every file a checked machine was read from: its own and its includes, any depth (each once)."""
    names = (level.source.name for level in spec.levels()) if spec is not None else ()
    return list(dict.fromkeys(n for n in names if n))


__all__ = ["analyse", "build", "check", "compile", "conditions_of", "load", "machine_files", "pointer",
           "read_json", "register_reader", "signal_names", "uses_car", "value_kind"]
