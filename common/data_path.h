/* SPDX-License-Identifier: MIT */
/*
 * Where run-time data (the ICT face model, dlib's landmark model) is found. In order, the first that
 * exists wins: the environment variable (used as given when set), $XDG_DATA_HOME/sunprobe/REL
 * (~/.local/share), each $XDG_DATA_DIRS entry's sunprobe/REL (/usr/local/share:/usr/share), the install
 * prefix's share/sunprobe/REL, then the build's fallback. README.md ("Data files") documents it.
 */
#ifndef SUNPROBE_COMMON_DATA_PATH_H
#define SUNPROBE_COMMON_DATA_PATH_H

#include <stddef.h>
#include "common/private_api.h"

typedef struct sp_data_location {
    char path[4096];
    char source[64];  /* where the path came from: "SP_ICT_FACEKIT_DIR", "XDG_DATA_HOME", ... */
    int found;        /* the path exists (and holds `probe` for a directory) */
} sp_data_location;

/*
 * env: variable name; rel: path under .../sunprobe/; probe: a file that must exist inside a directory
 * candidate (NULL: rel itself is the file); fallback: tried last (may be NULL). Fills out with the first
 * existing candidate, else with the variable's value (when set) or the fallback, found = 0.
 */
void sp_data_locate(const char *env, const char *rel, const char *probe, const char *fallback,
                    sp_data_location *out);

/* The two data sets sunprobe reads (defined beside their readers). */
SP_PRIVATE void sp_face_ict_locate(sp_data_location *out);   /* pipeline/face/face_ict.c */
SP_PRIVATE void sp_dlib_model_locate(sp_data_location *out); /* pipeline/sunstage/landmarks.c */

#endif
