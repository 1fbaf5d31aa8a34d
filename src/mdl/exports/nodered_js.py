"""The JavaScript of the function nodes of `mdl export --to nodered` (docs/nodered.md): mdl's value IR
(mdl.ir.steps) printed as JavaScript, one printer per decode step kind (`DECODE`: every kind but the Toolkit
expression's, whose functions the flow leaves out), a read fragment through mdl.exports.nodered_frag, and the
code of the flow's two function nodes: `assemble_code` (a poll's replies into one buffer, request after
request, as `ResolvedDevice.plan` lays them out) and `decode_code` (that buffer into `{device, unit, values}`).

What the code computes is what mdl.ir.codec computes in Python. Every integer is a BigInt from the registers
to the value (64-bit formats, sign extension and bit fields exact); every float is a Number, an IEEE 754
double as Python's float, and each step's arithmetic is the same operation in the same order (`x / 10`
where mdl divides, the offset added after). A value leaves as `mdl read --format json` prints it: an
integer as a number, or as its decimal digits in a string beyond what a JavaScript number holds exactly
(2^53 - 1); NaN and the infinities as "nan", "inf", "-inf"; an enumeration's label where one names the value.

Only checked values reach the code: integers printed by Python, floats by `repr` (which JavaScript reads as
the same double), text (function names, labels, the device's name, topics) as JSON string literals
(json.dumps, ASCII only), never the description's own text; no comment holds anything of the description.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from mdl.exports.nodered_frag import FRAGMENT_HELPERS, fragment_lines
from mdl.ir import steps as ir

if TYPE_CHECKING:
    from mdl.resolver import ResolvedDevice, ResolvedFunction

SAFE = (1 << 53) - 1  # the largest integer a JavaScript number holds, with every one below it

_PART = {"word": 0, "swap": 1, "low": 2, "high": 3}  # a unit's part as text() takes it

HELPERS = r"""const dv = new DataView(new ArrayBuffer(8));
function missing(r, patterns) {
    return patterns.some((p) => p.every((w, i) => w === r[i]));
}
function swap(w) {
    return ((w & 0xff) << 8) | (w >> 8);
}
function text(r, units) {
    const bytes = [];
    for (const [i, part] of units) {
        const w = r[i];
        if (part === 0) bytes.push(w >> 8, w & 0xff);
        else if (part === 1) bytes.push(w & 0xff, w >> 8);
        else bytes.push(part === 2 ? w & 0xff : w >> 8);
    }
    while (bytes.length && (bytes[bytes.length - 1] === 0 || bytes[bytes.length - 1] === 32)) bytes.pop();
    return Buffer.from(bytes).toString("utf8");
}
function f32(v) {
    dv.setUint32(0, Number(v));
    return dv.getFloat32(0);
}
function f64(v) {
    dv.setBigUint64(0, v);
    return dv.getFloat64(0);
}
function pow10(e) {
    let p = 1.0;
    for (let i = 0n; i < (e < 0n ? -e : e); i++) p *= 10.0;
    return p;
}
function num(x) {
    if (typeof x === "bigint") return x >= -SAFE && x <= SAFE ? Number(x) : x.toString();
    if (typeof x === "number" && !Number.isFinite(x)) return Number.isNaN(x) ? "nan" : x > 0 ? "inf" : "-inf";
    return x;
}
function label(x, labels) {
    let key = null;
    if (typeof x === "bigint") key = x.toString();
    else if (typeof x === "number" && Number.isInteger(x)) key = BigInt(x).toString();
    return key !== null && labels.has(key) ? labels.get(key) : num(x);
}
""".replace("SAFE", f"{SAFE}n")


def js_float(x: float) -> str:
    """A double as a JavaScript literal that reads as the same double (Python's repr is the shortest such)."""
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"no JavaScript literal for {x!r}")
    return repr(x)


def js_int(n: int) -> str:
    """An integer as a BigInt literal (in parentheses where negative)."""
    n = int(n)
    return f"{n}n" if n >= 0 else f"({n}n)"


def js_string(text: str) -> str:
    """Text as a JavaScript string literal: JSON, every character beyond ASCII escaped."""
    return json.dumps(str(text), ensure_ascii=True)


def js_data(value: Any) -> str:
    """Numbers and text (lists of them) as a JavaScript literal: JSON, ASCII only."""
    return json.dumps(value, ensure_ascii=True)


@dataclass
class _Body:
    """A decoder's lines as the printers write them: `var` holds the value so far (`v`, a BigInt, or `x`,
    a Number); `ended` once a step returned."""

    lines: list[str] = field(default_factory=list)
    var: str = "v"
    ended: bool = False

    def say(self, *lines: str) -> None:
        self.lines.extend(lines)


def _part(unit: ir.Unit) -> str:
    i = unit.index
    return {
        "word": f"BigInt(r[{i}])",
        "swap": f"BigInt(swap(r[{i}]))",
        "low": f"BigInt(r[{i}] & 0xff)",
        "high": f"BigInt(r[{i}] >> 8)",
    }[unit.part]


