"""Writing the files users name, safe for whatever path they give; every command and output option uses it.

- ``-`` is standard output; ``/dev/stdout``, ``/dev/stderr``, ``/dev/fd/N`` and ``/proc/self/fd/N`` write to
  that descriptor; a device node or FIFO is opened and written directly, never renamed over.
- A regular file (or a new one) is written to a unique temporary file in the same folder, fsynced and renamed
  over the target, keeping the old file's mode (and owner, as root). A symlink is followed: its target is
  replaced, the link stays. A file with several hard links is refused (replacing it would split the links,
  writing it in place could leave it half-written).
- Every check happens in :meth:`Output.open`, before a command does its work: a directory, a missing or
  unwritable folder, an output that is the same file as an input, two outputs naming one file.
- An output that is a whole new folder (``--bag``): :func:`check_new_folder` refuses anything already there
  (folder, file, symlink), an input, a missing or unwritable parent, a name another output took.
"""

from __future__ import annotations

import atexit
import errno
import os
import pathlib
import re
import shutil
import signal
import stat
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable
from typing import IO, Any

from fsm.model.errors import FsmError, UsageError

STDOUT = "-"
_FD_PATH = re.compile(r"^/(?:dev/fd|proc/self/fd)/(\d+)$")
_NAMED_FDS = {"/dev/stdout": 1, "/dev/stderr": 2}


