/* The training loop, Adam, checkpoints and full-view rendering. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_stream.h"
#include "cn_file.h"
#include "cn_prior.h"
#include "cn_preset.h"
#include "cn_train.h"
#include "cn_ckpt.h"

void cn_train_defaults(cn_train_opts *o)
{
    memset(o, 0, sizeof *o);
    o->preset = "small";
    o->depth = o->width = o->view_width = o->n_coarse = o->n_fine = -1;
    o->iters = 1000;
    o->batch = 1024;
    /* Ten times NeRF's 5e-4, decaying tenfold over the run rather than over 500,000 steps
     * (docs/training.md: on Lego at 100x100 tiny reaches 25 dB in about a third of the time). */
    o->lr = 5e-3;
    o->lr_decay_steps = 0;
    o->lr_warmup = -1;
    o->precrop_iters = -1;
    o->precrop_frac = 0.5;
    o->occ_grid = 32;
    o->occ_start = 100;
    o->occ_every = 16;
    o->seed = 1;
    o->compress = 0;
    o->lambda = 0;
    o->quality_slope = 0;
    o->average = 0;
    o->levels = 8;
    o->latent_lr_weight_units = 1;
    /* The paper's 5e-5 leaves the priors where they started over a few thousand iterations:
     * their rate estimate was 28% above the coded payload (docs/results.md). */
    o->lr_prior = 5e-3;
    o->lr_affine = 5e-4;
    o->lr_scale = 1e-3;
    o->random_bg = -1;
    o->coarse_color = 1;
    o->coarse_weight = 1;
    o->val_every = 100;
    o->float_iters = -1;
}

static int32_t q16(double v) { return (int32_t)lround(v * 65536.0); }

int cn_header_for_dataset(const cn_dataset *ds, const cn_train_opts *o, cnerf_info *hdr,
                          char *err, size_t errlen)
{
    if (cn_preset_header(o->preset, hdr)) {
        snprintf(err, errlen, "unknown preset '%s' (tiny, small, paper)", o->preset);
        return -1;
    }
    for (unsigned n = 0; n < CNERF_MAX_NETS; n++) {
        cnerf_net_info *N = &hdr->net[n];
        if (o->depth > 0) {
            N->depth = (uint8_t)o->depth;
            N->skip = o->depth >= 3 ? (uint8_t)(o->depth / 2) : CNERF_NO_SKIP;
            if (N->skip != CNERF_NO_SKIP && N->skip + 1 >= o->depth)
                N->skip = (uint8_t)(o->depth - 2);
        }
        if (o->width > 0)
            N->width = (uint16_t)o->width;
        if (o->view_width >= 0)
            N->view_width = (uint16_t)o->view_width;
    }
    if (o->n_coarse > 0)
        hdr->n_coarse = (uint16_t)o->n_coarse;
    if (o->n_fine >= 0)
        hdr->n_fine = (uint16_t)o->n_fine;
    hdr->n_nets = hdr->n_fine ? 2 : 1;
    for (int c = 0; c < 3; c++)
        hdr->background[c] = (uint8_t)lround(ds->bg[c] * 255.0);
    if (ds->ndc && o->contract) {
        snprintf(err, errlen, "a forward-facing scene is rendered in NDC, which reaches to "
                 "infinity already: --background contract is for 360-degree scenes");
        return -1;
    }
    if (ds->ndc) {
        /* Rays live in [-1, 1]^3 after the NDC warp; the bounds clip nothing visible. */
        hdr->coord = CNERF_COORD_NDC;
        hdr->near_q16 = 0;
        hdr->far_q16 = CNERF_Q16_ONE;
        for (int a = 0; a < 3; a++) {
            hdr->aabb_q16[a] = -2 * CNERF_Q16_ONE;
            hdr->aabb_q16[a + 3] = 2 * CNERF_Q16_ONE;
        }
    } else if (o->contract) {
        /* The inner box is where the cameras look: 3/8 of their mean distance from the
         * origin (1.5 for Blender's scenes at 4); the linear segment of the rays crosses it
         * from the nearest bound (docs/rendering.md). */
        double r = 0;
        for (int i = 0; i < ds->n_train; i++) {
            const double *c = &ds->train[i].c2w[0][3];
            r += sqrt(c[0] * c[0] + c[4] * c[4] + c[8] * c[8]) / ds->n_train;
        }
        const double half = 0.375 * r;
        hdr->coord = CNERF_COORD_CONTRACT;
        hdr->near_q16 = q16(fmin(ds->near, r));
        hdr->far_q16 = q16(r + sqrt(3.0) * half);
        for (int a = 0; a < 3; a++) {
            hdr->aabb_q16[a] = -q16(2 * half);
            hdr->aabb_q16[a + 3] = q16(2 * half);
        }
    } else {
        hdr->coord = CNERF_COORD_WORLD;
        hdr->near_q16 = q16(ds->near);
        hdr->far_q16 = q16(ds->far);
        /* Scene bounds: a cube of half-size 1.5 (Blender scenes fit in it), grown to reach
         * the far bound for other layouts, but never beyond the largest Q16.16 value. */
        double half = ds->kind == CN_DS_BLENDER ? 1.5 : fmin(ds->far, 30000.0);
        for (int a = 0; a < 3; a++) {
            hdr->aabb_q16[a] = -q16(half);
            hdr->aabb_q16[a + 3] = q16(half);
        }
    }
    cnerf_info check = *hdr;
    cnerf_status st = cnerf_expand_topology(&check);
    if (st != CNERF_OK || hdr->near_q16 < 0 || hdr->far_q16 <= hdr->near_q16) {
        snprintf(err, errlen, "invalid model for this dataset (%s; near %g, far %g)",
                 cnerf_status_str(st), ds->near, ds->far);
        return -1;
    }
    return 0;
}

/* cn_trainer_share_all's share (NULL: none). */
static const cn_share *process_share;

void cn_trainer_share_all(const cn_share *share) { process_share = share; }

