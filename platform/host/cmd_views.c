/* cnerf views DATASET -o DIR: writes a split's views as the trainer sees them (downscaled,
 * composited over the background) as 8-bit PNGs, and an order for coding them as a video;
 * and cnerf train --train-images DIR, which trains on such files instead (for example the
 * same views after a lossy codec). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_buf.h"
#include "cn_file.h"
#include "cli_args.h"
#include "cn_dataset.h"
#include "cn_image.h"

#define VIEWS_USAGE                                                                         \
    "usage: cnerf views DATASET -o DIR [--split train|val|test] [--downscale F|--max-size N] [--black]"

/* The order of views in a path through them for a video coder: nearest camera centre next. */
static double centre_dist2(const cn_view *a, const cn_view *b)
{
    double d = 0;
    for (int k = 0; k < 3; k++)
        d += (a->c2w[k][3] - b->c2w[k][3]) * (a->c2w[k][3] - b->c2w[k][3]);
    return d;
}

/* A path through the views that a video codec can predict along: from the camera farthest
 * from the cameras' mean, always on to the nearest camera not yet visited (the snake order
 * of a capture on a grid, a walk around a 360-degree one). order receives n indices. */
static void snake_order(const cn_view *v, int n, int *order)
{
    double mean[3] = {0, 0, 0};
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            mean[k] += v[i].c2w[k][3] / n;
    int cur = 0;
    double far = -1;
    for (int i = 0; i < n; i++) {
        double d = 0;
        for (int k = 0; k < 3; k++)
            d += (v[i].c2w[k][3] - mean[k]) * (v[i].c2w[k][3] - mean[k]);
        if (d > far)
            far = d, cur = i;
    }
    for (int i = 0; i < n; i++)
        order[i] = i;
    /* order[0..done) is the path; the rest are the views not yet visited. */
    for (int done = 0; done < n; done++) {
        int best = done;
        if (done == 0) {
            for (int j = 0; j < n; j++)
                if (order[j] == cur)
                    best = j;
        } else {
            double bd = INFINITY;
            for (int j = done; j < n; j++) {
                const double d = centre_dist2(&v[order[done - 1]], &v[order[j]]);
                if (d < bd)
                    bd = d, best = j;
            }
        }
        const int t = order[done];
        order[done] = order[best];
        order[best] = t;
    }
}

int cmd_views(int argc, char **argv)
{
    const char *outdir = NULL, *split = "train", *pos[1];
    long downscale = 1, max_size = 0;
    int black = 0, n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &outdir, 0, 0},
        {"--split", CLI_STR, &split, 0, 0},
        {"--downscale", CLI_LONG, &downscale, 1, 64},
        {"--max-size", CLI_LONG, &max_size, 1, 1 << 20},
        {"--black", CLI_FLAG, &black, 0, 0},
    };
    if (cli_parse("views", VIEWS_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos, 1,
                  &n_pos))
        return 2;
    if (n_pos != 1 || !outdir)
        return cli_usage("views", "need a dataset directory and -o DIR\n%s", VIEWS_USAGE);
    if (cli_check_output_dir("views", outdir, pos[0]))
        return 1;
    cn_dataset ds;
    if (cli_load_dataset("views", pos[0], downscale, max_size, black, 0, 0, -1, 1, 0, &ds))
        return 1;
    const cn_view *views = NULL;
    int n = 0, rc = cli_split_views("views", &ds, pos[0], split, &views, &n);
    if (rc == 0)
        rc = cli_make_dir("views", outdir);
    int *order = rc == 0 ? malloc(sizeof(int) * (size_t)n) : NULL;
    if (rc == 0 && !order)
        rc = cli_fail("views", "out of memory");
    char err[1024], path[4200];
    /* Every file it will write, checked before the first is: none is one of the images. */
    for (int i = 0; rc == 0 && i <= n; i++) {
        if (i < n)
            cli_view_path(path, sizeof path, outdir, i);
        else
            snprintf(path, sizeof path, "%s/order.txt", outdir);
        rc = cli_check_output("views", path, NULL, 0, NULL);
    }
    for (int i = 0; rc == 0 && i < n; i++) {
        cli_view_path(path, sizeof path, outdir, i);
        if (cli_write_png(path, views[i].rgb, views[i].w, views[i].h, err, sizeof err))
            rc = cli_fail("views", "%s", err);
    }
    if (rc == 0) {
        snake_order(views, n, order);
        snprintf(path, sizeof path, "%s/order.txt", outdir);
        cn_buf list = {0};
        for (int i = 0; i < n; i++)
            cn_buf_printf(&list, "%04d.png\n", order[i]);
        if (list.oom)
            rc = cli_fail("views", "out of memory");
        else if (cn_write_file_atomic(path, list.p, list.n, err, sizeof err))
            rc = cli_fail("views", "%s", err);
        cn_buf_free(&list);
    }
    if (rc == 0) {
        int lo = 0, hi = 0, differ = 0; /* the smallest and the largest view, by pixels */
        for (int i = 1; i < n; i++) {
            differ |= views[i].w != views[0].w || views[i].h != views[0].h;
            const long a = (long)views[i].w * views[i].h;
            lo = a < (long)views[lo].w * views[lo].h ? i : lo;
            hi = a > (long)views[hi].w * views[hi].h ? i : hi;
        }
        char size[64];
        if (!differ)
            snprintf(size, sizeof size, "%dx%d", views[0].w, views[0].h);
        else if (views[lo].w * views[lo].h == views[hi].w * views[hi].h)
            snprintf(size, sizeof size, "%dx%d and other shapes of as many pixels", views[0].w,
                     views[0].h);
        else
            snprintf(size, sizeof size, "from %dx%d to %dx%d", views[lo].w, views[lo].h,
                     views[hi].w, views[hi].h);
        printf("views: %d %s views of %s, %s, in %s/0000.png ...; a path through them for "
               "a video coder in %s/order.txt\n", n, split, pos[0], size, outdir, outdir);
    }
    free(order);
    cn_dataset_free(&ds);
    return rc;
}

