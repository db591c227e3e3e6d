"""Layering (docs/architecture.md, "Layering"): the ``fsm`` core (everything under ``fsm/`` but ``fsm/sim/`` and
``fsm/vision/``) imports none of cv2, pymunk, lxml, ``fsm.sim``, ``fsm.vision`` or ``fsm.tools``; ``fsm.vision``
(OpenCV) imports neither pymunk nor ``fsm.sim`` nor ``fsm.tools``, since a real camera feeds it. Each core module is
imported in a fresh interpreter and its ``sys.modules`` inspected, so one module's imports cannot hide another's."""

from __future__ import annotations

import json
import os
import pkgutil
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

import fsm

FORBIDDEN = ("cv2", "pymunk", "lxml", "fsm.sim", "fsm.vision", "fsm.tools")
#: What the perception layer must not import (it may import cv2, numpy and the core).
VISION_FORBIDDEN = ("pymunk", "lxml", "fsm.sim", "fsm.tools")
CORE_DIR = Path(fsm.__file__).resolve().parent
#: Subpackages of fsm/ that are not the core: the adapters (car, camera, ROS 2), the libraries of state and
#: transition types, the tools, the pytest plugin and the bundled worlds.
NOT_CORE = ("fsm.sim", "fsm.vision", "fsm.ros", "fsm.states", "fsm.transitions", "fsm.tools", "fsm.testing",
            "fsm.worlds")

#: One fresh interpreter that imports each module in a child of its own (``os.fork``), so one module's imports cannot
#: hide another's. What the modules need besides ``fsm`` and the forbidden modules (the standard library, pydantic,
#: jsonschema, ...) is imported once by the parent first, found by a child that imports them all: the children then
#: import only the project's modules, fresh. Should that warm-up bring in a forbidden module, every module is
#: probed without it (still one child each, from a parent with nothing imported).
PROBE_SERVER = textwrap.dedent('''
    import importlib, json, os, sys

    job = json.loads(sys.stdin.read())
    modules, forbidden = job["modules"], tuple(job["forbidden"])

    def banned(name):
        return any(name == f or name.startswith(f + ".") for f in forbidden)

    def in_child(work):
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(read)
            try:
                out = work()
            except BaseException as exc:
                text = str(exc).strip().splitlines()
                out = "import failed: " + (type(exc).__name__ + ": " + text[-1] if text else type(exc).__name__)
            os.write(write, json.dumps(out).encode())
            os._exit(0)
        os.close(write)
        chunks = []
        while True:
            chunk = os.read(read, 65536)
            if not chunk:
                break
            chunks.append(chunk)
        os.close(read)
        os.waitpid(pid, 0)
        return json.loads(b"".join(chunks) or b'"import failed: the child died"')

    def everything():
        for m in modules:
            try:
                importlib.import_module(m)
            except BaseException:
                pass
        return [m for m in sys.modules if not (m == "fsm" or m.startswith("fsm.") or banned(m) or m == "__main__")]

    needed = in_child(everything)
    for name in needed if isinstance(needed, list) else []:
        try:
            importlib.import_module(name)
        except BaseException:
            pass
    warm = not any(banned(m) for m in sys.modules) and not any(m == "fsm" or m.startswith("fsm.") for m in sys.modules)
    if not warm:  # start again from an interpreter with nothing of that imported
        os.execv(sys.executable, [sys.executable, "-c", job["cold"]])

    def one(m):
        def work():
            importlib.import_module(m)
            return sorted(n for n in sys.modules if banned(n))
        return work

    print(json.dumps({m: in_child(one(m)) for m in modules}))
''')


def core_modules() -> list[str]:
    """Every module and package under fsm/ (found on disk, so new modules are covered), except fsm/sim/ and
    fsm/vision/."""
    names = ["fsm"]
    for info in pkgutil.walk_packages([str(CORE_DIR)], prefix="fsm.", onerror=lambda name: None):
        if any(info.name == p or info.name.startswith(p + ".") for p in NOT_CORE):
            continue
        names.append(info.name)
    return sorted(names)


