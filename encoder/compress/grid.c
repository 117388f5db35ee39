/* The stream's occupancy grid from the final model (see cn_grid.h for the rule). */
#include "cn_grid.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_metrics.h"
#include "cn_occ.h"
#include "cn_render.h"
#include "cn_stream.h"
#include "cn_train.h"

float *cn_grid_lattice(const cn_model *m, int M)
{
    const cnerf_info *T = &m->topo;
    const size_t n1 = (size_t)M + 1, pts_n = n1 * n1 * n1, chunk = 16384;
    float *sig = malloc(sizeof(float) * pts_n);
    float *pts = malloc(sizeof(float) * 3 * chunk);
    cn_net_buf nb[2];
    memset(nb, 0, sizeof nb);
    int bad = !sig || !pts;
    for (unsigned n = 0; n < T->n_nets && !bad; n++)
        bad = cn_net_buf_init(&nb[n], T, n, chunk) != 0;
    if (bad) {
        free(sig), free(pts);
        for (unsigned n = 0; n < 2; n++)
            if (nb[n].cap)
                cn_net_buf_free(&nb[n]);
        return NULL;
    }
    double lo[3], step[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = T->aabb_q16[a] / 65536.0;
        step[a] = ((double)T->aabb_q16[a + 3] - T->aabb_q16[a]) / 65536.0 / M;
    }
    float vpe[CNERF_MAX_IN_DIR];
    const float up[3] = {0.0f, 0.0f, 1.0f}; /* density does not depend on the direction */
    if (T->in_dir)
        cn_posenc(vpe, T->in_dir, up, 1, T->l_dir, T->pe_flags & CNERF_PE_INCLUDE_INPUT);
    for (size_t c0 = 0; c0 < pts_n; c0 += chunk) {
        const size_t P = pts_n - c0 < chunk ? pts_n - c0 : chunk;
        for (size_t j = 0; j < P; j++) {
            const size_t c = c0 + j, idx[3] = {c % n1, c / n1 % n1, c / (n1 * n1)};
            for (int a = 0; a < 3; a++)
                pts[3 * j + a] = (float)(lo[a] + (double)idx[a] * step[a]);
        }
        for (size_t j = 0; j < P; j++)
            sig[c0 + j] = 0.0f;
        for (unsigned n = 0; n < T->n_nets; n++) {
            cn_net_inputs(T, n, &nb[n], pts, P, vpe, NULL, 1);
            cn_net_density(m, n, &nb[n], P);
            for (size_t j = 0; j < P; j++)
                sig[c0 + j] = fmaxf(sig[c0 + j], nb[n].out[4 * j + 3]);
        }
    }
    for (unsigned n = 0; n < 2; n++)
        if (nb[n].cap)
            cn_net_buf_free(&nb[n]);
    free(pts);
    return sig;
}

float *cn_grid_dilate(const float *lat, int M)
{
    const size_t n1 = (size_t)M + 1, pts_n = n1 * n1 * n1;
    float *a0 = malloc(sizeof(float) * pts_n), *a1 = malloc(sizeof(float) * pts_n);
    if (!a0 || !a1) {
        free(a0), free(a1);
        return NULL;
    }
    /* A separable max over -1..1 along each axis: lat -> a0 -> a1 -> a0. */
    const size_t stride[3] = {1, n1, n1 * n1};
    for (int a = 0; a < 3; a++) {
        const float *src = a == 0 ? lat : a == 1 ? a0 : a1;
        float *dst = a == 1 ? a1 : a0;
#pragma omp parallel for schedule(static)
        for (size_t c = 0; c < pts_n; c++) {
            const size_t i = c / stride[a] % n1;
            float v = src[c];
            if (i > 0)
                v = fmaxf(v, src[c - stride[a]]);
            if (i + 1 < n1)
                v = fmaxf(v, src[c + stride[a]]);
            dst[c] = v;
        }
    }
    free(a1);
    return a0;
}

size_t cn_grid_from_lattice(const float *lat, int M, int g, float thr, uint8_t *occ)
{
    const size_t n1 = (size_t)M + 1, G = (size_t)g, k = (size_t)(M / g);
    size_t count = 0;
    for (size_t z = 0; z < G; z++)
        for (size_t y = 0; y < G; y++)
            for (size_t x = 0; x < G; x++) {
                int on = 0;
                for (size_t kz = z * k; kz <= (z + 1) * k && !on; kz++)
                    for (size_t ky = y * k; ky <= (y + 1) * k && !on; ky++)
                        for (size_t kx = x * k; kx <= (x + 1) * k && !on; kx++)
                            on = lat[(kz * n1 + ky) * n1 + kx] > thr;
                occ[(z * G + y) * G + x] = (uint8_t)on;
                count += (size_t)on;
            }
    return count;
}

