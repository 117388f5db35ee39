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
     {0.8841, 1.2598, 8.4850, 7.7136, 10.2857, 86.6267, -435.5852, 57.4664,
      2751.4210, -1059.7705, -23.1482, 12104.7750, 1575.1066, 8042.2659},
     0.170},
    {"Cortex-M55", "mve", 160e6,
     {0.2617, 0.1952, 18.0145, 8.5433, 9.0290, 93.4553, -147.2207, 40.5135,
      2283.2506, -578.8259, -39.1221, 12096.3668, 2595.8722, 7496.5230},
     0.385},
    {"Cortex-M7", "dsp", 480e6,
     {0.8841, 1.2598, 8.4812, 7.7180, 10.2887, 86.6202, -423.6551, 57.4655,
      2742.7216, -1051.5158, -22.9955, 12102.8988, 1565.3339, 8042.3054},
     0.170},
    {"Cortex-M33", "dsp", 160e6,
     {0.8841, 1.2598, 8.4854, 7.7213, 10.2881, 86.6259, -428.3172, 57.5222,
      2751.1581, -1059.5842, -23.0734, 12104.5843, 1570.4737, 8051.8540},
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
