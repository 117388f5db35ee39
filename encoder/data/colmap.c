/* COLMAP sparse models in text and binary form (cn_colmap.h). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_colmap.h"
#include "cn_buf.h"
#include "cn_file.h"
#include "cn_loader.h"
#include "cn_reader.h"

static const struct {
    const char *name;
    int n;
    const char *params; /* their names, blank-separated */
} cn_models[CN_COLMAP_N_MODELS] = {
    {"SIMPLE_PINHOLE", 3, "f cx cy"},
    {"PINHOLE", 4, "fx fy cx cy"},
    {"SIMPLE_RADIAL", 4, "f cx cy k"},
    {"RADIAL", 5, "f cx cy k1 k2"},
    {"OPENCV", 8, "fx fy cx cy k1 k2 p1 p2"},
    {"OPENCV_FISHEYE", 8, "fx fy cx cy k1 k2 k3 k4"},
    {"FULL_OPENCV", 12, "fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6"},
    {"FOV", 5, "fx fy cx cy omega"},
    {"SIMPLE_RADIAL_FISHEYE", 4, "f cx cy k"},
    {"RADIAL_FISHEYE", 5, "f cx cy k1 k2"},
    {"THIN_PRISM_FISHEYE", 12, "fx fy cx cy k1 k2 p1 p2 k3 k4 sx1 sy1"}};

/* The name of parameter k of a model, into buf. */
static const char *param_name(int model, int k, char *buf, size_t n)
{
    const char *p = cn_models[model].params;
    for (int i = 0; i < k && p; i++) {
        p = strchr(p, ' ');
        p = p ? p + 1 : NULL;
    }
    const char *e = p ? strchr(p, ' ') : NULL;
    snprintf(buf, n, "%.*s", p ? (int)(e ? (size_t)(e - p) : strlen(p)) : 1, p ? p : "?");
    return buf;
}

const char *cn_colmap_model_name(int model)
{
    return model >= 0 && model < CN_COLMAP_N_MODELS ? cn_models[model].name : NULL;
}

int cn_colmap_model_params(int model)
{
    return model >= 0 && model < CN_COLMAP_N_MODELS ? cn_models[model].n : 0;
}

void cn_colmap_free(cn_colmap *m)
{
    free(m->cams);
    free(m->imgs);
    free(m->xyz);
    memset(m, 0, sizeof *m);
}

/* Room for one more element in a growing array. */
static int grow(void **p, int *cap, int n, size_t elem)
{
    if (n < *cap)
        return 0;
    const int c = *cap > n ? 2 * *cap : n + 16;
    void *q = realloc(*p, elem * (size_t)c);
    if (!q)
        return -1;
    *p = q;
    *cap = c;
    return 0;
}

static int add_camera(cn_colmap *m, int *cap, const cn_colmap_camera *c, const char *file,
                      char *err, size_t errlen)
{
    for (int i = 0; i < m->n_cams; i++)
        if (m->cams[i].id == c->id)
            return cn_fail(err, errlen, "%s: camera %u is listed twice", file, c->id);
    if (grow((void **)&m->cams, cap, m->n_cams, sizeof *c))
        return cn_fail(err, errlen, "%s: out of memory", file);
    m->cams[m->n_cams++] = *c;
    return 0;
}

/* ---- binary ---- */

typedef struct cn_cur {
    const uint8_t *p;
    size_t n, pos;
} cn_cur;

static int take(cn_cur *c, size_t k, const uint8_t **out)
{
    if (k > c->n - c->pos)
        return -1;
    *out = c->p + c->pos;
    c->pos += k;
    return 0;
}

static int rd_u64(cn_cur *c, uint64_t *v)
{
    const uint8_t *b;
    if (take(c, 8, &b))
        return -1;
    *v = cn_le64(b);
    return 0;
}

static int rd_u32(cn_cur *c, uint32_t *v)
{
    const uint8_t *b;
    if (take(c, 4, &b))
        return -1;
    *v = cn_le32(b);
    return 0;
}

static int rd_f64(cn_cur *c, double *v)
{
    const uint8_t *b;
    if (take(c, 8, &b))
        return -1;
    *v = cn_get_f64(b);
    return isfinite(*v) ? 0 : -2;
}

static int rd_count(cn_cur *c, size_t least, uint64_t max, uint64_t *n)
{
    if (rd_u64(c, n))
        return -1;
    return *n > max || *n > (c->n - c->pos) / least ? -1 : 0;
}

