/* The bitstream writer: everything docs/bitstream.md specifies, then a read-back. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"
#include "cn_buf.h"
#include "cn_stream.h"

static void put_chunk(cn_buf *out, uint32_t tag, const cn_buf *payload)
{
    uint8_t t[4] = {(uint8_t)tag, (uint8_t)(tag >> 8), (uint8_t)(tag >> 16), (uint8_t)(tag >> 24)};
    cn_buf_put(out, t, 4);
    cn_buf_u32(out, (uint32_t)payload->n);
    cn_buf_put(out, payload->p, payload->n);
    uint32_t crc = cnerf_crc32(0, t, 4);
    crc = cnerf_crc32(crc, payload->p, payload->n);
    cn_buf_u32(out, crc);
}

void cn_put_head(cn_buf *h, const cnerf_info *I)
{
    cn_buf_u8(h, I->coord);
    cn_buf_u8(h, I->l_pos);
    cn_buf_u8(h, I->l_dir);
    cn_buf_u8(h, I->pe_flags);
    cn_buf_u32(h, (uint32_t)I->near_q16);
    cn_buf_u32(h, (uint32_t)I->far_q16);
    for (int i = 0; i < 6; i++)
        cn_buf_u32(h, (uint32_t)I->aabb_q16[i]);
    for (int i = 0; i < 3; i++)
        cn_buf_u8(h, I->background[i]);
    cn_buf_u16(h, I->n_coarse);
    cn_buf_u16(h, I->n_fine);
    cn_buf_u8(h, I->n_nets);
    for (unsigned n = 0; n < I->n_nets; n++) {
        cn_buf_u8(h, I->net[n].depth);
        cn_buf_u16(h, I->net[n].width);
        cn_buf_u8(h, I->net[n].skip);
        cn_buf_u16(h, I->net[n].view_width);
    }
}

int cn_topology_pruned(const cnerf_info *I)
{
    for (unsigned n = 0; n < I->n_nets; n++) {
        const cnerf_net_info *N = &I->net[n];
        for (unsigned i = 0; i < N->depth; i++)
            if (N->units[i] && N->units[i] != N->width)
                return 1;
        if (N->view_units && N->view_units != N->view_width)
            return 1;
    }
    return 0;
}

/* UNIT payload: per network the units of each trunk layer, then of the view layer. */
static void put_units(cn_buf *c, const cnerf_info *I)
{
    for (unsigned n = 0; n < I->n_nets; n++) {
        const cnerf_net_info *N = &I->net[n];
        for (unsigned i = 0; i < N->depth; i++)
            cn_buf_u16(c, N->units[i]);
        if (N->view_width)
            cn_buf_u16(c, N->view_units);
    }
}

/* Chooses the table (source and precision) with the smallest estimated total size. */
typedef struct table_choice {
    uint32_t *freq;
    unsigned prec, order, source;
    double bits;
} table_choice;

static int choose_table(const uint64_t *cnt, const double *prior, uint32_t n, table_choice *best)
{
    double *pc = malloc(sizeof(double) * n);
    uint32_t *f = malloc(sizeof(uint32_t) * n);
    if (!pc || !f) {
        free(pc);
        free(f);
        return -1;
    }
    for (uint32_t i = 0; i < n; i++)
        pc[i] = (double)cnt[i];
    unsigned pmin = 1;
    while ((1u << pmin) < n)
        pmin++;
    best->bits = -1;
    for (unsigned src = CN_TABLE_COUNTS; src <= CN_TABLE_PRIOR; src++) {
        const double *p = src == CN_TABLE_COUNTS ? pc : prior;
        if (!p)
            continue;
        for (unsigned prec = pmin; prec <= CNERF_MAX_PREC; prec++) {
            if (cn_quantize_pmf(p, n, prec, f)) {
                free(pc);
                free(f);
                return -1;
            }
            unsigned order;
            double bits = (double)cn_table_bits(f, n, &order) + 16.0 +
                          cn_table_cost_bits(cnt, f, n, prec);
            if (best->bits < 0 || bits < best->bits) {
                best->bits = bits;
                best->prec = prec;
                best->order = order;
                best->source = src;
                memcpy(best->freq, f, sizeof(uint32_t) * n);
            }
        }
    }
    free(pc);
    free(f);
    return 0;
}

/* The coded part of a layer's latents or shifts: range, then (unless constant) table and
 * rANS payload. `what` names the matrix in messages. */
