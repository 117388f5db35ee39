/* PNG input/output, downscaling and dataset loading: the shared Lego and Fern scenes, an
 * instant-ngp copy, and malformed copies made in a temporary directory. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cjson/cJSON.h>
#include <png.h>

#include "cn_file.h"
#include "cn_dataset.h"
#include "cn_image.h"
#include "testutil.h"

#define LEGO CNERF_DATA_DIR "/lego"
#define FERN CNERF_DATA_DIR "/fern"
#define TMP_ROOT CNERF_BINARY_DIR "/test_dataset_tmp"
#define PATH_LEN 1024

/* Fern's hwf and depth bounds (poses_bounds.npy). */
#define FERN_FOCAL 3260.5263328805895
#define FERN_BMIN 16.985296178676084
#define FERN_BMAX 80.00209740336334

/* ---- files and directories ---- */

static void make_dir(const char *path)
{
    if (mkdir(path, 0755) != 0 && errno != EEXIST)
        fail_msg("mkdir %s: %s", path, strerror(errno));
}

static int rm_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st;
    (void)flag;
    (void)ftw;
    return remove(path);
}

static void rm_tree(const char *path) { nftw(path, rm_entry, 16, FTW_DEPTH | FTW_PHYS); }

/* An empty directory TMP_ROOT/name (name may have several components); its path goes to
 * out. */
static void fresh_dir(char out[PATH_LEN], const char *name)
{
    make_dir(TMP_ROOT);
    snprintf(out, PATH_LEN, "%s/%s", TMP_ROOT, name);
    for (char *p = out + strlen(TMP_ROOT) + 1; (p = strchr(p, '/')) != NULL; p++) {
        *p = '\0';
        make_dir(out);
        *p = '/';
    }
    rm_tree(out);
    make_dir(out);
}

static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    closedir(d);
    return n;
}

static void join(char out[PATH_LEN], const char *dir, const char *name)
{
    int n = snprintf(out, PATH_LEN, "%s/%s", dir, name);
    if (n < 0 || n >= PATH_LEN)
        fail_msg("path too long: %s/%s", dir, name);
}

static void write_file(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        fail_msg("cannot create %s: %s", path, strerror(errno));
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static void write_text(const char *dir, const char *name, const char *text)
{
    char path[PATH_LEN];
    join(path, dir, name);
    write_file(path, text, strlen(text));
}

/* Copies the first `max` bytes of src (all with SIZE_MAX) to dir/name. */
static void copy_file(const char *src, const char *dir, const char *name, size_t max)
{
    char path[PATH_LEN], err[256];
    uint8_t *data;
    size_t len;
    if (cn_read_file(src, &data, &len, err, sizeof err) != 0)
        fail_msg("%s", err);
    join(path, dir, name);
    write_file(path, data, len < max ? len : max);
    free(data);
}

static void assert_contains(const char *s, const char *word)
{
    if (!strstr(s, word))
        fail_msg("expected \"%s\" in the message: %s", word, s);
}

/* The load fails, the message contains every word, and the dataset is left empty. */
static void expect_fail_words(const char *dir, const cn_dataset_opts *o,
                              const char *const *words)
{
    cn_dataset ds;
    memset(&ds, 0x5a, sizeof ds);
    char err[1024] = "";
    int rc = cn_dataset_load(dir, o, &ds, err, sizeof err);
    if (rc == 0) {
        cn_dataset_free(&ds);
        fail_msg("%s: loaded, expected an error containing \"%s\"", dir, words[0]);
    }
    assert_int_equal(rc, -1);
    for (size_t i = 0; words[i]; i++)
        assert_contains(err, words[i]);
    assert_null(ds.train);
    assert_null(ds.val);
    assert_null(ds.test);
    assert_int_equal(ds.n_train + ds.n_val + ds.n_test, 0);
}

#define EXPECT_FAIL(dir, opts, ...) expect_fail_words(dir, opts, (const char *[]){__VA_ARGS__, NULL})

static void load_ok(const char *dir, const cn_dataset_opts *o, cn_dataset *ds)
{
    char err[1024] = "";
    if (cn_dataset_load(dir, o, ds, err, sizeof err) != 0)
        fail_msg("%s: %s", dir, err);
}

/* ---- checks on loaded views ---- */

static void assert_rotation_orthonormal(const double m[3][4], double tol)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double d = 0;
            for (int k = 0; k < 3; k++)
                d += m[k][i] * m[k][j];
            assert_true(fabs(d - (i == j)) < tol);
        }
}

static void assert_pixels_in_range(const cn_view *v)
{
    for (size_t i = 0; i < (size_t)v->w * v->h * 3; i++)
        assert_true(v->rgb[i] >= 0.0f && v->rgb[i] <= 1.0f);
}

/* ---- PNG helpers ---- */

/* Writes a PNG of any format with libpng; rows are packed, palette optional. */
typedef struct png_spec {
    int w, h, depth, ctype, interlace;
    const uint8_t *data;
    const png_color *palette;
    int npalette;
    const uint8_t *trns;
    int ntrns;
} png_spec;

static void write_png_spec(const char *path, const png_spec *s)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    assert_non_null(info);
    if (setjmp(png_jmpbuf(png)))
        fail_msg("libpng failed writing %s", path);
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)s->w, (png_uint_32)s->h, s->depth, s->ctype,
                 s->interlace, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (s->palette)
        png_set_PLTE(png, info, s->palette, s->npalette);
    if (s->trns)
        png_set_tRNS(png, info, s->trns, s->ntrns, NULL);
    png_write_info(png, info);
    size_t rowbytes = png_get_rowbytes(png, info);
    png_bytep rows[16];
    assert_true(s->h <= 16);
    for (int y = 0; y < s->h; y++)
        rows[y] = (png_bytep)s->data + (size_t)y * rowbytes;
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(f);
}

static void read_png_ok(const char *path, cn_image *img)
{
    char err[512];
    if (cn_png_read(path, img, err, sizeof err) != 0)
        fail_msg("%s", err);
}

static void assert_px(const cn_image *img, int x, int y, const float *want)
{
    const float *p = img->px + ((size_t)y * img->w + x) * img->c;
    for (int k = 0; k < img->c; k++)
        if (fabsf(p[k] - want[k]) > 1e-6f)
            fail_msg("pixel (%d, %d) channel %d: %g, expected %g", x, y, k, p[k], want[k]);
}

/* ---- image module ---- */

static void test_png_roundtrip(void **state)
{
    (void)state;
    char dir[PATH_LEN], path[PATH_LEN], err[512];
    fresh_dir(dir, "png_roundtrip");
    enum { W = 7, H = 5, STRIDE = 3 * W + 3 };
    uint8_t rgb[H * STRIDE];
    for (int i = 0; i < H * STRIDE; i++)
        rgb[i] = (uint8_t)(i * 37 + 11);
    join(path, dir, "out.png");
    assert_int_equal(cn_png_write_rgb8(path, rgb, W, H, STRIDE, err, sizeof err), 0);
    cn_image img;
    read_png_ok(path, &img);
    assert_int_equal(img.w, W);
    assert_int_equal(img.h, H);
    assert_int_equal(img.c, 3);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < 3 * W; x++)
            assert_true(img.px[y * 3 * W + x] == rgb[y * STRIDE + x] / 255.0f);
    cn_image_free(&img);
    assert_null(img.px);
    /* Overwriting works and leaves no temporary file behind. */
    assert_int_equal(cn_png_write_rgb8(path, rgb, W, H, STRIDE, err, sizeof err), 0);
    assert_int_equal(count_entries(dir), 1);
    /* Bad arguments and an impossible destination fail with a message. */
    assert_int_equal(cn_png_write_rgb8(path, rgb, W, H, 3 * W - 1, err, sizeof err), -1);
    assert_contains(err, "stride");
    join(path, dir, "no/such/dir/out.png");
    assert_int_equal(cn_png_write_rgb8(path, rgb, W, H, STRIDE, err, sizeof err), -1);
    assert_contains(err, "no/such/dir/out.png");
    rm_tree(dir);
}

