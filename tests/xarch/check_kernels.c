/*
 * The decoder's kernels against its portable C, in the manner of dav1d's checkasm: every
 * dot-product kernel this build and CPU have (cn_dot_variants) on random packed layers of
 * every shape up to 13 rows and 71 input pairs and on the extremes (the largest latents a
 * row may hold for int32 sums, saturated inputs), every set's sums over lists of the non-zero
 * latents (spdot) on the same layers, cn_dot_s16_c itself against a plain int64
 * sum over the unpacked rows, and the layers' fast rescale and input quantization against
 * the exact arithmetic they stand for. Decoder only, no libc beyond stdio, stdlib and the
 * clock: it also runs under qemu-user for other architectures (scripts/xarch.sh).
 *   check_kernels [--bench] [ITERATIONS]
 * --bench: after the checks, times every kernel against the portable C on the shapes the
 * checks use and prints the medians (checkasm's --bench), and each set's costs of packed
 * sums and lists, as cnerf_open weighs them. Timings are never pass or fail: the exit status
 * is the checks'.
 */
#if defined(CK_FIRMWARE)
/* The Cortex-M firmware build (platform/cortex-m, ctests check_kernels_m4 and _m55): no libc;
 * the checks print through semihosting, with the number of iterations fixed and no bench. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include "semihost.h"

/* printf for the checks' lines: %s, %u, %d and %ld only. */
#define printf ck_printf
static void ck_printf(const char *fmt, ...)
{
    char buf[160];
    size_t n = 0;
    va_list ap;
    va_start(ap, fmt);
    for (const char *f = fmt; *f && n + 24 < sizeof buf; f++) {
        if (*f != '%') {
            buf[n++] = *f;
            continue;
        }
        f++;
        int neg = 0;
        uint64_t v = 0;
        if (*f == 's') {
            for (const char *a = va_arg(ap, const char *); *a && n + 24 < sizeof buf; a++)
                buf[n++] = *a;
            continue;
        } else if (*f == 'u') {
            v = va_arg(ap, unsigned);
        } else if (*f == 'd' || (*f == 'l' && f[1] == 'd')) {
            const long x = *f == 'd' ? va_arg(ap, int) : va_arg(ap, long);
            f += *f == 'l';
            neg = x < 0;
            v = neg ? 0u - (uint64_t)x : (uint64_t)x;
        }
        char d[24];
        int k = 0;
        do
            d[k++] = (char)('0' + v % 10u);
        while ((v /= 10u) != 0u);
        if (neg)
            buf[n++] = '-';
        while (k > 0)
            buf[n++] = d[--k];
    }
    va_end(ap);
    buf[n] = 0;
    sh_puts(buf);
}
#else
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#endif

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
static int8_t kbuf8[MAX_ROWS * 2 * MAX_PAIRS + 16] __attribute__((aligned(8)));

/* The packed layouts of the decoded latents (cn_packed_index in decoder/cn_kernels.h:
 * blocks of four rows, pair by pair (CN_PAIRS) or run by run of eight inputs, a last run of
 * m < 8 inputs holding each row's m latents in turn (CN_RUNS8); the last one to three rows
 * row after row), written here independently of the decoder's, into kbuf. */
static void pack(uint32_t rows, uint32_t pairs, uint32_t layout)
{
    for (uint32_t j = 0; j < rows; j++)
        for (uint32_t i = 0; i < 2 * pairs; i++) {
            const uint32_t b = j / 4, q = j % 4, run = i / 8;
            const uint32_t m = 2 * pairs - 8 * run < 8 ? 2 * pairs - 8 * run : 8;
            if ((b + 1) * 4 > rows) /* the last one to three rows, row after row */
                packed[b * 8 * pairs + q * 2 * pairs + i] = rowmajor[j][i];
            else if (layout == CN_RUNS8)
                packed[b * 8 * pairs + run * 32 + q * m + i % 8] = rowmajor[j][i];
            else
                packed[b * 8 * pairs + (i / 2) * 8 + 2 * q + (i & 1)] = rowmajor[j][i];
        }
    for (uint32_t i = 0; i < rows * 2 * pairs; i++)
        kbuf[i] = packed[i];
}

