/* cnerf info FILE.cnrf */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_report.h"
#include "cn_stream.h"

#define INFO_USAGE                                                                            \
    "usage: cnerf info [--check] FILE.cnrf\n"                                                \
    "  --check  also decode every payload (cnerf_open), as a device would; without it the\n" \
    "           structure and every chunk's CRC are checked, not the coded latents"

/* cnerf_open into a workspace of its own: decodes every payload. */
static cnerf_status open_all(const uint8_t *buf, size_t len, const cnerf_info *info)
{
    const size_t n = cnerf_workspace_size(info);
    void *ws = aligned_alloc(CNERF_WS_ALIGN, (n + 7) & ~(size_t)7);
    cnerf_decoder *dec = malloc(sizeof *dec);
    cnerf_status st = ws && dec ? cnerf_open(dec, buf, len, ws, n) : CNERF_E_WS_SMALL;
    free(ws);
    free(dec);
    return st;
}

int cmd_info(int argc, char **argv)
{
    int check = 0;
    if (argc >= 2 && !strcmp(argv[1], "--check")) {
        check = 1;
        argc--, argv++;
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
    if (cn_read_file(argv[1], &buf, &len, err, sizeof err))
        return cli_fail("info", "%s", err);
    cnerf_info *info = malloc(sizeof *info);
    if (!info) {
        free(buf);
        return cli_fail("info", "out of memory");
    }
    cnerf_status st = cnerf_peek(buf, len, info);
    if (st == CNERF_OK && check)
        st = open_all(buf, len, info);
    int rc = 0;
    if (st != CNERF_OK)
        rc = cli_fail("info", "%s: %s (%d): not a valid cnerf stream%s", argv[1],
                      cnerf_status_str(st), (int)st,
                      check ? " (every payload decoded)" : "");
    else
        cn_print_info(stdout, argv[1], buf, info);
    if (rc == 0 && check)
        printf("check: every payload decodes (cnerf_open)\n");
    free(info);
    free(buf);
    return rc;
}
