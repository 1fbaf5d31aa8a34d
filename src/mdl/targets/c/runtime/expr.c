/* Runtime of Toolkit expressions in a generated C driver (mdl.targets.c.expressions). mdl copies
 * the functions a driver calls, each block below as one piece. Text is written into arrays whose
 * capacity the generator computed; nothing is allocated. Needs <math.h>, <stdbool.h>, <stddef.h>,
 * <stdint.h>, <stdio.h>, <stdlib.h> and <string.h>. */

/* 64-bit arithmetic that wraps, as the JVM's long does (plain C leaves signed overflow undefined) */
static int64_t x_wrap(uint64_t v) {
    int64_t s;
    memcpy(&s, &v, sizeof s);
    return s;
}

static int64_t x_add(int64_t a, int64_t b) {
    return x_wrap((uint64_t)a + (uint64_t)b);
}

static int64_t x_sub(int64_t a, int64_t b) {
    return x_wrap((uint64_t)a - (uint64_t)b);
}

static int64_t x_mul(int64_t a, int64_t b) {
    return x_wrap((uint64_t)a * (uint64_t)b);
}

/* the registers as one unsigned number, the first most significant */
static uint64_t x_uint(const uint16_t *r, size_t n) {
    uint64_t v = 0;
    size_t i;
    for (i = 0; i < n; ++i) {
        v = (v << 16U) | r[i];
    }
    return v;
}

/* the registers as an integer: false (null) for a uint64 above 2^63 - 1, as the Toolkit */
static bool x_int(const uint16_t *r, size_t n, bool is_signed, int64_t *out) {
    const uint64_t v = x_uint(r, n);
    if (is_signed) {
        if (n == 4U) {
            *out = x_wrap(v);
        } else {
            const uint64_t sign = (uint64_t)1U << (16U * n - 1U);
            *out = (int64_t)(v ^ sign) - (int64_t)sign;
        }
        return true;
    }
    if (n == 4U && (v >> 63U) != 0U) {
        return false;
    }
    *out = (int64_t)v;
    return true;
}

static double x_float(const uint16_t *r, size_t n) {
    const uint64_t v = x_uint(r, n);
    if (n == 2U) {
        const uint32_t u = (uint32_t)v;
        float f;
        memcpy(&f, &u, sizeof f);
        return (double)f;
    } else {
        double d;
        memcpy(&d, &v, sizeof d);
        return d;
    }
}

/* byte k of the registers, the first register's high byte first */
static unsigned x_byte(const uint16_t *r, size_t k) {
    const unsigned w = r[k / 2U];
    return k % 2U == 0U ? w >> 8U : w & 0xFFU;
}

/* how many continuation bytes a UTF-8 lead byte announces (0: it is no lead byte), and the range
 * the first of them must fall in */
static size_t x_lead(unsigned c, unsigned *lo, unsigned *hi) {
    *lo = 0x80U;
    *hi = 0xBFU;
    if (c >= 0xC2U && c <= 0xDFU) {
        return 1U;
    }
    if (c >= 0xE0U && c <= 0xEFU) {
        *lo = c == 0xE0U ? 0xA0U : 0x80U;
        *hi = c == 0xEDU ? 0x9FU : 0xBFU;
        return 2U;
    }
    if (c >= 0xF0U && c <= 0xF4U) {
        *lo = c == 0xF0U ? 0x90U : 0x80U;
        *hi = c == 0xF4U ? 0x8FU : 0xBFU;
        return 3U;
    }
    return 0U;
}

/* UTF-8 up to the first NUL; each invalid sequence (its maximal valid prefix) becomes U+FFFD.
 * out holds at least 6n + 1 bytes. */
static void x_utf8(const uint16_t *r, size_t n, char *out) {
    size_t len = 0;
    size_t i = 0;
    size_t o = 0;
    while (len < 2U * n && x_byte(r, len) != 0U) {
        ++len;
    }
    while (i < len) {
        const unsigned c = x_byte(r, i);
        unsigned lo;
        unsigned hi;
        size_t need;
        size_t j = i + 1U;
        size_t k = 0;
        if (c < 0x80U) {
            out[o++] = (char)c;
            ++i;
            continue;
        }
        need = x_lead(c, &lo, &hi);
        while (k < need && j < len && x_byte(r, j) >= (k == 0U ? lo : 0x80U) &&
               x_byte(r, j) <= (k == 0U ? hi : 0xBFU)) {
            ++k;
            ++j;
        }
        if (need > 0U && k == need) {
            size_t b;
            for (b = i; b < j; ++b) {
                out[o++] = (char)x_byte(r, b);
            }
            i = j;
        } else {
            out[o++] = (char)0xEF;
            out[o++] = (char)0xBF;
            out[o++] = (char)0xBD;
            i = need > 0U ? j : i + 1U;
        }
    }
    out[o] = '\0';
}

