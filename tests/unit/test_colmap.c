/* COLMAP sparse models (cn_colmap.h) and the COLMAP layout of the dataset loader: a synthetic
 * capture written here in COLMAP's text and binary forms, with known cameras and points. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_colmap.h"
#include "cn_dataset.h"
#include "cn_image.h"
#include "cn_rng.h"
#include "cn_buf.h"
#include "cn_file.h"
#include "testutil.h"

#define TMP CNERF_BINARY_DIR "/test_colmap_tmp"
#define N_CAMS 12
#define N_PTS 300
#define IW 40
#define IH 30

/* The capture: N_CAMS cameras (OPENCV, one shared camera) on a tilted ring around CENTRE,
 * each looking at it, and points scattered within 0.8 of it. */
static const double CENTRE[3] = {1.0, -2.0, 0.5};
static const double CAM_PARAMS[8] = {36, 35, 20.5, 14.8, -0.05, 0.01, 0.001, -0.002};

typedef struct pose {
    double R[3][3], t[3], q[4]; /* world-to-camera, OpenCV axes */
} pose;

static void rot_to_quat(const double R[3][3], double q[4])
{
    const double tr = R[0][0] + R[1][1] + R[2][2];
    const double w = sqrt(fmax(0, 1 + tr)) / 2;
    q[0] = w;
    q[1] = (R[2][1] - R[1][2]) / (4 * w);
    q[2] = (R[0][2] - R[2][0]) / (4 * w);
    q[3] = (R[1][0] - R[0][1]) / (4 * w);
}

static void normalize(double v[3])
{
    const double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; i++)
        v[i] /= n;
}

static void cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* Camera i at a point of the ring (radius 5, tilted), looking at `look` (forward-facing
 * captures look along one direction instead). */
static void make_pose(int i, int forward, pose *p)
{
    const double a = 2 * M_PI * i / N_CAMS;
    double c[3], f[3];
    if (forward) {
        c[0] = CENTRE[0] + 0.3 * cos(a);
        c[1] = CENTRE[1] + 0.2 * sin(a);
        c[2] = CENTRE[2] - 6;
        f[0] = 0.02 * cos(a);
        f[1] = 0.02 * sin(a);
        f[2] = 1;
    } else {
        c[0] = CENTRE[0] + 5 * cos(a);
        c[1] = CENTRE[1] + 5 * sin(a) * 0.9;
        c[2] = CENTRE[2] + 2 + 5 * sin(a) * 0.3;
        for (int k = 0; k < 3; k++)
            f[k] = CENTRE[k] - c[k];
    }
    normalize(f);
    /* OpenCV axes: x right, y down, z forward; world "down" is roughly -z with a tilt */
    double down[3] = {0.1, 0.05, -1}, x[3], y[3];
    cross(down, f, x); /* right = down x forward */
    normalize(x);
    cross(f, x, y);
    for (int k = 0; k < 3; k++) {
        p->R[0][k] = x[k];
        p->R[1][k] = y[k];
        p->R[2][k] = f[k];
    }
    for (int r = 0; r < 3; r++)
        p->t[r] = -(p->R[r][0] * c[0] + p->R[r][1] * c[1] + p->R[r][2] * c[2]);
    rot_to_quat(p->R, p->q);
}

