/* The stream's exact number formats: m24e8 scalars and bias blocks. */
#include <math.h>
#include <stdlib.h>

#include "cn_stream.h"

int cn_to_m24e8(double v, int32_t *m, int8_t *e)
{
    *m = 0;
    *e = 0;
    if (!isfinite(v))
        return -1;
    if (v == 0)
        return 0;
    int ex;
    double fr = frexp(v, &ex); /* v = fr * 2^ex, 0.5 <= |fr| < 1 */
    long long mm = llround(ldexp(fr, 23));
    int ee = ex - 23;
    if (llabs(mm) > CNERF_M24_ABS_MAX) { /* rounded up to 2^23 */
        mm /= 2;
        ee++;
    }
    if (ee < CNERF_EXP_MIN) { /* below the smallest exponent: fewer mantissa bits */
        mm = llround(ldexp(v, -CNERF_EXP_MIN));
        ee = CNERF_EXP_MIN;
    }
    if (ee > CNERF_EXP_MAX)
        return -1;
    *m = (int32_t)mm;
    *e = (int8_t)ee;
    return 0;
}

double cn_from_m24e8(int32_t m, int8_t e) { return ldexp((double)m, e); }

int cn_quantize_biases(const float *b, uint32_t n, unsigned nbits, int32_t *m, uint8_t *bits,
                       int8_t *e)
{
    *bits = 0;
    *e = 0;
    if (nbits < 1 || nbits > CNERF_MAX_BIAS_BITS)
        return -1;
    double maxabs = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (!isfinite(b[i]))
            return -1;
        if (fabs(b[i]) > maxabs)
            maxabs = fabs(b[i]);
    }
    for (uint32_t i = 0; i < n; i++)
        m[i] = 0;
    if (maxabs == 0)
        return 0;
    const double mmax = (double)((1u << (nbits - 1)) - 1u);
    if (mmax == 0) /* 1-bit mantissas hold only {-1, 0} */
        return -1;
    int ee = (int)ceil(log2(maxabs / mmax));
    while (llround(ldexp(maxabs, -ee)) > (long long)mmax)
        ee++;
    if (ee < CNERF_EXP_MIN)
        ee = CNERF_EXP_MIN;
    if (ee > CNERF_EXP_MAX)
        return -1;
    for (uint32_t i = 0; i < n; i++)
        m[i] = (int32_t)llround(ldexp(b[i], -ee));
    *bits = (uint8_t)nbits;
    *e = (int8_t)ee;
    return 0;
}
