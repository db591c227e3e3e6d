"""What a composite box shows in a drawing: its inline machine, its included file, or its parallel regions.

Included files are read relative to the including file, each drawn once; cycles and missing files become
notes in the box instead of errors, so a drawing is made even of a broken machine.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from fsm.loading.reading import reader_for
from fsm.model.document import normalize_legacy
from fsm.model.errors import DiagramError

from .labels import BOX_MARGIN, LABEL_FONT, text_width
from .layout import Expansion, region_name, sequence_machine

MAX_INCLUDE_DEPTH = 16
def parallel_note(st: dict[str, Any]) -> str:
    join = st.get("join")
    return "(Parallel" + (f", join={join}" if isinstance(join, str) else "") + ")"


def sequence_note(st: dict[str, Any]) -> str:
    keys = []
    if isinstance(st.get("repeat"), int) and st["repeat"] != 1:
        keys.append(f"repeat={st['repeat']}")
    if st.get("blocking") is False:
        keys.append("non-blocking")
    if st.get("pause_signal"):
        keys.append(f"pause={st['pause_signal']}")
    return "(Sequence" + (", " + ", ".join(keys) if keys else "") + ")"


def expander(directory: Path | None, where: str = "", stack: tuple[Path, ...] = (),
             seen: dict[Path, Any] | None = None) -> Callable[[dict[str, Any]], Expansion | None]:
    """What a composite shows: inline machines, ``{"file": ...}`` includes (read relative to ``directory``, the
    including file's folder) and the regions of a ``Parallel`` state.

    An included file is drawn where it is first included (in document order); a later include of the same file
    is a box naming the file and that first place, so a machine reused many times is drawn once.
    """
    return _Expander(directory, where, stack, {} if seen is None else seen).expand


Part = tuple[dict[str, Any] | None, Any, str | None, bool]


class _Expander:
    """:func:`expander`'s hook and what it shares with the hooks of the machines it opens: ``seen`` maps a file to
    (its document and folder, or what is wrong with it; where it is drawn)."""

    def __init__(self, directory: Path | None, where: str, stack: tuple[Path, ...], seen: dict[Path, Any]) -> None:
        self.directory, self.where, self.stack, self.seen = directory, where, stack, seen

    def expand(self, st: dict[str, Any]) -> Expansion | None:
        """What state ``st`` shows: by its type, when the key that type opens holds what it must (see ``_OPENS``)."""
        opens = _OPENS.get(st.get("type"))
        if opens is None or not isinstance(st.get(opens[0]), opens[1]):
            return None
        return opens[2](self, st, f"{self.where}/{st.get('id')}" if self.where else str(st.get("id")))

    def sequence(self, st: dict[str, Any], here: str) -> Expansion:
        """A ``Sequence`` as the machine its steps make, its keys in the note."""
        return Expansion([(None, sequence_machine(st), expander(self.directory, here, self.stack, self.seen))],
                         sequence_note(st))

    def machine(self, st: dict[str, Any], here: str) -> Expansion | None:
        """An ``FSMState``'s inline machine, or its included file (named in the note, or what is wrong with it)."""
        machine, hook, note, error = self.part(st["machine"], here)
        if "file" not in st["machine"]:
            return Expansion([(None, machine, hook)]) if machine is not None else None
        return Expansion([(None, machine, hook)] if machine is not None else [], note, foreign=True, error=error)

    def regions(self, st: dict[str, Any], here: str) -> Expansion | None:
        """A ``Parallel`` state's regions, one compartment each, named by their machine (and what went wrong)."""
        names: list[str] = []
        parts: list[tuple[str | None, dict[str, Any], Any]] = []
        for i, ref in enumerate(st["regions"]):
            machine, hook, note, error = self.part(ref, f"{here}/{region_name(ref, i)}")
            names.append(region_name(machine, i) + ("" if not note else f" — {note}" if error else f" ({note})"))
            parts.append((names[-1], machine if machine is not None else {"states": []}, hook))
        widths = [text_width(name, LABEL_FONT) + 2 * BOX_MARGIN + 4 for name in names]
        return Expansion(parts, parallel_note(st), foreign=True, min_widths=widths) if parts else None

    def part(self, ref: Any, here: str) -> Part:
        """(machine, expand hook for its states, note, whether the note is an error) of a region or sub-machine."""
        if not isinstance(ref, dict):
            return None, None, None, False
        if "file" in ref:
            return self.resolve(ref, here)
        if isinstance(ref.get("states"), list):
            return ref, expander(self.directory, here, self.stack, self.seen), None, False
        return None, None, None, False

    def resolve(self, ref: dict[str, Any], here: str) -> Part:
        file = str(ref.get("file"))
        if self.directory is None:
            return None, None, f"{file} (not opened)", False
        path = (self.directory / file).resolve()
        if path in self.stack:
            return None, None, f"{file}: include cycle", True
        if len(self.stack) >= MAX_INCLUDE_DEPTH:
            return None, None, f"{file}: nested too deep", True
        fresh = path not in self.seen
        if fresh:
            self.seen[path] = (read_include(path), here)
        got, first = self.seen[path]
        if isinstance(got, str):
            return None, None, f"{file}: {got}", True
        if not fresh:
            return None, None, f"{file}, drawn in {first}", False
        data, folder = got
        return data, expander(folder, here, self.stack + (path,), self.seen), file, False


#: What each composite type opens: the key it needs, of which type, and the ``_Expander`` method that opens it.
_OPENS: dict[Any, tuple[str, type, Callable[[_Expander, dict[str, Any], str], Expansion | None]]] = {
    "Parallel": ("regions", list, _Expander.regions),
    "Sequence": ("steps", list, _Expander.sequence),
    "FSMState": ("machine", dict, _Expander.machine),
}


def read_include(path: Path) -> tuple[dict[str, Any], Path] | str:
    """An included machine document and its folder, or what is wrong with it."""
    try:
        data, source = reader_for(path)(path)
    except DiagramError as exc:
        first = exc.problems[0].message if exc.problems else "cannot be read"
        return "not found" if first == "file not found" else first
    except (OSError, ValueError) as exc:
        return f"cannot be read ({exc})"
    if not isinstance(data, dict) or not isinstance(data.get("states"), list):
        return "not a machine document"
    data = normalize_legacy(data)[0]
    folder = getattr(source, "directory", None)
    return data, Path(folder) if folder is not None else path.parent
