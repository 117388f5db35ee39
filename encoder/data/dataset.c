/* Dataset loading: Blender, instant-ngp, LLFF, DTU and COLMAP layouts (see cn_dataset.h). */
#include <ctype.h>
#include <errno.h>
#include <dirent.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include <cjson/cJSON.h>

#include "cn_dataset.h"
#include "cn_colmap.h"
#include "cn_dtu.h"
#include "cn_image.h"
#include "cn_loader.h"
#include "cn_undistort.h"
#include "cn_file.h"

#define CN_PATH_MAX 4096
#define CN_VIEW_ERR 1024 /* per-image error message buffer of the parallel load */
#define CN_LLFF_HOLD 8   /* every 8th view is a test view */

enum { CN_TRAIN = 0, CN_VAL = 1, CN_TEST = 2 };

/* ---- errors and paths ---- */

/* out = dir/name (name used as is when absolute, "./" prefixes dropped) + ext. */
static int cn_join(char out[CN_PATH_MAX], const char *dir, const char *name, const char *ext,
                   char *err, size_t errlen)
{
    while (name[0] == '.' && name[1] == '/')
        name += 2;
    int n = name[0] == '/' ? snprintf(out, CN_PATH_MAX, "%s%s", name, ext)
                           : snprintf(out, CN_PATH_MAX, "%s/%s%s", dir, name, ext);
    if (n < 0 || n >= CN_PATH_MAX)
        return cn_fail(err, errlen, "%s/%s%s: path too long", dir, name, ext);
    return 0;
}

static int cn_is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* Why `path` is not a regular file: "missing", "a directory, not a file", ... */
static const char *cn_not_file_why(const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return errno == ENOENT ? "missing" : strerror(errno);
    return S_ISDIR(st.st_mode) ? "a directory, not a file" : "not a regular file";
}

static int cn_is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

/* The file name of path without directory and extension, truncated to fit. */
static void cn_stem(const char *path, char name[64])
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *dot = strrchr(base, '.');
    size_t n = dot && dot != base ? (size_t)(dot - base) : strlen(base);
    if (n > 63)
        n = 63;
    memcpy(name, base, n);
    name[n] = '\0';
}

/* ---- camera poses and intrinsics ---- */

/* Checks a camera-to-world matrix: finite, rotation orthonormal within 1e-3 and not a
 * reflection. Returns 0, or -1 with the problem in why. */
static int cn_pose_check(const double m[3][4], char *why, size_t n)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(m[i][j])) {
                snprintf(why, n, "non-finite entry [%d][%d]", i, j);
                return -1;
            }
    double dev = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double d = -(double)(i == j);
            for (int k = 0; k < 3; k++)
                d += m[k][i] * m[k][j];
            dev = fmax(dev, fabs(d));
        }
    if (dev > 1e-3) {
        snprintf(why, n, "degenerate pose: rotation is not orthonormal (max |R^T R - I| = %.3g)",
                 dev);
        return -1;
    }
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if (det < 0) {
        snprintf(why, n, "degenerate pose: rotation is a reflection (determinant %.3g)", det);
        return -1;
    }
    return 0;
}

/* Intrinsics as a dataset states them, resolved once the image size is known. NAN marks
 * a value that is not given. */
typedef struct cn_intr {
    double ref_w, ref_h;     /* image size the values refer to; NAN: the image file's size */
    double fx, fy, cx, cy;   /* pixels at the reference size; NAN: derived */
    double angle_x, angle_y; /* fields of view (radians) for fx / fy when those are NAN */
    double k[4], p[2];       /* lens distortion coefficients k1..k4, p1, p2 */
    int model;               /* CN_LENS_*, or -1: OPENCV, or FISHEYE when fisheye is 1 */
    int fisheye;             /* instant-ngp's is_fisheye; -1 unset */
    int sized;               /* 1: ref_w x ref_h is the shape of this camera's images (COLMAP,
                                instant-ngp's w and h); 0: only a scale for the intrinsics,
                                and every image of the dataset has the same size */
    const char *lens;        /* the lens model's name as the file gives it, or NULL */
    int colmap;              /* 1: a camera of a COLMAP model */
    char src[512];           /* where they are stated, for messages ("" : the image's camera) */
} cn_intr;

static const cn_intr cn_intr_none = {NAN, NAN, NAN, NAN, NAN, NAN, NAN, NAN,
                                     {0, 0, 0, 0}, {0, 0}, -1, -1, 0, NULL, 0, ""};

/* The lens of resolved intrinsics (checked when they were read). */
static cn_lens cn_intr_lens(const cn_intr *in)
{
    const int model = in->model >= 0 ? in->model
                      : in->fisheye == 1 ? CN_LENS_FISHEYE
                                         : CN_LENS_OPENCV;
    return (cn_lens){model, in->k[0], in->k[1], in->k[2], in->k[3], in->p[0], in->p[1]};
}

/* Intrinsics of view v (v->w, v->h set) loaded from an image file of file_w x file_h.
 * Missing focal lengths come from the fields of view (fy: else fx, square pixels),
 * a missing principal point is the image centre. */
/* Intrinsics of the loaded view: the reference size's intrinsics scaled to the file's size,
 * moved by the crop and divided by the downscale factor. */
static void cn_intr_resolve(const cn_intr *in, int file_w, int file_h, int crop_x, int crop_y,
                            int factor, cn_view *v)
{
    double rw = isnan(in->ref_w) ? file_w : in->ref_w;
    double rh = isnan(in->ref_h) ? file_h : in->ref_h;
    double fx = !isnan(in->fx) ? in->fx : 0.5 * rw / tan(0.5 * in->angle_x);
    double fy = !isnan(in->fy)        ? in->fy
                : !isnan(in->angle_y) ? 0.5 * rh / tan(0.5 * in->angle_y)
                                      : fx;
    double cx = isnan(in->cx) ? 0.5 * rw : in->cx;
    double cy = isnan(in->cy) ? 0.5 * rh : in->cy;
    double sx = file_w / rw, sy = file_h / rh;
    v->fx = fx * sx / factor;
    v->fy = fy * sy / factor;
    v->cx = (cx * sx - crop_x) / factor;
    v->cy = (cy * sy - crop_y) / factor;
}

/* ---- the list of frames before their images are loaded ---- */

typedef struct cn_frame {
    char *path; /* image file */
    int split;  /* CN_TRAIN, CN_VAL or CN_TEST */
    int unread; /* 1: listed but left out of the dataset (cn_dataset_opts' test_every and
                   test_only): its image is not read */
    cn_view v;  /* name and c2w; size, intrinsics and pixels once loaded */
    cn_intr in;
    int file_w, file_h; /* size of the image file */
    int crop_x, crop_y; /* file pixels cropped on the left and top before downscaling */
    int factor;         /* the downscale applied */
} cn_frame;

typedef struct cn_frames {
    cn_frame *f;
    int n, cap;
    int count[3];      /* frames kept per split */
    int max_views;     /* per split, 0 = all */
    int test_every;    /* cn_dataset_opts' */
    int test_only;
    int factor;        /* downscale applied to every image file */
    int offered;       /* frames offered to cn_frames_add, kept or not */
    int skipped;       /* frames skipped for a missing image */
    char first_skipped[sizeof(((cn_dataset *)0)->skipped)]; /* the first, "PATH: why" */
    double rmin, rmax; /* range of their camera distances from the origin */
} cn_frames;

static void cn_frames_free(cn_frames *L)
{
    for (int i = 0; i < L->n; i++) {
        free(L->f[i].path);
        free(L->f[i].v.rgb);
        free(L->f[i].v.alpha);
    }
    free(L->f);
    L->f = NULL;
    L->n = L->cap = 0;
}

/* Offers a frame for `split`; it is dropped (returning 0) when the split already has
 * max_views frames. */
static int cn_frames_add(cn_frames *L, const char *path, int split, const double c2w[3][4],
                         const cn_intr *in, char *err, size_t errlen)
{
    double r = sqrt(c2w[0][3] * c2w[0][3] + c2w[1][3] * c2w[1][3] + c2w[2][3] * c2w[2][3]);
    L->rmin = L->offered ? fmin(L->rmin, r) : r;
    L->rmax = L->offered ? fmax(L->rmax, r) : r;
    L->offered++;
    if (L->max_views > 0 && L->count[split] >= L->max_views)
        return 0;
    if (L->n == L->cap) {
        int cap = L->cap ? 2 * L->cap : 64;
        cn_frame *f = realloc(L->f, sizeof *f * (size_t)cap);
        if (!f)
            return cn_fail(err, errlen, "%s: out of memory", path);
        L->f = f;
        L->cap = cap;
    }
    cn_frame *fr = &L->f[L->n];
    *fr = (cn_frame){.split = split, .in = *in};
    fr->path = strdup(path);
    if (!fr->path)
        return cn_fail(err, errlen, "%s: out of memory", path);
    cn_stem(path, fr->v.name);
    memcpy(fr->v.c2w, c2w, sizeof fr->v.c2w);
    if (split == CN_TEST)
        fr->unread = L->test_every > 1 && L->count[split] % L->test_every != 0;
    else
        fr->unread = L->test_only;
    L->n++;
    L->count[split]++;
    return 0;
}

/* ---- images ---- */

/* RGB of an RGB or RGBA image, RGBA composited over bg with straight alpha, into v->rgb;
 * v->alpha keeps the opacities when some pixel is not opaque (else NULL). Returns 0, or -1
 * out of memory. */
static int cn_composite(const cn_image *im, const float bg[3], cn_view *v)
{
    size_t n = (size_t)im->w * (size_t)im->h;
    v->rgb = malloc(sizeof(float) * 3 * n);
    v->alpha = NULL;
    if (!v->rgb)
        return -1;
    int clear = 0;
    for (size_t i = 0; i < n; i++) {
        const float *p = im->px + i * (size_t)im->c;
        float a = im->c == 4 ? fminf(1.0f, fmaxf(0.0f, p[3])) : 1.0f;
        clear |= a < 1.0f;
        for (int k = 0; k < 3; k++)
            v->rgb[3 * i + k] = fminf(1.0f, fmaxf(0.0f, a * p[k] + (1.0f - a) * bg[k]));
    }
    if (!clear)
        return 0;
    v->alpha = malloc(sizeof(float) * n);
    if (!v->alpha) {
        free(v->rgb);
        v->rgb = NULL;
        return -1;
    }
    for (size_t i = 0; i < n; i++)
        v->alpha[i] = fminf(1.0f, fmaxf(0.0f, im->px[i * 4 + 3]));
    return 0;
}

/* The width / height that a frame's intrinsics refer to, when its camera file says. */
static double cn_ref_aspect(const cn_intr *in)
{
    return isnan(in->ref_w) || isnan(in->ref_h) ? NAN : in->ref_w / in->ref_h;
}

/* The fields of view a camera may have across its image, per lens kind (degrees): a
 * rectilinear lens (pinhole and OpenCV's models) cannot see 180 degrees; an equidistant
 * fisheye can, up to what a circular fisheye covers. */
#define CN_FOV_MIN 0.5
#define CN_FOV_MAX_PERSPECTIVE 170.0
#define CN_FOV_MAX_FISHEYE 270.0

/* A frame's camera against its image (file_w x file_h known): focal lengths, a field of
 * view within the lens kind's range, the principal point inside the image, and a lens that
 * does not fold it (cn_lens_check). Each message names where the camera is stated. */
