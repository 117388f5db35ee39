/* Build-time tool of the firmware (platform/cortex-m/CMakeLists.txt runs it on the host):
 * reads a list of render jobs (each a stream, a scene, a camera, a tile and knobs), sizes the
 * workspace, scratch and tile buffer with the decoder itself (cnerf_workspace_size,
 * cnerf_render_scratch_size; the largest over the jobs) and writes the header
 * cnerf_fw_embed.h that fw_render.c includes: the streams (each once) and the table of jobs.
 * Hosted C99.
 *
 *   cnerf_fw_embed OUT.h JOBS [SET]
 *
 * With SET (a kernel set: "dsp", "mve", "c"), each job's stream and scene are embedded as the
 * packed image for that set (cnerf_pack), 8-byte aligned, which the firmware opens in place
 * (cnerf_open_packed, CNERF_FW_PACKED); the workspace is then not needed.
 *
 * JOBS: one job a line, whitespace-separated:
 *   NAME EXPECT STREAM SCENE CAMERA CAMNAME X0 Y0 W H [N_COARSE N_FINE T_STOP [FLAGS]]
 * NAME and EXPECT (an MD5 or -) are for scripts/firmware.sh and are not embedded. CAMERA is a
 * text file of cameras, 18 integers each (as tests/xarch/render_tile.c reads them), each
 * optionally followed by a name on its line; CAMNAME picks the line whose last word it is, or
 * - the file's first camera. */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cnerf/cnerf.h"
#include "cnerf/tools.h"

#define MAX_JOBS 256
#define MAX_WORDS 16

typedef struct {
    int stream;   /* index into streams[] */
    uint8_t *image; /* with SET: the packed image of the stream's scene */
    size_t image_len;
    long long scene, tile[4], knobs[4], cam[18];
    int have_knobs, host_peek;
    unsigned long long stride;
} job;

typedef struct {
    char *path;
    uint8_t *buf;
    size_t len;
} stream;

static job jobs[MAX_JOBS];
static stream streams[MAX_JOBS];
static int n_jobs, n_streams;

static int die(const char *what, const char *why)
{
    fprintf(stderr, "cnerf_fw_embed: %s: %s\n", what, why);
    return 1;
}

/* A decimal integer in [lo, hi], the whole string. */
static int parse_int(const char *s, long long lo, long long hi, long long *out)
{
    char *end;
    errno = 0;
    const long long v = strtoll(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi)
        return 0;
    *out = v;
    return 1;
}

/* A C constant expression of type long long for any value (LLONG_MIN has no literal). */
static void put_ll(FILE *f, long long v)
{
    if (v == INT64_MIN)
        fprintf(f, "(-9223372036854775807LL - 1)");
    else
        fprintf(f, "(%lldLL)", v);
}

/* The camera named `name` (- the first) of the file: 18 integers and an optional name. */
static int read_camera(const char *path, const char *name, long long cam[18])
{
    FILE *f = fopen(path, "r");
    if (!f)
        return die(path, strerror(errno));
    char line[4096];
    int found = 0;
    while (!found && fgets(line, sizeof line, f)) {
        char *w[20];
        int n = 0;
        for (char *t = strtok(line, " \t\r\n"); t && n < 20; t = strtok(NULL, " \t\r\n"))
            w[n++] = t;
        if (n == 0)
            continue;
        if (strcmp(name, "-") ? !(n == 19 && !strcmp(w[18], name)) : !(n == 18 || n == 19))
            continue;
        for (int i = 0; i < 18; i++)
            if (!parse_int(w[i], INT64_MIN, INT64_MAX, &cam[i])) {
                fclose(f);
                return die(path, "expected 18 integers: rot[9] (Q30) pos[3] (Q32) fx fy cx cy "
                                 "(Q16) width height");
            }
        found = 1;
    }
    fclose(f);
    if (!found)
        return die(path, strcmp(name, "-") ? "no camera of that name" : "no camera");
    for (int i = 0; i < 18; i++) {
        const int is_pos = i >= 9 && i < 12, is_size = i >= 16;
        const long long lo = is_pos ? INT64_MIN : is_size ? 0 : INT32_MIN;
        const long long hi = is_pos ? INT64_MAX : is_size ? 65535 : INT32_MAX;
        if (cam[i] < lo || cam[i] > hi)
            return die(path, "a value is out of the range of its cnerf_camera field");
    }
    return 0;
}

