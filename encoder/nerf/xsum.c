/* Order-independent sums: terms rounded once to 128-bit fixed point, added exactly. */
#include <stdint.h>

#include "cn_xsum.h"

/* |term| is clamped here: 2^48 in units of 2^-64 is 2^112, so that 2^14 terms of that size
 * still fit in the 127 bits. The additions wrap (unsigned) instead of overflowing. */
#define CN_XSUM_MAX 0x1p48

cn_xsum cn_xsum_of(double v)
{
    if (!(v == v))
        return 0; /* not a number: no term (the loss, summed apart, shows it) */
    const int neg = v < 0;
    double a = neg ? -v : v;
    a = a > CN_XSUM_MAX ? CN_XSUM_MAX : a;
    /* |v| = hi + frac with frac = a - trunc(a) exact (the low bits of a), in [0, 1) */
    const uint64_t hi = (uint64_t)a;
    const uint64_t lo = (uint64_t)((a - (double)hi) * 0x1p64);
    const unsigned __int128 q = ((unsigned __int128)hi << 64) | lo;
    return (cn_xsum)(neg ? -q : q);
}

double cn_xsum_value(cn_xsum s) { return (double)s * 0x1p-64; }

void cn_xsum_add_f(cn_xsum *acc, const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        acc[i] = cn_xsum_plus(acc[i], cn_xsum_of(v[i]));
}

void cn_xsum_put_f(float *out, const cn_xsum *acc, size_t n)
{
    for (size_t i = 0; i < n; i++)
        out[i] += (float)cn_xsum_value(acc[i]);
}
