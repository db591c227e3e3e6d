"""The plan cache's stored form (fsm/loading/flat.py): what a cache file gives back is the load's result object for
object (every spec, parameter model, plan record, expression and action, with the same objects shared), for every
diagram the project ships and real UMLet files; the form is plain data (tables of columns), refused when it names
anything else."""

from __future__ import annotations

import copy
import dataclasses
import enum
import io
import json
import math
import os
import pickle
import threading
import types
from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel

import test_plan_cache
from fsm.loading import cache, flat, loader
from fsm.loading.compiling import ACTIONS
from fsm.loading.registry import default_registry
from fsm.model import expr as E
from fsm.model.document import MachineSpec, Source
from fsm.model.plan import NOTHING, MachinePlan, SupervisionPlan
from helpers import CORPUS, needs_corpus

REPO = Path(__file__).resolve().parents[1]
DIAGRAMS = sorted(p for p in (REPO / "diagrams").rglob("*") if p.suffix in (".json", ".uxf")
                  and not p.name.endswith(".scenario.json") and "worlds" not in p.parts
                  and p.name != "TRAL_State-Machine.uxf")  # the palette to draw from, not a machine
PLUGIN = REPO / "examples" / "eeros" / "eeros_plant.py"


#: An empty cache folder of each test's own, the cache switched on (the plan cache's tests' fixture).
folder = test_plan_cache.folder


class Same:
    """Compares two object graphs: equal values, the same classes, and objects shared in the first shared alike
    in the second."""

    def __init__(self) -> None:
        self.pairs: dict[int, Any] = {}
        self.kept: list[Any] = []

    def __call__(self, a: Any, b: Any, where: str = "") -> None:  # noqa: C901 - one case per kind
        assert type(a) is type(b), f"{where}: {type(a).__name__} against {type(b).__name__}"
        if isinstance(a, (type, types.BuiltinFunctionType)) or isinstance(a, (str, int, float, bool, type(None),
                                                                              enum.Enum)):
            assert a == b or a is b, f"{where}: {a!r} against {b!r}"
            return
        if id(a) in self.pairs:
            assert self.pairs[id(a)] is b, f"{where}: shared in the load, not shared from the cache"
            return
        self.pairs[id(a)] = b
        self.kept.append(a)
        kind = type(a)
        if kind is Source:
            assert (a.name, a.text, a.directory) == (b.name, b.text, b.directory), where
        elif kind is E.Compiled:
            assert (a.text, a.kind, a.constant, a.value) == (b.text, b.kind, b.constant, b.value), where
            self(a.var_op, b.var_op, f"{where}.var_op")
        elif kind is types.FunctionType:
            assert a.__qualname__ == b.__qualname__, where
            if a in ACTIONS:
                self(ACTIONS[a], ACTIONS[b], f"{where}()")
        elif kind is types.MappingProxyType:
            assert (a is NOTHING) == (b is NOTHING), where
            self(dict(a), dict(b), where)
        elif kind is dict:
            assert list(a) == list(b), f"{where}: keys {list(a)} against {list(b)}"
            for k in a:
                self(a[k], b[k], f"{where}[{k!r}]")
        elif kind in (list, tuple) or (isinstance(a, tuple) and hasattr(kind, "_fields")):
            assert len(a) == len(b), where
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                self(x, y, f"{where}[{i}]")
        elif kind in (set, frozenset):
            assert a == b, where
        elif isinstance(a, BaseModel):
            assert a.__pydantic_fields_set__ == b.__pydantic_fields_set__, where
            assert (a.__pydantic_extra__, a.__pydantic_private__) == (b.__pydantic_extra__, b.__pydantic_private__)
            self(a.__dict__, b.__dict__, f"{where}<{kind.__name__}>")
            assert a == b, where
        elif dataclasses.is_dataclass(a):
            self(vars(a), vars(b), f"{where}<{kind.__name__}>")
        else:
            raise AssertionError(f"{where}: nothing to compare {kind.__name__} with")


