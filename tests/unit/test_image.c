/* Loading images (cn_image.h): PNG and JPEG decoded straight into their downscaled, upright
 * form, against reading the whole image and downscaling it; EXIF orientations; the
 * messages for broken files. The JPEGs are written here with libjpeg. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <jpeglib.h>
#include <png.h>

#include "cn_dataset.h"
#include "cn_image.h"
#include "cn_rng.h"
#include "cn_buf.h"
#include "cn_file.h"
#include "testutil.h"

#define TMP CNERF_BINARY_DIR "/test_image_tmp"

/* A JPEG of w x h pixels (3 channels, or 1 for grey, or 4 for CMYK) at quality 100 without
 * chroma subsampling, with an EXIF orientation tag when orientation > 0. */
static void write_jpeg(cn_buf *out, const uint8_t *px, int w, int h, int c, int orientation)
{
    struct jpeg_compress_struct ci;
    struct jpeg_error_mgr jerr;
    ci.err = jpeg_std_error(&jerr);
    jpeg_create_compress(&ci);
    unsigned char *mem = NULL;
    unsigned long len = 0;
    jpeg_mem_dest(&ci, &mem, &len);
    ci.image_width = (JDIMENSION)w;
    ci.image_height = (JDIMENSION)h;
    ci.input_components = c;
    ci.in_color_space = c == 1 ? JCS_GRAYSCALE : c == 4 ? JCS_CMYK : JCS_RGB;
    jpeg_set_defaults(&ci);
    jpeg_set_quality(&ci, 100, TRUE);
    for (int i = 0; i < ci.num_components; i++)
        ci.comp_info[i].h_samp_factor = ci.comp_info[i].v_samp_factor = 1;
    jpeg_start_compress(&ci, TRUE);
    if (orientation > 0) {
        /* "Exif\0\0", a big-endian TIFF header and one IFD with the orientation. */
        const uint8_t exif[] = {'E', 'x', 'i', 'f', 0, 0, 'M', 'M', 0, 42, 0, 0, 0, 8,
                                0, 1, 0x01, 0x12, 0, 3, 0, 0, 0, 1, 0, (uint8_t)orientation,
                                0, 0, 0, 0, 0, 0};
        jpeg_write_marker(&ci, JPEG_APP0 + 1, exif, sizeof exif);
    }
    while (ci.next_scanline < ci.image_height) {
        JSAMPROW row = (JSAMPROW)(px + (size_t)ci.next_scanline * (size_t)w * (size_t)c);
        jpeg_write_scanlines(&ci, &row, 1);
    }
    jpeg_finish_compress(&ci);
    jpeg_destroy_compress(&ci);
    *out = (cn_buf){0};
    cn_buf_put(out, mem, len);
    free(mem);
}

/* Four flat 16 x 16 quadrants, red, green, blue and white from the top left, clockwise;
 * flat blocks survive JPEG coding to within a few levels. */
static const uint8_t quad[4][3] = {{255, 0, 0}, {0, 255, 0}, {255, 255, 255}, {0, 0, 255}};

static uint8_t *quadrants(void)
{
    uint8_t *px = malloc(32 * 32 * 3);
    assert_non_null(px);
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 32; x++) {
            const int q = y < 16 ? (x < 16 ? 0 : 1) : (x < 16 ? 3 : 2);
            memcpy(px + (y * 32 + x) * 3, quad[q], 3);
        }
    return px;
}

static void assert_near(const cn_image *im, int x, int y, const uint8_t want[3])
{
    const float *p = im->px + ((size_t)y * im->w + x) * im->c;
    for (int k = 0; k < 3; k++)
        if (fabsf(p[k] * 255 - want[k]) > 4) {
            print_error("pixel (%d, %d) channel %d: %.1f, want %d\n", x, y, k, p[k] * 255,
                        want[k]);
            fail();
        }
}

/* Every EXIF orientation: the image comes out as a viewer shows it. The stored image has
 * red at the top left; orientation 6 (turn 90 degrees clockwise to view) puts red at the top
 * right, and so on. */