/* The index of the stream at `path`, read whole the first time. */
static int stream_index(const char *path, int *index)
{
    for (int i = 0; i < n_streams; i++)
        if (!strcmp(streams[i].path, path)) {
            *index = i;
            return 0;
        }
    FILE *f = fopen(path, "rb");
    if (!f)
        return die(path, strerror(errno));
    size_t len = 0, cap = 1 << 16;
    uint8_t *buf = malloc(cap);
    for (;;) {
        if (!buf) {
            fclose(f);
            return die(path, "out of memory");
        }
        len += fread(buf + len, 1, cap - len, f);
        if (len < cap)
            break;
        cap *= 2;
        uint8_t *grown = realloc(buf, cap);
        if (!grown)
            free(buf);
        buf = grown;
    }
    const int read_error = ferror(f);
    fclose(f);
    if (read_error || len > UINT32_MAX) {
        free(buf);
        return die(path, read_error ? "read error" : "larger than 4 GB");
    }
    const size_t plen = strlen(path) + 1;
    streams[n_streams].path = malloc(plen);
    streams[n_streams].buf = buf;
    streams[n_streams].len = len;
    if (!streams[n_streams].path)
        return die(path, "out of memory");
    memcpy(streams[n_streams].path, path, plen);
    *index = n_streams++;
    return 0;
}

/* One line of JOBS into jobs[n_jobs]. The tile and knobs: only their syntax and ranges here;
 * whether the tile lies in the image and the knobs suit the stream is for the decoder to say,
 * at run time. */
static int parse_job(char *line, const char *where)
{
    char *w[MAX_WORDS + 1];
    int n = 0;
    for (char *t = strtok(line, " \t\r\n"); t && n <= MAX_WORDS; t = strtok(NULL, " \t\r\n"))
        w[n++] = t;
    if (n == 0 || w[0][0] == '#')
        return 0;
    if (n != 10 && n != 13 && n != 14)
        return die(where, "a job is NAME EXPECT STREAM SCENE CAMERA CAMNAME X0 Y0 W H "
                          "[N_COARSE N_FINE T_STOP [FLAGS]]");
    if (n_jobs == MAX_JOBS)
        return die(where, "more than 256 jobs");
    job *j = &jobs[n_jobs];
    memset(j, 0, sizeof *j);
    if (!parse_int(w[3], 0, CNERF_MAX_SCENES - 1, &j->scene))
        return die(w[3], "a scene index must be in 0..254");
    for (int i = 0; i < 4; i++)
        if (!parse_int(w[6 + i], 0, 65535, &j->tile[i]))
            return die(w[6 + i], "a tile coordinate must be an integer in 0..65535");
    j->have_knobs = n >= 13;
    if (j->have_knobs) {
        if (!parse_int(w[10], 0, 65535, &j->knobs[0]) || !parse_int(w[11], 0, 65535, &j->knobs[1]))
            return die(w[10], "sample counts must be integers in 0..65535");
        if (!parse_int(w[12], 0, 4294967295LL, &j->knobs[2]))
            return die(w[12], "T_STOP must be an integer in 0..2^32-1 (Q30)");
        if (n == 14 && !parse_int(w[13], 0, 4294967295LL, &j->knobs[3]))
            return die(w[13], "FLAGS must be an integer in 0..2^32-1 (CNERF_RENDER_*)");
    }
    if (read_camera(w[4], w[5], j->cam) || stream_index(w[2], &j->stream))
        return 1;
    j->stride = ((unsigned long long)j->tile[2] * 3u + 3u) & ~3ull;
    if (j->stride * (unsigned long long)j->tile[3] > (1u << 22))
        return die(w[0], "the tile buffer would exceed 4 MB, the RAM of the board");
    n_jobs++;
    return 0;
}