static int cn_camera_check(const cn_frame *fr, char *err, size_t errlen)
{
    cn_view full; /* the intrinsics at the file's size, as the user knows them */
    cn_intr_resolve(&fr->in, fr->file_w, fr->file_h, 0, 0, 1, &full);
    const double w = fr->file_w, h = fr->file_h;
    char src[CN_PATH_MAX + 64];
    if (fr->in.src[0])
        snprintf(src, sizeof src, "%s", fr->in.src);
    else
        snprintf(src, sizeof src, "%s (its camera)", fr->path);
    const cn_lens lens = cn_intr_lens(&fr->in);
    const char *name = fr->in.lens ? fr->in.lens
                       : lens.model == CN_LENS_FISHEYE ? "OPENCV_FISHEYE"
                       : cn_lens_distorts(&lens) ? "OPENCV" : "PINHOLE";
    if (!(isfinite(full.fx) && full.fx > 0 && isfinite(full.fy) && full.fy > 0))
        return cn_fail(err, errlen, "%s: the focal length (%g, %g) is not a positive number",
                       src, full.fx, full.fy);
    if (!(isfinite(full.cx) && isfinite(full.cy) && full.cx >= 0 && full.cx <= w &&
          full.cy >= 0 && full.cy <= h))
        return cn_fail(err, errlen, "%s: the principal point (%g, %g) lies outside the %dx%d "
                       "image %s; are the intrinsics for another image size?", src, full.cx,
                       full.cy, fr->file_w, fr->file_h, fr->path);
    const int fish = lens.model == CN_LENS_FISHEYE;
    const double hi = fish ? CN_FOV_MAX_FISHEYE : CN_FOV_MAX_PERSPECTIVE;
    for (int axis = 0; axis < 2; axis++) {
        const double px = axis ? h : w, f = axis ? full.fy : full.fx;
        const double fov = (fish ? px / f : 2 * atan(0.5 * px / f)) * 180 / M_PI;
        if (!(fov >= CN_FOV_MIN && fov <= hi))
            return cn_fail(err, errlen, "%s: a field of view of %.1f degrees across the image "
                           "(%s %.0f pixels of %s, focal length %g): a %s camera sees %g to %g; "
                           "are the intrinsics for another image size?", src, fov,
                           axis ? "the height's" : "the width's", px, fr->path, f, name,
                           CN_FOV_MIN, hi);
    }
    char why[256];
    if (cn_lens_check(&lens, w, h, full.fx, full.fy, full.cx, full.cy, why, sizeof why))
        return cn_fail(err, errlen, "%s: the %s lens folds the image: %s (k1 %g, k2 %g, k3 %g, "
                       "k4 %g, p1 %g, p2 %g)", src, name, why, lens.k1, lens.k2, lens.k3, lens.k4,
                       lens.p1, lens.p2);
    return 0;
}

/* Reads one frame's image, upright and downscaled by `factor`, and composites it. */
static int cn_frame_load(cn_frame *fr, int factor, const float bg[3], char *err, size_t errlen)
{
    cn_image im;
    cn_image_info info;
    fr->factor = factor > 1 ? factor : 1;
    if (cn_image_load(fr->path, fr->factor, cn_ref_aspect(&fr->in), &im, &info, err,
                      errlen) != 0) {
        if (fr->factor > 1 && strstr(err, "smaller than the factor"))
            snprintf(err + strlen(err), errlen - strlen(err), " (downscale %d)", fr->factor);
        return -1;
    }
    fr->file_w = info.file_w;
    fr->file_h = info.file_h;
    fr->crop_x = info.crop_x;
    fr->crop_y = info.crop_y;
    fr->v.w = im.w;
    fr->v.h = im.h;
    cn_intr_resolve(&fr->in, fr->file_w, fr->file_h, fr->crop_x, fr->crop_y, fr->factor, &fr->v);
    if (cn_camera_check(fr, err, errlen)) {
        cn_image_free(&im);
        return -1;
    }
    const cn_lens lens = cn_intr_lens(&fr->in);
    if (cn_lens_distorts(&lens)) {
        /* Resampled into a pinhole image: everything after the loader sees pinhole cameras. */
        cn_image flat;
        double s;
        char why[256];
        const int bad = cn_undistort(&im, &lens, fr->v.fx, fr->v.fy, fr->v.cx, fr->v.cy, &flat,
                                     &s, why, sizeof why);
        cn_image_free(&im);
        if (bad)
            return cn_fail(err, errlen, "%s: %s", fr->path, why);
        im = flat;
        fr->v.fx *= s;
        fr->v.fy *= s;
    }
    const int oom = cn_composite(&im, bg, &fr->v);
    cn_image_free(&im);
    if (oom)
        return cn_fail(err, errlen, "%s: out of memory", fr->path);
    return 0;
}

/* Loads every frame's image (in parallel), checks that they all have the same size and
 * resolves the intrinsics. */
static int cn_frames_load_images(cn_frames *L, const float bg[3], char *err, size_t errlen)
{
    if (L->n == 0)
        return 0;
    char *msg = malloc((size_t)L->n * CN_VIEW_ERR);
    int *rc = malloc(sizeof(int) * (size_t)L->n);
    if (!msg || !rc) {
        free(msg);
        free(rc);
        return cn_fail(err, errlen, "out of memory loading %d images", L->n);
    }
#pragma omp parallel for schedule(dynamic)
    for (int i = 0; i < L->n; i++)
        rc[i] = L->f[i].unread ? 0
                               : cn_frame_load(&L->f[i], L->factor, bg,
                                               msg + (size_t)i * CN_VIEW_ERR, CN_VIEW_ERR);
    int bad = -1;
    for (int i = 0; i < L->n && bad < 0; i++)
        if (rc[i] != 0)
            bad = i;
    if (bad >= 0)
        snprintf(err, errlen, "%s", msg + (size_t)bad * CN_VIEW_ERR);
    free(msg);
    free(rc);
    if (bad >= 0)
        return -1;
    /* An output must not replace an image, wherever it lies (a hard link outside the
     * dataset's folder, a --train-images folder): the command checks its outputs again. */
    for (int i = 0; i < L->n; i++)
        if (cn_input_add(L->f[i].path, "an image of the dataset"))
            return cn_fail(err, errlen, "out of memory loading %d images", L->n);
    /* Frames whose camera states the image size it is for (COLMAP, instant-ngp's and
     * nerfstudio's w, h) may differ in size, as long as each file has its camera's aspect;
     * the others must all have the same size. */
    const cn_frame *a = NULL;
    for (int i = 0; i < L->n; i++) {
        const cn_frame *b = &L->f[i];
        if (b->unread)
            continue;
        const double rw = b->in.ref_w, rh = b->in.ref_h;
        if (b->in.sized && !isnan(rw) && !isnan(rh)) {
            if (fabs((double)b->file_w * rh / ((double)b->file_h * rw) - 1) > 0.01) {
                if (b->in.colmap)
                    return cn_fail(err, errlen, "%s is %dx%d, but its camera (%s) is for %gx%g "
                                   "images (another shape): give it a camera of its own size "
                                   "in the COLMAP model", b->path, b->file_w, b->file_h,
                                   b->in.src, rw, rh);
                return cn_fail(err, errlen, "%s is %dx%d, but its camera is for %gx%g images "
                               "(another shape): give the frame its own w, h and intrinsics",
                               b->path, b->file_w, b->file_h, rw, rh);
            }
        } else if (!a) {
            a = b;
        } else if (b->file_w != a->file_w || b->file_h != a->file_h) {
            return cn_fail(err, errlen, "images differ in size: %s is %dx%d but %s is %dx%d "
                           "(and their cameras do not say which size they are for)",
                           a->path, a->file_w, a->file_h, b->path, b->file_w, b->file_h);
        }
    }
    return 0;
}

/* ---- JSON helpers ---- */

/* Where a JSON value sits, for messages: "file: key" or "file: frames[3].key". */
typedef struct cn_jloc {
    const char *file;
    int frame; /* index into frames[], or -1 for a top-level key */
} cn_jloc;

__attribute__((format(printf, 5, 6))) static int cn_jfail(const cn_jloc *l, const char *key,
                                                          char *err, size_t errlen,
                                                          const char *fmt, ...)
{
    char what[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (l->frame >= 0)
        return cn_fail(err, errlen, "%s: frames[%d]%s%s: %s", l->file, l->frame, key ? "." : "",
                       key ? key : "", what);
    return cn_fail(err, errlen, "%s: %s: %s", l->file, key, what);
}

/* 1 if JSON text ends inside a string or with brackets left open; *max_depth is the
 * deepest nesting of brackets reached. */
static int cn_json_incomplete(const char *text, size_t len, long *max_depth)
{
    long depth = 0;
    int in_str = 0;
    *max_depth = 0;
    for (size_t i = 0; i < len; i++) {
        char ch = text[i];
        if (in_str) {
            if (ch == '\\')
                i++;
            else if (ch == '"')
                in_str = 0;
        } else if (ch == '"') {
            in_str = 1;
        } else if (ch == '{' || ch == '[') {
            depth++;
            *max_depth = depth > *max_depth ? depth : *max_depth;
        } else if (ch == '}' || ch == ']') {
            depth--;
        }
    }
    return in_str || depth > 0;
}

/* Reports where parsing stopped: line, column and a hint for an incomplete document or
 * NaN/Infinity. */
static int cn_json_syntax_error(const char *path, const char *text, size_t len, const char *at,
                                char *err, size_t errlen)
{
    if (!text || !at || at < text || at > text + len)
        return cn_fail(err, errlen, "%s: malformed JSON (empty file)", path);
    int line = 1, col = 1;
    for (const char *p = text; p < at; p++) {
        col = *p == '\n' ? 1 : col + 1;
        line += *p == '\n';
    }
    size_t left = (size_t)(text + len - at);
    const char *hint = "";
    long depth;
    const int incomplete = cn_json_incomplete(text, len, &depth);
    char deep[96];
    if (depth > CJSON_NESTING_LIMIT) {
        snprintf(deep, sizeof deep, " (nested %ld deep; the parser stops at %d)", depth,
                 CJSON_NESTING_LIMIT);
        hint = deep;
    } else if (left == 0 || incomplete)
        hint = " (unexpected end of file)";
    else if ((left >= 3 && !strncmp(at, "NaN", 3)) || (left >= 4 && !strncmp(at, "-NaN", 4)) ||
             (left >= 8 && !strncmp(at, "Infinity", 8)) ||
             (left >= 9 && !strncmp(at, "-Infinity", 9)))
        hint = " (NaN and Infinity are not valid JSON numbers)";
    return cn_fail(err, errlen, "%s: malformed JSON at line %d, column %d%s", path, line, col,
                   hint);
}

/* Reads and parses a JSON file whose top level must be an object. */
/* Parses a JSON object from memory; `path` names it in messages. */
static int cn_json_parse(const char *path, const uint8_t *data, size_t len, cJSON **root,
                         char *err, size_t errlen)
{
    *root = NULL;
    const char *text = (const char *)data, *end = NULL;
    cJSON *j = len ? cJSON_ParseWithLengthOpts(text, len, &end, 0) : NULL;
    int rc = 0;
    if (!j) {
        rc = cn_json_syntax_error(path, text, len, end, err, errlen);
    } else {
        const char *p = end;
        while (p < text + len && isspace((unsigned char)*p))
            p++;
        if (p < text + len) {
            char why[256];
            cn_json_syntax_error(path, text, len, p, why, sizeof why);
            rc = cn_fail(err, errlen, "%s (unexpected data after the top-level value)", why);
        } else if (!cJSON_IsObject(j)) {
            rc = cn_fail(err, errlen, "%s: expected a JSON object at the top level", path);
        }
    }
    if (rc != 0)
        cJSON_Delete(j);
    else
        *root = j;
    return rc;
}

/* A transforms file lists a camera in under 1 kB per frame: 64 MiB is some 70,000 frames,
 * more than any capture, and a file larger than that is refused before it is read. */
#define CN_JSON_MAX (64u << 20)

static int cn_json_load(const char *path, cJSON **root, char *err, size_t errlen)
{
    *root = NULL;
    uint8_t *data;
    size_t len;
    if (cn_read_file_max(path, CN_JSON_MAX, "a camera file", &data, &len, err, errlen) != 0)
        return -1;
    if (cn_input_add(path, "a camera file of the dataset")) {
        free(data);
        return cn_fail(err, errlen, "%s: out of memory", path);
    }
    const int rc = cn_json_parse(path, data, len, root, err, errlen);
    free(data);
    return rc;
}

/* A finite number under `key`: 1 when found, 0 when absent and optional, -1 on error
 * (absent and required, not a number, not finite). */
static int cn_json_num(const cJSON *obj, const char *key, int required, const cn_jloc *l,
                       double *v, char *err, size_t errlen)
{
    const cJSON *it = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!it)
        return required ? cn_jfail(l, key, err, errlen, "missing") : 0;
    if (!cJSON_IsNumber(it))
        return cn_jfail(l, key, err, errlen, "expected a number");
    if (!isfinite(it->valuedouble))
        return cn_jfail(l, key, err, errlen, "not a finite number");
    *v = it->valuedouble;
    return 1;
}

