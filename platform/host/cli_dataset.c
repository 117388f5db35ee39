/* Loading a dataset as every command does (the validation views held out), and the options
 * that say how its views are composited and trained. */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "cn_file.h"
#include "cn_train.h"

int cli_load_dataset(const char *cmd, const char *dir, long downscale, long max_size, int black,
                     double near, double far, long val_views, long test_every, int test_only,
                     cn_dataset *ds)
{
    if (max_size > 0 && downscale > 1)
        return cli_fail(cmd, "give --downscale or --max-size, not both");
    cn_dataset_opts o;
    memset(&o, 0, sizeof o);
    o.downscale = (int)downscale;
    o.max_size = (int)max_size;
    o.black_bg = black;
    o.near = near;
    o.far = far;
    o.test_every = (int)test_every;
    o.test_only = test_only;
    char err[1024];
    if (cn_dataset_load(dir, &o, ds, err, sizeof err))
        return cli_fail(cmd, "%s", err);
    /* The loader recorded every file it read: an output that is one of them (a hard link to
     * an image, an image outside the dataset's folder) is refused now, before the work. */
    char oerr[8400];
    if (cn_outputs_recheck(oerr, sizeof oerr)) {
        cn_dataset_free(ds);
        return cli_fail(cmd, "%s", oerr);
    }
    if (ds->n_skipped == 1)
        fprintf(stderr, "cnerf %s: warning: %s, frame skipped\n", cmd, ds->skipped);
    else if (ds->n_skipped > 1)
        fprintf(stderr, "cnerf %s: warning: %d frames skipped for a missing image, the first: %s\n",
                cmd, ds->n_skipped, ds->skipped);
    if (ds->note[0])
        printf("%s\n", ds->note);
    const int held = test_only ? 0 : cn_dataset_hold_out(ds, (int)val_views, err, sizeof err);
    if (held < 0) {
        cn_dataset_free(ds);
        return cli_fail(cmd, "%s", err);
    }
    if (max_size > 0) {
        const cn_view *v = ds->n_train ? ds->train : ds->n_test ? ds->test : ds->val;
        printf("--max-size %ld: downscale %d, views %dx%d\n", max_size, ds->downscale,
               v ? v->w : 0, v ? v->h : 0);
    }
    return 0;
}

int cli_random_bg(const char *cmd, const char *word, int *random_bg)
{
    static const char *const words[] = {"off", "on", "auto"};
    for (int i = 0; i < 3; i++)
        if (!strcmp(word, words[i])) {
            *random_bg = i == 2 ? -1 : i;
            return 0;
        }
    return cli_usage(cmd, "--random-bg takes auto, on or off, not '%s'", word);
}

int cli_background(const char *cmd, const char *word, int *contract)
{
    if (!strcmp(word, "constant") || !strcmp(word, "contract") || !strcmp(word, "auto")) {
        *contract = !strcmp(word, "auto") ? -1 : !strcmp(word, "contract");
        return 0;
    }
    return cli_usage(cmd, "--background takes auto, constant or contract, not '%s'", word);
}

void cli_auto_background(const cn_dataset *ds, int n, int *contract)
{
    if (*contract >= 0)
        return;
    int transparent = 0, views = 0, forward = 0;
    for (int m = 0; m < n; m++) {
        forward |= ds[m].ndc;
        views += ds[m].n_train;
        for (int i = 0; i < ds[m].n_train; i++)
            transparent += ds[m].train[i].alpha != NULL;
    }
    *contract = !forward && transparent == 0;
    if (forward)
        printf("background: the constant colour (auto: a forward-facing scene, in NDC)\n");
    else if (transparent)
        printf("background: the constant colour (auto: %d of %d training views have "
               "transparency)\n", transparent, views);
    else
        printf("background: contracted (auto: the %d training views are opaque and see beyond "
               "the object; --background constant for a plain one)\n", views);
}

int cli_coarse_color(const char *cmd, const char *word, double weight, cn_train_opts *o)
{
    if (strcmp(word, "on") && strcmp(word, "off"))
        return cli_usage(cmd, "--coarse-color takes off (the default: the fine network "
                         "gives every pixel's colour, so the coarse one's is not sent) or on "
                         "(sent, for renders with --fine 0), not '%s'", word);
    o->coarse_color = !strcmp(word, "on");
    /* The coarse image is not shown: its error only has to teach the coarse density, and a
     * tenth of the fine error's weight leaves the rate for the fine network (measured in
     * docs/results.md, "At convergence"). */
    o->coarse_weight = weight > 0 ? weight : o->coarse_color ? 1.0 : 0.1;
    return 0;
}

void cli_say_random_bg(const cn_trainer *t)
{
    int clear = 0;
    for (int i = 0; i < t->ds->n_train; i++)
        clear += t->ds->train[i].alpha != NULL;
    if (t->opts.random_bg)
        printf("random backgrounds: %d of %d training views have transparency\n", clear,
               t->ds->n_train);
    else if (clear)
        printf("constant background: %d of %d training views have transparency\n", clear,
               t->ds->n_train);
}
