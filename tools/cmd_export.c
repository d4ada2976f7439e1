/* SPDX-License-Identifier: MIT */
/* `sunprobe export FACE_DIR -o face.glb`: the fitted face as a relightable glTF / OBJ / Draco asset. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "sunprobe/sp_export.h"

static void export_usage(FILE *out)
{
    fprintf(out, "usage: sunprobe export FACE_DIR -o OUT [options]\n\n"
                 "Writes the fitted face as a relightable asset (export/EXPORT.md) and the sky as OUT.env.hdr.\n"
                 "  --format F           glb (default: Draco-compressed binary glTF 2.0), obj (OBJ+MTL+PNGs),\n"
                 "                       drc (raw Draco mesh)\n"
                 "  --no-draco           glb with plain accessors, and the expressions as morph targets\n"
                 "  --draco-expressions  Draco keeping the vertex order (larger), with the morph targets\n"
                 "  --jpeg[=Q]           embed the albedo as JPEG (quality Q, default 90)\n"
                 "  --texture-size N     longest texture edge, 16..8192 (default 512; e.g. 1024)\n"
                 "  --position-bits N    Draco quantisation bits (default 14); --normal-bits (10), --uv-bits (12)\n"
                 "  --reorder            triangles in vertex-cache order, vertices in fetch order (meshoptimizer)\n"
                 "  --no-env             do not write OUT.env.hdr\n"
                 "  --stats              print vertex, triangle and byte counts\n");
}

/* 1 = help shown, 0 = parsed, -1 = usage error. */
static int parse_export(int argc, char **argv, sp_export_settings *s, const char **dir, const char **out,
                        int *stats)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' }, { "output", required_argument, NULL, 'o' },
        { "format", required_argument, NULL, 'f' }, { "no-draco", no_argument, NULL, 'D' },
        { "jpeg", optional_argument, NULL, 'j' }, { "texture-size", required_argument, NULL, 't' },
        { "position-bits", required_argument, NULL, 'p' }, { "normal-bits", required_argument, NULL, 'n' },
        { "uv-bits", required_argument, NULL, 'u' }, { "no-env", no_argument, NULL, 'E' },
        { "stats", no_argument, NULL, 's' }, { "draco-expressions", no_argument, NULL, 'X' },
        { "reorder", no_argument, NULL, 'R' }, { 0 },
    };
    static const char *const formats[] = { "glb", "obj", "drc" };
    int c, bad = 0, li = -1, fi = 0;
    while (!bad && (c = getopt_long(argc, argv, "ho:", opts, &li)) != -1) {
        const char *on = li >= 0 ? opts[li].name : "";
        li = -1;
        switch (c) {
        case 'h': export_usage(stdout); return 1;
        case 'o': *out = optarg; break;
        case 'f':
            bad = sp_opt_choice("export", on, optarg, formats, 3, &fi);
            s->format = bad ? s->format : fi == 0 ? SP_EXPORT_GLB : fi == 1 ? SP_EXPORT_OBJ : SP_EXPORT_DRC;
            break;
        case 'D': s->draco = 0; break;
        case 'j': s->jpeg = 1; bad = optarg && sp_opt_int("export", on, optarg, 1, 100, &s->jpeg_quality); break;
        case 't': bad = sp_opt_int("export", on, optarg, 16, 8192, &s->texture_size); break;
        case 'p': bad = sp_opt_int("export", on, optarg, 1, 30, &s->position_bits); break;
        case 'n': bad = sp_opt_int("export", on, optarg, 1, 30, &s->normal_bits); break;
        case 'u': bad = sp_opt_int("export", on, optarg, 1, 30, &s->uv_bits); break;
        case 'E': s->write_env = 0; break;
        case 'X': s->draco_expressions = 1; break;
        case 'R': s->reorder = 1; break;
        case 's': *stats = 1; break;
        default: bad = 1; /* getopt has said which option */
        }
    }
    if (bad) {
        fprintf(stderr, "sunprobe export: see --help\n");
        return -1;
    }
    if (optind != argc - 1 || !*out) {
        fprintf(stderr, "sunprobe export: expected FACE_DIR and -o OUT (see --help)\n");
        return -1;
    }
    *dir = argv[optind];
    return 0;
}

int sp_cmd_export(int argc, char **argv)
{
    sp_export_settings s;
    sp_export_default_settings(&s);
    const char *dir = NULL, *out = NULL;
    int stats = 0;
    int p = parse_export(argc, argv, &s, &dir, &out, &stats);
    if (p)
        return p > 0 ? SP_EXIT_OK : SP_EXIT_USAGE;
    sp_export_stats st;
    sp_cmd_signals sig; /* Ctrl-C before the files are put in place: none of them is, 128+N */
    sp_cmd_catch_signals(&sig);
    s.cancel = &sp_cmd_stop_signal;
    int ret = sp_export_face(dir, out, &s, &st);
    sp_cmd_restore_signals(&sig);
    if (ret) /* bad input names the face directory, anything else the output */
        return sp_cmd_fail("export", ret, sp_exit_for_error(ret) == SP_EXIT_BAD_INPUT ? dir : out);
    if (stats)
        printf("vertices %u\ntriangles %u\nraw_geometry_bytes %zu\ngeometry_bytes %zu\ntotal_bytes %zu\n"
               "specular_texture %d\nnormal_map %d\nsun %d\nmorph_targets %u\nmorph_bytes %zu\nacmr %.4f\n",
               st.vertices, st.triangles, st.raw_geometry_bytes, st.geometry_bytes, st.total_bytes,
               st.has_specular_texture, st.has_normal_map, st.has_sun, st.morph_targets, st.morph_bytes, st.acmr);
    return SP_EXIT_OK;
}
