/* Finite-difference checks of every backward pass: linear layer, ReLU, volume rendering
 * (density and colour), one whole network, the two-network render and the photometric loss.
 *
 * Tolerance: central differences with step h on float computations; a gradient passes when
 * |analytic - numeric| <= 2e-2 * max(|analytic|, |numeric|) + 2e-4 (float round-off of the
 * loss divided by 2h dominates below that); whole renders: see RENDER_ABS_TOL. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cn_nerf.h"
#include "cn_render.h"
#include "cn_train.h"
#include "testutil.h"

#define REL_TOL 2e-2
#define ABS_TOL 2e-4
/* Whole-render checks use h = 2.5e-4 on a float loss of order 1: round-off ~1e-7 / 5e-4. */
#define RENDER_ABS_TOL 1e-3

static void fill(float *x, size_t n, cn_rng *r, double scale)
{
    for (size_t i = 0; i < n; i++)
        x[i] = (float)((2 * cn_rng_uniform(r) - 1) * scale);
}

static int close_enough(double a, double n)
{
    return fabs(a - n) <= REL_TOL * fmax(fabs(a), fabs(n)) + ABS_TOL;
}

static double dot(const float *a, const float *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += (double)a[i] * b[i];
    return s;
}

/* ---- linear layer with ReLU: L = sum g * relu(x W^T + b) ---- */
enum { LP = 37, LIN = 11, LOUT = 7 };
static float lx[LP * LIN], lw[LOUT * LIN], lb[LOUT], lg[LP * LOUT];

static double linear_loss(void)
{
    float y[LP * LOUT];
    cn_linear_forward(y, LOUT, lx, LIN, lw, lb, LP, LIN, LOUT, 1);
    return dot(y, lg, LP * LOUT);
}

static void check_fd(const char *what, float *param, size_t n, const float *grad, double h)
{
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        float keep = param[i];
        param[i] = keep + (float)h;
        double lp = linear_loss();
        param[i] = keep - (float)h;
        double lm = linear_loss();
        param[i] = keep;
        double num = (lp - lm) / (2 * h);
        if (!close_enough(grad[i], num)) {
            print_error("%s[%zu]: analytic %g numeric %g\n", what, i, grad[i], num);
            bad++;
        }
    }
    assert_int_equal(bad, 0);
}

static void test_linear_relu(void **state)
{
    (void)state;
    cn_rng r = cn_rng_seed(1);
    fill(lx, LP * LIN, &r, 1.0);
    fill(lw, LOUT * LIN, &r, 0.5);
    fill(lb, LOUT, &r, 0.3);
    fill(lg, LP * LOUT, &r, 1.0);
    float y[LP * LOUT], dy[LP * LOUT], dw[LOUT * LIN] = {0}, db[LOUT] = {0}, dx[LP * LIN];
    cn_linear_forward(y, LOUT, lx, LIN, lw, lb, LP, LIN, LOUT, 1);
    memcpy(dy, lg, sizeof dy);
    cn_relu_backward(dy, LOUT, y, LOUT, LP, LOUT);
    cn_linear_backward(dx, LIN, 0, LIN, 0, dw, db, dy, LOUT, lx, LIN, lw, LP, LIN, LOUT);
    check_fd("dW", lw, LOUT * LIN, dw, 1e-3);
    check_fd("db", lb, LOUT, db, 1e-3);
    check_fd("dx", lx, LP * LIN, dx, 1e-3);
    /* Gradients accumulate: a second backward doubles dW and db. */
    float dw2[LOUT * LIN], db2[LOUT];
    memcpy(dw2, dw, sizeof dw);
    memcpy(db2, db, sizeof db);
    cn_linear_backward(NULL, 0, 0, 0, 0, dw2, db2, dy, LOUT, lx, LIN, lw, LP, LIN, LOUT);
    for (int i = 0; i < LOUT; i++)
        assert_float_equal(db2[i], 2 * db[i], 1e-5);
    /* A column slice of dx (the part after a skip concatenation). */
    float dxs[LP * 4];
    cn_linear_backward(dxs, 4, 5, 4, 0, dw2, db2, dy, LOUT, lx, LIN, lw, LP, LIN, LOUT);
    for (int p = 0; p < LP; p++)
        for (int i = 0; i < 4; i++)
            assert_float_equal(dxs[p * 4 + i], dx[p * LIN + 5 + i], 1e-5);
    /* The fused ReLU + linear backward gives the same bits as the two steps. */
    float fdy[LP * LOUT], fdw[LOUT * LIN] = {0}, fdb[LOUT] = {0}, fdx[LP * LIN];
    memcpy(fdy, lg, sizeof fdy);
    cn_linear_relu_backward(fdx, LIN, 0, LIN, 0, fdw, fdb, fdy, LOUT, y, LOUT, lx, LIN, lw, LP,
                            LIN, LOUT);
    assert_memory_equal(fdy, dy, sizeof dy);
    assert_memory_equal(fdw, dw, sizeof dw);
    assert_memory_equal(fdb, db, sizeof db);
    assert_memory_equal(fdx, dx, sizeof dx);
}

