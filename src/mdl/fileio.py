"""Reading input files with clear errors; writing outputs whole, and a run's outputs all or none.

`-` on the command line means standard input: input_path() turns it into STDIN, which read_bytes()
reads from sys.stdin and every message names `<stdin>`.

An output is written to a temporary file beside it and renamed into place, so no reader ever sees
half a file. A new file gets the permissions the umask gives (as any program creating a file); an
existing file keeps its mode, as editors do. Inside all_or_none() the renames wait until every file
of the run is written, and a failed rename puts back the files already replaced: a run changes all
its files or none. Temporary files are removed on every error, on SIGINT (KeyboardInterrupt), and on
SIGTERM/SIGHUP, which raise SystemExit(128 + signal) while files are being written; those a run
killed outright (SIGKILL, a power cut) leaves, remove_leftovers() removes on the next run.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import signal
import stat
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
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
    try:
        return Path(path).read_bytes() != content.encode("utf-8")
    except OSError:
        return True


@dataclass
class _Staged:
    """One output of a run: its final path, the written temporary file, the old file's second name."""

    path: Path
    tmp: Path
    old: Path | None = None


_run: list[_Staged] | None = None  # the outputs staged inside all_or_none()


def write_atomic(path: StrPath, content: str | bytes) -> None:
    """Write one file whole; inside all_or_none() it is put in place with the run's other files."""
    if _run is None:
        with all_or_none():
            write_atomic(path, content)
        return
    target = Path(path)
    try:
        data = content.encode("utf-8") if isinstance(content, str) else content
    except UnicodeEncodeError as exc:  # a lone surrogate from an input no writer refused
        bad = f"U+{ord(exc.object[exc.start]):04X}"
        raise error(f"cannot write: the text holds {bad}, which no file can carry (UTF-8)", target) from None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with _signals_blocked():  # the run knows the temporary file before a signal can stop it
            tmp, fd = _create_beside(target)
            _run.append(_Staged(target, tmp))
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        mode = _regular_file_mode(target)
        if mode is not None:
            os.chmod(tmp, mode)
    except OSError as exc:
        raise error(f"cannot write: {exc.strerror}", target) from None


@contextlib.contextmanager
def all_or_none() -> Iterator[None]:
    """Every write_atomic() inside is staged; on leaving without error all of them are put in place."""
    global _run
    if _run is not None:
        raise RuntimeError("all_or_none() does not nest")
    staged: list[_Staged] = []
    _run = staged
    try:
        with _signals_exit():
            yield
            with _signals_blocked():
                _commit(staged)
    finally:
        _run = None
        _discard(staged)


_TOKEN_BYTES = 6  # RANDOM in the names below: 12 hex digits


def _hidden_name(path: Path, kind: str) -> Path:
    """`.NAME.RANDOM.tmp` (a file being written) or `.NAME.RANDOM.old` (the old file's second name)."""
    return path.with_name(f".{path.name}.{secrets.token_hex(_TOKEN_BYTES)}.{kind}")


def remove_leftovers(path: StrPath) -> None:
    """Remove the hidden files beside `path` that a run killed while writing it left: only names of
    _hidden_name's pattern for this very file, never another file. (Two runs writing the same file at
    once are not supported: the later one's leftovers may be the earlier one's files in progress.)"""
    target = Path(path)
    pattern = re.compile(rf"\.{re.escape(target.name)}\.[0-9a-f]{{{2 * _TOKEN_BYTES}}}\.(?:tmp|old)")
    try:
        names = os.listdir(target.parent)
    except OSError:
        return  # no folder yet: nothing left in it
    for name in names:
        if pattern.fullmatch(name):
            with contextlib.suppress(OSError):
                os.unlink(target.parent / name)


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
            try:
                os.replace(item.tmp, item.path)
            except OSError as exc:
                raise error(f"cannot write: {exc.strerror}", item.path) from None
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
