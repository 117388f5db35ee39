/* Image quality metrics on float RGB images in [0, 1]. */
#ifndef CNERF_ENC_METRICS_H
#define CNERF_ENC_METRICS_H

#include <stddef.h>

/* Mean squared error over w*h*3 values. */
double cn_mse(const float *a, const float *b, size_t n);
/* PSNR in dB for data range 1: -10 log10(mse); 100 dB caps identical images. */
double cn_psnr_from_mse(double mse);
/* SSIM (Wang et al. 2004): 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03, data range
 * 1, computed per channel over the valid window positions and averaged. -1 if the image is
 * smaller than the window. */
double cn_ssim(const float *a, const float *b, int w, int h);

#endif
