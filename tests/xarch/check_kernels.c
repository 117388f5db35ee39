/*
 * The decoder's kernels against its portable C, in the manner of dav1d's checkasm: every
 * dot-product kernel this build and CPU have (cn_dot_variants) on random packed layers of
 * every shape up to 13 rows and 71 input pairs and on the extremes (the largest latents a
 * row may hold for int32 sums, saturated inputs), cn_dot_s16_c itself against a plain int64
 * sum over the unpacked rows, and the layers' fast rescale and input quantization against
 * the exact arithmetic they stand for. Decoder only, no libc beyond stdio: it also runs
 * under qemu-user for other architectures (scripts/xarch.sh).
 *   check_kernels [ITERATIONS]
 */
#include <stdio.h>
#include <stdlib.h>

#include "../../common/cn_fixed.h"
#include "../../decoder/cn_kernels.h"

static uint64_t rng = 0x9E3779B97F4A7C15u;
static uint32_t rnd(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (uint32_t)(rng >> 16);
}
/* Random values built from several draws take them in statement order (the order of
 * evaluation within an expression is unspecified), so every architecture checks the same
 * cases. */
static int32_t rnd_i32(void)
{
    const uint32_t lo = rnd();
    const uint32_t hi = rnd() << 16;
    return (int32_t)(lo ^ hi);
}
static int32_t rnd_shifted(void)
{
    const int32_t v = rnd_i32();
    return v >> (rnd() % 24u);
}
static int32_t rnd_signed(uint64_t below)
{
    const int64_t m = (int64_t)(rnd() % below);
    return (int32_t)(rnd() & 1 ? m : -m);
}
static int32_t rnd_range(int32_t lo, int32_t hi) { return lo + (int32_t)(rnd() % (uint32_t)(hi - lo + 1)); }

#define MAX_ROWS 13
#define MAX_PAIRS 71
static int16_t rowmajor[MAX_ROWS][2 * MAX_PAIRS];
static int16_t packed[MAX_ROWS * 2 * MAX_PAIRS + 16];
static int16_t xq[2 * MAX_PAIRS + 8] __attribute__((aligned(8)));
static int16_t kbuf[MAX_ROWS * 2 * MAX_PAIRS + 16] __attribute__((aligned(8)));

/* The packed layout of cnerf_decoder.latent (blocks of four rows, pair by pair; the last
 * one to three rows row after row), written here independently of the decoder's. */
static void pack(uint32_t rows, uint32_t pairs)
{
    for (uint32_t j = 0; j < rows; j++)
        for (uint32_t i = 0; i < 2 * pairs; i++) {
            const uint32_t b = j / 4, q = j % 4;
            if ((b + 1) * 4 <= rows)
                packed[b * 8 * pairs + (i / 2) * 8 + 2 * q + (i & 1)] = rowmajor[j][i];
            else /* the last one to three rows, row after row */
                packed[b * 8 * pairs + q * 2 * pairs + i] = rowmajor[j][i];
        }
    for (uint32_t i = 0; i < rows * 2 * pairs; i++)
        kbuf[i] = packed[i];
}

static int fails, passes;
static void check(int ok, const char *what, const char *name, uint32_t rows, uint32_t pairs)
{
    if (ok) {
        passes++;
        return;
    }
    if (fails++ < 20)
        printf("FAIL %s (%s): %u rows, %u pairs\n", what, name, rows, pairs);
}

/* Fills one case: mode 0 random small latents, 1 the extremes (each row's sum |k| at the
 * int32 bound 65535, inputs at -32768 or 32767), 2 random inputs with sparse large latents. */
static void fill(uint32_t rows, uint32_t pairs, int mode)
{
    for (uint32_t i = 0; i < 2 * pairs; i++)
        xq[i] = (int16_t)(mode == 1 ? (rnd() & 1 ? 32767 : -32768) : rnd_range(-32768, 32767));
    for (uint32_t j = 0; j < rows; j++) {
        for (uint32_t i = 0; i < 2 * pairs; i++)
            rowmajor[j][i] = (int16_t)(mode == 0 ? rnd_range(-127, 127) : 0);
        if (mode == 0)
            continue;
        int32_t budget = mode == 1 ? 65535 : rnd_range(1, 65535);
        while (budget > 0) {
            const uint32_t i = rnd() % (2 * pairs);
            int32_t m = budget < 32767 ? budget : 32767;
            m = mode == 1 ? m : rnd_range(1, m);
            const int32_t have = rowmajor[j][i] < 0 ? -rowmajor[j][i] : rowmajor[j][i];
            if (have + m > 32767)
                m = 32767 - have;
            if (m == 0)
                break;
            rowmajor[j][i] = (int16_t)((rowmajor[j][i] < 0 || (rowmajor[j][i] == 0 && (rnd() & 1)))
                                           ? rowmajor[j][i] - m
                                           : rowmajor[j][i] + m);
            budget -= m;
        }
    }
}