static int put_coded(cn_buf *c, const int32_t *k, size_t count, const double *pmf,
                     int32_t pmf_kmin, uint32_t pmf_n, const char *what, unsigned l,
                     uint8_t *source, double *ideal, char *err, size_t errlen)
{
    int32_t kmin = k[0], kmax = k[0];
    for (size_t i = 0; i < count; i++) {
        if (k[i] < -CNERF_MAX_ABS_K || k[i] > CNERF_MAX_ABS_K)
            return cn_fail(err, errlen, "layer %u: %s %d outside +-%d", l, what, k[i],
                        CNERF_MAX_ABS_K);
        if (k[i] < kmin)
            kmin = k[i];
        if (k[i] > kmax)
            kmax = k[i];
    }
    cn_buf_u16(c, (uint32_t)kmin & 0xFFFFu);
    cn_buf_u16(c, (uint32_t)kmax & 0xFFFFu);
    *source = CN_TABLE_NONE;
    *ideal = 0;
    if (kmin == kmax)
        return 0;
    const uint32_t n = (uint32_t)(kmax - kmin) + 1;
    uint64_t *cnt = calloc(n, sizeof(uint64_t));
    double *prior = pmf ? calloc(n, sizeof(double)) : NULL;
    uint32_t *syms = malloc(sizeof(uint32_t) * count);
    table_choice best = {malloc(sizeof(uint32_t) * n), 0, 0, 0, 0};
    int rc = -1;
    if (!cnt || (pmf && !prior) || !syms || !best.freq) {
        cn_fail(err, errlen, "layer %u: out of memory", l);
        goto done;
    }
    for (size_t i = 0; i < count; i++) {
        syms[i] = (uint32_t)(k[i] - kmin);
        cnt[syms[i]]++;
    }
    if (prior)
        for (uint32_t i = 0; i < n; i++) {
            int64_t j = (int64_t)kmin + i - pmf_kmin;
            prior[i] = j >= 0 && j < (int64_t)pmf_n ? pmf[j] : 0.0;
        }
    if (choose_table(cnt, prior, n, &best)) {
        cn_fail(err, errlen, "layer %u: out of memory", l);
        goto done;
    }
    cn_buf_u8(c, best.prec);
    cn_buf_u8(c, best.order);
    cn_bitw w;
    cn_bitw_init(&w, c);
    for (uint32_t i = 0; i + 1 < n; i++)
        cn_bitw_eg(&w, best.freq[i] - 1, best.order);
    cn_bitw_flush(&w);
    if (cn_rans_encode(syms, count, best.freq, n, best.prec, c)) {
        cn_fail(err, errlen, "layer %u: entropy coding failed", l);
        goto done;
    }
    *source = (uint8_t)best.source;
    *ideal = cn_table_cost_bits(cnt, best.freq, n, best.prec);
    rc = 0;
done:
    free(cnt);
    free(prior);
    free(syms);
    free(best.freq);
    return rc;
}

static int put_layer(cn_buf *c, const cnerf_layer_info *L, const cn_layer_src *S, unsigned l,
                     cn_write_report *rep, char *err, size_t errlen)
{
    if (!S->k)
        return cn_fail(err, errlen, "layer %u: no latents", l);
    if (llabs(S->a_m) > CNERF_M24_ABS_MAX || llabs(S->b_m) > CNERF_M24_ABS_MAX ||
        S->a_e < CNERF_EXP_MIN || S->a_e > CNERF_EXP_MAX || S->b_e < CNERF_EXP_MIN ||
        S->b_e > CNERF_EXP_MAX || S->bias_e < CNERF_EXP_MIN || S->bias_e > CNERF_EXP_MAX ||
        S->bias_bits > CNERF_MAX_BIAS_BITS)
        return cn_fail(err, errlen, "layer %u: affine decoder or bias format out of range", l);
    if (S->f_in < CNERF_F_MIN || S->f_in > CNERF_F_MAX)
        return cn_fail(err, errlen, "layer %u: input scale %d outside %d..%d", l, S->f_in,
                    CNERF_F_MIN, CNERF_F_MAX);
    cn_buf_u8(c, L->net);
    cn_buf_u8(c, L->index);
    cn_buf_u16(c, L->n_in);
    cn_buf_u16(c, L->n_out);
    cn_buf_u8(c, (uint32_t)(uint8_t)S->f_in);
    cn_buf_u24(c, (uint32_t)S->a_m & 0xFFFFFFu);
    cn_buf_u8(c, (uint32_t)(uint8_t)S->a_e);
    cn_buf_u24(c, (uint32_t)S->b_m & 0xFFFFFFu);
    cn_buf_u8(c, (uint32_t)(uint8_t)S->b_e);
    const unsigned bb = S->bias_m ? S->bias_bits : 0;
    cn_buf_u8(c, bb);
    cn_buf_u8(c, bb ? (uint32_t)(uint8_t)S->bias_e : 0);
    if (bb) {
        const int32_t lim = (int32_t)(1u << (bb - 1));
        cn_bitw w;
        cn_bitw_init(&w, c);
        for (unsigned j = 0; j < L->n_out; j++) {
            if (S->bias_m[j] < -lim || S->bias_m[j] >= lim)
                return cn_fail(err, errlen, "layer %u: bias %u does not fit %u bits", l, j, bb);
            cn_bitw_put(&w, (uint32_t)S->bias_m[j] & ((1u << bb) - 1u), bb);
        }
        cn_bitw_flush(&w);
    }
    uint8_t source;
    double ideal;
    if (put_coded(c, S->k, (size_t)L->n_in * L->n_out, S->pmf, S->pmf_kmin, S->pmf_n, "latent",
                  l, &source, &ideal, err, errlen))
        return -1;
    if (rep) {
        rep->table_source[l] = source;
        rep->ideal_bits[l] = ideal;
    }
    return 0;
}