/* ---- volume rendering: L = g . C ---- */
enum { VN = 12 };
static float vraw[VN * 4], vt[VN];
static uint8_t vin[VN];
static const float vbg[3] = {1.0f, 0.5f, 0.25f};
static float vg[3];

static double volume_loss(void)
{
    float C[3];
    cn_volume_forward(vraw, 4, vt, vin, VN, 6.0f, 1.3f, vbg, C, NULL, 0);
    return (double)vg[0] * C[0] + (double)vg[1] * C[1] + (double)vg[2] * C[2];
}

static void test_volume_rendering(void **state)
{
    (void)state;
    cn_rng r = cn_rng_seed(2);
    for (int trial = 0; trial < 20; trial++) {
        fill(vraw, VN * 4, &r, 2.0);
        fill(vg, 3, &r, 1.0);
        cn_sample_coarse(vt, VN, 2.0f, 6.0f, &r);
        for (int i = 0; i < VN; i++)
            vin[i] = (uint8_t)(cn_rng_below(&r, 5) != 0);
        float draw[VN * 4];
        cn_volume_backward(draw, 4, vraw, vt, vin, VN, 6.0f, 1.3f, vbg, vg);
        int bad = 0;
        for (int i = 0; i < VN * 4; i++) {
            float keep = vraw[i];
            const double h = 1e-3;
            vraw[i] = keep + (float)h;
            double lp = volume_loss();
            vraw[i] = keep - (float)h;
            double lm = volume_loss();
            vraw[i] = keep;
            if (i % 4 == 3 && fabs(keep) < 2 * h)
                continue; /* ReLU kink */
            double num = (lp - lm) / (2 * h);
            if (!close_enough(draw[i], num)) {
                print_error("trial %d raw[%d]: analytic %g numeric %g\n", trial, i, draw[i], num);
                bad++;
            }
        }
        assert_int_equal(bad, 0);
    }
    /* Weights sum with the background's share to one. */
    float C[3], w[VN];
    cn_volume_forward(vraw, 4, vt, NULL, VN, 6.0f, 1.0f, vbg, C, w, 0);
    double sw = 0;
    for (int i = 0; i < VN; i++) {
        assert_true(w[i] >= 0);
        sw += w[i];
    }
    assert_true(sw <= 1.0 + 1e-6);
}

/* ---- a whole network and the two-network render ---- */
static cn_model gm;
static cn_batch gb;
static float gg[2][64 * 3];
enum { GR = 6 };

static double render_loss(unsigned net)
{
    const uint64_t seed = 99;
    cn_model_materialize(&gm);
    cn_render_forward(&gm, &gb, GR, &seed);
    return dot(gb.color[net], gg[net], GR * 3) +
           cn_net_group_penalty(&gm, net, &gb.nb[net], gb.n_rows[net]);
}

/* pruned: trunk layers of 5, 3, 8 and 6 units (width 8; the skip after the 3-unit layer)
 * and a 3-unit view layer (width 5), as a UNIT chunk makes them. */
