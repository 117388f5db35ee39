/* Named presets: the topologies the commands' --preset names. Host C11. */
#ifndef CNERF_ENC_PRESET_H
#define CNERF_ENC_PRESET_H

#include "cnerf/cnerf.h"

/* Named presets fill the topology and render parameters of a Blender-style scene:
 * "tiny" (D 4, W 64, 32+32 samples), "small" (D 4, W 128, 32+32), "paper" (D 8, W 256,
 * 64+128). Returns 0, or -1 for an unknown name. */
int cn_preset_header(const char *name, cnerf_info *hdr);

#endif /* CNERF_ENC_PRESET_H */
