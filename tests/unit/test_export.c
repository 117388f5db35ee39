/* Model -> stream -> decoder -> float reference model: the numbers survive exactly, and the
 * reference renders the file bit-identically to the trainer's (snapped) model. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cn_export.h"
#include "cn_fixcam.h"
#include "cn_prune.h"
#include "cn_prior.h"
#include "cn_render.h"
#include "cn_report.h"
#include "testutil.h"

static void small_model(cn_model *m, int compressed)
{
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 8, 1);
    hdr.n_coarse = 6;
    hdr.n_fine = 4;
    char err[256];
    if (compressed)
        assert_int_equal(cn_model_init_compressed(m, &hdr, 11, 6.0, err, sizeof err), 0);
    else
        assert_int_equal(cn_model_init(m, &hdr, 11, err, sizeof err), 0);
    cn_rng r = cn_rng_seed(12);
    for (unsigned l = 0; l < m->topo.n_layers; l++)
        for (unsigned j = 0; j < m->topo.layer[l].n_out; j++)
            m->params[m->layer[l].b + j] = (float)(cn_rng_uniform(&r) - 0.5);
}

static void write_and_open(const cn_export *e, cn_buf *b, cnerf_decoder *dec, void **ws,
                           cn_write_report *rep)
{
    char err[256];
    memset(b, 0, sizeof *b);
    if (cn_write_stream(&e->src, b, rep, err, sizeof err))
        fail_msg("write: %s", err);
    assert_int_equal(tu_open(dec, b->p, b->n, ws), CNERF_OK);
}

static void rays(cn_batch *bt, size_t R)
{
    cn_rng r = cn_rng_seed(5);
    for (size_t i = 0; i < R; i++) {
        float d[3] = {(float)(cn_rng_uniform(&r) - 0.5) * 0.4f,
                      (float)(cn_rng_uniform(&r) - 0.5) * 0.4f, -1.0f};
        float n = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int a = 0; a < 3; a++) {
            bt->o[3 * i + a] = a == 2 ? 4.0f : 0.1f;
            bt->d[3 * i + a] = d[a];
            bt->vd[3 * i + a] = d[a] / n;
        }
    }
}

static void test_closed_loop(void **state)
{
    (void)state;
    cn_model m, ref;
    small_model(&m, 1);
    char err[256];
    assert_int_equal(cn_model_snap(&m, err, sizeof err), 0);
    cn_export e;
    assert_int_equal(cn_export_compressed(&m, "test", &e, err, sizeof err), 0);
    cn_buf b;
    cnerf_decoder *dec = malloc(sizeof *dec);
    void *ws;
    cn_write_report rep;
    write_and_open(&e, &b, dec, &ws, &rep);
    assert_int_equal(cn_model_from_stream(dec, &ref, err, sizeof err), 0);
    cn_model_materialize(&m);
    for (unsigned l = 0; l < m.topo.n_layers; l++) {
        const size_t n = (size_t)m.topo.layer[l].n_in * m.topo.layer[l].n_out;
        for (size_t i = 0; i < n; i++) {
            assert_int_equal(cnerf_latent(dec, l, (uint32_t)(i / m.topo.layer[l].n_in),
                                          (uint32_t)(i % m.topo.layer[l].n_in)),
                             cn_model_latent(&m, l, i));
        }
        assert_memory_equal(cn_model_kernel(&m, l), cn_model_kernel(&ref, l), n * sizeof(float));
        assert_memory_equal(m.params + m.layer[l].b, ref.params + ref.layer[l].b,
                            m.topo.layer[l].n_out * sizeof(float));
        assert_true(rep.table_source[l] == CN_TABLE_COUNTS || rep.table_source[l] == CN_TABLE_PRIOR ||
                    rep.table_source[l] == CN_TABLE_NONE);
    }
    /* Both render the same rays to the same bits. */
    enum { R = 16 };
    cn_batch b1, b2;
    assert_int_equal(cn_batch_init(&b1, &m.topo, R), 0);
    assert_int_equal(cn_batch_init(&b2, &ref.topo, R), 0);
    rays(&b1, R);
    rays(&b2, R);
    cn_render_forward(&m, &b1, R, NULL);
    cn_render_forward(&ref, &b2, R, NULL);
    assert_memory_equal(b1.color[1], b2.color[1], sizeof(float) * 3 * R);
    cn_batch_free(&b1);
    cn_batch_free(&b2);
    cn_model_free(&ref);
    cn_model_free(&m);
    cn_export_free(&e);
    cn_buf_free(&b);
    free(ws);
    free(dec);
}