def _not_implemented(step: ir.NotImplemented, body: _Body) -> None:
    body.say(f"if (missing(r, {js_data([[int(w) for w in p] for p in step.patterns])})) return null;")


def _fragment(step: ir.Fragment, body: _Body) -> None:
    body.say(*fragment_lines(step))
    body.ended = True


def _to_bool(step: ir.ToBool, body: _Body) -> None:
    body.say("return r[0] != 0;")
    body.ended = True


def _compose(step: ir.Compose, body: _Body) -> None:
    parts = [f"({_part(u)} << {u.shift}n)" if u.shift else _part(u) for u in step.units]
    body.say(f"v = {' | '.join(parts)};")


def _to_text(step: ir.ToText, body: _Body) -> None:
    units = [[int(u.index), _PART[u.part]] for u in step.units]
    body.say(f"return text(r, {js_data(units)});")
    body.ended = True


def _mask(step: ir.Mask, body: _Body) -> None:
    body.say(f"v &= 0x{(1 << step.bits) - 1:x}n;")


def _sign_extend(step: ir.SignExtend, body: _Body) -> None:
    body.say(f"if (v >> {step.bits - 1}n) v -= 0x{1 << step.bits:x}n;")


def _to_float(step: ir.ToFloat, body: _Body) -> None:
    body.say(f"x = f{64 if step.bits == 64 else 32}(v);")
    body.var = "x"


def _scaled(divisor: int | None, multiplier: float, body: _Body) -> None:
    """`x = double(v)`, then `/ divisor` or `* multiplier` (none where the multiplier is 1 and `divisor` None)."""
    if body.var == "v":
        body.say("x = Number(v);")
        body.var = "x"
    if divisor is not None:
        body.say(f"x = x / {int(divisor)};")
    elif multiplier != 1.0:
        body.say(f"x = x * {js_float(multiplier)};")


def _offset(offset: float, body: _Body) -> None:
    if offset != 0.0:
        body.say(f"x = x + {js_float(offset)};")


def _scale(step: ir.Scale, body: _Body) -> None:
    if body.var == "v":
        body.say("x = Number(v);")
        body.var = "x"
    if step.divisor is not None:
        body.say(f"x = x / {int(step.divisor)};")
    else:
        body.say(f"x = x * {js_float(step.multiplier)};")
    _offset(step.offset, body)


def _bits(step: ir.Bits, body: _Body) -> None:
    mask = f"0x{(1 << step.width) - 1:x}n"
    body.say(f"v = (v >> {step.shift}n) & {mask};" if step.shift else f"v &= {mask};")
    if step.boolean:
        body.say("return v != 0n;")
        body.ended = True


def _scale_factor(step: ir.ScaleFactor, body: _Body) -> None:
    outside = " || p0 < -22n || p0 > 22n" if step.exponent else ""
    body.say(f"if (p0 === null{outside}) return null;")
    _scaled(step.divisor, step.multiplier, body)
    if step.exponent:
        body.say("x = p0 >= 0n ? x * pow10(p0) : x / pow10(p0);")
    else:
        body.say("x = x * Number(p0);")
    _offset(step.offset, body)


Printer = Callable[[Any, _Body], None]
# one printer per decode step kind (ir.Expression is not printed: the flow leaves such functions out)
DECODE: dict[type, Printer] = {
    ir.NotImplemented: _not_implemented,
    ir.Fragment: _fragment,
    ir.ToBool: _to_bool,
    ir.Compose: _compose,
    ir.ToText: _to_text,
    ir.Mask: _mask,
    ir.SignExtend: _sign_extend,
    ir.ToFloat: _to_float,
    ir.Scale: _scale,
    ir.Bits: _bits,
    ir.ScaleFactor: _scale_factor,
}


def decoder(name: str, steps: Sequence[ir.DecodeStep]) -> str:
    """`function NAME(r[, p0]) {...}`: the steps as JavaScript, `r` the registers (numbers, bits as 0 or 1) in
    address order, `p0` the value of the function that scales it (ir.ScaleFactor)."""
    body = _Body()
    for step in steps:
        DECODE[type(step)](step, body)
    if not body.ended:
        body.say(f"return {body.var};")
    factor = " p0" if any(isinstance(s, ir.ScaleFactor) for s in steps) else ""
    head = f"function {name}(r,{factor})" if factor else f"function {name}(r)"
    locals_ = ["    let v, x;"] if any(isinstance(s, ir.Compose) for s in steps) else []
    return "\n".join([head + " {", *locals_, *("    " + line for line in body.lines), "}"])


