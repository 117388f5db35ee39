/* cnerf render scene.cnrf: renders views with the fixed-point decoder (tile by tile), compares
 * them with the float reference renderer of the same file and, with a dataset, with the
 * ground truth. Without a dataset it renders an orbit around the scene's centre. */
#include <math.h>
#include <md5.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cnerf/tools.h"
#include "cost_model.h"
#include "cli_args.h"
#include "cn_buf.h"
#include "cn_file.h"
#include "cn_dataset.h"
#include "cn_fixcam.h"
#include "cn_image.h"
#include "cn_metrics.h"
#include "cn_train.h"
#include "progress.h"

#define RENDER_USAGE                                                                          \
    "usage: cnerf render scene.cnrf [--dataset DIR [--split test|val|train] [--downscale F|--max-size N]\n" \
    "       [--every N]] [--orbit N [--size PX] [--radius R] [--elevation DEG] [--fov DEG]]\n" \
    "       [-o DIR] [--float|--no-reference] [--verify MD5] [--coarse N] [--fine N] [--t-stop X]\n" \
    "       [--tile PX] [--threads T] [--save-cameras FILE] [--no-skip] [--scene I]"

typedef struct render_cfg {
    cnerf_render_opts opts;
    long tile;
} render_cfg;

/* The fixed-point render of one camera, tile by tile (tiles in parallel). */
static int render_fixed(const cnerf_decoder *dec, const cnerf_camera *cam, const render_cfg *cfg,
                        uint8_t *px, cnerf_render_stats *stats, char *err, size_t errlen)
{
    const size_t need = cnerf_render_scratch_size(&dec->info);
    const int W = cam->width, H = cam->height, T = (int)cfg->tile;
    const int tx = (W + T - 1) / T, ty = (H + T - 1) / T;
    int bad = 0;
    cnerf_status first = CNERF_OK;
#pragma omp parallel
    {
        void *scratch = aligned_alloc(CNERF_WS_ALIGN, (need + 7) & ~(size_t)7);
        cnerf_render_stats mine;
        memset(&mine, 0, sizeof mine);
#pragma omp for schedule(dynamic, 1)
        for (int k = 0; k < tx * ty; k++) {
            const int x0 = k % tx * T, y0 = k / tx * T;
            const int w = x0 + T > W ? W - x0 : T, h = y0 + T > H ? H - y0 : T;
            cnerf_status st =
                scratch ? cnerf_render_tile_stats(dec, cam, &cfg->opts, (uint32_t)x0, (uint32_t)y0,
                                                  (uint32_t)w, (uint32_t)h,
                                                  px + ((size_t)y0 * W + x0) * 3, (size_t)W * 3,
                                                  scratch, need, &mine)
                        : CNERF_E_WS_SMALL;
            if (st != CNERF_OK) {
#pragma omp critical
                {
                    bad = 1;
                    first = st;
                }
            }
        }
        free(scratch);
#pragma omp critical
        {
            stats->rays += mine.rays;
            stats->evals += mine.evals;
            stats->in_bounds += mine.in_bounds;
            stats->macs += mine.macs;
            stats->list_macs += mine.list_macs;
            stats->list_nz += mine.list_nz;
            stats->samples += mine.samples;
            stats->layer_values += mine.layer_values;
            stats->exact_rescales += mine.exact_rescales;
            stats->wide_macs += mine.wide_macs;
            stats->s8_macs += mine.s8_macs;
        }
    }
    if (bad)
        snprintf(err, errlen, "the decoder refuses to render: %s", cnerf_status_str(first));
    return bad ? -1 : 0;
}

/* PSNR of a against b (8-bit RGB, n values), their largest difference, and the number of
 * pixels that differ by more than 2 in some channel. */
