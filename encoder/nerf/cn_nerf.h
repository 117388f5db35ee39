/*
 * The float NeRF model: parameters, gradients and Adam moments each in one contiguous block
 * with named per-layer views; batched forward and backward passes of both networks through
 * cn_sgemm (cn_gemm.h). Layer shapes and order come from the stream's topology (cnerf_expand_topology),
 * so the trained model maps one to one onto the bitstream.
 */
#ifndef CNERF_ENC_NERF_H
#define CNERF_ENC_NERF_H

#include <stddef.h>
#include <stdint.h>

#include "cnerf/cnerf.h"

struct cn_share;

/* ---- layer primitives: outputs first, gradients accumulate (+=) ---- */

/* y[p][o] = sum_i x[p][i] * w[o][i] + b[o] for p < P, then max(y, 0) when relu; x has row
 * stride ldx, y ldy. */
void cn_linear_forward(float *y, size_t ldy, const float *x, size_t ldx, const float *w,
                       const float *b, size_t P, size_t n_in, size_t n_out, int relu);
/* dw += dy^T x, db += column sums of dy; if dx: dx[:, 0:nx] (+)= dy w[:, x0:x0+nx]
 * (accumulate when dx_accum, else overwrite). */
void cn_linear_backward(float *dx, size_t lddx, size_t x0, size_t nx, int dx_accum, float *dw,
                        float *db, const float *dy, size_t lddy, const float *x, size_t ldx,
                        const float *w, size_t P, size_t n_in, size_t n_out);
/* dy *= (y > 0), with y the ReLU output. */
void cn_relu_backward(float *dy, size_t lddy, const float *y, size_t ldy, size_t P, size_t n);
/* The backward of a linear layer followed by a ReLU whose output is y (row stride ldy):
 * cn_relu_backward(dy, ...) then cn_linear_backward(...), with the mask and the bias
 * gradient's column sums made in one pass over dy (the same values, bit for bit). */
void cn_linear_relu_backward(float *dx, size_t lddx, size_t x0, size_t nx, int dx_accum,
                             float *dw, float *db, float *dy, size_t lddy, const float *y,
                             size_t ldy, const float *x, size_t ldx, const float *w, size_t P,
                             size_t n_in, size_t n_out);

/* Positional encoding of n 3-vectors into rows of width 3*inc + 6*L (row stride ld):
 * [v if inc], then for each octave l: sin(2^l v_xyz), cos(2^l v_xyz) (radians, as NeRF's
 * public code; docs/rendering.md). */
void cn_posenc(float *out, size_t ld, const float *v, size_t n, unsigned L, int inc);

/* ---- the model ---- */

typedef struct cn_layer_params {
    size_t w, b; /* offsets of the kernel [n_out][n_in] and the bias [n_out] in the block */
} cn_layer_params;

