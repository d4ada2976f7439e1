/* SPDX-License-Identifier: MIT */
/* IIO scan element types, record layout and value extraction, at their edges. */
#include "device/iio/iio_scan.h"

#include <errno.h>
#include <stdint.h>

#include "check.h"

static void test_parse(void)
{
    sp_iio_scan_type t;
    CHECK_EQ_INT(sp_iio_parse_scan_type("le:s16/16>>0", &t), 0);
    CHECK(!t.big_endian && t.is_signed && t.realbits == 16 && t.storagebits == 16 && t.shift == 0 && t.repeat == 1);
    CHECK_EQ_INT(sp_iio_parse_scan_type("be:u12/16>>4", &t), 0);
    CHECK(t.big_endian && !t.is_signed && t.realbits == 12 && t.shift == 4);
    CHECK_EQ_INT(sp_iio_parse_scan_type("le:s64/64>>0", &t), 0);
    CHECK_EQ_INT(sp_iio_parse_scan_type("le:s16/16X3>>0", &t), 0);
    CHECK_EQ_INT(t.repeat, 3);
    const char *bad[] = { "", "xe:s16/16>>0", "le:q16/16>>0", "le:s17/16>>0", "le:s16/24>>0", "le:s0/16>>0",
                          "le:s12/16>>8", "le:s16/128>>0", "le:s16/16X0>>0", "garbage" };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++)
        CHECK_MSG(sp_iio_parse_scan_type(bad[i], &t) == -EINVAL, "'%s' accepted", bad[i]);
    CHECK_EQ_INT(sp_iio_parse_scan_type(NULL, &t), -EINVAL);
}

static void test_layout(void)
{
    sp_iio_scan_type t16, t64, t8;
    sp_iio_parse_scan_type("le:s16/16>>0", &t16);
    sp_iio_parse_scan_type("le:s64/64>>0", &t64);
    sp_iio_parse_scan_type("le:u8/8>>0", &t8);
    /* three 16-bit axes then a 64-bit timestamp: the timestamp aligns to 8, the record to 8 */
    sp_iio_scan_type a[4] = { t16, t16, t16, t64 };
    uint32_t off[4];
    CHECK_EQ_INT(sp_iio_layout(a, 4, off), 16);
    CHECK(off[0] == 0 && off[1] == 2 && off[2] == 4 && off[3] == 8);
    sp_iio_scan_type b[3] = { t8, t16, t8 };
    CHECK_EQ_INT(sp_iio_layout(b, 3, off), 6);
    CHECK(off[0] == 0 && off[1] == 2 && off[2] == 4);
    CHECK_EQ_INT(sp_iio_layout(a, 0, off), -EINVAL);
}

static void test_extract(void)
{
    sp_iio_scan_type t;
    const uint8_t le_neg[2] = { 0xfe, 0xff }; /* -2 */
    sp_iio_parse_scan_type("le:s16/16>>0", &t);
    CHECK_EQ_INT(sp_iio_extract(&t, le_neg), -2);
    sp_iio_parse_scan_type("le:u16/16>>0", &t);
    CHECK_EQ_INT(sp_iio_extract(&t, le_neg), 65534);
    /* 12 bits, big endian, shifted by 4: 0x800 is the most negative 12-bit value */
    const uint8_t be[2] = { 0x80, 0x0f };
    sp_iio_parse_scan_type("be:s12/16>>4", &t);
    CHECK_EQ_INT(sp_iio_extract(&t, be), -2048);
    const uint8_t ts[8] = { 0x01, 0, 0, 0, 0, 0, 0, 0x80 };
    sp_iio_parse_scan_type("le:s64/64>>0", &t);
    CHECK(sp_iio_extract(&t, ts) == INT64_MIN + 1);
    const uint8_t max32[4] = { 0xff, 0xff, 0xff, 0x7f };
    sp_iio_parse_scan_type("le:s32/32>>0", &t);
    CHECK_EQ_INT(sp_iio_extract(&t, max32), INT32_MAX);
}

int main(void)
{
    test_parse();
    test_layout();
    test_extract();
    return check_exit();
}
