/* latent_context FILE.cnrf: what a context model for the latents could save over the
 * stream's coding (one static frequency table per layer, rANS). For every layer that codes
 * latents it prints, in bytes:
 *   coded     the layer's table and payload as the stream holds them;
 *   static    the latents' empirical entropy with one distribution per layer (what the
 *             table codes at best, the table itself not counted);
 *   adaptive  an adaptive code without a table: each latent coded in the stream's order
 *             (rows, then inputs) with the counts of the latents before it (each value of
 *             the layer's range starts at 1/2, the Krichevsky-Trofimov estimate), the
 *             cost a decoder that learns the distribution as it goes would pay;
 *   column    the same with a context: the mean magnitude of the latents of the same input
 *             in the rows before (5 buckets, and one for the first row);
 *   left      the same with the magnitude of the previous latent of the row (0, 1, 2, 3+);
 *   both      column and left together (3 column buckets x 2 left ones).
 * The adaptive costs are ideal code lengths (-log2 of each probability); an arithmetic
 * coder comes within a few bytes a layer. The last lines give each column's total, the
 * best context's saving against the stream, and the saving when each layer takes the best
 * of the four adaptive codes (its choice, two bits a layer, not counted). Layers that code
 * nothing are left out; so are the shared shifts of several-scene streams (scene 0's
 * latents only). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_file.h"
#include "cnerf/cnerf.h"

enum { N_CODES = 5, MAX_CTX = 6 };
static const char *const code_name[N_CODES] = {"static", "adaptive", "column", "left", "both"};

/* One adaptive distribution per context over the layer's range. */
typedef struct {
    double *count; /* [MAX_CTX][range] */
    double total[MAX_CTX];
    unsigned range;
} adaptive;

static double adaptive_code(adaptive *a, unsigned ctx, unsigned sym)
{
    double *c = a->count + (size_t)ctx * a->range;
    const double bits = -log2((c[sym] + 0.5) / (a->total[ctx] + 0.5 * a->range));
    c[sym] += 1;
    a->total[ctx] += 1;
    return bits;
}

static unsigned magnitude_bucket(double mean)
{
    return mean < 0.5 ? 0 : mean < 1.5 ? 1 : mean < 3 ? 2 : mean < 6 ? 3 : 4;
}