/* An optional positive number; *v keeps its value when the key is absent. */
static int cn_json_positive(const cJSON *obj, const char *key, const cn_jloc *l, double *v,
                            char *err, size_t errlen)
{
    double x = 0;
    int r = cn_json_num(obj, key, 0, l, &x, err, errlen);
    if (r < 0)
        return -1;
    if (r == 1 && !(x > 0))
        return cn_jfail(l, key, err, errlen, "must be positive (is %g)", x);
    if (r == 1)
        *v = x;
    return 0;
}

/* A field of view in radians, in (0, pi); *v keeps its value when absent and optional. */
static int cn_json_angle(const cJSON *obj, const char *key, int required, const cn_jloc *l,
                         double *v, char *err, size_t errlen)
{
    double x = 0;
    int r = cn_json_num(obj, key, required, l, &x, err, errlen);
    if (r < 0)
        return -1;
    if (r == 1 && !(x > 0 && x < M_PI))
        return cn_jfail(l, key, err, errlen, "must be a field of view in (0, pi) radians (is %g)",
                        x);
    if (r == 1)
        *v = x;
    return 0;
}

/* The top-level "frames" array. */
static int cn_json_frames(const cJSON *root, const char *file, const cJSON **frames, char *err,
                          size_t errlen)
{
    cn_jloc l = {file, -1};
    *frames = cJSON_GetObjectItemCaseSensitive(root, "frames");
    if (!*frames)
        return cn_jfail(&l, "frames", err, errlen, "missing");
    if (!cJSON_IsArray(*frames))
        return cn_jfail(&l, "frames", err, errlen, "expected an array");
    return 0;
}

/* The top 3x4 of a 4x4 array of numbers; -1 if it is anything else. */
static int cn_json_matrix(const cJSON *m, double c2w[3][4])
{
    if (!cJSON_IsArray(m) || cJSON_GetArraySize(m) != 4)
        return -1;
    int i = 0;
    const cJSON *row;
    cJSON_ArrayForEach(row, m)
    {
        if (!cJSON_IsArray(row) || cJSON_GetArraySize(row) != 4)
            return -1;
        int j = 0;
        const cJSON *x;
        cJSON_ArrayForEach(x, row)
        {
            if (!cJSON_IsNumber(x))
                return -1;
            if (i < 3)
                c2w[i][j] = x->valuedouble;
            j++;
        }
        i++;
    }
    return 0;
}

/* frames[i]: its file_path and a valid transform_matrix. */
static int cn_json_frame(const cJSON *fr, const cn_jloc *l, const char **file_path,
                         double c2w[3][4], char *err, size_t errlen)
{
    if (!cJSON_IsObject(fr))
        return cn_jfail(l, NULL, err, errlen, "expected an object");
    const cJSON *fp = cJSON_GetObjectItemCaseSensitive(fr, "file_path");
    if (!fp)
        return cn_jfail(l, "file_path", err, errlen, "missing");
    if (!cJSON_IsString(fp) || !fp->valuestring[0])
        return cn_jfail(l, "file_path", err, errlen, "expected a non-empty string");
    *file_path = fp->valuestring;
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(fr, "transform_matrix");
    if (!m)
        return cn_jfail(l, "transform_matrix", err, errlen, "missing");
    if (cn_json_matrix(m, c2w) != 0)
        return cn_jfail(l, "transform_matrix", err, errlen, "expected a 4x4 array of numbers");
    char why[256];
    if (cn_pose_check((const double(*)[4])c2w, why, sizeof why) != 0)
        return cn_jfail(l, "transform_matrix", err, errlen, "%s", why);
    return 0;
}

/* The image of a frame: file_path as given, else with ".png" appended; then, for a path
 * with backslashes (a transforms.json written on Windows, as instant-ngp's scripts there
 * write it: "./custom_data\images/0008.jpg"), the same with slashes. Returns 1 when found
 * (path in out), 0 when missing (out = the path the frame most likely means: as given when
 * it has an extension, else with ".png"), -1 on error. */
static int cn_find_image(const char *dir, const char *file_path, char out[CN_PATH_MAX],
                         char *err, size_t errlen)
{
    char slashed[CN_PATH_MAX];
    const int windows = strchr(file_path, '\\') != NULL && strlen(file_path) < sizeof slashed;
    if (windows) {
        strcpy(slashed, file_path);
        for (char *c = slashed; *c; c++)
            if (*c == '\\')
                *c = '/';
    }
    for (int pass = 0; pass <= windows; pass++)
        for (int png = 0; png <= 1; png++) {
            if (cn_join(out, dir, pass ? slashed : file_path, png ? ".png" : "", err,
                        errlen) != 0)
                return -1;
            if (cn_is_file(out))
                return 1;
        }
    const char *base = strrchr(file_path, '/');
    base = base ? base + 1 : file_path;
    int has_ext = strchr(base + (base[0] == '.'), '.') != NULL;
    return cn_join(out, dir, file_path, has_ext ? "" : ".png", err, errlen) == 0 ? 0 : -1;
}

/* How a JSON layout assigns frames to splits and treats missing images. */
typedef struct cn_frame_rule {
    int split;        /* fixed split, or -1: every CN_LLFF_HOLD-th usable frame is a test
                         view, the others train */
    int skip_missing; /* 1: skip frames without an image (warning); 0: error */
    int frame_camera; /* 1: a frame's own camera keys replace the file's (cn_json_camera) */
} cn_frame_rule;

static int cn_json_camera(const cJSON *obj, const cn_jloc *l, cn_intr *in, char *err,
                          size_t errlen);
static int cn_intr_check(const cn_intr *in, const cn_jloc *l, char *err, size_t errlen);

/* One frame's intrinsics: the file's, with the frame's own keys when the layout has them. */
static int cn_frame_intr(const cJSON *fr, const cn_jloc *l, const cn_frame_rule *rule,
                         const cn_intr *file_in, cn_intr *in, char *err, size_t errlen)
{
    *in = *file_in;
    if (rule->frame_camera && cn_json_camera(fr, l, in, err, errlen) != 0)
        return -1;
    if (memcmp(in, file_in, sizeof *in) != 0) /* the frame's own camera */
        snprintf(in->src, sizeof in->src, "%s: frames[%d]", l->file, l->frame);
    else
        snprintf(in->src, sizeof in->src, "%s", l->file);
    return cn_intr_check(in, l, err, errlen);
}

/* Adds every frame of a transforms file's "frames" array to L. */
static int cn_json_add_frames(const cJSON *root, const char *file, const char *dir,
                              const cn_frame_rule *rule, const cn_intr *in, cn_frames *L,
                              char *err, size_t errlen)
{
    const cJSON *frames;
    if (cn_json_frames(root, file, &frames, err, errlen) != 0)
        return -1;
    int i = 0, usable = 0;
    const cJSON *fr;
    cJSON_ArrayForEach(fr, frames)
    {
        cn_jloc l = {file, i++};
        const char *file_path = NULL;
        double c2w[3][4];
        char path[CN_PATH_MAX];
        cn_intr fin;
        if (cn_json_frame(fr, &l, &file_path, c2w, err, errlen) != 0 ||
            cn_frame_intr(fr, &l, rule, in, &fin, err, errlen) != 0)
            return -1;
        int found = cn_find_image(dir, file_path, path, err, errlen);
        if (found < 0)
            return -1;
        if (!found && !rule->skip_missing)
            return cn_fail(err, errlen, "%s: %s (frames[%d].file_path in %s)", path,
                           cn_not_file_why(path), l.frame,
                           file);
        if (!found) {
            /* (a path longer than the note is cut: it only names the frame) */
            if (L->skipped++ == 0 && snprintf(L->first_skipped, sizeof L->first_skipped,
                                              "%s: %s", path, cn_not_file_why(path)) < 0)
                L->first_skipped[0] = '\0';
            continue;
        }
        int split = rule->split >= 0 ? rule->split
                    : usable % CN_LLFF_HOLD == 0 ? CN_TEST
                                                 : CN_TRAIN;
        usable++;
        if (cn_frames_add(L, path, split, (const double(*)[4])c2w, &fin, err, errlen) != 0)
            return -1;
    }
    return 0;
}

/* ---- Blender ---- */

static int cn_load_blender_split(const char *dir, int split, cn_frames *L, char *err,
                                 size_t errlen)
{
    static const char *names[3] = {"transforms_train.json", "transforms_val.json",
                                   "transforms_test.json"};
    char file[CN_PATH_MAX];
    if (cn_join(file, dir, names[split], "", err, errlen) != 0)
        return -1;
    if (!cn_is_file(file)) {
        if (split == CN_TRAIN)
            return cn_fail(err, errlen, "%s: %s", file, cn_not_file_why(file));
        return 0; /* that split stays empty */
    }
    cJSON *root;
    if (cn_json_load(file, &root, err, errlen) != 0)
        return -1;
    cn_jloc l = {file, -1};
    cn_intr in = cn_intr_none;
    cn_frame_rule rule = {split, 0, 0};
    int rc = cn_json_angle(root, "camera_angle_x", 1, &l, &in.angle_x, err, errlen);
    if (rc == 0)
        rc = cn_json_add_frames(root, file, dir, &rule, &in, L, err, errlen);
    cJSON_Delete(root);
    return rc;
}

