/* cnerf_camera_look_at (decoder/camera.c): the integer camera against the same camera built
 * in double precision and converted (cnerf_camera_from_float), its refusals, and renders
 * with it. */
#include <math.h>
#include <stdlib.h>

#include "cn_buf.h"
#include "cn_fixcam.h"
#include "cn_render.h"
#include "cn_synth.h"
#include "testutil.h"

/* The look-at camera in double precision: eye, target and up in scene units. */
static void float_look_at(const double eye[3], const double target[3], const double up[3],
                          double fov_deg, int w, int h, cn_camera *c)
{
    double f[3], r[3], u[3], n = 0;
    for (int a = 0; a < 3; a++)
        f[a] = target[a] - eye[a], n += f[a] * f[a];
    for (int a = 0; a < 3; a++)
        f[a] /= sqrt(n);
    r[0] = f[1] * up[2] - f[2] * up[1];
    r[1] = f[2] * up[0] - f[0] * up[2];
    r[2] = f[0] * up[1] - f[1] * up[0];
    n = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    for (int a = 0; a < 3; a++)
        r[a] /= n;
    u[0] = r[1] * f[2] - r[2] * f[1];
    u[1] = r[2] * f[0] - r[0] * f[2];
    u[2] = r[0] * f[1] - r[1] * f[0];
    for (int a = 0; a < 3; a++) { /* within [-1, 1] despite rounding, as from_float requires */
        c->c2w[a][0] = fmax(-1.0, fmin(1.0, r[a]));
        c->c2w[a][1] = fmax(-1.0, fmin(1.0, u[a]));
        c->c2w[a][2] = fmax(-1.0, fmin(1.0, -f[a]));
        c->c2w[a][3] = eye[a];
    }
    c->w = w, c->h = h;
    c->fx = c->fy = 0.5 * w / tan(0.5 * fov_deg * M_PI / 180.0);
    c->cx = 0.5 * w, c->cy = 0.5 * h;
}

static int32_t q16(double x) { return (int32_t)llround(x * 65536.0); }

/* Orbits of every radius, elevation and field of view, non-square images, targets off the
 * origin and tilted up vectors: the rotation within 2^-26 of the double one, the centre
 * exact, the focal length within 5e-6 of it (the sine table's interpolation). */
static void test_look_at_matches_float(void **state)
{
    (void)state;
    int n = 0;
    double worst_rot = 0, worst_f = 0;
    for (int k = 0; k < 7; k++)
        for (int e = -80; e <= 80; e += 40)
            for (int fi = 0; fi < 4; fi++) {
                const double radii[4] = {0.25, 4.0, 37.5, 3000.0};
                const double fovs[4] = {1.0, 23.5, 40.0, 120.0};
                const double th = 2 * M_PI * k / 7 + 0.1, ph = e * M_PI / 180, R = radii[fi];
                const double tgt[3] = {0.5 * (k - 3), -0.25 * fi, 0.125 * e / 40};
                const double eye[3] = {tgt[0] + R * cos(ph) * cos(th),
                                       tgt[1] + R * cos(ph) * sin(th), tgt[2] + R * sin(ph)};
                const double up[3] = {0.05 * (k % 3), -0.03 * fi, 1.0};
                const int32_t ei[3] = {q16(eye[0]), q16(eye[1]), q16(eye[2])};
                const int32_t ti[3] = {q16(tgt[0]), q16(tgt[1]), q16(tgt[2])};
                const int32_t ui[3] = {q16(up[0]), q16(up[1]), q16(up[2])};
                const double ed[3] = {ei[0] / 65536.0, ei[1] / 65536.0, ei[2] / 65536.0};
                const double td[3] = {ti[0] / 65536.0, ti[1] / 65536.0, ti[2] / 65536.0};
                const double ud[3] = {ui[0] / 65536.0, ui[1] / 65536.0, ui[2] / 65536.0};
                const int w = 1 + 37 * k + 13 * fi, h = 1 + 29 * (6 - k) + 7 * fi;
                cnerf_camera got, want;
                cn_camera fc;
                float_look_at(ed, td, ud, fovs[fi], w, h, &fc);
                char err[256];
                if (cnerf_camera_from_float(&fc, &want, err, sizeof err))
                    fail_msg("k %d e %d fi %d: %s", k, e, fi, err);
                assert_int_equal(cnerf_camera_look_at(&got, ei, ti, ui, q16(fovs[fi]),
                                                      (uint16_t)w, (uint16_t)h), CNERF_OK);
                for (int i = 0; i < 9; i++) {
                    const double d = fabs((double)got.rot[i] - want.rot[i]) / (1 << 30);
                    worst_rot = d > worst_rot ? d : worst_rot;
                    if (d > 1.0 / (1 << 26))
                        print_message("k %d e %d fi %d rot[%d] %d against %d\n", k, e, fi, i,
                                      got.rot[i], want.rot[i]);
                    assert_true(d <= 1.0 / (1 << 26));
                }
                for (int a = 0; a < 3; a++)
                    assert_true(got.pos[a] == (int64_t)ei[a] * 65536);
                const double df = fabs((double)got.fx - want.fx) / want.fx;
                worst_f = df > worst_f ? df : worst_f;
                assert_true(df <= 5e-6);
                assert_int_equal(got.fx, got.fy);
                assert_int_equal(got.cx, w * 32768);
                assert_int_equal(got.cy, h * 32768);
                assert_int_equal(got.width, w);
                assert_int_equal(got.height, h);
                n++;
            }
    print_message("%d cameras: rotation within %.3g, focal length within %.3g of double\n",
                  n, worst_rot, worst_f);
}

