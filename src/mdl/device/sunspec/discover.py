"""`mdl discover --sunspec` (SPEC 12): walk a live device's SunSpec chain and build the document of it.

The marker `SunS` is looked for at 40000, then 0, then 50000 (a base that gives an exception, no clean
reply or other registers is skipped, and said). From the marker the chain is walked model by model with
one request per model header (ID and L, 2 registers) until ID 0xFFFF. A model pysunspec2 ships gets the
repeat count of its repeating groups from L (`fit`: the one count whose chain length is L; every
repeating group of a model takes the same count, as `mdl import --repeat` builds them); its count points
are then read (one small request) and must say that count. A model pysunspec2 does not know, or whose L
fits no count or whose count points disagree with L, is kept as raw UINT16 registers `<id>_reg_<n>`,
with a warning. The document is `build_chain` of exactly the models found at the base found, so `mdl sim`
of it serves the same layout.

A device that answers garbage is refused (DeviceError, exit 3): a length that runs past 65535, a chain
that wraps around to an address it visited (a loop), no end marker before the address space ends or
where the device stops answering, more than MAX_MODELS models. Replies are checked by the session
(mdl.device.runtime) before they are trusted; late bytes are dropped as `mdl discover` drops them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mdl.device.connection import Connection
from mdl.device.link import Link, ModbusExceptionError
from mdl.device.replies import LineLost
from mdl.device.survey.discover import _say, _Unit
from mdl.diagnostics import DeviceError, Diagnostic
from mdl.formats.sunspec.build import BASES, END_ID, SUNS, _count_points, build_chain
from mdl.formats.sunspec.models import TYPE_REGISTERS, ModelDef, load_model, models_dir
from mdl.formats.sunspec.read import DEFAULT_REPEAT
from mdl.model import Device
from mdl.model.layout import MAX_ADDRESS, MAX_REGISTERS
from mdl.plan import Request

MAX_MODELS = 200  # a real device holds a few dozen models; more is a device answering garbage
HEADER = 2  # a model's ID and L
ADDRESSES = MAX_ADDRESS + 1
COMMAND = "mdl discover"
RAW = "mdl_raw"  # marks a raw_model definition (no SunSpec definition has this key)


@dataclass(frozen=True)
class Found:
    """A model header of the chain: where its ID is, the ID and L (registers after ID and L)."""

    address: int
    model_id: int
    length: int


def _registers(point: dict[str, Any]) -> int:
    return TYPE_REGISTERS[point["type"]] or int(point["size"])


def group_length(group: dict[str, Any], repeat: int) -> int:
    """Registers of `group` as `build_chain` lays it out with `repeat` instances of each repeating group
    (a group of a fixed count that many times, one without a count once)."""
    total = sum(_registers(p) for p in group.get("points", []))
    for sub in group.get("groups", []):
        count = sub.get("count")
        times = 1 if count is None else count if isinstance(count, int) and count > 0 else repeat
        total += times * group_length(sub, repeat)
    return total


def fit(model: ModelDef, length: int) -> int | None:
    """The repeat count whose chain gives the model `length` registers after ID and L (DEFAULT_REPEAT for a
    model without repeating groups), or None when no count does. The length grows with the count (every
    repeating group has a point), so the one count is found by bisection."""

    def size(repeat: int) -> int:
        return group_length(model["group"], repeat) - HEADER

    if size(0) == size(1):
        return DEFAULT_REPEAT if size(0) == length else None
    low, high = 0, max(length, 0)
    while low < high:
        middle = (low + high) // 2
        if size(middle) < length:
            low = middle + 1
        else:
            high = middle
    return low if size(low) == length else None


def count_points(model: ModelDef) -> dict[str, int]:
    """The model's count points (named by a group's count, or of type `count` at the top level, which
    `build_chain` sets to the repeat count) -> their offset from the model's ID register."""
    group = model["group"]
    names = _count_points(group) | {p["name"] for p in group.get("points", []) if p["type"] == "count"}
    offsets, at = {}, 0
    for point in group.get("points", []):
        if point["name"] in names:
            offsets[point["name"]] = at
        at += _registers(point)
    return offsets


