/*
 * The learned factorized prior of one layer's latents (Ballé et al. 2017/2018): a small
 * monotone network gives a cumulative c(x) = sigmoid(f(x)); the likelihood of an integer k
 * is c(k + 1/2) - c(k - 1/2), computed with the sign trick for stability and bounded below
 * by CN_PRIOR_LIKELIHOOD_MIN with a pass-through gradient. Filters (3, 3, 3): layer dims
 * 1 -> 3 -> 3 -> 3 -> 1; each layer is softplus(H) v + b, gated (except the last) by
 * v + tanh(a) * tanh(v).
 */
#ifndef CNERF_ENC_PRIOR_H
#define CNERF_ENC_PRIOR_H

#include <stddef.h>

#define CN_PRIOR_LAYERS 4
/* Floats of one prior: H (3 + 9 + 9 + 3) + b (3 + 3 + 3 + 1) + a (3 + 3 + 3). */
#define CN_PRIOR_PARAMS 43
#define CN_PRIOR_LIKELIHOOD_MIN 1e-9
#define CN_PRIOR_INIT_SCALE 10.0

/* Initialises one prior's parameters (p[CN_PRIOR_PARAMS]): H so that the density starts
 * about CN_PRIOR_INIT_SCALE wide, b uniform in [-1/2, 1/2) from u01 values, a = 0.
 * u01 supplies uniform [0, 1) numbers (10 are read). */
void cn_prior_init(float *p, const double *u01);

/* f(x), the logit of the cumulative. */
double cn_prior_logit(const float *p, double x);

/* Rate in bits of the values x[0..n) under the prior: sum -log2 L(x_i), with
 * L(x) = c(x + 1/2) - c(x - 1/2) bounded below. When dx is not NULL, dx[i] (+)= scale *
 * d bits / d x_i (accumulated); when dp is not NULL, dp += scale * d bits / d p. */
double cn_prior_bits(const float *p, const float *x, size_t n, float scale, float *dx,
                     float *dp);

/* cn_prior_bits for many values at once, the rate of a training step: f and f' are
 * computed at nodes CN_PRIOR_TABLE_PER_UNIT to a unit apart over the values' range and
 * interpolated between them (cubic Hermite), so that the cost no longer grows with the
 * prior's network per value. dx is the derivative of the interpolated rate; dp spreads each
 * value's d bits / d f onto its two nearest nodes (linearly). With fewer values than twice
 * the nodes, the exact cn_prior_bits. */
#define CN_PRIOR_TABLE_PER_UNIT 8
double cn_prior_rate(const float *p, const float *x, size_t n, float scale, float *dx,
                     float *dp);

/* The discretized PMF over the integers kmin .. kmin + n - 1 (not normalised: the
 * interval masses c(k + 1/2) - c(k - 1/2)). */
void cn_prior_pmf(const float *p, int kmin, unsigned n, double *pmf);

#endif /* CNERF_ENC_PRIOR_H */