/* two hex digits of a byte at out[*o] */
static void x_hex2(char *out, size_t *o, unsigned c) {
    static const char digits[] = "0123456789ABCDEF";
    out[(*o)++] = digits[(c >> 4U) & 0xFU];
    out[(*o)++] = digits[c & 0xFU];
}

/* 0xAB 0xCD ...: out holds at least 10n bytes */
static void x_hexstring(const uint16_t *r, size_t n, char *out) {
    size_t o = 0;
    size_t k;
    for (k = 0; k < 2U * n; ++k) {
        if (k > 0U) {
            out[o++] = ' ';
        }
        out[o++] = '0';
        out[o++] = 'x';
        x_hex2(out, &o, x_byte(r, k));
    }
    out[o] = '\0';
}

/* the last 6 bytes as AA:BB:CC:DD:EE:FF */
static void x_eui48(const uint16_t *r, size_t n, char *out) {
    size_t o = 0;
    size_t k;
    for (k = 2U * n - 6U; k < 2U * n; ++k) {
        if (o > 0U) {
            out[o++] = ':';
        }
        x_hex2(out, &o, x_byte(r, k));
    }
    out[o] = '\0';
}

static void x_ipv4addr(const uint16_t *r, size_t n, char *out) {
    size_t o = 0;
    size_t k;
    for (k = 0; k < 2U * n; ++k) {
        const unsigned b = x_byte(r, k);
        if (o > 0U) {
            out[o++] = '.';
        }
        if (b >= 100U) {
            out[o++] = (char)('0' + b / 100U);
        }
        if (b >= 10U) {
            out[o++] = (char)('0' + b / 10U % 10U);
        }
        out[o++] = (char)('0' + b % 10U);
    }
    out[o] = '\0';
}

static void x_ipv6addr(const uint16_t *r, size_t n, char *out) {
    size_t o = 0;
    size_t k;
    for (k = 0; k < n; ++k) {
        if (o > 0U) {
            out[o++] = ':';
        }
        x_hex2(out, &o, (unsigned)r[k] >> 8U);
        x_hex2(out, &o, (unsigned)r[k] & 0xFFU);
    }
    out[o] = '\0';
}

/* a text copied whole (the generator sized out for the longest) */
static void x_copy(char *out, const char *text) {
    memcpy(out, text, strlen(text) + 1U);
}

/* the label of the registers' signed value, or "No mapping for value 0x.." */
static void x_enum(const uint16_t *r, size_t n, const int64_t *keys, const char *const *labels, size_t count,
                   char *out) {
    int64_t v = 0;
    const bool has = x_int(r, n, true, &v);
    size_t i;
    for (i = 0; i < count; ++i) {
        if (has && keys[i] == v) {
            x_copy(out, labels[i]);
            return;
        }
    }
    x_copy(out, "No mapping for value ");
    x_hexstring(r, n, out + strlen(out));
}

/* bit `bit`, bit 0 being the lowest bit of the last register */
static bool x_bit(const uint16_t *r, size_t n, size_t bit) {
    return (((unsigned)r[n - 1U - bit / 16U] >> (bit % 16U)) & 1U) != 0U;
}

/* the labels of the set bits, lowest first */
static void x_bitset(const uint16_t *r, size_t n, const char *const *labels, const char **items, size_t *count) {
    size_t bit;
    *count = 0;
    for (bit = 0; bit < 16U * n; ++bit) {
        if (x_bit(r, n, bit)) {
            items[(*count)++] = labels[bit];
        }
    }
}

static void x_swapbytes(const uint16_t *r, uint16_t *out, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i) {
        out[i] = (uint16_t)((((unsigned)r[i] & 0xFFU) << 8U) | ((unsigned)r[i] >> 8U));
    }
}

