/* A small declarative option parser shared by the subcommands. */
#ifndef CNERF_CLI_ARGS_H
#define CNERF_CLI_ARGS_H

#include <stddef.h>
#include <stdint.h>

enum cli_kind { CLI_FLAG, CLI_LONG, CLI_DOUBLE, CLI_STR, CLI_U64 };

typedef struct cli_opt {
    const char *name; /* "--iters" or "-o" */
    enum cli_kind kind;
    void *dst;        /* int*, long*, double*, const char**, uint64_t* */
    double lo, hi;    /* inclusive range for numbers */
} cli_opt;

/* Parses argv[1..argc) into opts and up to max_pos positional arguments. On error prints
 * "cnerf CMD: ..." and the usage to stderr and returns -1. */
int cli_parse(const char *cmd, const char *usage, int argc, char **argv, const cli_opt *opts,
              size_t n_opts, const char **pos, int max_pos, int *n_pos);

/* Sets OpenMP's and OpenBLAS's thread counts (t > 0). */
void cli_set_threads(long t);

#endif
