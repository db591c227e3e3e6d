"""The sweep file (``fsmctl sweep SPEC.json``, JSON Schema ``fsm/schema/sweep.schema.json``) and the grid it spans.

The grid is the product of worlds x seeds x every ``set`` value x every ``vars`` value; each point is one run,
numbered in that order. The same spec can be given as flags (``--machine``, ``--world``, ``--seeds``, ``--set``,
``--var``); flags override the file's keys.
"""

from __future__ import annotations

import glob
import hashlib
import itertools
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import Field, ValidationError

from fsm.loading.reading import parse_json_bytes, place, read_file_bytes
from fsm.model.document import Source, file_schema, problems_from_validation
from fsm.model.errors import DiagramError, Problem
from fsm.model.params import Int, ParamsBase
from fsm.runtime.clock import DEFAULT_DT

from .limits import MAX_RUNS as MAX_RUNS
from .limits import MAX_TICKS as MAX_TICKS

SWEEP_SCHEMA_PATH = Path(__file__).resolve().parents[2] / "schema" / "sweep.schema.json"
#: Bumped when a change of the runner would change results: finished runs of another version are run again.
RUN_VERSION = 1


class Outputs(ParamsBase):
    """What each run writes besides its summary, under OUT/runs/<run id>/."""

    trace: bool = Field(default=False, description="Write trace.jsonl.")
    report: bool = Field(default=False, description="Write report.html (the run's HTML report, as `fsmctl report`).")
    plot: bool = Field(default=False, description="Write plot.png (runs with a car).")
    video: bool = Field(default=False, description="Write video.mp4 (runs with a car; slow).")


class SweepSpec(ParamsBase):
    """A sweep: one machine run over worlds x seeds x parameter overrides x variables."""

    schema_: str | None = Field(default=None, alias="$schema", description="JSON Schema for editors.")
    name: str | None = Field(default=None, min_length=1, description="Name in the report (default: the file's).")
    description: str | None = Field(default=None, description="Free text for people.")
    machine: str = Field(min_length=1, description="The machine (.json or .uxf), relative to this file.")
    worlds: list[str] = Field(default_factory=list, description="World files or globs, relative to this file "
                                                                "(default: the machine's default world).")
    seeds: str | list[Int] = Field(default="0:1", description='Seeds: "START:STOP" (STOP excluded) or a list.')
    set: dict[str, list[Any]] = Field(default_factory=dict, description='Overrides: {"home.speed": [0.8, 1.0]}; '
                                                                         "the state path, a dot, the parameter.")
    vars: dict[str, list[Any]] = Field(default_factory=dict, description='Initial variables: {"limit": [1, 2]}.')
    duration: float | None = Field(default=None, gt=0, description="Stop each run after this much simulated time "
                                                                    "(default 600 s).")
    noise: bool = Field(default=True, description="Sensor noise on (each run seeded).")
    plugins: list[str] = Field(default_factory=list, description="Plugin modules or .py files (relative to this file).")
    outputs: Outputs = Field(default_factory=Outputs, description="What each run writes besides its summary.")


def sweep_schema() -> dict[str, Any]:
    return file_schema(SweepSpec, "sweep.schema.json", "tral-fsm sweep",
                       "A sweep for `fsmctl sweep`; generated from fsm.tools.sweep.spec by "
                       "`python -m fsm.tools.sweep --schema`.")


def sweep_schema_text() -> str:
    return json.dumps(sweep_schema(), indent=2, ensure_ascii=False) + "\n"


#: Seeds are whole numbers from 0 to this (as ``fsmctl run --seed``).
MAX_SEED = 2**63 - 1


class SpecError(ValueError):
    """A value of a sweep that cannot be run; ``pointer`` is the key it came from (a JSON pointer)."""

    def __init__(self, message: str, pointer: str = "") -> None:
        super().__init__(message)
        self.pointer = pointer


