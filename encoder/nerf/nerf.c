/* The float NeRF: layer primitives, the parameter block and both networks' passes. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_gemm.h"
#include "cn_nerf.h"
#include "cn_occ.h"
#include "cn_prior.h"
#include "cn_rng.h"
#include "cn_xsum.h"

/* ---- layer primitives ---- */

void cn_linear_forward(float *y, size_t ldy, const float *x, size_t ldx, const float *w,
                       const float *b, size_t P, size_t n_in, size_t n_out, int relu)
{
    if (P == 0)
        return;
    cn_sgemm(0, 1, P, n_out, n_in, x, ldx, w, n_in, 0.0f, y, ldy);
    /* Bias and activation in one branch-free pass (vectorizes). */
#pragma omp parallel for schedule(static)
    for (size_t p = 0; p < P; p++) {
        float *row = y + p * ldy;
        if (relu)
            for (size_t o = 0; o < n_out; o++) {
                const float v = row[o] + b[o];
                row[o] = v > 0.0f ? v : 0.0f;
            }
        else
            for (size_t o = 0; o < n_out; o++)
                row[o] += b[o];
    }
}

/* db += column sums of dy (P x n). Rows are summed in fixed blocks whose partial sums are
 * then added in block order, so the result does not depend on the thread count. With
 * masked (the same matrix as dy, writable) and y, dy is first masked in place by (y > 0)
 * (a ReLU's backward), in the same pass. */
static void colsum_acc(float *db, const float *dy, size_t ld, float *masked, const float *y,
                       size_t ldy, size_t P, size_t n)
{
    enum { BLOCK = 2048 };
    const size_t nblk = (P + BLOCK - 1) / BLOCK;
    double *part = malloc(sizeof(double) * nblk * n);
    if (!part) { /* the same sums, one thread */
        if (masked)
            cn_relu_backward(masked, ld, y, ldy, P, n);
        for (size_t o = 0; o < n; o++) {
            double acc = 0;
            for (size_t k = 0; k < nblk; k++) {
                double s = 0;
                for (size_t p = k * BLOCK; p < P && p < (k + 1) * BLOCK; p++)
                    s += dy[p * ld + o];
                acc += s;
            }
            db[o] += (float)acc;
        }
        return;
    }
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nblk; k++) {
        double *acc = part + k * n;
        for (size_t o = 0; o < n; o++)
            acc[o] = 0;
        for (size_t p = k * BLOCK; p < P && p < (k + 1) * BLOCK; p++) {
            const float *row = dy + p * ld;
            if (masked) { /* two loops over a row that stays in L1: each of them vectorizes */
                float *m = masked + p * ld;
                const float *v = y + p * ldy;
                for (size_t o = 0; o < n; o++)
                    m[o] = v[o] > 0.0f ? m[o] : 0.0f;
            }
            for (size_t o = 0; o < n; o++)
                acc[o] += row[o];
        }
    }
    for (size_t o = 0; o < n; o++) {
        double acc = 0;
        for (size_t k = 0; k < nblk; k++)
            acc += part[k * n + o];
        db[o] += (float)acc;
    }
    free(part);
}

/* The weight and input gradients of a linear layer (db done by the caller). */
static void linear_backward_products(float *dx, size_t lddx, size_t x0, size_t nx, int dx_accum,
                                     float *dw, const float *dy, size_t lddy, const float *x,
                                     size_t ldx, const float *w, size_t P, size_t n_in,
                                     size_t n_out)
{
    cn_sgemm(1, 0, n_out, n_in, P, dy, lddy, x, ldx, 1.0f, dw, n_in);
    if (dx && nx)
        cn_sgemm(0, 0, P, nx, n_out, dy, lddy, w + x0, n_in, dx_accum ? 1.0f : 0.0f, dx, lddx);
}

void cn_linear_backward(float *dx, size_t lddx, size_t x0, size_t nx, int dx_accum, float *dw,
                        float *db, const float *dy, size_t lddy, const float *x, size_t ldx,
                        const float *w, size_t P, size_t n_in, size_t n_out)
{
    if (P == 0)
        return;
    colsum_acc(db, dy, lddy, NULL, NULL, 0, P, n_out);
    linear_backward_products(dx, lddx, x0, nx, dx_accum, dw, dy, lddy, x, ldx, w, P, n_in, n_out);
}