/* A SHFT payload: the layer's identity and shape, g, then the shifts coded as latents. */
static int put_shift(cn_buf *c, const cnerf_layer_info *L, const cn_shift_src *S, unsigned l,
                     cn_write_report *rep, char *err, size_t errlen)
{
    if (llabs(S->g_m) > CNERF_M24_ABS_MAX || S->g_e < CNERF_EXP_MIN || S->g_e > CNERF_EXP_MAX)
        return cn_fail(err, errlen, "layer %u: shift scale out of range", l);
    cn_buf_u8(c, L->net);
    cn_buf_u8(c, L->index);
    cn_buf_u16(c, L->n_in);
    cn_buf_u16(c, L->n_out);
    cn_buf_u24(c, (uint32_t)S->g_m & 0xFFFFFFu);
    cn_buf_u8(c, (uint32_t)(uint8_t)S->g_e);
    const size_t count = (size_t)L->n_in * L->n_out;
    if (!S->s) { /* all zero: an empty range */
        cn_buf_u16(c, 0);
        cn_buf_u16(c, 0);
        if (rep) {
            rep->table_source[l] = CN_TABLE_NONE;
            rep->ideal_bits[l] = 0;
        }
        return 0;
    }
    uint8_t source;
    double ideal;
    if (put_coded(c, S->s, count, S->pmf, S->pmf_kmin, S->pmf_n, "shift", l, &source, &ideal,
                  err, errlen))
        return -1;
    if (rep) {
        rep->table_source[l] = source;
        rep->ideal_bits[l] = ideal;
    }
    return 0;
}

/* 1 when two headers have the same topology (what HEAD holds besides render parameters). */
static int same_topology(const cnerf_info *a, const cnerf_info *b)
{
    cn_buf x = {0}, y = {0};
    cn_put_head(&x, a);
    cn_put_head(&y, b);
    int same = !x.oom && !y.oom && x.n == y.n;
    for (size_t i = 1; same && i < x.n; i++)
        if ((i < 4 || i >= CNERF_HEAD_FIXED_BYTES - 1) && x.p[i] != y.p[i])
            same = 0;
    for (unsigned n = 0; same && n < a->n_nets; n++) {
        for (unsigned i = 0; i < CNERF_MAX_DEPTH; i++)
            same &= a->net[n].units[i] == b->net[n].units[i];
        same &= a->net[n].view_units == b->net[n].view_units;
    }
    cn_buf_free(&x);
    cn_buf_free(&y);
    return same;
}

