/* libFuzzer harness for the COLMAP sparse-model parsers (cn_colmap.h): the first byte picks
 * the file (cameras, images or points3D; .bin or .txt), the rest is its bytes. The cameras of
 * a cameras file that parses go through the loader's camera and lens validation
 * (cn_colmap_check_camera). A refusal is a normal outcome; a crash, a leak or a sanitizer
 * report is a finding. */
#include <stdint.h>
#include <string.h>

#include "cn_colmap.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    static const char *names[6] = {"cameras.bin", "images.bin", "points3D.bin",
                                   "cameras.txt", "images.txt", "points3D.txt"};
    cn_colmap m;
    memset(&m, 0, sizeof m);
    char err[512];
    if (cn_colmap_parse(names[data[0] % 6], data + 1, size - 1, &m, err, sizeof err) == 0)
        for (int i = 0; i < m.n_cams; i++)
            (void)cn_colmap_check_camera(&m.cams[i], err, sizeof err);
    cn_colmap_free(&m);
    return 0;
}
