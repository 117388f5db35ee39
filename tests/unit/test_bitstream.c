/* Bitstream round trips: random models of many shapes are written, opened and compared
 * integer for integer; workspace rules; pinned workspace sizes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cn_internal.h"
#include "testutil.h"

/* Writes `s`, opens it and checks every field, latent and bias against the source. */
static void check_roundtrip(const cn_synth *s)
{
    cn_buf b = {0};
    char err[256] = "";
    if (cn_write_stream(&s->src, &b, NULL, err, sizeof err))
        fail_msg("write: %s", err);
    cnerf_decoder *dec = malloc(sizeof *dec);
    void *ws = NULL;
    assert_int_equal(tu_open(dec, b.p, b.n, &ws), CNERF_OK);
    const cnerf_info *I = &dec->info;
    assert_int_equal(I->file_bytes, b.n);
    const cnerf_info *H = &s->src.hdr;
    assert_int_equal(I->coord, H->coord);
    assert_int_equal(I->near_q16, H->near_q16);
    assert_int_equal(I->far_q16, H->far_q16);
    assert_memory_equal(I->aabb_q16, H->aabb_q16, sizeof H->aabb_q16);
    assert_memory_equal(I->background, H->background, 3);
    assert_int_equal(I->n_coarse, H->n_coarse);
    assert_int_equal(I->n_fine, H->n_fine);
    for (uint32_t l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        const cn_layer_src *S = &s->src.layer[l];
        assert_int_equal(L->a_m, S->a_m);
        assert_int_equal(L->a_e, S->a_e);
        assert_int_equal(L->b_m, S->b_m);
        assert_int_equal(L->b_e, S->b_e);
        int32_t kmin = S->k[0], kmax = S->k[0];
        for (uint32_t o = 0; o < L->n_out; o++) {
            int32_t want = S->bias_m && S->bias_bits ? S->bias_m[o] : 0;
            assert_int_equal(cnerf_bias(dec, l, o), want);
            for (uint32_t i = 0; i < L->n_in; i++) {
                int32_t k = S->k[o * L->n_in + i];
                kmin = k < kmin ? k : kmin;
                kmax = k > kmax ? k : kmax;
                if (cnerf_latent(dec, l, o, i) != k)
                    fail_msg("layer %u latent [%u][%u]: %d != %d", l, o, i,
                             cnerf_latent(dec, l, o, i), k);
            }
        }
        assert_int_equal(L->kmin, kmin);
        assert_int_equal(L->kmax, kmax);
        assert_int_equal(L->f_in, S->f_in);
    }
    free(ws);
    free(dec);
    cn_buf_free(&b);
}

static void roundtrip_header(const cnerf_info *hdr, uint64_t seed, double spread)
{
    cn_synth s;
    char err[256];
    if (tu_synth(&s, hdr, seed, spread, err, sizeof err))
        fail_msg("synth: %s", err);
    check_roundtrip(&s);
    cn_synth_free(&s);
}

static void test_presets(void **state)
{
    (void)state;
    const char *names[] = {"tiny", "small"};
    for (int i = 0; i < 2; i++) {
        cnerf_info hdr;
        assert_int_equal(cn_preset_header(names[i], &hdr), 0);
        roundtrip_header(&hdr, 100 + (uint64_t)i, 2.0);
    }
}

static void test_many_shapes(void **state)
{
    (void)state;
    uint64_t seed = 1;
    for (unsigned depth = 1; depth <= 5; depth += 2)
        for (unsigned width = 1; width <= 33; width += 16)
            for (int two = 0; two <= 1; two++)
                for (int view = 0; view <= 1; view++) {
                    cnerf_info hdr;
                    tu_small_header(&hdr, depth, width, two);
                    for (unsigned n = 0; n < 2; n++)
                        hdr.net[n].view_width = view ? (uint16_t)(width / 2 + 1) : 0;
                    roundtrip_header(&hdr, seed, 0.3 + (double)(seed % 5));
                    seed++;
                }
}

/* 1-wide layers everywhere, no skip, no raw input, L = 1. */
static void test_one_wide(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 1, 1, 1);
    hdr.l_pos = 1;
    hdr.l_dir = 0;
    hdr.pe_flags = 0;
    hdr.net[0].view_width = hdr.net[1].view_width = 1;
    roundtrip_header(&hdr, 7, 1.0);
}

