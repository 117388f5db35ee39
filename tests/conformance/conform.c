/*
 * The conformance runner: checks a build of the decoder against vectors/ (docs/conformance.md).
 *
 *   conform check VECTORS_DIR
 *       valid/NAME.cnrf: every tile of NAME.md5 must have its MD5 (bit-exact decoders), and
 *       every camera's whole image must reach NAME.txt's `min_psnr` against the encoder's
 *       float reference render NAME.<camera>.ref.png; invalid/expected.txt: each broken
 *       stream must get exactly its status from cnerf_peek and cnerf_open (of scene N
 *       where its line says scene=N).
 *       A stream of several scenes checks scene 0 with NAME.cam, NAME.md5 and
 *       NAME.<camera>.ref.png, and each other scene m that has a NAME.s<m>.cam with
 *       NAME.s<m>.cam, NAME.s<m>.md5 and NAME.s<m>.<camera>.ref.png.
 *       A decoder of one level (built with CNERF_MAX_LEVEL=L) checks the valid vectors
 *       whose NAME.txt declares a level of at most L; every other valid vector, and every
 *       broken stream that cnerf_peek accepts, it must refuse with CNERF_E_LEVEL from both
 *       cnerf_peek and cnerf_open.
 *       packed/expected.txt: a valid vector's packed images and broken ones (check_packed).
 *       Prints one line per check and closes with "N passed, M failed".
 *   conform tiles STREAM CAMERAS TILE NC NF TSTOP [SCENE]
 *       prints NAME.md5 lines for every camera of CAMERAS tiled TILE x TILE (the edge tiles
 *       smaller), with the given knobs, of scene SCENE (0) (vectors/regenerate.sh writes the
 *       MD5 files with it).
 *
 * Tile MD5s hash the tile's visible pixels only, row by row, RGB888 (w * 3 bytes a row).
 */
#include <errno.h>
#include <stdarg.h>
#include <math.h>
#include <md5.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_image.h"
#include "cnerf/cnerf.h"

#define MAX_CAMS 16

typedef struct camera {
    cnerf_camera c;
    char name[64];
} camera;

/* A stream opened into heap memory (the runner is hosted; the decoder never allocates). */
typedef struct opened {
    uint8_t *buf;
    cnerf_decoder *dec;
    void *ws, *scratch;
    size_t scratch_n;
} opened;

static int read_file(const char *path, uint8_t **buf, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    size_t cap = 1 << 16, n = 0;
    uint8_t *p = malloc(cap);
    for (;;) {
        if (!p) {
            fclose(f);
            return -1;
        }
        n += fread(p + n, 1, cap - n, f);
        if (n < cap)
            break;
        cap *= 2;
        uint8_t *q = realloc(p, cap);
        if (!q)
            free(p);
        p = q;
    }
    const int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(p);
        return -1;
    }
    *buf = p;
    *len = n;
    return 0;
}

static void close_stream(opened *o)
{
    free(o->buf), free(o->dec), free(o->ws), free(o->scratch);
    memset(o, 0, sizeof *o);
}

static cnerf_status open_stream(const char *path, unsigned scene, opened *o)
{
    memset(o, 0, sizeof *o);
    size_t len;
    if (read_file(path, &o->buf, &len)) {
        fprintf(stderr, "conform: %s: %s\n", path, strerror(errno));
        return CNERF_E_NULL;
    }
    o->dec = calloc(1, sizeof *o->dec);
    if (!o->dec)
        return CNERF_E_NULL;
    cnerf_status st = cnerf_peek_scene(o->buf, len, scene, &o->dec->info);
    if (st != CNERF_OK)
        return st;
    const size_t ws_n = cnerf_workspace_size(&o->dec->info);
    o->scratch_n = cnerf_render_scratch_size(&o->dec->info);
    o->ws = aligned_alloc(CNERF_WS_ALIGN, (ws_n + 7) & ~(size_t)7);
    o->scratch = aligned_alloc(CNERF_WS_ALIGN, (o->scratch_n + 7) & ~(size_t)7);
    if (!o->ws || !o->scratch)
        return CNERF_E_NULL;
    return cnerf_open_scene(o->dec, o->buf, len, scene, o->ws, ws_n);
}

