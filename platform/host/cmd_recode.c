/* cnerf recode SCENE.cnrf -o OUT.cnrf [--level L | --no-level] [--grid-coding blocks|cells]:
 * a stream re-coded without training (cn_recode): its grids coded by blocks (format 2.3, less
 * decoder RAM) or cell by cell (for 2.2 decoders), its level declared; the same pixels. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_args.h"
#include "cn_file.h"
#include "cn_stream.h"

#define RECODE_USAGE                                                                          \
    "usage: cnerf recode SCENE.cnrf -o OUT.cnrf [--level L | --no-level]\n"                  \
    "       [--grid-coding blocks|cells]\n"                                                   \
    "  -o          the re-coded stream (written whole or not at all)\n"                       \
    "  --level L   declare level L (1..3; docs/bitstream.md): refused when a scene does\n"    \
    "              not fit it\n"                                                              \
    "  --no-level  declare none (by default the stream's own level is kept)\n"               \
    "  --grid-coding blocks (BGRD, format 2.3: the decoder stores the occupied blocks only;\n"\
    "              the default) or cells (GRID: a stream that decoders of 2.2 read)"

int cmd_recode(int argc, char **argv)
{
    const char *out = NULL, *coding = "blocks", *pos[1];
    long level = -1, none = 0;
    int n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &out, 0, 0},
        {"--level", CLI_LONG, &level, 1, CNERF_MAX_LEVELS},
        {"--no-level", CLI_FLAG, &none, 0, 0},
        {"--grid-coding", CLI_STR, &coding, 0, 0},
    };
    if (cli_parse("recode", RECODE_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos,
                  1, &n_pos))
        return 2;
    if (n_pos != 1)
        return cli_usage("recode", "need one stream file\n%s", RECODE_USAGE);
    if (!out)
        return cli_usage("recode", "no output file (-o)\n%s", RECODE_USAGE);
    if (none && level >= 0)
        return cli_usage("recode", "--level and --no-level together\n%s", RECODE_USAGE);
    if (strcmp(coding, "blocks") && strcmp(coding, "cells"))
        return cli_usage("recode", "--grid-coding takes blocks or cells, not '%s'", coding);
    char err[512];
    if (cn_input_add(pos[0], "the stream") < 0)
        return cli_fail("recode", "out of memory");
    if (cn_output_check(out, err, sizeof err))
        return cli_fail("recode", "%s", err);
    uint8_t *buf = NULL;
    size_t len = 0;
    if (cn_read_file_sig(pos[0], CLI_STREAM_SIG, 4, &buf, &len, err, sizeof err))
        return cli_fail("recode", "%s", err);
    cn_buf b = {0};
    int rc = 0;
    if (cn_recode(buf, len, none ? 0 : (int)level, !strcmp(coding, "cells"), &b, err,
                  sizeof err))
        rc = cli_fail("recode", "%s: %s", pos[0], err);
    if (rc == 0 && cn_write_file_atomic(out, b.p, b.n, err, sizeof err))
        rc = cli_fail("recode", "%s", err);
    if (rc == 0)
        printf("wrote %s: %zu bytes (was %zu)\n", out, b.n, len);
    cn_buf_free(&b);
    free(buf);
    return rc;
}
