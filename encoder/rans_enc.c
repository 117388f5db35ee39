/* rANS encoder (32-bit state, byte-wise renormalisation, after ryg_rans).
 * Symbols are coded last to first so that the decoder reads front to back. */
#include <stdlib.h>

#include "cn_stream.h"

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
        uint32_t f = freq[s];
        uint32_t x_max = ((CNERF_RANS_L >> prec) << 8) * f;
        while (x >= x_max) {
            *--p = (uint8_t)x;
            x >>= 8;
        }
        x = ((x / f) << prec) + (x % f) + cum[s];
    }
    p -= 4;
    p[0] = (uint8_t)x;
    p[1] = (uint8_t)(x >> 8);
    p[2] = (uint8_t)(x >> 16);
    p[3] = (uint8_t)(x >> 24);
    cn_buf_put(out, p, (size_t)(buf + cap - p));
    free(cum);
    free(buf);
    return out->oom ? -1 : 0;
}
