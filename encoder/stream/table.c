/* PMF -> frequency table quantization, table and payload cost estimates. */
#include <math.h>
#include <stdlib.h>

#include "cn_stream.h"

/* A binary min-heap of symbol indices ordered by key[]. */
typedef struct heap {
    uint32_t *idx;
    double *key;
    uint32_t n;
} heap;

static void sift_down(heap *h, uint32_t i)
{
    for (;;) {
        uint32_t l = 2 * i + 1, r = l + 1, m = i;
        if (l < h->n && h->key[h->idx[l]] < h->key[h->idx[m]])
            m = l;
        if (r < h->n && h->key[h->idx[r]] < h->key[h->idx[m]])
            m = r;
        if (m == i)
            return;
        uint32_t t = h->idx[i];
        h->idx[i] = h->idx[m];
        h->idx[m] = t;
        i = m;
    }
}

/* Bits lost by taking one count from f (mass p): p*(log2 f - log2(f-1)); f = 1 cannot. */
static double cost_remove(double p, uint32_t f)
{
    return f <= 1 ? HUGE_VAL : p * (log2((double)f) - log2((double)f - 1.0));
}

/* Bits lost by NOT adding a count: -(p*(log2(f+1) - log2 f)), so the min is the best add. */
static double cost_add(double p, uint32_t f)
{
    return -p * (log2((double)f + 1.0) - log2((double)f));
}

int cn_quantize_pmf(const double *p, uint32_t n, unsigned prec, uint32_t *freq)
{
    if (n == 0 || prec > CNERF_MAX_PREC || n > (1u << prec))
        return -1;
    const uint32_t M = 1u << prec;
    double total = 0;
    for (uint32_t i = 0; i < n; i++)
        total += p[i] > 0 && isfinite(p[i]) ? p[i] : 0.0;
    int64_t sum = 0;
    for (uint32_t i = 0; i < n; i++) {
        double q = total > 0 && p[i] > 0 && isfinite(p[i]) ? p[i] / total : 0.0;
        double r = floor(q * M + 0.5);
        freq[i] = r < 1 ? 1u : r > M ? M : (uint32_t)r;
        sum += freq[i];
    }
    if (sum == (int64_t)M)
        return 0;
    heap h = {malloc(sizeof(uint32_t) * n), malloc(sizeof(double) * n), n};
    if (!h.idx || !h.key) {
        free(h.idx);
        free(h.key);
        return -1;
    }
    const int remove = sum > (int64_t)M;
    for (uint32_t i = 0; i < n; i++) {
        double q = total > 0 && p[i] > 0 && isfinite(p[i]) ? p[i] / total : 0.0;
        h.idx[i] = i;
        h.key[i] = remove ? cost_remove(q, freq[i]) : cost_add(q, freq[i]);
    }
    for (uint32_t i = n / 2; i-- > 0;)
        sift_down(&h, i);
    while (sum != (int64_t)M) {
        uint32_t s = h.idx[0];
        double q = total > 0 && p[s] > 0 && isfinite(p[s]) ? p[s] / total : 0.0;
        if (remove) {
            freq[s]--; /* key < HUGE_VAL: n <= M guarantees some f > 1 while sum > M */
            sum--;
            h.key[s] = cost_remove(q, freq[s]);
        } else {
            freq[s]++;
            sum++;
            h.key[s] = cost_add(q, freq[s]);
        }
        sift_down(&h, 0);
    }
    free(h.idx);
    free(h.key);
    return 0;
}

uint64_t cn_table_bits(const uint32_t *freq, uint32_t n, unsigned *order)
{
    uint64_t best = UINT64_MAX;
    unsigned best_k = 0;
    for (unsigned k = 0; k <= CNERF_MAX_EG_ORDER; k++) {
        uint64_t bits = 0;
        for (uint32_t i = 0; i + 1 < n; i++)
            bits += cn_eg_bits(freq[i] - 1, k);
        if (bits < best) {
            best = bits;
            best_k = k;
        }
    }
    if (order)
        *order = best_k;
    return n < 2 ? 0 : best;
}

double cn_table_cost_bits(const uint64_t *cnt, const uint32_t *freq, uint32_t n, unsigned prec)
{
    double bits = 0;
    for (uint32_t i = 0; i < n; i++)
        if (cnt[i])
            bits += (double)cnt[i] * ((double)prec - log2((double)freq[i]));
    return bits;
}
