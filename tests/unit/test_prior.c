/* The factorized prior: finite-difference gradients of the rate with respect to the values
 * and to the prior's parameters, monotone cumulative, PMF mass, lower-bound pass-through;
 * the tabulated rate of a training step against the exact one, and repeatable.
 * Tolerance: |analytic - numeric| <= 1e-3 * max(|a|, |n|) + 1e-5 (rates are in double). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "cn_prior.h"
#include "cn_rng.h"
#include "testutil.h"

static void init_prior(float *p, uint64_t seed, int perturb)
{
    cn_rng r = cn_rng_seed(seed);
    double u[10];
    for (int i = 0; i < 10; i++)
        u[i] = cn_rng_uniform(&r);
    cn_prior_init(p, u);
    if (perturb) /* move away from the symmetric start so every path carries gradient */
        for (int i = 0; i < CN_PRIOR_PARAMS; i++)
            p[i] += (float)(0.3 * (cn_rng_uniform(&r) - 0.5));
}

static int agree(double a, double n) { return fabs(a - n) <= 1e-3 * fmax(fabs(a), fabs(n)) + 1e-5; }

static void test_rate_gradients(void **state)
{
    (void)state;
    float p[CN_PRIOR_PARAMS];
    init_prior(p, 1, 1);
    enum { N = 40 };
    float x[N], dx[N] = {0}, dp[CN_PRIOR_PARAMS] = {0};
    cn_rng r = cn_rng_seed(2);
    for (int i = 0; i < N; i++)
        x[i] = (float)((cn_rng_uniform(&r) - 0.5) * 40.0); /* across the body and the tails */
    const float scale = 0.7f;
    cn_prior_bits(p, x, N, scale, dx, dp);
    int bad = 0;
    for (int i = 0; i < N; i++) {
        const float keep = x[i], h = 1e-2f;
        x[i] = keep + h;
        double bp = cn_prior_bits(p, x, N, 1, NULL, NULL);
        x[i] = keep - h;
        double bm = cn_prior_bits(p, x, N, 1, NULL, NULL);
        x[i] = keep;
        double num = scale * (bp - bm) / (2.0 * h);
        if (!agree(dx[i], num)) {
            print_error("dx[%d] at x=%g: analytic %g numeric %g\n", i, keep, dx[i], num);
            bad++;
        }
    }
    for (int j = 0; j < CN_PRIOR_PARAMS; j++) {
        const float keep = p[j], h = 1e-3f;
        p[j] = keep + h;
        double bp = cn_prior_bits(p, x, N, 1, NULL, NULL);
        p[j] = keep - h;
        double bm = cn_prior_bits(p, x, N, 1, NULL, NULL);
        p[j] = keep;
        double num = scale * (bp - bm) / (2.0 * h);
        if (!agree(dp[j], num)) {
            print_error("dp[%d]: analytic %g numeric %g\n", j, dp[j], num);
            bad++;
        }
    }
    assert_int_equal(bad, 0);
}

static void test_monotone_and_mass(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 5; seed++) {
        float p[CN_PRIOR_PARAMS];
        init_prior(p, seed, 1);
        double prev = -INFINITY;
        for (double x = -300; x <= 300; x += 0.37) {
            double f = cn_prior_logit(p, x);
            assert_true(f > prev);
            prev = f;
        }
        /* The interval masses telescope to c(+inf) - c(-inf) = 1. */
        enum { K = 4001 };
        double *pmf = malloc(sizeof(double) * K);
        cn_prior_pmf(p, -2000, K, pmf);
        double sum = 0;
        for (int i = 0; i < K; i++) {
            assert_true(pmf[i] >= 0);
            sum += pmf[i];
        }
        assert_float_equal(sum, 1.0, 1e-6);
        free(pmf);
    }
}

/* Past the bound the likelihood is clamped (about 29.9 bits) and the gradient still pulls
 * the value towards the mass. (Much further out, about 30 logit units past the body, the
 * sigmoid's own slope underflows and the gradient fades: values that far from the prior's
 * mass do not arise from a Glorot start.) */
static void test_lower_bound_pass_through(void **state)
{
    (void)state;
    float p[CN_PRIOR_PARAMS];
    init_prior(p, 3, 0);
    float x[2] = {250.0f, -250.0f}, dx[2] = {0, 0};
    double bits = cn_prior_bits(p, x, 2, 1, dx, NULL);
    assert_float_equal(bits, 2 * -log2(CN_PRIOR_LIKELIHOOD_MIN), 1e-6);
    assert_true(dx[0] > 0); /* rate grows with x: descent moves x down */
    assert_true(dx[1] < 0);
}

/* The rate of integers under the discretized prior is what the coder will pay: the bits
 * equal -sum log2 pmf. */
static void test_bits_match_pmf(void **state)
{
    (void)state;
    float p[CN_PRIOR_PARAMS];
    init_prior(p, 4, 1);
    float x[21];
    double pmf[21], ideal = 0;
    cn_prior_pmf(p, -10, 21, pmf);
    for (int i = 0; i < 21; i++) {
        x[i] = (float)(i - 10);
        ideal += -log2(pmf[i]);
    }
    assert_float_equal(cn_prior_bits(p, x, 21, 1, NULL, NULL), ideal, 1e-9 * ideal + 1e-9);
}