def assemble_code(requests: Sequence[tuple[str, int, int]], size: int) -> str:
    """The assembling function node: `requests` (topic, offset in the buffer, count) of the read plan."""
    table = js_data({topic: [offset, count] for topic, offset, count in requests})
    return f"""// One poll's replies (the modbus-read nodes' first outputs, told apart by topic) into one buffer,
// request after request; sent on once every request of the poll has answered. A request that failed
// drops its poll, as a failed request fails mdl read's poll; a request answering again before the
// others did starts the next poll (the last one is dropped, said).
const requests = {table};
const size = {int(size)};
const total = {len(requests)};
if (!Object.prototype.hasOwnProperty.call(requests, msg.topic)) return null;
const [offset, count] = requests[msg.topic];
let poll = context.get("poll");
if (poll === undefined || Object.prototype.hasOwnProperty.call(poll.got, msg.topic)) {{
    if (poll !== undefined && !poll.failed) node.warn("poll dropped: not every request answered");
    poll = {{ got: {{}}, n: 0, failed: false, raw: new Array(size).fill(null) }};
}}
poll.got[msg.topic] = true;
poll.n += 1;
const data = msg.payload;
if (msg.error !== undefined || !Array.isArray(data) || data.length < count) {{
    if (!poll.failed) {{
        const why = msg.error && msg.error.message ? ": " + msg.error.message : "";
        node.warn("poll dropped: reading " + msg.topic + " failed" + why);
        node.status({{ fill: "red", shape: "dot", text: "reading " + msg.topic + " failed" }});
    }}
    poll.failed = true;
}} else {{
    for (let i = 0; i < count; i++) {{
        const w = data[i];
        poll.raw[offset + i] = typeof w === "boolean" ? (w ? 1 : 0) : w;
    }}
}}
if (poll.n < total) {{
    context.set("poll", poll);
    return null;
}}
context.set("poll", undefined);
if (poll.failed) return null;
node.status({{ fill: "green", shape: "dot", text: "polled" }});
return {{ payload: poll.raw }};
"""


@dataclass(frozen=True)
class Decoded:
    """A function the flow decodes: its name (the key of `values`), where its registers are in the buffer,
    its decoder's IR, the names of the functions its decoder takes (a scale register), and its labels."""

    name: str
    slots: tuple[int, ...]
    steps: tuple[ir.DecodeStep, ...]
    shape: str | None  # functions of one shape share their decoder; None: its own (a fragment)
    deps: tuple[str, ...]
    labels: dict[int, str] | None
    shown: bool  # in `values` (False: decoded only for a function it scales, which is left out)


def decoded(resolved: ResolvedDevice, f: ResolvedFunction, shown: bool = True) -> Decoded:
    steps = f.codec.decode
    assert steps is not None  # a readable function
    labels = dict(f.fn.values) if f.fn.values else None
    return Decoded(f.name, resolved.slots_of(f), steps, f.decode_shape, f.deps, labels, shown)


def decode_code(device: str, unit: int, topic: str, functions: Sequence[Decoded]) -> str:
    """The decoding function node: `functions` in decode order (each after the one that scales it)."""
    shapes: dict[str, str] = {}
    definitions: list[str] = []
    calls: list[str] = []
    index = {d.name: i for i, d in enumerate(functions)}
    for i, d in enumerate(functions):
        name = shapes.get(d.shape) if d.shape is not None else None
        if name is None:
            name = f"d{len(definitions)}"
            definitions.append(decoder(name, d.steps))
            if d.shape is not None:
                shapes[d.shape] = name
        regs = ", ".join(f"raw[{int(s)}]" for s in d.slots)
        deps = "".join(f", v[{index[dep]}]" for dep in d.deps)
        calls.append(f"    v[{i}] = {name}([{regs}]{deps});")
    values = []
    for i, d in enumerate(functions):
        if not d.shown:
            continue
        if d.labels:
            pairs = js_data([[str(int(key)), str(text)] for key, text in d.labels.items()])
            values.append(f"    [{js_string(d.name)}, label(v[{i}], new Map({pairs}))],")
        else:
            values.append(f"    [{js_string(d.name)}, num(v[{i}])],")
    fragments = any(isinstance(s, ir.Fragment) for d in functions for s in d.steps)
    return "\n".join(
        [
            "// The poll's buffer (the assembling node's) decoded as mdl decodes it: one decoder per shape of",
            "// mdl's value IR, then each value as `mdl read --format json` gives it. A read fragment that has",
            "// no value for the registers read fails the poll, as it fails mdl read's.",
            HELPERS.rstrip("\n"),
            *([FRAGMENT_HELPERS.rstrip("\n")] if fragments else []),
            *definitions,
            "const raw = msg.payload;",
            "const v = [];",
            "try {",
            *calls,
            "} catch (err) {",
            '    node.error("poll dropped: " + err.message, msg);',
            "    return null;",
            "}",
            "const values = Object.fromEntries([",
            *values,
            "]);",
            f"const payload = {{ device: {js_string(device)}, unit: {int(unit)}, values }};",
            f"return {{ topic: {js_string(topic)}, payload }};",
            "",
        ]
    )