static void test_png_formats(void **state)
{
    (void)state;
    char dir[PATH_LEN], path[PATH_LEN];
    fresh_dir(dir, "png_formats");
    cn_image img;
    join(path, dir, "f.png");

    /* 8-bit grey becomes RGB. */
    const uint8_t g8[4] = {0, 51, 204, 255};
    write_png_spec(path, &(png_spec){2, 2, 8, PNG_COLOR_TYPE_GRAY, 0, g8, NULL, 0, NULL, 0});
    read_png_ok(path, &img);
    assert_int_equal(img.c, 3);
    assert_px(&img, 1, 0, (float[]){0.2f, 0.2f, 0.2f});
    cn_image_free(&img);

    /* 16-bit grey keeps its precision. */
    const uint8_t g16[4] = {0x12, 0x34, 0xff, 0xfe};
    write_png_spec(path, &(png_spec){2, 1, 16, PNG_COLOR_TYPE_GRAY, 0, g16, NULL, 0, NULL, 0});
    read_png_ok(path, &img);
    float v = 0x1234 / 65535.0f, u = 0xfffe / 65535.0f;
    assert_px(&img, 0, 0, (float[]){v, v, v});
    assert_px(&img, 1, 0, (float[]){u, u, u});
    cn_image_free(&img);

    /* 1-bit grey expands to 0 and 1. */
    const uint8_t g1[1] = {0x40}; /* 0 1 0 0 */
    write_png_spec(path, &(png_spec){4, 1, 1, PNG_COLOR_TYPE_GRAY, 0, g1, NULL, 0, NULL, 0});
    read_png_ok(path, &img);
    assert_px(&img, 1, 0, (float[]){1, 1, 1});
    assert_px(&img, 2, 0, (float[]){0, 0, 0});
    cn_image_free(&img);

    /* Grey + alpha becomes RGBA. */
    const uint8_t ga[4] = {255, 0, 102, 153};
    write_png_spec(path,
                   &(png_spec){2, 1, 8, PNG_COLOR_TYPE_GRAY_ALPHA, 0, ga, NULL, 0, NULL, 0});
    read_png_ok(path, &img);
    assert_int_equal(img.c, 4);
    assert_px(&img, 0, 0, (float[]){1, 1, 1, 0});
    assert_px(&img, 1, 0, (float[]){0.4f, 0.4f, 0.4f, 0.6f});
    cn_image_free(&img);

    /* 16-bit RGBA. */
    const uint8_t rgba16[8] = {0, 0, 0xff, 0xff, 0x80, 0x00, 0xff, 0xff};
    write_png_spec(path,
                   &(png_spec){1, 1, 16, PNG_COLOR_TYPE_RGB_ALPHA, 0, rgba16, NULL, 0, NULL, 0});
    read_png_ok(path, &img);
    assert_px(&img, 0, 0, (float[]){0, 1, 0x8000 / 65535.0f, 1});
    cn_image_free(&img);

    /* Palette with transparency becomes RGBA; without it RGB. */
    const png_color pal[2] = {{255, 0, 0}, {0, 0, 255}};
    const uint8_t trns[1] = {0};
    const uint8_t idx[2] = {0, 1};
    write_png_spec(path,
                   &(png_spec){2, 1, 8, PNG_COLOR_TYPE_PALETTE, 0, idx, pal, 2, trns, 1});
    read_png_ok(path, &img);
    assert_int_equal(img.c, 4);
    assert_px(&img, 0, 0, (float[]){1, 0, 0, 0});
    assert_px(&img, 1, 0, (float[]){0, 0, 1, 1});
    cn_image_free(&img);
    write_png_spec(path, &(png_spec){2, 1, 8, PNG_COLOR_TYPE_PALETTE, 0, idx, pal, 2, NULL, 0});
    read_png_ok(path, &img);
    assert_int_equal(img.c, 3);
    assert_px(&img, 1, 0, (float[]){0, 0, 1});
    cn_image_free(&img);

    /* Interlaced (Adam7) RGB. */
    uint8_t rgb[9 * 9 * 3];
    for (int i = 0; i < 9 * 9 * 3; i++)
        rgb[i] = (uint8_t)(i * 7);
    write_png_spec(path, &(png_spec){9, 9, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_ADAM7, rgb, NULL,
                                     0, NULL, 0});
    read_png_ok(path, &img);
    for (int i = 0; i < 9 * 9 * 3; i++)
        assert_true(img.px[i] == rgb[i] / 255.0f);
    cn_image_free(&img);
    rm_tree(dir);
}

static void test_png_read_errors(void **state)
{
    (void)state;
    char dir[PATH_LEN], path[PATH_LEN], err[512];
    fresh_dir(dir, "png_errors");
    cn_image img;
    join(path, dir, "missing.png");
    assert_int_equal(cn_png_read(path, &img, err, sizeof err), -1);
    assert_contains(err, "missing.png");
    assert_contains(err, "No such file");
    assert_null(img.px);

    write_text(dir, "text.png", "this is not an image\n");
    join(path, dir, "text.png");
    assert_int_equal(cn_png_read(path, &img, err, sizeof err), -1);
    assert_contains(err, "text.png: not a PNG");

    /* Every cut of a real PNG is refused (not a PNG when even the signature is cut). */
    uint8_t *data;
    size_t len;
    assert_int_equal(cn_read_file(LEGO "/train/r_0.png", &data, &len, err, sizeof err), 0);
    const size_t cuts[] = {0, 5, 8, 20, 33, 200, 5000, len / 2, len - 12, len - 1};
    join(path, dir, "cut.png");
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        write_file(path, data, cuts[i]);
        assert_int_equal(cn_png_read(path, &img, err, sizeof err), -1);
        assert_contains(err, "cut.png: ");
        if (cuts[i] >= 5)
            assert_contains(err, "truncated");
        assert_null(img.px);
    }
    /* A corrupt header CRC. */
    data[29] ^= 0xff;
    write_file(path, data, len);
    assert_int_equal(cn_png_read(path, &img, err, sizeof err), -1);
    assert_contains(err, "cut.png: IHDR");
    free(data);
    rm_tree(dir);
}

static void test_downscale(void **state)
{
    (void)state;
    char err[256];
    /* 4x2 RGBA: each 2x2 block averages alpha, and its colour weighted by alpha (straight
     * colour = mean of premultiplied colour / mean alpha), so that the block composites
     * over any background as its four pixels do on average. */
    float px[4 * 2 * 4];
    for (int i = 0; i < 32; i++)
        px[i] = (float)i / 32.0f;
    cn_image in = {4, 2, 4, px}, out;
    assert_int_equal(cn_image_downscale(&in, 2, &out, err, sizeof err), 0);
    assert_int_equal(out.w, 2);
    assert_int_equal(out.h, 1);
    assert_int_equal(out.c, 4);
    const int blk[2][4] = {{0, 1, 4, 5}, {2, 3, 6, 7}};
    for (int x = 0; x < 2; x++) {
        float a = 0, pm[3] = {0, 0, 0};
        for (int j = 0; j < 4; j++) {
            const float *p = px + 4 * blk[x][j];
            a += p[3] / 4;
            for (int k = 0; k < 3; k++)
                pm[k] += p[3] * p[k] / 4;
        }
        assert_true(fabsf(out.px[x * 4 + 3] - a) < 1e-6f);
        for (int k = 0; k < 3; k++)
            assert_true(fabsf(out.px[x * 4 + k] - pm[k] / a) < 1e-6f);
    }
    cn_image_free(&out);
    /* An opaque red pixel beside a transparent black one (how Blender writes empty space)
     * is half-covered red, not half-covered dark red: over white it is (1, 0.5, 0.5). A
     * block with no coverage at all keeps the plain mean of its colours. */
    float edge[2][2 * 2 * 4] = {
        {1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0},
        {0.2f, 0.4f, 0.6f, 0, 0.4f, 0.6f, 0.8f, 0, 0.2f, 0.4f, 0.6f, 0, 0.4f, 0.6f, 0.8f, 0}};
    assert_int_equal(cn_image_downscale(&(cn_image){2, 2, 4, edge[0]}, 2, &out, err, sizeof err),
                     0);
    assert_true(fabsf(out.px[0] - 1) < 1e-6f && fabsf(out.px[1]) < 1e-6f);
    assert_true(fabsf(out.px[2]) < 1e-6f && fabsf(out.px[3] - 0.5f) < 1e-6f);
    cn_image_free(&out);
    assert_int_equal(cn_image_downscale(&(cn_image){2, 2, 4, edge[1]}, 2, &out, err, sizeof err),
                     0);
    assert_true(fabsf(out.px[0] - 0.3f) < 1e-6f && fabsf(out.px[1] - 0.5f) < 1e-6f);
    assert_true(fabsf(out.px[2] - 0.7f) < 1e-6f && out.px[3] == 0);
    cn_image_free(&out);
    /* Factor 1 copies. */
    assert_int_equal(cn_image_downscale(&in, 1, &out, err, sizeof err), 0);
    assert_memory_equal(out.px, px, sizeof px);
    cn_image_free(&out);
    /* A factor that does not divide the size, or is not positive, fails. */
    assert_int_equal(cn_image_downscale(&in, 3, &out, err, sizeof err), -1);
    assert_contains(err, "4x2");
    assert_contains(err, "not divisible");
    assert_null(out.px);
    assert_int_equal(cn_image_downscale(&in, 0, &out, err, sizeof err), -1);
    assert_contains(err, ">= 1");
}

