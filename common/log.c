/* SPDX-License-Identifier: MIT */
/* Leveled logging to stderr; SP_LOG=error|warn|info|debug sets the start level. */
#include "sunprobe/sp_common.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int log_level = -1; /* -1: not read from the environment yet */

static enum sp_log_level level_from_env(void)
{
    static const char *const names[] = { "error", "warn", "info", "debug" };
    const char *v = getenv("SP_LOG");
    if (v)
        for (int i = 0; i < 4; i++)
            if (strcmp(v, names[i]) == 0)
                return (enum sp_log_level)i;
    return SP_LOG_WARN;
}

void sp_log_set_level(enum sp_log_level level)
{
    log_level = (int)level;
}

enum sp_log_level sp_log_get_level(void)
{
    if (log_level < 0)
        log_level = (int)level_from_env();
    return (enum sp_log_level)log_level;
}

void sp_logv(enum sp_log_level level, const char *module, const char *fmt, va_list ap)
{
    static const char *const tags[] = { "error", "warning", "info", "debug" };
    if ((int)level > (int)sp_log_get_level())
        return;
    char line[1024];
    vsnprintf(line, sizeof(line), fmt, ap);
    /* One fputs per message so lines from threads do not interleave. */
    char out[1200];
    snprintf(out, sizeof(out), "sunprobe: %s: %s: %s\n", module ? module : "-", tags[level], line);
    fputs(out, stderr);
}

void sp_log(enum sp_log_level level, const char *module, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    sp_logv(level, module, fmt, ap);
    va_end(ap);
}