/* The decoder's image of a 12x12 view of the scene's centre. */
static void decode_view(const cnerf_decoder *dec, uint8_t rgb[12 * 12 * 3])
{
    cn_camera cam = {{{1, 0, 0, 0.05}, {0, 1, 0, -0.03}, {0, 0, 1, 4}}, 10, 10, 6, 6, 12, 12};
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
    const size_t n = cnerf_render_scratch_size(&dec->info);
    void *scratch = aligned_alloc(8, (n + 7) & ~(size_t)7);
    assert_non_null(scratch);
    assert_int_equal(cnerf_render_tile(dec, &fc, NULL, 0, 0, 12, 12, rgb, 36, scratch, n),
                     CNERF_OK);
    free(scratch);
}

/* Dead units (a pre-activation that no input can make positive) leave the stream, with the
 * next layer's columns for them, and neither renderer changes: the decoder's image is the
 * same bits, the float reference's colours the same within float rounding. Units that some
 * input can switch on stay. */
static void test_prune_dead_units(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 4, 8, 1); /* skip into layer 2, view branch of 4 */
    hdr.n_coarse = 6;
    hdr.n_fine = 4;
    cn_model m;
    char err[256];
    assert_int_equal(cn_model_init_compressed(&m, &hdr, 11, 6.0, err, sizeof err), 0);
    cn_rng r = cn_rng_seed(12);
    for (unsigned l = 0; l < m.topo.n_layers; l++)
        for (unsigned j = 0; j < m.topo.layer[l].n_out; j++)
            m.params[m.layer[l].b + j] = (float)(cn_rng_uniform(&r) - 0.5);
    /* Kill, in each network: trunk layer 0 unit 3 (inputs of both signs), layer 1 units 2
     * and 5 (its output feeds the skip layer's h part), layer 3 unit 7 (the last: its column
     * goes from sigma and feature) and view unit 1, by a bias that no input can outweigh. */
    static const struct { unsigned layer, unit; } kill[] = {{0, 3}, {1, 2}, {1, 5}, {3, 7}, {6, 1}};
    for (unsigned n = 0; n < 2; n++)
        for (unsigned q = 0; q < sizeof kill / sizeof kill[0]; q++) {
            const unsigned l = m.topo.net[n].first_layer + kill[q].layer;
            assert_true(m.topo.layer[l].role == (kill[q].layer == 6 ? CNERF_ROLE_VIEW
                                                                    : CNERF_ROLE_TRUNK));
            m.params[m.layer[l].b + kill[q].unit] = -40.0f;
        }
    assert_int_equal(cn_model_snap(&m, err, sizeof err), 0);
    cn_export e0, e1;
    assert_int_equal(cn_export_compressed(&m, "full", &e0, err, sizeof err), 0);
    assert_int_equal(cn_export_compressed(&m, "pruned", &e1, err, sizeof err), 0);
    cn_prune_report pr;
    assert_int_equal(cn_export_prune(&e1, &pr, err, sizeof err), 0);
    for (unsigned n = 0; n < 2; n++) {
        static const uint16_t after[5] = {7, 6, 8, 7, 3};
        for (unsigned i = 0; i < 5; i++) {
            assert_int_equal(pr.before[n][i], i < 4 ? 8 : 4);
            assert_int_equal(pr.after[n][i], after[i]);
        }
    }
    assert_true(pr.params_after < pr.params_before);
    cn_buf b0, b1;
    cnerf_decoder *d0 = malloc(sizeof *d0), *d1 = malloc(sizeof *d1);
    void *w0, *w1;
    write_and_open(&e0, &b0, d0, &w0, NULL);
    write_and_open(&e1, &b1, d1, &w1, NULL);
    assert_int_equal(d0->info.version_major, CNERF_VERSION_MAJOR);
    assert_int_equal(d1->info.version_major, CNERF_VERSION_MAJOR);
    assert_int_equal(d0->info.unit_bytes, 0);
    assert_int_equal(d1->info.unit_bytes, CNERF_CHUNK_OVERHEAD + 2 * 2 * 5);
    assert_int_equal(d1->info.n_params, pr.params_after);
    assert_true(b1.n < b0.n);
    const cnerf_layer_info *L = d1->info.layer;
    assert_int_equal(L[0].n_out, 7);
    assert_int_equal(L[1].n_in, 7);
    assert_int_equal(L[2].n_in, d1->info.in_pos + 6);
    assert_int_equal(L[4].n_in, 7);  /* sigma */
    assert_int_equal(L[5].n_in, 7);  /* feature */
    assert_int_equal(L[5].n_out, 8);
    assert_int_equal(L[6].n_out, 3); /* view */
    assert_int_equal(L[7].n_in, 3);  /* rgb */
    uint8_t img0[12 * 12 * 3], img1[12 * 12 * 3];
    decode_view(d0, img0);
    decode_view(d1, img1);
    assert_memory_equal(img0, img1, sizeof img0);
    /* The same image is not an accident of a blank one. */
    int spread = 0;
    for (size_t i = 1; i < sizeof img0; i++)
        spread |= img0[i] != img0[0];
    assert_true(spread);
    /* The float reference. */
    cn_model ref0, ref1;
    assert_int_equal(cn_model_from_stream(d0, &ref0, err, sizeof err), 0);
    assert_int_equal(cn_model_from_stream(d1, &ref1, err, sizeof err), 0);
    enum { R = 16 };
    cn_batch x0, x1;
    assert_int_equal(cn_batch_init(&x0, &ref0.topo, R), 0);
    assert_int_equal(cn_batch_init(&x1, &ref1.topo, R), 0);
    rays(&x0, R);
    rays(&x1, R);
    cn_render_forward(&ref0, &x0, R, NULL);
    cn_render_forward(&ref1, &x1, R, NULL);
    for (int i = 0; i < 3 * R; i++)
        assert_true(fabsf(x0.color[1][i] - x1.color[1][i]) < 1e-5f);
    cn_batch_free(&x0);
    cn_batch_free(&x1);
    cn_model_free(&ref0);
    cn_model_free(&ref1);
    /* Pruning a pruned export finds nothing more. */
    cn_prune_report again;
    assert_int_equal(cn_export_prune(&e1, &again, err, sizeof err), 0);
    assert_int_equal(again.params_after, again.params_before);
    cn_export_free(&e0);
    cn_export_free(&e1);
    cn_buf_free(&b0);
    cn_buf_free(&b1);
    free(w0);
    free(w1);
    free(d0);
    free(d1);
    cn_model_free(&m);
}

