"""``fsmctl new plugin NAME``: a plugin package that installs, type-checks and tests itself as written.

The package (``NAME/``) holds a ``src/NAME`` module with one state and one transition type with typed parameters,
registered through the ``fsm.states``/``fsm.transitions`` entry points of its ``pyproject.toml`` (with ``py.typed``
and a strict mypy configuration), a machine that uses them, a scenario, a pytest test and a README that lists the
five commands that pass on it. The name is checked before anything is written; the folder is built under a scratch
name beside it and renamed into place (:class:`fsm.tools.files.NewFolder`), so nothing is ever written over an
existing folder and a failure leaves nothing behind.
"""

from __future__ import annotations

import argparse
import keyword

from fsm.model.errors import UsageError

from .common import EXIT_OK, Subcommands

#: The kinds of thing ``fsmctl new`` makes.
KINDS = ("plugin",)


def register(sub: Subcommands) -> None:
    p = sub.add_parser("new", help="start a plugin package of your own types (fsmctl new plugin NAME)",
                       description="Write a new plugin package NAME/ in the current folder (or under -C DIR): a "
                                   "state and a transition type with typed parameters, registered through entry "
                                   "points, a machine using them, a scenario, a pytest test and a README. Then: cd "
                                   "NAME && pip install -e . && mypy --strict src/NAME && fsmctl validate "
                                   "machines/NAME.json && fsmctl test scenarios/NAME.scenario.json && pytest.")
    p.add_argument("kind", choices=KINDS, help="what to make: plugin (a package of state and transition types)")
    p.add_argument("name", metavar="NAME",
                   help="the Python package name: letters, digits and _, not starting with a digit (my_robot_types)")
    p.add_argument("-C", "--directory", metavar="DIR", default=".",
                   help="the folder to make NAME/ in (default: the current folder)")
    p.set_defaults(func=cmd_new)


def cmd_new(args: argparse.Namespace) -> int:
    import os

    from ..files import NewFolder

    name = args.name
    check_name(name)
    shown = os.path.join(args.directory, name) if args.directory != "." else name
    folder = NewFolder(shown, "new plugin")
    folder.check()  # an existing file or folder of that name, a missing or read-only DIR: refused, nothing written
    files = plugin_files(name)
    folder.open()
    try:
        for path, text in files.items():
            folder.write(path, text)
        folder.commit()
    finally:
        folder.discard()
    print(f"wrote {shown}/ ({len(files)} files); next:")
    for line in NEXT_STEPS:
        print("  " + line.replace("NAME", name).replace("FOLDER", shown))
    return EXIT_OK


#: What to type after ``fsmctl new plugin NAME`` (also the generated README's list).
NEXT_STEPS = ("cd FOLDER", "pip install -e .", "mypy --strict src/NAME", "fsmctl validate machines/NAME.json",
              "fsmctl test scenarios/NAME.scenario.json", "pytest")


def check_name(name: str) -> None:
    """Refuse a name that cannot be the package's import name, or that is taken by an importable module."""
    import importlib.util

    hint = "use letters, digits and _, starting with a letter (fsmctl new plugin my_robot_types)"
    if not name.isidentifier() or not name.isascii():
        raise UsageError(f"new plugin {name!r}: not a valid Python package name; {hint}")
    if keyword.iskeyword(name) or keyword.issoftkeyword(name):
        raise UsageError(f"new plugin {name!r}: a Python keyword cannot be a package name; {hint}")
    if name.startswith("_"):
        raise UsageError(f"new plugin {name!r}: a package name starting with _ is private; {hint}")
    try:
        taken = importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        taken = True
    if taken:
        raise UsageError(f"new plugin {name!r}: a module of that name is already importable here (it would "
                         f"shadow it or be shadowed); choose another name, e.g. {name}_types")


def camel(name: str) -> str:
    """``my_robot_types`` -> ``MyRobotTypes``: the prefix of the generated type names (unique per package)."""
    return "".join(part[:1].upper() + part[1:] for part in name.split("_") if part) or "Plugin"


def plugin_files(name: str) -> dict[str, str]:
    """Every file of the package ``name``, by its path inside the package's folder."""
    values = {"NAME": name, "DIST": name.replace("_", "-"), "CAMEL": camel(name), "VERSION": _version()}
    return {path.replace("NAME", name): _fill(text, values) for path, text in _TEMPLATES.items()}


