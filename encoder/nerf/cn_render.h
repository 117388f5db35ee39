/*
 * Float rendering: rays, sampling (stratified coarse, inverse-CDF fine), volume rendering
 * with its backward pass, and the batched two-network render used for training and for
 * evaluation. The rules are written down in docs/rendering.md; the fixed-point decoder
 * copies them.
 */
#ifndef CNERF_ENC_RENDER_H
#define CNERF_ENC_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "cn_nerf.h"
#include "cn_occ.h"
#include "cn_rng.h"

/* A pinhole camera: camera-to-world [R | t] with OpenGL axes (x right, y up, looking
 * down -z), intrinsics in pixels. */
typedef struct cn_camera {
    double c2w[3][4];
    double fx, fy, cx, cy;
    int w, h;
} cn_camera;

/* The ray through the centre of pixel (x, y): o + t d with d = R (u, v, -1),
 * u = (x + 0.5 - cx) / fx, v = -(y + 0.5 - cy) / fy. In NDC scenes the ray is then warped
 * into normalized device coordinates (near plane 1). `viewdir` is the unit world direction. */
void cn_camera_ray(const cn_camera *cam, int ndc, double x, double y, float o[3], float d[3],
                   float viewdir[3]);

/* Coarse samples: n bins of [near, far], t_i = near + (i + u_i) (far - near) / n with
 * u_i = 1/2 (rng NULL) or uniform in [0, 1). */
void cn_sample_coarse(float *t, unsigned n, float near, float far, cn_rng *rng);
/* Fine samples from the coarse weights w[0..nc) over the same bins: pdf (w_i + eps) /
 * sum, quantiles u_j = (j + 1/2) / nf (rng NULL) or (j + U) / nf, piecewise-linear inverse
 * CDF. Writes nf increasing values. */
void cn_sample_fine(float *t, unsigned nf, const float *w, unsigned nc, float near, float far,
                    cn_rng *rng);
/* The interval the samples are drawn from: [near, far], or for contracted scenes
 * [0, 2 - 2^-CNERF_CONTRACT_SHIFT] in s (cn_ray_t maps it to distances). */
void cn_sample_range(const cnerf_info *T, float *lo, float *hi);
/* Distances of n samples drawn in the sample range, in place (the identity but for
 * contracted scenes), and the distance that ends the last sample's interval. */
void cn_ray_t(const cnerf_info *T, float *t, unsigned n);
float cn_ray_far(const cnerf_info *T);
/* The point at distance t along o + t d as the networks see it: itself, or in contracted
 * scenes with c the bounds' centre and h a quarter of their size, c + h u for
 * u = (p - c) / h when |u|_inf <= 1, else c + h (2 - 1/|u|_inf) u / |u|_inf. */
void cn_ray_point(const cnerf_info *T, const float o[3], const float d[3], float t, float p[3]);
/* Merges two increasing lists into out (na + nb values). */
void cn_merge_sorted(float *out, const float *a, unsigned na, const float *b, unsigned nb);

#define CN_PDF_EPS 1e-5f

/* Volume rendering of one ray from raw network outputs raw[i*ld + 0..3] = (r, g, b, sigma)
 * at increasing t[0..n): c_i = sigmoid(rgb), sigma_i = ReLU(sigma) (0 where inside[i] == 0),
 * delta_i = t_{i+1} - t_i (last: far - t_{n-1}), times dnorm = |d|;
 * alpha_i = 1 - exp(-sigma_i delta_i), T_i = prod_{j<i} (1 - alpha_j), w_i = T_i alpha_i;
 * C = sum w_i c_i + T_n bg. Writes color and, if w is not NULL, the weights. With t_stop > 0
 * the ray ends as the decoder's does (cnerf_render_opts.t_stop): from the first sample whose
 * T_i is below t_stop on, w_i = 0 and T_n = T_i (training passes 0). */
void cn_volume_forward(const float *raw, size_t ld, const float *t, const uint8_t *inside,
                       unsigned n, float far, float dnorm, const float bg[3], float color[3],
                       float *w, float t_stop);