static void setup_model(int view, int compressed, int pruned)
{
    cnerf_info hdr;
    tu_small_header(&hdr, 4, 8, 1);
    hdr.n_coarse = 7;
    hdr.n_fine = 5;
    static const uint16_t units[4] = {5, 3, 8, 6};
    for (int n = 0; n < 2; n++) {
        hdr.net[n].view_width = view ? 5 : 0;
        hdr.net[n].skip = 1;
        if (pruned) {
            memcpy(hdr.net[n].units, units, sizeof units);
            hdr.net[n].view_units = view ? 3 : 0;
        }
    }
    char err[256];
    if (compressed)
        assert_int_equal(cn_model_init_compressed(&gm, &hdr, 5, 8.0, err, sizeof err), 0);
    else
        assert_int_equal(cn_model_init(&gm, &hdr, 5, err, sizeof err), 0);
    cn_rng r = cn_rng_seed(6);
    for (unsigned l = 0; l < gm.topo.n_layers; l++)
        fill(gm.params + gm.layer[l].b, gm.topo.layer[l].n_out, &r, 0.2);
    assert_int_equal(cn_batch_init(&gb, &gm.topo, GR), 0);
    for (int i = 0; i < GR; i++) {
        float o[3] = {(float)(cn_rng_uniform(&r) - 0.5), (float)(cn_rng_uniform(&r) - 0.5), 4.0f};
        float d[3] = {(float)(cn_rng_uniform(&r) - 0.5) * 0.3f,
                      (float)(cn_rng_uniform(&r) - 0.5) * 0.3f, -1.0f};
        memcpy(gb.o + 3 * i, o, sizeof o);
        memcpy(gb.d + 3 * i, d, sizeof d);
        float n = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int a = 0; a < 3; a++)
            gb.vd[3 * i + a] = d[a] / n;
    }
    fill(&gg[0][0], sizeof gg / sizeof(float), &r, 1.0);
}

static void setup_small_model(int view, int compressed) { setup_model(view, compressed, 0); }

/* The analytic gradients of network net's loss; with latents, mapped on to the latents, a
 * and b of a compressed model. */
static void net_grads(unsigned net, int latents)
{
    memset(gm.grads, 0, sizeof(float) * gm.n_params);
    render_loss(net);
    float *dcol[2] = {NULL, NULL};
    dcol[net] = gg[net];
    cn_render_backward(&gm, &gb, GR, dcol);
    if (latents)
        cn_model_kernels_backward(&gm);
}

static void check_render_grads(unsigned net)
{
    net_grads(net, 0);
    const cnerf_net_info *N = &gm.topo.net[net];
    int bad = 0, checked = 0;
    cn_rng r = cn_rng_seed(7 + net);
    for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
        const cnerf_layer_info *L = &gm.topo.layer[l];
        size_t nw = (size_t)L->n_in * L->n_out;
        for (int k = 0; k < 12; k++) {
            size_t idx = k < 8 ? gm.layer[l].w + cn_rng_below(&r, (uint32_t)nw)
                               : gm.layer[l].b + cn_rng_below(&r, L->n_out);
            float keep = gm.params[idx];
            const double h = 2.5e-4; /* small enough to rarely straddle a ReLU kink */
            gm.params[idx] = keep + (float)h;
            double lp = render_loss(net);
            gm.params[idx] = keep - (float)h;
            double lm = render_loss(net);
            gm.params[idx] = keep;
            double num = (lp - lm) / (2 * h);
            checked++;
            if (fabs(gm.grads[idx] - num) > REL_TOL * fmax(fabs(gm.grads[idx]), fabs(num)) +
                                                 RENDER_ABS_TOL) {
                print_error("net %u layer %u param %zu: analytic %g numeric %g\n", net, l,
                            idx, gm.grads[idx], num);
                bad++;
            }
        }
    }
    assert_true(checked > 50);
    assert_int_equal(bad, 0);
}

static void test_render_grads_view(void **state)
{
    (void)state;
    setup_small_model(1, 0);
    check_render_grads(0);
    check_render_grads(1);
    cn_batch_free(&gb);
    cn_model_free(&gm);
}

static void test_render_grads_no_view(void **state)
{
    (void)state;
    setup_small_model(0, 0);
    check_render_grads(0);
    check_render_grads(1);
    cn_batch_free(&gb);
    cn_model_free(&gm);
}

/* cn_net_density (the grid's lattice, the training grid's refresh) writes the density that
 * cn_net_forward writes, bit for bit, over more rows than one chunk, with and without a view
 * branch, float, compressed and pruned; with a view branch it leaves the colours alone. */
