/* cnerf encode DATASET -o scene.cnrf --lambda L: trains the compressed NeRF, writes the
 * stream, reads it back with the decoder's parser and reports size and test quality of the
 * float reference render of the file. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cn_file.h"
#include "cli.h"
#include "cli_args.h"
#include "cli_encode.h"
#include "cn_stream.h"
#include "progress.h"
#include "cn_export.h"
#include "cn_pipeline.h"
#include "cn_metrics.h"
#include "cn_rate.h"
#include "cn_synth.h"
#include "cn_report.h"
#include "cn_train.h"

#define ENCODE_USAGE                                                                          \
    "usage: cnerf encode DATASET -o scene.cnrf\n"                                            \
    "       or, several scenes in one stream with shared shifts (options as below, and\n"   \
    "       --shift-lr X; not --size, --bits-per-param, --rate-control, --prune on or\n"  \
    "       --average):\n"                                                                    \
    "       cnerf encode DATASET1 DATASET2 ... -o set.cnrf (--lambda L | --quality Q)\n"   \
    "       (--lambda L | --quality Q | --size BYTES | --bits-per-param X)\n"               \
    "       [--preset tiny|small|paper|auto (the default with --size; else small)]\n"        \
    "       [--rate-control dual|pi] [--lr X] [--lr-decay N] [--lr-warmup N] [--precrop-iters N]\n"          \
    "       [--average N]\n"                                                                 \
    "       [--iters N] [--downscale F|--max-size N] [--threads T] [--seed S]\n"                         \
    "       [--resume CKPT | --force]\n"                                                     \
    "       [--levels X] [--batch R] [--every N] [--black] [--ckpt-every N | --ckpt-secs S]\n" \
    "       [--log-every N] [--depth D] [--width W] [--view-width V] [--coarse N] [--fine N]\n"                \
    "       [--latent-lr latent|weight] [--init FLOAT.ckpt] [--float-iters N]\n"                                            \
    "       [--eval-every N] [--prior-lr X] [--affine-lr X] [--scale-lr R]\n"   \
    "       [--skip-saturated EPS] [--grid G|0] [--grid-verbose] [--random-bg auto|on|off]\n" \
    "       [--background auto|constant|contract]\n"                                               \
    "       [--prune on|off] [--group-penalty MU] [--coarse-color off|on] [--coarse-weight W]\n" \
    "       [--val-views N] [--level L]"

/* --size and --bits-per-param: the file may miss its target by this fraction. */
#define CLI_SIZE_TOLERANCE 0.03

static void say(const char *line)
{
    printf("%s\n", line);
    fflush(stdout);
}

/* "dead units removed: coarse 0+31+49+0+0+0+0+0 of 8 x 128, view 0 of 128; ...". */
static void print_pruning(const cnerf_info *T, const cn_prune_report *pr)
{
    static const char *const names[2] = {"coarse", "fine"};
    printf("dead units removed:");
    unsigned constant = 0;
    for (unsigned n = 0; n < T->n_nets; n++) {
        const cnerf_net_info *N = &T->net[n];
        printf("%s %s ", n ? ";" : "", names[n]);
        for (unsigned i = 0; i < N->depth; i++)
            printf("%s%u", i ? "+" : "", pr->before[n][i] - pr->after[n][i]);
        printf(" of %u x %u", N->depth, N->width);
        if (N->view_width)
            printf(", view %u of %u", pr->before[n][N->depth] - pr->after[n][N->depth],
                   N->view_width);
        for (unsigned i = 0; i <= N->depth; i++)
            constant += pr->constant[n][i];
    }
    const uint32_t fewer = pr->params_before - pr->params_after;
    printf("; %u latents fewer (%.1f%%)", fewer,
           pr->params_before ? 100.0 * fewer / pr->params_before : 0.0);
    if (constant)
        printf("; %u units with a constant output kept", constant);
    printf("\n");
}

/* --init without a preset: the float model's depth, width and samples, under the name of
 * the preset that has them (else small's, overridden) unless the command line sets them. */
/* The pipeline's reports between its steps: the units removed, and the grid's measurement
 * about to start (it renders the training views). */
static void report_stage(void *ctx, cn_encode_stage stage, const cn_encoded *enc)
{
    if (stage == CN_STAGE_PRUNED) /* ctx: the model's topology */
        print_pruning((const cnerf_info *)ctx, &enc->prune);
    else if (stage == CN_STAGE_GRID_START)
        say("occupancy grid: measuring the density on a 129^3 lattice and rendering "
            "training views with and without the grid");
}

static int init_topology(const char *path, const char **preset, long *depth, long *width,
                         long *coarse, long *fine)
{
    cn_model m;
    char err[1024];
    if (cn_checkpoint_load_model(path, &m, NULL, err, sizeof err))
        return cli_fail("encode", "%s", err);
    const cnerf_info *T = &m.topo;
    static const char *const names[] = {"tiny", "small", "paper"};
    *preset = "small";
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        cnerf_info p;
        if (cn_preset_header(names[i], &p) == 0 && p.net[0].depth == T->net[0].depth &&
            p.net[0].width == T->net[0].width && p.n_coarse == T->n_coarse &&
            p.n_fine == T->n_fine)
            *preset = names[i];
    }
    if (*depth < 0)
        *depth = T->net[0].depth;
    if (*width < 0)
        *width = T->net[0].width;
    if (*coarse < 0)
        *coarse = T->n_coarse;
    if (*fine < 0)
        *fine = T->n_fine;
    cn_model_free(&m);
    return 0;
}


