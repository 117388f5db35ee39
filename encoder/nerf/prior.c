/* The factorized prior: cumulative network, likelihoods, rate and gradients. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "cn_prior.h"
#include "cn_xsum.h"

static const int dims[CN_PRIOR_LAYERS + 1] = {1, 3, 3, 3, 1};
static const int off_h[CN_PRIOR_LAYERS] = {0, 3, 12, 21};
static const int off_b[CN_PRIOR_LAYERS] = {24, 27, 30, 33};
static const int off_a[CN_PRIOR_LAYERS - 1] = {34, 37, 40};

static double softplus(double h) { return h > 30 ? h : log1p(exp(h)); }
static double sigmoid(double z) { return 1.0 / (1.0 + exp(-z)); }

void cn_prior_init(float *p, const double *u01)
{
    const double scale = pow(CN_PRIOR_INIT_SCALE, 1.0 / CN_PRIOR_LAYERS);
    int r = 0;
    for (int k = 0; k < CN_PRIOR_LAYERS; k++) {
        const float h = (float)log(expm1(1.0 / scale / dims[k + 1]));
        for (int i = 0; i < dims[k] * dims[k + 1]; i++)
            p[off_h[k] + i] = h;
        for (int i = 0; i < dims[k + 1]; i++)
            p[off_b[k] + i] = (float)(u01[r++] - 0.5);
        if (k < CN_PRIOR_LAYERS - 1)
            for (int i = 0; i < dims[k + 1]; i++)
                p[off_a[k] + i] = 0;
    }
}

/* The functions of the parameters that every evaluation uses, computed once per call:
 * softplus and sigmoid of the matrices' parameters, tanh of the gates' parameters. */
typedef struct coef {
    double sp[CN_PRIOR_PARAMS], sg[CN_PRIOR_PARAMS], ta[CN_PRIOR_PARAMS], b[CN_PRIOR_PARAMS];
} coef;

static void coef_init(coef *c, const float *p)
{
    for (int k = 0; k < CN_PRIOR_LAYERS; k++) {
        for (int i = 0; i < dims[k] * dims[k + 1]; i++) {
            c->sp[off_h[k] + i] = softplus(p[off_h[k] + i]);
            c->sg[off_h[k] + i] = sigmoid(p[off_h[k] + i]);
        }
        for (int i = 0; i < dims[k + 1]; i++)
            c->b[off_b[k] + i] = p[off_b[k] + i];
        if (k < CN_PRIOR_LAYERS - 1)
            for (int i = 0; i < dims[k + 1]; i++)
                c->ta[off_a[k] + i] = tanh(p[off_a[k] + i]);
    }
}

/* Intermediates of one evaluation: v[k] inputs of layer k (v[4] the output), u[k] its
 * pre-gate values, tu[k] their tanh. */
typedef struct trace {
    double v[CN_PRIOR_LAYERS + 1][3];
    double u[CN_PRIOR_LAYERS][3];
    double tu[CN_PRIOR_LAYERS][3];
} trace;

static double forward(const coef *c, double x, trace *t)
{
    t->v[0][0] = x;
    for (int k = 0; k < CN_PRIOR_LAYERS; k++) {
        const int din = dims[k], dout = dims[k + 1];
        for (int i = 0; i < dout; i++) {
            double u = c->b[off_b[k] + i];
            for (int j = 0; j < din; j++)
                u += c->sp[off_h[k] + i * din + j] * t->v[k][j];
            t->u[k][i] = u;
            if (k < CN_PRIOR_LAYERS - 1) {
                t->tu[k][i] = tanh(u);
                t->v[k + 1][i] = u + c->ta[off_a[k] + i] * t->tu[k][i];
            } else {
                t->v[k + 1][i] = u;
            }
        }
    }
    return t->v[CN_PRIOR_LAYERS][0];
}

/* Adds g * d f / d x to *dx and g * d f / d p to dp (double[CN_PRIOR_PARAMS]). */
static void backward(const coef *c, const trace *t, double g, double *dx, double *dp)
{
    double dv[3] = {g, 0, 0};
    for (int k = CN_PRIOR_LAYERS; k-- > 0;) {
        const int din = dims[k], dout = dims[k + 1];
        double du[3];
        for (int i = 0; i < dout; i++) {
            if (k < CN_PRIOR_LAYERS - 1) {
                const double ta = c->ta[off_a[k] + i], tu = t->tu[k][i];
                du[i] = dv[i] * (1 + ta * (1 - tu * tu));
                if (dp)
                    dp[off_a[k] + i] += dv[i] * tu * (1 - ta * ta);
            } else {
                du[i] = dv[i];
            }
        }
        double dprev[3] = {0, 0, 0};
        for (int i = 0; i < dout; i++) {
            if (dp)
                dp[off_b[k] + i] += du[i];
            for (int j = 0; j < din; j++) {
                const int h = off_h[k] + i * din + j;
                if (dp)
                    dp[h] += du[i] * t->v[k][j] * c->sg[h];
                dprev[j] += du[i] * c->sp[h];
            }
        }
        memcpy(dv, dprev, sizeof dv);
    }
    if (dx)
        *dx += dv[0];
}

