/* The encode pipeline (cn_pipeline.h): export, scales, pruning, writing and the grid, once. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_buf.h"
#include "cn_export.h"
#include "cn_pipeline.h"
#include "cn_scales.h"

/* Prefixes err with "scene M: " (m < n of a set) or "shifts: " (m == n). */
static int in_set(char *err, size_t errlen, unsigned m, unsigned n)
{
    if (n > 1) {
        char why[512];
        snprintf(why, sizeof why, "%s", err);
        if (m < n)
            snprintf(err, errlen, "scene %u: %s", m, why);
        else
            snprintf(err, errlen, "shifts: %s", why);
    }
    return -1;
}

/* The shared shifts as the writer takes them: the shift model's exported latents, gains and
 * tables. */
static void shift_sources(const cn_export *es, unsigned n_layers, cn_shift_src *sh)
{
    for (unsigned l = 0; l < n_layers; l++) {
        const cn_layer_src *L = &es->src.layer[l];
        sh[l] = (cn_shift_src){L->k, L->a_m, L->a_e, L->pmf, L->pmf_kmin, L->pmf_n};
    }
}

static int export_models(const cn_encode_job *j, cn_export *e, unsigned *made,
                         cn_shift_src *sh, char *err, size_t errlen)
{
    const unsigned n = j->n;
    if (n > 1) {
        if (!j->shift)
            return cn_fail(err, errlen, "a set of %u scenes needs its shifts' model", n);
        if (cn_model_snap(j->shift, err, errlen) ||
            cn_export_compressed(j->shift, NULL, &e[n], err, errlen))
            return in_set(err, errlen, n, n);
        shift_sources(&e[n], j->shift->topo.n_layers, sh);
    }
    for (unsigned m = 0; m < n; m++) {
        if (cn_model_snap(j->models[m], err, errlen) ||
            cn_export_compressed(j->models[m], m ? NULL : j->meta, &e[m], err, errlen))
            return in_set(err, errlen, m, n);
        *made = m + 1;
    }
    /* The grid is measured on the kernels of the exported numbers (the last step's update,
     * and a resumed run's parameters, are not materialized yet). */
    if (n > 1)
        cn_model_materialize(j->shift);
    for (unsigned m = 0; m < n; m++)
        cn_model_materialize(j->models[m]);
    return 0;
}

int cn_encode_finish(const cn_encode_job *j, cn_encoded *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    const unsigned n = j->n;
    if (n < 1 || n > CNERF_MAX_SCENES)
        return cn_fail(err, errlen, "%u scenes: a stream holds 1 to %u", n, CNERF_MAX_SCENES);
    cn_export *e = calloc(n + 1, sizeof *e); /* the scenes', and the shifts' at [n] */
    cn_stream_src *copies = calloc(n, sizeof *copies);
    cn_shift_src sh[CNERF_MAX_LAYERS];
    const cn_shift_src *shift = NULL;
    cn_stream_src *S = NULL; /* the sources the steps work on */
    unsigned made = 0;
    int rc = e && copies ? 0 : cn_fail(err, errlen, "out of memory");
    /* 1. Export. */
    if (rc == 0 && j->models) {
        rc = export_models(j, e, &made, sh, err, errlen);
        shift = n > 1 ? sh : NULL;
        if (n == 1) {
            S = &e[0].src; /* pruning works on the export itself */
        } else {
            for (unsigned m = 0; m < n; m++)
                copies[m] = e[m].src;
            S = copies;
        }
    } else if (rc == 0 && (j->measured || j->float_model)) {
        if (n != 1)
            rc = cn_fail(err, errlen, "one model, one scene");
        else if (j->measured)
            rc = cn_export_compressed(j->measured, j->meta, &e[0], err, errlen);
        else
            rc = cn_export_quantized(j->float_model, j->bits, j->meta, &e[0], err, errlen);
        made = rc == 0;
        if (rc == 0 && j->float_model && j->drop_coarse_color && j->float_model->topo.n_nets > 1)
            cn_export_drop_color(&e[0], 0);
        S = &e[0].src;
    } else if (rc == 0) {
        if (!j->src)
            rc = cn_fail(err, errlen, "nothing to encode");
        S = j->src;
        shift = j->shift_src;
    }
    /* 2. The input scales, then 3. the dead units, whose proof holds at those scales
     * (removing them changes no other activation). */
    if (rc == 0) {
        if (n == 1 && !shift)
            rc = cn_choose_scales_points(S, j->seed, j->scale_points ? j->scale_points
                                                                      : CN_SCALE_POINTS,
                                         NULL, err, errlen);
        else
            rc = cn_choose_scales_set(S, n, shift, j->seed, NULL, err, errlen);
    }
    if (rc == 0 && j->prune && n == 1 && made) {
        rc = cn_export_prune(&e[0], &out->prune, err, errlen);
        if (rc == 0 && j->report)
            j->report(j->report_ctx, CN_STAGE_PRUNED, out);
    }
    /* 4. The stream, at its level. */
    if (rc == 0 && j->level)
        S[0].hdr.level = (uint8_t)j->level;
    if (rc == 0)
        rc = cn_write_set(S, n, shift, &out->stream, n == 1 ? &out->rep : NULL, NULL, err,
                          errlen);
    out->bytes_without_grid = out->stream.n;
    /* 5. A grid per scene, each paying for itself against its share of the stream. */
    if (rc == 0 && j->grid_g != 0 && j->models) {
        if (j->report)
            j->report(j->report_ctx, CN_STAGE_GRID_START, out);
        int any = 0;
        cnerf_info *info = malloc(sizeof *info);
        if (!info)
            rc = cn_fail(err, errlen, "out of memory");
        for (unsigned m = 0; rc == 0 && m < n; m++) {
            /* a level leaves the grid what the scene's workspace does not take */
            cn_grid_limits lim = {0, 0};
            if (j->level) {
                const cnerf_status st = cnerf_peek_scene(out->stream.p, out->stream.n, m, info);
                const size_t ws = st == CNERF_OK ? cnerf_workspace_size(info) : SIZE_MAX;
                const size_t cap = CNERF_LEVEL_WORKSPACE(j->level);
                lim.max_g = (int)CNERF_LEVEL_GRID(j->level);
                lim.max_ws = ws < cap ? cap - ws : 0;
            }
            if (cn_grid_choose(j->models[m], j->views[m], out->stream.n / n, j->grid_g,
                               j->level ? &lim : NULL, &out->grid[m], j->grid_log, err, errlen))
                rc = in_set(err, errlen, m, n);
            else if (out->grid[m].g) {
                S[m].grid = out->grid[m].occ;
                S[m].grid_g = (uint32_t)out->grid[m].g;
                any = 1;
            }
        }
        free(info);
        if (rc == 0 && any)
            rc = cn_write_set(S, n, shift, &out->stream, n == 1 ? &out->rep : NULL, NULL, err,
                              errlen);
    }
    for (unsigned m = 0; e && m <= n; m++) /* (a failed export has freed itself) */
        cn_export_free(&e[m]);
    free(e);
    free(copies);
    return rc;
}

void cn_encoded_free(cn_encoded *out)
{
    cn_buf_free(&out->stream);
    for (unsigned m = 0; m < CNERF_MAX_SCENES; m++)
        cn_grid_choice_free(&out->grid[m]);
}
