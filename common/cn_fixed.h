/*
 * Fixed-point primitives of the renderer (docs/fixed-point.md names every format).
 * Freestanding: <stdint.h> only; no division instruction wider than 32 bits, no
 * implementation-defined shifts of negative numbers, no overflow (each bound is stated).
 */
#ifndef CNERF_COMMON_FIXED_H
#define CNERF_COMMON_FIXED_H

#include <stdint.h>

#if defined(__ARM_FEATURE_DSP) && !defined(CNERF_PORTABLE) && !defined(__aarch64__)
#include <arm_acle.h>
#define CN_ARM_DSP 1
#endif

/* Saturation bound of cn_mul_exp: |result| <= 2^61, so three such terms add in int64. */
#define CN_SAT61 ((int64_t)1 << 61)

/* floor(x / 2^s) for any x and 0 <= s <= 63, without right-shifting a negative number. */
static inline int64_t cn_asr64(int64_t x, unsigned s)
{
    return x >= 0 ? x >> s : ~((~x) >> s);
}

static inline uint64_t cn_abs64(int64_t x) { return x < 0 ? 0u - (uint64_t)x : (uint64_t)x; }

static inline int64_t cn_clamp64(int64_t x, int64_t lo, int64_t hi)
{
    return x < lo ? lo : x > hi ? hi : x;
}

/* round(s * m * 2^e), saturated to +-2^61, rounding halves away from zero (up = 0: the
 * ray arithmetic) or up (up = 1, floor(v + 1/2): the layers' arithmetic). Exact for every
 * int64 s, int32 m and int e: the product is formed in 96 bits (|s m| < 2^94). For a
 * negative product, floor(v + 1/2) = -floor((|v| 2^sh - 1 + 2^(sh-1)) / 2^sh): the
 * magnitude less one unit, rounded half away from zero. */
static inline int64_t cn_mul_exp_r(int64_t s, int32_t m, int e, int up)
{
    if (s == 0 || m == 0)
        return 0;
    const int neg = (s < 0) != (m < 0);
    const unsigned less = e < 0 && neg && up; /* |V| >= 1: no wrap below */
    const uint64_t us = cn_abs64(s);
    const uint32_t um = m < 0 ? 0u - (uint32_t)m : (uint32_t)m;
    uint64_t r;
    if ((us >> 32) == 0u) {
        /* |s| < 2^32 (most accumulators, every bias): V = us um < 2^63 in one 64-bit word */
        const uint64_t v = us * um - less;
        if (e >= 0) {
            r = e >= 61 || (v >> (61 - e)) != 0 ? (uint64_t)CN_SAT61 : v << e;
        } else {
            const unsigned sh = (unsigned)-e; /* V < 2^63 <= 2^(sh-1) rounds to zero */
            r = sh >= 64 ? 0u : (v + ((uint64_t)1 << (sh - 1))) >> sh; /* < 2^64: no wrap */
            if (r > (uint64_t)CN_SAT61)
                r = (uint64_t)CN_SAT61;
        }
        return neg ? -(int64_t)r : (int64_t)r;
    }
    /* V = hi 2^32 + lo with lo < 2^32: us < 2^64, um <= 2^31, so hi < 2^63. */
    uint64_t lo = (us & 0xFFFFFFFFu) * um;
    uint64_t hi = (us >> 32) * um + (lo >> 32);
    lo &= 0xFFFFFFFFu;
    if (less) { /* V >= 2^32: hi >= 1 */
        if (lo == 0u) {
            lo = 0xFFFFFFFFu;
            hi--;
        } else {
            lo--;
        }
    }
    if (e >= 0) {
        if (e >= 61)
            r = (uint64_t)CN_SAT61;
        else if (e <= 29)
            r = (hi >> (29 - e)) != 0 ? (uint64_t)CN_SAT61 : ((hi << 32) | lo) << e;
        else
            r = hi != 0 || (lo >> (61 - e)) != 0 ? (uint64_t)CN_SAT61 : lo << e;
    } else {
        const unsigned sh = (unsigned)-e;
        if (sh > 95)
            return 0; /* V < 2^95 <= 2^(sh-1): rounds to zero */
        /* add 2^(sh-1) to V (hi < 2^63 and the addend is at most 2^62 in hi: no wrap) */
        if (sh <= 32) {
            lo += (uint64_t)1 << (sh - 1);
            hi += lo >> 32;
            lo &= 0xFFFFFFFFu;
        } else {
            hi += (uint64_t)1 << (sh - 33);
        }
        if (sh >= 32) {
            r = sh - 32 >= 64 ? 0 : hi >> (sh - 32);
        } else {
            /* (V >> sh) = hi 2^(32-sh) + lo >> sh; saturate when it reaches 2^61 */
            r = (hi >> (29 + sh)) != 0 ? (uint64_t)CN_SAT61 : (hi << (32 - sh)) | (lo >> sh);
        }
        if (r > (uint64_t)CN_SAT61)
            r = (uint64_t)CN_SAT61;
    }
    return neg ? -(int64_t)r : (int64_t)r;
}

/* round(s * m * 2^e), halves away from zero, saturated to +-2^61 (cn_mul_exp_r). */
static inline int64_t cn_mul_exp(int64_t s, int32_t m, int e) { return cn_mul_exp_r(s, m, e, 0); }

