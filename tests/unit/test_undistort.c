/* Lens distortion (cn_undistort.h): a synthetic distorted camera photographs known points;
 * after undistortion each lands on the pixel that the pinhole camera with the returned focal
 * scale projects it to. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_undistort.h"
#include "testutil.h"

#define W 160
#define H 120

/* A photo of bright dots at the points (x, y) (normalised pinhole coordinates), taken
 * through lens l: each dot is a Gaussian of 1.5 pixels around where the lens puts it. */
static void photograph(const cn_lens *l, double fx, double fy, double cx, double cy,
                       const double (*pts)[2], int n, cn_image *im)
{
    im->w = W;
    im->h = H;
    im->c = 3;
    im->px = calloc((size_t)W * H * 3, sizeof(float));
    assert_non_null(im->px);
    for (int i = 0; i < n; i++) {
        double xd, yd;
        cn_lens_distort(l, pts[i][0], pts[i][1], &xd, &yd);
        const double u = fx * xd + cx, v = fy * yd + cy;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const double d2 = (x + 0.5 - u) * (x + 0.5 - u) + (y + 0.5 - v) * (y + 0.5 - v);
                const float g = (float)exp(-d2 / (2 * 1.5 * 1.5));
                for (int k = 0; k < 3; k++)
                    im->px[((size_t)y * W + x) * 3 + k] += g;
            }
    }
}

/* The centroid of the dot near (u, v), in continuous pixel coordinates. */
static void centroid(const cn_image *im, double u, double v, double *cu, double *cv)
{
    double s = 0, su = 0, sv = 0;
    for (int y = (int)v - 6; y <= (int)v + 6; y++)
        for (int x = (int)u - 6; x <= (int)u + 6; x++) {
            if (x < 0 || y < 0 || x >= im->w || y >= im->h)
                continue;
            const double g = im->px[((size_t)y * im->w + x) * 3];
            if (g < 0.05)
                continue;
            s += g;
            su += g * (x + 0.5);
            sv += g * (y + 0.5);
        }
    assert_true(s > 0);
    *cu = su / s;
    *cv = sv / s;
}

static void check_lens(const cn_lens *l, const char *name)
{
    const double fx = 110, fy = 104, cx = 81.3, cy = 58.6;
    static const double pts[][2] = {{0, 0},     {0.35, -0.25}, {-0.4, 0.3},
                                    {0.5, 0.38}, {-0.55, -0.4}, {0.1, 0.45}};
    const int n = (int)(sizeof pts / sizeof pts[0]);
    cn_image photo, out;
    photograph(l, fx, fy, cx, cy, pts, n, &photo);
    double s;
    char err[256];
    assert_int_equal(cn_undistort(&photo, l, fx, fy, cx, cy, &out, &s, err, sizeof err), 0);
    assert_int_equal(out.w, W);
    assert_int_equal(out.h, H);
    double worst = 0;
    for (int i = 0; i < n; i++) {
        const double u = s * fx * pts[i][0] + cx, v = s * fy * pts[i][1] + cy;
        if (u < 8 || v < 8 || u > W - 8 || v > H - 8)
            continue; /* cropped by the scale */
        double cu, cv;
        centroid(&out, u, v, &cu, &cv);
        const double e = hypot(cu - u, cv - v);
        worst = e > worst ? e : worst;
    }
    print_message("# %s: focal scale %.4f, worst dot %.3f pixels from its projection\n", name,
                  s, worst);
    assert_true(worst < 0.2);
    /* No blank border: the corners see the photo. */
    for (int k = 0; k < 3; k++)
        assert_true(isfinite(out.px[k]));
    cn_image_free(&photo);
    cn_image_free(&out);
}

static void test_points_land_on_their_pixels(void **state)
{
    (void)state;
    check_lens(&(cn_lens){CN_LENS_OPENCV, -0.25, 0.06, 0, 0, 0.002, -0.003}, "barrel");
    check_lens(&(cn_lens){CN_LENS_OPENCV, 0.18, 0.02, 0.01, 0, 0, 0}, "pincushion");
    check_lens(&(cn_lens){CN_LENS_FISHEYE, 0.05, -0.01, 0.002, 0, 0, 0}, "fisheye");
    check_lens(&(cn_lens){CN_LENS_OPENCV, 0, 0, 0, 0, 0, 0}, "pinhole");
}