static void test_jpeg_orientation(void **state)
{
    (void)state;
    uint8_t *px = quadrants();
    /* Where stored quadrant 0 (red, top left) and 1 (green, top right) land upright, as
     * (x, y) quadrant coordinates. */
    static const int red[9][2] = {{0, 0}, {0, 0}, {1, 0}, {1, 1}, {0, 1},
                                  {0, 0}, {1, 0}, {1, 1}, {0, 1}};
    static const int green[9][2] = {{1, 0}, {1, 0}, {0, 0}, {0, 1}, {1, 1},
                                    {0, 1}, {1, 1}, {1, 0}, {0, 0}};
    char err[256];
    for (int o = 0; o <= 8; o++) {
        cn_buf b;
        write_jpeg(&b, px, 32, 32, 3, o);
        cn_image im;
        cn_image_info info;
        assert_int_equal(cn_image_load_mem("q.jpg", b.p, b.n, 1, NAN, &im, &info, err, sizeof err),
                         0);
        assert_int_equal(info.orientation, o == 0 ? 1 : o);
        assert_int_equal(im.w, 32);
        assert_int_equal(im.c, 3);
        assert_near(&im, red[o][0] * 16 + 8, red[o][1] * 16 + 8, quad[0]);
        assert_near(&im, green[o][0] * 16 + 8, green[o][1] * 16 + 8, quad[1]);
        cn_image_free(&im);
        cn_buf_free(&b);
    }
    free(px);
}

/* Cameras computed on the stored pixels (COLMAP ignores EXIF orientation): a quarter turn
 * is applied only when it makes the image's aspect match the cameras', a mirror or half turn
 * never. */
static void test_orientation_follows_cameras(void **state)
{
    (void)state;
    uint8_t px[32 * 16 * 3];
    memset(px, 128, sizeof px);
    char err[256];
    static const struct {
        int o;
        double aspect;
        int w, h, used;
    } cases[] = {{6, 2.0, 32, 16, 1},  {6, 0.5, 16, 32, 6},  {6, NAN, 16, 32, 6},
                 {8, 1.9, 32, 16, 1},  {8, 0.6, 16, 32, 8},  {3, 2.0, 32, 16, 1},
                 {3, NAN, 32, 16, 3},  {1, 0.5, 32, 16, 1}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        cn_buf b;
        write_jpeg(&b, px, 32, 16, 3, cases[i].o);
        cn_image im;
        cn_image_info info;
        assert_int_equal(cn_image_load_mem("r.jpg", b.p, b.n, 2, cases[i].aspect, &im, &info,
                                           err, sizeof err), 0);
        assert_int_equal(info.exif, cases[i].o);
        assert_int_equal(info.orientation, cases[i].used);
        assert_int_equal(info.file_w, cases[i].w);
        assert_int_equal(info.file_h, cases[i].h);
        assert_int_equal(im.w, cases[i].w / 2);
        cn_image_free(&im);
        cn_buf_free(&b);
    }
}

/* An image of w x h noise in c channels (3 or 4) as a 16-bit PNG. */
static void write_noise_png(const char *path, int w, int h, int c, uint64_t seed)
{
    /* A float image through cn_png_write_rgb8 would lose alpha; write the PNG by hand with
     * libpng's simplified API. */
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    pi.width = (png_uint_32)w;
    pi.height = (png_uint_32)h;
    pi.format = (c == 4 ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB) | PNG_FORMAT_FLAG_LINEAR;
    uint16_t *px = malloc(sizeof(uint16_t) * (size_t)w * h * c);
    assert_non_null(px);
    cn_rng r = cn_rng_seed(seed);
    for (size_t i = 0; i < (size_t)w * h * c; i++) {
        px[i] = (uint16_t)(cn_rng_u64(&r) >> 48);
        if (c == 4 && i % 4 == 3 && px[i] < 20000)
            px[i] = 0; /* some transparent pixels: the coverage-weighted colour */
    }
    assert_true(png_image_write_to_file(&pi, path, 0, px, 0, NULL));
    free(px);
}

/* Decoding into the downscaled image gives, bit for bit, the whole image downscaled. */
static void test_streaming_matches_downscale(void **state)
{
    (void)state;
    char err[256], path[512];
    assert_int_equal(system("rm -rf " TMP " && mkdir -p " TMP), 0);
    snprintf(path, sizeof path, "%s/noise.png", TMP);
    for (int c = 3; c <= 4; c++) {
        write_noise_png(path, 37, 29, c, 7 + c);
        cn_image full;
        assert_int_equal(cn_png_read(path, &full, err, sizeof err), 0);
        for (int f = 1; f <= 9; f++) {
            cn_image a, b;
            cn_image_info info;
            assert_int_equal(cn_image_load(path, f, NAN, &a, &info, err, sizeof err), 0);
            int x0, y0;
            if (f == 1) {
                b = full;
                x0 = y0 = 0;
            } else {
                assert_int_equal(cn_image_downscale_crop(&full, f, &b, &x0, &y0, err,
                                                         sizeof err), 0);
            }
            assert_int_equal(a.w, b.w);
            assert_int_equal(a.h, b.h);
            assert_int_equal(a.c, c);
            assert_int_equal(info.crop_x, x0);
            assert_int_equal(info.crop_y, y0);
            assert_int_equal(info.file_w, 37);
            assert_int_equal(info.file_h, 29);
            assert_memory_equal(a.px, b.px, sizeof(float) * (size_t)a.w * a.h * c);
            cn_image_free(&a);
            if (f > 1)
                cn_image_free(&b);
        }
        cn_image_free(&full);
    }
}

