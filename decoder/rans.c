/*
 * Static frequency tables and the rANS decoder (32-bit state, byte-wise
 * renormalisation, after ryg_rans). Multiply, shift, mask and compare only.
 */
#include "cn_internal.h"

cnerf_status cn_table_read(cn_bits *b, uint32_t n, unsigned prec, unsigned k, uint32_t *cum)
{
    if (n < 2u || prec < 1u || prec > CNERF_MAX_PREC || k > CNERF_MAX_EG_ORDER)
        return CNERF_E_TABLE;
    const uint32_t total = (uint32_t)1u << prec;
    if (n > total) /* every symbol needs a frequency of at least 1 */
        return CNERF_E_TABLE;
    uint32_t sum = 0;
    if (cum)
        cum[0] = 0;
    /* The first n-1 frequencies are coded as f-1; the last is what remains.
     * Invariant: sum <= total - (symbols still to come), so sum < 2^16 + 1. */
    for (uint32_t s = 0; s + 1u < n; s++) {
        uint32_t f = cn_bits_eg(b, k) + 1u;
        if (b->err)
            return CNERF_E_TABLE;
        if (f > total - sum - (n - 1u - s))
            return CNERF_E_TABLE; /* would leave less than 1 for the rest */
        sum += f;
        if (cum)
            cum[s + 1u] = sum;
    }
    /* total - sum >= 1 by the check above. */
    if (cum)
        cum[n] = total;
    return CNERF_OK;
}

/* Largest s with cum[s] <= slot, for cum[0] = 0 <= slot < cum[n]. */
static uint32_t find_symbol(const uint32_t *cum, uint32_t n, uint32_t slot)
{
    uint32_t lo = 0, hi = n; /* cum[lo] <= slot < cum[hi] */
    while (hi - lo > 1u) {
        uint32_t mid = lo + ((hi - lo) >> 1);
        if (cum[mid] <= slot)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* The payload's initial state (little-endian u32) into *x; 0 unless len >= 4 and the state
 * lies in [L, 256 L), where the encoder always leaves it. */
static int initial_state(const uint8_t *p, size_t len, uint32_t *x)
{
    if (len < 4u)
        return 0;
    *x = (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
    return *x >= CNERF_RANS_L && *x < CNERF_RANS_L * 256u;
}

cnerf_status cn_rans_decode(const uint8_t *payload, size_t len, const uint32_t *cum, uint32_t n,
                            unsigned prec, int32_t offset, void *out, unsigned elem_bytes,
                            uint32_t count)
{
    uint32_t x;
    if (!initial_state(payload, len, &x))
        return CNERF_E_PAYLOAD;
    const uint8_t *p = payload + 4;
    const uint8_t *end = payload + len;
    const uint32_t mask = ((uint32_t)1u << prec) - 1u;
    for (uint32_t i = 0; i < count; i++) {
        uint32_t slot = x & mask;
        uint32_t s = find_symbol(cum, n, slot);
        uint32_t start = cum[s], freq = cum[s + 1u] - cum[s];
        /* x < 2^31, so freq * (x >> prec) <= x >> prec << prec <= x: no overflow. */
        x = freq * (x >> prec) + slot - start;
        while (x < CNERF_RANS_L) {
            if (end - p < 1)
                return CNERF_E_PAYLOAD;
            x = (x << 8) | *p++;
        }
        int32_t v = (int32_t)s + offset;
        if (elem_bytes == 1u)
            ((int8_t *)out)[i] = (int8_t)v;
        else if (elem_bytes == 2u)
            ((int16_t *)out)[i] = (int16_t)v;
        else
            ((int32_t *)out)[i] = v;
    }
    /* A clean payload is consumed exactly and returns to the encoder's initial state. */
    if (p != end || x != CNERF_RANS_L)
        return CNERF_E_PAYLOAD;
    return CNERF_OK;
}

cnerf_status cn_grid_decode(const uint8_t *payload, size_t len, uint32_t g, unsigned prec,
                            const uint16_t *f1, uint8_t *bits, uint32_t *occupied)
{
    uint32_t x;
    if (!initial_state(payload, len, &x))
        return CNERF_E_PAYLOAD;
    const uint8_t *p = payload + 4;
    const uint8_t *end = payload + len;
    const uint32_t total = (uint32_t)1u << prec, mask = total - 1u;
    uint32_t n1 = 0, i = 0;
    for (uint32_t cz = 0; cz < g; cz++)
        for (uint32_t cy = 0; cy < g; cy++)
            for (uint32_t cx = 0; cx < g; cx++, i++) {
                /* symbol 0 (empty) owns [0, f0), symbol 1 (occupied) [f0, 2^prec) */
                if ((i & 7u) == 0u)
                    bits[i >> 3] = 0; /* the bitmap need not be zeroed beforehand */
                const uint32_t one = f1[cn_grid_context(bits, g, cx, cy, cz)];
                const uint32_t f0 = total - one, slot = x & mask;
                if (slot >= f0) {
                    x = one * (x >> prec) + slot - f0;
                    bits[i >> 3] = (uint8_t)(bits[i >> 3] | (1u << (i & 7u)));
                    n1++;
                } else {
                    x = f0 * (x >> prec) + slot;
                }
                while (x < CNERF_RANS_L) {
                    if (end - p < 1)
                        return CNERF_E_PAYLOAD;
                    x = (x << 8) | *p++;
                }
            }
    if (p != end || x != CNERF_RANS_L)
        return CNERF_E_PAYLOAD;
    *occupied = n1;
    return CNERF_OK;
}
