/* Layer input scales of a stream (cn_scales.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_export.h"
#include "cn_nerf.h"
#include "cn_rng.h"
#include "cn_scales.h"

int cn_scale_for(double max_abs)
{
    if (isnan(max_abs) || isinf(max_abs))
        return CNERF_F_MIN; /* a model that overflows float: the widest range */
    if (!(max_abs > 0))
        return CNERF_F_MAX;
    int f = (int)floor(log2(32767.0 / (2.0 * max_abs)));
    return f < CNERF_F_MIN ? CNERF_F_MIN : f > CNERF_F_MAX ? CNERF_F_MAX : f;
}

/* The largest |v| of an n-column block of P rows with row stride ld. */
static double block_max(const float *v, size_t ld, size_t P, size_t n)
{
    double m = 0;
    for (size_t p = 0; p < P; p++)
        for (size_t i = 0; i < n; i++)
            m = fmax(m, fabs((double)v[p * ld + i]));
    return m;
}

/* Largest inputs of network `net`'s layers over P points and directions. */
static int net_maxima(const cn_model *m, unsigned net, const float *pts, const float *dirs,
                      size_t P, double *mx)
{
    const cnerf_info *T = &m->topo;
    const cnerf_net_info *N = &T->net[net];
    cn_net_buf nb;
    if (cn_net_buf_init(&nb, T, net, P))
        return -1;
    const int inc = T->pe_flags & CNERF_PE_INCLUDE_INPUT;
    const size_t W = N->width, lv = W + T->in_dir;
    cn_posenc(nb.in, nb.ld_in, pts, P, T->l_pos, inc);
    if (N->view_width)
        cn_posenc(nb.view_in + W, lv, dirs, P, T->l_dir, inc);
    cn_net_forward(m, net, &nb, P);
    const unsigned l0 = N->first_layer, D = N->depth;
    for (unsigned i = 0; i < D; i++) {
        const size_t n = T->layer[l0 + i].n_in;
        const int from_in = i == 0 || (N->skip != CNERF_NO_SKIP && i == N->skip + 1u);
        const double v = from_in ? block_max(nb.in, nb.ld_in, P, n)
                                 : block_max(nb.h[i - 1], nb.ld_h[i - 1], P, n);
        mx[l0 + i] = fmax(mx[l0 + i], v);
    }
    const double h = block_max(nb.h[D - 1], nb.ld_h[D - 1], P, T->layer[l0 + D].n_in);
    mx[l0 + D] = fmax(mx[l0 + D], h);
    if (N->view_width) {
        mx[l0 + D + 1] = fmax(mx[l0 + D + 1], h);
        mx[l0 + D + 2] = fmax(mx[l0 + D + 2], block_max(nb.view_in, lv, P, lv));
        const size_t U = T->layer[l0 + D + 3].n_in;
        mx[l0 + D + 3] = fmax(mx[l0 + D + 3], block_max(nb.view_h, U, P, U));
    }
    cn_net_buf_free(&nb);
    return 0;
}

/* The layers' largest inputs of scene `scene` of the stream b (its float model over points
 * spread through that scene's bounds). */