def _fill(text: str, values: dict[str, str]) -> str:
    for key in ("NAME", "DIST", "CAMEL", "VERSION"):
        text = text.replace(f"@{key}@", values[key])
    return text


def _version() -> str:
    from .common import version

    return version()


_PYPROJECT = '''\
[build-system]
requires = ["setuptools>=64"]
build-backend = "setuptools.build_meta"

[project]
name = "@DIST@"
version = "0.1.0"
description = "State and transition types for tral-fsm"
requires-python = ">=3.11"
dependencies = ["tral-fsm>=@VERSION@"]

# The entry points make the types known to every fsmctl command, fsm.load and the pytest plugin once the package is
# installed: each names a module whose @register_state / @register_transition decorators register its types.
[project.entry-points."fsm.states"]
@NAME@ = "@NAME@.states"

[project.entry-points."fsm.transitions"]
@NAME@ = "@NAME@.transitions"

[tool.setuptools]
package-dir = { "" = "src" }
packages = ["@NAME@"]

[tool.setuptools.package-data]
@NAME@ = ["py.typed"]

# `mypy --strict src/@NAME@`: tral-fsm is typed (py.typed); pydantic's plugin checks the parameter models.
[tool.mypy]
python_version = "3.11"
strict = true
plugins = ["pydantic.mypy"]

[tool.pytest.ini_options]
# tests/ holds the Python tests; scenarios/ the scenario files, which the tral-fsm pytest plugin runs as tests.
testpaths = ["tests", "scenarios"]
'''

_INIT = '''\
"""State and transition types for tral-fsm: ``@CAMEL@Ramp`` (``states``) and ``@CAMEL@Above`` (``transitions``).

The entry points in ``pyproject.toml`` import both modules when a tral-fsm command needs the types."""
'''

_STATES = '''\
"""The ``@CAMEL@Ramp`` state: registered by its decorator when the ``fsm.states`` entry point imports this module."""

from __future__ import annotations

from pydantic import Field

from fsm import Context, State, StateParams, register_state


class RampParams(StateParams):
    """The parameters of ``@CAMEL@Ramp``: each field is a key of the state in a machine document."""

    var: str = Field("level", description="Blackboard variable to move.")
    target: float = Field(1.0, description="The value to move it to.")
    rate: float = Field(1.0, gt=0, description="How fast, per second.")


@register_state
class @CAMEL@Ramp(State[RampParams]):
    """Moves blackboard variable `var` towards `target` at `rate` per second; finishes when it is there."""

    can_finish = True

    def on_enter(self, ctx: Context) -> None:
        ctx.vars.setdefault(self.params.var, 0.0)

    def tick(self, ctx: Context) -> None:
        value: float = ctx.vars[self.params.var]
        step = self.params.rate * ctx.dt
        if abs(self.params.target - value) <= step:
            ctx.vars[self.params.var] = self.params.target
            self.finish("succeeded")
        else:
            ctx.vars[self.params.var] = value + step if self.params.target > value else value - step
'''

_TRANSITIONS = '''\
"""The ``@CAMEL@Above`` transition: registered by its decorator when the ``fsm.transitions`` entry point imports
this module."""

from __future__ import annotations

from pydantic import Field

from fsm import Context, Transition, TransitionParams, register_transition


class AboveParams(TransitionParams):
    """The parameters of ``@CAMEL@Above``."""

    var: str = Field(description="Blackboard variable to watch.")
    value: float = Field(description="Fires once the variable is at least this.")


@register_transition
class @CAMEL@Above(Transition[AboveParams]):
    """Fires when blackboard variable `var` is at least `value`."""

    def holds(self, ctx: Context) -> bool:
        current: float = ctx.vars.get(self.params.var, 0.0)
        return current >= self.params.value
'''

_MACHINE = '''\
{
  "name": "@NAME@",
  "description": "Ramps `level` up to 1.0 in 0.5 s, back down once it is above 0.8, then ends.",
  "initial": "up",
  "states": [
    {"id": "up", "type": "@CAMEL@Ramp", "var": "level", "target": 1.0, "rate": 2.0},
    {"id": "down", "type": "@CAMEL@Ramp", "var": "level", "target": 0.0, "rate": 4.0},
    {"id": "done", "type": "Final"}
  ],
  "transitions": [
    {"type": "@CAMEL@Above", "from": "up", "to": "down", "var": "level", "value": 0.8},
    {"type": "Finished", "from": "down", "to": "done"}
  ]
}
'''

