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

/* ---- the occupancy grid (docs/bitstream.md, GRID and BGRD) ---- */

/* C99 has no static assertion: an array of negative size does not compile. */
typedef char cn_grid_block_is_format_block[CN_GRID_B == CNERF_GRID_BLOCK ? 1 : -1];

/* A binary rANS decoder: symbol 0 (empty) owns [0, 2^prec - one), symbol 1 (occupied)
 * [2^prec - one, 2^prec). */
typedef struct bin_dec {
    uint32_t x;
    const uint8_t *p, *end;
    unsigned prec;
    int err; /* the payload ran out */
} bin_dec;

static uint32_t bin_get(bin_dec *d, uint32_t one)
{
    const uint32_t total = (uint32_t)1u << d->prec, f0 = total - one, slot = d->x & (total - 1u);
    uint32_t bit;
    if (slot >= f0) {
        d->x = one * (d->x >> d->prec) + slot - f0;
        bit = 1u;
    } else {
        d->x = f0 * (d->x >> d->prec) + slot;
        bit = 0u;
    }
    while (d->x < CNERF_RANS_L) {
        if (d->p == d->end) {
            d->err = 1;
            return 0u;
        }
        d->x = (d->x << 8) | *d->p++;
    }
    return bit;
}

/* A block being decoded: its record r, the records of its neighbours before it along x, y
 * and z (CN_GRID_NO_BLOCK: none or empty), its cells per row inside the grid. */
typedef struct block_at {
    uint8_t *rec;
    const uint16_t *f1;
    uint32_t r, rx, ry, rz, nx;
} block_at;

/* The cells lx = 0 .. nx-1 of row (ly, lz) of block b, each under the context of its three
 * neighbours. Returns the occupied cells. The
 * coder's state is kept in locals for the row (the loop runs for every cell of a grid). */
static uint32_t decode_row(bin_dec *d, const block_at *b, uint32_t ly, uint32_t lz)
{
    uint8_t *rec = b->rec;
    const uint16_t *f1 = b->f1;
    const uint32_t nx = b->nx, rx = b->rx, ry = b->ry, rz = b->rz;
    uint32_t n1 = 0, x = d->x;
    const uint8_t *p = d->p;
    const unsigned prec = d->prec;
    const uint32_t total = (uint32_t)1u << prec, mask = total - 1u;
    const uint32_t row = (lz * CN_GRID_B + ly) * CN_GRID_B, base = b->r * CN_GRID_REC_BITS + row;
    for (uint32_t lx = 0; lx < nx; lx++) {
        const uint32_t l = row + lx, i = base + lx;
        const uint32_t c = (lx ? cn_grid_bit(rec, i - 1u) : cn_grid_rec_bit(rec, rx, l + 7u)) |
                           (ly ? cn_grid_bit(rec, i - 8u) : cn_grid_rec_bit(rec, ry, l + 56u)) << 1 |
                           (lz ? cn_grid_bit(rec, i - 64u) : cn_grid_rec_bit(rec, rz, l + 448u)) << 2;
        const uint32_t one = f1[c], f0 = total - one, slot = x & mask;
        if (slot >= f0) {
            x = one * (x >> prec) + slot - f0;
            rec[i >> 3] = (uint8_t)(rec[i >> 3] | (1u << (i & 7u)));
            n1++;
        } else {
            x = f0 * (x >> prec) + slot;
        }
        while (x < CNERF_RANS_L) {
            if (p == d->end) {
                d->err = 1;
                d->x = x;
                d->p = p;
                return n1;
            }
            x = (x << 8) | *p++;
        }
    }
    d->x = x;
    d->p = p;
    return n1;
}

/* Record of block (X, Y, Z) less one along axis a (CN_GRID_NO_BLOCK at the grid's edge). */
static uint32_t before(const uint16_t *slot, uint32_t nb, uint32_t X, uint32_t Y, uint32_t Z,
                       unsigned a)
{
    if ((a == 0u && !X) || (a == 1u && !Y) || (a == 2u && !Z))
        return CN_GRID_NO_BLOCK;
    const uint32_t dz = a == 2u ? 1u : 0u, dy = a == 1u ? 1u : 0u, dx = a == 0u ? 1u : 0u;
    return slot[((Z - dz) * nb + (Y - dy)) * nb + (X - dx)];
}

