"""The plan cache (fsm/loading/cache.py): a load of unchanged content is taken from the cache; any change of the
document, an include, a plugin type's source or the loader misses; a corrupt, foreign or forged file is ignored and
rewritten; two processes may write at once; the cached machine runs as the loaded one does, with the same warnings."""

from __future__ import annotations

import importlib
import json
import os
import pickle
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

import fsm
from fsm.loading import cache, loader
from fsm.loading.registry import Registry, default_registry
from fsm.tools.cli import main
from helpers import CORPUS, needs_corpus

REPO = Path(__file__).resolve().parents[1]

#: A machine with what a plan holds as closures: ``set`` on entry, exit and transitions, a counter, a guard, a
#: timeout, an included sub-machine, and an unreachable state (a warning).
DOC: dict[str, Any] = {
    "name": "counting",
    "initial": "a",
    "vars": {"n": 0, "log": ""},
    "states": [
        {"id": "a", "type": "Idle", "set": {"on_enter": {"log": "log + 'a'"}, "on_exit": {"n": "n + 1"}}},
        {"id": "b", "type": "Idle", "timeout": 0.3},
        {"id": "sub", "type": "FSMState", "machine": {"file": "sub.json"}},
        {"id": "lonely", "type": "Idle"},
    ],
    "transitions": [
        {"type": "Always", "from": "a", "to": "b", "guard": "n < 3", "set": {"n": "n + 1"}},
        {"type": "Always", "from": "a", "to": "sub", "guard": "n >= 3"},
        {"type": "Timeout", "from": "b", "to": "a", "seconds": 0.1},
        {"type": "Finished", "from": "sub", "to": "a"},
    ],
}
SUB: dict[str, Any] = {
    "initial": "x",
    "states": [{"id": "x", "type": "Idle", "set": {"on_enter": {"log": "log + 'x'"}}}, {"id": "end", "type": "Final"}],
    "transitions": [{"type": "Always", "from": "x", "to": "end"}],
}


@pytest.fixture()
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder of this test's own, the cache switched on."""
    where = tmp_path / "cache"
    monkeypatch.setenv(cache.CACHE_DIR_ENV, str(where))
    monkeypatch.delenv(cache.NO_CACHE_ENV, raising=False)
    loader._LAST.clear()
    cache._KEPT.clear()
    return where


def write(path: Path, doc: dict[str, Any]) -> Path:
    path.write_text(json.dumps(doc, indent=1))
    return path


def machine_files(tmp_path: Path) -> Path:
    write(tmp_path / "sub.json", SUB)
    return write(tmp_path / "m.json", DOC)


def hit(path: Path, registry: Registry | None = None) -> bool:
    """Whether the cache folder holds an entry for ``path`` as it is now (what this process keeps in memory set
    aside)."""
    cache._KEPT.clear()
    doc = cache.document(str(path))
    assert doc is not None
    return cache.lookup(str(path), registry or default_registry(), doc) is not None


def run_trace(machine: fsm.Machine, ticks: int = 60) -> list[tuple[list[str], dict[str, Any]]]:
    machine.start()
    out = []
    for _ in range(ticks):
        machine.tick()
        out.append((list(machine.active_paths), dict(machine.ctx.vars)))
    return out