static int cn_load_blender(const char *dir, cn_dataset *ds, cn_frames *L, char *err,
                           size_t errlen)
{
    ds->near = 2.0;
    ds->far = 6.0;
    for (int s = CN_TRAIN; s <= CN_TEST; s++)
        if (cn_load_blender_split(dir, s, L, err, errlen) != 0)
            return -1;
    return 0;
}

/* ---- instant-ngp transforms.json ---- */

/* The camera keys of instant-ngp's and nerfstudio's transforms.json, at the top level or in
 * one frame: each key present replaces *in's value. camera_model (nerfstudio) is PINHOLE,
 * SIMPLE_PINHOLE, OPENCV or OPENCV_FISHEYE; is_fisheye (instant-ngp) picks the fisheye
 * model when camera_model is absent. */
static int cn_json_camera(const cJSON *obj, const cn_jloc *l, cn_intr *in, char *err,
                          size_t errlen)
{
    if (cn_json_positive(obj, "w", l, &in->ref_w, err, errlen) ||
        cn_json_positive(obj, "h", l, &in->ref_h, err, errlen) ||
        cn_json_positive(obj, "fl_x", l, &in->fx, err, errlen) ||
        cn_json_positive(obj, "fl_y", l, &in->fy, err, errlen) ||
        cn_json_angle(obj, "camera_angle_x", 0, l, &in->angle_x, err, errlen) ||
        cn_json_angle(obj, "camera_angle_y", 0, l, &in->angle_y, err, errlen) ||
        cn_json_num(obj, "cx", 0, l, &in->cx, err, errlen) < 0 ||
        cn_json_num(obj, "cy", 0, l, &in->cy, err, errlen) < 0)
        return -1;
    static const char *coef[6] = {"k1", "k2", "k3", "k4", "p1", "p2"};
    for (int i = 0; i < 6; i++)
        if (cn_json_num(obj, coef[i], 0, l, i < 4 ? &in->k[i] : &in->p[i - 4], err, errlen) < 0)
            return -1;
    in->sized = !isnan(in->ref_w) && !isnan(in->ref_h);
    const cJSON *fe = cJSON_GetObjectItemCaseSensitive(obj, "is_fisheye");
    if (fe && !cJSON_IsBool(fe))
        return cn_jfail(l, "is_fisheye", err, errlen, "expected true or false");
    if (fe)
        in->fisheye = cJSON_IsTrue(fe);
    const cJSON *cm = cJSON_GetObjectItemCaseSensitive(obj, "camera_model");
    if (cm) {
        static const struct {
            const char *name;
            int model;
        } models[] = {{"PINHOLE", CN_LENS_PINHOLE}, {"SIMPLE_PINHOLE", CN_LENS_PINHOLE},
                      {"OPENCV", CN_LENS_OPENCV}, {"OPENCV_FISHEYE", CN_LENS_FISHEYE}};
        if (!cJSON_IsString(cm))
            return cn_jfail(l, "camera_model", err, errlen, "expected a string");
        in->model = -2;
        for (size_t i = 0; i < sizeof models / sizeof models[0]; i++)
            if (!strcmp(cm->valuestring, models[i].name))
                in->model = models[i].model;
        if (in->model == -2)
            return cn_jfail(l, "camera_model", err, errlen, "'%s' is not supported (PINHOLE, "
                            "SIMPLE_PINHOLE, OPENCV, OPENCV_FISHEYE)", cm->valuestring);
    }
    return 0;
}

/* Complete intrinsics: a focal length, and coefficients that the lens model uses. */
static int cn_intr_check(const cn_intr *in, const cn_jloc *l, char *err, size_t errlen)
{
    if (isnan(in->fx) && isnan(in->angle_x))
        return cn_jfail(l, "fl_x", err, errlen, "missing (and no camera_angle_x either)");
    const cn_lens lens = cn_intr_lens(in);
    const char *model = lens.model == CN_LENS_PINHOLE ? "PINHOLE"
                        : lens.model == CN_LENS_FISHEYE ? "OPENCV_FISHEYE"
                                                        : "OPENCV";
    static const char *coef[6] = {"k1", "k2", "k3", "k4", "p1", "p2"};
    for (int i = 0; i < 6; i++) {
        const double c = i < 4 ? in->k[i] : in->p[i - 4];
        const int used = lens.model == CN_LENS_OPENCV    ? i != 3
                         : lens.model == CN_LENS_FISHEYE ? i < 4
                                                         : 0;
        if (c != 0 && !used)
            return cn_jfail(l, coef[i], err, errlen, "is %g, but the %s lens model has no %s",
                            c, model, coef[i]);
    }
    return 0;
}

/* Camera intrinsics and aabb_scale of a transforms.json. */
static int cn_ngp_intrinsics(const cJSON *root, const cn_jloc *l, cn_intr *in, double *aabb,
                             char *err, size_t errlen)
{
    *in = cn_intr_none;
    *aabb = 1.0;
    if (cn_json_camera(root, l, in, err, errlen) ||
        cn_json_positive(root, "aabb_scale", l, aabb, err, errlen))
        return -1;
    /* instant-ngp's scene box is aabb_scale times the unit cube, a power of two up to 128 */
    if (!(*aabb >= 1.0 / 64 && *aabb <= 128))
        return cn_jfail(l, "aabb_scale", err, errlen, "%g is not a scene scale (1/64 to 128)",
                        *aabb);
    return 0;
}

static int cn_load_ngp(const char *dir, cn_dataset *ds, cn_frames *L, char *err, size_t errlen)
{
    char file[CN_PATH_MAX];
    cJSON *root;
    if (cn_join(file, dir, "transforms.json", "", err, errlen) != 0 ||
        cn_json_load(file, &root, err, errlen) != 0)
        return -1;
    cn_jloc l = {file, -1};
    cn_intr in;
    double s;
    cn_frame_rule rule = {-1, 1, 1};
    int rc = cn_ngp_intrinsics(root, &l, &in, &s, err, errlen);
    if (rc == 0)
        rc = cn_json_add_frames(root, file, dir, &rule, &in, L, err, errlen);
    cJSON_Delete(root);
    /* Cameras around a scene centred at the origin inside the cube [-s, s]^3. */
    ds->near = fmax(0.05, L->rmin - sqrt(3.0) * s);
    ds->far = L->rmax + sqrt(3.0) * s;
    return rc;
}

/* ---- LLFF poses_bounds.npy ---- */

/* A cursor over the Python literal of a .npy header. */
typedef struct cn_scan {
    const char *p, *end;
} cn_scan;

static void cn_scan_blank(cn_scan *s)
{
    while (s->p < s->end && (*s->p == ' ' || *s->p == '\t' || *s->p == '\n'))
        s->p++;
}

/* Skips blanks, then consumes w if it comes next. */
static int cn_scan_word(cn_scan *s, const char *w)
{
    size_t n = strlen(w);
    cn_scan_blank(s);
    if ((size_t)(s->end - s->p) >= n && !strncmp(s->p, w, n)) {
        s->p += n;
        return 1;
    }
    return 0;
}

/* A quoted string without escapes. */
static int cn_scan_str(cn_scan *s, char *out, size_t n)
{
    char q = cn_scan_word(s, "'") ? '\'' : cn_scan_word(s, "\"") ? '"' : 0;
    if (!q)
        return 0;
    size_t k = 0;
    while (s->p < s->end && *s->p != q) {
        if (k + 1 >= n)
            return 0;
        out[k++] = *s->p++;
    }
    out[k] = '\0';
    return s->p < s->end && *s->p++ == q;
}

/* A tuple of non-negative integers: "(20, 17)", "(5,)", "()". */
static int cn_scan_shape(cn_scan *s, long *dim, int max, int *ndim)
{
    *ndim = 0;
    if (!cn_scan_word(s, "("))
        return 0;
    for (;;) {
        if (cn_scan_word(s, ")"))
            return 1;
        if (*ndim == max || s->p >= s->end || !isdigit((unsigned char)*s->p))
            return 0;
        long v = 0;
        while (s->p < s->end && isdigit((unsigned char)*s->p) && v < 100000000)
            v = 10 * v + (*s->p++ - '0');
        if (s->p < s->end && isdigit((unsigned char)*s->p))
            return 0; /* absurdly large */
        dim[(*ndim)++] = v;
        if (cn_scan_word(s, ")"))
            return 1;
        if (!cn_scan_word(s, ","))
            return 0;
    }
}

/* The header dictionary {'descr': ..., 'fortran_order': ..., 'shape': (...), }. Returns 0,
 * or -1 with the problem in why. */
static int cn_npy_dict(cn_scan *s, cn_npy *h, char *why, size_t n)
{
    unsigned seen = 0;
    if (!cn_scan_word(s, "{"))
        return cn_fail(why, n, "expected a dictionary");
    while (!cn_scan_word(s, "}")) {
        char key[32];
        if (!cn_scan_str(s, key, sizeof key) || !cn_scan_word(s, ":"))
            return cn_fail(why, n, "expected 'key': value");
        if (!strcmp(key, "descr")) {
            if (!cn_scan_str(s, h->descr, sizeof h->descr))
                return cn_fail(why, n, "descr: expected a short string");
            seen |= 1;
        } else if (!strcmp(key, "fortran_order")) {
            h->fortran = cn_scan_word(s, "True");
            if (!h->fortran && !cn_scan_word(s, "False"))
                return cn_fail(why, n, "fortran_order: expected True or False");
            seen |= 2;
        } else if (!strcmp(key, "shape")) {
            if (!cn_scan_shape(s, h->shape, 8, &h->ndim))
                return cn_fail(why, n, "shape: expected a tuple of integers");
            seen |= 4;
        } else {
            return cn_fail(why, n, "unexpected key '%s'", key);
        }
        if (!cn_scan_word(s, ",")) {
            if (!cn_scan_word(s, "}"))
                return cn_fail(why, n, "expected ',' or '}'");
            break;
        }
    }
    if (seen != 7)
        return cn_fail(why, n, "descr, fortran_order or shape missing");
    cn_scan_blank(s);
    if (s->p != s->end)
        return cn_fail(why, n, "unexpected text after the dictionary");
    return 0;
}

int cn_npy_parse(const char *file, const uint8_t *d, size_t len, cn_npy *h, char *err,
                 size_t errlen)
{
    memset(h, 0, sizeof *h);
    if (len < 10 || memcmp(d, "\x93NUMPY", 6) != 0)
        return cn_fail(err, errlen, "%s: not a NumPy .npy file (bad magic)", file);
    if ((d[6] != 1 && d[6] != 2) || d[7] != 0)
        return cn_fail(err, errlen, "%s: unsupported .npy version %d.%d (expected 1.0 or 2.0)",
                       file, d[6], d[7]);
    size_t off = d[6] == 1 ? 10 : 12;
    if (len < off)
        return cn_fail(err, errlen, "%s: truncated .npy header", file);
    size_t hl = d[8] | (size_t)d[9] << 8;
    if (d[6] == 2)
        hl |= (size_t)d[10] << 16 | (size_t)d[11] << 24;
    if (hl > len - off)
        return cn_fail(err, errlen, "%s: truncated .npy header", file);
    cn_scan s = {(const char *)d + off, (const char *)d + off + hl};
    char why[128];
    if (cn_npy_dict(&s, h, why, sizeof why) != 0)
        return cn_fail(err, errlen, "%s: bad .npy header: %s", file, why);
    h->body = d + off + hl;
    h->body_len = len - off - hl;
    return 0;
}

