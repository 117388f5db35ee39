/* Rays, sampling, volume rendering and the batched two-network render. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cn_render.h"

void cn_camera_ray(const cn_camera *cam, int ndc, double x, double y, float o[3], float d[3],
                   float viewdir[3])
{
    const double u = (x + 0.5 - cam->cx) / cam->fx, v = -(y + 0.5 - cam->cy) / cam->fy;
    double dw[3], ow[3];
    for (int a = 0; a < 3; a++) {
        dw[a] = cam->c2w[a][0] * u + cam->c2w[a][1] * v - cam->c2w[a][2];
        ow[a] = cam->c2w[a][3];
    }
    const double n = sqrt(dw[0] * dw[0] + dw[1] * dw[1] + dw[2] * dw[2]);
    for (int a = 0; a < 3; a++)
        viewdir[a] = (float)(dw[a] / n);
    if (ndc) {
        /* Move the origin to the near plane z = -1, then project (NeRF's NDC warp with
         * the half-extents cx/fx, cy/fy of the image plane at unit depth). */
        const double near = 1.0, sx = cam->fx / cam->cx, sy = cam->fy / cam->cy;
        const double t = -(near + ow[2]) / dw[2];
        for (int a = 0; a < 3; a++)
            ow[a] += t * dw[a];
        const double o0 = -sx * ow[0] / ow[2], o1 = -sy * ow[1] / ow[2], o2 = 1 + 2 * near / ow[2];
        const double d0 = -sx * (dw[0] / dw[2] - ow[0] / ow[2]);
        const double d1 = -sy * (dw[1] / dw[2] - ow[1] / ow[2]);
        const double d2 = -2 * near / ow[2];
        ow[0] = o0, ow[1] = o1, ow[2] = o2;
        dw[0] = d0, dw[1] = d1, dw[2] = d2;
    }
    for (int a = 0; a < 3; a++) {
        o[a] = (float)ow[a];
        d[a] = (float)dw[a];
    }
}

void cn_sample_coarse(float *t, unsigned n, float near, float far, cn_rng *rng)
{
    const float step = (far - near) / (float)n;
    for (unsigned i = 0; i < n; i++) {
        float u = rng ? (float)cn_rng_uniform(rng) : 0.5f;
        t[i] = near + ((float)i + u) * step;
    }
}

void cn_sample_fine(float *t, unsigned nf, const float *w, unsigned nc, float near, float far,
                    cn_rng *rng)
{
    double sum = 0;
    for (unsigned i = 0; i < nc; i++)
        sum += (double)w[i] + CN_PDF_EPS;
    const double step = ((double)far - near) / nc;
    unsigned i = 0;
    double cdf = 0, p = ((double)w[0] + CN_PDF_EPS) / sum;
    for (unsigned j = 0; j < nf; j++) {
        double u = ((double)j + (rng ? cn_rng_uniform(rng) : 0.5)) / nf;
        while (i + 1 < nc && u >= cdf + p) {
            cdf += p;
            i++;
            p = ((double)w[i] + CN_PDF_EPS) / sum;
        }
        double f = (u - cdf) / p;
        f = f < 0 ? 0 : f > 1 ? 1 : f;
        t[j] = (float)(near + (i + f) * step);
    }
}

void cn_sample_range(const cnerf_info *T, float *lo, float *hi)
{
    if (T->coord == CNERF_COORD_CONTRACT) {
        *lo = 0.0f;
        *hi = 2.0f - ldexpf(1.0f, -(int)CNERF_CONTRACT_SHIFT);
    } else {
        *lo = (float)T->near_q16 / 65536.0f;
        *hi = (float)T->far_q16 / 65536.0f;
    }
}

void cn_ray_t(const cnerf_info *T, float *t, unsigned n)
{
    if (T->coord != CNERF_COORD_CONTRACT)
        return;
    const double near = T->near_q16 / 65536.0, L = (T->far_q16 - T->near_q16) / 65536.0;
    for (unsigned i = 0; i < n; i++) {
        const double s = t[i];
        t[i] = (float)(s <= 1 ? near + s * L : near + L / (2 - s));
    }
}

