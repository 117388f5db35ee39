/*
 * Fixed-point primitives of the renderer (docs/fixed-point.md names every format).
 * Freestanding: <stdint.h> only; no division instruction wider than 32 bits, no
 * implementation-defined shifts of negative numbers, no overflow (each bound is stated).
 */
#ifndef CNERF_DECODER_FIXED_H
#define CNERF_DECODER_FIXED_H

#include <stdint.h>

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

/* round(s * m * 2^e), rounding halves away from zero, saturated to +-2^61. Exact for every
 * int64 s, int32 m and int e: the product is formed in 96 bits (|s m| < 2^94). */
static inline int64_t cn_mul_exp(int64_t s, int32_t m, int e)
{
    if (s == 0 || m == 0)
        return 0;
    const int neg = (s < 0) != (m < 0);
    const uint64_t us = cn_abs64(s);
    const uint32_t um = m < 0 ? 0u - (uint32_t)m : (uint32_t)m;
    uint64_t r;
    if ((us >> 32) == 0u) {
        /* |s| < 2^32 (most accumulators, every bias): V = us um < 2^63 in one 64-bit word */
        const uint64_t v = us * um;
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

/* floor(n 2^f / d) for d > 0, by restoring long division (no 64-bit divide instruction),
 * saturated to 2^63 - 1. Used per ray and per tile, never per network weight. */
static inline uint64_t cn_udiv_frac(uint64_t n, uint64_t d, unsigned f)
{
    const uint64_t top = (uint64_t)1 << 63;
    uint64_t q = 0, r = 0;
    if (d == 0 || d >= top)
        return top - 1; /* callers keep d < 2^63 */
    for (int b = 63; b >= 0; b--) {
        r = (r << 1) | ((n >> b) & 1u); /* r < d < 2^63: no wrap */
        q <<= 1;
        if (r >= d) {
            r -= d;
            q |= 1;
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

#endif /* CNERF_DECODER_FIXED_H */