/* Cameras: one per line, 18 integers and a name (cnerf render --save-cameras). */
static int read_cameras(const char *path, camera *cams, int *n)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "conform: %s: %s\n", path, strerror(errno));
        return -1;
    }
    char line[1024];
    *n = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#' || line[0] == '\n')
            continue;
        long long v[18];
        char name[64];
        if (*n == MAX_CAMS ||
            sscanf(line,
                   "%lld %lld %lld %lld %lld %lld %lld %lld %lld %lld %lld %lld %lld %lld %lld "
                   "%lld %lld %lld %63s",
                   &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6], &v[7], &v[8], &v[9], &v[10],
                   &v[11], &v[12], &v[13], &v[14], &v[15], &v[16], &v[17], name) != 19) {
            fprintf(stderr, "conform: %s: camera %d: want 18 integers and a name\n", path,
                    *n + 1);
            fclose(f);
            return -1;
        }
        camera *c = &cams[(*n)++];
        for (int i = 0; i < 9; i++)
            c->c.rot[i] = (int32_t)v[i];
        for (int i = 0; i < 3; i++)
            c->c.pos[i] = (int64_t)v[9 + i];
        c->c.fx = (int32_t)v[12], c->c.fy = (int32_t)v[13];
        c->c.cx = (int32_t)v[14], c->c.cy = (int32_t)v[15];
        c->c.width = (uint16_t)v[16], c->c.height = (uint16_t)v[17];
        snprintf(c->name, sizeof c->name, "%s", name);
    }
    fclose(f);
    return 0;
}

static cnerf_status render(const opened *o, const cnerf_camera *cam, const cnerf_render_opts *k,
                           uint32_t x0, uint32_t y0, uint32_t w, uint32_t h, uint8_t *px,
                           size_t stride)
{
    return cnerf_render_tile(o->dec, cam, k, x0, y0, w, h, px, stride, o->scratch, o->scratch_n);
}

/* The MD5 of a tile's rows, row_bytes of each (w * 3 in RGB888, w * 2 in RGB565). */
static void md5_tile(const uint8_t *px, size_t row_bytes, uint32_t h, size_t stride, char hex[33])
{
    MD5_CTX m;
    MD5Init(&m);
    for (uint32_t y = 0; y < h; y++)
        MD5Update(&m, px + y * stride, row_bytes);
    MD5End(&m, hex);
}

static int cmd_tiles(char **argv, unsigned scene)
{
    opened o;
    cnerf_status st = open_stream(argv[0], scene, &o);
    camera cams[MAX_CAMS];
    int n, rc = 0;
    if (st != CNERF_OK) {
        fprintf(stderr, "conform: %s: %s\n", argv[0], cnerf_status_str(st));
        close_stream(&o);
        return 1;
    }
    if (read_cameras(argv[1], cams, &n)) {
        close_stream(&o);
        return 1;
    }
    const uint32_t T = (uint32_t)atoi(argv[2]);
    cnerf_render_opts k = {(uint16_t)atoi(argv[3]), (uint16_t)atoi(argv[4]),
                           (uint32_t)strtoul(argv[5], NULL, 10), 0};
    for (int c = 0; c < n && rc == 0; c++) {
        const cnerf_camera *cam = &cams[c].c;
        uint8_t *px = malloc((size_t)T * T * 3 + 1);
        for (uint32_t y0 = 0; px && y0 < cam->height && rc == 0; y0 += T)
            for (uint32_t x0 = 0; x0 < cam->width && rc == 0; x0 += T) {
                const uint32_t w = x0 + T > cam->width ? cam->width - x0 : T;
                const uint32_t h = y0 + T > cam->height ? cam->height - y0 : T;
                st = render(&o, cam, &k, x0, y0, w, h, px, (size_t)w * 3);
                if (st != CNERF_OK) {
                    fprintf(stderr, "conform: %s: %s\n", cams[c].name, cnerf_status_str(st));
                    rc = 1;
                    break;
                }
                char hex[33];
                md5_tile(px, (size_t)w * 3, h, (size_t)w * 3, hex);
                printf("%s %u %u %u %u %u %u %u %s\n", cams[c].name, x0, y0, w, h, k.n_coarse,
                       k.n_fine, k.t_stop, hex);
            }
        if (!px)
            rc = 1;
        free(px);
    }
    close_stream(&o);
    return rc;
}

