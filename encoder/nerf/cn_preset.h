/* Named presets: the topologies the commands' --preset names. Host C11. */
#ifndef CNERF_ENC_PRESET_H
#define CNERF_ENC_PRESET_H

#include "cnerf/cnerf.h"

/* Named presets fill the topology and render parameters of a Blender-style scene:
 * "tiny" (D 4, W 64, a view branch of 32, 32+32 samples), "small" (D 4, W 128, view 32,
 * 32+32), "paper" (D 8, W 256, view 128, 64+128). small's view branch is tiny's, not half its
 * width: a wider one lets colour that changes with the direction stand in for the geometry
 * on captures of few, small views (docs/training.md, "Warm-up"). Returns 0, or -1 for an
 * unknown name. */
int cn_preset_header(const char *name, cnerf_info *hdr);

/* The learning rate's warm-up of the named preset's compressed runs that start with a float
 * phase (cn_train_opts.lr_warmup): 1 for "small" and "paper", whose float models Adam's
 * first full-rate steps can throw into a fog (docs/training.md, "Warm-up"); 0 for "tiny",
 * which finds every scene of the suite without it and whose encodes the warm-up cost up to
 * half a dB (docs/training.md, "The float phase"); -1 for an unknown name. */
int cn_preset_float_warmup(const char *name);

#endif /* CNERF_ENC_PRESET_H */