/* The naive baseline: 8-bit uniform quantization of a float model. */
static void test_quantized_baseline(void **state)
{
    (void)state;
    cn_model m, ref;
    small_model(&m, 0);
    char err[256];
    cn_export e;
    assert_int_equal(cn_export_quantized(&m, 8, NULL, &e, err, sizeof err), 0);
    cn_buf b;
    cnerf_decoder *dec = malloc(sizeof *dec);
    void *ws;
    write_and_open(&e, &b, dec, &ws, NULL);
    assert_int_equal(cn_model_from_stream(dec, &ref, err, sizeof err), 0);
    for (unsigned l = 0; l < m.topo.n_layers; l++) {
        const cnerf_layer_info *L = &dec->info.layer[l];
        assert_true(L->kmin >= -127 && L->kmax <= 127);
        const double a = cn_from_m24e8(L->a_m, L->a_e);
        const size_t n = (size_t)L->n_in * L->n_out;
        for (size_t i = 0; i < n; i++)
            assert_true(fabs(cn_model_kernel(&ref, l)[i] - cn_model_kernel(&m, l)[i]) <=
                        0.5 * a * (1 + 1e-5));
    }
    assert_int_equal(cn_export_quantized(&m, 1, NULL, &e, err, sizeof err), -1);
    cn_model_free(&ref);
    cn_model_free(&m);
    cn_export_free(&e);
    cn_buf_free(&b);
    free(ws);
    free(dec);
}

/* With latents that follow the prior's own shape, the prior's table is competitive: the
 * writer keeps whichever codes smaller, and never more than the counts' table would. */
static void test_prior_tables(void **state)
{
    (void)state;
    cn_model m;
    small_model(&m, 1);
    char err[256];
    cn_export e;
    assert_int_equal(cn_export_compressed(&m, NULL, &e, err, sizeof err), 0);
    cn_buf with = {0}, without = {0};
    assert_int_equal(cn_write_stream(&e.src, &with, NULL, err, sizeof err), 0);
    for (unsigned l = 0; l < m.topo.n_layers; l++)
        e.src.layer[l].pmf = NULL;
    assert_int_equal(cn_write_stream(&e.src, &without, NULL, err, sizeof err), 0);
    assert_true(with.n <= without.n);
    cn_buf_free(&with);
    cn_buf_free(&without);
    cn_export_free(&e);
    cn_model_free(&m);
}

