/* Build-time tool of the Cortex-M4 firmware (platform/cortex-m/CMakeLists.txt runs it on
 * the host): reads the stream, camera, tile and knobs, sizes the workspace and scratch with
 * the decoder itself (cnerf_workspace_size, cnerf_render_scratch_size) and writes the header
 * cnerf_fw_embed.h that fw_render.c includes. Hosted C99. */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"

static int die(const char *what, const char *why)
{
    fprintf(stderr, "cnerf_fw_embed: %s: %s\n", what, why);
    return 1;
}

/* A decimal integer in [lo, hi], the whole string. */
static int parse_int(const char *s, long long lo, long long hi, long long *out)
{
    char *end;
    errno = 0;
    const long long v = strtoll(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi)
        return 0;
    *out = v;
    return 1;
}

/* A C constant expression of type long long for any value (LLONG_MIN has no literal). */
static void put_ll(FILE *f, long long v)
{
    if (v == INT64_MIN)
        fprintf(f, "(-9223372036854775807LL - 1)");
    else
        fprintf(f, "(%lldLL)", v);
}

int main(int argc, char **argv)
{
    if (argc != 8 && argc != 11 && argc != 12) {
        fprintf(stderr, "usage: cnerf_fw_embed OUT.h STREAM CAMERA X0 Y0 W H [N_COARSE N_FINE "
                        "T_STOP [FLAGS]]\n");
        return 2;
    }
    const char *out_path = argv[1], *stream_path = argv[2], *cam_path = argv[3];

    /* The tile and knobs: only their syntax and ranges here; whether the tile lies in the
     * image and the knobs suit the stream is for the decoder to say, at run time. */
    long long tile[4], knobs[4] = {0, 0, 0, 0};
    for (int i = 0; i < 4; i++)
        if (!parse_int(argv[4 + i], 0, 65535, &tile[i]))
            return die(argv[4 + i], "a tile coordinate must be an integer in 0..65535");
    const int have_knobs = argc >= 11;
    if (have_knobs) {
        if (!parse_int(argv[8], 0, 65535, &knobs[0]) || !parse_int(argv[9], 0, 65535, &knobs[1]))
            return die(argv[8], "sample counts must be integers in 0..65535");
        if (!parse_int(argv[10], 0, 4294967295LL, &knobs[2]))
            return die(argv[10], "T_STOP must be an integer in 0..2^32-1 (Q30)");
        if (argc == 12 && !parse_int(argv[11], 0, 4294967295LL, &knobs[3]))
            return die(argv[11], "FLAGS must be an integer in 0..2^32-1 (CNERF_RENDER_*)");
    }

    /* The camera: 18 integers, as tests/xarch/render_tile.c reads them. */
    FILE *f = fopen(cam_path, "r");
    if (!f)
        return die(cam_path, strerror(errno));
    long long cam[18];
    for (int i = 0; i < 18; i++)
        if (fscanf(f, "%lld", &cam[i]) != 1) {
            fclose(f);
            return die(cam_path, "expected 18 integers: rot[9] (Q30) pos[3] (Q32) fx fy cx cy "
                                 "(Q16) width height");
        }
    fclose(f);
    for (int i = 0; i < 18; i++) {
        const int is_pos = i >= 9 && i < 12, is_size = i >= 16;
        const long long lo = is_pos ? INT64_MIN : is_size ? 0 : INT32_MIN;
        const long long hi = is_pos ? INT64_MAX : is_size ? 65535 : INT32_MAX;
        if (cam[i] < lo || cam[i] > hi)
            return die(cam_path, "a value is out of the range of its cnerf_camera field");
    }

    /* The stream, whole. */
    f = fopen(stream_path, "rb");
    if (!f)
        return die(stream_path, strerror(errno));
    size_t len = 0, cap = 1 << 16;
    uint8_t *buf = malloc(cap);
    for (;;) {
        if (!buf)
            return die(stream_path, "out of memory");
        len += fread(buf + len, 1, cap - len, f);
        if (len < cap)
            break;
        cap *= 2;
        buf = realloc(buf, cap);
    }
    const int read_error = ferror(f);
    fclose(f);
    if (read_error)
        return die(stream_path, "read error");
    if (len > UINT32_MAX)
        return die(stream_path, "larger than 4 GB");

    /* Static buffer sizes from the decoder. A stream that does not parse is embedded anyway
     * with minimal buffers: the firmware then reports the decoder's status. */
    /* The scene to open (CNERF_FW_SCENE in the environment; 0 when unset). */
    long long scene = 0;
    const char *scene_env = getenv("CNERF_FW_SCENE");
    if (scene_env && *scene_env && !parse_int(scene_env, 0, CNERF_MAX_SCENES - 1, &scene))
        return die(scene_env, "CNERF_FW_SCENE must be a scene index in 0..254");
    static cnerf_info info;
    const cnerf_status st = cnerf_peek_scene(buf, len, (uint32_t)scene, &info);
    size_t ws = 8, scratch = 8;
    if (st == CNERF_OK) {
        ws = cnerf_workspace_size(&info);
        scratch = cnerf_render_scratch_size(&info);
    } else {
        fprintf(stderr,
                "cnerf_fw_embed: warning: %s does not parse (%s); embedding it anyway, the "
                "firmware will report the error\n",
                stream_path, cnerf_status_str(st));
    }
    const unsigned long long stride = ((unsigned long long)tile[2] * 3u + 3u) & ~3ull;
    const unsigned long long rgb = stride * (unsigned long long)tile[3];
    if (rgb > (1u << 22))
        return die("tile", "the tile buffer would exceed 4 MB, the RAM of the board");

    f = fopen(out_path, "w");
    if (!f)
        return die(out_path, strerror(errno));
    fprintf(f, "/* Generated by cnerf_fw_embed (platform/cortex-m/fw_render.c). Do not edit.\n"
               " * stream %s\n * camera %s\n */\n",
            stream_path, cam_path);
    fprintf(f, "#define CNERF_FW_STREAM_BYTES %zuu\n", len);
    fprintf(f, "#define CNERF_FW_SCENE %lldu\n", scene);
    fprintf(f, "#define CNERF_FW_HOST_PEEK %d /* cnerf_peek on the build host */\n", (int)st);
    fprintf(f, "#define CNERF_FW_WS_BYTES %zuu\n", ws);
    fprintf(f, "#define CNERF_FW_SCRATCH_BYTES %zuu\n", scratch);
    fprintf(f, "#define CNERF_FW_TILE_X0 %lldu\n#define CNERF_FW_TILE_Y0 %lldu\n", tile[0],
            tile[1]);
    fprintf(f, "#define CNERF_FW_TILE_W %lldu\n#define CNERF_FW_TILE_H %lldu\n", tile[2], tile[3]);
    fprintf(f, "#define CNERF_FW_TILE_STRIDE %lluu /* w * 3 rounded up to 4 bytes */\n", stride);
    fprintf(f, "#define CNERF_FW_HAVE_KNOBS %d\n", have_knobs);
    fprintf(f, "#define CNERF_FW_KNOBS_INIT {%lldu, %lldu, %lldu, %lldu}\n", knobs[0],
            knobs[1], knobs[2], knobs[3]);
    fprintf(f, "#define CNERF_FW_CAMERA_INIT {{");
    for (int i = 0; i < 9; i++) {
        put_ll(f, cam[i]);
        fputs(i < 8 ? ", " : "}, {", f);
    }
    for (int i = 9; i < 12; i++) {
        put_ll(f, cam[i]);
        fputs(i < 11 ? ", " : "}, ", f);
    }
    for (int i = 12; i < 18; i++) {
        put_ll(f, cam[i]);
        fputs(i < 17 ? ", " : "}\n", f);
    }
    fprintf(f, "static const uint8_t cnerf_fw_stream[%zu] = {", len ? len : 1);
    for (size_t i = 0; i < len; i++)
        fprintf(f, "%s0x%02x,", i % 16 ? "" : "\n    ", buf[i]);
    fprintf(f, "%s\n};\n", len ? "" : "0");
    free(buf);
    if (fclose(f) != 0) {
        remove(out_path);
        return die(out_path, "write error");
    }
    return 0;
}

