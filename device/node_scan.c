/* SPDX-License-Identifier: MIT */
#include "node_scan.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

static int cmp_int(const void *a, const void *b)
{
    int x = *(const int *)a, y = *(const int *)b;
    return (x > y) - (x < y);
}

/* N when name is prefix + digits only, else -1. */
static int entry_number(const char *name, const char *prefix)
{
    size_t n = strlen(prefix);
    if (strncmp(name, prefix, n) != 0 || name[n] < '0' || name[n] > '9')
        return -1;
    char *end;
    errno = 0;
    long v = strtol(name + n, &end, 10);
    return *end || errno || v > INT_MAX ? -1 : (int)v;
}

size_t sp_scan_numbered_entries(const char *dir, const char *prefix, int *nums, size_t max)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    size_t n = 0;
    struct dirent *e;
    while ((e = readdir(d)) && n < max) {
        int num = entry_number(e->d_name, prefix);
        if (num >= 0)
            nums[n++] = num;
    }
    closedir(d);
    qsort(nums, n, sizeof(int), cmp_int);
    return n;
}
