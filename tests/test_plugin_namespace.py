"""A plugin author's ``self.``: what the bases take is listed (fsm.runtime.namespace.TAKEN, docs/extending.md), the
runtime's wiring is in one record, every other name is the author's (``self.index = 99`` on a transition works), and
a class that shadows a taken name is refused when it is registered, naming the class, the name and the line."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.loading.registry import builtin_types
from fsm.runtime.namespace import TAKEN, check_namespace
from fsm.runtime.region import transition_wiring, wiring

REPO = Path(__file__).resolve().parents[1]
DOC: dict[str, Any] = {"initial": "a", "states": [{"id": "a", "type": "Mine"}, {"id": "b", "type": "Final"}],
                       "transitions": [{"type": "Numbered", "from": "a", "to": "b"}]}
#: A plugin whose names are the author's own, among them names the bases once took (index, region, tick_method).
OWN_NAMES = '''
from fsm import Context, State, Transition, register_state, register_transition


@register_state
class Mine(State):
    def on_enter(self, ctx: Context) -> None:
        self.region = "north"
        self.tick_method = "fast"
        ctx.vars["mine"] = [self.region, self.tick_method]


@register_transition
class Numbered(Transition):
    def on_source_enter(self, ctx: Context) -> None:
        self.index = 99

    def holds(self, ctx: Context) -> bool:
        ctx.vars["index"] = self.index
        return True
'''


def plugin(tmp_path: Path, name: str, code: str) -> str:
    path = tmp_path / f"{name}.py"
    path.write_text(textwrap.dedent(code), encoding="utf-8")
    return str(path)


def test_every_name_a_base_puts_in_self_is_listed_and_documented() -> None:
    docs = (REPO / "docs" / "extending.md").read_text(encoding="utf-8")
    section = docs[docs.index("## What the bases take"):]
    section = section[:section.index("\n## ", 3)]
    for base, taken in TAKEN.items():
        class Empty(base):  # type: ignore[valid-type,misc]  # each base in turn
            pass

        public = {n for n in dir(Empty) if not n.startswith("_")}
        listed = taken.hooks | taken.settings | taken.own | taken.deprecated
        assert public == listed, (base.__name__, public ^ listed)
        for name in listed:
            assert f"`{name}`" in section, (base.__name__, name)


def test_the_built_in_types_shadow_no_taken_name() -> None:
    for _kind, name, cls in builtin_types():
        check_namespace(cls, name, read_source=True)


def test_the_authors_own_names_work_at_run_time(tmp_path: Path) -> None:
    path = plugin(tmp_path, "own_names", OWN_NAMES)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # the author's own names read no deprecated one
        result = fsm.run(DOC, plugins=(path,))
    assert result.outcome == "succeeded"
    assert result.variables == {"mine": ["north", "fast"], "index": 99}


@pytest.mark.parametrize(("code", "words"), [
    ("class Bad(State):\n    tick = 5\n",
     r"Bad \(type 'Bad'\): Bad.tick = 5 \(int\) shadows the hook tick\(\) with a plain attribute"),
    ("class Bad(State):\n    active = True\n", r"Bad.active shadows the base's 'active'"),
    ("class Bad(State):\n    def on_enter(self, ctx: Context) -> None:\n        self.active = True\n",
     r"self.active = \.\.\. \(.*bad_\w+\.py:8\) shadows the base's 'active'; choose another name"),
    ("class Bad(State):\n    def on_enter(self, ctx: Context) -> None:\n        self.finish = 3\n",
     r"self.finish = \.\.\. .* shadows the base's 'finish'"),
    ("class Bad(State):\n    def __init__(self, *a: Any) -> None:\n        super().__init__(*a)\n"
     "        self.can_finish = True\n", r"self.can_finish = \.\.\. .* shadows the setting 'can_finish'; set it in "
                                        r"the class body"),
    ("class Bad(Transition):\n    def on_source_enter(self, ctx: Context) -> None:\n        self.type_name = 'x'\n",
     r"shadows the base's 'type_name'"),
    ("class Bad(Transition):\n    holds = True\n", r"shadows the hook holds\(\)"),
    ("class Bad(Condition):\n    def reset(self, ctx: Context) -> None:\n        self.holds = lambda c: True\n",
     r"self.holds = \.\.\. .* shadows the hook 'holds'"),
])
def test_a_shadowing_class_is_refused_at_registration(tmp_path: Path, code: str, words: str) -> None:
    kind = re.search(r"class Bad\((\w+)\)", code).group(1)  # type: ignore[union-attr]
    header = "from typing import Any\nfrom fsm import Condition, Context, State, Transition, register_"
    source = f"{header}{kind.lower()}\n\n\n@register_{kind.lower()}\n{code}"
    path = plugin(tmp_path, f"bad_{kind.lower()}", source)
    with pytest.raises(fsm.RegistrationError, match=words) as caught:
        fsm.check(DOC, plugins=(path,))  # before any tick: the class is refused as the plugin registers it
    assert re.search(r"fsm_plugin_bad_\w+\.Bad \(type 'Bad'\): ", str(caught.value)), str(caught.value)


def test_registering_by_hand_is_checked_too() -> None:
    class Sneaky(fsm.State):  # type: ignore[type-arg]
        paused = False

    with pytest.raises(fsm.RegistrationError, match=r"Sneaky \(type 'Sneaky'\): Sneaky.paused shadows"):
        fsm.Registry().add_state(Sneaky)


@pytest.mark.parametrize(("element", "old", "called"), [
    ("transition", "index", False), ("transition", "binds_references", False),
    ("transition", "checks_document", False), ("transition", "tests_variables", False),
    ("state", "tick_method", True), ("state", "binds_references", False), ("state", "region", False),
    ("state", "transitions", False), ("state", "checks", False),
])
def test_the_wiring_names_moved_still_read_with_a_warning_whose_hint_works(element: str, old: str,
                                                                           called: bool) -> None:
    """Each deprecated read works, warns, and the call its warning names gives what the old name gave."""
    import fsm.runtime.region
    import fsm.runtime.state
    import fsm.runtime.transition

    machine = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                        "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 1}]})
    state = machine.state("a")
    transition = wiring(state).transitions[0]
    subject = state if element == "state" else transition
    words = rf"\.{old} is deprecated \(removed in the next release\): read "
    with pytest.warns(DeprecationWarning, match=words) as seen:
        value = getattr(subject, old)
    hint = str(seen[0].message).rsplit(": read ", 1)[1].split(" for ")[0]
    namespace = {"fsm": fsm, "state": state, "transition": transition, "Idle": type(state), "Timeout": type(transition)}
    assert eval(hint, namespace) == (value() if called else value), hint  # the hint, run as written
    assert transition_wiring(transition).index == 0


def test_deprecated_reads_in_a_plugin_are_shown_on_the_authors_line(tmp_path: Path) -> None:
    """Python hides DeprecationWarning outside ``__main__``; a plugin's deprecated read is shown anyway, with the
    plugin's file and line, by ``fsmctl --plugin`` and by a script's ``fsm.run`` (not with ``-W ignore``)."""
    path = plugin(tmp_path, "old_style", '''
        from fsm import Context, State, Transition, register_state, register_transition


        @register_state
        class Mine(State):
            def on_enter(self, ctx: Context) -> None:
                ctx.vars["level"] = self.region.path


        @register_transition
        class Numbered(Transition):
            def check(self, ctx: Context) -> bool:
                return True
        ''')
    machine = tmp_path / "m.json"
    machine.write_text(json.dumps(DOC), encoding="utf-8")
    cli = subprocess.run([sys.executable, "-m", "fsm.tools.cli", "--plugin", path, "run", str(machine)],
                         capture_output=True, text=True, timeout=120)
    assert cli.returncode == 0, cli.stderr
    assert f"{path}:8: DeprecationWarning: Mine.region is deprecated" in cli.stderr
    assert f"{path}:12: DeprecationWarning: fsm_plugin_old_style.Numbered: Transition.check(ctx) is renamed" \
        in cli.stderr
    script = f"import fsm\nprint(fsm.run({str(machine)!r}, plugins=[{path!r}]).outcome)\n"
    for flags, shown in (([], True), (["-W", "ignore"], False)):
        proc = subprocess.run([sys.executable, *flags, "-c", script], capture_output=True, text=True, timeout=120)
        assert proc.stdout == "succeeded\n", proc.stderr
        assert (f"{path}:8: DeprecationWarning" in proc.stderr) is shown, proc.stderr
        assert proc.stderr.count("Mine.region is deprecated") == int(shown)  # once per line, not per tick


def test_fsmctl_types_says_when_a_type_has_no_description(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from fsm.tools.cli import main

    path = plugin(tmp_path, "undocumented", "from fsm import State, register_state\n\n\n@register_state\n"
                                            "class Undocumented(State):\n    pass\n")
    assert main(["--plugin", path, "types", "Undocumented", "Idle"]) == 0
    out = capsys.readouterr().out
    assert "  Undocumented: (no description: add a docstring)\n" in out
    assert "  Idle: (no description" not in out  # a documented type shows its own line


def test_every_shadowed_name_of_a_class_is_named_at_once(tmp_path: Path) -> None:
    path = plugin(tmp_path, "two_clashes", "from fsm import Context, State, register_state\n\n\n@register_state\n"
                                           "class Clash(State):\n    finish = None\n\n"
                                           "    def on_enter(self, ctx: Context) -> None:\n"
                                           "        self.type_name = 'mine'\n        self.active = True\n")
    with pytest.raises(fsm.RegistrationError) as caught:
        fsm.check(DOC, plugins=(path,))
    message = str(caught.value)
    assert message.index("Clash.finish shadows") < message.index(f"self.type_name = ... ({path}:9)") \
        < message.index(f"self.active = ... ({path}:10)"), message


def test_a_warning_filter_the_user_chose_is_kept() -> None:
    """Only Python's default hiding is overridden: a filter of the user's (pytest's ``filterwarnings = error``, a
    ``simplefilter``) decides as it would without tral-fsm."""
    state = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}).state("a")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        with pytest.raises(DeprecationWarning, match="Idle.region is deprecated"):
            _ = state.region
        assert warnings.filters[0][0] == "error"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        assert state.region is wiring(state).region
        assert warnings.filters[0][0] == "ignore"


def test_a_plugin_file_edited_again_and_again_is_checked_as_it_is_now(tmp_path: Path) -> None:
    """The parsed source is kept per file (the classes of one file are checked one after the other): an edited
    file is parsed again, its new line is named, and its old trees are not kept (one entry per file)."""
    from fsm.runtime import namespace

    head = "from fsm import Context, State, register_state\n\n\n@register_state\nclass Edited(State):\n"
    path = ""
    for version in range(3):
        blank = "\n" * version  # the shadowing line moves down by one per edit
        path = plugin(tmp_path, "edited", f"{head}    def on_enter(self, ctx: Context) -> None:\n{blank}"
                                         f"        self.active = {version}\n")
        with pytest.raises(fsm.RegistrationError, match=re.escape(f"self.active = ... ({path}:{7 + version})")):
            fsm.check(DOC, plugins=(path,))
    assert [f for f in namespace._TREES if f == path] == [path]
