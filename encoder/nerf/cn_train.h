/*
 * Training: random ray batches over all training images, MSE on the coarse and fine
 * renders, Adam with NeRF's exponential learning-rate decay, optional centre crop,
 * atomic checkpoints with resume, and full-view rendering for evaluation.
 */
#ifndef CNERF_ENC_TRAIN_H
#define CNERF_ENC_TRAIN_H

#include <stdint.h>

#include "cn_dataset.h"
#include "cn_nerf.h"
#include "cn_occ.h"
#include "cn_ratectl.h"
#include "cn_render.h"
#include "cn_xsum.h"
#include "cn_validate.h"

#define CN_PRECROP_ITERS 500

/* The default warm-up of the learning rate, in iterations (docs/training.md, "Warm-up"). */
#define CN_LR_WARMUP 20

/* The most of a compressed run from scratch trained unrounded first (float_iters). */
#define CN_FLOAT_SHARE 0.25

typedef struct cn_train_opts {
    const char *preset; /* "tiny", "small" or "paper" */
    int depth, width, view_width, n_coarse, n_fine; /* overrides; -1 keeps the preset's */
    long iters;
    int batch;             /* rays per iteration */
    double lr;             /* initial learning rate */
    double lr_decay_steps; /* lr = lr0 * 0.1^(step / lr_decay_steps); 0: over iters */
    /* The first lr_warmup steps ramp lr linearly up to it (step k at (k + 1) / lr_warmup of it);
     * -1 (the default): CN_LR_WARMUP, at most a tenth of iters, for a float model and for a
     * compressed one with a float phase (float_iters) of a preset that warms up
     * (cn_preset_float_warmup: not tiny); none for one rounded from the start. */
    long lr_warmup;
    /* The first precrop_iters iterations draw their rays from the centre crop only (360-degree
     * scenes); -1 (the default): CN_PRECROP_ITERS when some training view has transparency,
     * else 0. */
    long precrop_iters;
    double precrop_frac;
    uint64_t seed;
    /* Occupancy grids (cn_occ.h): cells per axis (0: off), the iteration of the first
     * estimate, and the iterations between updates. */
    int occ_grid;
    long occ_start, occ_every;
    /* From occ_start on, the fine network skips samples behind the coarse network's surface
     * (cn_batch.sat_eps; 0: off). Training only, like the grids. */
    double sat_eps;
    /* Compression (cnerf encode): kernels become latents with an entropy penalty.
     * Objective: D + lambda R, D = squared error summed over all training pixels and
     * channels (a batch estimates it scaled by pixels / rays), R = bits of all latents. */
    int compress;
    double lambda;
    /* A quality setting instead of a fixed lambda (cnerf encode --quality): the objective
     * becomes 10 log10(D) + k b, b the bits per latent, so that each step trades k dB of
     * training PSNR for one bit per latent on every scene, whatever its pixel count, latent
     * count or error level. Equivalently lambda = k ln(10)/10 (D / R-unit), set at each
     * step from the batch's distortion (cn_quality_lambda). 0: off. */
    double quality_slope;
    double levels;   /* initial latent spread in integer steps (a = Glorot limit / levels) */
    double lr_prior; /* learning rate of the priors */
    double lr_affine; /* learning rate of the affine decoders' offsets b (weight units) */
    /* Adam's step of each layer's affine scale a, as a fraction of its initial value
     * a0_l = Glorot limit / levels: the step is lr_scale * a0_l, decayed with lr. An
     * absolute step (5e-4, as the offsets') rescaled every weight of a width-128 layer by
     * 2.6% an iteration, and on DTU scan 24 preset small learned no geometry (validation
     * 12.27 dB at 600 iterations, lambda 0; 19.08 dB at 1e-3). */
    double lr_scale;
    /* Adam's learning rate of layer l's latents: lr (the paper: a step in latent units)
     * when 0; lr / a0_l when 1, a0_l = Glorot limit / levels being the layer's initial
     * quantization step, so that a latent moves as fast in weight units as a float weight
     * does and the initial spread (levels) no longer sets the speed (the default: on Lego
     * at 50x50, preset tiny, lambda 1e-3, 300 iterations, test PSNR 17.40 dB against 9.59 dB
     * in latent units, at 30,963 and 30,289 bytes). */
    int latent_lr_weight_units;
    /* Training views with transparency (an alpha channel, e.g. Blender's): each ray's
     * background is drawn uniformly at random and its ground truth recomposited over it,
     * so that only an empty ray (transmittance 1) matches every background. This removes
     * the haze that a constant background lets the model put in empty space, which the
     * stream's occupancy grid then cannot skip. 1 on, 0 off, -1 (the default) on when
     * some training view has transparency. Rendering keeps the stream's background. */
    int random_bg;
    /* 1: a 360-degree scene with a background (CNERF_COORD_CONTRACT): the inner box, of
     * half-size 3/8 of the mean camera distance, in world space, all space beyond it
     * contracted into a box twice its size (docs/rendering.md). 0 (the default): the scene
     * ends at its bounds and the background is the constant colour. Refused for NDC scenes. */
    int contract;
    /* Group penalty on the trunk's units (cn_model.group), in the units of D: mu times the
     * sum over units of their L2 norm over all training samples, estimated from the batch
     * as sqrt(pixels / rays) times the batch's norm. 0 (the default) is off. */
    double group;
    /* 0: a compressed model with a fine network does not send the coarse network's colour
     * (cn_model.drop_color); 1 (the default here; cnerf encode's default is 0) sends it,
     * which lets a receiver render the coarse network's image alone. */
    int coarse_color;
    /* Weight of the coarse network's squared error in the objective (1, the default here, as
     * NeRF; cnerf encode's is 0.1 when the coarse colour is not sent). The coarse colour is
     * never shown when there is a fine network: below 1 the rate penalty spends less on the
     * coarse network, whose density only places the fine samples. */
    double coarse_weight;
    /* The model a compressed run ends with (and writes) is the mean of its parameters over
     * the run's last `average` iterations instead of the last iteration's: the mean of the
     * latents, rounded, keeps what they settle on and drops their step-to-step noise, which
     * costs both bits and quality. Under rate control the size measured within those
     * iterations is the mean's. 0 (the default) is off. */
    long average;
    /* Every val_every iterations (0: never) the trainer measures the model on the dataset's
     * validation views and on its training views, CN_VAL_RAYS fixed rays each
     * (cn_validate.h); 100 by default. Training itself does not change. */
    long val_every;
    /* Compressed runs: the first float_iters iterations train the latents unrounded
     * (cn_model.unrounded), a float model in the affine decoders' coordinates that finds the
     * scene's geometry before rounding starts at iteration float_iters; they also warm the
     * learning rate up (lr_warmup). -1 (the default): until the first validation (every
     * val_every iterations) that finds the model out of the fog (cn_trainer_fog's
     * yardstick), at most CN_FLOAT_SHARE of the iterations; 0: rounded from the first
     * iteration (the paper's, and the training before the option). Rounding from scratch
     * kept preset small in fog on a phone capture whatever the rate (docs/training.md, "The
     * float phase"). */
    long float_iters;
} cn_train_opts;

