/*
 * Multi-view datasets for training: Blender (NeRF-synthetic), instant-ngp style
 * transforms.json, LLFF (poses_bounds.npy), DTU as IDR, NeuS, VolSDF and MonoSDF ship it
 * (cameras.npz) and COLMAP sparse models. Host C11 (cJSON, libpng, libjpeg, libzip,
 * OpenMP).
 *
 * Layout detection, in this order: transforms_train.json -> Blender; transforms.json ->
 * instant-ngp (and nerfstudio); poses_bounds.npy -> LLFF; cameras.npz or
 * cameras_sphere.npz -> DTU; a COLMAP model -> COLMAP; anything else is an error. (A DTU
 * folder that also holds a transforms.json, written by a conversion, loads as instant-ngp;
 * one with a COLMAP model loads as DTU.)
 *
 * Blender: transforms_{train,val,test}.json, each with camera_angle_x and
 *   frames[].{file_path, transform_matrix}; file_path may omit ".png". A missing val or
 *   test file leaves that split empty. fx = fy = 0.5 W / tan(0.5 camera_angle_x),
 *   cx = W/2, cy = H/2. near 2, far 6.
 * instant-ngp: one transforms.json with fl_x, fl_y, cx, cy, w, h (fl_x/fl_y may be given
 *   as camera_angle_x/camera_angle_y instead; fl_y defaults to fl_x, cx/cy to the image
 *   centre, w/h to the image file's size; the intrinsics refer to a w x h image and are
 *   rescaled to the loaded size). Lens distortion: k1, k2, k3, p1, p2 (OpenCV's model) or,
 *   with is_fisheye true or nerfstudio's camera_model OPENCV_FISHEYE, k1..k4 on the angle;
 *   camera_model may also be PINHOLE or SIMPLE_PINHOLE (no coefficients) or OPENCV. A
 *   distorted view is resampled at load into a pinhole view (cn_undistort.h) with the same
 *   size and principal point and the focal lengths scaled until no border pixel is blank.
 *   nerfstudio's per-frame keys (any of the above in a frame) replace the file's for that
 *   frame; its applied_transform is not read: the poses are used as the file gives them,
 *   which is how nerfstudio itself reads them. Frames whose image is missing are skipped
 *   (counted in n_skipped, for the caller to tell). Split: of the usable frames in file
 *   order, indices 0, 8, 16, ... are test views, the rest train (no val). near/far: with camera centres c_i, the scene centred at
 *   the origin and s = aabb_scale (default 1), near = max(0.05, min |c_i| - sqrt(3) s),
 *   far = max |c_i| + sqrt(3) s, over all usable frames.
 * LLFF: images from images_<8*downscale>/ if it exists, else images_8/ area-downscaled by
 *   `downscale` (sorted file names, PNG or JPEG, one per pose). Rotation columns [down,
 *   right, back] become [right, up, back]. Forward-facing (the mean of the viewing
 *   directions longer than 0.9), NeRF's conventions: translations and bounds scaled by
 *   1 / (0.75 min bound), poses recentred on their average pose, ndc = 1, near = 0.9 min
 *   bound, far = max bound (after scaling), i.e. the scene's depth range; an NDC renderer
 *   itself starts its rays at the plane z = -1 (near 1.0). Otherwise a capture around the
 *   object (NeRF's 360-degree real scenes, NeRD's): oriented, centred and scaled as an
 *   inward COLMAP model below, near = max(0.01, 0.9 min bound), far = 1.1 max bound (after
 *   scaling), ndc = 0. Split: views 0, 8, 16, ... test, the rest train (no val).
 * DTU: cameras.npz (IDR, VolSDF, MonoSDF), else cameras_sphere.npz (NeuS): a zip archive
 *   (entries stored or deflated: np.savez or np.savez_compressed) of .npy arrays, for views
 *   i = 0 .. N-1 world_mat_i (the 3x4 projection P = K [R | t] from world to pixels in
 *   OpenCV's axes, x right, y down, z forward, over a last row that is not read) and
 *   scale_mat_i (the affine map from the normalised space, where the region of interest is
 *   the unit sphere, to the world; the same for every view). Arrays are 4x4, '<f4' or
 *   '<f8', C order; other entries (camera_mat_i, *_inv_i) are not read. View i's camera
 *   comes from P = world_mat_i scale_mat_i: P is negated when its left 3x3 M has a negative
 *   determinant, an RQ decomposition splits M into K (upper triangular, positive diagonal,
 *   divided by K[2][2]) and a rotation R, the camera centre is -M^-1 P[:, 3], and the
 *   camera-to-world matrix in NeRF's axes has the columns R^T e0, -R^T e1, -R^T e2 and the
 *   centre. fx = K[0][0], fy = K[1][1], cx = K[0][2], cy = K[1][2] refer to the stored
 *   images and are rescaled and cropped with the downscale as for instant-ngp. The
 *   principal point is taken as stored, as conversions to transforms.json take it, although
 *   OpenCV's pixel centres are at integer coordinates and cnerf's at half-integers (half a
 *   stored pixel). A skew |K[0][1]| up to 0.01 fx is dropped, a larger one refused.
 *   Normalisation: the normalised space's origin stays the scene centre and its axes stay;
 *   positions are scaled so that the mean camera distance is 4. With camera centres c_i,
 *   near = max(0.05, min |c_i| - sqrt(3)), far = max |c_i| + sqrt(3) (instant-ngp's rule
 *   with aabb_scale 1), ndc = 0.
 *   Images: image/ (IDR, NeuS), else images/, else the files ending in _rgb.png beside the
 *   cameras (MonoSDF), sorted by name, one per world_mat (PNG or JPEG). Masks (mask/,
 *   MonoSDF's *_mask.png) are not applied: every pixel of the photo, background included,
 *   is trained on. Split: views 0, 8, 16, ... test, the rest train (no val).
 * COLMAP (when none of the above is present): a sparse model in sparse/0/, sparse/ or
 *   colmap/sparse/0/ (cameras, images and optionally points3D, .bin or .txt, cn_colmap.h),
 *   images in images/ (images_<downscale>/ when it exists, read as they are). Cameras
 *   SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV and OPENCV_FISHEYE (distorted
 *   views are resampled as for instant-ngp). Poses: COLMAP's world-to-camera quaternion and
 *   translation in OpenCV axes become camera-to-world in NeRF's axes. Views in image-name
 *   order, every 8th (from the first) a test view. Normalisation:
 *   - forward-facing (the mean of the viewing directions longer than 0.9): LLFF's rules
 *     above, with each view's depth bounds the 1st and 99th percentiles of the depths of
 *     the sparse points inside its image (ndc = 1);
 *   - otherwise: up (the mean of the cameras' up axes) becomes +z, the point nearest to all
 *     optical axes (least squares; the mean camera centre if they are near parallel) the
 *     origin, and the mean camera distance 4; near = 0.9 x and far = 1.1 x the extreme
 *     point-depth percentiles (without points: 0.05 and twice the farthest camera).
 * Recentring and the near/far rules use every frame in the files, not just the views
 * that max_views keeps.
 * Images: PNG or JPEG in any layout, read by cn_image_load (cn_image.h): downscaled as they
 * decode, and turned upright by their EXIF orientation unless the camera file states an
 * image size (instant-ngp's w, h) whose aspect says that its cameras were made on the
 * stored pixels, as COLMAP makes them.
 */
