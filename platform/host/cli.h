/* The cnerf host program: one function per subcommand. */
#ifndef CNERF_CLI_H
#define CNERF_CLI_H

#include <stddef.h>
#include <stdint.h>

#include "cnerf/cnerf.h"

struct cn_dataset;
struct cn_view;
struct cn_model;
struct cn_trainer;
struct cn_train_opts;
struct cn_share;

int cmd_info(int argc, char **argv);
int cmd_pack(int argc, char **argv);
int cmd_recode(int argc, char **argv);
int cmd_synth(int argc, char **argv);
int cmd_train(int argc, char **argv);
int cmd_eval(int argc, char **argv);
int cmd_encode(int argc, char **argv);
int cmd_quantize(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_views(int argc, char **argv);
int cmd_html(int argc, char **argv);

/* cnerf train --train-images DIR: replaces the pixels of views[0..n) with DIR/0000.png ...
 * (as `cnerf views` writes them, the same size), dropping their alpha. Returns 0, or 1 with
 * the message printed (a missing, mis-sized or extra file). */
int cli_replace_views(const char *cmd, struct cn_view *views, int n, const char *dir);
/* DIR/NNNN.png, the name of view i as `cnerf views` writes it. */
void cli_view_path(char *path, size_t len, const char *dir, int i);

/* Before any work: `path` can be created as a regular file (its directory exists and is
 * writable; an existing output must be a regular file, not a link, device or directory), is
 * not one of inputs[0..n) (NULL entries skipped) and does not lie inside `dataset` (NULL: no
 * dataset). Returns 0, or 1 with the message printed. */
int cli_check_output(const char *cmd, const char *path, const char *const *inputs,
                     size_t n_inputs, const char *dataset);
/* 1 with the message printed when the output `path` and the input `input` (NULL: none) are
 * one file: for an input that a run reads and may write again (a --resume checkpoint), which
 * cli_check_output would protect. */
int cli_check_not(const char *cmd, const char *path, const char *input);
/* Before a run that starts a new checkpoint at `ckpt` (held locked): 1 with the message
 * printed when a file is there already, a checkpoint (its iteration named, with `resume`, the
 * option that continues it) or any other non-empty file; --force is what replaces it. */
int cli_check_fresh(const char *cmd, const char *ckpt, const char *resume);
#define CLI_RESUME_OR_FORCE "--resume continues a checkpoint and --force replaces it: give one of them"
/* The same for an output directory (existing or to be made): not inside `dataset`. */
int cli_check_output_dir(const char *cmd, const char *dir, const char *dataset);

/* Takes an exclusive lock on PATH.lock for a command that writes PATH over a long run, so
 * that two runs never write one output (the kernel drops the lock if the process dies).
 * Returns the descriptor to give cli_unlock_output, or -1 with the message printed. */
int cli_lock_output(const char *cmd, const char *path, char lock[], size_t locklen);
void cli_unlock_output(int fd, const char *lock);
/* The locks of every file a run writes: paths[0..n) (NULL skipped, n <= CLI_MAX_LOCKS), each
 * PATH.lock. Returns 0, or 1 with the message printed and none held. */
#define CLI_MAX_LOCKS 2
typedef struct cli_locks {
    int n;
    int fd[CLI_MAX_LOCKS];
    char path[CLI_MAX_LOCKS][4200];
} cli_locks;
int cli_lock_outputs(const char *cmd, const char *const *paths, int n, cli_locks *L);
void cli_unlock_outputs(cli_locks *L);
/* The stop signals of a run that holds the locks L (cli_lock_outputs and cli_unlock_outputs
 * call these): from cli_stop_watch on, SIGINT, SIGTERM or SIGHUP (those the caller does not
 * ignore) stops the run at once, printing "interrupted by SIGxxx " and the line of the
 * current phase, removing the locks and the run's unfinished temporaries, and exiting with
 * 128 + the signal; inside the training loop (cli_run_job) it stops the loop instead. */
void cli_stop_watch(const cli_locks *L);
void cli_stop_unwatch(void);
/* Enters a phase: its line says what is saved and what is not if a signal stops the run in
 * it, and how to go on ("while loading the dataset: nothing saved"). `name` is the phase's
 * name for the test hook (CNERF_TEST_TERM_AT=name sends SIGTERM there), or NULL. */
void cli_stop_phase(const char *name, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* A phase before training: "WHAT: nothing saved (RESUMED is as it was); run the command
 * again", RESUMED being the checkpoint a resumed run reads (NULL: none). */
void cli_stop_before(const char *name, const char *what, const char *resumed);

/* Seconds of training between two checkpoints by default: what kill -9 can lose. */
#define CLI_CKPT_SECS 60.0

/* The training loop shared by train and encode: progress, atomic checkpoints to `ckpt` every
 * ckpt_every iterations (0: every ckpt_secs seconds) and at the end; SIGINT, SIGTERM or
 * SIGHUP saves and sets *stopped to the signal's number. With eval_every > 0, every
 * eval_every iterations (and after the last) renders the test views loaded (the dataset's
 * every `--every`-th: cli_load_dataset) and prints
 * "eval: iteration I, training S s, test psnr P dB, ssim Q, V views", S being the training
 * time so far without the evaluations. Returns 0 or 1 (error printed). */
int cli_run_training(const char *cmd, struct cn_trainer *t, const char *ckpt, long ckpt_every,
                     double ckpt_secs, long log_every, long eval_every, const char *after,
                     int *stopped);
/* Measures the trained model on its validation and training rays (cn_validate.h), prints
 * both PSNRs and warns on stderr when the training views beat the validation views by more
 * than CN_VAL_GAP_DB; cli_run_training calls it at the end of a run. 0 or 1 (error printed). */
int cli_report_validation(const char *cmd, struct cn_trainer *t);
/* The same loop for any training job: done() gives the iterations done, step() runs one and
 * returns the loss (NaN with a message in err on failure), the PSNR to show and the rest of
 * the progress line, save() writes the checkpoint, eval() (NULL: none) evaluates and returns
 * the seconds it took or -1. A run that ends enters the phase "after training: saved CKPT at
 * iteration N; " + after (what is not done yet, and how to go on: cli_stop_phase). */
typedef struct cli_job {
    void *ctx;
    long iters;
    long (*done)(void *ctx);
    double (*step)(void *ctx, double *psnr, char *extra, size_t n, char *err, size_t errlen);
    int (*save)(void *ctx, const char *path, char *err, size_t errlen);
    double (*eval)(void *ctx, double trained);
    const char *after;
} cli_job;
int cli_run_job(const char *cmd, const cli_job *job, const char *ckpt, long ckpt_every,
                double ckpt_secs, long log_every, long eval_every, int *stopped);
/* "SIGINT", "SIGTERM" or "SIGHUP". */
const char *cli_signal_name(int sig);
/* The stop signal this process took in the training loop, 0 if none. */
int cli_stop_signal(void);
/* shared = 1: the run's batches are shared among processes (cli_mpi.c). A stop signal then
 * ends the training loop only once the step's sum has carried it to every rank (cn_share's
 * vote), so that they all stop after the same step. */
void cli_stop_shared(int shared);
/* MPI (a -DCNERF_MPI=ON build): initialises it and, with several ranks, shares every
 * trainer's batches among them; ranks other than 0 write nothing and print nothing on stdout.
 * Returns 0, or -1 with a message (a command other than train and encode on several ranks).
 * Without MPI: nothing. */
int cli_mpi_init(int *argc, char ***argv);
/* The share of the batches and evaluations among the ranks (cn_train.h's cn_share), or NULL
 * with one process. */
const struct cn_share *cli_mpi_share(void);
/* rc, or 1 when any rank's rc is not 0 (every rank then goes the same way); rc without MPI. */
int cli_mpi_agree(int rc);
/* Ends MPI with the command's exit status rc (a failed rank ends every rank); returns rc. */
int cli_mpi_end(int rc);
/* Restores a checkpoint into t (cn_checkpoint_resume) and says so, noting when the
 * occupancy grids are rebuilt from the model rather than restored (a version 1 checkpoint,
 * or another --occupancy); returns 0 or 1 (error printed). */
int cli_resume(const char *cmd, struct cn_trainer *t, const char *path);
/* Renders every `every`-th of views[0..n) with the evaluation rule, each ray ending once its
 * transmittance is below t_stop (0: never; a stream's float reference passes the decoder's
 * default, CLI_T_STOP), prints PSNR, SSIM and time per view unless `quiet`, writes
 * OUTDIR/<name>.png when outdir is not NULL; returns the number of views (means in the
 * out-parameters) or -1 after printing the error. */
int cli_eval_views(const struct cn_model *m, const struct cn_view *views, int n, int ndc,
                   long every, const char *outdir, int quiet, float t_stop, double *mean_psnr,
                   double *mean_ssim, double *secs);
/* An orbit camera: view k of n on a circle of `radius` at `elev` degrees, looking at the
 * origin with the z axis up (Blender scenes), `size` pixels square with a field of view of
 * `fov` degrees. */
struct cn_camera;
void cli_orbit_camera(int k, int n, double radius, double elev, double fov, int size,
                      struct cn_camera *c);

/* The decoder's default t_stop as a fraction: the float reference of a stream ends its rays
 * there, as the fixed-point render does. */
#define CLI_T_STOP ((float)(CNERF_T_STOP_DEFAULT / 1073741824.0))

/* Loads a dataset with the shared options and holds out val_views of its training views
 * for validation (cn_dataset_hold_out; -1: the default rule, which every command applies
 * alike so that their splits agree); prints the error and returns 1 on failure. Of the
 * test views only every test_every-th is loaded (1: all; cn_dataset_opts), and with
 * test_only no others (nor is anything held out): ds->test[i] is then the test view
 * i * test_every of the dataset. */
int cli_load_dataset(const char *cmd, const char *dir, long downscale, long max_size, int black,
                     double near, double far, long val_views, long test_every, int test_only,
                     struct cn_dataset *ds);
/* --random-bg auto|on|off into cn_train_opts.random_bg (-1, 1, 0); prints the error and
 * returns 1 for another word. */
int cli_random_bg(const char *cmd, const char *word, int *random_bg);
/* --background auto|constant|contract into cn_train_opts.contract (-1, 0, 1); prints the
 * error and returns 2 for another word. */
int cli_background(const char *cmd, const char *word, int *contract);
/* --background auto (*contract < 0) decided on the n datasets loaded: contracted when every
 * training view is opaque (its photos show what lies beyond the object) and no scene is
 * forward-facing (NDC reaches to infinity already), else the constant colour; says which and
 * why. A background given (0 or 1) is kept. */
void cli_auto_background(const struct cn_dataset *ds, int n, int *contract);
/* encode's --coarse-color off|on and --coarse-weight W (weight <= 0: not given) into
 * cn_train_opts.coarse_color and .coarse_weight; prints the error and returns 2 for another
 * word. */
int cli_coarse_color(const char *cmd, const char *word, double weight,
                     struct cn_train_opts *o);
/* After cn_trainer_init: one line saying whether training draws random backgrounds, and
 * on how many of the training views (those with transparency). */
void cli_say_random_bg(const struct cn_trainer *t);
/* The views of a split ("test", "val" or "train"); prints the error and returns 1 for an
 * unknown or empty split. */
int cli_split_views(const char *cmd, const struct cn_dataset *ds, const char *dir,
                    const char *split, const struct cn_view **views, int *n);
/* Writes float RGB in [0, 1] as an 8-bit PNG (atomically). */
int cli_write_png(const char *path, const float *rgb, int w, int h, char *err, size_t errlen);
/* mkdir that accepts an existing directory; prints the error and returns 1 on failure. */
int cli_make_dir(const char *cmd, const char *dir);

/* A stream file opened by the decoder. */
typedef struct cli_stream {
    uint8_t *file;
    size_t len;
    cnerf_decoder *dec;
    void *ws;
} cli_stream;
/* Reads and opens `path`, and builds its float reference model into *ref (when not NULL);
 * prints the error and returns 1 on failure. */
int cli_stream_open(const char *cmd, const char *path, cli_stream *s, struct cn_model *ref);
/* The same for scene `scene` of a stream of several (a message naming the scene count when
 * there is no such scene). */
int cli_stream_open_scene(const char *cmd, const char *path, unsigned scene, cli_stream *s,
                          struct cn_model *ref);
void cli_stream_free(cli_stream *s);
/* One line: file bytes = latent payload + overhead (tables, affine, biases, headers). */
void cli_print_sizes(const char *path, const cli_stream *s);

/* The first bytes of every cnerf stream (docs/bitstream.md section 2). */
#define CLI_STREAM_SIG "\x89" "CNF"

/* Prints "cnerf <cmd>: <message>" to stderr and returns 1 (a failure). */
int cli_fail(const char *cmd, const char *fmt, ...);
/* The same for a usage error (a bad command line): returns 2. */
int cli_usage(const char *cmd, const char *fmt, ...);

#endif
