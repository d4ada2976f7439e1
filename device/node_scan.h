/* SPDX-License-Identifier: MIT */
/* Finding numbered device entries (video0, iio:device3, ...) in a directory. */
#ifndef SUNPROBE_DEVICE_NODE_SCAN_H
#define SUNPROBE_DEVICE_NODE_SCAN_H

#include <stddef.h>

/*
 * Writes into nums (at most max) the N of every entry of `dir` named exactly
 * PREFIX followed by a decimal number N >= 0, sorted ascending; returns how many.
 * A missing directory yields 0.
 */
size_t sp_scan_numbered_entries(const char *dir, const char *prefix, int *nums, size_t max);

#endif
