/* Running a training as a job: progress, checkpoints, evaluations, the stop signals (Ctrl-C,
 * SIGTERM, SIGHUP) and the validation report; shared by train and encode. */
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "cn_file.h"
#include "cn_metrics.h"
#include "cn_train.h"
#include "progress.h"

/* Stopping a run: Ctrl-C (SIGINT), and SIGTERM and SIGHUP as schedulers, service managers
 * and closed terminals send them. Inside the training loop a signal stops it after the
 * current iteration, the checkpoint is saved and the command exits with 128 + the signal's
 * number. In every other phase of a run (loading, setting up, the work after training) the
 * run stops at once, with one line that says what was saved and what was not (the phase's,
 * cli_stop_phase), its locks and unfinished temporaries removed.
 *
 * No signal handler may run on a thread that is inside a matrix product: oneDNN's x64 GEMM
 * kernels (before its 3.11.2; Debian 12 has 2.6.3) point the stack pointer into a heap
 * workspace while they run, and a handler's frame written there corrupts the heap (glibc
 * aborts at a later malloc or free: "corrupted size vs. prev_size while consolidating").
 * So from the moment a run holds its locks the signals are blocked in the calling thread and
 * in every thread of OpenMP's pool, whose threads run the products (a thread created later
 * inherits the mask), and one watcher thread takes them with sigwait. A handler stays for
 * threads outside that pool (OpenBLAS's own, in a -DCNERF_GEMM=openblas build, whose kernels
 * keep their stack): it passes the signal on to the watcher. A signal the caller ignores
 * (nohup's SIGHUP, a script's background job's SIGINT) stays ignored. */
static const int stop_signals[] = {SIGINT, SIGTERM, SIGHUP};
#define N_STOP_SIGNALS (sizeof stop_signals / sizeof stop_signals[0])
static volatile sig_atomic_t interrupted; /* the first stop signal the loop took, 0 if none */
static struct {
    pthread_mutex_t mu;
    pthread_t watcher;
    int started;
    sigset_t set;
    int defer;            /* 1: a signal is only recorded in `interrupted` (the loop's) */
    char line[8400];      /* the phase's line after "interrupted by SIGxxx " */
    int n_locks;
    char locks[CLI_MAX_LOCKS][4200];
} stop = {.mu = PTHREAD_MUTEX_INITIALIZER};

/* Prints the phase's line, removes the locks and this process's temporaries, exits. Runs on
 * the watcher (or on the caller, holding stop.mu), never inside a signal handler, but another
 * thread may hold stdout's lock: the line goes out with write(). */
static void stop_now(int sig)
{
    char msg[8600];
    const int n = snprintf(msg, sizeof msg, "interrupted by %s %s\n", cli_signal_name(sig),
                           stop.line);
    if (n > 0) {
        size_t left = (size_t)n < sizeof msg ? (size_t)n : sizeof msg - 1;
        const char *p = msg;
        while (left) {
            const ssize_t w = write(STDOUT_FILENO, p, left);
            if (w <= 0)
                break;
            p += w;
            left -= (size_t)w;
        }
    }
    for (int i = 0; i < stop.n_locks; i++)
        cn_lock_abandon(stop.locks[i]);
    _exit(128 + sig);
}

static void *stop_watch(void *arg)
{
    (void)arg;
    for (;;) {
        int sig;
        if (sigwait(&stop.set, &sig) != 0)
            continue;
        pthread_mutex_lock(&stop.mu);
        if (!stop.defer)
            stop_now(sig);
        if (!interrupted)
            interrupted = sig;
        pthread_mutex_unlock(&stop.mu);
    }
    return NULL;
}

static void pass_to_watcher(int sig)
{
    pthread_kill(stop.watcher, sig);
}