/* A rotated JPEG of odd size: loading at a factor equals loading upright at full size and
 * downscaling (the crop taken on the upright image's sides), to rounding. */
static void test_orientation_with_downscale(void **state)
{
    (void)state;
    const int w = 35, h = 22;
    uint8_t *px = malloc((size_t)w * h * 3);
    assert_non_null(px);
    cn_rng r = cn_rng_seed(3);
    for (size_t i = 0; i < (size_t)w * h * 3; i++)
        px[i] = (uint8_t)(cn_rng_u64(&r) >> 56);
    char err[256];
    for (int o = 1; o <= 8; o++) {
        cn_buf b;
        write_jpeg(&b, px, w, h, 3, o);
        cn_image up;
        cn_image_info iu;
        assert_int_equal(cn_image_load_mem("n.jpg", b.p, b.n, 1, NAN, &up, &iu, err, sizeof err),
                         0);
        assert_int_equal(up.w, o >= 5 ? h : w);
        assert_int_equal(iu.file_w, up.w);
        for (int f = 2; f <= 4; f++) {
            cn_image a, want;
            cn_image_info info;
            int x0, y0;
            assert_int_equal(cn_image_load_mem("n.jpg", b.p, b.n, f, NAN, &a, &info, err,
                                               sizeof err), 0);
            assert_int_equal(cn_image_downscale_crop(&up, f, &want, &x0, &y0, err, sizeof err),
                             0);
            assert_int_equal(a.w, want.w);
            assert_int_equal(a.h, want.h);
            assert_int_equal(info.crop_x, x0);
            assert_int_equal(info.crop_y, y0);
            for (size_t i = 0; i < (size_t)a.w * a.h * 3; i++)
                assert_true(fabsf(a.px[i] - want.px[i]) < 1e-6f);
            cn_image_free(&a);
            cn_image_free(&want);
        }
        cn_image_free(&up);
        cn_buf_free(&b);
    }
    free(px);
}

/* Grey JPEGs become RGB; the header gives the upright size without decoding. */
static void test_jpeg_grey_and_size(void **state)
{
    (void)state;
    uint8_t g[16 * 8];
    for (int i = 0; i < 16 * 8; i++)
        g[i] = 100;
    cn_buf b;
    write_jpeg(&b, g, 16, 8, 1, 6);
    char err[256], path[512];
    assert_int_equal(system("mkdir -p " TMP), 0);
    snprintf(path, sizeof path, "%s/grey.jpg", TMP);
    assert_int_equal(cn_write_file_atomic(path, b.p, b.n, err, sizeof err), 0);
    int w, h;
    assert_int_equal(cn_image_size(path, NAN, &w, &h, err, sizeof err), 0);
    assert_int_equal(w, 8); /* orientation 6: turned upright */
    assert_int_equal(h, 16);
    cn_image im;
    assert_int_equal(cn_image_load(path, 1, NAN, &im, NULL, err, sizeof err), 0);
    assert_int_equal(im.c, 3);
    assert_near(&im, 3, 5, (const uint8_t[3]){100, 100, 100});
    cn_image_free(&im);
    cn_buf_free(&b);
}

#define EXPECT_LOAD_FAIL(data, len, f, want)                                                 \
    do {                                                                                       \
        cn_image im_;                                                                          \
        char e_[512];                                                                          \
        assert_int_equal(cn_image_load_mem("x.jpg", data, len, f, NAN, &im_, NULL, e_, sizeof e_), \
                         -1);                                                                  \
        assert_null(im_.px);                                                                   \
        if (!strstr(e_, want)) {                                                               \
            print_error("expected \"%s\" in: %s\n", want, e_);                                 \
            fail();                                                                            \
        }                                                                                      \
    } while (0)