/* 1024 rays, 5e-3 decaying tenfold over the run (NeRF: 5e-4 over 500k steps), preset
 * "small", centre crop of 50% (its iterations chosen by the views, see precrop_iters). */
void cn_train_defaults(cn_train_opts *o);

/* --preset auto: of the presets whose rate-distortion curves were measured (tiny, then
 * small), the largest whose latents sent get at least CN_AUTO_BITS bits each from the
 * target's bytes beyond its floor (headers, affine decoders and biases, cn_stream_floor);
 * tiny when none does. small's curve overtakes tiny's on Lego at 1.31 bits (3000 iterations
 * with encode's defaults, the coarse colour not sent; experiments/preset_frontier.sh,
 * docs/results.md "Which preset at which size"), but on the scene suite's real scenes at
 * 1.37 bits (30 kB) tiny was the better encode or within 0.31 dB on all eight, and small up
 * to 2.8 dB worse. CN_AUTO_BITS sits between that and Lego's 1.88 bits (40 kB), where small
 * leads tiny by 0.27 dB.
 * The scene enters through the floor (its render parameters): the presets share their
 * sample counts. *bits is the chosen preset's bits per latent. Returns 0, or -1 with a
 * message. */
#define CN_AUTO_BITS 1.6
int cn_preset_auto(const cn_dataset *ds, const cn_train_opts *o, double target,
                   const char **preset, double *bits, char *err, size_t errlen);
