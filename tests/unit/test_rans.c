/* rANS coder and frequency tables: encoder against decoder, edge cases, coding gap. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_internal.h"
#include "cn_rng.h"
#include "testutil.h"

/* Encodes syms with freq, decodes with the decoder's cn_rans_decode, compares; returns
 * the payload size. */
static size_t roundtrip(const uint32_t *syms, size_t count, const uint32_t *freq, uint32_t n,
                        unsigned prec)
{
    cn_buf b = {0};
    assert_int_equal(cn_rans_encode(syms, count, freq, n, prec, &b), 0);
    uint32_t *cum = malloc(sizeof(uint32_t) * (n + 1));
    int32_t *out = malloc(sizeof(int32_t) * (count ? count : 1));
    assert_non_null(cum);
    assert_non_null(out);
    cum[0] = 0;
    for (uint32_t i = 0; i < n; i++)
        cum[i + 1] = cum[i] + freq[i];
    assert_int_equal(cn_rans_decode(b.p, b.n, cum, n, prec, 0, out, 4, (uint32_t)count),
                     CNERF_OK);
    for (size_t i = 0; i < count; i++)
        assert_int_equal(out[i], syms[i]);
    /* Asking for one symbol fewer leaves bytes or a wrong state: detected (a certain
     * symbol never changes the state, so only with two or more symbols). */
    if (count > 0 && n > 1)
        assert_int_equal(cn_rans_decode(b.p, b.n, cum, n, prec, 0, out, 4, (uint32_t)count - 1),
                         CNERF_E_PAYLOAD);
    size_t len = b.n;
    cn_buf_free(&b);
    free(cum);
    free(out);
    return len;
}

static void test_empty_payload(void **state)
{
    (void)state;
    uint32_t freq[2] = {1, 1};
    /* No symbols: only the 4-byte final state. */
    assert_int_equal(roundtrip(NULL, 0, freq, 2, 1), 4);
}

static void test_one_symbol_alphabet(void **state)
{
    (void)state;
    uint32_t freq[1] = {1u << 12};
    uint32_t syms[1000] = {0};
    /* A certain symbol costs nothing. */
    assert_int_equal(roundtrip(syms, 1000, freq, 1, 12), 4);
}

static void test_frequency_one_symbols(void **state)
{
    (void)state;
    /* Max precision, one symbol takes almost everything, others frequency 1. */
    enum { N = 5 };
    uint32_t freq[N] = {(1u << 16) - 4, 1, 1, 1, 1};
    cn_rng r = cn_rng_seed(3);
    uint32_t syms[20000];
    for (size_t i = 0; i < 20000; i++)
        syms[i] = cn_rng_below(&r, 100) == 0 ? 1 + cn_rng_below(&r, 4) : 0;
    roundtrip(syms, 20000, freq, N, 16);
    /* Runs of only the rarest symbols (the largest renormalisation steps). */
    for (size_t i = 0; i < 20000; i++)
        syms[i] = 1 + (uint32_t)(i % 4);
    size_t len = roundtrip(syms, 20000, freq, N, 16);
    assert_true(len >= 20000 * 2 - 8); /* 16 bits each */
}

static void test_max_precision_large_alphabet(void **state)
{
    (void)state;
    const uint32_t n = 65535;
    uint32_t *freq = malloc(sizeof(uint32_t) * n);
    for (uint32_t i = 0; i < n; i++)
        freq[i] = 1;
    freq[n / 2] += 1; /* sum = 65536 */
    cn_rng r = cn_rng_seed(5);
    size_t count = 100000;
    uint32_t *syms = malloc(sizeof(uint32_t) * count);
    for (size_t i = 0; i < count; i++)
        syms[i] = cn_rng_below(&r, n);
    roundtrip(syms, count, freq, n, 16);
    free(freq);
    free(syms);
}