/* The options' defaults (what cmd_encode does with an option that is not given). */
static void encode_defaults(encode_args *A)
{
    memset(A, 0, sizeof *A);
    cn_train_defaults(&A->o);
    A->o.compress = 1;
    A->random_bg = "auto";
    A->background = "auto";
    A->coarse_color = "off";
    A->coarse_weight = -1;
    A->iters = A->o.iters;
    A->downscale = 1;
    A->batch = A->o.batch;
    A->every = 1;
    A->depth = A->width = A->coarse = A->fine = A->view_width = -1;
    A->log_every = 100;
    A->ckpt_secs = CLI_CKPT_SECS;
    A->grid_g = A->precrop = A->val_views = -1;
    A->lambda = -1;
    A->levels = A->o.levels;
    A->quality = A->lr_shift = -1;
    A->seed = A->o.seed;
}

/* The one-scene encode's checks of its options, and what follows from them. Returns -1 to go
 * on, or the command's exit status. */
static int check_args(encode_args *A)
{
    if (A->lr_shift >= 0)
        return cli_usage("encode", "--shift-lr sets the shared shifts' rate of a stream of "
                         "several scenes; this encode has one");
    if (A->n_pos != 1 || !A->out || (A->lambda < 0 && A->size == 0 && A->bpp == 0 && A->quality < 0))
        return cli_usage("encode", "need a dataset directory, -o FILE and one of --lambda L, "
                         "--quality Q, --size BYTES or --bits-per-param X\n%s", ENCODE_USAGE);
    if ((A->lambda >= 0) + (A->size > 0) + (A->bpp > 0) + (A->quality >= 0) > 1)
        return cli_usage("encode", "--lambda, --quality, --size and --bits-per-param each set "
                         "the rate: give one of them");
    if (strcmp(A->scheme, "pi") && strcmp(A->scheme, "dual"))
        return cli_usage("encode", "--rate-control takes dual (dual ascent, the default) or pi "
                         "(log-lambda PI control), not '%s'", A->scheme);
    A->controlled = A->size > 0 || A->bpp > 0;
    if (A->init && A->resume)
        return cli_usage("encode", "--init starts a run from a float model and --resume goes on "
                         "with an encode's checkpoint: give one of them");
    if (A->init && A->o.float_iters > 0)
        return cli_usage("encode", "--init starts from a float model, which has found the "
                         "scene already: leave out --float-iters (a run from --init rounds its "
                         "latents from the first iteration)");
    if (A->init)
        A->o.float_iters = 0;
    if (A->o.float_iters > 0 && A->o.float_iters >= A->iters)
        return cli_usage("encode", "--float-iters %ld leaves no iteration of the %ld for the "
                         "rounded latents that the file holds: give fewer than --iters",
                         A->o.float_iters, A->iters);
    if (A->init && A->preset && !strcmp(A->preset, "auto"))
        return cli_usage("encode", "--init takes the model of its checkpoint: leave out "
                         "--preset auto");
    if (A->preset)
        A->o.preset = A->preset;
    else if (A->init) {
        if (access(A->init, F_OK) != 0)
            return cli_fail("encode", "%s: no such checkpoint", A->init);
        if (init_topology(A->init, &A->o.preset, &A->depth, &A->width, &A->coarse, &A->fine))
            return 1;
    } else if (A->size > 0)
        A->o.preset = "auto";
    if (strcmp(A->o.preset, "tiny") && strcmp(A->o.preset, "small") && strcmp(A->o.preset, "paper") &&
        strcmp(A->o.preset, "auto"))
        return cli_usage("encode", "unknown preset '%s' (tiny, small, paper, auto)", A->o.preset);
    A->autop = !strcmp(A->o.preset, "auto");
    if (A->autop && A->size == 0)
        return cli_usage("encode", "--preset auto chooses the model from the file's size: give "
                         "--size BYTES, or a preset (tiny, small, paper)");
    if (A->autop && (A->depth > 0 || A->width > 0 || A->coarse > 0 || A->fine >= 0))
        return cli_usage("encode", "--preset auto chooses depth, width and samples itself: "
                         "give a preset to set them");
    if (A->controlled || A->quality >= 0)
        A->lambda = 0;
    if (A->quality >= 0)
        A->o.quality_slope = cn_quality_slope(A->quality);
    if (A->grid_g > 0 && (A->grid_g < 16 || (A->grid_g & (A->grid_g - 1))))
        return cli_usage("encode", "--grid takes 16, 32, 64 or 128 cells per axis, or 0 for no "
                        "grid, not %ld", A->grid_g);
    if (A->level && A->grid_g > (long)CNERF_LEVEL_GRID(A->level))
        return cli_usage("encode", "--grid %ld is finer than level %ld allows (%u cells per "
                         "axis)", A->grid_g, A->level, CNERF_LEVEL_GRID(A->level));
    if (strcmp(A->latent_lr, "latent") && strcmp(A->latent_lr, "weight"))
        return cli_usage("encode", "--latent-lr takes 'latent' (Adam's step in latent units, "
                        "the paper's) or 'weight' (in weight units), not '%s'", A->latent_lr);
    A->o.latent_lr_weight_units = !strcmp(A->latent_lr, "weight");
    if (cli_background("encode", A->background, &A->o.contract))
        return 2;
    if (cli_random_bg("encode", A->random_bg, &A->o.random_bg))
        return 2;
    if (strcmp(A->prune, "on") && strcmp(A->prune, "off"))
        return cli_usage("encode", "--prune takes on (remove dead units) or off, not '%s'",
                        A->prune);
    if (cli_coarse_color("encode", A->coarse_color, A->coarse_weight, &A->o))
        return 2;
    if (A->o.average > A->iters)
        return cli_usage("encode", "--average %ld averages the parameters over the last %ld of "
                         "the run's %ld iterations: give at most --iters", A->o.average, A->o.average,
                         A->iters);
    if (A->iters == 0 && !A->resume)
        return cli_usage("encode", "--iters 0 trains nothing: give at least 1, or --resume a "
                         "checkpoint");
    cli_set_threads(A->threads);
    A->o.iters = A->iters;
    A->o.seed = A->seed;
    A->o.batch = (int)A->batch;
    A->o.depth = (int)A->depth;
    A->o.width = (int)A->width;
    A->o.view_width = (int)A->view_width;
    A->o.n_coarse = (int)A->coarse;
    A->o.n_fine = (int)A->fine;
    A->o.lambda = A->lambda;
    A->o.levels = A->levels;
    /* A model from --init already holds the scene: the centre crop, which keeps a model
     * from scratch off the empty background, would only spend dearer iterations on it. */
    if (A->precrop >= 0 || A->init)
        A->o.precrop_iters = A->precrop >= 0 ? A->precrop : 0;
    snprintf(A->ckpt, sizeof A->ckpt, "%s", A->resume ? A->resume : A->out);
    if (!A->resume)
        strncat(A->ckpt, ".ckpt", sizeof A->ckpt - strlen(A->ckpt) - 1);
    return -1;
}