float cn_ray_far(const cnerf_info *T)
{
    float lo, hi;
    cn_sample_range(T, &lo, &hi);
    cn_ray_t(T, &hi, 1);
    return hi;
}

void cn_ray_point(const cnerf_info *T, const float o[3], const float d[3], float t, float p[3])
{
    for (int a = 0; a < 3; a++)
        p[a] = o[a] + t * d[a];
    if (T->coord != CNERF_COORD_CONTRACT)
        return;
    double c[3], h[3], u[3], m = 0;
    for (int a = 0; a < 3; a++) {
        c[a] = ((double)T->aabb_q16[a] + T->aabb_q16[a + 3]) / 131072.0;
        h[a] = ((double)T->aabb_q16[a + 3] - T->aabb_q16[a]) / 262144.0;
        u[a] = (p[a] - c[a]) / h[a];
        m = fmax(m, fabs(u[a]));
    }
    const double k = m > 1 ? (2 - 1 / m) / m : 1;
    for (int a = 0; a < 3; a++)
        p[a] = (float)(c[a] + h[a] * k * u[a]);
}

void cn_merge_sorted(float *out, const float *a, unsigned na, const float *b, unsigned nb)
{
    unsigned i = 0, j = 0, k = 0;
    while (i < na && j < nb)
        out[k++] = a[i] <= b[j] ? a[i++] : b[j++]; /* ties: coarse first */
    while (i < na)
        out[k++] = a[i++];
    while (j < nb)
        out[k++] = b[j++];
}

static inline float sigmoidf(float x) { return 1.0f / (1.0f + expf(-x)); }

/* Shared per-ray quantities: optical depth s_i, transmittance before each sample. */
static inline float sample_s(const float *raw, size_t ld, const float *t, const uint8_t *inside,
                             unsigned n, unsigned i, float far, float dnorm)
{
    float sigma = raw[i * ld + 3];
    if (!(sigma > 0) || (inside && !inside[i]))
        return 0;
    float delta = (i + 1 < n ? t[i + 1] : far) - t[i];
    return sigma * delta * dnorm;
}

void cn_volume_forward(const float *raw, size_t ld, const float *t, const uint8_t *inside,
                       unsigned n, float far, float dnorm, const float bg[3], float color[3],
                       float *w, float t_stop)
{
    float C[3] = {0, 0, 0};
    double acc = 0; /* sum of s_j for j < i */
    for (unsigned i = 0; i < n; i++) {
        float T = (float)exp(-acc);
        if (T < t_stop) { /* the ray ends: no later sample adds anything */
            for (; w && i < n; i++)
                w[i] = 0;
            break;
        }
        float s = sample_s(raw, ld, t, inside, n, i, far, dnorm);
        float wi = T * (1.0f - expf(-s));
        acc += s;
        if (w)
            w[i] = wi;
        for (int c = 0; c < 3; c++)
            C[c] += wi * sigmoidf(raw[i * ld + c]);
    }
    float Tn = (float)exp(-acc);
    for (int c = 0; c < 3; c++)
        color[c] = C[c] + Tn * bg[c];
}

void cn_volume_backward(float *draw, size_t ld, const float *raw, const float *t,
                        const uint8_t *inside, unsigned n, float far, float dnorm,
                        const float bg[3], const float dC[3])
{
    /* dC/ds_k = T_{k+1} c_k - (sum_{i>k} w_i c_i + T_n bg): one backward sweep keeps the
     * suffix sum; T_{k+1} = exp(-sum_{j<=k} s_j). */
    double total = 0;
    for (unsigned i = 0; i < n; i++)
        total += sample_s(raw, ld, t, inside, n, i, far, dnorm);
    double suffix[3];
    const double Tn = exp(-total);
    for (int c = 0; c < 3; c++)
        suffix[c] = Tn * bg[c];
    double after = total; /* sum_{j<=k} s_j, walked down from the end */
    for (unsigned k = n; k-- > 0;) {
        const float s = sample_s(raw, ld, t, inside, n, k, far, dnorm);
        const double T1 = exp(-after); /* T_{k+1} */
        const double T0 = exp(-(after - s));
        const double wk = T0 - T1;
        double ds = 0;
        for (int c = 0; c < 3; c++) {
            const double ck = sigmoidf(raw[k * ld + c]);
            ds += dC[c] * (T1 * ck - suffix[c]);
            draw[k * ld + c] = (float)(dC[c] * wk * ck * (1 - ck));
            suffix[c] += wk * ck;
        }
        const float sigma = raw[k * ld + 3];
        const int live = sigma > 0 && !(inside && !inside[k]);
        const float delta = (k + 1 < n ? t[k + 1] : far) - t[k];
        draw[k * ld + 3] = live ? (float)(ds * delta * dnorm) : 0.0f;
        after -= s;
    }
}