/* Job j's stream and scene packed for the kernel set `set` into j->image. */
static int pack_job(job *j, const stream *s, const char *set)
{
    static cnerf_info info;
    static cnerf_decoder dec;
    if (cnerf_peek_scene(s->buf, s->len, (uint32_t)j->scene, &info) != CNERF_OK)
        return die(s->path, "does not parse, so it cannot be packed");
    const size_t n = cnerf_workspace_size(&info);
    void *ws = calloc((n + 7u) / 8u + 1u, 8u);
    cnerf_status st = ws ? cnerf_pack(&dec, s->buf, s->len, (uint32_t)j->scene, set, ws, n,
                                      NULL, 0, &j->image_len)
                         : CNERF_E_WS_SMALL;
    if (st == CNERF_OK && !(j->image = malloc(j->image_len)))
        st = CNERF_E_WS_SMALL;
    if (st == CNERF_OK)
        st = cnerf_pack(&dec, s->buf, s->len, (uint32_t)j->scene, set, ws, n, j->image,
                        j->image_len, &j->image_len);
    free(ws);
    if (st == CNERF_E_ARG)
        return die(set, "not a kernel set (c, dsp, mve, neon, simd128, avx2)");
    if (st != CNERF_OK)
        return die(s->path, cnerf_status_str(st));
    return 0;
}

