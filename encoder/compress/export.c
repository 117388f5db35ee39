/* Model <-> stream. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_export.h"
#include "cn_occ.h"
#include "cn_prior.h"

static size_t layer_size(const cn_model *m, unsigned l)
{
    return (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
}

int cn_model_snap(cn_model *m, char *err, size_t errlen)
{
    if (!m->compressed) {
        snprintf(err, errlen, "only compressed models carry an affine decoder");
        return -1;
    }
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        for (int k = 0; k < 2; k++) {
            float *v = &m->params[m->off_ab + 2 * l + (size_t)k];
            int32_t mm;
            int8_t e;
            if (cn_to_m24e8(*v, &mm, &e)) {
                snprintf(err, errlen, "layer %u: affine decoder %s = %g cannot be coded", l,
                         k ? "b" : "a", *v);
                return -1;
            }
            *v = (float)cn_from_m24e8(mm, e);
        }
        const unsigned n = m->topo.layer[l].n_out;
        float *b = m->params + m->layer[l].b;
        int32_t *mant = malloc(sizeof(int32_t) * n);
        uint8_t bits;
        int8_t e;
        if (!mant || cn_quantize_biases(b, n, CN_BIAS_BITS, mant, &bits, &e)) {
            free(mant);
            snprintf(err, errlen, "layer %u: biases cannot be coded (non-finite?)", l);
            return -1;
        }
        for (unsigned j = 0; j < n; j++)
            b[j] = bits ? (float)ldexp(mant[j], e) : 0.0f;
        free(mant);
    }
    return 0;
}

/* Common part: header, bias blocks and buffers. */
static int export_begin(const cn_model *m, const char *meta, cn_export *e, char *err,
                        size_t errlen)
{
    memset(e, 0, sizeof *e);
    e->src.hdr = m->topo;
    e->src.meta = meta;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        const unsigned n_out = m->topo.layer[l].n_out;
        e->k[l] = malloc(sizeof(int32_t) * layer_size(m, l));
        e->bias[l] = malloc(sizeof(int32_t) * n_out);
        if (!e->k[l] || !e->bias[l]) {
            cn_export_free(e);
            snprintf(err, errlen, "out of memory");
            return -1;
        }
        cn_layer_src *S = &e->src.layer[l];
        S->k = e->k[l];
        S->bias_m = e->bias[l];
        if (cn_quantize_biases(m->params + m->layer[l].b, n_out, CN_BIAS_BITS, e->bias[l],
                               &S->bias_bits, &S->bias_e)) {
            cn_export_free(e);
            snprintf(err, errlen, "layer %u: biases cannot be coded (non-finite?)", l);
            return -1;
        }
    }
    return 0;
}

int cn_export_compressed(const cn_model *m, const char *meta, cn_export *e, char *err,
                         size_t errlen)
{
    if (!m->compressed) {
        snprintf(err, errlen, "the model was trained without compression");
        return -1;
    }
    if (export_begin(m, meta, e, err, errlen))
        return -1;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        cn_layer_src *S = &e->src.layer[l];
        const size_t n = layer_size(m, l);
        int32_t kmin = 0, kmax = 0;
        for (size_t i = 0; i < n; i++) {
            int32_t k = cn_model_latent(m, l, i);
            if (k < -CNERF_MAX_ABS_K || k > CNERF_MAX_ABS_K) {
                cn_export_free(e);
                snprintf(err, errlen, "layer %u: latent %d outside +-%d", l, k, CNERF_MAX_ABS_K);
                return -1;
            }
            e->k[l][i] = k;
            kmin = i == 0 || k < kmin ? k : kmin;
            kmax = i == 0 || k > kmax ? k : kmax;
        }
        if (cn_to_m24e8(m->params[m->off_ab + 2 * l], &S->a_m, &S->a_e) ||
            cn_to_m24e8(m->params[m->off_ab + 2 * l + 1], &S->b_m, &S->b_e)) {
            cn_export_free(e);
            snprintf(err, errlen, "layer %u: affine decoder cannot be coded", l);
            return -1;
        }
        const unsigned na = (unsigned)(kmax - kmin) + 1;
        e->pmf[l] = malloc(sizeof(double) * na);
        if (!e->pmf[l]) {
            cn_export_free(e);
            snprintf(err, errlen, "out of memory");
            return -1;
        }
        cn_prior_pmf(m->params + m->off_prior + CN_PRIOR_PARAMS * (size_t)l, kmin, na, e->pmf[l]);
        S->pmf = e->pmf[l];
        S->pmf_kmin = kmin;
        S->pmf_n = na;
    }
    for (unsigned n = 0; n < m->topo.n_nets; n++)
        if (m->drop_color[n])
            cn_export_drop_color(e, n);
    return 0;
}