/* Fits each layer's prior to its integer latents by Adam on -sum log2 L(k). */
static void fit_priors(cn_model *m, int steps)
{
    float g[CN_PRIOR_PARAMS], mo[CN_PRIOR_PARAMS], v[CN_PRIOR_PARAMS];
    size_t max = 0;
    for (unsigned l = 0; l < m->topo.n_layers; l++)
        max = fmax(max, (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out);
    float *k = malloc(sizeof(float) * max);
    assert_non_null(k);
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        const size_t n = (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
        for (size_t i = 0; i < n; i++)
            k[i] = (float)cn_model_latent(m, l, i);
        float *p = m->params + m->off_prior + CN_PRIOR_PARAMS * (size_t)l;
        memset(mo, 0, sizeof mo);
        memset(v, 0, sizeof v);
        for (int t = 1; t <= steps; t++) {
            memset(g, 0, sizeof g);
            cn_prior_bits(p, k, n, (float)(1.0 / n), NULL, g);
            for (int j = 0; j < CN_PRIOR_PARAMS; j++) {
                mo[j] = 0.9f * mo[j] + 0.1f * g[j];
                v[j] = 0.999f * v[j] + 0.001f * g[j] * g[j];
                const double mh = mo[j] / (1 - pow(0.9, t)), vh = v[j] / (1 - pow(0.999, t));
                p[j] -= (float)(0.05 * mh / (sqrt(vh) + 1e-8));
            }
        }
    }
    free(k);
}

/* The rate the training objective estimates is what the coder pays: with priors fitted to
 * the latents, the coded payload is within 3% of -sum log2 L(round(Phi)). */
static void test_rate_estimate_matches_payload(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 4, 64, 1);
    cn_model m;
    char err[256];
    assert_int_equal(cn_model_init_compressed(&m, &hdr, 3, 8.0, err, sizeof err), 0);
    const double before = cn_model_latent_bits(&m, NULL);
    fit_priors(&m, 100);
    double per[CNERF_MAX_LAYERS];
    const double est = cn_model_latent_bits(&m, per);
    assert_true(est < before); /* the fit did something */
    double sum = 0;
    for (unsigned l = 0; l < m.topo.n_layers; l++)
        sum += per[l];
    assert_float_equal(sum, est, 1e-9 * est);
    assert_int_equal(cn_model_snap(&m, err, sizeof err), 0);
    cn_export e;
    assert_int_equal(cn_export_compressed(&m, NULL, &e, err, sizeof err), 0);
    cn_buf b;
    cnerf_decoder *dec = malloc(sizeof *dec);
    void *ws;
    cn_write_report rep;
    write_and_open(&e, &b, dec, &ws, &rep);
    cn_totals tot;
    cn_breakdown(&dec->info, &tot);
    const double ratio = 8.0 * (double)tot.payload / est;
    print_message("rate estimate %.0f bytes, coded payload %llu bytes (%+.2f%%)\n", est / 8,
                  (unsigned long long)tot.payload, 100 * (ratio - 1));
    assert_true(fabs(ratio - 1) < 0.03);
    cn_buf_free(&b);
    cn_export_free(&e);
    free(ws);
    free(dec);
    cn_model_free(&m);
}

/* --coarse-color off: the coarse network's colour layers go into the stream as zero. No
 * image with fine samples changes (the fine network gives every colour), the file shrinks,
 * the decoder says the coarse network carries no colour and refuses its image alone, and
 * the rate leaves those layers out (no estimate, no gradient on their latents). */
