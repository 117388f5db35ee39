/* Several scenes trained jointly with shared shifts (cn_joint.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_joint.h"
#include "cn_buf.h"
#include "cn_file.h"
#include "cn_reader.h"

/* The topology's fields (what HEAD holds besides render parameters, and the units). */
static int same_topology(const cnerf_info *a, const cnerf_info *b)
{
    if (a->l_pos != b->l_pos || a->l_dir != b->l_dir || a->pe_flags != b->pe_flags ||
        a->n_nets != b->n_nets || a->n_layers != b->n_layers)
        return 0;
    for (unsigned n = 0; n < a->n_nets; n++) {
        const cnerf_net_info *x = &a->net[n], *y = &b->net[n];
        if (x->depth != y->depth || x->width != y->width || x->skip != y->skip ||
            x->view_width != y->view_width || x->view_units != y->view_units ||
            memcmp(x->units, y->units, sizeof x->units))
            return 0;
    }
    return 1;
}

void cn_joint_free(cn_joint *j)
{
    for (unsigned m = 0; j->t && m < j->n; m++) {
        j->t[m].model.shift = NULL;
        cn_trainer_free(&j->t[m]);
    }
    free(j->t);
    cn_model_free(&j->shift);
    memset(j, 0, sizeof *j);
}

int cn_joint_init(cn_joint *j, const cn_dataset *ds, unsigned n, const cn_train_opts *o,
                  double lr_shift_scale, char *err, size_t errlen)
{
    memset(j, 0, sizeof *j);
    if (n < 1 || n > CNERF_MAX_SCENES) {
        snprintf(err, errlen, "%u scenes: a stream holds 1 to %u", n, CNERF_MAX_SCENES);
        return -1;
    }
    j->t = calloc(n, sizeof *j->t);
    if (!j->t) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    j->lr_shift_scale = lr_shift_scale;
    for (unsigned m = 0; m < n; m++) {
        cn_train_opts om = *o;
        om.seed = o->seed + m;
        char e[512];
        if (cn_trainer_init(&j->t[m], &ds[m], &om, e, sizeof e)) {
            if (ds[m].dir[0])
                snprintf(err, errlen, "scene %u (%.300s): %s", m, ds[m].dir, e);
            else
                snprintf(err, errlen, "scene %u: %s", m, e);
            cn_joint_free(j);
            return -1;
        }
        j->n = m + 1;
        if (!same_topology(&j->t[0].model.topo, &j->t[m].model.topo)) {
            snprintf(err, errlen, "scene %u has another network topology than scene 0 (a "
                     "stream's scenes share one): give every scene the same preset and sizes",
                     m);
            cn_joint_free(j);
            return -1;
        }
    }
    /* The shifts: all 0, g at the kernels' initial step, b 0 (never trained). */
    cn_model *s = &j->shift;
    if (cn_model_init_compressed(s, &j->t[0].model.topo, o->seed ^ 0x5348494654ull, o->levels,
                                 err, errlen)) {
        cn_joint_free(j);
        return -1;
    }
    for (unsigned l = 0; l < s->topo.n_layers; l++) {
        const cnerf_layer_info *L = &s->topo.layer[l];
        memset(s->params + s->layer[l].w, 0, sizeof(float) * L->n_in * L->n_out);
        s->params[s->off_ab + 2 * l] = (float)(cn_glorot_limit(L) / o->levels);
        s->params[s->off_ab + 2 * l + 1] = 0.0f;
    }
    /* Without the coarse colour the shifts of its layers are written as zero too, and their
     * rate is not counted (cn_model.drop_color). */
    s->drop_color[0] = j->t[0].model.drop_color[0];
    for (unsigned m = 0; m < n; m++)
        j->t[m].model.shift = s;
    return 0;
}

double cn_joint_lambda(const cn_joint *j)
{
    double sum = 0;
    for (unsigned m = 0; m < j->n; m++)
        sum += j->t[m].opts.lambda;
    return j->n ? sum / j->n : 0;
}

double cn_joint_step(cn_joint *j, double *mse, double *bits)
{
    cn_model *s = &j->shift;
    cn_model_materialize(s); /* g round(S), and the shifts' kernel gradients zeroed */
    double loss = 0;
    for (unsigned m = 0; m < j->n; m++) {
        double e = 0, b = 0;
        const double l = cn_trainer_step(&j->t[m], &e, &b);
        if (isnan(l) && j->t[m].err[0]) {
            snprintf(j->err, sizeof j->err, "scene %u: %.200s", m, j->t[m].err);
            return NAN;
        }
        loss += l;
        if (mse)
            mse[m] = e;
        if (bits)
            bits[m] = b;
    }
    /* dS = g sum_m dW_m (straight through), dg = sum_m sum dW_m round(S); b stays 0. */
    cn_model_kernels_backward(s);
    const double lambda = cn_joint_lambda(j);
    const uint64_t seed = j->t[0].opts.seed ^ (0x9E3779B97F4A7C15ull * (uint64_t)(j->step + 1));
    j->shift_bits = lambda > 0 ? cn_model_rate(s, seed ^ 0x5A5A5A5Aull, (float)lambda) : 0;
    if (isnan(j->shift_bits)) {
        snprintf(j->err, sizeof j->err, "out of memory");
        return NAN;
    }
    j->step++;
    const cn_trainer *t0 = &j->t[0];
    const double lr = cn_trainer_lr(t0), decay = lr / t0->opts.lr;
    for (unsigned l = 0; l < s->topo.n_layers; l++) {
        const double g0 = cn_glorot_limit(&s->topo.layer[l]) / t0->opts.levels;
        const size_t w = s->layer[l].w, b = s->layer[l].b;
        cn_adam_range(s, w, b, t0->opts.latent_lr_weight_units ? lr / g0 : lr, j->step);
        s->grads[s->off_ab + 2 * l + 1] = 0.0f; /* no offset: the scenes have theirs */
    }
    cn_adam_range(s, s->off_ab, s->off_prior, j->lr_shift_scale * decay, j->step);
    cn_adam_range(s, s->off_prior, s->n_params, t0->opts.lr_prior * decay, j->step);
    return loss;
}