/* ---- batched rendering ---- */

int cn_batch_init(cn_batch *b, const cnerf_info *topo, size_t cap)
{
    memset(b, 0, sizeof *b);
    b->cap = cap;
    b->nc = topo->n_coarse;
    b->ns = topo->n_nets > 1 ? topo->n_coarse + topo->n_fine : topo->n_coarse;
    const size_t ns = b->ns;
    b->o = malloc(sizeof(float) * cap * 3);
    b->d = malloc(sizeof(float) * cap * 3);
    b->vd = malloc(sizeof(float) * cap * 3);
    b->t_c = malloc(sizeof(float) * cap * b->nc);
    b->t_f = malloc(sizeof(float) * cap * ns);
    b->w_c = malloc(sizeof(float) * cap * b->nc);
    b->pts = malloc(sizeof(float) * cap * ns * 3);
    b->inside[0] = malloc(cap * b->nc);
    b->inside[1] = malloc(cap * ns);
    int bad = !b->o || !b->d || !b->vd || !b->t_c || !b->t_f || !b->w_c || !b->pts ||
              !b->inside[0] || !b->inside[1];
    b->pts_in = malloc(sizeof(float) * cap * ns * 3);
    b->vpe = malloc(sizeof(float) * cap * (topo->in_dir ? topo->in_dir : 1));
    b->t_sat = malloc(sizeof(float) * cap);
    bad |= !b->pts_in || !b->vpe || !b->t_sat;
    for (unsigned n = 0; n < topo->n_nets && !bad; n++) {
        const size_t rows = cap * (n ? ns : b->nc);
        b->color[n] = malloc(sizeof(float) * cap * 3);
        b->rows[n] = malloc(sizeof(uint32_t) * rows);
        b->raw[n] = malloc(sizeof(float) * rows * 4);
        b->draw[n] = malloc(sizeof(float) * rows * 4);
        b->chunk[n] = malloc(sizeof(size_t) * ((cap + CN_CHUNK_RAYS - 1) / CN_CHUNK_RAYS + 1));
        bad |= !b->color[n] || !b->rows[n] || !b->raw[n] || !b->draw[n] || !b->chunk[n] ||
               cn_net_buf_init(&b->nb[n], topo, n, rows) != 0;
    }
    if (bad) {
        cn_batch_free(b);
        return -1;
    }
    return 0;
}

void cn_batch_free(cn_batch *b)
{
    free(b->o);
    free(b->d);
    free(b->vd);
    free(b->t_c);
    free(b->t_f);
    free(b->w_c);
    free(b->pts);
    free(b->pts_in);
    free(b->vpe);
    free(b->t_sat);
    for (int n = 0; n < 2; n++) {
        free(b->rows[n]);
        free(b->raw[n]);
        free(b->draw[n]);
        free(b->inside[n]);
        free(b->color[n]);
        free(b->chunk[n]);
        if (b->nb[n].cap)
            cn_net_buf_free(&b->nb[n]);
    }
    memset(b, 0, sizeof *b);
}

/* Points o + t d of every sample and their inside flags (within the bounds and, when the
 * batch has an occupancy grid for this network, in an occupied cell); the inside ones are
 * compacted into rows and encoded into the network's inputs. */
