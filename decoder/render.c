/*
 * Fixed-point tile renderer: the rules of docs/rendering.md in integers only. Formats
 * (docs/fixed-point.md):
 *   Q32  int64  positions, ray parameters t, unit view directions
 *   Q28  int32  ray directions (|component| < 8)
 *   Q16  int32  network activations, PE values, densities, optical depths (int64 sums)
 *   int16        a layer's inputs at its scale f_in: sat16(round(x 2^f_in)); int32 sums
 *   Q30  uint32 transmittance and weights, table values
 *   turns uint32 encoding phases: 2^32 = one period of sin / cos
 * One ray at a time, one sample at a time; all state lives in the caller's scratch.
 */
#include "../common/cn_fixed.h"
#include "cn_internal.h"
#include "cn_kernels.h"
#include "cn_tables.h"

#define Q30_ONE ((int64_t)1 << 30)
#define INV_2PI_Q32 683565276u  /* round(2^32 / (2 pi)) */
#define LOG2E_Q30 1549082005    /* round(log2(e) 2^30) */
#define PDF_EPS_Q30 10737u      /* round(1e-5 2^30): the fine pdf's floor (CN_PDF_EPS) */
#define MAX_UV_Q28 ((int64_t)2 << 28) /* |u|, |v| <= 2 at the image corners */
#define MAX_POS_Q32 ((int64_t)1 << 47) /* camera centre within +-2^15 world units */
#define MAX_DEPTH_Q16 ((int64_t)32 << 16) /* optical depth beyond which T is 0 in Q30 */
#define CN_BLOCK 8u /* pixels a side of the blocks tested whole for the background */

/* ---- tables ---- */

/* sin(2 pi p / 2^32) in Q16, from the quarter-wave table with linear interpolation. */
static int32_t sin_turns(uint32_t p)
{
    const int32_t q16 = (int32_t)((cn_sin_mag_q30(p) + (1u << 13)) >> 14);
    return p >> 31 ? -q16 : q16;
}

/* e^(-x) in Q30 for an optical depth x >= 0 in Q16; non-increasing in x, exactly 2^30 at 0. */
static uint32_t exp_neg(int64_t x)
{
    if (x >= MAX_DEPTH_Q16)
        return 0;
    const uint64_t y = ((uint64_t)x * LOG2E_Q30 + (1u << 29)) >> 30; /* x log2 e, Q16 */
    const uint32_t n = (uint32_t)(y >> 16), f = (uint32_t)(y & 0xFFFFu);
    const uint32_t i = f >> 8, fr = f & 0xFFu;
    const uint32_t a = cn_exp2_q30[i], b = cn_exp2_q30[i + 1];
    const uint32_t v = a - (uint32_t)(((uint64_t)(a - b) * fr + 128u) >> 8);
    if (n == 0)
        return v;
    return n >= 31 ? 0 : (uint32_t)(((uint64_t)v + ((uint64_t)1 << (n - 1))) >> n);
}

/* sigmoid(z) in Q16 for z in Q16. */
static int32_t sigmoid_q16(int32_t z)
{
    const uint32_t a = z < 0 ? 0u - (uint32_t)z : (uint32_t)z;
    uint32_t v;
    if (a >= (CN_SIGMOID_STEPS << 11)) {
        v = cn_sigmoid_q30[CN_SIGMOID_STEPS];
    } else {
        const uint32_t i = a >> 11, f = a & 0x7FFu;
        v = cn_sigmoid_q30[i] +
            (uint32_t)(((uint64_t)(cn_sigmoid_q30[i + 1] - cn_sigmoid_q30[i]) * f + 1024u) >> 11);
    }
    if (z < 0)
        v = (1u << 30) - v;
    return (int32_t)((v + (1u << 13)) >> 14);
}

/* ---- positional encoding ---- */

/* Phase of p (Q32 world units) in turns, p / (2 pi) modulo 1, as a 32-bit fraction. */
static uint32_t turns_of(int64_t p)
{
    const int64_t hi = cn_asr64(p, 32); /* |hi| < 2^31 */
    const uint64_t lo = (uint64_t)p & 0xFFFFFFFFu;
    const uint64_t a = (uint64_t)(hi * (int64_t)INV_2PI_Q32); /* modulo 2^64 */
    const uint64_t b = (lo * INV_2PI_Q32 + 0x80000000u) >> 32;
    return (uint32_t)(a + b);
}

static int32_t q32_to_q16(int64_t v)
{
    return (int32_t)cn_clamp64(cn_asr64(v + 0x8000, 16), INT32_MIN, INT32_MAX);
}

/* PE(v) of a 3-vector in Q32 into out (3 inc + 6 L values, Q16). */
static void posenc(int32_t *out, const int64_t v[3], unsigned L, int inc)
{
    uint32_t ph[3];
    unsigned n = 0;
    for (unsigned a = 0; a < 3; a++) {
        ph[a] = turns_of(v[a]);
        if (inc)
            out[n++] = q32_to_q16(v[a]);
    }
    for (unsigned l = 0; l < L; l++) {
        for (unsigned a = 0; a < 3; a++)
            out[n + a] = sin_turns(ph[a] << l);
        for (unsigned a = 0; a < 3; a++)
            out[n + 3 + a] = sin_turns((ph[a] << l) + 0x40000000u);
        n += 6;
    }
}

/* ---- one linear layer: y = a (sum k x) + b (sum x) [+ g (sum s x)] + bias, in Q16 ---- */

/* The layer's output o from its sum acc = sum_i k[o][i] x_q[i] (docs/fixed-point.md):
 * sat32(sat32(round(acc a 2^(16-f)) + t) + bias_q16), rounding half up, then ReLU. */
static int32_t finish(int32_t ya, int32_t t, int32_t bq, int relu)
{
    const int32_t v = cn_qadd32(cn_qadd32(ya, t), bq);
    return relu && v < 0 ? 0 : v;
}

/* The layer's inputs at its scale: xq[i] = sat16(round(x[i] 2^-s)), s = 16 - f_in; returns
 * their sum (|sum| <= 1123 2^15 < 2^26). For s <= 16, x + 2^(s-1) saturated at the int32
 * range and shifted gives the same value: it saturates only when x > 2^31 - 1 - 2^(s-1),
 * where the exact quotient is at least 2^(31-s) - 1/2, so at least 32767 after rounding
 * for s <= 16, as is the saturated one. */
/* The per-layer loops are kept out of line: inlined into linear() they share its registers
 * and reload their pointers from the stack on every element (GCC 12, Cortex-M4). */
#if defined(__GNUC__)
#define CN_NOINLINE __attribute__((noinline))
#else
#define CN_NOINLINE
#endif

CN_NOINLINE static int32_t requant(const int32_t *x, int16_t *xq, uint32_t n, unsigned s)
{
    int32_t sum = 0;
    if (s == 0u || s > 16u) {
        for (uint32_t i = 0; i < n; i++) {
            const int16_t q = cn_requant16(x[i], s);
            xq[i] = q;
            sum += q;
        }
        return sum;
    }
#if defined(CN_HAVE_MVE)
    return cn_requant_s16_mve(x, xq, n, s);
#elif defined(CN_HAVE_DSP)
    return cn_requant_s16_dsp(x, xq, n, s);
#elif defined(CN_HAVE_SIMD128)
    return cn_requant_s16_simd128(x, xq, n, s);
#else
    const int32_t h = (int32_t)1 << (s - 1u);
    for (uint32_t i = 0; i < n; i++) {
        const int32_t v = cn_sat16(cn_asr32(cn_qadd32(x[i], h), s));
        xq[i] = (int16_t)v;
        sum += v;
    }
    return sum;
#endif
}

/* Outputs of the live rows from their int32 sums, in stored row order, for layers whose
 * rescale the parser proved to need no saturation (cn_rescale_fast, written out: u = acc
 * a_m + 2^(n-1), the result is u >> n). One loop per case keeps its values in registers. */
#define CN_FINISH_LOOP(RESCALE, RELU)                                                     \
    for (uint32_t j = 0; j < live; j++) {                                                 \
        const uint64_t u = (uint64_t)((int64_t)acc[j] * am) + half;                       \
        const int32_t v = cn_qadd32(cn_qadd32(RESCALE, t), bq[j]);                        \
        y[j] = RELU && v < 0 ? 0 : v;                                                      \
    }
