/* make_jpeg_scene DIR N W H: writes an instant-ngp scene of N W x H JPEG photos (smooth
 * colour fields with some noise, quality 90, 4:2:0 as cameras write them) on a ring of
 * cameras looking at the origin, for measuring what loading real-size captures costs
 * (scripts/jpeg_memory.sh). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <jpeglib.h>

#include "cn_rng.h"

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: make_jpeg_scene DIR N W H\n");
        return 2;
    }
    const char *dir = argv[1];
    const int n = atoi(argv[2]), w = atoi(argv[3]), h = atoi(argv[4]);
    if (n < 1 || w < 16 || h < 16) {
        fprintf(stderr, "make_jpeg_scene: N >= 1, W and H >= 16\n");
        return 2;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/transforms.json", dir);
    FILE *js = fopen(path, "w");
    if (!js) {
        perror(path);
        return 1;
    }
    fprintf(js, "{\"camera_angle_x\": 0.9, \"w\": %d, \"h\": %d, \"frames\": [\n", w, h);
    unsigned char *row = malloc((size_t)w * 3);
    if (!row)
        return 1;
    cn_rng r = cn_rng_seed(1);
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%04d.jpg", dir, i);
        FILE *f = fopen(path, "wb");
        if (!f) {
            perror(path);
            return 1;
        }
        struct jpeg_compress_struct ci;
        struct jpeg_error_mgr jerr;
        ci.err = jpeg_std_error(&jerr);
        jpeg_create_compress(&ci);
        jpeg_stdio_dest(&ci, f);
        ci.image_width = (JDIMENSION)w;
        ci.image_height = (JDIMENSION)h;
        ci.input_components = 3;
        ci.in_color_space = JCS_RGB;
        jpeg_set_defaults(&ci);
        jpeg_set_quality(&ci, 90, TRUE);
        jpeg_start_compress(&ci, TRUE);
        while (ci.next_scanline < ci.image_height) {
            const double y = (double)ci.next_scanline / h;
            for (int x = 0; x < w; x++) {
                const double u = (double)x / w;
                for (int k = 0; k < 3; k++) {
                    const double v = 0.5 + 0.4 * sin(6.0 * u + 4.0 * y + k + 0.1 * i);
                    const int noise = (int)(cn_rng_u64(&r) >> 61) - 4;
                    const int q = (int)(255 * v) + noise;
                    row[3 * x + k] = (unsigned char)(q < 0 ? 0 : q > 255 ? 255 : q);
                }
            }
            JSAMPROW rp = row;
            jpeg_write_scanlines(&ci, &rp, 1);
        }
        jpeg_finish_compress(&ci);
        jpeg_destroy_compress(&ci);
        fclose(f);
        const double a = 2 * M_PI * i / n, c = cos(a), s = sin(a);
        /* camera at 4 (cos a, sin a, 0) looking at the origin, z up */
        fprintf(js, "%s{\"file_path\": \"%04d.jpg\", \"transform_matrix\": [[%.6f, 0, %.6f, %.6f], "
                "[%.6f, 0, %.6f, %.6f], [0, 1, 0, 0], [0, 0, 0, 1]]}\n", i ? "," : "", i, -s,
                c, 4 * c, c, s, 4 * s);
    }
    fprintf(js, "]}\n");
    free(row);
    return fclose(js) ? 1 : 0;
}
