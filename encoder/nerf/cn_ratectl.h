/*
 * Rate control's law (cnerf encode --size BYTES). lambda becomes a controlled variable: every
 * few iterations the driver measures the stream the model would give now (in memory, without
 * an occupancy grid; compress/cn_rate.h) and lambda moves so that this size follows a planned
 * path from where the run starts down to the target, which it reaches at CN_RC_ARRIVE of the
 * run and then holds. The occupancy grid's bytes are measured at CN_RC_GRID_AT and again at
 * CN_RC_GRID_AGAIN of the run (the grid shrinks as the model sharpens), and reserved from then
 * on. The trainer keeps the controller's state in its checkpoints. docs/results.md has the
 * controllers' measurements. Host C11.
 */
#ifndef CNERF_ENC_RATECTL_H
#define CNERF_ENC_RATECTL_H

#include <stddef.h>
#include <stdint.h>

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

/* The planned in-memory size at step. */
double cn_ratectl_plan(const cn_ratectl *rc, long step);

/* One measurement at step: size is the in-memory stream's bytes. Returns the new lambda. */
double cn_ratectl_update(cn_ratectl *rc, long step, double size);

#endif /* CNERF_ENC_RATECTL_H */