/* The tabulated rate of a training step against the exact one, on priors from about a
 * third of a unit to a hundred units wide (the first layer's slopes scaled) and values
 * across the body and the tails: the bits, every value's gradient and the prior's. */
static void test_table_matches_exact(void **state)
{
    (void)state;
    enum { N = 6000 };
    float *x = malloc(sizeof(float) * N), *dx_t = malloc(sizeof(float) * N),
          *dx_e = malloc(sizeof(float) * N);
    assert_non_null(x);
    assert_non_null(dx_t);
    assert_non_null(dx_e);
    const double widen[] = {-3.0, -1.0, 0.0, 1.5, 3.0}; /* added to the first layer's H */
    for (int s = 0; s < 5; s++) {
        float p[CN_PRIOR_PARAMS];
        init_prior(p, 10 + (uint64_t)s, 1);
        for (int i = 0; i < 3; i++)
            p[i] += (float)widen[s];
        cn_rng r = cn_rng_seed(20 + (uint64_t)s);
        const double spread = fmin(60.0 * exp(-widen[s]), 300.0); /* the table, not the fallback */
        for (int i = 0; i < N; i++)
            x[i] = (float)((cn_rng_uniform(&r) - 0.5) * spread);
        float dp_t[CN_PRIOR_PARAMS] = {0}, dp_e[CN_PRIOR_PARAMS] = {0};
        for (int i = 0; i < N; i++)
            dx_t[i] = dx_e[i] = 0;
        const double bt = cn_prior_rate(p, x, N, 0.5f, dx_t, dp_t);
        const double be = cn_prior_bits(p, x, N, 0.5f, dx_e, dp_e);
        double gmax = 0, ex = 0, pmax = 0, ep = 0;
        for (int i = 0; i < N; i++) {
            gmax = fmax(gmax, fabs(dx_e[i]));
            ex = fmax(ex, fabs(dx_t[i] - dx_e[i]));
        }
        for (int j = 0; j < CN_PRIOR_PARAMS; j++) {
            pmax = fmax(pmax, fabs(dp_e[j]));
            ep = fmax(ep, fabs(dp_t[j] - dp_e[j]));
        }
        print_message("width shift %+.1f: bits %.9g / %.9g (rel %.2e), dx %.2e of %.2e, dp %.2e of %.2e\n",
                      widen[s], bt, be, fabs(bt - be) / be, ex, gmax, ep, pmax);
        assert_true(fabs(bt - be) <= 1e-6 * be);
        assert_true(ex <= 1e-4 * gmax);
        assert_true(ep <= 1e-3 * pmax);
    }
    free(x);
    free(dx_t);
    free(dx_e);
}

/* The tabulated rate's gradient with respect to the values is the derivative of the
 * tabulated rate itself (finite differences of cn_prior_rate). */
static void test_table_gradients(void **state)
{
    (void)state;
    float p[CN_PRIOR_PARAMS];
    init_prior(p, 6, 1);
    enum { N = 2000 };
    float *x = malloc(sizeof(float) * N), *dx = calloc(N, sizeof(float));
    assert_non_null(x);
    assert_non_null(dx);
    cn_rng r = cn_rng_seed(7);
    for (int i = 0; i < N; i++)
        x[i] = (float)((cn_rng_uniform(&r) - 0.5) * 40.0);
    cn_prior_rate(p, x, N, 1, dx, NULL);
    int bad = 0;
    for (int i = 0; i < N; i += 97) {
        const float keep = x[i], h = 1e-2f;
        x[i] = keep + h;
        const double bp = cn_prior_rate(p, x, N, 1, NULL, NULL);
        x[i] = keep - h;
        const double bm = cn_prior_rate(p, x, N, 1, NULL, NULL);
        x[i] = keep;
        const double num = (bp - bm) / (2.0 * h);
        if (!agree(dx[i], num)) {
            print_error("dx[%d] at x=%g: analytic %g numeric %g\n", i, keep, dx[i], num);
            bad++;
        }
    }
    assert_int_equal(bad, 0);
    /* Three threads, twice: the same bits and the same gradients, to the bit (the partial
     * sums are added in thread order). */
    const int keep_threads = omp_get_max_threads();
    omp_set_num_threads(3);
    float dp[2][CN_PRIOR_PARAMS] = {{0}};
    double b[2];
    for (int k = 0; k < 2; k++) {
        memset(dx, 0, sizeof(float) * N);
        b[k] = cn_prior_rate(p, x, N, 1, dx, dp[k]);
    }
    omp_set_num_threads(keep_threads);
    assert_memory_equal(&b[0], &b[1], sizeof b[0]);
    assert_memory_equal(dp[0], dp[1], sizeof dp[0]);
    free(x);
    free(dx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rate_gradients),
        cmocka_unit_test(test_monotone_and_mass),
        cmocka_unit_test(test_lower_bound_pass_through),
        cmocka_unit_test(test_bits_match_pmf),
        cmocka_unit_test(test_table_matches_exact),
        cmocka_unit_test(test_table_gradients),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
