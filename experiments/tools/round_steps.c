/* round_steps IN.ckpt OUT.ckpt layer|row C: rounds every kernel that a stream sends of a
 * float checkpoint (cnerf train) to a uniform step, and writes the result as a float
 * checkpoint that `cnerf eval` scores (experiments/round_steps.sh). The step is C times the RMS
 * of the layer's kernel ("layer": one step per layer, what the stream's affine decoder can
 * express) or of each output row ("row": a step per row, which it cannot). Prints one line:
 *   scheme C latent_bytes step_bytes total_bytes
 * latent_bytes: the empirical entropy of the integers, one distribution per layer (the
 * stream codes each layer with its own table; the tables themselves are not counted);
 * step_bytes: two bytes per row for the per-row steps (0 for "layer"). The coarse network's
 * colour layers, which a stream does not send by default, are left as they are and not
 * counted. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_ckpt.h"
#include "cn_nerf.h"
#include "cn_buf.h"
#include "cn_file.h"

static double entropy_bits(const long *k, size_t n)
{
    long lo = k[0], hi = k[0];
    for (size_t i = 1; i < n; i++) {
        lo = k[i] < lo ? k[i] : lo;
        hi = k[i] > hi ? k[i] : hi;
    }
    const size_t r = (size_t)(hi - lo) + 1;
    double *h = calloc(r, sizeof *h);
    if (!h)
        return -1;
    for (size_t i = 0; i < n; i++)
        h[k[i] - lo] += 1;
    double bits = 0;
    for (size_t j = 0; j < r; j++)
        if (h[j] > 0)
            bits -= h[j] * log2(h[j] / (double)n);
    free(h);
    return bits;
}

static double rms(const float *w, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += (double)w[i] * w[i];
    return n ? sqrt(s / (double)n) : 0;
}

int main(int argc, char **argv)
{
    if (argc != 5 || (strcmp(argv[3], "layer") && strcmp(argv[3], "row"))) {
        fprintf(stderr, "usage: round_steps IN.ckpt OUT.ckpt layer|row C\n");
        return 2;
    }
    const int per_row = !strcmp(argv[3], "row");
    char *end;
    const double c = strtod(argv[4], &end);
    if (*end || !(c > 0)) {
        fprintf(stderr, "round_steps: C must be a positive number, not '%s'\n", argv[4]);
        return 2;
    }
    uint8_t *data;
    size_t len;
    char err[512];
    cn_ckpt ck;
    if (cn_read_file(argv[1], &data, &len, err, sizeof err) ||
        cn_ckpt_parse(argv[1], data, len, &ck, err, sizeof err)) {
        fprintf(stderr, "round_steps: %s\n", err);
        return 1;
    }
    if (ck.compressed) {
        fprintf(stderr, "round_steps: %s is a compressed checkpoint; give a float one (cnerf "
                "train)\n", argv[1]);
        return 1;
    }
    cn_model m; /* for the layer offsets of the parameter block */
    if (cn_model_init(&m, &ck.hdr, 1, err, sizeof err)) {
        fprintf(stderr, "round_steps: %s\n", err);
        return 1;
    }
    if (m.n_params != ck.n_params) {
        fprintf(stderr, "round_steps: %s holds %llu parameters, its topology %zu\n", argv[1],
                (unsigned long long)ck.n_params, m.n_params);
        return 1;
    }
    /* The parameter block (little-endian f32) is read out, rounded and written back. */
    uint8_t *block = data + (ck.blocks - data);
    float *p = malloc(sizeof(float) * (m.n_params ? m.n_params : 1));
    if (!p) {
        fprintf(stderr, "round_steps: out of memory\n");
        return 1;
    }
    cn_get_f32s(p, block, m.n_params);
    unsigned first = 0, count = 0;
    const int colour = cn_color_layers(&m.topo, 0, &first, &count);
    double bits = 0, step_bits = 0;
    for (unsigned l = 0; l < m.topo.n_layers; l++) {
        const cnerf_layer_info *L = &m.topo.layer[l];
        if (colour && L->net == 0 && l >= first && l < first + count)
            continue; /* not sent */
        const size_t no = L->n_out, ni = L->n_in;
        float *w = p + m.layer[l].w;
        long *k = malloc(sizeof(long) * no * ni);
        if (!k) {
            fprintf(stderr, "round_steps: out of memory\n");
            return 1;
        }
        const double layer_step = c * rms(w, no * ni);
        for (size_t o = 0; o < no; o++) {
            double s = per_row ? c * rms(w + o * ni, ni) : layer_step;
            if (!(s > 0))
                s = layer_step > 0 ? layer_step : 1; /* an all-zero row */
            for (size_t i = 0; i < ni; i++) {
                k[o * ni + i] = lround(w[o * ni + i] / s);
                w[o * ni + i] = (float)(k[o * ni + i] * s);
            }
        }
        step_bits += per_row ? 16.0 * (double)no : 0;
        const double b = entropy_bits(k, no * ni);
        free(k);
        if (b < 0) {
            fprintf(stderr, "round_steps: out of memory\n");
            return 1;
        }
        bits += b;
    }
    cn_buf out = {0};
    cn_buf_f32s(&out, p, m.n_params);
    if (out.oom) {
        fprintf(stderr, "round_steps: out of memory\n");
        return 1;
    }
    memcpy(block, out.p, out.n);
    cn_buf_free(&out);
    const uint32_t crc = cnerf_crc32(0, data, len - 4);
    for (int i = 0; i < 4; i++)
        data[len - 4 + i] = (uint8_t)(crc >> 8 * i);
    FILE *f = fopen(argv[2], "wb");
    if (!f || fwrite(data, 1, len, f) != len || fclose(f)) {
        fprintf(stderr, "round_steps: cannot write %s\n", argv[2]);
        return 1;
    }
    printf("%s %g %.0f %.0f %.0f\n", argv[3], c, bits / 8, step_bits / 8, (bits + step_bits) / 8);
    free(p);
    cn_model_free(&m);
    free(data);
    return 0;
}
