/* cnerf synth: writes a random model of a preset's (or a custom) topology. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_file.h"
#include "cli.h"
#include "cli_args.h"
#include "cn_pipeline.h"
#include "cn_synth.h"

#define SYNTH_USAGE                                                                          \
    "usage: cnerf synth -o FILE.cnrf [--preset tiny|small|paper] [--seed S] [--spread X]\n" \
    "       [--depth D] [--width W] [--view-width V] [--coarse N] [--fine N] [--lpos L]\n"  \
    "       [--ldir L] [--ndc|--contract] [--black] [--grid G [--grid-shape ball|full|empty]]\n"     \
    "       [--units U1,U2,...[:V]] [--scenes N [--shift-spread X] [--shift-gain G]]\n"   \
    "       [--level L]"

/* --units "U1,...,UD[:V]": units of each trunk layer (and of the view layer) of every
 * network, as a pruned stream's UNIT chunk gives them. Returns 0 or 1 (error printed). */
static int parse_units(const char *list, cnerf_info *hdr)
{
    const cnerf_net_info *N0 = &hdr->net[0];
    uint16_t u[CNERF_MAX_DEPTH + 1] = {0};
    unsigned n = 0, view = 0;
    const char *p = list;
    for (;;) {
        char *end;
        const long v = strtol(p, &end, 10);
        if (end == p || v < 1 || v > CNERF_MAX_WIDTH || n > CNERF_MAX_DEPTH)
            return cli_usage("synth", "--units '%s': expected U1,...,U%u[:V] with each U in "
                            "1..%u", list, N0->depth, N0->width);
        u[n++] = (uint16_t)v;
        if (*end == ',' && !view) {
            p = end + 1;
        } else if (*end == ':' && !view) {
            view = n;
            p = end + 1;
        } else if (*end == 0) {
            break;
        } else {
            return cli_usage("synth", "--units '%s': unexpected '%c'", list, *end);
        }
    }
    const unsigned trunk = view ? view : n;
    if (trunk != N0->depth || (view && n != trunk + 1))
        return cli_usage("synth", "--units '%s': %u trunk layers given, the networks have %u",
                        list, trunk, N0->depth);
    for (unsigned k = 0; k < hdr->n_nets; k++) {
        cnerf_net_info *N = &hdr->net[k];
        for (unsigned i = 0; i < trunk; i++) {
            if (u[i] > N->width)
                return cli_usage("synth", "--units: %u units in trunk layer %u, more than the "
                                "width %u", u[i], i, N->width);
            N->units[i] = u[i];
        }
        if (view && (!N->view_width || u[trunk] > N->view_width))
            return cli_usage("synth", "--units: %u view units, the view width is %u", u[trunk],
                            N->view_width);
        N->view_units = view ? u[trunk] : 0;
    }
    return 0;
}

