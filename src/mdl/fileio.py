"""Reading input files with clear errors; writing outputs whole or not at all."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from mdl.diagnostics import error


def read_bytes(path) -> bytes:
    try:
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise error("no such file", path) from None
    except IsADirectoryError:
        raise error("is a directory, not a file", path) from None
    except OSError as exc:
        raise error(f"cannot read: {exc.strerror}", path) from None


def decode_text(data: bytes, path, encodings=("utf-8",)) -> str:
    """Decode bytes, naming the line of the first undecodable byte when no encoding fits."""
    first_exc = None
    for enc in encodings:
        try:
            return data.decode(enc)
        except UnicodeDecodeError as exc:
            first_exc = first_exc or exc
    line = data[: first_exc.start].count(b"\n") + 1
    col = first_exc.start - (data.rfind(b"\n", 0, first_exc.start) + 1) + 1
    raise error(
        f"cannot decode byte 0x{data[first_exc.start]:02x} as {first_exc.encoding}", path, line, col
    )


def read_text(path, encodings=("utf-8",)) -> str:
    return decode_text(read_bytes(path), path, encodings)


def write_atomic(path, content: str | bytes) -> None:
    """Write to a temporary file beside the target, then rename: never a half-written file."""
    path = Path(path)
    data = content.encode("utf-8") if isinstance(content, str) else content
    directory = path.parent if str(path.parent) else Path(".")
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    except OSError as exc:
        raise error(f"cannot write: {exc.strerror}", path) from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except OSError as exc:
        os.unlink(tmp)
        raise error(f"cannot write: {exc.strerror}", path) from None


def would_change(path, content: str) -> bool:
    try:
        return Path(path).read_bytes() != content.encode("utf-8")
    except OSError:
        return True