int cn_trainer_init(cn_trainer *t, const cn_dataset *ds, const cn_train_opts *o, char *err,
                    size_t errlen)
{
    memset(t, 0, sizeof *t);
    t->ds = ds;
    t->opts = *o;
    t->float_asked = o->float_iters;
    if (o->float_iters < 0)
        t->opts.float_iters = o->compress ? (long)((double)o->iters * CN_FLOAT_SHARE) : 0;
    if (ds->n_train < 1) {
        snprintf(err, errlen, "no training views");
        return -1;
    }
    if (o->batch < 1 || o->iters < 0 || o->average < 0) {
        snprintf(err, errlen, "batch must be >= 1, iterations and averaged iterations >= 0");
        return -1;
    }
    if (o->average > 0 && !o->compress) {
        snprintf(err, errlen, "averaging the parameters is for compressed models");
        return -1;
    }
    cnerf_info hdr;
    if (cn_header_for_dataset(ds, o, &hdr, err, errlen))
        return -1;
    if (o->compress ? cn_model_init_compressed(&t->model, &hdr, o->seed, o->levels, err, errlen)
                    : cn_model_init(&t->model, &hdr, o->seed, err, errlen))
        return -1;
    cn_train_drop_color(&t->model, o);
    if (o->average > 0) {
        t->avg = calloc(t->model.n_params, sizeof *t->avg);
        t->avg_keep = malloc(sizeof *t->avg_keep * t->model.n_params);
        if (!t->avg || !t->avg_keep) {
            cn_trainer_free(t);
            snprintf(err, errlen, "out of memory for the mean of the parameters");
            return -1;
        }
    }
    const size_t R = (size_t)o->batch;
    t->gt = malloc(sizeof(float) * R * 3);
    t->dcolor[0] = malloc(sizeof(float) * R * 3);
    t->dcolor[1] = malloc(sizeof(float) * R * 3);
    if (!t->gt || !t->dcolor[0] || !t->dcolor[1] ||
        cn_batch_init(&t->batch, &t->model.topo, R)) {
        cn_trainer_free(t);
        snprintf(err, errlen, "out of memory for a batch of %zu rays", R);
        return -1;
    }
    int clear = 0;
    for (int i = 0; i < ds->n_train; i++)
        clear |= ds->train[i].alpha != NULL;
    t->opts.random_bg = o->random_bg < 0 ? clear : o->random_bg != 0;
    /* The centre crop keeps an object on a transparent background from collapsing onto the
     * empty background early on (NeRF's Blender scenes); on views that the picture fills it
     * traps larger networks in a degenerate solution (docs/training.md, "The centre crop"). */
    if (o->precrop_iters < 0)
        t->opts.precrop_iters = clear && !ds->ndc ? CN_PRECROP_ITERS : 0;
    if (t->opts.random_bg) {
        t->bg = malloc(sizeof(float) * R * 3);
        if (!t->bg) {
            cn_trainer_free(t);
            snprintf(err, errlen, "out of memory for a batch of %zu rays", R);
            return -1;
        }
        t->batch.bg = t->bg;
    }
    t->val_psnr = t->fit_psnr = t->flat_psnr = NAN;
    if (ds->n_val > 0 &&
        (cn_val_rays_init(&t->val_rays, ds->val, ds->n_val, ds->ndc, CN_VAL_RAYS, o->seed) ||
         cn_val_rays_init(&t->fit_rays, ds->train, ds->n_train, ds->ndc, CN_VAL_RAYS,
                          o->seed + 1))) {
        cn_trainer_free(t);
        snprintf(err, errlen, "out of memory for the validation rays");
        return -1;
    }
    float flat[3];
    if (cn_val_mean_color(&t->fit_rays, flat) == 0)
        t->flat_psnr = cn_val_flat_psnr(&t->val_rays, flat);
    for (unsigned n = 0; n < t->model.topo.n_nets && o->occ_grid > 0; n++)
        if (cn_occ_init(&t->occ[n], &t->model.topo, o->occ_grid)) {
            cn_trainer_free(t);
            snprintf(err, errlen, "occupancy grid of %d cells per axis: out of range (1..256) "
                     "or out of memory", o->occ_grid);
            return -1;
        }
    cn_trainer_share(t, process_share);
    return 0;
}

void cn_trainer_free(cn_trainer *t)
{
    cn_model_free(&t->model);
    if (t->batch.cap)
        cn_batch_free(&t->batch);
    free(t->gt);
    free(t->dcolor[0]);
    free(t->dcolor[1]);
    free(t->bg);
    free(t->avg);
    free(t->avg_keep);
    cn_val_rays_free(&t->val_rays);
    cn_val_rays_free(&t->fit_rays);
    t->avg = NULL;
    t->avg_keep = NULL;
    t->gt = t->dcolor[0] = t->dcolor[1] = t->bg = NULL;
    for (int n = 0; n < 2; n++)
        if (t->occ[n].g)
            cn_occ_free(&t->occ[n]);
}

long cn_trainer_warmup(const cn_trainer *t)
{
    if (t->opts.lr_warmup >= 0)
        return t->opts.lr_warmup;
    /* a float model, or a float phase of a preset that warms up */
    if (t->opts.compress &&
        (t->opts.float_iters <= 0 || cn_preset_float_warmup(t->opts.preset) != 1))
        return 0;
    return t->opts.iters / 10 < CN_LR_WARMUP ? t->opts.iters / 10 : CN_LR_WARMUP;
}

double cn_trainer_lr(const cn_trainer *t)
{
    const double span = t->opts.lr_decay_steps > 0 ? t->opts.lr_decay_steps
                        : t->opts.iters > 0 ? (double)t->opts.iters : 1.0;
    const long warmup = cn_trainer_warmup(t);
    const double warm = warmup > 0 && t->step < warmup
                            ? (double)(t->step + 1) / (double)warmup : 1.0;
    return t->opts.lr * warm * pow(0.1, (double)t->step / span);
}

void cn_view_camera(const cn_view *v, cn_camera *cam)
{
    memcpy(cam->c2w, v->c2w, sizeof cam->c2w);
    cam->fx = v->fx;
    cam->fy = v->fy;
    cam->cx = v->cx;
    cam->cy = v->cy;
    cam->w = v->w;
    cam->h = v->h;
}

