/* Lens models and undistortion at load (cn_undistort.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_undistort.h"

int cn_lens_distorts(const cn_lens *l)
{
    return l->model == CN_LENS_FISHEYE ||
           (l->model == CN_LENS_OPENCV && (l->k1 != 0 || l->k2 != 0 || l->k3 != 0 ||
                                           l->p1 != 0 || l->p2 != 0));
}

void cn_lens_distort(const cn_lens *l, double x, double y, double *xd, double *yd)
{
    const double r2 = x * x + y * y;
    if (l->model == CN_LENS_FISHEYE) {
        const double r = sqrt(r2);
        if (r < 1e-12) {
            *xd = x;
            *yd = y;
            return;
        }
        const double t = atan(r), t2 = t * t;
        const double td = t * (1 + t2 * (l->k1 + t2 * (l->k2 + t2 * (l->k3 + t2 * l->k4))));
        *xd = x * td / r;
        *yd = y * td / r;
        return;
    }
    if (l->model != CN_LENS_OPENCV) {
        *xd = x;
        *yd = y;
        return;
    }
    const double radial = 1 + r2 * (l->k1 + r2 * (l->k2 + r2 * l->k3));
    *xd = x * radial + 2 * l->p1 * x * y + l->p2 * (r2 + 2 * x * x);
    *yd = y * radial + l->p1 * (r2 + 2 * y * y) + 2 * l->p2 * x * y;
}

typedef struct cn_undist {
    const cn_lens *l;
    double fx, fy, cx, cy; /* the photo's */
    int w, h;
} cn_undist;

/* The photo's pixel coordinates (pixel centres at integers) seen by output pixel (x, y) at
 * focal scale s. */
static void source_of(const cn_undist *u, double s, double x, double y, double *sx, double *sy)
{
    double xd, yd;
    cn_lens_distort(u->l, (x + 0.5 - u->cx) / (s * u->fx), (y + 0.5 - u->cy) / (s * u->fy), &xd,
                    &yd);
    *sx = u->fx * xd + u->cx - 0.5;
    *sy = u->fy * yd + u->cy - 0.5;
}

/* Every border pixel of the output inside the photo's pixel centres at scale s (the
 * border is where the models used here reach furthest). */
static int fits(const cn_undist *u, double s)
{
    for (int i = 0; i < 2 * (u->w + u->h); i++) {
        double x, y, sx, sy;
        if (i < u->w) {
            x = i;
            y = 0;
        } else if (i < 2 * u->w) {
            x = i - u->w;
            y = u->h - 1;
        } else if (i < 2 * u->w + u->h) {
            x = 0;
            y = i - 2 * u->w;
        } else {
            x = u->w - 1;
            y = i - 2 * u->w - u->h;
        }
        source_of(u, s, x, y, &sx, &sy);
        if (!(sx >= 0 && sx <= u->w - 1 && sy >= 0 && sy <= u->h - 1))
            return 0;
    }
    return 1;
}

int cn_lens_check(const cn_lens *l, double w, double h, double fx, double fy, double cx,
                  double cy, char *why, size_t n)
{
    if (!cn_lens_distorts(l))
        return 0;
    /* the image's rectangle in normalised distorted coordinates */
    const double x0 = -cx / fx, x1 = (w - cx) / fx, y0 = -cy / fy, y1 = (h - cy) / fy;
    const int dirs = 48, steps = 1000;
    const double tmax = atan(CN_LENS_CHECK_TAN);
    for (int d = 0; d < dirs; d++) {
        const double c = cos(2 * M_PI * d / dirs), s = sin(2 * M_PI * d / dirs);
        double prev = 0;
        for (int i = 1; i <= steps; i++) {
            const double r = tan(tmax * i / steps), x = r * c, y = r * s;
            double xd, yd;
            cn_lens_distort(l, x, y, &xd, &yd);
            if (!isfinite(xd) || !isfinite(yd)) {
                snprintf(why, n, "its distortion is not finite %.0f degrees off the axis, "
                         "inside the image", tmax * i / steps * 180 / M_PI);
                return -1;
            }
            if (xd < x0 || xd > x1 || yd < y0 || yd > y1)
                break; /* this direction reaches the image's border unfolded */
            const double e = 1e-6 * (1 + r);
            double ax, ay, bx, by, cx_, cy_, dx, dy;
            cn_lens_distort(l, x + e, y, &ax, &ay);
            cn_lens_distort(l, x - e, y, &bx, &by);
            cn_lens_distort(l, x, y + e, &cx_, &cy_);
            cn_lens_distort(l, x, y - e, &dx, &dy);
            const double det = (ax - bx) * (cy_ - dy) - (ay - by) * (cx_ - dx);
            const double rd = hypot(xd, yd);
            if (!(rd > prev) || !(det > 0)) {
                snprintf(why, n, "its distortion turns back %.0f pixels from the principal "
                         "point, inside the image, where two directions meet on one pixel",
                         rd * fx);
                return -1;
            }
            prev = rd;
        }
    }
    return 0;
}

