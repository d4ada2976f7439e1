/* SPDX-License-Identifier: MIT */
/* Opening a capture from the command line with a message a user can act on. */
#ifndef SUNPROBE_TOOLS_CAPTURE_OPEN_H
#define SUNPROBE_TOOLS_CAPTURE_OPEN_H

#include "sunprobe/sp_capture.h"

/* Opens path; on failure prints why (naming the command and file) and returns the exit code, else 0. */
int sp_tool_open_capture(const char *cmd, const char *path, int skip_corrupt, sp_capture_reader **out);
/* Prints the reason a capture could not be read any further; returns the exit code. */
int sp_tool_capture_error(const char *cmd, const char *path, int err, uint64_t offset);

#endif