/* All latents equal: every layer is constant and codes nothing. */
static void test_constant_layers(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 8, 1);
    cn_synth s;
    char err[256];
    assert_int_equal(tu_synth(&s, &hdr, 3, 0.0, err, sizeof err), 0);
    cnerf_info info = hdr;
    assert_int_equal(cnerf_expand_topology(&info), CNERF_OK);
    /* Constant at different values, including the extremes (int16 storage). */
    const int32_t vals[] = {0, 5, -CNERF_MAX_ABS_K, CNERF_MAX_ABS_K, -128, 127};
    for (uint32_t l = 0; l < info.n_layers; l++)
        for (uint32_t i = 0; i < (uint32_t)info.layer[l].n_in * info.layer[l].n_out; i++)
            s.k[l][i] = vals[l % 6];
    check_roundtrip(&s);
    cn_buf b = {0};
    assert_int_equal(cn_write_stream(&s.src, &b, NULL, err, sizeof err), 0);
    assert_int_equal(cnerf_peek(b.p, b.n, &info), CNERF_OK);
    for (uint32_t l = 0; l < info.n_layers; l++) {
        assert_int_equal(info.layer[l].payload_bytes, 0);
        assert_int_equal(info.layer[l].prec, 0);
    }
    cn_buf_free(&b);
    cn_synth_free(&s);
}

/* Latent ranges up to the format's limit: the widest alphabet, precision 16. */
static void test_full_latent_range(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 16, 0);
    cn_synth s;
    char err[256];
    assert_int_equal(tu_synth(&s, &hdr, 9, 20000.0, err, sizeof err), 0);
    s.k[0][0] = -CNERF_MAX_ABS_K;
    s.k[0][1] = CNERF_MAX_ABS_K;
    check_roundtrip(&s);
    cn_buf b = {0};
    assert_int_equal(cn_write_stream(&s.src, &b, NULL, err, sizeof err), 0);
    cnerf_info info;
    assert_int_equal(cnerf_peek(b.p, b.n, &info), CNERF_OK);
    assert_int_equal(info.layer[0].kmax - info.layer[0].kmin + 1, 65535);
    assert_int_equal(info.layer[0].prec, 16);
    assert_true(info.layer[0].f_in >= CNERF_F_MIN && info.layer[0].f_in <= CNERF_F_MAX);
    cn_buf_free(&b);
    /* Outside the range: the writer refuses with a message. */
    s.k[0][0] = -CNERF_MAX_ABS_K - 1;
    assert_int_equal(cn_write_stream(&s.src, &b, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "outside"));
    cn_buf_free(&b);
    /* An input scale outside the format's range: refused with the range, nothing written. */
    s.k[0][0] = 0;
    for (int f = CNERF_F_MIN - 1; f <= CNERF_F_MAX + 1; f += CNERF_F_MAX - CNERF_F_MIN + 2) {
        s.src.layer[1].f_in = (int8_t)f;
        assert_int_equal(cn_write_stream(&s.src, &b, NULL, err, sizeof err), -1);
        assert_non_null(strstr(err, "layer 1: input scale"));
        assert_non_null(strstr(err, "outside -15..16"));
        cn_buf_free(&b);
    }
    cn_synth_free(&s);
}

/* Widths, depth and encoding octaves at their limits. */
static void test_limits(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, CNERF_MAX_WIDTH, 0);
    hdr.l_pos = CNERF_MAX_L_POS;
    hdr.l_dir = CNERF_MAX_L_DIR;
    hdr.net[0].view_width = CNERF_MAX_VIEW_WIDTH;
    hdr.n_coarse = CNERF_MAX_SAMPLES;
    roundtrip_header(&hdr, 13, 1.5);
    cnerf_info info = hdr;
    assert_int_equal(cnerf_expand_topology(&info), CNERF_OK);
    assert_int_equal(info.layer[2].n_in, CNERF_MAX_LAYER_IN);
    /* Deepest networks, both of them. */
    tu_small_header(&hdr, CNERF_MAX_DEPTH, 4, 1);
    hdr.net[0].skip = hdr.net[1].skip = CNERF_MAX_DEPTH - 2;
    roundtrip_header(&hdr, 14, 1.5);
    info = hdr;
    assert_int_equal(cnerf_expand_topology(&info), CNERF_OK);
    assert_int_equal(info.n_layers, CNERF_MAX_LAYERS);
}

/* A prior PMF offered to the writer: whichever table codes smaller is kept, and a
 * mismatched prior is never chosen over the counts when it costs more. */