/* The same rows as int8 (every latent within [-128, 127]) into kbuf8, in the int8 layouts:
 * CN_PAIRS and CN_RUNS8 as above, or CN_PAIRS_X, pair by pair with the bytes of rows 0
 * and 1 (2 and 3) crossed: k[0][2p], k[1][2p], k[0][2p+1], k[1][2p+1]. */
static void pack8(uint32_t rows, uint32_t pairs, uint32_t layout)
{
    pack(rows, pairs, layout == CN_PAIRS_X ? CN_PAIRS : layout);
    for (uint32_t i = 0; i < rows * 2 * pairs; i++)
        kbuf8[i] = (int8_t)packed[i];
    if (layout != CN_PAIRS_X)
        return;
    for (uint32_t j = 0; j < rows - rows % 4; j++) /* the full blocks only */
        for (uint32_t i = 0; i < 2 * pairs; i++) {
            const uint32_t b = j / 4, q = j % 4;
            kbuf8[b * 8 * pairs + (i / 2) * 8 + 4 * (q / 2) + 2 * (i & 1) + (q & 1)] =
                (int8_t)rowmajor[j][i];
        }
}

/* cn_spdot_fn's lists of the non-zero latents of rowmajor's rows (kernels.c's layout, written
 * here independently): per row its count, then (2 i) << 16 | (uint16_t)k. Returns the
 * non-zeros. */
static uint32_t lists[MAX_ROWS * (1 + 2 * MAX_PAIRS)];
static uint32_t make_lists(uint32_t rows, uint32_t pairs)
{
    uint32_t w = 0, nz = 0;
    for (uint32_t j = 0; j < rows; j++) {
        const uint32_t at = w++;
        lists[at] = 0;
        for (uint32_t i = 0; i < 2 * pairs; i++)
            if (rowmajor[j][i]) {
                lists[w++] = (2u * i) << 16 | ((uint32_t)(uint16_t)rowmajor[j][i]);
                lists[at]++;
                nz++;
            }
    }
    return nz;
}

/* 1 when the first `rows` sums of got (int32 or int64) are want's. */
static int same32(const int32_t *got, const int32_t *want, uint32_t rows)
{
    int ok = 1;
    for (uint32_t j = 0; j < rows; j++)
        ok &= got[j] == want[j];
    return ok;
}
static int same64(const int64_t *got, const int32_t *want, uint32_t rows)
{
    int ok = 1;
    for (uint32_t j = 0; j < rows; j++)
        ok &= got[j] == want[j];
    return ok;
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
 * int32 bound 65535, inputs at -32768 or 32767), 2 random inputs with sparse large latents,
 * 3 the int8 extremes (latents -128, 127 or 0, inputs at -32768 or 32767). Modes 0 and 3
 * fit int8. */