double cn_grid_eval_fraction(const cnerf_info *topo, int g, const uint8_t *occ,
                             const cn_view *views, int n_views, int ndc, size_t rays)
{
    cn_occ o;
    if (n_views < 1 || cn_occ_init_stream(&o, topo, g, occ))
        return 1.0;
    float near, far;
    cn_sample_range(topo, &near, &far);
    float lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (float)topo->aabb_q16[a] / 65536.0f;
        hi[a] = (float)topo->aabb_q16[a + 3] / 65536.0f;
    }
    size_t per_view = (views[0].w * (size_t)views[0].h);
    size_t total_px = per_view * (size_t)n_views;
    const size_t stride = total_px > rays && rays ? total_px / rays : 1;
    unsigned long long in = 0, hit = 0;
    float t[CNERF_MAX_SAMPLES];
    cn_sample_coarse(t, topo->n_coarse, near, far, NULL);
    cn_ray_t(topo, t, topo->n_coarse);
    for (int v = 0; v < n_views; v++) {
        cn_camera cam;
        cn_view_camera(&views[v], &cam);
        const size_t npx = (size_t)cam.w * cam.h;
        for (size_t px = (size_t)v % stride; px < npx; px += stride) {
            float ro[3], rd[3], vd[3];
            cn_camera_ray(&cam, ndc, (double)(px % (size_t)cam.w), (double)(px / (size_t)cam.w),
                          ro, rd, vd);
            for (unsigned i = 0; i < topo->n_coarse; i++) {
                float p[3];
                int inside = 1;
                cn_ray_point(topo, ro, rd, t[i], p);
                for (int a = 0; a < 3; a++)
                    inside &= p[a] >= lo[a] && p[a] <= hi[a];
                if (!inside)
                    continue;
                in++;
                hit += (unsigned long long)cn_occ_test(&o, p);
            }
        }
    }
    cn_occ_free(&o);
    return in ? (double)hit / (double)in : 1.0;
}

/* Mean PSNR against the ground truth of training views spread evenly, rendered with the model
 * (and its grid, if any): up to 8 views and about 2^17 pixels, at least one view (a large
 * image costs one view per trial, not eight). */
static double views_psnr(cn_view_renderer *vr, const cn_model *m, const cn_dataset *ds, int *ok)
{
    const size_t px = ds->n_train ? (size_t)ds->train[0].w * (size_t)ds->train[0].h : 1;
    const size_t fit = px ? ((size_t)1 << 17) / px : 8;
    int n = ds->n_train < 8 ? ds->n_train : 8;
    if ((size_t)n > fit)
        n = fit > 0 ? (int)fit : 1;
    double sum = 0;
    for (int k = 0; k < n; k++) {
        const cn_view *v = &ds->train[(size_t)k * (size_t)ds->n_train / (size_t)n];
        cn_camera cam;
        cn_view_camera(v, &cam);
        const size_t nv = (size_t)cam.w * cam.h * 3;
        float *rgb = malloc(sizeof(float) * nv);
        if (!rgb || cn_view_render(vr, m, &cam, ds->ndc, rgb, 4096, 0)) {
            free(rgb);
            *ok = 0;
            return 0;
        }
        sum += cn_psnr_from_mse(cn_mse(rgb, v->rgb, nv));
        free(rgb);
    }
    return n ? sum / n : 0;
}

void cn_grid_choice_free(cn_grid_choice *c)
{
    free(c->occ);
    memset(c, 0, sizeof *c);
}

#define GRID_M 128
#define GRID_RAYS 40000
#define GRID_MAX_DROP_DB 0.025
#define GRID_TRIES 7 /* the undilated lattice, then six thresholds on the dilated one */
#define GRID_GAIN_PER_BYTE 4.0

size_t cn_grid_workspace(int g, const uint8_t *occ)
{
    const int nb = (g + CNERF_GRID_BLOCK - 1) / CNERF_GRID_BLOCK;
    uint8_t *on = calloc((size_t)nb * nb * nb, 1);
    if (!on)
        return SIZE_MAX;
    for (int z = 0; z < g; z++)
        for (int y = 0; y < g; y++)
            for (int x = 0; x < g; x++)
                if (occ[((size_t)z * g + y) * g + x])
                    on[((size_t)(z / CNERF_GRID_BLOCK) * nb + y / CNERF_GRID_BLOCK) * nb +
                       x / CNERF_GRID_BLOCK] = 1;
    cnerf_info gi; /* a grid and nothing else: the workspace is the grid's */
    memset(&gi, 0, sizeof gi);
    gi.grid_g = (uint8_t)g;
    gi.grid_by_blocks = 1;
    for (size_t b = 0; b < (size_t)nb * nb * nb; b++)
        gi.grid_blocks = (uint16_t)(gi.grid_blocks + on[b]);
    free(on);
    return cnerf_workspace_size(&gi);
}

