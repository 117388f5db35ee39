/* Renders one tile of a stream with the fixed-point decoder and writes its RGB888 bytes to
 * stdout, row by row. Hosted C99 and the decoder only, so that it cross-compiles for any
 * Linux target; scripts/xarch.sh runs it under qemu-user and compares the MD5s.
 *   render_tile STREAM CAMERA X0 Y0 W H [N_COARSE N_FINE T_STOP [FLAGS]]
 * CAMERA is a text file of 18 integers: rot[9] (Q30), pos[3] (Q32), fx fy cx cy (Q16),
 * width height. */
#include <stdio.h>
#include <stdlib.h>

#include "cnerf/cnerf.h"

static int fail(const char *msg, cnerf_status st)
{
    fprintf(stderr, "render_tile: %s: %s\n", msg, cnerf_status_str(st));
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 7 && argc != 10 && argc != 11) {
        fprintf(stderr,
                "usage: [CNERF_SCENE=I] render_tile STREAM CAMERA X0 Y0 W H [N_COARSE N_FINE "
                "T_STOP [FLAGS]]\n");
        return 2;
    }
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        perror(argv[1]);
        return 1;
    }
    static uint8_t buf[1 << 22];
    const size_t len = fread(buf, 1, sizeof buf, f);
    fclose(f);
    /* CNERF_SCENE in the environment: the scene of a stream of several (0 when unset) */
    const char *scene_env = getenv("CNERF_SCENE");
    const uint32_t scene = scene_env ? (uint32_t)strtoul(scene_env, NULL, 10) : 0u;
    static cnerf_decoder dec;
    cnerf_status st = cnerf_peek_scene(buf, len, scene, &dec.info);
    if (st != CNERF_OK)
        return fail(argv[1], st);
    const size_t ws_n = cnerf_workspace_size(&dec.info);
    const size_t sc_n = cnerf_render_scratch_size(&dec.info);
    uint64_t *ws = malloc(ws_n + 8), *sc = malloc(sc_n + 8);
    if (!ws || !sc)
        return 1;
    st = cnerf_open_scene(&dec, buf, len, scene, ws, ws_n);
    if (st != CNERF_OK)
        return fail(argv[1], st);

    cnerf_camera cam;
    long long v[18];
    f = fopen(argv[2], "r");
    if (!f) {
        perror(argv[2]);
        return 1;
    }
    for (int i = 0; i < 18; i++)
        if (fscanf(f, "%lld", &v[i]) != 1) {
            fprintf(stderr, "render_tile: %s: expected 18 integers\n", argv[2]);
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
    if (argc >= 10) {
        o.n_coarse = (uint16_t)atoi(argv[7]);
        o.n_fine = (uint16_t)atoi(argv[8]);
        o.t_stop = (uint32_t)strtoul(argv[9], NULL, 10);
    }
    if (argc == 11)
        o.flags = (uint32_t)strtoul(argv[10], NULL, 10);
    const uint32_t x0 = (uint32_t)atoi(argv[3]), y0 = (uint32_t)atoi(argv[4]);
    const uint32_t w = (uint32_t)atoi(argv[5]), h = (uint32_t)atoi(argv[6]);
    uint8_t *px = malloc((size_t)w * h * 3 + 1);
    if (!px)
        return 1;
    st = cnerf_render_tile(&dec, &cam, &o, x0, y0, w, h, px, (size_t)w * 3, sc, sc_n);
    if (st != CNERF_OK)
        return fail("render", st);
    fwrite(px, 1, (size_t)w * h * 3, stdout);
    free(px), free(ws), free(sc);
    return 0;
}