static void write_file(const char *dir, const char *name, const void *p, size_t n)
{
    char path[2200], err[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    cn_inputs_clear(); /* as a new run: a load before recorded its files as its inputs */
    assert_int_equal(cn_write_file_atomic(path, p, n, err, sizeof err), 0);
}

static void points(double (*xyz)[3])
{
    cn_rng r = cn_rng_seed(11);
    for (int i = 0; i < N_PTS; i++)
        for (int k = 0; k < 3; k++)
            xyz[i][k] = CENTRE[k] + 0.8 * (2 * cn_rng_uniform(&r) - 1);
}

/* A capture in DIR: images/ (IW x IH PNGs) and sparse/0/ in text or binary form; `model`
 * replaces the camera's model name (text only), `missing` leaves one image out. */
static void make_capture(const char *dir, int binary, int forward, const char *model,
                         int missing)
{
    char cmd[1200], sub[1024], err[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s && mkdir -p %s/images %s/sparse/0", dir, dir, dir);
    assert_int_equal(system(cmd), 0);
    snprintf(sub, sizeof sub, "%s/sparse/0", dir);
    double xyz[N_PTS][3];
    points(xyz);
    pose P[N_CAMS];
    for (int i = 0; i < N_CAMS; i++)
        make_pose(i, forward, &P[i]);
    uint8_t px[IW * IH * 3];
    memset(px, 120, sizeof px);
    for (int i = 0; i < N_CAMS; i++) {
        char path[1100];
        snprintf(path, sizeof path, "%s/images/img_%02d.png", dir, i);
        if (i != missing)
            assert_int_equal(cn_png_write_rgb8(path, px, IW, IH, IW * 3, err, sizeof err), 0);
    }
    cn_buf cam = {0}, img = {0}, pts = {0};
    if (binary) {
        cn_buf_u64(&cam, 1);
        cn_buf_u32(&cam, 7);
        cn_buf_u32(&cam, 4); /* OPENCV */
        cn_buf_u64(&cam, IW);
        cn_buf_u64(&cam, IH);
        for (int k = 0; k < 8; k++)
            cn_buf_f64(&cam, CAM_PARAMS[k]);
        cn_buf_u64(&img, N_CAMS);
        for (int i = N_CAMS - 1; i >= 0; i--) { /* out of order: the loader sorts by name */
            cn_buf_u32(&img, 100 + (uint32_t)i);
            for (int k = 0; k < 4; k++)
                cn_buf_f64(&img, P[i].q[k]);
            for (int k = 0; k < 3; k++)
                cn_buf_f64(&img, P[i].t[k]);
            cn_buf_u32(&img, 7);
            char name[32];
            snprintf(name, sizeof name, "img_%02d.png", i);
            cn_buf_put(&img, name, strlen(name) + 1);
            cn_buf_u64(&img, 1); /* one 2D point */
            cn_buf_f64(&img, 3.5);
            cn_buf_f64(&img, 4.5);
            cn_buf_u64(&img, (uint64_t)-1);
        }
        cn_buf_u64(&pts, N_PTS);
        for (int i = 0; i < N_PTS; i++) {
            cn_buf_u64(&pts, (uint64_t)i + 1);
            for (int k = 0; k < 3; k++)
                cn_buf_f64(&pts, xyz[i][k]);
            cn_buf_put(&pts, "\x10\x20\x30", 3);
            cn_buf_f64(&pts, 0.5);
            cn_buf_u64(&pts, 2);
            cn_buf_u32(&pts, 100);
            cn_buf_u32(&pts, 0);
            cn_buf_u32(&pts, 101);
            cn_buf_u32(&pts, 0);
        }
        write_file(sub, "cameras.bin", cam.p, cam.n);
        write_file(sub, "images.bin", img.p, img.n);
        write_file(sub, "points3D.bin", pts.p, pts.n);
    } else {
        char line[512];
        int n = snprintf(line, sizeof line, "# Camera list\n7 %s %d %d", model ? model : "OPENCV",
                         IW, IH);
        cn_buf_put(&cam, line, (size_t)n);
        for (int k = 0; k < 8; k++) {
            n = snprintf(line, sizeof line, " %.17g", CAM_PARAMS[k]);
            cn_buf_put(&cam, line, (size_t)n);
        }
        cn_buf_put(&cam, "\n", 1);
        cn_buf_put(&img, "# Image list\n", 13);
        for (int i = 0; i < N_CAMS; i++) {
            n = snprintf(line, sizeof line, "%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g 7 "
                         "img_%02d.png\n%s\n", 100 + i, P[i].q[0], P[i].q[1], P[i].q[2], P[i].q[3],
                         P[i].t[0], P[i].t[1], P[i].t[2], i, i % 2 ? "3.5 4.5 -1" : "");
            cn_buf_put(&img, line, (size_t)n);
        }
        for (int i = 0; i < N_PTS; i++) {
            n = snprintf(line, sizeof line, "%d %.17g %.17g %.17g 16 32 48 0.5 100 0 101 0\n",
                         i + 1, xyz[i][0], xyz[i][1], xyz[i][2]);
            cn_buf_put(&pts, line, (size_t)n);
        }
        write_file(sub, "cameras.txt", cam.p, cam.n);
        write_file(sub, "images.txt", img.p, img.n);
        write_file(sub, "points3D.txt", pts.p, pts.n);
    }
    cn_buf_free(&cam);
    cn_buf_free(&img);
    cn_buf_free(&pts);
}

/* All views of a dataset in name order: the test views are images 0 and 8. */
static const cn_view *view_of(const cn_dataset *ds, int i)
{
    return i % 8 == 0 ? &ds->test[i / 8] : &ds->train[i - 1 - i / 8];
}

/* The ray of view v through continuous pixel (u, w), as the renderers make it. */
static void ray(const cn_view *v, double u, double w, double o[3], double d[3])
{
    const double x = (u - v->cx) / v->fx, y = -(w - v->cy) / v->fy;
    for (int r = 0; r < 3; r++) {
        o[r] = v->c2w[r][3];
        d[r] = x * v->c2w[r][0] + y * v->c2w[r][1] - v->c2w[r][2];
    }
    normalize(d);
}

/* Where COLMAP's camera i puts world point X, undistorted (pinhole with the loaded focal
 * lengths' scale s relative to the file's). */
static void project(int forward, int i, const double X[3], double s, double *u, double *w)
{
    pose P;
    make_pose(i, forward, &P);
    double c[3];
    for (int r = 0; r < 3; r++)
        c[r] = P.R[r][0] * X[0] + P.R[r][1] * X[1] + P.R[r][2] * X[2] + P.t[r];
    *u = s * CAM_PARAMS[0] * c[0] / c[2] + CAM_PARAMS[2];
    *w = s * CAM_PARAMS[1] * c[1] / c[2] + CAM_PARAMS[3];
}

/* The rays of every view through a world point's projection meet in one point: the
 * conversion of COLMAP's poses and the normalisation keep the geometry. */
static double rays_meet(const cn_dataset *ds, int forward, const double X[3])
{
    double A[3][3] = {{0}}, b[3] = {0};
    double o[N_CAMS][3], d[N_CAMS][3];
    const double s = view_of(ds, 1)->fx / CAM_PARAMS[0];
    for (int i = 0; i < N_CAMS; i++) {
        double u, w;
        project(forward, i, X, s, &u, &w);
        ray(view_of(ds, i), u, w, o[i], d[i]);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) {
                const double a = (r == c) - d[i][r] * d[i][c];
                A[r][c] += a;
                b[r] += a * o[i][c];
            }
    }
    /* least-squares meeting point by Gaussian elimination */
    double M[3][4];
    for (int r = 0; r < 3; r++) {
        memcpy(M[r], A[r], sizeof A[r]);
        M[r][3] = b[r];
    }
    for (int c = 0; c < 3; c++)
        for (int r = c + 1; r < 3; r++) {
            const double f = M[r][c] / M[c][c];
            for (int k = c; k < 4; k++)
                M[r][k] -= f * M[c][k];
        }
    double p[3];
    for (int r = 2; r >= 0; r--) {
        p[r] = M[r][3];
        for (int k = r + 1; k < 3; k++)
            p[r] -= M[r][k] * p[k];
        p[r] /= M[r][r];
    }
    double worst = 0;
    for (int i = 0; i < N_CAMS; i++) {
        double v[3], t = 0;
        for (int r = 0; r < 3; r++)
            v[r] = p[r] - o[i][r];
        for (int r = 0; r < 3; r++)
            t += v[r] * d[i][r];
        const double e = sqrt(fmax(0, v[0] * v[0] + v[1] * v[1] + v[2] * v[2] - t * t));
        worst = e > worst ? e : worst;
    }
    return worst;
}

static void test_inward_capture(void **state)
{
    (void)state;
    char err[512];
    cn_dataset ds[2];
    for (int binary = 0; binary < 2; binary++) {
        make_capture(TMP "/ring", binary, 0, NULL, -1);
        assert_int_equal(cn_dataset_load(TMP "/ring", NULL, &ds[binary], err, sizeof err), 0);
        assert_int_equal(ds[binary].kind, CN_DS_COLMAP);
        assert_int_equal(ds[binary].ndc, 0);
        assert_int_equal(ds[binary].n_train + ds[binary].n_test, N_CAMS);
        assert_int_equal(ds[binary].n_test, 2);
        /* normalised: mean distance 4 from the look-at point, up is +z */
        double dist = 0, upz = 0;
        for (int i = 0; i < N_CAMS; i++) {
            const cn_view *v = view_of(&ds[binary], i);
            dist += sqrt(v->c2w[0][3] * v->c2w[0][3] + v->c2w[1][3] * v->c2w[1][3] +
                         v->c2w[2][3] * v->c2w[2][3]) / N_CAMS;
            upz += v->c2w[2][1] / N_CAMS;
        }
        assert_true(fabs(dist - 4) < 1e-9);
        assert_true(upz > 0.9);
        /* bounds from the points: the cloud (radius up to 1.4) seen from about 4 away */
        print_message("# %s: near %.3f far %.3f\n", binary ? "binary" : "text", ds[binary].near,
                      ds[binary].far);
        assert_true(ds[binary].near > 1.5 && ds[binary].near < 4);
        assert_true(ds[binary].far > 4 && ds[binary].far < 7);
        const double X[3] = {1.3, -1.8, 0.2}, Y[3] = {0.6, -2.5, 0.9};
        assert_true(rays_meet(&ds[binary], 0, X) < 1e-6);
        assert_true(rays_meet(&ds[binary], 0, Y) < 1e-6);
    }
    /* the two forms load the same */
    for (int i = 0; i < N_CAMS; i++) {
        const cn_view *a = view_of(&ds[0], i), *b = view_of(&ds[1], i);
        assert_string_equal(a->name, b->name);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++)
                assert_true(fabs(a->c2w[r][c] - b->c2w[r][c]) < 1e-12);
        assert_true(fabs(a->fx - b->fx) < 1e-12 && fabs(a->cy - b->cy) < 1e-12);
    }
    cn_dataset_free(&ds[0]);
    cn_dataset_free(&ds[1]);
    /* Without points3D: near 0.05, far twice the farthest camera (mean distance 4). */
    assert_int_equal(remove(TMP "/ring/sparse/0/points3D.bin"), 0);
    assert_int_equal(cn_dataset_load(TMP "/ring", NULL, &ds[0], err, sizeof err), 0);
    assert_true(ds[0].near == 0.05);
    assert_true(ds[0].far >= 8 && ds[0].far < 12);
    cn_dataset_free(&ds[0]);
}