int cn_grid_choose(const cn_model *m, const cn_dataset *ds, size_t stream_bytes, int force_g,
                   const cn_grid_limits *lim, cn_grid_choice *out,
                   void (*say)(const char *line), char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    const cnerf_info *T = &m->topo;
    char line[256];
    float *lat0 = cn_grid_lattice(m, GRID_M), *lat1 = NULL;
    const size_t cells_max = (size_t)GRID_M * GRID_M * GRID_M;
    uint8_t *occ = malloc(cells_max), *best = malloc(cells_max);
    if (!lat0 || !occ || !best) {
        free(lat0), free(occ), free(best);
        snprintf(err, errlen, "occupancy grid: out of memory");
        return -1;
    }
    double diag = 0;
    for (int a = 0; a < 3; a++) {
        const double w = ((double)T->aabb_q16[a + 3] - T->aabb_q16[a]) / 65536.0;
        diag += w * w;
    }
    diag = sqrt(diag);
    int ok = 1;
    cn_view_renderer vr; /* one batch for every view rendered here */
    memset(&vr, 0, sizeof vr);
    cn_model plain = *m;
    plain.grid = NULL;
    double psnr0 = 0; /* the views without a grid: measured once a grid is to be tried */
    int have_psnr0 = 0;
    const float thr0 = (float)(-log(0.99) / diag);
    for (int tries = 0; ok && tries < GRID_TRIES && !out->g; tries++) {
        /* First the lattice as measured, then dilated at the same threshold, then dilated
         * with the threshold halved at each further trial. */
        const int dil = tries > 0;
        const float thr = ldexpf(thr0, dil ? 1 - tries : 0);
        if (dil && !lat1 && !(lat1 = cn_grid_dilate(lat0, GRID_M))) {
            ok = 0;
            break;
        }
        const float *lat = dil ? lat1 : lat0;
        /* The resolution: finer while the evaluations it removes pay for its bytes. */
        int g_best = 0;
        double e_best = 1, frac_best = 0;
        size_t b_best = 0;
        for (int g = 16; g <= GRID_M; g *= 2) {
            if ((force_g > 0 && g != force_g) || (lim && g > lim->max_g))
                continue;
            const size_t occupied = cn_grid_from_lattice(lat, GRID_M, g, thr, occ);
            if (lim && cn_grid_workspace(g, occ) > lim->max_ws) {
                if (say) {
                    snprintf(line, sizeof line,
                             "grid: threshold %.3g, dilation %d, %d^3: %zu bytes of the "
                             "decoder's workspace, over the %zu the level leaves",
                             thr, dil, g, cn_grid_workspace(g, occ), lim->max_ws);
                    say(line);
                }
                continue;
            }
            cn_buf b = {0};
            const int bad = cn_grid_encode(occ, (uint32_t)g, CN_GRID_PREC, &b);
            const size_t bytes = b.n;
            cn_buf_free(&b);
            if (bad) {
                ok = 0;
                break;
            }
            const double e = cn_grid_eval_fraction(T, g, occ, ds->train, ds->n_train, ds->ndc,
                                                   GRID_RAYS);
            const double frac = (double)occupied / ((double)g * g * g);
            if (say) {
                snprintf(line, sizeof line,
                         "grid: threshold %.3g, dilation %d, %d^3: %.1f%% occupied, %zu bytes, "
                         "%.1f%% of the evaluations",
                         thr, dil, g, 100 * frac, bytes, 100 * e);
                say(line);
            }
            /* A finer grid pays when each 1% of the file it adds removes at least
             * GRID_GAIN_PER_BYTE % of the evaluations still left (e_best starts at 1 with 0
             * bytes: no grid). */
            const double removed = 1.0 - e / e_best;
            const double added = ((double)bytes - (double)b_best) / (double)stream_bytes;
            if (force_g > 0 || (removed > 0 && removed >= GRID_GAIN_PER_BYTE * added)) {
                g_best = g, e_best = e, b_best = bytes, frac_best = frac;
                memcpy(best, occ, (size_t)g * g * g);
            }
        }
        if (!ok || !g_best)
            break; /* no grid pays for its bytes */
        cn_occ o;
        if (cn_occ_init_stream(&o, T, g_best, best)) {
            ok = 0;
            break;
        }
        if (!have_psnr0) {
            psnr0 = views_psnr(&vr, &plain, ds, &ok);
            have_psnr0 = 1;
        }
        cn_model with = *m;
        with.grid = &o;
        const double psnr1 = ok ? views_psnr(&vr, &with, ds, &ok) : 0;
        cn_occ_free(&o);
        if (say) {
            snprintf(line, sizeof line,
                     "grid: %d^3 at threshold %.3g, dilation %d: training views %.3f dB with "
                     "it, %.3f dB without",
                     g_best, thr, dil, psnr1, psnr0);
            say(line);
        }
        if (ok && psnr0 - psnr1 <= GRID_MAX_DROP_DB) {
            out->g = g_best;
            out->threshold = thr;
            out->dilation = dil;
            out->occupied = frac_best;
            out->eval_fraction = e_best;
            out->bytes = b_best;
            out->psnr_drop = psnr0 - psnr1;
            out->occ = malloc((size_t)g_best * g_best * g_best);
            if (out->occ)
                memcpy(out->occ, best, (size_t)g_best * g_best * g_best);
            else
                ok = 0;
        }
    }
    cn_view_renderer_free(&vr);
    free(lat0), free(lat1), free(occ), free(best);
    if (!ok) {
        cn_grid_choice_free(out);
        snprintf(err, errlen, "occupancy grid: out of memory");
        return -1;
    }
    return 0;
}
