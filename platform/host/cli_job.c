/* Running a training as a job: progress, checkpoints, evaluations, the stop signals (Ctrl-C,
 * SIGTERM, SIGHUP) and the validation report; shared by train and encode. */
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "cn_metrics.h"
#include "cn_train.h"
#include "progress.h"

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
    /* A signal the caller ignores stays ignored (nohup sets SIGHUP to SIG_IGN on purpose,
     * and an exec keeps it): it is neither taken nor handled. */
    sigemptyset(&g->set);
    for (size_t i = 0; i < N_STOP_SIGNALS; i++) {
        sigaction(stop_signals[i], NULL, &g->old_action[i]);
        if (g->old_action[i].sa_handler != SIG_IGN)
            sigaddset(&g->set, stop_signals[i]);
    }
    interrupted = 0;
    pthread_sigmask(SIG_BLOCK, &g->set, &g->old_mask);
#pragma omp parallel
    pthread_sigmask(SIG_BLOCK, &g->set, NULL);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal;
    for (size_t i = 0; i < N_STOP_SIGNALS; i++)
        if (sigismember(&g->set, stop_signals[i]))
            sigaction(stop_signals[i], &sa, NULL);
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
