/*
 * The encode pipeline: the one way a model becomes a stream. Every command that writes a
 * stream (encode, encode of several scenes, quantize, synth) and rate control's measurement
 * call it; nothing else exports, chooses scales, prunes or writes (tools/check_layers.py
 * keeps it so). Its steps, in order:
 *
 *   1. export: the model's numbers snapped to the stream's and exported (cn_export.h), or a
 *      float model quantized uniformly, or sources already made (synthetic models);
 *   2. the layers' input scales (cn_scales.h), from the float reference of the stream;
 *   3. dead units removed (cn_prune.h; one scene), the proof at those scales;
 *   4. the stream written to memory (cn_stream.h);
 *   5. an occupancy grid per scene chosen against the stream's bytes (cn_grid.h), and the
 *      stream written again with it.
 *
 * Host C11.
 */
#ifndef CNERF_ENC_PIPELINE_H
#define CNERF_ENC_PIPELINE_H

#include <stddef.h>
#include <stdint.h>

#include "cn_dataset.h"
#include "cn_grid.h"
#include "cn_nerf.h"
#include "cn_prune.h"
#include "cn_stream.h"

/* Where the pipeline calls back, so that a command can report between the steps. */
typedef enum cn_encode_stage {
    CN_STAGE_PRUNED,     /* after step 3 (out->prune holds the report) */
    CN_STAGE_GRID_START, /* before step 5, which renders the training views (slow) */
} cn_encode_stage;

struct cn_encoded;

typedef struct cn_encode_job {
    /* Step 1, one of four sources:
     * - models[0..n): compressed models (cnerf encode), and shift, the shared shifts' model,
     *   when n > 1; each is snapped (its parameters change) and materialized;
     * - float_model: a float model quantized to `bits` bits (cnerf quantize), its coarse
     *   network's colour dropped when drop_coarse_color;
     * - src[0..n): sources already made (synthetic models), with shift_src when n > 1;
 * - measured: a compressed model exported as it is, neither snapped nor materialized (rate
 *   control's measurement of the stream the model would give now: it must not change). */
    cn_model *const *models;
    cn_model *shift;
    const cn_model *measured;
    const cn_model *float_model;
    unsigned bits;
    int drop_coarse_color;
    cn_stream_src *src;
    const cn_shift_src *shift_src;
    unsigned n;       /* scenes: 1 .. CNERF_MAX_SCENES */
    const char *meta; /* the stream's ancillary text (scene 0), may be NULL */
    /* Step 2: the scales' sample points come from seed; points 0 means CN_SCALE_POINTS. */
    uint64_t seed;
    size_t scale_points;
    int prune;  /* step 3 (one compressed scene only) */
    int grid_g; /* step 5: -1 chosen, 0 none, G forced; needs models and views */
    unsigned level; /* the stream's level (0: none): declared, and its caps on the grid; a
                       stream over it is refused with what exceeds it */
    const cn_dataset *const *views; /* per scene: the training views the grid is judged on */
    void (*grid_log)(const char *line); /* the grid's trials, one line each; may be NULL */
    void (*report)(void *ctx, cn_encode_stage stage, const struct cn_encoded *out);
    void *report_ctx;
} cn_encode_job;

typedef struct cn_encoded {
    cn_buf stream;              /* the stream */
    size_t bytes_without_grid;  /* its size before step 5 */
    cn_write_report rep;        /* the writer's report (one scene) */
    cn_prune_report prune;      /* step 3's report, when job.prune */
    cn_grid_choice grid[CNERF_MAX_SCENES]; /* step 5's choice per scene (g 0: none) */
} cn_encoded;

/* Runs the pipeline. Returns 0, or -1 with a message (prefixed "scene M: " or "shifts: "
 * for a set). out is valid, and to be freed, either way. */
int cn_encode_finish(const cn_encode_job *job, cn_encoded *out, char *err, size_t errlen);
void cn_encoded_free(cn_encoded *out);

#endif /* CNERF_ENC_PIPELINE_H */
