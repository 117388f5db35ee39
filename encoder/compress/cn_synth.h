/* Synthetic models: random latents for a given topology, for tests, vectors and demos. */
#ifndef CNERF_ENC_SYNTH_H
#define CNERF_ENC_SYNTH_H

#include "cn_preset.h"
#include "cn_stream.h"

typedef struct cn_synth {
    cn_stream_src src; /* ready for cn_write_stream */
    int32_t *k[CNERF_MAX_LAYERS];
    int32_t *bias[CNERF_MAX_LAYERS];
} cn_synth;


/* Random latents ~ round(Laplace(0, spread)) clamped to the format's range, random
 * affine decoders and 16-bit biases. `hdr` as for cn_stream_src.hdr. The input scales are
 * not chosen: the encode pipeline (cn_pipeline.h) chooses them, as for any source. */
int cn_synth_make(cn_synth *s, const cnerf_info *hdr, uint64_t seed, double spread, char *err,
                  size_t errlen);
void cn_synth_free(cn_synth *s);

/* A set's shared shifts for a synthetic model's topology: s ~ round(Laplace(0, spread))
 * (spread 0: every shift 0) and g = g_rel times the layer's a in `ref`. */
typedef struct cn_synth_shift {
    cn_shift_src src[CNERF_MAX_LAYERS]; /* ready for cn_write_set */
    int32_t *s[CNERF_MAX_LAYERS];
} cn_synth_shift;

int cn_synth_shift_make(cn_synth_shift *s, const cn_synth *ref, uint64_t seed, double spread,
                        double g_rel, char *err, size_t errlen);
void cn_synth_shift_free(cn_synth_shift *s);

#endif /* CNERF_ENC_SYNTH_H */
