/* Small deterministic PRNG (splitmix64) for seeds, synthetic models and sampling. */
#ifndef CNERF_ENC_RNG_H
#define CNERF_ENC_RNG_H

#include <math.h>
#include <stdint.h>

typedef struct cn_rng {
    uint64_t s;
} cn_rng;

static inline cn_rng cn_rng_seed(uint64_t seed)
{
    cn_rng r = {seed ^ 0x9E3779B97F4A7C15ull};
    return r;
}

static inline uint64_t cn_rng_u64(cn_rng *r)
{
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double cn_rng_uniform(cn_rng *r) { return (double)(cn_rng_u64(r) >> 11) * 0x1p-53; }

/* Uniform integer in [0, n), n > 0. */
static inline uint32_t cn_rng_below(cn_rng *r, uint32_t n)
{
    return (uint32_t)(((cn_rng_u64(r) >> 32) * (uint64_t)n) >> 32);
}

/* Laplace(0, b). */
static inline double cn_rng_laplace(cn_rng *r, double b)
{
    double u = cn_rng_uniform(r) - 0.5;
    double a = 1.0 - 2.0 * fabs(u);
    if (a <= 0)
        a = 0x1p-53;
    return (u < 0 ? b : -b) * log(a);
}

/* Standard normal (Box-Muller). */
static inline double cn_rng_normal(cn_rng *r)
{
    double u1 = cn_rng_uniform(r), u2 = cn_rng_uniform(r);
    if (u1 <= 0)
        u1 = 0x1p-53;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

#endif /* CNERF_ENC_RNG_H */
