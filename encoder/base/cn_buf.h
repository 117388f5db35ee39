/*
 * Growable byte buffer with little-endian writers (and the readers of its float blocks), and
 * an MSB-first bit writer into it. Host C11.
 */
#ifndef CNERF_ENC_BUF_H
#define CNERF_ENC_BUF_H

#include <stddef.h>
#include <stdint.h>

/* Formats a message into err (errlen bytes) and returns -1: the encoder's way to fail. */
__attribute__((format(printf, 3, 4))) int cn_fail(char *err, size_t errlen, const char *fmt,
                                                  ...);

/* ---- growable byte buffer ---- */
typedef struct cn_buf {
    uint8_t *p;
    size_t n, cap;
    int oom; /* sticky: an allocation failed */
} cn_buf;

void cn_buf_free(cn_buf *b);
void cn_buf_put(cn_buf *b, const void *src, size_t n);
/* Appends formatted text (no terminating NUL). */
__attribute__((format(printf, 2, 3))) void cn_buf_printf(cn_buf *b, const char *fmt, ...);
void cn_buf_u8(cn_buf *b, uint32_t v);
void cn_buf_u16(cn_buf *b, uint32_t v);
void cn_buf_u24(cn_buf *b, uint32_t v);
void cn_buf_u32(cn_buf *b, uint32_t v);
void cn_buf_u64(cn_buf *b, uint64_t v);
void cn_buf_f64(cn_buf *b, double v); /* IEEE 754 bits, little-endian */
void cn_buf_f32s(cn_buf *b, const float *x, size_t n); /* n floats, IEEE bits, little-endian */
/* Reads n floats written by cn_buf_f32s from p (4 n bytes). */
void cn_get_f32s(float *x, const uint8_t *p, size_t n);
void cn_buf_f64s(cn_buf *b, const double *x, size_t n); /* n doubles, as cn_buf_f64 */
/* Reads n doubles written by cn_buf_f64s from p (8 n bytes). */
void cn_get_f64s(double *x, const uint8_t *p, size_t n);
/* A double from its IEEE 754 bits, little-endian (cn_buf_f64's): *x = the 8 bytes at p. */
double cn_get_f64(const uint8_t *p);
/* The same from a reader (common/cn_reader.h): 0 once it has run out. */
struct cn_reader;
double cn_rd_f64(struct cn_reader *r);

/* ---- bit writer: MSB-first into a cn_buf, zero-padded to a byte on flush ---- */
typedef struct cn_bitw {
    cn_buf *out;
    uint32_t acc;
    unsigned nacc;
} cn_bitw;

void cn_bitw_init(cn_bitw *w, cn_buf *out);
void cn_bitw_put(cn_bitw *w, uint32_t v, unsigned n); /* n <= 24 */
void cn_bitw_eg(cn_bitw *w, uint32_t v, unsigned k);  /* Exp-Golomb of order k */
void cn_bitw_flush(cn_bitw *w);
/* Length in bits of the order-k Exp-Golomb code of v. */
unsigned cn_eg_bits(uint32_t v, unsigned k);

#endif /* CNERF_ENC_BUF_H */