def same_entry(path: Path) -> None:
    """Load ``path`` (a miss: checked, compiled, written), then read the file back; the two results are alike."""
    registry = default_registry((str(PLUGIN),))  # the EEROS cases' axis and gripper types
    fresh = loader.compile(path, registry=registry)
    first = cache._KEPT[str(path)][2]
    assert first.plan is fresh
    cache._KEPT.clear()
    doc = cache.document(str(path))
    assert doc is not None
    again = cache.lookup(str(path), registry, doc)
    assert again is not None, f"{path.name}: not read back from its cache file"
    # nothing but the problems and the analysis is made until it is used: the plan, then the spec's contents
    assert type(again.spec) is not MachineSpec and again._plan is None
    assert again.spec.name == first.spec.name and type(again.spec) is not MachineSpec
    assert isinstance(again.plan, MachinePlan) and again.plan.spec is again.spec
    assert again.spec.states is not None and type(again.spec) is MachineSpec
    assert first.spec.states is not None  # (a hit too when the caller loaded it before: its contents made)
    for copy_of in (copy.copy, copy.deepcopy, lambda x: pickle.loads(pickle.dumps(x))):  # the plain spec, made
        cache._KEPT.clear()
        shell = cache.lookup(str(path), registry, doc)
        assert shell is not None and type(shell.spec) is not MachineSpec
        copied = copy_of(shell.spec)
        assert type(copied) is MachineSpec and type(shell.spec) is MachineSpec
        assert [st.id for st in copied.states] == [st.id for st in shell.spec.states]
    compare = Same()
    compare((first.spec, first.analysis, first.problems, first.plan),
            (again.spec, again.analysis, again.problems, again.plan), path.name)


@pytest.mark.parametrize("path", DIAGRAMS, ids=lambda p: str(p.relative_to(REPO / "diagrams")))
def test_every_diagram_reads_back_as_it_was_loaded(folder: Path, path: Path) -> None:
    same_entry(path)


@needs_corpus
def test_real_umlet_files_read_back_as_they_were_loaded(folder: Path) -> None:
    done = 0
    for path in sorted(CORPUS.glob("*.uxf")):
        try:
            loader.compile(path, registry=default_registry((str(PLUGIN),)))
        except Exception:  # noqa: BLE001 - a drawing this loader refuses is not cached; the others are compared
            continue
        loader._LAST.clear()
        cache._KEPT.clear()
        same_entry(path)
        done += 1
    assert done >= 2  # the corpus drawings this loader takes without errors


def test_a_big_machine_is_stored_as_columns_not_objects(folder: Path, tmp_path: Path) -> None:
    """1000 states: one batch per kind of record, each column a constant or one list, and the form is plain data
    (it unpickles with every class refused)."""
    n = 1000
    doc = {"initial": "s0", "states": [{"id": f"s{i}", "type": "Idle"} for i in range(n)],
           "transitions": [{"type": "Always", "from": f"s{i}", "to": f"s{(i + 1) % n}"} for i in range(n)]}
    path = tmp_path / "ring.json"
    path.write_text(json.dumps(doc))
    loader.compile(path)
    cache.flush()
    (entry,) = folder.iterdir()
    data = entry.read_bytes()
    start = len(cache.MAGIC) + 4
    size = int.from_bytes(data[len(cache.MAGIC):start], "big")
    stream = flat._PlainOnly(io.BytesIO(data[start + size:]))
    assert stream.load() == [flat.VERSION, 3]
    # three parts: the problems and analysis (what `fsmctl validate` reads); the plan with the parameters it
    # shares with the spec (what a load reads); the rest of the spec (read when first used)
    first, plan, spec = (stream.load()[0] for _ in range(3))
    big = {part: [b for b in batches if b[0] in ("record", "object", "model") and b[-2] == n]
           for part, batches in (("first", first), ("plan", plan), ("spec", spec))}
    assert [len(big["first"]), len(big["plan"]), len(big["spec"])] == [0, 4, 2]  # plan and parameters; specs
    batches = first + plan + spec
    assert len(batches) < 36  # one per kind of object, height and part, not one per object
    for b in big["plan"] + big["spec"]:
        assert all(column[0] in ("K", "C", "L", "R") for column in b[-1])
    same_entry(path)