static double psnr_u8(const uint8_t *a, const uint8_t *b, size_t n, int *maxdiff, long *over2)
{
    double s = 0;
    int md = 0;
    long o = 0;
    for (size_t i = 0; i < n; i += 3) {
        int pm = 0;
        for (size_t c = i; c < i + 3; c++) {
            const int d = abs((int)a[c] - (int)b[c]);
            s += (double)d * d;
            pm = d > pm ? d : pm;
        }
        md = pm > md ? pm : md;
        o += pm > 2;
    }
    *maxdiff = md;
    *over2 = o;
    return s == 0 ? INFINITY : 10.0 * log10(255.0 * 255.0 / (s / (double)n));
}

static void to_u8(const float *rgb, uint8_t *px, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        float v = rgb[i] * 255.0f + 0.5f;
        px[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
    }
}

static void to_float(const uint8_t *px, float *rgb, size_t n)
{
    for (size_t i = 0; i < n; i++)
        rgb[i] = px[i] / 255.0f;
}

/* One camera per line: rot[9] (Q30), pos[3] (Q32), fx fy cx cy (Q16), width, height, then
 * the view's name (the format tests/xarch/render_tile.c and the vectors read). */
static void cli_write_camera(cn_buf *f, const cnerf_camera *c, const char *name)
{
    for (int i = 0; i < 9; i++)
        cn_buf_printf(f, "%ld ", (long)c->rot[i]);
    for (int i = 0; i < 3; i++)
        cn_buf_printf(f, "%lld ", (long long)c->pos[i]);
    cn_buf_printf(f, "%ld %ld %ld %ld %u %u %s\n", (long)c->fx, (long)c->fy, (long)c->cx,
                  (long)c->cy, c->width, c->height, name);
}


/* What every view of one render shares, and the totals over the views. */
typedef struct render_job {
    const cnerf_decoder *dec;
    /* The same stream opened as each modelled core would (cost_model.h), and the work each
     * one's renders counted: the estimates of render_totals. */
    cnerf_decoder core_dec[CLI_MAX_CORES];
    void *core_ws[CLI_MAX_CORES];
    cnerf_render_stats core_stats[CLI_MAX_CORES];
    cn_model *ref; /* the float reference of the same file */
    cn_view_renderer ref_vr; /* its batch, kept from view to view */
    const render_cfg *cfg;
    int use_float;
    int no_ref; /* --no-reference: the fixed-point render alone */
    const char *outdir;
    cnerf_render_stats stats;
} render_job;

typedef struct render_tally {
    MD5_CTX all;
    double sum_gt, sum_ref_gt, sum_ssim, sum_vs, sum_ms, sum_ms_ref;
    int count, worst, inf_count;
    long over2_all, px_all;
} render_tally;

/* Renders one camera with the decoder and the float reference; prints the view's line
 * (against the ground truth gt when given); writes its PNG into j->outdir. */
