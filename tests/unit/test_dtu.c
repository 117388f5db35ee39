/* The DTU layout of the dataset loader (cn_dtu.h): a capture written here as IDR, NeuS and
 * MonoSDF lay it out, its cameras.npz made with libzip from known intrinsics, poses and
 * normalisation, with stored and deflated entries of float32 and float64 arrays. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zip.h>

#include "cn_file.h"
#include "cn_dataset.h"
#include "cn_image.h"
#include "testutil.h"

#define TMP CNERF_BINARY_DIR "/test_dtu_tmp"
#define N_CAMS 10
#define IW 40
#define IH 30

/* The normalisation: the unit sphere of the normalised space is a ball of radius SCALE
 * around CENTRE in the world (values that float32 holds exactly: every entry of scale_mat
 * is the same in both widths). */
static const double SCALE = 2.5, CENTRE[3] = {0.75, -1.25, 3.0};
static const double FX = 50.5, FY = 49.25, CX = 20.3, CY = 14.9;

/* What a capture gets wrong, if anything. */
enum {
    OK,
    NOT_ZIP,       /* cameras.npz is text */
    NO_CAMERAS,    /* no world_mat_i at all */
    NO_WORLD3,     /* world_mat_3 left out */
    NO_SCALE2,     /* scale_mat_2 left out */
    DTYPE,         /* world_mat_1 big-endian */
    SHAPE,         /* world_mat_0 of shape (3, 4) */
    FORTRAN,       /* world_mat_0 in Fortran order */
    TRUNCATED,     /* world_mat_6's data one value short */
    NAN_VALUE,     /* world_mat_2[1][2] is NaN */
    SINGULAR,      /* world_mat_5's left 3x3 of rank 2 */
    SCALE_SING,    /* every scale_mat singular */
    SCALE_DIFFERS, /* scale_mat_4 another */
    PROJECTIVE,    /* every scale_mat's last row not 0 0 0 1 */
    SKEW,          /* view 7's K[0][1] = 0.05 fx */
    FEW_IMAGES,    /* one image fewer than cameras */
    N_DEFECTS
};

/* View i: camera centre on a tilted ring around CENTRE, looking at it; world_mat_i =
 * lambda K [R | t] with a lambda of either sign (the loader divides K by K[2][2] and negates
 * P when det < 0). */
static void world_mat(int i, int defect, double W[4][4])
{
    const double a = 2 * M_PI * i / N_CAMS;
    double c[3] = {CENTRE[0] + 8 * cos(a), CENTRE[1] + 7 * sin(a), CENTRE[2] + 3 + 2 * sin(a)};
    double f[3], x[3], y[3], down[3] = {0.1, 0.05, -1};
    for (int k = 0; k < 3; k++)
        f[k] = CENTRE[k] - c[k];
    const double nf = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (int k = 0; k < 3; k++)
        f[k] /= nf;
    x[0] = down[1] * f[2] - down[2] * f[1]; /* right = down x forward */
    x[1] = down[2] * f[0] - down[0] * f[2];
    x[2] = down[0] * f[1] - down[1] * f[0];
    const double nx = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int k = 0; k < 3; k++)
        x[k] /= nx;
    y[0] = f[1] * x[2] - f[2] * x[1];
    y[1] = f[2] * x[0] - f[0] * x[2];
    y[2] = f[0] * x[1] - f[1] * x[0];
    const double *R[3] = {x, y, f};
    const double skew = defect == SKEW && i == 7 ? 0.05 * FX : 0;
    const double K[3][3] = {{FX, skew, CX}, {0, FY, CY}, {0, 0, 1}};
    const double lambda = i % 2 ? -0.5 - i : 1 + 0.25 * i;
    double Rt[3][4];
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++)
            Rt[r][k] = R[r][k];
        Rt[r][3] = -(R[r][0] * c[0] + R[r][1] * c[1] + R[r][2] * c[2]);
    }
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 4; k++)
            W[r][k] = lambda * (K[r][0] * Rt[0][k] + K[r][1] * Rt[1][k] + K[r][2] * Rt[2][k]);
    W[3][0] = W[3][1] = W[3][2] = 0;
    W[3][3] = 1;
    if (defect == SINGULAR && i == 5)
        for (int k = 0; k < 3; k++)
            W[2][k] = W[0][k] + W[1][k];
    if (defect == NAN_VALUE && i == 2)
        W[1][2] = NAN;
}