#define CN_LOW_WORD cn_s32(((uint32_t)u >> n) | ((uint32_t)(u >> 32) << (32u - n)))
#define CN_HIGH_WORD cn_asr32(cn_s32((uint32_t)(u >> 32)), n - 32u)

CN_NOINLINE static void finish_fast(const int32_t *acc, uint32_t live, int32_t am, unsigned n,
                                    int32_t t, const int32_t *bq, int32_t *y, int relu)
{
#if defined(CN_HAVE_MVE)
    if (n < 32u) {
        cn_finish_s32_mve(acc, live, am, n, t, bq, y, relu);
        return;
    }
#elif defined(CN_HAVE_DSP)
    if (n < 32u) {
        cn_finish_s32_dsp(acc, live, am, n, t, bq, y, relu);
        return;
    }
#elif defined(CN_HAVE_SIMD128)
    if (n < 32u) {
        cn_finish_s32_simd128(acc, live, am, n, t, bq, y, relu);
        return;
    }
#endif
    const uint64_t half = (uint64_t)1 << (n - 1u);
    if (n < 32u && relu)
        CN_FINISH_LOOP(CN_LOW_WORD, 1)
    else if (n < 32u)
        CN_FINISH_LOOP(CN_LOW_WORD, 0)
    else if (relu)
        CN_FINISH_LOOP(CN_HIGH_WORD, 1)
    else
        CN_FINISH_LOOP(CN_HIGH_WORD, 0)
}

/* y = layer l of x (Q16, n_in values), through the layer's inputs at its scale and the
 * chosen kernel (packed or sparse, as cnerf_open stored the layer; the same sums): the rows
 * with a non-zero latent (stored first; stored row j is output
 * ds->rows[l][j]) take their sums from the kernel, the others have sum k x = 0 exactly.
 * Outputs go to y in stored row order (y[j]), the next layer's columns being stored in that
 * order too, except for the layers whose outputs leave the network (cn_layer_final), which
 * write y[rows[j]]. The order changes no value: each output is its own exact sum. Returns
 * the multiply-accumulates done. */
static uint32_t linear(const cnerf_decoder *dec, unsigned l, const int32_t *x, int32_t *y,
                       int relu, int16_t *xq, int32_t *acc, cnerf_render_stats *work)
{
    const cn_state *ds = cn_cstate_of(dec);
    const cnerf_layer_info *L = &dec->info.layer[l];
    const uint32_t n_in = L->n_in, n_out = L->n_out, live = ds->n_live[l];
    const uint32_t pairs = ds->n_pairs[l];
    const int e = 16 - L->f_in; /* 0..31 */
#ifdef CN_DOT_DIRECT
    const int32_t sx = requant(x, xq, n_in, (unsigned)e);
#else
    const int32_t sx = ds->requant && e >= 1 && e <= 16 ? ds->requant(x, xq, n_in, (unsigned)e)
                                                         : requant(x, xq, n_in, (unsigned)e);
#endif
    if (n_in & 1u)
        xq[n_in] = 0; /* the pad input of an odd layer */
    const unsigned nb = ds->b_shift[l];
    const int32_t t = nb ? cn_rescale_fast(sx, L->b_m, nb, (uint64_t)1 << (nb - 1u))
                         : cn_sat32(cn_mul_exp_r(sx, L->b_m, L->b_e + e, 1));
    const int final = cn_layer_final(L);
    const int32_t *bq = ds->bias_q16[l];
    const void *k = ds->latent[l];
    const int k8 = cn_layer_s8(ds, L); /* int8 latents, else int16 */
    const unsigned form = ds->form[l];
    if (work) { /* the work done, for cost models: only when the caller asked for it */
        work->layer_values += n_in + n_out;
        if (form == CN_FORM_WIDE || !ds->a_shift[l] || final)
            work->exact_rescales += live;
        if (ds->shift[l])
            work->exact_rescales += live;
        if (form == CN_FORM_SPARSE)
            work->list_macs += live * n_in;
        if (form == CN_FORM_WIDE)
            work->wide_macs += live * n_in;
        if (form == CN_FORM_PACKED && k8)
            work->s8_macs += live * n_in;
        if (ds->shift[l] && ds->shift_wide[l])
            work->wide_macs += live * n_in;
    }
    if (form == CN_FORM_WIDE) {
        /* sums that may leave int32: four rows at a time in int64 (the same values) */
        for (uint32_t j = 0; j < live; j += 4u) {
            const uint32_t rb = live - j < 4u ? live - j : 4u;
            int64_t a64[4]; /* a full block of four, or the last rows (the same layout) */
            if (k8)
                cn_dot_s8_s64_c((const int8_t *)k + (size_t)j * 2u * pairs, xq, pairs, rb, a64);
            else
                cn_dot_s16_s64_c((const int16_t *)k + (size_t)j * 2u * pairs, xq, pairs, rb,
                                 a64);
            for (uint32_t q = 0; q < rb; q++)
                y[j + q] = cn_sat32(cn_mul_exp_r(a64[q], L->a_m, L->a_e + e, 1));
        }
    } else if (live) {
        if (form == CN_FORM_SPARSE) {
#ifdef CN_SPDOT_DIRECT
            const uint32_t nz = CN_SPDOT_DIRECT((const uint32_t *)k, xq, live, acc);
#else
            const uint32_t nz = ds->spdot((const uint32_t *)k, xq, live, acc);
#endif
            if (work)
                work->list_nz += nz;
        } else if (k8)
#ifdef CN_DOT8_DIRECT
            CN_DOT8_DIRECT((const int8_t *)k, xq, pairs, live, acc);
#else
            ds->dot8((const int8_t *)k, xq, pairs, live, acc);
#endif
        else
#ifdef CN_DOT_DIRECT
            CN_DOT_DIRECT((const int16_t *)k, xq, pairs, live, acc);
#else
            ds->dot((const int16_t *)k, xq, pairs, live, acc);
#endif
        if (ds->a_shift[l] && !final) {
#ifndef CN_DOT_DIRECT
            if (ds->finish && ds->a_shift[l] < 32u)
                ds->finish(acc, live, L->a_m, ds->a_shift[l], t, bq, y, relu);
            else
#endif
                finish_fast(acc, live, L->a_m, ds->a_shift[l], t, bq, y, relu);
        } else {
            for (uint32_t j = 0; j < live; j++)
                y[j] = cn_sat32(cn_mul_exp_r(acc[j], L->a_m, L->a_e + e, 1));
        }
    }
    const int16_t *sh = ds->shift[l];
    if (sh && live) {
        /* The shared shift's term G_j = sat32(round(g (sum s x_q) 2^(16-f))), added to A_j
         * (a_shift is 0 for such layers, so y[j] holds A_j). */
        const cnerf_shift_info *S = &dec->info.shift[l];
        if (ds->shift_wide[l]) {
            for (uint32_t j = 0; j < live; j += 4u) {
                const uint32_t rb = live - j < 4u ? live - j : 4u;
                int64_t a64[4];
                cn_dot_s16_s64_c(sh + (size_t)j * 2u * pairs, xq, pairs, rb, a64);
                for (uint32_t q = 0; q < rb; q++)
                    y[j + q] = cn_qadd32(y[j + q],
                                         cn_sat32(cn_mul_exp_r(a64[q], S->g_m, S->g_e + e, 1)));
            }
        } else {
#ifdef CN_DOT_DIRECT
            CN_DOT_DIRECT(sh, xq, pairs, live, acc);
#else
            ds->dot(sh, xq, pairs, live, acc);
#endif
            for (uint32_t j = 0; j < live; j++)
                y[j] = cn_qadd32(y[j], cn_sat32(cn_mul_exp_r(acc[j], S->g_m, S->g_e + e, 1)));
        }
    }
    if (form == CN_FORM_WIDE || !ds->a_shift[l] || final) /* y[j] holds A_j (+ G_j) */
        for (uint32_t j = 0; j < live; j++)
            y[j] = finish(y[j], t, bq[j], relu);
    for (uint32_t j = live; j < n_out; j++)
        y[j] = finish(0, t, bq[j], relu);
    if (final) {
        /* at most four outputs: from stored row order to output order */
        int32_t v[4];
        const uint16_t *rows = ds->rows[l];
        for (uint32_t j = 0; j < n_out; j++)
            v[j] = y[j];
        for (uint32_t j = 0; j < n_out; j++)
            y[rows[j]] = v[j];
    }
    /* the multiply-accumulates done: live <= 2^11, n_in <= 2^11 */
    return live * n_in * (sh ? 2u : 1u);
}

