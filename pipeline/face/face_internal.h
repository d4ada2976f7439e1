/* SPDX-License-Identifier: MIT */
/* Helpers shared by the face-model files (not installed). */
#ifndef SUNPROBE_PIPELINE_FACE_INTERNAL_H
#define SUNPROBE_PIPELINE_FACE_INTERNAL_H

#include <stdint.h>

#include "sunprobe/sp_face_model.h"

#define FACE_LOG "face"

/* Row-major rotation matrix of rotation vector r (Rodrigues); exact near zero. */
void face_rotvec_to_matrix(const double r[3], double R[9]);
/* dR/dr_k for k = 0..2, each row-major 3x3; accurate for tiny and large angles. */
void face_rotvec_derivatives(const double r[3], double dR[3][9]);

/*
 * Fills model->face_mask and model->cluster_map from the mean mesh and its
 * landmarks (rules relative to the landmarks, documented in FACE_MODEL.md).
 * The mesh, landmarks and map size must already be set.
 */
int face_regions_compute(sp_face_model *model);

/* Copies at most SP_FACE_NAME_LEN - 1 bytes of name into expression slot k. */
void face_set_exp_name(sp_face_model *model, uint32_t k, const char *name);

#endif
