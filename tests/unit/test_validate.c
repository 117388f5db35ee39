/* Validation (cn_validate.h): which views are held out, the fixed rays, the PSNR on them,
 * and that measuring a model while it trains leaves its training unchanged to the bit. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_metrics.h"
#include "cn_rate.h"
#include "cn_train.h"
#include "cn_validate.h"
#include "testutil.h"

static void load(const char *scene, cn_dataset *ds)
{
    cn_dataset_opts o;
    memset(&o, 0, sizeof o);
    o.downscale = 16;
    o.max_views = 20;
    char err[512];
    if (cn_dataset_load(scene, &o, ds, err, sizeof err))
        fail_msg("%s", err);
}

/* A trainer of preset tiny with the default options. */
static void tiny_trainer(cn_trainer *t, const cn_dataset *ds)
{
    cn_train_opts o;
    cn_train_defaults(&o);
    o.preset = "tiny";
    char err[256];
    if (cn_trainer_init(t, ds, &o, err, sizeof err))
        fail_msg("%s", err);
}

static void test_default_rule(void **state)
{
    (void)state;
    static const int rows[][3] = {/* n_train, n_val, held out */
                                  {1, 0, 0},   {7, 0, 0},  {8, 0, 1},   {17, 0, 1},
                                  {23, 0, 1},  {24, 0, 2}, {42, 0, 3},  {55, 0, 3},
                                  {100, 0, 6}, {1000, 0, 8}, {100, 5, 0}, {42, 1, 0}};
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        const int got = cn_val_default_views(rows[i][0], rows[i][1]);
        if (got != rows[i][2])
            fail_msg("%d train, %d val: %d held out, expected %d", rows[i][0], rows[i][1], got,
                     rows[i][2]);
    }
}

/* Fern: 17 training views (0, 8 and 16 of its 20 are test views). */
static void test_hold_out_fern(void **state)
{
    (void)state;
    cn_dataset ds, all;
    load(CNERF_DATA_DIR "/fern", &ds);
    load(CNERF_DATA_DIR "/fern", &all);
    assert_int_equal(all.n_train, 17);
    assert_int_equal(all.n_val, 0);
    char err[256];
    /* The default: one view, the middle one. */
    assert_int_equal(cn_dataset_hold_out(&ds, -1, err, sizeof err), 1);
    assert_int_equal(ds.n_train, 16);
    assert_int_equal(ds.n_val, 1);
    assert_string_equal(ds.val[0].name, all.train[8].name);
    /* The rest keep their order, and every view is in exactly one split. */
    for (int i = 0, j = 0; i < all.n_train; i++) {
        if (i == 8)
            continue;
        assert_string_equal(ds.train[j++].name, all.train[i].name);
    }
    /* A dataset with validation views is left alone. */
    assert_int_equal(cn_dataset_hold_out(&ds, 3, err, sizeof err), 0);
    assert_int_equal(ds.n_train, 16);
    cn_dataset_free(&ds);

    /* Four, spread evenly: training views 2, 6, 10 and 14. */
    load(CNERF_DATA_DIR "/fern", &ds);
    assert_int_equal(cn_dataset_hold_out(&ds, 4, err, sizeof err), 4);
    static const int picked[4] = {2, 6, 10, 14};
    for (int k = 0; k < 4; k++)
        assert_string_equal(ds.val[k].name, all.train[picked[k]].name);
    assert_int_equal(ds.n_train, 13);
    cn_dataset_free(&ds);

    /* None, and all: 0 holds none out; holding out every training view is refused, and the
     * dataset is left as it was. */
    load(CNERF_DATA_DIR "/fern", &ds);
    assert_int_equal(cn_dataset_hold_out(&ds, 0, err, sizeof err), 0);
    assert_int_equal(ds.n_val, 0);
    err[0] = 0;
    assert_int_equal(cn_dataset_hold_out(&ds, 17, err, sizeof err), -1);
    assert_non_null(strstr(err, "at least one must remain"));
    assert_int_equal(ds.n_train, 17);
    assert_int_equal(ds.n_val, 0);
    cn_dataset_free(&ds);
    cn_dataset_free(&all);
}