static int render_view(render_job *j, const cn_camera *cam, const cnerf_camera *fc,
                       const char *name, const float *gt, render_tally *t)
{
    const cnerf_info *I = &j->dec->info;
    const size_t npx = (size_t)cam->w * cam->h, nv = 3 * npx;
    uint8_t *px = malloc(nv), *refpx = malloc(nv);
    float *rgb = malloc(sizeof(float) * nv);
    char err[1024];
    int rc = 0;
    if (!px || !refpx || !rgb)
        rc = cli_fail("render", "out of memory");
    double t0 = cli_now();
    if (rc == 0 && !j->use_float &&
        render_fixed(j->dec, fc, j->cfg, px, &j->stats, err, sizeof err))
        rc = cli_fail("render", "%s: %s", name, err);
    const double ms = (cli_now() - t0) * 1e3;
    /* the work each modelled core would do for this view (untimed; the same pixels), once
     * per kernel set (only the first core of a set has a workspace) */
    for (size_t k = 0; rc == 0 && !j->use_float && k < cli_n_cores; k++)
        if (j->core_ws[k] && render_fixed(&j->core_dec[k], fc, j->cfg, refpx, &j->core_stats[k],
                                          err, sizeof err))
            rc = cli_fail("render", "%s: %s", name, err);
    t0 = cli_now();
    /* the float reference ends its rays where the decoder does (t_stop) */
    if (rc == 0 && !j->no_ref && cn_view_render(&j->ref_vr, j->ref, cam, I->coord == CNERF_COORD_NDC, rgb, 4096,
                                  (float)(j->cfg->opts.t_stop / 1073741824.0)))
        rc = cli_fail("render", "out of memory");
    const double ms_ref = (cli_now() - t0) * 1e3;
    if (rc != 0) {
        free(px), free(refpx), free(rgb);
        return rc;
    }
    if (j->no_ref)
        memcpy(refpx, px, nv); /* compared with itself: nothing of it is printed */
    else
        to_u8(rgb, refpx, nv);
    if (j->use_float)
        memcpy(px, refpx, nv);
    char hex[33];
    MD5_CTX one;
    MD5Init(&one);
    MD5Update(&one, px, nv);
    MD5End(&one, hex);
    MD5Update(&t->all, px, nv);
    int md;
    long over2;
    const double vs = psnr_u8(px, refpx, nv, &md, &over2);
    t->over2_all += over2;
    t->px_all += (long)npx;
    printf("  %-12s", name);
    if (gt) {
        to_float(px, rgb, nv);
        const double g = cn_psnr_from_mse(cn_mse(rgb, gt, nv));
        const double s = cn_ssim(rgb, gt, cam->w, cam->h);
        double rg = g; /* --no-reference: nothing of it is printed */
        if (!j->no_ref) {
            to_float(refpx, rgb, nv);
            rg = cn_psnr_from_mse(cn_mse(rgb, gt, nv));
        }
        printf(" psnr %6.2f dB  ssim %.4f", g, s);
        if (!j->no_ref)
            printf(" (float reference %6.2f dB)", rg);
        t->sum_gt += g, t->sum_ssim += s, t->sum_ref_gt += rg;
    }
    if (j->no_ref)
        printf("  %8.1f ms", ms);
    else if (!j->use_float)
        printf("  vs float %6.2f dB, max diff %d (%ld px > 2)  %8.1f ms", vs, md, over2, ms);
    if (!j->no_ref)
        printf("  float %8.1f ms", ms_ref);
    printf("  md5 %s\n", hex);
    fflush(stdout);
    if (isinf(vs))
        t->inf_count++;
    else
        t->sum_vs += vs;
    t->worst = md > t->worst ? md : t->worst;
    t->sum_ms += ms;
    t->sum_ms_ref += ms_ref;
    t->count++;
    if (j->outdir) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.png", j->outdir, name);
        if (cn_png_write_rgb8(path, px, cam->w, cam->h, (size_t)cam->w * 3, err, sizeof err))
            rc = cli_fail("render", "%s", err);
    }
    free(px), free(refpx), free(rgb);
    return rc;
}

