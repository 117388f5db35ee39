/* cnerf synth: writes a random model of a preset's topology. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_synth.h"

int cmd_synth(int argc, char **argv)
{
    const char *out = NULL, *preset = "tiny";
    unsigned long long seed = 1;
    double spread = 2.0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (i + 1 >= argc)
            return cli_fail("synth", "option %s needs a value", a);
        const char *v = argv[++i];
        char *end = NULL;
        if (!strcmp(a, "-o"))
            out = v;
        else if (!strcmp(a, "--preset"))
            preset = v;
        else if (!strcmp(a, "--seed")) {
            seed = strtoull(v, &end, 10);
            if (*end || !*v)
                return cli_fail("synth", "--seed: '%s' is not a non-negative integer", v);
        } else if (!strcmp(a, "--spread")) {
            spread = strtod(v, &end);
            if (*end || !*v || !(spread >= 0 && spread <= 10000))
                return cli_fail("synth", "--spread: '%s' is not a number in [0, 10000]", v);
        } else
            return cli_fail("synth", "unknown option '%s'", a);
    }
    if (!out)
        return cli_fail("synth", "usage: cnerf synth -o FILE.cnrf [--preset P] [--seed S] "
                                 "[--spread X]");
    cnerf_info hdr;
    if (cn_preset_header(preset, &hdr))
        return cli_fail("synth", "unknown preset '%s' (tiny, small, paper)", preset);
    char err[512], meta[256];
    snprintf(meta, sizeof meta, "encoder=cnerf %s; command=synth; preset=%s; seed=%llu; spread=%g",
             CNERF_VERSION_STRING, preset, seed, spread);
    cn_synth s;
    if (cn_synth_make(&s, &hdr, seed, spread, err, sizeof err))
        return cli_fail("synth", "%s", err);
    s.src.meta = meta;
    cn_buf b = {0};
    int rc = cn_write_stream(&s.src, &b, NULL, err, sizeof err);
    if (rc == 0)
        rc = cn_write_file_atomic(out, b.p, b.n, err, sizeof err);
    size_t n = b.n;
    cn_synth_free(&s);
    cn_buf_free(&b);
    if (rc)
        return cli_fail("synth", "%s", err);
    printf("wrote %s (%zu bytes)\n", out, n);
    return 0;
}
