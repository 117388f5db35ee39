/* Rate control's measurements and its hook into the training loop (cn_rate.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_grid.h"
#include "cn_pipeline.h"
#include "cn_rate.h"

int cn_stream_size(const cn_model *m, uint64_t seed, int prune, size_t *bytes, char *err,
                   size_t errlen)
{
    cn_encoded enc;
    const cn_encode_job job = {.measured = m, .n = 1, .seed = seed,
                               .scale_points = CN_RC_SCALE_POINTS, .prune = prune};
    const int rc = cn_encode_finish(&job, &enc, err, errlen);
    if (rc == 0)
        *bytes = enc.stream.n;
    cn_encoded_free(&enc);
    return rc;
}

int cn_stream_floor(cn_model *m, uint64_t seed, size_t *bytes, char *err, size_t errlen)
{
    const size_t n = m->off_ab; /* latents and biases, layer by layer, come first */
    float *keep = malloc(sizeof(float) * (n ? n : 1));
    if (!keep) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    memcpy(keep, m->params, sizeof(float) * n);
    for (unsigned l = 0; l < m->topo.n_layers; l++) {
        const size_t k = (size_t)m->topo.layer[l].n_in * m->topo.layer[l].n_out;
        memset(m->params + m->layer[l].w, 0, sizeof(float) * k);
        for (unsigned j = 0; j < m->topo.layer[l].n_out; j++)
            m->params[m->layer[l].b + j] = 0.5f;
    }
    const int rc = cn_stream_size(m, seed, 1, bytes, err, errlen);
    memcpy(m->params, keep, sizeof(float) * n);
    free(keep);
    return rc;
}

/* Rate control's work at a step: the grid's bytes once (twice), and lambda every rc.every. */
static int rate_control_step(cn_trainer *t)
{
    if (!t->rate_control)
        return 0;
    cn_ratectl *rc = &t->rc;
    cn_model *m = &t->model;
    const double at = rc->grid_done ? CN_RC_GRID_AGAIN : CN_RC_GRID_AT;
    const int grid_now = rc->grid_done < 2 && t->rc_grid_g != 0 &&
                         t->step >= rc->start + (long)(at * (double)(rc->iters - rc->start));
    if (!grid_now && (t->step - rc->start) % rc->every != 0)
        return 0;
    /* Within opts.average's window, the size of the model the run will write: the mean. */
    const int mean = t->avg_n > 0;
    if (mean)
        cn_trainer_swap_mean(t, 1);
    size_t bytes;
    int err = cn_stream_size(m, t->opts.seed, t->rc_prune, &bytes, t->err, sizeof t->err);
    if (!err && grid_now) {
        cn_grid_choice g;
        memset(&g, 0, sizeof g);
        err = cn_grid_choose(m, t->ds, bytes, t->rc_grid_g, NULL, &g, NULL, t->err, sizeof t->err);
        if (!err) {
            rc->reserved += (double)g.bytes - rc->grid;
            rc->grid = (double)g.bytes;
            rc->grid_done++;
        }
        cn_grid_choice_free(&g);
    }
    if (mean)
        cn_trainer_swap_mean(t, 0);
    if (err)
        return -1;
    t->opts.lambda = cn_ratectl_update(rc, t->step, (double)bytes);
    return 0;
}

void cn_trainer_rate_control(cn_trainer *t, double target_bytes, double reserved_bytes,
                             cn_rc_scheme scheme, int grid_g, int prune)
{
    cn_ratectl *rc = &t->rc;
    memset(rc, 0, sizeof *rc);
    rc->scheme = scheme;
    rc->target = target_bytes;
    rc->reserved = reserved_bytes;
    rc->every = 10;
    rc->start = t->step;
    rc->iters = t->opts.iters;
    rc->lambda_unit = cn_trainer_lambda_unit(t);
    t->rate_control = 1;
    t->rc_grid_g = grid_g;
    t->rc_prune = prune;
    t->step_hook = rate_control_step;
}
