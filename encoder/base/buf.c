/* Growable byte buffer and MSB-first bit writer. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_buf.h"
#include "cn_reader.h"

int cn_fail(char *err, size_t errlen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
    return -1;
}

void cn_buf_free(cn_buf *b)
{
    free(b->p);
    b->p = NULL;
    b->n = b->cap = 0;
    b->oom = 0;
}

static int reserve(cn_buf *b, size_t extra)
{
    if (b->oom)
        return -1;
    if (extra > SIZE_MAX - b->n) {
        b->oom = 1;
        return -1;
    }
    if (b->n + extra <= b->cap)
        return 0;
    size_t cap = b->cap ? b->cap : 256;
    while (cap < b->n + extra)
        cap = cap > SIZE_MAX / 2 ? b->n + extra : cap * 2;
    uint8_t *p = realloc(b->p, cap);
    if (!p) {
        b->oom = 1;
        return -1;
    }
    b->p = p;
    b->cap = cap;
    return 0;
}

void cn_buf_put(cn_buf *b, const void *src, size_t n)
{
    if (n == 0 || reserve(b, n))
        return;
    memcpy(b->p + b->n, src, n);
    b->n += n;
}

void cn_buf_printf(cn_buf *b, const char *fmt, ...)
{
    char line[1024];
    va_list ap;
    va_start(ap, fmt);
    const int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (n < 0) {
        b->oom = 1;
        return;
    }
    if ((size_t)n < sizeof line) {
        cn_buf_put(b, line, (size_t)n);
        return;
    }
    char *big = malloc((size_t)n + 1);
    if (!big) {
        b->oom = 1;
        return;
    }
    va_start(ap, fmt);
    vsnprintf(big, (size_t)n + 1, fmt, ap);
    va_end(ap);
    cn_buf_put(b, big, (size_t)n);
    free(big);
}

void cn_buf_u8(cn_buf *b, uint32_t v)
{
    uint8_t x = (uint8_t)v;
    cn_buf_put(b, &x, 1);
}

static void put_le(cn_buf *b, uint32_t v, unsigned bytes)
{
    uint8_t x[4];
    for (unsigned i = 0; i < bytes; i++)
        x[i] = (uint8_t)(v >> (8 * i));
    cn_buf_put(b, x, bytes);
}

void cn_buf_u16(cn_buf *b, uint32_t v) { put_le(b, v, 2); }
void cn_buf_u24(cn_buf *b, uint32_t v) { put_le(b, v, 3); }
void cn_buf_u32(cn_buf *b, uint32_t v) { put_le(b, v, 4); }

void cn_buf_u64(cn_buf *b, uint64_t v)
{
    put_le(b, (uint32_t)v, 4);
    put_le(b, (uint32_t)(v >> 32), 4);
}

void cn_buf_f64(cn_buf *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    cn_buf_u64(b, u);
}

void cn_bitw_init(cn_bitw *w, cn_buf *out)
{
    w->out = out;
    w->acc = 0;
    w->nacc = 0;
}

void cn_bitw_put(cn_bitw *w, uint32_t v, unsigned n)
{
    if (n == 0)
        return;
    w->acc = (w->acc << n) | (v & ((1u << n) - 1u));
    w->nacc += n;
    while (w->nacc >= 8) {
        w->nacc -= 8;
        cn_buf_u8(w->out, w->acc >> w->nacc);
    }
    w->acc &= (1u << w->nacc) - 1u;
}

unsigned cn_eg_bits(uint32_t v, unsigned k)
{
    uint64_t q = (uint64_t)v + (1u << k);
    unsigned nb = 0;
    while ((q >> nb) > 1)
        nb++;
    /* nb = floor(log2 q); code = (nb - k) zeros, then nb + 1 bits of q */
    return 2 * nb - k + 1;
}

void cn_bitw_eg(cn_bitw *w, uint32_t v, unsigned k)
{
    uint32_t q = v + (1u << k);
    unsigned nb = 0;
    while ((q >> nb) > 1)
        nb++;
    cn_bitw_put(w, 0, nb - k);
    /* q has nb + 1 <= 25 bits: write its leading 1 and then the rest */
    cn_bitw_put(w, 1, 1);
    cn_bitw_put(w, q & ((1u << nb) - 1u), nb);
}

void cn_bitw_flush(cn_bitw *w)
{
    if (w->nacc)
        cn_bitw_put(w, 0, 8 - w->nacc);
}

void cn_buf_f32s(cn_buf *b, const float *x, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &x[i], 4);
        cn_buf_u32(b, u);
    }
}

void cn_buf_f64s(cn_buf *b, const double *x, size_t n)
{
    for (size_t i = 0; i < n; i++)
        cn_buf_f64(b, x[i]);
}

double cn_rd_f64(cn_reader *r)
{
    const uint64_t u = cn_rd_u64(r);
    double x;
    memcpy(&x, &u, 8);
    return x;
}

double cn_get_f64(const uint8_t *p)
{
    const uint64_t u = cn_le64(p);
    double x;
    memcpy(&x, &u, 8);
    return x;
}

void cn_get_f64s(double *x, const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        x[i] = cn_get_f64(p + 8 * i);
}

void cn_get_f32s(float *x, const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        const uint32_t u = cn_le32(p + 4 * i);
        memcpy(&x[i], &u, 4);
    }
}
