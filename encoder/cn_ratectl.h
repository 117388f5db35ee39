/*
 * Rate control: cnerf encode --size BYTES. lambda becomes a controlled variable: every few
 * iterations the trainer writes the stream its model would give now (in memory, without an
 * occupancy grid) and moves lambda so that this size follows a planned path from where the
 * run starts down to the target, which it reaches at CN_RC_ARRIVE of the run and then holds.
 * The occupancy grid's bytes are measured at CN_RC_GRID_AT and again at CN_RC_GRID_AGAIN of
 * the run (the grid shrinks as the model sharpens), and reserved from then on.
 * docs/results.md has the controllers' measurements. Host C11.
 */
#ifndef CNERF_ENC_RATECTL_H
#define CNERF_ENC_RATECTL_H

#include <stddef.h>
#include <stdint.h>

#include "cn_nerf.h"

/* Fractions of the run: where the planned size reaches the target, where the grid is
 * measured. */
/* Overridable at build time only for experiments (docs/results.md, "Arriving earlier"). */
#ifndef CN_RC_ARRIVE
#define CN_RC_ARRIVE 0.7
#endif
#define CN_RC_GRID_AT 0.5
#define CN_RC_GRID_AGAIN 0.75

typedef enum cn_rc_scheme {
    CN_RC_LOG_PI = 0, /* proportional-integral control of log(lambda) on log(size / plan) */
    CN_RC_DUAL = 1,   /* dual ascent: lambda += step * (size - plan) / plan */
} cn_rc_scheme;

typedef struct cn_ratectl {
    cn_rc_scheme scheme;
    double target;     /* bytes of the whole file */
    double reserved;   /* bytes the in-memory stream does not hold: metadata, and the grid */
    long every;        /* iterations between measurements */
    long start, iters; /* the controlled iterations: [start, iters) */
    double lambda_unit; /* lambda's scale: 3 x training pixels / latents (see .c) */
    /* State (checkpointed). */
    double first;    /* the first measured size (the plan's start), 0 before it */
    double integral; /* PI: sum of log errors; dual: unused */
    double slope;    /* average change of log(size) per measurement */
    double lambda;   /* the current lambda */
    double size;     /* the last measured in-memory size, bytes */
    double plan;     /* the last planned size (in-memory part) */
    double grid;     /* the last measured grid's bytes (in reserved) */
    int grid_done;   /* grid measurements made: 0, 1 or 2 */
} cn_ratectl;

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

/* The planned in-memory size at step. */
double cn_ratectl_plan(const cn_ratectl *rc, long step);

/* One measurement at step: size is the in-memory stream's bytes. Returns the new lambda. */
double cn_ratectl_update(cn_ratectl *rc, long step, double size);

#endif /* CNERF_ENC_RATECTL_H */