/* The totals' lines; checks --verify against the frames' MD5. */
static int render_totals(const render_job *j, render_tally *t, int with_gt, int no_skip,
                         const char *verify)
{
    const cnerf_info *I = &j->dec->info;
    const cnerf_render_opts *o = &j->cfg->opts;
    const int n = t->count;
    printf("mean over %d views (%s, %u+%u samples, t_stop %.3g):", n,
           j->use_float ? "float reference" : "fixed point", o->n_coarse,
           I->n_nets > 1 ? o->n_fine : 0, o->t_stop / 1073741824.0);
    if (with_gt && j->no_ref)
        printf(" psnr %.2f dB  ssim %.4f", t->sum_gt / n, t->sum_ssim / n);
    else if (with_gt)
        printf(" psnr %.2f dB  ssim %.4f (float reference %.2f dB)", t->sum_gt / n,
               t->sum_ssim / n, t->sum_ref_gt / n);
    if (j->no_ref) {
        printf("  %.1f ms/frame\n", t->sum_ms / n);
    } else if (!j->use_float) {
        if (t->inf_count == n)
            printf("  vs float: identical");
        else
            printf("  vs float %.2f dB (%d identical views)", t->sum_vs / (n - t->inf_count),
                   t->inf_count);
        printf(", max diff %d (%ld of %ld px > 2)  %.1f ms/frame", t->worst, t->over2_all,
               t->px_all, t->sum_ms / n);
    }
    if (!j->no_ref)
        printf("  float reference %.1f ms/frame\n", t->sum_ms_ref / n);
    char hex[33];
    MD5End(&t->all, hex);
    printf("md5 of all frames: %s\n", hex);
    const cnerf_render_stats *s = &j->stats;
    if (!j->use_float && s->rays) {
        printf("network evaluations per ray: %.2f (%.2f without skipping%s)\n",
               (double)s->evals / (double)s->rays, (double)s->in_bounds / (double)s->rays,
               I->grid_g ? (no_skip ? "; --no-skip: the grid is ignored" : "")
                         : "; the stream has no occupancy grid");
        printf("network multiply-accumulates per ray: %.0f (%.0f per evaluation)\n",
               (double)s->macs / (double)s->rays,
               s->evals ? (double)s->macs / (double)s->evals : 0.0);
        if (s->list_macs)
            printf("of them in layers summed from lists of their non-zero latents on this "
                   "host: %.0f, which multiplied %.0f\n",
                   (double)s->list_macs / (double)s->rays, (double)s->list_nz / (double)s->rays);
        for (size_t k = 0; k < cli_n_cores; k++) {
            const cli_core *c = &cli_cores[k];
            const cnerf_render_stats *w = &j->core_stats[cli_core_same_work(k)];
            if (!w->rays)
                continue;
            /* per ray over the views, as if each were rendered in one tile */
            const double ipr = cli_cost_instructions(c, w, I, &j->cfg->opts, t->count) /
                               (double)w->rays;
            printf("%s (cost model, within %.0f%% on the conformance vectors): %.0f "
                   "instructions per ray, %.1f s for a 100x100 frame at %.0f MHz\n", c->name,
                   100 * c->error, ipr, ipr * 1e4 / c->hz, c->hz / 1e6);
        }
    }
    if (verify && strcmp(hex, verify))
        return cli_fail("render", "verification failed: the frames' md5 is %s, expected %s",
                        hex, verify);
    if (verify)
        printf("verified: %s\n", hex);
    return 0;
}

/* Sets the samples and the stop threshold asked for; checks them against the stream. */
static int render_options(const char *path, const cnerf_info *I, long coarse, long fine,
                          double t_stop, int no_skip, render_cfg *cfg)
{
    cnerf_render_defaults(I, &cfg->opts);
    if (coarse >= 0)
        cfg->opts.n_coarse = (uint16_t)coarse;
    if (fine >= 0)
        cfg->opts.n_fine = (uint16_t)fine;
    if (t_stop >= 0)
        cfg->opts.t_stop = (uint32_t)llround(t_stop * 1073741824.0);
    if (no_skip)
        cfg->opts.flags |= CNERF_RENDER_NO_SKIP;
    if (I->n_nets > 1 && cfg->opts.n_fine == 0 && !cnerf_net_has_color(I, 0))
        return cli_fail("render", "%s does not carry the coarse network's colour (encoded with "
                        "--coarse-color off, the default): --fine 0 has no image to show; give "
                        "--fine 1 or more, or encode with --coarse-color on", path);
    if (cfg->opts.n_coarse > I->n_coarse || cfg->opts.n_fine > I->n_fine)
        return cli_fail("render", "%s has %u coarse and %u fine samples: --coarse %u --fine %u "
                        "asks for more", path, I->n_coarse, I->n_fine, cfg->opts.n_coarse,
                        cfg->opts.n_fine);
    return 0;
}

