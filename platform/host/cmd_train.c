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
    "       [--downscale F|--max-size N] [--threads T] [--seed S] [--resume] [--batch R] [--depth D]\n"     \
    "       [--width W] [--view-width V] [--coarse N] [--fine N] [--lr X] [--precrop-iters N] [--black]\n"     \
    "       [--near X] [--far X] [--ckpt-every N | --ckpt-secs S] [--log-every N] [--occupancy G]\n"     \
    "       [--eval-every N] [--every K]\n"                                              \
    "       [--occupancy-start N] [--skip-saturated EPS] [--random-bg auto|on|off]\n"    \
    "       [--background constant|contract]\n"                                          \
    "       [--group-penalty MU] [--train-images DIR] [--val-views N]"

/* Stopping a training: Ctrl-C (SIGINT), and SIGTERM and SIGHUP as schedulers, service
 * managers and closed terminals send them. The loop stops after the current iteration, saves
 * and the command exits with 128 + the signal's number.
 *
 * No signal handler may run on a thread that is inside a matrix product: oneDNN's x64 GEMM
 * kernels (before its 3.11.2; Debian 12 has 2.6.3) point the stack pointer into a heap
 * workspace while they run, and a handler's frame written there corrupts the heap (glibc
 * aborts at a later malloc or free: "corrupted size vs. prev_size while consolidating").
 * So the three signals are blocked in the calling thread and in every thread of OpenMP's
 * pool, whose threads run the products (a thread created later inherits the mask), and are
 * taken with sigtimedwait between iterations. The handler stays for threads outside that pool
 * (OpenBLAS's own, in a -DCNERF_GEMM=openblas build, whose kernels keep their stack). The
 * guard lasts until the final checkpoint is written, so a second signal does not lose it,
 * and on to the exit of a stopped command. */
static const int stop_signals[] = {SIGINT, SIGTERM, SIGHUP};
#define N_STOP_SIGNALS (sizeof stop_signals / sizeof stop_signals[0])
static volatile sig_atomic_t interrupted; /* the first stop signal taken, 0 if none */
static void on_stop_signal(int sig)
{
    if (!interrupted)
        interrupted = sig;
}

typedef struct sigint_guard {
    struct sigaction old_action[N_STOP_SIGNALS];
    sigset_t set, old_mask;
} sigint_guard;

static void sigint_guard_begin(sigint_guard *g)
{
    sigemptyset(&g->set);
    for (size_t i = 0; i < N_STOP_SIGNALS; i++)
        sigaddset(&g->set, stop_signals[i]);
    interrupted = 0;
    pthread_sigmask(SIG_BLOCK, &g->set, &g->old_mask);
#pragma omp parallel
    pthread_sigmask(SIG_BLOCK, &g->set, NULL);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal;
    for (size_t i = 0; i < N_STOP_SIGNALS; i++)
        sigaction(stop_signals[i], &sa, &g->old_action[i]);
}

/* The stop signal taken so far (SIGINT, SIGTERM or SIGHUP), 0 if none. */
static int sigint_seen(const sigint_guard *g)
{
    const struct timespec now = {0, 0};
    int sig;
    while ((sig = sigtimedwait(&g->set, NULL, &now)) > 0)
        if (!interrupted)
            interrupted = sig;
    return interrupted;
}

/* Restores the caller's mask and handlers. The pool's threads keep the signals blocked: they
 * go to the caller's thread from then on. */
static void sigint_guard_end(sigint_guard *g)
{
    pthread_sigmask(SIG_SETMASK, &g->old_mask, NULL);
    for (size_t i = 0; i < N_STOP_SIGNALS; i++)
        sigaction(stop_signals[i], &g->old_action[i], NULL);
}

const char *cli_signal_name(int sig)
{
    return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : sig == SIGHUP ? "SIGHUP" : "a signal";
}

int cli_load_dataset(const char *cmd, const char *dir, long downscale, long max_size, int black,
                     double near, double far, long val_views, cn_dataset *ds)
{
    if (max_size > 0 && downscale > 1)
        return cli_fail(cmd, "give --downscale or --max-size, not both");
    cn_dataset_opts o;
    memset(&o, 0, sizeof o);
    o.downscale = (int)downscale;
    o.max_size = (int)max_size;
    o.black_bg = black;
    o.near = near;
    o.far = far;
    char err[1024];
    if (cn_dataset_load(dir, &o, ds, err, sizeof err))
        return cli_fail(cmd, "%s", err);
    if (ds->n_skipped == 1)
        fprintf(stderr, "cnerf %s: warning: %s, frame skipped\n", cmd, ds->skipped);
    else if (ds->n_skipped > 1)
        fprintf(stderr, "cnerf %s: warning: %d frames skipped for a missing image, the first: %s\n",
                cmd, ds->n_skipped, ds->skipped);
    const int held = cn_dataset_hold_out(ds, (int)val_views, err, sizeof err);
    if (held < 0) {
        cn_dataset_free(ds);
        return cli_fail(cmd, "%s", err);
    }
    if (max_size > 0) {
        const cn_view *v = ds->n_train ? ds->train : ds->n_test ? ds->test : ds->val;
        printf("--max-size %ld: downscale %d, views %dx%d\n", max_size, ds->downscale,
               v ? v->w : 0, v ? v->h : 0);
    }
    return 0;
}