static void scale_mat(int i, int defect, double S[4][4])
{
    memset(S, 0, sizeof(double) * 16);
    const double s = defect == SCALE_SING ? 0 : defect == SCALE_DIFFERS && i == 4 ? 3 : SCALE;
    for (int k = 0; k < 3; k++) {
        S[k][k] = s;
        S[k][3] = CENTRE[k];
    }
    S[3][3] = 1;
    if (defect == PROJECTIVE)
        S[3][0] = 0.5;
}

/* Array i is float32 when i is odd, float64 when even. */
static int is_f4(int i)
{
    return i % 2;
}

/* A .npy file of a 4x4 array (shape and order as the defect says) into a malloc'ed buffer. */
static uint8_t *npy(const double m[4][4], int f4, int defect, size_t *len)
{
    char dict[128];
    const char *descr = defect == DTYPE ? ">f8" : f4 ? "<f4" : "<f8";
    int n = snprintf(dict, sizeof dict, "{'descr': '%s', 'fortran_order': %s, 'shape': (%s), }",
                     descr, defect == FORTRAN ? "True" : "False",
                     defect == SHAPE ? "3, 4" : "4, 4");
    while ((10 + n + 1) % 64)
        dict[n++] = ' ';
    dict[n++] = '\n';
    const int size = f4 ? 4 : 8;
    const int values = defect == SHAPE ? 12 : defect == TRUNCATED ? 15 : 16;
    *len = 10 + (size_t)n + (size_t)(size * values);
    uint8_t *p = malloc(*len);
    assert_non_null(p);
    memcpy(p, "\x93NUMPY\x01\x00", 8);
    p[8] = (uint8_t)n;
    p[9] = (uint8_t)(n >> 8);
    memcpy(p + 10, dict, (size_t)n);
    for (int k = 0; k < values; k++) {
        const double v = m[k / 4][k % 4];
        uint64_t u;
        if (f4) {
            const float x = (float)v;
            uint32_t u32;
            memcpy(&u32, &x, 4);
            u = u32;
        } else {
            memcpy(&u, &v, 8);
        }
        for (int b = 0; b < size; b++)
            p[10 + n + size * k + b] = (uint8_t)(u >> (8 * b));
    }
    return p;
}

/* Adds NAME.npy to the archive, deflated or stored. */
static void add_npy(zip_t *za, const char *name, const double m[4][4], int f4, int defect,
                    int deflate)
{
    size_t len;
    uint8_t *p = npy(m, f4, defect, &len);
    zip_source_t *src = zip_source_buffer(za, p, len, 1);
    assert_non_null(src);
    char entry[64];
    snprintf(entry, sizeof entry, "%s.npy", name);
    const zip_int64_t idx = zip_file_add(za, entry, src, 0);
    assert_true(idx >= 0);
    assert_int_equal(zip_set_file_compression(za, (zip_uint64_t)idx,
                                              deflate ? ZIP_CM_DEFLATE : ZIP_CM_STORE, 0), 0);
}

/* The camera file: world_mat_i and scale_mat_i of every view, and a camera_mat_i that the
 * loader does not read. Entries of view i are deflated when i % 3 == 0 (np.savez_compressed),
 * else stored (np.savez). */
static void write_npz(const char *path, int defect)
{
    if (defect == NOT_ZIP) {
        FILE *f = fopen(path, "w");
        assert_non_null(f);
        fputs("world_mat_0\n", f);
        fclose(f);
        return;
    }
    int zerr;
    zip_t *za = zip_open(path, ZIP_CREATE | ZIP_TRUNCATE, &zerr);
    assert_non_null(za);
    for (int i = N_CAMS - 1; i >= 0; i--) { /* out of order: the names say which is which */
        double W[4][4], S[4][4];
        char name[32];
        world_mat(i, defect, W);
        scale_mat(i, defect, S);
        const int z = i % 3 == 0;
        snprintf(name, sizeof name, "world_mat_%d", i);
        const int wd = (defect == DTYPE && i == 1) || ((defect == SHAPE || defect == FORTRAN) &&
                                                        i == 0) || (defect == TRUNCATED && i == 6)
                           ? defect
                           : OK;
        if (defect != NO_CAMERAS && !(defect == NO_WORLD3 && i == 3))
            add_npy(za, name, W, is_f4(i), wd, z);
        snprintf(name, sizeof name, "scale_mat_%d", i);
        if (!(defect == NO_SCALE2 && i == 2))
            add_npy(za, name, S, !is_f4(i), OK, !z);
        snprintf(name, sizeof name, "camera_mat_%d", i);
        add_npy(za, name, S, 0, SHAPE, z);
    }
    assert_int_equal(zip_close(za), 0);
}

