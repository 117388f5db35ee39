/* Rate control (cn_ratectl.h): the planned path, both controllers on a model of how a
 * trained stream's size answers lambda, and the in-memory size of a real model. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_export.h"
#include "cn_nerf.h"
#include "cn_prune.h"
#include "cn_ratectl.h"
#include "cn_rate.h"
#include "cn_scales.h"
#include "cn_synth.h"
#include "cn_train.h"
#include "testutil.h"

static cn_ratectl make(cn_rc_scheme scheme, double target, long iters)
{
    cn_ratectl rc;
    memset(&rc, 0, sizeof rc);
    rc.scheme = scheme;
    rc.target = target;
    rc.reserved = 300;
    rc.every = 10;
    rc.start = 0;
    rc.iters = iters;
    rc.lambda_unit = 50;
    return rc;
}

/* The plan: the target (less the reserve) before any measurement; from the first size down
 * to the goal geometrically, arriving at CN_RC_ARRIVE of the run, then flat. */
static void test_plan(void **state)
{
    (void)state;
    cn_ratectl rc = make(CN_RC_LOG_PI, 10300, 1000);
    const long arrive = (long)(CN_RC_ARRIVE * 1000);
    assert_true(fabs(cn_ratectl_plan(&rc, 0) - 10000) < 1e-9);
    cn_ratectl_update(&rc, 0, 40000);
    assert_true(fabs(cn_ratectl_plan(&rc, 0) - 40000) < 1e-6);
    /* halfway: the mean of the logs */
    assert_true(fabs(cn_ratectl_plan(&rc, arrive / 2) - 20000) < 1e-6);
    assert_true(fabs(cn_ratectl_plan(&rc, arrive) - 10000) < 1e-6);
    assert_true(fabs(cn_ratectl_plan(&rc, 1000) - 10000) < 1e-6);
    rc.reserved = 1300; /* a grid measured later lowers the goal from then on */
    assert_true(fabs(cn_ratectl_plan(&rc, 900) - 9000) < 1e-6);
}

/* A check that both controllers converge and do not oscillate, not a model of training
 * (on real runs the size also drifts down at a fixed lambda; docs/results.md has those
 * runs). Targets 6,000 to 15,360 bytes, lags 0.05 to 0.2, constant or falling tenfold over
 * the run: with the tail term and the plan arriving at 70% every file lands within 1.5%;
 * arriving at 80% without it, 12 of the 36 ended more than 3% over (up to 10.2%).
 * A stand-in for training: the size the latents settle at falls steeply with lambda (from
 * 29 kB at lambda 0 towards the topology's 3 kB, 3 + 26 / (1 + gain lambda / unit) kB; tiny
 * on Lego at 100x100 goes from 28.7 kB to 15.6 kB at lambda = 0.1 units, a gain of 10, and
 * early in training a model answers lambda faster; these runs use 100, the settle test's
 * and a harder case), and the stream's size approaches it by a fraction `lag` of the gap per
 * measurement (the latents need tens to hundreds of iterations to follow a new lambda). */
static double settle(double lambda, double unit, double gain)
{
    return 3000 + 26000 / (1 + gain * lambda / unit);
}

/* decay: the lag falls to this fraction at the end of the run, as the latents' learning
 * rate does (tenfold in cnerf's default schedule), so that late in the run a larger lambda
 * takes longer to bring the size down. */
/* warm: the fraction by which the size grows at any lambda over the first 20 iterations, as a
 * freshly initialised model's does when it starts to learn (7% on Fern at 1/4 size). */
static double run_plant_warm(cn_rc_scheme scheme, double target, double lag, double decay,
                             double gain, double warm, double *overshoot, double *early)
{
    const long iters = 3000;
    cn_ratectl rc = make(scheme, target, iters);
    double x = settle(0, rc.lambda_unit, gain), lambda = 0, size = x;
    *overshoot = 0;
    *early = 0;
    for (long step = 0; step < iters; step += rc.every) {
        size = x * (1 + warm * (step < 20 ? (double)step / 20 : 1));
        lambda = cn_ratectl_update(&rc, step, size);
        assert_true(lambda > 0 && isfinite(lambda));
        const double below = 1 - size / rc.plan;
        if (step >= CN_RC_ARRIVE * iters)
            *overshoot = below > *overshoot ? below : *overshoot;
        else
            *early = below > *early ? below : *early;
        x += lag * pow(decay, (double)step / iters) * (settle(lambda, rc.lambda_unit, gain) - x);
    }
    return size / (target - rc.reserved) - 1;
}

static double run_plant(cn_rc_scheme scheme, double target, double lag, double decay,
                        double *overshoot)
{
    double early;
    return run_plant_warm(scheme, target, lag, decay, 100, 0, overshoot, &early);
}