/* Cameras that all look one way take LLFF's conventions: NDC, bounds from the points. */
static void test_forward_capture(void **state)
{
    (void)state;
    char err[512];
    cn_dataset ds;
    make_capture(TMP "/front", 1, 1, NULL, -1);
    assert_int_equal(cn_dataset_load(TMP "/front", NULL, &ds, err, sizeof err), 0);
    assert_int_equal(ds.ndc, 1);
    assert_true(ds.near > 0 && ds.near < ds.far);
    const double X[3] = {1.3, -1.8, 0.2};
    assert_true(rays_meet(&ds, 1, X) < 1e-6);
    cn_dataset_free(&ds);
    /* NDC needs depth bounds, which only the points give. */
    assert_int_equal(remove(TMP "/front/sparse/0/points3D.bin"), 0);
    assert_int_equal(cn_dataset_load(TMP "/front", NULL, &ds, err, sizeof err), -1);
    assert_non_null(strstr(err, "a forward-facing capture needs the sparse points"));
}

/* images_2/ holds the images at half size: --downscale 2 reads them as they are. */
static void test_reduced_images(void **state)
{
    (void)state;
    char err[512], path[600];
    make_capture(TMP "/half", 1, 0, NULL, -1);
    assert_int_equal(system("mkdir -p " TMP "/half/images_2"), 0);
    uint8_t px[IW / 2 * IH / 2 * 3];
    memset(px, 200, sizeof px);
    for (int i = 0; i < N_CAMS; i++) {
        snprintf(path, sizeof path, TMP "/half/images_2/img_%02d.png", i);
        assert_int_equal(cn_png_write_rgb8(path, px, IW / 2, IH / 2, IW / 2 * 3, err,
                                           sizeof err), 0);
    }
    cn_dataset full, half;
    assert_int_equal(cn_dataset_load(TMP "/half", NULL, &full, err, sizeof err), 0);
    assert_int_equal(cn_dataset_load(TMP "/half", &(cn_dataset_opts){.downscale = 2}, &half, err,
                                     sizeof err), 0);
    assert_int_equal(half.train[0].w, IW / 2);
    assert_true(fabsf(half.train[0].rgb[0] - 200 / 255.0f) < 1e-6f); /* from images_2/ */
    /* the undistorted focal length: its scale is found on the border pixels, which differ */
    assert_true(fabs(half.train[0].fx / (full.train[0].fx / 2) - 1) < 0.02);
    assert_true(fabs(half.train[0].cx - full.train[0].cx / 2) < 1e-9);
    cn_dataset_free(&full);
    cn_dataset_free(&half);
}

