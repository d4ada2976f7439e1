/* SPDX-License-Identifier: MIT */
/* A directory of cut-outs (RGBA PNG + sidecar JSON each, REPOPULATE.md) loaded for `sunprobe repopulate`. */
#ifndef SUNPROBE_TOOLS_CUTOUT_COLLECTION_H
#define SUNPROBE_TOOLS_CUTOUT_COLLECTION_H

#include <stddef.h>
#include <stdint.h>

#include "pipeline/probe/repopulate.h"

typedef struct cutout {
    char name[256]; /* the sidecar's file name */
    sp_cutout_meta m;
    uint8_t *rgba;  /* straight alpha */
    uint32_t w, h;
    double match, gain[3], score; /* against the scene, filled by the command */
    unsigned used;
} cutout;

/*
 * Loads every *.json in dir (in name order) and the PNG it names. A sidecar
 * that does not parse, a PNG that cannot be read, has no alpha or no
 * transparent and no opaque pixel, and an empty directory are bad input: a
 * message naming the file and field, and the exit code; 0 on success
 * (*out malloc'd, free with cutouts_free).
 */
int cutouts_load(const char *cmd, const char *dir, cutout **out, size_t *n);
void cutouts_free(cutout *c, size_t n);

#endif
