"""Reading input files with clear errors; writing outputs whole, and a run's outputs all or none.

`-` on the command line means standard input: input_path() turns it into STDIN, which read_bytes()
reads from sys.stdin and every message names `<stdin>`.

What an output path names decides how it is written (SPEC section 1, "Output files"):
- a regular file (or none yet) is written to a temporary file beside it and renamed into place, so no
  reader ever sees half a file. A new file gets the permissions the umask gives (as any program
  creating a file); an existing file keeps its mode, as editors do.
- a symbolic link (a chain of them) stays a link: the file it finally names is replaced as above, in
  its own folder; a dangling link's file is created.
- a FIFO, a device or a socket (`/dev/null`, a named pipe, a terminal), and a descriptor of this
  process (`/dev/stdout`, `/dev/fd/N` as `>(cmd)` gives) is written to in place, never replaced: no
  temporary file, no rename, no chmod. A folder is refused (the rename over it fails).
Inside all_or_none() nothing is renamed or written in place until every output of the run is ready;
then the files are renamed, and a failed rename puts back the files already replaced; then the
in-place outputs are written, and a failed one puts back every file: a run changes all its files or
none (what a stream has taken cannot be taken back). Temporary files are removed on every error, on
SIGINT (KeyboardInterrupt), and on SIGTERM/SIGHUP, which raise SystemExit(128 + signal) while files
are being written; those a run killed outright (SIGKILL, a power cut) leaves, remove_leftovers()
removes on the next run.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import stat
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from mdl.diagnostics import MdlError, error

if TYPE_CHECKING:
    from _typeshed import StrPath

STDIN = Path("<stdin>")
STDIO_ARG = "-"


def input_path(arg: StrPath) -> Path:
    """The path an input argument names: `-` is STDIN; a real file named `<stdin>` keeps its own name."""
    if str(arg) == STDIO_ARG:
        return STDIN
    path = Path(arg)
    return path.absolute() if path == STDIN else path


def is_stdin(path: StrPath) -> bool:
    return str(path) == str(STDIN)


def read_bytes(path: StrPath, limit: int | None = None) -> bytes:
    """The file's bytes; with `limit`, an error (naming the limit) for a file larger than that, read no further."""
    data = read_head(path, limit)
    if limit is not None and len(data) > limit:
        raise too_large(path, limit)
    return data


def too_large(path: StrPath, limit: int) -> MdlError:
    return error(f"larger than {limit:,} bytes, the most this format's reader takes", path)


def read_head(path: StrPath, limit: int | None = None) -> bytes:
    """The file's bytes, with `limit` no more than limit + 1 of them (more than limit: the file is larger)."""
    try:
        if is_stdin(path):
            return sys.stdin.buffer.read() if limit is None else sys.stdin.buffer.read(limit + 1)
        with open(path, "rb") as f:
            return f.read() if limit is None else f.read(limit + 1)
    except FileNotFoundError:
        raise error("no such file", path) from None
    except IsADirectoryError:
        raise error("is a directory, not a file", path) from None
    except OSError as exc:
        raise error(f"cannot read: {exc.strerror}", path) from None


def decode_text(data: bytes, path: StrPath, encodings: tuple[str, ...] = ("utf-8",)) -> str:
    """Decode bytes, naming the line of the first undecodable byte when no encoding fits."""
    first_exc: UnicodeDecodeError | None = None
    for enc in encodings:
        try:
            return data.decode(enc)
        except UnicodeDecodeError as exc:
            first_exc = first_exc or exc
    assert first_exc is not None, "decode_text needs at least one encoding"
    line = data[: first_exc.start].count(b"\n") + 1
    col = first_exc.start - (data.rfind(b"\n", 0, first_exc.start) + 1) + 1
    raise error(f"cannot decode byte 0x{data[first_exc.start]:02x} as {first_exc.encoding}", path, line, col)


def read_text(path: StrPath, encodings: tuple[str, ...] = ("utf-8",)) -> str:
    return decode_text(read_bytes(path), path, encodings)


def would_change(path: StrPath, content: str) -> bool:
    """Whether writing `content` to `path` changes it. Only a regular file is read and compared: a
    FIFO, a device or a descriptor is written every time (reading a FIFO would wait for a writer)."""
    target = Path(path)
    if _own_descriptor(target) is not None:
        return True
    try:
        if not stat.S_ISREG(os.stat(target).st_mode):
            return True
        return target.read_bytes() != content.encode("utf-8")
    except OSError:
        return True


MAX_LINKS = 40  # symbolic links followed to an output's file, as many as Linux's path lookup follows


class _Staged:
    """One output of a run. `shown`: the path as given, for messages; `path`: where the bytes go (the
    file a link names). Replaced whole: `tmp`, the written temporary file, and while the run is put in
    place `old`, the old file's second name. Written in place: its bytes `data`, and `fd` if it is a
    descriptor of this process or `socket` if it is a socket. (A plain class: a dataclass's methods are
    compiled as the class is made, by every command that imports this module.)"""

    __slots__ = ("data", "fd", "in_place", "old", "path", "shown", "socket", "tmp")

    def __init__(
        self, shown: Path, path: Path, in_place: bool = False, fd: int | None = None, socket: bool = False
    ) -> None:
        self.shown, self.path, self.in_place, self.fd, self.socket = shown, path, in_place, fd, socket
        self.tmp: Path | None = None
        self.old: Path | None = None
        self.data = b""


