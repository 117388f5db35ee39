/* PNG input/output (libpng) and area-averaging downscale of float images. */
#include <limits.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <png.h>

#include "cn_image.h"
#include "cn_stream.h"

/* libpng reports errors through this context: the message goes to err, prefixed with the
 * file name, and control returns to the setjmp of the codec call. */
typedef struct cn_png_err {
    const char *path;
    char *err;
    size_t errlen;
} cn_png_err;

static void cn_png_on_error(png_structp png, png_const_charp msg)
{
    cn_png_err *e = png_get_error_ptr(png);
    snprintf(e->err, e->errlen, "%s: %s", e->path, msg);
    png_longjmp(png, 1);
}

static void cn_png_on_warning(png_structp png, png_const_charp msg)
{
    /* Benign problems (bad ancillary chunk CRC, unknown profile) do not stop the read. */
    (void)png;
    (void)msg;
}

void cn_image_free(cn_image *img)
{
    free(img->px);
    *img = (cn_image){0};
}

/* ---- reading ---- */

/* State of one read. Everything allocated while libpng may longjmp lives here so that
 * cn_png_read frees it on every path. */
typedef struct cn_png_rd {
    cn_png_err e;
    const uint8_t *data; /* the whole file */
    size_t len, pos;
    png_structp png;
    png_infop info;
    uint8_t *raw;     /* decoded rows, 8 or 16 bits per sample */
    png_bytep *rows;
    float *px;
} cn_png_rd;

static void cn_png_mem_read(png_structp png, png_bytep out, size_t n)
{
    cn_png_rd *r = png_get_io_ptr(png);
    if (n > r->len - r->pos)
        png_error(png, "truncated (unexpected end of file)");
    memcpy(out, r->data + r->pos, n);
    r->pos += n;
}

/* Samples (8- or 16-bit big-endian) to floats in [0, 1]. */
static void cn_png_to_float(const uint8_t *raw, size_t count, int depth, float *px)
{
    if (depth == 16) {
        for (size_t i = 0; i < count; i++)
            px[i] = (float)((raw[2 * i] << 8) | raw[2 * i + 1]) / 65535.0f;
    } else {
        for (size_t i = 0; i < count; i++)
            px[i] = (float)raw[i] / 255.0f;
    }
}

/* The part of the read that libpng may leave by longjmp (from png_error). */
static void cn_png_decode_body(cn_png_rd *r, cn_image *img)
{
    png_structp png = r->png;
    png_set_read_fn(png, r, cn_png_mem_read);
    png_read_info(png, r->info);
    png_set_expand(png);      /* palette -> RGB, grey < 8 bits -> 8 bits, tRNS -> alpha */
    png_set_gray_to_rgb(png); /* grey -> RGB, grey+alpha -> RGBA */
    png_set_interlace_handling(png);
    png_read_update_info(png, r->info);

    png_uint_32 w = png_get_image_width(png, r->info);
    png_uint_32 h = png_get_image_height(png, r->info);
    int depth = png_get_bit_depth(png, r->info);
    int c = png_get_channels(png, r->info);
    size_t rowbytes = png_get_rowbytes(png, r->info);
    if ((c != 3 && c != 4) || (depth != 8 && depth != 16))
        png_error(png, "unsupported pixel format after expansion");
    if ((uint64_t)w * h > CN_IMAGE_MAX_PIXELS) {
        char msg[160]; /* copied by the error handler before it jumps */
        snprintf(msg, sizeof msg, "%lu x %lu pixels, more than the %llu that cnerf loads",
                 (unsigned long)w, (unsigned long)h, (unsigned long long)CN_IMAGE_MAX_PIXELS);
        png_error(png, msg);
    }
    if (w == 0 || h == 0 || w > INT_MAX || h > INT_MAX || rowbytes == 0 ||
        h > SIZE_MAX / rowbytes || (size_t)w * h > SIZE_MAX / sizeof(float) / (size_t)c)
        png_error(png, "image too large");
    size_t count = (size_t)w * h * (size_t)c;
    r->raw = malloc(rowbytes * h);
    r->rows = malloc(sizeof(png_bytep) * h);
    r->px = malloc(sizeof(float) * count);
    if (!r->raw || !r->rows || !r->px)
        png_error(png, "out of memory");
    for (png_uint_32 y = 0; y < h; y++)
        r->rows[y] = r->raw + (size_t)y * rowbytes;
    png_read_image(png, r->rows);
    png_read_end(png, NULL); /* checks the remaining chunks up to IEND */

    cn_png_to_float(r->raw, count, depth, r->px);
    img->w = (int)w;
    img->h = (int)h;
    img->c = c;
    img->px = r->px;
    r->px = NULL; /* now owned by img */
}