int cn_npy_floats(const char *file, const cn_npy *h, int f4, int ndim, const long *want,
                  const char *expect, char *err, size_t errlen)
{
    const size_t size = !strcmp(h->descr, "<f8") ? 8 : f4 && !strcmp(h->descr, "<f4") ? 4 : 0;
    if (!size)
        return cn_fail(err, errlen, "%s: dtype '%s' is not supported (expected %s)", file,
                       h->descr, f4 ? "'<f4' or '<f8', little-endian float32 or float64"
                                    : "'<f8', little-endian float64");
    if (h->fortran)
        return cn_fail(err, errlen, "%s: fortran_order True is not supported (expected C order)",
                       file);
    int ok = h->ndim == ndim;
    for (int i = 0; ok && i < ndim; i++)
        ok = want[i] < 0 ? h->shape[i] >= 1 : h->shape[i] == want[i];
    char shape[160] = "";
    for (int i = 0; i < h->ndim; i++)
        snprintf(shape + strlen(shape), sizeof shape - strlen(shape), "%s%ld", i ? ", " : "",
                 h->shape[i]);
    if (!ok)
        return cn_fail(err, errlen, "%s: array shape (%s): expected %s", file, shape, expect);
    size_t need = size;
    int huge = 0; /* more bytes than a size_t counts */
    for (int i = 0; i < ndim; i++) {
        huge |= need > SIZE_MAX / (size_t)h->shape[i];
        need *= huge ? 1 : (size_t)h->shape[i];
    }
    if (huge || h->body_len != need) {
        char n[32] = "more";
        if (!huge)
            snprintf(n, sizeof n, "%zu", need);
        return cn_fail(err, errlen, "%s: %s: %zu data bytes, but shape (%s) of float%d needs %s",
                       file, huge || h->body_len < need ? "truncated" : "trailing bytes",
                       h->body_len, shape, (int)size * 8, n);
    }
    return 0;
}

double cn_npy_at(const cn_npy *h, size_t i)
{
    const int size = h->descr[2] == '8' ? 8 : 4;
    const uint8_t *p = h->body + (size_t)size * i;
    uint64_t u = 0;
    for (int k = size - 1; k >= 0; k--)
        u = u << 8 | p[k];
    if (size == 8) {
        double v;
        memcpy(&v, &u, sizeof v);
        return v;
    }
    const uint32_t u32 = (uint32_t)u;
    float v;
    memcpy(&v, &u32, sizeof v);
    return v;
}

/* One LLFF camera, converted to NeRF's conventions. */
typedef struct cn_llff_cam {
    double c2w[3][4];
    cn_intr in;
    double bnear, bfar; /* depth bounds */
} cn_llff_cam;

/* Row r: a row-major 3x5 [R | t | hwf] with rotation columns [down, right, back], then the
 * depth bounds. The columns become [right, up, back] = [c1, -c0, c2]. */
static int cn_llff_row(const cn_npy *a, int r, const char *file, cn_llff_cam *cam, char *err,
                       size_t errlen)
{
    double v[17];
    for (int i = 0; i < 17; i++) {
        v[i] = cn_npy_at(a, (size_t)r * 17 + (size_t)i);
        if (!isfinite(v[i]))
            return cn_fail(err, errlen, "%s: row %d: non-finite value in column %d", file, r, i);
    }
    for (int i = 0; i < 3; i++) {
        const double *m = v + 5 * i;
        cam->c2w[i][0] = m[1];
        cam->c2w[i][1] = -m[0];
        cam->c2w[i][2] = m[2];
        cam->c2w[i][3] = m[3];
    }
    double h = v[4], w = v[9], f = v[14];
    if (!(h > 0 && w > 0 && f > 0))
        return cn_fail(err, errlen,
                       "%s: row %d: image height, width and focal length must be positive "
                       "(got %g, %g, %g)",
                       file, r, h, w, f);
    cam->bnear = v[15];
    cam->bfar = v[16];
    if (!(cam->bnear > 0 && cam->bnear <= cam->bfar))
        return cn_fail(err, errlen,
                       "%s: row %d: depth bounds must satisfy 0 < near <= far (got %g, %g)", file,
                       r, cam->bnear, cam->bfar);
    char why[256];
    if (cn_pose_check((const double(*)[4])cam->c2w, why, sizeof why) != 0)
        return cn_fail(err, errlen, "%s: row %d: %s", file, r, why);
    cam->in = cn_intr_none;
    cam->in.ref_w = w;
    cam->in.ref_h = h;
    cam->in.fx = cam->in.fy = f;
    cam->in.cx = 0.5 * w;
    cam->in.cy = 0.5 * h;
    return 0;
}

static double cn_normalize3(double v[3])
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 0)
        for (int i = 0; i < 3; i++)
            v[i] /= n;
    return n;
}

static void cn_cross3(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* NeRF's recentring: the average pose (mean centre, normalised sum of the z axes, up from
 * the sum of the y axes, made orthonormal) becomes the identity. */
static int cn_llff_recentre(cn_llff_cam *cams, int n, const char *file, char *err,
                            size_t errlen)
{
    double c[3] = {0}, z[3] = {0}, up[3] = {0}, x[3], y[3];
    for (int k = 0; k < n; k++)
        for (int i = 0; i < 3; i++) {
            c[i] += cams[k].c2w[i][3] / n;
            up[i] += cams[k].c2w[i][1];
            z[i] += cams[k].c2w[i][2];
        }
    cn_cross3(up, z, x);
    if (cn_normalize3(z) < 1e-9 || cn_normalize3(x) < 1e-9)
        return cn_fail(err, errlen,
                       "%s: cannot recentre: the cameras' average orientation is degenerate",
                       file);
    cn_cross3(z, x, y);
    const double *a[3] = {x, y, z}; /* rows of the average rotation's transpose */
    for (int k = 0; k < n; k++) {
        double m[3][4];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 4; j++) {
                double s = 0;
                for (int l = 0; l < 3; l++)
                    s += a[i][l] * (cams[k].c2w[l][j] - (j == 3 ? c[l] : 0.0));
                m[i][j] = s;
            }
        memcpy(cams[k].c2w, m, sizeof m);
    }
    return 0;
}

/* A capture whose cameras all look the same way (the mean of their viewing directions is
 * longer than this) is forward-facing and takes LLFF's conventions (NDC); any other is a
 * capture around its object (LLFF files and COLMAP models alike). */
#define CN_FORWARD 0.9

static int cn_orient_inward(cn_llff_cam *cams, int n, const char *file, double *scale,
                            char *err, size_t errlen);

/* poses_bounds.npy's bytes into NeRF-convention cameras (see cn_llff_cameras). */
static int cn_llff_cameras_mem(const char *file, const uint8_t *data, size_t len,
                               cn_llff_cam **cams, int *n, cn_dataset *ds, char *err,
                               size_t errlen)
{
    /* version 1.0 or 2.0, '<f8', C order, shape (N, 17), nothing after the data */
    static const long shape[2] = {-1, 17};
    *cams = NULL;
    cn_npy a;
    int rc = cn_npy_parse(file, data, len, &a, err, errlen);
    if (rc == 0)
        rc = cn_npy_floats(file, &a, 0, 2, shape, "(N, 17) with N >= 1", err, errlen);
    *n = rc == 0 ? (int)a.shape[0] : 0;
    if (rc == 0 && !(*cams = calloc((size_t)*n, sizeof **cams)))
        rc = cn_fail(err, errlen, "%s: out of memory", file);
    for (int i = 0; rc == 0 && i < *n; i++)
        rc = cn_llff_row(&a, i, file, &(*cams)[i], err, errlen);
    if (rc != 0)
        return -1;
    double bmin = (*cams)[0].bnear, bmax = (*cams)[0].bfar, fwd[3] = {0, 0, 0};
    for (int i = 0; i < *n; i++) {
        bmin = fmin(bmin, (*cams)[i].bnear);
        bmax = fmax(bmax, (*cams)[i].bfar);
        for (int a = 0; a < 3; a++)
            fwd[a] -= (*cams)[i].c2w[a][2] / *n;
    }
    ds->ndc = cn_normalize3(fwd) > CN_FORWARD;
    if (!ds->ndc) {
        /* a capture around the object (NeRF's 360-degree real scenes ship this way) */
        double sc;
        if (cn_orient_inward(*cams, *n, file, &sc, err, errlen) != 0)
            return -1;
        ds->near = fmax(0.01, 0.9 * bmin * sc);
        ds->far = 1.1 * bmax * sc;
        return 0;
    }
    double sc = 1.0 / (bmin * 0.75);
    for (int i = 0; i < *n; i++)
        for (int r = 0; r < 3; r++)
            (*cams)[i].c2w[r][3] *= sc;
    ds->near = bmin * sc * 0.9;
    ds->far = bmax * sc;
    return cn_llff_recentre(*cams, *n, file, err, errlen);
}

/* Reads poses_bounds.npy into NeRF-convention cameras. Forward-facing (CN_FORWARD):
 * scaled so that the nearest bound is 1/0.75, recentred, near/far 0.9 x the nearest bound
 * and the farthest, NDC. Otherwise inward (cn_orient_inward), near/far 0.9 and 1.1 x the
 * extreme bounds, no NDC. */
static int cn_llff_cameras(const char *file, cn_llff_cam **cams, int *n, cn_dataset *ds,
                           char *err, size_t errlen)
{
    *cams = NULL;
    uint8_t *data;
    size_t len;
    if (cn_read_file(file, &data, &len, err, errlen) != 0)
        return -1;
    if (cn_input_add(file, "a camera file of the dataset")) {
        free(data);
        return cn_fail(err, errlen, "%s: out of memory", file);
    }
    const int rc = cn_llff_cameras_mem(file, data, len, cams, n, ds, err, errlen);
    free(data);
    return rc;
}

static int cn_cmp_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int cn_has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return n > e && !strcasecmp(name + n - e, ext);
}

static void cn_free_names(char **names, int n)
{
    for (int i = 0; i < n; i++)
        free(names[i]);
    free(names);
}

/* The PNG and JPEG files of a directory (only those whose names end in `suffix`, when it is
 * not NULL), sorted by name. */
static int cn_list_images(const char *dir, const char *suffix, char ***names, int *n, char *err,
                          size_t errlen)
{
    *names = NULL;
    *n = 0;
    DIR *d = opendir(dir);
    if (!d)
        return cn_fail(err, errlen, "%s: cannot open the directory", dir);
    int cap = 0, rc = 0;
    struct dirent *e;
    while (rc == 0 && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        if (suffix ? !cn_has_ext(e->d_name, suffix)
                   : !cn_has_ext(e->d_name, ".png") && !cn_has_ext(e->d_name, ".jpg") &&
                         !cn_has_ext(e->d_name, ".jpeg"))
            continue;
        if (*n == cap) {
            cap = cap ? 2 * cap : 64;
            char **p = realloc(*names, sizeof *p * (size_t)cap);
            if (!p) {
                rc = -1;
                break;
            }
            *names = p;
        }
        if (!((*names)[*n] = strdup(e->d_name)))
            rc = -1;
        else
            (*n)++;
    }
    closedir(d);
    if (rc != 0)
        cn_fail(err, errlen, "%s: out of memory", dir);
    if (rc != 0) {
        cn_free_names(*names, *n);
        *names = NULL;
        *n = 0;
        return -1;
    }
    if (*n > 1) /* qsort may not be given the NULL of an empty list */
        qsort(*names, (size_t)*n, sizeof **names, cn_cmp_name);
    return 0;
}