static void x_swapendian(const uint16_t *r, uint16_t *out, size_t n) {
    size_t i;
    for (i = 0; i < n; ++i) {
        unsigned y = 0;
        unsigned b;
        for (b = 0; b < 16U; ++b) {
            y |= (((unsigned)r[i] >> b) & 1U) << (15U - b);
        }
        out[i] = (uint16_t)y;
    }
}

/* text appended at out[*len] */
static void x_cat(char *out, size_t *len, const char *text) {
    const size_t n = strlen(text);
    memcpy(out + *len, text, n + 1U);
    *len += n;
}

static void x_cat_long(char *out, size_t *len, int64_t v) {
    char buf[24];
    char *p = buf + sizeof buf - 1U;
    uint64_t u = v < 0 ? (uint64_t)0U - (uint64_t)v : (uint64_t)v;
    *p = '\0';
    do {
        *--p = (char)('0' + (int)(u % 10U));
        u /= 10U;
    } while (u != 0U);
    if (v < 0) {
        *--p = '-';
    }
    x_cat(out, len, p);
}

static void x_cat_bool(char *out, size_t *len, bool v) {
    x_cat(out, len, v ? "true" : "false");
}

/* Java's Double.toString: shortest round-trip digits; plain from 1e-3 to 1e7, else d.dddE<n> */
static void x_cat_double(char *out, size_t *len, double x) {
    char buf[40];
    char digits[20];
    char text[40];
    size_t n = 0;
    size_t at;
    size_t o = 0;
    long e;
    int p;
    double ax;
    if (isnan(x)) {
        x_cat(out, len, "NaN");
        return;
    }
    if (isinf(x)) {
        x_cat(out, len, x > 0 ? "Infinity" : "-Infinity");
        return;
    }
    if (x == 0) {
        x_cat(out, len, signbit(x) ? "-0.0" : "0.0");
        return;
    }
    for (p = 1; p <= 17; ++p) {
        (void)snprintf(buf, sizeof buf, "%.*e", p - 1, x);
        if (strtod(buf, NULL) == x) {
            break;
        }
    }
    /* buf holds [-]d[.ddd]e<exponent>: its digits without trailing zeros, and the exponent */
    for (at = buf[0] == '-' ? 1U : 0U; buf[at] != 'e'; ++at) {
        if (buf[at] != '.') {
            digits[n++] = buf[at];
        }
    }
    while (n > 1U && digits[n - 1U] == '0') {
        --n;
    }
    e = strtol(&buf[at + 1U], NULL, 10);
    if (x < 0) {
        text[o++] = '-';
    }
    ax = fabs(x);
    if (ax >= 1e-3 && ax < 1e7 && e >= 0) {
        const size_t whole = (size_t)e + 1U;
        size_t i;
        for (i = 0; i < whole; ++i) {
            text[o++] = i < n ? digits[i] : '0';
        }
        text[o++] = '.';
        if (n > whole) {
            for (i = whole; i < n; ++i) {
                text[o++] = digits[i];
            }
        } else {
            text[o++] = '0';
        }
        text[o] = '\0';
    } else if (ax >= 1e-3 && ax < 1e7) {
        long z;
        size_t i;
        text[o++] = '0';
        text[o++] = '.';
        for (z = 0; z < -e - 1; ++z) {
            text[o++] = '0';
        }
        for (i = 0; i < n; ++i) {
            text[o++] = digits[i];
        }
        text[o] = '\0';
    } else {
        size_t i;
        text[o++] = digits[0];
        text[o++] = '.';
        if (n > 1U) {
            for (i = 1; i < n; ++i) {
                text[o++] = digits[i];
            }
        } else {
            text[o++] = '0';
        }
        (void)snprintf(text + o, sizeof text - o, "E%ld", e);
    }
    x_cat(out, len, text);
}

/* a list as concat prints it: [a, b] */
static void x_cat_list(char *out, size_t *len, const char *const *items, size_t count) {
    size_t i;
    x_cat(out, len, "[");
    for (i = 0; i < count; ++i) {
        if (i > 0U) {
            x_cat(out, len, ", ");
        }
        x_cat(out, len, items[i]);
    }
    x_cat(out, len, "]");
}