/* ---- scratch layout ---- */

typedef struct scratch {
    int64_t *t_c, *t_f, *t_all; /* coarse, fine and merged sample positions */
    uint32_t *w_c;              /* coarse weights */
    int32_t *buf[2];            /* [PE(x) | h] for the trunk, alternating */
    int32_t *view_in, *view_h;  /* [feature | PE(d)], view hidden */
    int32_t *vpe;               /* the ray's encoded view direction */
    int16_t *xq;                /* a layer's inputs at its scale, padded to pairs */
    int32_t *acc;               /* a layer's sums, one per live row */
    uint8_t *maybe;             /* the coarse bins that may hold a density */
    uint16_t *bin_f, *bin_all;  /* the bins of the fine and of the merged samples */
    uint16_t *prior;            /* a block's marked bins before each bin (mark_bins) */
} scratch;

static uint32_t max_width(const cnerf_info *I, int view)
{
    uint32_t m = 1;
    for (unsigned n = 0; n < I->n_nets; n++) {
        const uint32_t v = view ? I->net[n].view_width : I->net[n].width;
        m = v > m ? v : m;
    }
    return m;
}

static size_t round8(size_t n) { return (n + 7u) & ~(size_t)7u; }

/* The widest layer input (padded to a pair) and output over the stream's layers. */
static void layer_extent(const cnerf_info *I, size_t *in, size_t *out)
{
    *in = 2;
    *out = 4;
    for (uint32_t l = 0; l < I->n_layers && l < CNERF_MAX_LAYERS; l++) {
        const size_t n = ((size_t)I->layer[l].n_in + 1u) & ~(size_t)1u;
        *in = n > *in ? n : *in;
        *out = I->layer[l].n_out > *out ? I->layer[l].n_out : *out;
    }
}

/* Carves the scratch; returns the bytes used (NULL base: only counts). */
static size_t carve(const cnerf_info *I, uint8_t *base, scratch *s)
{
    const size_t nc = I->n_coarse, nf = I->n_fine, W = max_width(I, 0), V = max_width(I, 1);
    size_t xin, yout;
    layer_extent(I, &xin, &yout);
    const size_t sizes[14] = {8 * nc, 8 * (nf ? nf : 1), 8 * (nc + nf), 4 * nc,
                              4 * (I->in_pos + W), 4 * (I->in_pos + W), 4 * (W + I->in_dir),
                              4 * V + 4 * (size_t)I->in_dir, 2 * xin, 4 * yout,
                              nc, 2 * (nf ? nf : 1), 2 * (nc + nf), 2 * (nc + 1)};
    void *p[14];
    size_t off = 0;
    for (unsigned i = 0; i < 14; i++) {
        p[i] = base ? base + off : (void *)0;
        off += round8(sizes[i]);
    }
    if (s) {
        s->t_c = (int64_t *)p[0];
        s->t_f = (int64_t *)p[1];
        s->t_all = (int64_t *)p[2];
        s->w_c = (uint32_t *)p[3];
        s->buf[0] = (int32_t *)p[4];
        s->buf[1] = (int32_t *)p[5];
        s->view_in = (int32_t *)p[6];
        s->view_h = (int32_t *)p[7];
        s->vpe = s->view_h + V;
        s->xq = (int16_t *)p[8];
        s->acc = (int32_t *)p[9];
        s->maybe = (uint8_t *)p[10];
        s->bin_f = (uint16_t *)p[11];
        s->bin_all = (uint16_t *)p[12];
        s->prior = (uint16_t *)p[13];
    }
    return off;
}

size_t cnerf_render_scratch_size(const cnerf_info *info)
{
    return info ? carve(info, (uint8_t *)0, (scratch *)0) : 0;
}

void cnerf_render_defaults(const cnerf_info *info, cnerf_render_opts *opts)
{
    if (!opts)
        return;
    opts->n_coarse = info ? info->n_coarse : 0;
    opts->n_fine = info ? info->n_fine : 0;
    opts->t_stop = CNERF_T_STOP_DEFAULT;
    opts->flags = 0;
}

int cnerf_net_has_color(const cnerf_info *info, unsigned net)
{
    if (!info || net >= info->n_nets || info->net[net].view_width == 0)
        return 1;
    const unsigned l = info->net[net].first_layer + info->net[net].depth + 3u; /* rgb */
    const cnerf_layer_info *L = &info->layer[l];
    const cnerf_shift_info *S = &info->shift[l];
    const int zero_kernel = L->kmin == L->kmax && (L->a_m == 0 || L->kmin == 0) && L->b_m == 0;
    const int no_shift = S->smin == S->smax && (S->g_m == 0 || S->smin == 0);
    return !(zero_kernel && no_shift && L->bias_bits == 0);
}

/* ---- one network at one point: raw (r, g, b, sigma) in Q16 ---- */

/* The trunk and the density: raw[3], and with no view branch raw[0..2] as well (one layer
 * gives all four). Adds the multiply-accumulates to *macs, and the rest of the work to *work
 * when it is not NULL (the caller asked for the work done). */
static void net_sigma(const cnerf_decoder *dec, unsigned net, const scratch *s, int32_t raw[4],
                      uint64_t *macs, cnerf_render_stats *work)
{
    const cnerf_info *I = &dec->info;
    const cnerf_net_info *N = &I->net[net];
    const uint32_t P = I->in_pos;
    uint32_t m = 0; /* < 2^3 2^22 */
    /* buf[0] and buf[1] both start with PE(x) (the caller wrote it into both). */
    for (unsigned i = 0; i < N->depth; i++) {
        const int32_t *in = s->buf[i & 1u];
        const int skip_in = i == 0 || (N->skip != CNERF_NO_SKIP && i == N->skip + 1u);
        m += linear(dec, N->first_layer + i, skip_in ? in : in + P, s->buf[(i + 1u) & 1u] + P, 1,
                    s->xq, s->acc, work);
    }
    const int32_t *h = s->buf[N->depth & 1u] + P;
    const unsigned l = N->first_layer + N->depth;
    m += linear(dec, l, h, N->view_width ? raw + 3 : raw, 0, s->xq, s->acc, work);
    *macs += m;
}

/* The colour raw[0..2] of a network with a view branch, after net_sigma at the same point
 * (whose trunk output it reads). The caller wrote the ray's PE(d) after the feature. */
static void net_color(const cnerf_decoder *dec, unsigned net, const scratch *s, int32_t raw[4],
                      uint64_t *macs, cnerf_render_stats *work)
{
    const cnerf_net_info *N = &dec->info.net[net];
    const int32_t *h = s->buf[N->depth & 1u] + dec->info.in_pos;
    const unsigned l = N->first_layer + N->depth;
    uint32_t m = linear(dec, l + 1, h, s->view_in, 0, s->xq, s->acc, work);
    m += linear(dec, l + 2, s->view_in, s->view_h, 1, s->xq, s->acc, work);
    m += linear(dec, l + 3, s->view_h, raw, 0, s->xq, s->acc, work);
    *macs += m;
}

/* ---- rays ---- */

typedef struct ray {
    int64_t o[3];   /* origin, Q32 */
    int32_t d[3];   /* direction, Q28 */
    int64_t d0[3];  /* the camera's direction (before NDC), Q28 */
    int64_t vd[3];  /* unit view direction, Q32 (ray_finish) */
    int32_t dn;     /* |d| in Q27 (ray_finish) */
} ray;

/* |v| of a Q28 vector in Q28 (< 2^32). */
static uint32_t norm_q28(const int64_t v[3])
{
    uint64_t s = 0;
    for (unsigned a = 0; a < 3; a++)
        s += (uint64_t)(v[a] * v[a]); /* |v_a| < 2^31: each < 2^62, the sum < 2^64 */
    return cn_isqrt64(s);
}