#define EXPECT_FAIL(dir, want)                                                               \
    do {                                                                                     \
        cn_dataset d_;                                                                       \
        char e_[1024];                                                                       \
        assert_int_equal(cn_dataset_load(dir, NULL, &d_, e_, sizeof e_), -1);               \
        if (!strstr(e_, want)) {                                                             \
            print_error("expected \"%s\" in: %s\n", want, e_);                               \
            fail();                                                                          \
        }                                                                                    \
    } while (0)

static void test_errors(void **state)
{
    (void)state;
    make_capture(TMP "/bad", 0, 0, "FULL_OPENCV", -1);
    /* FULL_OPENCV takes 12 parameters; the file gives 8 */
    EXPECT_FAIL(TMP "/bad", "cameras.txt:2: camera 7: FULL_OPENCV takes 12 parameters");
    make_capture(TMP "/bad", 0, 0, "CUSTOM_LENS", -1);
    EXPECT_FAIL(TMP "/bad", "cameras.txt:2: camera 7: unknown camera model 'CUSTOM_LENS'");
    make_capture(TMP "/bad", 0, 0, NULL, 5);
    EXPECT_FAIL(TMP "/bad", "images/img_05.png: missing (listed as image 105 in the COLMAP model");
    /* a model cnerf does not read, named with the image that uses it */
    make_capture(TMP "/bad", 0, 0, NULL, -1);
    write_file(TMP "/bad/sparse/0", "cameras.txt", "7 FOV 40 30 36 36 20 15 0.9\n", 28);
    EXPECT_FAIL(TMP "/bad", "image img_00.png: camera 7 is a FOV camera, which cnerf does not read");
    write_file(TMP "/bad/sparse/0", "cameras.txt", "8 PINHOLE 40 30 36 36 20 15\n", 28);
    EXPECT_FAIL(TMP "/bad", "image 100 (img_00.png) names camera 7, which is not in cameras");
    /* binary: truncated files */
    make_capture(TMP "/bad", 1, 0, NULL, -1);
    uint8_t *data;
    size_t len;
    char err[256];
    assert_int_equal(cn_read_file(TMP "/bad/sparse/0/images.bin", &data, &len, err, sizeof err),
                     0);
    write_file(TMP "/bad/sparse/0", "images.bin", data, len - 30);
    EXPECT_FAIL(TMP "/bad", "images.bin: image 100 (img_00.png): truncated 2D points");
    write_file(TMP "/bad/sparse/0", "images.bin", data, 40);
    EXPECT_FAIL(TMP "/bad", "images.bin: truncated or implausible image count");
    free(data);
    assert_int_equal(system("rm -rf " TMP "/bad/images"), 0);
    make_capture(TMP "/bad", 1, 0, NULL, -1);
    assert_int_equal(system("rm -rf " TMP "/bad/images"), 0);
    EXPECT_FAIL(TMP "/bad", "no images/ directory beside the COLMAP model");
}

/* Every prefix of a valid binary file and a few bit flips parse or fail cleanly. */
static void test_parse_robust(void **state)
{
    (void)state;
    make_capture(TMP "/robust", 1, 0, NULL, -1);
    const char *files[3] = {"cameras.bin", "images.bin", "points3D.bin"};
    for (int f = 0; f < 3; f++) {
        char path[512], err[256];
        snprintf(path, sizeof path, TMP "/robust/sparse/0/%s", files[f]);
        uint8_t *data;
        size_t len;
        assert_int_equal(cn_read_file(path, &data, &len, err, sizeof err), 0);
        for (size_t n = 0; n < len; n += 1 + n / 16) {
            cn_colmap m;
            memset(&m, 0, sizeof m);
            assert_int_equal(cn_colmap_parse(path, data, n, &m, err, sizeof err), -1);
            cn_colmap_free(&m);
        }
        cn_colmap m;
        memset(&m, 0, sizeof m);
        assert_int_equal(cn_colmap_parse(path, data, len, &m, err, sizeof err), 0);
        cn_colmap_free(&m);
        free(data);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_inward_capture),
        cmocka_unit_test(test_forward_capture),
        cmocka_unit_test(test_reduced_images),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_parse_robust),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