int cn_write_set(const cn_stream_src *scenes, unsigned n_scenes, const cn_shift_src *shift,
                 cn_buf *out, cn_write_report *rep, cn_write_report *shift_rep, char *err,
                 size_t errlen)
{
    if (n_scenes < 1 || n_scenes > CNERF_MAX_SCENES || (n_scenes > 1 && !shift))
        return cn_fail(err, errlen, "%u scenes %s shifts: a set has 1 to %u scenes and shifts",
                    n_scenes, shift ? "with" : "without", CNERF_MAX_SCENES);
    cnerf_info *info = malloc(sizeof *info), *other = malloc(sizeof *other);
    if (!info || !other) {
        free(info);
        free(other);
        return cn_fail(err, errlen, "out of memory");
    }
    *info = scenes[0].hdr;
    cnerf_status st = cnerf_expand_topology(info);
    int rc = 0;
    if (st != CNERF_OK)
        rc = cn_fail(err, errlen, "invalid topology: %s", cnerf_status_str(st));
    for (unsigned m = 1; m < n_scenes && rc == 0; m++) {
        *other = scenes[m].hdr;
        if ((st = cnerf_expand_topology(other)) != CNERF_OK)
            rc = cn_fail(err, errlen, "scene %u: invalid topology: %s", m, cnerf_status_str(st));
        else if (!same_topology(info, other))
            rc = cn_fail(err, errlen, "scene %u: its topology differs from scene 0's", m);
    }
    if (rc) {
        free(info);
        free(other);
        return rc;
    }
    if (rep)
        memset(rep, 0, sizeof *rep * n_scenes);
    if (shift_rep)
        memset(shift_rep, 0, sizeof *shift_rep);
    out->n = 0;
    out->oom = 0;
    const uint8_t sig[4] = {CNERF_MAGIC_0, CNERF_MAGIC_1, CNERF_MAGIC_2, CNERF_MAGIC_3};
    cn_buf_put(out, sig, 4);
    const int pruned = cn_topology_pruned(info);
    cn_buf_u16(out, CNERF_VERSION_MAJOR);
    unsigned minor = shift ? CNERF_VERSION_MINOR_SCENES : 0u; /* the lowest that fits */
    for (unsigned m = 0; m < n_scenes; m++)
        if (scenes[m].hdr.coord == CNERF_COORD_CONTRACT && minor < CNERF_VERSION_MINOR_CONTRACT)
            minor = CNERF_VERSION_MINOR_CONTRACT;
    for (unsigned m = 0; m < n_scenes; m++)
        if (scenes[m].grid_g) /* grids are coded by blocks */
            minor = CNERF_VERSION_MINOR_BLOCKS;
    if (scenes[0].hdr.level) /* levl is 2.3's */
        minor = CNERF_VERSION_MINOR_BLOCKS;
    cn_buf_u16(out, (uint16_t)minor);
    cn_buf c = {0};
    cn_put_head(&c, info);
    put_chunk(out, CNERF_TAG_HEAD, &c);
    if (scenes[0].hdr.level) { /* right after the first HEAD */
        c.n = 0;
        cn_buf_u8(&c, scenes[0].hdr.level);
        put_chunk(out, CNERF_TAG_LEVL, &c);
    }
    if (shift) {
        c.n = 0;
        cn_buf_u8(&c, n_scenes);
        put_chunk(out, CNERF_TAG_SCNS, &c);
    }
    if (pruned) {
        c.n = 0;
        put_units(&c, info);
        put_chunk(out, CNERF_TAG_UNIT, &c);
    }
    if (scenes[0].meta) {
        c.n = 0;
        cn_buf_put(&c, scenes[0].meta, strlen(scenes[0].meta));
        put_chunk(out, CNERF_TAG_META, &c);
    }
    for (unsigned l = 0; shift && l < info->n_layers && rc == 0; l++) {
        c.n = 0;
        rc = put_shift(&c, &info->layer[l], &shift[l], l, shift_rep, err, errlen);
        if (rc == 0)
            put_chunk(out, CNERF_TAG_SHFT, &c);
    }
    for (unsigned m = 0; m < n_scenes && rc == 0; m++) {
        const cn_stream_src *src = &scenes[m];
        if (m > 0) {
            c.n = 0;
            *other = src->hdr; /* its render parameters, the set's topology */
            cn_put_head(&c, other);
            put_chunk(out, CNERF_TAG_HEAD, &c);
        }
        if (src->grid_g) {
            c.n = 0;
            if (!src->grid || cn_grid_encode(src->grid, src->grid_g, CN_GRID_PREC, &c))
                rc = cn_fail(err, errlen,
                          "scene %u: occupancy grid of %u cells per axis: invalid or out of memory",
                          m, src->grid_g);
            else
                put_chunk(out, CNERF_TAG_BGRD, &c);
        }
        for (unsigned l = 0; l < info->n_layers && rc == 0; l++) {
            c.n = 0;
            rc = put_layer(&c, &info->layer[l], &src->layer[l], l, rep ? &rep[m] : NULL, err,
                           errlen);
            if (rc == 0)
                put_chunk(out, CNERF_TAG_LAYR, &c);
        }
    }
    c.n = 0;
    if (rc == 0)
        put_chunk(out, CNERF_TAG_DONE, &c);
    const int oom = out->oom || c.oom;
    cn_buf_free(&c);
    if (rc == 0 && oom)
        rc = cn_fail(err, errlen, "out of memory");
    for (unsigned m = 0; m < n_scenes && rc == 0; m++) {
        st = cnerf_peek_scene(out->p, out->n, m, info);
        if (st == CNERF_E_LEVEL_EXCEEDED) {
            char why[256];
            cn_level_excess(info, info->level, why, sizeof why);
            char scene[32] = "";
            if (n_scenes > 1)
                snprintf(scene, sizeof scene, "scene %u: ", m);
            rc = cn_fail(err, errlen, "%sthe stream does not fit level %u: %s", scene,
                         info->level, why);
        } else if (st != CNERF_OK) {
            rc = cn_fail(err, errlen,
                      "the written stream does not parse (%s): invalid header fields?",
                      cnerf_status_str(st));
        }
    }
    free(info);
    free(other);
    return rc;
}

int cn_write_stream(const cn_stream_src *src, cn_buf *out, cn_write_report *rep, char *err,
                    size_t errlen)
{
    return cn_write_set(src, 1, NULL, out, rep, NULL, err, errlen);
}
