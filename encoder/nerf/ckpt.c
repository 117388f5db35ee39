/* The checkpoint container (cn_ckpt.h): parsing from memory, shared by the trainer and the
 * fuzz harness. */
#include "cn_ckpt.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cn_buf.h"
#include "cn_reader.h"
#include "cnerf/tools.h"


/* The grids after the parameter blocks (version 2); NULL or the reason they are invalid. */
static const char *ckpt_read_grids(cn_reader *r, cn_ckpt *c)
{
    c->n_grids = cn_rd_u32(r);
    if (r->err || c->n_grids != c->hdr.n_nets)
        return "occupancy grids do not match the model";
    for (unsigned n = 0; n < c->n_grids; n++) {
        const uint32_t g = cn_rd_u32(r), valid = cn_rd_u32(r);
        if (r->err || g > 256 || valid > 1 || (valid && g == 0))
            return "invalid occupancy grid";
        c->grid_g[n] = g;
        if (!valid)
            continue;
        const size_t bytes = 4 * (size_t)g * g * g;
        if (cn_rd_left(r) < bytes)
            return "occupancy grid truncated";
        c->grid[n] = r->p;
        r->p += bytes;
    }
    return NULL;
}

/* What the run was trained on (version 3). */
static const char *ckpt_read_run(cn_reader *r, cn_ckpt *c)
{
    c->lambda = cn_rd_f64(r);
    c->n_train = cn_rd_u32(r);
    c->w = cn_rd_u32(r);
    c->h = cn_rd_u32(r);
    c->poses = cn_rd_u64(r);
    if (r->err)
        return "truncated after the occupancy grids";
    c->has_run = 1;
    return NULL;
}

/* Rate control (version 4). */
static const char *ckpt_read_rc(cn_reader *r, cn_ckpt *c)
{
    const uint32_t on = cn_rd_u32(r);
    if (r->err || on > 1)
        return "invalid rate-control flag";
    if (!on)
        return NULL;
    c->rc_scheme = cn_rd_u32(r);
    c->rc_grid_done = cn_rd_u32(r);
    c->rc_start = cn_rd_u64(r);
    for (int i = 0; i < 10; i++)
        c->rc[i] = cn_rd_f64(r);
    if (r->err)
        return "rate-control state truncated";
    if (c->rc_scheme > 1 || c->rc_grid_done > 2 || c->rc_start > c->step)
        return "invalid rate-control state";
    for (int i = 0; i < 10; i++) /* finite; >= 0 but the integral (4) and the slope (9) */
        if (!isfinite(c->rc[i]) || (i != 4 && i != 9 && c->rc[i] < 0))
            return "invalid rate-control state";
    if (c->rc[0] <= 0 || c->rc[2] <= 0)
        return "invalid rate-control state";
    c->has_rc = 1;
    return NULL;
}

/* The mean of the parameters (version 6). */
static const char *ckpt_read_average(cn_reader *r, cn_ckpt *c)
{
    c->average = cn_rd_u64(r);
    c->avg_n = cn_rd_u64(r);
    if (r->err)
        return "truncated before the mean of the parameters";
    if (c->avg_n > c->average || c->avg_n > c->step)
        return "invalid mean of the parameters";
    if (c->avg_n == 0)
        return NULL;
    if (cn_rd_left(r) / 8 < c->n_params)
        return "mean of the parameters truncated";
    c->avg = r->p;
    r->p += 8 * c->n_params;
    return NULL;
}

int cn_ckpt_parse(const char *path, const uint8_t *data, size_t len, cn_ckpt *c, char *err,
                  size_t errlen)
{
    memset(c, 0, sizeof *c);
    cn_reader r; /* over everything before the CRC */
    const char *why = NULL;
    if (len >= 4 && memcmp(data, CN_CKPT_JOINT_MAGIC, 4) == 0)
        why = "a checkpoint of an encode of several scenes: resume it with the same datasets "
              "(cnerf encode DATASET1 DATASET2 ... --resume)";
    else if (len < 12 || memcmp(data, CN_CKPT_MAGIC, 4) != 0)
        why = "not a cnerf checkpoint";
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION /* fuzzing: let mutations past the CRC */
    else if (cnerf_crc32(0, data, len - 4) !=
             (uint32_t)(data[len - 4] | data[len - 3] << 8 |
                        data[len - 2] << 16 | (uint32_t)data[len - 1] << 24))
        why = "checksum mismatch (truncated or corrupt)";
#endif
    if (!why) {
        cn_rd_init(&r, data + 4, len - 8);
        uint32_t version = cn_rd_u32(&r);
        c->step = cn_rd_u64(&r);
        c->seed = cn_rd_u64(&r);
        c->compressed = cn_rd_u32(&r);
        uint32_t hl = cn_rd_u32(&r);
        c->hdr.version_minor = CNERF_VERSION_MINOR; /* a model may use any HEAD value */
        if (version != CN_CKPT_VERSION && version != CN_CKPT_VERSION_NO_FLOAT &&
            version != CN_CKPT_VERSION_NO_AVERAGE &&
            version != CN_CKPT_VERSION_NO_QUALITY &&
            version != CN_CKPT_VERSION_NO_RC &&
            version != CN_CKPT_VERSION_NO_RUN &&
            version != CN_CKPT_VERSION_NO_GRIDS)
            why = "unsupported checkpoint version";
        else if (r.err || cn_rd_left(&r) < hl ||
                 cnerf_parse_head(r.p, hl, &c->hdr) != CNERF_OK)
            why = "invalid model header";
        else {
            r.p += hl;
            c->n_params = cn_rd_u64(&r);
            if (r.err || c->n_params > cn_rd_left(&r) / 12 ||
                (version == CN_CKPT_VERSION_NO_GRIDS && cn_rd_left(&r) != c->n_params * 12))
                why = "parameter blocks have the wrong size";
            else {
                c->blocks = r.p;
                r.p += c->n_params * 12;
                if (version != CN_CKPT_VERSION_NO_GRIDS)
                    why = ckpt_read_grids(&r, c);
                if (!why && version >= CN_CKPT_VERSION_NO_RC)
                    why = ckpt_read_run(&r, c);
                if (!why && version >= CN_CKPT_VERSION_NO_QUALITY)
                    why = ckpt_read_rc(&r, c);
                if (!why && version >= CN_CKPT_VERSION_NO_AVERAGE) {
                    c->quality = cn_rd_f64(&r);
                    if (r.err)
                        why = "truncated before the quality setting";
                    else if (!isfinite(c->quality) || c->quality < 0 ||
                             (c->quality > 0 && c->has_rc))
                        why = "invalid quality setting";
                }
                if (!why && version >= CN_CKPT_VERSION_NO_FLOAT)
                    why = ckpt_read_average(&r, c);
                if (!why && version >= CN_CKPT_VERSION) {
                    c->float_iters = cn_rd_u64(&r);
                    if (r.err)
                        why = "truncated before the float phase";
                    else if (c->float_iters > 0 && !c->compressed)
                        why = "a float phase in a float model";
                }
                if (!why && cn_rd_left(&r) != 0)
                    why = "unexpected bytes at the end";
            }
        }
    }
    if (why) {
        snprintf(err, errlen, "%s: %s", path, why);
        return -1;
    }
    return 0;
}

