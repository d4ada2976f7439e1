/* SPDX-License-Identifier: MIT */
/*
 * The parts of the ICT head the fit does not use: the mouth interior (mouth socket, gums, tongue,
 * teeth) as a small face model of its own with the head's identity and expression modes, and which
 * of the head's eyeball vertices are irises. For export (EXPORT.md, "Eyes and mouth"); not installed.
 */
#ifndef SUNPROBE_PIPELINE_FACE_INTERIOR_H
#define SUNPROBE_PIPELINE_FACE_INTERIOR_H

#include <stdint.h>

#include "sunprobe/sp_face_model.h"

#define FACE_INTERIOR_TRIANGLES 3000 /* decimation target of the mouth interior */

typedef struct face_interior {
    sp_face_model mouth; /* mesh and modes only (no landmarks, mask or clusters); owned */
    uint8_t *teeth;      /* per mouth vertex: 1 teeth, 0 socket, gums and tongue; owned */
    uint8_t *iris;       /* per vertex of the head model: 1 on an iris, 0 elsewhere; owned */
} face_interior;

/*
 * Reads the mouth interior and the irises of `head` (borrowed; an ICT model with its eyeballs) from
 * the ICT folder (sp_face_ict_dir), with head's identity count and expressions by name.
 * SP_ENODATA when head is not an ICT model with eyeballs; -ENOENT etc. when the data is missing.
 */
int face_interior_load(face_interior *fi, const sp_face_model *head);
void face_interior_free(face_interior *fi);

#endif
