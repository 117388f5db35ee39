/* cnerf train DATASET -o model.ckpt: trains the float NeRF. */
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "cli_args.h"
#include "cn_metrics.h"
#include "cn_train.h"
#include "progress.h"

#define TRAIN_USAGE                                                                            \
    "usage: cnerf train DATASET -o model.ckpt [--preset tiny|small|paper] [--iters N]\n"       \
    "       [--downscale F|--max-size N] [--threads T] [--seed S] [--resume | --force] [--batch R] [--depth D]\n"     \
    "       [--width W] [--view-width V] [--coarse N] [--fine N] [--lr X] [--precrop-iters N] [--black]\n"     \
    "       [--near X] [--far X] [--ckpt-every N | --ckpt-secs S] [--log-every N] [--occupancy G]\n"     \
    "       [--eval-every N] [--every K] [--lr-decay N] [--lr-warmup N]\n"                                            \
    "       [--occupancy-start N] [--skip-saturated EPS] [--random-bg auto|on|off]\n"    \
    "       [--background auto|constant|contract]\n"                                          \
    "       [--group-penalty MU] [--train-images DIR] [--val-views N]"


int cmd_train(int argc, char **argv)
{
    cn_train_opts o;
    cn_train_defaults(&o);
    const char *out = NULL, *pos[1], *random_bg = "auto", *background = "auto", *train_images = NULL;
    long iters = o.iters, downscale = 1, max_size = 0, threads = 0, batch = o.batch, depth = -1, width = -1;
    long view_width = -1;
    long coarse = -1, fine = -1, precrop = -1, ckpt_every = 0, log_every = 100;
    double ckpt_secs = CLI_CKPT_SECS;
    long eval_every = 0, every = 1, val_views = -1;
    long occ = o.occ_grid, occ_start = o.occ_start;
    double lr = o.lr, near = 0, far = 0;
    uint64_t seed = o.seed;
    int resume = 0, force = 0, black = 0, n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &out, 0, 0},
        {"--preset", CLI_STR, &o.preset, 0, 0},
        {"--iters", CLI_LONG, &iters, 0, 1e9},
        {"--downscale", CLI_LONG, &downscale, 1, 64},
        {"--max-size", CLI_LONG, &max_size, 1, 1 << 20},
        {"--threads", CLI_LONG, &threads, 1, 256},
        {"--seed", CLI_U64, &seed, 0, 0},
        {"--resume", CLI_FLAG, &resume, 0, 0},
        {"--force", CLI_FLAG, &force, 0, 0},
        {"--batch", CLI_LONG, &batch, 1, 65536},
        {"--depth", CLI_LONG, &depth, 1, CNERF_MAX_DEPTH},
        {"--width", CLI_LONG, &width, 1, CNERF_MAX_WIDTH},
        {"--view-width", CLI_LONG, &view_width, 0, CNERF_MAX_VIEW_WIDTH},
        {"--coarse", CLI_LONG, &coarse, 1, CNERF_MAX_SAMPLES},
        {"--fine", CLI_LONG, &fine, 0, CNERF_MAX_SAMPLES},
        {"--lr", CLI_DOUBLE, &lr, 1e-8, 1},
        {"--lr-decay", CLI_DOUBLE, &o.lr_decay_steps, 1, 1e12},
        {"--lr-warmup", CLI_LONG, &o.lr_warmup, 0, 1000000},
        {"--precrop-iters", CLI_LONG, &precrop, 0, 1e9},
        {"--black", CLI_FLAG, &black, 0, 0},
        {"--near", CLI_DOUBLE, &near, 1e-6, 1e4},
        {"--far", CLI_DOUBLE, &far, 1e-6, 1e4},
        {"--ckpt-every", CLI_LONG, &ckpt_every, 1, 1e9},
        {"--ckpt-secs", CLI_DOUBLE, &ckpt_secs, 1, 1e6},
        {"--log-every", CLI_LONG, &log_every, 1, 1e9},
        {"--eval-every", CLI_LONG, &eval_every, 0, 1e9},
        {"--val-views", CLI_LONG, &val_views, 0, 1e6},
        {"--every", CLI_LONG, &every, 1, 1e6},
        {"--occupancy", CLI_LONG, &occ, 0, 256},
        {"--occupancy-start", CLI_LONG, &occ_start, 0, 1e9},
        {"--skip-saturated", CLI_DOUBLE, &o.sat_eps, 0, 1},
        {"--group-penalty", CLI_DOUBLE, &o.group, 0, 1000},
        {"--random-bg", CLI_STR, &random_bg, 0, 0},
        {"--background", CLI_STR, &background, 0, 0},
        {"--train-images", CLI_STR, &train_images, 0, 0},
    };
    if (cli_parse("train", TRAIN_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos, 1,
                  &n_pos))
        return 2;
    if (n_pos != 1 || !out)
        return cli_usage("train", "need a dataset directory and -o FILE\n%s", TRAIN_USAGE);
    if (cli_background("train", background, &o.contract))
        return 2;
    if (cli_random_bg("train", random_bg, &o.random_bg))
        return 2;
    if (iters == 0 && !resume)
        return cli_usage("train", "--iters 0 trains nothing: give at least 1, or --resume a "
                         "checkpoint");
    if (resume && force)
        return cli_usage("train", CLI_RESUME_OR_FORCE);
    cli_set_threads(threads);
    o.iters = iters;
    o.seed = seed;
    o.batch = (int)batch;
    o.depth = (int)depth;
    o.width = (int)width;
    o.view_width = (int)view_width;
    o.n_coarse = (int)coarse;
    o.n_fine = (int)fine;
    o.lr = lr;
    if (precrop >= 0)
        o.precrop_iters = precrop;
    o.occ_grid = (int)occ;
    o.occ_start = occ_start;
    const char *inputs[1] = {train_images};
    if (cli_check_output("train", out, inputs, 1, pos[0]))
        return 1;
    cli_locks locks;
    const char *written[2] = {out, NULL};
    if (cli_lock_outputs("train", written, 2, &locks))
        return 1;
    if (!resume && !force && cli_check_fresh("train", out, "--resume")) {
        cli_unlock_outputs(&locks);
        return 1;
    }
    /* What a stop signal before training leaves: nothing new, and a checkpoint to resume as
     * it was. */
    const char *resumed = resume && access(out, F_OK) == 0 ? out : NULL;
    cli_stop_before("load", "while loading the dataset", resumed);
    cn_dataset ds;
    if (cli_load_dataset("train", pos[0], downscale, max_size, black, near, far, val_views, every,
                         0, &ds)) {
        cli_unlock_outputs(&locks);
        return 1;
    }
    if (train_images && cli_replace_views("train", ds.train, ds.n_train, train_images)) {
        cn_dataset_free(&ds);
        cli_unlock_outputs(&locks);
        return 1;
    }
    printf("dataset %s: %d train, %d val, %d test views, %dx%d, %s\n", pos[0], ds.n_train,
           ds.n_val, ds.n_test_listed, ds.train[0].w, ds.train[0].h,
           ds.ndc ? "forward-facing (NDC)" : "360 degrees");
    if (train_images)
        printf("training views: the %d images in %s instead of the dataset's\n", ds.n_train,
               train_images);
    cli_auto_background(&ds, 1, &o.contract);
    cli_stop_before("start", "before training", resumed);
    char err[1024];
    cn_trainer t;
    if (cn_trainer_init(&t, &ds, &o, err, sizeof err)) {
        cn_dataset_free(&ds);
        cli_unlock_outputs(&locks);
        return cli_fail("train", "%s", err);
    }
    cli_say_random_bg(&t);
    int rc = 0;
    if (resume && access(out, F_OK) == 0)
        rc = cli_resume("train", &t, out);
    const cnerf_info *T = &t.model.topo;
    if (rc == 0)
        printf("model: %u networks, depth %u, width %u, %u+%u samples, %zu parameters\n",
               T->n_nets, T->net[0].depth, T->net[0].width, T->n_coarse, T->n_fine,
               t.model.n_params);
    int stopped = 0;
    char after[4400];
    snprintf(after, sizeof after, "the model is complete, its validation not measured (cnerf "
             "eval %s %s measures it)", out, pos[0]);
    if (rc == 0)
        rc = cli_run_training("train", &t, out, ckpt_every, ckpt_secs, log_every, eval_every,
                              after, &stopped);
    cn_trainer_free(&t);
    cn_dataset_free(&ds);
    cli_unlock_outputs(&locks);
    return rc ? rc : stopped ? 128 + stopped : 0;
}