/* Broken and unsupported files: each message names the file and what is wrong. */
static void test_jpeg_errors(void **state)
{
    (void)state;
    uint8_t *px = quadrants();
    cn_buf b;
    write_jpeg(&b, px, 32, 32, 3, 0);
    EXPECT_LOAD_FAIL(b.p, b.n / 2, 1, "x.jpg: corrupt or truncated JPEG");
    EXPECT_LOAD_FAIL(b.p, 2, 1, "x.jpg: truncated");
    EXPECT_LOAD_FAIL(b.p, 40, 1, "x.jpg: corrupt or truncated JPEG");
    EXPECT_LOAD_FAIL(b.p, b.n, 33, "x.jpg: cannot downscale a 32x32 image by 33");
    cn_buf_free(&b);
    /* A frame header (SOF0) with no rows. */
    write_jpeg(&b, px, 32, 32, 3, 0);
    size_t sof = 2;
    while (sof + 8 < b.n && !(b.p[sof] == 0xFF && b.p[sof + 1] == 0xC0))
        sof++;
    assert_true(sof + 8 < b.n);
    b.p[sof + 5] = b.p[sof + 6] = 0; /* height */
    EXPECT_LOAD_FAIL(b.p, b.n, 1, "x.jpg: corrupt or truncated JPEG");
    cn_buf_free(&b);
    uint8_t cmyk[16 * 16 * 4];
    memset(cmyk, 0, sizeof cmyk);
    write_jpeg(&b, cmyk, 16, 16, 4, 0);
    EXPECT_LOAD_FAIL(b.p, b.n, 1, "x.jpg: a CMYK JPEG");
    cn_buf_free(&b);
    static const uint8_t gif[] = "GIF89a....";
    EXPECT_LOAD_FAIL(gif, sizeof gif, 1, "x.jpg: neither a PNG nor a JPEG file");
    free(px);
}

/* An instant-ngp scene of JPEGs stored 64 x 48 with orientation 6 (upright 48 x 64). */
static void make_ngp_jpegs(const char *dir, const char *size, const char *frame1)
{
    char cmd[600], path[600], err[256];
    snprintf(cmd, sizeof cmd, "rm -rf %s && mkdir -p %s", dir, dir);
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/transforms.json", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "{\"fl_x\": 40, \"cx\": 30, %s \"frames\": [", size);
    for (int i = 0; i < 3; i++)
        fprintf(f, "%s{%s\"file_path\": \"im%d.jpg\", \"transform_matrix\": [[1,0,0,0],"
                   "[0,1,0,0],[0,0,1,%d],[0,0,0,1]]}", i ? "," : "", i == 1 ? frame1 : "", i,
                3 + i);
    fprintf(f, "]}\n");
    fclose(f);
    uint8_t px[64 * 48 * 3];
    memset(px, 90, sizeof px);
    for (int i = 0; i < 3; i++) {
        cn_buf b;
        write_jpeg(&b, px, 64, 48, 3, 6);
        snprintf(path, sizeof path, "%s/im%d.jpg", dir, i);
        assert_int_equal(cn_write_file_atomic(path, b.p, b.n, err, sizeof err), 0);
        cn_buf_free(&b);
    }
}

/* JPEG scenes load; the cameras' stated size keeps the stored orientation; --max-size picks
 * the factor from the first image. */
static void test_ngp_jpeg_scene(void **state)
{
    (void)state;
    char err[512];
    cn_dataset ds;
    const char *dir = TMP "/ngp_jpeg";
    make_ngp_jpegs(dir, "\"w\": 64, \"h\": 48,", "");
    assert_int_equal(cn_dataset_load(dir, &(cn_dataset_opts){.max_size = 20}, &ds, err,
                                     sizeof err), 0);
    assert_int_equal(ds.downscale, 4);
    assert_int_equal(ds.n_train + ds.n_test, 3);
    assert_int_equal(ds.train[0].w, 16);
    assert_int_equal(ds.train[0].h, 12);
    assert_true(fabs(ds.train[0].fx - 10) < 1e-9);
    assert_true(fabs(ds.train[0].cx - 7.5) < 1e-9);
    assert_true(fabsf(ds.train[0].rgb[0] - 90 / 255.0f) < 3 / 255.0f);
    cn_dataset_free(&ds);
    /* Without a stated size the tag applies: upright 48 x 64, longer side 64 again. */
    make_ngp_jpegs(dir, "", "");
    assert_int_equal(cn_dataset_load(dir, &(cn_dataset_opts){.max_size = 20}, &ds, err,
                                     sizeof err), 0);
    assert_int_equal(ds.downscale, 4);
    assert_int_equal(ds.train[0].w, 12);
    assert_int_equal(ds.train[0].h, 16);
    cn_dataset_free(&ds);
    assert_int_equal(cn_dataset_load(dir, &(cn_dataset_opts){.max_size = 20, .downscale = 2},
                                     &ds, err, sizeof err), -1);
    assert_non_null(strstr(err, "not given with a downscale"));
}

