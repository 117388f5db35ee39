/* Occupancy grids: cells from points, updates from a network's density, and the render
 * skipping samples in empty cells. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cn_occ.h"
#include "cn_render.h"
#include "testutil.h"

static void set_biases(cn_model *m, float v)
{
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        memset(m->params + m->layer[l].w, 0,
               sizeof(float) * m->topo.layer[l].n_in * m->topo.layer[l].n_out);
        for (unsigned o = 0; o < m->topo.layer[l].n_out; o++)
            m->params[m->layer[l].b + o] = v;
    }
}

static void make_model(cn_model *m)
{
    cnerf_info hdr;
    tu_small_header(&hdr, 4, 8, 1);
    char err[256];
    assert_int_equal(cn_model_init(m, &hdr, 3, err, sizeof err), 0);
}

/* Points map to the cell that contains them; a grid without an estimate lets all through. */
static void test_cells(void **state)
{
    (void)state;
    cn_model m;
    make_model(&m);
    cn_occ o;
    assert_int_equal(cn_occ_init(&o, &m.topo, 4), 0);
    const float lo = (float)m.topo.aabb_q16[0] / 65536.0f, hi = (float)m.topo.aabb_q16[3] / 65536.0f;
    const float p_lo[3] = {lo, lo, lo}, p_hi[3] = {hi, hi, hi};
    assert_true(cn_occ_test(&o, p_lo)); /* no estimate yet */
    o.valid = 1;
    memset(o.occupied, 0, 64);
    assert_false(cn_occ_test(&o, p_lo));
    o.occupied[0] = 1; /* the lowest corner cell */
    assert_true(cn_occ_test(&o, p_lo));
    assert_false(cn_occ_test(&o, p_hi));
    o.occupied[63] = 1; /* the highest, which also holds the upper bound itself */
    assert_true(cn_occ_test(&o, p_hi));
    const float step = (hi - lo) / 4;
    const float p[3] = {lo + 1.5f * step, lo + 2.5f * step, lo + 3.5f * step}; /* cell (1,2,3) */
    assert_false(cn_occ_test(&o, p));
    o.occupied[(3 * 4 + 2) * 4 + 1] = 1;
    assert_true(cn_occ_test(&o, p));
    cn_occ_free(&o);
    assert_int_equal(cn_occ_init(&o, &m.topo, 0), -1);
    assert_int_equal(cn_occ_init(&o, &m.topo, 257), -1);
    cn_model_free(&m);
}

/* A network of zero density empties every cell; a dense one fills them; the decaying maximum
 * keeps a cell occupied for a while after its density drops. */
static void test_update(void **state)
{
    (void)state;
    cn_model m;
    make_model(&m);
    cn_net_buf nb;
    assert_int_equal(cn_net_buf_init(&nb, &m.topo, 0, 100), 0); /* fewer rows than cells */
    cn_occ o;
    assert_int_equal(cn_occ_init(&o, &m.topo, 8), 0);
    cn_rng r = cn_rng_seed(1);
    const float thr = cn_occ_threshold(&m.topo);
    assert_true(thr > 0);
    set_biases(&m, -1.0f); /* sigma = ReLU(-1) = 0 everywhere */
    assert_float_equal(cn_occ_update(&o, &m, 0, &nb, &r, 0.5f, thr), 0.0, 0);
    set_biases(&m, 4.0f * thr); /* sigma = 4 thr */
    assert_float_equal(cn_occ_update(&o, &m, 0, &nb, &r, 0.5f, thr), 1.0, 0);
    set_biases(&m, 0.0f);
    assert_float_equal(cn_occ_update(&o, &m, 0, &nb, &r, 0.5f, thr), 1.0, 0); /* 2 thr left */
    assert_float_equal(cn_occ_update(&o, &m, 0, &nb, &r, 0.5f, thr), 0.0, 0); /* thr: not above */
    cn_occ_free(&o);
    cn_net_buf_free(&nb);
    cn_model_free(&m);
}

/* R rays from above the scene, fanning out in y and starting apart in x. */
static void fan_of_rays(cn_batch *b, int R)
{
    for (int i = 0; i < R; i++) {
        const float o[3] = {0.1f * i, 0.0f, 4.0f}, d[3] = {0.0f, 0.05f * i, -1.0f};
        memcpy(b->o + 3 * i, o, sizeof o);
        memcpy(b->d + 3 * i, d, sizeof d);
        memcpy(b->vd + 3 * i, d, sizeof d);
    }
}