static void test_density_only(void **state)
{
    (void)state;
    enum { P = CN_CHUNK_ROWS + 77 };
    static float pts[3 * P], sigma[P];
    cn_rng r = cn_rng_seed(21);
    fill(pts, 3 * P, &r, 1.5);
    const float dir[3] = {0.6f, -0.48f, 0.64f};
    for (int kind = 0; kind < 6; kind++) {
        const int view = kind & 1, compressed = kind == 2 || kind == 3, pruned = kind >= 4;
        setup_model(view, compressed, pruned);
        for (unsigned net = 0; net < gm.topo.n_nets; net++) {
            cn_net_buf nb;
            assert_int_equal(cn_net_buf_init(&nb, &gm.topo, net, P), 0);
            float vpe[CNERF_MAX_IN_DIR];
            if (gm.topo.in_dir)
                cn_posenc(vpe, gm.topo.in_dir, dir, 1, gm.topo.l_dir,
                          gm.topo.pe_flags & CNERF_PE_INCLUDE_INPUT);
            cn_net_inputs(&gm.topo, net, &nb, pts, P, vpe, NULL, 1);
            cn_net_forward(&gm, net, &nb, P);
            for (size_t j = 0; j < P; j++)
                sigma[j] = nb.out[4 * j + 3];
            for (size_t j = 0; j < 4 * (size_t)P; j++)
                nb.out[j] = -12345.0f;
            cn_net_density(&gm, net, &nb, P);
            for (size_t j = 0; j < P; j++) {
                assert_memory_equal(&nb.out[4 * j + 3], &sigma[j], sizeof(float));
                if (view)
                    assert_true(nb.out[4 * j] == -12345.0f && nb.out[4 * j + 2] == -12345.0f);
            }
            cn_net_buf_free(&nb);
        }
        cn_batch_free(&gb);
        cn_model_free(&gm);
    }
}

/* Layers narrower than the width (a pruned stream's float model), and a background per
 * ray (training on views with transparency): the gradients still match. */
static void test_render_grads_pruned(void **state)
{
    (void)state;
    static float bg[GR * 3];
    for (int view = 0; view < 2; view++) {
        setup_model(view, 0, 1);
        assert_int_equal(gm.topo.layer[1].n_in, 5);
        assert_int_equal(gm.topo.layer[2].n_in, gm.topo.in_pos + 3);
        assert_int_equal(gm.topo.layer[4].n_in, 6);
        cn_rng r = cn_rng_seed(11);
        fill(bg, GR * 3, &r, 1.0);
        gb.bg = bg;
        check_render_grads(0);
        check_render_grads(1);
        cn_batch_free(&gb);
        cn_model_free(&gm);
    }
}

/* The group penalty on the trunk's units adds its gradient to every layer before it, and
 * it is the sum of the units' norms. */
static void test_render_grads_group(void **state)
{
    (void)state;
    for (int pruned = 0; pruned < 2; pruned++) {
        setup_model(1, 0, pruned);
        gm.group = 0.0f;
        render_loss(0);
        assert_true(cn_net_group_penalty(&gm, 0, &gb.nb[0], gb.n_rows[0]) == 0.0);
        gm.group = 0.5f;
        const double pen = cn_net_group_penalty(&gm, 0, &gb.nb[0], gb.n_rows[0]);
        const cn_net_buf *nb = &gb.nb[0];
        double sum = 0;
        for (unsigned i = 0; i < gm.topo.net[0].depth; i++)
            for (size_t u = 0; u < gm.topo.net[0].units[i]; u++) {
                double s2 = 0;
                for (size_t p = 0; p < gb.n_rows[0]; p++)
                    s2 += (double)nb->h[i][p * nb->ld_h[i] + u] * nb->h[i][p * nb->ld_h[i] + u];
                sum += sqrt(s2);
            }
        assert_true(sum > 0);
        assert_true(fabs(pen - 0.5 * sum) <= 1e-9 * sum);
        check_render_grads(0);
        check_render_grads(1);
        cn_batch_free(&gb);
        cn_model_free(&gm);
    }
}

/* Rays that never enter the scene bounds run no network rows: the colour is the background
 * and no parameter receives a gradient. */