def probe(modules: list[str], forbidden: tuple[str, ...] = FORBIDDEN) -> dict[str, list[str] | str]:
    """Import each module in a fresh child interpreter (:data:`PROBE_SERVER`): the forbidden modules it pulled in, or
    why it failed to import."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    job = {"modules": modules, "forbidden": list(forbidden)}
    job["cold"] = PROBE_SERVER.replace("job = json.loads(sys.stdin.read())", f"job = {json.dumps(job)!r}; "
                                       "job = json.loads(job)").replace("needed = in_child(everything)", "needed = 0")
    proc = subprocess.run([sys.executable, "-c", PROBE_SERVER], input=json.dumps(job), capture_output=True, text=True,
                          env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    result: dict[str, list[str] | str] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def test_core_modules_are_found() -> None:
    modules = core_modules()
    for name in ("fsm", "fsm.loading.loader", "fsm.runtime.machine", "fsm.model.document", "fsm.loading.registry",
                 "fsm.model.jsonpos", "fsm.model.errors",
                 "fsm.schema"):
        assert name in modules
    assert not any(m.startswith(NOT_CORE) for m in modules)


def test_no_core_module_imports_the_car_umlet_or_tools() -> None:
    results = probe(core_modules())
    offenders = {m: r for m, r in results.items() if r}
    assert not offenders, "core modules importing what they must not (or failing to import):\n" + "\n".join(
        f"  {m}: {r}" for m, r in sorted(offenders.items()))


def test_the_probe_detects_a_forbidden_import() -> None:
    """The check itself works: fsm.tools.cli is (by definition) in fsm.tools."""
    assert "fsm.tools" in probe(["fsm.tools.cli"])["fsm.tools.cli"]


LOAD_AND_RUN = textwrap.dedent('''
    import json, sys
    import fsm
    machine = fsm.load({"initial": "a", "states": [{"id": "a", "type": "Idle"}, {"id": "b", "type": "Final"}],
                        "transitions": [{"type": "Timeout", "from": "a", "to": "b", "seconds": 0.1}]})
    outcome = fsm.run(machine, max_ticks=100).outcome
    spec, problems = fsm.check({"initial": "a", "states": [{"id": "a", "type": "Nope"}]})
    heavy = sorted(m for m in sys.modules if m.split(".")[0] in ("cv2", "pymunk", "lxml")
                   or m == "fsm.sim" or m.startswith("fsm.sim.") or m == "fsm.tools" or m.startswith("fsm.tools."))
    print(json.dumps({"outcome": outcome, "problems": len(problems), "heavy": heavy}))
''')


def test_load_and_run_import_no_heavy_module() -> None:
    proc = subprocess.run([sys.executable, "-c", LOAD_AND_RUN], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["outcome"] == "succeeded" and result["problems"] == 1
    assert result["heavy"] == [], f"import fsm; fsm.load(...) imported {result['heavy']}"


@pytest.mark.parametrize("command", [["validate"], ["types"]])
def test_fsmctl_validate_and_types_do_not_import_cv2_or_pymunk(tmp_path: Path, command: list[str]) -> None:
    """`fsmctl validate` starts fast (docs/architecture.md, "Layering"): the heavy modules stay unimported for JSON
    documents."""
    doc = tmp_path / "m.json"
    doc.write_text(json.dumps({"initial": "a", "states": [{"id": "a", "type": "Idle"}]}))
    argv = [*command, str(doc)] if command == ["validate"] else command
    script = textwrap.dedent(f'''
        import json, sys
        from fsm.tools.cli import main
        code = main({argv!r})
        heavy = sorted(m for m in sys.modules if m.split(".")[0] in ("cv2", "pymunk"))
        print(json.dumps({{"code": code, "heavy": heavy}}))
    ''')
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["code"] == 0
    assert result["heavy"] == [], f"fsmctl {command[0]} imported {result['heavy']}"


def test_state_and_transition_libraries_use_the_car_only_through_its_interface() -> None:
    """fsm.states / fsm.transitions may know the car Protocol, never pymunk, OpenCV, UMLet or the tools."""
    code = textwrap.dedent('''
        import json, sys
        from fsm.loading.registry import builtin_types
        builtin_types()  # every module of fsm.states and fsm.transitions
        bad = sorted(m for m in sys.modules if m.split(".")[0] in ("pymunk", "cv2", "lxml")
                     or m.startswith("fsm.tools") or m in ("fsm.sim.car", "fsm.sim.loop", "fsm.sim.render"))
        print(json.dumps(bad))
    ''')
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          cwd=tempfile.gettempdir())
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []


def test_core_source_names_no_tools_or_car_module() -> None:
    """Also lazy imports count: the core's source names neither fsm.tools nor fsm.sim nor a heavy module."""
    import re

    core = Path(fsm.__file__).parent
    pattern = re.compile(
        r"(import_module\(\s*['\"]|^\s*(from|import)\s+)(fsm\.tools|fsm\.sim|fsm\.vision|cv2|pymunk|lxml)\b", re.M)
    offenders = [str(p.relative_to(core)) for p in core.rglob("*.py")
                 if not {n.split(".")[1] for n in NOT_CORE} & set(p.relative_to(core).parts[:1])
                 and pattern.search(p.read_text(encoding="utf-8"))]
    assert offenders == []