void cn_linear_relu_backward(float *dx, size_t lddx, size_t x0, size_t nx, int dx_accum,
                             float *dw, float *db, float *dy, size_t lddy, const float *y,
                             size_t ldy, const float *x, size_t ldx, const float *w, size_t P,
                             size_t n_in, size_t n_out)
{
    if (P == 0)
        return;
    colsum_acc(db, dy, lddy, dy, y, ldy, P, n_out);
    linear_backward_products(dx, lddx, x0, nx, dx_accum, dw, dy, lddy, x, ldx, w, P, n_in, n_out);
}

void cn_relu_backward(float *dy, size_t lddy, const float *y, size_t ldy, size_t P, size_t n)
{
#pragma omp parallel for schedule(static)
    for (size_t p = 0; p < P; p++) {
        float *d = dy + p * lddy;
        const float *v = y + p * ldy;
        for (size_t o = 0; o < n; o++)
            d[o] = v[o] > 0.0f ? d[o] : 0.0f;
    }
}

void cn_posenc(float *out, size_t ld, const float *v, size_t n, unsigned L, int inc)
{
#pragma omp parallel for schedule(static)
    for (size_t p = 0; p < n; p++) {
        float *o = out + p * ld;
        const float *x = v + 3 * p;
        if (inc) {
            *o++ = x[0];
            *o++ = x[1];
            *o++ = x[2];
        }
        double s[3], c[3];
        for (int a = 0; a < 3; a++) {
            s[a] = sin((double)x[a]);
            c[a] = cos((double)x[a]);
        }
        for (unsigned l = 0; l < L; l++) {
            for (int a = 0; a < 3; a++)
                o[a] = (float)s[a];
            for (int a = 0; a < 3; a++)
                o[3 + a] = (float)c[a];
            o += 6;
            /* double angle: accurate to ~1e-13 over 16 octaves in double */
            for (int a = 0; a < 3; a++) {
                double s2 = 2 * s[a] * c[a], c2 = c[a] * c[a] - s[a] * s[a];
                s[a] = s2;
                c[a] = c2;
            }
        }
    }
}

/* ---- the model ---- */

/* Lays out and allocates the blocks; kernels uninitialised. */
static int model_alloc(cn_model *m, const cnerf_info *hdr, int compressed, char *err,
                       size_t errlen)
{
    memset(m, 0, sizeof *m);
    m->topo = *hdr;
    m->compressed = compressed;
    cnerf_status st = cnerf_expand_topology(&m->topo);
    if (st != CNERF_OK) {
        snprintf(err, errlen, "invalid model topology: %s", cnerf_status_str(st));
        return -1;
    }
    size_t off = 0, koff = 0;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        const cnerf_layer_info *L = &m->topo.layer[l];
        m->layer[l].w = off;
        off += (size_t)L->n_in * L->n_out;
        m->layer[l].b = off;
        off += L->n_out;
        m->kofs[l] = koff;
        koff += (size_t)L->n_in * L->n_out;
    }
    m->off_ab = off;
    if (compressed)
        off += 2 * (size_t)m->topo.n_layers;
    m->off_prior = off;
    if (compressed)
        off += CN_PRIOR_PARAMS * (size_t)m->topo.n_layers;
    m->n_params = off;
    size_t bytes = sizeof(float) * off;
    m->params = calloc(1, bytes);
    m->grads = calloc(1, bytes);
    m->adam_m = calloc(1, bytes);
    m->adam_v = calloc(1, bytes);
    int bad = !m->params || !m->grads || !m->adam_m || !m->adam_v;
    if (compressed) {
        m->kernel = calloc(koff, sizeof(float));
        m->kgrad = calloc(koff, sizeof(float));
        bad |= !m->kernel || !m->kgrad;
    }
    if (bad) {
        cn_model_free(m);
        snprintf(err, errlen, "out of memory for %zu parameters", off);
        return -1;
    }
    return 0;
}

double cn_glorot_limit(const cnerf_layer_info *L) { return sqrt(6.0 / (L->n_in + L->n_out)); }

/* Kernels Glorot-uniform, divided by `unit` (1 for plain kernels, a for latents). */
static void init_kernels(cn_model *m, cn_rng *r, int compressed, double levels)
{
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        const cnerf_layer_info *L = &m->topo.layer[l];
        const double lim = cn_glorot_limit(L);
        const double unit = compressed ? lim / levels : 1.0;
        float *w = m->params + m->layer[l].w;
        for (size_t i = 0; i < (size_t)L->n_in * L->n_out; i++)
            w[i] = (float)((2 * cn_rng_uniform(r) - 1) * lim / unit);
        if (compressed) {
            m->params[m->off_ab + 2 * l] = (float)unit;
            m->params[m->off_ab + 2 * l + 1] = 0.0f;
        }
    }
}

