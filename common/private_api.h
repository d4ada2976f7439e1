/* SPDX-License-Identifier: MIT */
/*
 * SP_PRIVATE marks an internal helper the `sunprobe` command shares with libsunprobe instead of carrying a
 * second copy. libsunprobe.map exports these under their own version node, SUNPROBE_PRIVATE_0: not API
 * (no installed header declares them), free to change or vanish in any release. Everything else that is
 * not SP_API stays hidden.
 */
#ifndef SUNPROBE_COMMON_PRIVATE_API_H
#define SUNPROBE_COMMON_PRIVATE_API_H

#if defined(SP_BUILDING_LIBRARY) && defined(__GNUC__)
#define SP_PRIVATE __attribute__((visibility("default")))
#else
#define SP_PRIVATE
#endif

#endif