int cli_random_bg(const char *cmd, const char *word, int *random_bg)
{
    static const char *const words[] = {"off", "on", "auto"};
    for (int i = 0; i < 3; i++)
        if (!strcmp(word, words[i])) {
            *random_bg = i == 2 ? -1 : i;
            return 0;
        }
    return cli_usage(cmd, "--random-bg takes auto, on or off, not '%s'", word);
}

int cli_background(const char *cmd, const char *word, int *contract)
{
    if (!strcmp(word, "constant") || !strcmp(word, "contract")) {
        *contract = !strcmp(word, "contract");
        return 0;
    }
    return cli_usage(cmd, "--background takes constant or contract, not '%s'", word);
}

int cli_coarse_color(const char *cmd, const char *word, double weight, cn_train_opts *o)
{
    if (strcmp(word, "on") && strcmp(word, "off"))
        return cli_usage(cmd, "--coarse-color takes off (the default: the fine network "
                         "gives every pixel's colour, so the coarse one's is not sent) or on "
                         "(sent, for renders with --fine 0), not '%s'", word);
    o->coarse_color = !strcmp(word, "on");
    /* The coarse image is not shown: its error only has to teach the coarse density, and a
     * tenth of the fine error's weight leaves the rate for the fine network (measured in
     * docs/results.md, "At convergence"). */
    o->coarse_weight = weight > 0 ? weight : o->coarse_color ? 1.0 : 0.1;
    return 0;
}

void cli_say_random_bg(const cn_trainer *t)
{
    int clear = 0;
    for (int i = 0; i < t->ds->n_train; i++)
        clear += t->ds->train[i].alpha != NULL;
    if (t->opts.random_bg)
        printf("random backgrounds: %d of %d training views have transparency\n", clear,
               t->ds->n_train);
    else if (clear)
        printf("constant background: %d of %d training views have transparency\n", clear,
               t->ds->n_train);
}

/* The test PSNR of the model being trained; returns the seconds it took, or -1. */
static double eval_now(cn_trainer *t, long every, double trained)
{
    const double t0 = cli_now();
    double psnr, ssim, secs;
    cn_model_materialize(&t->model); /* the kernels of the latest step's parameters */
    const int n = cli_eval_views(&t->model, t->ds->test, t->ds->n_test, t->ds->ndc, every, NULL,
                                 1, &psnr, &ssim, &secs);
    if (n < 0)
        return -1;
    if (n > 0)
        printf("eval: iteration %ld, training %.1f s, test psnr %.2f dB, ssim %.4f, %d views\n",
               t->step, trained, psnr, ssim, n);
    fflush(stdout);
    return cli_now() - t0;
}

int cli_resume(const char *cmd, cn_trainer *t, const char *path)
{
    char err[1024];
    if (cn_checkpoint_resume(t, path, err, sizeof err))
        return cli_fail(cmd, "%s", err);
    const int rebuilt = t->opts.occ_grid > 0 && t->step > t->opts.occ_start && !t->occ[0].valid;
    printf("resumed %s at iteration %ld%s\n", path, t->step,
           rebuilt ? " (occupancy grids rebuilt from the model: the checkpoint has none of "
                     "this size)" : "");
    return 0;
}