static void test_drop_coarse_color(void **state)
{
    (void)state;
    cn_model m;
    small_model(&m, 1);
    char err[256];
    assert_int_equal(cn_model_snap(&m, err, sizeof err), 0);
    unsigned first, count;
    assert_int_equal(cn_color_layers(&m.topo, 0, &first, &count), 1);
    assert_int_equal(m.topo.layer[first].role, CNERF_ROLE_FEATURE);
    assert_int_equal(m.topo.layer[first + 2].role, CNERF_ROLE_RGB);
    cn_export e[2];
    cn_buf b[2];
    cnerf_decoder *dec[2];
    void *ws[2];
    cn_write_report rep;
    uint8_t img[2][12 * 12 * 3];
    double est[2], per[2][CNERF_MAX_LAYERS];
    for (int d = 0; d < 2; d++) {
        m.drop_color[0] = (uint8_t)d;
        est[d] = cn_model_latent_bits(&m, per[d]);
        assert_int_equal(cn_export_compressed(&m, NULL, &e[d], err, sizeof err), 0);
        dec[d] = malloc(sizeof *dec[d]);
        write_and_open(&e[d], &b[d], dec[d], &ws[d], &rep);
        assert_int_equal(cnerf_net_has_color(&dec[d]->info, 0), !d);
        assert_int_equal(cnerf_net_has_color(&dec[d]->info, 1), 1);
        decode_view(dec[d], img[d]);
    }
    assert_memory_equal(img[0], img[1], sizeof img[0]);
    print_message("stream with the coarse colour %zu bytes, without %zu\n", b[0].n, b[1].n);
    assert_true(b[1].n < b[0].n);
    for (unsigned l = 0; l < m.topo.n_layers; l++) {
        const int colour = l >= first && l < first + count;
        assert_true(colour ? per[1][l] == 0 && per[0][l] > 0 : per[1][l] == per[0][l]);
        assert_int_equal(dec[1]->info.layer[l].kmin == dec[1]->info.layer[l].kmax, colour ||
                         dec[0]->info.layer[l].kmin == dec[0]->info.layer[l].kmax);
    }
    assert_true(est[1] < est[0]);
    /* Pruning removes the zero view units but one (their rows are exactly 0), and the
     * decoder's image stays the same bits. */
    cn_prune_report pr;
    assert_int_equal(cn_export_prune(&e[1], &pr, err, sizeof err), 0);
    assert_int_equal(e[1].src.hdr.net[0].view_units, 1);
    assert_int_equal(e[1].src.hdr.net[1].view_units, m.topo.net[1].view_width);
    {
        cn_buf pb;
        cnerf_decoder *pd = malloc(sizeof *pd);
        void *pws;
        uint8_t pimg[12 * 12 * 3];
        write_and_open(&e[1], &pb, pd, &pws, &rep);
        decode_view(pd, pimg);
        assert_memory_equal(img[0], pimg, sizeof pimg);
        cn_buf_free(&pb);
        free(pws);
        free(pd);
    }
    /* The coarse network's image alone: refused without its colour, rendered with it. */
    cn_camera cam = {{{1, 0, 0, 0.05}, {0, 1, 0, -0.03}, {0, 0, 1, 4}}, 10, 10, 6, 6, 12, 12};
    cnerf_camera fc;
    assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
    const size_t n = cnerf_render_scratch_size(&dec[0]->info);
    void *scratch = aligned_alloc(8, (n + 7) & ~(size_t)7);
    assert_non_null(scratch);
    for (int d = 0; d < 2; d++) {
        cnerf_render_opts o;
        cnerf_render_defaults(&dec[d]->info, &o);
        o.n_fine = 0;
        assert_int_equal(cnerf_render_tile(dec[d], &fc, &o, 0, 0, 12, 12, img[d], 36, scratch, n),
                         d ? CNERF_E_ARG : CNERF_OK);
    }
    free(scratch);
    /* No rate gradient reaches the dropped layers' latents; the others get theirs. */
    memset(m.grads, 0, sizeof(float) * m.n_params);
    m.drop_color[0] = 1;
    cn_model_rate(&m, 7, 1.0f);
    for (unsigned l = 0; l < m.topo.n_layers; l++) {
        const size_t k = (size_t)m.topo.layer[l].n_in * m.topo.layer[l].n_out;
        double g = 0;
        for (size_t i = 0; i < k; i++)
            g += fabs(m.grads[m.layer[l].w + i]);
        assert_true(l >= first && l < first + count ? g == 0 : g > 0);
    }
    for (int d = 0; d < 2; d++) {
        cn_export_free(&e[d]);
        cn_buf_free(&b[d]);
        free(ws[d]);
        free(dec[d]);
    }
    cn_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closed_loop),
        cmocka_unit_test(test_prune_dead_units),
        cmocka_unit_test(test_quantized_baseline),
        cmocka_unit_test(test_prior_tables),
        cmocka_unit_test(test_rate_estimate_matches_payload),
        cmocka_unit_test(test_drop_coarse_color),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
