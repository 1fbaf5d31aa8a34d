"""mdl as a Python library (SPEC 16; docs/api.md): what the commands do, as calls. Load a description
(MDL, another format, or a vendor's table with its INI), validate and resolve it, generate drivers,
export it to another format or engine, and read and write a device with a Session.

Nothing here prints, exits or touches logging: a problem is an MdlError carrying Diagnostics (file,
line, column, message, as the commands print them), and what a call only warns about is returned or
kept on its result (`Device.warnings`, the list `export` returns).
"""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mdl.diagnostics import Diagnostic, MdlError, error
from mdl.model import Device as Document
from mdl.model import Scalar, Value
from mdl.resolver import ResolvedDevice as Device

if TYPE_CHECKING:
    from _typeshed import StrPath

    from mdl.device.connection import Connection
    from mdl.device.runtime import Session as Link

__all__ = ["Diagnostic", "Document", "Device", "MdlError", "Session", "export", "generate", "load", "resolve"]

TABLE = "table"  # load(..., format="table"): a vendor's register table (csv2xml), with or without an INI


def load(path: StrPath, *, format: str | None = None, ini: StrPath | None = None) -> Document:  # noqa: A002
    """The description in `path`: MDL XML, a format `mdl import` reads (`format` one of "xif", "wise",
    "schema"; guessed from the file when None), or a vendor's register table converted as `mdl
    csv2xml` converts it (`ini` its device INI; `format="table"`, or a table's file name ending, or a
    device INI naming its table as `path`), with its warnings and notes on the document's `notes`.
    MdlError for what cannot be read."""
    from mdl.formats import guess_format
    from mdl.formats.loading import load_any
    from mdl.formats.table.ini import is_ini
    from mdl.formats.table.readers.document import EXCEL, HTML, MARKDOWN

    given = Path(path)
    if format is None and ini is None:
        format = guess_format(given)  # XIF, a Toolkit schema, a WISE-Agent INI; None: anything else
        suffix = given.suffix.lower()
        if format is None and (suffix in (".csv", ".tsv", *MARKDOWN, *HTML, *EXCEL) or is_ini(given)):
            format = TABLE
    if format == TABLE or ini is not None:
        return _table(given, None if ini is None else Path(ini))
    return load_any(given, format)


def _table(source: Path, ini_path: Path | None) -> Document:
    from mdl.formats.table.convert import Options, convert
    from mdl.formats.table.ini import is_ini, read_ini
    from mdl.formats.table.report import Report

    if ini_path is None and is_ini(source):
        ini_path, table = source, None
    else:
        table = source
    ini = read_ini(ini_path) if ini_path is not None else None
    kept = Report(quiet=True, printing=False)
    if ini is not None:
        for diag in [*ini.warnings, *ini.notes]:
            kept.add(diag)
    table = table or (ini.csv_file if ini else None)
    if table is None:
        raise error("the INI names no address_map_csv_file in [Input/Output]: give the table's path", ini_path)
    document = convert(table, ini, Options(), kept)
    assert document is not None  # None only with Options.explain
    document.notes = [*kept.diagnostics(), *document.notes]
    return document


def validate(document: Document | StrPath) -> list[Diagnostic]:
    """Every problem `mdl validate` finds (the XSD, then the checks of SPEC 2), errors and warnings; an
    empty list for a valid description. A path is validated as the file it names (positions in it); a
    Document as the MDL it would be written as, its checks with the positions its source gave."""
    from mdl.formats.mdl import device_to_xml, validate_file
    from mdl.formats.mdl.load import text_problems
    from mdl.resolver.checks import check_device

    if not isinstance(document, Document):
        return validate_file(Path(document))[1]
    try:
        problems = text_problems(device_to_xml(document), document.source or "<document>", model=False)
    except MdlError as exc:  # a text no XML can carry
        return list(exc.diagnostics)
    return problems or check_device(document, document.source)


def resolve(document: Document) -> Device:
    """The checked device every other call takes (layouts, read plan, codecs), its warnings on
    `Device.warnings`; MdlError with every error found."""
    from mdl.resolver import resolve as resolve_device

    return resolve_device(document, document.source)


def generate(device: Device, lang: str, out_dir: StrPath, *, profile: str | None = None) -> list[Path]:
    """Write the drivers of `lang` ("python", "cpp", "c" or "all") into `out_dir` (made if absent), as
    `mdl gen` writes them: a file only when its content changes, all of a run's files or none. With
    `profile` (a shipped profile's name or a YAML file), the profile's interface too. The paths written."""
    from mdl.fileio import all_or_none
    from mdl.targets import generate as generate_files
    from mdl.targets import names

    if lang != "all" and lang not in names():
        raise error(f"unknown language {lang!r}: one of {', '.join([*names(), 'all'])}")
    source = Path(device.device.source or f"{device.stem}.xml")
    interface = None
    if profile is not None:
        from mdl.targets.profile import prepare

        interface, _, device = prepare(profile, device, str(source))
    with all_or_none():
        return generate_files(device, source, lang, Path(out_dir), False, interface)