void cli_stop_watch(const cli_locks *L)
{
    pthread_mutex_lock(&stop.mu);
    stop.n_locks = 0;
    for (int i = 0; i < L->n; i++)
        snprintf(stop.locks[stop.n_locks++], sizeof stop.locks[0], "%s", L->path[i]);
    snprintf(stop.line, sizeof stop.line, "while starting: nothing saved");
    stop.defer = 0;
    if (!stop.started) {
        sigemptyset(&stop.set);
        for (size_t i = 0; i < N_STOP_SIGNALS; i++) {
            struct sigaction old;
            sigaction(stop_signals[i], NULL, &old);
            if (old.sa_handler != SIG_IGN)
                sigaddset(&stop.set, stop_signals[i]);
        }
        pthread_sigmask(SIG_BLOCK, &stop.set, NULL);
#pragma omp parallel
        pthread_sigmask(SIG_BLOCK, &stop.set, NULL);
        stop.started = pthread_create(&stop.watcher, NULL, stop_watch, NULL) == 0;
        if (stop.started) {
            struct sigaction sa;
            memset(&sa, 0, sizeof sa);
            sa.sa_handler = pass_to_watcher;
            sigfillset(&sa.sa_mask);
            for (size_t i = 0; i < N_STOP_SIGNALS; i++)
                if (sigismember(&stop.set, stop_signals[i]))
                    sigaction(stop_signals[i], &sa, NULL);
        } else { /* no watcher: the signals keep their default meaning */
            pthread_sigmask(SIG_UNBLOCK, &stop.set, NULL);
        }
    }
    pthread_mutex_unlock(&stop.mu);
}

/* The phase's test hook: CNERF_TEST_TERM_AT=NAME sends SIGTERM to the process as it enters
 * the phase NAME and waits there (up to 10 s) for the watcher to end the run, so that a test
 * sees exactly that phase's stop. (A signal sent from outside while the process was stopped
 * there raced the watcher: the calling thread could go on into the next phase first.) */
static void stop_test_hook(const char *name)
{
    const char *at = getenv("CNERF_TEST_TERM_AT");
    if (!at || !name || strcmp(at, name) != 0)
        return;
    kill(getpid(), SIGTERM); /* to the process: the watcher takes it */
    const struct timespec ms = {0, 1000000};
    for (int i = 0; i < 10000; i++)
        nanosleep(&ms, NULL);
}

void cli_stop_phase(const char *name, const char *fmt, ...)
{
    pthread_mutex_lock(&stop.mu);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(stop.line, sizeof stop.line, fmt, ap);
    va_end(ap);
    stop.defer = 0;
    if (interrupted && stop.started) /* taken by the loop after its last look */
        stop_now(interrupted);
    pthread_mutex_unlock(&stop.mu);
    stop_test_hook(name);
}

void cli_stop_before(const char *name, const char *what, const char *resumed)
{
    cli_stop_phase(name, "%s: nothing saved%s%s%s; run the command again", what,
                   resumed ? " (" : "", resumed ? resumed : "", resumed ? " is as it was)" : "");
}

void cli_stop_unwatch(void)
{
    pthread_mutex_lock(&stop.mu);
    stop.defer = 1; /* the run has ended: what is left is the exit */
    stop.n_locks = 0;
    pthread_mutex_unlock(&stop.mu);
}

/* Inside the training loop: a signal is recorded, and the loop stops at it. */
static void stop_defer(void)
{
    pthread_mutex_lock(&stop.mu);
    stop.defer = 1;
    pthread_mutex_unlock(&stop.mu);
}

int cli_stop_signal(void) { return interrupted; }

/* cli_stop_shared: the loop stops when the ranks' vote says so (voted), not at this rank's
 * own signal. */
static int shared_run, voted;

void cli_stop_shared(int shared) { shared_run = shared; }