/* Every camera that cannot be made is refused, each by itself. */
static void test_look_at_refusals(void **state)
{
    (void)state;
    cnerf_camera c;
    const int32_t eye[3] = {0, -4 * 65536, 65536}, target[3] = {0, 0, 0}, up[3] = {0, 0, 65536};
    const int32_t fov = 40 * 65536;
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, fov, 64, 48), CNERF_OK);
    assert_int_equal(cnerf_camera_look_at(NULL, eye, target, up, fov, 64, 48), CNERF_E_NULL);
    assert_int_equal(cnerf_camera_look_at(&c, NULL, target, up, fov, 64, 48), CNERF_E_NULL);
    assert_int_equal(cnerf_camera_look_at(&c, eye, eye, up, fov, 64, 48), CNERF_E_ARG);
    const int32_t zero[3] = {0, 0, 0};
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, zero, fov, 64, 48), CNERF_E_ARG);
    /* up along the view, and within a tenth of a degree of it; at 3 degrees accepted */
    const int32_t along[3] = {0, 4 * 65536, -65536};
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, along, fov, 64, 48), CNERF_E_ARG);
    const int32_t near_along[3] = {114, 4 * 65536, -65536};
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, near_along, fov, 64, 48),
                     CNERF_E_ARG);
    const int32_t off3[3] = {q16(4.123 * tan(3 * M_PI / 180)), 4 * 65536, -65536};
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, off3, fov, 64, 48), CNERF_OK);
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, CNERF_FOV_MIN_Q16 - 1, 64, 48),
                     CNERF_E_ARG);
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, CNERF_FOV_MAX_Q16 + 1, 64, 48),
                     CNERF_E_ARG);
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, CNERF_FOV_MAX_Q16, 64, 48),
                     CNERF_OK);
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, fov, 0, 48), CNERF_E_ARG);
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, fov, 64, 0), CNERF_E_ARG);
    /* the extremes of the inputs */
    const int32_t far_eye[3] = {INT32_MAX, INT32_MIN, INT32_MAX};
    assert_int_equal(cnerf_camera_look_at(&c, far_eye, target, up, fov, 64, 48), CNERF_OK);
    const int32_t big_up[3] = {INT32_MIN, INT32_MIN, INT32_MAX};
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, big_up, fov, 64, 48), CNERF_OK);
    /* the focal length in Q16 must fit an int32: below 32,768 pixels */
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, CNERF_FOV_MAX_Q16, 65535, 65535),
                     CNERF_OK);
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, 89 * 65536, 65535, 65535),
                     CNERF_E_ARG);
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, 91 * 65536, 65535, 65535),
                     CNERF_OK);
}

/* A look-at camera renders a synthetic model, and the same camera built in double renders
 * it with at most rounding differences (the cameras differ by a few units in the last
 * place). */
static void test_look_at_renders(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 16, 1);
    cn_buf stream = {0};
    cn_synth model;
    tu_synth_stream(&hdr, 7, 1.0, &stream, &model);
    cnerf_decoder dec;
    void *ws;
    assert_int_equal(tu_open(&dec, stream.p, stream.n, &ws), CNERF_OK);
    const size_t sn = cnerf_render_scratch_size(&dec.info);
    void *sc = aligned_alloc(CNERF_WS_ALIGN, (sn + CNERF_WS_ALIGN - 1) / CNERF_WS_ALIGN * CNERF_WS_ALIGN);
    assert_non_null(sc);
    const int32_t eye[3] = {q16(2.5), q16(-3.0), q16(1.5)}, target[3] = {0, 0, 0};
    const int32_t up[3] = {0, 0, 1 << 16};
    cnerf_camera c;
    assert_int_equal(cnerf_camera_look_at(&c, eye, target, up, 45 << 16, 24, 16), CNERF_OK);
    uint8_t a[24 * 16 * 3], b[24 * 16 * 3];
    assert_int_equal(cnerf_render_tile(&dec, &c, NULL, 0, 0, 24, 16, a, 24 * 3, sc, sn), CNERF_OK);
    cn_camera fc;
    const double ed[3] = {2.5, -3.0, 1.5}, td[3] = {0, 0, 0}, ud[3] = {0, 0, 1};
    float_look_at(ed, td, ud, 45.0, 24, 16, &fc);
    cnerf_camera cf;
    char err[256];
    assert_int_equal(cnerf_camera_from_float(&fc, &cf, err, sizeof err), 0);
    assert_int_equal(cnerf_render_tile(&dec, &cf, NULL, 0, 0, 24, 16, b, 24 * 3, sc, sn), CNERF_OK);
    int maxd = 0;
    for (size_t i = 0; i < sizeof a; i++) {
        const int d = abs((int)a[i] - (int)b[i]);
        maxd = d > maxd ? d : maxd;
    }
    assert_true(maxd <= 2);
    free(sc);
    free(ws);
    cn_buf_free(&stream);
    cn_synth_free(&model);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_look_at_matches_float),
        cmocka_unit_test(test_look_at_refusals),
        cmocka_unit_test(test_look_at_renders),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
