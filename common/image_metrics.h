/* SPDX-License-Identifier: MIT */
/*
 * Image comparison inside a mask: PSNR and SSIM (Wang et al. 2004: an 11x11
 * Gaussian window, sigma 1.5, K1 0.01, K2 0.03, data range 1), for RGB images
 * of values in [0, 1]. SSIM is computed per channel over the whole image (the
 * window sees unmasked neighbours, as a photograph's would) and averaged over
 * the masked pixels and the three channels.
 */
#ifndef SUNPROBE_COMMON_IMAGE_METRICS_H
#define SUNPROBE_COMMON_IMAGE_METRICS_H

#include <stdint.h>
#include "common/private_api.h"

/* PSNR in dB over pixels with mask != 0 (mask NULL: all); +inf for identical images, NaN for an empty mask. */
SP_PRIVATE double sp_psnr_masked(const float *a, const float *b, const uint8_t *mask, int width, int height);
/* Mean SSIM over pixels with mask != 0 (mask NULL: all); NaN for an empty mask or no memory. */
SP_PRIVATE double sp_ssim_masked(const float *a, const float *b, const uint8_t *mask, int width, int height);

#endif
