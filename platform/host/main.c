/* cnerf: the host program. */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"

static void say_error(const char *cmd, const char *fmt, va_list ap)
{
    fprintf(stderr, "cnerf %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
}

int cli_fail(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    say_error(cmd, fmt, ap);
    va_end(ap);
    return 1;
}

int cli_usage(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    say_error(cmd, fmt, ap);
    va_end(ap);
    return 2;
}

static const struct {
    const char *name;
    int (*fn)(int, char **);
    const char *help;
} commands[] = {
    {"info", cmd_info, "info [--check] FILE.cnrf  size breakdown, parameters and topology"},
    {"train", cmd_train,
     "train DATASET -o model.ckpt [--preset P] [--iters N] [--downscale F] [--threads T]\n"
     "                                  [--seed S] [--resume]   train the float NeRF"},
    {"eval", cmd_eval,
     "eval model.ckpt|scene.cnrf DATASET [--split test] [--downscale F] [--every N] [-o DIR]\n"
     "                                  render a split, PSNR and SSIM per view"},
    {"encode", cmd_encode,
     "encode DATASET -o scene.cnrf --lambda L [--preset P] [--iters N] [--downscale F]\n"
     "                                  [--threads T] [--seed S] [--resume CKPT]\n"
     "                                  train with the entropy penalty, write the stream"},
    {"quantize", cmd_quantize,
     "quantize model.ckpt -o scene.cnrf [--bits B]\n"
     "                                  post-training uniform quantization (the baseline)"},
    {"render", cmd_render,
     "render scene.cnrf --dataset DIR [--split test] [--downscale F] [-o DIR] [--float]\n"
     "                                  [--verify MD5] | --orbit N [--size PX]\n"
     "                                  fixed-point decoder render, checked against the float\n"
     "                                  reference and the ground truth"},
    {"pack", cmd_pack,
     "pack scene.cnrf --target CORE -o scene.bin\n"
     "                                  the decoded workspace for one core, read in place\n"
     "                                  from flash by cnerf_open_packed"},
    {"recode", cmd_recode,
     "recode scene.cnrf -o out.cnrf [--level L | --no-level]\n"
     "                                  the stream re-coded without training: its grid by\n"
     "                                  blocks (less decoder RAM), its level; the same pixels"},
    {"views", cmd_views,
     "views DATASET -o DIR [--split train] [--downscale F]\n"
     "                                  a split's views as trained on, as PNGs, and a path\n"
     "                                  through them for a video coder"},
    {"html", cmd_html,
     "html scene.cnrf -o scene.html    the viewer, the WebAssembly decoder and the stream in\n"
     "                                  one file that a browser opens by double-click"},
    {"synth", cmd_synth,
     "synth -o FILE.cnrf [--preset tiny|small|paper] [--seed S] [--spread X]\n"
     "                                  a random model of a preset's topology (tests, demos)"},
};

static void usage(FILE *f)
{
    fprintf(f, "usage: cnerf COMMAND [ARGS] | cnerf help [COMMAND] | cnerf --version\n\n"
               "COMMAND --help (or -h) prints a command's options. Exit status: 0 success, 1\n"
               "failure, 2 a bad command line, 128 + N stopped by signal N.\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  cnerf %s\n", commands[i].help);
}

int main(int argc, char **argv)
{
    /* A log file or pipe gets every line as it is written: a job that is killed leaves its
     * last progress line (stdio would hold up to a block of output). */
    if (!isatty(fileno(stdout)))
        setvbuf(stdout, NULL, _IOLBF, 0);
    if (argc < 2 || !strcmp(argv[1], "-h") || !strcmp(argv[1], "--help")) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("cnerf %s (bitstream %u.%u)\n", CNERF_VERSION_STRING, CNERF_VERSION_MAJOR,
               CNERF_VERSION_MINOR);
        return 0;
    }
    if (!strcmp(argv[1], "help")) { /* cnerf help [COMMAND]: as COMMAND --help */
        if (argc == 2) {
            usage(stdout);
            return 0;
        }
        for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
            if (!strcmp(argv[2], commands[i].name)) {
                char *help_argv[] = {argv[2], "--help", NULL};
                return commands[i].fn(2, help_argv);
            }
        fprintf(stderr, "cnerf help: unknown command '%s'\n", argv[2]);
        usage(stderr);
        return 2;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name)) {
            if (cli_mpi_init(&argc, &argv))
                return cli_mpi_end(1);
            return cli_mpi_end(commands[i].fn(argc - 1, argv + 1));
        }
    fprintf(stderr, "cnerf: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return 2;
}