/* Draws the batch's R rays and keeps rays [r0, r1) with their ground truth (all of them in
 * one process; a rank's share of them when a share splits the batch). */
static void draw_rays(cn_trainer *t, size_t R, size_t r0, size_t r1)
{
    const cn_dataset *ds = t->ds;
    cn_rng rng = cn_rng_seed(t->opts.seed * 0x2545F4914F6CDD1Dull + (uint64_t)t->step);
    cn_rng bgr = cn_rng_seed(t->opts.seed * 0x9E3779B97F4A7C15ull + 0xB6ull + (uint64_t)t->step);
    const int crop = t->step < t->opts.precrop_iters && !ds->ndc;
    for (size_t r = 0; r < R; r++) {
        const cn_view *v = &ds->train[cn_rng_below(&rng, (uint32_t)ds->n_train)];
        int x0 = 0, y0 = 0, cw = v->w, ch = v->h;
        if (crop) {
            cw = (int)(v->w * t->opts.precrop_frac);
            ch = (int)(v->h * t->opts.precrop_frac);
            cw = cw < 1 ? 1 : cw;
            ch = ch < 1 ? 1 : ch;
            x0 = (v->w - cw) / 2;
            y0 = (v->h - ch) / 2;
        }
        int x = x0 + (int)cn_rng_below(&rng, (uint32_t)cw);
        int y = y0 + (int)cn_rng_below(&rng, (uint32_t)ch);
        const size_t px = (size_t)y * v->w + x;
        float bg[3] = {0, 0, 0};
        if (t->bg) /* its own stream, so that the rays drawn do not depend on the option */
            for (int c = 0; c < 3; c++)
                bg[c] = v->alpha ? (float)cn_rng_uniform(&bgr) : ds->bg[c];
        if (r < r0 || r >= r1)
            continue;
        const size_t k = r - r0;
        cn_camera cam;
        cn_view_camera(v, &cam);
        cn_camera_ray(&cam, ds->ndc, x, y, t->batch.o + 3 * k, t->batch.d + 3 * k,
                      t->batch.vd + 3 * k);
        memcpy(t->gt + 3 * k, v->rgb + px * 3, sizeof(float) * 3);
        if (t->bg) {
            /* Recomposite over a random background: the stored pixel is a c + (1 - a) bg0,
             * so a c + (1 - a) bg = pixel + (1 - a)(bg - bg0). Opaque views keep bg0. */
            const float a = v->alpha ? v->alpha[px] : 1.0f;
            for (int c = 0; c < 3; c++) {
                t->bg[3 * k + c] = bg[c];
                t->gt[3 * k + c] += (1.0f - a) * (bg[c] - ds->bg[c]);
            }
        }
    }
}

void cn_trainer_share(cn_trainer *t, const cn_share *share)
{
    t->share = share && share->size > 1 ? share : NULL;
    t->batch.share = t->share;
}

/* This process's rays of a batch of R: the chunks [c0, c1) of its rank, as rays [r0, r1). */
static void my_rays(const cn_trainer *t, size_t R, size_t *r0, size_t *r1)
{
    if (!t->share) {
        *r0 = 0;
        *r1 = R;
        return;
    }
    const size_t n = (R + CN_CHUNK_RAYS - 1) / CN_CHUNK_RAYS, size = (size_t)t->share->size;
    const size_t k = (size_t)t->share->rank, c0 = n * k / size, c1 = n * (k + 1) / size;
    *r0 = c0 * CN_CHUNK_RAYS < R ? c0 * CN_CHUNK_RAYS : R;
    *r1 = c1 * CN_CHUNK_RAYS < R ? c1 * CN_CHUNK_RAYS : R;
}

/* Adam over params[lo, hi) at learning rate lr; zeroes the gradients. */
void cn_adam_range(cn_model *m, size_t lo, size_t hi, double lr, long step)
{
    const float b1 = 0.9f, b2 = 0.999f;
    const float eps = getenv("CN_EXP_EPS") ? (float)atof(getenv("CN_EXP_EPS")) : 1e-7f;
    const float c1 = (float)(1.0 - pow(b1, (double)step)), c2 = (float)(1.0 - pow(b2, (double)step));
    const float a = (float)lr * sqrtf(c2) / c1;
    float *p = m->params, *g = m->grads, *mm = m->adam_m, *vv = m->adam_v;
#pragma omp parallel for schedule(static)
    for (size_t i = lo; i < hi; i++) {
        mm[i] = b1 * mm[i] + (1 - b1) * g[i];
        vv[i] = b2 * vv[i] + (1 - b2) * g[i] * g[i];
        p[i] -= a * mm[i] / (sqrtf(vv[i]) + eps);
        g[i] = 0;
    }
}

double cn_trainer_pixels(const cn_trainer *t)
{
    double n = 0;
    for (int i = 0; i < t->ds->n_train; i++)
        n += (double)t->ds->train[i].w * t->ds->train[i].h;
    return n;
}

/* Network n's occupancy grid estimated afresh from the current (materialized) model. */
static void estimate_occupancy(cn_trainer *t, unsigned n)
{
    cn_rng rng = cn_rng_seed(t->opts.seed * 0x9E3779B97F4A7C15ull + (uint64_t)t->step * 2 + n);
    t->occ_frac[n] = cn_occ_update(&t->occ[n], &t->model, n, &t->batch.nb[n], &rng, 0.95f,
                                   cn_occ_threshold(&t->model.topo));
}

/* From occ_start on (or earlier once a grid has an estimate, as a run from a trained model's
 * has from its start), every occ_every iterations (and on the first step after a resume),
 * re-estimates each network's grid with the current model and lets the batch use it. */
