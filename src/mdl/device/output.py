"""Printing values read from a device: table, json, csv, senml; once (`render`) or as a poll's records
(`record_header` once, then `record` per poll); and the WISE-Agent guide's SenML capability document
without a device (`mdl export --to senml`). The SenML shape has this one home.

The table shows a number with the function's `precision` (decimal places; negative rounds left of the
point: 1234 with -1 shows 1230); csv and senml print values as read; the table, csv and senml show a FLOAT32
as the shortest decimal that reads back as the same float32 (`shortest_float32`), json the exact double the
drivers return (programs compare it with a driver's value). A NaN or an infinity is `nan`,
`inf`, `-inf` in the table and csv, those strings in json (which has no number for them), and no `v` in senml.
"""

from __future__ import annotations

import functools
import io
import json
import math
import operator
import struct
from collections import Counter
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from typing import Any, TypedDict, cast

from mdl.exchange.text import aligned
from mdl.model import Function, Value


class Block(TypedDict):
    """One SenML record pack: the block's name and its entries."""

    bn: str
    e: list[dict[str, Value]]


def shown(fn: Function, value: Value, exact: bool = False) -> Value:
    """The value as users see it: enumeration text where `values` names it; a FLOAT32 read as it is as
    the shortest decimal that reads back as the same float32 (230.1, not 230.10000610351562), unless
    `exact` (json: the double the drivers return, for programs that compare)."""
    if fn.values and isinstance(value, (int, float)) and not isinstance(value, bool):
        if float(value).is_integer() and int(value) in fn.values:
            return fn.values[int(value)]
    if not exact and isinstance(value, float) and _plain_float32(fn):
        return shortest_float32(value)
    return value


def _plain_float32(fn: Function) -> bool:
    """Whether the function's value is a float32 as the registers hold it (no arithmetic in doubles after)."""
    return (
        fn.format == "FLOAT32"
        and fn.multiplier in (None, 1.0)
        and not fn.offset
        and fn.expression is None
        and fn.read_function_code is None
    )


_FLOAT32 = struct.Struct(">f")


def shortest_float32(value: float) -> float:
    """The double of the fewest significant digits that rounds to the same float32 as `value` (which is one):
    printed, it shows what mbpoll shows; read back as a float32, it is the same bits. NaN and infinities,
    zeros (either sign), and a value no float32 holds, as they are."""
    if value == 0 or not math.isfinite(value):
        return value  # before the cache: it keys -0.0 and 0.0 as one (they are equal), and NaN as none
    return _shortest_float32(value)


_FLOAT32_NORMAL = 2.0**-126  # the least normal float32's magnitude
_FLOAT32_DIG = 6  # C's FLT_DIG: two decimals of this many significant digits are never one float32


@functools.lru_cache(maxsize=4096, typed=True)  # a poll's readings mostly repeat the last poll's
def _shortest_float32(value: float) -> float:
    try:
        bits = _FLOAT32.pack(value)
    except OverflowError:
        return value
    if _FLOAT32.unpack(bits)[0] != value:
        return value
    if abs(value) >= _FLOAT32_NORMAL:
        # A normal float32 is closer to its neighbours than any two 6-digit decimals are to each other, so at
        # most one 6-digit decimal reads back as it, the nearest: if a shorter text does, it is that decimal
        # too, and if the nearest does not, no shorter text does. One try, where most values need 4 to 6
        # digits (tests/fuzz/test_fuzz_float32_text.py holds it equal to trying 1, 2 ... digits).
        candidate = float(f"{value:.{_FLOAT32_DIG}g}")
        if _FLOAT32.pack(candidate) == bits:
            return candidate
        first = _FLOAT32_DIG + 1
    else:  # a subnormal: its neighbours are as far apart as at the least normal, its digits fewer
        first = 1
    for digits in range(first, 10):  # 9 significant digits always identify a float32
        candidate = float(f"{value:.{digits}g}")
        try:
            if _FLOAT32.pack(candidate) == bits:
                return candidate
        except OverflowError:  # rounded past the largest float32
            continue
    return value