def test_second_load_is_a_hit_and_runs_as_the_first(folder: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    path = machine_files(tmp_path)
    expected = run_trace(fsm.load(path, dt=0.05))
    assert hit(path) and len(list(folder.iterdir())) == 1  # (the lookup waits for the background writer)
    loader._LAST.clear()

    def no_parse(*_args: Any, **_kw: Any) -> Any:
        raise AssertionError("a cache hit parses nothing")

    real_parse = loader.parse
    monkeypatch.setattr(loader, "parse", no_parse)
    assert run_trace(fsm.load(path, dt=0.05)) == expected
    monkeypatch.setattr(loader, "parse", real_parse)
    monkeypatch.setenv(cache.NO_CACHE_ENV, "1")
    assert run_trace(fsm.load(path, dt=0.05)) == expected
    assert expected[-1][1]["log"].count("x") > 3  # the included machine ran, its set too


def test_a_process_reuses_what_it_read_until_a_file_changes(folder: Path, tmp_path: Path) -> None:
    path = machine_files(tmp_path)
    loader.compile(path)
    loader._LAST.clear()
    cache.flush()
    shutil.rmtree(folder)  # answered from memory now, as long as the texts and the key are the same
    spec, problems = fsm.check(path)
    assert spec is not None and [p.severity for p in problems] == ["warning"]
    problems[0].element = "changed by a caller"
    assert fsm.check(path)[1][0].element != "changed by a caller"  # each load gets its own problems
    write(tmp_path / "sub.json", {**SUB, "states": [{"id": "x", "type": "Idle"}, {"id": "end", "type": "Final"}]})
    loader._LAST.clear()
    plan = loader.compile(path)
    assert plan.root.states[2].regions[0].states[0].on_enter is None


def test_a_sequence_with_monitors_and_exceptions_runs_the_same_from_the_cache(folder: Path, tmp_path: Path) -> None:
    path = tmp_path / "delta.json"
    shutil.copy(REPO / "diagrams" / "eeros" / "case2_delta_mouse.json", path)

    def trace() -> list[tuple[list[str], dict[str, Any]]]:
        m = fsm.load(path, dt=0.1)
        m.schedule_signal("mouse_moved", 1.0)
        m.schedule_signal("mouse_moved", 9.0)
        return run_trace(m, 200)

    fresh = trace()
    assert hit(path)
    loader._LAST.clear()
    assert trace() == fresh


def test_warnings_are_printed_the_same_from_the_cache(folder: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    path = machine_files(tmp_path)
    outputs = []
    for argv in (["validate", "--no-cache", str(path)], ["validate", str(path)], ["validate", str(path)]):
        assert main(argv) == 0
        captured = capsys.readouterr()
        outputs.append(captured.out + captured.err)
    assert "lonely" in outputs[0] and "warning" in outputs[0]
    assert outputs[0] == outputs[1] == outputs[2]
    assert hit(path)


@pytest.mark.parametrize("change", ["document", "include"])
def test_a_changed_document_or_include_misses(folder: Path, tmp_path: Path, change: str) -> None:
    path = machine_files(tmp_path)
    loader.compile(path)
    assert hit(path)
    if change == "document":
        write(path, {**DOC, "vars": {"n": 1, "log": ""}})
    else:
        write(tmp_path / "sub.json", {**SUB, "states": [{"id": "x", "type": "Idle"}, {"id": "end", "type": "Final"}]})
    assert not hit(path)
    plan = loader.compile(path)
    assert hit(path)
    if change == "document":
        assert plan.variables["n"] == 1
    else:
        assert plan.root.states[2].regions[0].states[0].on_enter is None


def test_a_document_and_include_with_a_byte_order_mark_hit_and_miss_by_their_bytes(folder: Path,
                                                                                   tmp_path: Path) -> None:
    """A hit hashes the bytes it read (a byte-order mark set aside): the same key as the text the miss hashed, and
    one byte changed in the document or its include misses."""
    bom = b"\xef\xbb\xbf"
    path = machine_files(tmp_path)
    sub = tmp_path / "sub.json"
    for file in (path, sub):
        file.write_bytes(bom + file.read_bytes())
    loader.compile(path)
    cache.flush()
    assert hit(path)
    for file in (path, sub):
        original = file.read_bytes()
        file.write_bytes(original.replace(b'"Idle"', b'"Idle" ', 1))  # the same machine, another text
        assert not hit(path)
        file.write_bytes(original)
        assert hit(path)


def test_a_read_marks_the_cache_file_used_only_when_it_was_not_recently(folder: Path, tmp_path: Path) -> None:
    """Pruning keeps the most recently used files: a read sets the file's time when it is older than a minute,
    not on every hit (a write per read)."""
    path = machine_files(tmp_path)
    loader.compile(path)
    cache.flush()
    target = cache.file_of(str(path))
    recent = target.stat().st_mtime_ns - 10_000_000_000
    os.utime(target, ns=(recent, recent))
    assert hit(path)
    assert target.stat().st_mtime_ns == recent  # ten seconds ago: as recent as any
    os.utime(target, (1_000_000, 1_000_000))
    assert hit(path)
    assert target.stat().st_mtime > 1_000_000 + 3600  # long ago: now


def test_a_changed_plugin_type_misses(folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    plugin = tmp_path / "cached_plugin_types.py"
    plugin.write_text(textwrap.dedent("""
        from fsm import State

        class Blink(State):
            pass
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    import cached_plugin_types  # type: ignore[import-not-found]

    registry = Registry.with_builtins()
    registry.add_state(cached_plugin_types.Blink, "Blink")
    path = write(tmp_path / "p.json", {"initial": "a", "states": [{"id": "a", "type": "Blink"}]})
    loader.compile(path, registry=registry)
    assert hit(path, registry)
    plugin.write_text(plugin.read_text() + "\n    # the type's source changed\n")
    stat = plugin.stat()
    os.utime(plugin, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))
    # this process still runs the code it imported (its stamp is taken once): what it cached still describes it
    assert hit(path, registry)
    # the changed source imported (as by a new process, or a reload): it misses
    importlib.reload(cached_plugin_types)
    registry = Registry.with_builtins()
    registry.add_state(cached_plugin_types.Blink, "Blink")
    assert not hit(path, registry)
    loader.compile(path, registry=registry)
    assert hit(path, registry)
    other = Registry.with_builtins()  # the same name for another class
    other.add_state(default_registry().states["Idle"], "Blink")
    assert not hit(path, other)
    sys.modules.pop("cached_plugin_types", None)


def test_a_changed_loader_version_misses(folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = machine_files(tmp_path)
    loader.compile(path)
    assert hit(path)
    monkeypatch.setattr(cache, "LOADER_VERSION", cache.LOADER_VERSION + "+next")
    assert not hit(path)


@pytest.mark.parametrize("damage", ["garbage", "truncated", "empty", "flipped"])
def test_a_corrupt_cache_file_is_ignored_and_rewritten(folder: Path, tmp_path: Path, damage: str) -> None:
    path = machine_files(tmp_path)
    loader.compile(path)
    cache.flush()  # the file is written in the background
    (entry,) = folder.iterdir()
    data = entry.read_bytes()
    entry.write_bytes({"garbage": b"\x80\x05not a cache file", "truncated": data[: len(data) // 2], "empty": b"",
                       "flipped": data[:-40] + bytes([data[-40] ^ 0xFF]) + data[-39:]}[damage])
    assert not hit(path)
    loader._LAST.clear()
    m = fsm.load(path, dt=0.05)
    assert m.name == "counting"
    assert hit(path)


def test_a_forged_cache_file_runs_no_code(folder: Path, tmp_path: Path) -> None:
    """A file with the right key and checksum whose payload names a function: refused, never called."""
    path = machine_files(tmp_path)
    loader.compile(path)
    cache.flush()  # the file is written in the background
    (entry,) = folder.iterdir()
    data = entry.read_bytes()
    start = len(cache.MAGIC) + 4
    size = int.from_bytes(data[len(cache.MAGIC):start], "big")
    header = json.loads(data[start:start + size])
    marker = tmp_path / "ran"

    class Evil:
        def __reduce__(self) -> Any:
            return (os.system, (f"touch {marker}",))

    payload = pickle.dumps(Evil())
    import hashlib

    header["payload"] = hashlib.sha256(payload).hexdigest()
    head = json.dumps(header).encode()
    entry.write_bytes(cache.MAGIC + len(head).to_bytes(4, "big") + head + payload)
    assert not hit(path)
    assert not marker.exists()
    assert loader.compile(path).name == "counting"


def test_no_cache_writes_nothing(folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    path = machine_files(tmp_path)
    assert main(["validate", str(path), "--no-cache"]) == 0
    assert main(["--no-cache", "validate", str(path)]) == 0
    assert not folder.exists()
    assert cache.NO_CACHE_ENV not in os.environ  # the option does not outlive the command
    monkeypatch.setenv(cache.NO_CACHE_ENV, "1")
    loader.compile(path)
    assert not folder.exists()


def test_documents_with_errors_are_not_cached(folder: Path, tmp_path: Path) -> None:
    path = write(tmp_path / "bad.json", {"initial": "nowhere", "states": [{"id": "a", "type": "Idle"}]})
    _spec, problems = fsm.check(path)
    assert any(p.severity == "error" for p in problems)
    assert not folder.exists()


def test_an_unwritable_cache_folder_is_no_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(cache.CACHE_DIR_ENV, str(blocker / "cache"))
    monkeypatch.delenv(cache.NO_CACHE_ENV, raising=False)
    path = machine_files(tmp_path)
    assert loader.compile(path).name == "counting"
    assert blocker.read_text() == "not a folder"


def test_the_default_folder_is_the_users_cache(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv(cache.CACHE_DIR_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.folder() == tmp_path / "xdg" / "tral-fsm" / "plans"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.folder() == tmp_path / "home" / ".cache" / "tral-fsm" / "plans"


def test_two_processes_writing_at_once(folder: Path, tmp_path: Path) -> None:
    path = machine_files(tmp_path)
    env = {**os.environ, cache.CACHE_DIR_ENV: str(folder)}
    env.pop(cache.NO_CACHE_ENV, None)
    code = textwrap.dedent("""
        import sys, fsm
        from fsm.loading import cache, loader
        from fsm.loading.registry import default_registry
        loader.compile(sys.argv[1])
        entry = loader._LAST[0]
        for _ in range(40):
            assert cache.store(sys.argv[1], default_registry(), entry, "json")
        loader._LAST.clear()
        loader.compile(sys.argv[1])
        print("ok")
    """)
    procs = [subprocess.Popen([sys.executable, "-c", code, str(path)], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    for p in procs:
        out, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
        assert out.strip() == "ok"
    assert [f.name for f in folder.iterdir()] == [cache.file_of(str(path)).name]  # no temporary file left
    assert hit(path)


@needs_corpus
def test_a_real_umlet_file_is_cached_and_validates_the_same(folder: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A diagram drawn by someone else in UMLet: read by the UMLet reader, cached, validated the same."""
    for drawn in sorted(CORPUS.glob("*.uxf")):
        spec, problems = fsm.check(drawn)
        if spec is not None and not any(p.severity == "error" for p in problems):
            break
    else:
        pytest.skip("no error-free diagram in the corpus")
    path = tmp_path / drawn.name
    shutil.copy(drawn, path)
    outputs = []
    for argv in (["validate", "--no-cache", str(path)], ["validate", str(path)], ["validate", str(path)]):
        assert main(argv) == 0
        captured = capsys.readouterr()
        outputs.append(captured.out + captured.err)
    assert outputs[0] == outputs[1] == outputs[2]
    assert hit(path)


def test_the_machine_chosen_in_a_diagram_is_part_of_the_key(folder: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A diagram with two machines: ``--machine`` picks one; the cache never answers with the other."""
    import re

    from fsm.tools.umlet.writer import diagram, element, relation

    one = [element("UMLSpecialState", 100, 20, 20, 20, "type=initial"),
           relation([[110, 40], [110, 80]], "lt=->"),
           element("UMLState", 40, 80, 160, 60, 'wait\n--\n"type": "Idle"\n--'),
           element("UMLState", 40, 220, 160, 60, "done\n--\ntype=Final"),
           relation([[110, 140], [110, 220]], 'lt=->\n"type": "Timeout", "seconds": 0.5')]
    text = diagram(one)
    body = text.split("  <zoom_level>10</zoom_level>\n")[1].rsplit("</diagram>", 1)[0]
    other = re.sub(r"<x>(\d+)</x>", lambda m: f"<x>{int(m.group(1)) + 2000}</x>", body).replace("wait", "other")
    src = tmp_path / "two.uxf"
    src.write_text(text.replace("</diagram>", other + "</diagram>"))
    from fsm.tools.umlet import reader
    from fsm.tools.umlet.convert import select

    conv = reader.convert_file(src)
    for name in ("wait", "other", "wait", "other"):  # as `fsmctl convert/graph --machine NAME` check the diagram
        token = reader.PRESELECTED.set((src.resolve(), conv, select(conv, name)))
        try:
            spec, problems = fsm.check(src)
        finally:
            reader.PRESELECTED.reset(token)
        assert spec is not None and spec.initial == name, problems
        cache.flush()
        assert [f.name for f in folder.iterdir()] == [cache.file_of(str(src)).name]
    for name in ("wait", "other"):
        assert main(["graph", str(src), "--machine", name, "--format", "dot"]) == 0
        assert f'"{name}"' in capsys.readouterr().out


def test_the_folder_keeps_the_most_recently_used_files(folder: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Every document ever loaded would leave a file: beyond the limit the least recently used go, and a
    temporary file a dead writer left behind is removed."""
    monkeypatch.setattr(cache, "MAX_FILES", 3)
    paths = [write(tmp_path / f"d{i}.json", {"initial": "a", "states": [{"id": "a", "type": "Idle"}]})
             for i in range(3)]
    for i, path in enumerate(paths):
        loader.compile(path)
        cache.flush()
        os.utime(cache.file_of(str(path)), (1_000_000 + i, 1_000_000 + i))
    assert hit(paths[0])  # read: now the most recently used
    stale = folder / ".left-behind.tmp"
    stale.write_bytes(b"half")
    os.utime(stale, (1_000, 1_000))
    fresh = folder / ".being-written.tmp"
    fresh.write_bytes(b"half")
    loader.compile(write(tmp_path / "d3.json", {"initial": "b", "states": [{"id": "b", "type": "Idle"}]}))
    cache.flush()
    left = sorted(f.name for f in folder.iterdir())
    assert cache.file_of(str(paths[1])).name not in left  # the least recently used
    assert {cache.file_of(str(p)).name for p in (paths[0], paths[2])} <= set(left)
    assert ".left-behind.tmp" not in left and ".being-written.tmp" in left
    assert len([n for n in left if n.endswith(".plan")]) == 3


FRESH_LOAD = """
import json, sys
from fsm.loading import cache, loader
real_parse = loader.parse
parsed = []
loader.parse = lambda *a, **k: parsed.append(1) or real_parse(*a, **k)
loader.compile(sys.argv[1])
cache.flush()
print(json.dumps({"parsed": bool(parsed), "modules": sorted(m for m in sys.modules if m.startswith("fsm."))}))
"""


def test_a_fresh_process_reads_the_cache_importing_only_the_types_it_uses(folder: Path, tmp_path: Path) -> None:
    """The key does not import every type: a hit in a fresh process imports the modules of the types the machine
    uses (Idle, Final, Always, Timeout, Finished here), not the car's or the markers'."""
    path = machine_files(tmp_path)
    env = {**os.environ, cache.CACHE_DIR_ENV: str(folder)}
    env.pop(cache.NO_CACHE_ENV, None)
    first, second = (json.loads(subprocess.run([sys.executable, "-c", FRESH_LOAD, str(path)], env=env, check=True,
                                               capture_output=True, text=True).stdout) for _ in range(2))
    assert first["parsed"] and not second["parsed"]  # the second process read the file the first wrote
    for unused in ("fsm.states.driving", "fsm.transitions.markers", "fsm.transitions.car", "fsm.states.plants"):
        assert unused not in first["modules"] and unused not in second["modules"], unused
    assert "fsm.states.generic" in second["modules"] and "fsm.transitions.generic" in second["modules"]


class Blink(fsm.State[fsm.StateParams]):
    """A type an installed plugin would register (defined here, so its source file is this test's)."""


def deferred_plugin_registry() -> Registry:
    """A registry as a fresh process has it: built-ins by name, the installed plugins (here: Blink) still due."""
    registry = Registry.with_builtins()
    registry.load_entry_points = lambda: registry.add_state(Blink)  # type: ignore[method-assign,assignment]
    registry.defer_entry_points()
    return registry


def test_a_machine_of_an_installed_plugins_type_is_a_hit_in_a_process_that_has_not_loaded_it(
        folder: Path, tmp_path: Path) -> None:
    """The plugins a load needed are loaded before the key is compared, so a machine of a plugin's type is read
    from the cache by a process whose plugins are still due, as a fresh process's are."""
    path = write(tmp_path / "blink.json", {"initial": "a", "states": [{"id": "a", "type": "Blink"},
                                                                          {"id": "b", "type": "Final"}],
                                           "transitions": [{"type": "Always", "from": "a", "to": "b"}]})
    loader.compile(path, registry=deferred_plugin_registry())
    cache.flush()
    fresh = deferred_plugin_registry()
    assert fresh.plugins_due()
    assert hit(path, fresh) and not fresh.plugins_due()
    loaded = deferred_plugin_registry()
    loaded.complete()
    assert hit(path, loaded)  # a process that had loaded them first: the same key
    only_builtins = write(tmp_path / "plain.json", {"initial": "a", "states": [{"id": "a", "type": "Idle"}]})
    loader.compile(only_builtins, registry=deferred_plugin_registry())
    cache.flush()
    untouched = deferred_plugin_registry()
    assert hit(only_builtins, untouched) and untouched.plugins_due()  # no plugin loaded for built-in types


FRESH_VALIDATE = """
import json, sys
from fsm.loading import cache, loader
from fsm.tools.cli.app import main
real_parse = loader.parse
parsed = []
loader.parse = lambda *a, **k: parsed.append(1) or real_parse(*a, **k)
status = main(["validate", sys.argv[1]])
cache.flush()
entry = loader._LAST[0]
print(json.dumps({"parsed": bool(parsed), "status": status, "plan_made": entry._plan is not None,
                  "spec": type(entry.spec).__name__,
                  "modules": sorted(m for m in sys.modules if m.startswith("fsm."))}))
"""


def test_validate_from_the_cache_makes_neither_the_plan_nor_the_spec(folder: Path, tmp_path: Path) -> None:
    """`fsmctl validate` needs a document's problems only: a fresh process's hit reads them and makes nothing
    else of the file (no plan, no spec contents), imports no type's module, and prints what the miss printed."""
    path = machine_files(tmp_path)
    env = {**os.environ, cache.CACHE_DIR_ENV: str(folder)}
    env.pop(cache.NO_CACHE_ENV, None)
    runs = [subprocess.run([sys.executable, "-c", FRESH_VALIDATE, str(path)], env=env, check=True,
                           capture_output=True, text=True) for _ in range(2)]
    first, second = (json.loads(run.stdout.splitlines()[-1]) for run in runs)
    assert first["parsed"] and not second["parsed"]
    assert first["status"] == second["status"] == 0
    assert runs[0].stdout.splitlines()[:-1] == runs[1].stdout.splitlines()[:-1]  # "ok, 1 warning" and the warning
    assert "1 warning" in runs[1].stdout and runs[0].stderr == runs[1].stderr
    assert not second["plan_made"] and second["spec"] != "MachineSpec"
    assert not [m for m in second["modules"] if m.startswith(("fsm.states.", "fsm.transitions."))]


def test_a_part_that_cannot_be_made_later_is_a_located_problem_and_the_file_goes(
        folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The plan part is made after the key and checksum passed: when it still cannot be made (a forged file, a
    type's class gone), the load fails with one located message, the file is removed and the next load misses."""
    path = machine_files(tmp_path)
    loader.compile(path)
    cache.flush()
    loader._LAST.clear()
    cache._KEPT.clear()
    monkeypatch.setattr(cache, "_allowed", lambda registry, key: dict(cache._model_classes()))  # no type allowed
    spec, problems = loader.check(path)  # the problems only: nothing of the plan is made, so nothing fails yet
    assert spec is not None and [p.severity for p in problems] == ["warning"]
    with pytest.raises(fsm.DiagramError) as err:
        loader.compile(path)
    (problem,) = err.value.problems
    assert problem.file == str(path) and "plan cache" in problem.message and "--no-cache" in (problem.hint or "")
    assert not cache.file_of(str(path)).exists()
    monkeypatch.undo()
    loader._LAST.clear()
    assert loader.compile(path).root.initial == "a"  # a miss: checked and compiled again