def _descriptor(name: str) -> int | None:
    """The file descriptor an output name stands for (``-``, ``/dev/stdout``, ``/dev/fd/N``), or ``None``."""
    if name == STDOUT:
        return 1
    if name in _NAMED_FDS:
        return _NAMED_FDS[name]
    match = _FD_PATH.match(name)
    return int(match.group(1)) if match else None


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _kind_of(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "a regular file"


def os_reason(exc: OSError) -> str:
    """A short, user-facing reason for an OSError (no errno numbers, no repr)."""
    if exc.errno == errno.ENAMETOOLONG:
        return "the file name is too long"
    if exc.errno == errno.ELOOP:
        return "too many levels of symbolic links (a symlink loop)"
    if exc.errno == errno.EROFS:
        return "the file system is read-only"
    return (exc.strerror or str(exc)).rstrip(".")


def shown_path(path: str | os.PathLike[str]) -> str:
    """A file the program found itself (a default world, an include), named as the user would: relative to the
    current folder when it is under it, else as it is."""
    try:
        return str(pathlib.Path(path).resolve().relative_to(pathlib.Path.cwd().resolve()))
    except (ValueError, OSError):
        return str(path)


def identity(path: str) -> tuple[int, int] | None:
    """``(st_dev, st_ino)`` of the file ``path`` names (through symlinks), or ``None`` if there is none."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return st.st_dev, st.st_ino


class Output:
    """One output a user named (``name``) for an option (``option``, for messages).

    ``open`` checks it and prepares it (creates the temporary file), ``stream``/``scratch`` give what to write
    to, ``commit`` puts the result in place and ``discard`` throws it away, leaving the user's file untouched.
    """

    def __init__(self, name: str, option: str, *, binary: bool = False, suffix: str = "") -> None:
        self.name = name
        self.option = option
        self.binary = binary
        self.suffix = suffix  # of the temporary file (encoders that pick the container by suffix)
        self.kind = ""  # "fd" (standard output, /dev/fd/N), "special" (device, FIFO), "file"
        self.target = name
        self.fd = -1  #: the descriptor of a "fd" output (none: -1)
        self.mode: int | None = None
        self.owner: tuple[int, int] | None = None
        self._tmp: str | None = None
        self._fh: Stream | None = None

    # -- checks -------------------------------------------------------------------------------------
    def _fail(self, reason: str, hint: str | None = None) -> UsageError:
        shown = "-" if self.name == STDOUT else self.name
        return UsageError(f"{self.option} {shown}: {reason}" + (f"; {hint}" if hint else ""))

    def classify(self) -> None:
        """Decide how the output is written; raise :class:`UsageError` for a path that cannot be an output."""
        fd = _descriptor(self.name)
        if fd is not None:
            self._classify_descriptor(fd)
            return
        st = self._stat_target()
        if st is not None and not stat.S_ISREG(st.st_mode):
            self._classify_special(st)
            return
        self._classify_file(st)

    def _classify_descriptor(self, fd: int) -> None:
        """``-``, ``/dev/stdout``, ``/dev/fd/N``: an open descriptor, written in place."""
        self.kind = "fd"
        self.fd = fd
        if self.binary and fd == 1 and _stdout_is_terminal():
            raise self._fail("will not write binary data to a terminal", "redirect standard output or name a file")
        try:
            os.fstat(fd)
        except OSError:
            raise self._fail(f"file descriptor {fd} is not open") from None

    def _stat_target(self) -> os.stat_result | None:
        """Resolve the name into :attr:`target`; its status, or ``None`` when nothing is there yet."""
        name = self.name
        if not name:
            raise self._fail("empty file name")
        if "\0" in name:
            raise self._fail("the file name contains a NUL byte")
        try:
            self.target = os.path.realpath(name)
            return os.stat(self.target)
        except FileNotFoundError:
            return None
        except ValueError:
            raise self._fail("not a usable file name") from None
        except OSError as exc:
            if exc.errno == errno.ENOTDIR:
                raise self._fail("a folder on the path is not a folder") from None
            raise self._fail(os_reason(exc)) from None

    def _classify_special(self, st: os.stat_result) -> None:
        """A device or FIFO is written in place; a folder or socket is no output."""
        if stat.S_ISDIR(st.st_mode):
            raise self._fail("is a directory", "name a file in it")
        if stat.S_ISSOCK(st.st_mode):
            raise self._fail("is a socket")
        self.kind = "special"

    def _classify_file(self, st: os.stat_result | None) -> None:
        """A regular file (or none yet): replaced atomically, keeping its mode and owner."""
        self.kind = "file"
        if st is not None:
            if st.st_nlink > 1:
                raise self._fail(f"has {st.st_nlink} hard links; replacing it would split them and writing it in "
                                 "place is not atomic", "remove the other links or write to another name")
            self.mode = stat.S_IMODE(st.st_mode)
            self.owner = (st.st_uid, st.st_gid)
        folder = os.path.dirname(self.target) or "."
        if not os.path.isdir(folder):
            raise self._fail(f"folder {os.path.dirname(self.name) or folder} does not exist", "create it first")

    # -- life cycle ---------------------------------------------------------------------------------
    def open(self) -> Output:
        """Check and prepare: after this the output can be written and committed without a usage error."""
        self.classify()
        if self.kind == "file":
            folder = os.path.dirname(self.target) or "."
            base = os.path.basename(self.target)
            try:
                fd, self._tmp = tempfile.mkstemp(prefix=f".{base[:80]}.", suffix=f".part{self.suffix}", dir=folder)
            except OSError as exc:
                raise self._fail(f"cannot create a file in {folder}: {os_reason(exc)}",
                                 "choose a folder you can write to") from None
            os.close(fd)
            track_temporary(self._tmp)
            try:
                os.chmod(self._tmp, self.mode if self.mode is not None else 0o666 & ~_umask())
            except OSError:
                pass
        elif self.binary:
            fd, self._tmp = tempfile.mkstemp(prefix="fsmctl-", suffix=f".part{self.suffix}")
            os.close(fd)
            track_temporary(self._tmp)
        return self

    @property
    def path(self) -> str:
        """Where an encoder writes (a temporary file that :meth:`commit` puts in place)."""
        if self._tmp is None:
            raise RuntimeError("open() an output before writing, and binary outputs through path")
        return self._tmp

    def stream(self) -> Stream:
        """A file object to write to (text: UTF-8 with ``\\n`` lines)."""
        if self._fh is None:
            self._fh = Stream(self._open_stream(), self)
        return self._fh

    def _open_stream(self) -> IO[Any]:
        if self._tmp is not None:
            return self._open(self._tmp)
        if self.kind == "fd":
            return self._std_stream() or self._open(os.dup(self.fd))
        try:
            return self._open(self.target)
        except OSError as exc:
            raise self._fail(f"cannot write: {os_reason(exc)}") from None

    def _open(self, file: str | int) -> IO[Any]:
        """``file`` (a path or a descriptor) opened for writing: bytes, or UTF-8 text with ``\\n`` lines."""
        if self.binary:
            return open(file, "wb")
        return open(file, "w", encoding="utf-8", newline="\n")

    def write(self, data: str | bytes) -> None:
        self.stream().write(data)

    def _write_failed(self, exc: OSError) -> FsmError:
        shown = "-" if self.name == STDOUT else self.name
        return FsmError(f"{self.option} {shown}: cannot write: {os_reason(exc)}")

    def commit(self) -> None:
        """Put the written output in place: rename the temporary file, or copy a scratch file to the device."""
        try:
            self._commit()
        except OSError as exc:
            raise self._write_failed(exc) from None

    def _commit(self) -> None:
        fh = self._fh.raw if self._fh is not None else None
        self._fh = None
        if fh is not None:
            self._finish_stream(fh)
        tmp, self._tmp = self._tmp, None
        if tmp is not None and self.kind == "file":
            self._replace_target(tmp, synced=fh is not None)
        elif tmp is not None:
            self._copy_out(tmp)

    def _finish_stream(self, fh: Any) -> None:
        """The stream written through: flushed (to the disk, for a file) and closed (standard output stays open)."""
        fh.flush()
        if self.kind == "file":
            os.fsync(fh.fileno())
        if fh is not self._std_stream():
            fh.close()

    def _replace_target(self, tmp: str, synced: bool) -> None:
        """The finished temporary file put in the target's place (with the target's owner when root writes it),
        then the folder synced."""
        if self.owner is not None and os.geteuid() == 0:
            try:
                os.chown(tmp, *self.owner)
            except OSError:
                pass
        if not synced:  # an encoder wrote it
            with open(tmp, "rb") as f:
                os.fsync(f.fileno())
        os.replace(tmp, self.target)
        _TEMPORARY.discard(tmp)
        _fsync_folder(os.path.dirname(self.target) or ".")

    def _copy_out(self, tmp: str) -> None:
        """A binary output to standard output or a device: written from the scratch file, which then goes."""
        try:
            with open(tmp, "rb") as src:
                if self.kind == "fd":
                    std = self._std_stream()
                    if std is not None:
                        shutil.copyfileobj(src, std)
                        std.flush()
                    else:
                        with open(os.dup(self.fd), "wb") as dst:
                            shutil.copyfileobj(src, dst)
                else:
                    with open(self.target, "wb") as dst:
                        shutil.copyfileobj(src, dst)
        finally:
            os.unlink(tmp)
            _TEMPORARY.discard(tmp)

    def discard(self) -> None:
        """Throw away what was written; the user's file stays as it was."""
        fh = self._fh.raw if self._fh is not None else None
        self._fh = None
        if fh is not None and fh is not self._std_stream():
            try:
                fh.close()
            except OSError:
                pass
        tmp, self._tmp = self._tmp, None
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            _TEMPORARY.discard(tmp)

    @property
    def to_stdout(self) -> bool:
        return self.kind == "fd" and self.fd == 1

    def _std_stream(self) -> IO[Any] | None:
        """Python's own ``sys.stdout``/``sys.stderr`` (binary: their buffer) for descriptors 1 and 2, so that
        output stays in order with what else is printed (and redirections of ``sys.stdout`` are honoured)."""
        if self.kind != "fd" or self.fd not in (1, 2):
            return None
        stream = sys.stdout if self.fd == 1 else sys.stderr
        if stream is None:
            return None
        return getattr(stream, "buffer", None) if self.binary else stream