/* Blender's own val split is the validation: nothing is moved. */
static void test_hold_out_blender(void **state)
{
    (void)state;
    cn_dataset ds;
    load(CNERF_DATA_DIR "/lego", &ds);
    const int n_train = ds.n_train, n_val = ds.n_val;
    assert_true(n_val > 0);
    char err[256];
    assert_int_equal(cn_dataset_hold_out(&ds, -1, err, sizeof err), 0);
    assert_int_equal(ds.n_train, n_train);
    assert_int_equal(ds.n_val, n_val);
    cn_dataset_free(&ds);
}

/* The rays: the same for a seed, others for another; each starts at its view's camera and
 * carries one of its pixels. The PSNR on rays made of every pixel of a view is the PSNR of
 * the whole view rendered by cn_render_view. */
static void test_rays_and_psnr(void **state)
{
    (void)state;
    cn_dataset ds;
    load(CNERF_DATA_DIR "/lego", &ds);
    cn_val_rays a, b, c;
    assert_int_equal(cn_val_rays_init(&a, ds.val, 3, ds.ndc, 300, 5), 0);
    assert_int_equal(cn_val_rays_init(&b, ds.val, 3, ds.ndc, 300, 5), 0);
    assert_int_equal(cn_val_rays_init(&c, ds.val, 3, ds.ndc, 300, 6), 0);
    assert_int_equal(a.n, 300);
    assert_memory_equal(a.d, b.d, sizeof(float) * 3 * a.n);
    assert_memory_equal(a.gt, b.gt, sizeof(float) * 3 * a.n);
    assert_true(memcmp(a.d, c.d, sizeof(float) * 3 * a.n) != 0);
    for (size_t r = 0; r < a.n; r++) {
        int found = 0;
        for (int v = 0; v < 3 && !found; v++) {
            const cn_view *w = &ds.val[v];
            int at_camera = 1;
            for (int k = 0; k < 3; k++)
                at_camera &= fabs(a.o[3 * r + k] - w->c2w[k][3]) < 1e-5;
            for (size_t p = 0; at_camera && p < (size_t)w->w * w->h && !found; p++)
                found = !memcmp(w->rgb + 3 * p, a.gt + 3 * r, sizeof(float) * 3);
        }
        assert_true(found);
    }
    cn_val_rays_free(&a);
    cn_val_rays_free(&b);
    cn_val_rays_free(&c);
    cn_val_rays empty;
    assert_int_equal(cn_val_rays_init(&empty, ds.val, 0, ds.ndc, 300, 5), 0);
    assert_int_equal(empty.n, 0);

    /* Every pixel of view 0, in order. */
    const cn_view *w = &ds.val[0];
    const size_t n = (size_t)w->w * w->h;
    cn_val_rays all = {n, malloc(sizeof(float) * 3 * n), malloc(sizeof(float) * 3 * n),
                       malloc(sizeof(float) * 3 * n), malloc(sizeof(float) * 3 * n)};
    assert_true(all.o && all.d && all.vd && all.gt);
    cn_camera cam;
    cn_view_camera(w, &cam);
    for (size_t p = 0; p < n; p++)
        cn_camera_ray(&cam, ds.ndc, (double)(p % w->w), (double)(p / w->w), all.o + 3 * p,
                      all.d + 3 * p, all.vd + 3 * p);
    memcpy(all.gt, w->rgb, sizeof(float) * 3 * n);
    cn_trainer t;
    tiny_trainer(&t, &ds);
    float *rgb = malloc(sizeof(float) * 3 * n);
    assert_non_null(rgb);
    assert_int_equal(cn_render_view(&t.model, &cam, ds.ndc, rgb, 1024), 0);
    const double want = cn_psnr_from_mse(cn_mse(rgb, w->rgb, 3 * n));
    const double got = cn_val_psnr(&t.model, &all);
    print_message("# whole view %.6f dB, rays %.6f dB\n", want, got);
    assert_true(fabs(got - want) < 1e-6);
    assert_true(isnan(cn_val_psnr(&t.model, &empty)));
    free(rgb);
    cn_val_rays_free(&all);
    cn_trainer_free(&t);
    cn_dataset_free(&ds);
}

