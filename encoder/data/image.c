/* PNG input/output (libpng), loading PNG and JPEG files downscaled as they decode, and the
 * area-averaging downscale of float images. */
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <png.h>

#include "cn_image.h"
#include "cn_image_load.h"
#include "cn_buf.h"
#include "cn_file.h"

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

/* ---- loading: the row accumulator ---- */

/* x0 of the stored image from the upright crop: which stored side lies on the upright left
 * (top) depends on the orientation (EXIF: 2 mirrors, 3 turns 180 degrees, 4 flips, 5
 * transposes, 6 turns 90 clockwise, 7 transverses, 8 turns 90 counterclockwise). */
typedef struct cn_orient {
    int swap, flip_x, flip_y; /* upright x' from stored y when swap; mirrored when flip */
} cn_orient;

static cn_orient cn_orient_of(int o)
{
    static const cn_orient t[9] = {{0, 0, 0}, {0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1},
                                   {1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}};
    return t[o >= 1 && o <= 8 ? o : 1];
}

/* The orientation to apply: the file's, unless the cameras were made on the stored image
 * (cn_image_load in cn_image.h). */
static int cn_orientation_used(const cn_load *ld)
{
    const cn_orient o = cn_orient_of(ld->orientation);
    if (isnan(ld->ref_aspect) || ld->orientation <= 1)
        return ld->orientation >= 1 && ld->orientation <= 8 ? ld->orientation : 1;
    if (!o.swap)
        return 1;
    const double stored = (double)ld->w / ld->h, turned = (double)ld->h / ld->w;
    return fabs(log(ld->ref_aspect / turned)) < fabs(log(ld->ref_aspect / stored)) ? ld->orientation
                                                                                    : 1;
}

int cn_load_begin(cn_load *ld, char *why, size_t whylen)
{
    const int f = ld->factor, used = cn_orientation_used(ld);
    const cn_orient o = cn_orient_of(used);
    const int uw = o.swap ? ld->h : ld->w, uh = o.swap ? ld->w : ld->h; /* upright */
    if ((uint64_t)ld->w * (uint64_t)ld->h > CN_IMAGE_MAX_PIXELS) {
        snprintf(why, whylen, "%d x %d pixels, more than the %llu that cnerf loads", ld->w,
                 ld->h, (unsigned long long)CN_IMAGE_MAX_PIXELS);
        return -1;
    }
    if (f < 1 || ld->w < f || ld->h < f) {
        snprintf(why, whylen, "cannot downscale a %dx%d image by %d: smaller than the factor",
                 uw, uh, f);
        return -1;
    }
    const int rx = uw % f, ry = uh % f, ux0 = rx / 2, uy0 = ry / 2;
    if (o.swap) {
        ld->x0 = o.flip_y ? ry - uy0 : uy0;
        ld->y0 = o.flip_x ? rx - ux0 : ux0;
    } else {
        ld->x0 = o.flip_x ? rx - ux0 : ux0;
        ld->y0 = o.flip_y ? ry - uy0 : uy0;
    }
    ld->ow = ld->w / f;
    ld->oh = ld->h / f;
    ld->y = 0;
    ld->info = (cn_image_info){uw, uh, ux0, uy0, used, ld->orientation};
    const size_t n = (size_t)ld->ow * (size_t)ld->oh * (size_t)ld->c;
    ld->out = (cn_image){ld->ow, ld->oh, ld->c, malloc(sizeof(float) * n)};
    ld->acc = calloc((size_t)ld->ow * 4, sizeof(double));
    ld->pm = calloc((size_t)ld->ow * 3, sizeof(double));
    if (!ld->out.px || !ld->acc || !ld->pm) {
        snprintf(why, whylen, "out of memory for a %dx%d image", uw, uh);
        return -1;
    }
    return 0;
}

/* The sums run in the order of cn_image_downscale_crop's (rows of a block top to bottom,
 * pixels left to right), so that the two agree bit for bit. */
