/*
 * Lens distortion: the models that COLMAP, instant-ngp and nerfstudio write, and the
 * resampling of a distorted photo into a pinhole image at load, so that everything after
 * the loader (trainer, renderers, decoder, streams) keeps pinhole cameras. Host C11.
 */
#ifndef CNERF_ENC_UNDISTORT_H
#define CNERF_ENC_UNDISTORT_H

#include "cn_image.h"

enum {
    CN_LENS_PINHOLE = 0,
    CN_LENS_OPENCV = 1, /* radial k1 k2 k3, tangential p1 p2 (COLMAP's SIMPLE_RADIAL,
                           RADIAL, OPENCV; instant-ngp and nerfstudio's OPENCV) */
    CN_LENS_FISHEYE = 2 /* equidistant, k1..k4 on the angle (OPENCV_FISHEYE) */
};

typedef struct cn_lens {
    int model;          /* CN_LENS_* */
    double k1, k2, k3, k4, p1, p2;
} cn_lens;

/* 1 when the lens bends rays (any coefficient not zero, or the fisheye model). */
int cn_lens_distorts(const cn_lens *l);

/* Where the ray through the normalised pinhole point (x, y) = ((u - cx) / fx,
 * (v - cy) / fy) lands on the distorted image, in the same normalised units; image axes
 * (x right, y down). OpenCV's model:
 *   r2 = x^2 + y^2, radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3,
 *   xd = x radial + 2 p1 x y + p2 (r2 + 2 x^2), yd = y radial + p1 (r2 + 2 y^2) + 2 p2 x y;
 * fisheye: t = atan(r), td = t (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8), (xd, yd) = td / r (x, y). */
void cn_lens_distort(const cn_lens *l, double x, double y, double *xd, double *yd);

/* Checks that lens l, on an image of w x h pixels with intrinsics fx, fy, cx, cy, is a lens:
 * along 48 directions from the principal point, out to where the ray leaves the image (or to
 * atan(CN_LENS_CHECK_TAN) off the axis), the distorted radius grows and the Jacobian's
 * determinant stays positive, so that no two rays meet on one pixel. Returns 0, or -1 with
 * the rule broken in why (a model whose coefficients fold the image: OpenCV's k1 = -5, or
 * tangential p1 = 3, p2 = -3). */
#define CN_LENS_CHECK_TAN 20.0
int cn_lens_check(const cn_lens *l, double w, double h, double fx, double fy, double cx,
                  double cy, char *why, size_t n);

/* Resamples a photo taken through lens l with intrinsics fx, fy, cx, cy (pixels of `in`,
 * pixel centres at half-integers) into a pinhole image of the same size, principal point
 * and channels, with focal lengths scale * fx, scale * fy. scale is the smallest (the
 * widest view) at which every output pixel sees a point of the photo, so that the result
 * has no blank border, as COLMAP's undistorter does by default. Bilinear; RGBA is
 * interpolated premultiplied. Returns 0, or -1 with a message (out of memory, or a lens so
 * strong that no scale up to 8 fits). */
int cn_undistort(const cn_image *in, const cn_lens *l, double fx, double fy, double cx,
                 double cy, cn_image *out, double *scale, char *err, size_t errlen);

#endif /* CNERF_ENC_UNDISTORT_H */
