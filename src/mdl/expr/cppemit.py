"""Lowered expression operations -> straight-line C++17 over std::optional (helpers in
CPP_HELPERS, emitted once into a generated .cc that uses expressions)."""

from __future__ import annotations

from mdl.expr.lower import Lowered, Op
from mdl.gen.render import cstring

CPP_TYPES = {"long": "int64_t", "double": "double", "string": "std::string", "bool": "bool",
             "list": "std::vector<std::string>", "regs": "Regs"}
_CONVERT = {"int16": "x_int(*{a}, 16, true)", "uint16": "x_int(*{a}, 16, false)", "int32": "x_int(*{a}, 32, true)",
            "uint32": "x_int(*{a}, 32, false)", "int64": "x_int(*{a}, 64, true)", "uint64": "x_int(*{a}, 64, false)",
            "ieee754_32": "x_float(*{a}, 32)", "ieee754_64": "x_float(*{a}, 64)", "utf8": "x_utf8(*{a})",
            "hexstring": "x_hexstring(*{a})", "eui48": "x_eui48(*{a})", "ipv4addr": "x_ipv4addr(*{a})",
            "ipv6addr": "x_ipv6addr(*{a})"}


def cpp_type(t: str) -> str:
    return CPP_TYPES[t]


def _double(value: float) -> str:
    text = repr(float(value))
    return text if any(c in text for c in ".e") else text + ".0"


def _regs_literal(words) -> str:
    return "Regs{" + ", ".join(f"0x{w:04X}u" for w in words) + "}"


def _lines(op: Op) -> list[str]:
    t = f"std::optional<{cpp_type(op.type)}>"
    a = op.args[0] if op.args else None
    d = op.data
    if op.kind == "lit":
        v = d["value"]
        lit = {"long": lambda: f"INT64_C({v})", "double": lambda: _double(v),
               "string": lambda: f"std::string({cstring(v)}, {len(v.encode('utf-8'))})",
               "bool": lambda: "true" if v else "false"}[op.type]()
        return [f"const {t} {op.tmp} = {lit};"]
    if op.kind == "regs":
        index = ", ".join(str(i) for i in d["index"])
        regs = ", ".join(f"r[{i}]" for i in d["index"])
        return [f"const {t} {op.tmp} = x_all(present, {{{index}}}) ? {t}(Regs{{{regs}}}) : std::nullopt;"]
    if op.kind == "const":
        return [f"const {t} {op.tmp} = {_regs_literal(d['words'])};"]
    if op.kind == "concat":
        return [f"const {t} {op.tmp} = {' + '.join(['std::string()'] + [f'x_text({x})' for x in op.args])};"]
    out = [f"{t} {op.tmp};"]
    if op.kind in ("swapbytes", "swapendian"):
        return out + [f"if ({a}) {op.tmp} = x_{op.kind}(*{a});"]
    if op.kind == "bit":
        return out + [f"if ({a}) {op.tmp} = (*{a})[0] != 0;"]
    if op.kind == "label":
        f, tr = d["labels"]
        return out + [f"if ({a}) {op.tmp} = std::string(*{a} ? {cstring(tr)} : {cstring(f)});"]
    if op.kind == "todouble":
        return out + [f"if ({a}) {op.tmp} = static_cast<double>(*{a});"]
    if op.kind == "neg":
        expr = f"x_sub(0, *{a})" if op.type == "long" else f"-*{a}"
        return out + [f"if ({a}) {op.tmp} = {expr};"]
    if op.kind in ("arith", "div", "pow"):
        b = op.args[1]
        if op.kind == "div":
            expr = f"*{a} / *{b}"
        elif op.kind == "pow":
            expr = f"std::pow(*{a}, *{b})"
        elif op.type == "long":
            name = {"+": "add", "-": "sub", "*": "mul"}[d["op"]]
            expr = f"x_{name}(*{a}, *{b})"
        else:
            expr = f"*{a} {d['op']} *{b}"
        return out + [f"if ({a} && {b}) {op.tmp} = {expr};"]
    guard = f"{a}" + "".join(f" && *{a} != {_regs_literal(g)}" for g in d["ni"])
    if op.kind == "enum":
        table = ", ".join(f"{{INT64_C({k}), {cstring(v)}}}" for k, v in sorted(d["mapping"].items()))
        expr = f"x_enum(*{a}, {{{table}}})"
    elif op.kind == "bitset":
        table = ", ".join(f"{{{k}, {cstring(v)}}}" for k, v in sorted(d["mapping"].items()))
        expr = f"x_bitset(*{a}, {{{table}}})"
    elif op.kind == "bitsetbit":
        expr = f"x_bit(*{a}, {d['bit']})"
    else:
        expr = _CONVERT[op.kind].format(a=a)
    return out + [f"if ({guard}) {op.tmp} = {expr};"]


