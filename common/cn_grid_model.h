/*
 * The occupancy grid's bitmap and context model (docs/bitstream.md, GRID), shared by the
 * decoder, which reads it, and the encoder, which codes it. Freestanding C99.
 */
#ifndef CNERF_COMMON_GRID_MODEL_H
#define CNERF_COMMON_GRID_MODEL_H

#include <stdint.h>

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

/* ---- the grid stored by blocks (the decoder's workspace, docs/decoder.md) ----
 * Blocks of CN_GRID_B^3 cells, nb = ceil(g / CN_GRID_B) per axis, block (X, Y, Z) at index
 * (Z nb + Y) nb + X. slot[block] is the index of the block's record, or CN_GRID_NO_BLOCK for a
 * block whose cells are all empty. A record is CN_GRID_REC_BITS bits, records one after
 * another bit by bit: the block's 512 cells (local (z 8 + y) 8 + x), then the grid's
 * summary over it, 4^3 bits of level 1 and 2^3 of level 2 (a level-k cell is set when one
 * of the cells of level k - 1 it covers is). Cells outside the grid are empty. */
#define CN_GRID_B 8u
#define CN_GRID_NO_BLOCK 0xFFFFu
#define CN_GRID_REC_BITS 584u
#define CN_GRID_REC_BYTES 73u

/* First bit of summary level k (0: the cells, 1, 2) in a record. */
static inline uint32_t cn_grid_rec_level(unsigned k)
{
    return k == 0u ? 0u : k == 1u ? 512u : 576u;
}

/* Bit of record r at bit offset i of its own (0 for CN_GRID_NO_BLOCK). */
static inline uint32_t cn_grid_rec_bit(const uint8_t *rec, uint32_t r, uint32_t i)
{
    return r == CN_GRID_NO_BLOCK ? 0u : cn_grid_bit(rec, r * CN_GRID_REC_BITS + i);
}

/* Cell (x, y, z) of summary level k < 3 (level 0: the grid's cells). */
static inline uint32_t cn_grid_block_bit(const uint16_t *slot, const uint8_t *rec, uint32_t nb,
                                         unsigned k, uint32_t x, uint32_t y, uint32_t z)
{
    const unsigned s = 3u - k;
    const uint32_t m = (1u << s) - 1u;
    return cn_grid_rec_bit(rec, slot[((z >> s) * nb + (y >> s)) * nb + (x >> s)],
                           cn_grid_rec_level(k) + ((((z & m) << s) | (y & m)) << s | (x & m)));
}

/* The cell along one axis of an offset s from the box's minimum, in Q16 units
 * (0 <= s <= w, w the box's width in Q16), with r = floor(g 2^32 / w):
 * min(g - 1, (s r) >> 32). s r <= g 2^32 < 2^39 (docs/bitstream.md, GRID). */
static inline uint32_t cn_grid_cell(uint64_t s, uint64_t r, uint32_t g)
{
    const uint64_t c = (s * r) >> 32;
    return c >= g ? g - 1u : (uint32_t)c;
}

#endif /* CNERF_COMMON_GRID_MODEL_H */