static void update_occupancy(cn_trainer *t)
{
    const cn_train_opts *o = &t->opts;
    if (t->step < o->occ_start && !t->occ[0].valid)
        return;
    t->batch.sat_eps = (float)o->sat_eps;
    if (o->occ_grid <= 0)
        return;
    const long every = o->occ_every > 0 ? o->occ_every : 1;
    for (unsigned n = 0; n < t->model.topo.n_nets; n++) {
        if (!t->occ[n].valid || (t->step - o->occ_start) % every == 0)
            estimate_occupancy(t, n);
        t->batch.occ[n] = &t->occ[n];
    }
}

/* cn_sq_error's sum, exact (cn_xsum.h). */
static cn_xsum sq_error(float *grad, const float *x, const float *y, size_t n, float gscale)
{
    cn_xsum se = 0;
    for (size_t i = 0; i < n; i++) {
        const float d = x[i] - y[i];
        se = cn_xsum_plus(se, cn_xsum_of((double)d * d));
        grad[i] = gscale * d;
    }
    return se;
}

double cn_sq_error(float *grad, const float *x, const float *y, size_t n, float gscale)
{
    return cn_xsum_value(sq_error(grad, x, y, n, gscale));
}

void cn_train_drop_color(cn_model *m, const cn_train_opts *o)
{
    m->drop_color[0] = o->compress && !o->coarse_color && m->topo.n_nets > 1;
}

double cn_trainer_lambda_unit(const cn_trainer *t)
{
    return 3 * cn_trainer_pixels(t) / (double)cn_model_sent_latents(&t->model);
}

double cn_quality_slope(double q)
{
    return pow(2.0, (50.0 - q) / 10.0);
}

double cn_quality_from_slope(double k)
{
    return 50.0 - 10.0 * log2(k);
}

/* The objective 10 log10(D) + k R / latents has the gradient of D + lambda R with
 * lambda = k ln(10)/10 D / latents, and D = 3 pixels x the summed MSE. */
double cn_quality_lambda(const cn_trainer *t, double k, double mse_sum)
{
    return k * log(10.0) / 10.0 * mse_sum * 3.0 * cn_trainer_pixels(t) /
           (double)cn_model_sent_latents(&t->model);
}

/* opts.average: the mean of the parameters becomes the model, with its kernels. */
static void put_mean(cn_trainer *t)
{
    cn_model *m = &t->model;
    for (size_t i = 0; i < m->n_params; i++)
        m->params[i] = (float)t->avg[i];
    cn_model_materialize(m);
}

void cn_trainer_swap_mean(cn_trainer *t, int in)
{
    cn_model *m = &t->model;
    if (in) {
        memcpy(t->avg_keep, m->params, sizeof(float) * m->n_params);
        put_mean(t);
    } else {
        memcpy(m->params, t->avg_keep, sizeof(float) * m->n_params);
        cn_model_materialize(m);
    }
}

/* After an iteration: adds the parameters to their mean within the last opts.average
 * iterations, and at the last iteration leaves the mean as the model. */
static void average_step(cn_trainer *t)
{
    cn_model *m = &t->model;
    if (!t->avg || t->step <= t->opts.iters - t->opts.average || t->step > t->opts.iters)
        return;
    t->avg_n++;
    const double w = 1.0 / (double)t->avg_n;
    for (size_t i = 0; i < m->n_params; i++)
        t->avg[i] += ((double)m->params[i] - t->avg[i]) * w;
    if (t->step == t->opts.iters)
        put_mean(t);
}

/* Under rate control: the validation PSNR fell CN_VAL_COLLAPSE_DB below its best. */
static int collapse_check(cn_trainer *t)
{
    if (!t->rate_control || t->val_best - t->val_psnr <= CN_VAL_COLLAPSE_DB ||
        (t->from_float && t->fit_psnr - t->val_psnr <= CN_VAL_GAP_DB))
        return 0;
    t->collapsed = 1;
    char larger[96] = "a larger --size";
    if (t->val_best_size > t->rc.target)
        snprintf(larger, sizeof larger, "--size %.0f or more (its size at its best)",
                 t->val_best_size);
    snprintf(t->err, sizeof t->err, "%.0f bytes is too small for this scene at preset %s: "
             "validation PSNR fell from %.2f dB (iteration %ld) to %.2f dB (iteration %ld) as "
             "the rate penalty rose; try %s%s", t->rc.target, t->opts.preset, t->val_best,
             t->val_best_step, t->val_psnr, t->val_step,
             strcmp(t->opts.preset, "tiny") ? "--preset tiny or " : "", larger);
    return -1;
}

/* The default float phase ends at the first validation that finds the model out of the fog
 * (its validation PSNR CN_VAL_FOG_DB above a flat colour's, cn_trainer_fog's yardstick): the
 * network has found the scene, and the rest of the run trains the integers the file holds.
 * At most the share it started with (no validation views: all of it). */
static void float_phase_check(cn_trainer *t)
{
    if (t->model.compressed && t->float_asked < 0 && t->step < t->opts.float_iters &&
        t->val_step == t->step && t->val_psnr >= t->flat_psnr + CN_VAL_FOG_DB) {
        t->opts.float_iters = t->step;
        t->float_left_fog = 1;
    }
}