/* The flat colour: its PSNR is the mean squared error of one colour painted on every ray;
 * the rays' own mean scores best; the trainer's is the training rays' mean on the
 * validation rays; the fog verdict waits for CN_VAL_FOG_ITERS and is CN_VAL_FOG_DB wide. */
static void test_flat_colour_and_fog(void **state)
{
    (void)state;
    float gt[4 * 3] = {0, 0, 0, 1, 1, 1, 0.5f, 0.25f, 0, 0.5f, 0.75f, 1};
    cn_val_rays v = {4, NULL, NULL, NULL, gt};
    float mean[3];
    assert_int_equal(cn_val_mean_color(&v, mean), 0);
    assert_float_equal(mean[0], 0.5, 1e-7);
    assert_float_equal(mean[1], 0.5, 1e-7);
    assert_float_equal(mean[2], 0.5, 1e-7);
    /* squared errors from 0.5: 3 x 0.25, 3 x 0.25, 0 + 1/16 + 1/4, 0 + 1/16 + 1/4 */
    const double mse = (0.75 + 0.75 + 0.3125 + 0.3125) / 12;
    assert_float_equal(cn_val_flat_psnr(&v, mean), -10 * log10(mse), 1e-9);
    const float off[3] = {0.6f, 0.5f, 0.5f};
    assert_true(cn_val_flat_psnr(&v, off) < cn_val_flat_psnr(&v, mean));
    cn_val_rays empty = {0, NULL, NULL, NULL, NULL};
    assert_int_equal(cn_val_mean_color(&empty, mean), -1);
    assert_true(isnan(cn_val_flat_psnr(&empty, mean)));

    cn_dataset ds;
    load(CNERF_DATA_DIR "/lego", &ds);
    cn_trainer t;
    tiny_trainer(&t, &ds);
    assert_int_equal(cn_val_mean_color(&t.fit_rays, mean), 0);
    assert_float_equal(t.flat_psnr, cn_val_flat_psnr(&t.val_rays, mean), 1e-12);
    assert_true(t.flat_psnr > 5 && t.flat_psnr < 30);
    t.step = t.val_step = CN_VAL_FOG_ITERS;
    t.val_psnr = t.flat_psnr + CN_VAL_FOG_DB - 0.01;
    assert_int_equal(cn_trainer_fog(&t), 1);
    t.val_psnr = t.flat_psnr + CN_VAL_FOG_DB + 0.01;
    assert_int_equal(cn_trainer_fog(&t), 0);
    t.val_psnr = t.flat_psnr;
    t.step = t.val_step = CN_VAL_FOG_ITERS - 1; /* too short a run to tell */
    assert_int_equal(cn_trainer_fog(&t), 0);
    t.step = CN_VAL_FOG_ITERS + 1; /* the measurement is not the current model's */
    assert_int_equal(cn_trainer_fog(&t), 0);
    t.step = 0;
    cn_trainer_free(&t);
    cn_dataset_free(&ds);
}

/* Validating every iteration changes no bit of the training, float or compressed (its float
 * phase's length given: by default a validation may end it, test_float_phase_end), and
 * leaves the last measurement in the trainer. */
