/* Removal of provably dead units at export (cn_prune.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_prune.h"

#define ULP 0x1p-16 /* one step of the decoder's Q16 activations */

static double bias_of(const cn_layer_src *S, unsigned o)
{
    return S->bias_m && S->bias_bits ? ldexp(S->bias_m[o], S->bias_e) : 0.0;
}

/* Output bounds of layer L from its inputs' bounds [lo, hi]. The decoder feeds each input
 * x to its sums as x_q 2^-f = sat16(round(x 2^f)) 2^-f, which lies within half a step
 * 2^(-f-1) of x clamped to the int16 range, then computes a (sum k x_q) + b (sum x_q) +
 * bias with exact sums and three roundings of at most one Q16 step each; the float
 * reference computes the sum of the unquantized inputs in float32 (relative error below
 * (n_in + 2) 2^-24 of the magnitudes). The input intervals are widened to hold both
 * renderers' inputs, and the margin covers the roundings and the double sums here. */
static void layer_bounds(const cnerf_layer_info *L, const cn_layer_src *S, const double *lo,
                         const double *hi, int relu, double *olo, double *ohi, uint8_t *dead,
                         uint8_t *constant)
{
    const double a = cn_from_m24e8(S->a_m, S->a_e), b = cn_from_m24e8(S->b_m, S->b_e);
    const double step = ldexp(1.0, -S->f_in), qmin = -32768 * step, qmax = 32767 * step;
    for (unsigned o = 0; o < L->n_out; o++) {
        const int32_t *k = S->k + (size_t)o * L->n_in;
        double slo = 0, shi = 0, mag = 0, spread = 0;
        int zero = 1; /* every coefficient exactly 0 */
        for (unsigned i = 0; i < L->n_in; i++) {
            const double xl = fmin(lo[i], fmin(fmax(lo[i], qmin), qmax) - step / 2);
            const double xh = fmax(hi[i], fmin(fmax(hi[i], qmin), qmax) + step / 2);
            const double c = a * k[i] + b, p = c * xl, q = c * xh;
            slo += fmin(p, q);
            shi += fmax(p, q);
            mag += fmax(fabs(p), fabs(q));
            spread += fabs(c) * (hi[i] - lo[i]); /* constant inputs give constant x_q */
            zero &= c == 0;
        }
        const double bias = bias_of(S, o);
        /* A row of zeros with no bias sums to exactly 0 in both renderers: no rounding. */
        const double margin = zero && bias == 0 ? 0
                              : 4 * ULP + (L->n_in + 4.0) * 0x1p-22 * (mag + fabs(bias));
        double vlo = slo + bias - margin, vhi = shi + bias + margin;
        vlo = fmax(vlo, -32768.0); /* the decoder clamps to int32 Q16 */
        vhi = fmin(vhi, 32768.0);
        if (relu) {
            dead[o] = vhi <= 0;
            constant[o] = !dead[o] && spread == 0;
            vlo = fmax(vlo, 0.0);
            vhi = fmax(vhi, 0.0);
            if (dead[o])
                vlo = vhi = 0;
        }
        olo[o] = vlo;
        ohi[o] = vhi;
    }
}

/* Bounds of a positional encoding: the raw input (inc) in [rlo, rhi] per axis, then sines
 * and cosines in [-1, 1]. */
static unsigned encoding_bounds(unsigned L, int inc, const double rlo[3], const double rhi[3],
                                double *lo, double *hi)
{
    unsigned n = 0;
    for (unsigned a = 0; inc && a < 3; a++, n++) {
        lo[n] = rlo[a];
        hi[n] = rhi[a];
    }
    for (unsigned i = 0; i < 6 * L; i++, n++) {
        lo[n] = -1;
        hi[n] = 1;
    }
    return n;
}

/* dead[l][o] and constant[l][o] for the ReLU layers of an expanded topology. Returns 0 or -1
 * (out of memory). */