/* ---- check ---- */

static int passed, failed;

static void result(int ok, const char *what, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void result(int ok, const char *what, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    printf("%s %s: ", ok ? "PASS" : "FAIL", what);
    vprintf(fmt, ap);
    printf("\n");
    va_end(ap);
    ok ? passed++ : failed++;
}

/* The number after "KEY: " on NAME.txt's first line that starts so, or `none` when there is
 * no such line or no number ("level: none"). */
static double txt_value(const char *txt, const char *key, double none)
{
    FILE *f = fopen(txt, "r");
    char line[1024];
    const size_t k = strlen(key);
    double v = none;
    while (f && fgets(line, sizeof line, f))
        if (strncmp(line, key, k) == 0 && line[k] == ':' && line[k + 1] == ' ') {
            char *end;
            const double x = strtod(line + k + 2, &end);
            if (end != line + k + 2)
                v = x;
            break;
        }
    if (f)
        fclose(f);
    return v;
}

/* NAME.txt's min_psnr (-1 when absent) and declared level (0 for "level: none"). */
static double min_psnr_of(const char *txt) { return txt_value(txt, "min_psnr", -1); }
static unsigned level_of(const char *txt) { return (unsigned)txt_value(txt, "level", 0); }

/* 1 when this decoder's level (CNERF_MAX_LEVEL; 0 for a decoder of every level) is below a
 * stream declaring `level` (0 for none): it must refuse the stream with CNERF_E_LEVEL. */
static int above_this_decoder(unsigned level)
{
#if CNERF_MAX_LEVEL > 0
    return level == 0 || level > (unsigned)CNERF_MAX_LEVEL;
#else
    (void)level;
    return 0;
#endif
}

/* cnerf_peek and cnerf_open (with a workspace of 64 bytes, or as large as peek asks) of
 * scene `scene` of buf[0..len). */
static void peek_and_open(const uint8_t *buf, size_t len, unsigned scene, cnerf_status *p,
                          cnerf_status *op)
{
    cnerf_info *info = malloc(sizeof *info);
    *p = info ? cnerf_peek_scene(buf, len, scene, info) : CNERF_E_NULL;
    const size_t ws_n = info && *p == CNERF_OK ? cnerf_workspace_size(info) : 64;
    free(info);
    opened o;
    memset(&o, 0, sizeof o);
    o.dec = calloc(1, sizeof *o.dec);
    o.ws = aligned_alloc(CNERF_WS_ALIGN, (ws_n + 7) & ~(size_t)7);
    *op = o.dec && o.ws ? cnerf_open_scene(o.dec, buf, len, scene, o.ws, ws_n) : CNERF_E_NULL;
    close_stream(&o);
}

/* The MD5 of the tile x0, y0, w, h of camera `cname` (one of cams[n]) rendered with k: over
 * rows of w * 3 bytes, or w * 2 when k asks for RGB565. CNERF_E_ARG for an unknown camera. */
static cnerf_status tile_md5(const opened *o, const camera *cams, int n, const char *cname,
                             const cnerf_render_opts *k, unsigned x0, unsigned y0, unsigned w,
                             unsigned h, char got[33])
{
    const camera *cam = NULL;
    for (int c = 0; c < n; c++)
        if (!strcmp(cams[c].name, cname))
            cam = &cams[c];
    const int rgb565 = (k->flags & (CNERF_RENDER_RGB565 | CNERF_RENDER_RGB565_BE)) != 0;
    const size_t row = (size_t)w * (rgb565 ? 2u : 3u);
    uint8_t *px = malloc(row * h + 1);
    const cnerf_status st = cam && px ? render(o, &cam->c, k, x0, y0, w, h, px, row) : CNERF_E_ARG;
    if (st == CNERF_OK)
        md5_tile(px, row, h, row, got);
    free(px);
    return st;
}

/* Every tile of valid/NAME<sfx>.md5 rendered by the opened decoder o with cameras cams[n]:
 * one result, named `what`. */
static void check_tiles(const char *dir, const char *name, const char *sfx, const opened *o,
                        const camera *cams, int n, const char *what)
{
    char path[4096];
    cnerf_status st;
    snprintf(path, sizeof path, "%s/valid/%s%s.md5", dir, name, sfx);
    FILE *f = fopen(path, "r");
    char line[512];
    int tiles = 0, bad = 0;
    while (f && fgets(line, sizeof line, f)) {
        char cname[64], want[40], got[33];
        unsigned x0, y0, w, h, nc, nf, ts;
        if (sscanf(line, "%63s %u %u %u %u %u %u %u %39s", cname, &x0, &y0, &w, &h, &nc, &nf,
                   &ts, want) != 9) {
            bad++;
            continue;
        }
        const cnerf_render_opts k = {(uint16_t)nc, (uint16_t)nf, ts, 0};
        st = tile_md5(o, cams, n, cname, &k, x0, y0, w, h, got);
        if (st == CNERF_OK) {
            if (strcmp(got, want)) {
                if (bad < 3)
                    printf("  %s%s tile %s (%u,%u %ux%u, %u+%u, t_stop %u): md5 %s, want %s\n",
                           name, sfx, cname, x0, y0, w, h, nc, nf, ts, got, want);
                bad++;
            }
        } else {
            printf("  %s%s tile %s (%u,%u %ux%u): %s\n", name, sfx, cname, x0, y0, w, h,
                   cnerf_status_str(st));
            bad++;
        }
        tiles++;
    }
    if (f)
        fclose(f);
    result(tiles > 0 && bad == 0, what, "%d tile MD5s, %d differ", tiles, bad);
}

/* One valid vector: its tiles' MD5s and each camera's PSNR against the float reference. */
/* Checks scene `scene` of vector NAME with its files NAME<sfx>.*; returns the stream's scene
 * count (0 when it does not open). */
static unsigned check_scene(const char *dir, const char *name, unsigned scene, const char *sfx)
{
    char path[4096], what[256];
    snprintf(what, sizeof what, "valid/%s%s", name, sfx);
    snprintf(path, sizeof path, "%s/valid/%s.cnrf", dir, name);
    opened o;
    cnerf_status st = open_stream(path, scene, &o);
    if (st != CNERF_OK) {
        result(0, what, "open: %s", cnerf_status_str(st));
        close_stream(&o);
        return 0;
    }
    const unsigned n_scenes = o.dec->info.n_scenes;
    camera cams[MAX_CAMS];
    int n;
    snprintf(path, sizeof path, "%s/valid/%s%s.cam", dir, name, sfx);
    if (read_cameras(path, cams, &n) || n == 0) {
        result(0, what, "no cameras in %s", path);
        close_stream(&o);
        return n_scenes;
    }
    check_tiles(dir, name, sfx, &o, cams, n, what);
    FILE *f;
    char line[512];
    int tiles, bad;

    /* Its tiles in RGB565 (valid/RGB565, one line a tile: NAME CAMERA X0 Y0 W H N_COARSE
     * N_FINE T_STOP FLAGS MD5, the MD5 over rows of w * 2 bytes). */
    snprintf(path, sizeof path, "%s/valid/RGB565", dir);
    f = fopen(path, "r");
    char full[192];
    snprintf(full, sizeof full, "%s%s", name, sfx);
    tiles = bad = 0;
    while (f && fgets(line, sizeof line, f)) {
        char vname[192], cname[64], want[40], got[33];
        unsigned x0, y0, w, h, nc, nf, ts, fl;
        if (sscanf(line, "%191s %63s %u %u %u %u %u %u %u %u %39s", vname, cname, &x0, &y0, &w,
                   &h, &nc, &nf, &ts, &fl, want) != 11 || strcmp(vname, full))
            continue;
        const cnerf_render_opts k = {(uint16_t)nc, (uint16_t)nf, ts, fl};
        st = tile_md5(&o, cams, n, cname, &k, x0, y0, w, h, got);
        if (st == CNERF_OK) {
            if (strcmp(got, want)) {
                printf("  %s tile %s (%u,%u %ux%u, flags %u): RGB565 md5 %s, want %s\n", full,
                       cname, x0, y0, w, h, fl, got, want);
                bad++;
            }
        } else {
            printf("  %s tile %s, flags %u: %s\n", full, cname, fl, cnerf_status_str(st));
            bad++;
        }
        tiles++;
    }
    if (f)
        fclose(f);
    if (tiles)
        result(bad == 0, what, "%d RGB565 tile MD5s, %d differ", tiles, bad);

    /* Whole images against the float reference. */
    snprintf(path, sizeof path, "%s/valid/%s.txt", dir, name);
    const double need = min_psnr_of(path);
    for (int c = 0; c < n; c++) {
        const cnerf_camera *cam = &cams[c].c;
        char ref_path[4096], err[512];
        snprintf(ref_path, sizeof ref_path, "%s/valid/%s%s.%s.ref.png", dir, name, sfx,
                 cams[c].name);
        cn_image ref;
        snprintf(what, sizeof what, "valid/%s%s %s", name, sfx, cams[c].name);
        if (cn_png_read(ref_path, &ref, err, sizeof err)) {
            result(0, what, "%s", err);
            continue;
        }
        const size_t nv = (size_t)cam->width * cam->height * 3;
        uint8_t *px = malloc(nv);
        st = px && ref.w == cam->width && ref.h == cam->height && ref.c == 3
                 ? render(&o, cam, NULL, 0, 0, cam->width, cam->height, px,
                          (size_t)cam->width * 3)
                 : CNERF_E_ARG;
        if (st != CNERF_OK) {
            result(0, what, "render: %s (reference %dx%d)", cnerf_status_str(st), ref.w, ref.h);
        } else {
            double se = 0;
            int md = 0;
            for (size_t i = 0; i < nv; i++) {
                const int r = (int)lrintf(ref.px[i] * 255.0f), d = abs((int)px[i] - r);
                se += (double)d * d;
                md = d > md ? d : md;
            }
            const double psnr = se == 0 ? INFINITY : 10 * log10(255.0 * 255.0 * (double)nv / se);
            result(need > 0 && psnr >= need, what,
                   "%.2f dB against the float reference (needs %.1f), max diff %d", psnr, need,
                   md);
        }
        free(px);
        cn_image_free(&ref);
    }
    close_stream(&o);
    return n_scenes;
}

/* Scene 0 of vector NAME, then every other scene that has cameras of its own. */
static void check_valid(const char *dir, const char *name)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/valid/%s.txt", dir, name);
    const unsigned level = level_of(path);
    if (above_this_decoder(level)) { /* a decoder of a lower level refuses it */
        uint8_t *buf;
        size_t len;
        char what[300];
        snprintf(what, sizeof what, "valid/%s", name);
        snprintf(path, sizeof path, "%s/valid/%s.cnrf", dir, name);
        if (read_file(path, &buf, &len)) {
            result(0, what, "%s", strerror(errno));
            return;
        }
        cnerf_status p, op;
        peek_and_open(buf, len, 0, &p, &op);
        free(buf);
        char declared[32] = "declares no level";
        if (level)
            snprintf(declared, sizeof declared, "declares level %u", level);
        result(p == CNERF_E_LEVEL && op == CNERF_E_LEVEL, what,
               "%s: peek %s, open %s (want CNERF_E_LEVEL from a decoder of level %d)",
               declared, cnerf_status_str(p), cnerf_status_str(op), CNERF_MAX_LEVEL);
        return;
    }
    const unsigned n = check_scene(dir, name, 0, "");
    for (unsigned m = 1; m < n; m++) {
        char sfx[16];
        snprintf(sfx, sizeof sfx, ".s%u", m);
        snprintf(path, sizeof path, "%s/valid/%s%s.cam", dir, name, sfx);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        fclose(f);
        check_scene(dir, name, m, sfx);
    }
}