int cn_export_quantized(const cn_model *m, unsigned bits, const char *meta, cn_export *e,
                        char *err, size_t errlen)
{
    if (bits < 2 || bits > 16) {
        snprintf(err, errlen, "quantization to %u bits is not supported (2..16)", bits);
        return -1;
    }
    if (export_begin(m, meta, e, err, errlen))
        return -1;
    const int32_t half = (int32_t)(1u << (bits - 1)) - 1; /* levels -half .. half */
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        cn_layer_src *S = &e->src.layer[l];
        const size_t n = layer_size(m, l);
        const float *w = cn_model_kernel(m, l);
        float lo = w[0], hi = w[0];
        for (size_t i = 0; i < n; i++) {
            lo = w[i] < lo ? w[i] : lo;
            hi = w[i] > hi ? w[i] : hi;
        }
        double a = ((double)hi - lo) / (2.0 * half), b = 0.5 * ((double)hi + lo);
        if (!(a > 0))
            a = 1; /* constant layer: every k is 0 */
        if (cn_to_m24e8(a, &S->a_m, &S->a_e) || cn_to_m24e8(b, &S->b_m, &S->b_e)) {
            cn_export_free(e);
            snprintf(err, errlen, "layer %u: weights out of range", l);
            return -1;
        }
        const double aq = cn_from_m24e8(S->a_m, S->a_e), bq = cn_from_m24e8(S->b_m, S->b_e);
        for (size_t i = 0; i < n; i++) {
            long k = lround((w[i] - bq) / aq);
            e->k[l][i] = (int32_t)(k < -half ? -half : k > half ? half : k);
        }
    }
    return 0;
}

void cn_export_drop_color(cn_export *e, unsigned net)
{
    unsigned first, count;
    if (!cn_color_layers(&e->src.hdr, net, &first, &count))
        return;
    for (unsigned l = first; l < first + count; l++) {
        const cnerf_layer_info *L = &e->src.hdr.layer[l];
        cn_layer_src *S = &e->src.layer[l];
        memset(e->k[l], 0, sizeof(int32_t) * L->n_in * L->n_out);
        memset(e->bias[l], 0, sizeof(int32_t) * L->n_out);
        S->b_m = 0;
        S->b_e = 0;
        S->bias_bits = 0;
        S->bias_e = 0;
        if (e->pmf[l]) { /* one symbol, 0: the layer is constant */
            e->pmf[l][0] = 1.0;
            S->pmf_kmin = 0;
            S->pmf_n = 1;
        }
    }
}

void cn_export_free(cn_export *e)
{
    for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++) {
        free(e->k[l]);
        free(e->bias[l]);
        free(e->pmf[l]);
        e->k[l] = e->bias[l] = NULL;
        e->pmf[l] = NULL;
    }
}

int cn_model_from_stream(const cnerf_decoder *dec, cn_model *m, char *err, size_t errlen)
{
    const cnerf_info *I = &dec->info;
    if (cn_model_init_compressed(m, I, 0, 1.0, err, errlen))
        return -1;
    for (unsigned l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        float *phi = m->params + m->layer[l].w;
        for (uint32_t o = 0; o < L->n_out; o++)
            for (uint32_t i = 0; i < L->n_in; i++)
                phi[(size_t)o * L->n_in + i] = (float)cnerf_latent(dec, l, o, i);
        m->params[m->off_ab + 2 * l] = (float)cn_from_m24e8(L->a_m, L->a_e);
        m->params[m->off_ab + 2 * l + 1] = (float)cn_from_m24e8(L->b_m, L->b_e);
        float *b = m->params + m->layer[l].b;
        for (uint32_t o = 0; o < L->n_out; o++)
            b[o] = L->bias_bits ? (float)ldexp(cnerf_bias(dec, l, o), L->bias_e) : 0.0f;
    }
    int shifted = 0;
    for (unsigned l = 0; l < I->n_layers; l++)
        shifted |= I->shift[l].smin != 0 || I->shift[l].smax != 0;
    if (shifted) {
        /* the set's shared shift: latents S, a = g, b = 0 */
        cn_model *sh = calloc(1, sizeof *sh);
        if (!sh || cn_model_init_compressed(sh, I, 0, 1.0, err, errlen)) {
            free(sh);
            cn_model_free(m);
            if (!sh)
                snprintf(err, errlen, "out of memory");
            return -1;
        }
        for (unsigned l = 0; l < I->n_layers; l++) {
            const cnerf_layer_info *L = &I->layer[l];
            float *s = sh->params + sh->layer[l].w;
            for (uint32_t o = 0; o < L->n_out; o++)
                for (uint32_t i = 0; i < L->n_in; i++)
                    s[(size_t)o * L->n_in + i] = (float)cnerf_shift(dec, l, o, i);
            sh->params[sh->off_ab + 2 * l] =
                (float)cn_from_m24e8(I->shift[l].g_m, I->shift[l].g_e);
            sh->params[sh->off_ab + 2 * l + 1] = 0.0f;
        }
        cn_model_materialize(sh);
        m->shift = sh;
        m->own_shift = 1;
    }
    cn_model_materialize(m);
    if (I->grid_g) {
        const size_t g = I->grid_g, cells = g * g * g;
        uint8_t *occ = malloc(cells);
        m->grid = malloc(sizeof *m->grid);
        if (occ)
            for (size_t c = 0; c < cells; c++)
                occ[c] = (uint8_t)cnerf_cell_occupied(dec, (uint32_t)c);
        if (!occ || !m->grid || cn_occ_init_stream(m->grid, I, (int)g, occ)) {
            free(occ);
            free(m->grid);
            m->grid = NULL;
            cn_model_free(m);
            snprintf(err, errlen, "out of memory");
            return -1;
        }
        free(occ);
    }
    return 0;
}
