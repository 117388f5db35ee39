/*
 * From a trained model to a stream, and from a decoded stream back to a float model.
 *
 * A compressed model exports its integer latents round(Phi), its affine decoders in m24e8
 * and its biases as bias blocks; the writer is offered each layer's prior PMF next to the
 * empirical counts. cn_model_snap() first moves a, b and the biases onto exactly those
 * representable values, so that the trainer's model and the file define the same numbers.
 * An uncompressed (float) model exports through post-training uniform quantization, the
 * naive baseline. cn_model_from_stream() builds the float reference model of a stream.
 */
#ifndef CNERF_ENC_EXPORT_H
#define CNERF_ENC_EXPORT_H

#include "cn_nerf.h"
#include "cn_stream.h"

typedef struct cn_export {
    cn_stream_src src;
    int32_t *k[CNERF_MAX_LAYERS];
    int32_t *bias[CNERF_MAX_LAYERS];
    double *pmf[CNERF_MAX_LAYERS];
} cn_export;

#define CN_BIAS_BITS 16

/* Rounds a, b (m24e8) and the biases (CN_BIAS_BITS-bit blocks) of a compressed model to the
 * values the stream will carry. */
int cn_model_snap(cn_model *m, char *err, size_t errlen);

/* A compressed model's stream source (call cn_model_snap first for an exact round trip). */
int cn_export_compressed(const cn_model *m, const char *meta, cn_export *e, char *err,
                         size_t errlen);
/* An uncompressed model quantized uniformly to `bits` per weight (symmetric around each
 * layer's mid-range, 2 <= bits <= 16). */
int cn_export_quantized(const cn_model *m, unsigned bits, const char *meta, cn_export *e,
                        char *err, size_t errlen);
void cn_export_free(cn_export *e);

/* Writes network `net`'s colour layers as zero: latents, affine offset b and biases (a stays,
 * 0 k = 0). The stream then carries no colour for it (cnerf_net_has_color); for the coarse
 * network of a stream with a fine one this changes no pixel of any image with fine samples,
 * whose colour only the fine network gives. Nothing happens without a view branch. */
void cn_export_drop_color(cn_export *e, unsigned net);

/* The float reference model of a decoded stream: a compressed cn_model whose latents,
 * affine decoders and biases are the stream's numbers. */
int cn_model_from_stream(const cnerf_decoder *dec, cn_model *m, char *err, size_t errlen);

#endif
