"""The output folder of a sweep (``-o``): checked before any run, its ``sweep.jsonl`` read back and appended to.

A sweep writes only the files it names inside its folder, never through a symlink there (``sweep.html ->
../machine.json`` would replace the machine), never to a FIFO, device or hard-linked file, never to one of its
inputs (machine and includes, worlds, sweep file, plugin files). ``sweep.jsonl`` is read line by line, regular
files only: a last line without its end of line (a sweep killed while writing it) is cut off with a warning, so
the next record starts on a line of its own; other lines that are not records of a run are ignored with a warning
(their runs run again). Appends write whole lines; a write that fails is cut back, so the file ends on a line.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, GetCoreSchemaHandler, ValidationError
from pydantic_core import CoreSchema

from fsm.loading.reading import parse_json_bytes
from fsm.model.document import Source, problems_from_validation
from fsm.model.errors import DiagramError, FsmError, Problem, UsageError
from fsm.model.params import ParamsBase
from fsm.model.problems import Problems

from ..files import os_reason

#: What a sweep writes at the top of its folder, and in each run's folder runs/<id>/.
REPORTS = ("sweep.jsonl", "sweep.csv", "sweep.html")
RUN_FILES = ("summary.json", "trace.jsonl", "report.html", "plot.png", "video.mp4")
#: A line of sweep.jsonl longer than this is not a record (a run's record is about 10 KB); longer lines are
#: skipped without being held in memory.
MAX_LINE = 16 * 1024 * 1024
#: Coordinates of a trajectory point beyond this (metres) are not a car's.
MAX_COORDINATE = 1e6
#: A JSON escape of half a surrogate pair: the line may hold text that cannot be written as UTF-8.
_SURROGATE = re.compile(rb"\\[uU][dD][89a-fA-F]")
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def _reason(exc: OSError) -> str:
    return os_reason(exc)


class Folder:
    """The sweep's output folder ``out`` (named by ``option`` in messages) and the files the sweep reads
    (``inputs``), which no output may be."""

    def __init__(self, out: Path, inputs: Iterable[str], option: str = "-o") -> None:
        self.out = out
        self.option = option
        self.inputs: dict[tuple[int, int], str] = {}
        for name in inputs:
            try:
                st = os.stat(name)
            except (OSError, ValueError):
                continue
            self.inputs.setdefault((st.st_dev, st.st_ino), name)

    def _refuse(self, path: Path, reason: str, hint: str = "remove it or choose another output folder") -> UsageError:
        return UsageError(f"{self.option} {self.out}: {path} {reason}; {hint}")

    def _check(self, path: Path, folder: bool) -> bool:
        """Refuse ``path`` as something the sweep writes (a folder when ``folder``); ``True`` when it exists."""
        try:
            st = os.lstat(path)
        except FileNotFoundError:
            return False
        except (OSError, ValueError) as exc:
            reason = _reason(exc) if isinstance(exc, OSError) else "is not a usable file name"
            raise self._refuse(path, f"cannot be checked: {reason}") from None
        if stat.S_ISLNK(st.st_mode):
            try:
                target = os.readlink(path)
            except OSError:
                target = "?"
            raise self._refuse(path, f"is a symlink to {target}; a sweep never writes through a link in its "
                                     "output folder", "remove the link or choose another output folder")
        if folder:
            if not stat.S_ISDIR(st.st_mode):
                raise self._refuse(path, f"is {_kind(st.st_mode)}, not a folder")
            return True
        if not stat.S_ISREG(st.st_mode):
            raise self._refuse(path, f"is {_kind(st.st_mode)}; a sweep writes regular files there")
        same = self.inputs.get((st.st_dev, st.st_ino))
        if same is not None:
            raise self._refuse(path, f"is the same file as the input {same}", "choose another output folder")
        if st.st_nlink > 1:
            raise self._refuse(path, f"has {st.st_nlink} hard links; writing it would change the others too")
        return True

    def check(self) -> None:
        """The folder itself and sweep.jsonl, sweep.csv and sweep.html in it: before anything is read or run."""
        try:
            st = os.stat(self.out)
        except FileNotFoundError:
            return
        except (OSError, ValueError) as exc:
            reason = _reason(exc) if isinstance(exc, OSError) else "not a usable folder name"
            raise UsageError(f"{self.option} {self.out}: {reason}") from None
        if not stat.S_ISDIR(st.st_mode):
            raise UsageError(f"{self.option} {self.out}: not a folder")
        for name in REPORTS:
            self._check(self.out / name, folder=False)
        self._check(self.out / "runs", folder=True)

    def check_runs(self, ids: Iterable[str]) -> None:
        """runs/<id>/ and the files a run writes there, for each run about to run."""
        if not (self.out / "runs").is_dir():
            return
        for run_id in ids:
            folder = self.out / "runs" / run_id
            if self._check(folder, folder=True):
                for name in RUN_FILES:
                    self._check(folder / name, folder=False)

    def mkdir(self, path: Path) -> None:
        """Create ``path`` (and its parents) inside the sweep's folder, naming it if the system refuses."""
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise FsmError(f"{path}: cannot create the folder: {_reason(exc)}") from None