int cli_run_job(const char *cmd, const cli_job *job, const char *ckpt, long ckpt_every,
                double ckpt_secs, long log_every, long eval_every, long every, int *stopped)
{
    char err[1024];
    int rc = 0;
    *stopped = 0;
    if (job->done(job->ctx) >= job->iters) { /* a resumed checkpoint that is already done */
        printf("%s is at iteration %ld of %ld: nothing to train\n", ckpt, job->done(job->ctx),
               job->iters);
        return 0;
    }
    sigint_guard guard;
    sigint_guard_begin(&guard);
    cli_progress p;
    cli_progress_init(&p, job->done(job->ctx), job->iters, log_every);
    double psnr = 0;
    const double t0 = cli_now();
    const long first = job->done(job->ctx);
    double eval_secs = 0; /* time spent on evaluations, left out of the training time */
    double last_save = t0;  /* with ckpt_every 0: a checkpoint each ckpt_secs of training */
    while (rc == 0 && job->done(job->ctx) < job->iters && !sigint_seen(&guard)) {
        char extra[160] = "";
        const double loss = job->step(job->ctx, &psnr, extra, sizeof extra, err, sizeof err);
        if (isnan(loss) && err[0]) {
            cli_progress_break(&p);
            rc = cli_fail(cmd, "%s", err);
            break;
        }
        const long it = job->done(job->ctx);
        cli_progress_update(&p, it, loss, psnr, extra);
        const int due = ckpt_every > 0 ? it % ckpt_every == 0 : cli_now() - last_save >= ckpt_secs;
        if (due && it < job->iters) {
            if (job->save(job->ctx, ckpt, err, sizeof err))
                rc = cli_fail(cmd, "%s", err);
            last_save = cli_now();
        }
        if (rc == 0 && eval_every > 0 && job->eval && (it % eval_every == 0 || it == job->iters)) {
            cli_progress_break(&p);
            const double s = job->eval(job->ctx, every, cli_now() - t0 - eval_secs);
            if (s < 0)
                rc = 1;
            eval_secs += s;
            cli_progress_pause(&p, s);
        }
    }
    cli_progress_done(&p);
    if (rc == 0 && job->save(job->ctx, ckpt, err, sizeof err))
        rc = cli_fail(cmd, "%s", err);
    *stopped = sigint_seen(&guard); /* a signal during the save stops the command too */
    if (rc == 0) {
        const double el = cli_now() - t0 - eval_secs;
        const long it = job->done(job->ctx);
        if (*stopped)
            printf("interrupted by %s: ", cli_signal_name(*stopped));
        printf("saved %s at iteration %ld: %.1f s, %.3f s/it, train psnr %.2f dB\n", ckpt, it,
               el, it > first ? el / (double)(it - first) : 0.0, psnr);
    }
    /* A stopped command exits next, and takes any further signal until then; a finished
     * run gives the signals back their default meaning for the work after training. */
    if (!*stopped && rc == 0)
        sigint_guard_end(&guard);
    return rc;
}

/* ---- a trainer as a job ---- */

static long trainer_done(void *ctx) { return ((cn_trainer *)ctx)->step; }

static double trainer_step(void *ctx, double *psnr, char *extra, size_t n, char *err,
                           size_t errlen)
{
    cn_trainer *t = ctx;
    double mse = 0, bits = 0;
    const double loss = cn_trainer_step(t, &mse, &bits);
    if (isnan(loss) && t->err[0]) {
        snprintf(err, errlen, "%s", t->err);
        return loss;
    }
    err[0] = 0;
    *psnr = cn_psnr_from_mse(mse);
    if (t->rate_control && t->rc.first > 0)
        snprintf(extra, n, "  size %.2f kB, plan %.2f, target %.2f, lambda %.3g",
                 (t->rc.size + t->rc.reserved) / 1000.0, (t->rc.plan + t->rc.reserved) / 1000.0,
                 t->rc.target / 1000.0, t->opts.lambda);
    else if (t->model.compressed && t->opts.quality_slope > 0)
        snprintf(extra, n, "  rate %.1f kB, lambda %.3g", bits / 8000.0, t->opts.lambda);
    else if (t->model.compressed)
        snprintf(extra, n, "  rate %.1f kB", bits / 8000.0);
    else
        extra[0] = 0;
    size_t k = strlen(extra);
    if (t->occ[0].valid && k < n)
        snprintf(extra + k, n - k, "  occupied %.0f%%",
                 100.0 * t->occ_frac[t->model.topo.n_nets - 1]);
    k = strlen(extra);
    if (!isnan(t->val_psnr) && k < n)
        snprintf(extra + k, n - k, "  val %.2f dB", t->val_psnr);
    return loss;
}

static int trainer_save(void *ctx, const char *path, char *err, size_t errlen)
{
    return cn_checkpoint_save(ctx, path, err, errlen);
}

static double trainer_eval(void *ctx, long every, double trained)
{
    return eval_now(ctx, every, trained);
}

int cli_run_training(const char *cmd, cn_trainer *t, const char *ckpt, long ckpt_every,
                     double ckpt_secs, long log_every, long eval_every, long every, int *stopped)
{
    const cli_job job = {t, t->opts.iters, trainer_done, trainer_step, trainer_save,
                         trainer_eval};
    int rc = cli_run_job(cmd, &job, ckpt, ckpt_every, ckpt_secs, log_every, eval_every, every,
                         stopped);
    if (rc == 0 && !*stopped)
        rc = cli_report_validation(cmd, t);
    return rc;
}