static cnerf_status status_of(const char *name)
{
    for (int s = 0; s >= -64; s--)
        if (!strcmp(cnerf_status_str((cnerf_status)s), name))
            return (cnerf_status)s;
    return (cnerf_status)1; /* no such status */
}

static void check_invalid(const char *dir)
{
    char path[4096], line[1024];
    snprintf(path, sizeof path, "%s/invalid/expected.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        result(0, "invalid/expected.txt", "%s", strerror(errno));
        return;
    }
    while (fgets(line, sizeof line, f)) {
        char file[256], peek_s[64], open_s[64], opt[64] = "", what[300];
        if (line[0] == '#' || sscanf(line, "%255s %63s %63s %63s", file, peek_s, open_s, opt) < 3)
            continue;
        unsigned scene = 0; /* "scene=N": peek and open scene N */
        if (strncmp(opt, "scene=", 6) == 0)
            scene = (unsigned)strtoul(opt + 6, NULL, 10);
        snprintf(path, sizeof path, "%s/invalid/%s", dir, file);
        snprintf(what, sizeof what, "invalid/%s", file);
        uint8_t *buf;
        size_t len;
        if (read_file(path, &buf, &len)) {
            result(0, what, "%s", strerror(errno));
            continue;
        }
        cnerf_status p, op;
        peek_and_open(buf, len, scene, &p, &op);
        free(buf);
        /* what peek accepts, a decoder of a lower level than the stream's refuses (the
         * broken streams that peek accepts declare no level) */
        if (status_of(peek_s) == CNERF_OK && above_this_decoder(0)) {
            snprintf(peek_s, sizeof peek_s, "%s", "CNERF_E_LEVEL");
            snprintf(open_s, sizeof open_s, "%s", "CNERF_E_LEVEL");
        }
        const int ok = p == status_of(peek_s) && op == status_of(open_s);
        result(ok, what, "peek %s, open %s (want %s, %s)", cnerf_status_str(p),
               cnerf_status_str(op), peek_s, open_s);
    }
    fclose(f);
}