# -- reading sweep.jsonl back -----------------------------------------------------------------------------------
@dataclass
class Resume:
    """What an earlier sweep left: its good records by key, warnings to show, and where a cut-off last line
    starts (``None`` when the file ends on a line)."""

    records: dict[str, dict[str, Any]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    cut_at: int | None = None


def read_records(path: Path, keys: set[str] | None = None) -> Resume:
    """The finished runs recorded in ``path`` whose key is in ``keys`` (all when ``None``); a missing file is an
    empty one. Only a :class:`DiagramError` comes out (a FIFO, a folder, an unreadable file)."""
    resume = Resume()
    fh = _open_regular(path)
    if fh is None:
        return resume
    bad: list[tuple[str, str]] = []  # (line or line:column, why)
    with fh:
        offset = 0
        number = 0
        while line := _read_line(fh, path):
            number += 1
            start, offset = offset, offset + len(line)
            if len(line) > MAX_LINE and not line.endswith(b"\n"):
                offset += _skip_line(fh)
                bad.append((str(number), f"more than {MAX_LINE // 1048576} MiB without an end of line"))
                continue
            if not line.endswith(b"\n"):
                resume.cut_at = start
                resume.warnings.append(
                    f"{path}:{number}: warning: the last line has no end of line ({len(line)} bytes left by a sweep "
                    "that was stopped while writing it): removed; its run runs again")
                break
            wrong = _take(resume, line, path, keys)
            if wrong is not None:
                bad.append((f"{number}{wrong[0]}", wrong[1]))
    if bad:
        more = f", and {len(bad) - 1} more line{'s' * (len(bad) > 2)} like it" if len(bad) > 1 else ""
        resume.warnings.insert(0, f"{path}:{bad[0][0]}: warning: not the record of a finished run ({bad[0][1]}){more}: "
                                  "ignored; such a run runs again")
    return resume


def _read_line(fh: Any, path: Path) -> bytes:
    """The next line of sweep.jsonl, at most one byte over :data:`MAX_LINE` (``b""`` at the end)."""
    try:
        line: bytes = fh.readline(MAX_LINE + 1)
    except OSError as exc:
        raise DiagramError([Problem(f"cannot read: {_reason(exc)}", str(path))]) from None
    return line


def _take(resume: Resume, line: bytes, path: Path, keys: set[str] | None) -> tuple[str, str] | None:
    """A whole line into ``resume`` when it is the record of a finished run of this grid; a line that is no such
    record: where in the line (``""``, or ``:column``) and why."""
    rec, why, source = _record(line, path)
    if rec is None:
        return "", why
    if keys is not None and rec["key"] not in keys or not rec["ok"]:
        return None  # another grid's run, or a run that raised: it runs again
    problem = _reuse_problem(rec, line, source)
    if problem is not None:
        return (f":{problem.column}" if problem.column else ""), problem.message
    resume.records[rec["key"]] = rec
    return None


def jsonl_text(path: Path, records: list[dict[str, Any]]) -> bytes | None:
    """sweep.jsonl with the line of each flagged record (by key) replaced by the record with its ``flags``, and the
    ``flags`` of an earlier sweep's line updated; every other line stays byte for byte (a record without ``flags``
    has none). ``None`` when nothing changes."""
    by_key = {r["key"]: r for r in records}
    done: set[str] = set()
    lines = [raw for raw in _read_all(path).split(b"\n") if raw]
    out = [_flagged(raw, by_key, done) for raw in lines]
    extra = [json.dumps(r, separators=(",", ":")).encode("utf-8") for r in records
             if r["key"] not in done and r.get("flags")]
    if out == lines and not extra:
        return None
    return b"".join(line + b"\n" for line in out + extra)


def _flagged(raw: bytes, by_key: dict[str, dict[str, Any]], done: set[str]) -> bytes:
    """A line of sweep.jsonl, or (for the first line of a key in ``by_key`` only, noted in ``done``) that key's
    record when their ``flags`` differ."""
    rec = _line_record(raw)
    if rec is None or rec["key"] not in by_key or rec["key"] in done:
        return raw
    done.add(rec["key"])
    new = by_key[rec["key"]]
    if (new.get("flags") or []) == (rec.get("flags") or []):
        return raw
    return json.dumps(new, separators=(",", ":")).encode("utf-8")


def _read_all(path: Path) -> bytes:
    """The bytes of ``path`` (none when there is no such file), read by the rule of :func:`_open_regular`."""
    fh = _open_regular(path)
    if fh is None:
        return b""
    with fh:
        try:
            data: bytes = fh.read()
        except OSError as exc:
            raise DiagramError([Problem(f"cannot read: {_reason(exc)}", str(path))]) from None
    return data


def _line_record(raw: bytes) -> dict[str, Any] | None:
    """A line as a JSON object with a text ``key`` (when it is not too long to read), else ``None``."""
    if len(raw) > MAX_LINE:
        return None
    try:
        rec = json.loads(raw)
    except ValueError:
        return None
    return rec if isinstance(rec, dict) and isinstance(rec.get("key"), str) else None


def _open_regular(path: Path) -> Any:
    """``path`` opened for reading when it is a regular file; ``None`` when there is none; else a DiagramError.
    Checked before and after opening, without blocking: a FIFO never hangs the sweep."""
    name = str(path)
    try:
        st = os.lstat(path)
        if stat.S_ISLNK(st.st_mode):
            raise DiagramError([Problem(f"is a symlink to {os.readlink(path)}; a sweep's record file must be a "
                                        "regular file", name)])
        if not stat.S_ISREG(st.st_mode):
            raise DiagramError([Problem(f"is {_kind(st.st_mode)}; a sweep's record file must be a regular file",
                                        name)])
        fd = os.open(path, os.O_RDONLY | _NOFOLLOW | _NONBLOCK | _CLOEXEC)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise DiagramError([Problem(f"cannot read: {_reason(exc)}", name)]) from None
    except ValueError:
        raise DiagramError([Problem("not a usable file name", repr(name))]) from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise DiagramError([Problem("not a regular file; a sweep's record file must be one", name)])
    return os.fdopen(fd, "rb")


def _skip_line(fh: Any) -> int:
    """Read past the rest of an overlong line, a chunk at a time; how many bytes that was."""
    skipped = 0
    while True:
        chunk = fh.readline(MAX_LINE)
        skipped += len(chunk)
        if not chunk or chunk.endswith(b"\n"):
            return skipped


def _record(line: bytes, path: Path) -> tuple[dict[str, Any] | None, str, Source | None]:
    """One line as a record with a text ``key`` and ``id`` and a boolean ``ok`` and its source (to locate its
    problems in), or ``None`` and why not."""
    if not line.strip():
        return None, "an empty line", None
    try:
        rec, source = parse_json_bytes(line, str(path))
    except DiagramError as exc:
        return None, " ".join(exc.problems[0].message.split())[:200] if exc.problems else "not JSON", None
    if not isinstance(rec, dict):
        return None, f"a JSON {type(rec).__name__}, not an object", None
    for name, kind in (("key", str), ("id", str), ("ok", bool)):
        if not isinstance(rec.get(name), kind):
            return None, f"no {kind.__name__} '{name}'", None
    return rec, "", source


def _reuse_problem(rec: dict[str, Any], line: bytes, source: Source | None) -> Problem | None:
    """Why a finished run's record (read from ``line``) cannot be reused: its shape, or text that is not Unicode."""
    problem = record_problem(rec, source)
    if problem is None and _SURROGATE.search(line) and not _unicode(rec):
        problem = Problem("text that is not Unicode (a lone surrogate)")
    return problem


def _number(value: Any, bound: float | None = MAX_COORDINATE) -> bool:
    """A JSON number that is a float (NaN and infinity too when ``bound`` is ``None``), else at most ``bound``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        number = float(value)
    except OverflowError:
        return False
    return bound is None or (math.isfinite(number) and abs(number) <= bound)


def _checked(test: Callable[[Any], bool], words: str) -> AfterValidator:
    """A field validator that refuses a value ``test`` rejects, in ``words``."""
    def check(value: Any) -> Any:
        if not test(value):
            raise ValueError(words)
        return value
    return AfterValidator(check)


def _point(p: list[Any]) -> bool:
    return len(p) >= 2 and _number(p[0]) and _number(p[1])


def _rms(value: Any) -> bool:
    return value is None or isinstance(value, float) or _number(value, 1e300)


class _Record(ParamsBase):
    """What sweep.csv and sweep.html read from a finished run's record; the record's other keys (``key``, ``id``,
    ``ok``, ``flags``, ...) are its own. Strict: a bool is no number, null no list."""

    model_config = ConfigDict(extra="allow", allow_inf_nan=True, frozen=False)

    @classmethod
    def __get_pydantic_core_schema__(cls, source: type[BaseModel], handler: GetCoreSchemaHandler) -> CoreSchema:
        """A record is no machine document: ``world`` is null for a run without a world."""
        return handler(source)


class RunSummary(_Record):
    wall_error_rms_m: Annotated[Any, _checked(_rms, "not a number")] = None


class FinishedRun(_Record):
    index: int
    seed: int
    run_seed: int
    params: dict[str, Any]
    command: str
    summary: RunSummary
    world: str | None = None
    states: list[Any] = []
    track: list[Annotated[list[Any], _checked(_point, f"not a point (x, y within {MAX_COORDINATE:g} m)")]] = []
    dwell: dict[str, Annotated[Any, _checked(lambda v: _number(v, 1e12), "not seconds")]] = {}
    files: list[str] = []
    seconds: int | float = 0
    error: str = ""
    traceback: str = ""


def record_problem(rec: dict[str, Any], source: Source | None = None) -> Problem | None:
    """Why a finished run's record cannot be reused in the reports (a wrong type, a trajectory that is not points),
    by the located-problems path machine documents take: the first problem, at its place in ``source`` (the
    record's line), or ``None``."""
    try:
        FinishedRun.model_validate(rec)
    except ValidationError as err:
        found = Problems()
        found.extend(problems_from_validation(err, source=source or Source(name=""), base="", element=None,
                                              model=FinishedRun, kind="field", data=rec), source)
        return found.located()[0]
    return None


def _unicode(rec: dict[str, Any]) -> bool:
    """No lone surrogate (``"\\ud800"`` in the JSON) in the record: sweep.csv and sweep.html are UTF-8."""
    try:
        json.dumps(rec, ensure_ascii=False).encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


# -- appending to sweep.jsonl ------------------------------------------------------------------------------------
class RecordLog:
    """sweep.jsonl opened for appending whole lines (never through a symlink, never a FIFO); ``cut_at`` removes a
    cut-off last line first. A write that fails is cut back to the last whole line and raises an
    :class:`FsmError` naming the file."""

    def __init__(self, path: Path, cut_at: int | None = None) -> None:
        self.path = path
        flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | _NOFOLLOW | _NONBLOCK | _CLOEXEC
        try:
            self.fd = os.open(path, flags, 0o666)
        except OSError as exc:
            raise FsmError(f"{path}: cannot open for writing: {_reason(exc)}") from None
        try:
            st = os.fstat(self.fd)
            if not stat.S_ISREG(st.st_mode):
                raise UsageError(f"{path}: is {_kind(st.st_mode)}; a sweep writes its records to a regular file")
            if cut_at is not None and cut_at < st.st_size:
                os.ftruncate(self.fd, cut_at)
            self.size = os.fstat(self.fd).st_size
        except OSError as exc:
            self.close()
            raise FsmError(f"{path}: cannot write: {_reason(exc)}") from None
        except BaseException:
            self.close()
            raise

    def append(self, line: str) -> None:
        """Write one record (``line`` ends with a newline) in full, or nothing."""
        encoded = line.encode("utf-8")
        data = memoryview(encoded)
        try:
            while data:
                data = data[os.write(self.fd, data):]
        except OSError as exc:
            try:
                os.ftruncate(self.fd, self.size)
            except OSError:
                pass
            raise FsmError(f"{self.path}: cannot write: {_reason(exc)}") from None
        self.size += len(encoded)

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def __enter__(self) -> RecordLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class OutFile:
    """A file of the sweep's folder opened for writing (``mode`` ``"w"``, ``"w+"``, ``"wb"``), never through a
    symlink and never a FIFO or device; a failing write (a full disk) raises an :class:`FsmError` naming it."""

    def __init__(self, path: Path, mode: str = "w") -> None:
        self.path = path
        access = os.O_RDWR if "+" in mode else os.O_WRONLY
        try:
            fd = os.open(path, access | os.O_CREAT | os.O_TRUNC | _NOFOLLOW | _NONBLOCK | _CLOEXEC, 0o666)
        except OSError as exc:
            raise self._failed(exc) from None
        kind = os.fstat(fd).st_mode
        if not stat.S_ISREG(kind):
            os.close(fd)
            raise FsmError(f"{path}: is {_kind(kind)}; a sweep writes regular files in its folder")
        os.set_blocking(fd, True)
        # the descriptor is open: no second truncation
        self.raw: IO[Any] = os.fdopen(fd, mode) if "b" in mode else os.fdopen(fd, mode, encoding="utf-8", newline="\n")

    def _failed(self, exc: OSError) -> FsmError:
        return FsmError(f"{self.path}: cannot write: {_reason(exc)}")

    def write(self, data: Any) -> int:
        try:
            return self.raw.write(data)
        except OSError as exc:
            raise self._failed(exc) from None

    def flush(self) -> None:
        try:
            self.raw.flush()
        except OSError as exc:
            raise self._failed(exc) from None

    def seek(self, offset: int) -> int:
        return self.raw.seek(offset)

    def read(self) -> Any:
        return self.raw.read()

    def close(self) -> None:
        try:
            self.raw.close()
        except OSError as exc:
            raise self._failed(exc) from None

    def __enter__(self) -> OutFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def write_file(path: Path, data: str | bytes) -> None:
    """``data`` into ``path`` of the sweep's folder, by the rules of :class:`OutFile`."""
    with OutFile(path, "wb" if isinstance(data, bytes) else "w") as fh:
        fh.write(data)
