/* SPDX-License-Identifier: MIT */
/* Entry point: dispatches `sunprobe COMMAND ...` to one subcommand. */
#include <stdio.h>
#include <string.h>

#include "cmd.h"
#include "sunprobe/sp_common.h"

static const sp_command commands[] = {
    { "info", "summarise a capture: devices, durations, frame/IMU counts, gaps, corrupt chunks", sp_cmd_info },
    { "verify", "check every chunk checksum of a capture", sp_cmd_verify },
    { "recover", "cut a torn or corrupt tail off a capture, in place or into a copy", sp_cmd_recover },
    { "replay", "stream a capture through a pipeline stage, as fast as possible or in real time", sp_cmd_replay },
    { "import", "image sequence, video or sensor-log export (+ IMU log + metadata JSON) to a capture", sp_cmd_import },
    { "check", "before fitting: can this selfie capture work, and what to re-shoot", sp_cmd_check },
    { "export-video", "capture frames to PNG files or a video file", sp_cmd_export_video },
    { "synth", "generate a synthetic capture with ground truth", sp_cmd_synth },
    { "texture", "synthesise a texture of any size from an exemplar image", sp_cmd_texture },
    { "fit", "rotating selfie: fit face geometry, reflectance, sun and sky (SunStage)", sp_cmd_fit },
    { "relight", "render a fitted face directory under a new sun and sky", sp_cmd_relight },
    { "evaluate", "score a fitted face against a capture with ground truth (gt/relight, gt/nvs)", sp_cmd_evaluate },
    { "export", "fitted face directory to a relightable glTF (Draco), OBJ or Draco asset", sp_cmd_export },
    { "probe", "static camera: learn occlusion, lighting, scale and shadow from passers-by", sp_cmd_probe },
    { "composite", "insert cut-outs into a probed scene with size, occlusion, lighting, shadow", sp_cmd_composite },
    { "retexture", "replace the ground of a probed scene with a texture, in perspective, shading kept", sp_cmd_retexture },
    { "depopulate", "remove people and their shadows from one street image", sp_cmd_depopulate },
    { "repopulate", "insert lighting-matched people from a cut-out collection into a street image", sp_cmd_repopulate },
    { "cutouts", "write the people of a capture as cut-outs for repopulate", sp_cmd_cutouts },
    { "devices", "list cameras (formats, sizes) and IMUs (channels, rates)", sp_cmd_devices },
    { "record", "record a live camera (+ IMU) to a capture until the duration or Ctrl-C", sp_cmd_record },
};
#define N_COMMANDS (sizeof(commands) / sizeof(commands[0]))

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe COMMAND [OPTIONS] ...\n"
                 "       sunprobe COMMAND --help\n\ncommands:\n");
    for (size_t i = 0; i < N_COMMANDS; i++)
        fprintf(out, "  %-14s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "\nexit codes: 0 ok, 1 usage, 2 bad input, 3 device or I/O error,\n"
                 "            4 optional feature not built, 70 internal error,\n"
                 "            128+N stopped by signal N (Ctrl-C: 130); which error gives which: README.md\n"
                 "environment: SP_LOG=error|warn|info|debug sets the log level\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return SP_EXIT_OK;
    }
    if (!strcmp(argv[1], "--version"))
        return sp_cmd_version(argc - 1, argv + 1);
    for (size_t i = 0; i < N_COMMANDS; i++)
        if (!strcmp(argv[1], commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "sunprobe: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return SP_EXIT_USAGE;
}
