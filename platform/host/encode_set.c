/* The encode command with several datasets (cmd_encode hands them here): cnerf encode DATASET1
 * DATASET2 ... -o set.cnrf, several scenes trained jointly with shared
 * shifts (encoder/compress/cn_joint.h), written as one stream (docs/bitstream.md section 13), read
 * back scene by scene and evaluated on each scene's test views. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cn_file.h"
#include "cli.h"
#include "cli_args.h"
#include "cli_encode.h"
#include "cn_joint.h"
#include "cn_metrics.h"
#include "cn_pipeline.h"
#include "cn_train.h"

/* The job cli_run_job runs: one joint step, per-scene PSNR on the progress line. */
static long set_done(void *ctx) { return ((cn_joint *)ctx)->step; }

static double set_step(void *ctx, double *psnr, char *extra, size_t n, char *err,
                       size_t errlen)
{
    cn_joint *j = ctx;
    double mse[CNERF_MAX_SCENES], bits[CNERF_MAX_SCENES];
    const double loss = cn_joint_step(j, mse, bits);
    if (isnan(loss) && j->err[0]) {
        snprintf(err, errlen, "%s", j->err);
        return loss;
    }
    err[0] = 0;
    double msum = 0, bsum = 0;
    size_t k = (size_t)snprintf(extra, n, "  scenes");
    for (unsigned m = 0; m < j->n; m++) {
        msum += mse[m];
        bsum += bits[m];
        if (m < 4 && k < n)
            k += (size_t)snprintf(extra + k, n - k, " %.2f", cn_psnr_from_mse(mse[m]));
    }
    if (k < n)
        snprintf(extra + k, n - k, "%s dB, rate %.1f kB + shifts %.1f kB", j->n > 4 ? " ..." : "",
                 bsum / 8000.0, j->shift_bits / 8000.0);
    *psnr = cn_psnr_from_mse(msum / j->n);
    return loss;
}

static int set_save(void *ctx, const char *path, char *err, size_t errlen)
{
    return cn_joint_save(ctx, path, err, errlen);
}

/* The options a stream of several scenes does not take, and the ones it needs. Returns 0, or
 * the command's exit status. */
static int check_set(const encode_args *A)
{
    static const char one[] = "encodes one scene; a stream of several scenes does not take it";
    const unsigned M = (unsigned)A->n_pos;
    if (A->o.average > 0)
        return cli_usage("encode", "--average encodes one scene: a stream of several scenes "
                         "ends with its last iteration's model");
    if (A->size > 0 || A->bpp > 0 || A->scheme)
        return cli_usage("encode", "--size, --bits-per-param and --rate-control encode one "
                         "scene; a stream of several scenes takes --lambda L or --quality Q");
    if (!A->out || (A->lambda < 0 && A->quality < 0))
        return cli_usage("encode", "several scenes need their dataset directories, -o FILE and "
                         "--lambda L or --quality Q");
    if (A->prune && strcmp(A->prune, "off"))
        return cli_usage("encode", "--prune: a stream of several scenes keeps every unit (its "
                         "proof of a dead unit would have to hold in every scene); give "
                         "--prune off or leave it out");
    const struct { int given; const char *name; } single[] = {
        {A->init != NULL, "--init"},           {A->black, "--black"},
        {A->val_views >= 0, "--val-views"},    {A->view_width >= 0, "--view-width"},
        {A->latent_lr != NULL, "--latent-lr"}, {A->precrop >= 0, "--precrop-iters"},
        {A->o.sat_eps != 0, "--skip-saturated"}, {A->o.group != 0, "--group-penalty"},
        {A->grid_verbose, "--grid-verbose"},   {A->o.float_iters >= 0, "--float-iters"},
    };
    for (size_t k = 0; k < sizeof single / sizeof single[0]; k++)
        if (single[k].given)
            return cli_usage("encode", "%s %s", single[k].name, one);
    if (A->lambda >= 0 && A->quality >= 0)
        return cli_usage("encode", "--lambda and --quality each set the rate: give one of them");
    if (A->grid_g > 0 && (A->grid_g < 16 || (A->grid_g & (A->grid_g - 1))))
        return cli_usage("encode", "--grid takes 16, 32, 64 or 128 cells per axis, or 0 for no "
                        "grid, not %ld", A->grid_g);
    if (A->iters == 0 && !A->resume)
        return cli_usage("encode", "--iters 0 trains nothing: give at least 1, or --resume a "
                         "checkpoint");
    for (unsigned a = 0; a < M; a++)
        for (unsigned b = a + 1; b < M; b++) {
            if (!strcmp(A->pos[a], A->pos[b]))
                return cli_usage("encode", "%s is given twice: a set's scenes are different "
                                 "datasets", A->pos[a]);
            struct stat sa, sb; /* one folder by two names */
            if (stat(A->pos[a], &sa) == 0 && stat(A->pos[b], &sb) == 0 &&
                sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino)
                return cli_usage("encode", "%s and %s are one dataset: a set's scenes are "
                                 "different datasets", A->pos[a], A->pos[b]);
        }
    return 0;
}

