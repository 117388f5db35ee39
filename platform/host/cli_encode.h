/* The encode command's parsed options, shared by its one-scene path (cmd_encode.c) and its
 * several-scene path (encode_set.c). */
#ifndef CNERF_CLI_ENCODE_H
#define CNERF_CLI_ENCODE_H

#include "cn_train.h"

/* The encode command's options, and what follows from them. Strings left NULL and numbers
 * left -1 were not given (--rate-control, --prune and --latent-lr take their defaults after
 * the several-scene path has seen whether they were given). */
typedef struct encode_args {
    cn_train_opts o;
    const char *out, *resume, *init, *pos[CNERF_MAX_SCENES], *latent_lr, *random_bg, *background;
    const char *prune, *coarse_color, *scheme, *preset;
    double coarse_weight, ckpt_secs, lambda, levels, size, bpp, quality, lr_shift;
    long iters, downscale, max_size, threads, batch, every, depth, width, coarse, fine;
    long ckpt_every, log_every, view_width, eval_every, grid_g, precrop, val_views, level;
    uint64_t seed;
    int black, n_pos, grid_verbose, force;
    int controlled; /* --size or --bits-per-param: lambda follows rate control */
    int autop;      /* --preset auto */
    char ckpt[4096];
} encode_args;

/* Locks the stream A->out and the checkpoint ckpt (OUT.ckpt, or --resume's), refuses to
 * start a new checkpoint over an existing file without --force (cli_check_fresh) and enters
 * the loading phase (cli_stop_before). 0, or 1 with the message printed and no lock held. */
int cli_encode_lock(const encode_args *A, const char *ckpt, struct cli_locks *L);

/* cnerf encode DATASET1 DATASET2 ... -o set.cnrf: several scenes in one stream with shared
 * shifts. A holds the parsed command line; returns the command's exit status. */
int cli_encode_set(const encode_args *A);

#endif /* CNERF_CLI_ENCODE_H */