#ifndef CNERF_ENC_DATASET_H
#define CNERF_ENC_DATASET_H

#include <stddef.h>
#include <stdint.h>

enum { CN_DS_BLENDER = 1, CN_DS_NGP = 2, CN_DS_LLFF = 3, CN_DS_COLMAP = 4, CN_DS_DTU = 5 };

typedef struct cn_view {
    char name[64];         /* view name: file stem, e.g. "r_40" or "image008" */
    int w, h;
    double c2w[3][4];      /* camera-to-world, OpenGL camera axes: x right, y up, camera
                              looks down -z */
    double fx, fy, cx, cy; /* intrinsics in pixels of THIS (downscaled) image */
    float *rgb;            /* w*h*3 floats in [0,1], already composited over the background */
    float *alpha;          /* w*h opacities in [0,1] of an image with an alpha channel that is
                              not opaque everywhere; NULL otherwise (every pixel opaque) */
} cn_view;

typedef struct cn_dataset {
    int kind;        /* CN_DS_* */
    int ndc;         /* 1: forward-facing scene to be rendered in NDC (LLFF) */
    double near, far; /* ray bounds in world units; for NDC scenes the scene's depth range
                         (the NDC warp itself uses the near plane z = -1) */
    float bg[3];     /* background colour used for compositing */
    cn_view *train, *val, *test;
    int n_train, n_val, n_test;
    int n_test_listed; /* test views the files list; n_test of them are loaded (test_every,
                          test_only) */
    int downscale;   /* the factor applied: the option's, or the one max_size chose */
    int n_skipped;   /* frames left out because their image is missing (instant-ngp and
                        nerfstudio layouts); the library prints nothing, the caller tells */
    char skipped[300]; /* the first of them: "PATH: why" (truncated), or "" */
    char dir[4096];    /* the directory it was loaded from, for messages ("" : not loaded) */
    char note[600];    /* how the images were found when the layout's own rule did not (an LLFF
                          capture with images/ only), for the caller to print; or "" */
} cn_dataset;