# -- fsm/vision/: perception for a real camera too -----------------------------------------------------------------


def vision_modules() -> list[str]:
    folder = CORE_DIR / "vision"
    return ["fsm.vision"] + sorted(info.name for info in pkgutil.walk_packages([str(folder)], prefix="fsm.vision.",
                                                                            onerror=lambda name: None))


def test_vision_imports_neither_the_simulator_nor_pymunk_nor_the_tools() -> None:
    modules = vision_modules()
    assert {"fsm.vision.detector", "fsm.vision.calibration", "fsm.vision.gates", "fsm.vision.camera"} <= set(modules)
    results = probe(modules, VISION_FORBIDDEN)
    offenders = {m: r for m, r in results.items() if r}
    assert not offenders, "fsm.vision modules importing what they must not:\n" + "\n".join(
        f"  {m}: {r}" for m, r in sorted(offenders.items()))


def test_vision_source_names_no_simulator() -> None:
    """Lazy imports count too: no ``fsm.sim``, pymunk or ``fsm.tools`` anywhere in fsm/vision/ (relative ``..sim``
    included)."""
    import re

    pattern = re.compile(r"(import_module\(\s*['\"]|^\s*(from|import)\s+)(fsm\.tools|fsm\.sim|\.\.sim|pymunk)\b",
                         re.M)
    offenders = [p.name for p in (CORE_DIR / "vision").rglob("*.py") if pattern.search(p.read_text(encoding="utf-8"))]
    assert offenders == []


def test_the_vision_probe_detects_a_forbidden_import() -> None:
    assert "fsm.sim" in probe(["fsm.sim.camera"], VISION_FORBIDDEN)["fsm.sim.camera"]


# -- fsm/ros/: the car over ROS 2 ------------------------------------------------------------------------------


#: What the ROS 2 layer must not import: the tools, UMLet; pymunk only in fsm.ros.robot (the simulated robot).
ROS_FORBIDDEN = ("lxml", "fsm.tools", "pymunk", "fsm.sim.car", "fsm.sim.loop")


def test_ros_layer_imports_neither_the_tools_nor_the_simulator_but_in_its_robot() -> None:
    folder = CORE_DIR / "ros"
    modules = ["fsm.ros"] + sorted(info.name for info in pkgutil.walk_packages([str(folder)], prefix="fsm.ros.",
                                                                               onerror=lambda name: None))
    assert {"fsm.ros.profile", "fsm.ros.car", "fsm.ros.driver", "fsm.ros.robot"} <= set(modules)
    results = probe([m for m in modules if m != "fsm.ros.robot"], ROS_FORBIDDEN)
    offenders = {m: r for m, r in results.items() if r}
    assert not offenders, "fsm.ros modules importing what they must not:\n" + "\n".join(
        f"  {m}: {r}" for m, r in sorted(offenders.items()))
    # and the profile needs neither rosbags nor Zenoh: checking one works without the extra
    light = probe(["fsm.ros.profile"], ("rosbags", "zenoh", "cv2", "numpy"))
    assert light["fsm.ros.profile"] == []