class Stream:
    """A stream whose write errors (a full disk, /dev/full, a closed pipe) name the output, in one line."""

    __slots__ = ("raw", "_output")

    def __init__(self, raw: IO[Any], output: Output) -> None:
        self.raw = raw
        self._output = output

    def write(self, data: Any) -> int:
        try:
            return self.raw.write(data)
        except OSError as exc:
            raise self._output._write_failed(exc) from None

    def flush(self) -> None:
        try:
            self.raw.flush()
        except OSError as exc:
            raise self._output._write_failed(exc) from None

    def fileno(self) -> int:
        return self.raw.fileno()


def _stdout_is_terminal() -> bool:
    try:
        return bool(sys.stdout is not None and sys.stdout.isatty())
    except (OSError, ValueError, AttributeError):
        return False


def _fsync_folder(folder: str) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


class Outputs:
    """The outputs of one command: checked together (against each other and the inputs), committed together."""

    def __init__(self) -> None:
        self.items: list[Output] = []

    def add(self, name: str | None, option: str, *, binary: bool = False, suffix: str = "") -> Output | None:
        if name is None:
            return None
        out = Output(name, option, binary=binary, suffix=suffix)
        self.items.append(out)
        return out

    def open(self, inputs: Iterable[str | os.PathLike[str]] = ()) -> None:
        """Check every output (raising :class:`UsageError`), then prepare them; nothing is left behind on error."""
        self.check(inputs)
        try:
            for out in self.items:
                out.open()
        except BaseException:
            self.discard()
            raise

    def check(self, inputs: Iterable[str | os.PathLike[str]] = ()) -> None:
        """What each output is (a folder, a missing folder: a :class:`UsageError`), and none the same file as
        another or as one of ``inputs``; nothing is opened yet."""
        for out in self.items:
            out.classify()
        check_distinct(self.items, inputs)

    @property
    def to_stdout(self) -> bool:
        return any(o.to_stdout for o in self.items)

    def commit(self) -> None:
        try:
            for out in self.items:
                out.commit()
        finally:
            self.discard()

    def discard(self) -> None:
        for out in self.items:
            out.discard()


