/* Synthetic models: random latents of a topology. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_rng.h"
#include "cn_synth.h"

void cn_synth_free(cn_synth *s)
{
    for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++) {
        free(s->k[l]);
        free(s->bias[l]);
        s->k[l] = s->bias[l] = NULL;
    }
}

/* round(Laplace(0, spread)) clamped to the latents' range. */
static int32_t laplace_int(cn_rng *r, double spread)
{
    double v = cn_rng_laplace(r, spread);
    v = v > CNERF_MAX_ABS_K ? CNERF_MAX_ABS_K : v < -CNERF_MAX_ABS_K ? -CNERF_MAX_ABS_K : v;
    return (int32_t)lround(v);
}

int cn_synth_make(cn_synth *s, const cnerf_info *hdr, uint64_t seed, double spread, char *err,
                  size_t errlen)
{
    memset(s, 0, sizeof *s);
    s->src.hdr = *hdr;
    cnerf_info info = *hdr;
    cnerf_status st = cnerf_expand_topology(&info);
    if (st != CNERF_OK) {
        snprintf(err, errlen, "invalid topology: %s", cnerf_status_str(st));
        return -1;
    }
    cn_rng r = cn_rng_seed(seed);
    for (unsigned l = 0; l < info.n_layers; l++) {
        const cnerf_layer_info *L = &info.layer[l];
        size_t count = (size_t)L->n_in * L->n_out;
        s->k[l] = malloc(sizeof(int32_t) * count);
        s->bias[l] = malloc(sizeof(int32_t) * L->n_out);
        if (!s->k[l] || !s->bias[l]) {
            cn_synth_free(s);
            snprintf(err, errlen, "out of memory");
            return -1;
        }
        for (size_t i = 0; i < count; i++)
            s->k[l][i] = laplace_int(&r, spread);
        for (unsigned j = 0; j < L->n_out; j++)
            s->bias[l][j] = (int32_t)cn_rng_below(&r, 65536) - 32768;
        cn_layer_src *S = &s->src.layer[l];
        S->k = s->k[l];
        S->bias_m = s->bias[l];
        S->bias_bits = 16;
        S->bias_e = -16;
        /* a spreads the latents over roughly the Glorot range of the layer. */
        double glorot = sqrt(6.0 / (L->n_in + L->n_out));
        cn_to_m24e8(glorot / (3.0 * (spread > 0.5 ? spread : 0.5)), &S->a_m, &S->a_e);
        cn_to_m24e8((cn_rng_uniform(&r) - 0.5) * 1e-3, &S->b_m, &S->b_e);
    }
    return 0;
}

void cn_synth_shift_free(cn_synth_shift *s)
{
    for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++) {
        free(s->s[l]);
        s->s[l] = NULL;
    }
}

int cn_synth_shift_make(cn_synth_shift *s, const cn_synth *ref, uint64_t seed, double spread,
                        double g_rel, char *err, size_t errlen)
{
    memset(s, 0, sizeof *s);
    cnerf_info info = ref->src.hdr;
    cnerf_status st = cnerf_expand_topology(&info);
    if (st != CNERF_OK) {
        snprintf(err, errlen, "invalid topology: %s", cnerf_status_str(st));
        return -1;
    }
    cn_rng r = cn_rng_seed(seed);
    for (unsigned l = 0; l < info.n_layers; l++) {
        const cnerf_layer_info *L = &info.layer[l];
        const size_t count = (size_t)L->n_in * L->n_out;
        s->s[l] = malloc(sizeof(int32_t) * count);
        if (!s->s[l]) {
            cn_synth_shift_free(s);
            snprintf(err, errlen, "out of memory");
            return -1;
        }
        for (size_t i = 0; i < count; i++)
            s->s[l][i] = spread > 0 ? laplace_int(&r, spread) : 0;
        cn_shift_src *S = &s->src[l];
        S->s = s->s[l];
        const cn_layer_src *R = &ref->src.layer[l];
        cn_to_m24e8(g_rel * cn_from_m24e8(R->a_m, R->a_e), &S->g_m, &S->g_e);
    }
    return 0;
}