static int analyse(const cnerf_info *I, const cn_layer_src *src, uint8_t *const dead[],
                   uint8_t *const constant[])
{
    const size_t cap = CNERF_MAX_LAYER_IN + 8;
    double *lo = malloc(sizeof(double) * cap * 4);
    if (!lo)
        return -1;
    double *hi = lo + cap, *olo = hi + cap, *ohi = olo + cap;
    const int inc = (I->pe_flags & CNERF_PE_INCLUDE_INPUT) != 0;
    double blo[3], bhi[3], dlo[3], dhi[3];
    for (int a = 0; a < 3; a++) {
        /* Samples are evaluated inside the box; the float path's points may sit a
         * rounding outside it. */
        const double mn = I->aabb_q16[a] / 65536.0, mx = I->aabb_q16[a + 3] / 65536.0;
        blo[a] = mn - 1e-3 * (mx - mn) - ULP;
        bhi[a] = mx + 1e-3 * (mx - mn) + ULP;
        dlo[a] = -1 - ULP; /* unit view directions */
        dhi[a] = 1 + ULP;
    }
    for (unsigned n = 0; n < I->n_nets; n++) {
        const cnerf_net_info *N = &I->net[n];
        const unsigned P = encoding_bounds(I->l_pos, inc, blo, bhi, lo, hi);
        unsigned width = P; /* inputs of the next layer held in lo/hi */
        for (unsigned i = 0; i < N->depth; i++) {
            const unsigned l = N->first_layer + i;
            const int skip_in = i > 0 && N->skip != CNERF_NO_SKIP && i == N->skip + 1u;
            if (skip_in) {
                /* [PE(x), h]: the encoding first */
                memmove(lo + P, lo, sizeof(double) * width);
                memmove(hi + P, hi, sizeof(double) * width);
                encoding_bounds(I->l_pos, inc, blo, bhi, lo, hi);
            }
            layer_bounds(&I->layer[l], &src[l], lo, hi, 1, olo, ohi, dead[l], constant[l]);
            width = I->layer[l].n_out;
            memcpy(lo, olo, sizeof(double) * width);
            memcpy(hi, ohi, sizeof(double) * width);
        }
        if (N->view_width) {
            const unsigned l = N->first_layer + N->depth;
            uint8_t *scratch = calloc(2 * (size_t)I->layer[l + 1].n_out, 1);
            if (!scratch) {
                free(lo);
                return -1;
            }
            /* feature (no activation), then [feature, PE(d)] into the view layer */
            layer_bounds(&I->layer[l + 1], &src[l + 1], lo, hi, 0, olo, ohi, scratch,
                         scratch + I->layer[l + 1].n_out);
            free(scratch);
            const unsigned F = I->layer[l + 1].n_out;
            memcpy(lo, olo, sizeof(double) * F);
            memcpy(hi, ohi, sizeof(double) * F);
            encoding_bounds(I->l_dir, inc, dlo, dhi, lo + F, hi + F);
            layer_bounds(&I->layer[l + 2], &src[l + 2], lo, hi, 1, olo, ohi, dead[l + 2],
                         constant[l + 2]);
        }
    }
    free(lo);
    return 0;
}

/* A copy of the export's topology, expanded. */
static cnerf_info *expanded(const cn_export *e)
{
    cnerf_info *I = malloc(sizeof *I);
    if (I) {
        *I = e->src.hdr;
        if (cnerf_expand_topology(I) != CNERF_OK) {
            free(I);
            return NULL;
        }
    }
    return I;
}

static int is_relu(const cnerf_layer_info *L)
{
    return L->role == CNERF_ROLE_TRUNK || L->role == CNERF_ROLE_VIEW;
}

void cn_export_dead_units(const cn_export *e, uint8_t *const dead[CNERF_MAX_LAYERS])
{
    cnerf_info *I = expanded(e);
    uint8_t *cst[CNERF_MAX_LAYERS] = {0};
    int ok = I != NULL;
    for (unsigned l = 0; ok && l < I->n_layers; l++) {
        memset(dead[l], 0, I->layer[l].n_out);
        ok = (cst[l] = calloc(I->layer[l].n_out, 1)) != NULL;
    }
    if (ok && analyse(I, e->src.layer, dead, cst) != 0)
        for (unsigned l = 0; l < I->n_layers; l++)
            memset(dead[l], 0, I->layer[l].n_out); /* out of memory: claim nothing */
    for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++)
        free(cst[l]);
    free(I);
}

/* Kept indices of a layer's outputs (all when keep is NULL) into idx; returns the count. */
static unsigned kept(const uint8_t *dead, unsigned n, unsigned *idx)
{
    unsigned c = 0;
    for (unsigned j = 0; j < n; j++)
        if (!dead || !dead[j])
            idx[c++] = j;
    return c;
}

