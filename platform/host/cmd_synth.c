/* cnerf synth: writes a random model of a preset's (or a custom) topology. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_synth.h"

#define SYNTH_USAGE                                                                          \
    "usage: cnerf synth -o FILE.cnrf [--preset tiny|small|paper] [--seed S] [--spread X]\n" \
    "       [--depth D] [--width W] [--view-width V] [--coarse N] [--fine N] [--lpos L]\n"  \
    "       [--ldir L] [--ndc] [--black]"

/* Parses an unsigned integer option value in [lo, hi]; returns 0 or prints an error. */
static int parse_uint(const char *opt, const char *v, unsigned long lo, unsigned long hi,
                      unsigned long *out)
{
    char *end = NULL;
    unsigned long x = strtoul(v, &end, 10);
    if (!*v || *end || *v == '-' || x < lo || x > hi) {
        cli_fail("synth", "%s: '%s' is not an integer in [%lu, %lu]", opt, v, lo, hi);
        return -1;
    }
    *out = x;
    return 0;
}

int cmd_synth(int argc, char **argv)
{
    const char *out = NULL, *preset = "tiny";
    unsigned long long seed = 1;
    double spread = 2.0;
    long depth = -1, width = -1, view = -1, coarse = -1, fine = -1, lpos = -1, ldir = -1;
    int ndc = 0, black = 0;
    struct {
        const char *name;
        long *dst;
        unsigned long lo, hi;
    } ints[] = {{"--depth", &depth, 1, CNERF_MAX_DEPTH},
                {"--width", &width, 1, CNERF_MAX_WIDTH},
                {"--view-width", &view, 0, CNERF_MAX_VIEW_WIDTH},
                {"--coarse", &coarse, 1, CNERF_MAX_SAMPLES},
                {"--fine", &fine, 0, CNERF_MAX_SAMPLES},
                {"--lpos", &lpos, 0, CNERF_MAX_L_POS},
                {"--ldir", &ldir, 0, CNERF_MAX_L_DIR}};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--ndc")) {
            ndc = 1;
            continue;
        }
        if (!strcmp(a, "--black")) {
            black = 1;
            continue;
        }
        if (i + 1 >= argc)
            return cli_fail("synth", "option %s needs a value\n%s", a, SYNTH_USAGE);
        const char *v = argv[++i];
        char *end = NULL;
        int known = 0;
        for (size_t j = 0; j < sizeof ints / sizeof ints[0]; j++)
            if (!strcmp(a, ints[j].name)) {
                unsigned long x;
                if (parse_uint(a, v, ints[j].lo, ints[j].hi, &x))
                    return 1;
                *ints[j].dst = (long)x;
                known = 1;
            }
        if (known)
            continue;
        if (!strcmp(a, "-o"))
            out = v;
        else if (!strcmp(a, "--preset"))
            preset = v;
        else if (!strcmp(a, "--seed")) {
            seed = strtoull(v, &end, 10);
            if (*end || !*v || *v == '-')
                return cli_fail("synth", "--seed: '%s' is not a non-negative integer", v);
        } else if (!strcmp(a, "--spread")) {
            spread = strtod(v, &end);
            if (*end || !*v || !(spread >= 0 && spread <= 40000))
                return cli_fail("synth", "--spread: '%s' is not a number in [0, 40000]", v);
        } else
            return cli_fail("synth", "unknown option '%s'\n%s", a, SYNTH_USAGE);
    }
    if (!out)
        return cli_fail("synth", "no output file (-o)\n%s", SYNTH_USAGE);
    cnerf_info hdr;
    if (cn_preset_header(preset, &hdr))
        return cli_fail("synth", "unknown preset '%s' (tiny, small, paper)", preset);
    for (unsigned n = 0; n < CNERF_MAX_NETS; n++) {
        cnerf_net_info *N = &hdr.net[n];
        if (depth > 0) {
            N->depth = (uint8_t)depth;
            N->skip = depth >= 3 ? (uint8_t)(depth / 2) : CNERF_NO_SKIP;
            if (N->skip != CNERF_NO_SKIP && N->skip + 1 >= depth)
                N->skip = (uint8_t)(depth - 2);
        }
        if (width > 0)
            N->width = (uint16_t)width;
        if (view >= 0)
            N->view_width = (uint16_t)view;
    }
    if (coarse > 0)
        hdr.n_coarse = (uint16_t)coarse;
    if (fine >= 0)
        hdr.n_fine = (uint16_t)fine;
    hdr.n_nets = hdr.n_fine ? 2 : 1;
    if (lpos >= 0)
        hdr.l_pos = (uint8_t)lpos;
    if (ldir >= 0)
        hdr.l_dir = (uint8_t)ldir;
    if (ndc) {
        hdr.coord = CNERF_COORD_NDC;
        hdr.near_q16 = 0;
        hdr.far_q16 = CNERF_Q16_ONE;
    }
    if (black)
        memset(hdr.background, 0, sizeof hdr.background);
    char err[512], meta[512];
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
