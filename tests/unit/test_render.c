/* The fixed-point renderer: its arithmetic primitives against exact references, its images
 * against the float reference renderer of the same stream, and the hard cases of
 * docs/fixed-point.md, each with its expected behaviour. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_export.h"
#include "cn_fixcam.h"
#include "cn_fixed.h"
#include "cn_render.h"
#include "cn_rng.h"
#include "cn_train.h"
#include "testutil.h"

/* ---- primitives ---- */

static int64_t ref_mul_exp(int64_t s, int32_t m, int e)
{
    __int128 v = (__int128)s * m;
    const __int128 sat = (__int128)1 << 61;
    int neg = v < 0;
    unsigned __int128 u = neg ? (unsigned __int128)(-v) : (unsigned __int128)v;
    if (e >= 0) {
        for (int i = 0; i < e && u < (unsigned __int128)sat; i++)
            u <<= 1;
    } else if (-e >= 127) {
        u = 0;
    } else {
        u = (u + ((unsigned __int128)1 << (-e - 1))) >> -e;
    }
    if (u > (unsigned __int128)sat)
        u = (unsigned __int128)sat;
    return neg ? -(int64_t)u : (int64_t)u;
}

static int64_t rand_i64(cn_rng *r)
{
    /* magnitudes spread over every bit length */
    const unsigned bits = (unsigned)(cn_rng_u64(r) % 64);
    uint64_t v = cn_rng_u64(r) & (bits == 63 ? ~0ull >> 1 : ((1ull << bits) - 1));
    return cn_rng_u64(r) & 1 ? -(int64_t)v : (int64_t)v;
}

static void test_mul_exp(void **state)
{
    (void)state;
    cn_rng r = cn_rng_seed(1);
    for (int i = 0; i < 200000; i++) {
        const int64_t s = rand_i64(&r);
        const int32_t m = (int32_t)rand_i64(&r);
        const int e = (int)(cn_rng_u64(&r) % 200) - 120;
        const int64_t got = cn_mul_exp(s, m, e), want = ref_mul_exp(s, m, e);
        if (got != want)
            fail_msg("cn_mul_exp(%lld, %d, %d) = %lld, want %lld", (long long)s, m, e,
                     (long long)got, (long long)want);
    }
    assert_int_equal(cn_mul_exp(INT64_MIN, INT32_MIN, 0), CN_SAT61);
    assert_int_equal(cn_mul_exp(3, 1, -1), 2);   /* 1.5 rounds away from zero */
    assert_int_equal(cn_mul_exp(-3, 1, -1), -2);
}

static void test_div_sqrt(void **state)
{
    (void)state;
    cn_rng r = cn_rng_seed(2);
    for (int i = 0; i < 100000; i++) {
        const uint64_t n = (uint64_t)rand_i64(&r) & ~(1ull << 63);
        uint64_t d = (uint64_t)rand_i64(&r) & ~(1ull << 63);
        d = d ? d : 1;
        const unsigned f = (unsigned)(cn_rng_u64(&r) % 40);
        unsigned __int128 q = (((unsigned __int128)n) << f) / d;
        const uint64_t want = q > (unsigned __int128)INT64_MAX ? (uint64_t)INT64_MAX : (uint64_t)q;
        assert_true(cn_udiv_frac(n, d, f) == want);
        const int64_t sn = i & 1 ? -(int64_t)n : (int64_t)n, sd = i & 2 ? -(int64_t)d : (int64_t)d;
        __int128 sq = ((((__int128)llabs(sn)) << (f + 1)) / llabs(sd) + 1) / 2;
        if (sq > (__int128)1 << 62)
            sq = (__int128)1 << 62;
        const int64_t swant = (sn < 0) != (sd < 0) ? -(int64_t)sq : (int64_t)sq;
        assert_true(cn_sdiv_frac(sn, sd, f) == swant);
        const uint64_t x = (uint64_t)rand_i64(&r) << (cn_rng_u64(&r) % 2);
        const uint64_t s = cn_isqrt64(x);
        assert_true((unsigned __int128)s * s <= x && (unsigned __int128)(s + 1) * (s + 1) > x);
    }
    assert_true(cn_asr64(-1, 5) == -1 && cn_asr64(-33, 5) == -2 && cn_asr64(33, 5) == 1);
}

/* ---- images against the float reference ---- */

typedef struct scene {
    cn_buf buf;
    cnerf_decoder dec;
    void *ws;
    cn_model ref;
    void *scratch;
    size_t scratch_size;
} scene;

/* A trained-looking scene is not needed to test arithmetic: a synthetic model whose
 * latents are spread like a trained one, opened by the decoder, and its float reference. */