/* packed/expected.txt (vectors/packed.sh): images of a valid vector packed for each kernel
 * set, and broken ones. Per line: FILE, its status on a decoder of the image's kernel set,
 * on a decoder of any other set, the image's set. This decoder must open the image of
 * exactly one set (its own) and render the vector's tiles from it as from the stream, refuse
 * that image one byte short and one byte off alignment, and refuse every other set's image
 * with the second status; a broken image gets the first status when it is of this decoder's
 * set. */
static void check_packed(const char *dir)
{
    char path[4096], line[1024], own[16] = "";
    snprintf(path, sizeof path, "%s/packed/expected.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        result(0, "packed/expected.txt", "%s", strerror(errno));
        return;
    }
    int owned = 0;
    for (int pass = 0; pass < 2; pass++) { /* the images that open, then the broken ones */
        rewind(f);
        while (fgets(line, sizeof line, f)) {
            char file[256], st_own[64], st_other[64], set[16], what[300];
            if (line[0] == '#' ||
                sscanf(line, "%255s %63s %63s %15s", file, st_own, st_other, set) != 4)
                continue;
            const int good = status_of(st_own) == CNERF_OK;
            if (good != (pass == 0))
                continue;
            snprintf(path, sizeof path, "%s/packed/%s", dir, file);
            snprintf(what, sizeof what, "packed/%s", file);
            uint8_t *raw;
            size_t len;
            if (read_file(path, &raw, &len)) {
                result(0, what, "%s", strerror(errno));
                continue;
            }
            opened o;
            memset(&o, 0, sizeof o);
            o.buf = aligned_alloc(CNERF_WS_ALIGN, (len + 8u + 7u) & ~(size_t)7u);
            o.dec = calloc(1, sizeof *o.dec);
            if (!o.buf || !o.dec) {
                result(0, what, "out of memory");
                free(raw);
                close_stream(&o);
                continue;
            }
            memcpy(o.buf, raw, len);
            free(raw);
            const cnerf_status st = cnerf_open_packed(o.dec, o.buf, len);
            if (pass == 1) {
                const char *want = !strcmp(set, own) ? st_own : st_other;
                result(st == status_of(want), what, "%s (want %s on a decoder of set %s)",
                       cnerf_status_str(st), want, own[0] ? own : "unknown");
            } else if (st == status_of(st_other)) {
                result(1, what, "%s: an image for other kernels", cnerf_status_str(st));
            } else {
                /* this decoder's set: the vector's tiles, from the image in place */
                char name[256];
                snprintf(name, sizeof name, "%s", file);
                char *dot = strstr(name, ".");
                if (dot)
                    *dot = 0;
                snprintf(path, sizeof path, "%s/valid/%s.txt", dir, name);
                const cnerf_status want =
                    above_this_decoder(level_of(path)) ? CNERF_E_LEVEL : CNERF_OK;
                result(st == want, what, "%s (want %s or, for another set's image, %s)",
                       cnerf_status_str(st), cnerf_status_str(want), st_other);
                if (st == want) {
                    snprintf(own, sizeof own, "%s", set);
                    owned++;
                }
                camera cams[MAX_CAMS];
                int n = 0;
                snprintf(path, sizeof path, "%s/valid/%s.cam", dir, name);
                if (st == CNERF_OK && (read_cameras(path, cams, &n) || n == 0))
                    result(0, what, "no cameras in %s", path);
                else if (st == CNERF_OK) {
                    o.scratch_n = cnerf_render_scratch_size(&o.dec->info);
                    o.scratch = aligned_alloc(CNERF_WS_ALIGN, (o.scratch_n + 7) & ~(size_t)7);
                    if (o.scratch)
                        check_tiles(dir, name, "", &o, cams, n, what);
                }
                /* the same image one byte short, and one byte off alignment */
                cnerf_decoder *d2 = calloc(1, sizeof *d2);
                const cnerf_status cut = d2 ? cnerf_open_packed(d2, o.buf, len - 1u) : CNERF_E_NULL;
                memmove(o.buf + 1, o.buf, len);
                const cnerf_status al = d2 ? cnerf_open_packed(d2, o.buf + 1, len) : CNERF_E_NULL;
                free(d2);
                result(cut == CNERF_E_TRUNCATED && al == CNERF_E_IMAGE_ALIGN, what,
                       "one byte short: %s; one byte off alignment: %s", cnerf_status_str(cut),
                       cnerf_status_str(al));
            }
            close_stream(&o);
        }
        if (pass == 0)
            result(owned == 1, "packed/", "%d images of this decoder's kernel set (%s) opened, "
                                          "want 1", owned, own[0] ? own : "none");
    }
    fclose(f);
}