static int bin_cameras(const char *file, cn_cur *c, cn_colmap *m, char *err, size_t errlen)
{
    uint64_t n;
    if (rd_count(c, 24, 1u << 20, &n))
        return cn_fail(err, errlen, "%s: truncated or implausible camera count", file);
    int cap = 0;
    for (uint64_t i = 0; i < n; i++) {
        cn_colmap_camera cam;
        memset(&cam, 0, sizeof cam);
        uint32_t model;
        if (rd_u32(c, &cam.id) || rd_u32(c, &model) || rd_u64(c, &cam.w) || rd_u64(c, &cam.h))
            return cn_fail(err, errlen, "%s: camera %llu: truncated", file, (unsigned long long)i);
        if (model >= CN_COLMAP_N_MODELS)
            return cn_fail(err, errlen, "%s: camera %u: unknown camera model id %u", file, cam.id,
                        model);
        cam.model = (int)model;
        for (int k = 0; k < cn_models[model].n; k++) {
            const int r = rd_f64(c, &cam.params[k]);
            if (r)
                return cn_fail(err, errlen, "%s: camera %u: %s", file, cam.id,
                            r == -2 ? "a parameter is not a finite number" : "truncated");
        }
        if (add_camera(m, &cap, &cam, file, err, errlen))
            return -1;
    }
    return 0;
}

static int bin_images(const char *file, cn_cur *c, cn_colmap *m, char *err, size_t errlen)
{
    uint64_t n;
    if (rd_count(c, 73, 1u << 20, &n))
        return cn_fail(err, errlen, "%s: truncated or implausible image count", file);
    int cap = 0;
    for (uint64_t i = 0; i < n; i++) {
        cn_colmap_image im;
        memset(&im, 0, sizeof im);
        int r = rd_u32(c, &im.id);
        for (int k = 0; k < 4 && !r; k++)
            r = rd_f64(c, &im.q[k]);
        for (int k = 0; k < 3 && !r; k++)
            r = rd_f64(c, &im.t[k]);
        if (!r)
            r = rd_u32(c, &im.camera_id);
        if (r)
            return cn_fail(err, errlen, "%s: image %llu: %s", file, (unsigned long long)i,
                        r == -2 ? "a pose value is not a finite number" : "truncated");
        if (im.q[0] == 0 && im.q[1] == 0 && im.q[2] == 0 && im.q[3] == 0)
            return cn_fail(err, errlen, "%s: image %u: the rotation quaternion QW QX QY QZ is "
                           "zero", file, im.id);
        size_t k = 0;
        const uint8_t *ch;
        for (;;) {
            if (take(c, 1, &ch))
                return cn_fail(err, errlen, "%s: image %u: truncated name", file, im.id);
            if (!*ch)
                break;
            if (k + 1 >= sizeof im.name)
                return cn_fail(err, errlen, "%s: image %u: name longer than %d bytes", file, im.id,
                            CN_COLMAP_NAME - 1);
            im.name[k++] = (char)*ch;
        }
        uint64_t n2d;
        const uint8_t *skip;
        if (rd_u64(c, &n2d) || n2d > (c->n - c->pos) / 24 || take(c, (size_t)n2d * 24, &skip))
            return cn_fail(err, errlen, "%s: image %u (%s): truncated 2D points", file, im.id,
                        im.name);
        if (grow((void **)&m->imgs, &cap, m->n_imgs, sizeof im))
            return cn_fail(err, errlen, "%s: out of memory", file);
        m->imgs[m->n_imgs++] = im;
    }
    return 0;
}

static int bin_points(const char *file, cn_cur *c, cn_colmap *m, char *err, size_t errlen)
{
    uint64_t n;
    if (rd_count(c, 43, (uint64_t)1 << 28, &n))
        return cn_fail(err, errlen, "%s: truncated or implausible point count", file);
    m->xyz = malloc(sizeof(double) * 3 * (n ? (size_t)n : 1));
    if (!m->xyz)
        return cn_fail(err, errlen, "%s: out of memory", file);
    for (uint64_t i = 0; i < n; i++) {
        uint64_t id, track;
        const uint8_t *skip;
        int r = rd_u64(c, &id);
        for (int k = 0; k < 3 && !r; k++)
            r = rd_f64(c, &m->xyz[3 * i + (size_t)k]);
        if (!r)
            r = take(c, 3, &skip);
        if (!r)
            r = rd_f64(c, &(double){0});
        if (!r)
            r = rd_u64(c, &track) || track > (c->n - c->pos) / 8 ||
                take(c, (size_t)track * 8, &skip);
        if (r)
            return cn_fail(err, errlen, "%s: point %llu: %s", file, (unsigned long long)i,
                        r == -2 ? "not a finite number" : "truncated");
        m->n_points++;
    }
    return 0;
}

