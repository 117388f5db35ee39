/* cnerf eval MODEL DATASET: renders a split with a checkpoint's model or with the float
 * reference model of a stream, and reports PSNR and SSIM. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "cli_args.h"
#include "cn_image.h"
#include "cn_metrics.h"
#include "cn_train.h"
#include "progress.h"

#define EVAL_USAGE                                                                          \
    "usage: cnerf eval model.ckpt|scene.cnrf DATASET [--split test|val|train] [--downscale F|--max-size N]\n"      \
    "       [--every N] [-o DIR] [--threads T] [--black] [--chunk R] [--scene I]"

/* Writes rgb floats in [0, 1] as an 8-bit PNG. */
int cli_write_png(const char *path, const float *rgb, int w, int h, char *err, size_t errlen)
{
    uint8_t *px = malloc((size_t)w * h * 3);
    if (!px) {
        snprintf(err, errlen, "%s: out of memory", path);
        return -1;
    }
    for (size_t i = 0; i < (size_t)w * h * 3; i++) {
        float v = rgb[i] * 255.0f + 0.5f;
        px[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
    }
    int rc = cn_png_write_rgb8(path, px, w, h, (size_t)w * 3, err, errlen);
    free(px);
    return rc;
}

int cli_make_dir(const char *cmd, const char *dir)
{
    if (mkdir(dir, 0755) != 0 && errno != EEXIST)
        return cli_fail(cmd, "%s: cannot create directory: %s", dir, strerror(errno));
    return 0;
}

int cli_eval_views(const cn_model *m, const cn_view *views, int n, int ndc, long every,
                   const char *outdir, int quiet, double *mean_psnr, double *mean_ssim,
                   double *secs)
{
    double sp = 0, ss = 0, st = 0;
    int count = 0;
    char err[1024];
    for (int i = 0; i < n; i += (int)every) {
        const cn_view *v = &views[i];
        const size_t npx = (size_t)v->w * v->h;
        float *rgb = malloc(sizeof(float) * 3 * npx);
        cn_camera cam;
        cn_view_camera(v, &cam);
        const double t0 = cli_now();
        if (!rgb || cn_render_view(m, &cam, ndc, rgb, 4096)) {
            free(rgb);
            return cli_fail("eval", "out of memory rendering %s", v->name), -1;
        }
        const double dt = cli_now() - t0;
        const double psnr = cn_psnr_from_mse(cn_mse(rgb, v->rgb, 3 * npx));
        const double ssim = cn_ssim(rgb, v->rgb, v->w, v->h);
        if (!quiet) {
            printf("  %-16s psnr %6.2f dB  ssim %.4f  %.2f s\n", v->name, psnr, ssim, dt);
            fflush(stdout);
        }
        sp += psnr;
        ss += ssim;
        st += dt;
        count++;
        int bad = 0;
        if (outdir) {
            char path[4096];
            snprintf(path, sizeof path, "%s/%s.png", outdir, v->name);
            bad = cli_write_png(path, rgb, v->w, v->h, err, sizeof err);
        }
        free(rgb);
        if (bad)
            return cli_fail("eval", "%s", err), -1;
    }
    *mean_psnr = count ? sp / count : 0;
    *mean_ssim = count ? ss / count : 0;
    *secs = count ? st / count : 0;
    return count;
}

int cli_split_views(const char *cmd, const cn_dataset *ds, const char *dir, const char *split,
                    const cn_view **views, int *n)
{
    if (!strcmp(split, "test"))
        *views = ds->test, *n = ds->n_test;
    else if (!strcmp(split, "val"))
        *views = ds->val, *n = ds->n_val;
    else if (!strcmp(split, "train"))
        *views = ds->train, *n = ds->n_train;
    else
        return cli_fail(cmd, "unknown split '%s' (test, val, train)", split);
    if (*n == 0)
        return cli_fail(cmd, "%s: the %s split has no views", dir, split);
    return 0;
}

/* A stream starts with the format's magic; anything else is taken for a checkpoint. */
static int is_stream(const char *path)
{
    unsigned char m[4] = {0};
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    size_t n = fread(m, 1, 4, f);
    fclose(f);
    return n == 4 && m[0] == CNERF_MAGIC_0 && m[1] == CNERF_MAGIC_1 && m[2] == CNERF_MAGIC_2 &&
           m[3] == CNERF_MAGIC_3;
}

int cmd_eval(int argc, char **argv)
{
    const char *outdir = NULL, *split = "test", *pos[2];
    long downscale = 1, max_size = 0, every = 1, threads = 0, chunk = 4096, scene = -1;
    int black = 0, n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &outdir, 0, 0},
        {"--split", CLI_STR, &split, 0, 0},
        {"--downscale", CLI_LONG, &downscale, 1, 64},
        {"--max-size", CLI_LONG, &max_size, 1, 1 << 20},
        {"--every", CLI_LONG, &every, 1, 1e6},
        {"--threads", CLI_LONG, &threads, 1, 256},
        {"--black", CLI_FLAG, &black, 0, 0},
        {"--chunk", CLI_LONG, &chunk, 1, 1 << 20},
        {"--scene", CLI_LONG, &scene, 0, CNERF_MAX_SCENES - 1},
    };
    if (cli_parse("eval", EVAL_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos, 2,
                  &n_pos))
        return 2;
    if (n_pos != 2)
        return cli_usage("eval", "need a checkpoint or stream and a dataset directory\n%s",
                        EVAL_USAGE);
    cli_set_threads(threads);
    char err[1024];
    cn_model m;
    long step = -1;
    if (scene >= 0 && !is_stream(pos[0]))
        return cli_usage("eval", "--scene picks a scene of a stream; %s is a checkpoint", pos[0]);
    if (is_stream(pos[0])) {
        cli_stream st;
        if (cli_stream_open_scene("eval", pos[0], scene < 0 ? 0u : (unsigned)scene, &st, &m))
            return 1;
        cli_print_sizes(pos[0], &st);
        cli_stream_free(&st);
    } else if (cn_checkpoint_load_model(pos[0], &m, &step, err, sizeof err))
        return cli_fail("eval", "%s", err);
    cn_dataset ds;
    if (cli_load_dataset("eval", pos[1], downscale, max_size, black, 0, 0, -1, &ds)) {
        cn_model_free(&m);
        return 1;
    }
    const cn_view *views = NULL;
    int n = 0;
    int rc = cli_split_views("eval", &ds, pos[1], split, &views, &n);
    if (rc == 0 && outdir && cli_check_output_dir("eval", outdir, pos[1]))
        rc = 1;
    if (rc == 0 && outdir)
        rc = cli_make_dir("eval", outdir);
    if (rc == 0) {
        double psnr, ssim, secs;
        int count = cli_eval_views(&m, views, n, ds.ndc, every, outdir, 0, &psnr, &ssim, &secs);
        if (count < 0)
            rc = 1;
        else if (step >= 0)
            printf("mean over %d %s views (iteration %ld): psnr %.2f dB  ssim %.4f  %.2f s/view\n",
                   count, split, step, psnr, ssim, secs);
        else
            printf("mean over %d %s views (stream): psnr %.2f dB  ssim %.4f  %.2f s/view\n", count,
                   split, psnr, ssim, secs);
    }
    cn_dataset_free(&ds);
    cn_model_free(&m);
    return rc;
}