static void test_render_all_outside(void **state)
{
    (void)state;
    setup_small_model(1, 0);
    for (int i = 0; i < GR; i++) {
        const float o[3] = {50.0f + (float)i, 50.0f, 50.0f}, d[3] = {1.0f, 0.0f, 0.0f};
        memcpy(gb.o + 3 * i, o, sizeof o);
        memcpy(gb.d + 3 * i, d, sizeof d);
        memcpy(gb.vd + 3 * i, d, sizeof d);
    }
    memset(gm.grads, 0, sizeof(float) * gm.n_params);
    render_loss(1);
    assert_int_equal(gb.n_rows[0], 0);
    assert_int_equal(gb.n_rows[1], 0);
    float bg[3];
    for (int a = 0; a < 3; a++)
        bg[a] = (float)gm.topo.background[a] / 255.0f;
    for (int i = 0; i < GR; i++)
        for (int a = 0; a < 3; a++) {
            assert_float_equal(gb.color[0][3 * i + a], bg[a], 1e-6);
            assert_float_equal(gb.color[1][3 * i + a], bg[a], 1e-6);
        }
    float *dcol[2] = {gg[0], gg[1]};
    cn_render_backward(&gm, &gb, GR, dcol);
    for (size_t k = 0; k < gm.n_params; k++)
        assert_true(gm.grads[k] == 0.0f);
    cn_batch_free(&gb);
    cn_model_free(&gm);
}

/* Compressed kernels: W = a round(Phi) + b; finite differences through a and b; the
 * straight-through gradient of Phi is a dW exactly. */
static void test_compressed_kernels(void **state)
{
    (void)state;
    setup_small_model(1, 1);
    cn_model_materialize(&gm);
    for (unsigned l = 0; l < gm.topo.n_layers; l++) {
        const float a = gm.params[gm.off_ab + 2 * l], b = gm.params[gm.off_ab + 2 * l + 1];
        assert_true(a > 0);
        for (size_t i = 0; i < 5; i++)
            assert_float_equal(cn_model_kernel(&gm, l)[i], a * cn_model_latent(&gm, l, i) + b,
                               1e-7);
    }
    for (unsigned net = 0; net < 2; net++) {
        net_grads(net, 1);
        const cnerf_net_info *N = &gm.topo.net[net];
        int bad = 0;
        for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
            const float a = gm.params[gm.off_ab + 2 * l];
            for (size_t i = 0; i < 7; i++)
                assert_float_equal(gm.grads[gm.layer[l].w + i], a * gm.kgrad[gm.kofs[l] + i],
                                   1e-6 * fabs(gm.grads[gm.layer[l].w + i]) + 1e-12);
        }
        for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
            for (int k = 0; k < 2; k++) {
                const size_t idx = gm.off_ab + 2 * l + (size_t)k;
                const float keep = gm.params[idx];
                /* a is small (Glorot limit / levels): a relative step keeps the float loss's
                 * round-off below the difference; b moves every weight of the layer, so a
                 * smaller step crosses fewer ReLU kinks */
                /* A central difference is wrong when [x - h, x + h] holds a kink, and which
                 * h does depends on the GEMM kernels' rounding (the CPU): b is checked at
                 * three steps and passes when one of them agrees; a wrong gradient disagrees
                 * at all three. */
                const double hs[3] = {k == 0 ? 1e-3 * keep : 6.25e-5, 2.5e-4, 1.5625e-5};
                double num = 0;
                int agree = 0;
                for (int j = 0; j < (k == 0 ? 1 : 3) && !agree; j++) {
                    const double h = hs[j];
                    gm.params[idx] = keep + (float)h;
                    const double lp = render_loss(net);
                    gm.params[idx] = keep - (float)h;
                    const double lm = render_loss(net);
                    gm.params[idx] = keep;
                    num = (lp - lm) / (((double)(keep + (float)h) - (double)(keep - (float)h)));
                    agree = fabs(gm.grads[idx] - num) <=
                            REL_TOL * fmax(fabs(gm.grads[idx]), fabs(num)) + RENDER_ABS_TOL;
                }
                if (!agree) {
                    print_error("net %u layer %u %s: analytic %g numeric %g\n", net, l,
                                k ? "b" : "a", gm.grads[idx], num);
                    bad++;
                }
            }
        }
        assert_int_equal(bad, 0);
    }
    /* The rate adds its gradient to the latents and priors, scaled. */
    memset(gm.grads, 0, sizeof(float) * gm.n_params);
    double bits = cn_model_rate(&gm, 3, 2.0f);
    assert_true(bits > 0);
    double g1 = gm.grads[gm.layer[0].w], p1 = gm.grads[gm.off_prior];
    memset(gm.grads, 0, sizeof(float) * gm.n_params);
    assert_float_equal(cn_model_rate(&gm, 3, 1.0f), bits, 1e-9 * bits);
    assert_float_equal(gm.grads[gm.layer[0].w] * 2, g1, 1e-6 * fabs(g1) + 1e-12);
    assert_float_equal(gm.grads[gm.off_prior] * 2, p1, 1e-5 * fabs(p1) + 1e-9);
    cn_batch_free(&gb);
    cn_model_free(&gm);
}