/* ---- the shared scenes ---- */

static void test_lego(void **state)
{
    (void)state;
    cn_dataset ds;
    cn_dataset_opts o = {.downscale = 4, .max_views = 5};
    load_ok(LEGO, &o, &ds);
    assert_int_equal(ds.kind, CN_DS_BLENDER);
    assert_int_equal(ds.ndc, 0);
    assert_true(ds.near == 2.0 && ds.far == 6.0);
    assert_true(ds.bg[0] == 1.0f && ds.bg[1] == 1.0f && ds.bg[2] == 1.0f);
    assert_int_equal(ds.n_train, 5);
    assert_int_equal(ds.n_val, 5);
    assert_int_equal(ds.n_test, 5);
    assert_string_equal(ds.train[0].name, "r_0");
    assert_string_equal(ds.train[4].name, "r_4");
    assert_string_equal(ds.val[1].name, "r_1");
    assert_string_equal(ds.test[2].name, "r_2");
    const double focal = 0.5 * 100 / tan(0.5 * 0.6911112070083618);
    const cn_view *split[3] = {ds.train, ds.val, ds.test};
    for (int s = 0; s < 3; s++)
        for (int i = 0; i < 5; i++) {
            const cn_view *v = &split[s][i];
            assert_int_equal(v->w, 100);
            assert_int_equal(v->h, 100);
            assert_true(fabs(v->fx - focal) < 1e-9 && fabs(v->fy - focal) < 1e-9);
            assert_true(fabs(v->fx - 138.89) < 1e-2);
            assert_true(v->cx == 50.0 && v->cy == 50.0);
            assert_rotation_orthonormal(v->c2w, 1e-6); /* float32 in the JSON */
            assert_pixels_in_range(v);
            /* Transparent corner: the white background. */
            for (int k = 0; k < 3; k++)
                assert_true(fabsf(v->rgb[k] - 1.0f) < 1e-6f);
        }
    const double r0[3][4] = {
        {-0.9999021887779236, 0.004192245192825794, -0.013345719315111637, -0.05379832163453102},
        {-0.013988681137561798, -0.2996590733528137, 0.95394366979599, 3.845470428466797},
        {-4.656612873077393e-10, 0.9540371894836426, 0.29968830943107605, 1.2080823183059692}};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            assert_true(ds.train[0].c2w[i][j] == r0[i][j]);

    /* The pixels: the RGBA file area-averaged by 4, then composited over white. */
    cn_image full, small;
    char err[256];
    read_png_ok(LEGO "/train/r_0.png", &full);
    assert_int_equal(full.c, 4);
    assert_int_equal(cn_image_downscale(&full, 4, &small, err, sizeof err), 0);
    double maxdiff = 0;
    int opaque = 0;
    for (int i = 0; i < 100 * 100; i++) {
        const float *p = small.px + 4 * i;
        opaque += p[3] > 0.99f;
        for (int k = 0; k < 3; k++)
            maxdiff = fmax(maxdiff, fabs(ds.train[0].rgb[3 * i + k] - (p[3] * p[k] + 1 - p[3])));
        /* The view keeps its opacities (for training with random backgrounds). */
        assert_non_null(ds.train[0].alpha);
        assert_true(ds.train[0].alpha[i] == p[3]);
    }
    assert_true(maxdiff < 1e-6);
    assert_true(opaque > 500); /* the object is there */
    cn_image_free(&full);
    cn_image_free(&small);
    cn_dataset_free(&ds);
    assert_null(ds.train);

    /* Black background. */
    o = (cn_dataset_opts){.downscale = 4, .max_views = 1, .black_bg = 1};
    load_ok(LEGO, &o, &ds);
    assert_true(ds.bg[0] == 0.0f);
    for (int k = 0; k < 3; k++)
        assert_true(ds.train[0].rgb[k] < 1e-6f);
    cn_dataset_free(&ds);
}

/* Mean centre and average rotation (NeRF's poses_avg) of a set of views. */
static void assert_average_pose_identity(const cn_dataset *ds)
{
    double c[3] = {0}, z[3] = {0}, up[3] = {0};
    int n = ds->n_train + ds->n_test;
    for (int k = 0; k < n; k++) {
        const cn_view *v = k < ds->n_train ? &ds->train[k] : &ds->test[k - ds->n_train];
        for (int i = 0; i < 3; i++) {
            c[i] += v->c2w[i][3] / n;
            up[i] += v->c2w[i][1];
            z[i] += v->c2w[i][2];
        }
    }
    double zn = sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
    double x[3] = {up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2],
                   up[0] * z[1] - up[1] * z[0]};
    double xn = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int i = 0; i < 3; i++) {
        assert_true(fabs(c[i]) < 1e-9);
        assert_true(fabs(z[i] / zn - (i == 2)) < 1e-9);
        assert_true(fabs(x[i] / xn - (i == 0)) < 1e-9);
    }
}

/* Two views alike: name, size, camera and every pixel. */
static void assert_same_view(const cn_view *a, const cn_view *b)
{
    assert_string_equal(a->name, b->name);
    assert_int_equal(a->w, b->w);
    assert_int_equal(a->h, b->h);
    assert_memory_equal(a->c2w, b->c2w, sizeof a->c2w);
    assert_true(a->fx == b->fx && a->fy == b->fy && a->cx == b->cx && a->cy == b->cy);
    assert_memory_equal(a->rgb, b->rgb, sizeof(float) * 3 * (size_t)a->w * (size_t)a->h);
    assert_int_equal(a->alpha == NULL, b->alpha == NULL);
    if (a->alpha)
        assert_memory_equal(a->alpha, b->alpha, sizeof(float) * (size_t)a->w * (size_t)a->h);
}

/* test_every and test_only leave views out unread; those kept are the full load's, and the
 * scene's rules (bounds, NDC, the downscale --max-size chooses) are the same. */
static void test_test_every(void **state)
{
    (void)state;
    const struct {
        const char *dir;
        cn_dataset_opts o;
    } cases[] = {{LEGO, {.downscale = 16, .max_views = 7}}, {FERN, {.max_size = 60}}};
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        cn_dataset full;
        load_ok(cases[c].dir, &cases[c].o, &full);
        assert_int_equal(full.n_test_listed, full.n_test);
        assert_true(full.n_test >= 3);
        for (int every = 1; every <= 3; every++)
            for (int only = 0; only <= 1; only++) {
                cn_dataset_opts o = cases[c].o;
                o.test_every = every;
                o.test_only = only;
                cn_dataset ds;
                load_ok(cases[c].dir, &o, &ds);
                assert_int_equal(ds.kind, full.kind);
                assert_int_equal(ds.ndc, full.ndc);
                assert_true(ds.near == full.near && ds.far == full.far);
                assert_int_equal(ds.downscale, full.downscale);
                assert_int_equal(ds.n_test_listed, full.n_test);
                assert_int_equal(ds.n_test, (full.n_test + every - 1) / every);
                for (int i = 0; i < ds.n_test; i++)
                    assert_same_view(&ds.test[i], &full.test[i * every]);
                assert_int_equal(ds.n_train, only ? 0 : full.n_train);
                assert_int_equal(ds.n_val, only ? 0 : full.n_val);
                for (int i = 0; i < ds.n_train; i++)
                    assert_same_view(&ds.train[i], &full.train[i]);
                for (int i = 0; i < ds.n_val; i++)
                    assert_same_view(&ds.val[i], &full.val[i]);
                cn_dataset_free(&ds);
            }
        cn_dataset_free(&full);
    }
    EXPECT_FAIL(LEGO, (&(cn_dataset_opts){.downscale = 16, .test_every = -1}), "test_every -1",
                ">= 0");
}