double cn_trainer_step(cn_trainer *t, double *mse_last, double *bits)
{
    const size_t R = (size_t)t->opts.batch;
    const unsigned nets = t->model.topo.n_nets;
    cn_model *m = &t->model;
    if (t->opts.val_every > 0 && t->step > 0 && t->step % t->opts.val_every == 0 &&
        t->val_step != t->step) {
        if (cn_trainer_validate(t)) {
            snprintf(t->err, sizeof t->err, "out of memory for validation");
            return NAN;
        }
        if (collapse_check(t))
            return NAN;
        float_phase_check(t);
    }
    size_t r0, r1;
    my_rays(t, R, &r0, &r1);
    const size_t Rl = r1 - r0; /* this process's rays */
    t->batch.ray0 = r0;
    draw_rays(t, R, r0, r1);
    const uint64_t seed = t->opts.seed + 0x9E3779B97F4A7C15ull * (uint64_t)(t->step + 1);
    m->unrounded = m->compressed && t->step < t->opts.float_iters;
    cn_model_materialize(m);
    if (t->step_hook && t->step_hook(t))
        return NAN;
    m->group = (float)(t->opts.group * sqrt((double)cn_trainer_pixels(t) / (double)R));
    update_occupancy(t);
    cn_render_forward(m, &t->batch, Rl, &seed);
    double loss = 0, mse = 0, weighted = 0;
    /* Plain training: mean squared error. Compression: the summed squared error over all
     * training pixels, estimated from the batch, so that lambda has the paper's units. The
     * errors are summed over the whole batch, every rank's rays. */
    const float scale = m->compressed ? (float)(2.0 * cn_trainer_pixels(t) / (double)R)
                                      : 2.0f / (float)(3 * R);
    cn_xsum se[3] = {0, 0, 0}; /* the networks' errors, and the ranks' votes to stop */
    for (unsigned n = 0; n < nets; n++) {
        const float w = n == 0 && nets > 1 ? (float)t->opts.coarse_weight : 1.0f;
        se[n] = sq_error(t->dcolor[n], t->batch.color[n], t->gt, 3 * Rl, scale * w);
    }
    if (t->share && t->share->vote)
        se[2] = cn_xsum_of(t->share->vote(t->share->ctx));
    if (cn_share_allsum(t->share, se, 3)) {
        snprintf(t->err, sizeof t->err, "the batch's error could not be summed over the ranks");
        return NAN;
    }
    t->stop_votes = (int)cn_xsum_value(se[2]);
    for (unsigned n = 0; n < nets; n++) {
        const float w = n == 0 && nets > 1 ? (float)t->opts.coarse_weight : 1.0f;
        mse = cn_xsum_value(se[n]) / (double)(3 * R);
        loss += mse;
        weighted += w * mse;
    }
    if (cn_render_backward(m, &t->batch, Rl, t->dcolor)) {
        snprintf(t->err, sizeof t->err, "out of memory for the gradients' sums, or they "
                 "could not be summed over the ranks");
        return NAN;
    }
    cn_model_kernels_backward(m);
    /* --quality: D is the distortion whose gradient this step takes, the coarse error at
     * its weight (the returned loss is the plain sum, for the progress line). */
    if (m->compressed && t->opts.quality_slope > 0)
        t->opts.lambda = cn_quality_lambda(t, t->opts.quality_slope, weighted);
    double rate = 0;
    if (m->compressed && t->opts.lambda > 0)
        rate = cn_model_rate(m, seed ^ 0xA5A5A5A5ull, (float)t->opts.lambda);
    t->step++;
    const double decay = cn_trainer_lr(t) / t->opts.lr;
    if (m->compressed) {
        if (t->opts.latent_lr_weight_units) {
            for (unsigned l = 0; l < m->topo.n_layers; l++) {
                const double a0 = cn_glorot_limit(&m->topo.layer[l]) / t->opts.levels;
                const size_t w = m->layer[l].w, b = m->layer[l].b;
                cn_adam_range(m, w, b, cn_trainer_lr(t) / a0, t->step);
                cn_adam_range(m, b, b + m->topo.layer[l].n_out, cn_trainer_lr(t), t->step);
            }
        } else {
            cn_adam_range(m, 0, m->off_ab, cn_trainer_lr(t), t->step);
        }
        for (unsigned l = 0; l < m->topo.n_layers; l++) {
            const double a0 = cn_glorot_limit(&m->topo.layer[l]) / t->opts.levels;
            const size_t ab = m->off_ab + 2 * l;
            cn_adam_range(m, ab, ab + 1, t->opts.lr_scale * a0 * decay, t->step);
            cn_adam_range(m, ab + 1, ab + 2, t->opts.lr_affine * decay, t->step);
        }
    } else {
        cn_adam_range(m, 0, m->off_prior, cn_trainer_lr(t), t->step);
    }
    if (m->compressed)
        cn_adam_range(m, m->off_prior, m->n_params, t->opts.lr_prior * decay, t->step);
    average_step(t);
    if (mse_last)
        *mse_last = mse;
    if (bits)
        *bits = rate;
    return loss;
}

int cn_trainer_fog(const cn_trainer *t)
{
    return t->val_step >= CN_VAL_FOG_ITERS && t->val_step == t->step &&
           t->val_psnr < t->flat_psnr + CN_VAL_FOG_DB;
}

int cn_trainer_validate(cn_trainer *t)
{
    if (t->val_rays.n == 0)
        return 0;
    cn_model_materialize(&t->model);
    const double v = cn_val_psnr(&t->model, &t->val_rays);
    const double f = cn_val_psnr(&t->model, &t->fit_rays);
    if (v < 0 || f < 0)
        return -1;
    t->val_psnr = v;
    t->fit_psnr = f;
    t->val_step = t->step;
    if (t->val_best_step == 0 || v > t->val_best) {
        t->val_best = v;
        t->val_best_step = t->step;
        t->val_best_size = t->rate_control && t->rc.first > 0 ? t->rc.size + t->rc.reserved : 0;
    }
    return 0;
}

/* ---- checkpoints ---- */


/* FNV-1a over the training views' camera-to-world matrices, each double taken as its
 * little-endian IEEE bytes: the scene's identity, independent of the resolution. */
static uint64_t poses_hash(const cn_dataset *ds)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (int v = 0; v < ds->n_train; v++)
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 4; j++) {
                uint64_t u;
                memcpy(&u, &ds->train[v].c2w[i][j], 8);
                for (int k = 0; k < 8; k++) {
                    h ^= (uint8_t)(u >> (8 * k));
                    h *= 0x100000001b3ull;
                }
            }
    return h;
}