/* Parses and checks the command line into A (its defaults first). Returns -1 to go on, or
 * the command's exit status. */
static int parse_args(int argc, char **argv, encode_args *A)
{
    encode_defaults(A);
    const cli_opt opts[] = {
        {"-o", CLI_STR, &A->out, 0, 0},
        {"--lambda", CLI_DOUBLE, &A->lambda, 0, 1e3},
        {"--quality", CLI_DOUBLE, &A->quality, 0, 100},
        {"--size", CLI_DOUBLE, &A->size, 1, 1e9},
        {"--bits-per-param", CLI_DOUBLE, &A->bpp, 1e-3, 32},
        {"--rate-control", CLI_STR, &A->scheme, 0, 0},
        {"--preset", CLI_STR, &A->preset, 0, 0},
        {"--iters", CLI_LONG, &A->iters, 0, 1e9},
        {"--downscale", CLI_LONG, &A->downscale, 1, 64},
        {"--max-size", CLI_LONG, &A->max_size, 1, 1 << 20},
        {"--threads", CLI_LONG, &A->threads, 1, 256},
        {"--seed", CLI_U64, &A->seed, 0, 0},
        {"--resume", CLI_STR, &A->resume, 0, 0},
        {"--force", CLI_FLAG, &A->force, 0, 0},
        {"--init", CLI_STR, &A->init, 0, 0},
        {"--levels", CLI_DOUBLE, &A->levels, 0.5, 10000},
        {"--batch", CLI_LONG, &A->batch, 1, 65536},
        {"--every", CLI_LONG, &A->every, 1, 1e6},
        {"--black", CLI_FLAG, &A->black, 0, 0},
        {"--ckpt-every", CLI_LONG, &A->ckpt_every, 1, 1e9},
        {"--ckpt-secs", CLI_DOUBLE, &A->ckpt_secs, 1, 1e6},
        {"--log-every", CLI_LONG, &A->log_every, 1, 1e9},
        {"--eval-every", CLI_LONG, &A->eval_every, 0, 1e9},
        {"--val-views", CLI_LONG, &A->val_views, 0, 1e6},
        {"--depth", CLI_LONG, &A->depth, 1, CNERF_MAX_DEPTH},
        {"--width", CLI_LONG, &A->width, 1, CNERF_MAX_WIDTH},
        {"--view-width", CLI_LONG, &A->view_width, 0, CNERF_MAX_VIEW_WIDTH},
        {"--coarse", CLI_LONG, &A->coarse, 1, CNERF_MAX_SAMPLES},
        {"--fine", CLI_LONG, &A->fine, 0, CNERF_MAX_SAMPLES},
        {"--latent-lr", CLI_STR, &A->latent_lr, 0, 0},
        {"--lr", CLI_DOUBLE, &A->o.lr, 1e-8, 1},
        {"--lr-decay", CLI_DOUBLE, &A->o.lr_decay_steps, 1, 1e12},
        {"--lr-warmup", CLI_LONG, &A->o.lr_warmup, 0, 1000000},
        {"--precrop-iters", CLI_LONG, &A->precrop, 0, 1e9},
        {"--average", CLI_LONG, &A->o.average, 1, 1e9},
        {"--prior-lr", CLI_DOUBLE, &A->o.lr_prior, 0, 1},
        {"--skip-saturated", CLI_DOUBLE, &A->o.sat_eps, 0, 1},
        {"--group-penalty", CLI_DOUBLE, &A->o.group, 0, 1000},
        {"--affine-lr", CLI_DOUBLE, &A->o.lr_affine, 0, 1},
        {"--scale-lr", CLI_DOUBLE, &A->o.lr_scale, 0, 1},
        {"--grid", CLI_LONG, &A->grid_g, -1, CNERF_MAX_GRID},
        {"--grid-verbose", CLI_FLAG, &A->grid_verbose, 0, 0},
        {"--level", CLI_LONG, &A->level, 1, CNERF_MAX_LEVELS},
        {"--random-bg", CLI_STR, &A->random_bg, 0, 0},
        {"--background", CLI_STR, &A->background, 0, 0},
        {"--prune", CLI_STR, &A->prune, 0, 0},
        {"--coarse-color", CLI_STR, &A->coarse_color, 0, 0},
        {"--coarse-weight", CLI_DOUBLE, &A->coarse_weight, 1e-3, 10},
        {"--shift-lr", CLI_DOUBLE, &A->lr_shift, 0, 1},
        {"--float-iters", CLI_LONG, &A->o.float_iters, 0, 1e9},
    };
    if (cli_parse("encode", ENCODE_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], A->pos,
                  CNERF_MAX_SCENES, &A->n_pos))
        return 2;
    if (A->resume && A->force)
        return cli_usage("encode", CLI_RESUME_OR_FORCE);
    if (A->n_pos > 1) /* several scenes */
        return cli_encode_set(A);
    if (!A->scheme)
        A->scheme = "dual";
    if (!A->prune)
        A->prune = "on";
    if (!A->latent_lr)
        A->latent_lr = "weight";
    return check_args(A);
}