static void make_scene(scene *s, const cnerf_info *hdr, double spread, uint64_t seed)
{
    cn_synth syn;
    memset(s, 0, sizeof *s);
    tu_synth_stream(hdr, seed, spread, &s->buf, &syn);
    cn_synth_free(&syn);
    assert_int_equal(tu_open(&s->dec, s->buf.p, s->buf.n, &s->ws), CNERF_OK);
    char err[256];
    assert_int_equal(cn_model_from_stream(&s->dec, &s->ref, err, sizeof err), 0);
    s->scratch_size = cnerf_render_scratch_size(&s->dec.info);
    s->scratch = aligned_alloc(8, (s->scratch_size + 7) & ~(size_t)7);
}

static void free_scene(scene *s)
{
    free(s->scratch);
    free(s->ws);
    free(s->buf.p);
    cn_model_free(&s->ref);
}

static void look_at(cn_camera *c, double px, double py, double pz, int w, int h, double fov)
{
    const double r = sqrt(px * px + py * py + pz * pz);
    const double back[3] = {px / r, py / r, pz / r};
    double right[3] = {-back[1], back[0], 0};
    double rn = sqrt(right[0] * right[0] + right[1] * right[1]);
    if (rn < 1e-9) {
        right[0] = 1, right[1] = 0, rn = 1;
    }
    for (int a = 0; a < 3; a++)
        right[a] /= rn;
    const double up[3] = {back[1] * right[2] - back[2] * right[1],
                          back[2] * right[0] - back[0] * right[2],
                          back[0] * right[1] - back[1] * right[0]};
    const double pos[3] = {px, py, pz};
    for (int a = 0; a < 3; a++) {
        c->c2w[a][0] = right[a];
        c->c2w[a][1] = up[a];
        c->c2w[a][2] = back[a];
        c->c2w[a][3] = pos[a];
    }
    c->w = w, c->h = h;
    c->fx = c->fy = 0.5 * w / tan(0.5 * fov * M_PI / 180);
    c->cx = 0.5 * w, c->cy = 0.5 * h;
}

typedef struct cmp {
    double psnr;
    int maxdiff, n_over2;
} cmp;

/* Renders cam with both renderers, the fixed one in tiles of `tile` pixels. */
static cmp compare(scene *s, const cn_camera *cam, unsigned tile, uint8_t *out)
{
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(cam, &fc, err, sizeof err), 0);
    const size_t n = (size_t)cam->w * cam->h * 3;
    uint8_t *px = out ? out : malloc(n);
    float *rgb = malloc(n * sizeof(float));
    for (int y0 = 0; y0 < cam->h; y0 += (int)tile)
        for (int x0 = 0; x0 < cam->w; x0 += (int)tile) {
            const uint32_t w = (uint32_t)(x0 + (int)tile > cam->w ? cam->w - x0 : (int)tile);
            const uint32_t h = (uint32_t)(y0 + (int)tile > cam->h ? cam->h - y0 : (int)tile);
            assert_int_equal(cnerf_render_tile(&s->dec, &fc, NULL, (uint32_t)x0, (uint32_t)y0,
                                               w, h, px + ((size_t)y0 * cam->w + x0) * 3,
                                               (size_t)cam->w * 3, s->scratch, s->scratch_size),
                             CNERF_OK);
        }
    assert_int_equal(cn_render_view(&s->ref, cam, s->dec.info.coord == CNERF_COORD_NDC, rgb,
                                    4096), 0);
    cmp c = {0, 0, 0};
    double se = 0;
    for (size_t i = 0; i < n; i++) {
        const float v = rgb[i] * 255.0f + 0.5f;
        const int q = v < 0 ? 0 : v > 255 ? 255 : (int)v;
        const int d = abs(q - (int)px[i]);
        se += (double)d * d;
        c.maxdiff = d > c.maxdiff ? d : c.maxdiff;
        c.n_over2 += d > 2;
    }
    c.psnr = se == 0 ? 99 : 10 * log10(255.0 * 255.0 * (double)n / se);
    if (!out)
        free(px);
    free(rgb);
    return c;
}

static void test_matches_float(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    scene s;
    make_scene(&s, &hdr, 3.0, 7);
    cn_camera cam;
    look_at(&cam, 2.5, -3.0, 2.0, 24, 20, 40);
    const cmp c = compare(&s, &cam, 7, NULL);
    printf("fixed vs float: %.2f dB, max diff %d, %d values off by more than 2\n", c.psnr,
           c.maxdiff, c.n_over2);
    assert_true(c.psnr >= 50.0);
    assert_true(c.maxdiff <= 2);
    free_scene(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mul_exp),
        cmocka_unit_test(test_div_sqrt),
        cmocka_unit_test(test_matches_float),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