int main(int argc, char **argv)
{
    /* --fast: the workspace sized by cnerf_workspace_size_fast (every latent as int16) */
    const int fast = argc > 1 && strcmp(argv[1], "--fast") == 0;
    argc -= fast;
    argv += fast;
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: cnerf_fw_embed [--fast] OUT.h JOBS [SET]\n");
        return 2;
    }
    const char *out_path = argv[1], *jobs_path = argv[2], *set = argc == 4 ? argv[3] : NULL;
    if (fast && set) {
        fprintf(stderr, "cnerf_fw_embed: --fast is for streams decoded into RAM, not packed images\n");
        return 2;
    }
    FILE *f = fopen(jobs_path, "r");
    if (!f)
        return die(jobs_path, strerror(errno));
    char line[8192];
    while (fgets(line, sizeof line, f))
        if (parse_job(line, jobs_path)) {
            fclose(f);
            return 1;
        }
    fclose(f);
    if (n_jobs == 0)
        return die(jobs_path, "no jobs");

    /* Static buffer sizes from the decoder: the largest over the jobs. A stream that does not
     * parse is embedded anyway: the firmware then reports the decoder's status. */
    size_t ws = 8, scratch = 8;
    unsigned long long tile_bytes = 4;
    for (int i = 0; i < n_jobs; i++) {
        job *j = &jobs[i];
        static cnerf_info info;
        const stream *s = &streams[j->stream];
        const cnerf_status st = cnerf_peek_scene(s->buf, s->len, (uint32_t)j->scene, &info);
        j->host_peek = (int)st;
        if (st == CNERF_OK) {
            const size_t a = fast ? cnerf_workspace_size_fast(&info) : cnerf_workspace_size(&info);
            const size_t b = cnerf_render_scratch_size(&info);
            ws = a > ws ? a : ws;
            scratch = b > scratch ? b : scratch;
        } else {
            fprintf(stderr,
                    "cnerf_fw_embed: warning: %s does not parse (%s); embedding it anyway, the "
                    "firmware will report the error\n",
                    s->path, cnerf_status_str(st));
        }
        const unsigned long long t = j->stride * (unsigned long long)j->tile[3];
        tile_bytes = t > tile_bytes ? t : tile_bytes;
        if (set && st == CNERF_OK && pack_job(j, s, set))
            return 1;
    }
    if (set)
        ws = 8; /* the images hold the workspaces */

    f = fopen(out_path, "w");
    if (!f)
        return die(out_path, strerror(errno));
    fprintf(f, "/* Generated by cnerf_fw_embed (platform/cortex-m/fw_embed.c) from %s. Do not "
               "edit. */\n",
            jobs_path);
    fprintf(f, "#define CNERF_FW_WS_BYTES %zuu\n", ws);
    fprintf(f, "#define CNERF_FW_SCRATCH_BYTES %zuu\n", scratch);
    fprintf(f, "#define CNERF_FW_TILE_BYTES %lluu\n", tile_bytes);
    fprintf(f, "#define CNERF_FW_JOBS %d\n", n_jobs);
    size_t total = 0;
    for (int i = 0; i < n_streams && !set; i++)
        total += streams[i].len;
    for (int i = 0; i < n_jobs && set; i++)
        total += jobs[i].image_len;
    fprintf(f, "#define CNERF_FW_STREAM_BYTES %zuu /* %s */\n", total,
            set ? "all packed images, one per job" : "all streams, each once");
    for (int i = 0; i < n_jobs && set; i++) {
        const job *j = &jobs[i];
        fprintf(f, "/* job %d, packed for %s */\nstatic const uint8_t cnerf_fw_image%d[%zu] "
                   "__attribute__((aligned(8))) = {",
                i, set, i, j->image_len ? j->image_len : 1);
        for (size_t k = 0; k < j->image_len; k++)
            fprintf(f, "%s0x%02x,", k % 16 ? "" : "\n    ", j->image[k]);
        fprintf(f, "%s\n};\n", j->image_len ? "" : "0");
    }
    for (int i = 0; i < n_streams && !set; i++) {
        const stream *s = &streams[i];
        fprintf(f, "/* %s */\nstatic const uint8_t cnerf_fw_stream%s%.0d[%zu] = {", s->path,
                i ? "_" : "", i, s->len ? s->len : 1);
        for (size_t k = 0; k < s->len; k++)
            fprintf(f, "%s0x%02x,", k % 16 ? "" : "\n    ", s->buf[k]);
        fprintf(f, "%s\n};\n", s->len ? "" : "0");
    }
    fprintf(f, "static const fw_job cnerf_fw_jobs[CNERF_FW_JOBS] = {\n");
    for (int i = 0; i < n_jobs; i++) {
        const job *j = &jobs[i];
        if (set)
            fprintf(f, "    {cnerf_fw_image%d, %zuu, ", i, j->image_len);
        else
            fprintf(f, "    {cnerf_fw_stream%s%.0d, %zuu, ", j->stream ? "_" : "", j->stream,
                    streams[j->stream].len);
        fprintf(f, "%lldu, %d, {%lldu, %lldu, %lldu, %lldu}, "
                   "%lluu, %d, {%lldu, %lldu, %lldu, %lldu},\n     {{",
                j->scene, j->host_peek,
                j->tile[0], j->tile[1], j->tile[2], j->tile[3], j->stride, j->have_knobs,
                j->knobs[0], j->knobs[1], j->knobs[2], j->knobs[3]);
        for (int k = 0; k < 9; k++) {
            put_ll(f, j->cam[k]);
            fputs(k < 8 ? ", " : "}, {", f);
        }
        for (int k = 9; k < 12; k++) {
            put_ll(f, j->cam[k]);
            fputs(k < 11 ? ", " : "}, ", f);
        }
        for (int k = 12; k < 18; k++) {
            put_ll(f, j->cam[k]);
            fputs(k < 17 ? ", " : "}},\n", f);
        }
    }
    fprintf(f, "};\n");
    for (int i = 0; i < n_jobs; i++)
        free(jobs[i].image);
    for (int i = 0; i < n_streams; i++) {
        free(streams[i].buf);
        free(streams[i].path);
    }
    if (fclose(f) != 0) {
        remove(out_path);
        return die(out_path, "write error");
    }
    return 0;
}