/* The models against values worked by hand. */
static void test_models(void **state)
{
    (void)state;
    double xd, yd;
    cn_lens_distort(&(cn_lens){CN_LENS_OPENCV, 0.1, 0.01, 0.001, 0, 0.002, 0.003}, 0.3, -0.4,
                    &xd, &yd);
    /* r2 = 0.25, radial = 1 + 0.025 + 0.000625 + 0.000015625 */
    const double radial = 1.025640625;
    assert_true(fabs(xd - (0.3 * radial + 2 * 0.002 * 0.3 * -0.4 + 0.003 * (0.25 + 0.18))) <
                1e-15);
    assert_true(fabs(yd - (-0.4 * radial + 0.002 * (0.25 + 0.32) + 2 * 0.003 * 0.3 * -0.4)) <
                1e-15);
    cn_lens_distort(&(cn_lens){CN_LENS_FISHEYE, 0, 0, 0, 0, 0, 0}, 1, 0, &xd, &yd);
    assert_true(fabs(xd - M_PI / 4) < 1e-15 && yd == 0); /* equidistant: r = theta */
    assert_false(cn_lens_distorts(&(cn_lens){CN_LENS_OPENCV, 0, 0, 0, 0, 0, 0}));
    assert_true(cn_lens_distorts(&(cn_lens){CN_LENS_OPENCV, 0, 0, 0, 0, 0, 1e-4}));
    assert_true(cn_lens_distorts(&(cn_lens){CN_LENS_FISHEYE, 0, 0, 0, 0, 0, 0}));
}

/* A lens that folds the image back on itself cannot be undistorted without a blank border
 * at any scale up to 8: refused with a message. */
static void test_too_strong(void **state)
{
    (void)state;
    cn_image photo = {W, H, 3, calloc((size_t)W * H * 3, sizeof(float))}, out;
    assert_non_null(photo.px);
    double s;
    char err[256];
    const cn_lens l = {CN_LENS_OPENCV, 40, 0, 0, 0, 0, 0};
    assert_int_equal(cn_undistort(&photo, &l, 0.5, 0.5, 80, 60, &out, &s, err, sizeof err), -1);
    assert_non_null(strstr(err, "too strong"));
    assert_null(out.px);
    cn_image_free(&photo);
}

/* cn_lens_check: lenses that real calibrations give pass; coefficients that fold the image
 * (the distortion turns back, or the Jacobian changes sign, inside the image) are refused,
 * whichever model; what lies beyond the image's border does not count. */
static void test_lens_check(void **state)
{
    (void)state;
    char why[256];
    const double w = 400, h = 300, f = 300, cx = 200, cy = 150;
    const cn_lens ok[] = {{CN_LENS_PINHOLE, 0, 0, 0, 0, 0, 0},
                          {CN_LENS_OPENCV, -0.05, 0.01, 0, 0, 0.001, -0.001},
                          {CN_LENS_OPENCV, 0.2, 0, 0, 0, 0, 0},
                          {CN_LENS_FISHEYE, 0.01, -0.005, 0, 0, 0, 0}};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++)
        assert_int_equal(cn_lens_check(&ok[i], w, h, f, f, cx, cy, why, sizeof why), 0);
    const cn_lens bad[] = {{CN_LENS_OPENCV, -5, 0, 0, 0, 0, 0},
                           {CN_LENS_OPENCV, 0, 0, 0, 0, 3, -3},
                           {CN_LENS_FISHEYE, -5, 3, 0, 0, 0, 0},
                           {CN_LENS_OPENCV, -0.6, 0, 0, 0, 0, 0}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        why[0] = 0;
        assert_int_equal(cn_lens_check(&bad[i], w, h, f, f, cx, cy, why, sizeof why), -1);
        assert_non_null(strstr(why, "turns back"));
    }
    /* k1 = -0.6 turns back at r = 0.745 (rd 0.497): inside a wide image, beyond a narrow one */
    const cn_lens k = {CN_LENS_OPENCV, -0.6, 0, 0, 0, 0, 0};
    assert_int_equal(cn_lens_check(&k, w, h, 1000, 1000, cx, cy, why, sizeof why), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_models),
        cmocka_unit_test(test_points_land_on_their_pixels),
        cmocka_unit_test(test_too_strong),
        cmocka_unit_test(test_lens_check),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
