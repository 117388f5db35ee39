#include "cli_args.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <omp.h>

#include "cli.h"
#include "cn_gemm.h"

static int bad(const char *cmd, const char *usage, const char *fmt, const char *a, const char *b)
{
    fprintf(stderr, "cnerf %s: ", cmd);
    fprintf(stderr, fmt, a, b);
    fprintf(stderr, "\n%s\n", usage);
    return -1;
}

static int set_value(const char *cmd, const char *usage, const cli_opt *o, const char *v)
{
    char *end = NULL;
    errno = 0;
    switch (o->kind) {
    case CLI_STR:
        *(const char **)o->dst = v;
        return 0;
    case CLI_LONG: {
        long x = strtol(v, &end, 10);
        if (!*v || *end || errno || x < o->lo || x > o->hi) {
            char range[96];
            snprintf(range, sizeof range, "an integer in [%.0f, %.0f]", o->lo, o->hi);
            return bad(cmd, usage, "%s: expected %s", o->name, range);
        }
        *(long *)o->dst = x;
        return 0;
    }
    case CLI_U64: {
        unsigned long long x = strtoull(v, &end, 10);
        if (!*v || *end || errno || *v == '-')
            return bad(cmd, usage, "%s: '%s' is not a non-negative integer", o->name, v);
        *(uint64_t *)o->dst = x;
        return 0;
    }
    case CLI_DOUBLE: {
        double x = strtod(v, &end);
        if (!*v || *end || errno || !(x >= o->lo && x <= o->hi)) {
            char range[96];
            snprintf(range, sizeof range, "a number in [%g, %g]", o->lo, o->hi);
            return bad(cmd, usage, "%s: expected %s", o->name, range);
        }
        *(double *)o->dst = x;
        return 0;
    }
    case CLI_FLAG:
        break;
    }
    return -1;
}

int cli_parse(const char *cmd, const char *usage, int argc, char **argv, const cli_opt *opts,
              size_t n_opts, const char **pos, int max_pos, int *n_pos)
{
    *n_pos = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            printf("%s\n", usage);
            exit(0);
        }
        if (a[0] != '-' || !a[1]) {
            if (*n_pos >= max_pos)
                return bad(cmd, usage, "unexpected argument '%s'%s", a, "");
            pos[(*n_pos)++] = a;
            continue;
        }
        const cli_opt *o = NULL;
        for (size_t j = 0; j < n_opts; j++)
            if (!strcmp(a, opts[j].name))
                o = &opts[j];
        if (!o)
            return bad(cmd, usage, "unknown option '%s'%s", a, "");
        if (o->kind == CLI_FLAG) {
            *(int *)o->dst = 1;
            continue;
        }
        if (i + 1 >= argc)
            return bad(cmd, usage, "option %s needs a value%s", a, "");
        if (set_value(cmd, usage, o, argv[++i]))
            return -1;
    }
    return 0;
}

void cli_set_threads(long t)
{
    if (t <= 0)
        return;
    cn_gemm_set_threads((int)t);
}