int cli_report_validation(const char *cmd, cn_trainer *t)
{
    if (t->val_rays.n == 0) {
        printf("validation: none (%d training views; fewer than %d are all trained on)\n",
               t->ds->n_train, CN_VAL_MIN_TRAIN);
        return 0;
    }
    if (t->val_step != t->step && cn_trainer_validate(t))
        return cli_fail(cmd, "out of memory for validation");
    const double gap = t->fit_psnr - t->val_psnr;
    printf("validation: psnr %.2f dB on %d held-out views, %.2f dB on the training views "
           "(%zu fixed rays each)\n", t->val_psnr, t->ds->n_val, t->fit_psnr, t->val_rays.n);
    if (gap > CN_VAL_GAP_DB)
        fprintf(stderr, "cnerf %s: warning: the model does not generalize: %.1f dB better on "
                "its training views than on views it did not see (more than %.0f dB); the "
                "capture may have too few views or bad poses, or the model reproduces each "
                "view without the scene's geometry (try --preset tiny)\n", cmd, gap,
                CN_VAL_GAP_DB);
    return 0;
}

int cmd_train(int argc, char **argv)
{
    cn_train_opts o;
    cn_train_defaults(&o);
    const char *out = NULL, *pos[1], *random_bg = "auto", *background = "constant", *train_images = NULL;
    long iters = o.iters, downscale = 1, max_size = 0, threads = 0, batch = o.batch, depth = -1, width = -1;
    long view_width = -1;
    long coarse = -1, fine = -1, precrop = -1, ckpt_every = 0, log_every = 100;
    double ckpt_secs = CLI_CKPT_SECS;
    long eval_every = 0, every = 1, val_views = -1;
    long occ = o.occ_grid, occ_start = o.occ_start;
    double lr = o.lr, near = 0, far = 0;
    uint64_t seed = o.seed;
    int resume = 0, black = 0, n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &out, 0, 0},
        {"--preset", CLI_STR, &o.preset, 0, 0},
        {"--iters", CLI_LONG, &iters, 0, 1e9},
        {"--downscale", CLI_LONG, &downscale, 1, 64},
        {"--max-size", CLI_LONG, &max_size, 1, 1 << 20},
        {"--threads", CLI_LONG, &threads, 1, 256},
        {"--seed", CLI_U64, &seed, 0, 0},
        {"--resume", CLI_FLAG, &resume, 0, 0},
        {"--batch", CLI_LONG, &batch, 1, 65536},
        {"--depth", CLI_LONG, &depth, 1, CNERF_MAX_DEPTH},
        {"--width", CLI_LONG, &width, 1, CNERF_MAX_WIDTH},
        {"--view-width", CLI_LONG, &view_width, 0, CNERF_MAX_VIEW_WIDTH},
        {"--coarse", CLI_LONG, &coarse, 1, CNERF_MAX_SAMPLES},
        {"--fine", CLI_LONG, &fine, 0, CNERF_MAX_SAMPLES},
        {"--lr", CLI_DOUBLE, &lr, 1e-8, 1},
        {"--lr-decay", CLI_DOUBLE, &o.lr_decay_steps, 1, 1e12},
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
    if (cli_check_output("train", out, NULL, 0, pos[0]))
        return 1;
    char lock[4200];
    const int lk = cli_lock_output("train", out, lock, sizeof lock);
    if (lk < 0)
        return 1;
    cn_dataset ds;
    if (cli_load_dataset("train", pos[0], downscale, max_size, black, near, far, val_views, &ds)) {
        cli_unlock_output(lk, lock);
        return 1;
    }
    if (train_images && cli_replace_views("train", ds.train, ds.n_train, train_images)) {
        cn_dataset_free(&ds);
        cli_unlock_output(lk, lock);
        return 1;
    }
    printf("dataset %s: %d train, %d val, %d test views, %dx%d, %s\n", pos[0], ds.n_train,
           ds.n_val, ds.n_test, ds.train[0].w, ds.train[0].h,
           ds.ndc ? "forward-facing (NDC)" : "360 degrees");
    if (train_images)
        printf("training views: the %d images in %s instead of the dataset's\n", ds.n_train,
               train_images);
    char err[1024];
    cn_trainer t;
    if (cn_trainer_init(&t, &ds, &o, err, sizeof err)) {
        cn_dataset_free(&ds);
        cli_unlock_output(lk, lock);
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
    if (rc == 0)
        rc = cli_run_training("train", &t, out, ckpt_every, ckpt_secs, log_every, eval_every,
                              every, &stopped);
    cn_trainer_free(&t);
    cn_dataset_free(&ds);
    cli_unlock_output(lk, lock);
    return rc ? rc : stopped ? 128 + stopped : 0;
}