int cn_export_prune(cn_export *e, cn_prune_report *rep, char *err, size_t errlen)
{
    cn_prune_report local;
    rep = rep ? rep : &local;
    memset(rep, 0, sizeof *rep);
    cnerf_info *I = expanded(e);
    uint8_t *dead[CNERF_MAX_LAYERS] = {0}, *cst[CNERF_MAX_LAYERS] = {0};
    unsigned *rows = malloc(sizeof(unsigned) * CNERF_MAX_LAYER_IN);
    unsigned *cols = malloc(sizeof(unsigned) * CNERF_MAX_LAYER_IN);
    int rc = -1;
    const char *why = "out of memory while pruning";
    if (!I || !rows || !cols)
        goto done;
    for (unsigned l = 0; l < I->n_layers; l++)
        if (!(dead[l] = calloc(I->layer[l].n_out, 1)) || !(cst[l] = calloc(I->layer[l].n_out, 1)))
            goto done;
    if (analyse(I, e->src.layer, dead, cst))
        goto done;
    rep->params_before = I->n_params;
    cnerf_info *H = &e->src.hdr;
    for (unsigned n = 0; n < I->n_nets; n++) {
        const cnerf_net_info *N = &I->net[n];
        for (unsigned i = 0; i <= N->depth; i++) {
            if (i == N->depth && !N->view_width)
                break;
            const unsigned l = N->first_layer + (i < N->depth ? i : N->depth + 2u);
            const unsigned n_out = I->layer[l].n_out;
            unsigned live = kept(dead[l], n_out, rows), c = 0;
            if (live == 0)
                dead[l][0] = 0, live = 1; /* a layer keeps one unit; its output is 0 */
            for (unsigned j = 0; j < n_out; j++)
                c += cst[l][j] && !dead[l][j];
            rep->before[n][i] = (uint16_t)n_out;
            rep->after[n][i] = (uint16_t)live;
            rep->constant[n][i] = (uint16_t)c;
            if (i < N->depth)
                H->net[n].units[i] = (uint16_t)live;
            else
                H->net[n].view_units = (uint16_t)live;
        }
    }
    /* Rebuild each layer from the kept rows and columns. */
    for (unsigned n = 0; n < I->n_nets; n++) {
        const cnerf_net_info *N = &I->net[n];
        const unsigned last = N->first_layer + N->depth - 1u;
        for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
            const cnerf_layer_info *L = &I->layer[l];
            const unsigned i = l - N->first_layer;
            const unsigned nr = kept(is_relu(L) ? dead[l] : NULL, L->n_out, rows);
            unsigned nc;
            if (L->role == CNERF_ROLE_TRUNK && i > 0) {
                const int skip_in = N->skip != CNERF_NO_SKIP && i == N->skip + 1u;
                const unsigned off = skip_in ? I->in_pos : 0;
                nc = kept(NULL, off, cols);
                nc += kept(dead[l - 1], I->layer[l - 1].n_out, cols + nc);
                for (unsigned j = off; j < nc; j++)
                    cols[j] += off;
            } else if (L->role == CNERF_ROLE_SIGMA || L->role == CNERF_ROLE_FEATURE ||
                       L->role == CNERF_ROLE_OUTPUT) {
                nc = kept(dead[last], I->layer[last].n_out, cols);
            } else if (L->role == CNERF_ROLE_RGB) {
                nc = kept(dead[l - 1], I->layer[l - 1].n_out, cols);
            } else {
                nc = kept(NULL, L->n_in, cols);
            }
            if (nr == L->n_out && nc == L->n_in)
                continue;
            int32_t *k = malloc(sizeof(int32_t) * (size_t)nr * nc);
            int32_t *b = malloc(sizeof(int32_t) * nr);
            if (!k || !b) {
                free(k);
                free(b);
                goto done;
            }
            for (unsigned r = 0; r < nr; r++) {
                for (unsigned c = 0; c < nc; c++)
                    k[(size_t)r * nc + c] = e->k[l][(size_t)rows[r] * L->n_in + cols[c]];
                b[r] = e->bias[l][rows[r]];
            }
            free(e->k[l]);
            free(e->bias[l]);
            e->k[l] = k;
            e->bias[l] = b;
            e->src.layer[l].k = k;
            e->src.layer[l].bias_m = b;
        }
    }
    if (cnerf_expand_topology(H) != CNERF_OK) {
        why = "pruning produced an invalid topology";
        goto done;
    }
    rep->params_after = H->n_params;
    rc = 0;
done:
    if (rc)
        snprintf(err, errlen, "%s", why);
    for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++) {
        free(dead[l]);
        free(cst[l]);
    }
    free(rows);
    free(cols);
    free(I);
    return rc;
}
