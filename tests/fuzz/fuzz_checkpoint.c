/* libFuzzer harness for the checkpoint container that `--resume`, `quantize` and `eval` read:
 * parse any input; when it parses, read every parameter and grid value it points to, so that
 * the sanitizers see any size the parser let through. A refusal is a normal outcome. */
#include <stdint.h>
#include <string.h>

#include "cn_ckpt.h"

static float f32_at(const uint8_t *p)
{
    const uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                       (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &u, 4);
    return f;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    cn_ckpt c;
    char err[512];
    if (cn_ckpt_parse("fuzz.ckpt", data, size, &c, err, sizeof err) != 0)
        return 0;
    volatile float sum = 0;
    for (uint64_t i = 0; i < 3 * c.n_params; i++)
        sum += f32_at(c.blocks + 4 * i);
    for (unsigned n = 0; n < c.n_grids; n++)
        if (c.grid[n])
            for (size_t i = 0; i < (size_t)c.grid_g[n] * c.grid_g[n] * c.grid_g[n]; i++)
                sum += f32_at(c.grid[n] + 4 * i);
    for (uint64_t i = 0; c.avg && i < 2 * c.n_params; i++) /* the mean: f64s */
        sum += f32_at(c.avg + 4 * i);
    (void)sum;
    return 0;
}