/* Under --size (or --bits-per-param): refuses a target out of the preset's reach on this
 * scene, else puts the trainer under rate control. Returns 0, or -1 with a message. */
/* The sizes a preset can reach on a scene, from its floor (cn_stream_floor) and the latents
 * it sends: at least the floor and a tenth of a bit per latent sent (docs/results.md: below
 * that the models lose several dB); at most every latent sent at 32 bits, as float32
 * weights would take (the latents' range is bounded far below that). */
static void size_reach(size_t floor_bytes, double latents, double *least, double *most)
{
    *least = (double)floor_bytes + 0.1 * latents / 8 + 300;
    *most = (double)floor_bytes + 4 * latents;
}

static int start_rate_control(encode_args *A, cn_trainer *t, const cn_dataset *ds, char *err,
                              size_t errlen)
{
    if (!A->controlled)
        return 0;
    {
        const double latents = (double)cn_model_sent_latents(&t->model);
        const double target = A->size > 0 ? A->size : A->bpp * latents / 8;
        /* The sizes the preset can reach on this scene (size_reach). */
        size_t floor_bytes = 0;
        int bad = cn_stream_floor(&t->model, A->seed, &floor_bytes, err, errlen);
        double least, most;
        size_reach(floor_bytes, latents, &least, &most);
        if (!bad && target < least)
            bad = snprintf(err, errlen, "a %.0f-byte file is too small for preset %s on "
                           "this scene: its headers, affine decoders and biases alone take %zu "
                           "bytes, and below about %.0f bytes (0.1 bit per latent for the %.0f "
                           "latents it sends, and a grid) the model collapses; ask for at least "
                           "%.0f bytes, or a smaller preset", target, A->o.preset, floor_bytes,
                           least, latents, least) > 0;
        else if (!bad && target > most)
            bad = snprintf(err, errlen, "a %.0f-byte file is more than preset %s can use "
                           "on this scene: %.0f bytes hold its %.0f latents at 32 bits each, "
                           "as float32 weights, with its headers, affine decoders and biases; "
                           "ask for at most %.0f bytes, or a larger preset", target, A->o.preset,
                           most, latents, most) > 0;
        if (bad)
            return -1;
        char meta0[1024];
        const int mlen = snprintf(meta0, sizeof meta0,
                                  "encoder=cnerf %s; command=encode; dataset=%s; preset=%s; "
                                  "iters=%ld; size=%.0f; lambda=%g; downscale=%ld; seed=%llu; "
                                  "levels=%g; latent-lr=%s; float-iters=%ld%s%s",
                                  CNERF_VERSION_STRING, A->pos[0], A->o.preset, A->iters, target,
                                  1.0, (long)ds->downscale, (unsigned long long)A->seed,
                                  A->levels, A->latent_lr, t->opts.float_iters,
                                  A->init ? "; init=" : "", A->init ? A->init : "");
        cn_trainer_rate_control(t, target, mlen + 16, strcmp(A->scheme, "dual") ? CN_RC_LOG_PI
                                                                                : CN_RC_DUAL,
                                (int)A->grid_g, !strcmp(A->prune, "on"));
        printf("rate control (%s): a file of %.0f bytes (%.3f bits per latent); the topology "
               "alone takes %zu\n", A->scheme, target, 8 * target / latents, floor_bytes);
    }
    return 0;
}

/* 1 when a topology (its expanded layers, before training) is over level L in a way no
 * training changes: its samples, its multiply-accumulates, its render scratch, or its
 * workspace with every latent in int8 and no grid (the least a stream of it can take); the
 * caps it exceeds into why. */
static int topology_over_level(const cnerf_info *topo, unsigned L, char *why, size_t n)
{
    cnerf_info least = *topo;
    least.grid_g = 0;
    least.level = 0;
    for (uint32_t l = 0; l < least.n_layers; l++)
        least.layer[l].kmin = least.layer[l].kmax = 0;
    return cn_level_excess(&least, L, why, n) > 0;
}

/* The same for a preset with the options' overrides (cn_preset_header). */
static int preset_over_level(const char *preset, const cn_train_opts *o, unsigned L, char *why,
                             size_t n)
{
    cnerf_info *T = calloc(1, sizeof *T);
    int over = 0;
    if (T && cn_preset_header(preset, T) == 0) {
        if (o->n_coarse > 0)
            T->n_coarse = (uint16_t)o->n_coarse;
        if (o->n_fine >= 0)
            T->n_fine = (uint16_t)o->n_fine;
        over = cnerf_expand_topology(T) == CNERF_OK && topology_over_level(T, L, why, n);
    }
    free(T);
    return over;
}

