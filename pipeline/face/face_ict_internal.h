/* SPDX-License-Identifier: MIT */
/* The ICT importer's pieces shared with the mouth-interior reader (face_interior.c); not installed. */
#ifndef SUNPROBE_PIPELINE_FACE_ICT_INTERNAL_H
#define SUNPROBE_PIPELINE_FACE_ICT_INTERNAL_H

#include <stdint.h>

#include "obj_reader.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_mesh.h"

/* A part of the neutral OBJ as triangles, metres, vertices renumbered to those used. */
typedef struct cropped {
    sp_mesh mesh;
    uint32_t *to_old;   /* mesh vertex -> ICT vertex */
    uint32_t *from_old; /* ICT vertex -> mesh vertex or UINT32_MAX */
} cropped;

/* Reads generic_neutral_mesh.obj from dir (logs why it cannot); SP_EUNSUPPORTED for another topology. */
int ict_load_neutral(const char *dir, obj_data *o);
/* Keeps the polygons keep() accepts (arg passed through), split into triangles. SP_ENODATA for none. */
int ict_crop(const obj_data *o, int (*keep)(const obj_data *, uint32_t, const void *), const void *arg,
             cropped *out);
void ict_crop_free(cropped *c);
/* dst = (file NAME in dir - neutral) in metres at c's vertices; refused when its RMS exceeds head_radius / 4. */
int ict_read_mode(const char *dir, const char *name, const obj_data *neutral, const cropped *c, double head_radius,
                  float *dst);
/* m's identity modes (identityNNN.obj) and expressions (exp_files[k].obj, names set) at c's vertices. */
int ict_read_modes(sp_face_model *m, const char *dir, const obj_data *neutral, const cropped *c, double radius,
                   const char *const *exp_files);
/* Half the diagonal of the mesh's bounding box. */
double ict_bounding_radius(const sp_mesh *m);

#endif
