/* SPDX-License-Identifier: MIT */
/* IIO scan element types, record layout and value extraction (Documentation/ABI: iio scan_elements). */
#include "device/iio/iio_scan.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

int sp_iio_parse_scan_type(const char *text, sp_iio_scan_type *out)
{
    char endian[3], sign;
    unsigned real, storage, shift = 0, repeat = 1;
    if (!text || !out)
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    /* "le:s12/16>>4", or with a repeat count "le:s16/16X3>>0" */
    if (sscanf(text, "%2[lb]e:%c%u/%uX%u>>%u", endian, &sign, &real, &storage, &repeat, &shift) != 6) {
        repeat = 1;
        if (sscanf(text, "%2[lb]e:%c%u/%u>>%u", endian, &sign, &real, &storage, &shift) != 5)
            return -EINVAL;
    }
    if ((sign != 's' && sign != 'u') || real == 0 || real > storage || (storage != 8 && storage != 16 &&
        storage != 32 && storage != 64) || shift >= storage || real + shift > storage || repeat == 0 || repeat > 16)
        return -EINVAL;
    out->big_endian = endian[0] == 'b';
    out->is_signed = sign == 's';
    out->realbits = real;
    out->storagebits = storage;
    out->shift = shift;
    out->repeat = repeat;
    return 0;
}

int sp_iio_layout(const sp_iio_scan_type *types, size_t n, uint32_t *offsets)
{
    if (!types || !offsets || n == 0)
        return -EINVAL;
    uint32_t pos = 0, largest = 1;
    for (size_t i = 0; i < n; i++) {
        uint32_t bytes = types[i].storagebits / 8;
        if (bytes == 0)
            return -EINVAL;
        pos = (pos + bytes - 1) / bytes * bytes;
        offsets[i] = pos;
        pos += bytes * (types[i].repeat ? types[i].repeat : 1);
        if (bytes > largest)
            largest = bytes;
    }
    pos = (pos + largest - 1) / largest * largest;
    return pos > 4096 ? -EINVAL : (int)pos;
}

int64_t sp_iio_extract(const sp_iio_scan_type *t, const uint8_t *p)
{
    unsigned bytes = t->storagebits / 8;
    uint64_t v = 0;
    for (unsigned i = 0; i < bytes; i++) {
        unsigned b = t->big_endian ? i : bytes - 1 - i;
        v = (v << 8) | p[b];
    }
    v >>= t->shift;
    if (t->realbits < 64) {
        uint64_t mask = (UINT64_C(1) << t->realbits) - 1;
        v &= mask;
        if (t->is_signed && (v >> (t->realbits - 1)) & 1)
            v |= ~mask;
    }
    return (int64_t)v;
}
