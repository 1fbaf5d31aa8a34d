// Runtime of the Toolkit expressions in generated C++17 drivers (mdl.targets.cpp.expressions copies
// the parts a driver's expressions use, and the parts those use, in this order). Each part starts
// with a line `// part: NAMES | HEADERS`: the names it defines, the standard headers it needs.

// part: Regs | array cstddef cstdint
// register values of an expression
template <std::size_t N> using Regs = std::array<uint16_t, N>;

// part: x_all | algorithm array cstddef initializer_list
// a register the device did not answer has no value
template <std::size_t N> bool x_all(const std::array<bool, N> &present, std::initializer_list<std::size_t> index) {
    return std::all_of(index.begin(), index.end(), [&present](std::size_t i) { return present[i]; });
}

// part: x_wrap | cstring type_traits
// 64-bit arithmetic that wraps, as the JVM's long does (plain C++ leaves signed overflow undefined)
template <typename T> T x_wrap(std::make_unsigned_t<T> v) {
    T s = 0;
    std::memcpy(&s, &v, sizeof s);
    return s;
}

// part: x_add | type_traits
template <typename T> T x_add(T a, T b) {
    using U = std::make_unsigned_t<T>;
    return x_wrap<T>(static_cast<U>(static_cast<U>(a) + static_cast<U>(b)));
}

// part: x_sub | type_traits
template <typename T> T x_sub(T a, T b) {
    using U = std::make_unsigned_t<T>;
    return x_wrap<T>(static_cast<U>(static_cast<U>(a) - static_cast<U>(b)));
}

// part: x_mul | type_traits
template <typename T> T x_mul(T a, T b) {
    using U = std::make_unsigned_t<T>;
    return x_wrap<T>(static_cast<U>(static_cast<U>(a) * static_cast<U>(b)));
}

// part: x_uint | cstddef cstdint
template <std::size_t N> uint64_t x_uint(const Regs<N> &r) {
    uint64_t v = 0;
    for (const uint16_t x : r) {
        v = (v << 16U) | x;
    }
    return v;
}

// part: x_int | cstddef cstdint optional
template <std::size_t N> std::optional<int64_t> x_int(const Regs<N> &r, bool is_signed) {
    const uint64_t v = x_uint(r);
    if (is_signed) {
        if constexpr (N == 4) {
            return x_wrap<int64_t>(v);
        } else {
            const uint64_t sign = UINT64_C(1) << (16 * N - 1);
            return static_cast<int64_t>(v ^ sign) - static_cast<int64_t>(sign);
        }
    }
    if (N == 4 && (v >> 63U) != 0) {
        return std::nullopt;  // as the Toolkit: no uint64 above 2^63 - 1
    }
    return static_cast<int64_t>(v);
}

// part: x_float | cstddef cstdint cstring
template <std::size_t N> double x_float(const Regs<N> &r) {
    const uint64_t v = x_uint(r);
    if constexpr (N == 2) {
        const auto u = static_cast<uint32_t>(v);
        float f = 0.0F;
        std::memcpy(&f, &u, sizeof f);
        return static_cast<double>(f);
    } else {
        double d = 0.0;
        std::memcpy(&d, &v, sizeof d);
        return d;
    }
}

// part: x_byte | cstddef
// byte k of the registers, the first register's high byte first
template <std::size_t N> unsigned char x_byte(const Regs<N> &r, std::size_t k) {
    const uint16_t w = r[k / 2];
    return k % 2 == 0 ? static_cast<unsigned char>(w >> 8U) : static_cast<unsigned char>(w & 0xFFU);
}

// part: XLead x_lead | cstddef
// how many continuation bytes a UTF-8 lead byte announces (0: it is no lead byte), and the range
// the first of them must fall in
struct XLead {
    std::size_t need;
    unsigned lo;
    unsigned hi;
};

inline XLead x_lead(unsigned c) {
    if (c >= 0xC2U && c <= 0xDFU) {
        return {1, 0x80U, 0xBFU};
    }
    if (c >= 0xE0U && c <= 0xEFU) {
        return {2, c == 0xE0U ? 0xA0U : 0x80U, c == 0xEDU ? 0x9FU : 0xBFU};
    }
    if (c >= 0xF0U && c <= 0xF4U) {
        return {3, c == 0xF0U ? 0x90U : 0x80U, c == 0xF4U ? 0x8FU : 0xBFU};
    }
    return {0, 0, 0};
}