typedef struct cn_model cn_model;
struct cn_model {
    cnerf_info topo;   /* render parameters and expanded topology */
    size_t n_params;   /* floats in each block */
    float *params;     /* the one parameter block */
    float *grads;      /* gradients, same layout */
    float *adam_m, *adam_v;
    cn_layer_params layer[CNERF_MAX_LAYERS];
    /* Compression (the paper's reparameterization): the block holds per layer the float
     * latents Phi in place of the kernel, then a and b of every layer's affine decoder
     * (off_ab + 2 l), then every layer's prior (off_prior + CN_PRIOR_PARAMS l). The kernel
     * the network uses is materialized as W = a round(Phi) + b. Parameters before
     * off_prior learn at the main rate, the priors at their own. */
    int compressed;
    /* 1: the kernels are materialized without rounding, W = a Phi + b (the trainer's float
     * phase, cn_train_opts.float_iters); 0 (the default): W = a round(Phi) + b. */
    int unrounded;
    size_t off_ab, off_prior;
    float *kernel, *kgrad;  /* materialized kernels and their gradients */
    size_t kofs[CNERF_MAX_LAYERS];
    /* The stream's occupancy grid (owned; NULL: none): a sample in an empty cell has
     * density 0 and is not evaluated, by every renderer of the model. */
    struct cn_occ *grid;
    /* Several scenes in one stream: the set's shared shift, a compressed model of the same
     * topology whose latents are the shifts S and whose a is g (its b stays 0; its biases
     * are not used); NULL: none. Materialized kernels become a round(Phi) + b + g round(S)
     * (the shift materialized first), and the kernel gradients also accumulate into the
     * shift's (cn_model_kernels_backward; then the shift's own maps them onto S and g).
     * Freed with this model when own_shift. */
    struct cn_model *shift;
    int own_shift;
    /* Group penalty on the trunk's units (0: off): the backward pass adds the gradient of
     * group * sum over trunk layers and units u of sqrt(sum over the P rows of h_u^2), which
     * drives whole units to output 0 on every sample, so that export can remove them. */
    float group;
    /* Networks whose colour the stream does not carry (the coarse network of a model with a
     * fine one, whose colour no image shows): their colour layers are written as zero
     * (cn_export_drop_color) and are left out of the rate, so that λ spends nothing on them.
     * They still train on the coarse loss, which is what teaches the coarse density. */
    uint8_t drop_color[CNERF_MAX_NETS];
};

/* The colour layers of network `net` (feature, view, rgb: *count layers from *first), or 0
 * when it has none (no view branch: one output layer gives density and colour). */
int cn_color_layers(const cnerf_info *I, unsigned net, unsigned *first, unsigned *count);

/* Glorot-uniform limit of a layer's kernel, sqrt(6 / (n_in + n_out)). */
double cn_glorot_limit(const cnerf_layer_info *L);

/* Allocates the blocks for the header's topology and initialises the kernels Glorot-uniform
 * and biases to zero. Returns 0 or -1 with a message. */
int cn_model_init(cn_model *m, const cnerf_info *hdr, uint64_t seed, char *err, size_t errlen);
/* The same with compressed kernels: latents Glorot-uniform over [-levels, levels] integer
 * steps, a = (Glorot limit) / levels, b = 0, priors at their initial scale. */
int cn_model_init_compressed(cn_model *m, const cnerf_info *hdr, uint64_t seed, double levels,
                             char *err, size_t errlen);
void cn_model_free(cn_model *m);

/* Latents the stream carries: all but the dropped colour layers' (drop_color). */
size_t cn_model_sent_latents(const cn_model *m);

/* The kernel that the forward pass uses for layer l. Every linear kernel is read through
 * here, so the reparameterization (latents -> integer -> affine decoder) sits in one place. */
const float *cn_model_kernel(const cn_model *m, unsigned l);
/* Where the gradient of layer l's kernel accumulates. */
float *cn_model_kernel_grad(cn_model *m, unsigned l);
/* Compressed models: W = a round(Phi) + b for every layer, and zeroed kernel gradients.
 * Call before a forward pass (no-op otherwise). */
void cn_model_materialize(cn_model *m);
/* Compressed models: maps the kernel gradients onto Phi (straight-through: dPhi = a dW),
 * a (sum dW round(Phi)) and b (sum dW). Call after the backward pass (no-op otherwise). */
void cn_model_kernels_backward(cn_model *m);
/* Compressed models: the rate in bits of all latents under their priors, with uniform
 * noise in [-1/2, 1/2) in place of rounding (streams from `seed`); adds scale * gradients
 * to the latents' and the priors' gradients. Returns 0 for uncompressed models. */
double cn_model_rate(cn_model *m, uint64_t seed, float scale);
/* Compressed models: the rate the coder is aiming at, -sum log2 L(round(Phi)) over all
 * latents under their priors (no noise, no gradients); per_layer[l] gets each layer's bits
 * when not NULL. NAN when out of memory, 0 for uncompressed models. */
double cn_model_latent_bits(const cn_model *m, double *per_layer);
/* The integer latent round(Phi) of layer l, element i. */
int32_t cn_model_latent(const cn_model *m, unsigned l, size_t i);

