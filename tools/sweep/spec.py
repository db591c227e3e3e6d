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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import Field

from fsm.params import Int, ParamsBase

SWEEP_SCHEMA_PATH = Path(__file__).resolve().parents[2] / "fsm" / "schema" / "sweep.schema.json"
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
    from fsm.document import file_schema

    return file_schema(SweepSpec, "sweep.schema.json", "tral-fsm sweep",
                       "A sweep for `fsmctl sweep`; generated from fsm.tools.sweep.spec by "
                       "`python -m fsm.tools.sweep --schema`.")


def sweep_schema_text() -> str:
    return json.dumps(sweep_schema(), indent=2, ensure_ascii=False) + "\n"


def parse_seeds(value: str | list[int]) -> list[int]:
    """``"0:16"`` (or ``"5"``), or a list of integers."""
    if isinstance(value, list):
        return list(value)
    text = value.strip()
    try:
        if ":" in text:
            a, b = text.split(":", 1)
            start, stop = int(a or 0), int(b)
            if stop <= start or start < 0:
                raise ValueError
            return list(range(start, stop))
        n = int(text)
        if n < 0:
            raise ValueError
        return [n]
    except ValueError:
        raise ValueError(f"seeds {value!r}: write START:STOP with 0 <= START < STOP (0:16 is 16 seeds), or one "
                         "seed") from None


def expand_worlds(patterns: list[str], base: Path) -> list[Path]:
    """World files from names and globs (relative to ``base``); a glob that matches nothing is an error."""
    out: list[Path] = []
    for pattern in patterns:
        full = str(base / pattern) if not Path(pattern).is_absolute() else pattern
        if any(c in pattern for c in "*?["):
            found = sorted(Path(p) for p in glob.glob(full))
            if not found:
                raise ValueError(f"worlds: {pattern!r} matches no file (looked in {base})")
            out.extend(found)
        else:
            path = Path(full)
            if not path.is_file():
                raise ValueError(f"worlds: no world file {path}")
            out.append(path)
    return out


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


def grid(worlds: list[Path | None], seeds: list[int], sets: list[tuple[str, str, list[Any]]],
         variables: dict[str, list[Any]]) -> list[Run]:
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