def _json_value(value: Value) -> Value:
    """A value JSON can hold: NaN and the infinities, which JSON has no number for, as the strings "nan", "inf",
    "-inf" (null is taken: it is a value the device does not have)."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def json_value(fn: Function, value: Value) -> Value:
    """A value as json records carry it (and MQTT payloads, mdl.device.fleet.mqtt)."""
    return _json_value(shown(fn, value, exact=True))


def _json_values(functions: list[Function], values: dict[str, Value]) -> dict[str, Value]:
    out: dict[str, Value] = {}
    for fn in functions:  # json_value of each, written out for a value without labels (a poll's cost)
        value = values[fn.name]
        if fn.values:
            value = json_value(fn, value)
        elif isinstance(value, float) and not math.isfinite(value):
            value = _json_value(value)
        out[fn.name] = value
    return out


def _csv_line(cells: list[str]) -> str:
    """One CSV record ending in `\n`; a cell holding a carriage return is quoted too (csv quotes only the
    line terminator's own characters, and a bare `\r` ends a row for most readers)."""
    import csv  # here: a one-shot read that prints a table starts without it

    buf = io.StringIO()
    if any("\r" in cell for cell in cells):
        csv.writer(buf, lineterminator="\n", quoting=csv.QUOTE_ALL).writerow(cells)
    else:
        csv.writer(buf, lineterminator="\n").writerow(cells)
    return buf.getvalue()


def _cell(value: Value) -> str:
    return "" if value is None else _text(value)


def shown_text(fn: Function, value: Value) -> str:
    """The table's text of a value: shown (enumeration text), numbers with the function's precision."""
    value = shown(fn, value, exact=fn.precision is not None)  # precision rounds the exact value, once
    if fn.precision is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
        return with_precision(value, fn.precision)
    return _text(value)


MAX_PLACES = 30  # more decimal places than a double has digits show nothing more: the display stops here


def with_precision(value: int | float, places: int) -> str:
    """`value` with `places` decimal places (21.456, 2 -> 21.46); negative places round left of the point
    (1234, -1 -> 1230). The exact value is rounded, ties to the even digit; zero never shows a sign; NaN and
    infinities as they are."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    from decimal import ROUND_HALF_EVEN, Context, Decimal, localcontext  # here: as csv above

    places = max(min(places, MAX_PLACES), -400)  # a double is below 1e309: 400 places left round it to 0
    with localcontext(Context(prec=1000, rounding=ROUND_HALF_EVEN)):
        rounded = Decimal(value).quantize(Decimal(1).scaleb(-places))
    return f"{rounded.copy_abs() if rounded.is_zero() else rounded:f}"


def _text(value: Value) -> str:
    kind = type(value)
    if kind is int or kind is float or kind is str:  # most values: their str
        return str(value)
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return ", ".join(value)
    return str(value)


def _bound(value: float) -> int | float:
    """A minimum or maximum as the guide writes it: 5, not 5.0."""
    return int(value) if value.is_integer() and abs(value) < 2**53 else value


def access_mode(fn: Function) -> str:
    """The guide's `asm`: r, w or rw."""
    return ("r" if fn.readable else "") + ("w" if fn.writable else "") or "r"


def _entry(fn: Function, n: str) -> dict[str, Value]:
    """A function's SenML entry without its value: n, u, min, max, asm."""
    entry: dict[str, Value] = {"n": n}
    if fn.units and fn.units.strip():
        entry["u"] = fn.units.strip()
    for key in ("minimum", "maximum"):
        bound = getattr(fn, key)
        if bound is not None:
            entry[key[:3]] = _bound(bound)
    entry["asm"] = access_mode(fn)
    return entry


def _with_value_items(n: str, rest: dict[str, Value], value: Value) -> dict[str, Value]:
    """_with_value of an entry given as its name and the items after it (the same keys, written out: a
    poll's records make hundreds of these)."""
    kind = type(value)
    if kind is bool:
        return {"n": n, "bv": value, **rest}
    if kind is int or (kind is float and math.isfinite(value)):  # type: ignore[arg-type]
        return {"n": n, "v": value, **rest}
    if kind is list:
        return {"n": n, "sv": ", ".join(value), **rest}  # type: ignore[arg-type]
    if kind is str:
        return {"n": n, "sv": value, **rest}
    return _with_value({"n": n, **rest}, value)  # null, NaN, infinities: no value key


def _with_value(entry: dict[str, Value], value: Value) -> dict[str, Value]:
    """The entry with its value after `n`: `bv` for a bool, `v` a number, `sv` text (a bitset's labels joined);
    none for a null, nor for a NaN or an infinity (SenML's `v` is a JSON number, and JSON has none for them)."""
    key: str | None = None
    if isinstance(value, bool):
        key = "bv"
    elif isinstance(value, (int, float)):
        key = None if isinstance(value, float) and not math.isfinite(value) else "v"
    elif isinstance(value, list):
        key, value = "sv", ", ".join(value)
    elif value is not None:
        key = "sv"
    if key is None:
        return entry
    n, *rest = entry.items()
    return dict([n, (key, value), *rest])


def _blocks(
    functions: list[Function], device_name: str, entry: Callable[[Function, str], dict[str, Value]]
) -> dict[str, Block]:
    """One record pack per block label (the device's name for functions without one), in order of appearance.
    An entry's `n` is the function's name inside its block (`Status.Mode` -> `Mode` in block Status); where
    two functions of a block have the same such name, both keep their whole names."""
    inside = Counter((fn.block, fn.field_id) for fn in functions)
    out: dict[str, Block] = {}
    for fn in functions:
        block = fn.block or device_name
        n = fn.field_id if inside[(fn.block, fn.field_id)] == 1 else fn.name
        out.setdefault(block, {"bn": block, "e": []})["e"].append(entry(fn, n))
    return out


def senml(functions: list[Function], values: dict[str, Value], device_name: str) -> dict[str, Block]:
    """The WISE-Agent guide's JSON of values read: one object per block label, {"bn": block, "e": [entries]},
    each entry n, v|bv|sv, u, min, max, asm."""
    return _blocks(functions, device_name, lambda fn, n: _with_value(_entry(fn, n), shown(fn, values[fn.name])))


def capability(functions: list[Function], device_name: str) -> dict[str, Block]:
    """The guide's capability document: the same objects as `senml`, each entry n, u, min, max, asm, no value."""
    return _blocks(functions, device_name, _entry)


def render(functions: list[Function], values: dict[str, Value], fmt: str, device_name: str = "") -> str:
    if fmt == "senml":
        return json.dumps(senml(functions, values, device_name), indent=2, ensure_ascii=False) + "\n"
    if fmt == "json":
        return json.dumps(_json_values(functions, values), indent=2, ensure_ascii=False) + "\n"
    if fmt == "csv":
        rows = [[fn.name, _cell(shown(fn, values[fn.name])), (fn.units or "").strip()] for fn in functions]
        return "".join(_csv_line(row) for row in [["name", "value", "units"], *rows])
    return _table([(fn.name, shown_text(fn, values[fn.name]), (fn.units or "").strip()) for fn in functions])


def _table(rows: list[tuple[str, str, str]]) -> str:
    """Lines `name  value units`, names padded to the longest."""
    lines = aligned([(name, f"{text}{' ' + units if units else ''}") for name, text, units in rows])
    return "\n".join(lines) + ("\n" if lines else "")


TIME_KEY = "time"  # the key (json), column (csv) and first row (table) of a poll record's time


def iso_time(when: datetime) -> str:
    """ISO 8601 UTC to the millisecond: 2026-11-23T05:00:00.123Z."""
    when = when.astimezone(timezone.utc)
    return f"{when:%Y-%m-%dT%H:%M:%S}.{when.microsecond // 1000:03d}Z"


def record_header(functions: list[Function], fmt: str) -> str:
    """What a poll prints once before its records: csv's header (time, then the function names)."""
    return _csv_line([TIME_KEY, *(fn.name for fn in functions)]) if fmt == "csv" else ""


_PLAIN, _LABELLED, _FLOAT32_SHOWN, _PRECISION = range(4)  # how a record shows a function's value
MEMO_MOST = 8  # texts a plan remembers per function (a poll's readings mostly repeat the last polls')
AFRESH_POLLS = 15  # polls whose texts are made without the memos once most of a poll's were new


class _Plan:
    """What every record of one poll's functions repeats, worked out once (a poll prints hundreds of records
    of the same functions): how each value is shown, the table's padded names and units, the SenML blocks
    with each entry's fixed part."""

    def __init__(self, functions: list[Function], device_name: str) -> None:
        self.functions, self.device_name = functions, device_name
        self.members = list(functions)  # the list's content when planned (a list is mutable)
        self.names = [fn.name for fn in functions]
        # a record's values, in the list's order, taken from the values read at once
        self.take: Callable[[dict[str, Value]], Sequence[Value]] = (
            operator.itemgetter(*self.names) if len(self.names) > 1 else lambda values: [values[n] for n in self.names]
        )
        self.kinds = [
            _PRECISION
            if fn.precision is not None
            else _LABELLED
            if fn.values
            else _FLOAT32_SHOWN
            if _plain_float32(fn)
            else _PLAIN
            for fn in functions
        ]
        width = max((len(n) for n in [TIME_KEY, *self.names]), default=4)
        self.table_names = [f"{n:<{width}}  " for n in self.names]
        self.table_units = [f" {u}" if (u := (fn.units or "").strip()) else "" for fn in functions]
        self.time_row = f"{TIME_KEY:<{width}}  "
        # the table's rows joined at once: name, value (None here), units and the line's end, row after row
        self.table_parts: list[str | None] = [None] * (3 * len(functions))
        self.table_parts[0::3] = self.table_names
        self.table_parts[2::3] = [units + "\n" for units in self.table_units]
        # the values shown otherwise than as they are: float32 as their shortest decimal, and the rest
        self.float32 = [i for i, kind in enumerate(self.kinds) if kind == _FLOAT32_SHOWN]
        self.special = [i for i, kind in enumerate(self.kinds) if kind in (_LABELLED, _PRECISION)]
        self.blocks: list[tuple[str, list[tuple[int, str, dict[str, Value]]]]] = []
        # each block's JSON around its entries, and each entry's JSON before and after a number value `v`
        self.senml: list[tuple[str, list[int], list[str], list[str]]] = []
        for label, block in _blocks(functions, device_name, _entry_at(functions)).items():
            entries = []
            for e in block["e"]:
                i = cast(int, e.pop("i"))
                n = str(e.pop("n"))
                entries.append((i, n, e))
            self.blocks.append((label, entries))
            head = f"{_dumps(label)}: {{{_dumps('bn')}: {_dumps(label)}, {_dumps('bt')}: "
            self.senml.append(
                (
                    head,
                    [i for i, _, _ in entries],
                    [f"{{{_dumps('n')}: {_dumps(n)}, {_dumps('v')}: " for _, n, _ in entries],
                    [", " + _dumps(rest)[1:] if rest else "}" for _, _, rest in entries],
                )
            )
        # each block's entries joined at once: before, the value (None here), after and ", " but after the last
        self.senml_parts: list[tuple[str, list[int], list[str | None]]] = []
        for head, at, before, after in self.senml:
            parts: list[str | None] = [None] * (3 * len(at))
            parts[0::3] = before
            parts[2::3] = [*(a + ", " for a in after[:-1]), *after[-1:]]
            self.senml_parts.append((head, at, parts))
        self.unlabelled = not any(fn.values for fn in functions)  # no label: a number is shown as a number
        self.shows_float32 = [kind == _FLOAT32_SHOWN for kind in self.kinds]
        # json written out, where each name is a key once: each key's JSON after the one before ("time" first),
        # then its value (None here)
        self.json_fast = len(set(self.names)) == len(self.names) and TIME_KEY not in self.names
        self.json_parts: list[str | None] = [None] * (2 * len(functions))
        self.json_parts[0::2] = [f", {_dumps(n)}: " for n in self.names]
        # the text of each value printed before, by function (`_texts`): exact (json) and shown (the others),
        # for the types of the values it was last asked for
        self.types: list[type] | None = None
        self.numbers = self.texty = False  # those types: int and float only; int, float and str only
        self.memos: tuple[list[dict[Value, str]], list[dict[Value, str]]] = ([], [])
        self.floats_at: list[int] = []  # where those types are float
        self.afresh = 0
        self.looked_up = False

    def remember(self, types: list[type]) -> None:
        """Start remembering texts of values of these types (one a function), forgetting the others: a text is
        found by its value, and values of other types can be equal (1 == 1.0 == True) and print otherwise."""
        self.types = types
        self.numbers = _NUMBER_TYPES.issuperset(types)
        self.texty = self.numbers or _STR_TYPES.issuperset(types)
        self.memos = ([{} for _ in types], [{} for _ in types])
        self.floats_at = [i for i, kind in enumerate(types) if kind is float]
        self.afresh = 0  # texts to make without the memos, for this many more polls (`_texts`)
        self.looked_up = False  # whether the memos hold a poll's texts (the first poll finds none)

    def shown(self, i: int, value: Value) -> Value:
        kind = self.kinds[i]
        if kind == _PLAIN or value is None or isinstance(value, bool):
            return value
        return shown(self.functions[i], value)


def _entry_at(functions: list[Function]) -> Callable[[Function, str], dict[str, Value]]:
    """_entry, with the function's index (the plan's) under the key "i"."""
    index = {id(fn): i for i, fn in enumerate(functions)}
    return lambda fn, n: {**_entry(fn, n), "i": index[id(fn)]}


# by the functions list's identity; the plan holds the list and its members, and is made again when the
# list holds other functions (the Function objects themselves are taken as they were: a poll never changes them)
_PLANS: dict[tuple[int, str], _Plan] = {}
MAX_PLANS = 1024  # a fleet polls this many devices before plans are made again


def _plan(functions: list[Function], device_name: str) -> _Plan:
    key = (id(functions), device_name)
    plan = _PLANS.get(key)
    # the members compared as a list: each one the same object is equal at once, without a call
    if plan is None or plan.functions is not functions or plan.members != functions:
        if len(_PLANS) >= MAX_PLANS:  # the oldest plan goes
            _PLANS.pop(next(iter(_PLANS)))
        plan = _PLANS[key] = _Plan(functions, device_name)
    return plan


def _csv_cells(cells: list[str]) -> str:
    """_csv_line, joined directly where no cell needs quotes (most records)."""
    line = ",".join(cells)
    if line.count(",") != len(cells) - 1 or '"' in line or "\n" in line or "\r" in line:
        return _csv_line(cells)
    return line + "\n"


def _dumps(value: object) -> str:
    return json.dumps(value, ensure_ascii=False)


_STR_TYPES = frozenset((int, float, str))  # values whose text, in csv and table, is their str
_NUMBER_TYPES = frozenset((int, float))  # values whose text in every format is their str (if finite)


def _texts(plan: _Plan, got: Sequence[Value], shown: bool) -> tuple[list[str], bool] | None:
    """Each value's text, and whether every number is finite, where every value is an int or a float (or, if
    `shown`, a text): its str, or if `shown` a float32's shortest decimal's where the function shows one
    (labels and precisions are the caller's); None where another type is there. A text printed before for the
    same value of the function, of the same type, is taken from the plan (MEMO_MOST at most per function;
    never for a zero of a float, whose two signs are equal values and print otherwise, nor for a NaN)."""
    types = list(map(type, got))
    if types != plan.types:
        plan.remember(types)
    if not (plan.texty if shown else plan.numbers):
        return None
    if plan.afresh:  # values mostly new of late: each value's str made at once, then each float32's shown
        plan.afresh -= 1
        texts: list[Any] = list(map(str, got))
        if shown:
            for i in plan.float32:
                if type(got[i]) is float:
                    texts[i] = str(shortest_float32(got[i]))  # type: ignore[arg-type]
        floats = cast("list[float]", list(map(got.__getitem__, plan.floats_at)))
        return texts, all(map(math.isfinite, floats))
    memos = plan.memos[shown]
    texts = list(map(dict.get, memos, got))
    finite = True
    if not all(texts):  # some printed afresh (or a text that is empty)
        if plan.looked_up and 2 * texts.count(None) > len(texts):
            plan.afresh = AFRESH_POLLS  # most are new: looking each up costs more than it saves
        float32 = plan.shows_float32
        i = -1
        while True:
            try:
                i = texts.index(None, i + 1)
            except ValueError:  # no more
                break
            value = got[i]
            if type(value) is float:
                if shown and float32[i]:
                    text = str(shortest_float32(value))
                else:
                    text = str(value)
                if not math.isfinite(value):
                    finite = False
                    texts[i] = text
                    continue
                if not value:  # 0.0 or -0.0
                    texts[i] = text
                    continue
            else:
                text = str(value)
            memo = memos[i]
            if len(memo) >= MEMO_MOST:
                memo.clear()
            memo[value] = texts[i] = text
    plan.looked_up = True
    return texts, finite


def _senml_record(plan: _Plan, got: Sequence[Value], when: datetime) -> str | None:
    """The senml record written out where every value is a finite number shown as itself (most polls):
    None otherwise."""
    if not plan.unlabelled:
        return None
    found = _texts(plan, got, True)
    if found is None or not plan.numbers or not found[1]:  # a text, a NaN or an infinity
        return None
    texts = found[0]
    for i in plan.special:
        texts[i] = repr(plan.shown(i, got[i]))
    bt = f"{round(when.timestamp(), 3)!r}, {_dumps('e')}: ["
    blocks = []
    for head, at, template in plan.senml_parts:
        parts = template.copy()
        parts[1::3] = texts if len(at) == len(texts) else [texts[i] for i in at]  # one block: every entry, in order
        blocks.append(head + bt + "".join(parts) + "]}")  # type: ignore[arg-type]  # every part a text now
    return "{" + ", ".join(blocks) + "}\n"


def _number_texts(plan: _Plan, got: Sequence[Value], text: Callable[[_Plan, int, Value], str]) -> list[str] | None:
    """csv's and table's texts of the values where every value is an int, a float or a text (most polls), with
    `text` of those labelled or with a precision; None otherwise."""
    found = _texts(plan, got, True)
    if found is None:
        return None
    texts = found[0]
    for i in plan.special:
        texts[i] = text(plan, i, got[i])
    return texts


def record(functions: list[Function], values: dict[str, Value], fmt: str, when: datetime, device_name: str = "") -> str:
    """One poll's record, ending with a newline: json one object on one line, time first; csv one row, time
    first; table a block (a time row, the values, a blank line); senml one document on one line, each
    block with `bt`, the time in seconds since 1970 (UTC)."""
    plan = _plan(functions, device_name)
    got = plan.take(values)
    if fmt == "json":
        if plan.unlabelled and plan.json_fast:  # finite numbers, each as it is: their JSON is their str
            found = _texts(plan, got, False)
            if found is not None and found[1]:
                parts = plan.json_parts.copy()
                parts[1::2] = found[0]
                return f'{{"{TIME_KEY}": "{iso_time(when)}"' + "".join(parts) + "}\n"  # type: ignore[arg-type]
        if plan.unlabelled:  # each value as it is, but NaN and the infinities (allow_nan: ValueError)
            try:
                numbers = {TIME_KEY: iso_time(when), **dict(zip(plan.names, got, strict=True))}
                return json.dumps(numbers, ensure_ascii=False, allow_nan=False) + "\n"
            except ValueError:
                pass
        return json.dumps({TIME_KEY: iso_time(when), **_json_values(functions, values)}, ensure_ascii=False) + "\n"
    if fmt == "senml":
        fast = _senml_record(plan, got, when)
        if fast is not None:
            return fast
        bt = round(when.timestamp(), 3)
        doc: dict[str, Any] = {
            label: {"bn": label, "bt": bt, "e": [_with_value_items(n, rest, plan.shown(i, got[i])) for i, n, rest in e]}
            for label, e in plan.blocks
        }
        return json.dumps(doc, ensure_ascii=False) + "\n"
    if fmt == "csv":
        texts = _number_texts(plan, got, _csv_text) or [_csv_text(plan, i, v) for i, v in enumerate(got)]
        return _csv_cells([iso_time(when), *texts])
    texts = _number_texts(plan, got, _table_text) or [_table_text(plan, i, v) for i, v in enumerate(got)]
    parts = plan.table_parts.copy()
    parts[1::3] = texts
    return f"{plan.time_row}{iso_time(when)}\n" + "".join(parts) + "\n"  # type: ignore[arg-type]


def _csv_text(plan: _Plan, i: int, value: Value) -> str:
    return _cell(plan.shown(i, value))


def _table_text(plan: _Plan, i: int, value: Value) -> str:
    if plan.kinds[i] == _PRECISION:
        return shown_text(plan.functions[i], value)
    return _text(plan.shown(i, value))


DEVICE_KEY = "device"  # the key (json), column (csv) and row (table) naming a record's device when several are polled


def device_record_header(fmt: str) -> str:
    """What polling several devices prints once: csv's header (time, device, name, value, units)."""
    return _csv_line([TIME_KEY, DEVICE_KEY, "name", "value", "units"]) if fmt == "csv" else ""


def device_record(
    device: str, functions: list[Function], values: dict[str, Value], fmt: str, when: datetime, device_name: str = ""
) -> str:
    """One poll's record of one of several devices, naming it: json {"time", "device", "values"} on one line;
    csv a row per function (time, device, name, value, units); table a block with a device row; senml the
    document of `record` with each `bn` prefixed by `device/`."""
    if fmt == "json":
        doc = {TIME_KEY: iso_time(when), DEVICE_KEY: device, "values": _json_values(functions, values)}
        return json.dumps(doc, ensure_ascii=False) + "\n"
    if fmt == "csv":
        stamp = iso_time(when)
        return "".join(
            _csv_line([stamp, device, fn.name, _cell(shown(fn, values[fn.name])), (fn.units or "").strip()])
            for fn in functions
        )
    if fmt == "senml":
        doc = json.loads(record(functions, values, fmt, when, device_name))
        for block in doc.values():
            block["bn"] = f"{device}/{block['bn']}"
        return json.dumps(doc, ensure_ascii=False) + "\n"
    rows = [(fn.name, shown_text(fn, values[fn.name]), (fn.units or "").strip()) for fn in functions]
    return _table([(TIME_KEY, iso_time(when), ""), (DEVICE_KEY, device, ""), *rows]) + "\n"