void cn_load_row(cn_load *ld, const float *row)
{
    const int f = ld->factor, c = ld->c, yy = ld->y++ - ld->y0;
    if (yy < 0 || yy >= ld->oh * f)
        return;
    float *q = ld->out.px + (size_t)(yy / f) * (size_t)ld->ow * (size_t)c;
    if (f == 1) {
        memcpy(q, row + (size_t)ld->x0 * (size_t)c, sizeof(float) * (size_t)ld->ow * (size_t)c);
        return;
    }
    const int dy = yy % f, alpha = c == 4;
    if (dy == 0) {
        memset(ld->acc, 0, sizeof(double) * (size_t)ld->ow * 4);
        memset(ld->pm, 0, sizeof(double) * (size_t)ld->ow * 3);
    }
    for (int x = 0; x < ld->ow; x++) {
        double *acc = ld->acc + (size_t)x * 4, *pm = ld->pm + (size_t)x * 3;
        const float *p = row + ((size_t)ld->x0 + (size_t)x * f) * (size_t)c;
        for (int i = 0; i < f; i++, p += c) {
            for (int k = 0; k < c; k++)
                acc[k] += p[k];
            for (int k = 0; alpha && k < c - 1; k++)
                pm[k] += (double)p[c - 1] * p[k];
        }
    }
    if (dy != f - 1)
        return;
    /* As in downscale_rect: the colour weighted by coverage where the block has any. */
    const double inv = 1.0 / ((double)f * f);
    for (int x = 0; x < ld->ow; x++) {
        const double *acc = ld->acc + (size_t)x * 4, *pm = ld->pm + (size_t)x * 3;
        const int weighted = alpha && acc[c - 1] > 0;
        for (int k = 0; k < c; k++)
            q[(size_t)x * c + k] = (float)(weighted && k < c - 1 ? pm[k] / acc[c - 1]
                                                                 : acc[k] * inv);
    }
}

int cn_load_finish(cn_load *ld, cn_image *img)
{
    const cn_orient o = cn_orient_of(ld->info.orientation);
    if (!o.swap && !o.flip_x && !o.flip_y) {
        *img = ld->out;
        ld->out = (cn_image){0};
        return 0;
    }
    const int w = ld->out.w, h = ld->out.h, c = ld->out.c;
    const int uw = o.swap ? h : w, uh = o.swap ? w : h;
    float *px = malloc(sizeof(float) * (size_t)w * (size_t)h * (size_t)c);
    if (!px)
        return -1;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int ux = o.swap ? y : x, uy = o.swap ? x : y;
            ux = o.flip_x ? uw - 1 - ux : ux;
            uy = o.flip_y ? uh - 1 - uy : uy;
            memcpy(px + ((size_t)uy * uw + ux) * c, ld->out.px + ((size_t)y * w + x) * c,
                   sizeof(float) * (size_t)c);
        }
    *img = (cn_image){uw, uh, c, px};
    return 0;
}

void cn_load_free(cn_load *ld)
{
    free(ld->acc);
    free(ld->pm);
    cn_image_free(&ld->out);
    ld->acc = ld->pm = NULL;
}

/* ---- PNG ---- */

/* State of one read. Everything allocated while libpng may longjmp lives here so that
 * the caller frees it on every path. */
typedef struct cn_png_rd {
    cn_png_err e;
    const uint8_t *data; /* the whole file */
    size_t len, pos;
    png_structp png;
    png_infop info;
    uint8_t *raw;     /* decoded rows, 8 or 16 bits per sample: one, or all when interlaced */
    png_bytep *rows;
    float *row;       /* one row in floats */
    cn_load *ld;
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
static void cn_png_decode_body(cn_png_rd *r, int header_only)
{
    png_structp png = r->png;
    cn_load *ld = r->ld;
    png_set_read_fn(png, r, cn_png_mem_read);
    png_read_info(png, r->info);
    png_set_expand(png);      /* palette -> RGB, grey < 8 bits -> 8 bits, tRNS -> alpha */
    png_set_gray_to_rgb(png); /* grey -> RGB, grey+alpha -> RGBA */
    const int passes = png_set_interlace_handling(png);
    png_read_update_info(png, r->info);

    png_uint_32 w = png_get_image_width(png, r->info);
    png_uint_32 h = png_get_image_height(png, r->info);
    int depth = png_get_bit_depth(png, r->info);
    int c = png_get_channels(png, r->info);
    size_t rowbytes = png_get_rowbytes(png, r->info);
    if ((c != 3 && c != 4) || (depth != 8 && depth != 16))
        png_error(png, "unsupported pixel format after expansion");
    if (w == 0 || h == 0 || w > INT_MAX || h > INT_MAX || rowbytes == 0 ||
        h > SIZE_MAX / rowbytes || (size_t)w > SIZE_MAX / sizeof(float) / (size_t)c)
        png_error(png, "image too large");
    ld->w = (int)w;
    ld->h = (int)h;
    ld->c = c;
    ld->orientation = 1;
    if (header_only)
        return;
    char why[160]; /* copied by the error handler before it jumps */
    if (cn_load_begin(ld, why, sizeof why))
        png_error(png, why);
    const size_t held = passes > 1 ? h : 1; /* interlaced: every row until the last pass */
    r->raw = malloc(rowbytes * held);
    r->rows = malloc(sizeof(png_bytep) * held);
    r->row = malloc(sizeof(float) * (size_t)w * (size_t)c);
    if (!r->raw || !r->rows || !r->row)
        png_error(png, "out of memory");
    if (passes > 1) {
        for (png_uint_32 y = 0; y < h; y++)
            r->rows[y] = r->raw + (size_t)y * rowbytes;
        png_read_image(png, r->rows);
    }
    for (png_uint_32 y = 0; y < h; y++) {
        const uint8_t *src = r->raw + (passes > 1 ? (size_t)y * rowbytes : 0);
        if (passes == 1)
            png_read_row(png, r->raw, NULL);
        cn_png_to_float(src, (size_t)w * (size_t)c, depth, r->row);
        cn_load_row(ld, r->row);
    }
    png_read_end(png, NULL); /* checks the remaining chunks up to IEND */
}

static int cn_png_decode(cn_png_rd *r, int header_only)
{
    if (setjmp(png_jmpbuf(r->png)))
        return -1;
    cn_png_decode_body(r, header_only);
    return 0;
}

static int is_png(const uint8_t *data, size_t len)
{
    return len >= 8 && png_sig_cmp(data, 0, 8) == 0;
}

static int is_jpeg(const uint8_t *data, size_t len)
{
    return len >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF;
}

/* PNG into ld: the header only, or the whole image. */
static int cn_png_load(const char *path, const uint8_t *data, size_t len, cn_load *ld,
                       int header_only, char *err, size_t errlen)
{
    cn_png_rd r = {.e = {path, err, errlen}, .data = data, .len = len, .ld = ld};
    r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r.e, cn_png_on_error,
                                   cn_png_on_warning);
    if (r.png)
        r.info = png_create_info_struct(r.png);
    int rc = -1;
    if (r.info)
        rc = cn_png_decode(&r, header_only);
    else
        snprintf(err, errlen, "%s: out of memory", path);
    png_destroy_read_struct(&r.png, &r.info, NULL);
    free(r.raw);
    free(r.rows);
    free(r.row);
    return rc;
}