_run: list[_Staged] | None = None  # the outputs staged inside all_or_none()


def write_atomic(path: StrPath, content: str | bytes) -> None:
    """Write one output: a file replaced whole, a FIFO, device, socket or descriptor written in place
    (the module docstring); inside all_or_none() it is put in place with the run's other outputs."""
    if _run is None:
        with all_or_none():
            write_atomic(path, content)
        return
    shown = Path(path)
    try:
        data = content.encode("utf-8") if isinstance(content, str) else content
    except UnicodeEncodeError as exc:  # a lone surrogate from an input no writer refused
        bad = f"U+{ord(exc.object[exc.start]):04X}"
        raise error(f"cannot write: the text holds {bad}, which no file can carry (UTF-8)", shown) from None
    item = _staged(shown)
    if item.in_place:
        item.data = data
        _run.append(item)
    else:
        _stage_file(item, data)


def _staged(shown: Path) -> _Staged:
    """What `shown` names: a descriptor of this process, a stream (kept as it is), or the file to replace."""
    fd = _own_descriptor(shown)
    if fd is not None:
        return _Staged(shown, shown, in_place=True, fd=fd)
    try:
        mode = os.stat(shown).st_mode
    except FileNotFoundError:
        return _Staged(shown, _linked_file(shown))  # no file yet, or a dangling link: its file is created
    except OSError as exc:
        raise _cannot_write(exc, shown, shown) from None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):  # a folder: the rename over it fails, the run puts back
        return _Staged(shown, _linked_file(shown))
    return _Staged(shown, shown, in_place=True, socket=stat.S_ISSOCK(mode))  # opened through its links


def _stage_file(item: _Staged, data: bytes) -> None:
    """Write the temporary file that will replace `item.path`, beside it, with the old file's mode."""
    assert _run is not None
    target = item.path
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with _signals_blocked():  # the run knows the temporary file before a signal can stop it
            item.tmp, fd = _create_beside(target)
            _run.append(item)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        mode = _regular_file_mode(target)
        if mode is not None:
            os.chmod(item.tmp, mode)
    except OSError as exc:
        raise _cannot_write(exc, item.shown, target) from None


def _cannot_write(exc: OSError, shown: Path, path: Path) -> MdlError:
    """`cannot write: REASON` at the path as given, naming the file its link leads to if that is another."""
    linked = "" if path == shown else f" {path}, the file its link names"
    return error(f"cannot write{linked}: {exc.strerror or exc}", shown)


# a pattern's text, compiled where it is used (re.compile keeps it): no compiling at import (issue 40)
_DESCRIPTOR = (
    r"/dev/(?:std(?P<std>out|err)|fd/(?P<fd>[0-9]+))|/proc/(?P<pid>self|thread-self|[0-9]+)/fd/(?P<pfd>[0-9]+)"
)


def _own_descriptor(path: Path) -> int | None:
    """The open descriptor of this process `/dev/stdout`, `/dev/stderr`, `/dev/fd/N` or `/proc/self/fd/N`
    names: written to as it is, as bash does (reopening a socket fails, and reopening a file would
    start it over at its beginning, or replace a file `>>` appends to)."""
    match = re.compile(_DESCRIPTOR).fullmatch(os.path.normpath(os.path.abspath(path)))
    if match is None or match["pid"] not in (None, "self", "thread-self", str(os.getpid())):
        return None
    fd = {"out": 1, "err": 2}[match["std"]] if match["std"] else int(match["fd"] or match["pfd"])
    try:
        os.fstat(fd)
    except OSError:
        return None  # not open here: the path is looked up as any other
    return fd


def _linked_file(path: Path) -> Path:
    """The file `path` finally names through its symbolic links (`path` itself if it is no link); a
    relative link is taken from its own folder. A chain longer than MAX_LINKS (a loop) is an error."""
    at = path
    for _ in range(MAX_LINKS + 1):
        try:
            link = os.readlink(at)
        except OSError:  # not a link (or not there): this is the file
            return at
        at = Path(os.path.join(os.path.dirname(at), link))
    raise error(f"cannot write: cannot follow its symbolic links, more than {MAX_LINKS} (a loop?)", path)


@contextlib.contextmanager
def all_or_none() -> Iterator[None]:
    """Every write_atomic() inside is staged; on leaving without error all of them are put in place:
    first the files renamed, then the outputs written in place, which cannot be taken back: if one of
    them fails (a reader gone, a device full), the files are put back too."""
    global _run
    if _run is not None:
        raise RuntimeError("all_or_none() does not nest")
    staged: list[_Staged] = []
    _run = staged
    try:
        with _signals_exit():
            yield
            files = [item for item in staged if not item.in_place]
            with _signals_blocked():
                _commit(files)
            try:
                for item in staged:
                    if item.in_place:
                        _write_in_place(item)  # signals not held: a FIFO nobody reads can be interrupted
            except BaseException:
                with _signals_blocked():
                    for item in reversed(files):
                        _put_back(item)
                raise
    finally:
        _run = None
        _discard(staged)