/* valid/LOOKAT: cnerf_camera_look_at on each line's inputs must give the line's status and,
 * when CNERF_OK, its camera's 18 integers (vectors/tools/lookat.c writes the lines). */
static void check_lookat(const char *dir)
{
    char path[4096], line[1024];
    snprintf(path, sizeof path, "%s/valid/LOOKAT", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        result(0, "valid/LOOKAT", "%s", strerror(errno));
        return;
    }
    int cases = 0, bad = 0, lineno = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        long long v[30];
        char status[64];
        int used = 0, k = 0;
        const char *p = line;
        for (; k < 12 && sscanf(p, "%lld%n", &v[k], &used) == 1; k++)
            p += used;
        if (k != 12 || sscanf(p, "%63s%n", status, &used) != 1) {
            printf("  LOOKAT line %d: unreadable\n", lineno);
            bad++;
            continue;
        }
        p += used;
        int n = 0;
        for (; n < 18 && sscanf(p, "%lld%n", &v[12 + n], &used) == 1; n++)
            p += used;
        const int32_t eye[3] = {(int32_t)v[0], (int32_t)v[1], (int32_t)v[2]};
        const int32_t tgt[3] = {(int32_t)v[3], (int32_t)v[4], (int32_t)v[5]};
        const int32_t up[3] = {(int32_t)v[6], (int32_t)v[7], (int32_t)v[8]};
        cnerf_camera c;
        const cnerf_status st = cnerf_camera_look_at(&c, eye, tgt, up, (int32_t)v[9],
                                                     (uint16_t)v[10], (uint16_t)v[11]);
        int ok = !strcmp(cnerf_status_str(st), status) && n == (st == CNERF_OK ? 18 : 0);
        if (ok && st == CNERF_OK) {
            const long long *w = v + 12;
            for (int i = 0; i < 9; i++)
                ok &= c.rot[i] == w[i];
            for (int i = 0; i < 3; i++)
                ok &= c.pos[i] == w[9 + i];
            ok &= c.fx == w[12] && c.fy == w[13] && c.cx == w[14] && c.cy == w[15] &&
                  c.width == w[16] && c.height == w[17];
        }
        if (!ok) {
            printf("  LOOKAT line %d: %s, the line says %s%s\n", lineno, cnerf_status_str(st),
                   status, st == CNERF_OK ? " (or another camera)" : "");
            bad++;
        }
        cases++;
    }
    fclose(f);
    result(cases > 0 && bad == 0, "valid/LOOKAT", "%d look-at cameras and refusals, %d differ",
           cases, bad);
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int cmd_check(const char *dir)
{
    /* The valid vectors are the names listed in valid/LIST (one per line, sorted). */
    char path[4096], line[512];
    snprintf(path, sizeof path, "%s/valid/LIST", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "conform: %s: %s\n", path, strerror(errno));
        return 1;
    }
    char *names[256];
    int n = 0;
    while (n < 256 && fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = 0;
        if (line[0] && line[0] != '#')
            names[n++] = strdup(line);
    }
    fclose(f);
    qsort(names, (size_t)n, sizeof names[0], cmp_str);
    for (int i = 0; i < n; i++) {
        check_valid(dir, names[i]);
        fflush(stdout);
        free(names[i]);
    }
    check_lookat(dir);
    check_invalid(dir);
    check_packed(dir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed || passed == 0 ? 1 : 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "check"))
        return cmd_check(argv[2]);
    if ((argc == 8 || argc == 9) && !strcmp(argv[1], "tiles"))
        return cmd_tiles(argv + 2, argc == 9 ? (unsigned)strtoul(argv[8], NULL, 10) : 0u);
    fprintf(stderr, "usage: conform check VECTORS_DIR\n"
                    "       conform tiles STREAM CAMERAS TILE NC NF TSTOP [SCENE]\n");
    return 2;
}