static void test_validation_leaves_training_alone(void **state)
{
    (void)state;
    cn_dataset ds;
    load(CNERF_DATA_DIR "/fern", &ds);
    char err[256];
    assert_int_equal(cn_dataset_hold_out(&ds, -1, err, sizeof err), 1);
    for (int compress = 0; compress < 2; compress++) {
        cn_trainer t[2];
        for (int k = 0; k < 2; k++) {
            cn_train_opts o;
            cn_train_defaults(&o);
            o.preset = "tiny";
            o.batch = 128;
            o.n_coarse = o.n_fine = 8;
            o.iters = 6;
            o.compress = compress;
            o.lambda = compress ? 1 : 0;
            o.float_iters = compress ? 2 : 0;
            o.val_every = k ? 1 : 0;
            assert_int_equal(cn_trainer_init(&t[k], &ds, &o, err, sizeof err), 0);
            for (int i = 0; i < 6; i++)
                assert_false(isnan(cn_trainer_step(&t[k], NULL, NULL)));
        }
        assert_memory_equal(t[0].model.params, t[1].model.params,
                            sizeof(float) * t[0].model.n_params);
        assert_true(isnan(t[0].val_psnr));
        assert_false(isnan(t[1].val_psnr));
        assert_int_equal(t[1].val_step, 5); /* measured before the sixth step */
        assert_int_equal(cn_trainer_validate(&t[1]), 0);
        assert_int_equal(t[1].val_step, 6);
        assert_true(t[1].val_psnr > 3 && t[1].val_psnr < 60);
        assert_true(t[1].fit_psnr > 3 && t[1].fit_psnr < 60);
        cn_trainer_free(&t[0]);
        cn_trainer_free(&t[1]);
    }
    cn_dataset_free(&ds);
}

/* The default float phase ends at the first validation that finds the model out of the fog,
 * and lasts its whole share when none does, when there is no validation, or when its length
 * was given. The flat colour is moved so that every model is out of the fog, or none. */
static void test_float_phase_end(void **state)
{
    (void)state;
    cn_dataset ds;
    load(CNERF_DATA_DIR "/fern", &ds);
    char err[256];
    assert_int_equal(cn_dataset_hold_out(&ds, -1, err, sizeof err), 1);
    const struct {
        double flat;      /* the flat colour's PSNR, as the trainer is told */
        long val_every, asked, want; /* want: the first rounded iteration */
    } cases[] = {{-1e9, 2, -1, 2}, {1e9, 2, -1, 10}, {-1e9, 0, -1, 10}, {-1e9, 2, 7, 7},
                 {-1e9, 4, -1, 4}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        cn_train_opts o;
        cn_train_defaults(&o);
        o.preset = "tiny";
        o.batch = 128;
        o.n_coarse = o.n_fine = 8;
        o.iters = 40; /* the share: 10 */
        o.compress = 1;
        o.lambda = 1;
        o.float_iters = cases[c].asked;
        o.val_every = cases[c].val_every;
        cn_trainer t;
        assert_int_equal(cn_trainer_init(&t, &ds, &o, err, sizeof err), 0);
        assert_int_equal(t.opts.float_iters, cases[c].asked < 0 ? 10 : cases[c].asked);
        t.flat_psnr = cases[c].flat;
        for (long i = 0; i < 12; i++) {
            assert_false(isnan(cn_trainer_step(&t, NULL, NULL)));
            /* the step just taken was unrounded when it came before the phase's end */
            if (t.model.unrounded != (t.step - 1 < cases[c].want))
                fail_msg("case %zu, iteration %ld: unrounded %d, the phase ends at %ld", c,
                         t.step, t.model.unrounded, cases[c].want);
        }
        assert_int_equal(t.opts.float_iters, cases[c].want);
        cn_trainer_free(&t);
    }
    cn_dataset_free(&ds);
}

/* Under rate control a validation PSNR CN_VAL_COLLAPSE_DB below the run's best stops the
 * run with a message that names the preset, the fall and what to try; a smaller fall does
 * not, and neither does any fall without rate control. */
