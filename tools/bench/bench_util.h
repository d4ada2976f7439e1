/* SPDX-License-Identifier: MIT */
/* Helpers the benchmarks share: the median of a few timed runs and this thread's CPU time. */
#ifndef SUNPROBE_BENCH_UTIL_H
#define SUNPROBE_BENCH_UTIL_H

#include <stdint.h>
#include <stdlib.h>
#include <time.h>

static int bench_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The median of n values (v is sorted in place). */
static inline double bench_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), bench_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Thread CPU time in ns: robust to other jobs sharing the cores. */
static inline int64_t bench_thread_cpu_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

#endif