void cn_checkpoint_put(const cn_trainer *t, cn_buf *out)
{
    cn_buf b = {0}, h = {0};
    cn_buf_put(&b, CN_CKPT_MAGIC, 4);
    cn_buf_u32(&b, CN_CKPT_VERSION);
    cn_buf_u64(&b, (uint64_t)t->step);
    cn_buf_u64(&b, t->opts.seed);
    cn_buf_u32(&b, (uint32_t)t->model.compressed);
    cn_put_head(&h, &t->model.topo);
    cn_buf_u32(&b, (uint32_t)h.n);
    cn_buf_put(&b, h.p, h.n);
    cn_buf_free(&h);
    cn_buf_u64(&b, t->model.n_params);
    cn_buf_f32s(&b, t->model.params, t->model.n_params);
    cn_buf_f32s(&b, t->model.adam_m, t->model.n_params);
    cn_buf_f32s(&b, t->model.adam_v, t->model.n_params);
    cn_buf_u32(&b, t->model.topo.n_nets);
    for (unsigned n = 0; n < t->model.topo.n_nets; n++) {
        const cn_occ *o = &t->occ[n];
        cn_buf_u32(&b, (uint32_t)o->g);
        cn_buf_u32(&b, (uint32_t)(o->g && o->valid));
        if (o->g && o->valid)
            cn_buf_f32s(&b, o->density, (size_t)o->g * o->g * o->g);
    }
    cn_buf_f64(&b, t->opts.lambda);
    cn_buf_u32(&b, (uint32_t)t->ds->n_train);
    cn_buf_u32(&b, t->ds->n_train ? (uint32_t)t->ds->train[0].w : 0u);
    cn_buf_u32(&b, t->ds->n_train ? (uint32_t)t->ds->train[0].h : 0u);
    cn_buf_u64(&b, poses_hash(t->ds));
    cn_buf_u32(&b, (uint32_t)t->rate_control);
    if (t->rate_control) {
        const cn_ratectl *rc = &t->rc;
        cn_buf_u32(&b, (uint32_t)rc->scheme);
        cn_buf_u32(&b, (uint32_t)rc->grid_done);
        cn_buf_u64(&b, (uint64_t)rc->start);
        const double v[10] = {rc->target, rc->reserved, rc->lambda_unit, rc->first,
                              rc->integral, rc->lambda, rc->size, rc->plan, rc->grid,
                              rc->slope};
        for (int i = 0; i < 10; i++)
            cn_buf_f64(&b, v[i]);
    }
    cn_buf_f64(&b, t->opts.quality_slope);
    cn_buf_u64(&b, (uint64_t)t->opts.average);
    cn_buf_u64(&b, (uint64_t)t->avg_n);
    if (t->avg_n > 0)
        cn_buf_f64s(&b, t->avg, t->model.n_params);
    cn_buf_u64(&b, (uint64_t)(t->model.compressed ? t->opts.float_iters : 0));
    cn_buf_u32(&b, cnerf_crc32(0, b.p, b.n));
    cn_buf_put(out, b.p, b.n);
    out->oom |= b.oom;
    cn_buf_free(&b);
}

int cn_checkpoint_save(const cn_trainer *t, const char *path, char *err, size_t errlen)
{
    cn_buf b = {0};
    cn_checkpoint_put(t, &b);
    int rc = b.oom ? -1 : cn_write_file_atomic(path, b.p, b.n, err, errlen);
    if (b.oom)
        snprintf(err, errlen, "%s: out of memory", path);
    cn_buf_free(&b);
    return rc;
}

/* Reads and parses a checkpoint file; *data (to free) holds what c points into. */
static int ckpt_read(const char *path, uint8_t **data, cn_ckpt *c, char *err, size_t errlen)
{
    size_t len;
    if (cn_read_file_sig(path, "CN", 2, data, &len, err, errlen)) /* CNCK, CNJT */
        return -1;
    if (cn_ckpt_parse(path, *data, len, c, err, errlen)) {
        free(*data);
        *data = NULL;
        return -1;
    }
    return 0;
}

static void ckpt_fill(const cn_ckpt *c, cn_model *m)
{
    const size_t n = m->n_params;
    cn_get_f32s(m->params, c->blocks, n);
    cn_get_f32s(m->adam_m, c->blocks + 4 * n, n);
    cn_get_f32s(m->adam_v, c->blocks + 8 * n, n);
}

/* Whether checkpoint c was trained on other views than the trainer's (another scene, or
 * another --downscale); the message says to `verb` on the checkpoint's. */
static int other_run(const cn_trainer *t, const cn_ckpt *c, const char *path, const char *verb,
                     char *err, size_t errlen)
{
    if (!c->has_run)
        return 0;
    if (c->n_train != (uint32_t)t->ds->n_train || c->poses != poses_hash(t->ds)) {
        snprintf(err, errlen, "%s was trained on another dataset (%u training views with "
                 "other camera poses; this one has %d): %s on that dataset, or start a new "
                 "run", path, c->n_train, t->ds->n_train, verb);
        return -1;
    }
    if (t->ds->n_train &&
        (c->w != (uint32_t)t->ds->train[0].w || c->h != (uint32_t)t->ds->train[0].h)) {
        snprintf(err, errlen, "%s was trained on %ux%u images and this run has %dx%d: %s "
                 "with that --downscale, or start a new run", path, c->w, c->h,
                 t->ds->train[0].w, t->ds->train[0].h, verb);
        return -1;
    }
    return 0;
}

/* Whether checkpoint c holds a model of m's topology and compression: what a resume needs. */
static int same_model(const cn_ckpt *c, const cn_model *m)
{
    return c->n_params == m->n_params && c->compressed == (uint32_t)m->compressed &&
           memcmp(&c->hdr.net, &m->topo.net, sizeof c->hdr.net) == 0 &&
           c->hdr.n_coarse == m->topo.n_coarse && c->hdr.n_fine == m->topo.n_fine;
}

int cn_checkpoint_holds(const char *path, const cn_model *m, char *err, size_t errlen)
{
    uint8_t *data;
    cn_ckpt c;
    if (ckpt_read(path, &data, &c, err, errlen))
        return -1;
    const int same = same_model(&c, m);
    free(data);
    return same;
}

int cn_checkpoint_resume(cn_trainer *t, const char *path, char *err, size_t errlen)
{
    uint8_t *data;
    size_t len;
    if (cn_read_file_sig(path, "CN", 2, &data, &len, err, errlen)) /* CNCK, CNJT */
        return -1;
    const int rc = cn_checkpoint_resume_data(t, path, data, len, err, errlen);
    free(data);
    return rc;
}