int cn_model_init(cn_model *m, const cnerf_info *hdr, uint64_t seed, char *err, size_t errlen)
{
    if (model_alloc(m, hdr, 0, err, errlen))
        return -1;
    cn_rng r = cn_rng_seed(seed);
    init_kernels(m, &r, 0, 1.0);
    return 0;
}

int cn_model_init_compressed(cn_model *m, const cnerf_info *hdr, uint64_t seed, double levels,
                             char *err, size_t errlen)
{
    if (!(levels > 0)) {
        snprintf(err, errlen, "the initial latent spread must be positive");
        return -1;
    }
    if (model_alloc(m, hdr, 1, err, errlen))
        return -1;
    cn_rng r = cn_rng_seed(seed);
    init_kernels(m, &r, 1, levels);
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        double u[10];
        for (int i = 0; i < 10; i++)
            u[i] = cn_rng_uniform(&r);
        cn_prior_init(m->params + m->off_prior + CN_PRIOR_PARAMS * (size_t)l, u);
    }
    return 0;
}

void cn_model_free(cn_model *m)
{
    free(m->params);
    free(m->grads);
    free(m->adam_m);
    free(m->adam_v);
    free(m->kernel);
    free(m->kgrad);
    m->params = m->grads = m->adam_m = m->adam_v = m->kernel = m->kgrad = NULL;
    if (m->shift && m->own_shift) {
        cn_model_free(m->shift);
        free(m->shift);
    }
    m->shift = NULL;
    if (m->grid) {
        cn_occ_free(m->grid);
        free(m->grid);
        m->grid = NULL;
    }
}

const float *cn_model_kernel(const cn_model *m, unsigned l)
{
    return m->compressed ? m->kernel + m->kofs[l] : m->params + m->layer[l].w;
}

float *cn_model_kernel_grad(cn_model *m, unsigned l)
{
    return m->compressed ? m->kgrad + m->kofs[l] : m->grads + m->layer[l].w;
}

int32_t cn_model_latent(const cn_model *m, unsigned l, size_t i)
{
    return (int32_t)lroundf(m->params[m->layer[l].w + i]);
}

void cn_model_materialize(cn_model *m)
{
    if (!m->compressed)
        return;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        const size_t n = (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
        const float a = m->params[m->off_ab + 2 * l], b = m->params[m->off_ab + 2 * l + 1];
        const float *phi = m->params + m->layer[l].w;
        float *w = m->kernel + m->kofs[l], *dw = m->kgrad + m->kofs[l];
        const float *gs = m->shift ? m->shift->kernel + m->shift->kofs[l] : NULL;
        const int unrounded = m->unrounded;
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++) {
            /* ties away from zero, as the export */
            w[i] = a * (unrounded ? phi[i] : roundf(phi[i])) + b;
            if (gs)
                w[i] += gs[i]; /* the shared shift g round(S) */
            dw[i] = 0;
        }
    }
}

void cn_model_kernels_backward(cn_model *m)
{
    if (!m->compressed)
        return;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        const size_t n = (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
        const float a = m->params[m->off_ab + 2 * l];
        const float *phi = m->params + m->layer[l].w, *dw = m->kgrad + m->kofs[l];
        float *dphi = m->grads + m->layer[l].w;
        cn_xsum da = 0, db = 0; /* exact: the same for any thread count */
        const int unrounded = m->unrounded;
#pragma omp parallel
        {
            cn_xsum la = 0, lb = 0;
#pragma omp for schedule(static)
            for (size_t i = 0; i < n; i++) {
                dphi[i] += a * dw[i]; /* straight-through: d round(x) / dx := 1 */
                const float q = unrounded ? phi[i] : roundf(phi[i]);
                la = cn_xsum_plus(la, cn_xsum_of((double)dw[i] * q));
                lb = cn_xsum_plus(lb, cn_xsum_of(dw[i]));
            }
#pragma omp critical
            {
                da = cn_xsum_plus(da, la);
                db = cn_xsum_plus(db, lb);
            }
        }
        m->grads[m->off_ab + 2 * l] += (float)cn_xsum_value(da);
        m->grads[m->off_ab + 2 * l + 1] += (float)cn_xsum_value(db);
        if (m->shift) { /* W = ... + g round(S): the shift's kernel gradient gains dW */
            float *ds = m->shift->kgrad + m->shift->kofs[l];
#pragma omp parallel for schedule(static)
            for (size_t i = 0; i < n; i++)
                ds[i] += dw[i];
        }
    }
}