/* Axis a of the camera's direction through image-plane point (u, v) (Q28), |d_a| <= 5 2^28:
 * the rounding of a function affine in u and v. */
static int64_t cam_dir(const cnerf_camera *c, unsigned a, int64_t u, int64_t v)
{
    const int64_t acc = (int64_t)c->rot[3 * a] * u + (int64_t)c->rot[3 * a + 1] * v -
                        (int64_t)c->rot[3 * a + 2] * ((int64_t)1 << 28);
    return cn_asr64(acc + ((int64_t)1 << 29), 30);
}

/* The ray through the pixel whose image-plane coordinates are u, v (Q28: (x + 1/2 - cx) /
 * fx and -(y + 1/2 - cy) / fy, rounded half away from zero); 0 when it cannot be
 * represented (then the pixel shows the background: a zero direction, NDC rays parallel to
 * the image plane or leaving the Q28 range). The unit view direction and |d| come after,
 * from ray_finish, for the rays that meet the scene. */
static int make_ray(const cnerf_info *I, const cnerf_camera *c, int64_t sx_q28, int64_t sy_q28,
                    int64_t u, int64_t v, ray *r)
{
    int64_t d[3];
    for (unsigned a = 0; a < 3; a++) {
        d[a] = cam_dir(c, a, u, v);
        r->o[a] = c->pos[a];
        r->d0[a] = d[a];
    }
    if (d[0] == 0 && d[1] == 0 && d[2] == 0)
        return 0; /* |d| = 0 */
    if (I->coord == CNERF_COORD_NDC) {
        /* Move to the near plane z = -1, then warp (docs/rendering.md). */
        if (d[2] == 0)
            return 0;
        const int64_t tn = cn_sdiv_frac(-((int64_t)1 << 32) - r->o[2], d[2], 28); /* Q32 */
        int64_t o[3];
        for (unsigned a = 0; a < 3; a++)
            o[a] = r->o[a] + cn_mul_exp(tn, (int32_t)d[a], -28);
        if (o[2] == 0)
            return 0;
        const int64_t rx = cn_sdiv_frac(o[0], o[2], 32), ry = cn_sdiv_frac(o[1], o[2], 32);
        const int64_t dx = cn_sdiv_frac(d[0], d[2], 32), dy = cn_sdiv_frac(d[1], d[2], 32);
        const int32_t sx = (int32_t)sx_q28, sy = (int32_t)sy_q28;
        r->o[0] = -cn_mul_exp(rx, sx, -28);
        r->o[1] = -cn_mul_exp(ry, sy, -28);
        r->o[2] = ((int64_t)1 << 32) + cn_sdiv_frac((int64_t)2 << 32, o[2], 32);
        d[0] = -cn_mul_exp(dx - rx, sx, -32);
        d[1] = -cn_mul_exp(dy - ry, sy, -32);
        d[2] = -cn_sdiv_frac((int64_t)2 << 32, o[2], 28);
        for (unsigned a = 0; a < 3; a++)
            if (d[a] <= INT32_MIN || d[a] > INT32_MAX || cn_abs64(r->o[a]) > (uint64_t)MAX_POS_Q32)
                return 0;
    }
    for (unsigned a = 0; a < 3; a++)
        r->d[a] = (int32_t)d[a];
    return 1;
}

/* The unit view direction (from the camera's direction) and |d| of a ray from make_ray. */
static void ray_finish(ray *r)
{
    const uint32_t n = norm_q28(r->d0); /* > 0: make_ray refused a zero direction */
    for (unsigned a = 0; a < 3; a++)
        r->vd[a] = cn_sdiv_frac(r->d0[a], n, 32);
    const int64_t dd[3] = {r->d[0], r->d[1], r->d[2]};
    r->dn = (int32_t)(norm_q28(dd) >> 1);
}

/* u = round((p + 1/2 - c) / f) in Q28 (halves away from zero) for the pixels p = p0, p0 + 1,
 * ... of a row or a column, one addition each: N = (p 2^16 + 2^15 - c) 2^29 is kept as
 * q f + r with 0 <= r < f (f > 0, Q16), and u = sign(N) round(|N| / (2 f)) follows from q
 * and r. |N| < 2^62: the camera's check bounds |u| by 2 over the image. */
typedef struct pixel_coord {
    int64_t q;
    uint64_t r, f, step_q, step_r; /* 2^45 = step_q f + step_r */
} pixel_coord;

/* The step of pixel coordinates with focal length f (Q16, > 0): once per tile. */
static void coord_setup(pixel_coord *pc, int64_t f)
{
    pc->f = (uint64_t)f;
    pc->step_q = cn_udiv_frac(1, pc->f, 45);
    pc->step_r = ((uint64_t)1 << 45) - pc->step_q * pc->f;
}

/* Starts at pixel p0 with principal point c (Q16), after coord_setup. */
static void coord_start(pixel_coord *pc, uint32_t p0, int64_t c)
{
    const int64_t n0 = (int64_t)p0 * 65536 + 32768 - c, n = n0 * ((int64_t)1 << 29);
    const uint64_t qa = cn_udiv_frac(cn_abs64(n0), pc->f, 29), ra = cn_abs64(n) - qa * pc->f;
    /* floor(n / f) and its remainder from |n|'s */
    pc->q = n >= 0 ? (int64_t)qa : -(int64_t)qa - (ra != 0);
    pc->r = n >= 0 || ra == 0 ? ra : pc->f - ra;
}

static int64_t coord_value(const pixel_coord *pc)
{
    /* |N| / f floored: q for N >= 0; for N < 0, -q - 1 when r > 0, else -q */
    if (pc->q >= 0)
        return (pc->q + 1) >> 1;
    const int64_t qa = -pc->q - (pc->r != 0);
    return -((qa + 1) >> 1);
}

/* *d = *s, field by field: a structure assignment may become a memcpy call (Armv6-M). */
static void coord_copy(pixel_coord *d, const pixel_coord *s)
{
    d->q = s->q;
    d->r = s->r;
    d->f = s->f;
    d->step_q = s->step_q;
    d->step_r = s->step_r;
}

static void coord_next(pixel_coord *pc)
{
    pc->q += (int64_t)pc->step_q;
    pc->r += pc->step_r;
    if (pc->r >= pc->f) {
        pc->r -= pc->f;
        pc->q++;
    }
}

/* ---- sampling ---- */

/* Fine samples from the coarse weights (docs/rendering.md): quantile j = (2j + 1) / (2 nf)
 * of the pdf (w_i + eps) / sum, compared in integers as (2j + 1) W >= 2 nf U_i. */
static void sample_fine(int64_t *t, uint16_t *bin, unsigned nf, const uint32_t *w, unsigned nc,
                        int64_t near, int64_t step)
{
    uint64_t total = 0;
    for (unsigned i = 0; i < nc; i++)
        total += (uint64_t)w[i] + PDF_EPS_Q30; /* < 2^31 + 2^24 */
    unsigned i = 0;
    uint64_t below = 0; /* sum over bins before i */
    const uint64_t two_nf = 2u * (uint64_t)nf;
    for (unsigned j = 0; j < nf; j++) {
        const uint64_t target = (2u * (uint64_t)j + 1u) * total; /* < 2^43 */
        while (i + 1 < nc && target >= two_nf * (below + w[i] + PDF_EPS_Q30)) {
            below += (uint64_t)w[i] + PDF_EPS_Q30;
            i++;
        }
        const uint64_t num = target - two_nf * below, den = two_nf * ((uint64_t)w[i] + PDF_EPS_Q30);
        const uint64_t f = num >= den ? (uint64_t)1 << 24 : cn_udiv_frac(num, den, 24);
        t[j] = near + (int64_t)i * step + cn_mul_exp(step, (int32_t)f, -24);
        bin[j] = (uint16_t)i; /* near + i step <= t[j] <= near + (i + 1) step */
    }
}

/* ---- marching one ray through one network ---- */

typedef struct march {
    uint32_t T;       /* transmittance after the last sample, Q30 */
    int64_t rgb[3];   /* sum w c, Q46 */
} march;