static int scene_maxima(const cn_buf *b, unsigned scene, uint64_t seed, size_t points,
                        double *mx, char *err, size_t errlen)
{
    cnerf_decoder *dec = calloc(1, sizeof *dec);
    void *ws = NULL;
    float *pts = malloc(sizeof(float) * 3 * points);
    float *dirs = malloc(sizeof(float) * 3 * points);
    cn_model m;
    int have_model = 0, rc = -1;
    if (!dec || !pts || !dirs) {
        snprintf(err, errlen, "out of memory");
        goto done;
    }
    cnerf_status st = cnerf_peek_scene(b->p, b->n, scene, &dec->info);
    const size_t wsz = st == CNERF_OK ? cnerf_workspace_size(&dec->info) : 0;
    if (st == CNERF_OK && !(ws = aligned_alloc(CNERF_WS_ALIGN, (wsz + 7u) & ~(size_t)7u))) {
        snprintf(err, errlen, "out of memory");
        goto done;
    }
    if (st == CNERF_OK)
        st = cnerf_open_scene(dec, b->p, b->n, scene, ws, wsz);
    if (st != CNERF_OK) {
        snprintf(err, errlen, "the stream does not decode: %s", cnerf_status_str(st));
        goto done;
    }
    if (cn_model_from_stream(dec, &m, err, errlen))
        goto done;
    have_model = 1;
    const cnerf_info *T = &m.topo;
    cn_rng r = cn_rng_seed(seed);
    for (size_t p = 0; p < points; p++) {
        double d[3], n2 = 0;
        for (unsigned a = 0; a < 3; a++) {
            const double lo = T->aabb_q16[a] / 65536.0, hi = T->aabb_q16[a + 3] / 65536.0;
            pts[3 * p + a] = (float)(lo + (hi - lo) * cn_rng_uniform(&r));
            d[a] = cn_rng_normal(&r);
            n2 += d[a] * d[a];
        }
        const double n = n2 > 0 ? sqrt(n2) : 1;
        for (unsigned a = 0; a < 3; a++)
            dirs[3 * p + a] = (float)(n2 > 0 ? d[a] / n : a == 2);
    }
    cn_model_materialize(&m);
    for (unsigned net = 0; net < T->n_nets; net++)
        if (net_maxima(&m, net, pts, dirs, points, mx)) {
            snprintf(err, errlen, "out of memory");
            goto done;
        }
    rc = 0;
done:
    if (have_model)
        cn_model_free(&m);
    free(ws);
    free(dec);
    free(pts);
    free(dirs);
    return rc;
}

static int choose_set(cn_stream_src *scenes, unsigned n_scenes, const cn_shift_src *shift,
                      uint64_t seed, size_t points, double *max_abs, char *err, size_t errlen)
{
    /* The float models of the stream as it is, whatever scales it holds now. The stream is
     * written and decoded back on purpose: the scales bound the activations of the stream's
     * float reference (cn_model_from_stream), and a synthetic or quantized source has no
     * other model of those numbers; for a trained model its snapped parameters may agree,
     * but that is not shown bit for bit (docs/architecture.md, rule 6). */
    for (unsigned m = 0; m < n_scenes; m++)
        for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++)
            scenes[m].layer[l].f_in = CNERF_F_MAX;
    cn_buf b = {0};
    if (cn_write_set(scenes, n_scenes, shift, &b, NULL, NULL, err, errlen)) {
        cn_buf_free(&b);
        return -1;
    }
    for (unsigned m = 0; m < n_scenes; m++) {
        double mx[CNERF_MAX_LAYERS] = {0};
        if (scene_maxima(&b, m, seed, points, mx, err, errlen)) {
            cn_buf_free(&b);
            return -1;
        }
        for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++) {
            scenes[m].layer[l].f_in = (int8_t)cn_scale_for(mx[l]);
            if (max_abs)
                max_abs[(size_t)m * CNERF_MAX_LAYERS + l] = mx[l];
        }
    }
    cn_buf_free(&b);
    return 0;
}

int cn_choose_scales_set(cn_stream_src *scenes, unsigned n_scenes, const cn_shift_src *shift,
                         uint64_t seed, double *max_abs, char *err, size_t errlen)
{
    return choose_set(scenes, n_scenes, shift, seed, CN_SCALE_POINTS, max_abs, err, errlen);
}

int cn_choose_scales_points(cn_stream_src *src, uint64_t seed, size_t points, double *max_abs,
                            char *err, size_t errlen)
{
    double mx[CNERF_MAX_LAYERS];
    if (choose_set(src, 1, NULL, seed, points, mx, err, errlen))
        return -1;
    if (max_abs)
        for (unsigned l = 0; l < CNERF_MAX_LAYERS; l++)
            max_abs[l] = mx[l];
    return 0;
}

int cn_choose_scales(cn_stream_src *src, uint64_t seed, double *max_abs, char *err,
                     size_t errlen)
{
    return cn_choose_scales_points(src, seed, CN_SCALE_POINTS, max_abs, err, errlen);
}