/* Whether --preset auto races tiny and small (cn_train.h) on this run: an encode to a size
 * from scratch, long enough, with validation views, at a size that small can meet
 * (CN_RACE_BITS) within the level. */
static int race_wanted(const encode_args *A, const cn_dataset *ds, char *err, size_t errlen)
{
    if (!A->autop || A->size <= 0 || A->resume || A->init || ds->n_val == 0 ||
        A->iters < CN_RACE_MIN_ITERS || A->o.val_every <= 0)
        return 0;
    cn_train_opts p = A->o;
    p.preset = "small";
    size_t floor_bytes, latents;
    if (cn_preset_floor(ds, &p, &floor_bytes, &latents, err, errlen))
        return -1;
    if (8 * (A->size - (double)floor_bytes) / (double)latents < CN_RACE_BITS)
        return 0;
    p.preset = "tiny"; /* a size beyond tiny's reach is small's alone */
    double least, most;
    if (cn_preset_floor(ds, &p, &floor_bytes, &latents, err, errlen))
        return -1;
    size_reach(floor_bytes, (double)latents, &least, &most);
    if (A->size > most)
        return 0;
    return !(A->level && preset_over_level("small", &A->o, (unsigned)A->level, NULL, 0));
}

/* --preset auto's race of tiny (tr[0], initialised by the caller with rate control) and
 * small (tr[1], initialised here) until the validation views rank them (cn_race_step); the
 * loser is freed (a trainer holds pointers into itself: the winner stays where it is).
 * *win: 0 tiny, 1 small. Returns 0, or -1 with a message and tr[0] left to the caller. */
static int auto_race(encode_args *A, const cn_dataset *ds, cn_trainer tr[2], int *win,
                     char *err, size_t errlen)
{
    A->o.preset = "small";
    if (cn_trainer_init(&tr[1], ds, &A->o, err, errlen))
        return -1;
    if (start_rate_control(A, &tr[1], ds, err, errlen)) {
        cn_trainer_free(&tr[1]);
        return -1;
    }
    cli_stop_before("race", "while --preset auto races tiny and small", NULL);
    printf("preset auto: racing tiny and small, each a whole encode, until the validation "
           "views rank them (from %.0f%% of the run by more than %.1f dB, else at %.0f%%; a lead "
           "of small's only at its size)\n",
           100 * CN_RACE_FIRST, CN_RACE_MARGIN_DB, 100 * CN_RACE_LAST);
    fflush(stdout);
    const double t0 = cli_now();
    cn_race race;
    memset(&race, 0, sizeof race);
    int w = -1;
    long seen = 0; /* the last validation step looked at */
    while (w < 0) {
        int lost = -1; /* a preset that the rate collapsed (cn_trainer_step's check) */
        for (int k = 0; k < 2; k++)
            if (isnan(cn_trainer_step(&tr[k], NULL, NULL))) {
                if (!tr[k].collapsed || lost >= 0) {
                    snprintf(err, errlen, "%.900s", tr[k].err);
                    cn_trainer_free(&tr[1]); /* tr[0]: the caller's */
                    return -1;
                }
                printf("race: %s\n", tr[k].err);
                lost = k;
            }
        if (lost >= 0) {
            w = 1 - lost;
            break;
        }
        /* A trainer validates at the start of the step after each val_every-th: both did in
         * this step when its val_step moved. */
        const long step = tr[0].val_step;
        if (step == seen && tr[0].step < A->iters)
            continue;
        seen = step;
        const double small_kb = (tr[1].rc.size + tr[1].rc.reserved) / 1000.0;
        const int small_sized = tr[1].rc.size > 0 &&
            tr[1].rc.size + tr[1].rc.reserved <= (1 + CN_RACE_SIZE_TOL) * tr[1].rc.target;
        w = cn_race_step(&race, step, A->iters, tr[0].val_psnr, tr[1].val_psnr, small_sized);
        printf("race %ld/%ld: validation psnr tiny %.2f dB, small %.2f dB (%.2f kB, %.2f kB), "
               "small's lead %+.2f dB over the last %d%s\n", step, A->iters, tr[0].val_psnr,
               tr[1].val_psnr, (tr[0].rc.size + tr[0].rc.reserved) / 1000.0, small_kb,
               race.mean, race.n < CN_RACE_MEAN ? race.n : CN_RACE_MEAN,
               race.waiting && w < 0 ? ", waiting for small to reach its size" : "");
        fflush(stdout);
        if (tr[0].step >= A->iters && w < 0)
            w = race.n > 0 && race.mean > 0;
    }
    printf("preset auto: %s, by the race (%.0f s, %ld iterations of each)\n",
           w ? "small" : "tiny", cli_now() - t0, tr[0].step);
    cn_trainer_free(&tr[1 - w]);
    A->o.preset = w ? "small" : "tiny";
    *win = w;
    return 0;
}

/* The trained model through the encode pipeline into the file, read back through the
 * decoder and reported: the sizes, the rate against the target, the test views. Returns the
 * command's exit status (rc: the training's). */