int cn_checkpoint_resume_data(cn_trainer *t, const char *path, const uint8_t *data, size_t len,
                              char *err, size_t errlen)
{
    cn_ckpt c;
    if (cn_ckpt_parse(path, data, len, &c, err, errlen))
        return -1;
    int rc = 0;
    if (c.seed != t->opts.seed) { /* every step's random draws derive from the seed */
        snprintf(err, errlen, "%s was trained with --seed %llu: resume with that seed (this run "
                 "has %llu), or start a new run", path, (unsigned long long)c.seed,
                 (unsigned long long)t->opts.seed);
        rc = -1;
    } else if (!same_model(&c, &t->model)) {
        snprintf(err, errlen, "%s: checkpoint model differs from the requested one (preset, "
                 "depth, width, samples or compression)", path);
        rc = -1;
    } else if (other_run(t, &c, path, "resume", err, errlen)) {
        rc = -1;
    } else if (c.quality != t->opts.quality_slope || c.has_rc != t->rate_control) {
        if (c.quality > 0)
            snprintf(err, errlen, "%s was encoded with --quality %.4g: resume with that "
                     "quality, or start a new run", path, cn_quality_from_slope(c.quality));
        else if (c.has_rc)
            snprintf(err, errlen, "%s was encoded with --size %.0f (rate control): resume with "
                     "that --size, or start a new run", path, c.rc[0]);
        else
            snprintf(err, errlen, "%s was encoded with a fixed --lambda %g: resume with that "
                     "lambda, or start a new run", path, c.lambda);
        rc = -1;
    } else if (c.has_rc && c.rc_scheme != (uint32_t)t->rc.scheme) {
        snprintf(err, errlen, "%s was encoded with --rate-control %s: resume with that "
                 "controller, or start a new run", path,
                 c.rc_scheme == CN_RC_DUAL ? "dual" : "pi");
        rc = -1;
    } else if (c.has_rc && c.rc[0] != t->rc.target) {
        snprintf(err, errlen, "%s was encoded with --size %.0f: resume with that size (this "
                 "run asks for %.0f), or start a new run", path, c.rc[0], t->rc.target);
        rc = -1;
    } else if (c.average != (uint64_t)t->opts.average) {
        if (c.average)
            snprintf(err, errlen, "%s was encoded with --average %llu: resume with that, or "
                     "start a new run", path, (unsigned long long)c.average);
        else
            snprintf(err, errlen, "%s was encoded without --average: resume without it, or "
                     "start a new run", path);
        rc = -1;
    } else if (t->model.compressed && t->float_asked >= 0 &&
               c.float_iters != (uint64_t)t->float_asked) {
        snprintf(err, errlen, "%s was encoded with its latents rounded from iteration %llu: "
                 "resume without --float-iters (or with --float-iters %llu), or start a new "
                 "run", path, (unsigned long long)c.float_iters,
                 (unsigned long long)c.float_iters);
        rc = -1;
    } else if (c.has_run && !c.has_rc && c.quality == 0 && c.lambda != t->opts.lambda) {
        snprintf(err, errlen, "%s was encoded with --lambda %g: resume with that lambda (this "
                 "run has %g), or start a new run", path, c.lambda, t->opts.lambda);
        rc = -1;
    } else {
        ckpt_fill(&c, &t->model);
        t->step = (long)c.step;
        t->avg_n = (long)c.avg_n;
        if (t->model.compressed) /* the run's own, whatever --iters now makes the default */
            t->opts.float_iters = (long)c.float_iters;
        if (c.avg_n > 0)
            cn_get_f64s(t->avg, c.avg, c.n_params);
        if (c.quality > 0) /* the last step's; the next step sets its own */
            t->opts.lambda = c.lambda;
        if (c.has_rc) {
            cn_ratectl *r = &t->rc;
            r->scheme = (cn_rc_scheme)c.rc_scheme;
            r->grid_done = (int)c.rc_grid_done;
            r->start = (long)c.rc_start;
            r->reserved = c.rc[1];
            r->lambda_unit = c.rc[2];
            r->first = c.rc[3];
            r->integral = c.rc[4];
            r->lambda = c.rc[5];
            r->size = c.rc[6];
            r->plan = c.rc[7];
            r->grid = c.rc[8];
            r->slope = c.rc[9];
            t->opts.lambda = c.lambda;
        }
        /* A grid of the size the run asks for continues; any other is rebuilt from the
         * model at the next step, as a version 1 file's is. */
        const float threshold = cn_occ_threshold(&t->model.topo);
        for (unsigned n = 0; n < c.n_grids; n++) {
            cn_occ *o = &t->occ[n];
            if (!o->g || (uint32_t)o->g != c.grid_g[n] || !c.grid[n])
                continue;
            cn_get_f32s(o->density, c.grid[n], (size_t)o->g * o->g * o->g);
            t->occ_frac[n] = cn_occ_refresh(o, threshold);
        }
    }
    return rc;
}

