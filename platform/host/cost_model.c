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
     {0.8787, 9.0898, 13.6888, 11.1913, 83.4921, -1752.0232, 52.6051, 3598.6595, -2102.8230,
      -30.1103, 12068.1223, 2014.4587, 7998.0225},
     0.184},
    {"Cortex-M55", "mve", 160e6,
     {0.1972, 17.6628, 12.6257, 9.1003, 94.3781, -265.7708, 40.0567, 2340.1876, -636.6981,
      -38.2441, 12095.3726, 2539.8061, 7463.7881},
     0.384},
    {"Cortex-M7", "dsp", 480e6,
     {0.8787, 9.0845, 13.6970, 11.1971, 83.4883, -1736.5541, 52.6263, 3590.1898, -2094.5479,
      -29.9337, 12066.8701, 2002.9994, 8037.8275},
     0.184},
    {"Cortex-M33", "dsp", 160e6,
     {0.8787, 9.0902, 13.6963, 11.1936, 83.4918, -1745.6179, 52.6679, 3599.0397, -2103.2591,
      -30.0576, 12068.7882, 2011.0456, 8047.9876},
     0.184},
    {"Cortex-M0+", "c", 133e6,
     {8.1170, 27.2966, 61.8015, 47.0557, 130.5467, -9920.3315, 198.8276, 12445.7222, -9329.3021,
      -69.3625, 25773.7299, 4618.8330, 15198.3480},
     0.094},
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
        (double)(s->macs - s->list_macs - s->wide_macs), (double)s->list_nz,
        (double)s->wide_macs, (double)s->layer_values, (double)s->exact_rescales,
        (double)s->evals, (double)s->evals * I->in_pos, samples,
        I->coord == CNERF_COORD_CONTRACT ? samples : 0.0, rays * per_ray,
        I->coord == CNERF_COORD_NDC ? rays : 0.0, rays, tiles};
    double ins = 0;
    for (int i = 0; i < CLI_COST_TERMS; i++)
        ins += c->coef[i] * x[i];
    return ins;
}
