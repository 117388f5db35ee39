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
#include "cn_internal.h"
#include "cn_kernels.h"
#include "cnerf/tools.h"
#include "cn_render.h"
#include "cn_rng.h"
#include "cn_scales.h"
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
    /* the edges of the one-word path (|s| < 2^32) and of the two-word one */
    const int64_t edge_s[] = {1, 2, 0xFFFFFFFFll, 0x100000000ll, 0x7FFFFFFFll, 0x80000000ll,
                              0x1FFFFFFFFll, INT64_MAX, INT64_MIN + 1};
    const int32_t edge_m[] = {1, -1, INT32_MAX, INT32_MIN, 3, 0x40000000};
    for (size_t a = 0; a < sizeof edge_s / sizeof edge_s[0]; a++)
        for (size_t b = 0; b < sizeof edge_m / sizeof edge_m[0]; b++)
            for (int e = -100; e <= 70; e++)
                for (int sign = -1; sign <= 1; sign += 2) {
                    const int64_t sv = sign * edge_s[a];
                    const int64_t got = cn_mul_exp(sv, edge_m[b], e);
                    const int64_t want = ref_mul_exp(sv, edge_m[b], e);
                    if (got != want)
                        fail_msg("cn_mul_exp(%lld, %d, %d) = %lld, want %lld", (long long)sv,
                                 edge_m[b], e, (long long)got, (long long)want);
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
/* Optional edit of the synthetic model before it is written. */
typedef void (*edit_fn)(cn_synth *syn, const cnerf_info *I);

static void make_scene_edit(scene *s, const cnerf_info *hdr, double spread, uint64_t seed,
                            edit_fn edit)
{
    cn_synth syn;
    char err[256];
    memset(s, 0, sizeof *s);
    if (tu_synth(&syn, hdr, seed, spread, err, sizeof err))
        fail_msg("synth: %s", err);
    cnerf_info I = *hdr; /* with the expanded topology */
    assert_int_equal(cnerf_expand_topology(&I), CNERF_OK);
    if (edit)
        edit(&syn, &I);
    if (cn_write_stream(&syn.src, &s->buf, NULL, err, sizeof err))
        fail_msg("write: %s", err);
    cn_synth_free(&syn);
    assert_int_equal(tu_open(&s->dec, s->buf.p, s->buf.n, &s->ws), CNERF_OK);
    assert_int_equal(cn_model_from_stream(&s->dec, &s->ref, err, sizeof err), 0);
    s->scratch_size = cnerf_render_scratch_size(&s->dec.info);
    s->scratch = aligned_alloc(8, (s->scratch_size + 7) & ~(size_t)7);
}

static void make_scene(scene *s, const cnerf_info *hdr, double spread, uint64_t seed)
{
    make_scene_edit(s, hdr, spread, seed, NULL);
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
    size_t n_scene; /* pixels that are not the background: the test saw the scene */
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
    cnerf_render_opts o; /* the float reference ends its rays as the decoder does */
    cnerf_render_defaults(&s->dec.info, &o);
    assert_int_equal(cn_render_view_stop(&s->ref, cam, s->dec.info.coord == CNERF_COORD_NDC, rgb,
                                         4096, (float)(o.t_stop / 1073741824.0)),
                     0);
    cmp c = {0, 0, 0, 0};
    for (size_t i = 0; i < n; i += 3)
        c.n_scene += memcmp(px + i, s->dec.info.background, 3) != 0;
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


/* Renders the whole image of cam in one tile; returns a malloc'd RGB buffer. */
static uint8_t *render_all(scene *s, const cn_camera *cam, const cnerf_render_opts *o)
{
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(cam, &fc, err, sizeof err), 0);
    uint8_t *px = malloc((size_t)cam->w * cam->h * 3);
    assert_int_equal(cnerf_render_tile(&s->dec, &fc, o, 0, 0, (uint32_t)cam->w,
                                       (uint32_t)cam->h, px, (size_t)cam->w * 3, s->scratch,
                                       s->scratch_size),
                     CNERF_OK);
    return px;
}

static void expect_background(const scene *s, const uint8_t *px, size_t npx)
{
    for (size_t i = 0; i < npx; i++)
        for (int c = 0; c < 3; c++)
            assert_int_equal(px[3 * i + c], s->dec.info.background[c]);
}

/* Rays that miss the bounds: every pixel is exactly the background. */
static void test_rays_miss(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 8, 1);
    scene s;
    make_scene(&s, &hdr, 3.0, 3);
    cn_camera cam;
    look_at(&cam, 0, 0, 4.0, 9, 9, 30);
    for (int a = 0; a < 3; a++) /* turn around: look away from the scene */
        cam.c2w[a][2] = -cam.c2w[a][2], cam.c2w[a][0] = -cam.c2w[a][0];
    uint8_t *px = render_all(&s, &cam, NULL);
    expect_background(&s, px, 81);
    free(px);
    free_scene(&s);
}

static int density_e = -5;

/* Raises the density heads' biases to 32767 2^density_e. */
static void dense(cn_synth *syn, const cnerf_info *I)
{
    for (unsigned n = 0; n < I->n_nets; n++) {
        const unsigned l = I->net[n].first_layer + I->net[n].depth;
        syn->bias[l][0] = 32767;
        syn->src.layer[l].bias_e = (int8_t)density_e;
    }
}

/* The camera inside the volume, and rays along each axis (exact 0 / +-1 rotations): the
 * fixed-point image stays within the float reference's tolerance. */
static void test_inside_and_axes(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    hdr.near_q16 = 0; /* so that a camera inside the bounds sees its surroundings */
    scene s;
    density_e = -15; /* sigma about 1 plus the network's own: a fog with structure */
    make_scene_edit(&s, &hdr, 3.0, 21, dense);
    const double at[][3] = {{0.3, -0.2, 0.1}, {4, 0, 0}, {0, -4, 0}, {0, 0, 4}, {-4, 0, 0}};
    for (unsigned k = 0; k < sizeof at / sizeof at[0]; k++) {
        cn_camera cam;
        look_at(&cam, at[k][0], at[k][1], at[k][2], 15, 13, k == 0 ? 90 : 30);
        const cmp c = compare(&s, &cam, 15, NULL);
        printf("camera %u: %.2f dB, max diff %d, %zu scene pixels\n", k, c.psnr, c.maxdiff,
               c.n_scene);
        assert_true(c.n_scene > 15 * 13 / 4);
        assert_true(c.psnr >= 50.0);
        assert_true(c.maxdiff <= 2);
    }
    free_scene(&s);
}

/* near = far - 2^-16: one tiny interval; both renderers give nearly the background. */
static void test_near_far(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 8, 1);
    hdr.near_q16 = 3 * 65536;
    hdr.far_q16 = hdr.near_q16 + 1;
    scene s;
    make_scene(&s, &hdr, 3.0, 4);
    cn_camera cam;
    look_at(&cam, 0, 0, 3.5, 8, 8, 30);
    const cmp c = compare(&s, &cam, 8, NULL);
    assert_true(c.maxdiff <= 1);
    free_scene(&s);
}

/* Huge densities: the first sample inside the bounds takes the whole weight; no overflow. */
static void test_saturation(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 8, 1);
    scene s;
    density_e = -5; /* sigma about 1024: every ray saturates in its first sample */
    make_scene_edit(&s, &hdr, 3.0, 5, dense);
    cn_camera cam;
    look_at(&cam, 2, 3, 1, 12, 12, 40);
    const cmp c = compare(&s, &cam, 5, NULL);
    printf("saturated: %.2f dB, max diff %d, %zu scene pixels\n", c.psnr, c.maxdiff, c.n_scene);
    assert_true(c.n_scene > 12 * 12 / 4);
    assert_true(c.maxdiff <= 2);
    free_scene(&s);
}