static int write_and_report(encode_args *A, cn_trainer *t, const cn_dataset *ds,
                            int stepped_down, int rc)
{
    char err[1024];
    cn_encoded enc;
    memset(&enc, 0, sizeof enc);
    char meta[1024], sizebuf[64] = "";
    char levelbuf[16] = "";
    if (A->level)
        snprintf(levelbuf, sizeof levelbuf, "; level=%ld", A->level);
    if (t->rate_control)
        snprintf(sizebuf, sizeof sizebuf, "size=%.0f; ", t->rc.target);
    else if (A->quality >= 0)
        snprintf(sizebuf, sizeof sizebuf, "quality=%g; ", A->quality);
    snprintf(meta, sizeof meta,
             "encoder=cnerf %s; command=encode; dataset=%s; preset=%s; iters=%ld; %slambda=%g; "
             "downscale=%ld; seed=%llu; levels=%g; latent-lr=%s; float-iters=%ld; "
             "coarse-color=%s; coarse-weight=%g%s%s%s",
             CNERF_VERSION_STRING, A->pos[0], A->o.preset, t->step, sizebuf, t->opts.lambda,
             (long)ds->downscale, (unsigned long long)A->seed, A->levels, A->latent_lr,
             t->opts.float_iters, A->coarse_color, A->o.coarse_weight, A->init ? "; init=" : "", A->init ? A->init : "", levelbuf);
    if (rc == 0) {
        cn_model *model = &t->model;
        const cn_dataset *views = ds;
        const cn_encode_job job = {.models = &model, .n = 1, .meta = meta, .seed = A->seed,
                                   .prune = !strcmp(A->prune, "on"), .grid_g = (int)A->grid_g,
                                   .level = (unsigned)A->level,
                                   .views = &views, .grid_log = A->grid_verbose ? say : NULL,
                                   .report = report_stage, .report_ctx = &t->model.topo};
        if (cn_encode_finish(&job, &enc, err, sizeof err))
            rc = A->level ? cli_fail("encode", "%s; the trained model is in %s: --resume it "
                                     "with another --level, or none", err, A->ckpt)
                          : cli_fail("encode", "%s", err);
    }
    const cn_grid_choice *grid = &enc.grid[0];
    if (rc == 0 && grid->g) {
        printf("occupancy grid: %d^3, %.1f%% of the cells occupied, %zu bytes; %.1f%% of the "
               "evaluations left on the training rays, %+.3f dB on the training views "
               "(threshold %.3g, dilation %d)\n",
               grid->g, 100 * grid->occupied, grid->bytes, 100 * grid->eval_fraction,
               0.0 - grid->psnr_drop + 0.0, grid->threshold, grid->dilation); /* no "-0.000" */
    } else if (rc == 0 && A->grid_g > 0) {
        printf("occupancy grid: none: at every threshold tried, the %ld^3 grid cost the "
               "training views more than 0.025 dB\n", A->grid_g);
    } else if (rc == 0 && A->grid_g != 0) {
        printf("occupancy grid: none (no resolution skips enough to pay for its bytes, or "
               "none kept the training views within 0.025 dB)\n");
    }
    if (rc == 0 && cn_write_file_atomic(A->out, enc.stream.p, enc.stream.n, err, sizeof err))
        rc = cli_fail("encode", "%s", err);
    if (rc == 0)
        cli_stop_phase("wrote", "after training: saved %s at iteration %ld and wrote %s; its "
                       "measurement was not finished (cnerf render %s --dataset %s measures it)",
                       A->ckpt, t->step, A->out, A->out, A->pos[0]);
    const cn_write_report rep = enc.rep;
    /* The closed loop: read the file back through the decoder's parser. */
    cli_stream st;
    cn_model ref;
    memset(&st, 0, sizeof st);
    memset(&ref, 0, sizeof ref);
    if (rc == 0 && cli_stream_open("encode", A->out, &st, &ref))
        rc = 1;
    if (rc == 0) {
        printf("wrote ");
        cli_print_sizes(A->out, &st);
        int prior = 0, counts = 0;
        for (uint32_t l = 0; l < st.dec->info.n_layers; l++) {
            prior += rep.table_source[l] == CN_TABLE_PRIOR;
            counts += rep.table_source[l] == CN_TABLE_COUNTS;
        }
        printf("tables: %d from the prior, %d from counts, %u constant layers\n", prior, counts,
               st.dec->info.n_layers - prior - counts);
        if (A->quality >= 0)
            printf("quality: %g (%.3g dB per bit per latent), final lambda %.4g = %.4g x 3 "
                   "pixels / latents\n", A->quality, A->o.quality_slope, t->opts.lambda,
                   t->opts.lambda / cn_trainer_lambda_unit(t));
        if (t->rate_control) {
            const double dev = (double)st.len / t->rc.target - 1;
            printf("size: %zu bytes against the target %.0f (%+.2f%%), final lambda %.4g\n",
                   st.len, t->rc.target, 100 * dev, t->opts.lambda);
            if (dev > CLI_SIZE_TOLERANCE)
                rc = cli_fail("encode", "%s is %.1f%% over the target of %.0f bytes (the file is "
                              "written): the run ended before the rate settled; give more "
                              "--iters or a larger --size", A->out, 100 * dev, t->rc.target);
            else if (dev < -CLI_SIZE_TOLERANCE && stepped_down)
                printf("size: %.1f%% under the target: preset tiny, which --preset auto took for "
                       "this scene, does not use more\n", -100 * dev);
            else if (dev < -CLI_SIZE_TOLERANCE)
                rc = cli_fail("encode", "%s is %.1f%% under the target of %.0f bytes (the file "
                              "is written): preset %s does not use that many bytes on this "
                              "scene (lambda fell to %.3g); take a larger preset or a smaller "
                              "--size", A->out, -100 * dev, t->rc.target, A->o.preset, t->opts.lambda);
        }
        /* The rate the training objective estimated, against what the coder wrote. */
        cn_totals tot;
        cn_breakdown(&st.dec->info, &tot);
        const double est = cn_model_latent_bits(&t->model, NULL) / 8;
        printf("rate: prior estimate %.0f bytes for the integer latents, coded payload %llu bytes "
               "(%+.2f%%)\n",
               est, (unsigned long long)tot.payload, 100.0 * ((double)tot.payload / est - 1));
        double psnr = 0, ssim = 0, secs = 0;
        printf("float reference render of %s, test views:\n", A->out);
        int n = cli_eval_views(&ref, ds->test, ds->n_test, ds->ndc, 1, NULL, 0,
                               CLI_T_STOP, &psnr, &ssim, &secs);
        if (n < 0)
            rc = 1;
        else if (n > 0)
            printf("test: %d views, psnr %.2f dB, ssim %.4f, file %zu bytes\n", n, psnr, ssim,
                   st.len);
    }
    if (ref.params)
        cn_model_free(&ref);
    cli_stream_free(&st);
    cn_encoded_free(&enc);
    return rc;
}

