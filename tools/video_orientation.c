/* SPDX-License-Identifier: MIT */
/* The video-orientation pass over a whole capture (video_orientation.h). */
#include "video_orientation.h"

#include <errno.h>
#include <string.h>

#include "cmd.h"
#include "pipeline/stages/stages.h"

int sp_tool_video_orientation(const char *path, int progress, FILE *summary, sp_stage *stage, sp_vo_result *r)
{
    memset(r, 0, sizeof(*r));
    sp_stage_options none = { 0 };
    int ret = sp_stage_open(stage, &sp_stage_video_orientation, &none);
    if (ret)
        return ret;
    sp_run_settings rs;
    sp_run_default_settings(&rs);
    rs.progress = progress ? -1 : 0;
    rs.progress_label = "orientation";
    rs.stop = &sp_cmd_stop_signal;
    rs.summary = summary;
    sp_run_stats st;
    ret = sp_stage_run(path, stage, &rs, &st);
    if (sp_cmd_stop_signal)
        return -ECANCELED;
    if (!ret || st.failed_in == SP_RUN_FAILED_FINISH)
        sp_video_orientation_result(stage->ctx, r);
    return ret;
}