/* ---- text ---- */

/* The next line (without its end) from *pos; 0 at the end of the data. */
static int next_line(const uint8_t *data, size_t len, size_t *pos, char *line, size_t cap,
                     int *too_long)
{
    if (*pos >= len)
        return 0;
    size_t k = 0;
    *too_long = 0;
    while (*pos < len && data[*pos] != '\n') {
        if (k + 1 < cap)
            line[k++] = (char)data[*pos];
        else
            *too_long = 1;
        (*pos)++;
    }
    if (*pos < len)
        (*pos)++;
    if (k && line[k - 1] == '\r')
        k--;
    line[k] = '\0';
    return 1;
}

/* Splits off the next blank-separated word of *s. */
static char *word(char **s)
{
    char *p = *s;
    while (*p == ' ' || *p == '\t')
        p++;
    if (!*p)
        return NULL;
    char *w = p;
    while (*p && *p != ' ' && *p != '\t')
        p++;
    if (*p)
        *p++ = '\0';
    *s = p;
    return w;
}

/* The next word as a number: 0, -1 (no word, or not a number), or -2 with *w the word when it
 * reads as a number that is not finite (nan, inf, 1e999). */
static int num_w(char **s, double *v, const char **wp)
{
    char *w = word(s), *end;
    if (wp)
        *wp = w;
    if (!w)
        return -1;
    errno = 0;
    *v = strtod(w, &end);
    if (*end)
        return -1;
    if (!isfinite(*v))
        return -2;
    return errno ? -1 : 0;
}

static int num(char **s, double *v)
{
    return num_w(s, v, NULL) ? -1 : 0;
}

static int uint_word(char **s, uint64_t max, uint64_t *v)
{
    char *w = word(s), *end;
    if (!w || *w == '-' || *w == '+')
        return -1;
    errno = 0;
    const unsigned long long x = strtoull(w, &end, 10);
    if (*end || errno || x > max)
        return -1;
    *v = x;
    return 0;
}

enum { TXT_CAMERAS, TXT_IMAGES, TXT_POINTS };