int cli_encode_lock(const encode_args *A, const char *ckpt, cli_locks *L)
{
    /* The stream and the checkpoint (--resume's when it is given) are both locked: another
     * run may write neither. */
    const char *written[2] = {A->out, ckpt};
    if (cli_lock_outputs("encode", written, 2, L))
        return 1;
    char resume[4200];
    snprintf(resume, sizeof resume, "--resume %s", ckpt);
    if (!A->resume && !A->force && cli_check_fresh("encode", ckpt, resume)) {
        cli_unlock_outputs(L);
        return 1;
    }
    cli_stop_before("load", A->n_pos > 1 ? "while loading the datasets" :
                    "while loading the dataset", A->resume);
    return 0;
}

int cmd_encode(int argc, char **argv)
{
    encode_args args, *A = &args;
    const int parsed = parse_args(argc, argv, A);
    if (parsed >= 0)
        return parsed;
    /* --resume's checkpoint is read and written again: an input that is not protected, but
     * that may not be the stream. */
    const char *inputs[1] = {A->init};
    if (cli_check_output("encode", A->out, inputs, 1, A->pos[0]) ||
        cli_check_output("encode", A->ckpt, inputs, 1, A->pos[0]) ||
        cli_check_not("encode", A->out, A->resume))
        return 1;
    cli_locks locks;
    if (cli_encode_lock(A, A->ckpt, &locks))
        return 1;
    cn_dataset ds;
    if (cli_load_dataset("encode", A->pos[0], A->downscale, A->max_size, A->black, 0, 0,
                         A->val_views, A->every, 0, &ds)) {
        cli_unlock_outputs(&locks);
        return 1;
    }
    char err[1024];
    if (A->init && A->o.contract < 0) { /* auto: the float model's own background */
        cn_model fm;
        if (cn_checkpoint_load_model(A->init, &fm, NULL, err, sizeof err)) {
            cn_dataset_free(&ds);
            cli_unlock_outputs(&locks);
            return cli_fail("encode", "%s", err);
        }
        A->o.contract = fm.topo.coord == CNERF_COORD_CONTRACT;
        cn_model_free(&fm);
    }
    cli_auto_background(&ds, 1, &A->o.contract);
    int stepped_down = 0; /* --preset auto took tiny over the rule's choice */
    int race = 0;         /* --preset auto races tiny and small (auto_race) */
    if (A->autop) {
        double bits;
        if (cn_preset_auto(&ds, &A->o, A->size, &A->o.preset, &bits, err, sizeof err)) {
            cn_dataset_free(&ds);
            cli_unlock_outputs(&locks);
            return cli_fail("encode", "%s", err);
        }
        printf("preset auto: %s (%.2f bits per latent beyond the topology's floor; small from "
               "%.2f)\n", A->o.preset, bits, CN_AUTO_BITS);
        /* A resumed run goes on with the preset it trained: its trials, or fog, may have
         * taken tiny over the rule's choice. */
        const char *held;
        const int r = A->resume && access(A->resume, F_OK) == 0
                          ? cn_preset_of_checkpoint(&ds, &A->o, A->resume, &held, err, sizeof err)
                          : 1;
        if (r < 0) {
            cn_dataset_free(&ds);
            cli_unlock_outputs(&locks);
            return cli_fail("encode", "%s", err);
        }
        if (r == 0 && strcmp(held, A->o.preset)) {
            printf("preset auto: %s, the preset of %s (the rule: %s)\n", held, A->resume,
                   A->o.preset);
            stepped_down = !strcmp(held, "tiny");
            A->o.preset = held;
        }
        /* a level: the largest preset within it, at most the rule's */
        while (A->level && strcmp(A->o.preset, "tiny") &&
               preset_over_level(A->o.preset, &A->o, (unsigned)A->level, NULL, 0)) {
            const char *down = !strcmp(A->o.preset, "paper") ? "small" : "tiny";
            printf("preset auto: %s is over level %ld; %s\n", A->o.preset, A->level, down);
            A->o.preset = down;
        }
    }
    if (A->autop && (race = race_wanted(A, &ds, err, sizeof err)) < 0) {
        cn_dataset_free(&ds);
        cli_unlock_outputs(&locks);
        return cli_fail("encode", "%s", err);
    }
    if (race)
        A->o.preset = "tiny"; /* the first of the two trainers */
    int rc = 0, stopped = 0;
step_down: /* --preset auto encodes again with tiny when the rate collapses a larger preset */
    rc = 0;
    cli_stop_before("start", "before training", A->resume);
    cn_trainer tr[2], *tp = &tr[0]; /* tr[1]: small in the race */
    if (cn_trainer_init(tp, &ds, &A->o, err, sizeof err)) {
        cn_dataset_free(&ds);
        cli_unlock_outputs(&locks);
        return cli_fail("encode", "%s", err);
    }
    cli_say_random_bg(tp);
    char why[320];
    if (A->level && topology_over_level(&tp->model.topo, (unsigned)A->level, why, sizeof why)) {
        cn_trainer_free(tp);
        cn_dataset_free(&ds);
        cli_unlock_outputs(&locks);
        return cli_fail("encode", "the model is over level %ld before any training: %s (a "
                        "smaller preset, --width or fewer --coarse and --fine samples)",
                        A->level, why);
    }
    int bad = start_rate_control(A, tp, &ds, err, sizeof err);
    if (bad == 0 && race) {
        int w;
        race = 0; /* once: a step down from fog does not race again */
        bad = auto_race(A, &ds, tr, &w, err, sizeof err);
        if (bad == 0) {
            tp = &tr[w];
            stepped_down = !w;
        }
    }
    if (bad < 0) {
        cn_trainer_free(tp);
        cn_dataset_free(&ds);
        cli_unlock_outputs(&locks);
        return cli_fail("encode", "%s", err);
    }
    if (A->resume) {
        if (access(A->resume, F_OK) != 0)
            rc = cli_fail("encode", "%s: no such checkpoint", A->resume);
        else
            rc = cli_resume("encode", tp, A->resume);
    }
    if (A->init && rc == 0) {
        if (access(A->init, F_OK) != 0)
            rc = cli_fail("encode", "%s: no such checkpoint", A->init);
        else if (cn_trainer_init_from_float(tp, A->init, err, sizeof err))
            rc = cli_fail("encode", "%s", err);
        else
            printf("starting from the float model %s\n", A->init);
    }
    if (rc == 0) {
        char lam[80];
        if (A->quality >= 0)
            snprintf(lam, sizeof lam, "from --quality %g (%.3g dB per bit per latent)",
                     A->quality, A->o.quality_slope);
        else
            snprintf(lam, sizeof lam, A->controlled ? "controlled" : "%g", A->lambda);
        printf("encoding %s: %d train views %dx%d, %d validation views, lambda %s, %zu "
               "latents, checkpoint %s\n", A->pos[0], ds.n_train, ds.train[0].w, ds.train[0].h,
               ds.n_val, lam,
               cn_model_sent_latents(&tp->model), A->ckpt);
        if (A->o.average > 0)
            printf("the file will hold the mean of the parameters over the last %ld "
                   "iterations\n", A->o.average);
        char after[8400];
        snprintf(after, sizeof after, "%s not written: run the command again with --resume %s "
                 "to write it", A->out, A->ckpt);
        rc = cli_run_training("encode", tp, A->ckpt, A->ckpt_every, A->ckpt_secs, A->log_every,
                              A->eval_every, after, &stopped);
        if (rc == 0 && !stopped && tp->opts.float_iters > 0) {
            const long warm = cn_trainer_warmup(tp);
            printf("float phase: the latents trained unrounded for the first %ld iterations%s; ",
                   tp->opts.float_iters, tp->float_asked >= 0 ? " (--float-iters)"
                   : tp->float_left_fog ? ", until the model left the fog" : "");
            if (warm > 0)
                printf("the learning rate warmed up over the first %ld\n", warm);
            else if (A->o.lr_warmup < 0)
                printf("no warm-up of the learning rate (preset %s's default)\n", tp->opts.preset);
            else
                printf("no warm-up of the learning rate (--lr-warmup 0)\n");
        }
        /* A model the rate collapsed, or fog (cn_trainer_fog): a file that would not show
         * the scene is not written; --preset auto encodes again with tiny instead. */
        const int fog = rc == 0 && !stopped && tp->rate_control && cn_trainer_fog(tp);
        if ((fog || (rc && tp->collapsed)) && A->autop && !A->resume && !A->init &&
            strcmp(A->o.preset, "tiny")) {
            if (fog)
                printf("preset auto: %s is fog at %.0f bytes (validation psnr %.2f dB, a flat "
                       "colour %.2f dB); encoding again with preset tiny\n", A->o.preset,
                       tp->rc.target, tp->val_psnr, tp->flat_psnr);
            else
                printf("preset auto: %s collapsed at %.0f bytes; encoding again with preset "
                       "tiny\n", A->o.preset, tp->rc.target);
            A->o.preset = "tiny";
            stepped_down = 1;
            cn_trainer_free(tp);
            goto step_down;
        }
        if (fog)
            rc = cli_fail("encode", "%.0f bytes is too small for this scene at preset %s in %ld "
                          "iterations: its validation PSNR %.2f dB is less than %.0f dB above a "
                          "flat colour's %.2f dB, the model has not found the scene (fog); %s "
                          "not written (the model is in %s); try %sa larger --size%s",
                          tp->rc.target, A->o.preset, tp->step, tp->val_psnr, CN_VAL_FOG_DB,
                          tp->flat_psnr, A->out, A->ckpt,
                          strcmp(A->o.preset, "tiny") ? "--preset tiny, " : "",
                          A->init ? " or more --iters"
                                  : ", more --iters, or a float model from cnerf train as "
                                    "--init");
    }
    if (rc == 0 && stopped) {
        printf("interrupted: resume with --resume %s\n", A->ckpt);
        rc = 128 + stopped;
    }
    rc = write_and_report(A, tp, &ds, stepped_down, rc);
    cn_trainer_free(tp);
    cn_dataset_free(&ds);
    cli_unlock_outputs(&locks);
    return rc;
}