/* A capture in DIR: `camfile` and n_img images of IW x IH named as `layout` says:
 * 0 image/000000.png, 1 images/000000.png, 2 000000_rgb.png beside the cameras (MonoSDF,
 * with its other files). */
static void make_capture(const char *dir, const char *camfile, int layout, int defect)
{
    char cmd[1200], path[1100], err[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s && mkdir -p %s/mask %s%s", dir, dir, dir,
             layout == 0 ? "/image" : layout == 1 ? "/images" : "");
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/%s", dir, camfile);
    write_npz(path, defect);
    uint8_t px[IW * IH * 3];
    const int n_img = defect == FEW_IMAGES ? N_CAMS - 1 : N_CAMS;
    for (int i = 0; i < n_img; i++) {
        memset(px, 10 * i, sizeof px);
        if (layout == 2)
            snprintf(path, sizeof path, "%s/%06d_rgb.png", dir, i);
        else
            snprintf(path, sizeof path, "%s/%s/%06d.png", dir, layout ? "images" : "image", i);
        assert_int_equal(cn_png_write_rgb8(path, px, IW, IH, IW * 3, err, sizeof err), 0);
        /* masks (not applied), and MonoSDF's other files beside its images */
        if (layout == 2)
            snprintf(path, sizeof path, "%s/%06d_mask.png", dir, i);
        else
            snprintf(path, sizeof path, "%s/mask/%03d.png", dir, i);
        memset(px, 0, sizeof px);
        assert_int_equal(cn_png_write_rgb8(path, px, IW, IH, IW * 3, err, sizeof err), 0);
    }
}

/* All views in name order: the test views are 0 and 8. */
static const cn_view *view_of(const cn_dataset *ds, int i)
{
    return i % 8 == 0 ? &ds->test[i / 8] : &ds->train[i - 1 - i / 8];
}

/* The matrix as the file holds it (float32 entries rounded). */
static void stored(double m[4][4], int f4)
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            m[r][c] = f4 ? (double)(float)m[r][c] : m[r][c];
}

/* The mean distance of the cameras from CENTRE in units of the normalised space (the
 * loader's scale is 4 over it). */
static double mean_norm_dist(void)
{
    double d = 0;
    for (int i = 0; i < N_CAMS; i++) {
        const double a = 2 * M_PI * i / N_CAMS;
        const double v[3] = {8 * cos(a), 7 * sin(a), 3 + 2 * sin(a)};
        d += sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) / SCALE / N_CAMS;
    }
    return d;
}

/* Largest distance in pixels between where world_mat_i puts world points and where the
 * loaded view puts them (the points carried into the loaded space: normalised by scale_mat,
 * then scaled by 4 / mean distance); `factor` is the downscale of the loaded view. */