def check_distinct(outputs: list[Output], inputs: Iterable[str | os.PathLike[str]]) -> None:
    """Refuse an output that is the same file as an input, and two outputs that name the same file."""
    seen_inputs = _input_identities(inputs)
    taken: dict[object, Output] = {}
    for out in outputs:
        if out.kind == "special":
            continue  # /dev/null twice, or as an "input", is harmless
        if out.kind == "fd":
            key: object = ("fd", out.fd)
        else:
            ident = identity(out.target)
            if ident is not None and ident in seen_inputs:
                raise out._fail(f"is the same file as the input {seen_inputs[ident]}",
                                "write the output to another file")
            key = ident if ident is not None else out.target
        if key in taken:
            other = taken[key]
            if out.kind == "fd" and out.fd == 1 and other.option != out.option:
                raise out._fail(f"standard output is already taken by {other.option}", "write one of them to a file")
            raise out._fail(f"names the same file as {other.option}", "give each output its own file")
        taken[key] = out


def _input_identities(inputs: Iterable[str | os.PathLike[str]]) -> dict[tuple[int, int], str]:
    """The identity of each input file that exists (standard input left out), with the first name given for it."""
    seen: dict[tuple[int, int], str] = {}
    for given in inputs:
        p = os.fspath(given)
        ident = identity(p) if p != STDOUT else None
        if ident is not None:
            seen.setdefault(ident, p)
    return seen


