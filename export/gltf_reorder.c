/* SPDX-License-Identifier: MIT */
/*
 * `export --reorder`: triangles in vertex-cache order, then vertices in first-use order
 * (meshoptimizer, Debian's libmeshoptimizer-dev), for engines drawing the plain or sequentially
 * encoded mesh. Draco's edgebreaker re-orders both itself (figures in EXPORT.md).
 */
#include "export/gltf_internal.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "sp_config.h"
#if HAVE_MESHOPTIMIZER
#include <meshoptimizer.h>
#endif

#if HAVE_MESHOPTIMIZER
/* a[i] = a_old[j] for remap[j] = i, n items of size bytes */
static int remap_array(void *a, uint32_t n, size_t size, const unsigned int *remap)
{
    void *tmp = malloc((size_t)n * size + 1);
    if (!tmp)
        return -ENOMEM;
    meshopt_remapVertexBuffer(tmp, a, n, size, remap);
    memcpy(a, tmp, (size_t)n * size);
    free(tmp);
    return 0;
}
#endif

double sp_gltf_geom_acmr(const sp_gltf_geom *g)
{
#if HAVE_MESHOPTIMIZER
    return meshopt_analyzeVertexCache(g->indices, (size_t)g->n_triangles * 3, g->n_vertices, 16, 0, 0).acmr;
#else
    (void)g;
    return 0.0;
#endif
}

int sp_gltf_geom_reorder(sp_gltf_geom *g)
{
#if HAVE_MESHOPTIMIZER
    size_t ni = (size_t)g->n_triangles * 3;
    unsigned int *remap = malloc((size_t)g->n_vertices * sizeof(unsigned int) + 1);
    if (!remap)
        return -ENOMEM;
    meshopt_optimizeVertexCache(g->indices, g->indices, ni, g->n_vertices);
    meshopt_optimizeVertexFetchRemap(remap, g->indices, ni, g->n_vertices); /* every vertex is used */
    meshopt_remapIndexBuffer(g->indices, g->indices, ni, remap);
    int ret = remap_array(g->positions, g->n_vertices, 3 * sizeof(float), remap);
    if (!ret)
        ret = remap_array(g->normals, g->n_vertices, 3 * sizeof(float), remap);
    if (!ret)
        ret = remap_array(g->uvs, g->n_vertices, 2 * sizeof(float), remap);
    if (!ret)
        ret = remap_array(g->tangents, g->n_vertices, 4 * sizeof(float), remap);
    if (!ret)
        ret = remap_array(g->source, g->n_vertices, sizeof(uint32_t), remap);
    free(remap);
    return ret;
#else
    (void)g;
    return SP_EDISABLED;
#endif
}
