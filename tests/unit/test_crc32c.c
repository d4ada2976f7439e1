/* SPDX-License-Identifier: MIT */
/* CRC-32C: the dispatched and software paths against a bit-at-a-time reference, for every length
 * 0..4096 at random alignments and seeds, around the three-way split's block boundaries, and 1 MiB. */
#include "common/crc32c.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;

static uint32_t rng_u32(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)(rng_state >> 32);
}

/* One bit per step, straight from the definition (reflected polynomial 0x82F63B78). */
static uint32_t crc_ref(uint32_t crc, const uint8_t *p, size_t len)
{
    crc = ~crc;
    for (size_t i = 0; i < len; i++) {
        crc ^= p[i];
        for (int k = 0; k < 8; k++)
            crc = (crc >> 1) ^ (0x82F63B78u & (0u - (crc & 1u)));
    }
    return ~crc;
}

static int failures_before_stop(void)
{
    return check_failures < 20; /* keep a broken build's output readable */
}

static void check_len(const uint8_t *p, size_t len, uint32_t seed)
{
    uint32_t want = crc_ref(seed, p, len);
    uint32_t hw = sp_crc32c(seed, p, len), sw = sp_crc32c_sw(seed, p, len);
    CHECK_MSG(hw == want, "len %zu align %u seed %08x: %08x != %08x", len, (unsigned)((uintptr_t)p & 15),
              (unsigned)seed, (unsigned)hw, (unsigned)want);
    CHECK_MSG(sw == want, "sw len %zu: %08x != %08x", len, (unsigned)sw, (unsigned)want);
}

static void test_all_lengths(uint8_t *buf)
{
    for (size_t len = 0; len <= 4096 && failures_before_stop(); len++)
        check_len(buf + (rng_u32() & 63), len, len & 1 ? rng_u32() : 0);
}

/* Block boundaries of the split (3 x 32, 3 x 256, 3 x 4096 bytes) and their sums, +-9 bytes. */
static void test_boundaries(uint8_t *buf)
{
    static const size_t base[] = { 96, 768, 864, 12288, 12384, 13056, 13152, 24576, 25440 };
    for (size_t i = 0; i < sizeof(base) / sizeof(base[0]); i++)
        for (size_t d = 0; d <= 18; d++)
            check_len(buf + (rng_u32() & 63), base[i] + d - 9, rng_u32());
}

/* 1 MiB (and an odd length near it) in one call and split at random points. */
static void test_large(uint8_t *buf)
{
    size_t sizes[] = { (size_t)1 << 20, ((size_t)1 << 20) - 61 };
    for (int s = 0; s < 2; s++) {
        const uint8_t *p = buf + 1 + s * 6;
        size_t len = sizes[s];
        uint32_t want = crc_ref(0, p, len);
        CHECK_EQ_INT(sp_crc32c(0, p, len), want);
        CHECK_EQ_INT(sp_crc32c_sw(0, p, len), want);
        size_t cut = rng_u32() % len;
        CHECK_EQ_INT(sp_crc32c(sp_crc32c(0, p, cut), p + cut, len - cut), want);
    }
}

/* Published check values: 32 zero bytes, 32 0xFF bytes, "123456789". */
static void test_vectors(void)
{
    uint8_t z[32], f[32];
    memset(z, 0, sizeof(z));
    memset(f, 0xff, sizeof(f));
    CHECK_EQ_INT(sp_crc32c(0, z, sizeof(z)), 0x8A9136AAu);
    CHECK_EQ_INT(sp_crc32c(0, f, sizeof(f)), 0x62A8AB43u);
    CHECK_EQ_INT(sp_crc32c(0, "123456789", 9), 0xE3069283u);
    CHECK_EQ_INT(sp_crc32c(0, NULL, 0), 0u);
}

int main(void)
{
    size_t cap = ((size_t)1 << 20) + 128;
    uint8_t *buf = malloc(cap);
    if (!buf)
        SKIP("cannot allocate %zu bytes", cap);
    for (size_t i = 0; i < cap; i++)
        buf[i] = (uint8_t)rng_u32();
    test_vectors();
    test_all_lengths(buf);
    test_boundaries(buf);
    test_large(buf);
    free(buf);
    return check_exit();
}
