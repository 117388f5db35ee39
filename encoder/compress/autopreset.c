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

int cn_race_step(cn_race *r, long step, long iters, double val_tiny, double val_small,
                 int small_sized)
{
    const int last = (double)step >= CN_RACE_LAST * (double)iters;
    if (isnan(val_tiny) || isnan(val_small)) /* no validation yet: nothing to tell */
        return r->n == 0 ? (last ? 0 : -1) : last && !r->waiting ? r->mean > 0 : -1;
    r->sized[r->n % CN_RACE_MEAN] = small_sized != 0;
    r->lead[r->n++ % CN_RACE_MEAN] = val_small - val_tiny;
    const int k = r->n < CN_RACE_MEAN ? r->n : CN_RACE_MEAN;
    double sum = 0;
    int sized = 1;
    for (int i = 0; i < k; i++) {
        sum += r->lead[i];
        sized &= r->sized[i];
    }
    r->mean = sum / k;
    if ((double)step < CN_RACE_FIRST * (double)iters)
        return -1;
    if (r->waiting) /* only a window with small at its size decides */
        return sized && k == CN_RACE_MEAN ? r->mean > 0 : -1;
    if (r->mean < -CN_RACE_MARGIN_DB || (r->mean > CN_RACE_MARGIN_DB && sized))
        return r->mean > 0;
    if (!last)
        return -1;
    if (r->mean > 0 && !sized) {
        r->waiting = 1;
        return -1;
    }
    return r->mean > 0;
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
