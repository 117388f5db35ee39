/*
 * The cameras of the DTU layout as IDR, NeuS, VolSDF and MonoSDF ship it: cameras.npz or
 * cameras_sphere.npz, a zip archive (stored or deflated entries, as np.savez and
 * np.savez_compressed write it) of 4x4 .npy arrays world_mat_i and scale_mat_i. Read with
 * libzip from bytes, every entry checked; the dataset loader pairs the cameras with the
 * images (conventions: cn_dataset.h). Host C11.
 */
#ifndef CNERF_ENC_DTU_H
#define CNERF_ENC_DTU_H

#include <stddef.h>
#include <stdint.h>

typedef struct cn_dtu_cam {
    double c2w[3][4];      /* camera-to-world in NeRF's axes (x right, y up, looking down -z),
                              the normalised space scaled to a mean camera distance of 4 */
    double fx, fy, cx, cy; /* pixels of the stored images */
} cn_dtu_cam;

/* The cameras of a cameras.npz's bytes, view i from world_mat_i and scale_mat_i, into
 * *cams (n of them, n >= 1; the caller frees *cams). `file` names it in messages. Returns 0,
 * or -1 with a message naming the file, the array and the problem (*cams is then NULL). */
int cn_dtu_parse(const char *file, const uint8_t *data, size_t len, cn_dtu_cam **cams, int *n,
                 char *err, size_t errlen);

/* The same from the file. */
int cn_dtu_read(const char *file, cn_dtu_cam **cams, int *n, char *err, size_t errlen);

#endif /* CNERF_ENC_DTU_H */