/* ---- either format ---- */

static int cn_any_load(const char *path, const uint8_t *data, size_t len, cn_load *ld,
                       int header_only, char *err, size_t errlen)
{
    if (is_png(data, len))
        return cn_png_load(path, data, len, ld, header_only, err, errlen);
    if (is_jpeg(data, len))
        return cn_jpeg_decode(path, data, len, ld, header_only, err, errlen);
    if (len < 8 && len > 0 && (png_sig_cmp(data, 0, len) == 0 || data[0] == 0xFF))
        snprintf(err, errlen, "%s: truncated (unexpected end of file)", path);
    else
        snprintf(err, errlen, "%s: neither a PNG nor a JPEG file (bad signature)", path);
    return -1;
}

int cn_image_load_mem(const char *path, const uint8_t *data, size_t len, int f,
                      double ref_aspect, cn_image *img, cn_image_info *info, char *err,
                      size_t errlen)
{
    *img = (cn_image){0};
    cn_load ld = {.factor = f, .ref_aspect = ref_aspect};
    int rc = cn_any_load(path, data, len, &ld, 0, err, errlen);
    if (rc == 0 && ld.y != ld.h) {
        snprintf(err, errlen, "%s: truncated (%d of %d rows)", path, ld.y, ld.h);
        rc = -1;
    }
    if (rc == 0 && cn_load_finish(&ld, img) != 0) {
        snprintf(err, errlen, "%s: out of memory", path);
        rc = -1;
    }
    if (rc == 0 && info)
        *info = ld.info;
    cn_load_free(&ld);
    return rc;
}

int cn_image_load(const char *path, int f, double ref_aspect, cn_image *img,
                  cn_image_info *info, char *err, size_t errlen)
{
    *img = (cn_image){0};
    uint8_t *data;
    size_t len;
    if (cn_read_file(path, &data, &len, err, errlen) != 0)
        return -1;
    const int rc = cn_image_load_mem(path, data, len, f, ref_aspect, img, info, err, errlen);
    free(data);
    return rc;
}

int cn_image_size_mem(const char *path, const uint8_t *data, size_t len, double ref_aspect,
                      int *w, int *h, char *err, size_t errlen)
{
    cn_load ld = {.factor = 1, .ref_aspect = ref_aspect};
    const int rc = cn_any_load(path, data, len, &ld, 1, err, errlen);
    if (rc == 0) {
        const int swap = cn_orient_of(cn_orientation_used(&ld)).swap;
        *w = swap ? ld.h : ld.w;
        *h = swap ? ld.w : ld.h;
    }
    return rc;
}

int cn_image_size(const char *path, double ref_aspect, int *w, int *h, char *err,
                  size_t errlen)
{
    uint8_t *data;
    size_t len;
    if (cn_read_file(path, &data, &len, err, errlen) != 0)
        return -1;
    const int rc = cn_image_size_mem(path, data, len, ref_aspect, w, h, err, errlen);
    free(data);
    return rc;
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
    return cn_image_load_mem(path, data, len, 1, NAN, img, NULL, err, errlen);
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