static void zero_layers(cn_synth *syn, const cnerf_info *I)
{
    for (unsigned l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        memset(syn->k[l], 0, sizeof(int32_t) * L->n_in * L->n_out);
        memset(syn->bias[l], 0, sizeof(int32_t) * L->n_out);
        syn->src.layer[l].a_m = syn->src.layer[l].b_m = 0;
    }
}

/* All-zero layers: zero density everywhere, so the image is the background. */
static void test_zero_layers(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 8, 1);
    scene s;
    make_scene_edit(&s, &hdr, 3.0, 6, zero_layers);
    cn_camera cam;
    look_at(&cam, 2, -3, 1, 10, 10, 40);
    uint8_t *px = render_all(&s, &cam, NULL);
    expect_background(&s, px, 100);
    free(px);
    free_scene(&s);
}

static int extreme_sign;

static void extreme(cn_synth *syn, const cnerf_info *I)
{
    for (unsigned l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        for (size_t i = 0; i < (size_t)L->n_in * L->n_out; i++)
            syn->k[l][i] = i % 3 == 0 ? CNERF_MAX_ABS_K : -CNERF_MAX_ABS_K;
        syn->src.layer[l].a_m = extreme_sign * CNERF_M24_ABS_MAX;
        syn->src.layer[l].a_e = (int8_t)(extreme_sign > 0 ? CNERF_EXP_MAX : CNERF_EXP_MIN);
        syn->src.layer[l].b_m = -CNERF_M24_ABS_MAX;
        syn->src.layer[l].b_e = CNERF_EXP_MAX;
        for (unsigned j = 0; j < L->n_out; j++)
            syn->bias[l][j] = j & 1 ? 32767 : -32768;
        syn->src.layer[l].bias_e = CNERF_EXP_MAX;
    }
}

/* The largest latents and the most extreme affine decoders and biases the parser accepts:
 * every sum saturates instead of overflowing (UBSan would report it), the image is the same
 * every time and every tiling. */
static void test_extreme_values(void **state)
{
    (void)state;
    for (extreme_sign = -1; extreme_sign <= 1; extreme_sign += 2) {
        cnerf_info hdr;
        tu_small_header(&hdr, 3, 8, 1);
        scene s;
        make_scene_edit(&s, &hdr, 3.0, 7, extreme);
        cn_camera cam;
        look_at(&cam, 2, -3, 1, 6, 6, 40);
        uint8_t *a = render_all(&s, &cam, NULL), *b = render_all(&s, &cam, NULL);
        assert_memory_equal(a, b, 6 * 6 * 3);
        free(a), free(b);
        free_scene(&s);
    }
}

/* Points far outside the encoding's usual range: a scene 30,000 units wide seen from the
 * edge of the camera range. No overflow; the phases wrap. */
static void test_far_points(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 8, 1);
    for (int a = 0; a < 3; a++) {
        hdr.aabb_q16[a] = -30000 * 65536;
        hdr.aabb_q16[a + 3] = 30000 * 65536;
    }
    hdr.near_q16 = 1 * 65536;
    hdr.far_q16 = 32000 * 65536;
    scene s;
    make_scene(&s, &hdr, 3.0, 8);
    cn_camera cam;
    look_at(&cam, 20000, -20000, 5000, 6, 6, 40);
    uint8_t *a = render_all(&s, &cam, NULL);
    free(a);
    free_scene(&s);
}

/* 1x1 tiles, odd tiles clipped at the borders and one image-sized tile give the same bytes. */
static void test_tilings(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    scene s;
    make_scene(&s, &hdr, 3.0, 9);
    cn_camera cam;
    look_at(&cam, 2.5, 3, 1.5, 17, 11, 40);
    const size_t n = 17 * 11 * 3;
    uint8_t *whole = render_all(&s, &cam, NULL), *tiled = malloc(n);
    const unsigned sizes[] = {1, 4, 7, 16};
    for (unsigned k = 0; k < 4; k++) {
        memset(tiled, 0, n);
        compare(&s, &cam, sizes[k], tiled);
        assert_memory_equal(whole, tiled, n);
    }
    free(whole), free(tiled);
    free_scene(&s);
}