/* Very long payloads at every precision; reports the gap to -sum log2 p. */
static void test_long_payload_gap(void **state)
{
    (void)state;
    const size_t count = 2000000;
    uint32_t *syms = malloc(sizeof(uint32_t) * count);
    cn_rng r = cn_rng_seed(11);
    for (unsigned prec = 8; prec <= 16; prec += 4) {
        /* A discretized Laplacian over 33 symbols. */
        enum { N = 33 };
        double p[N];
        for (int i = 0; i < N; i++)
            p[i] = exp(-fabs(i - 16.0) / 2.5);
        uint32_t freq[N];
        assert_int_equal(cn_quantize_pmf(p, N, prec, freq), 0);
        uint32_t cum[N + 1] = {0};
        for (int i = 0; i < N; i++)
            cum[i + 1] = cum[i] + freq[i];
        uint64_t cnt[N] = {0};
        for (size_t i = 0; i < count; i++) {
            uint32_t slot = cn_rng_below(&r, 1u << prec), s = 0;
            while (cum[s + 1] <= slot)
                s++;
            syms[i] = s;
            cnt[s]++;
        }
        double ideal = cn_table_cost_bits(cnt, freq, N, prec) / 8.0;
        size_t len = roundtrip(syms, count, freq, N, prec);
        double gap = (len - ideal) / ideal * 100.0;
        printf("# rANS prec %2u: %zu symbols, ideal %.0f bytes, coded %zu bytes, gap %.4f%%\n",
               prec, count, ideal, len, gap);
        assert_true(len >= ideal - 1);
        assert_true(gap < 0.1);
    }
    free(syms);
}

static void test_corrupt_payload_detected(void **state)
{
    (void)state;
    uint32_t freq[4] = {200, 30, 20, 6};
    uint32_t syms[5000];
    cn_rng r = cn_rng_seed(9);
    for (size_t i = 0; i < 5000; i++)
        syms[i] = cn_rng_below(&r, 4);
    cn_buf b = {0};
    assert_int_equal(cn_rans_encode(syms, 5000, freq, 4, 8, &b), 0);
    uint32_t cum[5] = {0, 200, 230, 250, 256};
    int32_t *out = malloc(sizeof(int32_t) * 5000);
    /* Truncated payloads and bad initial states. */
    for (size_t cut = 0; cut < b.n; cut += 1 + cut / 3)
        assert_int_equal(cn_rans_decode(b.p, cut, cum, 4, 8, 0, out, 4, 5000), CNERF_E_PAYLOAD);
    uint8_t bad[4] = {0, 0, 0, 0};
    assert_int_equal(cn_rans_decode(bad, 4, cum, 4, 8, 0, out, 4, 0), CNERF_E_PAYLOAD);
    uint8_t big[4] = {0, 0, 0, 0x80};
    assert_int_equal(cn_rans_decode(big, 4, cum, 4, 8, 0, out, 4, 0), CNERF_E_PAYLOAD);
    /* Extra trailing byte. */
    cn_buf_u8(&b, 0x55);
    assert_int_equal(cn_rans_decode(b.p, b.n, cum, 4, 8, 0, out, 4, 5000), CNERF_E_PAYLOAD);
    free(out);
    cn_buf_free(&b);
}

static void test_encoder_rejects_bad_input(void **state)
{
    (void)state;
    cn_buf b = {0};
    uint32_t freq[2] = {100, 100}; /* does not sum to 256 */
    uint32_t syms[2] = {0, 1};
    assert_int_equal(cn_rans_encode(syms, 2, freq, 2, 8, &b), -1);
    uint32_t ok[2] = {128, 128};
    uint32_t bad[1] = {2};
    assert_int_equal(cn_rans_encode(bad, 1, ok, 2, 8, &b), -1);
    assert_int_equal(cn_rans_encode(syms, 2, ok, 2, 17, &b), -1);
    cn_buf_free(&b);
}

/* ---- occupancy grids: context-coded bits ---- */

/* Decodes a grid payload of the coding gc into the grid stored by blocks; returns the
 * status, with the cells in `cells` (g^3 flags) and their count in *occupied. */