static int txt_parse(const char *file, int kind, const uint8_t *data, size_t len, cn_colmap *m,
                     char *err, size_t errlen)
{
    char line[8192];
    size_t pos = 0;
    int lineno = 0, cap = 0, too_long, expect_points2d = 0;
    size_t pcap = 0;
    while (next_line(data, len, &pos, line, sizeof line, &too_long)) {
        lineno++;
        if (too_long && kind != TXT_IMAGES)
            return cn_fail(err, errlen, "%s:%d: line longer than %zu bytes", file, lineno,
                        sizeof line - 1);
        if (line[0] == '#')
            continue;
        if (kind == TXT_IMAGES && expect_points2d) { /* the image's 2D points: not used */
            expect_points2d = 0;
            continue;
        }
        if (too_long)
            return cn_fail(err, errlen, "%s:%d: line longer than %zu bytes", file, lineno,
                        sizeof line - 1);
        char *s = line;
        char *probe = s;
        while (*probe == ' ' || *probe == '\t')
            probe++;
        if (!*probe)
            continue; /* blank line */
        uint64_t id;
        if (uint_word(&s, kind == TXT_POINTS ? UINT64_MAX : UINT32_MAX, &id))
            return cn_fail(err, errlen, "%s:%d: expected an id", file, lineno);
        if (kind == TXT_CAMERAS) {
            cn_colmap_camera cam;
            memset(&cam, 0, sizeof cam);
            cam.id = (uint32_t)id;
            const char *model = word(&s);
            cam.model = -1;
            for (int i = 0; model && i < CN_COLMAP_N_MODELS; i++)
                if (!strcmp(model, cn_models[i].name))
                    cam.model = i;
            if (cam.model < 0)
                return cn_fail(err, errlen, "%s:%d: camera %u: unknown camera model '%s'", file,
                            lineno, cam.id, model ? model : "");
            if (uint_word(&s, UINT32_MAX, &cam.w) || uint_word(&s, UINT32_MAX, &cam.h))
                return cn_fail(err, errlen, "%s:%d: camera %u: expected its width and height",
                            file, lineno, cam.id);
            for (int k = 0; k < cn_models[cam.model].n; k++) {
                const char *w;
                char pn[16];
                const int r = num_w(&s, &cam.params[k], &w);
                if (r == -2)
                    return cn_fail(err, errlen, "%s:%d: camera %u: %s parameter %d (%s) is '%s', "
                                   "not a finite number", file, lineno, cam.id, model, k + 1,
                                   param_name(cam.model, k, pn, sizeof pn), w);
                if (r)
                    return cn_fail(err, errlen, "%s:%d: camera %u: %s takes %d parameters (%s)%s%s%s",
                                   file, lineno, cam.id, model, cn_models[cam.model].n,
                                   cn_models[cam.model].params, w ? ": '" : "", w ? w : "",
                                   w ? "' is not a number" : "");
            }
            if (word(&s))
                return cn_fail(err, errlen, "%s:%d: camera %u: %s takes %d parameters", file,
                            lineno, cam.id, model, cn_models[cam.model].n);
            if (add_camera(m, &cap, &cam, file, err, errlen))
                return -1;
        } else if (kind == TXT_IMAGES) {
            cn_colmap_image im;
            memset(&im, 0, sizeof im);
            im.id = (uint32_t)id;
            uint64_t cam;
            int r = 0;
            static const char *field[7] = {"QW", "QX", "QY", "QZ", "TX", "TY", "TZ"};
            for (int k = 0; k < 7 && !r; k++) {
                const char *w;
                r = num_w(&s, k < 4 ? &im.q[k] : &im.t[k - 4], &w);
                if (r == -2)
                    return cn_fail(err, errlen, "%s:%d: image %u: %s is '%s', not a finite "
                                   "number", file, lineno, im.id, field[k], w);
            }
            if (r || uint_word(&s, UINT32_MAX, &cam))
                return cn_fail(err, errlen, "%s:%d: image %u: expected QW QX QY QZ TX TY TZ "
                            "CAMERA_ID NAME", file, lineno, im.id);
            if (im.q[0] == 0 && im.q[1] == 0 && im.q[2] == 0 && im.q[3] == 0)
                return cn_fail(err, errlen, "%s:%d: image %u: the rotation quaternion QW QX QY "
                               "QZ is zero", file, lineno, im.id);
            im.line = lineno;
            im.camera_id = (uint32_t)cam;
            while (*s == ' ' || *s == '\t')
                s++;
            size_t n = strlen(s);
            while (n && (s[n - 1] == ' ' || s[n - 1] == '\t'))
                s[--n] = '\0';
            if (!n || n >= sizeof im.name)
                return cn_fail(err, errlen, "%s:%d: image %u: %s", file, lineno, im.id,
                            n ? "name too long" : "no name");
            memcpy(im.name, s, n + 1);
            if (grow((void **)&m->imgs, &cap, m->n_imgs, sizeof im))
                return cn_fail(err, errlen, "%s: out of memory", file);
            m->imgs[m->n_imgs++] = im;
            expect_points2d = 1;
        } else {
            if (m->n_points == pcap) {
                pcap = pcap ? 2 * pcap : 1024;
                double *p = realloc(m->xyz, sizeof(double) * 3 * pcap);
                if (!p)
                    return cn_fail(err, errlen, "%s: out of memory", file);
                m->xyz = p;
            }
            for (int k = 0; k < 3; k++)
                if (num(&s, &m->xyz[3 * m->n_points + (size_t)k]))
                    return cn_fail(err, errlen, "%s:%d: point %llu: expected X Y Z", file, lineno,
                                (unsigned long long)id);
            m->n_points++;
        }
    }
    return 0;
}

static int ends_with(const char *s, const char *e)
{
    const size_t n = strlen(s), k = strlen(e);
    return n >= k && !strcmp(s + n - k, e);
}

static int by_id(const void *a, const void *b)
{
    const cn_colmap_image *x = *(const cn_colmap_image *const *)a;
    const cn_colmap_image *y = *(const cn_colmap_image *const *)b;
    return x->id != y->id ? (x->id > y->id ? 1 : -1) : x < y ? -1 : x > y;
}
static int by_name(const void *a, const void *b)
{
    const cn_colmap_image *x = *(const cn_colmap_image *const *)a;
    const cn_colmap_image *y = *(const cn_colmap_image *const *)b;
    const int c = strcmp(x->name, y->name);
    return c ? c : x < y ? -1 : x > y;
}