typedef struct cn_dataset_opts {
    int downscale;    /* integer factor >= 1 (0 means 1), area averaging; a size that F does
                         not divide loses its w % F (h % F) leftover columns (rows) first,
                         half on the left (top), and the principal point moves with them:
                         Fern's 504x378 at F = 4 is 126x94 */
    int black_bg;     /* composite RGBA over black instead of white */
    double near, far; /* overrides when > 0 (else derived, see above) */
    int max_views;    /* 0 = all; else load at most this many views per split */
    int max_size;     /* 0 = none; else the smallest downscale that brings the first image's
                         longer side to at most this many pixels (downscale must be 0 or 1) */
    int test_every;   /* 0 or 1 = every test view; N > 1: only the test views 0, N, 2N, ... of
                         the split (after max_views) are loaded, as a command that evaluates
                         every Nth test view needs */
    int test_only;    /* 1: the training and validation views are not loaded (n_train and
                         n_val are 0), for a command that renders test views only */
} cn_dataset_opts;
/* Views left out by test_every and test_only are not read at all (nor are their cameras
 * checked against their images), but the files must still list training views, every rule
 * that uses the cameras (recentring, bounds, max_size's first image) sees every frame as
 * before, and outputs are kept off their image files too. */

/* Loads the dataset in `dir` (o may be NULL for the defaults). Returns 0, or -1 with a
 * message naming the file and the problem in err; *ds is then empty. */
int cn_dataset_load(const char *dir, const cn_dataset_opts *o, cn_dataset *ds, char *err,
                    size_t errlen);

/* Frees every view and empties *ds; safe on an empty dataset. */
void cn_dataset_free(cn_dataset *ds);

/* The loaders' metadata parsers on a file's bytes, without the file system: kind 0 a
 * Blender transforms_*.json, 1 an instant-ngp transforms.json, 2 an LLFF poses_bounds.npy,
 * 3 a DTU cameras.npz.
 * Everything the loader checks before it looks for images is checked; images are not
 * read. Returns 0, or -1 with the loader's message (for fuzzing and tests). */
int cn_dataset_parse_meta(int kind, const uint8_t *data, size_t len, char *err, size_t errlen);
/* The same, and (img_w, img_h > 0) every frame's camera of a JSON layout checked against an
 * image file of img_w x img_h as the loader checks it (focal length, field of view,
 * principal point, lens). */
int cn_dataset_check_cameras(int kind, const uint8_t *data, size_t len, int img_w, int img_h,
                             char *err, size_t errlen);

#endif /* CNERF_ENC_DATASET_H */