/* The occupancy grid's integer cell mapping (docs/bitstream.md, GRID), set up per tile. */
typedef struct gridmap {
    const uint16_t *slot;   /* the grid stored by blocks (cn_state); NULL: no grid, or ignored */
    const uint8_t *rec;
    const uint8_t *summary; /* its summary's levels 3 and up (cn_state.grid_summary) */
    uint32_t g;
    uint32_t n[9], off[9];  /* level k's cells per axis and, k >= 3, its first bit in summary */
    int64_t lo[3], hi[3];   /* box minimum and maximum, Q32 */
    uint64_t r[3];          /* floor(g 2^32 / w), w the box's width in Q16 */
} gridmap;

static void gridmap_init(const cnerf_decoder *dec, int skip, gridmap *gm)
{
    const cn_state *ds = cn_cstate_of(dec);
    const cnerf_info *I = &dec->info;
    gm->slot = skip && I->grid_g ? ds->grid_slot : (const uint16_t *)0;
    gm->rec = ds->grid_rec;
    gm->summary = ds->grid_summary;
    gm->g = I->grid_g;
    gm->n[0] = gm->g;
    gm->off[0] = 0;
    for (unsigned k = 1; k < 9u; k++) { /* g <= 128: level 7 has one cell */
        gm->n[k] = (gm->n[k - 1u] + 1u) >> 1;
        gm->off[k] = k <= 3u ? 0u : gm->off[k - 1u] + gm->n[k - 1u] * gm->n[k - 1u] * gm->n[k - 1u];
    }
    for (unsigned a = 0; a < 3; a++) {
        gm->lo[a] = (int64_t)I->aabb_q16[a] * 65536;
        gm->hi[a] = (int64_t)I->aabb_q16[a + 3] * 65536;
        /* 0 < w < 2^32 by the header checks */
        const uint64_t w = (uint64_t)((int64_t)I->aabb_q16[a + 3] - I->aabb_q16[a]);
        gm->r[a] = gm->slot ? cn_udiv_frac(gm->g, w, 32) : 0u;
    }
}

/* Cell (x, y, z) of the grid's level k: 0 the cells, 1 and 2 in the blocks' records, 3
 * and up in the summary. */
static uint32_t grid_at(const gridmap *gm, unsigned k, uint32_t x, uint32_t y, uint32_t z)
{
    if (k < 3u)
        return cn_grid_block_bit(gm->slot, gm->rec, gm->n[3], k, x, y, z);
    const uint32_t n = gm->n[k];
    return cn_grid_bit(gm->summary, gm->off[k] + (z * n + y) * n + x);
}

/* 1 when p (inside the bounds, Q32) lies in an occupied cell or there is no grid. */
static int occupied(const gridmap *gm, const int64_t p[3])
{
    if (!gm->slot)
        return 1;
    uint32_t c[3];
    for (unsigned a = 0; a < 3; a++)
        c[a] = cn_grid_cell((uint64_t)(p[a] - gm->lo[a]) >> 16, gm->r[a], gm->g);
    return (int)grid_at(gm, 0, c[0], c[1], c[2]);
}

/* ---- ruling out stretches of a ray ---- */

/* 1 when a cell of the box of cells c0..c1 (inclusive, per axis) may be occupied: at the
 * first level of the grid and its summary where the box spans at most two cells per axis,
 * one of those (at most eight) is set. Never 0 for a box holding an occupied cell. */
static int cells_maybe(const gridmap *gm, const uint32_t c0[3], const uint32_t c1[3])
{
    /* the first level k where the box spans at most two cells: from the widest span's bit
     * length less one (at most one level short of it) */
    uint32_t span = (c1[0] - c0[0]) | (c1[1] - c0[1]) | (c1[2] - c0[2]);
    unsigned k = 0;
    while (span > 1u) {
        span >>= 1;
        k++;
    }
    k = k ? k - 1u : 0u;
    while ((c1[0] >> k) - (c0[0] >> k) > 1u || (c1[1] >> k) - (c0[1] >> k) > 1u ||
           (c1[2] >> k) - (c0[2] >> k) > 1u)
        k++; /* at most twice; the last level has one cell */
    for (uint32_t z = c0[2] >> k; z <= c1[2] >> k; z++)
        for (uint32_t y = c0[1] >> k; y <= c1[1] >> k; y++)
            for (uint32_t x = c0[0] >> k; x <= c1[0] >> k; x++)
                if (grid_at(gm, k, x, y, z))
                    return 1;
    return 0;
}

/* A ray's positions at the coarse bins' edges e_i = near + i step, i = 0..nc, as mark_bins
 * bounds them: o + round(e_i d) (what ray_at gives) lies within m of base + i inc on every
 * axis (Q32): base = o + round(near d) and round(e_i d) are each within 1/2 of their exact
 * products, and inc = round(step d) within 1/2 of step d, so the two differ by at most
 * i / 2 + 1 <= nc / 2 + 1. */
typedef struct edges {
    int64_t base[3], inc[3], m;
} edges;

/* 0 when no position p with mn <= p <= mx (Q32, axis by axis) can have a density: outside
 * the bounds on some axis, or in cells the grid has empty (the cell of a position is
 * monotone in it, cn_grid_cell, so those cells lie between the cells of the clipped ends). */
static int box_maybe(const gridmap *gm, const int64_t mn[3], const int64_t mx[3])
{
    uint32_t c0[3], c1[3];
    for (unsigned i = 0; i < 3; i++) {
        if (mx[i] < gm->lo[i] || mn[i] > gm->hi[i])
            return 0;
        if (!gm->slot)
            continue;
        const int64_t a = mn[i] < gm->lo[i] ? gm->lo[i] : mn[i];
        const int64_t b = mx[i] > gm->hi[i] ? gm->hi[i] : mx[i];
        c0[i] = cn_grid_cell((uint64_t)(a - gm->lo[i]) >> 16, gm->r[i], gm->g);
        c1[i] = cn_grid_cell((uint64_t)(b - gm->lo[i]) >> 16, gm->r[i], gm->g);
    }
    return gm->slot ? cells_maybe(gm, c0, c1) : 1;
}

/* 0 when no sample of the bins lo..hi-1 can have a density: its position lies, axis by
 * axis, between the positions at the stretch's two ends. */
static int span_maybe(const gridmap *gm, const edges *E, unsigned lo, unsigned hi)
{
    int64_t mn[3], mx[3];
    for (unsigned i = 0; i < 3; i++) {
        const int64_t a = E->base[i] + (int64_t)lo * E->inc[i];
        const int64_t b = E->base[i] + (int64_t)hi * E->inc[i];
        mn[i] = (a < b ? a : b) - E->m;
        mx[i] = (a < b ? b : a) + E->m;
    }
    return box_maybe(gm, mn, mx);
}

/* The position o + t d (Q32) of ray parameter t (Q32), as the marcher computes it. */
static void ray_at(const ray *r, int64_t t, int64_t p[3])
{
    for (unsigned a = 0; a < 3; a++)
        p[a] = r->o[a] + cn_mul_exp(t, r->d[a], -28);
}

/* What mark_bins rules out stretches of: one ray (its edges), or a block of rays (their
 * origin and the range of each axis of their directions, Q28; block_range). */
typedef struct stretch {
    const edges *E;        /* one ray; NULL: the block */
    const int64_t *o;      /* the block's origin, Q32 */
    int64_t dl[3], dh[3];  /* the block's directions, widened */
    int64_t near, step;
} stretch;

/* The positions of the block's rays at t in [ta, tb] (0 <= ta <= tb) lie within mn..mx:
 * each axis of o + t d is monotone in t (t >= 0) and in d, so its extremes are at the
 * corners. */
static int block_span_maybe(const gridmap *gm, const stretch *S, unsigned lo, unsigned hi)
{
    const int64_t ta = S->near + (int64_t)lo * S->step, tb = S->near + (int64_t)hi * S->step;
    int64_t mn[3], mx[3];
    for (unsigned a = 0; a < 3; a++) {
        const int64_t p[4] = {cn_mul_exp(ta, (int32_t)S->dl[a], -28),
                              cn_mul_exp(ta, (int32_t)S->dh[a], -28),
                              cn_mul_exp(tb, (int32_t)S->dl[a], -28),
                              cn_mul_exp(tb, (int32_t)S->dh[a], -28)};
        int64_t l = p[0], h = p[0];
        for (unsigned i = 1; i < 4; i++) {
            l = p[i] < l ? p[i] : l;
            h = p[i] > h ? p[i] : h;
        }
        mn[a] = S->o[a] + l;
        mx[a] = S->o[a] + h;
    }
    return box_maybe(gm, mn, mx);
}