/* The trainer's float phase (cn_model.unrounded): W = a Phi + b, so that every latent has a
 * true derivative: finite differences through latents, a and b; rounding returns with the
 * flag cleared. */
static void test_unrounded_kernels(void **state)
{
    (void)state;
    setup_small_model(1, 1);
    gm.unrounded = 1;
    cn_model_materialize(&gm);
    int fractional = 0;
    for (unsigned l = 0; l < gm.topo.n_layers; l++) {
        const float a = gm.params[gm.off_ab + 2 * l], b = gm.params[gm.off_ab + 2 * l + 1];
        for (size_t i = 0; i < 5; i++) {
            const float phi = gm.params[gm.layer[l].w + i];
            assert_float_equal(cn_model_kernel(&gm, l)[i], a * phi + b, 1e-7);
            fractional += phi != roundf(phi);
        }
    }
    assert_true(fractional > 0); /* the check would not tell rounding apart otherwise */
    for (unsigned net = 0; net < 2; net++) {
        net_grads(net, 1);
        const cnerf_net_info *N = &gm.topo.net[net];
        int bad = 0, checked = 0;
        for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
            size_t idx[5] = {gm.layer[l].w, gm.layer[l].w + 3, gm.layer[l].w + 11,
                             gm.off_ab + 2 * l, gm.off_ab + 2 * l + 1};
            for (int k = 0; k < 5; k++) {
                const float keep = gm.params[idx[k]];
                /* as test_compressed_kernels: three steps, one of them clear of ReLU kinks;
                 * a latent's in latent units, a's relative to it, b's as there */
                const double hs[3][3] = {{1e-2, 2.5e-3, 6.25e-4},
                                         {1e-3 * keep, 2.5e-4 * keep, 6.25e-5 * keep},
                                         {6.25e-5, 2.5e-4, 1.5625e-5}};
                const double *h3 = hs[k < 3 ? 0 : k - 2];
                double num = 0;
                int agree = 0;
                for (int j = 0; j < 3 && !agree; j++) {
                    const double h = h3[j];
                    gm.params[idx[k]] = keep + (float)h;
                    const double lp = render_loss(net);
                    gm.params[idx[k]] = keep - (float)h;
                    const double lm = render_loss(net);
                    gm.params[idx[k]] = keep;
                    num = (lp - lm) / ((double)(keep + (float)h) - (double)(keep - (float)h));
                    agree = fabs(gm.grads[idx[k]] - num) <=
                            REL_TOL * fmax(fabs(gm.grads[idx[k]]), fabs(num)) + RENDER_ABS_TOL;
                }
                checked++;
                if (!agree) {
                    print_error("net %u layer %u param %d: analytic %g numeric %g\n", net, l, k,
                                gm.grads[idx[k]], num);
                    bad++;
                }
            }
        }
        assert_true(checked > 0);
        assert_int_equal(bad, 0);
    }
    gm.unrounded = 0;
    cn_model_materialize(&gm);
    for (size_t i = 0; i < 5; i++) {
        const float a = gm.params[gm.off_ab], b = gm.params[gm.off_ab + 1];
        assert_float_equal(cn_model_kernel(&gm, 0)[i], a * cn_model_latent(&gm, 0, i) + b, 1e-7);
    }
    cn_batch_free(&gb);
    cn_model_free(&gm);
}

/* Shared shifts (several scenes): W = a round(Phi) + b + g round(S). The scene's kernel
 * gradient reaches the shift model's kernel gradient unchanged; S gets g dW (straight
 * through) and g its finite difference. */