/* images_<8F>/ when it exists (no further downscaling), else images_8/ downscaled by F. */
/* An LLFF capture without images_8/ (as imgs2poses leaves it: images/ only): images/ or any
 * images_N/ whose files have the shape of poses_bounds.npy's cameras (W x H). The one
 * closest above the width that images_{8f}/ would have (W / 8f) is taken, reduced by the
 * integer factor that comes nearest to that width; the intrinsics scale with the files. */
static int cn_llff_any_dir(const char *dir, int f, double W, double H, char out[CN_PATH_MAX],
                           int *factor, char *note, size_t notelen, char *err, size_t errlen)
{
    DIR *d = opendir(dir);
    if (!d)
        return cn_fail(err, errlen, "%s: %s", dir, strerror(errno));
    const double T = W / (8.0 * f);
    int bw = 0, bh = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        const char *nm = e->d_name;
        if (strcmp(nm, "images") != 0 &&
            !(strncmp(nm, "images_", 7) == 0 && nm[7] && strspn(nm + 7, "0123456789") == strlen(nm + 7)))
            continue;
        char sub[CN_PATH_MAX], first[CN_PATH_MAX], e2[512];
        if (cn_join(sub, dir, nm, "", e2, sizeof e2) != 0 || !cn_is_dir(sub))
            continue;
        char **names;
        int n, w, h;
        if (cn_list_images(sub, NULL, &names, &n, e2, sizeof e2) != 0)
            continue;
        const int joined = n > 0 && cn_join(first, sub, names[0], "", e2, sizeof e2) == 0;
        cn_free_names(names, n);
        if (!joined || cn_image_size(first, W / H, &w, &h, e2, sizeof e2) != 0 ||
            fabs((double)w * H / ((double)h * W) - 1) > 0.01)
            continue;
        const int better = !bw || (w >= T ? (bw < T || w < bw) : (bw < T && w > bw));
        if (better) {
            bw = w;
            bh = h;
            memcpy(out, sub, CN_PATH_MAX);
        }
    }
    closedir(d);
    char tried[40] = "";
    if (f > 1)
        snprintf(tried, sizeof tried, "images_%d/, ", 8 * f);
    if (!bw)
        return cn_fail(err, errlen, "%s: no image directory: looked for %simages_8/, and images/ "
                       "or images_N/ with images of the shape of poses_bounds.npy's cameras "
                       "(%gx%g)", dir, tried, W, H);
    const long k = lround(bw / T);
    *factor = k > 1 ? (int)k : 1;
    snprintf(note, notelen, "images: %.400s (%dx%d files; poses_bounds.npy's cameras are for "
             "%gx%g), downscaled by %d", out, bw, bh, W, H, *factor);
    return 0;
}

static int cn_llff_image_dir(const char *dir, int f, char out[CN_PATH_MAX], int *factor,
                             char *err, size_t errlen)
{
    char name[32];
    snprintf(name, sizeof name, "images_%d", 8 * f);
    if (cn_join(out, dir, name, "", err, errlen) != 0)
        return -1;
    if (cn_is_dir(out)) {
        *factor = 1;
        return 0;
    }
    if (cn_join(out, dir, "images_8", "", err, errlen) != 0)
        return -1;
    if (cn_is_dir(out)) {
        *factor = f;
        return 0;
    }
    return 1; /* neither: cn_llff_any_dir looks further */
}

/* Pairs the images of imgdir (cn_list_images), in name order, with the n cameras of `file`;
 * views 0, 8, 16, ... are test views. `kinds` names the files looked for in the message of a
 * count that differs. */
static int cn_sorted_frames(const char *imgdir, const char *suffix, const char *kinds,
                            const char *file, const cn_llff_cam *cams, int n, cn_frames *L,
                            char *err, size_t errlen)
{
    char path[CN_PATH_MAX];
    char **names;
    int nimg;
    if (cn_list_images(imgdir, suffix, &names, &nimg, err, errlen) != 0)
        return -1;
    int rc = 0;
    if (nimg != n)
        rc = cn_fail(err, errlen, "%s: %d images (%s) for %d poses in %s", imgdir, nimg, kinds, n,
                     file);
    for (int i = 0; rc == 0 && i < n; i++) {
        int split = i % CN_LLFF_HOLD == 0 ? CN_TEST : CN_TRAIN;
        rc = cn_join(path, imgdir, names[i], "", err, errlen);
        if (rc == 0)
            rc = cn_frames_add(L, path, split, (const double(*)[4])cams[i].c2w, &cams[i].in,
                               err, errlen);
    }
    cn_free_names(names, nimg);
    return rc;
}

static int cn_load_llff(const char *dir, cn_dataset *ds, cn_frames *L, char *err,
                        size_t errlen)
{
    char file[CN_PATH_MAX], imgdir[CN_PATH_MAX];
    cn_llff_cam *cams = NULL;
    int n = 0;
    int rc = cn_join(file, dir, "poses_bounds.npy", "", err, errlen);
    if (rc == 0)
        rc = cn_llff_cameras(file, &cams, &n, ds, err, errlen);
    if (rc == 0)
        rc = cn_llff_image_dir(dir, L->factor, imgdir, &L->factor, err, errlen);
    if (rc == 1)
        rc = n > 0 ? cn_llff_any_dir(dir, L->factor, cams[0].in.ref_w, cams[0].in.ref_h, imgdir,
                                     &L->factor, ds->note, sizeof ds->note, err, errlen)
                   : cn_fail(err, errlen, "%s: no cameras", file);
    if (rc == 0)
        rc = cn_sorted_frames(imgdir, NULL, "PNG, JPEG", file, cams, n, L, err, errlen);
    free(cams);
    return rc;
}

/* ---- DTU: cameras.npz of IDR, NeuS, VolSDF and MonoSDF ---- */

static int cn_load_dtu(const char *dir, cn_dataset *ds, cn_frames *L, char *err, size_t errlen)
{
    char file[CN_PATH_MAX], imgdir[CN_PATH_MAX];
    int rc = cn_join(file, dir, "cameras.npz", "", err, errlen);
    if (rc == 0 && !cn_is_file(file)) /* NeuS's name */
        rc = cn_join(file, dir, "cameras_sphere.npz", "", err, errlen);
    cn_dtu_cam *dc = NULL;
    int n = 0;
    if (rc == 0)
        rc = cn_dtu_read(file, &dc, &n, err, errlen);
    cn_llff_cam *cams = rc == 0 ? calloc((size_t)n, sizeof *cams) : NULL;
    if (rc == 0 && !cams)
        rc = cn_fail(err, errlen, "%s: out of memory", file);
    for (int i = 0; rc == 0 && i < n; i++) {
        memcpy(cams[i].c2w, dc[i].c2w, sizeof cams[i].c2w);
        cams[i].in = cn_intr_none;
        cams[i].in.fx = dc[i].fx;
        cams[i].in.fy = dc[i].fy;
        cams[i].in.cx = dc[i].cx;
        cams[i].in.cy = dc[i].cy;
    }
    /* image/ (IDR, NeuS), images/, or MonoSDF's NNNNNN_rgb.png beside the cameras */
    const char *suffix = NULL, *kinds = "PNG, JPEG";
    if (rc == 0)
        rc = cn_join(imgdir, dir, "image", "", err, errlen);
    if (rc == 0 && !cn_is_dir(imgdir))
        rc = cn_join(imgdir, dir, "images", "", err, errlen);
    if (rc == 0 && !cn_is_dir(imgdir)) {
        snprintf(imgdir, sizeof imgdir, "%s", dir);
        suffix = "_rgb.png";
        kinds = "*_rgb.png, and no image/ or images/ directory";
    }
    if (rc == 0)
        rc = cn_sorted_frames(imgdir, suffix, kinds, file, cams, n, L, err, errlen);
    /* as instant-ngp's rule for a scene centred at the origin inside [-1, 1]^3 */
    ds->near = fmax(0.05, L->rmin - sqrt(3.0));
    ds->far = L->rmax + sqrt(3.0);
    free(cams);
    free(dc);
    return rc;
}

/* ---- COLMAP sparse models ---- */

/* The sparse model's directory: sparse/0/, sparse/ or colmap/sparse/0/ (nerfstudio). */
static int cn_colmap_dir(const char *dir, char out[CN_PATH_MAX])
{
    static const char *subs[] = {"sparse/0", "sparse", "colmap/sparse/0"};
    for (size_t i = 0; i < sizeof subs / sizeof subs[0]; i++) {
        char f[CN_PATH_MAX], e[64];
        if (cn_join(out, dir, subs[i], "", e, sizeof e) != 0)
            return 0;
        if ((cn_join(f, out, "cameras.bin", "", e, sizeof e) == 0 && cn_is_file(f)) ||
            (cn_join(f, out, "cameras.txt", "", e, sizeof e) == 0 && cn_is_file(f)))
            return 1;
    }
    return 0;
}

/* A camera's intrinsics; -1 for a model that cnerf does not read. */
static int cn_colmap_intr(const cn_colmap_camera *c, cn_intr *in)
{
    const double *p = c->params;
    *in = cn_intr_none;
    in->ref_w = (double)c->w;
    in->ref_h = (double)c->h;
    in->sized = 1;
    in->model = CN_LENS_OPENCV;
    switch (c->model) {
    case CN_COLMAP_SIMPLE_PINHOLE:
    case CN_COLMAP_SIMPLE_RADIAL:
    case CN_COLMAP_RADIAL:
        in->fx = in->fy = p[0];
        in->cx = p[1];
        in->cy = p[2];
        in->k[0] = c->model == CN_COLMAP_SIMPLE_PINHOLE ? 0 : p[3];
        in->k[1] = c->model == CN_COLMAP_RADIAL ? p[4] : 0;
        break;
    case CN_COLMAP_PINHOLE:
    case CN_COLMAP_OPENCV:
    case CN_COLMAP_OPENCV_FISHEYE:
        in->fx = p[0];
        in->fy = p[1];
        in->cx = p[2];
        in->cy = p[3];
        if (c->model == CN_COLMAP_OPENCV) {
            in->k[0] = p[4];
            in->k[1] = p[5];
            in->p[0] = p[6];
            in->p[1] = p[7];
        } else if (c->model == CN_COLMAP_OPENCV_FISHEYE) {
            in->model = CN_LENS_FISHEYE;
            for (int k = 0; k < 4; k++)
                in->k[k] = p[4 + k];
        }
        break;
    default:
        return -1;
    }
    return in->fx > 0 && in->fy > 0 && c->w > 0 && c->h > 0 ? 0 : -2;
}

/* Camera-to-world in NeRF's axes (x right, y up, z back) from COLMAP's world-to-camera
 * quaternion (w, x, y, z) and translation in OpenCV's axes (x right, y down, z forward). */