// part: x_utf8 | cstddef string
// UTF-8 up to the first NUL; each invalid sequence (its maximal valid prefix) becomes U+FFFD.
template <std::size_t N> std::string x_utf8(const Regs<N> &r) {
    std::size_t len = 0;
    while (len < 2 * N && x_byte(r, len) != 0) {
        ++len;
    }
    std::string out;
    out.reserve(len);
    std::size_t i = 0;
    while (i < len) {
        const unsigned c = x_byte(r, i);
        if (c < 0x80U) {
            out += static_cast<char>(c);
            ++i;
            continue;
        }
        const XLead lead = x_lead(c);
        std::size_t j = i + 1;
        std::size_t k = 0;
        while (k < lead.need && j < len && x_byte(r, j) >= (k == 0 ? lead.lo : 0x80U) &&
               x_byte(r, j) <= (k == 0 ? lead.hi : 0xBFU)) {
            ++k;
            ++j;
        }
        if (lead.need > 0 && k == lead.need) {
            for (std::size_t b = i; b < j; ++b) {
                out += static_cast<char>(x_byte(r, b));
            }
            i = j;
        } else {
            out += "\xEF\xBF\xBD";  // U+FFFD
            i = lead.need > 0 ? j : i + 1;
        }
    }
    return out;
}

// part: x_hex2 | string string_view
inline void x_hex2(std::string &out, unsigned c) {
    constexpr std::string_view kDigits = "0123456789ABCDEF";
    out += kDigits[(c >> 4U) & 0xFU];
    out += kDigits[c & 0xFU];
}

// part: x_hexstring | cstddef string
template <std::size_t N> std::string x_hexstring(const Regs<N> &r) {
    std::string out;
    out.reserve(10 * N);
    for (std::size_t k = 0; k < 2 * N; ++k) {
        out += k > 0 ? " 0x" : "0x";
        x_hex2(out, x_byte(r, k));
    }
    return out;
}

// part: x_eui48 | cstddef string
template <std::size_t N> std::string x_eui48(const Regs<N> &r) {
    std::string out;
    out.reserve(17);
    for (std::size_t k = 2 * N - 6; k < 2 * N; ++k) {
        if (!out.empty()) {
            out += ':';
        }
        x_hex2(out, x_byte(r, k));
    }
    return out;
}

// part: x_ipv4addr | cstddef string
template <std::size_t N> std::string x_ipv4addr(const Regs<N> &r) {
    std::string out;
    out.reserve(15);
    for (std::size_t k = 0; k < 2 * N; ++k) {
        if (!out.empty()) {
            out += '.';
        }
        out += std::to_string(x_byte(r, k));
    }
    return out;
}

// part: x_ipv6addr | cstddef string
template <std::size_t N> std::string x_ipv6addr(const Regs<N> &r) {
    std::string out;
    out.reserve(5 * N);
    for (const uint16_t x : r) {
        if (!out.empty()) {
            out += ':';
        }
        x_hex2(out, x >> 8U);
        x_hex2(out, x & 0xFFU);
    }
    return out;
}

// part: x_enum | cstddef cstdint initializer_list optional string utility
template <std::size_t N>
std::string x_enum(const Regs<N> &r, std::initializer_list<std::pair<int64_t, const char *>> mapping) {
    const std::optional<int64_t> v = x_int(r, true);
    for (const auto &m : mapping) {
        if (v && m.first == *v) {
            return m.second;
        }
    }
    return "No mapping for value " + x_hexstring(r);
}

// part: x_bit | cstddef
template <std::size_t N> bool x_bit(const Regs<N> &r, std::size_t bit) {
    return ((r[N - 1 - bit / 16] >> (bit % 16)) & 1U) != 0;
}

// part: x_bitset | cstddef initializer_list string utility vector
template <std::size_t N>
std::vector<std::string> x_bitset(const Regs<N> &r,
                                  std::initializer_list<std::pair<std::size_t, const char *>> mapping) {
    std::vector<std::string> out;
    for (std::size_t bit = 0; bit < 16 * N; ++bit) {
        if (!x_bit(r, bit)) {
            continue;
        }
        const char *name = nullptr;
        for (const auto &m : mapping) {
            if (m.first == bit) {
                name = m.second;
            }
        }
        out.emplace_back(name != nullptr ? std::string(name) : "Bit " + std::to_string(bit));
    }
    return out;
}

