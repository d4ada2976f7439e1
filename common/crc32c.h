/* SPDX-License-Identifier: MIT */
/* CRC-32C (Castagnoli), the checksum of capture chunks; hardware-accelerated where the CPU has it. */
#ifndef SUNPROBE_COMMON_CRC32C_H
#define SUNPROBE_COMMON_CRC32C_H

#include <stddef.h>
#include <stdint.h>

/* Extends `crc` (0 to start) over len bytes; crc32c("123456789") == 0xE3069283. */
uint32_t sp_crc32c(uint32_t crc, const void *data, size_t len);
/* Same result without the hardware path, for tests. */
uint32_t sp_crc32c_sw(uint32_t crc, const void *data, size_t len);

#endif