static void test_fern(void **state)
{
    (void)state;
    cn_dataset ds1, ds2;
    load_ok(FERN, &(cn_dataset_opts){.downscale = 1}, &ds1);
    assert_null(ds1.train[0].alpha); /* RGB files: every pixel opaque */
    assert_int_equal(ds1.kind, CN_DS_LLFF);
    assert_int_equal(ds1.ndc, 1);
    assert_int_equal(ds1.n_train, 17);
    assert_int_equal(ds1.n_val, 0);
    assert_int_equal(ds1.n_test, 3);
    assert_string_equal(ds1.test[0].name, "image000");
    assert_string_equal(ds1.test[1].name, "image008");
    assert_string_equal(ds1.test[2].name, "image016");
    assert_string_equal(ds1.train[0].name, "image001");
    assert_string_equal(ds1.train[7].name, "image009");
    assert_string_equal(ds1.train[16].name, "image019");
    assert_true(fabs(ds1.near - 1.2) < 1e-12);
    assert_true(fabs(ds1.far - FERN_BMAX / (FERN_BMIN * 0.75)) < 1e-9);
    for (int i = 0; i < ds1.n_train + ds1.n_test; i++) {
        const cn_view *v = i < ds1.n_train ? &ds1.train[i] : &ds1.test[i - ds1.n_train];
        assert_int_equal(v->w, 504);
        assert_int_equal(v->h, 378);
        assert_true(fabs(v->fx - FERN_FOCAL / 8) < 1e-9 && fabs(v->fy - FERN_FOCAL / 8) < 1e-9);
        assert_true(v->cx == 252.0 && v->cy == 189.0);
        assert_rotation_orthonormal(v->c2w, 1e-9);
        assert_pixels_in_range(v);
    }
    assert_average_pose_identity(&ds1);

    /* Downscale 2: 252x189, each pixel the mean of a 2x2 block. */
    load_ok(FERN, &(cn_dataset_opts){.downscale = 2, .max_views = 2}, &ds2);
    assert_int_equal(ds2.n_train, 2);
    assert_int_equal(ds2.n_test, 2);
    assert_string_equal(ds2.test[1].name, "image008");
    const cn_view *a = &ds1.test[1], *b = &ds2.test[1];
    assert_int_equal(b->w, 252);
    assert_int_equal(b->h, 189);
    assert_true(fabs(b->fx - FERN_FOCAL / 16) < 1e-9 && b->cx == 126.0 && b->cy == 94.5);
    assert_memory_equal(a->c2w, b->c2w, sizeof a->c2w); /* recentred on all 20 poses */
    for (int y = 0; y < 189; y++)
        for (int x = 0; x < 252; x++)
            for (int k = 0; k < 3; k++) {
                const float *p = a->rgb + ((size_t)(2 * y) * 504 + 2 * x) * 3 + k;
                float m = (p[0] + p[3] + p[504 * 3] + p[504 * 3 + 3]) / 4;
                assert_true(fabsf(b->rgb[((size_t)y * 252 + x) * 3 + k] - m) < 1e-6f);
            }

    /* 378 / 4 is not an integer: the two leftover rows are cropped, one at the top and one
     * at the bottom, before averaging; the principal point follows the crop. */
    cn_dataset ds4;
    load_ok(FERN, &(cn_dataset_opts){.downscale = 4, .max_views = 2}, &ds4);
    const cn_view *c4 = &ds4.test[1];
    assert_int_equal(c4->w, 126);
    assert_int_equal(c4->h, 94);
    assert_true(fabs(c4->fx - FERN_FOCAL / 32) < 1e-9 && fabs(c4->fy - FERN_FOCAL / 32) < 1e-9);
    assert_true(c4->cx == 63.0 && c4->cy == 47.0);
    assert_memory_equal(a->c2w, c4->c2w, sizeof a->c2w);
    for (int y = 0; y < 94; y++)
        for (int x = 0; x < 126; x++)
            for (int k = 0; k < 3; k++) {
                float m = 0;
                for (int dy = 0; dy < 4; dy++)
                    for (int dx = 0; dx < 4; dx++)
                        m += a->rgb[((size_t)(1 + 4 * y + dy) * 504 + 4 * x + dx) * 3 + k];
                assert_true(fabsf(c4->rgb[((size_t)y * 126 + x) * 3 + k] - m / 16) < 1e-6f);
            }
    cn_dataset_free(&ds4);
    cn_dataset_free(&ds1);
    cn_dataset_free(&ds2);
}

/* ---- instant-ngp variant ---- */

/* Redirects stderr to a file while the dataset loads; returns what was printed. */
static void load_capturing_stderr(const char *dir, const cn_dataset_opts *o, cn_dataset *ds,
                                  char *out, size_t n)
{
    char path[PATH_LEN];
    join(path, dir, "stderr.txt");
    fflush(stderr);
    int saved = dup(2);
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    close(fd);
    char err[1024] = "";
    int rc = cn_dataset_load(dir, o, ds, err, sizeof err);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    if (rc != 0)
        fail_msg("%s: %s", dir, err);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    size_t got = fread(out, 1, n - 1, f);
    out[got] = '\0';
    fclose(f);
}

/* An instant-ngp copy of Lego's first ten training views in dir, with a missing frame
 * inserted at index 3; `intr` is the intrinsics part of the JSON. The distances of the
 * cameras from the origin go to rmin/rmax. */
static void make_ngp(const char *dir, const char *intr, double *rmin, double *rmax)
{
    char path[PATH_LEN], err[256], name[64];
    uint8_t *text;
    size_t len;
    assert_int_equal(cn_read_file(LEGO "/transforms_train.json", &text, &len, err, sizeof err),
                     0);
    cJSON *lego = cJSON_ParseWithLength((const char *)text, len);
    free(text);
    assert_non_null(lego);
    cJSON *root = cJSON_Parse(intr);
    assert_non_null(root);
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    join(path, dir, "images");
    make_dir(path);
    *rmin = INFINITY;
    *rmax = 0;
    for (int i = 0; i < 10; i++) {
        const cJSON *src = cJSON_GetArrayItem(cJSON_GetObjectItem(lego, "frames"), i);
        cJSON *m = cJSON_GetObjectItem(src, "transform_matrix");
        double r = 0;
        for (int k = 0; k < 3; k++) {
            double t = cJSON_GetArrayItem(cJSON_GetArrayItem(m, k), 3)->valuedouble;
            r += t * t;
        }
        *rmin = fmin(*rmin, sqrt(r));
        *rmax = fmax(*rmax, sqrt(r));
        snprintf(path, sizeof path, "%s/train/r_%d.png", LEGO, i);
        snprintf(name, sizeof name, "images/r_%d.png", i);
        copy_file(path, dir, name, SIZE_MAX);
        if (i == 3) { /* an image that does not exist */
            cJSON *gone = cJSON_CreateObject();
            cJSON_AddStringToObject(gone, "file_path", "images/gone.png");
            cJSON_AddItemToObject(gone, "transform_matrix", cJSON_Duplicate(m, 1));
            cJSON_AddItemToArray(frames, gone);
        }
        cJSON *fr = cJSON_CreateObject();
        snprintf(name, sizeof name, i % 2 ? "images/r_%d.png" : "./images/r_%d", i);
        cJSON_AddStringToObject(fr, "file_path", name);
        cJSON_AddItemToObject(fr, "transform_matrix", cJSON_Duplicate(m, 1));
        cJSON_AddItemToArray(frames, fr);
    }
    char *json = cJSON_Print(root);
    write_text(dir, "transforms.json", json);
    free(json);
    cJSON_Delete(root);
    cJSON_Delete(lego);
}