def parse_seeds(value: str | list[int]) -> Sequence[int]:
    """``"0:16"`` (a ``range``: nothing is built for a long one), ``"5"``, or a list of whole numbers, each from 0
    to :data:`MAX_SEED`; a :class:`SpecError` otherwise."""
    if isinstance(value, list):
        for i, seed in enumerate(value):
            if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
                raise SpecError(f"seeds: {_short(seed)} is not a seed; a seed is a whole number from 0 to 2**63-1",
                                f"/seeds/{i}")
        return list(value)
    text = value.strip()
    try:
        if ":" in text:
            a, b = text.split(":", 1)
            start, stop = int(a or 0), int(b)
            if stop <= start or start < 0 or stop - 1 > MAX_SEED:
                raise ValueError
            return range(start, stop)
        n = int(text)
        if not 0 <= n <= MAX_SEED:
            raise ValueError
        return [n]
    except ValueError:
        raise SpecError(f"seeds {_short(value)}: write START:STOP with 0 <= START < STOP <= 2**63 (0:16 is 16 seeds), "
                        "or one seed", "/seeds") from None


def _short(value: Any, limit: int = 60) -> str:
    """``value`` as JSON (text as Python writes it, in single quotes), shortened for a message."""
    try:
        text = repr(value) if isinstance(value, str) else json.dumps(value)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def check_duration(duration: float | None) -> str | None:
    """Why ``duration`` (seconds of simulated time per run) cannot be a sweep's, or ``None`` when it can: finite,
    > 0, and at most :data:`MAX_TICKS` ticks of the default period, the longest run ``fsmctl run`` accepts."""
    if duration is None:
        return None
    if not (isinstance(duration, (int, float)) and duration > 0 and math.isfinite(duration)):
        return f"duration {_short(duration)}: give a number of seconds > 0"
    if not duration / DEFAULT_DT <= MAX_TICKS:
        return (f"duration {duration!r}: more than {MAX_TICKS:,} ticks of {DEFAULT_DT:g} s, the longest run "
                f"`fsmctl run` accepts without --max-ticks; give at most {MAX_TICKS * DEFAULT_DT:g} s")
    return None


def check_vars(variables: dict[str, list[Any]]) -> None:
    """Each variable a name ``fsmctl run --var`` takes and a non-empty list of JSON scalars (what its printed
    command can give back), else a :class:`SpecError`."""
    for name, values in variables.items():
        where = f"/vars/{escape_pointer(name)}"
        if not name.isidentifier():
            raise SpecError(f"vars {_short(name)}: a variable's name is a word of letters, digits and _ (not "
                            "starting with a digit)", where)
        if not isinstance(values, list) or not values:
            raise SpecError(f"vars {_short(name)}: give a non-empty list of values", where)
        for i, v in enumerate(values):
            if isinstance(v, float) and not math.isfinite(v) or not isinstance(v, (bool, int, float, str)):
                raise SpecError(f"vars {name}: {_short(v)} is not a number, true/false or text", f"{where}/{i}")


def check_unique(values: Sequence[Any], what: str, pointer: str) -> None:
    """A :class:`SpecError` when a value is given twice (two runs would be the same run)."""
    if isinstance(values, range):
        return
    seen: dict[str, int] = {}
    for i, value in enumerate(values):
        text = json.dumps(value, sort_keys=True, default=str)
        if text in seen:
            raise SpecError(f"{what}: {_short(value)} is given twice (items {seen[text]} and {i}), which would "
                            "run the same run twice", f"{pointer}/{i}")
        seen[text] = i


def escape_pointer(key: str) -> str:
    """``key`` as one step of a JSON pointer."""
    return key.replace("~", "~0").replace("/", "~1")


def count_runs(worlds: int, seeds: int, axes: list[int]) -> int:
    """How many runs a grid has, computed, not built: worlds x seeds x the number of values of each axis."""
    return math.prod([worlds, seeds, *axes])


def read_spec_file(path: Path) -> SweepSpec:
    """A sweep file, read by the project's reading rule (regular files only, size cap, strict JSON) and validated
    against the model; a :class:`DiagramError` with located problems otherwise."""
    raw = read_file_bytes(path, "sweep")
    data, source = parse_json_bytes(raw, str(path), path.parent)
    if not isinstance(data, dict):
        raise DiagramError([Problem("a sweep file is a JSON object with 'machine'", str(path), line=1, column=1,
                                    hint='e.g. {"machine": "lap.uxf", "seeds": "0:16"}')])
    try:
        return SweepSpec.model_validate(data)
    except ValidationError as err:
        problems = problems_from_validation(err, source=Source(name=str(path)), base="", element=None,
                                            model=SweepSpec, kind="key", data=data)
        place(problems, source.locator)
        raise DiagramError(problems) from None


