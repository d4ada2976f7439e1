/* SPDX-License-Identifier: MIT */
/*
 * The render mesh: the face model's triangles plus fan "caps" closing its eye
 * and mouth openings (the ICT head has holes there; through them the camera
 * would see the sky). Caps are for rendering only: they reuse the rim's UVs and
 * get a centre UV inside the hole's (otherwise unused) UV polygon, where the
 * albedo paints an eye or a dark mouth. Rim vertices are duplicated so the
 * model's own vertex normals are unchanged.
 */
#include "pipeline/synth/synth_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct bedge {
    uint64_t key;    /* min << 32 | max of the position indices */
    uint32_t a, b;   /* directed as in its triangle */
    uint32_t ua, ub; /* UV indices of a and b */
} bedge;

static int cmp_edge(const void *pa, const void *pb)
{
    uint64_t a = ((const bedge *)pa)->key, b = ((const bedge *)pb)->key;
    return a < b ? -1 : a > b;
}

/* Edges used by exactly one triangle, directed as in that triangle. Caller frees *out. */
static int boundary_edges(const sp_mesh *m, bedge **out, size_t *n_out)
{
    size_t n = (size_t)m->n_triangles * 3, nb = 0;
    bedge *e = malloc((n ? n : 1) * sizeof(*e));
    if (!e)
        return -ENOMEM;
    for (size_t t = 0; t < m->n_triangles; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = m->tri_vertices[t * 3 + (size_t)k], b = m->tri_vertices[t * 3 + (size_t)(k + 1) % 3];
            bedge *x = &e[t * 3 + (size_t)k];
            x->a = a;
            x->b = b;
            x->ua = m->tri_uvs[t * 3 + (size_t)k];
            x->ub = m->tri_uvs[t * 3 + (size_t)(k + 1) % 3];
            x->key = a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a);
        }
    qsort(e, n, sizeof(*e), cmp_edge);
    for (size_t i = 0; i < n;) {
        size_t j = i + 1;
        while (j < n && e[j].key == e[i].key)
            j++;
        if (j - i == 1)
            e[nb++] = e[i];
        i = j;
    }
    *out = e;
    *n_out = nb;
    return 0;
}

/* Face-frame coordinates (units of the eye-corner distance) of a model point. */
static void to_face(const synth_face_frame *ff, const double p[3], double out[3])
{
    double d[3] = { p[0] - ff->o[0], p[1] - ff->o[1], p[2] - ff->o[2] };
    const double *ax[3] = { ff->x, ff->y, ff->z };
    for (int i = 0; i < 3; i++)
        out[i] = (d[0] * ax[i][0] + d[1] * ax[i][1] + d[2] * ax[i][2]) / ff->unit;
}

/* Centre (face frame) of the landmarks [first, last] of a model. */
static void lm_center(const sp_synth_selfie *g, int first, int last, double out[3])
{
    double s[3] = { 0, 0, 0 };
    for (int l = first; l <= last; l++)
        for (int k = 0; k < 3; k++)
            s[k] += (double)g->model->mesh.positions[(size_t)g->model->landmarks[l] * 3 + (size_t)k];
    for (int k = 0; k < 3; k++)
        s[k] /= (last - first + 1);
    to_face(&g->ff, s, out);
}

typedef struct loop_info {
    uint32_t start, n; /* into the loop-order edge array */
    double c[3];       /* centroid, face frame */
    double radius;     /* largest distance of a rim vertex from the centroid, face units */
    int uv_closed;     /* consecutive edges share their UV index */
} loop_info;

static void measure_loop(const sp_synth_selfie *g, const bedge *le, loop_info *L)
{
    const float *P = g->model->mesh.positions;
    double s[3] = { 0, 0, 0 }, f[3];
    for (uint32_t i = 0; i < L->n; i++)
        for (int k = 0; k < 3; k++)
            s[k] += (double)P[(size_t)le[L->start + i].a * 3 + (size_t)k] / L->n;
    to_face(&g->ff, s, L->c);
    L->radius = 0.0;
    L->uv_closed = 1;
    for (uint32_t i = 0; i < L->n; i++) {
        const bedge *e = &le[L->start + i], *nx = &le[L->start + (i + 1) % L->n];
        double p[3] = { P[(size_t)e->a * 3], P[(size_t)e->a * 3 + 1], P[(size_t)e->a * 3 + 2] };
        to_face(&g->ff, p, f);
        double d = sqrt((f[0] - L->c[0]) * (f[0] - L->c[0]) + (f[1] - L->c[1]) * (f[1] - L->c[1]) +
                        (f[2] - L->c[2]) * (f[2] - L->c[2]));
        L->radius = d > L->radius ? d : L->radius;
        if (e->ub != nx->ua)
            L->uv_closed = 0;
    }
}

