/* The receiver's cost model (cost_model.h). */
#include "cost_model.h"

#include <string.h>

/* experiments/cost_model.sh on the firmware of each core (-Os; FW_CORE=m4, m55, m7, m33,
 * m0plus): the coefficients it printed, and its largest error over the 79 tiles it measured
 * (docs/decoder.md, Predicted cost). The clock is an example part's (docs/firmware.md). The
 * terms are correlated (an evaluation brings its layers' inputs and outputs with it), so a
 * coefficient is a fit, not the cost of one operation: some are negative. */
const cli_core cli_cores[] = {
    {"Cortex-M4", "dsp", 168e6,
     {0.8841, 1.2595, 8.4811, 13.6304, 10.3048, 86.6472, -467.7507, 57.5821,
      2758.8949, -1067.1328, -23.7185, 12104.8482, 1611.9151, 8002.2648},
     0.170},
    {"Cortex-M55", "mve", 160e6,
     {0.2617, 0.1952, 18.0145, 12.9238, 9.0290, 93.4553, -147.2207, 40.5135,
      2283.2506, -578.8259, -39.1221, 12096.3668, 2595.8722, 7496.5230},
     0.385},
    {"Cortex-M7", "dsp", 480e6,
     {0.8841, 1.2595, 8.4773, 13.6348, 10.3078, 86.6407, -455.8109, 57.5824,
      2750.1796, -1058.8604, -23.5676, 12102.8982, 1601.7929, 8042.0792},
     0.170},
    {"Cortex-M33", "dsp", 160e6,
     {0.8841, 1.2595, 8.4815, 13.6382, 10.3072, 86.6463, -460.4143, 57.6386,
      2758.5648, -1066.8855, -23.6426, 12104.4806, 1607.2943, 8001.8503},
     0.170},
    {"Cortex-M0+", "c", 133e6,
     {8.1073, 7.8676, 30.4719, 59.4421, 46.8736, 131.8212, -3605.9630, 181.9422,
      7337.8753, -3799.7522, -84.3873, 25774.9866, 5598.8136, 15205.3956},
     0.091},
};
const size_t cli_n_cores = sizeof cli_cores / sizeof cli_cores[0];

size_t cli_core_same_work(size_t k)
{
    size_t first = 0;
    while (strcmp(cli_cores[first].set, cli_cores[k].set) != 0)
        first++;
    return first;
}

double cli_cost_instructions(const cli_core *c, const cnerf_render_stats *s,
                             const cnerf_info *I, const cnerf_render_opts *o, double tiles)
{
    const double rays = (double)s->rays, samples = (double)s->samples;
    const double per_ray = (double)o->n_coarse + (I->n_nets > 1 ? (double)o->n_fine : 0.0);
    const double x[CLI_COST_TERMS] = {
        (double)(s->macs - s->list_macs - s->wide_macs - s->s8_macs), (double)s->s8_macs,
        (double)s->list_nz,
        (double)s->wide_macs, (double)s->layer_values, (double)s->exact_rescales,
        (double)s->evals, (double)s->evals * I->in_pos, samples,
        I->coord == CNERF_COORD_CONTRACT ? samples : 0.0, rays * per_ray,
        I->coord == CNERF_COORD_NDC ? rays : 0.0, rays, tiles};
    double ins = 0;
    for (int i = 0; i < CLI_COST_TERMS; i++)
        ins += c->coef[i] * x[i];
    return ins;
}
