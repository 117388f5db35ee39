/*
 * Decoder internals shared by its translation units (and by unit tests).
 * Freestanding: <stdint.h>, <stddef.h> only.
 */
#ifndef CNERF_DECODER_INTERNAL_H
#define CNERF_DECODER_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "cnerf/cnerf.h"

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
    uint32_t v = (uint32_t)r->p[0] | ((uint32_t)r->p[1] << 8);
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
    uint32_t v = (uint32_t)r->p[0] | ((uint32_t)r->p[1] << 8) | ((uint32_t)r->p[2] << 16) |
                 ((uint32_t)r->p[3] << 24);
    r->p += 4;
    return v;
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

/* ---- frequency tables and rANS ---- */

/* Parses a coded frequency table of `n` >= 2 symbols with precision `prec` and
 * Exp-Golomb order `k` from b. Writes the cumulative table cum[0..n] (cum[0] = 0,
 * cum[n] = 2^prec) when `cum` is not NULL. Returns CNERF_OK or CNERF_E_TABLE (also for
 * a table that runs past its chunk). */
cnerf_status cn_table_read(cn_bits *b, uint32_t n, unsigned prec, unsigned k, uint32_t *cum);

/* Decodes `count` symbols from the rANS payload[0..len) with the cumulative table
 * cum[0..n] of precision `prec`. Symbol s is stored as (s + offset) into out, an array
 * of elements of `elem_bytes` (1: int8_t, 2: int16_t, 4: int32_t). The payload must
 * be consumed exactly and end in the encoder's initial state, else CNERF_E_PAYLOAD. */
cnerf_status cn_rans_decode(const uint8_t *payload, size_t len, const uint32_t *cum, uint32_t n,
                            unsigned prec, int32_t offset, void *out, unsigned elem_bytes,
                            uint32_t count);

/* Decodes a GRID payload[0..len): g^3 bits in raster order (x fastest, then y, then z),
 * each with binary rANS of precision `prec` under the context of its already decoded
 * neighbours (cn_grid_context), into the bitmap `bits` (bit i at bits[i >> 3],
 * 1 << (i & 7); the bits after the last cell are 0). Counts the occupied cells into *occupied. CNERF_E_PAYLOAD unless the
 * payload is consumed exactly and ends in the encoder's initial state. */
cnerf_status cn_grid_decode(const uint8_t *payload, size_t len, uint32_t g, unsigned prec,
                            const uint16_t *f1, uint8_t *bits, uint32_t *occupied);

static inline uint32_t cn_grid_bit(const uint8_t *bits, uint32_t i)
{
    return ((uint32_t)bits[i >> 3] >> (i & 7u)) & 1u;
}

/* Context of cell (x, y, z): occupied(x-1, y, z) + 2 occupied(x, y-1, z) +
 * 4 occupied(x, y, z-1), a neighbour outside the grid counting as empty. */
static inline uint32_t cn_grid_context(const uint8_t *bits, uint32_t g, uint32_t x, uint32_t y,
                                       uint32_t z)
{
    const uint32_t i = (z * g + y) * g + x;
    return (x ? cn_grid_bit(bits, i - 1u) : 0u) | (y ? cn_grid_bit(bits, i - g) << 1 : 0u) |
           (z ? cn_grid_bit(bits, i - g * g) << 2 : 0u);
}

/* The cell along one axis of an offset s from the box's minimum, in Q16 units
 * (0 <= s <= w, w the box's width in Q16), with r = floor(g 2^32 / w):
 * min(g - 1, (s r) >> 32). s r <= g 2^32 < 2^39 (docs/bitstream.md, GRID). */
static inline uint32_t cn_grid_cell(uint64_t s, uint64_t r, uint32_t g)
{
    const uint64_t c = (s * r) >> 32;
    return c >= g ? g - 1u : (uint32_t)c;
}

/* ---- container walk ---- */

/* Parses a HEAD payload of clen bytes into info (render parameters, expanded topology);
 * info->version_minor says which values the HEAD may hold. */
cnerf_status cn_parse_head(const uint8_t *p, uint32_t clen, cnerf_info *info);

/* Parses the whole stream into `info`, describing scene `scene` (CNERF_E_ARG after a
 * complete walk when the stream has fewer scenes); used by cnerf_peek and cnerf_open. */
cnerf_status cn_parse(const uint8_t *buf, size_t len, uint32_t scene, cnerf_info *info);

/* 1 for the layers whose outputs leave the networks (density and colour): the renderer
 * writes them by output index, every other layer's outputs in its stored row order. */
int cn_layer_final(const cnerf_layer_info *L);

/* Freestanding memset. */
void cn_memzero(void *p, size_t n);

#endif /* CNERF_DECODER_INTERNAL_H */