/* Every bad argument gets its status and leaves the output untouched. */
static void test_bad_arguments(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 8, 1);
    scene s;
    make_scene(&s, &hdr, 3.0, 10);
    cn_camera cam;
    look_at(&cam, 2, 3, 1, 8, 8, 40);
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
    uint8_t px[8 * 8 * 3], ref[8 * 8 * 3];
    memset(px, 0xAB, sizeof px);
    memcpy(ref, px, sizeof px);
    void *sc = s.scratch;
    const size_t ss = s.scratch_size;
    assert_int_equal(cnerf_render_tile(NULL, &fc, NULL, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_NULL);
    assert_int_equal(cnerf_render_tile(&s.dec, NULL, NULL, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_NULL);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 0, 0, 8, 8, NULL, 24, sc, ss), CNERF_E_NULL);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 0, 0, 8, 8, px, 24, NULL, ss), CNERF_E_NULL);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 0, 0, 8, 8, px, 24, (char *)sc + 4, ss),
                     CNERF_E_WS_ALIGN);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 0, 0, 8, 8, px, 24, sc, ss - 1),
                     CNERF_E_WS_SMALL);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 0, 0, 8, 8, px, 23, sc, ss),
                     CNERF_E_BUF_SMALL);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 1, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 0, 8, 1, 1, px, 24, sc, ss), CNERF_E_ARG);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, NULL, 0, 0, 0, 8, px, 24, sc, ss), CNERF_E_ARG);
    cnerf_render_opts o;
    cnerf_render_defaults(&s.dec.info, &o);
    o.n_coarse = 0;
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, &o, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    cnerf_render_defaults(&s.dec.info, &o);
    o.n_fine = (uint16_t)(s.dec.info.n_fine + 1);
    assert_int_equal(cnerf_render_tile(&s.dec, &fc, &o, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    cnerf_camera bad = fc;
    bad.fx = 0;
    assert_int_equal(cnerf_render_tile(&s.dec, &bad, NULL, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    bad = fc;
    bad.fx = bad.fy = 65536; /* 8 pixels at focal length 1: |u| = 4, beyond the Q28 range */
    assert_int_equal(cnerf_render_tile(&s.dec, &bad, NULL, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    bad = fc;
    bad.rot[4] = (1 << 30) + 1;
    assert_int_equal(cnerf_render_tile(&s.dec, &bad, NULL, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    bad = fc;
    bad.pos[2] = ((int64_t)1 << 47) + 1;
    assert_int_equal(cnerf_render_tile(&s.dec, &bad, NULL, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    assert_memory_equal(px, ref, sizeof px);
    cnerf_decoder closed;
    memset(&closed, 0, sizeof closed);
    assert_int_equal(cnerf_render_tile(&closed, &fc, NULL, 0, 0, 8, 8, px, 24, sc, ss), CNERF_E_ARG);
    free_scene(&s);
}

/* Fewer samples and early termination are approximations of the full render: their error
 * against it shrinks as the knobs approach the defaults. */
static void test_knobs(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    scene s;
    make_scene(&s, &hdr, 3.0, 11);
    cn_camera cam;
    look_at(&cam, 2.5, -3, 1.5, 12, 12, 40);
    cnerf_render_opts o;
    cnerf_render_defaults(&s.dec.info, &o);
    o.t_stop = 0;
    uint8_t *exact = render_all(&s, &cam, &o);
    o.t_stop = 1u << 18;
    uint8_t *stop = render_all(&s, &cam, &o);
    for (size_t i = 0; i < 12 * 12 * 3; i++) /* the bound of docs/fixed-point.md: 1/4096 */
        assert_true(abs((int)exact[i] - (int)stop[i]) <= 1);
    o.t_stop = 0;
    o.n_fine = 0; /* the coarse network's image */
    uint8_t *coarse = render_all(&s, &cam, &o);
    s.ref.topo.n_nets = 1;
    s.ref.topo.n_fine = 0;
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
    float rgb[12 * 12 * 3];
    assert_int_equal(cn_render_view(&s.ref, &cam, 0, rgb, 4096), 0);
    for (size_t i = 0; i < 12 * 12 * 3; i++) {
        const float v = rgb[i] * 255.0f + 0.5f;
        assert_true(abs((int)v - (int)coarse[i]) <= 2);
    }
    free(exact), free(stop), free(coarse);
    free_scene(&s);
}

/* A forward-facing scene in NDC. */
static void test_ndc(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    hdr.coord = CNERF_COORD_NDC;
    hdr.near_q16 = 0;
    hdr.far_q16 = 65536;
    for (int a = 0; a < 3; a++) {
        hdr.aabb_q16[a] = -2 * 65536;
        hdr.aabb_q16[a + 3] = 2 * 65536;
    }
    scene s;
    make_scene(&s, &hdr, 3.0, 12);
    cn_camera cam;
    memset(&cam, 0, sizeof cam);
    const double c = cos(0.1), sn = sin(0.1);
    const double R[3][3] = {{c, 0, sn}, {0, 1, 0}, {-sn, 0, c}};
    for (int a = 0; a < 3; a++) {
        for (int b = 0; b < 3; b++)
            cam.c2w[a][b] = R[a][b];
    }
    cam.c2w[0][3] = 0.1, cam.c2w[1][3] = -0.05, cam.c2w[2][3] = 0.2;
    cam.w = 20, cam.h = 15;
    cam.fx = cam.fy = 18;
    cam.cx = 10, cam.cy = 7.5;
    const cmp r = compare(&s, &cam, 6, NULL);
    printf("ndc: %.2f dB, max diff %d\n", r.psnr, r.maxdiff);
    assert_true(r.psnr >= 50.0);
    assert_true(r.maxdiff <= 2);
    free_scene(&s);
}

/* A contracted scene (format 2.2): the samples reach 2^6 times the linear segment's length
 * and every point, however far, is drawn into the bounds; the fixed-point render follows the
 * float one from a camera inside the bounds, one outside them and one far beyond. */
static void contract_header(cnerf_info *hdr)
{
    tu_small_header(hdr, 3, 16, 1);
    hdr->n_coarse = 32; /* with 8, one sample spans half the background: flips of a density
                           near 0 between the renderers move a pixel by up to 5 */
    hdr->n_fine = 16;
    hdr->coord = CNERF_COORD_CONTRACT;
    hdr->near_q16 = 65536 / 2;
    hdr->far_q16 = 5 * 65536;
    for (int a = 0; a < 3; a++) {
        hdr->aabb_q16[a] = -3 * 65536;
        hdr->aabb_q16[a + 3] = 3 * 65536;
    }
}

static void test_contract(void **state)
{
    (void)state;
    cnerf_info hdr;
    contract_header(&hdr);
    scene s;
    density_e = -15; /* the fog of test_inside_and_axes, everywhere */
    make_scene_edit(&s, &hdr, 3.0, 21, dense);
    assert_int_equal(s.dec.info.version_minor, CNERF_VERSION_MINOR_CONTRACT);
    hdr.coord = CNERF_COORD_WORLD; /* the same model, ending at its bounds */
    scene w;
    make_scene_edit(&w, &hdr, 3.0, 21, dense);
    const double where[3][3] = {{0.8, -0.6, 0.3}, {2.5, -3.0, 2.0}, {60, 45, -20}};
    for (int k = 0; k < 3; k++) {
        cn_camera cam;
        look_at(&cam, where[k][0], where[k][1], where[k][2], 20, 16, 60);
        if (k == 2) /* the far camera looks away from the bounds */
            for (int a = 0; a < 3; a++) {
                cam.c2w[a][0] = -cam.c2w[a][0];
                cam.c2w[a][2] = -cam.c2w[a][2];
            }
        const cmp c = compare(&s, &cam, 7, NULL);
        printf("contracted, camera %d: fixed vs float %.2f dB, max diff %d, %zu of %d pixels "
               "not the background\n", k, c.psnr, c.maxdiff, c.n_scene, cam.w * cam.h);
        assert_true(c.psnr >= 50.0);
        assert_true(c.maxdiff <= 2);
        if (k == 2) { /* beyond the bounds: the fog when contracted, nothing in world space */
            assert_int_equal(c.n_scene, (size_t)cam.w * cam.h);
            assert_int_equal(compare(&w, &cam, 7, NULL).n_scene, 0);
        }
    }
    free_scene(&w);
    /* The float rule at the seams: a point on the inner cube's face stays, one beyond it is
     * drawn in towards 2h, and the last sample's distance is near + 2^6 L. */
    float o[3] = {0, 0, 0}, d[3] = {1, 0, 0}, p[3];
    cn_ray_point(&s.ref.topo, o, d, 1.5f, p);
    assert_float_equal(p[0], 1.5f, 1e-6f);
    cn_ray_point(&s.ref.topo, o, d, 3.0f, p);
    assert_float_equal(p[0], 2.25f, 1e-5f); /* u = 2: h (2 - 1/u) = 1.5 * 1.5 */
    cn_ray_point(&s.ref.topo, o, d, 1e6f, p);
    assert_true(p[0] < 3.0f && p[0] > 2.99f);
    assert_float_equal(cn_ray_far(&s.ref.topo), 0.5f + 64 * 4.5f, 1e-3f);
    free_scene(&s); /* the header's rules: tests/support/negcases.c */
}

/* ---- occupancy grids ---- */

#define GRID_G 8
static uint8_t grid_cells[GRID_G * GRID_G * GRID_G];

/* The fog of test_inside_and_axes, with the stream grid grid_cells. */
static void dense_grid(cn_synth *syn, const cnerf_info *I)
{
    dense(syn, I);
    syn->src.grid = grid_cells;
    syn->src.grid_g = GRID_G;
}

static void grid_ball(void)
{
    for (int i = 0; i < GRID_G * GRID_G * GRID_G; i++) {
        const int x = 2 * (i % GRID_G) - GRID_G + 1, y = 2 * (i / GRID_G % GRID_G) - GRID_G + 1,
                  z = 2 * (i / GRID_G / GRID_G) - GRID_G + 1;
        grid_cells[i] = x * x + y * y + z * z <= 5 * 5 * 2;
    }
}

/* Renders cam in one tile with opts, counting the work. */
static uint8_t *render_counted(scene *s, const cn_camera *cam, uint32_t flags,
                               cnerf_render_stats *st)
{
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(cam, &fc, err, sizeof err), 0);
    cnerf_render_opts o;
    cnerf_render_defaults(&s->dec.info, &o);
    o.flags = flags;
    uint8_t *px = malloc((size_t)cam->w * cam->h * 3);
    memset(st, 0, sizeof *st);
    assert_int_equal(cnerf_render_tile_stats(&s->dec, &fc, &o, 0, 0, (uint32_t)cam->w,
                                             (uint32_t)cam->h, px, (size_t)cam->w * 3,
                                             s->scratch, s->scratch_size, st),
                     CNERF_OK);
    assert_int_equal(st->rays, (uint64_t)cam->w * (uint64_t)cam->h);
    return px;
}

/* The MACs of a network's layers [l0, l1): the stored rows with a latent, times their inputs. */
static uint64_t layer_macs(const cnerf_decoder *dec, unsigned l0, unsigned l1)
{
    uint64_t m = 0;
    for (unsigned l = l0; l < l1; l++)
        m += (uint64_t)cn_cstate_of(dec)->n_live[l] * dec->info.layer[l].n_in;
    return m;
}

/* The work counter counts what is done: every evaluation runs the trunk and the density, the
 * colour branch runs only where it adds to the image (never for the coarse network of a
 * two-network render), and skipping it does not change a bit. */
static void test_macs_counted(void **state)
{
    (void)state;
    cn_camera cam;
    look_at(&cam, 2.5, -3.0, 2.0, 24, 20, 40);
    for (int two = 0; two < 2; two++) {
        cnerf_info hdr;
        tu_small_header(&hdr, 3, 16, two);
        density_e = -15;
        scene sc;
        make_scene_edit(&sc, &hdr, 3.0, 21, dense);
        const cnerf_decoder *dec = &sc.dec;
        cnerf_render_stats st;
        uint8_t *px = render_counted(&sc, &cam, 0, &st);
        free(px);
        const cnerf_net_info *N = &dec->info.net[two];
        const unsigned sig_end = N->first_layer + N->depth + 1u;
        const uint64_t sig = layer_macs(dec, N->first_layer, sig_end);
        const uint64_t col = layer_macs(dec, sig_end, sig_end + 3u);
        uint64_t coarse_sig = 0, evals_fine = st.evals;
        if (two) {
            /* the coarse pass: trunk and density only */
            const cnerf_net_info *C = &dec->info.net[0];
            coarse_sig = layer_macs(dec, C->first_layer, C->first_layer + C->depth + 1u);
            cnerf_render_opts o;
            cnerf_render_defaults(&dec->info, &o);
            o.n_fine = 0;
            cnerf_camera fc;
            char err[256];
            assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
            cnerf_render_stats c;
            memset(&c, 0, sizeof c);
            uint8_t *cpx = malloc((size_t)cam.w * cam.h * 3);
            assert_int_equal(cnerf_render_tile_stats(dec, &fc, &o, 0, 0, (uint32_t)cam.w,
                                                     (uint32_t)cam.h, cpx, (size_t)cam.w * 3,
                                                     sc.scratch, sc.scratch_size, &c),
                             CNERF_OK);
            free(cpx);
            evals_fine = st.evals - c.evals; /* same coarse samples in both renders */
        }
        const uint64_t evals_coarse = st.evals - evals_fine;
        const uint64_t lo = evals_coarse * coarse_sig + evals_fine * sig;
        printf("%s: %llu MACs, %llu evaluations, trunk and density %llu, colour %llu each\n",
               two ? "two networks" : "one network", (unsigned long long)st.macs,
               (unsigned long long)st.evals, (unsigned long long)sig, (unsigned long long)col);
        assert_true(evals_fine > 0 && sig > 0 && col > 0);
        assert_true(st.macs >= lo + col);                    /* some colour was needed */
        assert_true(st.macs <= lo + evals_fine * col);       /* never for the coarse pass */
        assert_int_equal((st.macs - lo) % col, 0);           /* whole colour branches */
        free_scene(&sc);
    }
}

/* A grid changes what is evaluated and nothing else: a full grid renders the stream
 * without a grid bit for bit, an empty one the background with no evaluation; a partial one
 * skips work, matches the float reference, and with CNERF_RENDER_NO_SKIP is the stream
 * without a grid again. */
static void test_grid(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    density_e = -15;
    cn_camera cam;
    look_at(&cam, 2.5, -3.0, 2.0, 24, 20, 40);
    const size_t nv = (size_t)cam.w * cam.h * 3;
    scene plain;
    make_scene_edit(&plain, &hdr, 3.0, 21, dense);
    assert_int_equal(plain.dec.info.version_minor, 0);
    assert_int_equal(plain.dec.info.grid_g, 0);
    cnerf_render_stats st0, st;
    uint8_t *px0 = render_counted(&plain, &cam, 0, &st0);
    assert_true(st0.evals > 0 && st0.evals == st0.in_bounds);

    memset(grid_cells, 1, sizeof grid_cells);
    scene full;
    make_scene_edit(&full, &hdr, 3.0, 21, dense_grid);
    assert_int_equal(full.dec.info.version_minor, CNERF_VERSION_MINOR_BLOCKS);
    assert_int_equal(full.dec.info.grid_by_blocks, 1);
    assert_int_equal(full.dec.info.grid_g, GRID_G);
    assert_int_equal(cn_cstate_of(&full.dec)->grid_occupied, GRID_G * GRID_G * GRID_G);
    uint8_t *px = render_counted(&full, &cam, 0, &st);
    assert_memory_equal(px, px0, nv);
    assert_true(st.evals == st0.evals && st.in_bounds == st0.in_bounds);
    free(px);
    free_scene(&full);

    memset(grid_cells, 0, sizeof grid_cells);
    scene empty;
    make_scene_edit(&empty, &hdr, 3.0, 21, dense_grid);
    assert_int_equal(cn_cstate_of(&empty.dec)->grid_occupied, 0);
    px = render_counted(&empty, &cam, 0, &st);
    expect_background(&empty, px, nv / 3);
    assert_true(st.evals == 0 && st.in_bounds > 0);
    const cmp ce = compare(&empty, &cam, 24, NULL);
    assert_true(ce.maxdiff == 0 && ce.n_scene == 0);
    free(px);
    free_scene(&empty);

    grid_ball();
    scene ball;
    make_scene_edit(&ball, &hdr, 3.0, 21, dense_grid);
    px = render_counted(&ball, &cam, 0, &st);
    printf("ball grid: %llu of %llu in-bounds samples evaluated (no grid: %llu)\n",
           (unsigned long long)st.evals, (unsigned long long)st.in_bounds,
           (unsigned long long)st0.evals);
    assert_true(st.evals > 0 && st.evals < st.in_bounds * 3 / 4);
    assert_true(memcmp(px, px0, nv) != 0);
    const cmp c = compare(&ball, &cam, 7, NULL);
    printf("ball grid, fixed vs float: %.2f dB, max diff %d, %zu scene pixels\n", c.psnr,
           c.maxdiff, c.n_scene);
    assert_true(c.psnr >= 50.0 && c.maxdiff <= 2 && c.n_scene > 0);
    free(px);
    px = render_counted(&ball, &cam, CNERF_RENDER_NO_SKIP, &st);
    assert_memory_equal(px, px0, nv);
    assert_true(st.evals == st0.evals);
    free(px);
    /* An unknown flag is misuse. */
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
    cnerf_render_opts o;
    cnerf_render_defaults(&ball.dec.info, &o);
    o.flags = 16;
    uint8_t one[3];
    assert_int_equal(cnerf_render_tile(&ball.dec, &fc, &o, 0, 0, 1, 1, one, 3, ball.scratch,
                                       ball.scratch_size),
                     CNERF_E_ARG);
    free_scene(&ball);
    free(px0);
    free_scene(&plain);
}

/* RGB565 (docs/rendering.md, Output) is the RGB888 image converted pixel by pixel: each
 * field the nearest of its levels, round(c (2^n - 1) / 255), computed here in double; the
 * 16-bit value low byte first (CNERF_RENDER_RGB565) or high byte first (_BE). Checked on
 * every path that writes a pixel: rays marched, rays and whole blocks of the background
 * (a ball grid, the view half empty), whole and in tiles, at a stride wider than the row. */
static void test_rgb565(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    density_e = -15;
    grid_ball();
    scene ball;
    make_scene_edit(&ball, &hdr, 3.0, 21, dense_grid);
    cn_camera cam;
    look_at(&cam, 2.5, -3.0, 2.0, 24, 20, 40);
    const uint32_t w = (uint32_t)cam.w, h = (uint32_t)cam.h;
    cnerf_render_opts o;
    cnerf_render_defaults(&ball.dec.info, &o);
    uint8_t *ref = render_all(&ball, &cam, &o);
    size_t n_bg = 0;
    for (size_t i = 0; i < (size_t)w * h; i++)
        n_bg += !memcmp(ref + 3 * i, ball.dec.info.background, 3);
    assert_true(n_bg > 0 && n_bg < (size_t)w * h); /* both kinds of pixel */
    cnerf_camera fc;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
    const size_t stride = (size_t)w * 2 + 6;
    uint8_t *px = malloc(stride * h);
    for (int be = 0; be < 2; be++) {
        o.flags = be ? CNERF_RENDER_RGB565_BE : CNERF_RENDER_RGB565;
        for (uint32_t t = 0; t < 2; t++) { /* whole, then in 7x5 tiles */
            memset(px, 0xA5, stride * h);
            const uint32_t tw = t ? 7 : w, th = t ? 5 : h;
            for (uint32_t y0 = 0; y0 < h; y0 += th)
                for (uint32_t x0 = 0; x0 < w; x0 += tw) {
                    const uint32_t cw = w - x0 < tw ? w - x0 : tw, ch = h - y0 < th ? h - y0 : th;
                    assert_int_equal(cnerf_render_tile(&ball.dec, &fc, &o, x0, y0, cw, ch,
                                                       px + y0 * stride + 2 * x0, stride,
                                                       ball.scratch, ball.scratch_size),
                                     CNERF_OK);
                }
            for (uint32_t y = 0; y < h; y++) {
                for (uint32_t x = 0; x < w; x++) {
                    const uint8_t *c = ref + 3 * ((size_t)y * w + x);
                    const unsigned v = (unsigned)floor(c[0] * 31.0 / 255 + 0.5) << 11 |
                                       (unsigned)floor(c[1] * 63.0 / 255 + 0.5) << 5 |
                                       (unsigned)floor(c[2] * 31.0 / 255 + 0.5);
                    const uint8_t *p = px + y * stride + 2 * x;
                    assert_int_equal(be ? p[0] << 8 | p[1] : p[1] << 8 | p[0], v);
                }
                for (size_t k = 2 * (size_t)w; k < stride; k++) /* the stride's padding */
                    assert_int_equal(px[y * stride + k], 0xA5);
            }
        }
    }
    /* a row of 2 w - 1 bytes is too small; both byte orders at once are misuse */
    o.flags = CNERF_RENDER_RGB565;
    assert_int_equal(cnerf_render_tile(&ball.dec, &fc, &o, 0, 0, w, 1, px, 2 * w - 1,
                                       ball.scratch, ball.scratch_size),
                     CNERF_E_BUF_SMALL);
    assert_int_equal(cnerf_render_tile(&ball.dec, &fc, &o, 0, 0, w, 1, px, 2 * w, ball.scratch,
                                       ball.scratch_size),
                     CNERF_OK);
    o.flags = CNERF_RENDER_RGB565 | CNERF_RENDER_RGB565_BE;
    assert_int_equal(cnerf_render_tile(&ball.dec, &fc, &o, 0, 0, w, 1, px, 2 * w, ball.scratch,
                                       ball.scratch_size),
                     CNERF_E_ARG);
    free(px), free(ref);
    free_scene(&ball);
}

/* Ruling out empty stretches of rays (the grid's summary, the bounds) changes nothing: the
 * same pixels and the same work counted as examining every sample, for grids sparse and
 * dense, from cameras inside and outside the bounds, near and far, rendered whole and in
 * tiles (a tile's rows and columns start anywhere). */
static void test_rule_out_exact(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    hdr.near_q16 = 0; /* cameras inside the bounds see their surroundings */
    density_e = -15;
    cn_rng r = cn_rng_seed(45);
    const int fills[] = {0, 2, 10, 40, 100, -1}; /* percent occupied; -1: the ball */
    uint64_t ruled = 0, every = 0;
    for (size_t f = 0; f < sizeof fills / sizeof fills[0]; f++) {
        if (fills[f] < 0)
            grid_ball();
        else
            for (int i = 0; i < GRID_G * GRID_G * GRID_G; i++)
                grid_cells[i] = (int)(cn_rng_u64(&r) % 100) < fills[f];
        scene s;
        make_scene_edit(&s, &hdr, 3.0, 21 + f, dense_grid);
        for (int k = 0; k < 12; k++) {
            const double d = k < 3 ? 0.2 + 0.3 * k : 1.5 + 0.5 * k;
            double v[3];
            for (int a = 0; a < 3; a++)
                v[a] = (double)(cn_rng_u64(&r) % 2001) / 1000.0 - 1.0;
            const double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + 1e-9;
            cn_camera cam;
            look_at(&cam, d * v[0] / n, d * v[1] / n, d * v[2] / n + 1e-3, 19, 14,
                    k % 3 ? 40 : 100);
            cnerf_camera fc;
            char err[256];
            assert_int_equal(cnerf_camera_from_float(&cam, &fc, err, sizeof err), 0);
            const size_t nv = (size_t)cam.w * cam.h * 3;
            uint8_t *px[2];
            for (int e = 0; e < 2; e++) {
                cnerf_render_opts o;
                cnerf_render_defaults(&s.dec.info, &o);
                o.flags = e ? CNERF_RENDER_EVERY_SAMPLE : 0u;
                px[e] = malloc(nv);
                /* tiles of 5 x 4: rows and columns that start mid-image */
                for (uint32_t y0 = 0; y0 < (uint32_t)cam.h; y0 += 4)
                    for (uint32_t x0 = 0; x0 < (uint32_t)cam.w; x0 += 5) {
                        const uint32_t w = x0 + 5 > (uint32_t)cam.w ? (uint32_t)cam.w - x0 : 5;
                        const uint32_t h = y0 + 4 > (uint32_t)cam.h ? (uint32_t)cam.h - y0 : 4;
                        assert_int_equal(cnerf_render_tile(&s.dec, &fc, &o, x0, y0, w, h,
                                                           px[e] + (y0 * (uint32_t)cam.w + x0) * 3,
                                                           (size_t)cam.w * 3, s.scratch,
                                                           s.scratch_size),
                                         CNERF_OK);
                    }
            }
            assert_memory_equal(px[0], px[1], nv);
            /* the whole frame in one tile: blocks of pixels that a tile does not cut */
            {
                cnerf_render_opts o;
                cnerf_render_defaults(&s.dec.info, &o);
                uint8_t *whole = malloc(nv);
                assert_int_equal(cnerf_render_tile(&s.dec, &fc, &o, 0, 0, (uint32_t)cam.w,
                                                   (uint32_t)cam.h, whole, (size_t)cam.w * 3,
                                                   s.scratch, s.scratch_size),
                                 CNERF_OK);
                assert_memory_equal(whole, px[1], nv);
                free(whole);
            }
            cnerf_render_stats st[2];
            for (int e = 0; e < 2; e++) {
                free(px[e]);
                px[e] = render_counted(&s, &cam, e ? CNERF_RENDER_EVERY_SAMPLE : 0u, &st[e]);
            }
            assert_memory_equal(px[0], px[1], nv);
            assert_true(st[0].evals == st[1].evals && st[0].in_bounds == st[1].in_bounds &&
                        st[0].macs == st[1].macs);
            ruled += st[0].evals;
            every += st[1].in_bounds;
            free(px[0]);
            free(px[1]);
        }
        free_scene(&s);
    }
    printf("ruling out: %llu evaluations of %llu samples in bounds, all identical\n",
           (unsigned long long)ruled, (unsigned long long)every);
}

/* The cell of a point: the float reference's exact mapping is the decoder's integer one, on
 * offsets at and around every cell boundary of boxes of awkward widths. */
static void test_grid_cell_mapping(void **state)
{
    (void)state;
    cn_rng r = cn_rng_seed(17);
    const uint64_t widths[] = {1, 3, 65536, 196608, 0x7FFFFFFFu, 0xFFFFFFFEu, 12345678};
    for (size_t k = 0; k < sizeof widths / sizeof widths[0]; k++)
        for (uint32_t g = 1; g <= CNERF_MAX_GRID; g = g * 2 + (g & 1u)) {
            const uint64_t w = widths[k], rr = cn_udiv_frac(g, w, 32);
            for (uint32_t c = 0; c <= g; c++) {
                /* the first offset of cell c: ceil(c w / g) */
                const uint64_t s0 = ((uint64_t)c * w + g - 1) / g;
                for (int d = -2; d <= 2; d++) {
                    const int64_t sd = (int64_t)s0 + d;
                    if (sd < 0 || (uint64_t)sd > w)
                        continue;
                    const uint64_t sv = (uint64_t)sd;
                    const uint32_t dec = cn_grid_cell(sv, rr, g);
                    assert_int_equal(dec, cn_occ_cell_exact(sv, rr, (int)g));
                    /* within one cell of floor(s g / w) (the reciprocal is rounded down) */
                    const uint64_t ideal = sv * g / w >= g ? g - 1 : sv * g / w;
                    assert_true(dec <= ideal && dec + 1 >= ideal);
                }
            }
            for (int i = 0; i < 100; i++) {
                const uint64_t sv = cn_rng_u64(&r) % (w + 1);
                assert_int_equal(cn_grid_cell(sv, rr, g), cn_occ_cell_exact(sv, rr, (int)g));
            }
        }
}

/* ---- rows without latents ---- */

/* Zeroes every third kernel row of every layer (a row of layer 2 keeps one int16 latent). */
static void zero_rows(cn_synth *syn, const cnerf_info *I)
{
    for (unsigned l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        for (uint32_t o = 0; o < L->n_out; o += 3)
            for (uint32_t i = 0; i < L->n_in; i++)
                syn->k[l][(size_t)o * L->n_in + i] = 0;
    }
    syn->k[2][0] = 0;
    syn->k[2][1] = 300; /* int16 storage; row 0 stays live */
}

/* The decoder skips the dot products of rows whose latents are all 0 (their sum is exactly
 * 0): the rows are counted at open, and the picture still matches the float reference. */
static void test_zero_rows(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    scene s;
    make_scene_edit(&s, &hdr, 3.0, 7, zero_rows);
    const cnerf_info *I = &s.dec.info;
    for (unsigned l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        const uint32_t zero = (L->n_out + 2) / 3 - (l == 2 ? 1u : 0u);
        assert_int_equal(cn_cstate_of(&s.dec)->n_live[l], L->n_out - zero);
        /* rows[] is a permutation: live rows first, each with a non-zero latent */
        uint8_t seen[CNERF_MAX_WIDTH] = {0};
        for (uint32_t j = 0; j < L->n_out; j++) {
            const uint16_t o = cn_cstate_of(&s.dec)->rows[l][j];
            assert_true(o < L->n_out && !seen[o]);
            seen[o] = 1;
            int nz = 0;
            for (uint32_t i = 0; i < L->n_in; i++)
                nz |= cnerf_latent(&s.dec, l, o, i) != 0;
            assert_int_equal(nz, j < cn_cstate_of(&s.dec)->n_live[l]);
        }
    }
    cn_camera cam;
    look_at(&cam, 2.5, -3.0, 2.0, 24, 20, 40);
    const cmp c = compare(&s, &cam, 7, NULL);
    printf("zero rows, fixed vs float: %.2f dB, max diff %d\n", c.psnr, c.maxdiff);
    assert_true(c.psnr >= 50.0 && c.maxdiff <= 2 && c.n_scene > 0);
    free_scene(&s);
}

/* ---- zero latents: the layers stored sparse ---- */

/* Keeps each latent of layer l with a probability that varies by layer (none to all), and
 * makes row 0 of every fourth layer whole, which leaves no room for lists stored in place:
 * that layer must stay packed. */
static void sparsify(cn_synth *syn, const cnerf_info *I)
{
    static const int keep[] = {3, 12, 30, 0, 60, 100, 7};
    cn_rng r = cn_rng_seed(77);
    for (unsigned l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        for (uint32_t o = 0; o < L->n_out; o++)
            for (uint32_t i = 0; i < L->n_in; i++) {
                int32_t *k = &syn->k[l][(size_t)o * L->n_in + i];
                if ((int)(cn_rng_u64(&r) % 100) >= keep[l % 7])
                    *k = 0;
                if (l % 4 == 1 && o == 0 && *k == 0)
                    *k = 1 + (int32_t)(i % 5);
            }
    }
}

/* Opens s's stream again with kernels v into c (the rest of s shared). */
static void reopen(const scene *s, const cn_dot_variant *v, scene *c)
{
    *c = *s;
    const size_t n = cnerf_workspace_size(&s->dec.info);
    c->ws = aligned_alloc(CNERF_WS_ALIGN, (n + 7) & ~(size_t)7);
    assert_int_equal(cn_open_with(&c->dec, s->buf.p, s->buf.n, 0, c->ws, n, v, 0), CNERF_OK);
}

/* A layer stored as lists of its non-zero latents gives the same sums as packed: the same
 * latents read back, the same pixels and the same work counted, from every view, with the
 * kernels of this build that store no layer sparse, every layer that fits, or as they
 * choose; with latents stored as int8 (a small spread) and as int16 (a wide one). */
static void test_sparse_exact(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 4, 24, 1);
    hdr.l_pos = 3; /* 21 inputs: an odd layer */
    cn_dot_variant all[CN_DOT_MAX_VARIANTS];
    const uint32_t nv = cn_dot_variants(all);
    unsigned sparse_layers = 0, kept_packed = 0;
    uint64_t listed = 0; /* multiply-accumulates of layers in lists */
    for (int wide = 0; wide < 2; wide++)
    for (uint32_t k = 0; k < nv; k++)
        for (int mode = 0; mode < 3; mode++) {
            cn_dot_variant v = all[k];
            if (mode == 0)
                v.mac_cost = v.mac8_cost = 0; /* never sparse */
            else if (mode == 1) /* sparse wherever it fits */
                v.mac_cost = v.mac8_cost = 1000, v.nz_cost = 0, v.row_cost = 0;
            scene s, c[2];
            make_scene_edit(&s, &hdr, wide ? 60.0 : 3.0, 31 + k, sparsify);
            unsigned s8 = 0;
            for (unsigned l = 0; l < s.dec.info.n_layers; l++)
                s8 += s.dec.info.layer[l].kmin >= -128 && s.dec.info.layer[l].kmax <= 127;
            /* every layer int8, or most int16 */
            assert_true(wide ? 2 * s8 < s.dec.info.n_layers : s8 == s.dec.info.n_layers);
            reopen(&s, &v, &c[0]);
            v = all[k];
            v.mac_cost = v.mac8_cost = 0;
            reopen(&s, &v, &c[1]); /* packed */
            const cnerf_info *I = &s.dec.info;
            for (unsigned l = 0; l < I->n_layers; l++) {
                const unsigned form = cn_cstate_of(&c[0].dec)->form[l];
                assert_true(cn_cstate_of(&c[1].dec)->form[l] != CN_FORM_SPARSE);
                if (mode == 0)
                    assert_true(form != CN_FORM_SPARSE);
                if (mode == 1 && l % 4 == 1)
                    assert_true(form != CN_FORM_SPARSE); /* row 0 is whole: no room */
                sparse_layers += form == CN_FORM_SPARSE;
                kept_packed += mode == 1 && form != CN_FORM_SPARSE;
                const cnerf_layer_info *L = &I->layer[l];
                for (uint32_t o = 0; o < L->n_out; o++)
                    for (uint32_t i = 0; i < L->n_in; i++)
                        assert_int_equal(cnerf_latent(&c[0].dec, l, o, i),
                                         cnerf_latent(&c[1].dec, l, o, i));
            }
            for (int view = 0; view < 3; view++) {
                cn_camera cam;
                look_at(&cam, 2.5 - view, -3.0 + view, 2.0, 17, 13, 40 + 20 * view);
                cnerf_render_stats st[2];
                uint8_t *px[2];
                for (int e = 0; e < 2; e++)
                    px[e] = render_counted(&c[e], &cam, 0u, &st[e]);
                assert_memory_equal(px[0], px[1], (size_t)cam.w * cam.h * 3);
                assert_true(st[0].evals == st[1].evals && st[0].macs == st[1].macs &&
                            st[0].evals > 0);
                /* the packed open does every multiply-accumulate, the lists fewer */
                assert_true(st[1].list_macs == 0 && st[1].list_nz == 0);
                /* packed: int8 latents' sums counted apart (all of them with a small spread) */
                assert_true(wide ? st[1].s8_macs < st[1].macs
                                 : st[1].s8_macs == st[1].macs - st[1].wide_macs);
                assert_true(st[0].list_nz <= st[0].list_macs && st[0].list_macs <= st[0].macs);
                listed += st[0].list_macs;
                free(px[0]);
                free(px[1]);
            }
            free(c[0].ws);
            free(c[1].ws);
            free_scene(&s);
        }
    printf("sparse layers: %u opened sparse, %u left packed where lists would not fit or "
           "cost more, the same pixels\n", sparse_layers, kept_packed);
    assert_true(sparse_layers > 0 && kept_packed > 0 && listed > 0);
}

/* cnerf_workspace_size_fast: given that much, kernels whose int8 sums cost more (the DSP
 * extension's, Advanced SIMD's) keep every latent as int16, and the decoder holds the same
 * latents and renders the same pixels with the same work, none of it int8 sums; given less,
 * or on kernels whose int8 sums cost the same, the int8 layers stay int8. */
static void test_open_fast(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 4, 24, 1);
    scene s;
    make_scene_edit(&s, &hdr, 3.0, 41, sparsify);
    const cnerf_info *info = &s.dec.info;
    const size_t n = cnerf_workspace_size(info), nf = cnerf_workspace_size_fast(info);
    unsigned s8_layers = 0;
    for (unsigned l = 0; l < info->n_layers; l++)
        s8_layers += cn_latents_s8(info->layer[l].kmin, info->layer[l].kmax);
    assert_true(s8_layers > 0); /* else there is nothing to widen */
    assert_true(nf > n);
    assert_int_equal(cnerf_workspace_size_fast(NULL), 0);
    cn_camera cam;
    look_at(&cam, 2.0, -2.5, 1.5, 15, 11, 50);
    static const char *const sets[] = {"c", "dsp", "mve", "neon", "avx2"};
    for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++) {
        cn_dot_variant v;
        assert_true(cn_dot_variant_as(sets[k], &v));
        const int widens = v.mac8_cost > v.mac_cost;
        scene a = s, b = s;
        a.ws = aligned_alloc(CNERF_WS_ALIGN, (n + 7) & ~(size_t)7);
        b.ws = aligned_alloc(CNERF_WS_ALIGN, (nf + 7) & ~(size_t)7);
        /* room for int16 but not asked (fast 0), and asked with one byte too few */
        assert_int_equal(cn_open_with(&a.dec, s.buf.p, s.buf.n, 0, b.ws, nf, &v, 0), CNERF_OK);
        assert_int_equal(cn_cstate_of(&a.dec)->k16, 0);
        assert_int_equal(cn_open_with(&a.dec, s.buf.p, s.buf.n, 0, b.ws, nf - 1, &v, 1), CNERF_OK);
        assert_int_equal(cn_cstate_of(&a.dec)->k16, 0);
        assert_int_equal(cn_open_with(&a.dec, s.buf.p, s.buf.n, 0, a.ws, n, &v, 1), CNERF_OK);
        assert_int_equal(cn_cstate_of(&a.dec)->k16, 0);
        assert_int_equal(cn_open_with(&b.dec, s.buf.p, s.buf.n, 0, b.ws, nf, &v, 1), CNERF_OK);
        assert_int_equal(cn_cstate_of(&b.dec)->k16, widens);
        for (unsigned l = 0; l < info->n_layers; l++)
            for (unsigned o = 0; o < info->layer[l].n_out; o++)
                for (unsigned i = 0; i < info->layer[l].n_in; i++)
                    assert_int_equal(cnerf_latent(&a.dec, l, o, i), cnerf_latent(&b.dec, l, o, i));
        cnerf_render_stats sa, sb;
        uint8_t *pa = render_counted(&a, &cam, 0u, &sa), *pb = render_counted(&b, &cam, 0u, &sb);
        assert_memory_equal(pa, pb, (size_t)cam.w * cam.h * 3);
        assert_true(sa.macs == sb.macs && sa.evals == sb.evals);
        if (widens)
            assert_true(sb.s8_macs == 0 && (sa.s8_macs > 0 || sa.list_macs > 0));
        else
            assert_true(sb.s8_macs == sa.s8_macs);
        free(pa);
        free(pb);
        free(a.ws);
        free(b.ws);
    }
    free_scene(&s);
}

/* cnerf_open_as: a device's forms, computed here: every named set opens the stream with the
 * layers its costs choose (the same as cn_open_with with that set's costs) and renders the
 * same pixels; an unknown name is refused and leaves the decoder zeroed. */
static void test_open_as(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 4, 24, 1);
    scene s;
    make_scene_edit(&s, &hdr, 3.0, 41, sparsify);
    const size_t n = cnerf_workspace_size(&s.dec.info);
    static const char *const sets[] = {"c", "dsp", "mve", "neon", "avx2"};
    cn_camera cam;
    look_at(&cam, 2.0, -2.5, 1.5, 15, 11, 50);
    cnerf_render_stats st0;
    uint8_t *px0 = render_counted(&s, &cam, 0u, &st0);
    unsigned listed = 0;
    for (size_t k = 0; k < sizeof sets / sizeof sets[0]; k++) {
        scene c = s;
        c.ws = aligned_alloc(CNERF_WS_ALIGN, (n + 7) & ~(size_t)7);
        assert_int_equal(cnerf_open_as(&c.dec, s.buf.p, s.buf.n, 0, c.ws, n, sets[k]), CNERF_OK);
        cn_dot_variant v;
        assert_true(cn_dot_variant_as(sets[k], &v));
        cnerf_decoder d;
        void *ws = aligned_alloc(CNERF_WS_ALIGN, (n + 7) & ~(size_t)7);
        assert_int_equal(cn_open_with(&d, s.buf.p, s.buf.n, 0, ws, n, &v, 0), CNERF_OK);
        for (unsigned l = 0; l < s.dec.info.n_layers; l++) {
            assert_int_equal(cn_cstate_of(&c.dec)->form[l], cn_cstate_of(&d)->form[l]);
            listed += cn_cstate_of(&c.dec)->form[l] == CN_FORM_SPARSE;
        }
        cnerf_render_stats st;
        uint8_t *px = render_counted(&c, &cam, 0u, &st);
        assert_memory_equal(px, px0, (size_t)cam.w * cam.h * 3);
        assert_true(st.macs == st0.macs && st.evals == st0.evals);
        free(px);
        free(ws);
        free(c.ws);
    }
    assert_true(listed > 0);
    cnerf_decoder bad;
    assert_int_equal(cnerf_open_as(&bad, s.buf.p, s.buf.n, 0, s.ws, n, "sse"), CNERF_E_NULL);
    assert_int_equal(bad.info.n_layers, 0);
    assert_int_equal(cnerf_open_as(&bad, s.buf.p, s.buf.n, 0, s.ws, n, NULL), CNERF_E_NULL);
    free(px0);
    free_scene(&s);
}

/* ---- several scenes: the shared shift's term ---- */

/* A set of two synthetic scenes of one topology (different bounds and backgrounds) with
 * shifts of `spread` at g = g_rel a, written, then opened per scene. */
typedef struct set2 {
    cn_buf buf;
    cn_synth syn[2];
    cn_synth_shift sh;
} set2;

static void make_set(set2 *t, double spread, double g_rel)
{
    char err[256];
    memset(t, 0, sizeof *t);
    cnerf_info hdr;
    tu_small_header(&hdr, 3, 16, 1);
    for (unsigned m = 0; m < 2; m++) {
        if (tu_synth(&t->syn[m], &hdr, 7 + m, 3.0, err, sizeof err))
            fail_msg("synth: %s", err);
        hdr.background[0] = 30; /* scene 1: another background and bounds */
        for (unsigned a = 0; a < 3; a++)
            hdr.aabb_q16[a + 3] += 1 << 15;
    }
    if (cn_synth_shift_make(&t->sh, &t->syn[0], 11, spread, g_rel, err, sizeof err))
        fail_msg("shift: %s", err);
    cn_stream_src src[2] = {t->syn[0].src, t->syn[1].src};
    if (cn_choose_scales_set(src, 2, t->sh.src, 3, NULL, err, sizeof err) ||
        cn_write_set(src, 2, t->sh.src, &t->buf, NULL, NULL, err, sizeof err))
        fail_msg("write: %s", err);
}

static void free_set(set2 *t)
{
    cn_synth_free(&t->syn[0]);
    cn_synth_free(&t->syn[1]);
    cn_synth_shift_free(&t->sh);
    free(t->buf.p);
}

static void open_in_set(scene *s, const set2 *t, unsigned m)
{
    char err[256];
    memset(s, 0, sizeof *s);
    assert_int_equal(tu_open_scene(&s->dec, t->buf.p, t->buf.n, m, &s->ws), CNERF_OK);
    assert_int_equal(cn_model_from_stream(&s->dec, &s->ref, err, sizeof err), 0);
    s->scratch_size = cnerf_render_scratch_size(&s->dec.info);
    s->scratch = aligned_alloc(8, (s->scratch_size + 7) & ~(size_t)7);
}

/* Each scene of a two-scene stream: its own latents and render parameters, the shared
 * shifts, and a picture that matches its float reference (W = a k + b + g s). */
static void test_two_scenes(void **state)
{
    (void)state;
    set2 t;
    make_set(&t, 0.8, 0.5);
    cn_camera cam;
    look_at(&cam, 2.5, -3.0, 2.0, 24, 20, 40);
    for (unsigned m = 0; m < 2; m++) {
        scene s;
        open_in_set(&s, &t, m);
        const cnerf_info *I = &s.dec.info;
        assert_int_equal(I->n_scenes, 2);
        assert_int_equal(I->scene, m);
        assert_int_equal(I->background[0], m ? 30 : t.syn[0].src.hdr.background[0]);
        uint32_t nonzero = 0;
        for (unsigned l = 0; l < I->n_layers; l++) {
            const cnerf_layer_info *L = &I->layer[l];
            for (uint32_t o = 0; o < L->n_out; o++)
                for (uint32_t i = 0; i < L->n_in; i++) {
                    const size_t k = (size_t)o * L->n_in + i;
                    assert_int_equal(cnerf_latent(&s.dec, l, o, i), t.syn[m].k[l][k]);
                    assert_int_equal(cnerf_shift(&s.dec, l, o, i), t.sh.s[l][k]);
                    nonzero += t.sh.s[l][k] != 0;
                }
        }
        assert_true(nonzero > 0);
        const cmp c = compare(&s, &cam, 7, NULL);
        printf("scene %u of 2, fixed vs float: %.2f dB, max diff %d, %zu scene pixels\n", m,
               c.psnr, c.maxdiff, c.n_scene);
        assert_true(c.psnr >= 50.0 && c.maxdiff <= 2 && c.n_scene > 0);
        free_scene(&s);
    }
    /* no third scene; peek says how many there are */
    cnerf_info *info = malloc(sizeof *info);
    assert_int_equal(cnerf_peek_scene(t.buf.p, t.buf.n, 2, info), CNERF_E_ARG);
    assert_int_equal(info->n_scenes, 2);
    free(info);
    cnerf_decoder dec;
    void *ws;
    assert_int_equal(tu_open_scene(&dec, t.buf.p, t.buf.n, 2, &ws), CNERF_E_ARG);
    free(ws);
    free_set(&t);
}

/* Shifts that are all 0 add nothing: each scene renders exactly as its own one-scene
 * stream. Non-zero ones change the picture (the term is not ignored). */
static void test_zero_shifts(void **state)
{
    (void)state;
    set2 z, t;
    make_set(&z, 0.0, 0.5);
    make_set(&t, 0.8, 0.5);
    cn_camera cam;
    look_at(&cam, 2.5, -3.0, 2.0, 24, 20, 40);
    for (unsigned m = 0; m < 2; m++) {
        scene sz, st, one;
        open_in_set(&sz, &z, m);
        open_in_set(&st, &t, m);
        for (unsigned l = 0; l < sz.dec.info.n_layers; l++)
            assert_null(cn_cstate_of(&sz.dec)->shift[l]);
        cn_stream_src src = z.syn[m].src;
        char err[256];
        assert_int_equal(cn_choose_scales(&src, 3, NULL, err, sizeof err), 0);
        memset(&one, 0, sizeof one);
        assert_int_equal(cn_write_stream(&src, &one.buf, NULL, err, sizeof err), 0);
        assert_int_equal(tu_open(&one.dec, one.buf.p, one.buf.n, &one.ws), CNERF_OK);
        assert_int_equal(cn_model_from_stream(&one.dec, &one.ref, err, sizeof err), 0);
        one.scratch_size = cnerf_render_scratch_size(&one.dec.info);
        one.scratch = aligned_alloc(8, (one.scratch_size + 7) & ~(size_t)7);
        const size_t n = (size_t)cam.w * cam.h * 3;
        uint8_t *a = malloc(n), *b = malloc(n), *c = malloc(n);
        compare(&sz, &cam, 7, a);
        compare(&one, &cam, 7, b);
        compare(&st, &cam, 7, c);
        assert_memory_equal(a, b, n);
        assert_true(memcmp(a, c, n) != 0);
        free(a);
        free(b);
        free(c);
        free_scene(&one);
        free_scene(&sz);
        free_scene(&st);
    }
    free_set(&z);
    free_set(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mul_exp),
        cmocka_unit_test(test_rgb565),
        cmocka_unit_test(test_sparse_exact),
        cmocka_unit_test(test_open_as),
        cmocka_unit_test(test_open_fast),
        cmocka_unit_test(test_div_sqrt),
        cmocka_unit_test(test_matches_float),
        cmocka_unit_test(test_rays_miss),
        cmocka_unit_test(test_inside_and_axes),
        cmocka_unit_test(test_near_far),
        cmocka_unit_test(test_saturation),
        cmocka_unit_test(test_zero_layers),
        cmocka_unit_test(test_extreme_values),
        cmocka_unit_test(test_far_points),
        cmocka_unit_test(test_tilings),
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_knobs),
        cmocka_unit_test(test_ndc),
        cmocka_unit_test(test_contract),
        cmocka_unit_test(test_grid),
        cmocka_unit_test(test_rule_out_exact),
        cmocka_unit_test(test_macs_counted),
        cmocka_unit_test(test_grid_cell_mapping),
        cmocka_unit_test(test_zero_rows),
        cmocka_unit_test(test_two_scenes),
        cmocka_unit_test(test_zero_shifts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
