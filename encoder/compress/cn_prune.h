/*
 * Removal of dead units at export (docs/bitstream.md, UNIT chunk). A ReLU unit (a trunk
 * layer's or the view layer's) is dead when its pre-activation is at most 0 for every input
 * the renderers can give the network: the bound is propagated layer by layer from the
 * encoding's range (sines and cosines in [-1, 1], positions in the scene box, unit view
 * directions), with a margin that covers the fixed-point decoder's roundings and the float
 * reference's float32 arithmetic. Its output is then exactly 0 in both renderers, so its row
 * and the next layer's column for it can be dropped without changing a single output bit.
 * Host C11.
 */
#ifndef CNERF_ENC_PRUNE_H
#define CNERF_ENC_PRUNE_H

#include "cn_export.h"

typedef struct cn_prune_report {
    /* Per network: units of trunk layers 0..depth-1, then of the view layer (index depth;
     * 0 without a view branch), before and after; and kept units whose output is provably
     * constant (not removed: folding them into the next bias would change the decoder's
     * rounding, which sums exactly and rounds once). */
    uint16_t before[CNERF_MAX_NETS][CNERF_MAX_DEPTH + 1];
    uint16_t after[CNERF_MAX_NETS][CNERF_MAX_DEPTH + 1];
    uint16_t constant[CNERF_MAX_NETS][CNERF_MAX_DEPTH + 1];
    uint32_t params_before, params_after; /* latents */
} cn_prune_report;

/* Finds the dead units of an export (cn_export_compressed or cn_export_quantized) and
 * removes them: rows, biases, the next layer's columns, and the topology's units (a layer
 * keeps at least one). Returns 0 (also when nothing is dead: the export is then unchanged),
 * or -1 with a message on allocation failure. */
int cn_export_prune(cn_export *e, cn_prune_report *rep, char *err, size_t errlen);

/* The dead units alone: dead[l][o] != 0 for output o of layer l (ReLU layers only), from
 * the same bound. dead[l] must hold n_out flags per layer of the expanded topology. */
void cn_export_dead_units(const cn_export *e, uint8_t *const dead[CNERF_MAX_LAYERS]);

#endif /* CNERF_ENC_PRUNE_H */
