"""The machine document a trace's header carries: as the user drew it (a ``.uxf`` converted, with its layout),
every ``{"file": ...}`` include replaced by the included document, so a report draws the whole machine from the
trace alone."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

from fsm.loading.reading import preloaded, reader_for
from fsm.model.document import normalize_legacy
from fsm.model.errors import DiagramError

from ..graph.includes import read_include

#: Includes nested deeper than this stay references (the loader refused such a machine anyway).
MAX_DEPTH = 16


def header_document(file: str, preloaded_files: dict[str, Any] | None = None) -> dict[str, Any] | None:
    """The document of ``file`` (``<stdin>`` when preloaded) with its includes inlined; ``None`` if it cannot be
    read again (the run still writes its trace, without a drawing)."""
    try:
        with preloaded(preloaded_files or {}):
            data, source = reader_for(Path(file))(Path(file))
    except (DiagramError, OSError, ValueError):
        return None
    if not isinstance(data, dict):
        return None
    data = copy.deepcopy(normalize_legacy(data)[0])
    folder = getattr(source, "directory", None)
    return inline_includes(data, Path(folder) if folder is not None else Path(file).parent)


def inline_includes(doc: dict[str, Any], folder: Path, stack: tuple[Path, ...] = ()) -> dict[str, Any]:
    """``doc`` with each include (an ``FSMState``'s ``machine`` or a ``Parallel`` region given as ``{"file": ...}``)
    replaced by the included document, recursively; one that cannot be read (or a cycle) stays a reference."""

    def resolve(ref: Any) -> Any:
        if not (isinstance(ref, dict) and isinstance(ref.get("file"), str)):
            return inline_includes(ref, folder, stack) if isinstance(ref, dict) else ref
        path = (folder / ref["file"]).resolve()
        if path in stack or len(stack) >= MAX_DEPTH:
            return ref
        got = read_include(path)
        if isinstance(got, str):
            return ref
        data, sub_folder = got
        out = inline_includes(copy.deepcopy(data), sub_folder, stack + (path,))
        if isinstance(ref.get("name"), str) and "name" not in out:
            out["name"] = ref["name"]
        return out

    for st in doc.get("states", []) if isinstance(doc.get("states"), list) else []:
        if not isinstance(st, dict):
            continue
        if isinstance(st.get("machine"), dict):
            st["machine"] = resolve(st["machine"])
        if isinstance(st.get("regions"), list):
            st["regions"] = [resolve(r) for r in st["regions"]]
    return doc
