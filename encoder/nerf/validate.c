/* Validation views and rays (cn_validate.h). */
#include "cn_validate.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_metrics.h"
#include "cn_render.h"
#include "cn_rng.h"
#include "cn_train.h"

int cn_val_default_views(int n_train, int n_val)
{
    if (n_val > 0 || n_train < CN_VAL_MIN_TRAIN)
        return 0;
    int n = (n_train + CN_VAL_PER_VIEWS / 2) / CN_VAL_PER_VIEWS;
    return n < 1 ? 1 : n > CN_VAL_MAX_VIEWS ? CN_VAL_MAX_VIEWS : n;
}

int cn_dataset_hold_out(cn_dataset *ds, int n, char *err, size_t errlen)
{
    if (ds->n_val > 0)
        return 0;
    if (n < 0)
        n = cn_val_default_views(ds->n_train, ds->n_val);
    if (n == 0)
        return 0;
    if (n >= ds->n_train) {
        snprintf(err, errlen, "cannot hold out %d of %d training views for validation: at "
                 "least one must remain to train on", n, ds->n_train);
        return -1;
    }
    cn_view *val = malloc(sizeof *val * (size_t)n);
    if (!val) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    /* View k of the held-out ones is training view floor((k + 1/2) n_train / n): evenly
     * spread, and never the first (often a test view's neighbour in LLFF's order). */
    int kept = 0, k = 0;
    for (int i = 0; i < ds->n_train; i++) {
        const int pick = k < n && i == (int)(((2 * (long)k + 1) * ds->n_train) / (2 * (long)n));
        if (pick)
            val[k++] = ds->train[i];
        else
            ds->train[kept++] = ds->train[i];
    }
    ds->n_train = kept;
    ds->val = val;
    ds->n_val = n;
    return n;
}

int cn_val_rays_init(cn_val_rays *v, const cn_view *views, int n_views, int ndc, size_t rays,
                     uint64_t seed)
{
    memset(v, 0, sizeof *v);
    if (n_views < 1 || rays == 0)
        return 0;
    v->o = malloc(sizeof(float) * 3 * rays);
    v->d = malloc(sizeof(float) * 3 * rays);
    v->vd = malloc(sizeof(float) * 3 * rays);
    v->gt = malloc(sizeof(float) * 3 * rays);
    if (!v->o || !v->d || !v->vd || !v->gt) {
        cn_val_rays_free(v);
        return -1;
    }
    cn_rng rng = cn_rng_seed(seed * 0xD1B54A32D192ED03ull + 0x56A1ull);
    for (size_t r = 0; r < rays; r++) {
        const cn_view *w = &views[cn_rng_below(&rng, (uint32_t)n_views)];
        const int x = (int)cn_rng_below(&rng, (uint32_t)w->w);
        const int y = (int)cn_rng_below(&rng, (uint32_t)w->h);
        cn_camera cam;
        cn_view_camera(w, &cam);
        cn_camera_ray(&cam, ndc, x, y, v->o + 3 * r, v->d + 3 * r, v->vd + 3 * r);
        memcpy(v->gt + 3 * r, w->rgb + 3 * ((size_t)y * w->w + x), sizeof(float) * 3);
    }
    v->n = rays;
    return 0;
}

void cn_val_rays_free(cn_val_rays *v)
{
    free(v->o);
    free(v->d);
    free(v->vd);
    free(v->gt);
    memset(v, 0, sizeof *v);
}

double cn_val_psnr(const cn_model *m, const cn_val_rays *v)
{
    if (v->n == 0)
        return NAN;
    const size_t chunk = v->n < 1024 ? v->n : 1024;
    cn_batch b;
    if (cn_batch_init(&b, &m->topo, chunk))
        return -1;
    b.occ[0] = b.occ[1] = m->grid;
    const unsigned last = m->topo.n_nets - 1;
    double se = 0;
    for (size_t start = 0; start < v->n; start += chunk) {
        const size_t R = v->n - start < chunk ? v->n - start : chunk;
        memcpy(b.o, v->o + 3 * start, sizeof(float) * 3 * R);
        memcpy(b.d, v->d + 3 * start, sizeof(float) * 3 * R);
        memcpy(b.vd, v->vd + 3 * start, sizeof(float) * 3 * R);
        cn_render_forward(m, &b, R, NULL);
        for (size_t i = 0; i < 3 * R; i++) {
            const double e = (double)b.color[last][i] - v->gt[3 * start + i];
            se += e * e;
        }
    }
    cn_batch_free(&b);
    return cn_psnr_from_mse(se / (3.0 * (double)v->n));
}

int cn_val_mean_color(const cn_val_rays *v, float mean[3])
{
    if (v->n == 0)
        return -1;
    double s[3] = {0, 0, 0};
    for (size_t i = 0; i < v->n; i++)
        for (int c = 0; c < 3; c++)
            s[c] += v->gt[3 * i + c];
    for (int c = 0; c < 3; c++)
        mean[c] = (float)(s[c] / (double)v->n);
    return 0;
}

double cn_val_flat_psnr(const cn_val_rays *v, const float color[3])
{
    if (v->n == 0)
        return NAN;
    double se = 0;
    for (size_t i = 0; i < v->n; i++)
        for (int c = 0; c < 3; c++) {
            const double e = (double)v->gt[3 * i + c] - color[c];
            se += e * e;
        }
    return cn_psnr_from_mse(se / (3.0 * (double)v->n));
}