static void cn_colmap_c2w(const cn_colmap_image *im, double c2w[3][4])
{
    double q[4] = {im->q[0], im->q[1], im->q[2], im->q[3]};
    const double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++)
        q[i] /= n;
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                            {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                            {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    for (int i = 0; i < 3; i++) {
        /* column j of R^T is row j of R; y and z flip to NeRF's axes */
        c2w[i][0] = R[0][i];
        c2w[i][1] = -R[1][i];
        c2w[i][2] = -R[2][i];
        c2w[i][3] = -(R[0][i] * im->t[0] + R[1][i] * im->t[1] + R[2][i] * im->t[2]);
    }
}

static int cn_cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Every step-th sparse point is used for the depth bounds: at most about 200,000. */
static size_t cn_colmap_step(const cn_colmap *m)
{
    return m->n_points > 200000 ? m->n_points / 200000 : 1;
}

/* Depth bounds of the sparse points that camera k sees (in front, inside its image): the
 * 1st and 99th percentiles. 0 when fewer than 10 points are seen. dep holds one depth per
 * point used. */
static int cn_colmap_bounds(const cn_colmap *m, const cn_llff_cam *cam, double *dep,
                            double *bnear, double *bfar)
{
    size_t n = 0;
    const size_t step = cn_colmap_step(m);
    for (size_t i = 0; i < m->n_points; i += step) {
        const double *p = m->xyz + 3 * i;
        double v[3];
        for (int r = 0; r < 3; r++)
            v[r] = p[r] - cam->c2w[r][3];
        double c[3] = {0, 0, 0}; /* camera axes: right, up, back */
        for (int a = 0; a < 3; a++)
            for (int r = 0; r < 3; r++)
                c[a] += cam->c2w[r][a] * v[r];
        const double z = -c[2];
        if (!(z > 0))
            continue;
        const double u = cam->in.fx * c[0] / z + cam->in.cx, w = -cam->in.fy * c[1] / z + cam->in.cy;
        if (u < 0 || w < 0 || u > cam->in.ref_w || w > cam->in.ref_h)
            continue;
        dep[n++] = z;
    }
    if (n < 10)
        return 0;
    qsort(dep, n, sizeof *dep, cn_cmp_double);
    *bnear = dep[n / 100];
    *bfar = dep[n - 1 - n / 100];
    return 1;
}

/* An inward capture: up (the mean of the cameras' up axes) becomes +z, the point nearest to
 * every optical axis (least squares; the mean camera centre when the axes are close to
 * parallel) the origin, and the mean camera distance 4, as for Blender's scenes. */
static int cn_orient_inward(cn_llff_cam *cams, int n, const char *file, double *scale,
                            char *err, size_t errlen)
{
    double up[3] = {0, 0, 0}, A[3][3] = {{0}}, b[3] = {0, 0, 0}, mean[3] = {0, 0, 0};
    for (int k = 0; k < n; k++) {
        double d[3] = {-cams[k].c2w[0][2], -cams[k].c2w[1][2], -cams[k].c2w[2][2]};
        for (int i = 0; i < 3; i++) {
            up[i] += cams[k].c2w[i][1];
            mean[i] += cams[k].c2w[i][3] / n;
            for (int j = 0; j < 3; j++) {
                const double a = (i == j) - d[i] * d[j];
                A[i][j] += a;
                b[i] += a * cams[k].c2w[j][3];
            }
        }
    }
    if (cn_normalize3(up) < 1e-9)
        return cn_fail(err, errlen, "%s: the cameras' up directions cancel out", file);
    /* centre: solve A c = b by Cramer's rule when A is well conditioned */
    const double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                       A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                       A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
    const double tr = A[0][0] + A[1][1] + A[2][2];
    double c[3] = {mean[0], mean[1], mean[2]};
    if (det > 1e-3 * (tr / 3) * (tr / 3) * (tr / 3)) {
        for (int col = 0; col < 3; col++) {
            double M[3][3];
            memcpy(M, A, sizeof M);
            for (int r = 0; r < 3; r++)
                M[r][col] = b[r];
            c[col] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                      M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                      M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) /
                     det;
        }
    }
    /* rotation taking up to +z: x' = normalize(e x up) with e the axis least like up */
    double e[3] = {0, 0, 0}, x[3], y[3];
    const int least = fabs(up[0]) < fabs(up[1]) ? (fabs(up[0]) < fabs(up[2]) ? 0 : 2)
                                                : (fabs(up[1]) < fabs(up[2]) ? 1 : 2);
    e[least] = 1;
    cn_cross3(e, up, x);
    cn_normalize3(x);
    cn_cross3(up, x, y);
    const double *rows[3] = {x, y, up};
    double dist = 0;
    for (int k = 0; k < n; k++) {
        double t[3];
        for (int i = 0; i < 3; i++)
            t[i] = cams[k].c2w[i][3] - c[i];
        dist += sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) / n;
    }
    if (!(dist > 1e-12))
        return cn_fail(err, errlen, "%s: every camera is at the same place", file);
    *scale = 4.0 / dist;
    for (int k = 0; k < n; k++) {
        double mm[3][4];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 4; j++) {
                double s = 0;
                for (int l = 0; l < 3; l++)
                    s += rows[i][l] * (cams[k].c2w[l][j] - (j == 3 ? c[l] : 0.0));
                mm[i][j] = j == 3 ? s * *scale : s;
            }
        memcpy(cams[k].c2w, mm, sizeof mm);
    }
    return 0;
}

static int cn_cmp_image_name(const void *a, const void *b)
{
    return strcmp(((const cn_colmap_image *)a)->name, ((const cn_colmap_image *)b)->name);
}

static int cn_load_colmap(const char *dir, cn_dataset *ds, cn_frames *L, char *err,
                          size_t errlen)
{
    char sparse[CN_PATH_MAX], imgdir[CN_PATH_MAX], path[CN_PATH_MAX], name[32];
    if (!cn_colmap_dir(dir, sparse))
        return cn_fail(err, errlen, "%s: no COLMAP model", dir);
    cn_colmap m;
    if (cn_colmap_read(sparse, &m, err, errlen) != 0)
        return -1;
    char camfile[CN_PATH_MAX + 16]; /* the one cn_colmap_read took: .bin before .txt */
    snprintf(camfile, sizeof camfile, "%s/cameras.bin", sparse);
    if (!cn_is_file(camfile))
        snprintf(camfile, sizeof camfile, "%s/cameras.txt", sparse);
    int rc = 0;
    const int n = m.n_imgs;
    if (n == 0)
        rc = cn_fail(err, errlen, "%s: no registered images", sparse);
    /* images_F/ when it exists holds the images already reduced by F */
    snprintf(name, sizeof name, "images_%d", L->factor);
    if (rc == 0)
        rc = cn_join(imgdir, dir, L->factor > 1 ? name : "images", "", err, errlen);
    if (rc == 0 && L->factor > 1 && cn_is_dir(imgdir))
        L->factor = 1;
    else if (rc == 0)
        rc = cn_join(imgdir, dir, "images", "", err, errlen);
    if (rc == 0 && !cn_is_dir(imgdir))
        rc = cn_fail(err, errlen, "%s: no images/ directory beside the COLMAP model %s", dir,
                     sparse);
    cn_llff_cam *cams = rc == 0 ? calloc((size_t)n, sizeof *cams) : NULL;
    const size_t used = (m.n_points + cn_colmap_step(&m) - 1) / cn_colmap_step(&m);
    double *dep = rc == 0 ? malloc(sizeof(double) * (used + 1)) : NULL;
    if (rc == 0 && (!cams || !dep))
        rc = cn_fail(err, errlen, "%s: out of memory", sparse);
    if (rc == 0)
        qsort(m.imgs, (size_t)n, sizeof *m.imgs, cn_cmp_image_name);
    double fwd[3] = {0, 0, 0}, bmin = INFINITY, bmax = 0;
    int bounded = 0;
    for (int i = 0; rc == 0 && i < n; i++) {
        const cn_colmap_image *im = &m.imgs[i];
        const cn_colmap_camera *c = NULL;
        for (int k = 0; k < m.n_cams && !c; k++)
            c = m.cams[k].id == im->camera_id ? &m.cams[k] : NULL;
        const int r = cn_colmap_intr(c, &cams[i].in);
        if (r == 0) {
            snprintf(cams[i].in.src, sizeof cams[i].in.src, "%.480s, camera %u", camfile, c->id);
            cams[i].in.lens = cn_colmap_model_name(c->model);
            cams[i].in.colmap = 1;
        }
        if (r == -1)
            rc = cn_fail(err, errlen, "%s: image %s: camera %u is a %s camera, which cnerf does "
                         "not read (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, "
                         "OPENCV_FISHEYE)", sparse, im->name, c->id,
                         cn_colmap_model_name(c->model));
        else if (r == -2)
            rc = cn_fail(err, errlen, "%s: image %s: camera %u has a size or focal length that "
                         "is not positive", sparse, im->name, c->id);
        if (rc)
            break;
        cn_colmap_c2w(im, cams[i].c2w);
        char why[256];
        if (cn_pose_check((const double(*)[4])cams[i].c2w, why, sizeof why) != 0)
            rc = cn_fail(err, errlen, "%s: image %s: %s", sparse, im->name, why);
        for (int a = 0; a < 3; a++)
            fwd[a] -= cams[i].c2w[a][2] / n;
        if (cn_colmap_bounds(&m, &cams[i], dep, &cams[i].bnear, &cams[i].bfar)) {
            bounded++;
            bmin = fmin(bmin, cams[i].bnear);
            bmax = fmax(bmax, cams[i].bfar);
        }
    }
    const int forward = cn_normalize3(fwd) > CN_FORWARD;
    if (rc == 0 && forward) {
        /* LLFF's conventions, on bounds from the sparse points */
        if (!bounded)
            rc = cn_fail(err, errlen, "%s: a forward-facing capture needs the sparse points "
                         "(points3D) for its depth bounds, and none are seen", sparse);
        const double sc = rc == 0 ? 1.0 / (bmin * 0.75) : 1;
        for (int i = 0; rc == 0 && i < n; i++)
            for (int r = 0; r < 3; r++)
                cams[i].c2w[r][3] *= sc;
        ds->ndc = 1;
        ds->near = bmin * sc * 0.9;
        ds->far = bmax * sc;
        if (rc == 0)
            rc = cn_llff_recentre(cams, n, sparse, err, errlen);
    }
    double sc = 1;
    if (rc == 0 && !forward)
        rc = cn_orient_inward(cams, n, sparse, &sc, err, errlen);
    for (int i = 0; rc == 0 && i < n; i++) {
        rc = cn_join(path, imgdir, m.imgs[i].name, "", err, errlen);
        if (rc == 0 && !cn_is_file(path))
            rc = cn_fail(err, errlen, "%s: %s (listed as image %u in the COLMAP model %s)",
                         path, cn_not_file_why(path), m.imgs[i].id, sparse);
        if (rc == 0)
            rc = cn_frames_add(L, path, i % CN_LLFF_HOLD == 0 ? CN_TEST : CN_TRAIN,
                               (const double(*)[4])cams[i].c2w, &cams[i].in, err, errlen);
    }
    if (rc == 0 && !forward) {
        /* From the points; without them, 0.05 to twice the farthest camera's distance. */
        ds->near = bounded ? fmax(0.01, 0.9 * bmin * sc) : 0.05;
        ds->far = bounded ? 1.1 * bmax * sc : 2 * L->rmax;
    }
    free(dep);
    free(cams);
    cn_colmap_free(&m);
    return rc;
}

/* ---- the dataset ---- */

