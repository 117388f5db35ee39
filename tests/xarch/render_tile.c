/* Renders one tile of a stream with the fixed-point decoder and writes its RGB888 bytes to
 * stdout, row by row. Hosted C99 and the decoder only, so that it cross-compiles for any
 * Linux target; scripts/xarch.sh runs it under qemu-user and compares the MD5s.
 *   render_tile STREAM CAMERA X0 Y0 W H [N_COARSE N_FINE T_STOP [FLAGS]]
 *   render_tile --jobs LIST OUTDIR   (many tiles, one a file: render_jobs below)
 * STREAM may be a packed image (cnerf pack), opened in place by cnerf_open_packed.
 * CAMERA is a text file of 18 integers: rot[9] (Q30), pos[3] (Q32), fx fy cx cy (Q16),
 * width height.
 * Built with CNERF_COST_MODEL and platform/host/cost_model.c (scripts/firmware.sh does), and
 * CNERF_CORE naming a core of cost_model.c in the environment, it also opens the stream as
 * that core would (cnerf_open_as), renders the tile again counting the work, and prints the
 * work and the cost model's instructions to stderr. A core the model has no fit for is
 * named with its kernel set in CNERF_CORE_SET ("dsp", "c"): the work only.
 * CNERF_WS_FAST=1 opens the stream (and the cost's copy) with cnerf_workspace_size_fast
 * bytes: every latent as int16 where the kernels' int8 sums cost more (as a firmware of
 * FW_FAST=1 does), the same pixels. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"
#if defined(CNERF_COST_MODEL)
#include "cnerf/tools.h"
#include "cost_model.h"

/* The work of the tile as core `name` would do it, and the model's instructions. */
static int cost(const char *name, const uint8_t *buf, size_t len, uint32_t scene,
                const cnerf_camera *cam, const cnerf_render_opts *o, uint32_t x0, uint32_t y0,
                uint32_t w, uint32_t h)
{
    const cli_core *c = NULL;
    for (size_t k = 0; k < cli_n_cores; k++)
        if (strcmp(cli_cores[k].name, name) == 0)
            c = &cli_cores[k];
    const char *set = c ? c->set : getenv("CNERF_CORE_SET");
    if (!set) {
        fprintf(stderr, "render_tile: CNERF_CORE: no cost model of '%s', and no "
                        "CNERF_CORE_SET\n", name);
        return 1;
    }
    static cnerf_decoder d;
    if (cnerf_peek_scene(buf, len, scene, &d.info) != CNERF_OK)
        return 1;
    const char *fast = getenv("CNERF_WS_FAST");
    const size_t ws_n = fast && strcmp(fast, "1") == 0 ? cnerf_workspace_size_fast(&d.info)
                                                       : cnerf_workspace_size(&d.info);
    const size_t sc_n = cnerf_render_scratch_size(&d.info);
    uint64_t *ws = malloc(ws_n + 8), *sc = malloc(sc_n + 8);
    uint8_t *px = malloc((size_t)w * h * 3 + 1);
    cnerf_render_stats s;
    memset(&s, 0, sizeof s);
    if (!ws || !sc || !px || cnerf_open_as(&d, buf, len, scene, ws, ws_n, set) != CNERF_OK ||
        cnerf_render_tile_stats(&d, cam, o, x0, y0, w, h, px, (size_t)w * 3, sc, sc_n, &s) !=
            CNERF_OK)
        return 1;
    fprintf(stderr,
            "host work of the tile: rays %llu evals %llu in_bounds %llu macs %llu list_macs %llu "
            "list_nz %llu samples %llu layer_values %llu exact_rescales %llu wide_macs %llu "
            "s8_macs %llu\n",
            (unsigned long long)s.rays, (unsigned long long)s.evals,
            (unsigned long long)s.in_bounds, (unsigned long long)s.macs,
            (unsigned long long)s.list_macs, (unsigned long long)s.list_nz,
            (unsigned long long)s.samples, (unsigned long long)s.layer_values,
            (unsigned long long)s.exact_rescales, (unsigned long long)s.wide_macs,
            (unsigned long long)s.s8_macs);
    if (c)
        fprintf(stderr, "cost model %s: %.0f instructions (within %.0f%% on the vectors' tiles)\n",
                c->name, cli_cost_instructions(c, &s, &d.info, o, 1), 100 * c->error);
    free(ws), free(sc), free(px);
    return 0;
}
#endif