/* Code lengths in bits of one layer's latents k[o * n_in + i] under each model. */
static int layer_bits(const int32_t *k, unsigned n_out, unsigned n_in, int32_t kmin,
                      int32_t kmax, double bits[N_CODES])
{
    const unsigned range = (unsigned)(kmax - kmin) + 1;
    const size_t n = (size_t)n_out * n_in;
    double *hist = calloc(range, sizeof *hist);
    double *col = calloc(n_in, sizeof *col);
    adaptive a[N_CODES];
    int ok = hist && col;
    for (int m = 0; m < N_CODES; m++) {
        memset(&a[m], 0, sizeof a[m]);
        a[m].range = range;
        a[m].count = calloc((size_t)MAX_CTX * range, sizeof(double));
        ok = ok && a[m].count;
        bits[m] = 0;
    }
    if (ok) {
        for (size_t j = 0; j < n; j++)
            hist[k[j] - kmin] += 1;
        for (unsigned r = 0; r < range; r++)
            if (hist[r] > 0)
                bits[0] -= hist[r] * log2(hist[r] / (double)n);
        for (unsigned o = 0; o < n_out; o++)
            for (unsigned i = 0; i < n_in; i++) {
                const int32_t v = k[(size_t)o * n_in + i];
                const unsigned sym = (unsigned)(v - kmin);
                const unsigned cb = o ? magnitude_bucket(col[i] / o) : 5;
                const int32_t prev = i ? k[(size_t)o * n_in + i - 1] : 0;
                const unsigned lb = prev < 0 ? (prev < -3 ? 3 : (unsigned)-prev)
                                             : (prev > 3 ? 3 : (unsigned)prev);
                bits[1] += adaptive_code(&a[1], 0, sym);
                bits[2] += adaptive_code(&a[2], cb, sym);
                bits[3] += adaptive_code(&a[3], lb, sym);
                bits[4] += adaptive_code(&a[4], (cb == 0 ? 0u : cb < 3 ? 1u : 2u) * 2u + (lb > 0),
                                         sym);
                col[i] += v < 0 ? -(double)v : (double)v;
            }
    }
    free(hist);
    free(col);
    for (int m = 0; m < N_CODES; m++)
        free(a[m].count);
    return ok ? 0 : -1;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: latent_context FILE.cnrf\n");
        return 2;
    }
    uint8_t *buf;
    size_t len;
    char err[512];
    if (cn_read_file(argv[1], &buf, &len, err, sizeof err)) {
        fprintf(stderr, "latent_context: %s\n", err);
        return 1;
    }
    static cnerf_info info;
    static cnerf_decoder dec;
    int32_t *k = NULL;
    void *ws = NULL;
    int rc = 1;
    cnerf_status st = cnerf_peek(buf, len, &info);
    const size_t ws_size = st == CNERF_OK ? cnerf_workspace_size(&info) : 0;
    if (st == CNERF_OK) {
        ws = aligned_alloc(CNERF_WS_ALIGN,
                           (ws_size + CNERF_WS_ALIGN - 1) / CNERF_WS_ALIGN * CNERF_WS_ALIGN);
        if (!ws) {
            fprintf(stderr, "latent_context: out of memory\n");
            goto done;
        }
        st = cnerf_open(&dec, buf, len, ws, ws_size);
    }
    if (st != CNERF_OK) {
        fprintf(stderr, "latent_context: %s: %s\n", argv[1], cnerf_status_str(st));
        goto done;
    }
    printf("| layer | net | latents | coded | static | adaptive | column | left | both |\n");
    printf("|---|---|---|---|---|---|---|---|---|\n");
    double total[N_CODES] = {0}, per_layer_best = 0;
    unsigned long coded = 0;
    for (uint32_t l = 0; l < info.n_layers; l++) {
        const cnerf_layer_info *L = &info.layer[l];
        if (L->kmin == L->kmax)
            continue;
        const size_t n = (size_t)L->n_out * L->n_in;
        double bits[N_CODES];
        free(k);
        k = malloc(sizeof *k * n);
        if (!k) {
            fprintf(stderr, "latent_context: out of memory\n");
            goto done;
        }
        for (unsigned o = 0; o < L->n_out; o++)
            for (unsigned i = 0; i < L->n_in; i++)
                k[(size_t)o * L->n_in + i] = cnerf_latent(&dec, l, o, i);
        if (layer_bits(k, L->n_out, L->n_in, L->kmin, L->kmax, bits)) {
            fprintf(stderr, "latent_context: out of memory\n");
            goto done;
        }
        const unsigned long c = (unsigned long)L->table_bytes + L->payload_bytes;
        coded += c;
        printf("| %u | %s | %zu | %lu |", l, L->net ? "fine" : "coarse", n, c);
        double b = bits[1];
        for (int m = 0; m < N_CODES; m++) {
            printf(" %.0f |", bits[m] / 8);
            total[m] += bits[m] / 8;
            b = m > 1 && bits[m] < b ? bits[m] : b;
        }
        per_layer_best += b / 8;
        printf("\n");
    }
    printf("| all | | | %lu |", coded);
    int best = 1;
    for (int m = 0; m < N_CODES; m++) {
        printf(" %.0f |", total[m]);
        if (m > 1 && total[m] < total[best])
            best = m;
    }
    printf("\n\nbest context model: %s, %.0f bytes against %lu coded (%+.2f%%); without a "
           "context: %+.2f%%\n",
           code_name[best], total[best], coded,
           100.0 * (total[best] - (double)coded) / (double)coded,
           100.0 * (total[1] - (double)coded) / (double)coded);
    printf("the best of the four for each layer: %.0f bytes (%+.2f%%)\n", per_layer_best,
           100.0 * (per_layer_best - (double)coded) / (double)coded);
    rc = 0;
done:
    free(k);
    free(ws);
    free(buf);
    return rc;
}