def test_the_in_process_simulator_loads_nothing_of_ros() -> None:
    """The ROS 2 bridge costs the in-process simulator nothing: neither its modules nor the command line's
    entry point load fsm.ros, Zenoh or rosbags (only --ros, `fsmctl sim --ros` and `fsmctl replay` do)."""
    folder = CORE_DIR / "sim"
    modules = ["fsm.sim"] + sorted(info.name for info in pkgutil.walk_packages([str(folder)], prefix="fsm.sim.",
                                                                               onerror=lambda name: None))
    modules += ["fsm.tools.cli", "fsm.tools.cli.run", "fsm.tools.cli.sim"]
    results = probe(modules, ("fsm.ros", "zenoh", "rosbags"))
    offenders = {m: r for m, r in results.items() if r}
    assert not offenders, "the simulator loading the ROS 2 bridge:\n" + "\n".join(
        f"  {m}: {r}" for m, r in sorted(offenders.items()))
    # the probe sees the bridge where it is loaded
    assert "fsm.ros.driver" in probe(["fsm.ros.driver"], ("fsm.ros",))[
        "fsm.ros.driver"]


# -- tools/: one subpackage per concern ------------------------------------------------------------------------


#: package -> the fsm.tools packages it must never import (the CLI sits on top; graph sits below UMLet).
TOOLS_RULES = {"umlet": ("fsm.tools.cli",), "graph": ("fsm.tools.cli", "fsm.tools.umlet"),
               "scenario": ("fsm.tools.cli",)}


def tools_modules(package: str) -> list[str]:
    import fsm.tools

    folder = Path(fsm.tools.__file__).resolve().parent / package
    prefix = f"fsm.tools.{package}."
    return [f"fsm.tools.{package}"] + sorted(
        info.name for info in pkgutil.walk_packages([str(folder)], prefix=prefix, onerror=lambda name: None))


def test_tools_is_one_package_per_concern() -> None:
    """No loose modules pile up in tools/ again: besides the subpackages, only the shared file helpers."""
    import fsm.tools

    folder = Path(fsm.tools.__file__).resolve().parent
    loose = sorted(p.name for p in folder.glob("*.py") if p.name not in ("__init__.py", "files.py"))
    assert loose == []
    for package in ("cli", "umlet", "graph"):
        init = folder / package / "__init__.py"
        assert init.is_file() and len((importlib_docstring(init) or "").split()) >= 20, f"{package} needs a docstring"


def importlib_docstring(path: Path) -> str | None:
    import ast

    return ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))


@pytest.mark.parametrize("package", sorted(TOOLS_RULES))
def test_umlet_and_graph_never_import_the_cli(package: str) -> None:
    """Each module of the package, imported alone, pulls in none of what sits above it."""
    modules = tools_modules(package)
    assert len(modules) >= 4
    results = probe(modules, TOOLS_RULES[package])
    offenders = {m: r for m, r in results.items() if r}
    assert offenders == {}


@pytest.mark.parametrize("package", sorted(TOOLS_RULES))
def test_umlet_and_graph_source_names_no_cli(package: str) -> None:
    """Lazy imports count too: no ``from ..cli`` (or the packages above) anywhere in the package's source."""
    import re

    import fsm.tools

    folder = Path(fsm.tools.__file__).resolve().parent / package
    names = "|".join(re.escape(f.rsplit(".", 1)[1]) for f in TOOLS_RULES[package])
    pattern = re.compile(rf"^\s*(from\s+(\.\.|fsm\.tools\.)({names})\b|import\s+fsm\.tools\.({names})\b)", re.M)
    offenders = [p.name for p in folder.rglob("*.py") if pattern.search(p.read_text(encoding="utf-8"))]
    assert offenders == []


# -- private names: no module reads another module's ---------------------------------------------------------------