/*
 * Orders the boundary edges into loops (le receives them loop by loop).
 * Vertices with several outgoing boundary edges end a walk; such open chains are dropped.
 */
static int walk_loops(const sp_mesh *m, const bedge *e, size_t ne, bedge *le, loop_info *loops, int max_loops,
                      int *n_loops)
{
    int32_t *next = malloc((size_t)m->n_vertices * sizeof(*next));
    uint8_t *used = calloc(ne ? ne : 1, 1);
    if (!next || !used) {
        free(next);
        free(used);
        return -ENOMEM;
    }
    for (uint32_t v = 0; v < m->n_vertices; v++)
        next[v] = -1;
    for (size_t i = 0; i < ne; i++)
        next[e[i].a] = next[e[i].a] == -1 ? (int32_t)i : -2;
    size_t pos = 0;
    *n_loops = 0;
    for (size_t i = 0; i < ne && *n_loops < max_loops; i++) {
        if (used[i] || next[e[i].a] < 0)
            continue;
        size_t start = pos, cur = i;
        int closed = 0;
        while (!used[cur]) {
            used[cur] = 1;
            le[pos++] = e[cur];
            int32_t nx = next[e[cur].b];
            if (nx < 0)
                break;
            if ((size_t)nx == i) {
                closed = 1;
                break;
            }
            cur = (size_t)nx;
        }
        if (closed && pos - start >= 3)
            loops[(*n_loops)++] = (loop_info){ .start = (uint32_t)start, .n = (uint32_t)(pos - start) };
        else
            pos = start;
    }
    free(next);
    free(used);
    return 0;
}

/* Picks, per opening, the closest small UV-closed loop; fills g->caps. */
static int choose_caps(sp_synth_selfie *g, const bedge *le, loop_info *loops, int n_loops)
{
    static const int range[3][2] = { { 36, 41 }, { 42, 47 }, { 60, 67 } };
    static const double offset[3] = { -0.002, -0.002, -0.008 };
    int has_eyes = 0; /* a model with eyeballs shows them through the openings: only the mouth is closed */
    for (uint32_t v = 0; v < g->model->mesh.n_vertices && !has_eyes; v++)
        has_eyes = g->model->part[v] == SP_FACE_PART_EYE;
    for (int kind = has_eyes ? SYNTH_CAP_MOUTH : 0; kind < 3; kind++) {
        double c[3], best = 0.35;
        int pick = -1;
        lm_center(g, range[kind][0], range[kind][1], c);
        for (int i = 0; i < n_loops; i++) {
            loop_info *L = &loops[i];
            double d = sqrt((L->c[0] - c[0]) * (L->c[0] - c[0]) + (L->c[1] - c[1]) * (L->c[1] - c[1]) +
                            (L->c[2] - c[2]) * (L->c[2] - c[2]));
            if (L->uv_closed && L->radius < 0.6 && d < best) {
                best = d;
                pick = i;
            }
        }
        if (pick < 0)
            continue;
        synth_cap *cap = &g->caps[g->n_caps];
        cap->kind = (enum synth_cap_kind)kind;
        cap->n = loops[pick].n;
        cap->offset_m = offset[kind];
        cap->rim = malloc(cap->n * 2 * sizeof(uint32_t)); /* vertex then UV index per rim corner */
        if (!cap->rim)
            return -ENOMEM;
        for (uint32_t j = 0; j < cap->n; j++) {
            cap->rim[j] = le[loops[pick].start + j].a;
            cap->rim[cap->n + j] = le[loops[pick].start + j].ua;
        }
        g->n_caps++;
    }
    return 0;
}