static double reprojection_error(const cn_dataset *ds, int factor)
{
    static const double X[4][3] = {{0.75, -1.25, 3.0}, {2.0, -0.5, 3.5}, {-0.5, -2.0, 2.2},
                                   {1.5, -3.0, 4.4}};
    const double s = 4 / mean_norm_dist();
    double worst = 0;
    for (int i = 0; i < N_CAMS; i++) {
        double W[4][4];
        world_mat(i, OK, W);
        stored(W, is_f4(i));
        const cn_view *v = view_of(ds, i);
        for (int p = 0; p < 4; p++) {
            double q[3];
            for (int r = 0; r < 3; r++)
                q[r] = W[r][0] * X[p][0] + W[r][1] * X[p][1] + W[r][2] * X[p][2] + W[r][3];
            const double u = q[0] / q[2], w = q[1] / q[2];
            double d[3], cam[3] = {0, 0, 0};
            for (int r = 0; r < 3; r++)
                d[r] = s * (X[p][r] - CENTRE[r]) / SCALE - v->c2w[r][3];
            for (int a = 0; a < 3; a++)
                for (int r = 0; r < 3; r++)
                    cam[a] += v->c2w[r][a] * d[r];
            /* NeRF's axes: y up, looking down -z */
            const double lu = v->fx * cam[0] / -cam[2] + v->cx;
            const double lw = -v->fy * cam[1] / -cam[2] + v->cy;
            worst = fmax(worst, fmax(fabs(lu * factor - u), fabs(lw * factor - w)));
        }
    }
    return worst;
}

static void test_capture(void **state)
{
    (void)state;
    static const struct {
        const char *camfile;
        int layout;
    } kinds[3] = {{"cameras.npz", 0}, {"cameras_sphere.npz", 1}, {"cameras.npz", 2}};
    for (int k = 0; k < 3; k++) {
        char err[512];
        cn_dataset ds;
        make_capture(TMP "/scan", kinds[k].camfile, kinds[k].layout, OK);
        /* a COLMAP model beside the cameras is not read */
        assert_int_equal(system("mkdir -p " TMP "/scan/sparse/0 && touch " TMP
                                "/scan/sparse/0/cameras.txt"), 0);
        if (cn_dataset_load(TMP "/scan", NULL, &ds, err, sizeof err) != 0)
            fail_msg("%s", err);
        assert_int_equal(ds.kind, CN_DS_DTU);
        assert_int_equal(ds.ndc, 0);
        assert_int_equal(ds.n_train, 8);
        assert_int_equal(ds.n_test, 2);
        assert_int_equal(ds.n_val, 0);
        assert_true(ds.bg[0] == 1.0f && ds.train[0].alpha == NULL);
        double dist = 0, rmin = INFINITY, rmax = 0;
        for (int i = 0; i < N_CAMS; i++) {
            const cn_view *v = view_of(&ds, i);
            char name[32];
            snprintf(name, sizeof name, kinds[k].layout == 2 ? "%06d_rgb" : "%06d", i);
            assert_string_equal(v->name, name);
            assert_int_equal(v->w, IW);
            assert_true(fabsf(v->rgb[0] - 10 * i / 255.0f) < 1e-6f); /* paired in name order */
            /* float64 world_mat: K to rounding; float32: to its precision */
            const double tol = is_f4(i) ? 1e-4 : 1e-9;
            assert_true(fabs(v->fx - FX) < tol && fabs(v->fy - FY) < tol);
            assert_true(fabs(v->cx - CX) < tol && fabs(v->cy - CY) < tol);
            const double r = sqrt(v->c2w[0][3] * v->c2w[0][3] + v->c2w[1][3] * v->c2w[1][3] +
                                  v->c2w[2][3] * v->c2w[2][3]);
            dist += r / N_CAMS;
            rmin = fmin(rmin, r);
            rmax = fmax(rmax, r);
        }
        assert_true(fabs(dist - 4) < 1e-9);
        assert_true(fabs(ds.near - fmax(0.05, rmin - sqrt(3.0))) < 1e-12);
        assert_true(fabs(ds.far - (rmax + sqrt(3.0))) < 1e-12);
        const double e = reprojection_error(&ds, 1);
        print_message("# %s, layout %d: near %.4f far %.4f, reprojection error %.2g px\n",
                      kinds[k].camfile, kinds[k].layout, ds.near, ds.far, e);
        assert_true(e < 1e-4);
        cn_dataset_free(&ds);
    }
    /* downscaled: the intrinsics follow the images */
    cn_dataset ds;
    char err[512];
    assert_int_equal(cn_dataset_load(TMP "/scan", &(cn_dataset_opts){.downscale = 2}, &ds, err,
                                     sizeof err), 0);
    assert_int_equal(ds.train[0].w, IW / 2);
    assert_int_equal(ds.train[0].h, IH / 2);
    assert_true(fabs(ds.test[0].cx - CX / 2) < 1e-9);
    assert_true(reprojection_error(&ds, 2) < 1e-4);
    cn_dataset_free(&ds);
}

