/* Renders a view of a cnerf stream row by row into a one-row buffer and streams each row
 * out as it is done, the way a device without a framebuffer would feed a display: here to
 * a binary PPM file. The only decoder memory is one workspace and one render scratch, sized
 * by the decoder for the stream.
 *   render_rows STREAM CAMERA OUT.ppm [X0 Y0 W H [N_COARSE N_FINE T_STOP]]
 * CAMERA is a text file of 18 integers: the rotation (9, Q30), the position (3, Q32), fx fy
 * cx cy (Q16), width and height, as `cnerf render --save-cameras` writes them (one camera a
 * line; the first is used). Without X0 Y0 W H the whole image; without the knobs (samples
 * and t_stop in Q30, docs/rendering.md) the stream's defaults. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "cnerf/cnerf.h"

static int fail(const char *what, cnerf_status st)
{
    fprintf(stderr, "render_rows: %s: %s\n", what, cnerf_status_str(st));
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 4 && argc != 8 && argc != 11) {
        fprintf(stderr, "usage: render_rows STREAM CAMERA OUT.ppm [X0 Y0 W H [N_COARSE N_FINE "
                        "T_STOP]]\n");
        return 2;
    }
    /* the stream, read whole (on a device it is read in place from flash) */
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        perror(argv[1]);
        return 1;
    }
    static uint8_t stream[1u << 24];
    const size_t len = fread(stream, 1, sizeof stream, f);
    fclose(f);

    static cnerf_decoder dec;
    cnerf_status st = cnerf_peek(stream, len, &dec.info);
    if (st != CNERF_OK)
        return fail(argv[1], st);
    const size_t ws_size = cnerf_workspace_size(&dec.info);
    const size_t sc_size = cnerf_render_scratch_size(&dec.info);
    /* CNERF_WS_ALIGN-aligned: malloc's alignment is at least 8 on the hosts this runs on */
    void *ws = malloc(ws_size), *scratch = malloc(sc_size);
    if (!ws || !scratch)
        return 1;
    st = cnerf_open(&dec, stream, len, ws, ws_size);
    if (st != CNERF_OK)
        return fail(argv[1], st);

    long long v[18];
    f = fopen(argv[2], "r");
    if (!f) {
        perror(argv[2]);
        return 1;
    }
    for (int i = 0; i < 18; i++)
        if (fscanf(f, "%lld", &v[i]) != 1) {
            fprintf(stderr, "render_rows: %s: expected 18 integers\n", argv[2]);
            return 1;
        }
    fclose(f);
    cnerf_camera cam;
    for (int i = 0; i < 9; i++)
        cam.rot[i] = (int32_t)v[i];
    for (int i = 0; i < 3; i++)
        cam.pos[i] = (int64_t)v[9 + i];
    cam.fx = (int32_t)v[12], cam.fy = (int32_t)v[13], cam.cx = (int32_t)v[14], cam.cy = (int32_t)v[15];
    cam.width = (uint16_t)v[16], cam.height = (uint16_t)v[17];

    uint32_t x0 = 0, y0 = 0, w = cam.width, h = cam.height;
    if (argc >= 8) {
        x0 = (uint32_t)strtoul(argv[4], NULL, 10), y0 = (uint32_t)strtoul(argv[5], NULL, 10);
        w = (uint32_t)strtoul(argv[6], NULL, 10), h = (uint32_t)strtoul(argv[7], NULL, 10);
    }
    cnerf_render_opts opts;
    cnerf_render_defaults(&dec.info, &opts);
    if (argc == 11) {
        opts.n_coarse = (uint16_t)strtoul(argv[8], NULL, 10);
        opts.n_fine = (uint16_t)strtoul(argv[9], NULL, 10);
        opts.t_stop = (uint32_t)strtoul(argv[10], NULL, 10);
    }

    FILE *out = fopen(argv[3], "wb");
    if (!out) {
        perror(argv[3]);
        return 1;
    }
    fprintf(out, "P6\n%u %u\n255\n", (unsigned)w, (unsigned)h);
    uint8_t *row = malloc((size_t)w * 3);
    if (!row)
        return 1;
    for (uint32_t y = y0; y < y0 + h; y++) {
        st = cnerf_render_tile(&dec, &cam, &opts, x0, y, w, 1, row, (size_t)w * 3, scratch,
                               sc_size);
        if (st != CNERF_OK) {
            fclose(out);
            remove(argv[3]);
            return fail("cnerf_render_tile", st);
        }
        fwrite(row, 3, w, out); /* a device sends the row to its display here */
    }
    if (fclose(out) != 0) {
        perror(argv[3]);
        return 1;
    }
    free(row), free(scratch), free(ws);
    return 0;
}