int cmd_render(int argc, char **argv)
{
    const char *dataset = NULL, *split = "test", *outdir = NULL, *verify = NULL, *pos[1];
    const char *cam_path = NULL;
    long downscale = 1, max_size = 0, every = 1, threads = 0, orbit = 0, size = 100, coarse = -1, fine = -1;
    long tile = 32, scene = 0;
    double radius = 4.0, elev = 30.0, fov = 40.0, t_stop = -1;
    int use_float = 0, no_ref = 0, no_skip = 0, n_pos;
    const cli_opt opts[] = {
        {"--dataset", CLI_STR, &dataset, 0, 0},
        {"--split", CLI_STR, &split, 0, 0},
        {"--downscale", CLI_LONG, &downscale, 1, 64},
        {"--max-size", CLI_LONG, &max_size, 1, 1 << 20},
        {"--every", CLI_LONG, &every, 1, 1e6},
        {"--orbit", CLI_LONG, &orbit, 1, 10000},
        {"--size", CLI_LONG, &size, 1, 65535},
        {"--radius", CLI_DOUBLE, &radius, 1e-3, 1e4},
        {"--elevation", CLI_DOUBLE, &elev, -89, 89},
        {"--fov", CLI_DOUBLE, &fov, 1, 120},
        {"-o", CLI_STR, &outdir, 0, 0},
        {"--float", CLI_FLAG, &use_float, 0, 0},
        {"--no-reference", CLI_FLAG, &no_ref, 0, 0},
        {"--verify", CLI_STR, &verify, 0, 0},
        {"--coarse", CLI_LONG, &coarse, 1, CNERF_MAX_SAMPLES},
        {"--fine", CLI_LONG, &fine, 0, CNERF_MAX_SAMPLES},
        {"--t-stop", CLI_DOUBLE, &t_stop, 0, 1},
        {"--tile", CLI_LONG, &tile, 1, 65535},
        {"--threads", CLI_LONG, &threads, 1, 256},
        {"--save-cameras", CLI_STR, &cam_path, 0, 0},
        {"--no-skip", CLI_FLAG, &no_skip, 0, 0},
        {"--scene", CLI_LONG, &scene, 0, CNERF_MAX_SCENES - 1},
    };
    if (cli_parse("render", RENDER_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos, 1,
                  &n_pos))
        return 2;
    if (n_pos != 1)
        return cli_usage("render", "need a stream file\n%s", RENDER_USAGE);
    if (!dataset == !orbit)
        return cli_fail("render", "give either --dataset DIR or --orbit N\n%s", RENDER_USAGE);
    if (use_float && no_ref)
        return cli_usage("render", "--float renders the float reference; --no-reference leaves it "
                                   "out: give one of them\n%s", RENDER_USAGE);
    if (verify && (strlen(verify) != 32 || strspn(verify, "0123456789abcdef") != 32))
        return cli_usage("render", "--verify takes 32 lower-case hex digits, not '%s'", verify);
    cli_set_threads(threads);

    cli_stream st;
    cn_model ref;
    if (cli_stream_open_scene("render", pos[0], (unsigned)scene, &st, &ref))
        return 1;
    const cnerf_info *I = &st.dec->info;
    render_cfg cfg = {.tile = tile};
    int rc = render_options(pos[0], I, coarse, fine, t_stop, no_skip, &cfg);
    /* The float reference with the same sample counts; --no-skip: both renderers ignore
     * the stream's occupancy grid. */
    struct cn_occ *grid = ref.grid;
    if (no_skip)
        ref.grid = NULL;
    ref.topo.n_coarse = cfg.opts.n_coarse;
    ref.topo.n_fine = cfg.opts.n_fine;
    if (ref.topo.n_fine == 0)
        ref.topo.n_nets = 1;

    cn_dataset ds;
    memset(&ds, 0, sizeof ds);
    const cn_view *views = NULL;
    int n = orbit ? (int)orbit : 0;
    const int black = I->background[0] == 0 && I->background[1] == 0 && I->background[2] == 0;
    if (rc == 0 && dataset) {
        /* Of a test split only the views rendered are read. */
        const int test = !strcmp(split, "test");
        if (cli_load_dataset("render", dataset, downscale, max_size, black, 0, 0, -1,
                             test ? every : 1, test, &ds))
            rc = 1;
        else
            rc = cli_split_views("render", &ds, dataset, split, &views, &n);
        if (test)
            every = 1; /* the views loaded are the ones to render */
        if (rc == 0 && ds.ndc != (I->coord == CNERF_COORD_NDC))
            rc = cli_fail("render", "%s is %s but %s was encoded %s", dataset,
                          ds.ndc ? "forward-facing (NDC)" : "a 360-degree scene", pos[0],
                          I->coord == CNERF_COORD_NDC ? "in NDC" : "in world coordinates");
    }
    if (rc == 0 && outdir && cn_input_add(pos[0], NULL))
        rc = cli_fail("render", "out of memory recording the inputs");
    if (rc == 0 && outdir && cli_check_output_dir("render", outdir, dataset))
        rc = 1;
    if (rc == 0 && outdir)
        rc = cli_make_dir("render", outdir);
    if (rc == 0 && cam_path && cli_check_output("render", cam_path, pos, 1, dataset))
        rc = 1;
    cn_buf cams = {0}; /* --save-cameras' lines, written at the end */

    render_job job = {.dec = st.dec, .ref = &ref, .cfg = &cfg, .use_float = use_float,
                      .no_ref = no_ref, .outdir = outdir};
    /* The stream as each modelled core opens it: the work its estimate is made from. */
    for (size_t k = 0; rc == 0 && !use_float && !no_ref && k < cli_n_cores; k++) {
        if (cli_core_same_work(k) != k)
            continue; /* counted with an earlier core's set */
        const size_t need = cnerf_workspace_size(I);
        job.core_ws[k] = aligned_alloc(CNERF_WS_ALIGN, (need + 7) & ~(size_t)7);
        if (!job.core_ws[k] ||
            cnerf_open_as(&job.core_dec[k], st.file, st.len, (uint32_t)scene, job.core_ws[k],
                          need, cli_cores[k].set) != CNERF_OK)
            rc = cli_fail("render", "out of memory opening %s as a %s would", pos[0],
                          cli_cores[k].name);
    }
    render_tally tally;
    memset(&tally, 0, sizeof tally);
    MD5Init(&tally.all);
    for (int i = 0; rc == 0 && i < n; i += dataset ? (int)every : 1) {
        cn_camera cam;
        char name[80], err[1024];
        if (dataset) {
            cn_view_camera(&views[i], &cam);
            snprintf(name, sizeof name, "%s", views[i].name);
        } else {
            cli_orbit_camera(i, n, radius, elev, fov, (int)size, &cam);
            snprintf(name, sizeof name, "orbit_%03d", i);
        }
        cnerf_camera fc;
        if (cnerf_camera_from_float(&cam, &fc, err, sizeof err)) {
            rc = cli_fail("render", "%s: %s", name, err);
            break;
        }
        if (cam_path)
            cli_write_camera(&cams, &fc, name);
        rc = render_view(&job, &cam, &fc, name, dataset ? views[i].rgb : NULL, &tally);
    }
    if (rc == 0 && tally.count)
        rc = render_totals(&job, &tally, dataset != NULL, no_skip, verify);
    if (rc == 0 && cam_path && cams.oom)
        rc = cli_fail("render", "out of memory");
    else if (rc == 0 && cam_path) {
        char err[8400];
        if (cn_write_file_atomic(cam_path, cams.p, cams.n, err, sizeof err))
            rc = cli_fail("render", "%s", err);
    }
    cn_buf_free(&cams);
    for (size_t k = 0; k < cli_n_cores; k++)
        free(job.core_ws[k]);
    cn_view_renderer_free(&job.ref_vr);
    cn_dataset_free(&ds);
    ref.grid = grid;
    cn_model_free(&ref);
    cli_stream_free(&st);
    return rc;
}