/* With an empty grid the render runs no network rows and returns the background; with a full
 * one it renders as without a grid. */
static void test_render_skips(void **state)
{
    (void)state;
    cn_model m;
    make_model(&m);
    cn_rng r = cn_rng_seed(2);
    for (size_t i = 0; i < m.n_params; i++)
        m.params[i] = (float)(cn_rng_uniform(&r) - 0.5);
    enum { R = 5 };
    cn_batch b;
    assert_int_equal(cn_batch_init(&b, &m.topo, R), 0);
    fan_of_rays(&b, R);
    cn_render_forward(&m, &b, R, NULL);
    float plain[R * 3];
    memcpy(plain, b.color[0], sizeof plain);
    const size_t rows = b.n_rows[0];
    assert_true(rows > 0);
    cn_occ o;
    assert_int_equal(cn_occ_init(&o, &m.topo, 4), 0);
    o.valid = 1;
    b.occ[0] = &o;
    cn_render_forward(&m, &b, R, NULL);
    assert_int_equal(b.n_rows[0], rows);
    assert_memory_equal(plain, b.color[0], sizeof plain);
    memset(o.occupied, 0, 64);
    cn_render_forward(&m, &b, R, NULL);
    assert_int_equal(b.n_rows[0], 0);
    for (int i = 0; i < R * 3; i++)
        assert_float_equal(b.color[0][i], m.topo.background[i % 3] / 255.0f, 1e-6);
    cn_occ_free(&o);
    cn_batch_free(&b);
    cn_model_free(&m);
}

/* With sat_eps, the fine network skips exactly the samples behind the coarse sample after
 * which the coarse transmittance falls below sat_eps; behind an opaque surface they carry no
 * weight, so the colour hardly moves. */
static void test_render_skips_saturated(void **state)
{
    (void)state;
    cn_model m;
    make_model(&m);
    set_biases(&m, 1.0f);
    /* Density 40 in both networks: opaque after a sample or two inside the bounds (where
     * the fine network disagrees with the coarse one, the skip changes its colour: that is
     * the approximation training accepts). */
    for (unsigned n = 0; n < 2; n++)
        m.params[m.layer[m.topo.net[n].first_layer + m.topo.net[n].depth].b] = 40.0f;
    enum { R = 4 };
    cn_batch b;
    assert_int_equal(cn_batch_init(&b, &m.topo, R), 0);
    fan_of_rays(&b, R);
    const unsigned ns = b.ns, nc = b.nc;
    cn_render_forward(&m, &b, R, NULL);
    const size_t rows = b.n_rows[1];
    float plain[R * 3];
    uint8_t *in_plain = malloc((size_t)R * ns);
    memcpy(plain, b.color[1], sizeof plain);
    memcpy(in_plain, b.inside[1], (size_t)R * ns);
    b.sat_eps = 1e-3f;
    cn_render_forward(&m, &b, R, NULL);
    assert_true(b.n_rows[1] < rows);
    size_t kept = 0;
    for (int r = 0; r < R; r++) {
        /* the expected cut: the coarse sample after the first whose transmittance < eps */
        double T = 1;
        float cut = (float)m.topo.far_q16 / 65536.0f;
        for (unsigned i = 0; i + 1 < nc; i++) {
            T -= b.w_c[r * nc + i];
            if (T < 1e-3) {
                cut = b.t_c[r * nc + i + 1];
                break;
            }
        }
        assert_true(cut < (float)m.topo.far_q16 / 65536.0f); /* every ray hits the surface */
        for (unsigned i = 0; i < ns; i++) {
            const size_t k = (size_t)r * ns + i;
            assert_int_equal(b.inside[1][k], in_plain[k] && b.t_f[k] <= cut);
            kept += b.inside[1][k];
        }
        for (int c = 0; c < 3; c++)
            assert_float_equal(b.color[1][r * 3 + c], plain[r * 3 + c], 2e-3);
    }
    assert_int_equal(kept, b.n_rows[1]);
    free(in_plain);
    cn_batch_free(&b);
    cn_model_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cells),
        cmocka_unit_test(test_update),
        cmocka_unit_test(test_render_skips),
        cmocka_unit_test(test_render_skips_saturated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