int main(int argc, char **argv)
{
    const long iters = argc > 1 ? atol(argv[1]) : 3;
    cn_dot_variant v[CN_DOT_MAX_VARIANTS];
    const uint32_t nv = cn_dot_variants(v);
    printf("kernels:");
    for (uint32_t i = 0; i < nv; i++)
        printf(" %s", v[i].name);
    printf(" (chosen: %s)\n", v[nv - 1].name);
    int32_t want[MAX_ROWS], got[MAX_ROWS];
    int64_t want64[MAX_ROWS];
    for (long it = 0; it < iters; it++)
        for (int mode = 0; mode < 3; mode++)
            for (uint32_t rows = 1; rows <= MAX_ROWS; rows++)
                for (uint32_t pairs = 1; pairs <= MAX_PAIRS; pairs += pairs < 9 ? 1 : 7) {
                    fill(rows, pairs, mode);
                    pack(rows, pairs);
                    int ok = 1;
                    for (uint32_t j = 0; j < rows; j++) {
                        int64_t s = 0;
                        for (uint32_t i = 0; i < 2 * pairs; i++)
                            s += (int64_t)rowmajor[j][i] * xq[i];
                        want[j] = (int32_t)s;
                        ok &= s >= INT32_MIN && s <= INT32_MAX;
                    }
                    check(ok, "the case keeps the int32 bound", "setup", rows, pairs);
                    cn_dot_s16_s64_c(kbuf, xq, pairs, rows, want64);
                    ok = 1;
                    for (uint32_t j = 0; j < rows; j++)
                        ok &= want64[j] == want[j];
                    check(ok, "int64 sums", "c", rows, pairs);
                    for (uint32_t k = 0; k < nv; k++) {
                        for (uint32_t j = 0; j < rows; j++)
                            got[j] = 0x5A5A5A5A;
                        v[k].fn(kbuf, xq, pairs, rows, got);
                        ok = 1;
                        for (uint32_t j = 0; j < rows; j++)
                            ok &= got[j] == want[j];
                        check(ok, "int32 sums", v[k].name, rows, pairs);
                    }
                }
    /* The fast rescale against the exact product, wherever cnerf_open takes it: |acc| at most
     * 2^15 S with S <= 65535, and 2^15 S |m| < 2^(30+n). */
    for (long it = 0; it < 200000 * iters; it++) {
        const unsigned n = 1u + rnd() % 62u;
        const int32_t m = rnd_range(-8388607, 8388607);
        const uint64_t am = (uint64_t)(m < 0 ? -(int64_t)m : m);
        uint64_t lim = (uint64_t)65535 << 15; /* the largest |acc| */
        if (am && 30 + n < 63 && ((uint64_t)1 << (30 + n)) / am < lim)
            lim = ((uint64_t)1 << (30 + n)) / am;
        if (lim < 1)
            continue;
        const int32_t acc = rnd_signed(lim);
        const int32_t fast = cn_rescale_fast(acc, m, n, (uint64_t)1 << (n - 1u));
        const int64_t exact = cn_mul_exp_r(acc, m, -(int)n, 1);
        check(fast == exact, "fast rescale", "c", n, 0);
    }
    /* Input quantization: the saturating-add form against floor(x / 2^s + 1/2) in int64. */
    for (long it = 0; it < 200000 * iters; it++) {
        const unsigned s = rnd() % 32u;
        const int32_t x = rnd_shifted();
        const int64_t e = s ? ((int64_t)x + ((int64_t)1 << (s - 1))) >> s : x; /* gcc: arithmetic */
        const int32_t want_q = (int32_t)(e > 32767 ? 32767 : e < -32768 ? -32768 : e);
        check(cn_requant16(x, s) == want_q, "input quantization", "c", s, 0);
        if (s >= 1 && s <= 16) {
            const int32_t q = cn_sat16(cn_asr32(cn_qadd32(x, (int32_t)1 << (s - 1u)), s));
            check(q == want_q, "input quantization, saturating add", "c", s, 0);
        }
    }
    /* Each kernel set's own input quantization and output loops against the C forms. */
    static int32_t xs[97], accs[97], bqs[97], ys[97], yc[97];
    static int16_t qa[98], qc[98];
    for (uint32_t k = 0; k < nv; k++) {
        if (!v[k].requant && !v[k].finish)
            continue;
        for (long it = 0; it < 2000 * iters; it++) {
            const uint32_t n = 1u + rnd() % 97u;
            const unsigned s = 1u + rnd() % 16u;
            for (uint32_t i = 0; i < n; i++)
                xs[i] = rnd_shifted();
            int32_t sum = 0;
            for (uint32_t i = 0; i < n; i++) {
                qc[i] = cn_requant16(xs[i], s);
                sum += qc[i];
            }
            if (v[k].requant) {
                int ok = v[k].requant(xs, qa, n, s) == sum;
                for (uint32_t i = 0; i < n; i++)
                    ok &= qa[i] == qc[i];
                check(ok, "input quantization", v[k].name, n, s);
            }
            /* outputs: a_m and n as cnerf_open allows them (|acc a_m| < 2^(30+n)) */
            const unsigned nn = 1u + rnd() % 31u;
            const int32_t am = rnd_range(-8388607, 8388607);
            const uint64_t mag = (uint64_t)(am < 0 ? -(int64_t)am : am) + 1u;
            uint64_t lim = (((uint64_t)1 << (30 + nn)) - 1u) / mag;
            lim = lim > 0x7FFFFFFFu ? 0x7FFFFFFFu : lim;
            const int32_t t = rnd_i32(), relu = (int32_t)(rnd() & 1u);
            for (uint32_t i = 0; i < n; i++) {
                accs[i] = rnd_signed(lim + 1u);
                bqs[i] = rnd_i32();
                bqs[i] >>= rnd() % 31u;
                const int32_t a = (int32_t)cn_mul_exp_r(accs[i], am, -(int)nn, 1);
                const int32_t r = cn_sat32((int64_t)cn_sat32((int64_t)a + t) + bqs[i]);
                yc[i] = relu && r < 0 ? 0 : r;
            }
            if (v[k].finish) {
                v[k].finish(accs, n, am, nn, t, bqs, ys, relu);
                int ok = 1;
                for (uint32_t i = 0; i < n; i++)
                    ok &= ys[i] == yc[i];
                check(ok, "outputs", v[k].name, n, nn);
            }
        }
    }
    printf("%d passed, %d failed\n", passes, fails);
    return fails != 0;
}