class Evil:
    def __reduce__(self) -> Any:
        return (print, ("ran",))


def test_the_form_refuses_what_is_not_data() -> None:
    with pytest.raises(flat.Unflattenable):
        flat.flatten(Evil(), {}, {})
    with pytest.raises(flat.Unflattenable):
        flat.flatten([Source], {}, {})  # a class not allowed
    forged = pickle.dumps([flat.VERSION, 1]) + pickle.dumps([[["lit", [Evil()]]], 0])
    with pytest.raises(pickle.UnpicklingError):
        flat.unflatten(forged, {}, {})
    with pytest.raises(pickle.UnpicklingError):  # the stream's head itself
        flat.unflatten(pickle.dumps([flat.VERSION, Evil()]), {}, {})
    plain = {"a": [1, 2.5, "x", None, True], "b": (frozenset({1}), {"k": ()})}
    assert flat.unflatten(flat.flatten(plain, {}, {}), {}, {}) == plain


def test_a_forged_table_names_only_allowed_classes() -> None:
    """A batch whose class column is not an allowed class, or whose columns do not fit, is refused."""
    allowed = {(Source.__module__, "Source"): Source}
    bad_class = [[["lit", []], ["class", [("os", "system")]]], 0]
    with pytest.raises(pickle.UnpicklingError):
        flat.unflatten(pickle.dumps([flat.VERSION, 1]) + pickle.dumps(bad_class), allowed, {})
    not_a_record = [[["lit", []], ["class", [(Source.__module__, "Source")]], ["record", 1, [["C", 0], ["K", 1]]]], 1]
    with pytest.raises(ValueError):
        flat.unflatten(pickle.dumps([flat.VERSION, 1]) + pickle.dumps(not_a_record), allowed, {})


def test_parts_are_made_in_order_and_refer_to_earlier_ones() -> None:
    """A later part's objects refer to an earlier part's by index; a named object is the reader's own."""
    allowed = {(SupervisionPlan.__module__, "SupervisionPlan"): SupervisionPlan}
    shared, own = SupervisionPlan(timeout=1.5), SupervisionPlan(timeout=2.5)
    marker = object()
    data = flat.flatten_parts([[shared], [shared, own, marker]], allowed, {}, {id(marker): "_mine"})
    mine = object()
    reader = flat.Reader(data, {"_mine": lambda: mine})
    assert len(reader) == 2
    first = reader.part(0, allowed)
    assert first == [shared] and len(reader.roots) == 1  # the second part not made yet
    second = reader.part(1, allowed)
    assert second[0] is first[0] and second[1] == own and second[2] is mine


def test_a_miss_returns_before_the_file_is_written(folder: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The writer runs beside the caller: the load is back while the file is still being made (none there yet,
    not even half of one), the process's next read of it waits for it, and so does a fork."""
    gate = threading.Event()
    real = flat.flatten_parts

    def slow(*args: Any) -> bytes:
        assert gate.wait(10)
        return real(*args)

    monkeypatch.setattr(flat, "flatten_parts", slow)
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}))
    assert loader.compile(path).root.initial == "a"  # returned while the writer waits
    assert not folder.exists() or not any(folder.iterdir())
    threading.Timer(0.2, gate.set).start()
    pid = os.fork()  # waits for the writer first
    if pid == 0:
        os._exit(0 if cache.file_of(str(path)).exists() else 1)
    assert os.waitpid(pid, 0)[1] == 0
    assert [f.name for f in folder.iterdir()] == [cache.file_of(str(path)).name]
    cache._KEPT.clear()
    doc = cache.document(str(path))
    assert doc is not None and cache.lookup(str(path), default_registry(), doc) is not None