/* --preset auto's race: where both presets can meet the size, the encode trains tiny and
 * small side by side, each a whole encode of its own (rate control, float phase), and keeps
 * the one that the validation views (cn_validate.h) rank first; the other is dropped, and
 * the winner goes on from where it stands, the same model as an encode of that preset alone.
 * A preset that learns the scene more slowly, or that the size compresses harder, shows it
 * on the validation views within the first half of the run (docs/results.md, "Every scene
 * a user brings"): the trials this replaced, short runs at lambda 0, measured how fast a
 * preset learns, not what the size leaves of it.
 * Decisions are taken at validations (every val_every iterations) on the mean of small's
 * lead over tiny at the last CN_RACE_MEAN of them: from CN_RACE_FIRST of the run, a lead
 * beyond CN_RACE_MARGIN_DB either way ends the race; at CN_RACE_LAST the leader wins (tiny
 * on a tie: it renders cheaper). A lead of small's counts only where small was at its size
 * (within CN_RACE_SIZE_TOL over the target) at each of those validations: small starts at
 * two to three times the size and comes down to it late in the run (the plan arrives at
 * CN_RC_ARRIVE), and a lead bought with bytes it will not keep named the worse preset on
 * the chair of the suite (1.2 dB ahead at 59 kB of 30, 0.44 dB behind at 30). When small
 * leads at CN_RACE_LAST without being at its size, the race goes on until it is, and the
 * leader over those validations wins; at the end of the run the leader wins. Tiny's lead
 * counts whatever the sizes: it ends at or under its target, and small's bytes over the
 * target only flatter small. On the suite's encodes at 30 kB (both presets' validations
 * at every 100 iterations, 2,000 iterations, experiments/race_replay.py), this names the
 * better encode on the test views, or one within 0.3 dB, on every scene but DTU scan 24,
 * where the validation views tie. No race below CN_RACE_BITS bits per latent for small
 * (the rule's measure, cn_preset_auto: below every crossing of the presets measured), or in
 * runs shorter than CN_RACE_MIN_ITERS. */
#define CN_RACE_FIRST 0.15
#define CN_RACE_LAST 0.5
#define CN_RACE_MARGIN_DB 1.0
#define CN_RACE_MEAN 3
#define CN_RACE_SIZE_TOL 0.05
#define CN_RACE_BITS 1.0
#define CN_RACE_MIN_ITERS 1000
typedef struct cn_race {
    double lead[CN_RACE_MEAN]; /* small's validation PSNR minus tiny's, the last ones */
    int sized[CN_RACE_MEAN];   /* small at its size at those validations */
    int n;                     /* validations seen */
    double mean;               /* the mean lead at the last decision taken */
    int waiting;               /* small led at CN_RACE_LAST away from its size */
} cn_race;
/* The validation of both at `step` of `iters` (NaN: none yet, not counted), small_sized:
 * small's size then within CN_RACE_SIZE_TOL over the target: -1 to go on, 0 for tiny, 1 for
 * small. */
int cn_race_step(cn_race *r, long step, long iters, double val_tiny, double val_small,
                 int small_sized);

/* --preset auto resuming the checkpoint at path: of the presets it chooses between, the one
 * whose model the checkpoint holds (cn_checkpoint_holds), with o's other options; a run that
 * stepped down from the rule's choice resumes the preset it trained. Returns 0 with *preset
 * set, 1 when it holds none of them, -1 with a message. */
int cn_preset_of_checkpoint(const cn_dataset *ds, const cn_train_opts *o, const char *path,
                            const char **preset, char *err, size_t errlen);

/* The floor (cn_stream_floor) and the latents sent (cn_model_sent_latents) of o's preset on
 * this dataset, with the colour layers that o leaves out (cn_train_drop_color) left out. */
int cn_preset_floor(const cn_dataset *ds, const cn_train_opts *o, size_t *floor_bytes,
                    size_t *latents, char *err, size_t errlen);

/* Marks in m.drop_color the networks whose colour a run with options o does not send: the
 * coarse network's of a compressed model with two networks and coarse_color off. */
void cn_train_drop_color(cn_model *m, const cn_train_opts *o);

/* The stream header (render parameters and topology) for a dataset and options. */
int cn_header_for_dataset(const cn_dataset *ds, const cn_train_opts *o, cnerf_info *hdr,
                          char *err, size_t errlen);