static void test_shared_shift(void **state)
{
    (void)state;
    setup_small_model(1, 1);
    cn_model sh;
    char err[256];
    assert_int_equal(cn_model_init_compressed(&sh, &gm.topo, 5, 1.0, err, sizeof err), 0);
    cn_rng r = cn_rng_seed(41);
    for (unsigned l = 0; l < sh.topo.n_layers; l++) {
        const cnerf_layer_info *L = &sh.topo.layer[l];
        float *s = sh.params + sh.layer[l].w;
        for (size_t i = 0; i < (size_t)L->n_in * L->n_out; i++)
            s[i] = (float)((int)cn_rng_below(&r, 5) - 2);
        sh.params[sh.off_ab + 2 * l] = 0.5f * gm.params[gm.off_ab + 2 * l];
        sh.params[sh.off_ab + 2 * l + 1] = 0.0f;
    }
    gm.shift = &sh;
    cn_model_materialize(&sh);
    cn_model_materialize(&gm);
    for (unsigned l = 0; l < gm.topo.n_layers; l++) {
        const float a = gm.params[gm.off_ab + 2 * l], b = gm.params[gm.off_ab + 2 * l + 1];
        const float g = sh.params[sh.off_ab + 2 * l];
        for (size_t i = 0; i < 5; i++)
            assert_float_equal(cn_model_kernel(&gm, l)[i],
                               a * cn_model_latent(&gm, l, i) + b + g * cn_model_latent(&sh, l, i),
                               1e-6);
    }
    for (unsigned net = 0; net < 2; net++) {
        memset(gm.grads, 0, sizeof(float) * gm.n_params);
        memset(sh.grads, 0, sizeof(float) * sh.n_params);
        cn_model_materialize(&sh); /* zeroes the shift's kernel gradients */
        render_loss(net);
        float *dcol[2] = {NULL, NULL};
        dcol[net] = gg[net];
        cn_render_backward(&gm, &gb, GR, dcol);
        cn_model_kernels_backward(&gm);
        cn_model_kernels_backward(&sh);
        const cnerf_net_info *N = &gm.topo.net[net];
        int bad = 0;
        for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
            const float g = sh.params[sh.off_ab + 2 * l];
            for (size_t i = 0; i < 7; i++) {
                assert_true(sh.kgrad[sh.kofs[l] + i] == gm.kgrad[gm.kofs[l] + i]);
                assert_float_equal(sh.grads[sh.layer[l].w + i], g * gm.kgrad[gm.kofs[l] + i],
                                   1e-6 * fabs(sh.grads[sh.layer[l].w + i]) + 1e-12);
            }
        }
        /* (each difference below re-materializes, which zeroes the kernel gradients) */
        for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
            const size_t idx = sh.off_ab + 2 * (size_t)l;
            const float keep = sh.params[idx];
            /* g moves every weight of the layer: as for b above, three steps, one of which
             * must agree (a kink inside [g - h, g + h] spoils a central difference) */
            double num = 0;
            int agree = 0;
            for (int k = 0; k < 3 && !agree; k++) {
                const double h = 1e-3 * keep / (double)(1 << (2 * k));
                sh.params[idx] = keep + (float)h;
                cn_model_materialize(&sh);
                const double lp = render_loss(net);
                sh.params[idx] = keep - (float)h;
                cn_model_materialize(&sh);
                const double lm = render_loss(net);
                sh.params[idx] = keep;
                cn_model_materialize(&sh);
                num = (lp - lm) / (((double)(keep + (float)h) - (double)(keep - (float)h)));
                agree = fabs(sh.grads[idx] - num) <=
                        REL_TOL * fmax(fabs(sh.grads[idx]), fabs(num)) + RENDER_ABS_TOL;
            }
            if (!agree) {
                print_error("net %u layer %u g: analytic %g numeric %g\n", net, l, sh.grads[idx],
                            num);
                bad++;
            }
        }
        assert_int_equal(bad, 0);
    }
    gm.shift = NULL;
    cn_model_free(&sh);
    cn_batch_free(&gb);
    cn_model_free(&gm);
}

/* The photometric loss L = s/2 sum (x - y)^2 against its gradient s (x - y), at both of
 * the trainer's scales (cn_sq_error). */