static void test_table_choice(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 32, 0);
    cn_synth s;
    char err[256];
    assert_int_equal(tu_synth(&s, &hdr, 21, 3.0, err, sizeof err), 0);
    /* A deliberately wrong prior (uniform over a huge range). */
    static double flat[2001];
    for (int i = 0; i < 2001; i++)
        flat[i] = 1.0;
    for (unsigned l = 0; l < 6; l++) {
        s.src.layer[l].pmf = flat;
        s.src.layer[l].pmf_kmin = -1000;
        s.src.layer[l].pmf_n = 2001;
    }
    cn_buf b = {0};
    cn_write_report rep;
    assert_int_equal(cn_write_stream(&s.src, &b, &rep, err, sizeof err), 0);
    assert_int_equal(rep.table_source[0], CN_TABLE_COUNTS);
    check_roundtrip(&s);
    cn_buf_free(&b);
    cn_synth_free(&s);
}

static void test_workspace_rules(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 8, 1);
    cn_buf b;
    tu_synth_stream(&hdr, 5, 2.0, &b, NULL);
    cnerf_info info;
    assert_int_equal(cnerf_peek(b.p, b.n, &info), CNERF_OK);
    size_t need = cnerf_workspace_size(&info);
    uint8_t *mem = aligned_alloc(16, need + 16);
    cnerf_decoder dec;
    assert_int_equal(cnerf_open(&dec, b.p, b.n, mem + 4, need), CNERF_E_WS_ALIGN);
    assert_int_equal(cnerf_open(&dec, b.p, b.n, mem, need - 1), CNERF_E_WS_SMALL);
    assert_int_equal(dec.info.n_layers, 0); /* left zeroed on error */
    assert_int_equal(cnerf_open(&dec, b.p, b.n, mem, need), CNERF_OK);
    assert_int_equal(cnerf_open(NULL, b.p, b.n, mem, need), CNERF_E_NULL);
    assert_int_equal(cnerf_open(&dec, NULL, b.n, mem, need), CNERF_E_NULL);
    assert_int_equal(cnerf_open(&dec, b.p, b.n, NULL, need), CNERF_E_NULL);
    assert_int_equal(cnerf_peek(NULL, b.n, &info), CNERF_E_NULL);
    assert_int_equal(cnerf_peek(b.p, b.n, NULL), CNERF_E_NULL);
    /* No bytes at all is an empty stream, not misuse (an empty file reads as NULL, 0). */
    assert_int_equal(cnerf_peek(NULL, 0, &info), CNERF_E_TRUNCATED);
    assert_int_equal(cnerf_open(&dec, NULL, 0, mem, need), CNERF_E_TRUNCATED);
    assert_int_equal(cnerf_workspace_size(NULL), 0);
    /* An occupancy grid adds its blocks' records and its summary (cnerf_open builds it):
     * GRID a record per block, BGRD one per occupied block; CNERF_WORKSPACE_BOUND covers
     * both at every resolution. */
    cnerf_info plain;
    assert_int_equal(cnerf_peek(b.p, b.n, &plain), CNERF_OK);
    assert_int_equal(plain.grid_g, 0);
    for (uint32_t g = 1; g <= CNERF_MAX_GRID; g++) {
        const size_t nb = (g + 7) / 8;
        cnerf_info gi = plain;
        gi.grid_g = g;
        const size_t ws = cnerf_workspace_size(&gi);
        assert_true(ws >= need + nb * nb * nb * (CN_GRID_REC_BYTES + 2));
        assert_true(ws <= CNERF_WORKSPACE_BOUND(gi.n_params, gi.n_biases, gi.n_layers, g));
        gi.grid_by_blocks = 1;
        gi.grid_blocks = (uint16_t)(nb * nb * nb);
        assert_int_equal(cnerf_workspace_size(&gi), ws);
        gi.grid_blocks = 1;
        assert_true(cnerf_workspace_size(&gi) ==
                    ws - ((nb * nb * nb * CN_GRID_REC_BYTES + 7) & ~(size_t)7) +
                        ((CN_GRID_REC_BYTES + 7) & ~(size_t)7));
    }
    /* The stream buffer is not needed after open: wipe it and read latents. */
    int32_t before = cnerf_latent(&dec, 1, 3, 2);
    memset(b.p, 0, b.n);
    assert_int_equal(cnerf_latent(&dec, 1, 3, 2), before);
    /* Out-of-range accessor arguments read as 0, never out of bounds. */
    assert_int_equal(cnerf_latent(&dec, 99, 0, 0), 0);
    assert_int_equal(cnerf_latent(&dec, 0, 9999, 0), 0);
    free(mem);
    cn_buf_free(&b);
}

