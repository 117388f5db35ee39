/*
 * Rate control's measurements (cnerf encode --size): the bytes of the stream a model gives
 * now, and the hook that measures them every few iterations of training and moves lambda
 * by the law of cn_ratectl.h. Host C11.
 */
#ifndef CNERF_ENC_RATE_H
#define CNERF_ENC_RATE_H

#include <stddef.h>
#include <stdint.h>

#include "cn_nerf.h"
#include "cn_train.h"

/* Points the input scales of a measured size are chosen from: an eighth of the written
 * stream's CN_SCALE_POINTS. The scales change the size only through the bounds that find
 * dead units (the scales' byte is there either way), and choosing them from 16384 points
 * was most of the measurement's time (test_ratectl compares the two sizes). Overridable at
 * build time only for experiments (docs/training.md, "Rate control's measurements"). */
#ifndef CN_RC_SCALE_POINTS
#define CN_RC_SCALE_POINTS 2048u
#endif

/* The bytes of the stream a compressed model gives now, without an occupancy grid or
 * metadata: exported, input scales chosen from seed (over CN_RC_SCALE_POINTS points), dead
 * units removed when prune is set, written to memory. The model is not changed. Returns 0,
 * or -1 with a message. */
int cn_stream_size(const cn_model *m, uint64_t seed, int prune, size_t *bytes, char *err,
                   size_t errlen);

/* The smallest stream of the model's topology: every latent 0 and every bias block at its
 * full width (what any trained model pays for its headers, affine decoders and biases),
 * without a grid or metadata. The model's parameters are restored. */
int cn_stream_floor(cn_model *m, uint64_t seed, size_t *bytes, char *err, size_t errlen);

/* Puts the trainer under rate control: lambda follows the plan to target_bytes (the whole
 * file; reserved_bytes of it are not in the measured stream: metadata), measured every
 * rc.every iterations through the trainer's step hook; grid_g is the encode's --grid (-1
 * automatic, 0 none), prune removes dead units from the measured stream. */
void cn_trainer_rate_control(cn_trainer *t, double target_bytes, double reserved_bytes,
                             cn_rc_scheme scheme, int grid_g, int prune);

#endif /* CNERF_ENC_RATE_H */