typedef struct cn_trainer {
    cn_model model;
    cn_batch batch;
    const cn_dataset *ds;
    cn_train_opts opts;
    long step;        /* iterations done */
    float *gt;        /* batch x 3 */
    float *dcolor[2]; /* batch x 3 */
    cn_occ occ[2];
    double occ_frac[2]; /* occupied fraction after the last update */
    float *bg;          /* batch x 3 per-ray backgrounds when random_bg is on, else NULL */
    /* Rate control (cnerf encode --size): when rate_control is set, rc moves opts.lambda.
     * rc_grid_g is the encode's --grid (-1 automatic, 0 none), measured once (cn_ratectl.h). */
    int rate_control, rc_grid_g, rc_prune;
    /* Called before each step's forward pass when set: rate control's measurement
     * (compress/cn_rate.h installs it). Returns 0, or -1 with err set, which stops the step. */
    int (*step_hook)(struct cn_trainer *t);
    cn_ratectl rc;
    /* opts.average: the mean of the parameters over the avg_n iterations of the window
     * done so far (n_params doubles, NULL when off), and room for the parameters while the
     * mean stands in for them. */
    double *avg;
    float *avg_keep;
    long avg_n;
    /* Validation (opts.val_every, cn_validate.h): fixed rays of the validation and the
     * training views, and the last measurement of each (NaN before the first, or without
     * validation views), made after val_step iterations. */
    cn_val_rays val_rays, fit_rays;
    double val_psnr, fit_psnr;
    long val_step;
    /* The best validation PSNR of this process's run, its iteration and, under rate control,
     * the file's size measured then (0 without); collapsed is set, and the step fails with
     * its message in err, when under rate control the validation PSNR falls
     * CN_VAL_COLLAPSE_DB below that best; in a run started from a trained model (from_float),
     * whose best is the float model's, only when the training views also beat the
     * validation views by more than CN_VAL_GAP_DB. */
    double val_best, val_best_size;
    long val_best_step;
    int collapsed, from_float;
    long float_asked; /* opts.float_iters as asked (-1: the default share), before a resume */
    int float_left_fog; /* this process ended the default float phase at a validation */
    /* The validation PSNR of a flat colour, the training rays' mean (cn_val_flat_psnr);
     * NaN without validation views. */
    double flat_psnr;
    char err[512]; /* why cn_trainer_step returned NaN, when it says */
    /* The processes that share each batch (cn_trainer_share), or NULL: this one alone; the
     * sum of their votes to stop (cn_share.vote) at the last step: when it is not 0, every
     * rank stops after that step. */
    const cn_share *share;
    int stop_votes;
} cn_trainer;

int cn_trainer_init(cn_trainer *t, const cn_dataset *ds, const cn_train_opts *o, char *err,
                    size_t errlen);
void cn_trainer_free(cn_trainer *t);
/* Shares every batch from the next step on among share->size processes, each running the
 * same trainer (the same dataset, options and checkpoint) as rank share->rank: each renders
 * and differentiates the rays of its part of the batch's chunks (CN_CHUNK_RAYS), and the
 * errors and gradients are summed over all of them (share->allsum), so that every rank
 * takes the same step, the one a single process takes, to the bit. NULL or a size of 1:
 * one process. The share must outlive the trainer's steps. */
void cn_trainer_share(cn_trainer *t, const cn_share *share);
/* Every trainer that cn_trainer_init makes from now on shares its batches (cn_trainer_share):
 * a process that is one rank of several, every trainer of the command's run (NULL: none). */
void cn_trainer_share_all(const cn_share *share);
/* One iteration; returns the loss (coarse MSE + fine MSE) and the fine (or only) MSE;
 * with compression also the noisy rate estimate in bits (when `bits` is not NULL). Returns
 * NaN with a message in t->err when rate control fails (out of memory), or when a sum
 * over the ranks of a shared batch failed. */
double cn_trainer_step(cn_trainer *t, double *mse_last, double *bits);
/* The photometric loss of n colour values x against y: returns the squared error
 * SE = sum (x - y)^2 and writes grad = gscale (x - y), the gradient of the loss
 * L = gscale / 2 * SE (the trainer's gscale: 2 / (3 rays) for the mean squared error,
 * 2 pixels / rays for compression's summed squared error). */
double cn_sq_error(float *grad, const float *x, const float *y, size_t n, float gscale);
/* 1 when the last validation found fog: after at least CN_VAL_FOG_ITERS iterations, a
 * validation PSNR less than CN_VAL_FOG_DB above the flat colour's (cn_validate.h). */
int cn_trainer_fog(const cn_trainer *t);
/* Pixels in the training views (the distortion's scale). */
double cn_trainer_pixels(const cn_trainer *t);
/* lambda's scene-independent unit, 3 x training pixels / latents sent: the summed squared
 * error is 3 pixels times the MSE, the rate the latents sent (cn_model_sent_latents) times
 * the bits per latent. */
double cn_trainer_lambda_unit(const cn_trainer *t);
/* Within opts.average's window: puts the parameters' mean in the model's place (in 1), or
 * the parameters back (in 0). */
void cn_trainer_swap_mean(cn_trainer *t, int in);
/* --quality Q (0..100) as the slope k of cn_train_opts.quality_slope, in dB per bit per
 * latent sent: 1 at Q = 50, halving with each 10 more (Q 100: 1/32, Q 0: 32). */