REPO = Path(__file__).resolve().parents[1]
#: The documented exceptions (docs/architecture.md, "Layering rules"), where a property would cost a call per tick:
#: the Context's time slots, and pymunk's cffi handles for the car's ray queries, physics step and pose reads; and
#: the one slot of a state's or a transition's wiring record (``_fsm``), which only the module of the records reads
#: (everyone else calls its ``wiring`` and ``transition_wiring``). File -> attributes it may read.
PRIVATE_READS = {"fsm/runtime/machine.py": {"_now", "_tick", "_dt", "_pending"},
                 "fsm/runtime/region.py": {"_now", "_fsm"},
                 "fsm/trace/recorder.py": {"_tick"}, "fsm/transitions/generic.py": {"_now"},
                 "fsm/transitions/conditions.py": {"_now"},
                 "fsm/sim/car.py": {"_space", "_body", "_constraint"}, "fsm/sim/loop.py": {"_now", "_tick"},
                 # pydantic's cache of its plugins, set to none when no distribution declares one (the module says why)
                 "fsm/loading/pydantic_plugins.py": {"_plugins"},
                 # the frame a deprecated read names, to show its warning (CPython's public, if underscored, call)
                 "fsm/runtime/deprecation.py": {"_getframe"}}
#: The public API of named tuples, underscored so as not to clash with field names.
NAMEDTUPLE_API = {"_replace", "_asdict", "_fields", "_make"}


def foreign_private_reads(source: str) -> list[tuple[int, str]]:
    """``(line, expression)`` of each ``from m import _name``, and of each ``x._name`` in ``source`` where ``x`` is
    not ``self``, ``cls`` or ``type(self)`` and ``_name`` is not defined in ``source`` itself (the classes of one
    module may share theirs)."""
    import ast

    tree = ast.parse(source)
    own = {n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))}
    own |= {t.attr for n in ast.walk(tree) if isinstance(n, (ast.Assign, ast.AnnAssign, ast.AugAssign))
            for t in (n.targets if isinstance(n, ast.Assign) else [n.target])
            if isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name) and t.value.id in ("self", "cls")}
    own |= {t.id for n in ast.walk(tree) if isinstance(n, (ast.Assign, ast.AnnAssign))
            for t in (n.targets if isinstance(n, ast.Assign) else [n.target]) if isinstance(t, ast.Name)}
    found = [(node.lineno, f"from {'.' * node.level}{node.module or ''} import {alias.name}")
             for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module != "__future__"
             for alias in node.names if alias.name.startswith("_") and not alias.name.startswith("__")]
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")):
            continue
        owner = node.value
        if isinstance(owner, ast.Name) and owner.id in ("self", "cls"):
            continue
        if isinstance(owner, ast.Call) and isinstance(owner.func, ast.Name) and owner.func.id == "type":
            continue
        if node.attr in own or node.attr in NAMEDTUPLE_API:
            continue
        found.append((node.lineno, ast.unparse(node)))
    return found


def test_no_module_reads_another_modules_private_names() -> None:
    offenders = []
    for folder in ("fsm",):
        for path in sorted((REPO / folder).rglob("*.py")):
            name = path.relative_to(REPO).as_posix()
            allowed = PRIVATE_READS.get(name, set())
            offenders += [f"{name}:{line}: {expr}" for line, expr in foreign_private_reads(path.read_text("utf-8"))
                          if expr.startswith("from ") or expr.rsplit(".", 1)[1] not in allowed]
    assert offenders == [], "give these a public, documented name:\n" + "\n".join(offenders)


def test_the_private_name_check_finds_a_foreign_read() -> None:
    source = textwrap.dedent('''
        class A:
            def __init__(self) -> None:
                self._mine = 1

            def peek(self, other: "A", machine: object) -> object:
                machine._now = 0.0
                return self._mine, other._mine, type(self)._mine, machine._dt, other._replace

        from .driving import _clamp, clamp
    ''')
    assert sorted(foreign_private_reads(source)) == [(7, "machine._now"), (8, "machine._dt"),
                                                     (10, "from .driving import _clamp")]


# -- the core's layer order: an import graph of the source, every import counted -------------------------------------

#: The folders of the core and the package root, whose modules the import graph holds.
CORE_LAYERS_DOC = REPO / "docs" / "architecture.md"
#: The intra-layer imports of the runtime that close cycles, all of them type-only (``if TYPE_CHECKING``). Issue 31
#: emptied it (a state names none of the classes it is linked to: its wiring record, typed with them, lives with the
#: region); it may only shrink, so it stays empty.
TYPE_ONLY_CYCLE_EDGES: frozenset[tuple[str, str]] = frozenset()


