/* libFuzzer harness for packed images (cnerf_open_packed): the first 32 bytes choose a
 * camera, a tile and the knobs (fuzz_tile.h), the rest is an image. Unless the control's
 * byte 1 says otherwise, the harness makes the image this build's (its kernel set, layouts
 * and byte order) and its CRC right, so that the fuzzer reaches the checks of the contents
 * behind them. An image that opens is rendered, read in place as a device reads flash. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "../../common/cn_reader.h"
#include "../../decoder/cn_kernels.h"
#include "cnerf/cnerf.h"
#include "fuzz_tile.h"

static void put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static cnerf_decoder dec;
    static uint64_t scratch[1 << 14];
    if (size < CTRL || size - CTRL > ((size_t)4 << 20))
        return 0;
    const uint8_t *c = data;
    const size_t n = size - CTRL;
    /* an aligned copy: the image in place, as a device maps it */
    uint8_t *im = aligned_alloc(CNERF_WS_ALIGN, (n + 8) & ~(size_t)7);
    if (!im)
        return 0;
    memcpy(im, data + CTRL, n);
    if (n >= CNERF_IMAGE_HEADER_BYTES) {
        if (!(c[1] & 1)) { /* this build's kernels and byte order */
            const cn_dot_variant v = cn_dot_select();
            const uint16_t one = 1;
            memset(im + 8, 0, 8);
            for (int i = 0; i < 8 && v.name[i]; i++)
                im[8 + i] = (uint8_t)v.name[i];
            im[6] = *(const unsigned char *)&one == 1 ? 'L' : 'B';
            im[16] = v.layout;
            im[17] = v.layout8;
        }
        const uint32_t total = cn_le32(im + 24);
        if (!(c[1] & 2) && total >= 48 && total <= n) /* the CRC made right */
            put32(im + 44, cnerf_crc32(cnerf_crc32(0, im, 44), im + 48, total - 48));
    }
    if (cnerf_open_packed(&dec, im, n) == CNERF_OK && dec.info.n_params <= 20000u &&
        (uint32_t)dec.info.n_coarse + dec.info.n_fine <= 96u &&
        cnerf_render_scratch_size(&dec.info) <= sizeof scratch)
        fuzz_tile(&dec, c, scratch, sizeof scratch);
    free(im);
    return 0;
}