static void test_controllers_settle(void **state)
{
    (void)state;
    const char *names[2] = {"log PI", "dual"};
    int bad = 0;
    for (int s = 0; s < 2; s++)
        for (double target = 6000; target <= 16000; target *= 1.6)
            for (double lag = 0.05; lag <= 0.2; lag *= 2)
                for (double decay = 1; decay >= 0.1; decay /= 10) {
                    double over;
                    const double miss = run_plant((cn_rc_scheme)s, target, lag, decay, &over);
                    print_message("# %s, target %.0f, lag %.2f to %.3f: final %+.2f%%, "
                                  "largest undershoot after arrival %.2f%%\n", names[s],
                                  target, lag, lag * decay, 100 * miss, 100 * over);
                    bad += fabs(miss) >= 0.03;
                    bad += over >= 0.1;
                }
    assert_int_equal(bad, 0);
}

/* A model whose size grows while it warms up: the controller must not take that first slope
 * for where the size is heading. Extrapolated fifty measurements ahead, it raised lambda
 * to 0.075 units within 50 iterations on Fern at 1/4 size (target 20,000 bytes), and the
 * stream fell 26% under the plan and stayed there with lambda on its floor. Here, with a
 * gain of 30, the plant's stream fell up to 5.2% under the plan that way. */
static void test_warm_up(void **state)
{
    (void)state;
    const char *names[2] = {"log PI", "dual"};
    int bad = 0;
    for (int s = 0; s < 2; s++)
        for (double lag = 0.05; lag <= 0.2; lag *= 2) {
            double over, early;
            const double miss =
                run_plant_warm((cn_rc_scheme)s, 20000, lag, 0.1, 30, 0.07, &over, &early);
            print_message("# %s, warm-up 7%%, lag %.2f: final %+.2f%%, largest undershoot "
                          "before arrival %.2f%%, after %.2f%%\n",
                          names[s], lag, 100 * miss, 100 * early, 100 * over);
            bad += fabs(miss) >= 0.03;
            bad += early >= 0.03;
        }
    assert_int_equal(bad, 0);
}

/* A target above what the model needs: lambda sits on its floor, never below. */
static void test_floor(void **state)
{
    (void)state;
    cn_ratectl rc = make(CN_RC_LOG_PI, 100000, 1000);
    double lambda = 0;
    for (long step = 0; step < 1000; step += 10)
        lambda = cn_ratectl_update(&rc, step, 40000);
    assert_true(lambda > 0 && lambda <= 1e-3 * rc.lambda_unit);
    /* The integral did not wind up: one measurement over the plan raises lambda at once. */
    const double up = cn_ratectl_update(&rc, 1000, 200000);
    assert_true(up > lambda);
}

/* Preset tiny at initialisation (seed 5, 8 levels). */
static void tiny_model(cn_model *m)
{
    cnerf_info hdr;
    char err[256];
    assert_int_equal(cn_preset_header("tiny", &hdr), 0);
    assert_int_equal(cn_model_init_compressed(m, &hdr, 5, 8.0, err, sizeof err), 0);
}

/* A real model: its stream's size without and with dead units removed, and the floor of
 * its topology; none of them changes the model. */
static void test_stream_size(void **state)
{
    (void)state;
    cn_model m;
    char err[256];
    tiny_model(&m);
    float *before = malloc(sizeof(float) * m.n_params);
    assert_non_null(before);
    memcpy(before, m.params, sizeof(float) * m.n_params);
    size_t all, pruned, least;
    assert_int_equal(cn_stream_size(&m, 1, 0, &all, err, sizeof err), 0);
    assert_int_equal(cn_stream_size(&m, 1, 1, &pruned, err, sizeof err), 0);
    assert_int_equal(cn_stream_floor(&m, 1, &least, err, sizeof err), 0);
    print_message("# tiny at initialisation: %zu bytes, %zu with dead units removed; floor %zu\n",
                  all, pruned, least);
    assert_true(pruned <= all);
    assert_true(least < pruned / 4);
    assert_memory_equal(before, m.params, sizeof(float) * m.n_params);
    free(before);
    cn_model_free(&m);
}

/* The size rate control measures (scales from CN_RC_SCALE_POINTS points) against the
 * stream written with scales from CN_SCALE_POINTS, with dead units removed in both: a model
 * at initialisation, and the same with a third of its units' biases far below zero (dead). */
static void test_size_with_fewer_scale_points(void **state)
{
    (void)state;
    cn_model m;
    char err[256];
    tiny_model(&m);
    for (int pass = 0; pass < 2; pass++) {
        if (pass)
            for (unsigned l = 0; l < m.topo.n_layers; l++)
                for (unsigned o = 0; o < m.topo.layer[l].n_out; o += 3)
                    m.params[m.layer[l].b + o] = -50.0f;
        cn_model_materialize(&m);
        size_t fast;
        assert_int_equal(cn_stream_size(&m, 1, 1, &fast, err, sizeof err), 0);
        cn_export e;
        assert_int_equal(cn_export_compressed(&m, NULL, &e, err, sizeof err), 0);
        assert_int_equal(cn_choose_scales(&e.src, 1, NULL, err, sizeof err), 0);
        cn_prune_report pr;
        assert_int_equal(cn_export_prune(&e, &pr, err, sizeof err), 0);
        cn_buf b = {0};
        cn_write_report rep;
        assert_int_equal(cn_write_stream(&e.src, &b, &rep, err, sizeof err), 0);
        print_message("# pass %d: %zu bytes measured, %zu written (latents %u of %u kept)\n",
                      pass, fast, b.n, pr.params_after, pr.params_before);
        assert_int_equal(fast, b.n);
        assert_true(pass ? pr.params_after < pr.params_before : pr.params_after > 0);
        cn_buf_free(&b);
        cn_export_free(&e);
    }
    cn_model_free(&m);
}

