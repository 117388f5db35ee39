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

/* Context of cell (x, y, z): occupied(x-1) + 2 occupied(y-1) + 4 occupied(z-1), outside
 * neighbours empty (the decoder's). */
static uint32_t grid_ctx(const uint8_t *occ, uint32_t g, uint32_t x, uint32_t y, uint32_t z)
{
    const size_t i = ((size_t)z * g + y) * g + x, gg = (size_t)g * g;
    return (x && occ[i - 1] ? 1u : 0u) | (y && occ[i - g] ? 2u : 0u) | (z && occ[i - gg] ? 4u : 0u);
}

/* A binary symbol to code: its value and the frequency of "occupied" it is coded with. */
typedef struct bin_sym {
    uint8_t bit;
    uint8_t ctx;
} bin_sym;

/* The "occupied" frequency per context from the counts n1 of n: rounded, each symbol
 * keeping at least 1 of 2^prec. */
static void grid_freqs(const uint64_t *n1, const uint64_t *n, unsigned prec, uint32_t *f1)
{
    const uint32_t total = 1u << prec;
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++) {
        double p = n[c] ? (double)n1[c] / (double)n[c] : 0.5;
        long v = lround(p * total);
        f1[c] = (uint32_t)(v < 1 ? 1 : v > (long)total - 1 ? (long)total - 1 : v);
    }
}

/* Codes syms[0..count), each under the frequency table f1 of its level (lv[i]: 0 the
 * cells', 1 the blocks'), last to first; appends the payload to out. */
static int put_bins(const bin_sym *syms, const uint8_t *lv, size_t count, const uint32_t *f1,
                    const uint32_t *fb1, unsigned prec, cn_buf *out)
{
    /* Each symbol emits at most 2 bytes (prec <= 16); the state adds 4. */
    const size_t cap = 2 * count + 4;
    const uint32_t total = 1u << prec;
    uint8_t *buf = malloc(cap);
    if (!buf)
        return -1;
    uint8_t *p = buf + cap;
    uint32_t x = CNERF_RANS_L;
    for (size_t i = count; i-- > 0;) {
        const uint32_t one = (lv && lv[i] ? fb1 : f1)[syms[i].ctx];
        rans_put(&x, &p, syms[i].bit ? one : total - one, syms[i].bit ? total - one : 0, prec);
    }
    p = rans_flush(x, p);
    cn_buf_put(out, p, (size_t)(buf + cap - p));
    free(buf);
    return 0;
}

int cn_grid_encode_raster(const uint8_t *occ, uint32_t g, unsigned prec, cn_buf *out)
{
    if (g < 1 || g > CNERF_MAX_GRID || prec < 2 || prec > CNERF_MAX_PREC)
        return -1;
    const size_t cells = (size_t)g * g * g;
    bin_sym *syms = malloc(sizeof *syms * cells);
    if (!syms)
        return -1;
    uint64_t n1[CNERF_GRID_CONTEXTS] = {0}, n[CNERF_GRID_CONTEXTS] = {0};
    size_t i = 0;
    for (uint32_t z = 0; z < g; z++)
        for (uint32_t y = 0; y < g; y++)
            for (uint32_t x = 0; x < g; x++, i++) {
                syms[i].bit = occ[i] != 0;
                syms[i].ctx = (uint8_t)grid_ctx(occ, g, x, y, z);
                n[syms[i].ctx]++;
                n1[syms[i].ctx] += syms[i].bit;
            }
    uint32_t f1[CNERF_GRID_CONTEXTS];
    grid_freqs(n1, n, prec, f1);
    cn_buf_u8(out, g);
    cn_buf_u8(out, prec);
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
        cn_buf_u16(out, f1[c]);
    const int rc = put_bins(syms, NULL, cells, f1, NULL, prec, out);
    free(syms);
    return rc || out->oom ? -1 : 0;
}

int cn_grid_encode(const uint8_t *occ, uint32_t g, unsigned prec, cn_buf *out)
{
    if (g < 1 || g > CNERF_MAX_GRID || prec < 2 || prec > CNERF_MAX_PREC)
        return -1;
    const uint32_t B = CNERF_GRID_BLOCK, nb = (g + B - 1) / B;
    const size_t cells = (size_t)g * g * g, blocks = (size_t)nb * nb * nb;
    uint8_t *bo = calloc(blocks, 1), *lv = malloc(blocks + cells);
    bin_sym *syms = malloc(sizeof *syms * (blocks + cells));
    if (!bo || !lv || !syms) {
        free(bo);
        free(lv);
        free(syms);
        return -1;
    }
    for (uint32_t z = 0; z < g; z++)
        for (uint32_t y = 0; y < g; y++)
            for (uint32_t x = 0; x < g; x++)
                if (occ[((size_t)z * g + y) * g + x])
                    bo[((size_t)(z / B) * nb + y / B) * nb + x / B] = 1;
    uint64_t b1[CNERF_GRID_CONTEXTS] = {0}, bn[CNERF_GRID_CONTEXTS] = {0};
    uint64_t n1[CNERF_GRID_CONTEXTS] = {0}, n[CNERF_GRID_CONTEXTS] = {0};
    size_t k = 0, occupied = 0;
    /* the blocks, then the cells of the occupied ones, in the decoder's order */
    for (uint32_t Z = 0; Z < nb; Z++)
        for (uint32_t Y = 0; Y < nb; Y++)
            for (uint32_t X = 0; X < nb; X++, k++) {
                syms[k].bit = bo[k];
                syms[k].ctx = (uint8_t)grid_ctx(bo, nb, X, Y, Z);
                lv[k] = 1;
                bn[syms[k].ctx]++;
                b1[syms[k].ctx] += bo[k];
                occupied += bo[k];
            }
    for (uint32_t Z = 0, b = 0; Z < nb; Z++)
        for (uint32_t Y = 0; Y < nb; Y++)
            for (uint32_t X = 0; X < nb; X++, b++) {
                if (!bo[b])
                    continue;
                for (uint32_t z = Z * B; z < Z * B + B && z < g; z++)
                    for (uint32_t y = Y * B; y < Y * B + B && y < g; y++)
                        for (uint32_t x = X * B; x < X * B + B && x < g; x++, k++) {
                            syms[k].bit = occ[((size_t)z * g + y) * g + x] != 0;
                            syms[k].ctx = (uint8_t)grid_ctx(occ, g, x, y, z);
                            lv[k] = 0;
                            n[syms[k].ctx]++;
                            n1[syms[k].ctx] += syms[k].bit;
                        }
            }
    uint32_t f1[CNERF_GRID_CONTEXTS], fb1[CNERF_GRID_CONTEXTS];
    grid_freqs(b1, bn, prec, fb1);
    grid_freqs(n1, n, prec, f1);
    cn_buf_u8(out, g);
    cn_buf_u8(out, prec);
    cn_buf_u16(out, (uint32_t)occupied);
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
        cn_buf_u16(out, fb1[c]);
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
        cn_buf_u16(out, f1[c]);
    const int rc = put_bins(syms, lv, k, f1, fb1, prec, out);
    free(bo);
    free(lv);
    free(syms);
    return rc || out->oom ? -1 : 0;
}