static int fail(const char *msg, cnerf_status st)
{
    fprintf(stderr, "render_tile: %s: %s\n", msg, cnerf_status_str(st));
    return 1;
}

/* One tile: args[0..5] = STREAM CAMERA X0 Y0 W H, then none, 3 or 4 knobs (nargs 6, 9, 10);
 * its bytes to out. */
static int render_one(char **args, int nargs, uint32_t scene, FILE *out)
{
    FILE *f = fopen(args[0], "rb");
    if (!f) {
        perror(args[0]);
        return 1;
    }
    static uint64_t words[(1 << 22) / 8]; /* aligned for a packed image */
    uint8_t *const buf = (uint8_t *)words;
    const size_t len = fread(buf, 1, sizeof words, f);
    fclose(f);
    static cnerf_decoder dec;
    uint64_t *ws = NULL, *sc;
    size_t sc_n;
    cnerf_status st;
    if (len >= 4 && memcmp(buf, "CNPK", 4) == 0) { /* a packed image, read in place */
        st = cnerf_open_packed(&dec, buf, len);
        if (st != CNERF_OK)
            return fail(args[0], st);
        sc_n = cnerf_render_scratch_size(&dec.info);
        if (!(sc = malloc(sc_n + 8)))
            return 1;
    } else {
        st = cnerf_peek_scene(buf, len, scene, &dec.info);
        if (st != CNERF_OK)
            return fail(args[0], st);
        const char *fast = getenv("CNERF_WS_FAST"); /* 1: every latent as int16 */
        const size_t ws_n = fast && strcmp(fast, "1") == 0 ? cnerf_workspace_size_fast(&dec.info)
                                                           : cnerf_workspace_size(&dec.info);
        sc_n = cnerf_render_scratch_size(&dec.info);
        ws = malloc(ws_n + 8), sc = malloc(sc_n + 8);
        if (!ws || !sc)
            return 1;
        st = cnerf_open_scene(&dec, buf, len, scene, ws, ws_n);
        if (st != CNERF_OK)
            return fail(args[0], st);
    }

    cnerf_camera cam;
    long long v[18];
    f = fopen(args[1], "r");
    if (!f) {
        perror(args[1]);
        return 1;
    }
    for (int i = 0; i < 18; i++)
        if (fscanf(f, "%lld", &v[i]) != 1) {
            fprintf(stderr, "render_tile: %s: expected 18 integers\n", args[1]);
            fclose(f);
            return 1;
        }
    fclose(f);
    for (int i = 0; i < 9; i++)
        cam.rot[i] = (int32_t)v[i];
    for (int i = 0; i < 3; i++)
        cam.pos[i] = (int64_t)v[9 + i];
    cam.fx = (int32_t)v[12], cam.fy = (int32_t)v[13], cam.cx = (int32_t)v[14], cam.cy = (int32_t)v[15];
    cam.width = (uint16_t)v[16], cam.height = (uint16_t)v[17];

    cnerf_render_opts o;
    cnerf_render_defaults(&dec.info, &o);
    if (nargs >= 9) {
        o.n_coarse = (uint16_t)atoi(args[6]);
        o.n_fine = (uint16_t)atoi(args[7]);
        o.t_stop = (uint32_t)strtoul(args[8], NULL, 10);
    }
    if (nargs == 10)
        o.flags = (uint32_t)strtoul(args[9], NULL, 10);
    const uint32_t x0 = (uint32_t)atoi(args[2]), y0 = (uint32_t)atoi(args[3]);
    const uint32_t w = (uint32_t)atoi(args[4]), h = (uint32_t)atoi(args[5]);
    /* RGB888, or RGB565 in either byte order (FLAGS), rows without padding */
    const size_t bpp = o.flags & (CNERF_RENDER_RGB565 | CNERF_RENDER_RGB565_BE) ? 2u : 3u;
    uint8_t *px = malloc((size_t)w * h * bpp + 1);
    if (!px)
        return 1;
    st = cnerf_render_tile(&dec, &cam, &o, x0, y0, w, h, px, (size_t)w * bpp, sc, sc_n);
    if (st != CNERF_OK)
        return fail("render", st);
    fwrite(px, 1, (size_t)w * h * bpp, out);
    free(px), free(ws), free(sc);
#if defined(CNERF_COST_MODEL)
    const char *core = getenv("CNERF_CORE");
    if (core && cost(core, buf, len, scene, &cam, &o, x0, y0, w, h))
        return 1;
#endif
    return 0;
}

