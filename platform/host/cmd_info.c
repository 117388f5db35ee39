/* cnerf info FILE.cnrf */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_report.h"
#include "cn_stream.h"

#define INFO_USAGE "usage: cnerf info FILE.cnrf"

int cmd_info(int argc, char **argv)
{
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
    int rc = 0;
    if (st != CNERF_OK)
        rc = cli_fail("info", "%s: %s (%d): not a valid cnerf stream", argv[1],
                      cnerf_status_str(st), (int)st);
    else
        cn_print_info(stdout, argv[1], buf, info);
    free(info);
    free(buf);
    return rc;
}