int cn_undistort(const cn_image *in, const cn_lens *l, double fx, double fy, double cx,
                 double cy, cn_image *out, double *scale, char *err, size_t errlen)
{
    *out = (cn_image){0};
    const cn_undist u = {l, fx, fy, cx, cy, in->w, in->h};
    if (in->w < 2 || in->h < 2 || !(fx > 0 && fy > 0)) {
        snprintf(err, errlen, "cannot undistort a %dx%d image with focal lengths %g, %g",
                 in->w, in->h, fx, fy);
        return -1;
    }
    /* The smallest fitting scale by bisection on [1/8, 8]. */
    double lo = 0.125, hi = 8;
    if (!fits(&u, hi)) {
        snprintf(err, errlen, "the lens distortion is too strong to undistort: even at 8 times "
                 "the focal length the image's border sees past the photo");
        return -1;
    }
    if (fits(&u, lo))
        hi = lo;
    for (int it = 0; it < 60 && hi - lo > 1e-9 * hi; it++) {
        const double mid = 0.5 * (lo + hi);
        if (fits(&u, mid))
            hi = mid;
        else
            lo = mid;
    }
    const double s = hi;
    const int c = in->c, w = in->w, h = in->h;
    float *px = malloc(sizeof(float) * (size_t)w * (size_t)h * (size_t)c);
    if (!px) {
        snprintf(err, errlen, "out of memory undistorting a %dx%d image", w, h);
        return -1;
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double sx, sy;
            source_of(&u, s, x, y, &sx, &sy);
            sx = fmin(fmax(sx, 0), w - 1);
            sy = fmin(fmax(sy, 0), h - 1);
            const int x0 = sx < w - 1 ? (int)sx : w - 2, y0 = sy < h - 1 ? (int)sy : h - 2;
            const double ax = sx - x0, ay = sy - y0;
            const double wt[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
            const float *p[4] = {in->px + ((size_t)y0 * w + x0) * c,
                                 in->px + ((size_t)y0 * w + x0 + 1) * c,
                                 in->px + ((size_t)(y0 + 1) * w + x0) * c,
                                 in->px + ((size_t)(y0 + 1) * w + x0 + 1) * c};
            float *q = px + ((size_t)y * w + x) * c;
            double a = 0, v[4] = {0, 0, 0, 0};
            for (int j = 0; j < 4; j++) {
                const double pa = c == 4 ? p[j][3] : 1;
                a += wt[j] * pa;
                for (int k = 0; k < 3; k++)
                    v[k] += wt[j] * pa * p[j][k];
            }
            for (int k = 0; k < 3; k++) {
                double mean = 0;
                for (int j = 0; j < 4 && (c != 4 || a <= 0); j++)
                    mean += wt[j] * p[j][k]; /* nothing covered: the plain mean */
                q[k] = (float)(c == 4 && a > 0 ? v[k] / a : c == 4 ? mean : v[k]);
            }
            if (c == 4)
                q[3] = (float)a;
        }
    *out = (cn_image){w, h, c, px};
    *scale = s;
    return 0;
}