/* Which of the coarse bins [e_i, e_i+1], e_i = near + i step, i < nc, may hold a sample
 * with a density: maybe[i] = 1, else 0. Every sample of a stretch of bins lies, axis by
 * axis, between the positions its ends bound (span_maybe, block_span_maybe): a stretch
 * ruled out holds no density; the others are halved down to single bins. The coarse sample
 * of bin i and the fine samples drawn in it (sample_fine) lie in it. `prior` (NULL: none)
 * counts, before each bin, the bins a block's marking left: a stretch of none of them is
 * ruled out untested. Not for contracted scenes, whose positions are not affine in t.
 * Returns the bins marked. */
static unsigned mark_bins(const gridmap *gm, const stretch *S, unsigned nc,
                          const uint16_t *prior, uint8_t *maybe)
{
    uint16_t stack[2u * 12u]; /* depth <= log2(CNERF_MAX_SAMPLES) + 1 = 11 */
    unsigned top = 1, marked = 0;
    stack[0] = 0;
    stack[1] = (uint16_t)nc;
    while (top) {
        top--;
        const unsigned lo = stack[2u * top], hi = stack[2u * top + 1u];
        const int none = prior && prior[hi] == prior[lo];
        if (none || !(S->E ? span_maybe(gm, S->E, lo, hi) : block_span_maybe(gm, S, lo, hi))) {
            for (unsigned i = lo; i < hi; i++)
                maybe[i] = 0;
            continue;
        }
        if (hi - lo == 1u) {
            maybe[lo] = 1;
            marked++;
            continue;
        }
        const unsigned mid = (lo + hi) >> 1;
        stack[2u * top] = (uint16_t)mid; /* the far half after the near one */
        stack[2u * top + 1u] = (uint16_t)hi;
        stack[2u * top + 2u] = (uint16_t)lo;
        stack[2u * top + 3u] = (uint16_t)mid;
        top += 2u;
    }
    return marked;
}

/* mark_bins for one ray (edges: its positions at the bins' edges). */
static unsigned mark_ray_bins(const gridmap *gm, const ray *r, int64_t near, int64_t step,
                              unsigned nc, const uint16_t *prior, uint8_t *maybe)
{
    edges E;
    ray_at(r, near, E.base);
    for (unsigned a = 0; a < 3; a++)
        E.inc[a] = cn_mul_exp(step, r->d[a], -28);
    E.m = (int64_t)nc / 2 + 1;
    stretch S;
    S.E = &E;
    return mark_bins(gm, &S, nc, prior, maybe);
}

/* ---- contracted scenes (docs/rendering.md) ---- */

/* The distance of sampling parameter s (Q32): s itself, or in contracted scenes
 * near + s L on [0, 1] and near + L / (2 - s) beyond, L = far - near (Q32, < 2^54). */
static int64_t ray_t(const cnerf_info *I, int64_t s)
{
    if (I->coord != CNERF_COORD_CONTRACT)
        return s;
    const int64_t near = (int64_t)I->near_q16 * 65536;
    const uint64_t L = (uint64_t)((int64_t)I->far_q16 - I->near_q16); /* Q16, < 2^31 */
    if (s <= ((int64_t)1 << 32)) /* L s < 2^63, Q48 */
        return near + (int64_t)((L * (uint64_t)s + ((uint64_t)1 << 15)) >> 16);
    /* 2 - s >= 2^(32 - CNERF_CONTRACT_SHIFT): the quotient is below L 2^22 < 2^53 */
    return near + (int64_t)cn_udiv_frac(L, ((uint64_t)1 << 33) - (uint64_t)s, 48);
}

/* The point p (Q32, |p| < 2^58) as the networks see it: unchanged within the inner cube
 * |p - c|_inf <= h (c the bounds' centre, h a quarter of their width), else
 * c + (p - c) r (2 - r) with r = h / |p - c|_inf, in (0, 1). */
static void contract(const cnerf_info *I, int64_t p[3])
{
    const uint64_t h = (uint64_t)((int64_t)I->aabb_q16[3] - I->aabb_q16[0]) << 14; /* Q32 */
    int64_t c[3], q[3];
    uint64_t m = 0;
    for (unsigned a = 0; a < 3; a++) {
        c[a] = ((int64_t)I->aabb_q16[a] + I->aabb_q16[a + 3]) * 32768;
        q[a] = p[a] - c[a];
        const uint64_t u = cn_abs64(q[a]);
        m = u > m ? u : m;
    }
    if (m <= h)
        return;
    const uint64_t r = cn_udiv_frac(h, m, 31);                  /* Q31, < 2^31 */
    const uint64_t k = (r * (((uint64_t)1 << 32) - r)) >> 31;  /* r (2 - r), Q31, < 2^31 */
    for (unsigned a = 0; a < 3; a++)
        p[a] = c[a] + cn_mul_exp(q[a], (int32_t)k, -31);
}

static int inside(const cnerf_info *I, const int64_t p[3])
{
    for (unsigned a = 0; a < 3; a++)
        if (p[a] < (int64_t)I->aabb_q16[a] * 65536 || p[a] > (int64_t)I->aabb_q16[a + 3] * 65536)
            return 0;
    return 1;
}

/* What a march may skip: the bins mark_bins ruled out, and each sample's bin. */
typedef struct bins {
    const uint8_t *maybe; /* NULL: none ruled out */
    const uint16_t *of;   /* the bin of sample i; NULL: bin i (the coarse samples) */
    int count;            /* count the ruled-out samples inside the bounds in stats->in_bounds */
} bins;

/* Marches one network along the ray. The colour branch runs only for samples that add to the
 * image: with color 0 (the coarse pass before a fine one, whose colour is not shown) never,
 * else only where the weight is positive; either way the image is the same bits. A sample in
 * a bin ruled out has no density, as outside the bounds or in an empty cell. */
static void march_ray(const cnerf_decoder *dec, unsigned net, const scratch *s, const ray *r,
                      const gridmap *gm, const int64_t *t, unsigned n, int64_t far,
                      uint32_t t_stop, int color, uint32_t *w, const bins *b, march *m,
                      cnerf_render_stats *stats)
{
    const cnerf_info *I = &dec->info;
    const int view = I->net[net].view_width != 0;
    int64_t depth = 0; /* optical depth before sample i, Q16, at most MAX_DEPTH_Q16 */
    uint32_t T = 1u << 30;
    /* the work beyond evaluations and MACs, counted when the caller asked for it */
    cnerf_render_stats *const work = b->count ? stats : (cnerf_render_stats *)0;
    m->rgb[0] = m->rgb[1] = m->rgb[2] = 0;
    for (unsigned i = 0; i < n; i++) {
        if (w)
            w[i] = 0;
        if (T < t_stop || T == 0) {
            continue;
        }
        const int ruled_out = b->maybe && !b->maybe[b->of ? b->of[i] : i];
        if (ruled_out && !b->count)
            continue;
        if (work)
            work->samples += !ruled_out;
        int64_t p[3];
        ray_at(r, t[i], p);
        if (I->coord == CNERF_COORD_CONTRACT)
            contract(I, p);
        if (!inside(I, p))
            continue;
        stats->in_bounds++;
        if (ruled_out)
            continue;
        if (!occupied(gm, p))
            continue; /* an empty cell: density 0, like a sample outside the bounds */
        stats->evals++;
        posenc(s->buf[0], p, I->l_pos, I->pe_flags & CNERF_PE_INCLUDE_INPUT);
        for (uint32_t k = 0; k < I->in_pos; k++)
            s->buf[1][k] = s->buf[0][k];
        int32_t raw[4];
        net_sigma(dec, net, s, raw, &stats->macs, work);
        if (raw[3] <= 0)
            continue;
        const int64_t delta = (i + 1 < n ? t[i + 1] : far) - t[i];        /* Q32, >= 0 */
        const int64_t dd = cn_mul_exp(delta, r->dn, -27);                  /* delta |d|, Q32 */
        const int64_t sdep = cn_mul_exp(dd, raw[3], -32);                  /* Q16 */
        depth = depth + sdep > MAX_DEPTH_Q16 ? MAX_DEPTH_Q16 : depth + sdep;
        const uint32_t T1 = exp_neg(depth);
        const uint32_t wi = T - T1;
        T = T1;
        if (w)
            w[i] = wi;
        if (!color || wi == 0)
            continue; /* adds nothing to the pixel */
        if (view) {
            for (uint32_t k = 0; k < I->in_dir; k++)
                s->view_in[I->net[net].width + k] = s->vpe[k];
            net_color(dec, net, s, raw, &stats->macs, work);
        }
        for (unsigned c = 0; c < 3; c++)
            m->rgb[c] += (int64_t)wi * sigmoid_q16(raw[c]);
    }
    m->T = T;
}

