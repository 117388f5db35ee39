/* --preset auto: the model's size from the budget and the scene (cn_train.h). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cn_rate.h"
#include "cn_train.h"

int cn_preset_floor(const cn_dataset *ds, const cn_train_opts *o, size_t *floor_bytes,
                    size_t *latents, char *err, size_t errlen)
{
    cnerf_info hdr;
    if (cn_header_for_dataset(ds, o, &hdr, err, errlen))
        return -1;
    cn_model m;
    if (cn_model_init_compressed(&m, &hdr, o->seed, o->levels, err, errlen))
        return -1;
    cn_train_drop_color(&m, o);
    *latents = cn_model_sent_latents(&m);
    const int rc = cn_stream_floor(&m, o->seed, floor_bytes, err, errlen);
    cn_model_free(&m);
    return rc;
}

static const char *const order[] = {"tiny", "small"}; /* the presets measured, smallest first */

int cn_preset_auto(const cn_dataset *ds, const cn_train_opts *o, double target,
                   const char **preset, double *bits, char *err, size_t errlen)
{
    const size_t n = sizeof order / sizeof order[0];
    for (size_t i = n; i-- > 0;) {
        cn_train_opts p = *o;
        p.preset = order[i];
        size_t floor_bytes, latents;
        if (cn_preset_floor(ds, &p, &floor_bytes, &latents, err, errlen))
            return -1;
        const double b = 8 * (target - (double)floor_bytes) / (double)latents;
        if (b >= CN_AUTO_BITS || i == 0) {
            *preset = order[i];
            *bits = b;
            return 0;
        }
    }
    return -1; /* not reached */
}

double cn_preset_trial(const cn_dataset *ds, const cn_train_opts *o, const char *preset,
                       long iters, char *err, size_t errlen)
{
    cn_train_opts p = *o;
    p.preset = preset;
    p.iters = iters;
    p.compress = 1;
    p.lambda = 0;
    p.quality_slope = 0;
    p.average = 0;
    p.val_every = 0;
    p.precrop_iters = 0; /* measured on whole views: a crop would leave their borders untrained */
    cn_trainer t;
    if (cn_trainer_init(&t, ds, &p, err, errlen))
        return -1;
    for (long i = 0; i < iters; i++)
        if (isnan(cn_trainer_step(&t, NULL, NULL))) {
            snprintf(err, errlen, "%s", t.err);
            cn_trainer_free(&t);
            return -1;
        }
    const int rc = cn_trainer_validate(&t);
    const double v = t.val_psnr; /* NaN without validation views */
    cn_trainer_free(&t);
    if (rc) {
        snprintf(err, errlen, "out of memory for validation");
        return -1;
    }
    return v;
}

int cn_preset_of_checkpoint(const cn_dataset *ds, const cn_train_opts *o, const char *path,
                            const char **preset, char *err, size_t errlen)
{
    for (size_t i = 0; i < sizeof order / sizeof order[0]; i++) {
        cn_train_opts p = *o;
        p.preset = order[i];
        cnerf_info hdr;
        cn_model m;
        if (cn_header_for_dataset(ds, &p, &hdr, err, errlen) ||
            cn_model_init_compressed(&m, &hdr, p.seed, p.levels, err, errlen))
            return -1;
        const int holds = cn_checkpoint_holds(path, &m, err, errlen);
        cn_model_free(&m);
        if (holds < 0)
            return -1;
        if (holds) {
            *preset = order[i];
            return 0;
        }
    }
    return 1;
}