static void test_ngp(void **state)
{
    (void)state;
    char dir[PATH_LEN], dir2[PATH_LEN], log[4096];
    double rmin, rmax;
    cn_dataset ds;
    fresh_dir(dir, "ngp");
    make_ngp(dir,
             "{\"fl_x\": 555.5, \"fl_y\": 560, \"cx\": 201, \"cy\": 199, \"w\": 400, "
             "\"h\": 400, \"aabb_scale\": 2}",
             &rmin, &rmax);
    load_capturing_stderr(dir, &(cn_dataset_opts){.downscale = 2}, &ds, log, sizeof log);
    /* The missing frame is reported to the caller; the library prints nothing. */
    assert_string_equal(log, "");
    assert_int_equal(ds.n_skipped, 1);
    assert_contains(ds.skipped, "images/gone.png: missing");
    assert_int_equal(ds.kind, CN_DS_NGP);
    assert_int_equal(ds.ndc, 0);
    /* Ten usable frames: 0 and 8 are test views. */
    assert_int_equal(ds.n_test, 2);
    assert_int_equal(ds.n_val, 0);
    assert_int_equal(ds.n_train, 8);
    assert_string_equal(ds.test[0].name, "r_0");
    assert_string_equal(ds.test[1].name, "r_8");
    const char *train[8] = {"r_1", "r_2", "r_3", "r_4", "r_5", "r_6", "r_7", "r_9"};
    for (int i = 0; i < 8; i++) {
        const cn_view *v = &ds.train[i];
        assert_string_equal(v->name, train[i]);
        assert_int_equal(v->w, 200);
        assert_int_equal(v->h, 200);
        assert_true(fabs(v->fx - 277.75) < 1e-9 && fabs(v->fy - 280) < 1e-9);
        assert_true(fabs(v->cx - 100.5) < 1e-9 && fabs(v->cy - 99.5) < 1e-9);
        assert_pixels_in_range(v);
    }
    /* near = max(0.05, min |c| - sqrt(3) s), far = max |c| + sqrt(3) s with s = 2. */
    assert_true(fabs(ds.near - fmax(0.05, rmin - 2 * sqrt(3.0))) < 1e-9);
    assert_true(fabs(ds.far - (rmax + 2 * sqrt(3.0))) < 1e-9);
    cn_dataset_free(&ds);

    /* Overrides. */
    load_capturing_stderr(dir, &(cn_dataset_opts){.downscale = 4, .near = 0.5, .far = 9},
                          &ds, log, sizeof log);
    assert_true(ds.near == 0.5 && ds.far == 9.0);
    cn_dataset_free(&ds);

    /* Only a field of view: focal from it, principal point at the centre, fy = fx; the
     * bounds use every frame even when max_views keeps fewer. */
    rm_tree(dir);
    fresh_dir(dir2, "ngp_angle");
    make_ngp(dir2, "{\"camera_angle_x\": 0.6911112070083618}", &rmin, &rmax);
    load_capturing_stderr(dir2, &(cn_dataset_opts){.downscale = 4, .max_views = 2}, &ds, log,
                          sizeof log);
    assert_int_equal(ds.n_train, 2);
    assert_int_equal(ds.n_test, 2);
    assert_string_equal(ds.train[1].name, "r_2");
    assert_string_equal(ds.test[1].name, "r_8");
    double focal = 0.5 * 100 / tan(0.5 * 0.6911112070083618);
    assert_true(fabs(ds.train[0].fx - focal) < 1e-9 && fabs(ds.train[0].fy - focal) < 1e-9);
    assert_true(ds.train[0].cx == 50.0 && ds.train[0].cy == 50.0);
    assert_true(fabs(ds.near - fmax(0.05, rmin - sqrt(3.0))) < 1e-9);
    assert_true(fabs(ds.far - (rmax + sqrt(3.0))) < 1e-9);
    cn_dataset_free(&ds);
    rm_tree(dir2);
}

/* ---- malformed datasets ---- */

#define M_OK "[[1,0,0,0.5],[0,1,0,0],[0,0,1,4],[0,0,0,1]]"

/* A Blender copy in TMP_ROOT/name: train/r_0.png and r_1.png and the given
 * transforms_train.json. */
static void make_blender(char dir[PATH_LEN], const char *name, const char *json)
{
    char sub[PATH_LEN];
    fresh_dir(dir, name);
    join(sub, dir, "train");
    make_dir(sub);
    copy_file(LEGO "/train/r_0.png", sub, "r_0.png", SIZE_MAX);
    copy_file(LEGO "/train/r_1.png", sub, "r_1.png", SIZE_MAX);
    write_text(dir, "transforms_train.json", json);
}

/* A transforms file with two frames, r_0 and r_1, and the given angle and matrices. */
static void blender_json(char *out, size_t n, const char *angle, const char *m0,
                         const char *m1)
{
    snprintf(out, n,
             "{\"camera_angle_x\": %s, \"frames\": [\n"
             "  {\"file_path\": \"./train/r_0\", \"transform_matrix\": %s},\n"
             "  {\"file_path\": \"./train/r_1\", \"transform_matrix\": %s}]}\n",
             angle, m0, m1);
}

