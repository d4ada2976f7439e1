/* SPDX-License-Identifier: MIT */
/*
 * A set of output files committed together (an asset: .glb + .env.hdr, or
 * .obj + .mtl + PNGs): each is written under a temporary name, and only when
 * all are complete are they renamed into place. If any write or rename fails,
 * the temporaries are removed and the files that were there before stay as
 * they were, so a reader never sees half an old and half a new set.
 */
#ifndef SUNPROBE_COMMON_FILE_SET_H
#define SUNPROBE_COMMON_FILE_SET_H

#include <stddef.h>
#include "common/private_api.h"

typedef struct sp_file_set_entry {
    char *final_path, *temp_path;
    int in_place; /* final_path is a device or FIFO: written directly, never renamed or removed */
} sp_file_set_entry;

/* Zero-initialise before use ({ 0 }). */
typedef struct sp_file_set {
    sp_file_set_entry *files;
    size_t count, cap;
} sp_file_set;

/*
 * Adds final_path (borrowed) to the set and sets *temp_path to the name to
 * write it under, "<final_path>.new.<pid>" (owned by the set, valid until
 * commit or abort; final_path itself for an existing device or FIFO). The
 * caller creates, fills, syncs and closes that file.
 */
SP_PRIVATE int sp_file_set_add(sp_file_set *fs, const char *final_path, const char **temp_path);
/*
 * Renames every temporary to its final name and syncs the parent directories.
 * Existing final files are kept as hard links until every rename succeeded,
 * and put back if one fails. Every temporary is gone afterwards and fs is
 * reset, on success and on failure alike.
 */
SP_PRIVATE int sp_file_set_commit(sp_file_set *fs);
/* Removes every temporary (missing ones are fine) and resets fs. Safe on a zeroed or committed set. */
SP_PRIVATE void sp_file_set_abort(sp_file_set *fs);

#endif