/* Cells of block X along an axis that lie inside a grid of g. */
static uint32_t cells_in(uint32_t g, uint32_t X)
{
    return g - X * CN_GRID_B < CN_GRID_B ? g - X * CN_GRID_B : CN_GRID_B;
}

cnerf_status cn_grid_decode(const uint8_t *payload, size_t len, const cn_grid_code *gc,
                            uint16_t *slot, uint8_t *rec, uint32_t *occupied)
{
    bin_dec d;
    if (!initial_state(payload, len, &d.x))
        return CNERF_E_PAYLOAD;
    d.p = payload + 4;
    d.end = payload + len;
    d.prec = gc->prec;
    d.err = 0;
    const uint32_t g = gc->g, nb = (g + CN_GRID_B - 1u) / CN_GRID_B;
    uint32_t n1 = 0, recs = 0;
    /* the blocks: BGRD codes one bit each; GRID gives every block a record */
    for (uint32_t Z = 0, b = 0; Z < nb; Z++)
        for (uint32_t Y = 0; Y < nb; Y++)
            for (uint32_t X = 0; X < nb; X++, b++) {
                uint32_t on = 1u;
                if (gc->fb1) {
                    const uint32_t c = (before(slot, nb, X, Y, Z, 0) != CN_GRID_NO_BLOCK ? 1u : 0u) |
                                       (before(slot, nb, X, Y, Z, 1) != CN_GRID_NO_BLOCK ? 2u : 0u) |
                                       (before(slot, nb, X, Y, Z, 2) != CN_GRID_NO_BLOCK ? 4u : 0u);
                    on = bin_get(&d, gc->fb1[c]);
                }
                if (on && recs == gc->recs)
                    return CNERF_E_PAYLOAD; /* more occupied blocks than the chunk says */
                slot[b] = (uint16_t)(on ? recs++ : CN_GRID_NO_BLOCK);
            }
    if (d.err || recs != gc->recs)
        return CNERF_E_PAYLOAD;
    cn_memzero(rec, (size_t)recs * CN_GRID_REC_BYTES);
    if (gc->fb1) {
        /* the cells of each occupied block in turn, the block's own raster order */
        for (uint32_t Z = 0, b = 0; Z < nb; Z++)
            for (uint32_t Y = 0; Y < nb; Y++)
                for (uint32_t X = 0; X < nb; X++, b++) {
                    const uint32_t r = slot[b];
                    if (r == CN_GRID_NO_BLOCK)
                        continue;
                    const block_at at = {rec, gc->f1, r, before(slot, nb, X, Y, Z, 0),
                                         before(slot, nb, X, Y, Z, 1),
                                         before(slot, nb, X, Y, Z, 2), cells_in(g, X)};
                    const uint32_t ny = cells_in(g, Y), nz = cells_in(g, Z);
                    uint32_t in_block = 0;
                    for (uint32_t lz = 0; lz < nz; lz++)
                        for (uint32_t ly = 0; ly < ny; ly++)
                            in_block += decode_row(&d, &at, ly, lz);
                    if (!in_block)
                        return CNERF_E_PAYLOAD; /* an occupied block without a cell */
                    n1 += in_block;
                }
    } else {
        /* GRID: the cells in raster order, a row of a block at a time (GRID gives block b
         * record b, so a neighbour's record is its index) */
        for (uint32_t z = 0; z < g; z++)
            for (uint32_t y = 0; y < g; y++) {
                const uint32_t Y = y / CN_GRID_B, Z = z / CN_GRID_B, b0 = (Z * nb + Y) * nb;
                block_at at = {rec, gc->f1, b0, CN_GRID_NO_BLOCK,
                               Y ? b0 - nb : CN_GRID_NO_BLOCK,
                               Z ? b0 - nb * nb : CN_GRID_NO_BLOCK, CN_GRID_B};
                for (uint32_t X = 0; X < nb; X++) {
                    at.nx = cells_in(g, X);
                    n1 += decode_row(&d, &at, y % CN_GRID_B, z % CN_GRID_B);
                    at.rx = at.r++;
                    at.ry += at.ry != CN_GRID_NO_BLOCK;
                    at.rz += at.rz != CN_GRID_NO_BLOCK;
                }
            }
    }
    if (d.err || d.p != d.end || d.x != CNERF_RANS_L)
        return CNERF_E_PAYLOAD;
    *occupied = n1;
    return CNERF_OK;
}
