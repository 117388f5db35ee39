/* cnerf eval MODEL DATASET: renders a split with a checkpoint's model or with the float
 * reference model of a stream, and reports PSNR and SSIM. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "cn_file.h"
#include "cli_args.h"
#include "cn_image.h"
#include "cn_metrics.h"
#include "cn_train.h"
#include "progress.h"

#define EVAL_USAGE                                                                          \
    "usage: cnerf eval model.ckpt|scene.cnrf DATASET [--split test|val|train] [--downscale F|--max-size N]\n"      \
    "       [--every N] [-o DIR] [--threads T] [--black] [--chunk R] [--scene I]"

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
    /* Of a test split only the views rendered are read (the others are never held out). */
    const int test = !strcmp(split, "test");
    if (cli_load_dataset("eval", pos[1], downscale, max_size, black, 0, 0, -1, test ? every : 1,
                         test, &ds)) {
        cn_model_free(&m);
        return 1;
    }
    const cn_view *views = NULL;
    int n = 0;
    int rc = cli_split_views("eval", &ds, pos[1], split, &views, &n);
    if (rc == 0 && outdir && cn_input_add(pos[0], NULL))
        rc = cli_fail("eval", "out of memory recording the inputs");
    if (rc == 0 && outdir && cli_check_output_dir("eval", outdir, pos[1]))
        rc = 1;
    if (rc == 0 && outdir)
        rc = cli_make_dir("eval", outdir);
    rc = cli_mpi_agree(rc); /* over several ranks, each renders a share of the views */
    if (rc == 0) {
        double psnr, ssim, secs;
        int count = cli_eval_views(&m, views, n, ds.ndc, test ? 1 : every, outdir, 0, 0, &psnr,
                                   &ssim, &secs);
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