def check_new_folder(name: str, option: str, inputs: Iterable[str | os.PathLike[str]] = (),
                     outputs: Iterable[Output] = ()) -> str:
    """Check ``name`` as an output that is a whole new folder (a rosbag2 bag): it must not exist yet (not as a
    folder, a file, a symlink, even a dangling one, nor as one of the ``inputs``), its folder must exist and be
    writable, and no other output (already classified) may name it. :class:`UsageError` saying which, before
    anything is written; returns the absolute path. The writer builds the folder under a scratch name beside it
    and renames it into place when done (never over something that appeared meanwhile)."""
    def fail(reason: str, hint: str | None = None) -> UsageError:
        return UsageError(f"{option} {name}: {reason}" + (f"; {hint}" if hint else ""))

    if name in ("", STDOUT):
        raise fail("a folder is needed here (not standard output)", f"name a new folder, e.g. {option} runs/lap1")
    if "\0" in name:
        raise fail("the folder name contains a NUL byte")
    path = os.path.abspath(name)
    ident = identity(path)
    inputs_by_identity = _input_identities(inputs) if ident is not None else {}
    if ident in inputs_by_identity:
        raise fail(f"is the input {inputs_by_identity[ident]}", "name a new folder for the output")
    _refuse_existing(path, fail)
    parent = os.path.dirname(path)
    if not os.path.isdir(parent):
        raise fail(f"the folder {os.path.dirname(name) or parent} does not exist", "create it first")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise fail(f"the folder {os.path.dirname(name) or parent} cannot be written", "choose another folder")
    real = os.path.join(os.path.realpath(parent), os.path.basename(path))
    for out in outputs:
        if out.kind == "file" and os.path.realpath(out.target) == real:
            raise fail(f"names the same file as {out.option}", "give each output its own name")
    return path


