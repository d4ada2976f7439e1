/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe --version [--verbose]`: the version; verbose adds what this build has (optional features,
 * the renderer's kernel set on this CPU, the loadable modules and where they are) and where the run-time
 * data was found, so a user can tell why a command says "not built" or "not found" before running it.
 */
#include <stdio.h>
#include <string.h>

#include "cmd.h"
#include "common/data_path.h"
#include "sp_config.h"
#include "sunprobe/sp_render.h"
#if SP_LAZY_MODULES
#include "common/module.h"
#endif

static void feature(const char *name, int built, const char *why)
{
    printf("  %-13s %s%s%s\n", name, built ? "yes" : "no", why[0] ? "  " : "", why);
}

static void data(const char *what, const sp_data_location *l, const char *hint)
{
    printf("  %-22s %s\n  %-22s (%s; %s)\n", what, l->path[0] ? l->path : "-", "", l->source,
           l->found ? "found" : hint);
}

int sp_cmd_version(int argc, char **argv)
{
    int verbose = argc > 1 && (!strcmp(argv[1], "--verbose") || !strcmp(argv[1], "-v"));
    if (argc > 2 || (argc == 2 && !verbose)) {
        fprintf(stderr, "usage: sunprobe --version [--verbose]\n");
        return SP_EXIT_USAGE;
    }
    printf("sunprobe %s\n", sp_version());
    if (!verbose)
        return SP_EXIT_OK;
    printf("features (meson -D options; 'no' makes the commands that need it exit 4):\n");
    feature("libcamera", HAVE_LIBCAMERA, "record/devices from libcamera cameras");
    feature("V4L2", HAVE_V4L2, "record/devices from /dev/video*");
    feature("OpenCV", HAVE_OPENCV, "import of video files, HOG people detector in probe");
    feature("OpenImageIO", HAVE_OPENIMAGEIO, "EXR maps, image files beyond PNG/JPEG");
    feature("Draco", HAVE_DRACO, "export --draco");
    feature("dlib", HAVE_DLIB, "face landmarks on frames without landmark side data");
    feature("libiio", HAVE_IIO, "IIO through libiio (sysfs is always read)");
    feature("JPEG", HAVE_JPEG, "MJPEG frames");
    feature("zlib", HAVE_ZLIB, "");
    feature("libpng", HAVE_LIBPNG, "");
    feature("AVX2 kernels", HAVE_SIMD_AVX2, "");
    printf("renderer kernel set on this CPU: %s\n", sp_render_kernel_set());
#if SP_LAZY_MODULES
    printf("modules (OpenCV/OpenImageIO shims, loaded on first use; SP_MODULE_DIR overrides):\n");
    const sp_module *mods[] = { &sp_module_opencv_import, &sp_module_opencv_probe, &sp_module_oiio };
    int have[] = { HAVE_OPENCV, HAVE_OPENCV, HAVE_OPENIMAGEIO };
    for (size_t i = 0; i < sizeof(mods) / sizeof(mods[0]); i++) {
        char path[4096];
        if (!have[i])
            continue;
        int ok = sp_module_locate(mods[i], path, sizeof(path));
        printf("  %-22s %s (%s)\n", mods[i]->name, path, ok ? "found" : "missing");
    }
#else
    printf("modules: none (the shims are linked in)\n");
#endif
    printf("data (environment variable, then $XDG_DATA_HOME, $XDG_DATA_DIRS and the prefix's share, each "
           "under sunprobe/, then the build's default):\n");
    sp_data_location l;
    sp_face_ict_locate(&l);
    data("ICT face model", &l, "missing: tools/fetch-ict-facekit.sh DIR");
    sp_dlib_model_locate(&l);
    data("dlib 68-point model", &l, "missing: apt-get install libdlib-data, or fit needs landmark side data");
    return SP_EXIT_OK;
}
