/* libFuzzer harness for the host parsers that read a user's dataset files: the first byte
 * picks the parser, the rest is the file's bytes, parsed in memory (no file system):
 * 0 a Blender transforms_*.json, 1 an instant-ngp transforms.json, 2 an LLFF
 * poses_bounds.npy, 3 a PNG image. A refusal is a normal outcome; a crash, a leak or a
 * sanitizer report is a finding. */
#include <stdint.h>
#include <stdlib.h>

#include "cn_dataset.h"
#include "cn_image.h"

/* The loader accepts images up to 2^28 pixels, gigabytes once decoded: a PNG header that
 * claims more than FUZZ_MAX_PIXELS is skipped, so that the fuzzer's memory stays bounded
 * (the limit itself is tested in tests/cli/cli_bad_input.sh). */
#define FUZZ_MAX_PIXELS ((uint64_t)1 << 20)

static uint32_t be32(const uint8_t *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    char err[512];
    const int kind = data[0] & 3;
    if (kind < 3) {
        (void)cn_dataset_parse_meta(kind, data + 1, size - 1, err, sizeof err);
    } else {
        /* the signature (8 bytes), IHDR's length and tag (8), then width and height */
        if (size >= 1 + 24 && (uint64_t)be32(data + 17) * be32(data + 21) > FUZZ_MAX_PIXELS)
            return 0;
        cn_image img;
        if (cn_png_read_mem("fuzz.png", data + 1, size - 1, &img, err, sizeof err) == 0)
            cn_image_free(&img);
    }
    return 0;
}
