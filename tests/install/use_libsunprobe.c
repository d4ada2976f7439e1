/* SPDX-License-Identifier: MIT */
/* A program of a sunprobe user, built against the installed headers and pkg-config file only: reads a
 * capture's info, reads a fitted face directory and renders it from its own first camera. */
#include <stdio.h>
#include <stdlib.h>

#include <sunprobe/sp_capture.h>
#include <sunprobe/sp_sunstage.h>

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: use_libsunprobe CAPTURE FACE_DIR\n");
        return 1;
    }
    sp_capture_reader *r = NULL;
    if (sp_capture_reader_open(&r, argv[1], NULL)) {
        fprintf(stderr, "cannot open %s\n", argv[1]);
        return 2;
    }
    unsigned long long frames = 0;
    sp_chunk c;
    while (sp_capture_reader_next(r, &c) == 0)
        frames += c.type == SP_CHUNK_FRAME;
    sp_capture_reader_close(&r);
    sp_face_asset a;
    if (sp_face_dir_read(&a, argv[2])) {
        fprintf(stderr, "cannot read %s\n", argv[2]);
        return 2;
    }
    sp_face_view v;
    sp_face_view_init(&v, &a);
    float *rgb = malloc(sizeof(float) * 3 * (size_t)v.width * (size_t)v.height);
    float *mask = malloc(sizeof(float) * (size_t)v.width * (size_t)v.height);
    int ret = rgb && mask ? sp_face_asset_render(&a, &v, rgb, mask) : -1;
    double lit = 0.0, face = 0.0;
    for (int i = 0; !ret && i < v.width * v.height; i++) {
        face += mask[i];
        lit += mask[i] * (rgb[3 * i] + rgb[3 * i + 1] + rgb[3 * i + 2]) / 3.0;
    }
    printf("%s %llu frames; face %dx%d rendered: %.0f face pixels, mean %.3f\n", sp_version(), frames, v.width,
           v.height, face, face > 0 ? lit / face : 0.0);
    free(rgb);
    free(mask);
    sp_face_asset_free(&a);
    return ret == 0 && face > 100.0 && lit > 0.0 ? 0 : 3;
}