def expand_worlds(patterns: list[str], base: Path) -> list[Path]:
    """World files from names and globs (relative to ``base``, made absolute and normal); a glob that matches
    nothing, a file that is not there, or a world named twice (two runs would be one) is a :class:`SpecError`."""
    out: dict[Path, int] = {}
    for i, pattern in enumerate(patterns):
        full = os.path.normpath(os.path.join(base, pattern))
        try:
            if any(c in pattern for c in "*?["):
                found = sorted(Path(p) for p in glob.glob(full))
                if not found:
                    raise SpecError(f"worlds: {pattern!r} matches no file (looked in {base})", f"/worlds/{i}")
            elif os.path.isfile(full):
                found = [Path(full)]
            else:
                raise SpecError(f"worlds: no world file {full}", f"/worlds/{i}")
        except ValueError as exc:
            if isinstance(exc, SpecError):
                raise
            raise SpecError(f"worlds: {pattern!r} is not a usable file name", f"/worlds/{i}") from None
        for path in found:
            if path in out:
                raise SpecError(f"worlds: {path} is named twice (by {patterns[out[path]]!r} and {pattern!r}), which "
                                "would run the same runs twice", f"/worlds/{i}")
            out[path] = i
    return list(out)


@dataclass
class Run:
    """One point of the grid."""

    index: int
    world: Path | None
    seed: int
    sets: list[tuple[str, str, Any]]
    variables: dict[str, Any]
    run_seed: int = 0
    key: str = ""
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def id(self) -> str:
        return f"{self.index:04d}"


def grid(worlds: Sequence[Path | None], seeds: Sequence[int], sets: Sequence[tuple[str, str, list[Any]]],
         variables: Mapping[str, list[Any]]) -> list[Run]:
    """Worlds x seeds x each override's values x each variable's values, in that order."""
    set_axes = [[(path, param, v) for v in values] for path, param, values in sets]
    var_axes = [[(name, v) for v in values] for name, values in variables.items()]
    runs = []
    for i, (world, seed, *rest) in enumerate(itertools.product(worlds, seeds, *set_axes, *var_axes)):
        chosen_sets = list(rest[:len(set_axes)])
        chosen_vars = dict(rest[len(set_axes):])
        params = {f"{p}.{k}": v for p, k, v in chosen_sets} | {f"vars.{k}": v for k, v in chosen_vars.items()}
        runs.append(Run(i, world, seed, chosen_sets, chosen_vars, params=params))
    return runs


def seed_runs(runs: list[Run], root: int = 0) -> None:
    """Each run's own seed from ``numpy.random.SeedSequence``: the user's seed with the run's world and
    parameter point as spawn key, so runs are independent, and the same seed and point give the same run."""
    import numpy as np

    for run in runs:
        point = json.dumps([str(run.world.name) if run.world else "", run.params], sort_keys=True)
        salt = int.from_bytes(hashlib.sha256(point.encode()).digest()[:4], "big")
        ss = np.random.SeedSequence(entropy=[root, run.seed], spawn_key=(salt,))
        run.run_seed = int(ss.generate_state(1, dtype=np.uint64)[0] & (2**63 - 1))


def files_digest(paths: list[str]) -> str:
    """A hash of the contents of the files a run reads (machine, includes, world)."""
    h = hashlib.sha256()
    for p in sorted(set(paths)):
        h.update(p.encode())
        try:
            h.update(Path(p).read_bytes())
        except OSError:
            h.update(b"<missing>")
    return h.hexdigest()


def run_key(run: Run, digest: str, spec: SweepSpec) -> str:
    """What identifies a run's inputs: resuming skips a finished run with the same key."""
    data = json.dumps({"v": RUN_VERSION, "files": digest, "world": str(run.world), "seed": run.run_seed,
                       "set": run.sets, "vars": run.variables, "duration": spec.duration, "noise": spec.noise,
                       "outputs": spec.outputs.model_dump()}, sort_keys=True, default=str)
    return hashlib.sha256(data.encode()).hexdigest()[:16]
