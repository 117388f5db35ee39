/*
 * The stream's occupancy grid, derived at export from the final model (docs/bitstream.md,
 * GRID, has its semantics; docs/decoder.md the rule by which the encoder builds it).
 *
 * 1. Density on a lattice: both networks' density max(sigma, 0) at the (M + 1)^3 corners of
 *    M^3 equal cells of the scene box.
 * 2. A grid of g cells per axis (g divides M): a cell is occupied when some lattice point of
 *    its closed box has density above the threshold.
 * 3. A grid is kept only if rendering training views (up to 8, about 2^17 pixels) with it
 *    loses at most 0.025 dB against rendering them without (half of the 0.05 dB the grid may
 *    cost on test views). Trials: the lattice as measured at the density that makes an
 *    opacity of 1% over the box's diagonal; then the lattice dilated by one step (a max over
 *    each point's 26 neighbours, so a feature thinner than the lattice still marks its cells)
 *    at that threshold; then dilated with the threshold halved at each further trial.
 * 4. The resolution, in each trial: going from no grid through g = 16, 32, 64, 128, a finer
 *    grid is taken when each 1% that it adds to the file removes at least 4% of the network
 *    evaluations still left on the training rays (the in-bounds coarse samples, a proxy for
 *    both networks' work); no grid is written when even 16^3 does not pay that way.
 */
#ifndef CNERF_ENC_GRID_H
#define CNERF_ENC_GRID_H

#include <stddef.h>
#include <stdint.h>

#include "cn_dataset.h"
#include "cn_nerf.h"

/* Densities at the (M + 1)^3 lattice points, index (k (M + 1) + j) (M + 1) + i for the point
 * lo + (i, j, k) w / M, maximum of both networks. Returns a malloc'ed array or NULL. */
float *cn_grid_lattice(const cn_model *m, int M);

/* One lattice step of dilation: each point raised to the maximum over its 26 neighbours.
 * Returns a new malloc'ed array or NULL. */
float *cn_grid_dilate(const float *lat, int M);

/* occ[(z g + y) g + x] = 1 when a lattice point of the cell's closed box exceeds thr
 * (g divides M). Returns the number of occupied cells. */
size_t cn_grid_from_lattice(const float *lat, int M, int g, float thr, uint8_t *occ);

/* The fraction of the in-bounds coarse samples (bin midpoints) of `rays` rays spread evenly
 * over the views that fall in occupied cells of a stream grid g^3 (the exact mapping). */
double cn_grid_eval_fraction(const cnerf_info *topo, int g, const uint8_t *occ,
                             const cn_view *views, int n_views, int ndc, size_t rays);

typedef struct cn_grid_choice {
    int g;                 /* 0: no grid is worth writing */
    uint8_t *occ;          /* g^3 flags (malloc'ed) */
    float threshold;       /* density threshold used */
    int dilation;          /* lattice steps of dilation used: 0 or 1 */
    double occupied;       /* fraction of occupied cells */
    double eval_fraction;  /* estimated fraction of evaluations left on the training rays */
    size_t bytes;          /* GRID payload bytes */
    double psnr_drop;      /* training views: PSNR without the grid minus with it (dB) */
} cn_grid_choice;

/* What a stream's level leaves for its grid (docs/bitstream.md, levl): at most max_g cells
 * per axis and max_ws bytes of the decoder's workspace (the grid stored by blocks). */
typedef struct cn_grid_limits {
    int max_g;
    size_t max_ws;
} cn_grid_limits;

/* Workspace bytes a decoder takes for the grid occ of g^3 cells coded by blocks. */
size_t cn_grid_workspace(int g, const uint8_t *occ);

/* Steps 1-4 above on the model (already snapped to the stream's numbers). stream_bytes is
 * the size of the stream without a grid; force_g > 0 skips step 4 and takes that resolution;
 * lim (NULL: none) rules out the resolutions over its caps; `log` (may be NULL) receives
 * one line per trial. Returns 0, or -1 with a message. */
int cn_grid_choose(const cn_model *m, const cn_dataset *ds, size_t stream_bytes, int force_g,
                   const cn_grid_limits *lim, cn_grid_choice *out,
                   void (*say)(const char *line), char *err, size_t errlen);
void cn_grid_choice_free(cn_grid_choice *c);

#endif /* CNERF_ENC_GRID_H */
