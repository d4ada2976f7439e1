/* SPDX-License-Identifier: MIT */
/* Clocks: monotonic for timestamps and durations, realtime for wall-clock stamps. */
#ifndef SUNPROBE_COMMON_CLOCK_H
#define SUNPROBE_COMMON_CLOCK_H

#include <stdint.h>
#include "common/private_api.h"

SP_PRIVATE int64_t sp_clock_monotonic_ns(void);
int64_t sp_clock_realtime_ns(void);
/* Sleeps until the monotonic clock reads deadline_ns (returns at once if it has passed). */
void sp_clock_sleep_until(int64_t deadline_ns);

#endif
