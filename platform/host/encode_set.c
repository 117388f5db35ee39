/* The encode command with several datasets (cmd_encode hands them here): cnerf encode DATASET1
 * DATASET2 ... -o set.cnrf, several scenes trained jointly with shared
 * shifts (encoder/compress/cn_joint.h), written as one stream (docs/bitstream.md section 13), read
 * back scene by scene and evaluated on each scene's test views. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cn_file.h"
#include "cli.h"
#include "cli_args.h"
#include "cn_joint.h"
#include "cn_metrics.h"
#include "cn_pipeline.h"
#include "cn_train.h"

#define SET_USAGE                                                                            \
    "usage: cnerf encode DATASET1 DATASET2 [...] -o set.cnrf (--lambda L | --quality Q)\n"  \
    "       [--preset tiny|small|paper] [--iters N] [--downscale F|--max-size N]\n"          \
    "       [--threads T] [--seed S] [--resume CKPT] [--levels X] [--batch R] [--every N]\n" \
    "       [--lr X] [--lr-decay N] [--shift-lr X] [--prior-lr X] [--affine-lr X] [--scale-lr R]\n"        \
    "       [--ckpt-every N | --ckpt-secs S] [--log-every N] [--eval-every N]\n"            \
    "       [--depth D] [--width W] [--coarse N] [--fine N] [--grid G|0] [--random-bg auto|on|off]\n" \
    "       [--background constant|contract] [--coarse-color off|on] [--coarse-weight W]\n"          \
    "  Several scenes in one stream: one network topology, each scene's own latents,\n"    \
    "  affine decoders, biases, render parameters and grid, and shifts shared by all."

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

int cli_encode_set(int argc, char **argv)
{
    cn_train_opts o;
    cn_train_defaults(&o);
    o.compress = 1;
    const char *out = NULL, *resume = NULL, *pos[CNERF_MAX_SCENES], *random_bg = "auto", *background = "constant";
    long iters = o.iters, downscale = 1, max_size = 0, threads = 0, batch = o.batch, every = 1;
    long depth = -1, width = -1, coarse = -1, fine = -1, ckpt_every = 0, log_every = 100;
    long eval_every = 0, grid_g = -1;
    double ckpt_secs = CLI_CKPT_SECS, lambda = -1, quality = -1, levels = o.levels;
    double lr_shift = o.lr_affine, size = 0, bpp = 0;
    long average = 0;
    const char *prune = NULL, *scheme = NULL, *coarse_color = "off";
    double coarse_weight = -1;
    uint64_t seed = o.seed;
    int n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &out, 0, 0},
        {"--lambda", CLI_DOUBLE, &lambda, 0, 1e3},
        {"--quality", CLI_DOUBLE, &quality, 0, 100},
        {"--size", CLI_DOUBLE, &size, 1, 1e9},
        {"--average", CLI_LONG, &average, 1, 1e9},
        {"--bits-per-param", CLI_DOUBLE, &bpp, 1e-3, 32},
        {"--rate-control", CLI_STR, &scheme, 0, 0},
        {"--prune", CLI_STR, &prune, 0, 0},
        {"--preset", CLI_STR, &o.preset, 0, 0},
        {"--iters", CLI_LONG, &iters, 0, 1e9},
        {"--downscale", CLI_LONG, &downscale, 1, 64},
        {"--max-size", CLI_LONG, &max_size, 1, 1 << 20},
        {"--threads", CLI_LONG, &threads, 1, 256},
        {"--seed", CLI_U64, &seed, 0, 0},
        {"--resume", CLI_STR, &resume, 0, 0},
        {"--levels", CLI_DOUBLE, &levels, 0.5, 10000},
        {"--batch", CLI_LONG, &batch, 1, 65536},
        {"--every", CLI_LONG, &every, 1, 1e6},
        {"--ckpt-every", CLI_LONG, &ckpt_every, 1, 1e9},
        {"--ckpt-secs", CLI_DOUBLE, &ckpt_secs, 1, 1e6},
        {"--log-every", CLI_LONG, &log_every, 1, 1e9},
        {"--eval-every", CLI_LONG, &eval_every, 0, 1e9},
        {"--depth", CLI_LONG, &depth, 1, CNERF_MAX_DEPTH},
        {"--width", CLI_LONG, &width, 1, CNERF_MAX_WIDTH},
        {"--coarse", CLI_LONG, &coarse, 1, CNERF_MAX_SAMPLES},
        {"--fine", CLI_LONG, &fine, 0, CNERF_MAX_SAMPLES},
        {"--lr", CLI_DOUBLE, &o.lr, 1e-8, 1},
        {"--lr-decay", CLI_DOUBLE, &o.lr_decay_steps, 1, 1e12},
        {"--shift-lr", CLI_DOUBLE, &lr_shift, 0, 1},
        {"--prior-lr", CLI_DOUBLE, &o.lr_prior, 0, 1},
        {"--affine-lr", CLI_DOUBLE, &o.lr_affine, 0, 1},
        {"--scale-lr", CLI_DOUBLE, &o.lr_scale, 0, 1},
        {"--grid", CLI_LONG, &grid_g, -1, CNERF_MAX_GRID},
        {"--random-bg", CLI_STR, &random_bg, 0, 0},
        {"--background", CLI_STR, &background, 0, 0},
        {"--coarse-color", CLI_STR, &coarse_color, 0, 0},
        {"--coarse-weight", CLI_DOUBLE, &coarse_weight, 1e-3, 10},
    };
    if (cli_parse("encode", SET_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos,
                  CNERF_MAX_SCENES, &n_pos))
        return 2;
    const unsigned M = (unsigned)n_pos;
    if (average > 0)
        return cli_usage("encode", "--average encodes one scene: a stream of several scenes "
                         "ends with its last iteration's model");
    if (size > 0 || bpp > 0 || scheme)
        return cli_usage("encode", "--size, --bits-per-param and --rate-control encode one "
                         "scene; a stream of several scenes takes --lambda L or --quality Q");
    if (M < 2 || !out || (lambda < 0 && quality < 0))
        return cli_usage("encode", "several scenes need their dataset directories, -o FILE and "
                         "--lambda L or --quality Q\n%s", SET_USAGE);
    if (prune && strcmp(prune, "off"))
        return cli_usage("encode", "--prune: a stream of several scenes keeps every unit (its "
                         "proof of a dead unit would have to hold in every scene); give "
                         "--prune off or leave it out");
    if (lambda >= 0 && quality >= 0)
        return cli_usage("encode", "--lambda and --quality each set the rate: give one of them");
    if (grid_g > 0 && (grid_g < 16 || (grid_g & (grid_g - 1))))
        return cli_usage("encode", "--grid takes 16, 32, 64 or 128 cells per axis, or 0 for no "
                        "grid, not %ld", grid_g);
    if (cli_background("encode", background, &o.contract))
        return 2;
    if (cli_random_bg("encode", random_bg, &o.random_bg))
        return 2;
    if (cli_coarse_color("encode", coarse_color, coarse_weight, &o))
        return 2;
    if (iters == 0 && !resume)
        return cli_usage("encode", "--iters 0 trains nothing: give at least 1, or --resume a "
                         "checkpoint");
    for (unsigned a = 0; a < M; a++)
        for (unsigned b = a + 1; b < M; b++)
            if (!strcmp(pos[a], pos[b]))
                return cli_usage("encode", "%s is given twice: a set's scenes are different "
                                 "datasets", pos[a]);
    cli_set_threads(threads);
    o.iters = iters;
    o.seed = seed;
    o.batch = (int)batch;
    o.depth = (int)depth;
    o.width = (int)width;
    o.n_coarse = (int)coarse;
    o.n_fine = (int)fine;
    o.lambda = quality >= 0 ? 0 : lambda;
    o.levels = levels;
    o.latent_lr_weight_units = 1;
    if (quality >= 0)
        o.quality_slope = cn_quality_slope(quality);
    char ckpt[4096];
    snprintf(ckpt, sizeof ckpt, "%s", resume ? resume : out);
    if (!resume)
        strncat(ckpt, ".ckpt", sizeof ckpt - strlen(ckpt) - 1);
    const char *inputs[1] = {resume};
    for (unsigned m = 0; m < M; m++)
        if (cli_check_output("encode", out, inputs, 1, pos[m]) ||
            cli_check_output("encode", ckpt, NULL, 0, pos[m]))
            return 1;
    char lock[4200];
    const int lk = cli_lock_output("encode", out, lock, sizeof lock);
    if (lk < 0)
        return 1;
    cn_dataset *ds = calloc(M, sizeof *ds);
    unsigned loaded = 0;
    int rc = ds ? 0 : cli_fail("encode", "out of memory");
    for (; rc == 0 && loaded < M; loaded++)
        if (cli_load_dataset("encode", pos[loaded], downscale, max_size, 0, 0, 0, -1, &ds[loaded]))
            rc = 1;
    if (rc) {
        for (unsigned m = 0; m + 1 < loaded; m++)
            cn_dataset_free(&ds[m]);
        free(ds);
        cli_unlock_output(lk, lock);
        return rc;
    }
    char err[1024];
    cn_joint j;
    if (cn_joint_init(&j, ds, M, &o, lr_shift, err, sizeof err)) {
        rc = cli_fail("encode", "%s", err);
        goto out_data;
    }
    if (resume) {
        if (access(resume, F_OK) != 0)
            rc = cli_fail("encode", "%s: no such checkpoint", resume);
        else if (cn_joint_resume(&j, resume, err, sizeof err))
            rc = cli_fail("encode", "%s", err);
        else
            printf("resumed %s at iteration %ld\n", resume, j.step);
    }
    int stopped = 0;
    if (rc == 0) {
        printf("encoding %u scenes jointly, shifts shared: lambda %s, %zu latents per scene, "
               "checkpoint %s\n", M, quality >= 0 ? "from --quality" : "fixed",
               cn_model_sent_latents(&j.t[0].model), ckpt);
        for (unsigned m = 0; m < M; m++)
            printf("  scene %u: %s, %d train views %dx%d, %s\n", m, pos[m], ds[m].n_train,
                   ds[m].train[0].w, ds[m].train[0].h, ds[m].ndc ? "NDC" : "world");
        const cli_job job = {&j, iters, set_done, set_step, set_save, NULL};
        rc = cli_run_job("encode", &job, ckpt, ckpt_every, ckpt_secs, log_every, eval_every,
                         every, &stopped);
    }
    if (rc == 0 && stopped) {
        printf("interrupted: resume with --resume %s\n", ckpt);
        rc = 128 + stopped;
    }
    for (unsigned m = 0; rc == 0 && m < M; m++) { /* each scene on its own held-out views */
        printf("scene %u: ", m);
        rc = cli_report_validation("encode", &j.t[m]);
    }
    /* Every scene and the shifts snapped to the stream's numbers, the scales from each
     * scene's float model with the shifts, a grid per scene, one stream (cn_pipeline.h). */
    cn_encoded enc;
    memset(&enc, 0, sizeof enc);
    char meta[1024];
    snprintf(meta, sizeof meta,
             "encoder=cnerf %s; command=encode; scenes=%u; dataset=%s; preset=%s; iters=%ld; "
             "lambda=%g; downscale=%ld; seed=%llu; levels=%g; coarse-color=%s; coarse-weight=%g",
             CNERF_VERSION_STRING, M, pos[0], o.preset, j.step, cn_joint_lambda(&j), downscale,
             (unsigned long long)seed, levels, coarse_color, o.coarse_weight);
    if (rc == 0) {
        cn_model *models[CNERF_MAX_SCENES];
        const cn_dataset *views[CNERF_MAX_SCENES];
        for (unsigned m = 0; m < M; m++) {
            models[m] = &j.t[m].model;
            views[m] = &ds[m];
        }
        const cn_encode_job job = {.models = models, .shift = &j.shift, .n = M, .meta = meta,
                                   .seed = seed, .grid_g = (int)grid_g, .views = views};
        if (cn_encode_finish(&job, &enc, err, sizeof err))
            rc = cli_fail("encode", "%s", err);
    }
    for (unsigned m = 0; rc == 0 && grid_g != 0 && m < M; m++) {
        const cn_grid_choice *g = &enc.grid[m];
        if (g->g)
            printf("occupancy grid of scene %u: %d^3, %.1f%% of the cells occupied, %zu bytes; "
                   "%.1f%% of the evaluations left on the training rays\n", m, g->g,
                   100 * g->occupied, g->bytes, 100 * g->eval_fraction);
        else
            printf("occupancy grid of scene %u: none\n", m);
    }
    const cn_buf b = enc.stream;
    if (rc == 0 && cn_write_file_atomic(out, b.p, b.n, err, sizeof err))
        rc = cli_fail("encode", "%s", err);
    /* The closed loop: each scene read back through the decoder, its float reference
     * rendered on its test views. */
    double psum = 0;
    int scored = 0;
    for (unsigned m = 0; rc == 0 && m < M; m++) {
        cli_stream st;
        cn_model ref;
        if (cli_stream_open_scene("encode", out, m, &st, &ref)) {
            rc = 1;
            break;
        }
        if (m == 0)
            printf("wrote %s: %zu bytes, %u scenes, shared shifts %u bytes\n", out, st.len, M,
                   st.dec->info.shared_bytes);
        double psnr = 0, ssim = 0, secs = 0;
        const int n = cli_eval_views(&ref, ds[m].test, ds[m].n_test, ds[m].ndc, every, NULL, 1,
                                     &psnr, &ssim, &secs);
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
        printf("test: %u scenes, mean psnr %.2f dB, file %zu bytes\n", M, psum / scored, b.n);
    cn_encoded_free(&enc);
    cn_joint_free(&j);
out_data:
    for (unsigned m = 0; m < M; m++)
        cn_dataset_free(&ds[m]);
    free(ds);
    cli_unlock_output(lk, lock);
    return rc;
}