def raw_model(model_id: int, length: int) -> ModelDef:
    """A model of `length` plain registers `reg_1`..: what is kept of a model that cannot be built from its
    definition."""
    points = [{"name": "ID", "type": "uint16"}, {"name": "L", "type": "uint16"}]
    points += [
        {"name": f"reg_{n}", "type": "uint16", "label": f"Register {n} of model {model_id} (raw)"}
        for n in range(1, length + 1)
    ]
    return {"id": model_id, RAW: True, "group": {"name": f"raw_model_{model_id}", "points": points}}


class _Walk:
    """The requests of one walk (holding registers of one unit), counted; late bytes of another reply are
    dropped and the request asked again, as `mdl discover` does."""

    def __init__(self, session: Link, unit: int) -> None:
        self.session, self.asker = session, _Unit(session, unit)
        self.requests = 0
        self.warnings: list[str] = []

    def read(self, start: int, count: int) -> list[int]:
        self.requests += 1
        return self.asker._read_request(Request("holding", start, count, ()))

    def refuse(self, problem: str) -> DeviceError:
        return DeviceError(self.session.where(f"not a SunSpec chain: {problem}"))

    def warn(self, message: str) -> None:
        self.warnings.append(message)

    def base(self) -> int:
        """The first base holding `SunS`; DeviceError naming what each base gave otherwise (the first
        failure itself when no base got a clean reply: the device does not answer)."""
        tried: list[str] = []
        failures: list[DeviceError] = []
        for base in BASES:
            try:
                regs = self.read(base, len(SUNS))
            except ModbusExceptionError as exc:
                tried.append(f"{base}: exception {exc.code}")
                continue
            except LineLost:
                raise
            except DeviceError as exc:
                failures.append(exc)
                tried.append(f"{base}: no clean reply")
                self.asker._settle()
                continue
            if tuple(regs) == SUNS:
                return base
            tried.append(f"{base}: {' '.join(f'0x{r:04X}' for r in regs)}")
        if len(failures) == len(BASES):
            raise failures[0]
        raise DeviceError(
            self.session.where(
                f"no SunSpec marker 'SunS' (0x5375 0x6E53) at 40000, 0 or 50000 ({'; '.join(tried)}): "
                "not a SunSpec device, or another --unit"
            )
        )

    def chain(self, base: int, say: Callable[[str], None]) -> tuple[list[Found], int]:
        """The model headers from `base` to the end marker, and the end marker's address."""
        found: list[Found] = []
        at = {base: "the marker 'SunS'"}
        address = base + len(SUNS)
        while True:
            after = f"after {len(found)} model{'s' * (len(found) != 1)}"
            if address + HEADER > ADDRESSES:
                raise self.refuse(f"no end marker (model ID 0xFFFF) before the address space ends ({after})")
            if len(found) == MAX_MODELS:
                raise self.refuse(f"more than {MAX_MODELS} models before {address}, with no end marker")
            try:
                model_id, length = self.read(address, HEADER)
            except ModbusExceptionError as exc:
                problem = exc.diagnostics[0].message
                raise self.refuse(f"no end marker: the chain breaks off at {address} ({after}): {problem}") from None
            if model_id == END_ID:
                if length:
                    self.warn(f"the end marker at {address} has L {length}, not 0: the document serves 0")
                return found, address
            at[address] = f"where model {model_id} is"
            following = address + HEADER + length
            if following > ADDRESSES:
                wrapped = following % ADDRESSES
                where = f"model {model_id} at {address} has L {length}"
                if wrapped in at:
                    raise self.refuse(f"the chain loops: {where}, which wraps around to {wrapped}, {at[wrapped]}")
                raise self.refuse(f"{where}, which runs past {MAX_ADDRESS} (to {following - 1})")
            say(f"model {model_id} at {address}, L {length}")
            found.append(Found(address, model_id, length))
            address = following

    def model(self, header: Found) -> tuple[ModelDef, int]:
        """The definition to build `header`'s model from, with its repeat count (raw registers, with a
        warning, where pysunspec2 has no definition or it does not fit)."""
        mid, length = header.model_id, header.length
        where = f"model {mid} at {header.address} (L {length})"
        if not (models_dir() / f"model_{mid}.json").is_file():
            self.warn(f"{where}: pysunspec2 does not define model {mid}: kept as {length} raw registers")
            return raw_model(mid, length), 0
        model = load_model(str(mid))
        repeat = fit(model, length)
        if repeat is None:
            fixed = group_length(model["group"], 0) - HEADER
            self.warn(
                f"{where}: no repeat count gives this length (the definition: {fixed} registers, more for "
                f"each repeat): kept as {length} raw registers"
            )
            return raw_model(mid, length), 0
        wrong = self._counts(header, model, repeat)
        if wrong:
            self.warn(f"{where}: {wrong}, but L means {repeat}: kept as {length} raw registers")
            return raw_model(mid, length), 0
        return model, repeat

    def _counts(self, header: Found, model: ModelDef, repeat: int) -> str | None:
        """What the model's count points say where it is not `repeat` (read in one request when they are
        close, as they are in every shipped model), or None."""
        offsets = count_points(model)
        if not offsets or group_length(model["group"], 0) == group_length(model["group"], 1):
            return None
        first, last = min(offsets.values()), max(offsets.values())
        start = header.address + first
        try:
            if last - first < MAX_REGISTERS:
                regs = self.read(start, last - first + 1)
                values = {name: regs[offset - first] for name, offset in offsets.items()}
            else:
                values = {name: self.read(header.address + o, 1)[0] for name, o in offsets.items()}
        except ModbusExceptionError as exc:
            problem = exc.diagnostics[0].message
            raise self.refuse(f"model {header.model_id} at {header.address}: its count points: {problem}") from None
        wrong = [f"{name} reads {value}" for name, value in values.items() if value != repeat]
        return ", ".join(wrong) or None


