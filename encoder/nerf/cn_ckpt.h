/*
 * The checkpoint container of cnerf train and encode (encoder/nerf/train.c writes it).
 *
 * "CNCK", u32 version, u64 step, u64 seed, u32 compressed, u32 header length and the
 * stream's HEAD payload, u64 n_params, then params, Adam m and Adam v (n_params f32 each),
 * and a CRC-32 of everything before it; all little-endian.
 *
 * Version 2 adds the occupancy grids after the Adam moments: per network the cells per axis
 * g (0: no grid), whether it has an estimate, and then, when it has, the g^3 decaying maxima.
 * Without them a resumed run rebuilt its grids from one pass over the resumed model, which
 * marks fewer cells occupied than the running maxima did, and the first steps after the
 * resume trained with samples missing. Version 1 files still load; their grids are rebuilt.
 * Version 3 adds what the run was trained on, after the grids: lambda (f64 bits), the
 * number of training views, the first view's width and height, and a 64-bit hash of the
 * training poses, so that --resume refuses another dataset, resolution or lambda. Version 1
 * and 2 files load without those checks.
 * Version 4 adds rate control (cnerf encode --size) after those: u32 1 when the run is
 * rate-controlled (else 0 and nothing more), then u32 scheme, u32 grid measurements made,
 * u64 first controlled step, and f64 target, reserved, lambda unit, first size, integral,
 * lambda, last size, last plan, grid bytes, slope (cn_ratectl.h).
 * Version 5 adds an f64 after that: the quality slope of cnerf encode --quality (0: none;
 * cn_train_opts.quality_slope). Versions 3 and 4 load as runs without one.
 * Version 6 adds the mean of the parameters (cnerf encode --average): u64 the iterations
 * averaged at the end of the run (0: none), u64 those done so far, and when that is not 0
 * the mean, n_params f64. Versions 3 to 5 load as runs without it.
 * Version 7 adds after that a u64: the iteration at which the latents' rounding starts
 * (cn_train_opts.float_iters; 0: from the first). Earlier versions load as 0, which they
 * were. */
#ifndef CNERF_ENC_CKPT_H
#define CNERF_ENC_CKPT_H

#include <stddef.h>
#include <stdint.h>

#include "cnerf/cnerf.h"

#define CN_CKPT_MAGIC "CNCK"
/* The checkpoint of an encode of several scenes (compress/joint.c): named here so that a
 * one-scene run can tell it apart. */
#define CN_CKPT_JOINT_MAGIC "CNJT"
#define CN_CKPT_VERSION 7u
#define CN_CKPT_VERSION_NO_FLOAT 6u
#define CN_CKPT_VERSION_NO_AVERAGE 5u
#define CN_CKPT_VERSION_NO_QUALITY 4u
#define CN_CKPT_VERSION_NO_RC 3u
#define CN_CKPT_VERSION_NO_RUN 2u
#define CN_CKPT_VERSION_NO_GRIDS 1u

typedef struct cn_ckpt {
    uint64_t step, seed, n_params;
    uint32_t compressed;
    cnerf_info hdr;
    const uint8_t *blocks; /* params, m, v: 3 n_params little-endian f32 */
    unsigned n_grids;      /* 0 in a version 1 file */
    uint32_t grid_g[CNERF_MAX_NETS];
    const uint8_t *grid[CNERF_MAX_NETS]; /* g^3 densities, or NULL: no estimate */
    int has_run;                         /* version 3: the fields below are known */
    double lambda;
    uint32_t n_train, w, h;
    uint64_t poses;
    int has_rc; /* version 4 and rate-controlled: the fields below are set */
    uint32_t rc_scheme, rc_grid_done;
    uint64_t rc_start;
    double rc[10]; /* target, reserved, lambda unit, first, integral, lambda, size, plan,
                    * grid, slope */
    double quality; /* version 5: the quality slope, 0 for none */
    uint64_t average, avg_n; /* version 6: the window and the iterations averaged so far */
    const uint8_t *avg;      /* avg_n > 0: the mean, n_params little-endian f64 */
    uint64_t float_iters;    /* version 7: the first rounded iteration (0 before) */
} cn_ckpt;

/* Parses a checkpoint's bytes (path names it in messages); c's pointers point into data.
 * Every size is checked against len. Returns 0, or -1 with the reason. */
int cn_ckpt_parse(const char *path, const uint8_t *data, size_t len, cn_ckpt *c, char *err,
                  size_t errlen);

#endif /* CNERF_ENC_CKPT_H */