/* The training options of a set from the command line. Returns 0, or an exit status. */
static int set_options(const encode_args *A, cn_train_opts *o)
{
    *o = A->o;
    if (A->preset)
        o->preset = A->preset;
    if (cli_background("encode", A->background, &o->contract) ||
        cli_random_bg("encode", A->random_bg, &o->random_bg) ||
        cli_coarse_color("encode", A->coarse_color, A->coarse_weight, o))
        return 2;
    o->iters = A->iters;
    o->seed = A->seed;
    o->batch = (int)A->batch;
    o->depth = (int)A->depth;
    o->width = (int)A->width;
    o->n_coarse = (int)A->coarse;
    o->n_fine = (int)A->fine;
    o->lambda = A->quality >= 0 ? 0 : A->lambda;
    o->levels = A->levels;
    o->latent_lr_weight_units = 1;
    /* Rounded from the first iteration: the shared shifts are integers from the start, and
     * the float phase was measured on single scenes (docs/training.md, "The float phase"). */
    o->float_iters = 0;
    if (A->quality >= 0)
        o->quality_slope = cn_quality_slope(A->quality);
    return 0;
}

/* Every scene and the shifts snapped to the stream's numbers, the scales from each scene's
 * float model with the shifts, a grid per scene, one stream (cn_pipeline.h), written to
 * A->out. */
static int write_set(const encode_args *A, cn_joint *j, const cn_train_opts *o,
                     const cn_dataset *ds, cn_encoded *enc)
{
    const unsigned M = (unsigned)A->n_pos;
    char meta[1024], err[1024];
    snprintf(meta, sizeof meta,
             "encoder=cnerf %s; command=encode; scenes=%u; dataset=%s; preset=%s; iters=%ld; "
             "lambda=%g; downscale=%ld; seed=%llu; levels=%g; coarse-color=%s; coarse-weight=%g",
             CNERF_VERSION_STRING, M, A->pos[0], o->preset, j->step, cn_joint_lambda(j),
             A->downscale, (unsigned long long)A->seed, A->levels, A->coarse_color,
             o->coarse_weight);
    cn_model *models[CNERF_MAX_SCENES];
    const cn_dataset *views[CNERF_MAX_SCENES];
    for (unsigned m = 0; m < M; m++) {
        models[m] = &j->t[m].model;
        views[m] = &ds[m];
    }
    const cn_encode_job job = {.models = models, .shift = &j->shift, .n = M, .meta = meta,
                               .seed = A->seed, .grid_g = (int)A->grid_g, .views = views};
    if (cn_encode_finish(&job, enc, err, sizeof err))
        return cli_fail("encode", "%s", err);
    for (unsigned m = 0; A->grid_g != 0 && m < M; m++) {
        const cn_grid_choice *g = &enc->grid[m];
        if (g->g)
            printf("occupancy grid of scene %u: %d^3, %.1f%% of the cells occupied, %zu bytes; "
                   "%.1f%% of the evaluations left on the training rays\n", m, g->g,
                   100 * g->occupied, g->bytes, 100 * g->eval_fraction);
        else
            printf("occupancy grid of scene %u: none\n", m);
    }
    if (cn_write_file_atomic(A->out, enc->stream.p, enc->stream.n, err, sizeof err))
        return cli_fail("encode", "%s", err);
    cli_stop_phase("wrote", "after training: saved %s%s and wrote %s; its measurement was "
                   "not finished (cnerf render %s --scene M --dataset D measures scene M)",
                   A->resume ? A->resume : A->out, A->resume ? "" : ".ckpt", A->out, A->out);
    return 0;
}

/* The closed loop: each scene read back through the decoder, its float reference rendered
 * on its test views. */
static int score_set(const encode_args *A, const cn_dataset *ds, size_t bytes)
{
    const unsigned M = (unsigned)A->n_pos;
    double psum = 0;
    int scored = 0, rc = 0;
    for (unsigned m = 0; rc == 0 && m < M; m++) {
        cli_stream st;
        cn_model ref;
        if (cli_stream_open_scene("encode", A->out, m, &st, &ref))
            return 1;
        if (m == 0)
            printf("wrote %s: %zu bytes, %u scenes, shared shifts %u bytes\n", A->out, st.len, M,
                   st.dec->info.shared_bytes);
        double psnr = 0, ssim = 0, secs = 0;
        const int n = cli_eval_views(&ref, ds[m].test, ds[m].n_test, ds[m].ndc, 1, NULL,
                                     1, CLI_T_STOP, &psnr, &ssim, &secs);
        if (n < 0)
            rc = 1;
        else {
            printf("scene %u: %u bytes of its own, test: %d views, psnr %.2f dB, ssim %.4f\n", m,
                   st.dec->info.scene_bytes, n, psnr, ssim);
            if (n > 0)
                psum += psnr, scored++;
        }
        cn_model_free(&ref);
        cli_stream_free(&st);
    }
    if (rc == 0 && scored)
        printf("test: %u scenes, mean psnr %.2f dB, file %zu bytes\n", M, psum / scored, bytes);
    return rc;
}

