/* rANS encoder (32-bit state, byte-wise renormalisation, after ryg_rans).
 * Symbols are coded last to first so that the decoder reads front to back. */
#include <math.h>
#include <stdlib.h>

#include "cn_stream.h"

/* Codes one symbol of frequency f starting at cum (of 2^prec) into state *x, emitting bytes
 * backwards before *p. */
static void rans_put(uint32_t *x, uint8_t **p, uint32_t f, uint32_t cum, unsigned prec)
{
    const uint32_t x_max = ((CNERF_RANS_L >> prec) << 8) * f;
    while (*x >= x_max) {
        *--*p = (uint8_t)*x;
        *x >>= 8;
    }
    *x = ((*x / f) << prec) + (*x % f) + cum;
}

/* Writes the final state x (little-endian, read first by the decoder) before p; returns the
 * payload's start. */
static uint8_t *rans_flush(uint32_t x, uint8_t *p)
{
    p -= 4;
    p[0] = (uint8_t)x;
    p[1] = (uint8_t)(x >> 8);
    p[2] = (uint8_t)(x >> 16);
    p[3] = (uint8_t)(x >> 24);
    return p;
}

int cn_rans_encode(const uint32_t *syms, size_t count, const uint32_t *freq, uint32_t n,
                   unsigned prec, cn_buf *out)
{
    if (prec < 1 || prec > CNERF_MAX_PREC || n == 0 || count > (SIZE_MAX - 4) / 2)
        return -1;
    uint32_t *cum = malloc(sizeof(uint32_t) * ((size_t)n + 1));
    /* Each symbol emits at most 2 bytes when prec <= 16; the state adds 4. */
    size_t cap = 2 * count + 4;
    uint8_t *buf = malloc(cap);
    if (!cum || !buf) {
        free(cum);
        free(buf);
        return -1;
    }
    cum[0] = 0;
    for (uint32_t i = 0; i < n; i++)
        cum[i + 1] = cum[i] + freq[i];
    if (cum[n] != (1u << prec)) {
        free(cum);
        free(buf);
        return -1;
    }
    uint8_t *p = buf + cap;
    uint32_t x = CNERF_RANS_L;
    for (size_t i = count; i-- > 0;) {
        uint32_t s = syms[i];
        if (s >= n || freq[s] == 0) {
            free(cum);
            free(buf);
            return -1;
        }
        rans_put(&x, &p, freq[s], cum[s], prec);
    }
    p = rans_flush(x, p);
    cn_buf_put(out, p, (size_t)(buf + cap - p));
    free(cum);
    free(buf);
    return out->oom ? -1 : 0;
}

/* Context of cell i = (z g + y) g + x: occupied(x-1) + 2 occupied(y-1) + 4 occupied(z-1),
 * outside neighbours empty (the decoder's cn_grid_context). */
static uint32_t grid_ctx(const uint8_t *occ, uint32_t g, size_t i)
{
    const uint32_t x = (uint32_t)(i % g), y = (uint32_t)(i / g % g), z = (uint32_t)(i / g / g);
    const size_t gg = (size_t)g * g;
    return (x && occ[i - 1] ? 1u : 0u) | (y && occ[i - g] ? 2u : 0u) | (z && occ[i - gg] ? 4u : 0u);
}

int cn_grid_encode(const uint8_t *occ, uint32_t g, unsigned prec, cn_buf *out)
{
    if (g < 1 || g > CNERF_MAX_GRID || prec < 2 || prec > CNERF_MAX_PREC)
        return -1;
    const size_t cells = (size_t)g * g * g;
    const uint32_t total = 1u << prec;
    /* The frequency of "occupied" per context: the grid's own counts, rounded, each symbol
     * keeping at least 1 of 2^prec. */
    uint64_t n1[CNERF_GRID_CONTEXTS] = {0}, n[CNERF_GRID_CONTEXTS] = {0};
    for (size_t i = 0; i < cells; i++) {
        const uint32_t c = grid_ctx(occ, g, i);
        n[c]++;
        n1[c] += occ[i] != 0;
    }
    uint32_t f1[CNERF_GRID_CONTEXTS];
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++) {
        double p = n[c] ? (double)n1[c] / (double)n[c] : 0.5;
        long v = lround(p * total);
        f1[c] = (uint32_t)(v < 1 ? 1 : v > (long)total - 1 ? (long)total - 1 : v);
    }
    /* Each cell emits at most 2 bytes (prec <= 16); the state adds 4. */
    const size_t cap = 2 * cells + 4;
    uint8_t *buf = malloc(cap);
    if (!buf)
        return -1;
    uint8_t *p = buf + cap;
    uint32_t x = CNERF_RANS_L;
    for (size_t i = cells; i-- > 0;) {
        const uint32_t one = f1[grid_ctx(occ, g, i)];
        rans_put(&x, &p, occ[i] ? one : total - one, occ[i] ? total - one : 0, prec);
    }
    p = rans_flush(x, p);
    cn_buf_u8(out, g);
    cn_buf_u8(out, prec);
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
        cn_buf_u16(out, f1[c]);
    cn_buf_put(out, p, (size_t)(buf + cap - p));
    free(buf);
    return out->oom ? -1 : 0;
}
