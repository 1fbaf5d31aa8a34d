"""The inventory of a fleet (SPEC 15; docs/fleet.md, "Inventory"): every device of a site named once, in
YAML or in CSV with the same columns, read into Entries with every mistake said at once, each at its
FILE:LINE (read_inventory), then each device's description loaded and its profile fitted (load_inventory).

YAML (any file not named *.csv):

    defaults: {interval: 10, timeout: 1.0, retries: 1}
    devices:
      - id: plant1-meter-03              # unique (ignoring case); [A-Za-z0-9_.-], at most 64
        description: descriptions/em24.xml   # relative to the inventory's folder
        connection: tcp://192.0.2.15:502     # rtu:///dev/ttyUSB0?baud=9600&parity=E, rtu+tcp://HOST:PORT
        unit: 3
        interval: 5
        profile: meter
        tags: {site: plant1, feeder: A}

CSV (*.csv): a header row naming its columns (COLUMNS, in any order; id, description and connection
required), then a row per device; tags are `key=value;key=value`; an empty cell is the default; a row
whose first cell starts with `#`, or that is empty, is skipped. A CSV has no defaults section: timeout
and retries are columns (a device's own in YAML too), or the connection's `?timeout=S&retries=N`.

Each entry's connection is a URL of mdl.device.connection's one grammar; the devices on one serial line
or one RTU-over-TCP converter share it (mdl.device.fleet.run.shared_line), and two entries that give a
line different settings (baud, parity, stop bits, byte size, timeout, retries) are an error, as is one
host:port spoken to as Modbus TCP by one entry and as RTU over TCP by another.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import parse_qsl

from mdl.device.connection import SETTINGS, Connection, parse_connection
from mdl.device.fleet.run import line_settings, shared_line
from mdl.diagnostics import Diagnostic, MdlError, one_line, shown
from mdl.exchange.connection import host_port
from mdl.exchange.yamlnodes import MAX_FILE_BYTES, List, Map, Node, Text, load_yaml
from mdl.fileio import decode_text, is_stdin, read_bytes

if TYPE_CHECKING:
    from mdl.profiles.fit import Fit
    from mdl.profiles.load import Profile
    from mdl.resolver import ResolvedDevice

ID = re.compile(r"[A-Za-z0-9_.-]{1,64}")
TAG_KEY = ID
MAX_TAG_CHARS = 256
DEFAULT_INTERVAL = 10.0
INTERVALS = (0.1, 86400.0)  # seconds, as `mdl read --interval` takes them
MAX_UNIT = 255
COLUMNS = ("id", "description", "connection", "unit", "interval", "profile", "tags", "timeout", "retries")
REQUIRED = ("id", "description", "connection")
DEFAULT_KEYS = ("interval", "timeout", "retries")
TOP_KEYS = ("defaults", "devices")
MAX_BYTES = MAX_FILE_BYTES  # the YAML reader's bound (some 10,000 devices), the CSV reader's too
MAX_SHOWN = 100  # errors said in full; the rest are counted
_INT = re.compile(r"[0-9]{1,9}")
_FLOAT = re.compile(r"(?:[0-9]{1,9}(?:\.[0-9]{0,9})?|\.[0-9]{1,9})")


@dataclass(frozen=True)
class Entry:
    """One device of the inventory. `description` is the file to load (relative paths joined to the
    inventory's folder), `written` what the inventory wrote for each key, `lines` the line of each
    (a CSV row's line for all of them), `line` the entry's own."""

    id: str
    description: Path
    connection: Connection
    unit: int
    interval: float
    profile: str | None
    tags: dict[str, str]
    line: int
    lines: dict[str, int] = field(default_factory=dict)
    written: dict[str, str] = field(default_factory=dict)


@dataclass
class Inventory:
    """An inventory as read: its entries (those without errors) and its diagnostics (errors, warnings)."""

    path: Path
    entries: list[Entry]
    diagnostics: list[Diagnostic]

    @property
    def ok(self) -> bool:
        return not any(d.severity == "error" for d in self.diagnostics)


@dataclass
class Member:
    """A device of the fleet ready to poll: its entry and its description through the resolve step."""

    entry: Entry
    resolved: ResolvedDevice


@dataclass(frozen=True)
class _Cell:
    """A value as the inventory gives it: a text, or (YAML tags) a mapping of texts; where it is."""

    line: int
    col: int | None
    text: str | None = None
    pairs: tuple[tuple[str, _Cell], ...] | None = None


_Row = tuple[int, dict[str, _Cell]]


def is_csv(path: Path) -> bool:
    return path.suffix.lower() == ".csv"


def read_inventory(path: Path) -> Inventory:
    """The inventory in `path` (CSV if named *.csv, else YAML): every entry checked, every error found
    (Inventory.diagnostics). MdlError (exit 1) only for what stops the reading: a file that cannot be
    read, is larger than MAX_BYTES, or is not YAML or CSV."""
    reader = _Reader(path)
    rows, defaults = reader.csv_rows() if is_csv(path) else reader.yaml_rows()
    settings = reader.defaults(defaults)
    entries = [entry for line, row in rows if (entry := reader.entry(line, row, settings)) is not None]
    reader.cross_checks(rows, entries)
    if not rows and not reader.errors:
        reader.error(1, "the inventory lists no devices")
    return Inventory(path, entries, sorted(reader.errors, key=lambda d: d.line or 0))


def load_inventory(path: Path, load: Callable[[Path], ResolvedDevice]) -> tuple[list[Member], list[Diagnostic]]:
    """The inventory's devices with their descriptions loaded by `load` (once per file: the command's
    loader, which prints a description's warnings) and each profile fitted; the inventory's warnings.
    MdlError with every error at once (the inventory's at FILE:LINE, each followed by the description's or
    profile's own) otherwise."""
    inventory = read_inventory(path)
    groups: list[tuple[int, list[Diagnostic]]] = [(d.line or 0, [d]) for d in inventory.diagnostics]
    descriptions: dict[Path, ResolvedDevice | MdlError] = {}
    fits: dict[tuple[Path, str], Fit | MdlError] = {}
    told: set[object] = set()  # descriptions and profiles whose own errors are said already
    members = []
    for entry in inventory.entries:
        resolved = descriptions.get(entry.description)
        if resolved is None:
            try:
                resolved = load(entry.description)
            except MdlError as exc:
                resolved = exc
            descriptions[entry.description] = resolved
        line = entry.lines.get("description", entry.line)
        if isinstance(resolved, MdlError):
            said = f"device '{entry.id}': description {shown(entry.written['description'])} cannot be used"
            own = [] if entry.description in told else resolved.diagnostics
            told.add(entry.description)
            groups.append((line, [Diagnostic(str(path), line, None, said + (":" if own else " (above)")), *own]))
            continue
        if entry.profile is not None:
            problem = _profile_problem(path, entry, resolved, fits, told)
            if problem:
                groups.append((entry.lines.get("profile", entry.line), problem))
                continue
        members.append(Member(entry, resolved))
    groups.sort(key=lambda group: group[0])
    diagnostics = [d for _, group in groups for d in group]
    errors = [d for d in diagnostics if d.severity == "error"]
    if errors:
        raise MdlError(_capped(path, diagnostics))
    return members, diagnostics


def _profile_problem(
    path: Path, entry: Entry, resolved: ResolvedDevice, fits: dict[tuple[Path, str], Fit | MdlError], told: set[object]
) -> list[Diagnostic]:
    """The errors of an entry's profile: one that cannot be loaded, or a description that lacks a role
    it requires (as `mdl validate --profile` says them); none if it fits."""
    from mdl.profiles.fit import fit
    from mdl.profiles.load import load_profile
    from mdl.profiles.report import fit_diagnostics

    assert entry.profile is not None
    spec = entry.profile
    if spec.lower().endswith((".yaml", ".yml")) or "/" in spec or "\\" in spec:
        spec = str(_folder(path) / spec)  # a profile file, as descriptions are: beside the inventory
    key = (entry.description, spec)
    fitted = fits.get(key)
    if fitted is None:
        try:
            profile: Profile = load_profile(spec)
            fitted = fit(profile, resolved)
        except MdlError as exc:
            fitted = exc
        fits[key] = fitted
    line = entry.lines.get("profile", entry.line)
    where = f"device '{entry.id}': profile {shown(entry.profile)}"
    if isinstance(fitted, MdlError):
        own = [] if key in told else fitted.diagnostics
        told.add(key)
        reasons = "; ".join(d.message for d in own if d.file is None)
        own = [d for d in own if d.file is not None]
        return [Diagnostic(str(path), line, None, f"{where}: {reasons or 'cannot be used'}"), *own]
    if fitted.ok:
        return []
    own = [] if key in told else [d for d in fit_diagnostics(str(entry.description), fitted, _functions(resolved))]
    told.add(key)
    own = [d for d in own if d.severity == "error"]
    message = f"{where}: description {shown(entry.written['description'])} does not fit it"
    return [Diagnostic(str(path), line, None, message + (":" if own else " (above)")), *own]


def _functions(resolved: ResolvedDevice) -> dict[str, object]:
    return {f.name: f for f in resolved.device.functions}


def _capped(path: Path, diagnostics: list[Diagnostic]) -> list[Diagnostic]:
    """At most MAX_SHOWN errors (with what follows each), then how many more there are."""
    out: list[Diagnostic] = []
    errors = 0
    for diag in diagnostics:
        if diag.severity == "error" and diag.file == str(path):
            errors += 1
        if errors > MAX_SHOWN:
            break
        out.append(diag)
    left = sum(1 for d in diagnostics if d.severity == "error" and d.file == str(path)) - MAX_SHOWN
    if left > 0:
        out.append(Diagnostic(str(path), None, None, f"{left} more errors not shown: correct these first"))
    return out


def _folder(path: Path) -> Path:
    """Where an inventory's relative paths start: its folder (standard input's: the current folder)."""
    return Path() if is_stdin(path) else path.parent


class _Reader:
    """Reads one inventory, collecting its errors."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.folder = _folder(path)
        self.errors: list[Diagnostic] = []

    def error(self, line: int | None, message: str, col: int | None = None, severity: str = "error") -> None:
        self.errors.append(Diagnostic(str(self.path), line, col, message, severity))

    # -- YAML ----------------------------------------------------------------------------------------------

    def yaml_rows(self) -> tuple[list[_Row], dict[str, _Cell]]:
        root = load_yaml(self.path, "an inventory (defaults:, devices:)")
        for key, item in root.value.items():
            if key not in TOP_KEYS:
                self.error(item.line, f"unknown key {shown(key)} (an inventory has {', '.join(TOP_KEYS)})")
        defaults: dict[str, _Cell] = {}
        node = root.value.get("defaults")
        if node is not None:
            if isinstance(node, Map):
                defaults = self._cells(node, DEFAULT_KEYS, "defaults")
            elif not (isinstance(node, Text) and not node.value):
                self.error(node.line, "defaults must be a mapping: {interval: S, timeout: S, retries: N}", node.col)
        devices = root.value.get("devices")
        if devices is None:
            self.error(root.line, "missing 'devices': the list of devices")
            return [], defaults
        if isinstance(devices, Text) and not devices.value:  # `devices:` and nothing: no devices (said)
            return [], defaults
        if not isinstance(devices, List):
            self.error(devices.line, "devices must be a list, a '- id: ...' item per device", devices.col)
            return [], defaults
        rows = []
        for item in devices.value:
            if not isinstance(item, Map):
                self.error(item.line, "a device must be a mapping (id:, description:, connection: ...)", item.col)
                continue
            rows.append((item.line, self._cells(item, COLUMNS, "a device")))
        return rows, defaults

    def _cells(self, node: Map, known: tuple[str, ...], what: str) -> dict[str, _Cell]:
        cells = {}
        for key, value in node.value.items():
            if key not in known:
                self.error(value.line, f"unknown key {shown(key)} in {what} (known: {', '.join(known)})")
                continue
            cell = self._cell(key, value)
            if cell is not None:
                cells[key] = cell
        return cells

    def _cell(self, key: str, node: Node) -> _Cell | None:
        if isinstance(node, Text):
            return _Cell(node.line, node.col, node.value)
        if key == "tags" and isinstance(node, Map):
            pairs = []
            for tag, value in node.value.items():
                if not isinstance(value, Text):
                    self.error(value.line, f"tag {shown(tag)} must be a text, not a list or mapping", value.col)
                    return None
                pairs.append((tag, _Cell(value.line, value.col, value.value)))
            return _Cell(node.line, node.col, pairs=tuple(pairs))
        shape = "a mapping {key: value} or key=value;key=value" if key == "tags" else "a single value"
        self.error(node.line, f"{key} must be {shape}, not a {'list' if isinstance(node, List) else 'mapping'}")
        return None

    # -- CSV -----------------------------------------------------------------------------------------------

    def csv_rows(self) -> tuple[list[_Row], dict[str, _Cell]]:
        data = read_bytes(self.path, MAX_BYTES)
        if data.startswith(b"\xef\xbb\xbf"):  # the byte order mark spreadsheets write
            data = data[3:]
        text = decode_text(data, self.path)
        reader = csv.reader(io.StringIO(text, newline=""))
        header: list[str] | None = None
        rows: list[_Row] = []
        last = 0
        while True:
            try:
                cells = next(reader)
            except StopIteration:
                break
            except csv.Error as exc:
                self.error(last + 1, f"not CSV: {exc}")
                return rows, {}
            line, last = last + 1, reader.line_num
            if not any(c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
                continue
            if header is None:
                header = self._header(line, cells)
                if header is None:
                    return [], {}
                continue
            extra = [c for c in cells[len(header) :] if c.strip()]
            if extra:
                self.error(line, f"{len(cells)} cells where the header names {len(header)} columns")
                continue
            row = {
                name: _Cell(line, None, cell.strip()) for name, cell in zip(header, cells, strict=False) if cell.strip()
            }
            rows.append((line, row))
        if header is None:
            self.error(1, f"no header row: the first row names the columns ({', '.join(REQUIRED)}, ...)")
        return rows, {}

    def _header(self, line: int, cells: list[str]) -> list[str] | None:
        names = [c.strip().lower() for c in cells]
        bad = False
        for name in names:
            if name not in COLUMNS:
                hint = "; columns are separated by commas" if any(sep in name for sep in ";\t") else ""
                self.error(line, f"unknown column {shown(name)} (the columns are {', '.join(COLUMNS)}){hint}")
                bad = True
            elif names.count(name) > 1:
                self.error(line, f"column {shown(name)} is named twice")
                return None
        missing = [name for name in REQUIRED if name not in names]
        if missing:
            self.error(line, f"no column {', '.join(missing)}: every device needs {', '.join(REQUIRED)}")
            bad = True
        return None if bad else names

    # -- entries -------------------------------------------------------------------------------------------

    def defaults(self, cells: dict[str, _Cell]) -> dict[str, float]:
        """The defaults' values (those given and valid)."""
        out: dict[str, float] = {}
        for key, cell in cells.items():
            value = self._setting(key, cell, "defaults: ")
            if value is not None:
                out[key] = value
        return out

    def _setting(self, key: str, cell: _Cell, who: str) -> float | None:
        """interval, timeout or retries, checked; None (said) if it is not one."""
        if key == "interval":
            return self._number(cell, key, who, float, *INTERVALS, "s")
        kind, low, high = SETTINGS[key]
        return self._number(cell, key, who, kind, low, high, "s" if kind is float else "")

    def _number(
        self, cell: _Cell, key: str, who: str, kind: type, low: float, high: float, unit: str = ""
    ) -> float | None:
        text = (cell.text or "").strip()
        if not (_INT if kind is int else _FLOAT).fullmatch(text):
            what = "a whole number" if kind is int else "a number"
            self.error(cell.line, f"{who}{key} {shown(text)} is not {what}", cell.col)
            return None
        value = kind(text)
        if not low <= value <= high:
            unit = f" {unit}" if unit else ""
            self.error(cell.line, f"{who}{key} {text} is not in the range {low:g} to {high:g}{unit}", cell.col)
            return None
        return float(value)

    def entry(self, line: int, row: dict[str, _Cell], defaults: dict[str, float]) -> Entry | None:
        """The row as an Entry; None (every error said) if it is not one."""
        before = len(self.errors)
        given = {key: cell for key, cell in row.items() if cell.pairs is not None or (cell.text or "").strip()}
        for key in REQUIRED:
            if key not in given:
                self.error(line, f"a device without {key}")
        ident = self._id(given.get("id"))
        who = f"device '{ident}': " if ident else ""
        written = {key: (cell.text or "").strip() for key, cell in given.items() if cell.pairs is None}
        description = self._description(given.get("description"), who)
        numbers: dict[str, float] = {}
        for key in ("interval", "timeout", "retries", "unit"):
            if key in given:
                value = (
                    self._number(given[key], key, who, int, 0, MAX_UNIT)
                    if key == "unit"
                    else self._setting(key, given[key], who)
                )
                if value is not None:
                    numbers[key] = value
        connection, url_unit = self._connection(given.get("connection"), who, given, numbers, defaults)
        if url_unit is not None and "unit" in given:
            twice = f"{who}the unit is given twice: as unit and as #{url_unit} in the connection"
            self.error(given["unit"].line, twice)
        tags = self._tags(given["tags"], who) if "tags" in given else {}
        if len(self.errors) > before or connection is None or description is None or ident is None:
            return None
        unit = int(numbers.get("unit", url_unit if url_unit is not None else 1))
        return Entry(
            ident,
            description,
            connection,
            unit,
            numbers.get("interval", defaults.get("interval", DEFAULT_INTERVAL)),
            written.get("profile") or None,
            tags,
            line,
            {key: cell.line for key, cell in given.items()},
            written,
        )

    def _id(self, cell: _Cell | None) -> str | None:
        if cell is None:
            return None
        text = (cell.text or "").strip() if cell.pairs is None else ""
        if not ID.fullmatch(text) or set(text) == {"."}:
            self.error(
                cell.line,
                f"device id {shown(text)} is not one: 1 to 64 letters, digits, '_', '.' and '-' (not only dots)",
                cell.col,
            )
            return None
        return text

    def _description(self, cell: _Cell | None, who: str) -> Path | None:
        if cell is None:
            return None
        text = (cell.text or "").strip()
        if one_line(text) != text or "\0" in text:
            self.error(cell.line, f"{who}description {shown(text)} is not a file name", cell.col)
            return None
        path = Path(text)
        return path if path.is_absolute() else self.folder / path

    def _connection(
        self,
        cell: _Cell | None,
        who: str,
        given: dict[str, _Cell],
        numbers: dict[str, float],
        defaults: dict[str, float],
    ) -> tuple[Connection | None, int | None]:
        if cell is None:
            return None, None
        url = (cell.text or "").strip()
        query = url.partition("#")[0].partition("?")[2]
        in_query = {key for key, _ in parse_qsl(query, keep_blank_values=True)}
        settings: dict[str, float | int] = {}
        for key in ("timeout", "retries"):
            if key in in_query and key in given:
                self.error(given[key].line, f"{who}{key} is given twice: as {key} and in the connection's query")
            value = numbers.get(key, defaults.get(key))
            if value is not None:
                settings[key] = int(value) if key == "retries" else value
        try:
            return parse_connection(url, **settings)
        except ValueError as exc:
            self.error(cell.line, f"{who}connection {shown(url)}: {exc}", cell.col)
            return None, None

    def _tags(self, cell: _Cell, who: str) -> dict[str, str]:
        """A device's tags: a YAML mapping, or `key=value;key=value`."""
        pairs: list[tuple[str, _Cell]] = []
        if cell.pairs is not None:
            pairs = list(cell.pairs)
        else:
            for part in (cell.text or "").split(";"):
                if not part.strip():
                    continue
                name, sep, text = part.partition("=")
                if not sep:
                    self.error(cell.line, f"{who}tag {shown(part.strip())} has no value: write key=value;key=value")
                    continue
                pairs.append((name.strip(), _Cell(cell.line, cell.col, text.strip())))
        tags: dict[str, str] = {}
        for key, value in pairs:
            text = value.text or ""
            if not TAG_KEY.fullmatch(key):
                self.error(value.line, f"{who}tag name {shown(key)} is not one: letters, digits, '_', '.' and '-'")
            elif key in tags:
                self.error(value.line, f"{who}tag {shown(key)} is given twice")
            elif one_line(text) != text or len(text) > MAX_TAG_CHARS:
                long = f"{who}tag {key}: its value must be one line of at most {MAX_TAG_CHARS} characters"
                self.error(value.line, long)
            else:
                tags[key] = text
        return tags

    # -- the inventory as a whole --------------------------------------------------------------------------

    def cross_checks(self, rows: list[_Row], entries: list[Entry]) -> None:
        """Ids unique (ignoring case); a line given one setting; one host:port spoken to in one framing; a
        device named twice (a warning)."""
        seen: dict[str, tuple[str, int]] = {}
        for line, row in rows:
            cell = row.get("id")
            text = (cell.text or "").strip() if cell is not None and cell.pairs is None else ""
            if not ID.fullmatch(text) or set(text) == {"."}:
                continue
            earlier = seen.setdefault(text.lower(), (text, line))
            if earlier[1] != line:
                case = "" if earlier[0] == text else f" (as '{earlier[0]}': ids are compared ignoring case)"
                self.error(line, f"device id '{text}' is given twice: first at line {earlier[1]}{case}")
        lines: dict[tuple[str, ...], Entry] = {}
        framing: dict[tuple[str, int], Entry] = {}
        devices: dict[tuple[object, ...], Entry] = {}
        for entry in entries:
            conn = entry.connection
            at = entry.lines.get("connection", entry.line)
            bus = shared_line(conn)
            if bus is not None:
                first = lines.setdefault(bus, entry)
                if line_settings(conn) != line_settings(first.connection):
                    self.error(
                        at,
                        f"device '{entry.id}' gives the line {_line_name(conn)} {_settings(conn)}, but device "
                        f"'{first.id}' (line {first.line}) gives it {_settings(first.connection)}: a line has one "
                        "setting; give them the same",
                    )
            if conn.serial is None:
                where = (conn.host.lower(), conn.port)
                other = framing.setdefault(where, entry)
                if other.connection.rtu != conn.rtu:
                    self.error(
                        at,
                        f"device '{entry.id}' speaks {_framing(conn)} to {host_port(conn.host, conn.port)}, but device "
                        f"'{other.id}' (line {other.line}) speaks {_framing(other.connection)}: a port speaks one",
                    )
            device = (*(bus or ("tcp", conn.host.lower(), str(conn.port))), entry.unit)
            twin = devices.setdefault(device, entry)
            if twin is not entry:
                same = f"device '{entry.id}' is the same device as '{twin.id}' (line {twin.line}): "
                same += f"{conn} unit {entry.unit}"
                self.error(entry.line, same, severity="warning")


def _settings(conn: Connection) -> str:
    line = f"{conn.baud} {conn.bytesize}{conn.parity}{conn.stopbits}, " if conn.serial is not None else ""
    return f"({line}timeout {conn.timeout:g} s, retries {conn.retries})"


def _line_name(conn: Connection) -> str:
    return conn.serial if conn.serial is not None else f"{host_port(conn.host, conn.port)} (RTU over TCP)"


def _framing(conn: Connection) -> str:
    return "RTU over TCP" if conn.rtu else "Modbus TCP"
