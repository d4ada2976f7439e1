/* SPDX-License-Identifier: MIT */
/* Small order statistics shared by the library's stages and probes. Internal, not installed. */
#ifndef SUNPROBE_COMMON_STATS_H
#define SUNPROBE_COMMON_STATS_H

#include <stddef.h>

/* qsort's comparison of two doubles, ascending (NaNs are not expected). */
int sp_cmp_double(const void *a, const void *b);
/* The median of n values, sorting them in place (the mean of the middle two for even n); NaN for none. */
double sp_median_inplace(double *v, size_t n);

#endif