static int find_caps(sp_synth_selfie *g)
{
    enum { MAX_LOOPS = 64 };
    bedge *e = NULL, *le = NULL;
    size_t ne = 0;
    loop_info loops[MAX_LOOPS];
    int n_loops = 0;
    int ret = boundary_edges(&g->model->mesh, &e, &ne);
    if (!ret && !(le = malloc((ne ? ne : 1) * sizeof(*le))))
        ret = -ENOMEM;
    if (!ret)
        ret = walk_loops(&g->model->mesh, e, ne, le, loops, MAX_LOOPS, &n_loops);
    for (int i = 0; !ret && i < n_loops; i++)
        measure_loop(g, le, &loops[i]);
    if (!ret)
        ret = choose_caps(g, le, loops, n_loops);
    free(e);
    free(le);
    return ret;
}

/* Copies the model's mesh and appends the caps (rim duplicates + centre vertex, centre UV). */
static int assemble(sp_synth_selfie *g)
{
    const sp_mesh *m = &g->model->mesh;
    uint32_t nv = m->n_vertices, nt = m->n_triangles, nuv = m->n_uvs;
    for (int c = 0; c < g->n_caps; c++) {
        nv += g->caps[c].n + 1;
        nt += g->caps[c].n;
        nuv += 1;
    }
    int ret = sp_mesh_alloc(&g->mesh, nv, nuv, nt);
    if (ret)
        return ret;
    memcpy(g->mesh.uvs, m->uvs, (size_t)m->n_uvs * 2 * sizeof(float));
    memcpy(g->mesh.tri_vertices, m->tri_vertices, (size_t)m->n_triangles * 3 * sizeof(uint32_t));
    memcpy(g->mesh.tri_uvs, m->tri_uvs, (size_t)m->n_triangles * 3 * sizeof(uint32_t));
    memcpy(g->mesh.positions, m->positions, (size_t)m->n_vertices * 3 * sizeof(float));
    uint32_t v = m->n_vertices, t = m->n_triangles, uv = m->n_uvs;
    for (int c = 0; c < g->n_caps; c++) {
        synth_cap *cap = &g->caps[c];
        cap->first = v;
        double su = 0, sv = 0;
        for (uint32_t j = 0; j < cap->n; j++) {
            su += (double)m->uvs[(size_t)cap->rim[cap->n + j] * 2] / cap->n;
            sv += (double)m->uvs[(size_t)cap->rim[cap->n + j] * 2 + 1] / cap->n;
        }
        g->mesh.uvs[(size_t)uv * 2] = (float)su;
        g->mesh.uvs[(size_t)uv * 2 + 1] = (float)sv;
        uint32_t centre = v + cap->n;
        for (uint32_t j = 0; j < cap->n; j++) {
            uint32_t jn = (j + 1) % cap->n;
            /* the rim edge a->b runs counter-clockwise in its face triangle: the cap walks it backwards */
            uint32_t *tv = g->mesh.tri_vertices + (size_t)t * 3, *tu = g->mesh.tri_uvs + (size_t)t * 3;
            tv[0] = v + jn;
            tv[1] = v + j;
            tv[2] = centre;
            tu[0] = cap->rim[cap->n + jn];
            tu[1] = cap->rim[cap->n + j];
            tu[2] = uv;
            t++;
        }
        v += cap->n + 1;
        uv++;
    }
    synth_place_caps(g, NULL, 1.0);
    return 0;
}

int synth_build_mesh(sp_synth_selfie *g)
{
    int ret = find_caps(g);
    if (ret)
        return ret;
    sp_log(SP_LOG_DEBUG, "synth", "closed %d opening(s) of the model for rendering", g->n_caps);
    return assemble(g);
}

void synth_place_caps(sp_synth_selfie *g, const double R_head[9], double scale)
{
    float *P = g->mesh.positions;
    double fwd[3] = { 0, 0, 1 };
    if (R_head) /* the model's +z (out of the face) in the world */
        for (int k = 0; k < 3; k++)
            fwd[k] = R_head[k * 3 + 2];
    for (int c = 0; c < g->n_caps; c++) {
        const synth_cap *cap = &g->caps[c];
        double s[3] = { 0, 0, 0 };
        for (uint32_t j = 0; j < cap->n; j++)
            for (int k = 0; k < 3; k++) {
                float x = P[(size_t)cap->rim[j] * 3 + (size_t)k];
                P[(size_t)(cap->first + j) * 3 + (size_t)k] = x;
                s[k] += (double)x / cap->n;
            }
        for (int k = 0; k < 3; k++)
            P[(size_t)(cap->first + cap->n) * 3 + (size_t)k] = (float)(s[k] + cap->offset_m * scale * fwd[k]);
    }
}