static void fill(uint32_t rows, uint32_t pairs, int mode)
{
    for (uint32_t i = 0; i < 2 * pairs; i++)
        xq[i] = (int16_t)(mode == 1 || mode == 3 ? (rnd() & 1 ? 32767 : -32768)
                                                 : rnd_range(-32768, 32767));
    for (uint32_t j = 0; j < rows; j++) {
        for (uint32_t i = 0; i < 2 * pairs; i++) {
            const uint32_t r = rnd() % 3u;
            rowmajor[j][i] = (int16_t)(mode == 0   ? rnd_range(-127, 127)
                                       : mode == 3 ? (r == 0 ? -128 : r == 1 ? 127 : 0)
                                                   : 0);
        }
        if (mode == 0 || mode == 3)
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

#if !defined(CK_FIRMWARE)
/* ---- --bench ---- */

#define BENCH_RUNS 15        /* timed runs per kernel and shape; the median is printed */
#define BENCH_MIN_NS 20000u  /* a run makes calls until it lasts at least this long */
#define BENCH_MAX_CALLS (1L << 24)

static uint64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (uint64_t)t.tv_sec * 1000000000u + (uint64_t)t.tv_nsec;
}

/* render.c's portable loops for 1 <= s <= 16 and n < 32 (its requant and finish_fast where
 * there is no DSP extension), written here the same way: the C that the kernels' own input
 * and output loops replace. */
static int32_t requant_c(const int32_t *x, int16_t *q, uint32_t n, unsigned s)
{
    const int32_t h = (int32_t)1 << (s - 1u);
    int32_t sum = 0;
    for (uint32_t i = 0; i < n; i++) {
        const int32_t v = cn_sat16(cn_asr32(cn_qadd32(x[i], h), s));
        q[i] = (int16_t)v;
        sum += v;
    }
    return sum;
}
static void finish_c(const int32_t *acc, uint32_t live, int32_t am, unsigned n, int32_t t,
                     const int32_t *bq, int32_t *y, int relu)
{
    const uint64_t half = (uint64_t)1 << (n - 1u);
    for (uint32_t j = 0; j < live; j++) {
        const int32_t v = cn_qadd32(cn_qadd32(cn_rescale_fast(acc[j], am, n, half), t), bq[j]);
        y[j] = relu && v < 0 ? 0 : v;
    }
}

enum { OP_DOT, OP_REQUANT, OP_FINISH, OP_SPDOT, OP_DOT8 };
static const char *const op_name[] = {"dot_s16", "requant_s16", "finish_s32", "spdot_s16"};

/* One shape of one operation. */
typedef struct bench_case {
    int op;
    uint32_t rows, pairs; /* dot */
    uint32_t n;           /* requant: inputs; finish: outputs */
    unsigned s;           /* requant: the scale's shift; finish: the rescale's */
    int32_t am, t;
    int relu;
} bench_case;

static int32_t b_x[97], b_acc[97], b_bq[97], b_y[97], b_out[MAX_ROWS];
static int16_t b_q[98];
static volatile int32_t b_sink;

/* `calls` calls of set v's kernel for c's operation (through volatile pointers, so that
 * none is merged or hoisted). */
static void run(const cn_dot_variant *v, const bench_case *c, long calls)
{
    if (c->op == OP_DOT) {
        cn_dot_fn volatile f = v->fn;
        for (long i = 0; i < calls; i++)
            f(kbuf, xq, c->pairs, c->rows, b_out);
    } else if (c->op == OP_DOT8) {
        cn_dot8_fn volatile f = v->fn8;
        for (long i = 0; i < calls; i++)
            f(kbuf8, xq, c->pairs, c->rows, b_out);
    } else if (c->op == OP_SPDOT) {
        cn_spdot_fn volatile f = v->spdot;
        for (long i = 0; i < calls; i++)
            f(lists, xq, c->rows, b_out);
    } else if (c->op == OP_REQUANT) {
        cn_requant_fn volatile f = v->requant;
        for (long i = 0; i < calls; i++)
            b_sink = f(b_x, b_q, c->n, c->s);
    } else {
        cn_finish_fn volatile f = v->finish;
        for (long i = 0; i < calls; i++)
            f(b_acc, c->n, c->am, c->s, c->t, b_bq, b_y, c->relu);
    }
}

/* The latents of a dot case in the layout of v's sums, before v's calls are timed. */
static void layout_for(const cn_dot_variant *v, const bench_case *c)
{
    if (c->op == OP_DOT)
        pack(c->rows, c->pairs, v->layout);
    else if (c->op == OP_DOT8)
        pack8(c->rows, c->pairs, v->layout8);
}

/* The median nanoseconds per call of each set of v[0..nv) (v[0]: the C) on c: the calls a
 * run makes are doubled on the C until a run lasts BENCH_MIN_NS; then the sets take turns,
 * BENCH_RUNS runs each. */
static void bench_one(const cn_dot_variant *v, uint32_t nv, const bench_case *c, double *ns)
{
    for (uint32_t k = 0; k < nv; k++)
        layout_for(&v[k], c), run(&v[k], c, 1); /* warm */
    long calls = 1;
    layout_for(&v[0], c);
    for (;;) {
        const uint64_t t0 = now_ns();
        run(&v[0], c, calls);
        if (now_ns() - t0 >= BENCH_MIN_NS || calls >= BENCH_MAX_CALLS)
            break;
        calls *= 2;
    }
    static uint64_t t[CN_DOT_MAX_VARIANTS + 1][BENCH_RUNS];
    for (int r = 0; r < BENCH_RUNS; r++)
        for (uint32_t k = 0; k < nv; k++) {
            layout_for(&v[k], c);
            const uint64_t t0 = now_ns();
            run(&v[k], c, calls);
            t[k][r] = now_ns() - t0;
        }
    for (uint32_t k = 0; k < nv; k++) {
        for (int i = 1; i < BENCH_RUNS; i++) /* insertion sort: 15 values */
            for (int j = i; j > 0 && t[k][j - 1] > t[k][j]; j--) {
                const uint64_t x = t[k][j];
                t[k][j] = t[k][j - 1];
                t[k][j - 1] = x;
            }
        ns[k] = (double)t[k][BENCH_RUNS / 2] / (double)calls;
    }
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The median, least and largest speed-up of set k over the C among `count` shapes. */
static void summary(const char *op, const char *name, double *ratio, uint32_t count)
{
    qsort(ratio, count, sizeof *ratio, cmp_double);
    printf("%s %s: median speed-up over c %.2fx on %u shapes (least %.2fx, most %.2fx)\n", op,
           name, ratio[count / 2], count, ratio[0], ratio[count - 1]);
}

#define N_PAIRS 17 /* the checks' input pairs: 1 to 9, then 16 to 65 by 7 */
static const uint32_t bench_n[] = {1, 2, 3, 7, 8, 9, 15, 16, 17, 31, 32, 33, 63, 64, 65, 96, 97};
#define N_BENCH_N (sizeof bench_n / sizeof bench_n[0])

static void bench(const cn_dot_variant *v, uint32_t nv)
{
    printf("bench: nanoseconds per call, the median of %d runs of at least %u us each; "
           "timings are not checked\n", BENCH_RUNS, BENCH_MIN_NS / 1000u);
    /* dot_s16 on every shape the checks use: rows 1 to 13, the pairs of N_PAIRS */
    static double dot_ns[MAX_ROWS][N_PAIRS][CN_DOT_MAX_VARIANTS];
    uint32_t pairs_at[N_PAIRS], np = 0;
    for (uint32_t pairs = 1; pairs <= MAX_PAIRS; pairs += pairs < 9 ? 1 : 7)
        pairs_at[np++] = pairs;
    for (uint32_t rows = 1; rows <= MAX_ROWS; rows++)
        for (uint32_t p = 0; p < np; p++) {
            fill(rows, pairs_at[p], 0);
            bench_case c = {OP_DOT, rows, pairs_at[p], 0, 0, 0, 0, 0};
            bench_one(v, nv, &c, dot_ns[rows - 1][p]);
        }
    for (uint32_t k = 0; k < nv; k++) {
        printf("\ndot_s16 %s: %s; rows down, input pairs across\nrows", v[k].name,
               k ? "speed-up over c" : "ns per call");
        for (uint32_t p = 0; p < np; p++)
            printf(" %6u", pairs_at[p]);
        printf("\n");
        for (uint32_t rows = 1; rows <= MAX_ROWS; rows++) {
            printf("%4u", rows);
            for (uint32_t p = 0; p < np; p++) {
                const double *t = dot_ns[rows - 1][p];
                printf(k ? " %5.2fx" : " %6.1f", k ? t[0] / t[k] : t[0]);
            }
            printf("\n");
        }
    }
    printf("\n");
    /* The costs cnerf_open weighs (cn_dot_variant): packed sums per multiply-accumulate and
     * lists per non-zero latent and per row, from 12 rows of 128 inputs, whole and with
     * every 8th latent kept. */
    {
        static double pk[CN_DOT_MAX_VARIANTS], pk8[CN_DOT_MAX_VARIANTS],
            whole[CN_DOT_MAX_VARIANTS], eighth[CN_DOT_MAX_VARIANTS];
        fill(12, 64, 0);
        for (uint32_t j = 0; j < 12; j++)
            for (uint32_t i = 0; i < 128; i++)
                rowmajor[j][i] = (int16_t)(rowmajor[j][i] ? rowmajor[j][i] : 1);
        bench_case c = {OP_DOT, 12, 64, 0, 0, 0, 0, 0};
        bench_one(v, nv, &c, pk);
        c.op = OP_DOT8; /* the same rows as int8 (they are within its range) */
        bench_one(v, nv, &c, pk8);
        const double nz_whole = make_lists(12, 64);
        c.op = OP_SPDOT;
        bench_one(v, nv, &c, whole);
        for (uint32_t j = 0; j < 12; j++)
            for (uint32_t i = 0; i < 128; i++)
                rowmajor[j][i] = (int16_t)(i % 8 ? 0 : rowmajor[j][i]);
        const double nz_eighth = make_lists(12, 64);
        bench_one(v, nv, &c, eighth);
        for (uint32_t k = 0; k < nv; k++) {
            const double per_nz = (whole[k] - eighth[k]) / (nz_whole - nz_eighth);
            const double per_row = (eighth[k] - per_nz * nz_eighth) / 12;
            const double per_mac = pk[k] / (12 * 128);
            const double per_mac8 = pk8[k] / (12 * 128);
            printf("costs %s: %.3f ns per multiply-accumulate packed, %.3f ns per non-zero "
                   "latent and %.2f ns per row in lists, %.3f ns per multiply-accumulate over "
                   "int8 latents; in sixteenths of the first: 16, %.0f, %.0f, %.0f (kernels.c: "
                   "%u, %u, %u, %u)\n",
                   v[k].name, per_mac, per_nz, per_row, per_mac8, 16 * per_nz / per_mac,
                   16 * per_row / per_mac, 16 * per_mac8 / per_mac, v[k].mac_cost,
                   v[k].nz_cost, v[k].row_cost, v[k].mac8_cost);
        }
    }
    static double ratio[MAX_ROWS * N_PAIRS];
    for (uint32_t k = 1; k < nv; k++) {
        uint32_t count = 0;
        for (uint32_t rows = 1; rows <= MAX_ROWS; rows++)
            for (uint32_t p = 0; p < np; p++)
                ratio[count++] = dot_ns[rows - 1][p][0] / dot_ns[rows - 1][p][k];
        summary("dot_s16", v[k].name, ratio, count);
    }
    /* requant_s16 and finish_s32 on the checks' range of n, for the sets that have them */
    for (int op = OP_REQUANT; op <= OP_FINISH; op++) {
        cn_dot_variant w[CN_DOT_MAX_VARIANTS + 1];
        uint32_t nw = 0;
        w[nw].name = "c";
        w[nw].fn = cn_dot_s16_c;
        w[nw].requant = requant_c;
        w[nw++].finish = finish_c;
        for (uint32_t k = 0; k < nv; k++)
            if (op == OP_REQUANT ? v[k].requant != NULL : v[k].finish != NULL)
                w[nw++] = v[k];
        if (nw == 1) {
            printf("%s: no kernel but the c here\n", op_name[op]);
            continue;
        }
        static double ns[N_BENCH_N][CN_DOT_MAX_VARIANTS + 1];
        for (uint32_t i = 0; i < N_BENCH_N; i++) {
            const uint32_t n = bench_n[i];
            bench_case c = {op, 0, 0, n, 8, 0, 0, 1};
            if (op == OP_REQUANT) {
                for (uint32_t j = 0; j < n; j++)
                    b_x[j] = rnd_shifted();
            } else { /* a_m and sums within cnerf_open's bound for the fast rescale */
                c.s = 20;
                c.am = 3000000;
                c.t = rnd_i32() >> 8;
                const uint64_t lim = (((uint64_t)1 << (30 + c.s)) - 1u) / ((uint64_t)c.am + 1u);
                for (uint32_t j = 0; j < n; j++) {
                    b_acc[j] = rnd_signed(lim + 1u);
                    b_bq[j] = rnd_i32() >> 8;
                }
            }
            bench_one(w, nw, &c, ns[i]);
        }
        printf("\n%s: ns per call (speed-up over c)\n%5s", op_name[op], "n");
        for (uint32_t k = 0; k < nw; k++)
            printf(" %16s", w[k].name);
        printf("\n");
        for (uint32_t i = 0; i < N_BENCH_N; i++) {
            printf("%5u %16.1f", bench_n[i], ns[i][0]);
            for (uint32_t k = 1; k < nw; k++)
                printf(" %8.1f (%5.2fx)", ns[i][k], ns[i][0] / ns[i][k]);
            printf("\n");
        }
        for (uint32_t k = 1; k < nw; k++) {
            for (uint32_t i = 0; i < N_BENCH_N; i++)
                ratio[i] = ns[i][0] / ns[i][k];
            summary(op_name[op], w[k].name, ratio, (uint32_t)N_BENCH_N);
        }
    }
}

#endif /* the bench */

#if defined(CK_FIRMWARE)
int main(void)
{
    const int do_bench = 0;
    const long iters = 1;
#else
int main(int argc, char **argv)
{
    int do_bench = 0;
    if (argc > 1 && strcmp(argv[1], "--bench") == 0) {
        do_bench = 1;
        argc--;
        argv++;
    }
    const long iters = argc > 1 ? atol(argv[1]) : 3;
#endif
    cn_dot_variant v[CN_DOT_MAX_VARIANTS];
    const uint32_t nv = cn_dot_variants(v);
    printf("kernels:");
    for (uint32_t i = 0; i < nv; i++)
        printf(" %s", v[i].name);
    printf(" (chosen: %s)%s\n", v[nv - 1].name,
           v[nv - 1].mac8_cost > v[nv - 1].mac_cost ? ", whose int8 sums cost more" : "");
    int32_t want[MAX_ROWS], got[MAX_ROWS];
    int64_t want64[MAX_ROWS];
    for (long it = 0; it < iters; it++)
        for (int mode = 0; mode < 4; mode++)
            for (uint32_t rows = 1; rows <= MAX_ROWS; rows++)
                for (uint32_t pairs = 1; pairs <= MAX_PAIRS; pairs += pairs < 9 ? 1 : 7) {
                    fill(rows, pairs, mode);
                    pack(rows, pairs, CN_PAIRS);
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
                    check(same64(want64, want, rows), "int64 sums", "c", rows, pairs);
                    for (uint32_t k = 0; k < nv; k++) {
                        for (uint32_t j = 0; j < rows; j++)
                            got[j] = 0x5A5A5A5A;
                        pack(rows, pairs, v[k].layout);
                        v[k].fn(kbuf, xq, pairs, rows, got);
                        check(same32(got, want, rows), "int32 sums", v[k].name, rows, pairs);
                    }
                    if (mode == 0 || mode == 3) { /* int8 latents */
                        pack8(rows, pairs, CN_PAIRS);
                        cn_dot_s8_s64_c(kbuf8, xq, pairs, rows, want64);
                        check(same64(want64, want, rows), "int64 sums, int8 latents", "c", rows,
                              pairs);
                        for (uint32_t k = 0; k < nv; k++) {
                            for (uint32_t j = 0; j < rows; j++)
                                got[j] = 0x5A5A5A5A;
                            pack8(rows, pairs, v[k].layout8);
                            v[k].fn8(kbuf8, xq, pairs, rows, got);
                            check(same32(got, want, rows), "int32 sums, int8 latents", v[k].name,
                                  rows, pairs);
                        }
                    }
                    const uint32_t nz = make_lists(rows, pairs);
                    for (uint32_t k = 0; k < nv; k++) {
                        for (uint32_t j = 0; j < rows; j++)
                            got[j] = 0x5A5A5A5A;
                        ok = v[k].spdot(lists, xq, rows, got) == nz;
                        check(ok && same32(got, want, rows), "int32 sums of the non-zero latents", v[k].name, rows, pairs);
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
#if !defined(CK_FIRMWARE)
    if (do_bench) {
        if (fails)
            printf("bench: not run, a check failed\n");
        else
            bench(v, nv);
    }
#else
    (void)do_bench;
#endif
    printf("%d passed, %d failed\n", passes, fails);
    return fails != 0;
}
