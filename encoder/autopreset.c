/* --preset auto: the model's size from the budget and the scene (cn_train.h). */
#include <stdio.h>
#include <string.h>

#include "cn_ratectl.h"
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

int cn_preset_auto(const cn_dataset *ds, const cn_train_opts *o, double target,
                   const char **preset, double *bits, char *err, size_t errlen)
{
    static const char *const order[] = {"tiny", "small"}; /* the presets measured */
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
