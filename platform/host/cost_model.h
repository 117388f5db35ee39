/* The receiver's cost model: a device's instructions for a render, from the work a host
 * counts for that device (cnerf_open_as, cnerf_render_stats). The coefficients were fitted
 * by experiments/cost_model.sh to QEMU's counts on the conformance vectors; docs/decoder.md
 * (Predicted cost) gives the fit and its error. */
#ifndef CNERF_HOST_COST_MODEL_H
#define CNERF_HOST_COST_MODEL_H

#include <stddef.h>

#include "cnerf/cnerf.h"

#define CLI_COST_TERMS 14

typedef struct cli_core {
    const char *name; /* "Cortex-M4" */
    const char *set;  /* its kernel set, for cnerf_open_as: "dsp" */
    double hz;        /* the clock an estimated time assumes */
    /* instructions per term of the work (cli_cost_instructions, experiments/cost_model.sh's
     * columns): packed multiply-accumulate over int16 latents, over int8 latents, non-zero
     * latent of a list layer, int64
     * multiply-accumulate, layer input or output, exact rescale, network evaluation,
     * positional-encoding value, sample position, sample position of a contracted stream,
     * sample placed, ray of an NDC stream, ray, tile */
    double coef[CLI_COST_TERMS];
    double error;     /* the largest relative error of the fit over the vectors' tiles */
} cli_core;

/* The cores modelled (at most CLI_MAX_CORES), and how many. */
#define CLI_MAX_CORES 5
extern const cli_core cli_cores[];
extern const size_t cli_n_cores;

/* The first modelled core with core k's kernel set: cores of one set do the same work
 * (cnerf_open_as takes the set), so a host counts it once per set. */
size_t cli_core_same_work(size_t k);

/* The instructions core c would take for the work s (counted with c's forms, cnerf_open_as)
 * of stream I rendered with options o in `tiles` calls of cnerf_render_tile. */
double cli_cost_instructions(const cli_core *c, const cnerf_render_stats *s,
                             const cnerf_info *I, const cnerf_render_opts *o, double tiles);

#endif /* CNERF_HOST_COST_MODEL_H */
