/* Runtime of fragments translated to C and C++ (mdl.dsl.cfrag.cemit; docs/fragments.md defines the
 * results). Every operation C leaves undefined or implementation-defined is one of these
 * functions, with a defined result; errors are recorded in *e (the first one wins) and the
 * fragment's function returns -1 with errno set to it. mdl copies the functions a driver calls,
 * each block below as one piece; for C++ it writes the casts as static_casts and drops `static`
 * (the driver puts them in an anonymous namespace). Needs <errno.h> and <stdint.h>. */

/* the first error of a fragment: EDOM or ERANGE */
static void mdl_frag_fail(int *e, int code) {
    if (*e == 0) {
        *e = code;
    }
}

/* the low 8, 16, 32 or 64 bits of v as two's complement; the 8 and 16 bit ones promoted to int32_t */
static int32_t mdl_frag_to_i8(uint64_t v) {
    return (v & 0x80U) == 0U ? (int32_t)(v & 0x7FU) : (int32_t)(v & 0x7FU) - 128;
}

static int32_t mdl_frag_to_u8(uint64_t v) {
    return (int32_t)(v & 0xFFU);
}

static int32_t mdl_frag_to_i16(uint64_t v) {
    return (v & 0x8000U) == 0U ? (int32_t)(v & 0x7FFFU) : (int32_t)(v & 0x7FFFU) - 32768;
}

static int32_t mdl_frag_to_u16(uint64_t v) {
    return (int32_t)(v & 0xFFFFU);
}

static int32_t mdl_frag_to_i32(uint64_t v) {
    return (v & 0x80000000U) == 0U ? (int32_t)(v & 0x7FFFFFFFU) : (int32_t)(v & 0x7FFFFFFFU) - 2147483647 - 1;
}

static int64_t mdl_frag_to_i64(uint64_t v) {
    return (v & UINT64_C(0x8000000000000000)) == 0U
               ? (int64_t)(v)
               : (int64_t)(v & UINT64_C(0x7FFFFFFFFFFFFFFF)) - INT64_C(0x7FFFFFFFFFFFFFFF) - 1;
}

/* signed arithmetic wraps: computed in uint64_t (whose low bits are the same), converted back */
static int32_t mdl_frag_add_i32(int32_t a, int32_t b) {
    return mdl_frag_to_i32((uint64_t)(a) + (uint64_t)(b));
}

static int32_t mdl_frag_sub_i32(int32_t a, int32_t b) {
    return mdl_frag_to_i32((uint64_t)(a) - (uint64_t)(b));
}

static int32_t mdl_frag_mul_i32(int32_t a, int32_t b) {
    return mdl_frag_to_i32((uint64_t)(a) * (uint64_t)(b));
}

static int32_t mdl_frag_neg_i32(int32_t a) {
    return mdl_frag_to_i32(UINT64_C(0) - (uint64_t)(a));
}

static int64_t mdl_frag_add_i64(int64_t a, int64_t b) {
    return mdl_frag_to_i64((uint64_t)(a) + (uint64_t)(b));
}

static int64_t mdl_frag_sub_i64(int64_t a, int64_t b) {
    return mdl_frag_to_i64((uint64_t)(a) - (uint64_t)(b));
}

static int64_t mdl_frag_mul_i64(int64_t a, int64_t b) {
    return mdl_frag_to_i64((uint64_t)(a) * (uint64_t)(b));
}

static int64_t mdl_frag_neg_i64(int64_t a) {
    return mdl_frag_to_i64(UINT64_C(0) - (uint64_t)(a));
}

/* unsigned arithmetic wraps by itself; these keep arithmetic results out of casts (clang-tidy's
 * misplaced-widening-cast check) */
static uint32_t mdl_frag_add_u32(uint32_t a, uint32_t b) {
    return a + b;
}

static uint32_t mdl_frag_sub_u32(uint32_t a, uint32_t b) {
    return a - b;
}

static uint32_t mdl_frag_mul_u32(uint32_t a, uint32_t b) {
    return a * b;
}

static uint32_t mdl_frag_neg_u32(uint32_t a) {
    return 0U - a;
}

static uint64_t mdl_frag_add_u64(uint64_t a, uint64_t b) {
    return a + b;
}

static uint64_t mdl_frag_sub_u64(uint64_t a, uint64_t b) {
    return a - b;
}

static uint64_t mdl_frag_mul_u64(uint64_t a, uint64_t b) {
    return a * b;
}

static uint64_t mdl_frag_neg_u64(uint64_t a) {
    return UINT64_C(0) - a;
}

/* + and - with a zero operand: gcc folds `0.0 - (double)i` to `-(double)i` (and `0.0 + x` to x)
 * where IEEE 754 gives +0.0, not -0.0; a call keeps the operation as written */
static double mdl_frag_add_f64(double a, double b) {
    return a + b;
}

static double mdl_frag_sub_f64(double a, double b) {
    return a - b;
}

static float mdl_frag_add_f32(float a, float b) {
    return a + b;
}

static float mdl_frag_sub_f32(float a, float b) {
    return a - b;
}

/* ~, kept out of casts as well */
static int32_t mdl_frag_not_i32(int32_t a) {
    return ~a;
}

static uint32_t mdl_frag_not_u32(uint32_t a) {
    return ~a;
}

static int64_t mdl_frag_not_i64(int64_t a) {
    return ~a;
}

static uint64_t mdl_frag_not_u64(uint64_t a) {
    return ~a;
}

/* division and remainder truncate toward zero; by zero: EDOM; the most negative value / -1 wraps */
static int32_t mdl_frag_div_i32(int32_t a, int32_t b, int *e) {
    if (b == 0) {
        mdl_frag_fail(e, EDOM);
        return 0;
    }
    if (b == -1) {
        return mdl_frag_neg_i32(a);
    }
    return a / b;
}

