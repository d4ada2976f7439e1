/* SPDX-License-Identifier: MIT */
/*
 * A face directory, written completely: the pipeline's files (manifest, mesh,
 * float maps, lighting, cameras: sp_face_dir_write, SUNSTAGE.md) plus the 8-bit
 * albedo.png preview the manifest names, which needs this layer's PNG writer.
 */
#ifndef SUNPROBE_EXPORT_FACE_DIR_H
#define SUNPROBE_EXPORT_FACE_DIR_H

#include "sunprobe/sp_sunstage.h"
#include "common/private_api.h"

/* Writes every file of a fitted face into `dir` (which must exist; borrowed). */
SP_PRIVATE int sp_face_dir_write_all(const sp_sunstage *ss, const char *dir);

#endif