/* Every prefix of a camera file, and the file with one byte changed anywhere, is read or
 * refused cleanly (the metadata parser that the fuzz harness drives). */
static void test_parse_robust(void **state)
{
    (void)state;
    char err[512];
    uint8_t *data;
    size_t len;
    make_capture(TMP "/robust", "cameras.npz", 0, OK);
    assert_int_equal(cn_read_file(TMP "/robust/cameras.npz", &data, &len, err, sizeof err), 0);
    assert_int_equal(cn_dataset_parse_meta(3, data, len, err, sizeof err), 0);
    for (size_t n = 0; n < len; n += 1 + n / 64)
        assert_int_equal(cn_dataset_parse_meta(3, data, n, err, sizeof err), -1);
    int refused = 0;
    for (size_t i = 0; i < len; i += 7) {
        data[i] ^= 0x55;
        refused += cn_dataset_parse_meta(3, data, len, err, sizeof err) != 0;
        data[i] ^= 0x55;
    }
    print_message("# %d of %zu single-byte changes refused\n", refused, (len + 6) / 7);
    free(data);
}

static void test_errors(void **state)
{
    (void)state;
    static const struct {
        int defect;
        const char *want[3];
    } cases[] = {
        {NOT_ZIP, {"scan/cameras.npz: not a zip archive", NULL}},
        {NO_CAMERAS, {"cameras.npz: missing world_mat_0", NULL}},
        {NO_WORLD3, {"cameras.npz: missing world_mat_3", "world_mat_9"}},
        {NO_SCALE2, {"cameras.npz: missing scale_mat_2", NULL}},
        {DTYPE, {"cameras.npz: world_mat_1: dtype '>f8' is not supported", "'<f4' or '<f8'"}},
        {SHAPE, {"cameras.npz: world_mat_0: array shape (3, 4): expected (4, 4)", NULL}},
        {FORTRAN, {"cameras.npz: world_mat_0: fortran_order True", NULL}},
        {TRUNCATED, {"cameras.npz: world_mat_6: truncated", NULL}},
        {NAN_VALUE, {"cameras.npz: world_mat_2: non-finite value at [1][2]", NULL}},
        {SINGULAR, {"cameras.npz: world_mat_5 x scale_mat_5 is singular", NULL}},
        {SCALE_SING, {"cameras.npz: scale_mat_0 is singular", NULL}},
        {SCALE_DIFFERS, {"cameras.npz: scale_mat_4 differs from scale_mat_0", NULL}},
        {PROJECTIVE, {"cameras.npz: scale_mat_0: last row 0.5 0 0 1, expected 0 0 0 1", NULL}},
        {SKEW, {"cameras.npz: world_mat_7: the camera's skew K[0][1] = 2.525", "0.01 fx"}},
        {FEW_IMAGES, {"scan/image: 9 images (PNG, JPEG) for 10 poses in", "cameras.npz"}},
    };
    assert_int_equal(sizeof cases / sizeof cases[0], N_DEFECTS - 1);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        cn_dataset ds;
        char err[1024];
        make_capture(TMP "/scan", "cameras.npz", 0, cases[c].defect);
        assert_int_equal(cn_dataset_load(TMP "/scan", NULL, &ds, err, sizeof err), -1);
        for (int w = 0; w < 3 && cases[c].want[w]; w++)
            if (!strstr(err, cases[c].want[w]))
                fail_msg("defect %d: expected \"%s\" in: %s", cases[c].defect, cases[c].want[w],
                         err);
    }
    /* no images at all: neither directory, nor MonoSDF's files */
    cn_dataset ds;
    char err[1024];
    make_capture(TMP "/scan", "cameras.npz", 2, OK);
    assert_int_equal(system("rm " TMP "/scan/*_rgb.png"), 0);
    assert_int_equal(cn_dataset_load(TMP "/scan", NULL, &ds, err, sizeof err), -1);
    if (!strstr(err, "0 images (*_rgb.png, and no image/ or images/ directory) for 10 poses"))
        fail_msg("%s", err);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_capture),
        cmocka_unit_test(test_parse_robust),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