// part: x_swapbytes | cstddef cstdint
template <std::size_t N> Regs<N> x_swapbytes(Regs<N> r) {
    for (uint16_t &x : r) {
        x = static_cast<uint16_t>(((x & 0xFFU) << 8U) | (x >> 8U));
    }
    return r;
}

// part: x_swapendian | cstddef cstdint
template <std::size_t N> Regs<N> x_swapendian(Regs<N> r) {
    for (uint16_t &x : r) {
        unsigned y = 0;
        for (unsigned i = 0; i < 16; ++i) {
            y |= ((x >> i) & 1U) << (15U - i);
        }
        x = static_cast<uint16_t>(y);
    }
    return r;
}

// part: x_double_text | array cmath cstddef cstdio cstdlib cstring string
// Java's Double.toString: shortest round-trip digits; plain from 1e-3 to 1e7, else d.dddE<n>
inline std::string x_double_text(double x) {
    if (std::isnan(x)) {
        return "NaN";
    }
    if (std::isinf(x)) {
        return x > 0 ? "Infinity" : "-Infinity";
    }
    if (x == 0) {
        return std::signbit(x) ? "-0.0" : "0.0";
    }
    std::array<char, 40> buf{};
    for (int p = 1; p <= 17; ++p) {
        std::snprintf(buf.data(), buf.size(), "%.*e", p - 1, x);
        if (std::strtod(buf.data(), nullptr) == x) {
            break;
        }
    }
    // buf holds [-]d[.ddd]e<exponent>: its digits without trailing zeros, and the exponent
    std::array<char, 20> digits{};
    std::size_t n = 0;
    std::size_t at = buf[0] == '-' ? 1 : 0;
    for (; buf[at] != 'e'; ++at) {
        if (buf[at] != '.') {
            digits[n++] = buf[at];
        }
    }
    while (n > 1 && digits[n - 1] == '0') {
        --n;
    }
    const long exp = std::strtol(&buf[at + 1], nullptr, 10);
    std::string out;
    out.reserve(32);
    if (x < 0) {
        out += '-';
    }
    const double ax = std::fabs(x);
    if (ax >= 1e-3 && ax < 1e7 && exp >= 0) {
        const auto whole = static_cast<std::size_t>(exp) + 1;
        for (std::size_t i = 0; i < whole; ++i) {
            out += i < n ? digits[i] : '0';
        }
        out += '.';
        if (n > whole) {
            out.append(&digits[whole], n - whole);
        } else {
            out += '0';
        }
    } else if (ax >= 1e-3 && ax < 1e7) {
        out += "0.";
        out.append(static_cast<std::size_t>(-exp - 1), '0');
        out.append(digits.data(), n);
    } else {
        out += digits[0];
        out += '.';
        if (n > 1) {
            out.append(&digits[1], n - 1);
        } else {
            out += '0';
        }
        out += 'E';
        out += std::to_string(exp);
    }
    return out;
}

// part: x_text_string | optional string
// a value as concat prints it; an absent one prints as nothing
inline std::string x_text_string(const std::optional<std::string> &v) { return v ? *v : std::string(); }

// part: x_text_long | cstdint optional string
inline std::string x_text_long(const std::optional<int64_t> &v) { return v ? std::to_string(*v) : std::string(); }

// part: x_text_double | optional string
inline std::string x_text_double(const std::optional<double> &v) { return v ? x_double_text(*v) : std::string(); }

// part: x_text_bool | optional string
inline std::string x_text_bool(const std::optional<bool> &v) {
    return v ? std::string(*v ? "true" : "false") : std::string();
}

// part: x_text_list | cstddef optional string vector
inline std::string x_text_list(const std::optional<std::vector<std::string>> &v) {
    if (!v) {
        return {};
    }
    std::string out = "[";
    for (std::size_t i = 0; i < v->size(); ++i) {
        out += i > 0 ? ", " : "";
        out += (*v)[i];
    }
    out += ']';
    return out;
}