def layer_order(text: str) -> list[str]:
    """The layers of the core, lowest first, as docs/architecture.md writes them on its ``**Layer order**`` line
    (``model → runtime → ...``; ``fsm`` is the package root)."""
    import re

    found = re.search(r"^\*\*Layer order\*\*[^:\n]*:(.*)$", text, re.M)
    assert found, "docs/architecture.md has no **Layer order** line"
    return [re.sub(r"[`.\s]", "", part) for part in found.group(1).split("→")]


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(source: str, module: str, is_package: bool) -> set[tuple[str, bool]]:
    """Every module ``source`` imports, ``(name, type_only)``: top-level imports, those inside functions, those under
    ``if TYPE_CHECKING`` (``type_only``) and ``importlib.import_module("...")`` with a literal name."""
    import ast

    tree = ast.parse(source)
    type_only: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            type_only.update(id(n) for child in node.body for n in ast.walk(child))
    found: set[tuple[str, bool]] = set()
    package = module.split(".") if is_package else module.split(".")[:-1]
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package[:len(package) - node.level + 1] + ([base] if base else []))
            names = [f"{base}.{alias.name}" for alias in node.names]  # the module itself when it is one
        elif isinstance(node, ast.Call) and ast.unparse(node.func).endswith("import_module") and node.args \
                and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
            names = [node.args[0].value]
        found.update((name, id(node) in type_only) for name in names if name)
    return found


def import_graph(root: Path, layers: list[str]) -> dict[str, dict[str, bool]]:
    """module -> {imported module: type only} for the modules of ``layers`` (folders of ``root``, ``fsm`` the root's
    ``__init__``), keeping the imports of modules in that set (a name imported from a module counts as the module)."""
    files = {module_name(root / "__init__.py", root): root / "__init__.py"}
    for layer in layers:
        if layer != root.name:
            files.update({module_name(p, root): p for p in (root / layer).rglob("*.py")})
    graph: dict[str, dict[str, bool]] = {}
    for module, path in files.items():
        edges: dict[str, bool] = {}
        for name, type_only in imports_of(path.read_text(encoding="utf-8"), module, path.name == "__init__.py"):
            parts = name.split(".")
            if parts[0] == root.name and len(parts) > 1 and (root / parts[1]).is_dir() and parts[1] not in layers:
                continue  # a package beside the core (fsm.states, loaded by name as plugins are; fsm.sim; ...)
            target = name
            while target and target not in files:
                target = target.rpartition(".")[0]
            if target and target != module:
                edges[target] = edges.get(target, True) and type_only
        graph[module] = edges
    return graph


def layer_of(module: str, layers: list[str]) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in layers else parts[0]


def upward_imports(graph: dict[str, dict[str, bool]], layers: list[str]) -> list[str]:
    rank = {layer: i for i, layer in enumerate(layers)}
    return sorted(f"{a} -> {b}" for a, edges in graph.items() for b in edges
                  if rank[layer_of(b, layers)] > rank[layer_of(a, layers)])


def cycles(graph: dict[str, dict[str, bool]], ignore: frozenset[tuple[str, str]] = frozenset()) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), ``ignore``'s edges left out."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if (v, w) in ignore:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def core_graph() -> tuple[dict[str, dict[str, bool]], list[str]]:
    layers = layer_order(CORE_LAYERS_DOC.read_text(encoding="utf-8"))
    return import_graph(CORE_DIR, layers), layers