int cn_trainer_init_from_float(cn_trainer *t, const char *path, char *err, size_t errlen)
{
    cn_ckpt c;
    uint8_t *data;
    if (ckpt_read(path, &data, &c, err, errlen))
        return -1;
    const cnerf_info *a = &c.hdr, *b = &t->model.topo;
    int rc = 0;
    if (c.compressed) {
        snprintf(err, errlen, "%s is a compressed model (from cnerf encode): --init takes a "
                 "float model from cnerf train; to go on with this one, --resume it", path);
        rc = -1;
    } else if (memcmp(&a->net, &b->net, sizeof a->net) || a->n_coarse != b->n_coarse ||
               a->n_fine != b->n_fine || a->n_nets != b->n_nets) {
        snprintf(err, errlen, "%s is a model of depth %u, width %u and %u+%u samples; this "
                 "encode asks for depth %u, width %u and %u+%u: give the preset (or --depth, "
                 "--width, --coarse, --fine) it was trained with", path, a->net[0].depth,
                 a->net[0].width, a->n_coarse, a->n_fine, b->net[0].depth, b->net[0].width,
                 b->n_coarse, b->n_fine);
        rc = -1;
    } else if (a->coord != b->coord || a->l_pos != b->l_pos || a->l_dir != b->l_dir ||
               a->pe_flags != b->pe_flags || a->near_q16 != b->near_q16 ||
               a->far_q16 != b->far_q16 || memcmp(a->aabb_q16, b->aabb_q16, sizeof a->aabb_q16)) {
        snprintf(err, errlen, "%s maps the scene otherwise (coordinates, encoding, near and far "
                 "or bounds differ, as with another --background): encode with the options it "
                 "was trained with", path);
        rc = -1;
    } else
        rc = other_run(t, &c, path, "encode", err, errlen);
    cn_model f;
    if (rc == 0 && cn_model_init(&f, a, 0, err, errlen))
        rc = -1;
    if (rc == 0 && f.n_params != c.n_params) {
        snprintf(err, errlen, "%s: parameter count does not match its header", path);
        cn_model_free(&f);
        rc = -1;
    }
    if (rc == 0) {
        /* Each kernel onto its latents at the decoder's initial step a (b = 0): W = a Phi,
         * rounded by the first step's materialization; the biases as they are. */
        ckpt_fill(&c, &f);
        cn_model *m = &t->model;
        for (unsigned l = 0; l < m->topo.n_layers; l++) {
            const cnerf_layer_info *L = &m->topo.layer[l];
            const size_t n = (size_t)L->n_in * L->n_out;
            const float unit = m->params[m->off_ab + 2 * l];
            m->params[m->off_ab + 2 * l + 1] = 0.0f;
            for (size_t i = 0; i < n; i++)
                m->params[m->layer[l].w + i] = f.params[f.layer[l].w + i] / unit;
            memcpy(m->params + m->layer[l].b, f.params + f.layer[l].b, L->n_out * sizeof(float));
        }
        cn_model_free(&f);
        t->from_float = 1;
        /* The model is trained: its empty space is known now, not only from occ_start. */
        cn_model_materialize(m);
        for (unsigned n = 0; n < m->topo.n_nets && t->occ[n].g; n++)
            estimate_occupancy(t, n); /* at step 0, as update_occupancy would */
    }
    free(data);
    return rc;
}

int cn_checkpoint_load_model(const char *path, cn_model *m, long *step, char *err,
                             size_t errlen)
{
    cn_ckpt c;
    uint8_t *data;
    if (ckpt_read(path, &data, &c, err, errlen))
        return -1;
    int rc = c.compressed ? cn_model_init_compressed(m, &c.hdr, 0, 1.0, err, errlen)
                          : cn_model_init(m, &c.hdr, 0, err, errlen);
    if (rc == 0 && m->n_params != c.n_params) {
        snprintf(err, errlen, "%s: parameter count does not match its header", path);
        cn_model_free(m);
        rc = -1;
    }
    if (rc == 0) {
        ckpt_fill(&c, m);
        cn_model_materialize(m);
        if (step)
            *step = (long)c.step;
    }
    free(data);
    return rc;
}

/* ---- full views ---- */

/* Whether a batch made for topology a serves b: the sizes cn_batch_init reads. */
static int same_batch_shape(const cnerf_info *a, const cnerf_info *b)
{
    if (a->n_nets != b->n_nets || a->n_coarse != b->n_coarse || a->n_fine != b->n_fine ||
        a->in_pos != b->in_pos || a->in_dir != b->in_dir)
        return 0;
    for (unsigned n = 0; n < a->n_nets; n++) {
        const cnerf_net_info *x = &a->net[n], *y = &b->net[n];
        if (x->depth != y->depth || x->skip != y->skip || x->width != y->width ||
            x->view_width != y->view_width)
            return 0;
    }
    return 1;
}

int cn_view_render(cn_view_renderer *r, const cn_model *m, const cn_camera *cam, int ndc,
                   float *rgb, size_t chunk, float t_stop)
{
    if (r->live && (r->chunk != chunk || !same_batch_shape(&r->shape, &m->topo))) {
        cn_batch_free(&r->batch);
        r->live = 0;
    }
    if (!r->live) {
        if (cn_batch_init(&r->batch, &m->topo, chunk))
            return -1;
        r->shape = m->topo;
        r->chunk = chunk;
        r->live = 1;
        r->made++;
    }
    cn_batch *b = &r->batch;
    b->occ[0] = b->occ[1] = m->grid;
    b->t_stop = t_stop;
    const size_t total = (size_t)cam->w * cam->h;
    const unsigned last = m->topo.n_nets - 1;
    for (size_t start = 0; start < total; start += chunk) {
        size_t R = total - start < chunk ? total - start : chunk;
        for (size_t i = 0; i < R; i++) {
            size_t pix = start + i;
            cn_camera_ray(cam, ndc, (double)(pix % cam->w), (double)(pix / cam->w), b->o + 3 * i,
                          b->d + 3 * i, b->vd + 3 * i);
        }
        cn_render_forward(m, b, R, NULL);
        memcpy(rgb + 3 * start, b->color[last], sizeof(float) * 3 * R);
    }
    return 0;
}

void cn_view_renderer_free(cn_view_renderer *r)
{
    if (r->live)
        cn_batch_free(&r->batch);
    memset(r, 0, sizeof *r);
}

int cn_render_view_stop(const cn_model *m, const cn_camera *cam, int ndc, float *rgb,
                        size_t chunk, float t_stop)
{
    cn_view_renderer r;
    memset(&r, 0, sizeof r);
    const int rc = cn_view_render(&r, m, cam, ndc, rgb, chunk, t_stop);
    cn_view_renderer_free(&r);
    return rc;
}

int cn_render_view(const cn_model *m, const cn_camera *cam, int ndc, float *rgb, size_t chunk)
{
    return cn_render_view_stop(m, cam, ndc, rgb, chunk, 0);
}
