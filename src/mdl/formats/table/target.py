"""Where `mdl csv2xml` writes its MDL, and what it will not write over (docs/csv2xml.md, "Output file").

The output is `-o` if given; in the `mdl csv2xml DEVICE.ini` form the INI's `output_xml_file`; else
stdout. An INI is input like any other, so the file it names is held to rules:
- never an input of the run (the CSV, the INI itself), whatever the flags;
- for `output_xml_file`: inside the INI's folder (`--allow-outside` lifts that) and never in a hidden
  folder (`.git/hooks/pre-commit`, `.ssh/…`) or a hidden file;
- for `output_xml_file`: an existing file that is not an MDL document (an earlier output) is replaced
  only with `--force`. `-o` is the user's own word and replaces what it names, as `cp` does (a FIFO,
  a device or a socket is written in place: mdl.fileio).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from lxml import etree

from mdl.diagnostics import MdlError, error
from mdl.fileio import STDIO_ARG
from mdl.formats.table.ini import is_ini, read_ini

MDL_ROOT = "{http://www.ornl.gov/ModbusXMLSchema}device"
_SNIFF_BYTES = 1 << 16  # enough of a file to see its root element


def output_target(
    source: Path, ini_path: Path | None, output: Path | None, allow_outside: bool, force: bool
) -> Path | None:
    """The file csv2xml writes, checked against the rules above; None: stdout."""
    ini = read_ini(source) if ini_path is None and is_ini(source) else None  # the `mdl csv2xml DEVICE.ini` form
    named = (source, ini_path, ini.csv_file if ini else None)
    inputs = [p for p in named if p is not None and str(p) != STDIO_ARG]
    if output is not None:
        if str(output) == STDIO_ARG:
            return None
        _check_not_input(output, inputs, None, None)  # -o is the user's own word: it may replace other files
        _check_kind(output, "-o", output, None)
        return output
    if ini is None or ini.output_file is None:
        return None
    target = ini.output_file
    line = ini.line("io", "output_xml_file")
    folder = _resolved(source.parent, source, line)
    resolved = _resolved(target, source, line)
    if not allow_outside and not resolved.is_relative_to(folder):
        raise error(
            f"output_xml_file names {resolved}, outside the INI's folder {folder}; "
            "give -o FILE, or --allow-outside to write it there",
            source,
            line,
        )
    hidden = _hidden_part(resolved, Path(os.path.commonpath([resolved, folder])))
    if hidden is not None:
        raise error(
            f"output_xml_file names {target}, inside the hidden {hidden!r}; mdl csv2xml does not write "
            "into hidden files or folders from an INI: give -o FILE to write there",
            source,
            line,
        )
    _check_not_input(target, inputs, source, line)
    _check_replace(target, force, source, line)
    return target


def _check_not_input(target: Path, inputs: list[Path], ini: Path | None, line: int | None) -> None:
    """Refuse `target` if it is one of `inputs`; `ini`: the INI that named it (None: -o named it)."""
    for path in inputs:
        if _same_file(target, path):
            what = "the INI file itself" if ini is not None and _same_file(path, ini) else f"the input {path}"
            raise error(
                f"the output {target} is {what}: csv2xml never writes over an input of the run", ini or target, line
            )


def _resolved(path: Path, file: Path, line: int | None) -> Path:
    """`path` with its links and `..` resolved; an error at `file`:`line` for a link that loops."""
    try:
        return path.resolve()
    except (OSError, RuntimeError) as exc:  # Python 3.11 raises RuntimeError for a symbolic link loop
        raise error(f"{path}: cannot follow its symbolic links ({exc})", file, line) from None


def _check_kind(target: Path, named_by: str, file: Path, line: int | None) -> None:
    """Refuse a folder, and a link that loops. `-o` may name a FIFO, a device or a socket: it is written
    in place (mdl.fileio). The INI's output_xml_file may not: it is read to see whether it is an MDL
    document (a FIFO would be waited on for ever), and an INI is input, not the user's own word."""
    try:
        mode = target.stat().st_mode
    except FileNotFoundError:
        if target.name in ("", ".", ".."):
            raise error(f"{named_by} names {target}, a folder: give a file name", file, line) from None
        return
    except (OSError, RuntimeError) as exc:
        raise error(f"{named_by} names {target}: {exc}", file, line) from None
    if stat.S_ISDIR(mode):
        raise error(f"{named_by} names {target}, a folder: give a file name", file, line)
    if not stat.S_ISREG(mode) and named_by != "-o":
        raise error(
            f"{named_by} names {target}, which is not a regular file (a FIFO or a device): give -o {target} "
            "to write into it",
            file,
            line,
        )


def _check_replace(target: Path, force: bool, ini: Path, line: int | None) -> None:
    _check_kind(target, "output_xml_file", ini, line)
    if force or not target.exists():
        return
    if not is_mdl_document(target):
        raise error(
            f"output_xml_file names {target}, which exists and is not an MDL document (an earlier output "
            "of csv2xml); give --force to replace it, or -o FILE",
            ini,
            line,
        )


def is_mdl_document(path: Path) -> bool:
    """Whether `path` holds an MDL document: XML whose root element is MDL's `device`."""
    try:
        with path.open("rb") as fh:
            head = fh.read(_SNIFF_BYTES)
    except OSError:
        return False
    try:
        for _event, element in etree.iterparse(
            _Chunk(head), events=("start",), resolve_entities=False, no_network=True, load_dtd=False
        ):
            return bool(element.tag == MDL_ROOT)
    except (etree.XMLSyntaxError, MdlError):
        return False
    return False


class _Chunk:
    """A file-like object over bytes for lxml's iterparse (only the first start tag is read)."""

    def __init__(self, data: bytes):
        self._data = data
        self._pos = 0

    def read(self, size: int = -1) -> bytes:
        end = len(self._data) if size < 0 else self._pos + size
        chunk = self._data[self._pos : end]
        self._pos += len(chunk)
        return chunk


def _hidden_part(path: Path, below: Path) -> str | None:
    """The first name of `path` below `below` that starts with a dot (hidden), if any."""
    for part in path.relative_to(below).parts:
        if part.startswith(".") and part not in (".", ".."):
            return part
    return None


def _same_file(a: Path, b: Path) -> bool:
    """Whether `a` and `b` name one file: the same resolved path (`sub/../x` with no `sub` yet is `x`)
    or the same inode (a hard link)."""
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and a.samefile(b))
    except (OSError, RuntimeError):  # a link that loops is no input (the write then says what it is)
        return False
