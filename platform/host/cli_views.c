/* Views on disk: PNGs written and read back, a split's views listed, rendered and scored. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_dataset.h"
#include "cn_image.h"
#include "cn_metrics.h"
#include "cn_train.h"
#include "cn_xsum.h"
#include "progress.h"

/* Writes rgb floats in [0, 1] as an 8-bit PNG. */
int cli_write_png(const char *path, const float *rgb, int w, int h, char *err, size_t errlen)
{
    uint8_t *px = malloc((size_t)w * h * 3);
    if (!px) {
        snprintf(err, errlen, "%s: out of memory", path);
        return -1;
    }
    for (size_t i = 0; i < (size_t)w * h * 3; i++) {
        float v = rgb[i] * 255.0f + 0.5f;
        px[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
    }
    int rc = cn_png_write_rgb8(path, px, w, h, (size_t)w * 3, err, errlen);
    free(px);
    return rc;
}

/* Renders views[i], scores it (psnr, ssim, seconds) and writes it to outdir if given;
 * returns 0, or -1 with the message printed. */
static int eval_view(cn_view_renderer *vr, const cn_model *m, const cn_view *v, int ndc,
                     const char *outdir, float t_stop, double out[3])
{
    const size_t npx = (size_t)v->w * v->h;
    float *rgb = malloc(sizeof(float) * 3 * npx);
    cn_camera cam;
    cn_view_camera(v, &cam);
    const double t0 = cli_now();
    if (!rgb || cn_view_render(vr, m, &cam, ndc, rgb, 4096, t_stop)) {
        free(rgb);
        return cli_fail("eval", "out of memory rendering %s", v->name), -1;
    }
    out[2] = cli_now() - t0;
    out[0] = cn_psnr_from_mse(cn_mse(rgb, v->rgb, 3 * npx));
    out[1] = cn_ssim(rgb, v->rgb, v->w, v->h);
    int bad = 0;
    char err[1024];
    if (outdir) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.png", outdir, v->name);
        bad = cli_write_png(path, rgb, v->w, v->h, err, sizeof err);
    }
    free(rgb);
    return bad ? (cli_fail("eval", "%s", err), -1) : 0;
}

static void eval_line(const cn_view *v, const double r[3])
{
    printf("  %-16s psnr %6.2f dB  ssim %.4f  %.2f s\n", v->name, r[0], r[1], r[2]);
    fflush(stdout);
}

/* Renders every `every`-th view: one process all of them, printing each as it goes; over
 * several ranks (cli_mpi_share) rank k the k-th, (k+N)-th, ..., whose scores are then summed
 * over the ranks (each view's in its own slots, with the ranks' failures) so that every rank
 * has every view's. The means are taken in the views' order either way, so the report is
 * the same. Returns the number of views, or -1 (the message printed by the failing rank). */
int cli_eval_views(const cn_model *m, const cn_view *views, int n, int ndc, long every,
                   const char *outdir, int quiet, float t_stop, double *mean_psnr,
                   double *mean_ssim, double *secs)
{
    /* Every file it will write, checked before the first is: none is one of the inputs. */
    for (int i = 0; outdir && i < n; i += (int)every) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.png", outdir, views[i].name);
        if (cli_check_output("eval", path, NULL, 0, NULL))
            return -1;
    }
    const cn_share *sh = cli_mpi_share();
    const int rank = sh ? sh->rank : 0, ranks = sh ? sh->size : 1;
    const int count = n > 0 ? (int)((n + every - 1) / every) : 0;
    double *r = calloc(3 * (size_t)count + 1, sizeof *r); /* psnr, ssim, seconds; failed */
    if (!r)
        return cli_fail("eval", "out of memory (rank %d of %d)", rank, ranks), -1;
    int failed = 0;
    cn_view_renderer vr;
    memset(&vr, 0, sizeof vr);
    for (int j = rank; j < count && !failed; j += ranks) {
        failed = eval_view(&vr, m, &views[(long)j * every], ndc, outdir, t_stop, &r[3 * j]) != 0;
        if (!failed && !sh && !quiet)
            eval_line(&views[(long)j * every], &r[3 * j]);
    }
    cn_view_renderer_free(&vr);
    if (sh) {
        const size_t nx = 3 * (size_t)count + 1;
        cn_xsum *x = malloc(sizeof *x * nx);
        r[nx - 1] = failed;
        for (size_t i = 0; x && i < nx; i++)
            x[i] = cn_xsum_of(r[i]);
        if (!x || sh->allsum(sh->ctx, x, nx)) {
            free(x);
            free(r);
            return cli_fail("eval", "the ranks' sum of the scores failed"), -1;
        }
        for (size_t i = 0; i < nx; i++)
            r[i] = cn_xsum_value(x[i]);
        free(x);
        failed = r[nx - 1] != 0;
    }
    double sp = 0, ss = 0, st = 0;
    for (int j = 0; j < count && !failed; j++) {
        if (sh && !quiet)
            eval_line(&views[(long)j * every], &r[3 * j]);
        sp += r[3 * j];
        ss += r[3 * j + 1];
        st += r[3 * j + 2];
    }
    free(r);
    if (failed)
        return -1;
    *mean_psnr = count ? sp / count : 0;
    *mean_ssim = count ? ss / count : 0;
    *secs = count ? st / count : 0;
    return count;
}

