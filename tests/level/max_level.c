/* A device's decoder of one level: built with CNERF_MAX_LEVEL=1 from the decoder's sources,
 * with a static workspace of CNERF_LEVEL_WORKSPACE(1) bytes and scratch of
 * CNERF_LEVEL_SCRATCH(1),
 * as firmware sizes them (docs/bitstream.md, levl). Built again against the library decoder
 * (any level) as the reference. tests/cli/levels.sh runs both.
 *   max_level STREAM WANT_STATUS [OUT.rgb]
 * Opens STREAM, expects the status WANT_STATUS (a number: 0, -27, ...), and when it opens
 * renders a 24x24 view of it into OUT.rgb (RGB888). Exit 0 when the status is the one wanted. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"

#ifndef ARENA_LEVEL
#define ARENA_LEVEL 3 /* the reference: arenas of the largest level */
#endif

static uint64_t ws[CNERF_LEVEL_WORKSPACE(ARENA_LEVEL) / 8u];
static uint64_t scratch[CNERF_LEVEL_SCRATCH(ARENA_LEVEL) / 8u];
static uint8_t stream[1 << 20];
static cnerf_decoder dec;

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: max_level STREAM WANT_STATUS [OUT.rgb]\n");
        return 2;
    }
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        perror(argv[1]);
        return 2;
    }
    const size_t len = fread(stream, 1, sizeof stream, f);
    fclose(f);
    const int want = atoi(argv[2]);
    cnerf_status st = cnerf_open(&dec, stream, len, ws, sizeof ws);
    printf("%s: %s (level %u, workspace %zu of %zu bytes; decoder CNERF_MAX_LEVEL %d)\n",
           argv[1], cnerf_status_str(st), dec.info.level,
           st == CNERF_OK ? cnerf_workspace_size(&dec.info) : (size_t)0, sizeof ws,
           CNERF_MAX_LEVEL);
    if ((int)st != want) {
        fprintf(stderr, "%s: %s, wanted %d\n", argv[1], cnerf_status_str(st), want);
        return 1;
    }
    if (st != CNERF_OK || argc != 4)
        return 0;
    cnerf_camera cam;
    const int32_t eye[3] = {0, -(4 << 16), 2 << 16}, at[3] = {0, 0, 0}, up[3] = {0, 0, 1 << 16};
    static uint8_t rgb[24 * 24 * 3];
    st = cnerf_camera_look_at(&cam, eye, at, up, 40 << 16, 24, 24);
    if (st == CNERF_OK)
        st = cnerf_render_tile(&dec, &cam, NULL, 0, 0, 24, 24, rgb, 24 * 3, scratch,
                               sizeof scratch);
    if (st != CNERF_OK) {
        fprintf(stderr, "%s: render: %s\n", argv[1], cnerf_status_str(st));
        return 1;
    }
    f = fopen(argv[3], "wb");
    if (!f || fwrite(rgb, 1, sizeof rgb, f) != sizeof rgb || fclose(f)) {
        perror(argv[3]);
        return 1;
    }
    return 0;
}
