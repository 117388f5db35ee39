/*
 * Decoding an image file straight into its downscaled, upright form: the decoders (PNG in
 * image.c, JPEG in jpeg.c) hand over one row of the stored image at a time, and an area
 * accumulator keeps only one output row's sums, so that loading never holds the full-size
 * image in floats. Host C11; internal to the encoder.
 */
#ifndef CNERF_ENC_IMAGE_LOAD_H
#define CNERF_ENC_IMAGE_LOAD_H

#include "cn_image.h"

/* One load in progress. The decoder fills w, h, c and orientation, calls cn_load_begin, then
 * cn_load_row for each stored row top to bottom, and cn_load_finish. */
typedef struct cn_load {
    int factor;      /* downscale requested (>= 1) */
    int w, h, c;     /* the stored image: size and channels (3 or 4) */
    int orientation; /* EXIF orientation 1..8 of the stored image */
    double ref_aspect; /* width / height the caller's cameras refer to; NAN: not known */
    /* set by cn_load_begin */
    int x0, y0;      /* stored pixels cropped on the left and top */
    int ow, oh;      /* output size before orientation */
    int y;           /* next stored row */
    double *acc, *pm;
    cn_image out;    /* stored orientation, downscaled */
    cn_image_info info;
} cn_load;

/* Checks the size against the factor and the pixel limit and allocates; returns 0, or -1
 * with a message (without the file's name) in why. */
int cn_load_begin(cn_load *ld, char *why, size_t whylen);
/* One stored row of w * c floats in [0, 1]. */
void cn_load_row(cn_load *ld, const float *row);
/* Rotates or mirrors the result upright; moves it to *img. Returns 0, or -1 out of memory. */
int cn_load_finish(cn_load *ld, cn_image *img);
void cn_load_free(cn_load *ld);

/* JPEG (jpeg.c): the header only when header_only (w, h, orientation), else the whole
 * image through ld. Returns 0, or -1 with a message naming `path` in err. */
int cn_jpeg_decode(const char *path, const uint8_t *data, size_t len, cn_load *ld,
                   int header_only, char *err, size_t errlen);

#endif /* CNERF_ENC_IMAGE_LOAD_H */
