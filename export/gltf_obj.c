/* SPDX-License-Identifier: MIT */
/* OBJ + MTL + PNG variant of the face export, for DCC tools (y up, metres, OBJ's bottom-left UVs). */
#include "export/gltf_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/atomic_file.h"
#include "common/file_util.h"
#include "common/file_set.h"
#include "export/png.h"

/*
 * stem = out_path without extension; adds stem + suffix to the set, *tmp = the
 * name to write it under, *base = the final name's basename (for references).
 */
static int sibling(sp_file_set *fs, const char *out_path, const char *suffix, const char **tmp, const char **base)
{
    char buf[4096];
    const char *slash = strrchr(out_path, '/'), *dot = strrchr(out_path, '.');
    size_t stem = dot && (!slash || dot > slash) ? (size_t)(dot - out_path) : strlen(out_path);
    if ((size_t)snprintf(buf, sizeof(buf), "%.*s%s", (int)stem, out_path, suffix) >= sizeof(buf))
        return -ENAMETOOLONG;
    int ret = sp_file_set_add(fs, buf, tmp);
    if (ret)
        return ret;
    const char *f = fs->files[fs->count - 1].final_path, *s = strrchr(f, '/');
    *base = s ? s + 1 : f;
    return 0;
}

/* One channel of an image as an 8-bit grey PNG. */
static int write_channel(const char *path, const sp_export_image *im, int ch)
{
    size_t n = (size_t)im->width * (size_t)im->height;
    uint8_t *g = malloc(n);
    if (!g)
        return -ENOMEM;
    for (size_t i = 0; i < n; i++)
        g[i] = im->pixels[i * (size_t)im->channels + (size_t)ch];
    int ret = sp_png_write(path, g, (uint32_t)im->width, (uint32_t)im->height, (uint32_t)im->width, 1);
    free(g);
    return ret;
}

static int write_mtl(const char *out_path, sp_file_set *fs, const sp_export_textures *t, const char **mtl_base)
{
    const char *path, *tex, *base;
    int ret = sibling(fs, out_path, ".mtl", &path, mtl_base);
    sp_atomic_file af;
    if (ret || (ret = sp_atomic_file_open(&af, path)))
        return ret;
    fprintf(af.file, "# sunprobe face material\nnewmtl skin\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nillum 2\n");
    if (!(ret = sibling(fs, out_path, "_albedo.png", &tex, &base)))
        ret = sp_png_write(tex, t->albedo.pixels, (uint32_t)t->albedo.width, (uint32_t)t->albedo.height,
                           (uint32_t)(t->albedo.width * 3), 3);
    if (!ret)
        fprintf(af.file, "map_Kd %s\n", base);
    if (!ret && t->has_specular && !(ret = sibling(fs, out_path, "_specular.png", &tex, &base)) &&
        !(ret = write_channel(tex, &t->spec_rough, 3)))
        fprintf(af.file, "Ks 1 1 1\nmap_Ks %s\n", base);
    if (!ret && t->has_specular && !(ret = sibling(fs, out_path, "_roughness.png", &tex, &base)) &&
        !(ret = write_channel(tex, &t->spec_rough, 1)))
        fprintf(af.file, "map_Pr %s\n", base);
    if (!ret && t->has_normal && !(ret = sibling(fs, out_path, "_normal.png", &tex, &base)) &&
        !(ret = sp_png_write(tex, t->normal.pixels, (uint32_t)t->normal.width, (uint32_t)t->normal.height,
                             (uint32_t)(t->normal.width * 3), 3)))
        fprintf(af.file, "norm %s\n", base);
    if (!ret && ferror(af.file))
        ret = sp_write_error();
    return sp_atomic_file_finish(&af, ret);
}

int sp_export_write_obj(const char *out_path, sp_file_set *fs, const sp_gltf_geom *g, const sp_export_textures *t,
                        sp_export_stats *st)
{
    const char *mtl, *obj;
    int ret = write_mtl(out_path, fs, t, &mtl);
    if (!ret)
        ret = sp_file_set_add(fs, out_path, &obj);
    sp_atomic_file af;
    if (ret || (ret = sp_atomic_file_open(&af, obj)))
        return ret;
    FILE *f = af.file;
    fprintf(f, "# sunprobe face (metres, y up)\nmtllib %s\nusemtl skin\n", mtl);
    for (uint32_t i = 0; i < g->n_vertices; i++) {
        const float *p = g->positions + (size_t)i * 3, *n = g->normals + (size_t)i * 3, *u = g->uvs + (size_t)i * 2;
        fprintf(f, "v %.7g %.7g %.7g\nvn %.6f %.6f %.6f\nvt %.7g %.7g\n", (double)p[0], (double)p[1],
                (double)p[2], (double)n[0], (double)n[1], (double)n[2], (double)u[0], 1.0 - (double)u[1]);
    }
    for (uint32_t t3 = 0; t3 < g->n_triangles; t3++) {
        const uint32_t *v = g->indices + (size_t)t3 * 3;
        fprintf(f, "f %u/%u/%u %u/%u/%u %u/%u/%u\n", v[0] + 1, v[0] + 1, v[0] + 1, v[1] + 1, v[1] + 1, v[1] + 1,
                v[2] + 1, v[2] + 1, v[2] + 1);
    }
    if (ferror(f))
        ret = sp_write_error();
    long size = ftell(f);
    ret = sp_atomic_file_finish(&af, ret);
    st->vertices = g->n_vertices;
    st->triangles = g->n_triangles;
    st->raw_geometry_bytes = (size_t)g->n_vertices * 32 + (size_t)g->n_triangles * 12;
    st->geometry_bytes = st->total_bytes = size > 0 ? (size_t)size : 0;
    return ret;
}