static cnerf_status grid_decode_flat(const uint8_t *payload, size_t len, const cn_grid_code *gc,
                                     uint8_t *cells, uint32_t *occupied)
{
    const uint32_t g = gc->g, nb = (g + 7) / 8;
    uint16_t *slot = malloc(sizeof *slot * nb * nb * nb);
    uint8_t *rec = malloc((size_t)gc->recs * CN_GRID_REC_BYTES + 1);
    memset(slot, 0xA5, sizeof *slot * nb * nb * nb); /* the decoder needs nothing zeroed */
    memset(rec, 0xA5, (size_t)gc->recs * CN_GRID_REC_BYTES + 1);
    const cnerf_status st = cn_grid_decode(payload, len, gc, slot, rec, occupied);
    for (uint32_t z = 0, i = 0; st == CNERF_OK && z < g; z++)
        for (uint32_t y = 0; y < g; y++)
            for (uint32_t x = 0; x < g; x++, i++)
                cells[i] = (uint8_t)cn_grid_block_bit(slot, rec, nb, 0, x, y, z);
    for (uint32_t b = 0; st == CNERF_OK && b < nb * nb * nb; b++)
        assert_true(slot[b] == CN_GRID_NO_BLOCK || slot[b] < gc->recs);
    free(slot);
    free(rec);
    return st;
}

static uint16_t le16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }

/* Codes occ (g^3 flags) with cn_grid_encode (BGRD, blocks 1) or cn_grid_encode_raster
 * (GRID), reads the fixed fields back and decodes with the decoder's cn_grid_decode; returns
 * the payload size and checks every cell and the count. */
static size_t grid_roundtrip(const uint8_t *occ, uint32_t g, unsigned prec, int blocks)
{
    cn_buf b = {0};
    assert_int_equal(blocks ? cn_grid_encode(occ, g, prec, &b)
                            : cn_grid_encode_raster(occ, g, prec, &b),
                     0);
    const size_t fixed = blocks ? CNERF_BGRD_FIXED_BYTES : CNERF_GRID_FIXED_BYTES;
    assert_true(b.n >= fixed + 4);
    assert_int_equal(b.p[0], g);
    assert_int_equal(b.p[1], prec);
    uint16_t f1[CNERF_GRID_CONTEXTS], fb1[CNERF_GRID_CONTEXTS];
    const uint8_t *f = b.p + (blocks ? 4 + 2 * CNERF_GRID_CONTEXTS : 2);
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++) {
        f1[c] = le16(f + 2 * c);
        fb1[c] = blocks ? le16(b.p + 4 + 2 * c) : 0;
        assert_true(f1[c] >= 1 && f1[c] < (1u << prec));
        assert_true(!blocks || (fb1[c] >= 1 && fb1[c] < (1u << prec)));
    }
    const uint32_t nb = (g + 7) / 8;
    /* the occupied blocks, as the encoder counts them */
    uint32_t want_blocks = 0, want = 0;
    for (uint32_t B = 0; B < nb * nb * nb; B++) {
        const uint32_t X = B % nb, Y = B / nb % nb, Z = B / nb / nb;
        int any = 0;
        for (uint32_t z = Z * 8; z < Z * 8 + 8 && z < g; z++)
            for (uint32_t y = Y * 8; y < Y * 8 + 8 && y < g; y++)
                for (uint32_t x = X * 8; x < X * 8 + 8 && x < g; x++)
                    any |= occ[((size_t)z * g + y) * g + x] != 0;
        want_blocks += (uint32_t)any;
    }
    if (blocks)
        assert_int_equal(le16(b.p + 2), want_blocks);
    cn_grid_code gc = {g, prec, f1, blocks ? fb1 : NULL, blocks ? want_blocks : nb * nb * nb};
    const size_t cells = (size_t)g * g * g;
    uint8_t *got = malloc(cells);
    uint32_t occupied = 12345;
    assert_int_equal(grid_decode_flat(b.p + fixed, b.n - fixed, &gc, got, &occupied), CNERF_OK);
    for (size_t i = 0; i < cells; i++) {
        assert_int_equal(got[i], occ[i] != 0);
        want += occ[i] != 0;
    }
    assert_int_equal(occupied, want);
    /* One cell more or fewer per axis than coded: the payload is not consumed exactly. */
    if (g > 1) {
        cn_grid_code other = gc;
        for (int d = -1; d <= 1; d += 2) {
            other.g = (uint32_t)((int)g + d);
            const uint32_t onb = (other.g + 7) / 8;
            if (!blocks)
                other.recs = onb * onb * onb;
            uint8_t *big = malloc((size_t)(g + 1) * (g + 1) * (g + 1));
            /* BGRD codes no cell of an empty block: another g of the same blocks may
             * decode (the grid is then another one) */
            if (other.recs <= onb * onb * onb && (!blocks || onb != nb))
                assert_int_equal(grid_decode_flat(b.p + fixed, b.n - fixed, &other, big,
                                                  &occupied),
                                 CNERF_E_PAYLOAD);
            free(big);
        }
    }
    /* BGRD: a count of occupied blocks other than the payload's */
    if (blocks) {
        cn_grid_code other = gc;
        for (int d = -1; d <= 1; d += 2) {
            if ((d < 0 && !want_blocks) || (d > 0 && want_blocks == nb * nb * nb))
                continue;
            other.recs = (uint32_t)((int)want_blocks + d);
            assert_int_equal(grid_decode_flat(b.p + fixed, b.n - fixed, &other, got, &occupied),
                             CNERF_E_PAYLOAD);
        }
    }
    const size_t len = b.n;
    cn_buf_free(&b);
    free(got);
    return len;
}

