/* SPDX-License-Identifier: MIT */
/*
 * CRC-32C: slicing-by-8 tables in software; with the SSE4.2 / ARMv8 CRC instruction when present.
 * The instruction has ~3 cycles latency but issues once per cycle, so long buffers are cut into
 * three equal blocks checksummed as three independent chains, then joined: a block's CRC is
 * moved past the bytes that follow it by a carry-less multiply (PCLMULQDQ / PMULL) with the
 * precomputed constant x^(8n-33) mod P, reduced back to 32 bits with the CRC instruction itself.
 */
#include "crc32c.h"

#include <string.h>

#define POLY_REFLECTED 0x82F63B78u

static uint32_t table[8][256];
static int table_ready;

static void build_tables(void)
{
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t c = i;
        for (int k = 0; k < 8; k++)
            c = (c >> 1) ^ (POLY_REFLECTED & (0u - (c & 1u)));
        table[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; i++)
        for (int t = 1; t < 8; t++)
            table[t][i] = (table[t - 1][i] >> 8) ^ table[0][table[t - 1][i] & 0xff];
    __atomic_store_n(&table_ready, 1, __ATOMIC_RELEASE);
}

uint32_t sp_crc32c_sw(uint32_t crc, const void *data, size_t len)
{
    if (!__atomic_load_n(&table_ready, __ATOMIC_ACQUIRE))
        build_tables(); /* idempotent: racing builders write identical values */
    const uint8_t *p = data;
    crc = ~crc;
    while (len >= 8) {
        uint32_t lo, hi;
        memcpy(&lo, p, 4);
        memcpy(&hi, p + 4, 4);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
        lo = __builtin_bswap32(lo);
        hi = __builtin_bswap32(hi);
#endif
        lo ^= crc;
        crc = table[7][lo & 0xff] ^ table[6][(lo >> 8) & 0xff] ^ table[5][(lo >> 16) & 0xff] ^
              table[4][lo >> 24] ^ table[3][hi & 0xff] ^ table[2][(hi >> 8) & 0xff] ^
              table[1][(hi >> 16) & 0xff] ^ table[0][hi >> 24];
        p += 8;
        len -= 8;
    }
    while (len--)
        crc = (crc >> 8) ^ table[0][(crc ^ *p++) & 0xff];
    return ~crc;
}

/*
 * Hardware primitives per architecture: hw_crc_u64 / hw_crc_u8 extend a pre-inverted CRC held
 * in the low 32 bits of a hw_state (upper bits zero); hw_clmul32 is the 63-bit carry-less product
 * of two 32-bit values. have_hw() returns 0 (no CRC instruction), 1 (CRC instruction only) or
 * 2 (CRC and carry-less multiply).
 */
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HW_TARGET __attribute__((target("sse4.2,pclmul")))
/* 64-bit state: crc32q writes a 64-bit register, and truncating it every step would put an
 * extra zero-extending move into each chain's critical path */
typedef uint64_t hw_state;

HW_TARGET static inline hw_state hw_crc_u64(hw_state c, uint64_t v)
{
    return __builtin_ia32_crc32di(c, v);
}

HW_TARGET static inline hw_state hw_crc_u8(hw_state c, uint8_t v)
{
    return __builtin_ia32_crc32qi((uint32_t)c, v);
}

HW_TARGET static inline uint64_t hw_clmul32(uint32_t a, uint32_t b)
{
    __m128i p = _mm_clmulepi64_si128(_mm_cvtsi32_si128((int)a), _mm_cvtsi32_si128((int)b), 0);
    return (uint64_t)_mm_cvtsi128_si64(p);
}

static int have_hw(void)
{
    __builtin_cpu_init();
    if (!__builtin_cpu_supports("sse4.2"))
        return 0;
    return __builtin_cpu_supports("pclmul") ? 2 : 1;
}
#define HAVE_HW_CRC 1
#elif defined(__aarch64__) && defined(__GNUC__) && defined(__linux__) && defined(__BYTE_ORDER__) && \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#include <arm_neon.h>
#include <sys/auxv.h>
#ifndef HWCAP_CRC32
#define HWCAP_CRC32 (1 << 7)
#endif
#ifndef HWCAP_PMULL
#define HWCAP_PMULL (1 << 4)
#endif
#define HW_TARGET __attribute__((target("+crc+crypto")))
typedef uint32_t hw_state;

HW_TARGET static inline hw_state hw_crc_u64(hw_state c, uint64_t v)
{
    return __builtin_aarch64_crc32cx(c, v);
}

HW_TARGET static inline hw_state hw_crc_u8(hw_state c, uint8_t v)
{
    return __builtin_aarch64_crc32cb(c, v);
}

HW_TARGET static inline uint64_t hw_clmul32(uint32_t a, uint32_t b)
{
    return vgetq_lane_u64(vreinterpretq_u64_p128(vmull_p64((poly64_t)a, (poly64_t)b)), 0);
}

static int have_hw(void)
{
    unsigned long caps = getauxval(AT_HWCAP);
    if (!(caps & HWCAP_CRC32))
        return 0;
    return (caps & HWCAP_PMULL) ? 2 : 1;
}
#define HAVE_HW_CRC 1
#endif

#ifdef HAVE_HW_CRC
/* Block lengths (bytes, multiples of 8) of the three-way split, longest first; shorter tiers
 * pick up what the longer ones leave, the final < 3 * 32 bytes go through one chain. */