static int cn_png_decode(cn_png_rd *r, cn_image *img)
{
    if (setjmp(png_jmpbuf(r->png)))
        return -1;
    cn_png_decode_body(r, img);
    return 0;
}

int cn_png_read_mem(const char *path, const uint8_t *data, size_t len, cn_image *img, char *err,
                    size_t errlen)
{
    *img = (cn_image){0};
    size_t sig = len < 8 ? len : 8;
    if (sig == 0 || png_sig_cmp(data, 0, sig) != 0) {
        snprintf(err, errlen, "%s: not a PNG file (bad signature)", path);
        return -1;
    }
    if (len < 8) {
        snprintf(err, errlen, "%s: truncated (unexpected end of file)", path);
        return -1;
    }
    cn_png_rd r = {.e = {path, err, errlen}, .data = data, .len = len};
    r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r.e, cn_png_on_error,
                                   cn_png_on_warning);
    if (r.png)
        r.info = png_create_info_struct(r.png);
    int rc = -1;
    if (r.info)
        rc = cn_png_decode(&r, img);
    else
        snprintf(err, errlen, "%s: out of memory", path);
    png_destroy_read_struct(&r.png, &r.info, NULL);
    free(r.raw);
    free(r.rows);
    free(r.px);
    return rc;
}

int cn_png_read(const char *path, cn_image *img, char *err, size_t errlen)
{
    *img = (cn_image){0};
    uint8_t *data;
    size_t len;
    if (cn_read_file(path, &data, &len, err, errlen) != 0)
        return -1;
    const int rc = cn_png_read_mem(path, data, len, img, err, errlen);
    free(data);
    return rc;
}

/* ---- writing ---- */

typedef struct cn_png_wr {
    cn_png_err e;
    cn_buf out;
    png_structp png;
    png_infop info;
} cn_png_wr;

static void cn_png_mem_write(png_structp png, png_bytep p, size_t n)
{
    cn_png_wr *w = png_get_io_ptr(png);
    cn_buf_put(&w->out, p, n);
    if (w->out.oom)
        png_error(png, "out of memory");
}

static void cn_png_mem_flush(png_structp png) { (void)png; }

static void cn_png_encode_body(cn_png_wr *w, const uint8_t *rgb, int width, int height,
                               size_t stride)
{
    png_set_write_fn(w->png, w, cn_png_mem_write, cn_png_mem_flush);
    png_set_IHDR(w->png, w->info, (png_uint_32)width, (png_uint_32)height, 8,
                 PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(w->png, w->info);
    for (int y = 0; y < height; y++)
        png_write_row(w->png, rgb + (size_t)y * stride);
    png_write_end(w->png, NULL);
}

static int cn_png_encode(cn_png_wr *w, const uint8_t *rgb, int width, int height,
                         size_t stride)
{
    if (setjmp(png_jmpbuf(w->png)))
        return -1;
    cn_png_encode_body(w, rgb, width, height, stride);
    return 0;
}

int cn_png_write_rgb8(const char *path, const uint8_t *rgb, int w, int h, size_t stride,
                      char *err, size_t errlen)
{
    if (!rgb || w <= 0 || h <= 0 || stride < 3 * (size_t)w) {
        snprintf(err, errlen, "%s: invalid image (%dx%d, stride %zu)", path, w, h, stride);
        return -1;
    }
    cn_png_wr wr = {.e = {path, err, errlen}};
    wr.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &wr.e, cn_png_on_error,
                                     cn_png_on_warning);
    if (wr.png)
        wr.info = png_create_info_struct(wr.png);
    int rc = -1;
    if (wr.info)
        rc = cn_png_encode(&wr, rgb, w, h, stride);
    else
        snprintf(err, errlen, "%s: out of memory", path);
    png_destroy_write_struct(&wr.png, &wr.info);
    if (rc == 0)
        rc = cn_write_file_atomic(path, wr.out.p, wr.out.n, err, errlen);
    cn_buf_free(&wr.out);
    return rc;
}

