/*
 * Float images, PNG and JPEG input, PNG output for the encoder. Host C11, libpng,
 * libjpeg-turbo, libexif.
 */
#ifndef CNERF_ENC_IMAGE_H
#define CNERF_ENC_IMAGE_H

#include <stddef.h>
#include <stdint.h>

/* A float image: w*h pixels of c = 3 (RGB) or 4 (RGBA, straight alpha) channels,
 * row-major and interleaved, values in [0, 1]. */
typedef struct cn_image {
    int w, h, c;
    float *px;
} cn_image;

/* The most pixels an image may have (2^28, 268 megapixels): a larger header is refused
 * before anything is allocated. */
#define CN_IMAGE_MAX_PIXELS ((uint64_t)1 << 28)

/* What loading did to an image file. */
typedef struct cn_image_info {
    int file_w, file_h; /* the file's size, upright (after its EXIF orientation) */
    int crop_x, crop_y; /* upright file pixels cropped on the left and top before downscaling */
    int orientation;    /* the EXIF orientation applied: 1 (none) to 8 */
    int exif;           /* the file's EXIF orientation, 1 when it has none */
} cn_image_info;

/* Reads a PNG or a JPEG (told apart by their signatures), upright and downscaled by an
 * integer factor f >= 1, into RGB or RGBA floats:
 * - PNG: any bit depth (1 to 16) and colour type: grey and grey+alpha become RGB and RGBA,
 *   palette images RGB (RGBA with a tRNS chunk), 16-bit samples keep their full precision.
 * - JPEG (libjpeg-turbo): baseline or progressive, grey or colour; CMYK is refused. An EXIF
 *   orientation tag (APP1, libexif) is applied, so that the image comes out as a viewer
 *   shows it, unless the caller's cameras were computed on the stored pixels: COLMAP, and
 *   the tools built on it, read images as stored and ignore the tag. ref_aspect is the
 *   width / height that the cameras refer to (NAN when the camera file does not say): a
 *   quarter turn (orientations 5 to 8) is then applied only when it makes the image's
 *   aspect match the cameras', and a mirror or half turn (2 to 4) never.
 * Downscaling is cn_image_downscale_crop's, on the upright image: the result is the same,
 * bit for bit when the file needs no rotation. The file is decoded once, row by row into the
 * area sums of one output row, so that besides the compressed file only the output is held:
 * a 12-megapixel photo at factor 8 takes about 0.7 MB, not 144 MB of floats (an interlaced
 * PNG is the exception: libpng needs all its rows). Returns 0 and fills *info (may be NULL),
 * or -1 with a message naming the file and the problem (missing, neither PNG nor JPEG,
 * truncated, corrupt, CMYK, smaller than the factor) in err; *img is then empty. */
int cn_image_load(const char *path, int f, double ref_aspect, cn_image *img,
                  cn_image_info *info, char *err, size_t errlen);
int cn_image_load_mem(const char *path, const uint8_t *data, size_t len, int f,
                      double ref_aspect, cn_image *img, cn_image_info *info, char *err,
                      size_t errlen);
/* The size of a PNG or JPEG as cn_image_load would return it at factor 1, from its header,
 * without decoding the pixels. */
int cn_image_size(const char *path, double ref_aspect, int *w, int *h, char *err,
                  size_t errlen);
int cn_image_size_mem(const char *path, const uint8_t *data, size_t len, double ref_aspect,
                      int *w, int *h, char *err, size_t errlen);

/* cn_image_load of a PNG at factor 1; any other file is "not a PNG file". */
int cn_png_read(const char *path, cn_image *img, char *err, size_t errlen);
/* The same on a file's bytes in memory; `path` names it in messages. */
int cn_png_read_mem(const char *path, const uint8_t *data, size_t len, cn_image *img, char *err,
                    size_t errlen);

/* Writes w*h 8-bit RGB pixels (rows `stride` bytes apart, stride >= 3*w) as a PNG,
 * atomically: the file is encoded in memory, written to a temporary file in the same
 * directory, synced and renamed. Returns 0, or -1 with a message in err. */
int cn_png_write_rgb8(const char *path, const uint8_t *rgb, int w, int h, size_t stride,
                      char *err, size_t errlen);

/* Area-averaging downscale by an integer factor f >= 1: each output pixel is the mean of
 * an f x f block of input pixels. Images with alpha (grey+alpha, RGBA) stay straight-alpha:
 * alpha is the block's mean and the colour the coverage-weighted mean (mean premultiplied
 * colour / mean alpha; the plain mean where the block has no coverage), so that a block
 * composited over any background equals the mean of its pixels composited. NeRF's loaders
 * average straight colours instead, which darkens a silhouette against the transparent
 * black that Blender writes for empty space. Compositing happens afterwards.
 * Fails with a message if w or h is not divisible by f. *out is a new image. */
int cn_image_downscale(const cn_image *in, int f, cn_image *out, char *err, size_t errlen);

/* The same for any size: when f does not divide the width (height), the w % f leftover
 * columns (rows) are cropped first, half of them (rounded down) on the left (top) and the
 * rest on the right (bottom); *x0, *y0 are the crop's offsets in input pixels. Fails only
 * for f < 1, an invalid image, or an image smaller than f. */
int cn_image_downscale_crop(const cn_image *in, int f, cn_image *out, int *x0, int *y0,
                            char *err, size_t errlen);

/* Frees the pixels and empties the struct; safe on an empty image. */
void cn_image_free(cn_image *img);

#endif /* CNERF_ENC_IMAGE_H */
