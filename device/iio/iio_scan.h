/* SPDX-License-Identifier: MIT */
/* Internal: IIO scan element types ("le:s16/16>>0"), record layout and value extraction. */
#ifndef SUNPROBE_DEVICE_IIO_SCAN_H
#define SUNPROBE_DEVICE_IIO_SCAN_H

#include <stddef.h>
#include <stdint.h>

typedef struct sp_iio_scan_type {
    int big_endian;
    int is_signed;
    unsigned realbits, storagebits, shift, repeat;
} sp_iio_scan_type;

/* Parses a scan_elements/..._type string; -EINVAL when malformed or wider than 64 bits. */
int sp_iio_parse_scan_type(const char *text, sp_iio_scan_type *out);
/*
 * Byte offsets of `n` elements in index order, each aligned to its own storage
 * size, as the kernel packs a record; returns the record size (aligned to the
 * largest element), or -EINVAL.
 */
int sp_iio_layout(const sp_iio_scan_type *types, size_t n, uint32_t *offsets);
/* The value of one element (first repeat) at p, shifted, masked and sign-extended. */
int64_t sp_iio_extract(const sp_iio_scan_type *type, const uint8_t *p);

#endif