def export(device: Device, to: str, out: StrPath, **options: Any) -> list[Diagnostic]:
    """Write `device` as format or engine `to` (as `mdl export --to`: "xif", "wise", "senml",
    "volttron", "homeassistant", "telegraf", "esphome", "thingsboard"; `out` a file, or the folder
    VOLTTRON's files go in). Options as the command's: `connection` (a URL such as
    "tcp://192.0.2.10:502" or a Connection), `unit`, `interval` (seconds), `board`, `tx_pin`, `rx_pin`,
    `flow_control_pin` (each pin checked as the command checks it).
    The warnings the format's losses give (one per kind of loss, naming the functions)."""
    from mdl.exchange.export import DEFAULT_INTERVAL, Settings
    from mdl.exports import export as export_engine
    from mdl.exports import outputs
    from mdl.fileio import all_or_none, write_atomic

    if to not in outputs():
        raise error(f"unknown export {to!r}: one of {', '.join(outputs())}")
    unknown = set(options) - {"connection", "unit", "interval", "board", "tx_pin", "rx_pin", "flow_control_pin"}
    if unknown:
        raise error(f"export takes no option {sorted(unknown)[0]!r}")
    from mdl.exports.esphome import pin_problem

    for key in ("tx_pin", "rx_pin", "flow_control_pin"):
        problem = None if options.get(key) is None else pin_problem(str(options[key]))
        if problem is not None:
            raise error(f"{key}: {problem}")
    connection = options.get("connection")
    if isinstance(connection, str):
        connection = _connection(connection)[0]
    interval = options.get("interval")
    settings = Settings(
        connection,
        int(options.get("unit", 1)),
        float(interval or DEFAULT_INTERVAL),
        interval is not None,
        str(options.get("board", "esp32dev")),
        str(options.get("tx_pin", "GPIO17")),
        str(options.get("rx_pin", "GPIO16")),
        None if options.get("flow_control_pin") is None else str(options["flow_control_pin"]),
    )
    result = export_engine(device, to, settings)
    target = Path(out)
    with all_or_none():
        if result.text is not None:
            write_atomic(target, result.text)
        else:
            for name, text in result.files.items():
                write_atomic(target / name, text)
    return list(result.warnings)


def _connection(url: str) -> tuple[Connection, int | None]:
    from mdl.device.connection import parse_connection

    try:
        return parse_connection(url)
    except ValueError as exc:
        raise error(f"connection {url!r}: {exc}") from None


class Session:
    """One unit of a device, reached at `connection`: a URL (`tcp://HOST[:PORT]`, `rtu+tcp://HOST:PORT`,
    `rtu:///dev/ttyUSB0?baud=9600&parity=E`, each with `?timeout=S&retries=N`; `#UNIT` sets the unit) or
    a Connection. `read(*names)` reads with the coalesced read plan, `write(**values)` encodes and
    writes (refusing read-only functions and values outside minimum/maximum); `aread`, `awrite` and
    `aclose` are their asyncio twins (each on a worker thread; one exchange at a time either way). A device that
    does not answer raises MdlError (a DeviceError, exit status 3 in the commands)."""

    def __init__(self, device: Device, connection: str | Connection, unit: int | None = None) -> None:
        from mdl.device.runtime import Session as Link

        given_unit = None
        if isinstance(connection, str):
            connection, given_unit = _connection(connection)
        self.device = device
        self.unit = unit if unit is not None else given_unit if given_unit is not None else 1
        self._link: Link = Link(device, connection, self.unit)
        self._lock = threading.Lock()  # one exchange at a time, from any thread (the async twins use one)

    def read(self, *names: str) -> dict[str, Value]:
        """Function name -> value (None where the device reports "not implemented"), of the named
        functions, or of every readable one."""
        functions = self.device.device.select(names)
        with self._lock:
            return self._link.read(functions)

    def write(self, **values: Scalar | str) -> None:
        """Write each function's value: a number, a bool, an enumeration's label or a text."""
        from mdl.ir import codec

        todo = []
        for name, value in values.items():
            (fn,) = self.device.device.select([name], write=True)
            try:
                parsed = codec.parse_value(fn, value) if isinstance(value, str) else value
                codec.encode(fn, parsed)
            except (codec.CodecError, ValueError, ZeroDivisionError) as exc:
                raise error(f"{name}={value!r}: {exc}") from None
            todo.append((fn, parsed))
        with self._lock:
            for fn, parsed in todo:
                self._link.write(fn, parsed)

    def close(self) -> None:
        with self._lock:
            self._link.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    async def aread(self, *names: str) -> dict[str, Value]:
        return await asyncio.to_thread(self.read, *names)

    async def awrite(self, **values: Scalar | str) -> None:
        await asyncio.to_thread(self.write, **values)

    async def aclose(self) -> None:
        await asyncio.to_thread(self.close)

    async def __aenter__(self) -> Session:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()