double cn_prior_logit(const float *p, double x)
{
    coef c;
    coef_init(&c, p);
    trace t;
    return forward(&c, x, &t);
}

/* Likelihood of the unit interval around x with the sign trick, and its derivatives with
 * respect to the upper and lower logits. */
static double likelihood(double lo, double up, double *d_lo, double *d_up)
{
    const double s = lo + up > 0 ? -1.0 : 1.0;
    const double su = sigmoid(s * up), sl = sigmoid(s * lo);
    *d_up = su * (1 - su);
    *d_lo = -sl * (1 - sl);
    return s * (su - sl);
}

/* acc[k] += d[k] exactly for k < CN_PRIOR_PARAMS. */
static void add_params(cn_xsum *acc, const double *d)
{
    for (int k = 0; k < CN_PRIOR_PARAMS; k++)
        acc[k] = cn_xsum_plus(acc[k], cn_xsum_of(d[k]));
}

/* Sums are exact (cn_xsum.h), so that they do not depend on the thread count. */
double cn_prior_bits(const float *p, const float *x, size_t n, float scale, float *dx,
                     float *dp)
{
    cn_xsum bits = 0, dp_total[CN_PRIOR_PARAMS];
    memset(dp_total, 0, sizeof dp_total);
    const int want_p = dp != NULL;
    coef c;
    coef_init(&c, p);
#pragma omp parallel
    {
        cn_xsum bl = 0, dpl[CN_PRIOR_PARAMS];
        memset(dpl, 0, sizeof dpl);
#pragma omp for schedule(static)
        for (size_t i = 0; i < n; i++) {
            trace tl, tu;
            const double lo = forward(&c, (double)x[i] - 0.5, &tl);
            const double up = forward(&c, (double)x[i] + 0.5, &tu);
            double d_lo, d_up;
            const double L = likelihood(lo, up, &d_lo, &d_up);
            const double Lb = L > CN_PRIOR_LIKELIHOOD_MIN ? L : CN_PRIOR_LIKELIHOOD_MIN;
            bl = cn_xsum_plus(bl, cn_xsum_of(-log2(Lb)));
            if (!dx && !want_p)
                continue;
            /* d bits / d L, passed through the lower bound (it only pushes L up). */
            const double g = -(double)scale / (Lb * M_LN2);
            double gx = 0, di[CN_PRIOR_PARAMS] = {0};
            backward(&c, &tu, g * d_up, dx ? &gx : NULL, want_p ? di : NULL);
            backward(&c, &tl, g * d_lo, dx ? &gx : NULL, want_p ? di : NULL);
            if (dx)
                dx[i] += (float)gx;
            if (want_p)
                add_params(dpl, di);
        }
#pragma omp critical
        {
            bits = cn_xsum_plus(bits, bl);
            for (int j = 0; j < CN_PRIOR_PARAMS; j++)
                dp_total[j] = cn_xsum_plus(dp_total[j], dpl[j]);
        }
    }
    if (want_p)
        for (int j = 0; j < CN_PRIOR_PARAMS; j++)
            dp[j] += (float)cn_xsum_value(dp_total[j]);
    return cn_xsum_value(bits);
}

/* ---- the rate of many values from a table of the logit ---- */

/* f and h f' at the nodes x0 + j h, and the cubic Hermite interpolant between them: f at x
 * and f'(x); *j and *t locate x (node j, fraction t of the way to node j + 1). */
typedef struct table {
    double x0, h, inv_h;
    size_t nodes;
    double *f, *hd;
} table;

static double interp(const table *T, double x, double *dfdx, size_t *j, double *t)
{
    double s = (x - T->x0) * T->inv_h;
    size_t k = s <= 0 ? 0 : (size_t)s;
    if (k > T->nodes - 2)
        k = T->nodes - 2;
    const double u = s - (double)k, u2 = u * u, u3 = u2 * u;
    const double f0 = T->f[k], f1 = T->f[k + 1], d0 = T->hd[k], d1 = T->hd[k + 1];
    *dfdx = ((6 * u2 - 6 * u) * (f0 - f1) + (3 * u2 - 4 * u + 1) * d0 + (3 * u2 - 2 * u) * d1) *
            T->inv_h;
    *j = k;
    *t = u;
    return (2 * u3 - 3 * u2 + 1) * f0 + (u3 - 2 * u2 + u) * d0 + (3 * u2 - 2 * u3) * f1 +
           (u3 - u2) * d1;
}