static void prepare_net_inputs(const cnerf_info *T, unsigned net, cn_batch *b, size_t R,
                               const float *t, unsigned n)
{
    float lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (float)T->aabb_q16[a] / 65536.0f;
        hi[a] = (float)T->aabb_q16[a + 3] / 65536.0f;
    }
    uint8_t *inside = b->inside[net];
    const cn_occ *occ = b->occ[net];
    const int sat = net == 1 && b->sat_eps > 0;
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < R; r++) {
        for (unsigned i = 0; i < n; i++) {
            float *p = b->pts + (r * n + i) * 3;
            int in = !sat || t[r * n + i] <= b->t_sat[r];
            cn_ray_point(T, b->o + r * 3, b->d + r * 3, t[r * n + i], p);
            for (int a = 0; a < 3; a++)
                in &= p[a] >= lo[a] && p[a] <= hi[a];
            inside[r * n + i] = (uint8_t)(in && cn_occ_test(occ, p));
        }
    }
    size_t P = 0;
    const size_t per_chunk = (size_t)CN_CHUNK_RAYS * n;
    b->n_chunks = (R + CN_CHUNK_RAYS - 1) / CN_CHUNK_RAYS;
    for (size_t s = 0; s < R * n; s++) {
        if (s % per_chunk == 0)
            b->chunk[net][s / per_chunk] = P;
        if (inside[s]) {
            b->rows[net][P] = (uint32_t)s;
            memcpy(b->pts_in + 3 * P, b->pts + 3 * s, sizeof(float) * 3);
            P++;
        }
    }
    b->chunk[net][b->n_chunks] = P;
    b->n_rows[net] = P;
    if (T->in_dir)
        cn_posenc(b->vpe, T->in_dir, b->vd, R, T->l_dir, T->pe_flags & CNERF_PE_INCLUDE_INPUT);
    cn_net_inputs(T, net, &b->nb[net], b->pts_in, P, b->vpe, b->rows[net], n);
}

void cn_net_inputs(const cnerf_info *T, unsigned net, cn_net_buf *nb, const float *pts, size_t P,
                   const float *vpe, const uint32_t *rows, unsigned n)
{
    const int inc = T->pe_flags & CNERF_PE_INCLUDE_INPUT;
    cn_posenc(nb->in, nb->ld_in, pts, P, T->l_pos, inc);
    const cnerf_net_info *N = &T->net[net];
    if (N->view_width && T->in_dir) {
        const size_t lv = (size_t)N->width + T->in_dir;
#pragma omp parallel for schedule(static)
        for (size_t j = 0; j < P; j++)
            memcpy(nb->view_in + j * lv + N->width, vpe + (rows ? rows[j] / n : 0) * T->in_dir,
                   sizeof(float) * T->in_dir);
    }
}

/* Every sample's raw outputs: the network's for inside rows, zero density outside. */
static void scatter_outputs(cn_batch *b, unsigned net, size_t samples)
{
    float *raw = b->raw[net];
    const float *out = b->nb[net].out;
    const uint32_t *rows = b->rows[net];
#pragma omp parallel for schedule(static)
    for (size_t s = 0; s < samples; s++) {
        raw[4 * s + 0] = raw[4 * s + 1] = raw[4 * s + 2] = 0.0f;
        raw[4 * s + 3] = -1.0f;
    }
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < b->n_rows[net]; j++)
        memcpy(raw + 4 * (size_t)rows[j], out + 4 * j, sizeof(float) * 4);
}

static float norm3(const float *v) { return sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

static void bg_of(const cnerf_info *T, float bg[3])
{
    for (int c = 0; c < 3; c++)
        bg[c] = T->background[c] / 255.0f;
}

/* t_sat[r]: the coarse sample after the one at which ray r's coarse transmittance
 * 1 - sum(w_c) first falls below sat_eps (far when it never does, or when that was the
 * last sample). */
static void saturation_points(cn_batch *b, size_t R, float far)
{
    const unsigned nc = b->nc;
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < R; r++) {
        const float *w = b->w_c + r * nc, *t = b->t_c + r * nc;
        float T = 1.0f, ts = far;
        for (unsigned i = 0; i + 1 < nc; i++) {
            T -= w[i];
            if (T < b->sat_eps) {
                ts = t[i + 1];
                break;
            }
        }
        b->t_sat[r] = ts;
    }
}