/* floor(x / 2^s) for any x and 0 <= s <= 31, without right-shifting a negative number. */
static inline int32_t cn_asr32(int32_t x, unsigned s)
{
    return x >= 0 ? x >> s : ~((~x) >> s);
}

static inline int32_t cn_sat32(int64_t x)
{
    return (int32_t)(x < INT32_MIN ? INT32_MIN : x > INT32_MAX ? INT32_MAX : x);
}

/* sat32(a + b): one QADD on cores with the DSP extension. */
static inline int32_t cn_qadd32(int32_t a, int32_t b)
{
#ifdef CN_ARM_DSP
    return __qadd(a, b);
#else
    return cn_sat32((int64_t)a + b);
#endif
}

/* sat16(x) as an int32: one SSAT on cores with the DSP extension. */
static inline int32_t cn_sat16(int32_t x)
{
#ifdef CN_ARM_DSP
    int32_t r;
    __asm__("ssat %0, #16, %1" : "=r"(r) : "r"(x));
    return r;
#else
    return x > 32767 ? 32767 : x < -32768 ? -32768 : x;
#endif
}

/* The int32 whose two's complement is u (without an implementation-defined conversion). */
static inline int32_t cn_s32(uint32_t u)
{
    return u < 0x80000000u ? (int32_t)u : -(int32_t)(~u) - 1;
}

/* sat16(floor(x / 2^s + 1/2)) for 0 <= s <= 31: a layer input from its Q16 value x at the
 * layer's scale f = 16 - s. floor(x / 2^s + 1/2) = floor(x / 2^s) + bit s-1 of x, which
 * cannot overflow. */
static inline int16_t cn_requant16(int32_t x, unsigned s)
{
    int32_t q = s ? cn_asr32(x, s) + (int32_t)(((uint32_t)x >> (s - 1u)) & 1u) : x;
    return (int16_t)(q < -32768 ? -32768 : q > 32767 ? 32767 : q); /* SSAT where there is one */
}

/* floor(acc m / 2^n + 1/2) for 1 <= n <= 62 when the parser proved that it lies below 2^30
 * in magnitude (cnerf_open): the layers' fast rescale. u = acc m + 2^(n-1) is formed
 * modulo 2^64 (|acc m| < 2^54: no wrap), and the result is the low word of u shifted right
 * by n: from both words for n < 32, from the high word alone (shifted arithmetically) for
 * n >= 32. */
static inline int32_t cn_rescale_fast(int32_t acc, int32_t m, unsigned n, uint64_t half)
{
    const uint64_t u = (uint64_t)((int64_t)acc * m) + half;
    const uint32_t hi = (uint32_t)(u >> 32);
    if (n < 32u)
        return cn_s32(((uint32_t)u >> n) | (hi << (32u - n)));
    return cn_asr32(cn_s32(hi), n - 32u);
}

/* floor(n 2^f / d) for d > 0, by restoring long division (no 64-bit divide instruction),
 * saturated to 2^63 - 1. Used per ray and per tile, never per network weight. */
static inline uint64_t cn_udiv_frac(uint64_t n, uint64_t d, unsigned f)
{
    const uint64_t top = (uint64_t)1 << 63;
    uint64_t q = 0, r = 0;
    if (d == 0 || d >= top)
        return top - 1; /* callers keep d < 2^63 */
    if (n < d) {
        r = n; /* the integer bits of the quotient are all 0: the loop below leaves r = n */
    } else {
        for (int b = 63; b >= 0; b--) {
            r = (r << 1) | ((n >> b) & 1u); /* r < d < 2^63: no wrap */
            q <<= 1;
            if (r >= d) {
                r -= d;
                q |= 1;
            }
        }
    }
    for (unsigned i = 0; i < f; i++) {
        if (q >> 62)
            return top - 1;
        r <<= 1;
        q <<= 1;
        if (r >= d) {
            r -= d;
            q |= 1;
        }
    }
    return q;
}

/* round(n 2^f / d) with signs (halves away from zero), saturated to +-2^62; d != 0. */
static inline int64_t cn_sdiv_frac(int64_t n, int64_t d, unsigned f)
{
    const uint64_t un = cn_abs64(n), ud = cn_abs64(d);
    /* round half away from zero: floor((2 |n| 2^f / |d| + 1) / 2) */
    uint64_t q = cn_udiv_frac(un, ud, f + 1);
    q = q == ((uint64_t)1 << 63) - 1 ? (uint64_t)1 << 62 : (q + 1) >> 1;
    return (n < 0) != (d < 0) ? -(int64_t)q : (int64_t)q;
}

/* floor(sqrt(x)), bit by bit. */
static inline uint32_t cn_isqrt64(uint64_t x)
{
    uint64_t r = 0, bit = (uint64_t)1 << 62;
    while (bit > x)
        bit >>= 2;
    while (bit) {
        if (x >= r + bit) {
            x -= r + bit;
            r = (r >> 1) + bit;
        } else {
            r >>= 1;
        }
        bit >>= 2;
    }
    return (uint32_t)r;
}

#endif /* CNERF_COMMON_FIXED_H */
