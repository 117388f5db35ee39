/* cnerf pack SCENE.cnrf --target CORE -o scene.bin: the workspace a device would decode, packed
 * for its core, to be read in place from flash (cnerf_open_packed; docs/decoder.md,
 * "Rendering from flash"). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_args.h"
#include "cn_file.h"
#include "cn_reader.h"
#include "cnerf/tools.h"

#define PACK_USAGE                                                                            \
    "usage: cnerf pack SCENE.cnrf --target CORE -o IMAGE [--scene I]\n"                      \
    "  --target   the core whose decoder reads the image: cortex-m0, cortex-m0plus,\n"        \
    "             cortex-m3, cortex-m4, cortex-m7, cortex-m33, cortex-m55, aarch64, x86-64\n"  \
    "             (with AVX2), wasm32 (with SIMD), or portable (a CNERF_PORTABLE build)\n"    \
    "  -o         the image (written whole or not at all)\n"                                 \
    "  --scene I  a stream of several scenes: the scene to pack (0)"

/* The cores by name and the kernel set their decoder builds choose (docs/decoder.md,
 * "Kernels"). */
static const struct {
    const char *core, *set;
} targets[] = {{"cortex-m0", "c"},     {"cortex-m0plus", "c"}, {"cortex-m3", "c"},
               {"cortex-m4", "dsp"},   {"cortex-m7", "dsp"},   {"cortex-m33", "dsp"},
               {"cortex-m55", "mve"},  {"aarch64", "neon"},    {"x86-64", "avx2"},
               {"wasm32", "simd128"},  {"portable", "c"}};

int cmd_pack(int argc, char **argv)
{
    const char *out = NULL, *target = NULL, *pos[1];
    long scene = 0;
    int n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &out, 0, 0},
        {"--target", CLI_STR, &target, 0, 0},
        {"--scene", CLI_LONG, &scene, 0, CNERF_MAX_SCENES - 1},
    };
    if (cli_parse("pack", PACK_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos, 1,
                  &n_pos))
        return 2;
    if (n_pos != 1)
        return cli_usage("pack", "need one stream file\n%s", PACK_USAGE);
    if (!out)
        return cli_usage("pack", "no output file (-o)\n%s", PACK_USAGE);
    if (!target)
        return cli_usage("pack", "no --target: the image is made for one kind of core\n%s",
                         PACK_USAGE);
    const char *set = NULL;
    for (size_t i = 0; i < sizeof targets / sizeof targets[0]; i++)
        if (!strcmp(target, targets[i].core))
            set = targets[i].set;
    if (!set)
        return cli_usage("pack", "unknown --target '%s'\n%s", target, PACK_USAGE);
    const uint16_t one = 1;
    if (*(const unsigned char *)&one != 1)
        return cli_fail("pack", "this machine is big-endian and every --target is "
                                "little-endian: pack on a little-endian machine");
    char err[512];
    if (cn_input_add(pos[0], "the stream") < 0)
        return cli_fail("pack", "out of memory");
    if (cn_output_check(out, err, sizeof err))
        return cli_fail("pack", "%s", err);
    uint8_t *buf = NULL;
    size_t len = 0;
    if (cn_read_file_sig(pos[0], CLI_STREAM_SIG, 4, &buf, &len, err, sizeof err))
        return cli_fail("pack", "%s", err);
    cnerf_info *info = malloc(sizeof *info);
    cnerf_decoder *dec = malloc(sizeof *dec);
    void *ws = NULL;
    uint8_t *image = NULL;
    size_t ws_n = 0, n = 0;
    int rc = !info || !dec ? cli_fail("pack", "out of memory") : 0;
    cnerf_status st = CNERF_OK;
    if (rc == 0 && (st = cnerf_peek_scene(buf, len, (uint32_t)scene, info)) != CNERF_OK)
        rc = st == CNERF_E_ARG
                 ? cli_fail("pack", "%s: no scene %ld: the stream has %u", pos[0], scene,
                            info->n_scenes)
                 : cli_fail("pack", "%s: %s (%d): not a valid cnerf stream", pos[0],
                            cnerf_status_str(st), (int)st);
    if (rc == 0) {
        ws_n = cnerf_workspace_size(info);
        ws = aligned_alloc(CNERF_WS_ALIGN, (ws_n + 7) & ~(size_t)7);
        if (!ws)
            rc = cli_fail("pack", "out of memory");
    }
    if (rc == 0 && (st = cnerf_pack(dec, buf, len, (uint32_t)scene, set, ws, ws_n, NULL, 0,
                                    &n)) != CNERF_OK)
        rc = cli_fail("pack", "%s: %s (%d): the stream does not decode", pos[0],
                      cnerf_status_str(st), (int)st);
    if (rc == 0 && !(image = malloc(n)))
        rc = cli_fail("pack", "out of memory");
    if (rc == 0 && (st = cnerf_pack(dec, buf, len, (uint32_t)scene, set, ws, ws_n, image, n,
                                    &n)) != CNERF_OK)
        rc = cli_fail("pack", "%s: %s (%d)", pos[0], cnerf_status_str(st), (int)st);
    if (rc == 0 && cn_write_file_atomic(out, image, n, err, sizeof err))
        rc = cli_fail("pack", "%s", err);
    if (rc == 0)
        printf("wrote %s: %zu bytes for %s (kernels %s): header %zu, workspace %u, stream %zu; "
               "the device's RAM is then the render scratch (%zu bytes), the decoder struct "
               "and the stack, without the %zu-byte workspace\n",
               out, n, target, set, (size_t)cn_le32(image + 28), cn_le32(image + 32),
               len, cnerf_render_scratch_size(info), ws_n);
    free(image);
    free(ws);
    free(dec);
    free(info);
    free(buf);
    return rc;
}