static void test_collapse_stops_rate_control(void **state)
{
    (void)state;
    cn_dataset ds;
    load(CNERF_DATA_DIR "/fern", &ds);
    char err[256];
    assert_int_equal(cn_dataset_hold_out(&ds, -1, err, sizeof err), 1);
    for (int controlled = 0; controlled < 2; controlled++) {
        cn_train_opts o;
        cn_train_defaults(&o);
        o.preset = "small";
        o.batch = 64;
        o.n_coarse = o.n_fine = 8;
        o.iters = 40;
        o.compress = 1;
        o.lambda = 1;
        o.val_every = 2;
        cn_trainer t;
        assert_int_equal(cn_trainer_init(&t, &ds, &o, err, sizeof err), 0);
        if (controlled)
            cn_trainer_rate_control(&t, 20000, 0, CN_RC_DUAL, 0, 0);
        for (int i = 0; i < 3; i++)
            assert_false(isnan(cn_trainer_step(&t, NULL, NULL)));
        assert_int_equal(t.val_best_step, 2);
        /* A best that the model has since fallen from by a little: the run goes on. */
        t.val_best = t.val_psnr + CN_VAL_COLLAPSE_DB - 0.5;
        assert_false(isnan(cn_trainer_step(&t, NULL, NULL)));
        assert_false(t.collapsed);
        /* By more than the margin. */
        t.val_best = t.val_psnr + CN_VAL_COLLAPSE_DB + 3;
        const double loss = cn_trainer_step(&t, NULL, NULL);
        if (!controlled) {
            assert_false(isnan(loss));
            assert_false(t.collapsed);
        } else {
            assert_true(isnan(loss));
            assert_true(t.collapsed);
            print_message("# %s\n", t.err);
            assert_non_null(strstr(t.err, "20000 bytes is too small for this scene at preset "
                                          "small: validation PSNR fell from"));
            assert_non_null(strstr(t.err, "try --preset tiny or --size "));
            assert_non_null(strstr(t.err, " or more (its size at its best)"));
        }
        cn_trainer_free(&t);
    }
    cn_dataset_free(&ds);
}

/* --preset auto's race: nothing is decided before CN_RACE_FIRST of the run; from there a
 * mean lead beyond the margin decides; at CN_RACE_LAST the leader wins, tiny on a tie; the
 * mean is over the last CN_RACE_MEAN validations; no validation (NaN) ends with tiny. Here
 * small is at its size throughout (the last argument). */
static void test_race_rule(void **state)
{
    (void)state;
    cn_race r;
    memset(&r, 0, sizeof r);
    /* small far behind, but early: go on; from 15% it ends with tiny */
    assert_int_equal(cn_race_step(&r, 100, 2000, 20, 15, 1), -1);
    assert_int_equal(cn_race_step(&r, 200, 2000, 20, 15, 1), -1);
    assert_int_equal(cn_race_step(&r, 500, 2000, 20, 15, 1), 0);
    /* small ahead by more than the margin from 25% on */
    cn_race a;
    memset(&a, 0, sizeof a);
    assert_int_equal(cn_race_step(&a, 200, 2000, 20, 20 + CN_RACE_MARGIN_DB + 0.2, 1), -1);
    assert_int_equal(cn_race_step(&a, 300, 2000, 20, 20 + CN_RACE_MARGIN_DB + 0.2, 1), 1);
    /* close: on until 50%, then the leader; the mean is over the last three */
    cn_race c;
    memset(&c, 0, sizeof c);
    const double lead[] = {0.9, -0.9, 0.3, 0.2, -0.4, 0.3, 0.2, 0.1, 0.4, -0.2};
    int w = -1;
    long step = 0;
    for (int i = 0; i < 10 && w < 0; i++) {
        step = 100 * (i + 1);
        w = cn_race_step(&c, step, 2000, 20, 20 + lead[i], 1);
    }
    assert_int_equal(step, 1000);
    assert_int_equal(w, 1); /* (0.1 + 0.4 - 0.2) / 3 > 0 */
    assert_true(fabs(c.mean - 0.1) < 1e-12);
    cn_race d;
    memset(&d, 0, sizeof d);
    for (int i = 1; i < 10; i++)
        assert_int_equal(cn_race_step(&d, 100 * i, 2000, 20, 20, 1), -1);
    assert_int_equal(cn_race_step(&d, 1000, 2000, 20, 20, 1), 0); /* a tie: tiny */
    cn_race n;
    memset(&n, 0, sizeof n);
    assert_int_equal(cn_race_step(&n, 900, 2000, NAN, NAN, 1), -1);
    assert_int_equal(cn_race_step(&n, 1000, 2000, NAN, NAN, 1), 0);
    /* a validation not made yet is not counted: the mean is of those made */
    cn_race m;
    memset(&m, 0, sizeof m);
    assert_int_equal(cn_race_step(&m, 100, 2000, NAN, 20, 1), -1);
    assert_int_equal(cn_race_step(&m, 200, 2000, 20, 21.5, 1), -1);
    assert_int_equal(cn_race_step(&m, 300, 2000, 20, 21.3, 1), 1);
    assert_int_equal(m.n, 2);
    assert_true(fabs(m.mean - 1.4) < 1e-12);
}