/* The preset's topology with the options given (-1: not given). */
static void set_topology(cnerf_info *hdr, long depth, long width, long view, long coarse,
                         long fine, long lpos, long ldir)
{
    for (unsigned n = 0; n < CNERF_MAX_NETS; n++) {
        cnerf_net_info *N = &hdr->net[n];
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
        hdr->n_coarse = (uint16_t)coarse;
    if (fine >= 0)
        hdr->n_fine = (uint16_t)fine;
    hdr->n_nets = hdr->n_fine ? 2 : 1;
    if (lpos >= 0)
        hdr->l_pos = (uint8_t)lpos;
    if (ldir >= 0)
        hdr->l_dir = (uint8_t)ldir;
}

/* An occupancy grid of g^3 cells: the cells whose centre lies within 0.7 of the half-width
 * from the box's centre (in cell units on each axis) for "ball", all for "full", none for
 * "empty". NULL when out of memory. */
static uint8_t *synth_grid(size_t g, const char *shape)
{
    const size_t cells = g * g * g;
    uint8_t *occ = malloc(cells);
    for (size_t i = 0; occ && i < cells; i++) {
        const double x = (double)(i % g) + 0.5 - 0.5 * (double)g,
                     y = (double)(i / g % g) + 0.5 - 0.5 * (double)g,
                     z = (double)(i / g / g) + 0.5 - 0.5 * (double)g, r = 0.35 * (double)g;
        occ[i] = !strcmp(shape, "full") ||
                 (!strcmp(shape, "ball") && x * x + y * y + z * z <= r * r);
    }
    return occ;
}

int cmd_synth(int argc, char **argv)
{
    const char *out = NULL, *preset = "tiny";
    uint64_t seed = 1;
    double spread = 2.0;
    long depth = -1, width = -1, view = -1, coarse = -1, fine = -1, lpos = -1, ldir = -1;
    long grid = 0;
    const char *shape = "ball", *units = NULL;
    int ndc = 0, contract = 0, black = 0, n_pos;
    long scenes = 0; /* 0: a one-scene stream; N: a set of N scenes with shared shifts */
    double shift_spread = 1.0, shift_gain = 0.5;
    long level = 0; /* the level declared (levl), 0 for none */
    const cli_opt opts[] = {
        {"-o", CLI_STR, &out, 0, 0},
        {"--preset", CLI_STR, &preset, 0, 0},
        {"--seed", CLI_U64, &seed, 0, 0},
        {"--spread", CLI_DOUBLE, &spread, 0, 40000},
        {"--depth", CLI_LONG, &depth, 1, CNERF_MAX_DEPTH},
        {"--width", CLI_LONG, &width, 1, CNERF_MAX_WIDTH},
        {"--view-width", CLI_LONG, &view, 0, CNERF_MAX_VIEW_WIDTH},
        {"--coarse", CLI_LONG, &coarse, 1, CNERF_MAX_SAMPLES},
        {"--fine", CLI_LONG, &fine, 0, CNERF_MAX_SAMPLES},
        {"--lpos", CLI_LONG, &lpos, 0, CNERF_MAX_L_POS},
        {"--ldir", CLI_LONG, &ldir, 0, CNERF_MAX_L_DIR},
        {"--ndc", CLI_FLAG, &ndc, 0, 0},
        {"--contract", CLI_FLAG, &contract, 0, 0},
        {"--black", CLI_FLAG, &black, 0, 0},
        {"--grid", CLI_LONG, &grid, 0, CNERF_MAX_GRID},
        {"--grid-shape", CLI_STR, &shape, 0, 0},
        {"--units", CLI_STR, &units, 0, 0},
        {"--scenes", CLI_LONG, &scenes, 1, CNERF_MAX_SCENES},
        {"--shift-spread", CLI_DOUBLE, &shift_spread, 0, 40000},
        {"--shift-gain", CLI_DOUBLE, &shift_gain, -1e6, 1e6},
        {"--level", CLI_LONG, &level, 1, CNERF_MAX_LEVELS},
    };
    if (cli_parse("synth", SYNTH_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], NULL, 0,
                  &n_pos))
        return 2;
    if (!out)
        return cli_usage("synth", "no output file (-o)\n%s", SYNTH_USAGE);
    if (strcmp(shape, "ball") && strcmp(shape, "full") && strcmp(shape, "empty"))
        return cli_usage("synth", "--grid-shape takes ball, full or empty, not '%s'", shape);
    cnerf_info hdr;
    if (cn_preset_header(preset, &hdr))
        return cli_usage("synth", "unknown preset '%s' (tiny, small, paper)", preset);
    set_topology(&hdr, depth, width, view, coarse, fine, lpos, ldir);
    if (ndc && contract)
        return cli_usage("synth", "--ndc and --contract exclude each other");
    if (ndc) {
        hdr.coord = CNERF_COORD_NDC;
        hdr.near_q16 = 0;
        hdr.far_q16 = CNERF_Q16_ONE;
    }
    if (contract) { /* the bounds doubled: the inner cube is the usual box (format 2.2) */
        hdr.coord = CNERF_COORD_CONTRACT;
        for (int a = 0; a < 6; a++)
            hdr.aabb_q16[a] *= 2;
    }
    if (black)
        memset(hdr.background, 0, sizeof hdr.background);
    if (units && parse_units(units, &hdr))
        return 2;
    char err[512], meta[512];
    snprintf(meta, sizeof meta, "encoder=cnerf %s; command=synth; preset=%s; seed=%llu; spread=%g",
             CNERF_VERSION_STRING, preset, (unsigned long long)seed, spread);
    uint8_t *occ = NULL;
    if (grid > 0 && !(occ = synth_grid((size_t)grid, shape)))
        return cli_fail("synth", "out of memory");
    /* Scene m of a set: seed + m, its bounds 1 + (m mod 4) / 4 times as wide and its
     * background's channels changed with m, so that the scenes differ where a decoder could
     * mix them up. */
    const unsigned M = scenes ? (unsigned)scenes : 1u;
    cn_synth *syn = calloc(M, sizeof *syn);
    cn_stream_src *src = calloc(M, sizeof *src);
    cn_synth_shift sh;
    int have_shift = 0, rc = 0;
    unsigned made = 0;
    if (!syn || !src)
        rc = -1, snprintf(err, sizeof err, "out of memory");
    for (; rc == 0 && made < M; made++) {
        cnerf_info h = hdr;
        const double grow = 1.0 + (double)(made % 4) / 4.0;
        for (unsigned a = 0; a < 6 && hdr.coord != CNERF_COORD_NDC; a++)
            h.aabb_q16[a] = (int32_t)lround(hdr.aabb_q16[a] * grow);
        for (unsigned c = 0; c < 3; c++)
            h.background[c] = (uint8_t)(hdr.background[c] ^ ((37u * made * (c + 1u)) & 0xFFu));
        if (cn_synth_make(&syn[made], &h, seed + made, spread, err, sizeof err)) {
            rc = -1;
            break;
        }
        src[made] = syn[made].src;
        src[made].meta = meta;
        src[made].grid = occ;
        src[made].grid_g = occ ? (uint32_t)grid : 0;
    }
    if (rc == 0 && scenes) {
        rc = cn_synth_shift_make(&sh, &syn[0], seed ^ 0x5348465475ull, shift_spread, shift_gain,
                                 err, sizeof err);
        have_shift = rc == 0;
    }
    cn_encoded enc;
    memset(&enc, 0, sizeof enc);
    const cn_encode_job job = {.src = src, .shift_src = scenes ? sh.src : NULL, .n = M,
                               .seed = seed, .level = (unsigned)level};
    if (rc == 0)
        rc = cn_encode_finish(&job, &enc, err, sizeof err);
    const cn_buf b = enc.stream;
    if (rc == 0)
        rc = cn_write_file_atomic(out, b.p, b.n, err, sizeof err);
    size_t n = b.n;
    for (unsigned m = 0; syn && m < made; m++)
        cn_synth_free(&syn[m]);
    if (have_shift)
        cn_synth_shift_free(&sh);
    free(syn);
    free(src);
    cn_encoded_free(&enc);
    free(occ);
    if (rc)
        return cli_fail("synth", "%s", err);
    if (scenes)
        printf("wrote %s (%zu bytes, %u scenes)\n", out, n, M);
    else
        printf("wrote %s (%zu bytes)\n", out, n);
    return 0;
}
