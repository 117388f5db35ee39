/* The cnerf host program: one function per subcommand. */
#ifndef CNERF_CLI_H
#define CNERF_CLI_H

#include <stddef.h>

int cmd_info(int argc, char **argv);
int cmd_synth(int argc, char **argv);
int cmd_train(int argc, char **argv);
int cmd_eval(int argc, char **argv);

struct cn_dataset;
/* Loads a dataset with the shared options; prints the error and returns 1 on failure. */
int cli_load_dataset(const char *cmd, const char *dir, long downscale, int black, double near,
                     double far, struct cn_dataset *ds);
/* Writes float RGB in [0, 1] as an 8-bit PNG (atomically). */
int cli_write_png(const char *path, const float *rgb, int w, int h, char *err, size_t errlen);
/* mkdir that accepts an existing directory; prints the error and returns 1 on failure. */
int cli_make_dir(const char *cmd, const char *dir);

/* Prints "cnerf <cmd>: <message>" to stderr and returns 1. */
int cli_fail(const char *cmd, const char *fmt, ...);

#endif