/* --jobs LIST OUTDIR: LIST has a tile a line, "STREAM|SCENE|CAMERA|X0 Y0 W H|KNOBS" (KNOBS
 * empty, or N_COARSE N_FINE T_STOP [FLAGS]); tile n (from 1) is written to OUTDIR/n.rgb. One
 * process for many tiles: under qemu-user or Node, starting one costs more than a small
 * tile. */
static int render_jobs(const char *list, const char *outdir)
{
    FILE *f = fopen(list, "r");
    if (!f) {
        perror(list);
        return 1;
    }
    char line[4096];
    int n = 0, rc = 0;
    while (!rc && fgets(line, sizeof line, f)) {
        n++;
        char *args[11], *p = line, *fields[5];
        line[strcspn(line, "\n")] = 0;
        for (int i = 0; i < 5; i++) { /* split at '|' */
            fields[i] = p;
            char *bar = p ? strchr(p, '|') : NULL;
            if (bar)
                *bar = 0;
            p = bar ? bar + 1 : NULL;
            if (!fields[i] && i < 4) {
                fprintf(stderr, "render_tile: %s:%d: expected STREAM|SCENE|CAMERA|TILE|KNOBS\n",
                        list, n);
                fclose(f);
                return 1;
            }
        }
        int nargs = 0;
        args[nargs++] = fields[0];
        args[nargs++] = fields[2];
        for (int k = 3; k < 5; k++)
            for (char *t = fields[k] ? strtok(fields[k], " ") : NULL; t && nargs < 11;
                 t = strtok(NULL, " "))
                args[nargs++] = t;
        if (nargs != 6 && nargs != 9 && nargs != 10) {
            fprintf(stderr, "render_tile: %s:%d: a tile has 4 numbers, then 0, 3 or 4 knobs\n",
                    list, n);
            fclose(f);
            return 1;
        }
        char path[4200];
        snprintf(path, sizeof path, "%s/%d.rgb", outdir, n);
        FILE *out = fopen(path, "wb");
        if (!out) {
            perror(path);
            fclose(f);
            return 1;
        }
        rc = render_one(args, nargs, (uint32_t)strtoul(fields[1], NULL, 10), out);
        if (fclose(out) != 0)
            rc = 1;
        if (rc)
            fprintf(stderr, "render_tile: %s:%d: tile failed\n", list, n);
    }
    fclose(f);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc == 4 && strcmp(argv[1], "--jobs") == 0)
        return render_jobs(argv[2], argv[3]);
    if (argc != 7 && argc != 10 && argc != 11) {
        fprintf(stderr,
                "usage: [CNERF_SCENE=I] render_tile STREAM CAMERA X0 Y0 W H [N_COARSE N_FINE "
                "T_STOP [FLAGS]]\n"
                "       render_tile --jobs LIST OUTDIR\n");
        return 2;
    }
    /* CNERF_SCENE in the environment: the scene of a stream of several (0 when unset) */
    const char *scene_env = getenv("CNERF_SCENE");
    const uint32_t scene = scene_env ? (uint32_t)strtoul(scene_env, NULL, 10) : 0u;
    return render_one(argv + 1, argc - 1, scene, stdout);
}