static void test_blender_errors(void **state)
{
    (void)state;
    char dir[PATH_LEN], path[PATH_LEN], json[2048], err[256];
    const cn_dataset_opts *o = &(cn_dataset_opts){.max_views = 0};
    cn_dataset ds;

    /* The good copy loads; val and test are absent, so empty. */
    blender_json(json, sizeof json, "0.69", M_OK, M_OK);
    make_blender(dir, "bl/good", json);
    load_ok(dir, o, &ds);
    assert_int_equal(ds.n_train, 2);
    assert_int_equal(ds.n_val + ds.n_test, 0);
    assert_null(ds.val);
    cn_dataset_free(&ds);

    make_blender(dir, "bl/malformed", "{\"camera_angle_x\": 0.69, \"frames\": [");
    EXPECT_FAIL(dir, o, "transforms_train.json", "malformed JSON", "line 1",
                "unexpected end of file");
    make_blender(dir, "bl/trailing", "{\"camera_angle_x\": 0.69, \"frames\": []} x");
    EXPECT_FAIL(dir, o, "transforms_train.json", "malformed JSON", "after the top-level");
    make_blender(dir, "bl/array", "[1, 2]");
    EXPECT_FAIL(dir, o, "transforms_train.json", "JSON object");
    make_blender(dir, "bl/no_frames", "{\"camera_angle_x\": 0.69}");
    EXPECT_FAIL(dir, o, "transforms_train.json: frames: missing");
    make_blender(dir, "bl/frames_obj", "{\"camera_angle_x\": 0.69, \"frames\": {}}");
    EXPECT_FAIL(dir, o, "transforms_train.json: frames: expected an array");

    blender_json(json, sizeof json, "0.69", M_OK, "[[1,0,0],[0,1,0],[0,0,1]]");
    make_blender(dir, "bl/shape", json);
    EXPECT_FAIL(dir, o, "transforms_train.json: frames[1].transform_matrix: expected a 4x4 array"
                        " of numbers");
    blender_json(json, sizeof json, "0.69", "[[1,0,0,0],[0,1,0,0],[0,0,1,\"4\"],[0,0,0,1]]",
                 M_OK);
    make_blender(dir, "bl/shape_str", json);
    EXPECT_FAIL(dir, o, "frames[0].transform_matrix: expected a 4x4 array");

    blender_json(json, sizeof json, "\"0.69\"", M_OK, M_OK);
    make_blender(dir, "bl/angle_str", json);
    EXPECT_FAIL(dir, o, "transforms_train.json: camera_angle_x: expected a number");
    make_blender(dir, "bl/angle_missing", "{\"frames\": []}");
    EXPECT_FAIL(dir, o, "camera_angle_x: missing");
    blender_json(json, sizeof json, "4", M_OK, M_OK);
    make_blender(dir, "bl/angle_big", json);
    EXPECT_FAIL(dir, o, "camera_angle_x: must be a field of view");

    /* NaN is not JSON; an overflowing number is parsed as infinity. */
    blender_json(json, sizeof json, "0.69", M_OK,
                 "[[1,0,0,0],[0,1,0,NaN],[0,0,1,4],[0,0,0,1]]");
    make_blender(dir, "bl/nan", json);
    EXPECT_FAIL(dir, o, "transforms_train.json", "malformed JSON", "line 3", "NaN");
    blender_json(json, sizeof json, "0.69", "[[1,0,0,0],[0,1,0,1e999],[0,0,1,4],[0,0,0,1]]",
                 M_OK);
    make_blender(dir, "bl/inf", json);
    EXPECT_FAIL(dir, o, "frames[0].transform_matrix: non-finite");
    blender_json(json, sizeof json, "0.69", M_OK, "[[0,0,0,1],[0,0,0,2],[0,0,0,3],[0,0,0,1]]");
    make_blender(dir, "bl/zero_rot", json);
    EXPECT_FAIL(dir, o, "frames[1].transform_matrix: degenerate pose", "not orthonormal");
    blender_json(json, sizeof json, "0.69", M_OK, "[[-1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]");
    make_blender(dir, "bl/reflect", json);
    EXPECT_FAIL(dir, o, "frames[1].transform_matrix: degenerate pose", "reflection");

    make_blender(dir, "bl/empty", "{\"camera_angle_x\": 0.69, \"frames\": []}");
    EXPECT_FAIL(dir, o, "no training views");
    make_blender(dir, "bl/frame_path",
                 "{\"camera_angle_x\": 0.69, \"frames\": [{\"file_path\": 3, "
                 "\"transform_matrix\": " M_OK "}]}");
    EXPECT_FAIL(dir, o, "frames[0].file_path: expected a non-empty string");
    make_blender(dir, "bl/frame_nomatrix",
                 "{\"camera_angle_x\": 0.69, \"frames\": [{\"file_path\": \"./train/r_0\"}]}");
    EXPECT_FAIL(dir, o, "frames[0].transform_matrix: missing");
    make_blender(dir, "bl/missing_image",
                 "{\"camera_angle_x\": 0.69, \"frames\": [{\"file_path\": \"./train/r_7\", "
                 "\"transform_matrix\": " M_OK "}]}");
    EXPECT_FAIL(dir, o, "train/r_7.png: missing", "frames[0].file_path");

    /* A malformed val file is an error too. */
    blender_json(json, sizeof json, "0.69", M_OK, M_OK);
    make_blender(dir, "bl/bad_val", json);
    write_text(dir, "transforms_val.json", "{\"camera_angle_x\": 0.69, \"frames\": [}");
    EXPECT_FAIL(dir, o, "transforms_val.json: malformed JSON");

    /* Images: truncated, not a PNG, sizes differ, downscale not dividing the size. */
    make_blender(dir, "bl/truncated", json);
    join(path, dir, "train");
    copy_file(LEGO "/train/r_1.png", path, "r_1.png", 200);
    EXPECT_FAIL(dir, o, "train/r_1.png: truncated");
    make_blender(dir, "bl/not_png", json);
    join(path, dir, "train");
    write_text(path, "r_0.png", "GIF89a, not a PNG at all");
    EXPECT_FAIL(dir, o, "train/r_0.png: neither a PNG nor a JPEG");
    make_blender(dir, "bl/sizes", json);
    uint8_t *small = calloc(200 * 200, 3);
    assert_non_null(small);
    join(path, dir, "train/r_1.png");
    assert_int_equal(cn_png_write_rgb8(path, small, 200, 200, 600, err, sizeof err), 0);
    free(small);
    EXPECT_FAIL(dir, o, "images differ in size", "train/r_0.png is 400x400",
                "train/r_1.png is 200x200");
    make_blender(dir, "bl/downscale", json);
    EXPECT_FAIL(dir, &(cn_dataset_opts){.downscale = -2}, "downscale -2");
    EXPECT_FAIL(dir, &(cn_dataset_opts){.near = 7}, "near 7, far 6");

    /* Layout. */
    fresh_dir(dir, "bl/empty");
    EXPECT_FAIL(dir, o, "unknown dataset layout", "bl/empty", "transforms_train.json",
                "transforms.json", "poses_bounds.npy");
    EXPECT_FAIL(TMP_ROOT "/does-not-exist", o, "does-not-exist: No such file or directory");
    rm_tree(TMP_ROOT "/bl");
}

static void test_ngp_errors(void **state)
{
    (void)state;
    char dir[PATH_LEN];
    const cn_dataset_opts *o = &(cn_dataset_opts){.max_views = 0};
    fresh_dir(dir, "ngp_bad");
    write_text(dir, "transforms.json",
               "{\"w\": 400, \"frames\": [{\"file_path\": \"a.png\", \"transform_matrix\": "
               M_OK "}]}");
    EXPECT_FAIL(dir, o, "transforms.json: frames[0].fl_x: missing", "camera_angle_x");
    /* Lens models (nerfstudio's camera_model, instant-ngp's is_fisheye) and their keys. */
    write_text(dir, "transforms.json", "{\"fl_x\": 300, \"camera_model\": \"EQUIRECTANGULAR\", "
               "\"frames\": []}");
    EXPECT_FAIL(dir, o, "transforms.json: camera_model: 'EQUIRECTANGULAR' is not supported");
    write_text(dir, "transforms.json", "{\"fl_x\": 300, \"is_fisheye\": 1, \"frames\": []}");
    EXPECT_FAIL(dir, o, "transforms.json: is_fisheye: expected true or false");
    write_text(dir, "transforms.json",
               "{\"fl_x\": 300, \"k4\": 0.1, \"frames\": [{\"file_path\": \"a.png\", "
               "\"transform_matrix\": " M_OK "}]}");
    EXPECT_FAIL(dir, o, "transforms.json: frames[0].k4: is 0.1, but the OPENCV lens model has no k4");
    write_text(dir, "transforms.json",
               "{\"fl_x\": 300, \"frames\": [{\"file_path\": \"a.png\", \"camera_model\": "
               "\"PINHOLE\", \"k1\": -0.1, \"transform_matrix\": " M_OK "}]}");
    EXPECT_FAIL(dir, o, "transforms.json: frames[0].k1: is -0.1, but the PINHOLE lens model has no k1");
    write_text(dir, "transforms.json",
               "{\"fl_x\": 300, \"frames\": [{\"file_path\": \"a.png\", \"p2\": \"x\", "
               "\"transform_matrix\": " M_OK "}]}");
    EXPECT_FAIL(dir, o, "transforms.json: frames[0].p2: expected a number");
    write_text(dir, "transforms.json", "{\"fl_x\": -3, \"frames\": []}");
    EXPECT_FAIL(dir, o, "transforms.json: fl_x: must be positive");
    write_text(dir, "transforms.json", "{\"fl_x\": 300, \"cx\": \"200\", \"frames\": []}");
    EXPECT_FAIL(dir, o, "transforms.json: cx: expected a number");
    /* One usable frame: it is the test view, nothing is left to train on. */
    copy_file(LEGO "/train/r_0.png", dir, "a.png", SIZE_MAX);
    write_text(dir, "transforms.json",
               "{\"fl_x\": 300, \"frames\": [{\"file_path\": \"a.png\", \"transform_matrix\": " M_OK
               "}, {\"file_path\": \"b.png\", \"transform_matrix\": " M_OK "}]}");
    EXPECT_FAIL(dir, o, "no training views");
    /* No frame's image found: the error says so and names the first. */
    write_text(dir, "transforms.json",
               "{\"fl_x\": 300, \"frames\": [{\"file_path\": \"pics/x.png\", \"transform_matrix\": "
               M_OK "}, {\"file_path\": \"pics/y.png\", \"transform_matrix\": " M_OK "}]}");
    EXPECT_FAIL(dir, o, "no training views", "the images of all 2 frames are missing",
                "pics/x.png: missing");
    rm_tree(dir);
}