static int32_t mdl_frag_mod_i32(int32_t a, int32_t b, int *e) {
    if (b == 0) {
        mdl_frag_fail(e, EDOM);
        return 0;
    }
    if (b == -1) {
        return 0;
    }
    return a % b;
}

static uint32_t mdl_frag_div_u32(uint32_t a, uint32_t b, int *e) {
    if (b == 0U) {
        mdl_frag_fail(e, EDOM);
        return 0U;
    }
    return a / b;
}

static uint32_t mdl_frag_mod_u32(uint32_t a, uint32_t b, int *e) {
    if (b == 0U) {
        mdl_frag_fail(e, EDOM);
        return 0U;
    }
    return a % b;
}

static int64_t mdl_frag_div_i64(int64_t a, int64_t b, int *e) {
    if (b == 0) {
        mdl_frag_fail(e, EDOM);
        return 0;
    }
    if (b == -1) {
        return mdl_frag_neg_i64(a);
    }
    return a / b;
}

static int64_t mdl_frag_mod_i64(int64_t a, int64_t b, int *e) {
    if (b == 0) {
        mdl_frag_fail(e, EDOM);
        return 0;
    }
    if (b == -1) {
        return 0;
    }
    return a % b;
}

static uint64_t mdl_frag_div_u64(uint64_t a, uint64_t b, int *e) {
    if (b == 0U) {
        mdl_frag_fail(e, EDOM);
        return 0U;
    }
    return a / b;
}

static uint64_t mdl_frag_mod_u64(uint64_t a, uint64_t b, int *e) {
    if (b == 0U) {
        mdl_frag_fail(e, EDOM);
        return 0U;
    }
    return a % b;
}

/* shifts: a count from the width up (a negative one converted to uint64_t is that) shifts every
 * bit out; >> of a negative value is arithmetic */
static int32_t mdl_frag_shl_i32(int32_t a, uint64_t n) {
    return n < 32U ? mdl_frag_to_i32((uint64_t)(a) << n) : 0;
}

static uint32_t mdl_frag_shl_u32(uint32_t a, uint64_t n) {
    return n < 32U ? a << n : 0U;
}

static int64_t mdl_frag_shl_i64(int64_t a, uint64_t n) {
    return n < 64U ? mdl_frag_to_i64((uint64_t)(a) << n) : 0;
}

static uint64_t mdl_frag_shl_u64(uint64_t a, uint64_t n) {
    return n < 64U ? a << n : 0U;
}

static int32_t mdl_frag_shr_i32(int32_t a, uint64_t n) {
    return a < 0 ? ~(~a >> (n < 32U ? n : 31U)) : a >> (n < 32U ? n : 31U);
}

static uint32_t mdl_frag_shr_u32(uint32_t a, uint64_t n) {
    return n < 32U ? a >> n : 0U;
}

static int64_t mdl_frag_shr_i64(int64_t a, uint64_t n) {
    return a < 0 ? ~(~a >> (n < 64U ? n : 63U)) : a >> (n < 64U ? n : 63U);
}

static uint64_t mdl_frag_shr_u64(uint64_t a, uint64_t n) {
    return n < 64U ? a >> n : 0U;
}

/* -1, 0 or 1: how two integers compare; no comparison of the fragment is written as an operator
 * (compilers call `r1 > r1` or `(r1 | 3) != 0` always true or false) */
static int mdl_frag_cmp_i32(int32_t a, int32_t b) {
    if (a < b) {
        return -1;
    }
    return a > b ? 1 : 0;
}

static int mdl_frag_cmp_u32(uint32_t a, uint32_t b) {
    if (a < b) {
        return -1;
    }
    return a > b ? 1 : 0;
}

static int mdl_frag_cmp_i64(int64_t a, int64_t b) {
    if (a < b) {
        return -1;
    }
    return a > b ? 1 : 0;
}

static int mdl_frag_cmp_u64(uint64_t a, uint64_t b) {
    if (a < b) {
        return -1;
    }
    return a > b ? 1 : 0;
}

/* how two doubles compare: 1 less, 2 equal, 4 greater, 8 unordered (a NaN); a comparison tests
 * the bits where it holds (!= is 1 | 4 | 8), so no comparison is a self-comparison */
static int mdl_frag_fcmp(double a, double b) {
    if (a < b) {
        return 1;
    }
    if (a > b) {
        return 4;
    }
    return a == b ? 2 : 8;
}

/* x where it lies strictly between low and high (an integer type's range widened by the
 * truncation toward zero), else 0 and EDOM: NaN, infinities and values out of range */
static double mdl_frag_f2i(double x, double low, double high, int *e) {
    if (x > low && x < high) {
        return x;
    }
    mdl_frag_fail(e, EDOM);
    return 0.0;
}

/* what an assignment to a register stores: a value in -32768..65535 (a negative one as its two's
 * complement), truncated toward zero; else 0 and ERANGE */
static int32_t mdl_frag_store_i(int64_t v, int *e) {
    if (v >= -32768 && v <= 65535) {
        return v < 0 ? (int32_t)(v + 65536) : (int32_t)(v);
    }
    mdl_frag_fail(e, ERANGE);
    return 0;
}

static int32_t mdl_frag_store_u(uint64_t v, int *e) {
    if (v <= 65535U) {
        return (int32_t)(v);
    }
    mdl_frag_fail(e, ERANGE);
    return 0;
}

static int32_t mdl_frag_store_f(double v, int *e) {
    if (v > -32769.0 && v < 65536.0) {
        return mdl_frag_store_i((int64_t)(v), e);
    }
    mdl_frag_fail(e, ERANGE);
    return 0;
}
