/* The factorized prior: cumulative network, likelihoods, rate and gradients. */
#include <math.h>
#include <string.h>

#include "cn_prior.h"

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

double cn_prior_bits(const float *p, const float *x, size_t n, float scale, float *dx,
                     float *dp)
{
    double bits = 0;
    double dp_total[CN_PRIOR_PARAMS] = {0};
    const int want_p = dp != NULL;
    coef c;
    coef_init(&c, p);
#pragma omp parallel reduction(+ : bits)
    {
        double dpl[CN_PRIOR_PARAMS] = {0};
#pragma omp for schedule(static)
        for (size_t i = 0; i < n; i++) {
            trace tl, tu;
            const double lo = forward(&c, (double)x[i] - 0.5, &tl);
            const double up = forward(&c, (double)x[i] + 0.5, &tu);
            double d_lo, d_up;
            const double L = likelihood(lo, up, &d_lo, &d_up);
            const double Lb = L > CN_PRIOR_LIKELIHOOD_MIN ? L : CN_PRIOR_LIKELIHOOD_MIN;
            bits += -log2(Lb);
            if (!dx && !want_p)
                continue;
            /* d bits / d L, passed through the lower bound (it only pushes L up). */
            const double g = -(double)scale / (Lb * M_LN2);
            double gx = 0;
            backward(&c, &tu, g * d_up, dx ? &gx : NULL, want_p ? dpl : NULL);
            backward(&c, &tl, g * d_lo, dx ? &gx : NULL, want_p ? dpl : NULL);
            if (dx)
                dx[i] += (float)gx;
        }
        if (want_p) {
#pragma omp critical
            for (int j = 0; j < CN_PRIOR_PARAMS; j++)
                dp_total[j] += dpl[j];
        }
    }
    if (want_p)
        for (int j = 0; j < CN_PRIOR_PARAMS; j++)
            dp[j] += (float)dp_total[j];
    return bits;
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