/* The directions of a block of pixels whose image-plane coordinates span u0..u1 and v0..v1
 * (Q28; u and v are monotone in the pixel), axis by axis, into S: each axis of a ray's
 * direction is within 1 of the affine function it rounds, whose extremes over the block are
 * at its corners, so it lies within the corners' directions widened by 2. Not for NDC, whose
 * directions are not affine in the pixel. */
static void block_range(const cnerf_camera *c, int64_t u0, int64_t u1, int64_t v0, int64_t v1,
                        stretch *S)
{
    S->E = (const edges *)0;
    S->o = c->pos;
    for (unsigned a = 0; a < 3; a++) {
        const int64_t k[4] = {cam_dir(c, a, u0, v0), cam_dir(c, a, u1, v0),
                              cam_dir(c, a, u0, v1), cam_dir(c, a, u1, v1)};
        int64_t dl = k[0], dh = k[0];
        for (unsigned i = 1; i < 4; i++) {
            dl = k[i] < dl ? k[i] : dl;
            dh = k[i] > dh ? k[i] : dh;
        }
        S->dl[a] = dl - 2; /* |d| <= 5 2^28 + 2: int32 */
        S->dh[a] = dh + 2;
    }
}

/* The samples of one ray through both networks into m (make_ray gave it). */
static void render_ray(const cnerf_decoder *dec, const scratch *s, ray *r, const gridmap *gm,
                       const cnerf_render_opts *o, unsigned nc, unsigned nf, int64_t near,
                       int64_t step, int64_t far, bins *b, march *m, cnerf_render_stats *stats)
{
    const cnerf_info *I = &dec->info;
    const unsigned net = nf ? 1u : 0u;
    ray_finish(r);
    posenc(s->vpe, r->vd, I->l_dir, I->pe_flags & CNERF_PE_INCLUDE_INPUT);
    march_ray(dec, 0, s, r, gm, s->t_c, nc, far, o->t_stop, net == 0, s->w_c, b, m, stats);
    if (net == 0)
        return;
    sample_fine(s->t_f, s->bin_f, nf, s->w_c, nc, near, step);
    if (I->coord == CNERF_COORD_CONTRACT)
        for (unsigned j = 0; j < nf; j++)
            s->t_f[j] = ray_t(I, s->t_f[j]);
    unsigned i = 0, j = 0, k = 0;
    while (i < nc || j < nf) {
        const int coarse = j == nf || (i < nc && s->t_c[i] <= s->t_f[j]);
        s->bin_all[k] = coarse ? (uint16_t)i : s->bin_f[j];
        s->t_all[k++] = coarse ? s->t_c[i++] : s->t_f[j++];
    }
    b->of = s->bin_all;
    march_ray(dec, 1, s, r, gm, s->t_all, nc + nf, far, o->t_stop, 1, (uint32_t *)0, b, m,
              stats);
}

static uint8_t to_u8(int64_t rgb_q46, uint32_t T, uint8_t bg)
{
    const int64_t v = 255 * rgb_q46 + (int64_t)T * bg * 65536; /* Q46 of 255 C */
    const int64_t q = (v + ((int64_t)1 << 45)) >> 46;          /* v >= 0 */
    return (uint8_t)(q > 255 ? 255 : q);
}

/* c in 0..255 rounded to the nearest of the 2^n levels of an n-bit field:
 * (c (2^n - 1) + 127) / 255, the division by 255 as (x + 1 + (x >> 8)) >> 8, exact for
 * x < 65535 (here x <= 16,192). */
static uint32_t to_bits(uint32_t c, uint32_t max)
{
    const uint32_t x = c * max + 127u;
    return (x + 1u + (x >> 8)) >> 8;
}

/* One pixel into out: RGB888 (fmt 0), or RGB565 low byte first (CNERF_RENDER_RGB565) or
 * high byte first (CNERF_RENDER_RGB565_BE). */
static void put_pixel(uint8_t *out, const uint8_t px[3], unsigned fmt)
{
    if (!fmt) {
        out[0] = px[0], out[1] = px[1], out[2] = px[2];
        return;
    }
    const uint32_t v = to_bits(px[0], 31u) << 11 | to_bits(px[1], 63u) << 5 | to_bits(px[2], 31u);
    const unsigned hi = fmt == CNERF_RENDER_RGB565_BE ? 0u : 1u;
    out[hi] = (uint8_t)(v >> 8);
    out[1u - hi] = (uint8_t)v;
}

static cnerf_status check_camera(const cnerf_info *I, const cnerf_camera *c)
{
    if (c->fx <= 0 || c->fy <= 0 || c->width == 0 || c->height == 0)
        return CNERF_E_ARG;
    if (I->coord == CNERF_COORD_NDC && (c->cx <= 0 || c->cy <= 0))
        return CNERF_E_ARG;
    for (unsigned i = 0; i < 9; i++)
        if (c->rot[i] < -(1 << 30) || c->rot[i] > (1 << 30))
            return CNERF_E_ARG;
    for (unsigned a = 0; a < 3; a++)
        if (cn_abs64(c->pos[a]) > (uint64_t)MAX_POS_Q32)
            return CNERF_E_ARG;
    /* u, v are affine in the pixel: their extremes are at the image corners. */
    const int64_t xs[2] = {32768 - (int64_t)c->cx, (int64_t)c->width * 65536 - 32768 - c->cx};
    const int64_t ys[2] = {32768 - (int64_t)c->cy, (int64_t)c->height * 65536 - 32768 - c->cy};
    for (unsigned i = 0; i < 2; i++)
        if (cn_abs64(cn_sdiv_frac(xs[i], c->fx, 28)) > (uint64_t)MAX_UV_Q28 ||
            cn_abs64(cn_sdiv_frac(ys[i], c->fy, 28)) > (uint64_t)MAX_UV_Q28)
            return CNERF_E_ARG;
    return CNERF_OK;
}

cnerf_status cnerf_render_tile(const cnerf_decoder *dec, const cnerf_camera *cam,
                               const cnerf_render_opts *opts, uint32_t x0, uint32_t y0,
                               uint32_t w, uint32_t h, uint8_t *rgb, size_t stride,
                               void *scratch_mem, size_t scratch_size)
{
    return cnerf_render_tile_stats(dec, cam, opts, x0, y0, w, h, rgb, stride, scratch_mem,
                                   scratch_size, (cnerf_render_stats *)0);
}

