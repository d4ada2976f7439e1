/* SPDX-License-Identifier: MIT */
#include "common/stats.h"

#include <math.h>
#include <stdlib.h>

int sp_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double sp_median_inplace(double *v, size_t n)
{
    if (!v || !n)
        return (double)NAN;
    qsort(v, n, sizeof(double), sp_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