static int cn_detect(const char *dir, char *err, size_t errlen)
{
    static const struct {
        const char *file;
        int kind;
    } probes[] = {{"transforms_train.json", CN_DS_BLENDER},
                  {"transforms.json", CN_DS_NGP},
                  {"poses_bounds.npy", CN_DS_LLFF},
                  {"cameras.npz", CN_DS_DTU},
                  {"cameras_sphere.npz", CN_DS_DTU}};
    if (!cn_is_dir(dir)) {
        struct stat st;
        if (stat(dir, &st) != 0) /* missing, a symbolic link loop, no permission, ... */
            return cn_fail(err, errlen, "%s: %s", dir, strerror(errno));
        return cn_fail(err, errlen, "%s: not a directory", dir);
    }
    char path[CN_PATH_MAX];
    for (size_t i = 0; i < sizeof probes / sizeof probes[0]; i++) {
        if (cn_join(path, dir, probes[i].file, "", err, errlen) != 0)
            return -1;
        if (cn_is_file(path))
            return probes[i].kind;
    }
    if (cn_colmap_dir(dir, path))
        return CN_DS_COLMAP;
    return cn_fail(err, errlen,
                   "%s: unknown dataset layout: looked for transforms_train.json (Blender), "
                   "transforms.json (instant-ngp, nerfstudio), poses_bounds.npy (LLFF), "
                   "cameras.npz or cameras_sphere.npz (DTU as IDR, NeuS, VolSDF and MonoSDF "
                   "ship it) and a COLMAP model (sparse/0/, sparse/ or colmap/sparse/0/ with "
                   "cameras.bin or cameras.txt)",
                   dir);
}

/* Moves the loaded frames into the dataset's split arrays. */
static int cn_dataset_take(cn_dataset *ds, cn_frames *L, char *err, size_t errlen)
{
    cn_view **dst[3] = {&ds->train, &ds->val, &ds->test};
    int *cnt[3] = {&ds->n_train, &ds->n_val, &ds->n_test};
    int read[3] = {0, 0, 0};
    for (int i = 0; i < L->n; i++)
        read[L->f[i].split] += !L->f[i].unread;
    for (int s = 0; s < 3; s++)
        if (read[s] && !(*dst[s] = calloc((size_t)read[s], sizeof(cn_view))))
            return cn_fail(err, errlen, "out of memory");
    ds->n_test_listed = L->count[CN_TEST];
    for (int i = 0; i < L->n; i++) {
        cn_frame *fr = &L->f[i];
        if (fr->unread)
            continue;
        (*dst[fr->split])[(*cnt[fr->split])++] = fr->v;
        fr->v.rgb = NULL;
        fr->v.alpha = NULL;
    }
    ds->n_skipped = L->skipped;
    memcpy(ds->skipped, L->first_skipped, sizeof ds->skipped);
    return 0;
}

static int cn_apply_bounds(cn_dataset *ds, const cn_dataset_opts *o, const char *dir,
                           char *err, size_t errlen)
{
    if (o->near > 0)
        ds->near = o->near;
    if (o->far > 0)
        ds->far = o->far;
    if (!(isfinite(ds->near) && isfinite(ds->far) && ds->near >= 0 && ds->near < ds->far))
        return cn_fail(err, errlen, "%s: invalid ray bounds near %g, far %g (need near < far)",
                       dir, ds->near, ds->far);
    return 0;
}

/* The layout's cameras and image paths into L (no pixels yet), on an emptied *ds. */
static int cn_load_layout(const char *dir, int kind, const cn_dataset_opts *o, cn_dataset *ds,
                          cn_frames *L, char *err, size_t errlen)
{
    memset(ds, 0, sizeof *ds);
    ds->kind = kind;
    for (int k = 0; k < 3; k++)
        ds->bg[k] = o->black_bg ? 0.0f : 1.0f;
    return kind == CN_DS_BLENDER ? cn_load_blender(dir, ds, L, err, errlen)
           : kind == CN_DS_NGP   ? cn_load_ngp(dir, ds, L, err, errlen)
           : kind == CN_DS_LLFF  ? cn_load_llff(dir, ds, L, err, errlen)
           : kind == CN_DS_DTU   ? cn_load_dtu(dir, ds, L, err, errlen)
                                 : cn_load_colmap(dir, ds, L, err, errlen);
}

int cn_dataset_load(const char *dir, const cn_dataset_opts *o, cn_dataset *ds, char *err,
                    size_t errlen)
{
    static const cn_dataset_opts defaults = {0};
    memset(ds, 0, sizeof *ds);
    if (!o)
        o = &defaults;
    int f = o->downscale ? o->downscale : 1;
    if (f < 1)
        return cn_fail(err, errlen, "downscale %d: must be an integer >= 1", o->downscale);
    if (o->max_views < 0)
        return cn_fail(err, errlen, "max_views %d: must be >= 0", o->max_views);
    if (o->test_every < 0)
        return cn_fail(err, errlen, "test_every %d: must be >= 0", o->test_every);
    if (o->max_size < 0 || (o->max_size > 0 && f > 1))
        return cn_fail(err, errlen, "max size %d: must be >= 1, and not given with a downscale",
                       o->max_size);
    int kind = cn_detect(dir, err, errlen);
    if (kind < 0)
        return -1;
    const cn_frames L0 = {.max_views = o->max_views, .test_every = o->test_every,
                          .test_only = o->test_only != 0};
    cn_frames L = L0;
    L.factor = f;
    int rc = cn_load_layout(dir, kind, o, ds, &L, err, errlen);
    if (rc == 0 && o->max_size > 0 && L.n > 0) {
        /* The factor from the first image's upright size; then the frames again at it (an
         * LLFF scene may hold images already reduced by it). */
        int w, h;
        rc = cn_image_size(L.f[0].path, cn_ref_aspect(&L.f[0].in), &w, &h, err, errlen);
        const int big = w > h ? w : h;
        f = (big + o->max_size - 1) / o->max_size;
        if (rc == 0) {
            cn_frames_free(&L);
            L = L0;
            L.factor = f;
            rc = cn_load_layout(dir, kind, o, ds, &L, err, errlen);
        }
    }
    ds->downscale = f;
    if (rc == 0 && L.count[CN_TRAIN] == 0 && L.skipped > 0 && L.n == 0)
        rc = cn_fail(err, errlen, "%s: no training views: the images of all %d frames are "
                     "missing (the first: %s)", dir, L.skipped, L.first_skipped);
    else if (rc == 0 && L.count[CN_TRAIN] == 0)
        rc = cn_fail(err, errlen, "%s: no training views (no usable training frames)", dir);
    if (rc == 0)
        rc = cn_apply_bounds(ds, o, dir, err, errlen);
    if (rc == 0)
        rc = cn_frames_load_images(&L, ds->bg, err, errlen);
    if (rc == 0)
        rc = cn_dataset_take(ds, &L, err, errlen);
    cn_frames_free(&L);
    if (rc != 0)
        cn_dataset_free(ds);
    else
        snprintf(ds->dir, sizeof ds->dir, "%s", dir);
    return rc;
}

static void cn_views_free(cn_view *v, int n)
{
    for (int i = 0; v && i < n; i++) {
        free(v[i].rgb);
        free(v[i].alpha);
    }
    free(v);
}

void cn_dataset_free(cn_dataset *ds)
{
    cn_views_free(ds->train, ds->n_train);
    cn_views_free(ds->val, ds->n_val);
    cn_views_free(ds->test, ds->n_test);
    memset(ds, 0, sizeof *ds);
}

/* ---- the metadata parsers on bytes (fuzzing, tests) ---- */

/* A frame of the given camera on an image file of w x h (no pixels) through cn_camera_check. */
static int cn_camera_check_size(const cn_intr *in, int w, int h, char *err, size_t errlen)
{
    cn_frame fr = {.path = "(image)", .in = *in, .file_w = w, .file_h = h, .factor = 1};
    fr.v.w = w;
    fr.v.h = h;
    cn_intr_resolve(&fr.in, w, h, 0, 0, 1, &fr.v);
    return cn_camera_check(&fr, err, errlen);
}

int cn_colmap_check_camera(const cn_colmap_camera *c, char *err, size_t errlen)
{
    cn_intr in;
    const int r = cn_colmap_intr(c, &in);
    if (r == -1)
        return cn_fail(err, errlen, "camera %u: a %s camera, which cnerf does not read", c->id,
                       cn_colmap_model_name(c->model));
    if (r == -2 || c->w > CN_IMAGE_MAX_PIXELS || c->h > CN_IMAGE_MAX_PIXELS)
        return cn_fail(err, errlen, "camera %u: a size or focal length out of range", c->id);
    snprintf(in.src, sizeof in.src, "camera %u", c->id);
    in.lens = cn_colmap_model_name(c->model);
    return cn_camera_check_size(&in, (int)c->w, (int)c->h, err, errlen);
}

int cn_dataset_parse_meta(int kind, const uint8_t *data, size_t len, char *err, size_t errlen)
{
    return cn_dataset_check_cameras(kind, data, len, 0, 0, err, errlen);
}

int cn_dataset_check_cameras(int kind, const uint8_t *data, size_t len, int img_w, int img_h,
                             char *err, size_t errlen)
{
    static const char *names[4] = {"transforms_train.json", "transforms.json",
                                   "poses_bounds.npy", "cameras.npz"};
    if (kind < 0 || kind > 3)
        return cn_fail(err, errlen, "unknown metadata kind %d", kind);
    const char *file = names[kind];
    if (kind == 3) {
        cn_dtu_cam *cams;
        int n;
        const int rc = cn_dtu_parse(file, data, len, &cams, &n, err, errlen);
        free(cams);
        return rc;
    }
    if (kind == 2) {
        cn_llff_cam *cams;
        int n = 0;
        cn_dataset ds;
        memset(&ds, 0, sizeof ds);
        const int rc = cn_llff_cameras_mem(file, data, len, &cams, &n, &ds, err, errlen);
        free(cams);
        return rc;
    }
    cJSON *root;
    if (cn_json_parse(file, data, len, &root, err, errlen) != 0)
        return -1;
    cn_jloc l = {file, -1};
    cn_intr in = cn_intr_none;
    double aabb;
    int rc = kind == 0 ? cn_json_angle(root, "camera_angle_x", 1, &l, &in.angle_x, err, errlen)
                       : cn_ngp_intrinsics(root, &l, &in, &aabb, err, errlen);
    const cJSON *frames = NULL;
    if (rc == 0)
        rc = cn_json_frames(root, file, &frames, err, errlen);
    const cJSON *fr;
    int i = 0;
    if (rc == 0)
        cJSON_ArrayForEach(fr, frames)
        {
            cn_jloc lf = {file, i++};
            const char *file_path = NULL;
            double c2w[3][4];
            const cn_frame_rule rule = {0, 0, kind == 1};
            cn_intr fin;
            if ((rc = cn_json_frame(fr, &lf, &file_path, c2w, err, errlen)) != 0 ||
                (rc = cn_frame_intr(fr, &lf, &rule, &in, &fin, err, errlen)) != 0)
                break;
            if (img_w > 0 && img_h > 0 &&
                (rc = cn_camera_check_size(&fin, img_w, img_h, err, errlen)) != 0)
                break;
        }
    cJSON_Delete(root);
    return rc;
}