/* --preset auto: small from exactly the size that gives its latents CN_AUTO_BITS each beyond
 * its floor, tiny a byte below it and for any budget too small for either. */
static void test_preset_auto(void **state)
{
    (void)state;
    cn_dataset ds;
    memset(&ds, 0, sizeof ds);
    ds.kind = CN_DS_BLENDER;
    ds.near = 2;
    ds.far = 6;
    ds.bg[0] = ds.bg[1] = ds.bg[2] = 1;
    cn_train_opts o;
    cn_train_defaults(&o);
    o.compress = 1;
    char err[256];
    size_t floor_tiny, lat_tiny, floor_small, lat_small;
    o.preset = "tiny";
    assert_int_equal(cn_preset_floor(&ds, &o, &floor_tiny, &lat_tiny, err, sizeof err), 0);
    o.preset = "small";
    assert_int_equal(cn_preset_floor(&ds, &o, &floor_small, &lat_small, err, sizeof err), 0);
    assert_true(lat_small > 2 * lat_tiny && floor_small > floor_tiny);
    const double edge = (double)floor_small + CN_AUTO_BITS * (double)lat_small / 8;
    const char *p = NULL;
    double bits = 0;
    o.preset = "auto";
    assert_int_equal(cn_preset_auto(&ds, &o, ceil(edge), &p, &bits, err, sizeof err), 0);
    assert_string_equal(p, "small");
    assert_true(bits >= CN_AUTO_BITS && bits < CN_AUTO_BITS + 1e-3);
    assert_int_equal(cn_preset_auto(&ds, &o, ceil(edge) - 1, &p, &bits, err, sizeof err), 0);
    assert_string_equal(p, "tiny");
    assert_true(fabs(bits - 8 * (ceil(edge) - 1 - (double)floor_tiny) / (double)lat_tiny) < 1e-9);
    assert_int_equal(cn_preset_auto(&ds, &o, 100, &p, &bits, err, sizeof err), 0);
    assert_string_equal(p, "tiny");
    assert_true(bits < 0);
    print_message("# tiny: floor %zu bytes, %zu latents; small: floor %zu, %zu latents; small "
                  "from %.0f bytes\n", floor_tiny, lat_tiny, floor_small, lat_small, ceil(edge));
    /* Without the coarse colour (encode's default) the rule counts the latents sent: the
     * coarse feature, view and rgb layers' are not, and their zeros leave the floor too. */
    o.coarse_color = 0;
    size_t floor_off, lat_off;
    o.preset = "small";
    assert_int_equal(cn_preset_floor(&ds, &o, &floor_off, &lat_off, err, sizeof err), 0);
    cnerf_info hdr;
    assert_int_equal(cn_header_for_dataset(&ds, &o, &hdr, err, sizeof err), 0);
    assert_int_equal(cnerf_expand_topology(&hdr), CNERF_OK);
    unsigned first, count;
    assert_true(cn_color_layers(&hdr, 0, &first, &count));
    size_t colour = 0;
    for (unsigned l = first; l < first + count; l++)
        colour += (size_t)hdr.layer[l].n_in * hdr.layer[l].n_out;
    assert_int_equal(lat_off, lat_small - colour);
    assert_true(floor_off < floor_small);
    const double edge_off = (double)floor_off + CN_AUTO_BITS * (double)lat_off / 8;
    o.preset = "auto";
    assert_int_equal(cn_preset_auto(&ds, &o, ceil(edge_off), &p, &bits, err, sizeof err), 0);
    assert_string_equal(p, "small");
    assert_int_equal(cn_preset_auto(&ds, &o, ceil(edge_off) - 1, &p, &bits, err, sizeof err), 0);
    assert_string_equal(p, "tiny");
    print_message("# without the coarse colour: small sends %zu latents, floor %zu bytes; small "
                  "from %.0f bytes\n", lat_off, floor_off, ceil(edge_off));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plan),
        cmocka_unit_test(test_controllers_settle),
        cmocka_unit_test(test_warm_up),
        cmocka_unit_test(test_floor),
        cmocka_unit_test(test_stream_size),
        cmocka_unit_test(test_size_with_fewer_scale_points),
        cmocka_unit_test(test_preset_auto),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