/* ---- one network on a batch of points ---- */

typedef struct cn_net_buf {
    size_t cap;        /* points the buffers hold */
    size_t ld_in;      /* row stride of `in`: in_pos (+ W when the skip concatenates) */
    float *in;         /* [PE(x) | h_skip] */
    float *h[CNERF_MAX_DEPTH]; /* trunk outputs (the skip layer's lives inside `in`) */
    size_t ld_h[CNERF_MAX_DEPTH];
    float *view_in;    /* [feature | PE(d)], row stride W + in_dir (view branch) */
    float *view_h;     /* view hidden, V wide */
    float *out;        /* raw outputs: P x 4 as (r, g, b, sigma) */
    size_t ld_view_in, ld_view_h;
    /* gradients */
    float *d_in, *d_h[CNERF_MAX_DEPTH], *d_view_in, *d_view_h, *d_out;
    /* The chunked backward's per-thread gradients (floats) and exact sums (cn_xsum), each
     * g_len long per thread, allocated on first use; NULL in a chunk's view of the rows. */
    float *g_chunk;
    void *g_sum;
    size_t g_len, g_threads;
} cn_net_buf;

int cn_net_buf_init(cn_net_buf *nb, const cnerf_info *topo, unsigned net, size_t cap);
void cn_net_buf_free(cn_net_buf *nb);

/* Rows of a network pass that one task computes on its own: cn_net_forward splits its rows
 * into chunks of this many, the _chunks forms at the bounds the caller gives, and each chunk runs on one thread, its products single-threaded.
 * A chunk's outputs and gradients then depend on its rows alone, and its gradients are added
 * to the others' exactly (cn_xsum.h): the results are the same bits for any thread count and
 * any split of the chunks among threads or processes. */
#define CN_CHUNK_ROWS 4096

/* Forward pass of network `net` on P points whose encodings the caller wrote into
 * nb->in (columns 0..in_pos) and, with a view branch, nb->view_in (columns W..W+in_dir).
 * Raw outputs (r, g, b, sigma before sigmoid/ReLU) land in nb->out. */
void cn_net_forward(const cn_model *m, unsigned net, cn_net_buf *nb, size_t P);
/* The same pass up to the density: nb->out's sigma column (column 3) as cn_net_forward
 * writes it, bit for bit; the colour branch is skipped (its columns are left as they were,
 * except in a network without a view branch, whose one output layer writes all four). */
void cn_net_density(const cn_model *m, unsigned net, cn_net_buf *nb, size_t P);
/* The same over the chunks [bound[c], bound[c + 1]) of rows, c < n. */
void cn_net_forward_chunks(const cn_model *m, unsigned net, cn_net_buf *nb, const size_t *bound,
                           size_t n);
/* Backward pass from nb->d_out over the chunks [bound[c], bound[c + 1]) of rows, c < n;
 * accumulates into m->grads (the kernels' gradients where cn_model_kernel_grad says), plus
 * the group penalty's gradient when m->group > 0. Each chunk's gradients are summed apart
 * and the chunks' sums added exactly. Returns 0, or -1 (nothing accumulated) when out of
 * memory for the per-thread sums or when the ranks' sum failed. The group penalty's norms are the
 * units' over all the chunks' rows. With a share (NULL: none), this process's chunks are
 * its part of a batch: the norms' squares and the gradients are summed over every rank's
 * (cn_share_allsum) before they are used. */
int cn_net_backward_chunks(cn_model *m, unsigned net, cn_net_buf *nb, const size_t *bound,
                           size_t n, const struct cn_share *share);
/* The group penalty of the last forward pass of network `net`: m->group times the sum over
 * its trunk layers' units of the units' L2 norms over the P rows. */
double cn_net_group_penalty(const cn_model *m, unsigned net, const cn_net_buf *nb, size_t P);

#endif /* CNERF_ENC_NERF_H */