/* Elements in the largest kernel (at least 1). */
static size_t max_kernel(const cn_model *m)
{
    size_t max = 1;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        size_t n = (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
        max = n > max ? n : max;
    }
    return max;
}

int cn_color_layers(const cnerf_info *I, unsigned net, unsigned *first, unsigned *count)
{
    if (net >= I->n_nets || I->net[net].view_width == 0)
        return 0;
    *first = I->net[net].first_layer + I->net[net].depth + 1u; /* feature, view, rgb */
    *count = 3;
    return 1;
}

/* 1 when layer l is written as zero (a colour layer of a network in drop_color). */
static int dropped(const cn_model *m, unsigned l)
{
    const unsigned net = m->topo.layer[l].net;
    unsigned first, count;
    return m->drop_color[net] && cn_color_layers(&m->topo, net, &first, &count) &&
           l >= first && l < first + count;
}

size_t cn_model_sent_latents(const cn_model *m)
{
    size_t n = 0;
    for (unsigned l = 0; l < m->topo.n_layers; l++)
        if (!dropped(m, l))
            n += (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
    return n;
}

double cn_model_rate(cn_model *m, uint64_t seed, float scale)
{
    if (!m->compressed)
        return 0;
    const size_t max = max_kernel(m);
    float *x = malloc(sizeof(float) * max);
    if (!x)
        return NAN;
    double bits = 0;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        if (dropped(m, l))
            continue;
        const size_t n = (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
        const float *phi = m->params + m->layer[l].w;
        cn_rng r = cn_rng_seed(seed * 0x9E3779B97F4A7C15ull + l);
        for (size_t i = 0; i < n; i++)
            x[i] = phi[i] + (float)(cn_rng_uniform(&r) - 0.5);
        const size_t po = m->off_prior + CN_PRIOR_PARAMS * (size_t)l;
        /* d x / d Phi = 1: the rate's gradient lands on the latents directly. */
        bits += cn_prior_rate(m->params + po, x, n, scale, m->grads + m->layer[l].w,
                              m->grads + po);
    }
    free(x);
    return bits;
}

double cn_model_latent_bits(const cn_model *m, double *per_layer)
{
    if (!m->compressed)
        return 0;
    const size_t max = max_kernel(m);
    float *k = malloc(sizeof(float) * max);
    if (!k)
        return NAN;
    double bits = 0;
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        if (dropped(m, l)) {
            if (per_layer)
                per_layer[l] = 0;
            continue;
        }
        const size_t n = (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
        for (size_t i = 0; i < n; i++)
            k[i] = (float)cn_model_latent(m, l, i);
        const double b = cn_prior_bits(m->params + m->off_prior + CN_PRIOR_PARAMS * (size_t)l,
                                       k, n, 0, NULL, NULL);
        if (per_layer)
            per_layer[l] = b;
        bits += b;
    }
    free(k);
    return bits;
}

/* ---- network buffers ---- */

static float *fbuf(size_t n) { return malloc(sizeof(float) * (n ? n : 1)); }

int cn_net_buf_init(cn_net_buf *nb, const cnerf_info *topo, unsigned net, size_t cap)
{
    memset(nb, 0, sizeof *nb);
    const cnerf_net_info *N = &topo->net[net];
    const size_t W = N->width, in_pos = topo->in_pos;
    nb->cap = cap;
    nb->ld_in = in_pos + (N->skip != CNERF_NO_SKIP ? W : 0);
    nb->in = fbuf(cap * nb->ld_in);
    nb->d_in = fbuf(cap * nb->ld_in);
    int bad = !nb->in || !nb->d_in;
    for (unsigned i = 0; i < N->depth; i++) {
        if (i == N->skip) {
            nb->h[i] = nb->in + in_pos;
            nb->d_h[i] = nb->d_in + in_pos;
            nb->ld_h[i] = nb->ld_in;
        } else {
            nb->h[i] = fbuf(cap * W);
            nb->d_h[i] = fbuf(cap * W);
            nb->ld_h[i] = W;
            bad |= !nb->h[i] || !nb->d_h[i];
        }
    }
    if (N->view_width) {
        const size_t lv = W + topo->in_dir;
        nb->ld_view_in = lv;
        nb->ld_view_h = N->view_width;
        nb->view_in = fbuf(cap * lv);
        nb->d_view_in = fbuf(cap * lv);
        nb->view_h = fbuf(cap * N->view_width);
        nb->d_view_h = fbuf(cap * N->view_width);
        bad |= !nb->view_in || !nb->d_view_in || !nb->view_h || !nb->d_view_h;
    }
    nb->out = fbuf(cap * 4);
    nb->d_out = fbuf(cap * 4);
    bad |= !nb->out || !nb->d_out;
    if (bad) {
        cn_net_buf_free(nb);
        return -1;
    }
    return 0;
}

void cn_net_buf_free(cn_net_buf *nb)
{
    for (unsigned i = 0; i < CNERF_MAX_DEPTH; i++) {
        if (nb->h[i] && (nb->h[i] < nb->in || nb->h[i] >= nb->in + nb->cap * nb->ld_in)) {
            free(nb->h[i]);
            free(nb->d_h[i]);
        }
    }
    free(nb->in);
    free(nb->d_in);
    free(nb->view_in);
    free(nb->d_view_in);
    free(nb->view_h);
    free(nb->d_view_h);
    free(nb->out);
    free(nb->d_out);
    free(nb->g_chunk);
    free(nb->g_sum);
    memset(nb, 0, sizeof *nb);
}

/* nb's rows from row0 on, as a buffer of its own (pointers into nb). */
static void net_buf_rows(const cn_net_buf *nb, size_t row0, cn_net_buf *v)
{
    *v = *nb;
    v->cap = nb->cap - row0;
    v->in = nb->in + row0 * nb->ld_in;
    v->d_in = nb->d_in + row0 * nb->ld_in;
    for (unsigned i = 0; i < CNERF_MAX_DEPTH; i++)
        if (nb->h[i]) {
            v->h[i] = nb->h[i] + row0 * nb->ld_h[i];
            v->d_h[i] = nb->d_h[i] + row0 * nb->ld_h[i];
        }
    if (nb->view_in) {
        v->view_in = nb->view_in + row0 * nb->ld_view_in;
        v->d_view_in = nb->d_view_in + row0 * nb->ld_view_in;
        v->view_h = nb->view_h + row0 * nb->ld_view_h;
        v->d_view_h = nb->d_view_h + row0 * nb->ld_view_h;
    }
    v->out = nb->out + row0 * 4;
    v->d_out = nb->d_out + row0 * 4;
    v->g_chunk = NULL;
    v->g_sum = NULL;
    v->g_len = v->g_threads = 0;
}

/* Input of trunk layer i: pointer, row stride and width. */
static const float *trunk_input(const cnerf_info *T, const cnerf_net_info *N,
                                const cn_net_buf *nb, unsigned i, size_t *ld)
{
    if (i == 0 || (N->skip != CNERF_NO_SKIP && i == N->skip + 1u)) {
        *ld = nb->ld_in;
        return nb->in;
    }
    (void)T;
    *ld = nb->ld_h[i - 1];
    return nb->h[i - 1];
}

/* density_only: the trunk and sigma alone (nb->out's colour columns are left as they were) */
static void forward_rows(const cn_model *m, unsigned net, cn_net_buf *nb, size_t P,
                         int density_only)
{
    const cnerf_info *T = &m->topo;
    const cnerf_net_info *N = &T->net[net];
    const unsigned l0 = N->first_layer, D = N->depth;
    /* Shapes from the layer table: a pruned trunk layer has fewer units than the width. */
    for (unsigned i = 0; i < D; i++) {
        const cnerf_layer_info *L = &T->layer[l0 + i];
        size_t ldx;
        const float *x = trunk_input(T, N, nb, i, &ldx);
        cn_linear_forward(nb->h[i], nb->ld_h[i], x, ldx, cn_model_kernel(m, l0 + i),
                          m->params + m->layer[l0 + i].b, P, L->n_in, L->n_out, 1);
    }
    const float *h = nb->h[D - 1];
    const size_t ldh = nb->ld_h[D - 1], U = N->units[D - 1];
    const unsigned l = l0 + D;
    if (N->view_width) {
        const size_t F = T->layer[l + 1].n_out, lv = T->layer[l + 2].n_in, V = N->view_units;
        const size_t ldv = N->view_width;
        cn_linear_forward(nb->out + 3, 4, h, ldh, cn_model_kernel(m, l),
                          m->params + m->layer[l].b, P, U, 1, 0);
        if (density_only)
            return;
        cn_linear_forward(nb->view_in, N->width + T->in_dir, h, ldh, cn_model_kernel(m, l + 1),
                          m->params + m->layer[l + 1].b, P, U, F, 0);
        cn_linear_forward(nb->view_h, ldv, nb->view_in, N->width + T->in_dir,
                          cn_model_kernel(m, l + 2), m->params + m->layer[l + 2].b, P, lv, V, 1);
        cn_linear_forward(nb->out, 4, nb->view_h, ldv, cn_model_kernel(m, l + 3),
                          m->params + m->layer[l + 3].b, P, V, 3, 0);
    } else {
        cn_linear_forward(nb->out, 4, h, ldh, cn_model_kernel(m, l), m->params + m->layer[l].b,
                          P, U, 4, 0);
    }
}

/* Each unit's L2 norm over the P rows of a trunk layer's output. */
static void unit_norms(double *norm, const float *h, size_t ld, size_t P, size_t U)
{
#pragma omp parallel for schedule(static)
    for (size_t u = 0; u < U; u++) {
        double s = 0;
        for (size_t p = 0; p < P; p++)
            s += (double)h[p * ld + u] * h[p * ld + u];
        norm[u] = sqrt(s);
    }
}

double cn_net_group_penalty(const cn_model *m, unsigned net, const cn_net_buf *nb, size_t P)
{
    const cnerf_net_info *N = &m->topo.net[net];
    double norm[CNERF_MAX_WIDTH], sum = 0;
    for (unsigned i = 0; i < N->depth; i++) {
        unit_norms(norm, nb->h[i], nb->ld_h[i], P, N->units[i]);
        for (size_t u = 0; u < N->units[i]; u++)
            sum += norm[u];
    }
    return (double)m->group * sum;
}

/* Adds the group penalty's gradient, group h / |h_u|, to a trunk layer's output gradient,
 * with norm[u] the unit's L2 norm over all rows of the pass. A unit that is 0 on every row
 * has no gradient there (the subgradient 0). */
static void group_backward(float group, float *dh, const float *h, size_t ld, size_t P,
                           size_t U, const double *norm)
{
    float f[CNERF_MAX_WIDTH];
    for (size_t u = 0; u < U; u++)
        f[u] = norm[u] > 0 ? (float)(group / norm[u]) : 0.0f;
#pragma omp parallel for schedule(static)
    for (size_t p = 0; p < P; p++)
        for (size_t u = 0; u < U; u++)
            dh[p * ld + u] += f[u] * h[p * ld + u];
}

/* The backward pass over nb's P rows into the gradient block g (laid out as the parameters:
 * layer l's kernel at m->layer[l].w, its bias at m->layer[l].b), with norm[i * CNERF_MAX_WIDTH
 * + u] trunk layer i's unit norms for the group penalty. */
static void backward_rows(cn_model *m, unsigned net, cn_net_buf *nb, size_t P, float *g,
                          const double *norm)
{
    const cnerf_info *T = &m->topo;
    const cnerf_net_info *N = &T->net[net];
    const unsigned l0 = N->first_layer, D = N->depth;
    const float *h = nb->h[D - 1];
    float *dh = nb->d_h[D - 1];
    const size_t ldh = nb->ld_h[D - 1], U = N->units[D - 1];
    const unsigned l = l0 + D;
#define LAYER_ARGS(k) g + m->layer[k].w, g + m->layer[k].b
    if (N->view_width) {
        const size_t F = T->layer[l + 1].n_out, lv = T->layer[l + 2].n_in, V = N->view_units;
        const size_t ldv = N->view_width, ldi = N->width + T->in_dir;
        cn_linear_backward(nb->d_view_h, ldv, 0, V, 0, LAYER_ARGS(l + 3), nb->d_out, 4,
                           nb->view_h, ldv, cn_model_kernel(m, l + 3), P, V, 3);
        cn_linear_relu_backward(nb->d_view_in, ldi, 0, F, 0, LAYER_ARGS(l + 2), nb->d_view_h,
                                ldv, nb->view_h, ldv, nb->view_in, ldi,
                                cn_model_kernel(m, l + 2), P, lv, V);
        cn_linear_backward(dh, ldh, 0, U, 0, LAYER_ARGS(l + 1), nb->d_view_in, ldi, h, ldh,
                           cn_model_kernel(m, l + 1), P, U, F);
        cn_linear_backward(dh, ldh, 0, U, 1, LAYER_ARGS(l), nb->d_out + 3, 4, h, ldh,
                           cn_model_kernel(m, l), P, U, 1);
    } else {
        cn_linear_backward(dh, ldh, 0, U, 0, LAYER_ARGS(l), nb->d_out, 4, h, ldh,
                           cn_model_kernel(m, l), P, U, 4);
    }
    for (unsigned i = D; i-- > 0;) {
        const cnerf_layer_info *L = &T->layer[l0 + i];
        if (m->group > 0)
            group_backward(m->group, nb->d_h[i], nb->h[i], nb->ld_h[i], P, N->units[i],
                           norm + (size_t)i * CNERF_MAX_WIDTH);
        size_t ldx;
        const float *x = trunk_input(T, N, nb, i, &ldx);
        float *dx = NULL;
        size_t lddx = 0, x0 = 0, nx = 0;
        if (i > 0) {
            dx = nb->d_h[i - 1];
            lddx = nb->ld_h[i - 1];
            nx = N->units[i - 1];
            x0 = L->n_in - nx; /* after the skip, only the h part of [PE(x), h] */
        }
        cn_linear_relu_backward(dx, lddx, x0, nx, 0, LAYER_ARGS(l0 + i), nb->d_h[i],
                                nb->ld_h[i], nb->h[i], nb->ld_h[i], x, ldx,
                                cn_model_kernel(m, l0 + i), P, L->n_in, L->n_out);
    }
#undef LAYER_ARGS
}

/* ---- passes in chunks (CN_CHUNK_ROWS) ---- */

/* Chunk c of a pass: rows [*r0, *r1), from the bounds or every CN_CHUNK_ROWS of P rows. */
static void chunk_rows(const size_t *bound, size_t P, size_t c, size_t *r0, size_t *r1)
{
    if (bound) {
        *r0 = bound[c];
        *r1 = bound[c + 1];
    } else {
        *r0 = c * CN_CHUNK_ROWS;
        *r1 = P - *r0 < CN_CHUNK_ROWS ? P : *r0 + CN_CHUNK_ROWS;
    }
}

/* Chunk c's rows as a buffer of their own; returns their count. */
static size_t chunk_view(const cn_net_buf *nb, const size_t *bound, size_t P, size_t c,
                         cn_net_buf *v)
{
    size_t r0, r1;
    chunk_rows(bound, P, c, &r0, &r1);
    net_buf_rows(nb, r0, v);
    return r1 - r0;
}

static void forward_chunks(const cn_model *m, unsigned net, cn_net_buf *nb, const size_t *bound,
                           size_t n, size_t P, int density_only)
{
#pragma omp parallel
    {
        omp_set_num_threads(1); /* this task's products and loops: one thread */
#pragma omp for schedule(dynamic, 1)
        for (size_t c = 0; c < n; c++) {
            cn_net_buf v;
            forward_rows(m, net, &v, chunk_view(nb, bound, P, c, &v), density_only);
        }
    }
}

void cn_net_forward(const cn_model *m, unsigned net, cn_net_buf *nb, size_t P)
{
    forward_chunks(m, net, nb, NULL, (P + CN_CHUNK_ROWS - 1) / CN_CHUNK_ROWS, P, 0);
}

void cn_net_density(const cn_model *m, unsigned net, cn_net_buf *nb, size_t P)
{
    forward_chunks(m, net, nb, NULL, (P + CN_CHUNK_ROWS - 1) / CN_CHUNK_ROWS, P, 1);
}

void cn_net_forward_chunks(const cn_model *m, unsigned net, cn_net_buf *nb, const size_t *bound,
                           size_t n)
{
    forward_chunks(m, net, nb, bound, n, 0, 0);
}

/* The parameters of network net's layers: [*lo, *hi) of the block. */
static void net_params(const cn_model *m, unsigned net, size_t *lo, size_t *hi)
{
    const cnerf_net_info *N = &m->topo.net[net];
    const unsigned last = N->first_layer + N->n_layers - 1u;
    *lo = m->layer[N->first_layer].w;
    *hi = m->layer[last].b + m->topo.layer[last].n_out;
}

static int backward_chunks(cn_model *m, unsigned net, cn_net_buf *nb, const size_t *bound,
                           size_t n, size_t P, const cn_share *share)
{
    const cnerf_net_info *N = &m->topo.net[net];
    size_t lo, hi;
    net_params(m, net, &lo, &hi);
    const size_t len = hi - lo, threads = (size_t)omp_get_max_threads();
    if (nb->g_len < len || nb->g_threads < threads) {
        free(nb->g_chunk);
        free(nb->g_sum);
        nb->g_chunk = malloc(sizeof(float) * len * threads);
        nb->g_sum = malloc(sizeof(cn_xsum) * len * threads);
        nb->g_len = len;
        nb->g_threads = threads;
        if (!nb->g_chunk || !nb->g_sum) {
            free(nb->g_chunk);
            free(nb->g_sum);
            nb->g_chunk = NULL;
            nb->g_sum = NULL;
            nb->g_len = nb->g_threads = 0;
            return -1;
        }
    }
    cn_xsum *sum = nb->g_sum;
    /* The group penalty's unit norms over every row: each chunk's squares summed apart. */
    double *norm = NULL;
    if (m->group > 0) {
        const size_t nu = (size_t)N->depth * CNERF_MAX_WIDTH;
        norm = malloc(sizeof(double) * nu);
        cn_xsum *sq = calloc(nu, sizeof(cn_xsum));
        if (!norm || !sq) {
            free(norm);
            free(sq);
            return -1;
        }
        for (unsigned i = 0; i < N->depth; i++) {
            const size_t U = N->units[i], ld = nb->ld_h[i];
            cn_xsum *sqi = sq + (size_t)i * CNERF_MAX_WIDTH;
#pragma omp parallel for schedule(static)
            for (size_t u = 0; u < U; u++)
                for (size_t c = 0; c < n; c++) {
                    size_t r0, r1;
                    chunk_rows(bound, P, c, &r0, &r1);
                    double q = 0;
                    for (size_t p = r0; p < r1; p++)
                        q += (double)nb->h[i][p * ld + u] * nb->h[i][p * ld + u];
                    sqi[u] = cn_xsum_plus(sqi[u], cn_xsum_of(q));
                }
        }
        if (cn_share_allsum(share, sq, nu)) { /* every rank's rows */
            free(norm);
            free(sq);
            return -1;
        }
        for (unsigned i = 0; i < N->depth; i++)
            for (size_t u = 0; u < N->units[i]; u++)
                norm[(size_t)i * CNERF_MAX_WIDTH + u] =
                    sqrt(cn_xsum_value(sq[(size_t)i * CNERF_MAX_WIDTH + u]));
        free(sq);
    }
    memset(sum, 0, sizeof(cn_xsum) * len * threads);
#pragma omp parallel
    {
        omp_set_num_threads(1); /* this task's products and loops: one thread */
        const size_t me = (size_t)omp_get_thread_num();
        float *g = nb->g_chunk + me * len - lo; /* indexed as the parameter block */
        cn_xsum *acc = sum + me * len;
#pragma omp for schedule(dynamic, 1)
        for (size_t c = 0; c < n; c++) {
            cn_net_buf v;
            const size_t rows = chunk_view(nb, bound, P, c, &v);
            memset(g + lo, 0, sizeof(float) * len);
            backward_rows(m, net, &v, rows, g, norm);
            cn_xsum_add_f(acc, g + lo, len);
        }
    }
    /* Every thread's sums into the first's, then onto the model's gradients. */
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < len; i++)
        for (size_t t = 1; t < threads; t++)
            sum[i] = cn_xsum_plus(sum[i], sum[t * len + i]);
    if (cn_share_allsum(share, sum, len)) { /* every rank's chunks */
        free(norm);
        return -1;
    }
    for (unsigned l = N->first_layer; l < (unsigned)N->first_layer + N->n_layers; l++) {
        const cnerf_layer_info *L = &m->topo.layer[l];
        cn_xsum_put_f(cn_model_kernel_grad(m, l), sum + (m->layer[l].w - lo),
                      (size_t)L->n_in * L->n_out);
        cn_xsum_put_f(m->grads + m->layer[l].b, sum + (m->layer[l].b - lo), L->n_out);
    }
    free(norm);
    return 0;
}

int cn_net_backward_chunks(cn_model *m, unsigned net, cn_net_buf *nb, const size_t *bound,
                           size_t n, const cn_share *share)
{
    return backward_chunks(m, net, nb, bound, n, 0, share);
}