const char *cli_signal_name(int sig)
{
    return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : sig == SIGHUP ? "SIGHUP" : "a signal";
}
/* The test PSNR of the model being trained; returns the seconds it took, or -1. */
static double eval_now(cn_trainer *t, double trained)
{
    const double t0 = cli_now();
    double psnr, ssim, secs;
    cn_model_materialize(&t->model); /* the kernels of the latest step's parameters */
    const int n = cli_eval_views(&t->model, t->ds->test, t->ds->n_test, t->ds->ndc, 1, NULL,
                                 1, 0, &psnr, &ssim, &secs);
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
                double ckpt_secs, long log_every, long eval_every, int *stopped)
{
    char err[1024];
    int rc = 0;
    *stopped = 0;
    if (job->done(job->ctx) >= job->iters) { /* a resumed checkpoint that is already done */
        printf("%s is at iteration %ld of %ld: nothing to train\n", ckpt, job->done(job->ctx),
               job->iters);
        cli_stop_phase("after-training", "after training: saved %s at iteration %ld; %s", ckpt,
                       job->done(job->ctx), job->after ? job->after : "");
        return 0;
    }
    stop_defer();
    cli_progress p;
    cli_progress_init(&p, job->done(job->ctx), job->iters, log_every);
    double psnr = 0;
    const double t0 = cli_now();
    const long first = job->done(job->ctx);
    double eval_secs = 0; /* time spent on evaluations, left out of the training time */
    double last_save = t0;  /* with ckpt_every 0: a checkpoint each ckpt_secs of training */
    while (rc == 0 && job->done(job->ctx) < job->iters && !(shared_run ? voted : interrupted)) {
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
            const double s = job->eval(job->ctx, cli_now() - t0 - eval_secs);
            if (s < 0)
                rc = 1;
            eval_secs += s;
            cli_progress_pause(&p, s);
        }
    }
    cli_progress_done(&p);
    if (rc == 0 && job->save(job->ctx, ckpt, err, sizeof err))
        rc = cli_fail(cmd, "%s", err);
    *stopped = interrupted; /* a signal during the save stops the command too */
    if (rc == 0) {
        const double el = cli_now() - t0 - eval_secs;
        const long it = job->done(job->ctx);
        if (*stopped)
            printf("interrupted by %s: ", cli_signal_name(*stopped));
        printf("saved %s at iteration %ld: %.1f s, %.3f s/it, train psnr %.2f dB\n", ckpt, it,
               el, it > first ? el / (double)(it - first) : 0.0, psnr);
    }
    if (rc == 0 && !*stopped)
        cli_stop_phase("after-training", "after training: saved %s at iteration %ld; %s", ckpt,
                       job->done(job->ctx), job->after ? job->after : "");
    /* A stopped command exits next, and takes any further signal until then; a finished
     * run goes on to a phase of its own (cli_stop_phase). */
    if (*stopped)
        interrupted = 0;
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
    if (t->stop_votes > 0) { /* a rank took a signal: all stop after this step */
        voted = 1;
        if (!interrupted)
            interrupted = SIGTERM;
    }
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

static double trainer_eval(void *ctx, double trained)
{
    return eval_now(ctx, trained);
}

int cli_run_training(const char *cmd, cn_trainer *t, const char *ckpt, long ckpt_every,
                     double ckpt_secs, long log_every, long eval_every, const char *after,
                     int *stopped)
{
    const cli_job job = {t, t->opts.iters, trainer_done, trainer_step, trainer_save,
                         trainer_eval, after};
    int rc = cli_run_job(cmd, &job, ckpt, ckpt_every, ckpt_secs, log_every, eval_every, stopped);
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
           "(%zu fixed rays each); a flat colour %.2f dB\n", t->val_psnr, t->ds->n_val,
           t->fit_psnr, t->val_rays.n, t->flat_psnr);
    /* An encode to a size refuses fog itself (cmd_encode.c). */
    if (cn_trainer_fog(t) && !t->rate_control)
        fprintf(stderr, "cnerf %s: warning: the model has not found the scene: its validation "
                "PSNR %.2f dB is less than %.0f dB above a flat colour's %.2f dB (fog); try "
                "%smore --iters\n", cmd, t->val_psnr, CN_VAL_FOG_DB, t->flat_psnr,
                t->opts.preset && strcmp(t->opts.preset, "tiny") ? "--preset tiny or " : "");
    if (gap > CN_VAL_GAP_DB)
        fprintf(stderr, "cnerf %s: warning: the model does not generalize: %.1f dB better on "
                "its training views than on views it did not see (more than %.0f dB); the "
                "capture may have too few views or bad poses, or the model reproduces each "
                "view without the scene's geometry (try --preset tiny)\n", cmd, gap,
                CN_VAL_GAP_DB);
    return 0;
}
