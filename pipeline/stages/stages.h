/* SPDX-License-Identifier: MIT */
/* The built-in replay stages. */
#ifndef SUNPROBE_PIPELINE_STAGES_H
#define SUNPROBE_PIPELINE_STAGES_H

#include "pipeline/stage.h"

extern const sp_stage_ops sp_stage_null;
extern const sp_stage_ops sp_stage_stats;
extern const sp_stage_ops sp_stage_orientation;

#endif
