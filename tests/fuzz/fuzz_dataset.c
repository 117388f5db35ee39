/* libFuzzer harness for the host parsers that read a user's dataset files: the first byte
 * picks the parser, the rest is the file's bytes, parsed in memory (no file system):
 * 0 a Blender transforms_*.json, 1 an instant-ngp transforms.json (each frame's camera then
 * through the loader's camera and lens validation on an image of one of four sizes picked by
 * bits 3-4 of the first byte: cn_dataset_check_cameras), 2 an LLFF
 * poses_bounds.npy or, with bit 2 of the first byte set (6), a DTU cameras.npz (a zip of
 * .npy arrays), 3 a PNG or JPEG image, loaded at the downscale 1 + (bits 2-3 of the first
 * byte), with an EXIF orientation applied or not (bit 4). A refusal is a normal outcome; a
 * crash, a leak or a sanitizer report is a finding. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "cn_dataset.h"
#include "cn_image.h"

/* The loader accepts images up to 2^28 pixels, gigabytes once decoded: an image header that
 * claims more than FUZZ_MAX_PIXELS is skipped, so that the fuzzer's memory stays bounded
 * (the limit itself is tested in tests/cli/cli_bad_input.sh). */
#define FUZZ_MAX_PIXELS ((uint64_t)1 << 20)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    char err[512];
    const int kind = data[0] & 3;
    if (kind < 3) {
        const int meta = kind == 2 && data[0] & 4 ? 3 : kind;
        /* a JSON layout's cameras checked on an image of one of four sizes (bits 3-4) */
        static const int sizes[4][2] = {{400, 400}, {1080, 1920}, {64, 48}, {5000, 3000}};
        const int *wh = sizes[data[0] >> 3 & 3];
        (void)cn_dataset_check_cameras(meta, data + 1, size - 1, wh[0], wh[1], err, sizeof err);
    } else {
        const int f = 1 + (data[0] >> 2 & 3);
        const double aspect = data[0] & 16 ? 0.75 : NAN;
        int w, h;
        if (cn_image_size_mem("fuzz", data + 1, size - 1, aspect, &w, &h, err, sizeof err) ==
                0 &&
            (uint64_t)w * (uint64_t)h > FUZZ_MAX_PIXELS)
            return 0;
        cn_image img;
        if (cn_image_load_mem("fuzz", data + 1, size - 1, f, aspect, &img, NULL, err,
                              sizeof err) == 0)
            cn_image_free(&img);
    }
    return 0;
}