static void test_loss(void **state)
{
    (void)state;
    enum { NL = 48 };
    float x[NL], y[NL], g[NL], scratch[NL];
    cn_rng r = cn_rng_seed(11);
    fill(x, NL, &r, 1.0);
    fill(y, NL, &r, 1.0);
    const float scales[2] = {2.0f / (3 * 16), 2.0f * 2500 / 16};
    for (int k = 0; k < 2; k++) {
        const float s = scales[k];
        const double se = cn_sq_error(g, x, y, NL, s);
        double want = 0;
        for (int i = 0; i < NL; i++)
            want += ((double)x[i] - y[i]) * ((double)x[i] - y[i]);
        assert_float_equal(se, want, 1e-9 * want);
        int bad = 0;
        for (int i = 0; i < NL; i++) {
            const double h = 1e-3;
            const float keep = x[i];
            x[i] = keep + (float)h;
            const double lp = s / 2.0 * cn_sq_error(scratch, x, y, NL, s);
            x[i] = keep - (float)h;
            const double lm = s / 2.0 * cn_sq_error(scratch, x, y, NL, s);
            x[i] = keep;
            const double num = (lp - lm) / (2 * h);
            if (!close_enough(g[i] / s, num / s)) {
                print_error("scale %g, x[%d]: analytic %g numeric %g\n", s, i, g[i], num);
                bad++;
            }
        }
        assert_int_equal(bad, 0);
    }
}

static void test_posenc_values(void **state)
{
    (void)state;
    const float v[6] = {0.3f, -1.7f, 2.2f, 4.1f, 0.0f, -0.01f};
    float out[2 * 63];
    cn_posenc(out, 63, v, 2, 10, 1);
    for (int p = 0; p < 2; p++) {
        for (int a = 0; a < 3; a++)
            assert_float_equal(out[p * 63 + a], v[p * 3 + a], 0);
        for (int l = 0; l < 10; l++)
            for (int a = 0; a < 3; a++) {
                double arg = ldexp((double)v[p * 3 + a], l);
                assert_float_equal(out[p * 63 + 3 + 6 * l + a], sin(arg), 2e-6);
                assert_float_equal(out[p * 63 + 6 + 6 * l + a], cos(arg), 2e-6);
            }
    }
}

/* Hierarchical sampling: sorted, inside the bounds, concentrated where the weights are. */
static void test_fine_sampling(void **state)
{
    (void)state;
    enum { NC = 16, NF = 64 };
    float w[NC] = {0}, t[NF], tc[NC], all[NC + NF];
    w[5] = 0.7f;
    w[11] = 0.3f;
    cn_rng r = cn_rng_seed(4);
    for (int pass = 0; pass < 2; pass++) {
        cn_sample_fine(t, NF, w, NC, 2.0f, 6.0f, pass ? &r : NULL);
        int in5 = 0, in11 = 0;
        for (int j = 0; j < NF; j++) {
            assert_true(t[j] >= 2.0f && t[j] <= 6.0f);
            if (j)
                assert_true(t[j] >= t[j - 1]);
            in5 += t[j] >= 2.0f + 5 * 0.25f && t[j] < 2.0f + 6 * 0.25f;
            in11 += t[j] >= 2.0f + 11 * 0.25f && t[j] < 2.0f + 12 * 0.25f;
        }
        assert_true(in5 >= 40 && in5 <= 50);  /* ~70% of 64 */
        assert_true(in11 >= 15 && in11 <= 23); /* ~30% */
    }
    cn_sample_coarse(tc, NC, 2.0f, 6.0f, NULL);
    assert_float_equal(tc[0], 2.125f, 1e-6);
    cn_merge_sorted(all, tc, NC, t, NF);
    for (int j = 1; j < NC + NF; j++)
        assert_true(all[j] >= all[j - 1]);
    /* Deterministic quantiles: the evaluation rule. */
    float w1[4] = {1, 1, 1, 1};
    float t4[4];
    cn_sample_fine(t4, 4, w1, 4, 0.0f, 4.0f, NULL);
    for (int j = 0; j < 4; j++)
        assert_float_equal(t4[j], j + 0.5f, 1e-5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_linear_relu),
        cmocka_unit_test(test_volume_rendering),
        cmocka_unit_test(test_loss),
        cmocka_unit_test(test_posenc_values),
        cmocka_unit_test(test_fine_sampling),
        cmocka_unit_test(test_render_grads_view),
        cmocka_unit_test(test_render_grads_no_view),
        cmocka_unit_test(test_render_grads_pruned),
        cmocka_unit_test(test_density_only),
        cmocka_unit_test(test_render_grads_group),
        cmocka_unit_test(test_render_all_outside),
        cmocka_unit_test(test_compressed_kernels),
        cmocka_unit_test(test_unrounded_kernels),
        cmocka_unit_test(test_shared_shift),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
