/*
 * Byte and bit readers shared by the decoder and the encoder: little-endian, bounds-checked,
 * with a sticky error. Freestanding C99: <stddef.h>, <stdint.h> only.
 */
#ifndef CNERF_COMMON_READER_H
#define CNERF_COMMON_READER_H

#include <stddef.h>
#include <stdint.h>

/* ---- byte reader: little-endian, bounds-checked, sticky error ---- */
typedef struct cn_reader {
    const uint8_t *p;
    const uint8_t *end;
    int err; /* set once any read ran past `end`; reads then return 0 */
} cn_reader;

static inline void cn_rd_init(cn_reader *r, const uint8_t *p, size_t n)
{
    r->p = p;
    r->end = p + n;
    r->err = 0;
}

static inline size_t cn_rd_left(const cn_reader *r) { return (size_t)(r->end - r->p); }

/* Loads of little-endian numbers from p, whose bytes the caller has checked are there. */
static inline uint32_t cn_le16(const uint8_t *p) { return (uint32_t)p[0] | ((uint32_t)p[1] << 8); }
static inline uint32_t cn_le32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
           ((uint32_t)p[3] << 24);
}
static inline uint64_t cn_le64(const uint8_t *p)
{
    return (uint64_t)cn_le32(p) | ((uint64_t)cn_le32(p + 4) << 32);
}

static inline uint32_t cn_rd_u8(cn_reader *r)
{
    if (r->end - r->p < 1) {
        r->err = 1;
        return 0;
    }
    return *r->p++;
}

static inline uint32_t cn_rd_u16(cn_reader *r)
{
    if (r->end - r->p < 2) {
        r->err = 1;
        r->p = r->end;
        return 0;
    }
    uint32_t v = cn_le16(r->p);
    r->p += 2;
    return v;
}

static inline uint32_t cn_rd_u32(cn_reader *r)
{
    if (r->end - r->p < 4) {
        r->err = 1;
        r->p = r->end;
        return 0;
    }
    uint32_t v = cn_le32(r->p);
    r->p += 4;
    return v;
}

static inline uint64_t cn_rd_u64(cn_reader *r)
{
    const uint64_t lo = cn_rd_u32(r);
    return lo | ((uint64_t)cn_rd_u32(r) << 32);
}

/* Two's-complement sign extension of the low `bits` bits of v (1 <= bits <= 32),
 * written without implementation-defined conversions. */
static inline int32_t cn_sext(uint32_t v, unsigned bits)
{
    uint32_t sign = (uint32_t)1u << (bits - 1u);
    uint32_t mask = bits == 32u ? 0xFFFFFFFFu : (((uint32_t)1u << bits) - 1u);
    v &= mask;
    if (v & sign)
        return -(int32_t)(~v & mask) - 1; /* v - 2^bits */
    return (int32_t)v;
}

static inline int32_t cn_rd_i8(cn_reader *r) { return cn_sext(cn_rd_u8(r), 8); }
static inline int32_t cn_rd_i16(cn_reader *r) { return cn_sext(cn_rd_u16(r), 16); }
static inline int32_t cn_rd_i24(cn_reader *r)
{
    uint32_t lo = cn_rd_u16(r);
    uint32_t hi = cn_rd_u8(r);
    return cn_sext(lo | (hi << 16), 24);
}
static inline int32_t cn_rd_i32(cn_reader *r) { return cn_sext(cn_rd_u32(r), 32); }

/* ---- bit reader: MSB-first, bounds-checked, sticky error ---- */
typedef struct cn_bits {
    const uint8_t *p;
    const uint8_t *end;
    uint32_t acc;  /* the low `nacc` bits are unread */
    unsigned nacc;
    int err;
} cn_bits;

static inline void cn_bits_init(cn_bits *b, const uint8_t *p, size_t n)
{
    b->p = p;
    b->end = p + n;
    b->acc = 0;
    b->nacc = 0;
    b->err = 0;
}

/* Reads n bits, 0 <= n <= 24. */
static inline uint32_t cn_bits_get(cn_bits *b, unsigned n)
{
    while (b->nacc < n) {
        if (b->end - b->p < 1) {
            b->err = 1;
            return 0;
        }
        b->acc = (b->acc << 8) | *b->p++;
        b->nacc += 8u;
    }
    b->nacc -= n;
    uint32_t v = (b->acc >> b->nacc) & (((uint32_t)1u << n) - 1u);
    b->acc &= ((uint32_t)1u << b->nacc) - 1u;
    return v;
}

/* Bytes consumed so far (the partial last byte counts). */
static inline size_t cn_bits_used(const cn_bits *b, const uint8_t *start)
{
    return (size_t)(b->p - start);
}

/* Exp-Golomb code of order k (k <= CNERF_MAX_EG_ORDER); values up to 2^24 - 2^k.
 * Sets b->err on a code longer than that. */
static inline uint32_t cn_bits_eg(cn_bits *b, unsigned k)
{
    unsigned z = 0;
    while (cn_bits_get(b, 1) == 0u) {
        if (b->err || ++z + k > 24u) {
            b->err = 1;
            return 0;
        }
    }
    uint32_t q = ((uint32_t)1u << (z + k)) | cn_bits_get(b, z + k);
    return q - ((uint32_t)1u << k);
}

#endif /* CNERF_COMMON_READER_H */