/* Every image's id and name once: a model with two poses for one photo is not a capture. */
static int check_unique(const char *file, const cn_colmap *m, char *err, size_t errlen)
{
    if (m->n_imgs < 2)
        return 0;
    const cn_colmap_image **ix = malloc(sizeof *ix * (size_t)m->n_imgs);
    if (!ix)
        return cn_fail(err, errlen, "%s: out of memory", file);
    for (int i = 0; i < m->n_imgs; i++)
        ix[i] = &m->imgs[i];
    int rc = 0;
    qsort(ix, (size_t)m->n_imgs, sizeof *ix, by_id);
    for (int i = 1; i < m->n_imgs && !rc; i++) {
        const cn_colmap_image *b = ix[i];
        if (ix[i - 1]->id != b->id)
            continue;
        if (b->line)
            rc = cn_fail(err, errlen, "%s:%d: image %u: the id is used twice", file, b->line,
                         b->id);
        else
            rc = cn_fail(err, errlen, "%s: image %u: the id is used twice", file, b->id);
    }
    qsort(ix, (size_t)m->n_imgs, sizeof *ix, by_name);
    for (int i = 1; i < m->n_imgs && !rc; i++)
        if (!strcmp(ix[i - 1]->name, ix[i]->name))
            rc = cn_fail(err, errlen, "%s: images %u and %u are both named %s", file,
                         ix[i - 1]->id, ix[i]->id, ix[i]->name);
    free(ix);
    return rc;
}

int cn_colmap_parse(const char *file, const uint8_t *data, size_t len, cn_colmap *m, char *err,
                    size_t errlen)
{
    const char *base = strrchr(file, '/');
    base = base ? base + 1 : file;
    const int kind = !strncmp(base, "cameras", 7) ? TXT_CAMERAS
                     : !strncmp(base, "images", 6) ? TXT_IMAGES
                     : !strncmp(base, "points3D", 8) ? TXT_POINTS
                                                     : -1;
    if (kind < 0)
        return cn_fail(err, errlen, "%s: not a COLMAP cameras, images or points3D file", file);
    int rc;
    if (ends_with(base, ".txt")) {
        rc = txt_parse(file, kind, data, len, m, err, errlen);
    } else {
        cn_cur c = {data, len, 0};
        rc = kind == TXT_CAMERAS  ? bin_cameras(file, &c, m, err, errlen)
             : kind == TXT_IMAGES ? bin_images(file, &c, m, err, errlen)
                                  : bin_points(file, &c, m, err, errlen);
        if (rc == 0 && c.pos != c.n)
            return cn_fail(err, errlen, "%s: %zu bytes after the last entry", file, c.n - c.pos);
    }
    if (rc == 0 && kind == TXT_IMAGES)
        rc = check_unique(file, m, err, errlen);
    return rc;
}

static int read_one(const char *dir, const char *stem, int optional, cn_colmap *m, char *err,
                    size_t errlen)
{
    char path[4096];
    const char *ext[2] = {".bin", ".txt"};
    for (int i = 0; i < 2; i++) {
        snprintf(path, sizeof path, "%s/%s%s", dir, stem, ext[i]);
        FILE *f = fopen(path, "rb");
        if (!f)
            continue;
        fclose(f);
        uint8_t *data;
        size_t len;
        if (cn_read_file(path, &data, &len, err, errlen))
            return -1;
        if (cn_input_add(path, "a camera file of the dataset")) {
            free(data);
            return cn_fail(err, errlen, "%s: out of memory", path);
        }
        const int rc = cn_colmap_parse(path, data, len, m, err, errlen);
        free(data);
        return rc;
    }
    if (optional)
        return 0;
    return cn_fail(err, errlen, "%s: no %s.bin or %s.txt", dir, stem, stem);
}

int cn_colmap_read(const char *dir, cn_colmap *m, char *err, size_t errlen)
{
    memset(m, 0, sizeof *m);
    int rc = read_one(dir, "cameras", 0, m, err, errlen);
    if (rc == 0)
        rc = read_one(dir, "images", 0, m, err, errlen);
    if (rc == 0)
        rc = read_one(dir, "points3D", 1, m, err, errlen);
    for (int i = 0; rc == 0 && i < m->n_imgs; i++) {
        int found = 0;
        for (int k = 0; k < m->n_cams && !found; k++)
            found = m->cams[k].id == m->imgs[i].camera_id;
        if (!found)
            rc = cn_fail(err, errlen, "%s/images: image %u (%s) names camera %u, which is not in "
                      "cameras", dir, m->imgs[i].id, m->imgs[i].name, m->imgs[i].camera_id);
    }
    if (rc)
        cn_colmap_free(m);
    return rc;
}
