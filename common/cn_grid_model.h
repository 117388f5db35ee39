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

/* The cell along one axis of an offset s from the box's minimum, in Q16 units
 * (0 <= s <= w, w the box's width in Q16), with r = floor(g 2^32 / w):
 * min(g - 1, (s r) >> 32). s r <= g 2^32 < 2^39 (docs/bitstream.md, GRID). */
static inline uint32_t cn_grid_cell(uint64_t s, uint64_t r, uint32_t g)
{
    const uint64_t c = (s * r) >> 32;
    return c >= g ? g - 1u : (uint32_t)c;
}

#endif /* CNERF_COMMON_GRID_MODEL_H */
