/* PSNR and SSIM. */
#include <math.h>
#include <stdlib.h>

#include "cn_metrics.h"

double cn_mse(const float *a, const float *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)a[i] - b[i];
        s += d * d;
    }
    return n ? s / (double)n : 0;
}

double cn_psnr_from_mse(double mse) { return mse > 1e-10 ? -10.0 * log10(mse) : 100.0; }

#define SSIM_R 5 /* window radius: 11 x 11 */

double cn_ssim(const float *a, const float *b, int w, int h)
{
    if (w < 2 * SSIM_R + 1 || h < 2 * SSIM_R + 1)
        return -1;
    double g[2 * SSIM_R + 1], gs = 0;
    for (int i = -SSIM_R; i <= SSIM_R; i++)
        gs += g[i + SSIM_R] = exp(-(double)(i * i) / (2 * 1.5 * 1.5));
    for (int i = 0; i <= 2 * SSIM_R; i++)
        g[i] /= gs;
    const double C1 = 0.01 * 0.01, C2 = 0.03 * 0.03;
    const int ow = w - 2 * SSIM_R, oh = h - 2 * SSIM_R;
    double total = 0;
    /* Separable filtering of the five moments, one channel at a time. */
    double *tmp = malloc(sizeof(double) * 5 * (size_t)ow * h);
    if (!tmp)
        return -1;
    for (int c = 0; c < 3; c++) {
        for (int y = 0; y < h; y++)
            for (int x = 0; x < ow; x++) {
                double m[5] = {0, 0, 0, 0, 0};
                for (int k = 0; k <= 2 * SSIM_R; k++) {
                    size_t i = ((size_t)y * w + x + k) * 3 + c;
                    double va = a[i], vb = b[i];
                    m[0] += g[k] * va;
                    m[1] += g[k] * vb;
                    m[2] += g[k] * va * va;
                    m[3] += g[k] * vb * vb;
                    m[4] += g[k] * va * vb;
                }
                for (int q = 0; q < 5; q++)
                    tmp[((size_t)q * h + y) * ow + x] = m[q];
            }
        for (int y = 0; y < oh; y++)
            for (int x = 0; x < ow; x++) {
                double m[5] = {0, 0, 0, 0, 0};
                for (int k = 0; k <= 2 * SSIM_R; k++)
                    for (int q = 0; q < 5; q++)
                        m[q] += g[k] * tmp[((size_t)q * h + y + k) * ow + x];
                double va = m[2] - m[0] * m[0], vb = m[3] - m[1] * m[1], cov = m[4] - m[0] * m[1];
                total += ((2 * m[0] * m[1] + C1) * (2 * cov + C2)) /
                         ((m[0] * m[0] + m[1] * m[1] + C1) * (va + vb + C2));
            }
    }
    free(tmp);
    return total / (3.0 * ow * oh);
}