/* ---- downscaling ---- */

/* Area-averages the f*ow x f*oh rectangle at (x0, y0) of `in` into an ow x oh image. */
static int downscale_rect(const cn_image *in, int x0, int y0, int ow, int oh, int f,
                          cn_image *out, char *err, size_t errlen)
{
    const int c = in->c;
    float *px = malloc(sizeof(float) * (size_t)ow * (size_t)oh * (size_t)c);
    if (!px) {
        snprintf(err, errlen, "out of memory downscaling a %dx%d image", in->w, in->h);
        return -1;
    }
    const double inv = 1.0 / ((double)f * f);
    for (int y = 0; y < oh; y++) {
        for (int x = 0; x < ow; x++) {
            /* One pass: every channel's mean, and for images with alpha (grey+alpha, RGBA)
             * the colour weighted by coverage, so that the block composites over any
             * background as its pixels do on average (a transparent black pixel beside an
             * opaque one must not darken it); the plain mean where nothing is covered. */
            const int alpha = c == 2 || c == 4;
            double acc[4] = {0, 0, 0, 0}, pm[3] = {0, 0, 0};
            for (int dy = 0; dy < f; dy++) {
                const float *p =
                    in->px + ((size_t)(y0 + y * f + dy) * in->w + (size_t)x0 + (size_t)x * f) * c;
                for (int i = 0; i < f; i++, p += c) {
                    for (int k = 0; k < c; k++)
                        acc[k] += p[k];
                    for (int k = 0; alpha && k < c - 1; k++)
                        pm[k] += (double)p[c - 1] * p[k];
                }
            }
            float *q = px + ((size_t)y * ow + x) * c;
            const int weighted = alpha && acc[c - 1] > 0;
            for (int k = 0; k < c; k++)
                q[k] = (float)(weighted && k < c - 1 ? pm[k] / acc[c - 1] : acc[k] * inv);
        }
    }
    out->w = ow;
    out->h = oh;
    out->c = c;
    out->px = px;
    return 0;
}

static int downscale_check(const cn_image *in, int f, char *err, size_t errlen)
{
    if (f < 1) {
        snprintf(err, errlen, "downscale factor %d: must be an integer >= 1", f);
        return -1;
    }
    if (in->c < 1 || in->c > 4 || in->w <= 0 || in->h <= 0 || !in->px) {
        snprintf(err, errlen, "cannot downscale: not a valid image");
        return -1;
    }
    return 0;
}

int cn_image_downscale(const cn_image *in, int f, cn_image *out, char *err, size_t errlen)
{
    *out = (cn_image){0};
    if (downscale_check(in, f, err, errlen))
        return -1;
    if (in->w % f != 0 || in->h % f != 0) {
        snprintf(err, errlen,
                 "cannot downscale a %dx%d image by %d: the size is not divisible by the factor",
                 in->w, in->h, f);
        return -1;
    }
    return downscale_rect(in, 0, 0, in->w / f, in->h / f, f, out, err, errlen);
}

int cn_image_downscale_crop(const cn_image *in, int f, cn_image *out, int *x0, int *y0,
                            char *err, size_t errlen)
{
    *out = (cn_image){0};
    if (downscale_check(in, f, err, errlen))
        return -1;
    if (in->w < f || in->h < f) {
        snprintf(err, errlen, "cannot downscale a %dx%d image by %d: smaller than the factor",
                 in->w, in->h, f);
        return -1;
    }
    *x0 = in->w % f / 2;
    *y0 = in->h % f / 2;
    return downscale_rect(in, *x0, *y0, in->w / f, in->h / f, f, out, err, errlen);
}
