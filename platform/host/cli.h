/* The cnerf host program: one function per subcommand. */
#ifndef CNERF_CLI_H
#define CNERF_CLI_H

int cmd_info(int argc, char **argv);
int cmd_synth(int argc, char **argv);

/* Prints "cnerf <cmd>: <message>" to stderr and returns 1. */
int cli_fail(const char *cmd, const char *fmt, ...);

#endif