_SCENARIO = '''\
{
  "description": "The ramp goes up past 0.8 (0.4 s), down to 0 (0.2 s more), and the machine ends.",
  "machine": "../machines/@NAME@.json",
  "duration": 2,
  "expect": [
    {"visits": ["up", "down", "done"]},
    {"entered": "down", "within": [0.35, 0.45]},
    {"at": 1.0, "vars": {"level": 0.0}},
    {"outcome": "succeeded"}
  ]
}
'''

_TEST = '''\
"""The types in a machine, ticked by hand with tral-fsm's ``fsm_machine`` fixture (its pytest plugin)."""

from __future__ import annotations

from typing import Any

import pytest
from pydantic import ValidationError

from @NAME@.states import RampParams


def test_the_ramp_reaches_its_target_and_the_transition_fires(fsm_machine: Any) -> None:
    m = fsm_machine("../machines/@NAME@.json")
    m.run_for(0.2)
    m.expect({"active": "up"})
    m.run_for(1.0)
    m.expect({"visits": ["up", "down", "done"]}, {"vars": {"level": 0.0}}, {"outcome": "succeeded"})


def test_a_ramp_starting_in_down_ends_without_going_up(fsm_machine: Any) -> None:
    m = fsm_machine("../machines/@NAME@.json", state="down", vars={"level": 0.5})
    m.run_for(0.5)
    m.expect({"visits": ["down", "done"]}, {"never": ["up"]})


def test_the_rate_must_be_positive() -> None:
    with pytest.raises(ValidationError):
        RampParams(id="r", type="@CAMEL@Ramp", rate=0)
'''

_README = '''\
# @DIST@

State and transition types for tral-fsm: the state `@CAMEL@Ramp` (`src/@NAME@/states.py`)
and the transition `@CAMEL@Above` (`src/@NAME@/transitions.py`), with a machine that uses them
(`machines/@NAME@.json`), a scenario (`scenarios/@NAME@.scenario.json`) and a pytest test (`tests/`).

Made by `fsmctl new plugin @NAME@`. In the environment where tral-fsm is installed:

```sh
pip install -e .
mypy --strict src/@NAME@
fsmctl validate machines/@NAME@.json
fsmctl test scenarios/@NAME@.scenario.json
pytest
```

`pip install -e .` registers the entry points that make the types known to fsmctl; mypy checks `self.params`
against the parameter models; `pytest` runs `tests/` and the scenarios.

- A type is a class registered under its name (`@register_state`, `@register_transition`); a document names the
  type (`"type": "@CAMEL@Ramp"`). Its `Params` model (a subclass of `StateParams` or `TransitionParams`) lists the
  keys the document may give, and `State[RampParams]` types `self.params` for mypy and your editor.
- `fsmctl types @CAMEL@Ramp` shows the parameters as an application developer sees them; `fsmctl palette -o
  palette.uxf` writes a UMLet palette with these types in it.
- Add types to `states.py` and `transitions.py` (or new modules named by an entry point in `pyproject.toml`;
  reinstall after changing the entry points). The names must be unique among all installed types.
- tral-fsm's docs: "Writing state and transition types" (docs/extending.md) and "Scenarios" (docs/scenarios.md).
'''

_GITIGNORE = '''\
__pycache__/
*.egg-info/
.mypy_cache/
.pytest_cache/
build/
dist/
'''

#: The package's files, by path (``NAME`` in a path is the package name; ``@NAME@``, ``@CAMEL@``, ... in a text).
_TEMPLATES = {
    "pyproject.toml": _PYPROJECT,
    "README.md": _README,
    ".gitignore": _GITIGNORE,
    "src/NAME/__init__.py": _INIT,
    "src/NAME/py.typed": "",
    "src/NAME/states.py": _STATES,
    "src/NAME/transitions.py": _TRANSITIONS,
    "machines/NAME.json": _MACHINE,
    "scenarios/NAME.scenario.json": _SCENARIO,
    "tests/test_NAME.py": _TEST,
}
