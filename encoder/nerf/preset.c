/* The named presets' topologies and render parameters. */
#include <string.h>

#include "cn_preset.h"

static const struct {
    const char *name;
    unsigned depth, width, view_width, n_coarse, n_fine;
    int float_warmup; /* cn_preset_float_warmup */
} presets[] = {{"tiny", 4, 64, 32, 32, 32, 0},
               {"small", 4, 128, 32, 32, 32, 1},
               {"paper", 8, 256, 128, 64, 128, 1}};

int cn_preset_float_warmup(const char *name)
{
    if (!name)
        return -1;
    for (size_t i = 0; i < sizeof presets / sizeof presets[0]; i++)
        if (strcmp(name, presets[i].name) == 0)
            return presets[i].float_warmup;
    return -1;
}

int cn_preset_header(const char *name, cnerf_info *hdr)
{
    for (size_t i = 0; i < sizeof presets / sizeof presets[0]; i++) {
        if (strcmp(name, presets[i].name) != 0)
            continue;
        memset(hdr, 0, sizeof *hdr);
        hdr->coord = CNERF_COORD_WORLD;
        hdr->l_pos = 10;
        hdr->l_dir = 4;
        hdr->pe_flags = CNERF_PE_INCLUDE_INPUT;
        hdr->near_q16 = 2 * CNERF_Q16_ONE;
        hdr->far_q16 = 6 * CNERF_Q16_ONE;
        for (int a = 0; a < 3; a++) {
            hdr->aabb_q16[a] = -3 * CNERF_Q16_ONE / 2;
            hdr->aabb_q16[a + 3] = 3 * CNERF_Q16_ONE / 2;
            hdr->background[a] = 255;
        }
        hdr->n_coarse = (uint16_t)presets[i].n_coarse;
        hdr->n_fine = (uint16_t)presets[i].n_fine;
        hdr->n_nets = presets[i].n_fine ? 2 : 1;
        for (unsigned n = 0; n < hdr->n_nets; n++) {
            hdr->net[n].depth = (uint8_t)presets[i].depth;
            hdr->net[n].width = (uint16_t)presets[i].width;
            hdr->net[n].skip = (uint8_t)(presets[i].depth / 2);
            hdr->net[n].view_width = (uint16_t)presets[i].view_width;
        }
        return 0;
    }
    return -1;
}