/* ---- checkpoints ---- */

int cn_joint_save(const cn_joint *j, const char *path, char *err, size_t errlen)
{
    cn_buf b = {0}, one = {0};
    cn_buf_put(&b, CN_JOINT_MAGIC, 4);
    cn_buf_u32(&b, CN_JOINT_VERSION);
    cn_buf_u32(&b, j->n);
    cn_buf_u64(&b, (uint64_t)j->step);
    const cn_model *s = &j->shift;
    cn_buf_u64(&b, s->n_params);
    cn_buf_f32s(&b, s->params, s->n_params);
    cn_buf_f32s(&b, s->adam_m, s->n_params);
    cn_buf_f32s(&b, s->adam_v, s->n_params);
    for (unsigned m = 0; m < j->n; m++) {
        one.n = 0;
        cn_checkpoint_put(&j->t[m], &one);
        cn_buf_u64(&b, one.n);
        cn_buf_put(&b, one.p, one.n);
        b.oom |= one.oom;
    }
    cn_buf_free(&one);
    cn_buf_u32(&b, cnerf_crc32(0, b.p, b.n));
    int rc = b.oom ? -1 : cn_write_file_atomic(path, b.p, b.n, err, errlen);
    if (b.oom)
        snprintf(err, errlen, "%s: out of memory", path);
    cn_buf_free(&b);
    return rc;
}

int cn_joint_resume(cn_joint *j, const char *path, char *err, size_t errlen)
{
    uint8_t *data;
    size_t len;
    if (cn_read_file_sig(path, "CN", 2, &data, &len, err, errlen)) /* CNJT */
        return -1;
    const cn_model *s = &j->shift;
    const size_t fixed = 4 + 4 + 4 + 8 + 8, blocks = 12 * s->n_params;
    int rc = -1;
    if (len < 4 || memcmp(data, CN_JOINT_MAGIC, 4)) {
        snprintf(err, errlen, "%s is not a checkpoint of several scenes (a one-scene "
                 "checkpoint resumes a one-scene encode)", path);
        goto done;
    }
    if (len < fixed + 4 || cnerf_crc32(0, data, len - 4) != cn_le32(data + len - 4)) {
        snprintf(err, errlen, "%s: damaged (its CRC does not match)", path);
        goto done;
    }
    const uint32_t version = cn_le32(data + 4), n = cn_le32(data + 8);
    if (version != CN_JOINT_VERSION) {
        snprintf(err, errlen, "%s: joint checkpoint version %u, this build reads %u", path,
                 version, CN_JOINT_VERSION);
        goto done;
    }
    if (n != j->n) {
        snprintf(err, errlen, "%s holds %u scenes and this run has %u: resume with the same "
                 "datasets, in the same order", path, n, j->n);
        goto done;
    }
    const uint64_t step = cn_le64(data + 12), np = cn_le64(data + 20);
    if (np != s->n_params || len - 4 - fixed < blocks) {
        snprintf(err, errlen, "%s: checkpoint model differs from the requested one (preset, "
                 "depth, width or samples)", path);
        goto done;
    }
    size_t off = fixed + blocks;
    for (unsigned m = 0; m < n; m++) {
        if (len - 4 - off < 8 || cn_le64(data + off) > len - 4 - off - 8) {
            snprintf(err, errlen, "%s: truncated in scene %u", path, m);
            goto done;
        }
        const size_t one = (size_t)cn_le64(data + off);
        char name[4200], e[1024];
        snprintf(name, sizeof name, "%s (scene %u)", path, m);
        if (cn_checkpoint_resume_data(&j->t[m], name, data + off + 8, one, e, sizeof e)) {
            snprintf(err, errlen, "%s", e);
            goto done;
        }
        if (j->t[m].step != (long)step) {
            snprintf(err, errlen, "%s: scene %u is at iteration %ld, the set at %llu", path, m,
                     j->t[m].step, (unsigned long long)step);
            goto done;
        }
        off += 8 + one;
    }
    cn_get_f32s(j->shift.params, data + fixed, s->n_params);
    cn_get_f32s(j->shift.adam_m, data + fixed + 4 * s->n_params, s->n_params);
    cn_get_f32s(j->shift.adam_v, data + fixed + 8 * s->n_params, s->n_params);
    j->step = (long)step;
    rc = 0;
done:
    free(data);
    return rc;
}