def _refuse_existing(path: str, fail: Callable[..., UsageError]) -> None:
    """Refuse a new folder's ``path`` when something is there (a folder, a file, a link, even a dangling one)."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as exc:
        if exc.errno == errno.ENOTDIR:
            raise fail("a folder on the path is not a folder") from None
        raise fail(os_reason(exc)) from None
    if stat.S_ISLNK(st.st_mode):
        raise fail("is a symbolic link", "name a new folder; the output is never written through a link")
    what = "an existing folder" if stat.S_ISDIR(st.st_mode) else f"an existing {_kind_of(st.st_mode)[2:]}"
    raise fail(f"is {what}", "the output is a new folder: remove it or name another")


def write_output(name: str, data: str | bytes, option: str = "-o",
                 inputs: Iterable[str | os.PathLike[str]] = ()) -> None:
    """Write ``data`` to the output ``name`` by the rules above (checks first, then a whole file or nothing)."""
    outputs = Outputs()
    outputs.add(name, option, binary=isinstance(data, bytes))
    outputs.open(inputs)
    try:
        outputs.items[0].write(data)
        outputs.commit()
    finally:
        outputs.discard()


def write_atomic(path: str | os.PathLike[str], data: str | bytes) -> None:
    """Write ``data`` to ``path`` so that readers see the old file or the whole new one, never a half."""
    write_output(os.fspath(path), data, option="output")


# -- temporary files when the process is stopped -----------------------------------------------------
#: The temporary files of this process's open outputs, removed should a signal end it (they would stay behind).
_TEMPORARY: set[str] = set()
#: The process they belong to (a forked child must not remove its parent's files).
_OWNER = [os.getpid()]
_AT_EXIT: list[Any] = []  # not empty once remove_temporary_files runs at exit
#: Signals whose default action ends the process at once; SIGINT raises KeyboardInterrupt unless a program has
#: set it back to the default, and the outputs are then discarded as after any error.
_FATAL_SIGNALS = ("SIGTERM", "SIGINT", "SIGHUP")


def track_temporary(path: str) -> None:
    """Remember a temporary output file until it is committed or discarded; while any is open, a signal that
    would end the process at once (SIGTERM, SIGHUP; SIGINT where nothing handles it) first removes them.
    A handler a command installed itself (``fsmctl run`` stops between ticks) is left alone."""
    if _OWNER[0] != os.getpid():
        _TEMPORARY.clear()
        _OWNER[0] = os.getpid()
    if not _AT_EXIT:
        _AT_EXIT.append(atexit.register(remove_temporary_files))
    _TEMPORARY.add(path)
    if threading.current_thread() is threading.main_thread():
        for name in _FATAL_SIGNALS:
            num = getattr(signal, name, None)
            if num is not None and signal.getsignal(num) == signal.SIG_DFL:
                signal.signal(num, _end_by_signal)


def remove_temporary_files() -> None:
    """Remove the temporary files of outputs still open in this process (called on a fatal signal and at exit)."""
    if _OWNER[0] != os.getpid():
        return
    for path in list(_TEMPORARY):
        try:
            if os.path.isdir(path) and not os.path.islink(path):
                shutil.rmtree(path, ignore_errors=True)  # a NewFolder's scratch folder
            else:
                os.unlink(path)
        except OSError:
            pass
    _TEMPORARY.clear()


def _end_by_signal(signum: int, frame: Any) -> None:
    """Remove the temporary files, then end the process by the same signal, as it would have ended without us."""
    remove_temporary_files()
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


__all__ = ["Output", "Outputs", "STDOUT", "Stream", "check_distinct", "identity", "os_reason", "shown_path",
           "write_atomic", "write_output"]


# -- a new folder of files (fsmctl run --frames) --------------------------------------------------------------
class NewFolder:
    """An output that is a new folder of files (``fsmctl run --frames DIR``): ``check`` refuses a name that exists
    (a file, a folder, a link), a missing or unwritable parent; the files go into a hidden scratch folder beside it
    (``write``, names without a path), and ``commit`` renames it into place; ``discard`` removes it, so a failed or
    refused run leaves nothing behind."""

    def __init__(self, name: str, option: str) -> None:
        self.name = name
        self.option = option
        self.path = pathlib.Path(name)
        self._scratch: pathlib.Path | None = None
        self.files = 0

    def _fail(self, reason: str) -> UsageError:
        return UsageError(f"{self.option} {self.name}: {reason}")

    def check(self) -> None:
        if self.name in ("", "-") or self.name.startswith("/dev/"):
            raise self._fail("name a new folder for the files, e.g. " + self.option + " frames/")
        if os.path.lexists(self.path):
            kind = "a folder" if self.path.is_dir() else "a file" if self.path.is_file() else "there"
            raise self._fail(f"already exists ({kind}); the files go into a new folder: remove it or name another")
        parent = self.path.parent
        if not parent.is_dir():
            raise self._fail(f"the folder {parent} does not exist; create it first")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise self._fail(f"the folder {parent} cannot be written")

    def open(self) -> None:
        self.check()
        try:
            self._scratch = pathlib.Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", dir=self.path.parent))
            os.chmod(self._scratch, 0o777 & ~_umask())  # a folder like any the user makes, not mkdtemp's 0700
        except OSError as exc:
            raise self._fail(f"cannot create a folder beside it: {os_reason(exc)}") from None
        track_temporary(str(self._scratch))

    def write(self, filename: str, data: bytes | str) -> None:
        """One file of the folder: a plain name, or a relative path whose folders are made inside it (``src/a.py``)."""
        parts = filename.split("/")
        if self._scratch is None or any(p in ("", ".", "..") or os.sep in p for p in parts):
            raise ValueError(f"not a file name of the folder: {filename!r}")
        raw = data.encode("utf-8") if isinstance(data, str) else data
        try:
            if len(parts) > 1:
                os.makedirs(self._scratch.joinpath(*parts[:-1]), exist_ok=True)
            flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
            fd = os.open(self._scratch.joinpath(*parts), flags, 0o666)
            with os.fdopen(fd, "wb") as fh:
                fh.write(raw)
        except OSError as exc:
            raise FsmError(f"{self.option} {self.name}: cannot write {filename}: {os_reason(exc)}") from None
        self.files += 1

    def commit(self) -> None:
        """Put the folder in place (its name must still be free)."""
        if self._scratch is None:
            return
        if os.path.lexists(self.path):
            raise FsmError(f"{self.option} {self.name}: appeared while the run ran; the files stay in "
                           f"{self._scratch}")
        try:
            os.rename(self._scratch, self.path)
        except OSError as exc:
            raise FsmError(f"{self.option} {self.name}: cannot put the folder in place: {os_reason(exc)}") from None
        _TEMPORARY.discard(str(self._scratch))
        self._scratch = None

    def discard(self) -> None:
        if self._scratch is not None:
            shutil.rmtree(self._scratch, ignore_errors=True)
            _TEMPORARY.discard(str(self._scratch))
            self._scratch = None