void cn_render_forward(const cn_model *m, cn_batch *b, size_t R, const uint64_t *seed)
{
    const cnerf_info *T = &m->topo;
    float near, far_s;
    cn_sample_range(T, &near, &far_s);
    const float far = cn_ray_far(T);
    const unsigned nc = b->nc, nf = T->n_fine, ns = b->ns;
    float bg[3];
    bg_of(T, bg);
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < R; r++) {
        cn_rng rng = cn_rng_seed(seed ? *seed * 0x9E3779B97F4A7C15ull + b->ray0 + r : 0);
        cn_sample_coarse(b->t_c + r * nc, nc, near, far_s, seed ? &rng : NULL);
        cn_ray_t(T, b->t_c + r * nc, nc);
    }
    prepare_net_inputs(T, 0, b, R, b->t_c, nc);
    cn_net_forward_chunks(m, 0, &b->nb[0], b->chunk[0], b->n_chunks);
    scatter_outputs(b, 0, R * nc);
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < R; r++)
        cn_volume_forward(b->raw[0] + r * nc * 4, 4, b->t_c + r * nc, b->inside[0] + r * nc, nc,
                          far, norm3(b->d + r * 3), b->bg ? b->bg + 3 * r : bg,
                          b->color[0] + r * 3, b->w_c + r * nc, b->t_stop);
    if (T->n_nets < 2)
        return;
    if (b->sat_eps > 0)
        saturation_points(b, R, far);
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < R; r++) {
        float tf[CNERF_MAX_SAMPLES];
        cn_rng rng = cn_rng_seed(
            seed ? (*seed ^ 0x5851F42D4C957F2Dull) * 0x9E3779B97F4A7C15ull + b->ray0 + r : 0);
        cn_sample_fine(tf, nf, b->w_c + r * nc, nc, near, far_s, seed ? &rng : NULL);
        cn_ray_t(T, tf, nf);
        cn_merge_sorted(b->t_f + r * ns, b->t_c + r * nc, nc, tf, nf);
    }
    prepare_net_inputs(T, 1, b, R, b->t_f, ns);
    cn_net_forward_chunks(m, 1, &b->nb[1], b->chunk[1], b->n_chunks);
    scatter_outputs(b, 1, R * ns);
#pragma omp parallel for schedule(static)
    for (size_t r = 0; r < R; r++)
        cn_volume_forward(b->raw[1] + r * ns * 4, 4, b->t_f + r * ns, b->inside[1] + r * ns, ns,
                          far, norm3(b->d + r * 3), b->bg ? b->bg + 3 * r : bg,
                          b->color[1] + r * 3, NULL, b->t_stop);
}

int cn_render_backward(cn_model *m, cn_batch *b, size_t R, float *const dcolor[2])
{
    const cnerf_info *T = &m->topo;
    const float far = cn_ray_far(T);
    float bg[3];
    bg_of(T, bg);
    for (unsigned net = T->n_nets; net-- > 0;) {
        if (!dcolor[net])
            continue;
        const unsigned n = net ? b->ns : b->nc;
        const float *t = net ? b->t_f : b->t_c;
        cn_net_buf *nb = &b->nb[net];
#pragma omp parallel for schedule(static)
        for (size_t r = 0; r < R; r++)
            cn_volume_backward(b->draw[net] + r * n * 4, 4, b->raw[net] + r * n * 4, t + r * n,
                               b->inside[net] + r * n, n, far, norm3(b->d + r * 3),
                               b->bg ? b->bg + 3 * r : bg, dcolor[net] + r * 3);
        const uint32_t *rows = b->rows[net];
#pragma omp parallel for schedule(static)
        for (size_t j = 0; j < b->n_rows[net]; j++)
            memcpy(nb->d_out + 4 * j, b->draw[net] + 4 * (size_t)rows[j], sizeof(float) * 4);
        if (cn_net_backward_chunks(m, net, nb, b->chunk[net], b->n_chunks, b->share))
            return -1;
    }
    return 0;
}