# model 1's texts -> the device identity elements they fill (SPEC 2.2; `mdl sim` answers MEI 14 with them)
IDENTITY = (("1_Mn", "manufacturer"), ("1_Md", "product"), ("1_Vr", "product_version"))


def _identity(walk: _Walk, device: Device) -> None:
    """The device's identity from model 1 (Mn, Md, Vr): set as the document's manufacturer, product and
    version, and as the texts' `initial` registers, so that `mdl sim` of the document serves them and a
    second discovery writes the same file. A text that is not printable ASCII is left out with a warning."""
    by_name = {fn.name: fn for fn in device.functions}
    for name, element in IDENTITY:
        fn = by_name.get(name)
        if fn is None or not fn.addresses or not fn.count:
            continue
        words = walk.read(fn.addresses[0], fn.count)
        text = b"".join(w.to_bytes(2, "big") for w in words).rstrip(b"\0 ").decode("latin-1")
        if not text:
            continue
        if not all(" " <= ch <= "~" for ch in text):
            walk.warn(f"{name} holds {text[:40]!r}, not printable ASCII: left out of the document's identity")
            continue
        setattr(device, element, text)
        fn.initial = list(words)


def discover_sunspec(connection: Connection, unit: int) -> Device:
    """The document of the SunSpec chain unit `unit` serves over `connection` (progress on stderr);
    DeviceError (exit 3) when there is none or it is garbage, or the device cannot be reached."""

    def say(message: str) -> None:
        _say(message, COMMAND)

    session = Link(connection, unit)
    walk = _Walk(session, unit)
    with session:
        say(f"looking for a SunSpec chain on {connection} unit {unit}")
        base = walk.base()
        say(f"SunSpec marker 'SunS' at {base}")
        headers, end = walk.chain(base, say)
        models = [walk.model(h) for h in headers]
        device = build_chain(models, base)
        _identity(walk, device)
    raw = {str(m["group"]["name"]) for m, _ in models if m.get(RAW)}
    for fn in device.functions:
        if fn.block_labels and fn.block_labels[0] in raw and not fn.system:
            fn.not_implemented = None  # a raw register has no "not implemented" value
    if device.functions[-2].addresses != [end]:
        raise AssertionError(f"the chain built ends at {device.functions[-2].addresses}, the device's at {end}")
    ids = ", ".join(str(h.model_id) for h in headers)
    device.description = f"SunSpec chain at {base}: models {ids or 'none'} (mdl discover --sunspec)"
    device.notes[:0] = [Diagnostic(None, None, None, w, "warning") for w in walk.warnings]
    say(
        f"{len(headers)} model{'s' * (len(headers) != 1)} at {base} ({ids or 'none'}), end marker at {end}; "
        f"{walk.requests} requests"
    )
    return device
