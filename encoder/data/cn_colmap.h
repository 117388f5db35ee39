/*
 * COLMAP sparse models: cameras, images and points3D in COLMAP's text (.txt) or binary
 * (.bin) form, parsed from bytes with every read bounds-checked (the dataset loader turns
 * them into views, cn_dataset.h). Host C11.
 */
#ifndef CNERF_ENC_COLMAP_H
#define CNERF_ENC_COLMAP_H

#include <stddef.h>
#include <stdint.h>

/* COLMAP's camera model ids (src/colmap/sensor/models.h). */
enum {
    CN_COLMAP_SIMPLE_PINHOLE = 0, /* f, cx, cy */
    CN_COLMAP_PINHOLE = 1,        /* fx, fy, cx, cy */
    CN_COLMAP_SIMPLE_RADIAL = 2,  /* f, cx, cy, k */
    CN_COLMAP_RADIAL = 3,         /* f, cx, cy, k1, k2 */
    CN_COLMAP_OPENCV = 4,         /* fx, fy, cx, cy, k1, k2, p1, p2 */
    CN_COLMAP_OPENCV_FISHEYE = 5, /* fx, fy, cx, cy, k1, k2, k3, k4 */
    CN_COLMAP_FULL_OPENCV = 6,
    CN_COLMAP_FOV = 7,
    CN_COLMAP_SIMPLE_RADIAL_FISHEYE = 8,
    CN_COLMAP_RADIAL_FISHEYE = 9,
    CN_COLMAP_THIN_PRISM_FISHEYE = 10,
    CN_COLMAP_N_MODELS = 11
};

#define CN_COLMAP_MAX_PARAMS 12
#define CN_COLMAP_NAME 512

typedef struct cn_colmap_camera {
    uint32_t id;
    int model; /* CN_COLMAP_* */
    uint64_t w, h;
    double params[CN_COLMAP_MAX_PARAMS];
} cn_colmap_camera;

typedef struct cn_colmap_image {
    uint32_t id, camera_id;
    double q[4]; /* world-to-camera rotation, w x y z */
    double t[3]; /* world-to-camera translation; camera axes x right, y down, z forward */
    char name[CN_COLMAP_NAME];
    int line; /* its line in images.txt, 0 from images.bin */
} cn_colmap_image;

typedef struct cn_colmap {
    cn_colmap_camera *cams;
    int n_cams;
    cn_colmap_image *imgs;
    int n_imgs;
    double *xyz; /* points3D, 3 per point */
    size_t n_points;
} cn_colmap;

/* The model's name ("OPENCV") and its number of parameters; NULL / 0 for an unknown id. */
const char *cn_colmap_model_name(int model);
int cn_colmap_model_params(int model);

/* Parsers of one file's bytes into *m (which collects all three); `file` names it in
 * messages. Text when the name ends in ".txt", else binary. Returns 0, or -1 with a message
 * naming the file, the line (text) or the entry (binary) and the problem. */
int cn_colmap_parse(const char *file, const uint8_t *data, size_t len, cn_colmap *m, char *err,
                    size_t errlen);

/* Reads DIR/{cameras,images,points3D}.bin, or the .txt files when there is no .bin
 * (points3D is optional). Every image's camera must exist. */
int cn_colmap_read(const char *dir, cn_colmap *m, char *err, size_t errlen);

void cn_colmap_free(cn_colmap *m);

/* Checks a camera as the loader checks the cameras of the images it loads, on an image of the
 * camera's own size: a model cnerf reads, the focal length, field of view, principal point
 * and a lens that does not fold the image (encoder/data/dataset.c). 0, or -1 with a message. */
int cn_colmap_check_camera(const cn_colmap_camera *c, char *err, size_t errlen);

#endif /* CNERF_ENC_COLMAP_H */
