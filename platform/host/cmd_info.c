/* cnerf info FILE.cnrf */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_fixcam.h"
#include "cn_report.h"
#include "cn_file.h"
#include "cn_reader.h"
#include "cnerf/tools.h"
#include "cost_model.h"

#define INFO_USAGE                                                                            \
    "usage: cnerf info [--check] [--scene I] [--no-estimate] FILE.cnrf|IMAGE\n"              \
    "  --check        also decode every payload (cnerf_open), as a device would; without it\n" \
    "                 the structure and every chunk's CRC are checked, not the coded latents\n" \
    "  --scene I      a stream of several scenes: describe scene I (0 by default); --check\n" \
    "                 decodes every scene\n"                                                  \
    "  --no-estimate  without each core's time for a view (the cost model's, from a view\n"  \
    "                 rendered at 25x25 with each kernel set: slow for the larger presets)"

/* cnerf_open_scene of every scene, each into a workspace of its own: decodes every
 * payload. *bad gets the scene that failed. */
static cnerf_status open_all(const uint8_t *buf, size_t len, unsigned n_scenes, unsigned *bad)
{
    cnerf_info *info = malloc(sizeof *info);
    cnerf_decoder *dec = malloc(sizeof *dec);
    cnerf_status st = info && dec ? CNERF_OK : CNERF_E_WS_SMALL;
    for (unsigned m = 0; st == CNERF_OK && m < n_scenes; m++) {
        *bad = m;
        st = cnerf_peek_scene(buf, len, m, info);
        const size_t n = st == CNERF_OK ? cnerf_workspace_size(info) : 0;
        void *ws = st == CNERF_OK ? aligned_alloc(CNERF_WS_ALIGN, (n + 7) & ~(size_t)7) : NULL;
        if (st == CNERF_OK)
            st = ws ? cnerf_open_scene(dec, buf, len, m, ws, n) : CNERF_E_WS_SMALL;
        free(ws);
    }
    free(info);
    free(dec);
    return st;
}

/* The cost model's time for one 100x100 view on each modelled core: the stream opened as the
 * core would (cnerf_open_as), and the same view rendered once at 25x25 (every fourth ray of
 * each row and column), counting the work per ray. The view: the first of `cnerf render
 * --orbit` (radius 4, 30 degrees up, 40 degrees wide) for a 360-degree scene; the reference
 * camera at the origin for a forward-facing one (NDC). A stream whose payloads do not decode
 * gets no estimate, and no error: without --check, info checks the structure only. */
static int print_estimates(const uint8_t *buf, size_t len, uint32_t scene, const cnerf_info *I)
{
    cn_camera cam;
    if (I->coord == CNERF_COORD_NDC) {
        memset(&cam, 0, sizeof cam);
        for (int a = 0; a < 3; a++)
            cam.c2w[a][a] = 1;
        cam.w = cam.h = 25;
        cam.fx = cam.fy = 25;
        cam.cx = cam.cy = 12.5;
    } else {
        cli_orbit_camera(0, 1, 4.0, 30.0, 40.0, 25, &cam);
    }
    cnerf_camera fc;
    char err[256];
    if (cnerf_camera_from_float(&cam, &fc, err, sizeof err))
        return cli_fail("info", "the estimate's camera: %s", err);
    const size_t ws_n = cnerf_workspace_size(I), sc_n = cnerf_render_scratch_size(I);
    void *ws = aligned_alloc(CNERF_WS_ALIGN, (ws_n + 7) & ~(size_t)7);
    void *sc = aligned_alloc(CNERF_WS_ALIGN, (sc_n + 7) & ~(size_t)7);
    uint8_t *px = malloc(25 * 25 * 3);
    cnerf_decoder *dec = malloc(sizeof *dec);
    int rc = !ws || !sc || !px || !dec ? cli_fail("info", "out of memory") : 0;
    cnerf_render_stats work[CLI_MAX_CORES]; /* per kernel set (cli_core_same_work) */
    for (size_t k = 0; rc == 0 && k < cli_n_cores; k++) {
        const cli_core *c = &cli_cores[k];
        cnerf_render_opts o;
        cnerf_render_defaults(I, &o);
        cnerf_render_stats *s = &work[cli_core_same_work(k)];
        cnerf_status st = CNERF_OK;
        if (cli_core_same_work(k) == k) {
            memset(s, 0, sizeof *s);
            st = cnerf_open_as(dec, buf, len, scene, ws, ws_n, c->set);
            if (st == CNERF_OK)
                st = cnerf_render_tile_stats(dec, &fc, &o, 0, 0, 25, 25, px, 75, sc, sc_n, s);
        }
        if (st != CNERF_OK) {
            /* without --check, info reads the structure only: a payload that does not
             * decode is --check's to report, and leaves no estimate */
            printf("%s: no estimate: the stream does not decode (%s; cnerf info --check)\n",
                   c->name, cnerf_status_str(st));
            break;
        }
        const double ipr = cli_cost_instructions(c, s, I, &o, 1) / (double)s->rays;
        printf("%s at %.0f MHz (cost model, within %.0f%%): %.1f s for a 100x100 view (%s), "
               "%.0f instructions per ray\n", c->name, c->hz / 1e6, 100 * c->error,
               ipr * 1e4 / c->hz, I->coord == CNERF_COORD_NDC ? "the reference camera" :
               "orbit_000", ipr);
    }
    free(ws), free(sc), free(px), free(dec);
    return rc;
}

/* A packed image (cnerf pack): its header, whether its CRC holds and whether this machine's
 * decoder opens it; *off and *len get the stream inside it. Returns 1 (with a message) when
 * the image is cut short or its parts lie outside it. */