/* Gradient of the loss with respect to raw, given dC = dL/dC (overwrites draw rows). */
void cn_volume_backward(float *draw, size_t ld, const float *raw, const float *t,
                        const uint8_t *inside, unsigned n, float far, float dnorm,
                        const float bg[3], const float dC[3]);

/* ---- batched rendering of rays through both networks ---- */

typedef struct cn_batch {
    size_t cap;                 /* rays */
    unsigned nc, ns;            /* coarse samples, samples of the last network */
    float *o, *d, *vd;          /* cap x 3: origins, directions, unit view directions */
    float *t_c, *t_f;           /* cap x nc, cap x ns (fine: merged coarse + fine) */
    float *w_c;                 /* coarse weights, cap x nc */
    float *pts;                 /* cap x ns x 3 */
    uint8_t *inside[2];         /* per network: cap x nc, cap x ns */
    float *color[2];            /* cap x 3 per network */
    /* Only samples inside the scene bounds go through a network: rows[net][j] is the sample
     * (ray * n + i) of compacted row j, n_rows[net] their count; raw/draw hold every
     * sample's (r, g, b, sigma) and its gradient, outside ones as zero density. */
    uint32_t *rows[2];
    size_t n_rows[2];
    /* The rays in chunks of CN_CHUNK_RAYS (the last may be shorter): chunk c's rows are
     * [chunk[net][c], chunk[net][c + 1]) of n_chunks. Each chunk goes through the networks
     * on its own (CN_CHUNK_ROWS in cn_nerf.h), so that a ray's outputs and the gradients
     * summed over the batch do not depend on how the chunks are split among threads. */
    size_t *chunk[2];
    size_t n_chunks;
    /* The batch's first ray in the step's whole batch (its sampling streams are the whole
     * batch's rays'), and the processes the whole batch is shared among (NULL: none). A
     * process renders the rays of its chunks: ray0 is a multiple of CN_CHUNK_RAYS. */
    size_t ray0;
    const struct cn_share *share;
    float *raw[2], *draw[2];
    float *pts_in;              /* compacted points */
    float *vpe;                 /* cap x in_dir: each ray's encoded view direction */
    cn_net_buf nb[2];
    /* Training may skip samples in empty cells: per network an occupancy grid or NULL. */
    const cn_occ *occ[2];
    /* Training may skip the fine network's samples behind the coarse network's surface:
     * with sat_eps > 0, a ray's fine samples beyond the coarse sample after which the
     * coarse transmittance falls below sat_eps are treated as empty (t_sat: cap floats). */
    float sat_eps;
    float *t_sat;
    /* The reference render's early ray termination (cn_volume_forward; 0, as cn_batch_init
     * leaves it, in training). */
    float t_stop;
    /* Per-ray background colours (cap x 3, set by the caller), or NULL for the stream's
     * background. Training draws them at random on views with transparency. */
    const float *bg;
} cn_batch;

/* Rays per chunk of a batch: part of the training's definition, as the batch size is (a
 * different value changes the sums' rounding, so the trained model's bits). */
#define CN_CHUNK_RAYS 128

int cn_batch_init(cn_batch *b, const cnerf_info *topo, size_t cap);
void cn_batch_free(cn_batch *b);

/* Encodes P points and their view directions into a network's inputs: row j's direction is
 * vpe[rows[j] / n] (already encoded, in_dir wide), or vpe[0] for every row when rows is NULL. */
void cn_net_inputs(const cnerf_info *T, unsigned net, cn_net_buf *nb, const float *pts, size_t P,
                   const float *vpe, const uint32_t *rows, unsigned n);

/* Renders rays b->o/d/vd[0..R) through the coarse network (and the fine one when the model
 * has it). Training (rng not NULL) jitters the samples with per-ray streams derived from
 * `seed`, so the result does not depend on the thread count. */
void cn_render_forward(const cn_model *m, cn_batch *b, size_t R, const uint64_t *seed);
/* Backward from dcolor[net] (R x 3 each; NULL to skip a network); accumulates gradients.
 * Returns 0, or -1 (no gradient accumulated) when out of memory or when the sum over the
 * ranks of a shared batch (b->share) failed. */
int cn_render_backward(cn_model *m, cn_batch *b, size_t R, float *const dcolor[2]);

#endif /* CNERF_ENC_RENDER_H */
