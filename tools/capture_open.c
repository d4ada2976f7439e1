/* SPDX-License-Identifier: MIT */
#include "capture_open.h"

#include <stdio.h>
#include <string.h>

#include "cmd.h"

int sp_tool_capture_error(const char *cmd, const char *path, int err, uint64_t offset)
{
    switch (err) {
    case SP_EFORMAT:
        fprintf(stderr, "sunprobe %s: %s: not a sunprobe capture (bad magic)\n", cmd, path);
        break;
    case SP_EVERSION:
        fprintf(stderr, "sunprobe %s: %s: written by a newer sunprobe (format major version above %d); upgrade to read it\n",
                cmd, path, SP_CAPTURE_VERSION_MAJOR);
        break;
    case SP_ETRUNCATED:
        if (offset == 0) {
            fprintf(stderr, "sunprobe %s: %s: file too short to hold a capture header\n", cmd, path);
            break;
        }
        fprintf(stderr, "sunprobe %s: %s: truncated at byte %llu (torn tail); `sunprobe recover %s` keeps everything before it\n",
                cmd, path, (unsigned long long)offset, path);
        break;
    case SP_ECORRUPT: /* only replay can read past a bad chunk; the others can offer what recover keeps */
        if (offset == 0)
            fprintf(stderr, "sunprobe %s: %s: corrupt capture header\n", cmd, path);
        else if (!strcmp(cmd, "replay"))
            fprintf(stderr, "sunprobe %s: %s: corrupt chunk at byte %llu; use --skip-corrupt to read past it\n", cmd,
                    path, (unsigned long long)offset);
        else
            fprintf(stderr, "sunprobe %s: %s: corrupt chunk at byte %llu; `sunprobe recover %s -o COPY` keeps the "
                            "capture before it\n", cmd, path, (unsigned long long)offset, path);
        break;
    default:
        fprintf(stderr, "sunprobe %s: %s: %s\n", cmd, path, sp_strerror(err));
    }
    return sp_exit_for_error(err);
}

int sp_tool_open_capture(const char *cmd, const char *path, int skip_corrupt, sp_capture_reader **out)
{
    sp_capture_reader_settings rs;
    sp_capture_reader_default_settings(&rs);
    rs.skip_corrupt = skip_corrupt;
    int ret = sp_capture_reader_open(out, path, &rs);
    return ret ? sp_tool_capture_error(cmd, path, ret, 0) : 0;
}