int cli_encode_set(const encode_args *A)
{
    const unsigned M = (unsigned)A->n_pos;
    cn_train_opts o;
    int rc = check_set(A);
    if (rc == 0)
        rc = set_options(A, &o);
    if (rc)
        return rc;
    cli_set_threads(A->threads);
    char ckpt[4096];
    snprintf(ckpt, sizeof ckpt, "%s", A->resume ? A->resume : A->out);
    if (!A->resume)
        strncat(ckpt, ".ckpt", sizeof ckpt - strlen(ckpt) - 1);
    for (unsigned m = 0; m < M; m++)
        if (cli_check_output("encode", A->out, NULL, 0, A->pos[m]) ||
            cli_check_output("encode", ckpt, NULL, 0, A->pos[m]) ||
            cli_check_not("encode", A->out, A->resume))
            return 1;
    cli_locks locks;
    if (cli_encode_lock(A, ckpt, &locks))
        return 1;
    cn_dataset *ds = calloc(M, sizeof *ds);
    unsigned loaded = 0;
    rc = ds ? 0 : cli_fail("encode", "out of memory");
    for (; rc == 0 && loaded < M; loaded++)
        if (cli_load_dataset("encode", A->pos[loaded], A->downscale, A->max_size, 0, 0, 0, -1,
                             A->every, 0, &ds[loaded]))
            rc = 1;
    if (rc) {
        for (unsigned m = 0; m + 1 < loaded; m++)
            cn_dataset_free(&ds[m]);
        free(ds);
        cli_unlock_outputs(&locks);
        return rc;
    }
    cli_stop_before("start", "before training", A->resume);
    cli_auto_background(ds, (int)M, &o.contract);
    char err[1024];
    cn_joint j;
    if (cn_joint_init(&j, ds, M, &o, A->lr_shift >= 0 ? A->lr_shift : A->o.lr_affine, err,
                      sizeof err)) {
        rc = cli_fail("encode", "%s", err);
        goto out_data;
    }
    if (A->resume) {
        if (access(A->resume, F_OK) != 0)
            rc = cli_fail("encode", "%s: no such checkpoint", A->resume);
        else if (cn_joint_resume(&j, A->resume, err, sizeof err))
            rc = cli_fail("encode", "%s", err);
        else
            printf("resumed %s at iteration %ld\n", A->resume, j.step);
    }
    int stopped = 0;
    if (rc == 0) {
        printf("encoding %u scenes jointly, shifts shared: lambda %s, %zu latents per scene, "
               "checkpoint %s\n", M, A->quality >= 0 ? "from --quality" : "fixed",
               cn_model_sent_latents(&j.t[0].model), ckpt);
        for (unsigned m = 0; m < M; m++)
            printf("  scene %u: %s, %d train views %dx%d, %s\n", m, A->pos[m], ds[m].n_train,
                   ds[m].train[0].w, ds[m].train[0].h, ds[m].ndc ? "NDC" : "world");
        char after[8400];
        snprintf(after, sizeof after, "%s not written: run the command again with --resume %s "
                 "to write it", A->out, ckpt);
        const cli_job job = {&j, A->iters, set_done, set_step, set_save, NULL, after};
        rc = cli_run_job("encode", &job, ckpt, A->ckpt_every, A->ckpt_secs, A->log_every,
                         A->eval_every, &stopped);
    }
    if (rc == 0 && stopped) {
        printf("interrupted: resume with --resume %s\n", ckpt);
        rc = 128 + stopped;
    }
    for (unsigned m = 0; rc == 0 && m < M; m++) { /* each scene on its own held-out views */
        printf("scene %u: ", m);
        rc = cli_report_validation("encode", &j.t[m]);
    }
    cn_encoded enc;
    memset(&enc, 0, sizeof enc);
    if (rc == 0)
        rc = write_set(A, &j, &o, ds, &enc);
    if (rc == 0)
        rc = score_set(A, ds, enc.stream.n);
    cn_encoded_free(&enc);
    cn_joint_free(&j);
out_data:
    for (unsigned m = 0; m < M; m++)
        cn_dataset_free(&ds[m]);
    free(ds);
    cli_unlock_outputs(&locks);
    return rc;
}
