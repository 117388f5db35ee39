/*
 * Validation: what a model delivers on views it never trained on, measured while it trains.
 *
 * The held-out views. A dataset with its own validation split (Blender's val) keeps it and
 * trains on all of its training views. Any other dataset gives up some of its training
 * views: by default one in CN_VAL_PER_VIEWS, rounded, at least 1 and at most
 * CN_VAL_MAX_VIEWS, spread evenly over the training views in their order; a dataset of
 * fewer than CN_VAL_MIN_TRAIN training views keeps them all and is not validated. The rule
 * depends on the training views alone, so that `cnerf eval --split val` finds the same views.
 *
 * The measurement. CN_VAL_RAYS pixels drawn once, at random (seeded), from the held-out
 * views, and as many from the training views, are rendered with the evaluation rule (sample
 * midpoints, no training grid) and compared with the images: the validation PSNR and a
 * training PSNR on fixed rays, which differ from each other only by the views.
 */
#ifndef CNERF_ENC_VALIDATE_H
#define CNERF_ENC_VALIDATE_H

#include <stddef.h>
#include <stdint.h>

#include "cn_dataset.h"
#include "cn_nerf.h"

#define CN_VAL_PER_VIEWS 16
#define CN_VAL_MAX_VIEWS 8
#define CN_VAL_MIN_TRAIN 8
#define CN_VAL_RAYS 1024
/* A model whose training PSNR (on fixed rays) exceeds its validation PSNR by more than this
 * many dB is reported as not generalizing: too few views, bad poses, or a degenerate
 * solution that paints each view's colours on rays instead of finding the geometry. */
#define CN_VAL_GAP_DB 6.0
/* Under rate control, a validation PSNR this many dB below the best it reached means the
 * rate penalty is destroying the model rather than trading a little quality for bytes: the
 * run stops (cn_trainer.collapsed) instead of writing a file of fog. */
#define CN_VAL_COLLAPSE_DB 5.0
/* Fog: a model whose validation PSNR is less than CN_VAL_FOG_DB above that of a flat colour
 * (the training rays' mean painted on every validation ray) has not found the scene: it
 * leaves more than half of the flat colour's squared error. After CN_VAL_FOG_ITERS
 * iterations or more, such a model is reported (train) or refused (encode --size); a shorter
 * run may not have left the flat colour yet on any scene. On the scene suite the slowest to
 * leave it (preset small on a phone capture of a figure, float) was 3.1 dB above it after
 * 500 iterations, and every model that found its scene 9.7 to 15.4 dB above it after 2000;
 * the fog that the suite met was 1.5 dB above it (docs/training.md, "Validation"). */
#define CN_VAL_FOG_DB 3.0
#define CN_VAL_FOG_ITERS 1000

/* The number of training views the default rule holds out of a dataset of n_train training
 * views and n_val validation views (0 when it has a validation split of its own). */
int cn_val_default_views(int n_train, int n_val);

/* Holds out n training views (n < 0: the default rule) by moving them, spread evenly, into
 * ds's validation split. A dataset with validation views of its own is left as it is.
 * Returns the number moved, or -1 with a message (n too large, out of memory). */
int cn_dataset_hold_out(cn_dataset *ds, int n, char *err, size_t errlen);

/* A fixed set of rays with their ground truth. */
typedef struct cn_val_rays {
    size_t n;
    float *o, *d, *vd, *gt; /* n x 3 each */
} cn_val_rays;

/* Draws `rays` pixels uniformly over views[0..n_views) (seeded); 0 or -1 on allocation
 * failure. An empty set (n_views 0) is valid and measures nothing. */
int cn_val_rays_init(cn_val_rays *v, const cn_view *views, int n_views, int ndc, size_t rays,
                     uint64_t seed);
void cn_val_rays_free(cn_val_rays *v);

/* The model's PSNR on the rays with the evaluation rule; NaN for an empty set, -1 on
 * allocation failure. */
double cn_val_psnr(const cn_model *m, const cn_val_rays *v);

/* The mean colour of the rays' ground truth; -1 for an empty set. */
int cn_val_mean_color(const cn_val_rays *v, float mean[3]);

/* The PSNR on the rays of one colour painted everywhere; NaN for an empty set. */
double cn_val_flat_psnr(const cn_val_rays *v, const float color[3]);

#endif /* CNERF_ENC_VALIDATE_H */