double cn_quality_slope(double q);
/* Its inverse, for messages. */
double cn_quality_from_slope(double k);
/* The lambda that quality slope k gives at a step whose networks' mean squared errors, the
 * coarse network's at its weight (cn_train_opts.coarse_weight), sum to mse_sum:
 * k ln(10)/10 x mse_sum x 3 pixels / latents sent. */
double cn_quality_lambda(const cn_trainer *t, double k, double mse_sum);
/* Measures the current model on the validation and training rays (t->val_psnr,
 * t->fit_psnr, t->val_step); 0, or -1 on allocation failure. Without validation views it
 * measures nothing and leaves val_psnr NaN. */
int cn_trainer_validate(cn_trainer *t);
/* The learning rate's warm-up, in iterations (cn_train_opts.lr_warmup, its default resolved). */
long cn_trainer_warmup(const cn_trainer *t);
/* Current learning rate. */
double cn_trainer_lr(const cn_trainer *t);

/* Adam over m->params[lo, hi) at learning rate lr, at iteration `step` (1 first); zeroes
 * those gradients. */
void cn_adam_range(cn_model *m, size_t lo, size_t hi, double lr, long step);

/* Checkpoints: magic, version, step, options, header, parameters, Adam moments, the
 * occupancy grids, CRC (train.c has the layout). A resumed run continues bit for bit. */
int cn_checkpoint_save(const cn_trainer *t, const char *path, char *err, size_t errlen);
/* The same bytes appended to a buffer (out->oom on allocation failure). */
struct cn_buf;
void cn_checkpoint_put(const cn_trainer *t, struct cn_buf *out);
/* Starts an initialised compressed trainer from a float model (cnerf train's checkpoint of
 * the same topology, trained on the same views): its kernels become the latents at each
 * layer's initial decoder step, its biases are copied; moments, priors and the step start
 * afresh. */
int cn_trainer_init_from_float(cn_trainer *t, const char *path, char *err, size_t errlen);
/* Restores parameters, moments, the step and the occupancy grids into an initialised
 * trainer whose topology matches; a grid that the checkpoint lacks (version 1) or has at
 * another size stays empty and is rebuilt from the model at the next step. */
int cn_checkpoint_resume(cn_trainer *t, const char *path, char *err, size_t errlen);
/* The same from a checkpoint's bytes (path names them in messages). */
int cn_checkpoint_resume_data(cn_trainer *t, const char *path, const uint8_t *data, size_t len,
                              char *err, size_t errlen);
/* 1 when the checkpoint at path holds a model of m's topology and compression (the model a
 * cn_checkpoint_resume into a trainer of m needs), 0 when it holds another, -1 with a message
 * when it cannot be read. */
int cn_checkpoint_holds(const char *path, const cn_model *m, char *err, size_t errlen);
/* Loads a checkpoint's model alone (for evaluation); m is initialised by this call.
 * *step receives the iteration count when not NULL. */
int cn_checkpoint_load_model(const char *path, cn_model *m, long *step, char *err,
                             size_t errlen);

/* The camera of a dataset view. */
void cn_view_camera(const cn_view *v, cn_camera *cam);
/* Renders a whole view (rgb: w*h*3 floats) with the evaluation rule, `chunk` rays at a time. */
int cn_render_view(const cn_model *m, const cn_camera *cam, int ndc, float *rgb, size_t chunk);
/* The same, each ray ending once its transmittance is below t_stop as the decoder's does
 * (cnerf_render_opts.t_stop / 2^30): the float reference of a fixed-point render. */
int cn_render_view_stop(const cn_model *m, const cn_camera *cam, int ndc, float *rgb,
                        size_t chunk, float t_stop);

/* Whole views one after another through one batch, kept from view to view. At 4,096 rays a
 * batch holds hundreds of megabytes of activations: made and freed for each view, its pages
 * were mapped, faulted in and zeroed again every time, which took three quarters of an
 * evaluation's time. The batch is made at the first view and made again when a model of
 * another shape comes; the pixels are those of cn_render_view_stop with the same chunk.
 * Zero-initialise, render, then free. */
typedef struct cn_view_renderer {
    cn_batch batch;
    cnerf_info shape; /* the topology the batch was made for */
    size_t chunk;
    int live;
    unsigned made; /* batches made since the last cn_view_renderer_free */
} cn_view_renderer;
int cn_view_render(cn_view_renderer *r, const cn_model *m, const cn_camera *cam, int ndc,
                   float *rgb, size_t chunk, float t_stop);
void cn_view_renderer_free(cn_view_renderer *r);

#endif /* CNERF_ENC_TRAIN_H */