int cli_split_views(const char *cmd, const cn_dataset *ds, const char *dir, const char *split,
                    const cn_view **views, int *n)
{
    if (!strcmp(split, "test"))
        *views = ds->test, *n = ds->n_test;
    else if (!strcmp(split, "val"))
        *views = ds->val, *n = ds->n_val;
    else if (!strcmp(split, "train"))
        *views = ds->train, *n = ds->n_train;
    else
        return cli_fail(cmd, "unknown split '%s' (test, val, train)", split);
    if (*n == 0)
        return cli_fail(cmd, "%s: the %s split has no views", dir, split);
    return 0;
}

void cli_view_path(char *path, size_t len, const char *dir, int i)
{
    snprintf(path, len, "%s/%04d.png", dir, i);
}

int cli_replace_views(const char *cmd, struct cn_view *views, int n, const char *dir)
{
    char err[1024], path[4200];
    for (int i = 0; i < n; i++) {
        cn_view *v = &views[i];
        cn_image img;
        cli_view_path(path, sizeof path, dir, i);
        if (cn_png_read(path, &img, err, sizeof err))
            return cli_fail(cmd, "%s (--train-images takes the files `cnerf views` writes: "
                            "one per training view)", err);
        if (img.c != 3) {
            cn_image_free(&img);
            return cli_fail(cmd, "%s has an alpha channel: --train-images takes opaque RGB "
                            "views, composited as `cnerf views` writes them", path);
        }
        if (img.w != v->w || img.h != v->h) {
            const int w = img.w, h = img.h;
            cn_image_free(&img);
            return cli_fail(cmd, "%s is %dx%d and training view %d (%s) %dx%d: give the same "
                            "--downscale as to `cnerf views`", path, w, h, i, v->name, v->w,
                            v->h);
        }
        for (size_t p = 0; p < (size_t)v->w * v->h; p++)
            for (int c = 0; c < 3; c++)
                v->rgb[3 * p + c] = img.px[(size_t)img.c * p + (size_t)c];
        cn_image_free(&img);
        free(v->alpha); /* the files are opaque: nothing to recomposite */
        v->alpha = NULL;
    }
    cli_view_path(path, sizeof path, dir, n);
    FILE *extra = fopen(path, "rb");
    if (extra) {
        fclose(extra);
        return cli_fail(cmd, "%s has more views than the dataset's %d training views (%s "
                        "exists): give the same dataset as to `cnerf views`", dir, n, path);
    }
    return 0;
}

/* An orbit camera: view k of n on a circle of `radius` at `elev` degrees, looking at the
 * origin with the z axis up (Blender scenes). */
void cli_orbit_camera(int k, int n, double radius, double elev, double fov, int size,
                      cn_camera *c)
{
    const double th = 2.0 * M_PI * k / n, ph = elev * M_PI / 180.0;
    const double pos[3] = {radius * cos(ph) * cos(th), radius * cos(ph) * sin(th),
                           radius * sin(ph)};
    double back[3], right[3], up[3];
    const double r = sqrt(pos[0] * pos[0] + pos[1] * pos[1] + pos[2] * pos[2]);
    for (int a = 0; a < 3; a++)
        back[a] = pos[a] / r;
    /* right = (0, 0, 1) x back, normalised; up = back x right */
    right[0] = -back[1], right[1] = back[0], right[2] = 0;
    const double rn = sqrt(right[0] * right[0] + right[1] * right[1]);
    for (int a = 0; a < 3; a++)
        right[a] /= rn;
    up[0] = back[1] * right[2] - back[2] * right[1];
    up[1] = back[2] * right[0] - back[0] * right[2];
    up[2] = back[0] * right[1] - back[1] * right[0];
    for (int a = 0; a < 3; a++) {
        c->c2w[a][0] = right[a];
        c->c2w[a][1] = up[a];
        c->c2w[a][2] = back[a];
        c->c2w[a][3] = pos[a];
    }
    c->w = c->h = size;
    c->fx = c->fy = 0.5 * size / tan(0.5 * fov * M_PI / 180.0);
    c->cx = c->cy = 0.5 * size;
}
