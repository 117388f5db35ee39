/* cnerf quantize model.ckpt -o scene.cnrf [--bits B]: the naive baseline. A float model's
 * kernels are quantized uniformly after training (each layer's range split into 2^B - 1
 * levels) and coded with the same entropy coder and format as cnerf encode's streams. */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "cli_args.h"
#include "cn_pipeline.h"
#include "cn_file.h"
#include "cn_train.h"

#define QUANTIZE_USAGE                                                                        \
    "usage: cnerf quantize model.ckpt -o scene.cnrf [--bits B] [--coarse-color on|off]"

int cmd_quantize(int argc, char **argv)
{
    const char *out = NULL, *pos[1];
    long bits = 8;
    const char *coarse_color = "on";
    int n_pos;
    const cli_opt opts[] = {
        {"-o", CLI_STR, &out, 0, 0},
        {"--bits", CLI_LONG, &bits, 2, 16},
        {"--coarse-color", CLI_STR, &coarse_color, 0, 0},
    };
    if (cli_parse("quantize", QUANTIZE_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos,
                  1, &n_pos))
        return 2;
    if (n_pos != 1 || !out)
        return cli_usage("quantize", "need a checkpoint and -o FILE\n%s", QUANTIZE_USAGE);
    if (strcmp(coarse_color, "on") && strcmp(coarse_color, "off"))
        return cli_usage("quantize", "--coarse-color takes on (the default: the coarse "
                         "network's colour is sent) or off (not sent, as cnerf encode's "
                         "default), not '%s'", coarse_color);
    if (cli_check_output("quantize", out, pos, 1, NULL))
        return 1;
    char err[1024];
    cn_model m;
    long step = 0;
    if (cn_checkpoint_load_model(pos[0], &m, &step, err, sizeof err))
        return cli_fail("quantize", "%s", err);
    int rc = 0;
    if (m.compressed)
        rc = cli_fail("quantize", "%s: a compressed model; its stream comes from cnerf encode",
                      pos[0]);
    char meta[1024];
    snprintf(meta, sizeof meta,
             "encoder=cnerf %s; command=quantize; checkpoint=%s; iters=%ld; bits=%ld; "
             "coarse-color=%s", CNERF_VERSION_STRING, pos[0], step, bits, coarse_color);
    cn_encoded enc;
    memset(&enc, 0, sizeof enc);
    const cn_encode_job job = {.float_model = &m, .bits = (unsigned)bits,
                               .drop_coarse_color = !strcmp(coarse_color, "off"), .n = 1,
                               .meta = meta, .seed = 1};
    if (rc == 0 && (cn_encode_finish(&job, &enc, err, sizeof err) ||
                    cn_write_file_atomic(out, enc.stream.p, enc.stream.n, err, sizeof err)))
        rc = cli_fail("quantize", "%s", err);
    cli_stream st;
    if (rc == 0 && cli_stream_open("quantize", out, &st, NULL) == 0) {
        printf("wrote ");
        cli_print_sizes(out, &st);
        printf("float model: %zu parameters, %zu bytes as float32\n", (size_t)m.topo.n_params +
               m.topo.n_biases, 4 * ((size_t)m.topo.n_params + m.topo.n_biases));
        cli_stream_free(&st);
    } else if (rc == 0)
        rc = 1;
    cn_encoded_free(&enc);
    cn_model_free(&m);
    return rc;
}
