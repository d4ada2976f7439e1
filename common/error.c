/* SPDX-License-Identifier: MIT */
/* One table of messages for every code sunprobe returns. */
#include "sunprobe/sp_common.h"

#include <errno.h>
#include <string.h>

static const struct {
    int code;
    const char *message;
} project_errors[] = {
    { SP_EOS, "end of stream" },
    { SP_ECORRUPT, "corrupt data (checksum or structure check failed)" },
    { SP_EVERSION, "written by a newer incompatible format version" },
    { SP_EFORMAT, "not a file of the expected format" },
    { SP_ETRUNCATED, "file is truncated" },
    { SP_EUNSUPPORTED, "unsupported content" },
    { SP_EDISABLED, "this build left out the optional feature needed" },
    { SP_ENODATA, "input holds nothing usable" },
};

const char *sp_strerror(int err)
{
    if (err == 0)
        return "success";
    for (size_t i = 0; i < sizeof(project_errors) / sizeof(project_errors[0]); i++)
        if (project_errors[i].code == err)
            return project_errors[i].message;
    if (err < 0 && err > -4096)
        return strerror(-err);
    return "unknown error";
}

const char *sp_version(void)
{
#ifdef SP_VERSION_STRING
    return SP_VERSION_STRING;
#else
    return "unknown";
#endif
}