/* A lead of small's counts only where small was at its size at each validation of the mean:
 * early, a lead beyond the margin bought with bytes goes on; at CN_RACE_LAST a lead away
 * from the size waits for it, and then the leader over validations at the size wins, either
 * preset. Tiny's lead counts at any size. (The chair of the scene suite: small 1.2 dB ahead
 * at twice its size, behind once at it.) */
static void test_race_waits_for_size(void **state)
{
    (void)state;
    cn_race r;
    memset(&r, 0, sizeof r);
    for (long s = 100; s < 1000; s += 100) /* far ahead, not at its size */
        assert_int_equal(cn_race_step(&r, s, 2000, 20, 21.5, 0), -1);
    assert_int_equal(cn_race_step(&r, 1000, 2000, 20, 20.5, 0), -1); /* half: the leader waits */
    assert_true(r.waiting);
    assert_int_equal(cn_race_step(&r, 1100, 2000, 20, 20.3, 1), -1); /* one at size of three */
    assert_int_equal(cn_race_step(&r, 1200, 2000, 20, 19.9, 1), -1);
    assert_int_equal(cn_race_step(&r, 1300, 2000, 20, 19.6, 0), -1); /* above it again */
    assert_int_equal(cn_race_step(&r, 1400, 2000, 20, 19.5, 1), -1);
    assert_int_equal(cn_race_step(&r, 1500, 2000, 20, 19.4, 1), -1);
    assert_int_equal(cn_race_step(&r, 1600, 2000, 20, 19.5, 1), 0); /* three at size: tiny */
    assert_true(fabs(r.mean + 0.5333333333333333) < 1e-9);
    /* the same wait, with small still ahead at its size */
    cn_race s;
    memset(&s, 0, sizeof s);
    for (long k = 100; k <= 1000; k += 100)
        assert_int_equal(cn_race_step(&s, k, 2000, 20, 20.4, 0), -1);
    assert_int_equal(cn_race_step(&s, 1100, 2000, 20, 20.2, 1), -1);
    assert_int_equal(cn_race_step(&s, 1200, 2000, 20, 20.2, 1), -1);
    assert_int_equal(cn_race_step(&s, 1300, 2000, 20, 20.2, 1), 1);
    /* small not at its size does not stop tiny's lead, early or at half the run */
    cn_race t;
    memset(&t, 0, sizeof t);
    assert_int_equal(cn_race_step(&t, 300, 2000, 22, 20, 0), 0);
    cn_race u;
    memset(&u, 0, sizeof u);
    for (long k = 100; k < 1000; k += 100)
        assert_int_equal(cn_race_step(&u, k, 2000, 20.3, 20, 0), -1);
    assert_int_equal(cn_race_step(&u, 1000, 2000, 20.3, 20, 0), 0);
    /* a missed validation while waiting decides nothing */
    cn_race v;
    memset(&v, 0, sizeof v);
    for (long k = 100; k <= 1000; k += 100)
        assert_int_equal(cn_race_step(&v, k, 2000, 20, 20.4, 0), -1);
    assert_int_equal(cn_race_step(&v, 1100, 2000, NAN, NAN, 1), -1);
    assert_int_equal(v.n, 10);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_rule),
        cmocka_unit_test(test_hold_out_fern),
        cmocka_unit_test(test_hold_out_blender),
        cmocka_unit_test(test_rays_and_psnr),
        cmocka_unit_test(test_flat_colour_and_fog),
        cmocka_unit_test(test_validation_leaves_training_alone),
        cmocka_unit_test(test_float_phase_end),
        cmocka_unit_test(test_collapse_stops_rate_control),
        cmocka_unit_test(test_race_rule),
        cmocka_unit_test(test_race_waits_for_size),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