static int describe_image(const char *path, const uint8_t *im, size_t n, size_t *off,
                          size_t *len)
{
    if (n < CNERF_IMAGE_HEADER_BYTES)
        return cli_fail("info", "%s: a packed image cut short (%zu bytes, less than its "
                                "%u-byte header)", path, n, CNERF_IMAGE_HEADER_BYTES);
    const uint32_t total = cn_le32(im + 24), ws_len = cn_le32(im + 32), s_off = cn_le32(im + 36),
                   s_len = cn_le32(im + 40);
    if (total > n || total < CNERF_IMAGE_HEADER_BYTES || s_off > total || s_len > total - s_off)
        return cli_fail("info", "%s: a packed image whose parts lie outside its %zu bytes "
                                "(CNERF_E_TRUNCATED or CNERF_E_IMAGE)", path, n);
    char set[9] = {0};
    memcpy(set, im + 8, 8);
    const uint32_t crc = cnerf_crc32(cnerf_crc32(0, im, 44), im + 48, total - 48u);
    printf("%s: packed image (cnerf pack), version %u%s, kernels %s, %s-endian, scene %u: "
           "%u bytes = header and layer records %u + workspace %u + stream %u; CRC-32 %s\n",
           path, cn_le16(im + 4),
           cn_le16(im + 4) == CNERF_IMAGE_VERSION ? "" : " (not this decoder's)", set,
           im[6] == 'L' ? "little" : "big", cn_le32(im + 20), total, cn_le32(im + 28), ws_len,
           s_len, crc == cn_le32(im + 44) ? "ok" : "WRONG");
    /* whether this machine's decoder opens it in place (an aligned copy) */
    uint8_t *copy = aligned_alloc(CNERF_WS_ALIGN, (total + 7u) & ~(size_t)7u);
    cnerf_decoder *dec = malloc(sizeof *dec);
    if (copy && dec) {
        memcpy(copy, im, total);
        const cnerf_status st = cnerf_open_packed(dec, copy, total);
        printf("this machine's decoder: %s (%d)%s\n", cnerf_status_str(st), (int)st,
               st == CNERF_OK ? ": it renders the image in place"
                              : st == CNERF_E_IMAGE_TARGET ? ": packed for another core" : "");
    }
    free(copy);
    free(dec);
    *off = s_off;
    *len = s_len;
    return 0;
}

int cmd_info(int argc, char **argv)
{
    int check = 0, estimate = 1;
    long scene = 0;
    for (;;) {
        if (argc >= 2 && !strcmp(argv[1], "--check")) {
            check = 1;
            argc--, argv++;
        } else if (argc >= 2 && !strcmp(argv[1], "--no-estimate")) {
            estimate = 0;
            argc--, argv++;
        } else if (argc >= 3 && !strcmp(argv[1], "--scene")) {
            char *end;
            scene = strtol(argv[2], &end, 10);
            if (*end || end == argv[2] || scene < 0 || scene >= (long)CNERF_MAX_SCENES)
                return cli_usage("info", "--scene '%s': expected a scene index 0..%u\n%s",
                                 argv[2], CNERF_MAX_SCENES - 1, INFO_USAGE);
            argc -= 2, argv += 2;
        } else {
            break;
        }
    }
    if (argc == 2 && (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help"))) {
        printf("%s\n", INFO_USAGE);
        return 0;
    }
    if (argc != 2 || (argv[1][0] == '-' && argv[1][1]))
        return cli_usage("info", "need one stream file\n%s", INFO_USAGE);
    char err[512];
    uint8_t *buf;
    size_t len;
    if (cn_read_file_sig(argv[1], CLI_STREAM_SIG, 4, &buf, &len, err, sizeof err))
        return cli_fail("info", "%s", err);
    uint8_t *file = buf; /* a packed image: describe it, then the stream inside */
    if (len >= 4 && !memcmp(buf, "CNPK", 4)) {
        size_t off = 0;
        if (describe_image(argv[1], buf, len, &off, &len)) {
            free(file);
            return 1;
        }
        buf += off;
    }
    cnerf_info *info = malloc(sizeof *info);
    if (!info) {
        free(file);
        return cli_fail("info", "out of memory");
    }
    cnerf_status st = cnerf_peek_scene(buf, len, (uint32_t)scene, info);
    unsigned bad = 0;
    if (st == CNERF_OK && check)
        st = open_all(buf, len, info->n_scenes, &bad);
    int rc = 0;
    if (st == CNERF_E_ARG && scene > 0)
        rc = cli_fail("info", "%s: no scene %ld: the stream has %u (0..%u)", argv[1], scene,
                      info->n_scenes, info->n_scenes - 1u);
    else if (st != CNERF_OK && check && info->n_scenes > 1)
        rc = cli_fail("info", "%s: scene %u: %s (%d): not a valid cnerf stream (every payload "
                      "decoded)", argv[1], bad, cnerf_status_str(st), (int)st);
    else if (st != CNERF_OK)
        rc = cli_fail("info", "%s: %s (%d): not a valid cnerf stream%s", argv[1],
                      cnerf_status_str(st), (int)st,
                      check ? " (every payload decoded)" : "");
    else
        cn_print_info(stdout, argv[1], buf, info);
    if (rc == 0 && estimate)
        rc = print_estimates(buf, len, (uint32_t)scene, info);
    if (rc == 0 && check)
        printf("check: every payload decodes (cnerf_open)\n");
    free(info);
    free(file);
    return rc;
}