/* A BGRD payload of chosen bits: every frequency one half, so that cn_rans_encode's
 * two-symbol table codes them. */
static void grid_bits(const uint32_t *bits, size_t n, cn_buf *out)
{
    const uint32_t half[2] = {1u << (CN_GRID_PREC - 1), 1u << (CN_GRID_PREC - 1)};
    assert_int_equal(cn_rans_encode(bits, n, half, 2, CN_GRID_PREC, out), 0);
}

/* BGRD's rules on the blocks: a block said to be occupied must have an occupied cell. */
static void test_grid_blocks_rules(void **state)
{
    (void)state;
    uint16_t f[CNERF_GRID_CONTEXTS];
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
        f[c] = 1u << (CN_GRID_PREC - 1);
    const cn_grid_code gc = {8, CN_GRID_PREC, f, f, 1};
    uint32_t bits[1 + 512] = {1}; /* the one block occupied, then its cells */
    uint8_t cells[512];
    uint32_t occupied;
    cn_buf b = {0};
    grid_bits(bits, 513, &b);
    assert_int_equal(grid_decode_flat(b.p, b.n, &gc, cells, &occupied), CNERF_E_PAYLOAD);
    bits[1 + 300] = 1; /* one cell: valid */
    b.n = 0;
    grid_bits(bits, 513, &b);
    assert_int_equal(grid_decode_flat(b.p, b.n, &gc, cells, &occupied), CNERF_OK);
    assert_int_equal(occupied, 1);
    assert_int_equal(cells[300], 1);
    /* g = 9: 8 blocks; only block 7's one cell (8, 8, 8) lies in the grid */
    const cn_grid_code g9 = {9, CN_GRID_PREC, f, f, 1};
    uint32_t b9[8 + 1] = {0, 0, 0, 0, 0, 0, 0, 1, 1};
    uint8_t c9[729];
    b.n = 0;
    grid_bits(b9, 9, &b);
    assert_int_equal(grid_decode_flat(b.p, b.n, &g9, c9, &occupied), CNERF_OK);
    assert_int_equal(occupied, 1);
    assert_int_equal(c9[728], 1);
    cn_buf_free(&b);
}