double cn_prior_rate(const float *p, const float *x, size_t n, float scale, float *dx,
                     float *dp)
{
    if (n == 0)
        return 0;
    float lo = x[0], hi = x[0];
    for (size_t i = 1; i < n; i++) {
        lo = x[i] < lo ? x[i] : lo;
        hi = x[i] > hi ? x[i] : hi;
    }
    table T;
    T.h = 1.0 / CN_PRIOR_TABLE_PER_UNIT;
    T.inv_h = CN_PRIOR_TABLE_PER_UNIT;
    T.x0 = floor((double)lo) - 1; /* the nodes cover [lo - 1/2, hi + 1/2] with a margin */
    const double span = ceil((double)hi) + 1 - T.x0;
    /* Worth it only when the values outnumber the nodes: otherwise (and without memory,
     * or with values that are not finite) every value is evaluated exactly. */
    if (!(span * CN_PRIOR_TABLE_PER_UNIT * 2 < (double)n))
        return cn_prior_bits(p, x, n, scale, dx, dp);
    T.nodes = (size_t)(span * CN_PRIOR_TABLE_PER_UNIT) + 2;
    const int want_p = dp != NULL;
    /* Exact sums (cn_xsum.h), the same for any thread count: the bits, d bits / d f at each
     * node (each value's spread linearly; per thread, then added), the prior's gradient. */
    const size_t nt = (size_t)omp_get_max_threads();
    double *mem = malloc(sizeof(double) * 2 * T.nodes);
    cn_xsum *w = want_p ? calloc(T.nodes * nt, sizeof(cn_xsum)) : NULL;
    if (!mem || (want_p && !w)) {
        free(mem);
        free(w);
        return cn_prior_bits(p, x, n, scale, dx, dp);
    }
    T.f = mem;
    T.hd = mem + T.nodes;
    coef c;
    coef_init(&c, p);
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < T.nodes; j++) {
        trace t;
        double d = 0;
        T.f[j] = forward(&c, T.x0 + (double)j * T.h, &t);
        backward(&c, &t, 1.0, &d, NULL);
        T.hd[j] = d * T.h;
    }
    cn_xsum bits = 0;
#pragma omp parallel
    {
        cn_xsum bl = 0;
        cn_xsum *wl = w ? w + T.nodes * (size_t)omp_get_thread_num() : NULL;
#pragma omp for schedule(static)
        for (size_t i = 0; i < n; i++) {
            double dlo, dup, t_lo, t_up;
            size_t j_lo, j_up;
            const double flo = interp(&T, (double)x[i] - 0.5, &dlo, &j_lo, &t_lo);
            const double fup = interp(&T, (double)x[i] + 0.5, &dup, &j_up, &t_up);
            double d_lo, d_up;
            const double L = likelihood(flo, fup, &d_lo, &d_up);
            const double Lb = L > CN_PRIOR_LIKELIHOOD_MIN ? L : CN_PRIOR_LIKELIHOOD_MIN;
            bl = cn_xsum_plus(bl, cn_xsum_of(-log2(Lb)));
            const double g = -(double)scale / (Lb * M_LN2);
            if (dx)
                dx[i] += (float)(g * (d_up * dup + d_lo * dlo));
            if (wl) {
                wl[j_up] = cn_xsum_plus(wl[j_up], cn_xsum_of(g * d_up * (1 - t_up)));
                wl[j_up + 1] = cn_xsum_plus(wl[j_up + 1], cn_xsum_of(g * d_up * t_up));
                wl[j_lo] = cn_xsum_plus(wl[j_lo], cn_xsum_of(g * d_lo * (1 - t_lo)));
                wl[j_lo + 1] = cn_xsum_plus(wl[j_lo + 1], cn_xsum_of(g * d_lo * t_lo));
            }
        }
#pragma omp critical
        bits = cn_xsum_plus(bits, bl);
    }
    if (want_p) {
        cn_xsum dp_total[CN_PRIOR_PARAMS];
        memset(dp_total, 0, sizeof dp_total);
#pragma omp parallel
        {
            cn_xsum dpl[CN_PRIOR_PARAMS];
            memset(dpl, 0, sizeof dpl);
#pragma omp for schedule(static)
            for (size_t j = 0; j < T.nodes; j++) {
                cn_xsum wj = w[j];
                for (size_t k = 1; k < nt; k++)
                    wj = cn_xsum_plus(wj, w[T.nodes * k + j]);
                const double wv = cn_xsum_value(wj);
                if (wv == 0)
                    continue;
                trace t;
                double dj[CN_PRIOR_PARAMS] = {0};
                forward(&c, T.x0 + (double)j * T.h, &t);
                backward(&c, &t, wv, NULL, dj);
                add_params(dpl, dj);
            }
#pragma omp critical
            for (int k = 0; k < CN_PRIOR_PARAMS; k++)
                dp_total[k] = cn_xsum_plus(dp_total[k], dpl[k]);
        }
        for (int k = 0; k < CN_PRIOR_PARAMS; k++)
            dp[k] += (float)cn_xsum_value(dp_total[k]);
    }
    free(mem);
    free(w);
    return cn_xsum_value(bits);
}

void cn_prior_pmf(const float *p, int kmin, unsigned n, double *pmf)
{
    coef c;
    coef_init(&c, p);
    trace t;
    for (unsigned i = 0; i < n; i++) {
        const double k = (double)kmin + i;
        double d_lo, d_up;
        const double lo = forward(&c, k - 0.5, &t), up = forward(&c, k + 0.5, &t);
        pmf[i] = likelihood(lo, up, &d_lo, &d_up);
    }
}