cnerf_status cnerf_render_tile_stats(const cnerf_decoder *dec, const cnerf_camera *cam,
                                     const cnerf_render_opts *opts, uint32_t x0, uint32_t y0,
                                     uint32_t w, uint32_t h, uint8_t *rgb, size_t stride,
                                     void *scratch_mem, size_t scratch_size,
                                     cnerf_render_stats *stats_out)
{
    if (!dec || !cam || !rgb || !scratch_mem)
        return CNERF_E_NULL;
    const cnerf_info *I = &dec->info;
    const cn_state *ds = cn_cstate_of(dec);
    if (I->n_layers == 0 || !ds->latent[0] || !ds->dot)
        return CNERF_E_ARG; /* not opened */
    if (((uintptr_t)scratch_mem & (CNERF_WS_ALIGN - 1u)) != 0)
        return CNERF_E_WS_ALIGN;
    if (scratch_size < cnerf_render_scratch_size(I))
        return CNERF_E_WS_SMALL;
    cnerf_render_opts o;
    cnerf_render_defaults(I, &o);
    if (opts)
        o = *opts;
    if (o.n_coarse < 1u || o.n_coarse > I->n_coarse || o.n_fine > I->n_fine ||
        (o.flags & ~(CNERF_RENDER_NO_SKIP | CNERF_RENDER_EVERY_SAMPLE | CNERF_RENDER_RGB565 |
                     CNERF_RENDER_RGB565_BE)) ||
        ((o.flags & CNERF_RENDER_RGB565) && (o.flags & CNERF_RENDER_RGB565_BE)))
        return CNERF_E_ARG;
    if (I->n_nets > 1 && o.n_fine == 0 && !cnerf_net_has_color(I, 0))
        return CNERF_E_ARG; /* the coarse network's image, of a stream without its colour */
    if (w == 0 || h == 0 || x0 >= cam->width || y0 >= cam->height || w > cam->width - x0 ||
        h > cam->height - y0)
        return CNERF_E_ARG;
    /* the pixel format: 3 bytes (RGB888), or 2 (RGB565) in either byte order */
    const unsigned fmt = o.flags & (CNERF_RENDER_RGB565 | CNERF_RENDER_RGB565_BE);
    const unsigned bpp = fmt ? 2u : 3u;
    if (stride / bpp < w)
        return CNERF_E_BUF_SMALL;
    cnerf_status st = check_camera(I, cam);
    if (st != CNERF_OK)
        return st;

    scratch s;
    carve(I, (uint8_t *)scratch_mem, &s);
    gridmap gm;
    gridmap_init(dec, !(o.flags & CNERF_RENDER_NO_SKIP), &gm);
    cnerf_render_stats stats; /* field by field: an initializer may become a memset call */
    stats.rays = stats.evals = stats.in_bounds = stats.macs = stats.list_macs = stats.list_nz = 0;
    stats.samples = stats.layer_values = stats.exact_rescales = stats.wide_macs = stats.s8_macs = 0;
    const unsigned nc = o.n_coarse, nf = I->n_nets > 1 ? o.n_fine : 0;
    /* The sampling interval [near, far] in Q32; contracted scenes sample s in
     * [0, 2 - 2^-CNERF_CONTRACT_SHIFT] and march at the distances ray_t(s). */
    const int contracted = I->coord == CNERF_COORD_CONTRACT;
    const int64_t near = contracted ? 0 : (int64_t)I->near_q16 * 65536;
    const int64_t far_s = contracted
                              ? ((int64_t)1 << 33) - ((int64_t)1 << (32 - CNERF_CONTRACT_SHIFT))
                              : (int64_t)I->far_q16 * 65536;
    const int64_t far = ray_t(I, far_s);
    /* bin width (far - near) / nc in Q32, floored: far - near < 2^47 */
    const int64_t step = (int64_t)cn_udiv_frac((uint64_t)(far_s - near), nc, 0);
    for (unsigned i = 0; i < nc; i++)
        s.t_c[i] = ray_t(I, near + (int64_t)i * step + step / 2);
    /* NDC scale factors fx / cx, fy / cy in Q28 (only used by NDC streams) */
    int64_t sx = 0, sy = 0;
    if (I->coord == CNERF_COORD_NDC) {
        sx = cn_sdiv_frac(cam->fx, cam->cx, 28);
        sy = cn_sdiv_frac(cam->fy, cam->cy, 28);
        if (sx > INT32_MAX || sy > INT32_MAX)
            return CNERF_E_ARG;
    }

    /* The image-plane coordinates of the tile's pixels, one addition per pixel. */
    pixel_coord pu, pv;
    coord_setup(&pu, cam->fx);
    coord_setup(&pv, cam->fy);
    /* Stretches of rays are ruled out where the positions are affine in t, and their
     * samples are then counted only when the caller asks for the work done; where the
     * directions are affine in the pixel too, whole blocks of pixels. */
    const int count = stats_out != (cnerf_render_stats *)0;
    const int rule_out = !contracted && !(o.flags & CNERF_RENDER_EVERY_SAMPLE);
    const int by_block = rule_out && !count && I->coord != CNERF_COORD_NDC;
    uint8_t bgpx[3];
    for (unsigned c = 0; c < 3; c++)
        bgpx[c] = to_u8(0, 1u << 30, I->background[c]);
    for (uint32_t by = 0; by < h; by += CN_BLOCK) {
        const uint32_t bh = h - by < CN_BLOCK ? h - by : CN_BLOCK;
        for (uint32_t bx = 0; bx < w; bx += CN_BLOCK) {
            const uint32_t bw = w - bx < CN_BLOCK ? w - bx : CN_BLOCK;
            coord_start(&pv, y0 + by, cam->cy);
            coord_start(&pu, x0 + bx, cam->cx);
            const uint16_t *prior = (const uint16_t *)0;
            if (by_block) {
                /* the bins that may hold a density for some ray of the block */
                pixel_coord u1, v1;
                coord_copy(&u1, &pu);
                coord_copy(&v1, &pv);
                coord_start(&u1, x0 + bx + bw - 1u, cam->cx);
                coord_start(&v1, y0 + by + bh - 1u, cam->cy);
                stretch S;
                block_range(cam, coord_value(&pu), coord_value(&u1), -coord_value(&pv),
                            -coord_value(&v1), &S);
                S.near = near;
                S.step = step;
                if (!mark_bins(&gm, &S, nc, (const uint16_t *)0, s.maybe)) {
                    for (uint32_t yy = by; yy < by + bh; yy++)
                        for (uint32_t xx = bx; xx < bx + bw; xx++)
                            put_pixel(rgb + (size_t)yy * stride + bpp * xx, bgpx, fmt);
                    continue;
                }
                s.prior[0] = 0;
                for (unsigned i = 0; i < nc; i++)
                    s.prior[i + 1u] = (uint16_t)(s.prior[i] + s.maybe[i]);
                prior = s.prior;
            }
            pixel_coord pu0; /* every row of the block starts at bx */
            coord_copy(&pu0, &pu);
            for (uint32_t yy = by; yy < by + bh; yy++, coord_next(&pv)) {
                uint8_t *row = rgb + (size_t)yy * stride;
                const int64_t v = -coord_value(&pv);
                coord_copy(&pu, &pu0);
                for (uint32_t xx = bx; xx < bx + bw; xx++, coord_next(&pu)) {
                    ray r;
                    march m;
                    m.T = 1u << 30;
                    m.rgb[0] = m.rgb[1] = m.rgb[2] = 0;
                    bins b;
                    b.maybe = (const uint8_t *)0;
                    b.of = (const uint16_t *)0;
                    b.count = count;
                    int live = make_ray(I, cam, sx, sy, coord_value(&pu), v, &r);
                    if (live && rule_out) {
                        /* a ray none of whose bins may hold a density shows the background */
                        live = mark_ray_bins(&gm, &r, near, step, nc, prior, s.maybe) != 0 ||
                               count;
                        b.maybe = s.maybe;
                    }
                    if (live)
                        render_ray(dec, &s, &r, &gm, &o, nc, nf, near, step, far, &b, &m, &stats);
                    uint8_t px[3];
                    for (unsigned c = 0; c < 3; c++)
                        px[c] = to_u8(m.rgb[c], m.T, I->background[c]);
                    put_pixel(row + bpp * xx, px, fmt);
                }
            }
        }
    }
    if (stats_out) {
        stats_out->rays += (uint64_t)w * h;
        stats_out->evals += stats.evals;
        stats_out->in_bounds += stats.in_bounds;
        stats_out->macs += stats.macs;
        stats_out->list_macs += stats.list_macs;
        stats_out->list_nz += stats.list_nz;
        stats_out->samples += stats.samples;
        stats_out->layer_values += stats.layer_values;
        stats_out->exact_rescales += stats.exact_rescales;
        stats_out->wide_macs += stats.wide_macs;
        stats_out->s8_macs += stats.s8_macs;
    }
    return CNERF_OK;
}
