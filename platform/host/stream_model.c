/* The float reference model of a stream file: read, opened by the decoder's parser and
 * rebuilt with exactly the file's numbers. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cn_export.h"
#include "cn_report.h"
#include "cn_file.h"

int cli_stream_open_scene(const char *cmd, const char *path, unsigned scene, cli_stream *s,
                          cn_model *ref)
{
    char err[1024];
    memset(s, 0, sizeof *s);
    if (ref)
        memset(ref, 0, sizeof *ref);
    if (cn_read_file_sig(path, CLI_STREAM_SIG, 4, &s->file, &s->len, err, sizeof err))
        return cli_fail(cmd, "%s", err);
    s->dec = malloc(sizeof *s->dec);
    if (!s->dec) {
        cli_stream_free(s);
        return cli_fail(cmd, "out of memory");
    }
    cnerf_status st = cnerf_peek_scene(s->file, s->len, scene, &s->dec->info);
    /* the faster workspace: a host has the memory (on x86-64 the int8 sums cost the same) */
    size_t need = st == CNERF_OK ? cnerf_workspace_size_fast(&s->dec->info) : 0;
    if (st == CNERF_OK) {
        s->ws = aligned_alloc(CNERF_WS_ALIGN, (need + CNERF_WS_ALIGN - 1) & ~(size_t)(CNERF_WS_ALIGN - 1));
        st = s->ws ? cnerf_open_scene(s->dec, s->file, s->len, scene, s->ws, need)
                   : CNERF_E_WS_SMALL;
    }
    if (st == CNERF_E_ARG) {
        const unsigned n = s->dec->info.n_scenes;
        cli_stream_free(s);
        return cli_fail(cmd, "%s: no scene %u: the stream has %u (--scene 0..%u)", path, scene, n,
                        n - 1);
    }
    if (st != CNERF_OK) {
        cli_stream_free(s);
        return cli_fail(cmd, "%s: the decoder refuses the stream: %s", path, cnerf_status_str(st));
    }
    if (ref && cn_model_from_stream(s->dec, ref, err, sizeof err)) {
        cli_stream_free(s);
        return cli_fail(cmd, "%s: %s", path, err);
    }
    return 0;
}

int cli_stream_open(const char *cmd, const char *path, cli_stream *s, cn_model *ref)
{
    return cli_stream_open_scene(cmd, path, 0, s, ref);
}

void cli_stream_free(cli_stream *s)
{
    free(s->ws);
    free(s->dec);
    free(s->file);
    memset(s, 0, sizeof *s);
}

void cli_print_sizes(const char *path, const cli_stream *s)
{
    cn_totals tot;
    cn_breakdown(&s->dec->info, &tot);
    const cnerf_info *I = &s->dec->info;
    if (I->shared_bytes) { /* one scene of several: its own chunks, the shared ones */
        printf("%s: %zu bytes, %u scenes; scene %u: %" PRIu32 " bytes of its own (latent payload "
               "%llu), %.3f bits per parameter; shared shifts %" PRIu32 " bytes\n",
               path, s->len, I->n_scenes, I->scene, I->scene_bytes,
               (unsigned long long)tot.payload, 8.0 * I->scene_bytes / I->n_params,
               I->shared_bytes);
        return;
    }
    const uint64_t overhead = tot.total - tot.payload;
    printf("%s: %zu bytes = latent payload %llu + overhead %llu (tables %llu, affine %llu, "
           "biases %llu, headers %llu); %.3f bits per parameter\n",
           path, s->len, (unsigned long long)tot.payload, (unsigned long long)overhead,
           (unsigned long long)tot.tables, (unsigned long long)tot.affine,
           (unsigned long long)tot.biases,
           (unsigned long long)(tot.layer_hdr + tot.stream_hdr + tot.ancillary),
           8.0 * (double)s->len / s->dec->info.n_params);
}
