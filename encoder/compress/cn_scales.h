/*
 * Each layer's input scale f_in (docs/fixed-point.md): the fixed-point decoder feeds a
 * layer's inputs to its sums as int16 x_q = sat16(round(x 2^f_in)). The encoder takes f_in
 * from the largest input the stream's own float model gives that layer over points spread
 * through the scene's bounds and view directions spread over the sphere, with one bit of
 * margin.
 */
#ifndef CNERF_ENC_SCALES_H
#define CNERF_ENC_SCALES_H

#include <stdint.h>

#include "cn_stream.h"

/* Points (each with a view direction) the choice evaluates. */
#define CN_SCALE_POINTS 16384u

/* The scale for inputs up to max_abs: the largest f with 2 max_abs 2^f <= 32767, clamped
 * to CNERF_F_MIN..CNERF_F_MAX (CNERF_F_MAX for an input that is always 0). */
int cn_scale_for(double max_abs);

/* Sets src->layer[l].f_in of every layer from the float model of the stream that src
 * describes (written and read back here). max_abs, when not NULL, gets each layer's largest
 * input. Returns 0, or -1 with a message. */
int cn_choose_scales(cn_stream_src *src, uint64_t seed, double *max_abs, char *err,
                     size_t errlen);

/* cn_choose_scales from `points` points instead of CN_SCALE_POINTS (points >= 1). */
int cn_choose_scales_points(cn_stream_src *src, uint64_t seed, size_t points, double *max_abs,
                            char *err, size_t errlen);

/* The same for each scene of a set (cn_write_set's arguments): each scene's scales from
 * its own float model, shifts included. max_abs, when not NULL, gets n_scenes rows of
 * CNERF_MAX_LAYERS values. */
int cn_choose_scales_set(cn_stream_src *scenes, unsigned n_scenes, const cn_shift_src *shift,
                         uint64_t seed, double *max_abs, char *err, size_t errlen);

#endif /* CNERF_ENC_SCALES_H */