static void test_grid_roundtrip(void **state)
{
    (void)state;
    cn_rng r = cn_rng_seed(41);
    const uint32_t gs[] = {1, 2, 3, 7, 8, 9, 16, 33};
    const double p1[] = {0.0, 0.02, 0.5, 0.97, 1.0};
    for (size_t a = 0; a < sizeof gs / sizeof gs[0]; a++)
        for (size_t b = 0; b < sizeof p1 / sizeof p1[0]; b++) {
            const uint32_t g = gs[a];
            const size_t cells = (size_t)g * g * g;
            uint8_t *occ = malloc(cells);
            for (size_t i = 0; i < cells; i++)
                occ[i] = cn_rng_uniform(&r) < p1[b];
            for (int blocks = 0; blocks < 2; blocks++) {
                grid_roundtrip(occ, g, CN_GRID_PREC, blocks);
                grid_roundtrip(occ, g, 2, blocks);
                grid_roundtrip(occ, g, CNERF_MAX_PREC, blocks);
            }
            free(occ);
        }
}

/* A ball: the contexts make a smooth shape cost far less than a bit per cell, and an empty or
 * full grid next to nothing. */
static void test_grid_coding_cost(void **state)
{
    (void)state;
    const uint32_t g = 64;
    const size_t cells = (size_t)g * g * g;
    uint8_t *occ = malloc(cells);
    size_t n1 = 0;
    for (size_t i = 0; i < cells; i++) {
        const double x = (double)(i % g) - 31.5, y = (double)(i / g % g) - 31.5,
                     z = (double)(i / g / g) - 31.5;
        occ[i] = x * x + y * y + z * z < 20.0 * 20.0;
        n1 += occ[i];
    }
    uint8_t *ball_occ = malloc(cells);
    memcpy(ball_occ, occ, cells);
    for (int blocks = 0; blocks < 2; blocks++) {
        memcpy(occ, ball_occ, cells);
        const size_t ball = grid_roundtrip(occ, g, CN_GRID_PREC, blocks);
        memset(occ, 0, cells);
        const size_t empty = grid_roundtrip(occ, g, CN_GRID_PREC, blocks);
        memset(occ, 1, cells);
        const size_t full = grid_roundtrip(occ, g, CN_GRID_PREC, blocks);
        print_message("# grid 64^3 %s: ball of %zu cells %zu bytes (%.4f bits per cell), "
                      "empty %zu, full %zu\n", blocks ? "BGRD" : "GRID", n1, ball,
                      8.0 * (double)ball / (double)cells, empty, full);
        assert_true(8 * ball < cells / 10);
        assert_true(empty < 128 && full < 128);
    }
    free(ball_occ);
    free(occ);
}

static void test_grid_encoder_rejects(void **state)
{
    (void)state;
    uint8_t occ[8] = {0};
    cn_buf b = {0};
    assert_int_equal(cn_grid_encode(occ, 0, CN_GRID_PREC, &b), -1);
    assert_int_equal(cn_grid_encode(occ, CNERF_MAX_GRID + 1, CN_GRID_PREC, &b), -1);
    assert_int_equal(cn_grid_encode(occ, 2, 1, &b), -1);
    assert_int_equal(cn_grid_encode(occ, 2, CNERF_MAX_PREC + 1, &b), -1);
    assert_int_equal(cn_grid_encode_raster(occ, 0, CN_GRID_PREC, &b), -1);
    assert_int_equal(cn_grid_encode_raster(occ, 2, 1, &b), -1);
    assert_int_equal(b.n, 0);
    cn_buf_free(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_empty_payload),
        cmocka_unit_test(test_one_symbol_alphabet),
        cmocka_unit_test(test_frequency_one_symbols),
        cmocka_unit_test(test_max_precision_large_alphabet),
        cmocka_unit_test(test_long_payload_gap),
        cmocka_unit_test(test_corrupt_payload_detected),
        cmocka_unit_test(test_encoder_rejects_bad_input),
        cmocka_unit_test(test_grid_roundtrip),
        cmocka_unit_test(test_grid_blocks_rules),
        cmocka_unit_test(test_grid_coding_cost),
        cmocka_unit_test(test_grid_encoder_rejects),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