static const size_t tier_len[] = { 4096, 256, 32 };
#define NTIERS (sizeof(tier_len) / sizeof(tier_len[0]))
/* tier_k[t][0] moves a CRC past one block, tier_k[t][1] past two (see shift_const). */
static uint32_t tier_k[NTIERS][2];

/* a * b mod P, both bit-reflected (bit 31 holds x^0). */
static uint32_t gf2_mulmod(uint32_t a, uint32_t b)
{
    uint32_t prod = 0;
    for (int i = 31; i >= 0; i--) {
        prod ^= b & (0u - ((a >> i) & 1u));
        b = (b >> 1) ^ (POLY_REFLECTED & (0u - (b & 1u))); /* b *= x */
    }
    return prod;
}

/* x^n mod P, bit-reflected, by square and multiply. */
static uint32_t gf2_xpow(uint64_t n)
{
    uint32_t result = 0x80000000u, base = 0x40000000u; /* 1 and x */
    for (; n; n >>= 1) {
        if (n & 1u)
            result = gf2_mulmod(result, base);
        base = gf2_mulmod(base, base);
    }
    return result;
}

/*
 * The reflected 63-bit product of two reflected 32-bit polynomials A, B stands for A*B*x in
 * 64 reflected bits, and the CRC instruction over those 8 bytes from a zero state multiplies by
 * x^32 mod P: so K = x^(8n-33) turns a CRC into CRC * x^(8n), i.e. extended by n zero bytes.
 */
static uint32_t shift_const(size_t nbytes)
{
    return gf2_xpow((uint64_t)nbytes * 8u - 33u);
}

static void init_tiers(void)
{
    for (size_t t = 0; t < NTIERS; t++) {
        /* atomic stores: racing initialisers write the same values without a data race */
        __atomic_store_n(&tier_k[t][0], shift_const(tier_len[t]), __ATOMIC_RELAXED);
        __atomic_store_n(&tier_k[t][1], shift_const(2 * tier_len[t]), __ATOMIC_RELAXED);
    }
}

HW_TARGET static inline uint64_t load64(const uint8_t *p)
{
    uint64_t v;
    memcpy(&v, p, 8);
    return v;
}

/* Extends c over 3 * blk bytes at p as three independent chains joined at the end. */
HW_TARGET static hw_state crc_3way(hw_state c, const uint8_t *p, size_t blk, uint32_t k1, uint32_t k2)
{
    hw_state a = c, b = 0, d = 0;
    const uint8_t *q = p + blk, *r = p + 2 * blk;
    for (size_t i = 0; i < blk; i += 8) {
        a = hw_crc_u64(a, load64(p + i));
        b = hw_crc_u64(b, load64(q + i));
        d = hw_crc_u64(d, load64(r + i));
    }
    /* (a * x^(16 blk) + b * x^(8 blk)) mod P; the reduction is linear, so one suffices */
    return hw_crc_u64(0, hw_clmul32((uint32_t)a, k2) ^ hw_clmul32((uint32_t)b, k1)) ^ d;
}

/* Runs the three-way split over as much of *p as the tiers cover; advances *p and *len.
 * Out of line so short buffers, which skip it, pay for no register spills. */
HW_TARGET __attribute__((noinline)) static hw_state crc_tiers(hw_state c, const uint8_t **p, size_t *len)
{
    const uint8_t *q = *p;
    size_t n = *len;
    for (size_t t = 0; t < NTIERS; t++) {
        size_t blk = tier_len[t];
        if (n < 3 * blk)
            continue;
        uint32_t k1 = __atomic_load_n(&tier_k[t][0], __ATOMIC_RELAXED);
        uint32_t k2 = __atomic_load_n(&tier_k[t][1], __ATOMIC_RELAXED);
        do {
            c = crc_3way(c, q, blk, k1, k2);
            q += 3 * blk;
            n -= 3 * blk;
        } while (n >= 3 * blk);
    }
    *p = q;
    *len = n;
    return c;
}

HW_TARGET static uint32_t crc32c_hw(uint32_t crc, const uint8_t *p, size_t len, int fold)
{
    hw_state c = (uint32_t)~crc;
    if (fold && len >= 3 * tier_len[NTIERS - 1])
        c = crc_tiers(c, &p, &len);
    while (len >= 8) {
        c = hw_crc_u64(c, load64(p));
        p += 8;
        len -= 8;
    }
    while (len--)
        c = hw_crc_u8(c, *p++);
    return ~(uint32_t)c;
}
#endif

#ifdef HAVE_HW_CRC
static int hw_level = -1;

/* First call only; out of line so the common path stays a load, a test and a jump. */
__attribute__((noinline, cold)) static int detect_hw(void)
{
    int h = have_hw();
    if (h == 2)
        init_tiers();
    __atomic_store_n(&hw_level, h, __ATOMIC_RELEASE); /* publishes tier_k */
    return h;
}
#endif

uint32_t sp_crc32c(uint32_t crc, const void *data, size_t len)
{
#ifdef HAVE_HW_CRC
    int h = __atomic_load_n(&hw_level, __ATOMIC_ACQUIRE);
    if (h < 0)
        h = detect_hw();
    if (h)
        return crc32c_hw(crc, data, len, h == 2);
#endif
    return sp_crc32c_sw(crc, data, len);
}