/* A transforms.json written on Windows (instant-ngp's scripts there write file_path with
 * backslashes): the frames' images are found under the same path with slashes. */
static void test_ngp_windows_paths(void **state)
{
    (void)state;
    char dir[PATH_LEN], top[PATH_LEN], sub[PATH_LEN];
    cn_dataset ds;
    fresh_dir(dir, "ngp_win");
    join(top, dir, "custom_data");
    make_dir(top);
    join(sub, top, "images");
    make_dir(sub);
    copy_file(LEGO "/train/r_0.png", sub, "0001.png", SIZE_MAX);
    copy_file(LEGO "/train/r_1.png", sub, "0002.png", SIZE_MAX);
    copy_file(LEGO "/train/r_2.png", sub, "0003.png", SIZE_MAX);
    write_text(dir, "transforms.json",
               "{\"fl_x\": 300, \"frames\": ["
               "{\"file_path\": \"./custom_data\\\\images/0001.png\", \"transform_matrix\": " M_OK "}, "
               "{\"file_path\": \"custom_data\\\\images\\\\0002\", \"transform_matrix\": " M_OK "}, "
               "{\"file_path\": \".\\\\custom_data\\\\images\\\\0003.png\", \"transform_matrix\": " M_OK "}]}");
    load_ok(dir, &(cn_dataset_opts){.max_views = 0}, &ds);
    assert_int_equal(ds.n_skipped, 0);
    assert_int_equal(ds.n_test, 1);
    assert_int_equal(ds.n_train, 2);
    assert_string_equal(ds.train[0].name, "0002");
    assert_string_equal(ds.train[1].name, "0003");
    cn_dataset_free(&ds);
    rm_tree(dir);
}

/* ---- LLFF ---- */

/* Writes a .npy file: magic, version, header dict padded to a multiple of 64, data. */
static void write_npy(const char *dir, int major, const char *dict, const double *v, size_t n)
{
    char path[PATH_LEN];
    size_t pre = major == 1 ? 10 : 12, dl = strlen(dict);
    size_t hl = (pre + dl + 1 + 63) / 64 * 64 - pre;
    uint8_t *buf = calloc(1, pre + hl + 8 * n);
    assert_non_null(buf);
    memcpy(buf, "\x93NUMPY", 6);
    buf[6] = (uint8_t)major;
    buf[7] = 0;
    for (size_t i = 0; i < pre - 8; i++)
        buf[8 + i] = (uint8_t)(hl >> (8 * i));
    memset(buf + pre, ' ', hl);
    memcpy(buf + pre, dict, dl);
    buf[pre + hl - 1] = '\n';
    memcpy(buf + pre + hl, v, 8 * n); /* the test host is little-endian */
    join(path, dir, "poses_bounds.npy");
    write_file(path, buf, pre + hl + 8 * n);
    free(buf);
}

#define NPY_DICT "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 17), }"

/* One poses_bounds row for a camera with NeRF-convention rotation R ([right, up, back]
 * columns) and centre t. */
static void llff_row(double *r, const double R[3][3], const double t[3], double bn, double bf)
{
    const double hwf[3] = {3024, 4032, FERN_FOCAL};
    for (int i = 0; i < 3; i++) {
        r[5 * i + 0] = -R[i][1]; /* down */
        r[5 * i + 1] = R[i][0];  /* right */
        r[5 * i + 2] = R[i][2];  /* back */
        r[5 * i + 3] = t[i];
        r[5 * i + 4] = hwf[i];
    }
    r[15] = bn;
    r[16] = bf;
}

/* Two cameras with the same rotation about y, 1 unit left and right of (5, 2, 3). */
static void llff_rows(double rows[34])
{
    const double a = 0.5, c = cos(a), s = sin(a);
    const double R[3][3] = {{c, 0, s}, {0, 1, 0}, {-s, 0, c}};
    for (int k = 0; k < 2; k++) {
        double d = k ? 1 : -1;
        double t[3] = {5 + d * R[0][0], 2 + d * R[1][0], 3 + d * R[2][0]};
        llff_row(rows + 17 * k, R, t, 2.0 + k, 8.0 - k);
    }
}

/* An LLFF copy in TMP_ROOT/name with two of Fern's images in images_8/. */
static void make_llff(char dir[PATH_LEN], const char *name)
{
    char sub[PATH_LEN];
    fresh_dir(dir, name);
    join(sub, dir, "images_8");
    make_dir(sub);
    copy_file(FERN "/images_8/image000.png", sub, "a.png", SIZE_MAX);
    copy_file(FERN "/images_8/image001.png", sub, "b.png", SIZE_MAX);
}

static void test_llff_synthetic(void **state)
{
    (void)state;
    char dir[PATH_LEN];
    double rows[34];
    cn_dataset ds;
    make_llff(dir, "llff_good");
    llff_rows(rows);
    write_npy(dir, 1, NPY_DICT, rows, 34);
    load_ok(dir, NULL, &ds);
    /* Scaled by 1 / (0.75 * 2), recentred: both cameras axis-aligned at x = -/+ 1/1.5. */
    const double sc = 1 / 1.5;
    assert_int_equal(ds.ndc, 1);
    assert_true(fabs(ds.near - 0.9 * 2 * sc) < 1e-12 && fabs(ds.far - 8 * sc) < 1e-12);
    assert_int_equal(ds.n_test, 1);
    assert_int_equal(ds.n_train, 1);
    assert_string_equal(ds.test[0].name, "a");
    assert_string_equal(ds.train[0].name, "b");
    for (int k = 0; k < 2; k++) {
        const cn_view *v = k ? &ds.train[0] : &ds.test[0];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 4; j++) {
                double want = j < 3 ? (i == j) : i == 0 ? (k ? sc : -sc) : 0.0;
                assert_true(fabs(v->c2w[i][j] - want) < 1e-12);
            }
    }
    cn_dataset_free(&ds);

    /* Version 2.0 headers are read too; an images_16 directory serves downscale 2. */
    write_npy(dir, 2, NPY_DICT, rows, 34);
    char sub[PATH_LEN], err[256];
    join(sub, dir, "images_16");
    make_dir(sub);
    uint8_t px[6 * 4 * 3] = {0};
    for (int i = 0; i < 2; i++) {
        char path[PATH_LEN], name[8] = "a.png";
        name[0] = (char)('a' + i);
        join(path, sub, name);
        assert_int_equal(cn_png_write_rgb8(path, px, 6, 4, 18, err, sizeof err), 0);
    }
    load_ok(dir, &(cn_dataset_opts){.downscale = 2}, &ds);
    assert_int_equal(ds.train[0].w, 6);
    assert_true(fabs(ds.train[0].fx - FERN_FOCAL * 6 / 4032) < 1e-9);
    cn_dataset_free(&ds);
    rm_tree(dir);
}

/* A capture around an object stored as poses_bounds.npy (as NeRF's own 360-degree real
 * scenes and NeRD's are): four cameras 3 units from the origin on the x and z axes, all
 * looking at it, up +y. NDC would put half of them behind the plane z = -1; the loader
 * takes the inward conventions instead (up to +z, the origin where the optical axes meet,
 * mean camera distance 4, near and far from the depth bounds, 0.9 and 1.1 times). */