def test_the_layer_order_is_written_in_the_architecture_page() -> None:
    graph, layers = core_graph()
    assert layers[0] == "schema" and layers[-1] == "fsm" and {"model", "runtime", "loading", "session"} <= set(layers)
    missing = sorted({p.name for p in CORE_DIR.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
                     - set(layers) - {n.split(".")[1] for n in NOT_CORE})
    assert missing == [], f"core folders missing from the layer order: {missing}"
    assert len(graph) > 40


def test_no_core_module_imports_a_higher_layer() -> None:
    """Every import counts: at the top, inside a function, under TYPE_CHECKING."""
    graph, layers = core_graph()
    assert upward_imports(graph, layers) == []


def test_no_import_cycle_in_the_core() -> None:
    graph, _layers = core_graph()
    assert cycles(graph, TYPE_ONLY_CYCLE_EDGES) == []
    stale = sorted(f"{a} -> {b}" for a, b in TYPE_ONLY_CYCLE_EDGES if graph.get(a, {}).get(b) is not True)
    assert stale == [], f"no longer type-only imports (or gone: take them off TYPE_ONLY_CYCLE_EDGES): {stale}"


def test_the_layer_checks_find_a_cycle_and_an_upward_import(tmp_path: Path) -> None:
    root = tmp_path / "fsm"
    for folder, files in {"model": {"a.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                            "    from fsm.runtime.b import B\n"},
                          "runtime": {"b.py": "def f():\n    from ..model import a\n"}}.items():
        (root / folder).mkdir(parents=True)
        (root / folder / "__init__.py").write_text("")
        for name, text in files.items():
            (root / folder / name).write_text(text)
    (root / "__init__.py").write_text("import importlib\nimportlib.import_module('fsm.runtime.b')\n")
    graph = import_graph(root, ["model", "runtime", "fsm"])
    assert graph["fsm.model.a"] == {"fsm.runtime.b": True} and graph["fsm.runtime.b"] == {"fsm.model.a": False}
    assert graph["fsm"] == {"fsm.runtime.b": False}
    assert upward_imports(graph, ["model", "runtime", "fsm"]) == ["fsm.model.a -> fsm.runtime.b"]
    assert cycles(graph) == [["fsm.model.a", "fsm.runtime.b"]]
    assert layer_order("x\n**Layer order** (lowest first): `schema` → `model` → `fsm`\n") == ["schema", "model", "fsm"]


# -- the tools' layer order: the same import graph over fsm/tools ------------------------------------------------

TOOLS_DIR = CORE_DIR / "tools"


def tools_order(text: str) -> list[str]:
    """The packages of ``fsm/tools``, lowest first, from the ``**Tools order**`` line of docs/architecture.md."""
    import re

    found = re.search(r"^\*\*Tools order\*\*[^:\n]*:(.*)$", text, re.M)
    assert found, "docs/architecture.md has no **Tools order** line"
    return [re.sub(r"[`.\s]", "", part) for part in found.group(1).split("→")]


def tools_graph() -> dict[str, dict[str, bool]]:
    """module -> {imported module: type only} over the modules of fsm/tools (imports of the core left out)."""
    graph = import_graph(CORE_DIR, ["tools"])
    graph.pop("fsm")
    return {m: {t: only for t, only in edges.items() if t != "fsm"} for m, edges in graph.items()}


def tools_package(module: str) -> str:
    """``fsm.tools.cli.run`` -> ``cli``; ``fsm.tools.files`` -> ``files``; the package itself -> ``tools``."""
    parts = module.split(".")
    return parts[2] if len(parts) > 2 else "tools"


def test_the_tools_order_names_every_package() -> None:
    order = tools_order(CORE_LAYERS_DOC.read_text(encoding="utf-8"))
    found = {tools_package(m) for m in tools_graph()}
    assert sorted(found - set(order)) == [], "tools packages missing from the **Tools order** line"
    assert order.index("runs") < min(order.index(p) for p in ("cli", "live", "ros"))


def test_no_tools_module_imports_a_higher_package() -> None:
    """Every import counts (at the top, inside a function, under TYPE_CHECKING), as for the core."""
    order = tools_order(CORE_LAYERS_DOC.read_text(encoding="utf-8"))
    rank = {p: i for i, p in enumerate(order)}
    upward = sorted(f"{a} -> {b}" for a, edges in tools_graph().items() for b in edges
                    if rank[tools_package(b)] > rank[tools_package(a)])
    assert upward == []


def test_no_import_cycle_in_tools() -> None:
    graph = tools_graph()
    assert len(graph) > 80
    assert cycles(graph) == []
