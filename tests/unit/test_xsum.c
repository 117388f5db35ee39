/* Exact sums (encoder/nerf/cn_xsum.h): the same total for any order and any split of the
 * terms, the exact value where a double holds it, the clamps. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "cn_rng.h"
#include "cn_xsum.h"
#include "testutil.h"

enum { N = 4096 };

/* Terms over 40 binary orders of magnitude and both signs, as gradients are. */
static void terms(float *v, uint64_t seed)
{
    cn_rng r = cn_rng_seed(seed);
    for (int i = 0; i < N; i++) {
        const double mag = ldexp(1.0, (int)cn_rng_below(&r, 40) - 30);
        v[i] = (float)((2 * cn_rng_uniform(&r) - 1) * mag);
    }
}

static void test_order_and_split(void **state)
{
    (void)state;
    static float v[N];
    terms(v, 1);
    cn_xsum fwd = 0, rev = 0;
    for (int i = 0; i < N; i++)
        fwd = cn_xsum_plus(fwd, cn_xsum_of(v[i]));
    for (int i = N; i-- > 0;)
        rev = cn_xsum_plus(rev, cn_xsum_of(v[i]));
    assert_true(fwd == rev);
    /* Split into 1 to 7 parts summed apart, then the parts in any order. */
    for (int parts = 1; parts <= 7; parts++) {
        cn_xsum part[7] = {0}, total = 0;
        for (int i = 0; i < N; i++)
            part[i * parts / N] = cn_xsum_plus(part[i * parts / N], cn_xsum_of(v[i]));
        for (int k = parts; k-- > 0;)
            total = cn_xsum_plus(total, part[k]);
        assert_true(total == fwd);
    }
    /* The same terms in float, summed forward and backward, do differ: the test would see an
     * order-dependent sum. */
    float f = 0, b = 0;
    for (int i = 0; i < N; i++)
        f += v[i];
    for (int i = N; i-- > 0;)
        b += v[i];
    assert_true(f != b);
    /* The exact total, read back, is within the float sums' error of either. */
    assert_true(fabs(cn_xsum_value(fwd) - f) < 1e-3 * 1024);
}

static void test_exact_values(void **state)
{
    (void)state;
    /* Dyadic terms add exactly: 2^40 + 2^-60 - 2^40 is 2^-60. */
    cn_xsum s = cn_xsum_plus(cn_xsum_of(0x1p40), cn_xsum_of(0x1p-60));
    s = cn_xsum_plus(s, cn_xsum_of(-0x1p40));
    assert_true(cn_xsum_value(s) == 0x1p-60);
    /* Terms round toward zero: +-(2^-64 + 2^-70) become +-2^-64, +-2^-70 nothing. */
    assert_true(cn_xsum_value(cn_xsum_of(-(0x1p-64 + 0x1p-70))) == -0x1p-64);
    assert_true(cn_xsum_value(cn_xsum_of(0x1p-64 + 0x1p-70)) == 0x1p-64);
    assert_true(cn_xsum_of(-0x1p-70) == 0 && cn_xsum_of(0x1p-70) == 0);
    assert_true(cn_xsum_value(cn_xsum_of(-1.0 + 0x1p-52)) == -1.0 + 0x1p-52);
    assert_true(cn_xsum_value(cn_xsum_of(-3.25)) == -3.25);
    assert_true(cn_xsum_value(cn_xsum_of(0.0)) == 0.0);
    /* Clamps: beyond +-2^48, infinities; NaN adds nothing. */
    assert_true(cn_xsum_value(cn_xsum_of(1e300)) == 0x1p48);
    assert_true(cn_xsum_value(cn_xsum_of(-INFINITY)) == -0x1p48);
    assert_true(cn_xsum_of(NAN) == 0);
}

static void test_arrays(void **state)
{
    (void)state;
    static float v[N], out[N];
    static cn_xsum acc[N];
    terms(v, 2);
    memset(acc, 0, sizeof acc);
    cn_xsum_add_f(acc, v, N);
    cn_xsum_add_f(acc, v, N);
    for (int i = 0; i < N; i++)
        out[i] = 1.0f;
    cn_xsum_put_f(out, acc, N);
    for (int i = 0; i < N; i++)
        assert_true(out[i] == 1.0f + (float)(2.0 * v[i]));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_order_and_split),
        cmocka_unit_test(test_exact_values),
        cmocka_unit_test(test_arrays),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