static void test_llff_inward(void **state)
{
    (void)state;
    char dir[PATH_LEN], sub[PATH_LEN];
    make_llff(dir, "llff_inward");
    join(sub, dir, "images_8");
    copy_file(FERN "/images_8/image002.png", sub, "c.png", SIZE_MAX);
    copy_file(FERN "/images_8/image003.png", sub, "d.png", SIZE_MAX);
    double rows[4 * 17];
    const double pos[4][3] = {{3, 0, 0}, {0, 0, 3}, {-3, 0, 0}, {0, 0, -3}};
    for (int k = 0; k < 4; k++) {
        /* back = the centre's direction, up = +y, right = up x back */
        const double *b = pos[k];
        const double R[3][3] = {{b[2] / 3, 0, b[0] / 3}, {0, 1, 0}, {-b[0] / 3, 0, b[2] / 3}};
        llff_row(rows + 17 * k, R, pos[k], 2.0, 4.0);
    }
    write_npy(dir, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (4, 17), }", rows,
              4 * 17);
    cn_dataset ds;
    load_ok(dir, NULL, &ds);
    assert_int_equal(ds.ndc, 0);
    const double sc = 4.0 / 3.0;
    assert_true(fabs(ds.near - 0.9 * 2 * sc) < 1e-9 && fabs(ds.far - 1.1 * 4 * sc) < 1e-9);
    assert_int_equal(ds.n_test, 1);
    assert_int_equal(ds.n_train, 3);
    for (int k = 0; k < 4; k++) {
        const cn_view *v = k ? &ds.train[k - 1] : &ds.test[0];
        double cc[3], r = 0, dot = 0;
        for (int i = 0; i < 3; i++) {
            cc[i] = v->c2w[i][3];
            r += cc[i] * cc[i];
            dot += v->c2w[i][2] * cc[i]; /* back axis along the centre: looks at the origin */
        }
        r = sqrt(r);
        assert_true(fabs(r - 4) < 1e-9);
        assert_true(fabs(dot - 4) < 1e-9);
        assert_true(fabs(cc[2]) < 1e-9);           /* every camera at the height of the origin */
        assert_true(fabs(v->c2w[2][1] - 1) < 1e-9); /* up is +z */
    }
    cn_dataset_free(&ds);
    rm_tree(dir);
}

static void test_llff_errors(void **state)
{
    (void)state;
    char dir[PATH_LEN];
    double rows[34];
    const cn_dataset_opts *o = NULL;
    make_llff(dir, "llff_bad");
    llff_rows(rows);

    write_npy(dir, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 15), }", rows, 30);
    EXPECT_FAIL(dir, o, "poses_bounds.npy", "shape (2, 15)", "(N, 17)");
    write_npy(dir, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (34,), }", rows, 34);
    EXPECT_FAIL(dir, o, "poses_bounds.npy", "shape (34)");
    write_npy(dir, 1, "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 17), }", rows, 17);
    EXPECT_FAIL(dir, o, "poses_bounds.npy", "dtype '<f4'", "'<f8'");
    write_npy(dir, 1, "{'descr': '>f8', 'fortran_order': False, 'shape': (2, 17), }", rows, 34);
    EXPECT_FAIL(dir, o, "dtype '>f8'");
    write_npy(dir, 1, "{'descr': '<f8', 'fortran_order': True, 'shape': (2, 17), }", rows, 34);
    EXPECT_FAIL(dir, o, "poses_bounds.npy", "fortran_order True");
    write_npy(dir, 1, "{'descr': '<f8', 'shape': (2, 17), }", rows, 34);
    EXPECT_FAIL(dir, o, "bad .npy header", "missing");
    write_npy(dir, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 17), 'x': 1}",
              rows, 34);
    EXPECT_FAIL(dir, o, "bad .npy header", "unexpected key 'x'");
    write_npy(dir, 1, "not a dict", rows, 34);
    EXPECT_FAIL(dir, o, "bad .npy header");
    write_npy(dir, 3, NPY_DICT, rows, 34);
    EXPECT_FAIL(dir, o, "unsupported .npy version 3.0");
    write_npy(dir, 1, NPY_DICT, rows, 33);
    EXPECT_FAIL(dir, o, "poses_bounds.npy", "truncated");
    write_npy(dir, 1, NPY_DICT, rows, 34);
    char path[PATH_LEN];
    join(path, dir, "poses_bounds.npy");
    write_file(path, "\x93NUMPX\x01\x00", 8);
    EXPECT_FAIL(dir, o, "not a NumPy .npy file");

    /* Values. */
    double bad[34];
    memcpy(bad, rows, sizeof bad);
    bad[17 + 8] = NAN;
    write_npy(dir, 1, NPY_DICT, bad, 34);
    EXPECT_FAIL(dir, o, "poses_bounds.npy: row 1: non-finite");
    memcpy(bad, rows, sizeof bad);
    for (int i = 0; i < 3; i++)
        bad[5 * i] = bad[5 * i + 1] = bad[5 * i + 2] = 0;
    write_npy(dir, 1, NPY_DICT, bad, 34);
    EXPECT_FAIL(dir, o, "poses_bounds.npy: row 0: degenerate pose");
    memcpy(bad, rows, sizeof bad);
    bad[17 + 15] = -1;
    write_npy(dir, 1, NPY_DICT, bad, 34);
    EXPECT_FAIL(dir, o, "row 1: depth bounds");
    memcpy(bad, rows, sizeof bad);
    bad[14] = 0;
    write_npy(dir, 1, NPY_DICT, bad, 34);
    EXPECT_FAIL(dir, o, "row 0: image height, width and focal length must be positive");

    /* Images: one too many, none, a directory missing. */
    write_npy(dir, 1, NPY_DICT, rows, 34);
    char sub[PATH_LEN];
    join(sub, dir, "images_8");
    copy_file(FERN "/images_8/image002.png", sub, "c.png", SIZE_MAX);
    EXPECT_FAIL(dir, o, "images_8: 3 images (PNG, JPEG) for 2 poses");
    rm_tree(sub);
    EXPECT_FAIL(dir, o, "no image directory", "images_8/");
    /* One pose: it is the test view; nothing to train on. */
    make_dir(sub);
    copy_file(FERN "/images_8/image002.png", sub, "c.png", SIZE_MAX);
    write_npy(dir, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 17), }", rows, 17);
    EXPECT_FAIL(dir, o, "no training views");
    rm_tree(dir);
}

/* Removes the temporary root once every test has cleaned up after itself. */
static int remove_tmp_root(void **state)
{
    (void)state;
    rmdir(TMP_ROOT);
    return 0;
}

/* cn_read_file_max: a regular file by its size, a pipe as it is read (a FIFO fed without end
 * is refused once it passes the limit, not read to 4 GiB), and what fits is read whole. */
static void test_read_limit(void **state)
{
    (void)state;
    char err[512], path[256];
    uint8_t *data;
    size_t len;
    snprintf(path, sizeof path, "/tmp/cnerf_read_limit_%ld", (long)getpid());
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    for (int i = 0; i < 3000; i++)
        fputc('x', f);
    fclose(f);
    assert_int_equal(cn_read_file_max(path, 3000, "a test file", &data, &len, err, sizeof err), 0);
    assert_int_equal(len, 3000);
    free(data);
    assert_int_equal(cn_read_file_max(path, 2999, "a test file", &data, &len, err, sizeof err), -1);
    assert_non_null(strstr(err, "3000 bytes, more than the 2999 that a test file can need"));
    assert_null(data);
    remove(path);
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    const pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) { /* the writer: zeros until the reader closes the pipe */
        close(fd[0]);
        static const uint8_t zero[4096];
        while (write(fd[1], zero, sizeof zero) > 0) {
        }
        _exit(0);
    }
    close(fd[1]);
    snprintf(path, sizeof path, "/dev/fd/%d", fd[0]);
    assert_int_equal(cn_read_file_max(path, 100000, "a test file", &data, &len, err, sizeof err),
                     -1);
    assert_non_null(strstr(err, "bytes or more, more than the 100000 that a test file can need"));
    close(fd[0]);
    int st;
    waitpid(pid, &st, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_png_roundtrip),  cmocka_unit_test(test_png_formats),
        cmocka_unit_test(test_png_read_errors), cmocka_unit_test(test_downscale),
        cmocka_unit_test(test_lego),           cmocka_unit_test(test_fern),
        cmocka_unit_test(test_test_every),
        cmocka_unit_test(test_ngp),            cmocka_unit_test(test_blender_errors),
        cmocka_unit_test(test_ngp_errors),
        cmocka_unit_test(test_ngp_windows_paths),     cmocka_unit_test(test_llff_synthetic),
        cmocka_unit_test(test_llff_inward),
        cmocka_unit_test(test_llff_errors),    cmocka_unit_test(test_read_limit),
    };
    return cmocka_run_group_tests(tests, NULL, remove_tmp_root);
}