def test_equal_values_that_differ_stay_apart() -> None:
    """0.0 and -0.0 are equal, True and 1 too: a constant column or a shared literal keeps them apart."""
    allowed = {(SupervisionPlan.__module__, "SupervisionPlan"): SupervisionPlan}
    plans = [SupervisionPlan(timeout=0.0), SupervisionPlan(timeout=-0.0), SupervisionPlan(timeout=1),
             SupervisionPlan(timeout=True)]
    back = flat.unflatten(flat.flatten([plans, [SupervisionPlan(timeout=-0.0)] * 2, [0.0, -0.0, plans[0]]],
                                       allowed, {}), allowed, {})
    assert [math.copysign(1, p.timeout) for p in back[0][:2]] == [1, -1]
    assert [type(p.timeout) for p in back[0]] == [float, float, int, bool]
    assert math.copysign(1, back[1][0].timeout) == -1
    assert [math.copysign(1, v) for v in back[2][:2]] == [1, -1]


class _Strict(BaseModel):
    """A model with a ``__setattr__`` of its own and validated assignment."""

    model_config = {"validate_assignment": True}
    name: str
    count: int = 0
    tags: list[str] = []

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "count" and value < 0:
            raise ValueError("count below zero")
        super().__setattr__(name, value)


@dataclasses.dataclass
class _Record:
    name: str
    size: int = 1


def test_models_and_dataclasses_read_back_behave_as_made() -> None:
    """Models and dataclasses read back hold their fields, their set fields and private parts as made, and behave
    as models do afterwards (assignment validated, copies, dumps); the reader sets the instance dict and the
    model's slots directly, as ``object.__setattr__`` would."""
    allowed = {(__name__, "_Strict"): _Strict, (__name__, "_Record"): _Record}
    models = [_Strict(name="a"), _Strict(name="b", count=3, tags=["x"]), _Strict(name="c", count=2)]
    records = [_Record("r"), _Record("s", 5)]
    back = flat.unflatten(flat.flatten([models, records], allowed, {}), allowed, {})
    assert back == [models, records]
    for made, was in zip(back[0], models, strict=True):
        assert type(made) is _Strict
        assert made.model_fields_set == was.model_fields_set
        assert made.__pydantic_extra__ == was.__pydantic_extra__
        assert made.__pydantic_private__ == was.__pydantic_private__
        assert made.model_dump() == was.model_dump()
    assert back[0][0].model_fields_set is not back[0][2].model_fields_set  # each model its own set
    with pytest.raises(ValueError):
        back[0][1].count = -1
    back[0][1].count = 4
    assert back[0][1].count == 4 and back[0][1].model_copy(update={"name": "z"}).name == "z"
    assert [type(r) for r in back[1]] == [_Record, _Record] and back[1][1].size == 5
    back[1][0].size = 2
    assert vars(back[1][0]) == {"name": "r", "size": 2}


def test_containers_of_one_length_and_of_several_read_back() -> None:
    """Containers of one kind are cut from one run of items: all of one length (cut by ``zip``) or of several;
    each read back as its own object (two equal lists stay two lists)."""
    shared = SupervisionPlan(timeout=1.0)
    allowed = {(SupervisionPlan.__module__, "SupervisionPlan"): SupervisionPlan}
    ones = [(shared,), (SupervisionPlan(timeout=2.0),), ("x",)] * 3
    pairs = [[1, "a"], [1, "a"], [shared, 2]]
    mixed = [(), (1,), (1, 2, 3), (shared, shared)]
    sets = [frozenset({1}), frozenset({2}), {3, 4}, {5, 6}]
    root = [ones, pairs, mixed, sets, [[], []]]
    back = flat.unflatten(flat.flatten(root, allowed, {}), allowed, {})
    assert back == root
    assert [type(t) for t in back[0]] == [tuple] * 9 and back[0][0][0] is back[1][2][0] is back[2][3][1]
    assert back[1][0] is not back[1][1] and back[4][0] is not back[4][1]
    assert [type(s) for s in back[3]] == [frozenset, frozenset, set, set]