def body(lowered: Lowered) -> list[str]:
    lines = ["(void)r;", "(void)present;"]
    for op in lowered.ops:
        lines += _lines(op)
    return lines + [f"return {lowered.result};"]


CPP_HELPERS = r"""
// ---- runtime of the Modbus Schema Toolkit expressions ----
using Regs = std::vector<uint16_t>;

// a register the device did not answer has no value
inline bool x_all(const bool *present, std::initializer_list<int> index) {
    for (int i : index) {
        if (!present[i]) return false;
    }
    return true;
}

inline uint64_t x_uint(const Regs &r) {
    uint64_t v = 0;
    for (uint16_t x : r) v = (v << 16) | x;
    return v;
}

inline std::optional<int64_t> x_int(const Regs &r, int bits, bool is_signed) {
    const uint64_t v = x_uint(r);
    if (is_signed) {
        if (bits == 64) {
            int64_t s;
            std::memcpy(&s, &v, sizeof s);
            return s;
        }
        const uint64_t sign = UINT64_C(1) << (bits - 1);
        return static_cast<int64_t>(v ^ sign) - static_cast<int64_t>(sign);
    }
    if (bits == 64 && (v >> 63) != 0) return std::nullopt;  // as the Toolkit: no uint64 above 2^63 - 1
    return static_cast<int64_t>(v);
}

inline double x_float(const Regs &r, int bits) {
    const uint64_t v = x_uint(r);
    if (bits == 32) {
        const uint32_t u = static_cast<uint32_t>(v);
        float f;
        std::memcpy(&f, &u, sizeof f);
        return static_cast<double>(f);
    }
    double d;
    std::memcpy(&d, &v, sizeof d);
    return d;
}

inline std::string x_bytes(const Regs &r) {
    std::string out;
    for (uint16_t x : r) {
        out += static_cast<char>(x >> 8);
        out += static_cast<char>(x & 0xFF);
    }
    return out;
}

// UTF-8 up to the first NUL; each invalid sequence (its maximal valid prefix) becomes U+FFFD.
inline std::string x_utf8(const Regs &r) {
    std::string b = x_bytes(r);
    const size_t nul = b.find('\0');
    if (nul != std::string::npos) b.resize(nul);
    std::string out;
    size_t i = 0;
    while (i < b.size()) {
        const unsigned char c = static_cast<unsigned char>(b[i]);
        size_t need = 0;
        unsigned char lo = 0x80, hi = 0xBF;
        if (c < 0x80) { out += b[i++]; continue; }
        if (c >= 0xC2 && c <= 0xDF) need = 1;
        else if (c >= 0xE0 && c <= 0xEF) { need = 2; if (c == 0xE0) lo = 0xA0; if (c == 0xED) hi = 0x9F; }
        else if (c >= 0xF0 && c <= 0xF4) { need = 3; if (c == 0xF0) lo = 0x90; if (c == 0xF4) hi = 0x8F; }
        size_t j = i + 1;
        bool ok = need > 0;
        for (size_t k = 0; ok && k < need; ++k, ++j) {
            if (j >= b.size()) { ok = false; break; }
            const unsigned char cc = static_cast<unsigned char>(b[j]);
            const unsigned char l = k == 0 ? lo : 0x80, h = k == 0 ? hi : 0xBF;
            if (cc < l || cc > h) { ok = false; break; }
        }
        if (ok) { out.append(b, i, need + 1); i += need + 1; }
        else { out += "\xEF\xBF\xBD"; i = need > 0 ? j : i + 1; }
    }
    return out;
}

inline std::string x_hexstring(const Regs &r) {
    std::string out;
    char buf[8];
    for (unsigned char c : x_bytes(r)) {
        std::snprintf(buf, sizeof buf, "%s0x%02X", out.empty() ? "" : " ", c);
        out += buf;
    }
    return out;
}

inline std::string x_eui48(const Regs &r) {
    const Regs last(r.end() - 3, r.end());
    std::string out;
    char buf[8];
    for (unsigned char c : x_bytes(last)) {
        std::snprintf(buf, sizeof buf, "%s%02X", out.empty() ? "" : ":", c);
        out += buf;
    }
    return out;
}

inline std::string x_ipv4addr(const Regs &r) {
    std::string out;
    for (unsigned char c : x_bytes(r)) out += (out.empty() ? "" : ".") + std::to_string(c);
    return out;
}

inline std::string x_ipv6addr(const Regs &r) {
    std::string out;
    char buf[8];
    for (uint16_t x : r) {
        std::snprintf(buf, sizeof buf, "%s%04X", out.empty() ? "" : ":", x);
        out += buf;
    }
    return out;
}

inline std::string x_enum(const Regs &r, std::initializer_list<std::pair<int64_t, const char *>> mapping) {
    const std::optional<int64_t> v = x_int(r, static_cast<int>(16 * r.size()), true);
    for (const auto &m : mapping) {
        if (v && m.first == *v) return m.second;
    }
    return "No mapping for value " + x_hexstring(r);
}

inline bool x_bit(const Regs &r, int bit) {
    const size_t index = r.size() - 1 - static_cast<size_t>(bit / 16);
    return ((r[index] >> (bit % 16)) & 1) != 0;
}

inline std::vector<std::string> x_bitset(const Regs &r, std::initializer_list<std::pair<int, const char *>> mapping) {
    std::vector<std::string> out;
    for (int bit = 0; bit < static_cast<int>(16 * r.size()); ++bit) {
        if (!x_bit(r, bit)) continue;
        std::string name = "Bit " + std::to_string(bit);
        for (const auto &m : mapping) {
            if (m.first == bit) name = m.second;
        }
        out.push_back(name);
    }
    return out;
}

inline Regs x_swapbytes(Regs r) {
    for (uint16_t &x : r) x = static_cast<uint16_t>(((x & 0xFF) << 8) | (x >> 8));
    return r;
}

inline Regs x_swapendian(Regs r) {
    for (uint16_t &x : r) {
        uint16_t y = 0;
        for (int i = 0; i < 16; ++i) y = static_cast<uint16_t>(y | (((x >> i) & 1) << (15 - i)));
        x = y;
    }
    return r;
}

// 64-bit arithmetic that wraps, as the JVM's Long does
inline int64_t x_wrap(uint64_t v) {
    int64_t s;
    std::memcpy(&s, &v, sizeof s);
    return s;
}
inline int64_t x_add(int64_t a, int64_t b) { return x_wrap(static_cast<uint64_t>(a) + static_cast<uint64_t>(b)); }
inline int64_t x_sub(int64_t a, int64_t b) { return x_wrap(static_cast<uint64_t>(a) - static_cast<uint64_t>(b)); }
inline int64_t x_mul(int64_t a, int64_t b) { return x_wrap(static_cast<uint64_t>(a) * static_cast<uint64_t>(b)); }

// Java's Double.toString: shortest round-trip digits; plain from 1e-3 to 1e7, else d.dddE<n>
inline std::string x_double_text(double x) {
    if (std::isnan(x)) return "NaN";
    if (std::isinf(x)) return x > 0 ? "Infinity" : "-Infinity";
    if (x == 0) return std::signbit(x) ? "-0.0" : "0.0";
    char buf[40];
    for (int p = 1; p <= 17; ++p) {
        std::snprintf(buf, sizeof buf, "%.*e", p - 1, x);
        if (std::strtod(buf, nullptr) == x) break;
    }
    std::string s(buf);
    const bool neg = s[0] == '-';
    if (neg) s.erase(0, 1);
    const size_t e = s.find('e');
    const int exp = std::atoi(s.c_str() + e + 1);
    std::string digits = s.substr(0, e);
    digits.erase(std::remove(digits.begin(), digits.end(), '.'), digits.end());
    while (digits.size() > 1 && digits.back() == '0') digits.pop_back();
    std::string out;
    const double ax = std::fabs(x);
    if (ax >= 1e-3 && ax < 1e7) {
        if (exp >= 0) {
            std::string whole = digits.substr(0, std::min(digits.size(), static_cast<size_t>(exp + 1)));
            while (static_cast<int>(whole.size()) < exp + 1) whole += '0';
            const std::string frac = digits.size() > static_cast<size_t>(exp + 1) ? digits.substr(exp + 1) : "0";
            out = whole + "." + frac;
        } else {
            out = "0." + std::string(static_cast<size_t>(-exp - 1), '0') + digits;
        }
    } else {
        out = digits.substr(0, 1) + "." + (digits.size() > 1 ? digits.substr(1) : "0") + "E" + std::to_string(exp);
    }
    return neg ? "-" + out : out;
}

inline std::string x_text(const std::optional<std::string> &v) { return v ? *v : std::string(); }
inline std::string x_text(const std::optional<int64_t> &v) { return v ? std::to_string(*v) : std::string(); }
inline std::string x_text(const std::optional<double> &v) { return v ? x_double_text(*v) : std::string(); }
inline std::string x_text(const std::optional<bool> &v) { return v ? std::string(*v ? "true" : "false") : std::string(); }
inline std::string x_text(const std::optional<std::vector<std::string>> &v) {
    if (!v) return std::string();
    std::string out = "[";
    for (size_t i = 0; i < v->size(); ++i) out += (i ? ", " : "") + (*v)[i];
    return out + "]";
}
"""