/* A frame whose image is missing is skipped and reported once, also when --max-size lists
 * the frames twice (once to measure the first image); the library prints nothing. */
static void test_missing_frame_warned_once(void **state)
{
    (void)state;
    char err[512], path[600];
    const char *dir = TMP "/ngp_missing";
    make_ngp_jpegs(dir, "\"w\": 64, \"h\": 48,", "");
    snprintf(path, sizeof path, "%s/im2.jpg", dir);
    assert_int_equal(remove(path), 0);
    snprintf(path, sizeof path, "%s/stderr.txt", TMP);
    fflush(stderr);
    const int saved = dup(2);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_true(dup2(fileno(f), 2) >= 0);
    cn_dataset ds;
    const int rc = cn_dataset_load(dir, &(cn_dataset_opts){.max_size = 20}, &ds, err, sizeof err);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    fclose(f);
    assert_int_equal(rc, 0);
    assert_int_equal(ds.n_train + ds.n_test, 2);
    assert_int_equal(ds.n_skipped, 1);
    assert_non_null(strstr(ds.skipped, "im2.jpg: missing"));
    cn_dataset_free(&ds);
    uint8_t *txt;
    size_t len;
    assert_int_equal(cn_read_file(path, &txt, &len, err, sizeof err), 0);
    free(txt);
    assert_int_equal(len, 0);
}

/* nerfstudio's per-frame cameras replace the file's; a distorted lens is resampled into a
 * pinhole view whose focal length says how (cn_undistort). Frames 0 and 2 are train views
 * (0 is the test view). */
static void test_ngp_frame_cameras(void **state)
{
    (void)state;
    char err[512];
    cn_dataset ds;
    const char *dir = TMP "/ngp_frames";
    make_ngp_jpegs(dir, "\"w\": 64, \"h\": 48, \"k1\": -0.1, \"p1\": 0.01,",
                   "\"fl_x\": 80, \"camera_model\": \"PINHOLE\", \"k1\": 0, \"p1\": 0, ");
    assert_int_equal(cn_dataset_load(dir, NULL, &ds, err, sizeof err), 0);
    assert_int_equal(ds.n_train, 2);
    assert_int_equal(ds.train[0].w, 64);
    assert_true(fabs(ds.train[0].fx - 80) < 1e-9); /* frame 1: its own pinhole camera */
    const double s = ds.train[1].fx / 40;         /* frame 2: the file's distorted lens */
    print_message("# k1 -0.1, p1 0.01 on 64x48: focal scale %.4f\n", s);
    assert_true(s < 0.99 && s > 0.8);
    assert_true(fabs(ds.train[1].fy - 40 * s) < 1e-9);
    assert_true(fabs(ds.train[1].cx - 30) < 1e-9);
    cn_dataset_free(&ds);
    /* A file of another shape than the camera's stated size: refused by name. */
    uint8_t px[48 * 48 * 3];
    memset(px, 90, sizeof px);
    cn_buf b;
    write_jpeg(&b, px, 48, 48, 3, 0);
    char path[600];
    snprintf(path, sizeof path, "%s/im2.jpg", dir);
    cn_inputs_clear(); /* as a new run: the load above recorded the images as its inputs */
    assert_int_equal(cn_write_file_atomic(path, b.p, b.n, err, sizeof err), 0);
    cn_buf_free(&b);
    assert_int_equal(cn_dataset_load(dir, NULL, &ds, err, sizeof err), -1);
    assert_non_null(strstr(err, "im2.jpg is 48x48, but its camera is for 64x48 images"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_jpeg_orientation),
        cmocka_unit_test(test_streaming_matches_downscale),
        cmocka_unit_test(test_orientation_with_downscale),
        cmocka_unit_test(test_orientation_follows_cameras),
        cmocka_unit_test(test_jpeg_grey_and_size),
        cmocka_unit_test(test_jpeg_errors),
        cmocka_unit_test(test_ngp_jpeg_scene),
        cmocka_unit_test(test_ngp_frame_cameras),
        cmocka_unit_test(test_missing_frame_warned_once),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