def _write_in_place(item: _Staged) -> None:
    """Write `item.data` into the descriptor, socket, FIFO or device it names, as `cat > PATH` does."""
    try:
        if item.fd is not None:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()  # what was printed before comes first
            _write_all(item.fd, item.data)
        elif item.socket:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
                sock.connect(str(item.path))
                sock.sendall(item.data)
        else:
            fd = os.open(item.path, os.O_WRONLY | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0))
            try:
                _write_all(fd, item.data)
            finally:
                os.close(fd)
    except OSError as exc:
        raise _cannot_write(exc, item.shown, item.path) from None


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


_TOKEN_BYTES = 6  # RANDOM in the names below: 12 hex digits


def _hidden_name(path: Path, kind: str) -> Path:
    """`.NAME.RANDOM.tmp` (a file being written) or `.NAME.RANDOM.old` (the old file's second name)."""
    import secrets  # here, not at the top: only a write needs it (hashlib and hmac, for a one-shot read)

    return path.with_name(f".{path.name}.{secrets.token_hex(_TOKEN_BYTES)}.{kind}")


def remove_leftovers(path: StrPath) -> None:
    """Remove the hidden files beside `path` that a run killed while writing it left: only names of
    _hidden_name's pattern for this very file, never another file. (Two runs writing the same file at
    once are not supported: the later one's leftovers may be the earlier one's files in progress.)"""
    target = Path(path)
    if _own_descriptor(target) is not None or not _is_file_or_none(target):
        return  # written in place: nothing is ever left beside it
    try:
        target = _linked_file(target)  # a link's temporary files are beside the file it names
    except MdlError:
        return
    pattern = re.compile(rf"\.{re.escape(target.name)}\.[0-9a-f]{{{2 * _TOKEN_BYTES}}}\.(?:tmp|old)")
    try:
        names = os.listdir(target.parent)
    except OSError:
        return  # no folder yet: nothing left in it
    for name in names:
        if pattern.fullmatch(name):
            with contextlib.suppress(OSError):
                os.unlink(target.parent / name)


def _is_file_or_none(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return True


def _create_beside(path: Path) -> tuple[Path, int]:
    """Create `.NAME.RANDOM.tmp` exclusively, mode 0666 less the umask (what open(2) does)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    while True:
        tmp = _hidden_name(path, "tmp")
        try:
            return tmp, os.open(tmp, flags, 0o666)
        except FileExistsError:
            continue


def _regular_file_mode(path: Path) -> int | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return stat.S_IMODE(st.st_mode) if stat.S_ISREG(st.st_mode) else None


def _commit(staged: list[_Staged]) -> None:
    """Rename every temporary file into place; if one rename fails, put the replaced files back."""
    for item in staged:
        item.old = _second_name(item.path)
    done: list[_Staged] = []
    try:
        for item in staged:
            assert item.tmp is not None
            try:
                os.replace(item.tmp, item.path)
            except OSError as exc:
                raise _cannot_write(exc, item.shown, item.path) from None
            done.append(item)
    except BaseException:
        for item in reversed(done):
            _put_back(item)
        raise


def _second_name(path: Path) -> Path | None:
    """A hard link (else a copy) of the file at path, to put back if the run fails; None if no file."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise error(f"cannot write: {exc.strerror}", path) from None
    if not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
        return None  # a directory or a device: the rename fails, nothing to put back
    old = _hidden_name(path, "old")
    try:
        os.link(path, old, follow_symlinks=False)
    except OSError:
        import shutil  # here: a hard link is the rule (and shutil imports bz2 and lzma)

        try:
            shutil.copy2(path, old, follow_symlinks=False)
        except OSError as exc:
            raise error(f"cannot keep the old file: {exc.strerror}", path) from None
    return old


def _put_back(item: _Staged) -> None:
    with contextlib.suppress(OSError):
        if item.old is None:
            os.unlink(item.path)
        else:
            os.replace(item.old, item.path)
            item.old = None


def _discard(staged: list[_Staged]) -> None:
    """Remove the temporary files and second names a run leaves."""
    for item in staged:
        for leftover in (item.tmp, item.old):
            if leftover is not None:
                with contextlib.suppress(OSError):
                    os.unlink(leftover)


_EXIT_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))
_DEFERRED_SIGNALS = (signal.SIGINT, *_EXIT_SIGNALS)


def _exit_on_signal(signum: int, frame: FrameType | None) -> None:
    raise SystemExit(128 + signum)


@contextlib.contextmanager
def _signals_exit() -> Iterator[None]:
    """SIGTERM/SIGHUP raise SystemExit here (instead of killing the process) so that finally runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {}
    for signum in _EXIT_SIGNALS:
        if signal.getsignal(signum) == signal.SIG_DFL:
            previous[signum] = signal.signal(signum, _exit_on_signal)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def _signals_blocked() -> Iterator[None]:
    """Signals wait while the renames run, so that a run is never left half renamed."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, _DEFERRED_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