/* Pinned workspace sizes of the reference configurations (catches layout changes). */
static void test_pinned_workspace(void **state)
{
    (void)state;
    const struct {
        const char *preset;
        double spread; /* the synthetic latents' spread: within int8, or beyond it */
        int s8;        /* every layer's latents stored as int8 (1) or as int16 (0) */
        size_t bytes;
    } pins[] = {
        /* tiny per network: int8 latents of 27680 (inputs padded to pairs) + bias mantissas
         * and Q16 biases 2 x 1432 + row orders 720; x2; + open's scratch: four padded rows
         * of the widest layer input as int16, 4 x 128 x 2 = 1024 */
        {"tiny", 2.0, 1, 63552},
        /* the same with int16 latents: 2 x 27680 + 2864 + 720; x2; + open's scratch, now the
         * cumulative frequency table of the widest alphabet, [-445, 398]: 845 x 4, aligned, 3384 */
        {"tiny", 40.0, 0, 121272},
        /* small per network (a view branch of 32, as tiny's): 87136 + 2 x 2712 + 1360; x2;
         * + 4 x 192 x 2 */
        {"small", 2.0, 1, 189376},
        /* and with int16 latents: 2 x 87136 + 2 x 2712 + 1360; x2; + the cumulative frequency
         * table of this draw's widest alphabet, 4 bytes a symbol, aligned: 3408 */
        {"small", 40.0, 0, 365520},
    };
    for (size_t i = 0; i < sizeof pins / sizeof pins[0]; i++) {
        cnerf_info hdr;
        assert_int_equal(cn_preset_header(pins[i].preset, &hdr), 0);
        cn_buf b;
        tu_synth_stream(&hdr, 1, pins[i].spread, &b, NULL);
        cnerf_info info;
        assert_int_equal(cnerf_peek(b.p, b.n, &info), CNERF_OK);
        for (uint32_t l = 0; l < info.n_layers; l++)
            assert_int_equal(info.layer[l].kmin >= -128 && info.layer[l].kmax <= 127,
                             pins[i].s8);
        size_t ws = cnerf_workspace_size(&info);
        print_message("# workspace %s, spread %g: %zu bytes for %u latents\n", pins[i].preset,
                      pins[i].spread, ws, info.n_params);
        assert_int_equal(ws, pins[i].bytes);
        assert_true(ws <= CNERF_WORKSPACE_BOUND(info.n_params, info.n_biases, info.n_layers,
                                                info.grid_g));
        cn_buf_free(&b);
    }
}

static void test_crc32_known_value(void **state)
{
    (void)state;
    /* The standard check value of CRC-32/ISO-HDLC. */
    assert_int_equal(cnerf_crc32(0, (const uint8_t *)"123456789", 9), 0xCBF43926u);
    assert_int_equal(cnerf_crc32(cnerf_crc32(0, (const uint8_t *)"1234", 4),
                                 (const uint8_t *)"56789", 5),
                     0xCBF43926u);
}

static void test_number_formats(void **state)
{
    (void)state;
    int32_t m;
    int8_t e;
    const double vals[] = {0.0, 1.0, -1.0, 0.1, -3.14159e-7, 123456.789, 1e-25, 8388607.0};
    for (size_t i = 0; i < sizeof vals / sizeof vals[0]; i++) {
        assert_int_equal(cn_to_m24e8(vals[i], &m, &e), 0);
        assert_true(m >= -CNERF_M24_ABS_MAX && m <= CNERF_M24_ABS_MAX);
        double back = cn_from_m24e8(m, e);
        assert_true(fabs(back - vals[i]) <= fabs(vals[i]) * 0x1p-23 + 0x1p-64);
    }
    assert_int_equal(cn_to_m24e8(1e30, &m, &e), -1);
    assert_int_equal(cn_to_m24e8(NAN, &m, &e), -1);
    float bias[4] = {0.5f, -0.25f, 0.001f, 0.0f};
    int32_t bm[4];
    uint8_t bits;
    assert_int_equal(cn_quantize_biases(bias, 4, 12, bm, &bits, &e), 0);
    assert_int_equal(bits, 12);
    for (int i = 0; i < 4; i++) {
        assert_true(bm[i] >= -2048 && bm[i] < 2048);
        assert_true(fabs(ldexp(bm[i], e) - bias[i]) <= ldexp(0.5, e));
    }
    float zero[3] = {0, 0, 0};
    assert_int_equal(cn_quantize_biases(zero, 3, 12, bm, &bits, &e), 0);
    assert_int_equal(bits, 0);
    assert_int_equal(e, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_crc32_known_value),
        cmocka_unit_test(test_number_formats),
        cmocka_unit_test(test_presets),
        cmocka_unit_test(test_many_shapes),
        cmocka_unit_test(test_one_wide),
        cmocka_unit_test(test_constant_layers),
        cmocka_unit_test(test_full_latent_range),
        cmocka_unit_test(test_limits),
        cmocka_unit_test(test_table_choice),
        cmocka_unit_test(test_workspace_rules),
        cmocka_unit_test(test_pinned_workspace),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
