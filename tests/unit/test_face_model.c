/* SPDX-License-Identifier: MIT */
/*
 * Face model: the generic head's mesh, landmarks, mask and clusters; .spface
 * round trip and corrupt files; evaluation adjoint and landmark Jacobian
 * against central finite differences; extreme inputs.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "common/crc32c.h"
#include "sunprobe/sp_face_model.h"

static const double PI = 3.14159265358979323846;

/* Deterministic uniform numbers in [-1, 1]. */
static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static double urand(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) / (double)(1ull << 52) - 1.0;
}

static const float *vpos(const sp_face_model *m, uint32_t v) { return m->mesh.positions + (size_t)v * 3; }

/* Cluster id at the UV of vertex v (its first triangle corner). */
static int cluster_at_vertex(const sp_face_model *m, uint32_t v)
{
    for (uint32_t i = 0; i < m->mesh.n_triangles * 3; i++) {
        if (m->mesh.tri_vertices[i] != v)
            continue;
        const float *uv = m->mesh.uvs + (size_t)m->mesh.tri_uvs[i] * 2;
        int x = (int)((double)uv[0] * m->cluster_width), y = (int)((1.0 - (double)uv[1]) * m->cluster_height);
        x = x < 0 ? 0 : x >= (int)m->cluster_width ? (int)m->cluster_width - 1 : x;
        y = y < 0 ? 0 : y >= (int)m->cluster_height ? (int)m->cluster_height - 1 : y;
        return m->cluster_map[(size_t)y * m->cluster_width + (size_t)x];
    }
    return -1;
}

static uint32_t nearest_vertex(const sp_face_model *m, const double p[3])
{
    uint32_t best = 0;
    double bd = INFINITY;
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++) {
        const float *q = vpos(m, i);
        double d = 0;
        for (int k = 0; k < 3; k++)
            d += ((double)q[k] - p[k]) * ((double)q[k] - p[k]);
        if (d < bd) {
            bd = d;
            best = i;
        }
    }
    return best;
}

static void landmark_mid(const sp_face_model *m, int a, int b, double up, double out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = 0.5 * ((double)vpos(m, m->landmarks[a])[k] + (double)vpos(m, m->landmarks[b])[k]);
    out[1] += up;
}

/* ---- mesh ---- */

static void test_mesh(const sp_face_model *m)
{
    CHECK_EQ_INT(sp_face_model_validate(m), 0);
    CHECK(m->mesh.n_vertices > 2000 && m->mesh.n_triangles > 4000);
    CHECK(strncmp(m->source, "generic-head", 12) == 0);
    double vol = 0, ymin = INFINITY, ymax = -INFINITY;
    int degenerate = 0;
    for (uint32_t t = 0; t < m->mesh.n_triangles; t++) {
        const uint32_t *tv = m->mesh.tri_vertices + t * 3;
        if (tv[0] == tv[1] || tv[1] == tv[2] || tv[0] == tv[2])
            degenerate++;
        const float *a = vpos(m, tv[0]), *b = vpos(m, tv[1]), *c = vpos(m, tv[2]);
        double e1[3], e2[3], n[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = (double)b[k] - (double)a[k];
            e2[k] = (double)c[k] - (double)a[k];
        }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        if (!(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 1e-20))
            degenerate++;
        vol += ((double)a[0] * n[0] + (double)a[1] * n[1] + (double)a[2] * n[2]) / 6.0;
    }
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++) {
        ymin = fmin(ymin, (double)vpos(m, i)[1]);
        ymax = fmax(ymax, (double)vpos(m, i)[1]);
    }
    CHECK_EQ_INT(degenerate, 0);
    CHECK_MSG(vol > 0.002 && vol < 0.01, "enclosed volume %g m^3 (outward winding, head-sized)", vol);
    CHECK_MSG(ymax - ymin > 0.25 && ymax - ymin < 0.5, "height with neck %g m", ymax - ymin);
    for (uint32_t i = 0; i < m->mesh.n_uvs * 2; i++)
        CHECK(m->mesh.uvs[i] >= 0.0f && m->mesh.uvs[i] <= 1.0f);
    CHECK(strcmp(sp_face_model_exp_name(m, 0), "jawOpen") == 0);
    CHECK(strcmp(sp_face_model_exp_name(m, 1000), "") == 0);
}

static void test_landmarks(const sp_face_model *m)
{
    int distinct = 1;
    for (int i = 0; i < SP_FACE_N_LANDMARKS; i++) {
        CHECK(m->landmarks[i] < m->mesh.n_vertices);
        CHECK_MSG((double)vpos(m, m->landmarks[i])[2] > 0.0, "landmark %d faces backwards", i);
        for (int j = 0; j < i; j++)
            distinct &= m->landmarks[i] != m->landmarks[j];
    }
    CHECK(distinct);
#define LM(j, k) ((double)vpos(m, m->landmarks[j])[k])
    CHECK(LM(36, 0) < 0 && LM(45, 0) > 0);   /* subject's right eye at -x */
    CHECK(LM(0, 0) < LM(8, 0) && LM(8, 0) < LM(16, 0));
    CHECK(LM(19, 1) > LM(37, 1) && LM(24, 1) > LM(44, 1)); /* brows above eyes */
    CHECK(LM(27, 1) > LM(30, 1) && LM(30, 1) > LM(51, 1) && LM(51, 1) > LM(57, 1) && LM(57, 1) > LM(8, 1));
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        CHECK_MSG(j == 30 || LM(30, 2) > LM(j, 2), "nose tip is not the front-most landmark (%d)", j);
    double eye_dist = LM(45, 0) - LM(36, 0);
    CHECK_MSG(eye_dist > 0.07 && eye_dist < 0.12, "outer eye corners %g m apart", eye_dist);
#undef LM
}

static void test_regions(const sp_face_model *m)
{
    uint32_t in_mask = 0;
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++)
        in_mask += m->face_mask[i];
    CHECK_MSG(in_mask > m->mesh.n_vertices / 20 && in_mask < m->mesh.n_vertices / 2, "mask %u of %u", in_mask,
              m->mesh.n_vertices);
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        CHECK_MSG(m->face_mask[m->landmarks[j]] == 1, "landmark %d is outside the face mask", j);
    /* named regions where a face has them */
    double p[3];
    CHECK_EQ_INT(cluster_at_vertex(m, m->landmarks[30]), SP_FACE_CLUSTER_NOSE);
    CHECK_EQ_INT(cluster_at_vertex(m, m->landmarks[62]), SP_FACE_CLUSTER_LIPS);
    CHECK_EQ_INT(cluster_at_vertex(m, m->landmarks[37]), SP_FACE_CLUSTER_RIGHT_EYE);
    CHECK_EQ_INT(cluster_at_vertex(m, m->landmarks[44]), SP_FACE_CLUSTER_LEFT_EYE);
    landmark_mid(m, 3, 48, 0.01, p);
    CHECK_EQ_INT(cluster_at_vertex(m, nearest_vertex(m, p)), SP_FACE_CLUSTER_RIGHT_CHEEK);
    landmark_mid(m, 13, 54, 0.01, p);
    CHECK_EQ_INT(cluster_at_vertex(m, nearest_vertex(m, p)), SP_FACE_CLUSTER_LEFT_CHEEK);
    landmark_mid(m, 21, 22, 0.035, p);
    CHECK_EQ_INT(cluster_at_vertex(m, nearest_vertex(m, p)), SP_FACE_CLUSTER_FOREHEAD);
    landmark_mid(m, 57, 8, 0.0, p);
    CHECK_EQ_INT(cluster_at_vertex(m, nearest_vertex(m, p)), SP_FACE_CLUSTER_CHIN);
    /* every cluster is present, and every face-mask triangle has a face cluster */
    size_t count[256] = { 0 }, n = (size_t)m->cluster_width * m->cluster_height;
    for (size_t i = 0; i < n; i++)
        count[m->cluster_map[i]]++;
    for (int c = 0; c < SP_FACE_N_CLUSTERS; c++)
        CHECK_MSG(count[c] > 20, "cluster %d has %zu texels", c, count[c]);
    int bad = 0;
    for (uint32_t t = 0; t < m->mesh.n_triangles; t++) {
        const uint32_t *tv = m->mesh.tri_vertices + t * 3, *tu = m->mesh.tri_uvs + t * 3;
        if (!m->face_mask[tv[0]] || !m->face_mask[tv[1]] || !m->face_mask[tv[2]])
            continue;
        double u = 0, v = 0;
        for (int k = 0; k < 3; k++) {
            u += (double)m->mesh.uvs[tu[k] * 2] / 3.0;
            v += (double)m->mesh.uvs[tu[k] * 2 + 1] / 3.0;
        }
        size_t x = (size_t)(u * m->cluster_width), y = (size_t)((1.0 - v) * m->cluster_height);
        int c = m->cluster_map[y * m->cluster_width + x];
        bad += c == SP_FACE_CLUSTER_NONE || c == SP_FACE_CLUSTER_OTHER;
    }
    CHECK_EQ_INT(bad, 0);
}

/* ---- files ---- */

static int models_equal(const sp_face_model *a, const sp_face_model *b)
{
    size_t n3 = (size_t)a->mesh.n_vertices * 3;
    return a->mesh.n_vertices == b->mesh.n_vertices && a->mesh.n_uvs == b->mesh.n_uvs &&
           a->mesh.n_triangles == b->mesh.n_triangles && a->n_id == b->n_id && a->n_exp == b->n_exp &&
           a->cluster_width == b->cluster_width && a->cluster_height == b->cluster_height &&
           !memcmp(a->mesh.positions, b->mesh.positions, n3 * 4) &&
           !memcmp(a->mesh.uvs, b->mesh.uvs, (size_t)a->mesh.n_uvs * 8) &&
           !memcmp(a->mesh.tri_vertices, b->mesh.tri_vertices, (size_t)a->mesh.n_triangles * 12) &&
           !memcmp(a->mesh.tri_uvs, b->mesh.tri_uvs, (size_t)a->mesh.n_triangles * 12) &&
           !memcmp(a->id_basis, b->id_basis, n3 * 4 * a->n_id) &&
           !memcmp(a->exp_basis, b->exp_basis, n3 * 4 * a->n_exp) &&
           !memcmp(a->exp_names, b->exp_names, (size_t)a->n_exp * SP_FACE_NAME_LEN) &&
           !memcmp(a->landmarks, b->landmarks, sizeof(a->landmarks)) &&
           !memcmp(a->face_mask, b->face_mask, a->mesh.n_vertices) &&
           !memcmp(a->part, b->part, a->mesh.n_vertices) &&
           !memcmp(a->cluster_map, b->cluster_map, (size_t)a->cluster_width * a->cluster_height) &&
           !strcmp(a->source, b->source);
}

static uint8_t *read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *buf = malloc((size_t)n + 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *size = (size_t)n;
    return buf;
}

static uint32_t rd32(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static void wr32(uint8_t *p, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (uint8_t)(v >> (8 * k));
}

/* Offset of a section's 16-byte head (tag, crc, 64-bit size), or 0. */
static size_t find_section(const uint8_t *d, size_t size, const char *tag)
{
    size_t off = 192;
    while (off + 16 <= size) {
        if (!memcmp(d + off, tag, 4))
            return off;
        off += 16 + (size_t)rd32(d + off + 8);
    }
    return 0;
}

static void fix_section_crc(uint8_t *d, size_t off)
{
    wr32(d + off + 4, sp_crc32c(0, d + off + 16, rd32(d + off + 8)));
}

static int read_mutated(const uint8_t *d, size_t size)
{
    sp_face_model m;
    int err = sp_face_model_read_memory(&m, d, size);
    if (err == 0)
        sp_face_model_free(&m);
    else
        CHECK(m.mesh.positions == NULL && m.id_basis == NULL);
    return err;
}

static void test_corrupt(const uint8_t *good, size_t size)
{
    uint8_t *d = malloc(size);
    memcpy(d, good, size);
    CHECK_EQ_INT(read_mutated(d, size), 0);
    d[0] ^= 1;
    CHECK_EQ_INT(read_mutated(d, size), SP_EFORMAT);
    d[0] ^= 1;
    wr32(d + 8, 2); /* a newer version */
    CHECK_EQ_INT(read_mutated(d, size), SP_EVERSION);
    wr32(d + 8, 1);
    d[70] ^= 0x20; /* inside the source string: only the header checksum can tell */
    CHECK_EQ_INT(read_mutated(d, size), SP_ECORRUPT);
    d[70] ^= 0x20;
    static const size_t cuts[] = { 0, 4, 12, 100, 191, 192, 200 };
    for (size_t i = 0; i < sizeof(cuts) / sizeof(cuts[0]); i++)
        CHECK(read_mutated(d, cuts[i]) < 0);
    CHECK(read_mutated(d, size / 2) < 0);
    CHECK(read_mutated(d, size - 1) < 0);
    /* bit flips anywhere are caught by a checksum or a structural check */
    for (int i = 0; i < 200; i++) {
        size_t at = (size_t)((urand() + 1.0) * 0.5 * (double)(size - 1));
        d[at] ^= (uint8_t)(1u << (i % 8));
        CHECK_MSG(read_mutated(d, size) < 0, "flip at %zu accepted", at);
        d[at] ^= (uint8_t)(1u << (i % 8));
    }
    /* a huge vertex count with a valid header checksum must not allocate or crash */
    wr32(d + 16, 0x7fffffffu);
    wr32(d + 188, sp_crc32c(0, d, 188));
    CHECK(read_mutated(d, size) < 0);
    memcpy(d, good, size);
    /* NaN and a bad index behind valid checksums are rejected by validation */
    size_t pos = find_section(d, size, "POSI");
    CHECK(pos > 0);
    wr32(d + pos + 16 + 40, 0x7fc00000u);
    fix_section_crc(d, pos);
    CHECK_EQ_INT(read_mutated(d, size), SP_ECORRUPT);
    memcpy(d, good, size);
    size_t tri = find_section(d, size, "TRIV");
    wr32(d + tri + 16 + 8, 0xfffffff0u);
    fix_section_crc(d, tri);
    CHECK_EQ_INT(read_mutated(d, size), SP_ECORRUPT);
    memcpy(d, good, size);
    size_t lmk = find_section(d, size, "LMRK");
    wr32(d + lmk + 16, 0x00ffffffu);
    fix_section_crc(d, lmk);
    CHECK_EQ_INT(read_mutated(d, size), SP_ECORRUPT);
    free(d);
}

/*
 * Mesh parts: an eyeball vertex survives the round trip; a file from before the PART section
 * (the section cut out) reads as all skin; a part out of range, or an eye in the face mask, is corrupt.
 */
static void test_parts(const char *path)
{
    sp_face_model m;
    CHECK_EQ_INT(sp_face_model_read(&m, path), 0);
    uint32_t eye = UINT32_MAX;
    for (uint32_t i = 0; i < m.mesh.n_vertices && eye == UINT32_MAX; i++)
        if (!m.face_mask[i])
            eye = i;
    CHECK(eye != UINT32_MAX);
    if (eye == UINT32_MAX) {
        sp_face_model_free(&m);
        return;
    }
    m.part[eye] = SP_FACE_PART_EYE;
    CHECK_EQ_INT(sp_face_model_write(&m, path), 0);
    sp_face_model back;
    CHECK_EQ_INT(sp_face_model_read(&back, path), 0);
    CHECK(models_equal(&m, &back));
    sp_face_model_free(&back);
    size_t size = 0;
    uint8_t *d = read_all(path, &size);
    size_t off = d ? find_section(d, size, "PART") : 0;
    CHECK(off > 0);
    if (off > 0) {
        size_t len = 16 + (size_t)rd32(d + off + 8);
        memmove(d + off, d + off + len, size - off - len);
        CHECK_EQ_INT(sp_face_model_read_memory(&back, d, size - len), 0);
        int all_skin = 1;
        for (uint32_t i = 0; i < back.mesh.n_vertices; i++)
            all_skin &= back.part[i] == SP_FACE_PART_SKIN;
        CHECK(all_skin);
        sp_face_model_free(&back);
    }
    free(d);
    m.part[eye] = 7;
    CHECK_EQ_INT(sp_face_model_validate(&m), SP_ECORRUPT);
    m.part[eye] = SP_FACE_PART_EYE;
    m.face_mask[eye] = 1;
    CHECK_EQ_INT(sp_face_model_validate(&m), SP_ECORRUPT);
    sp_face_model_free(&m);
}

static void test_files(const sp_face_model *m)
{
    char path[] = "/tmp/sp_face_test_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    close(fd);
    CHECK_EQ_INT(sp_face_model_write(m, path), 0);
    sp_face_model back;
    CHECK_EQ_INT(sp_face_model_read(&back, path), 0);
    CHECK(models_equal(m, &back));
    /* the writer refuses a model that does not validate */
    float keep = back.mesh.positions[5];
    back.mesh.positions[5] = NAN;
    CHECK_EQ_INT(sp_face_model_write(&back, path), SP_ECORRUPT);
    back.mesh.positions[5] = keep;
    sp_face_model_free(&back);
    CHECK(back.mesh.positions == NULL);
    size_t size = 0;
    uint8_t *bytes = read_all(path, &size);
    CHECK(bytes != NULL);
    if (bytes)
        test_corrupt(bytes, size);
    free(bytes);
    test_parts(path);
    unlink(path);
    sp_face_model none;
    CHECK_EQ_INT(sp_face_model_read(&none, "/nonexistent/face.spface"), -ENOENT);
    CHECK(sp_face_model_read_memory(&none, "SPFACEMD", 8) < 0);
    CHECK_EQ_INT(sp_face_model_read_memory(&none, "PK\3\4 not a face", 15), SP_EFORMAT);
}

/* ---- evaluation gradients ---- */

typedef struct fd_setup {
    const sp_face_model *m;
    double *id, *exp;
    sp_face_params p;
    double *w; /* dL/dv, fixed: L = sum w . v */
} fd_setup;

static double loss(fd_setup *f)
{
    size_t n3 = (size_t)f->m->mesh.n_vertices * 3;
    double *v = malloc(sizeof(double) * n3);
    double L = 0;
    CHECK_EQ_INT(sp_face_model_eval(f->m, &f->p, v), 0);
    for (size_t i = 0; i < n3; i++)
        L += f->w[i] * v[i];
    free(v);
    return L;
}

/* Pointers to every scalar parameter in the order of the landmark Jacobian's columns. */
static double *param_ptr(fd_setup *f, uint32_t k)
{
    uint32_t ni = f->m->n_id, ne = f->m->n_exp;
    if (k < ni)
        return &f->id[k];
    if (k < ni + ne)
        return &f->exp[k - ni];
    k -= ni + ne;
    return k < 3 ? &f->p.rotvec[k] : k < 6 ? &f->p.t[k - 3] : &f->p.s;
}

static double rel_err(double a, double b, double floor_)
{
    return fabs(a - b) / fmax(fmax(fabs(a), fabs(b)), floor_);
}

static double check_adjoint(fd_setup *f)
{
    const sp_face_model *m = f->m;
    uint32_t np = sp_face_model_n_params(m);
    double *gid = malloc(sizeof(double) * m->n_id), *gexp = malloc(sizeof(double) * m->n_exp);
    sp_face_grad g = { .id = gid, .exp = gexp };
    CHECK_EQ_INT(sp_face_model_eval_adjoint(m, &f->p, f->w, &g), 0);
    double *ad = malloc(sizeof(double) * np), *fd = malloc(sizeof(double) * np), scale = 0;
    for (uint32_t k = 0; k < np; k++) {
        ad[k] = k < m->n_id ? gid[k] : k < m->n_id + m->n_exp ? gexp[k - m->n_id]
              : k < np - 4 ? g.rotvec[k - m->n_id - m->n_exp] : k < np - 1 ? g.t[k - (np - 4)] : g.s;
        double *x = param_ptr(f, k), x0 = *x, h = 1e-5 * fmax(1.0, fabs(x0));
        *x = x0 + h;
        double lp = loss(f);
        *x = x0 - h;
        double lm = loss(f);
        *x = x0;
        fd[k] = (lp - lm) / (2 * h);
        scale = fmax(scale, fabs(fd[k]));
    }
    double worst = 0;
    for (uint32_t k = 0; k < np; k++) {
        double e = rel_err(ad[k], fd[k], 1e-4 * scale);
        CHECK_MSG(e < 1e-6, "param %u: adjoint %.12g vs FD %.12g", k, ad[k], fd[k]);
        worst = fmax(worst, e);
    }
    free(ad);
    free(fd);
    free(gid);
    free(gexp);
    return worst;
}

static void camera_facing(sp_face_camera *cam)
{
    /* OpenCV camera 0.6 m in front of the face, looking back at it, slightly turned */
    sp_face_camera_init(cam, 800, 820, 320, 240);
    double a = 0.1, c = cos(a), s = sin(a);
    double R[9] = { c, 0, s, 0, -1, 0, s, 0, -c }; /* diag(1,-1,-1) then a small turn about y */
    memcpy(cam->R, R, sizeof(R));
    cam->t[0] = 0.01;
    cam->t[1] = 0.02;
    cam->t[2] = 0.6;
}

/* Central difference with one Richardson step: O(h^4) truncation, little roundoff at h = 1e-4. */
static void landmark_fd(fd_setup *f, const sp_face_camera *cam, uint32_t k, double out[136])
{
    double *x = param_ptr(f, k), x0 = *x, h = 1e-4 * fmax(1.0, fabs(x0)), d[2][136];
    for (int level = 0; level < 2; level++) {
        double hh = level ? 0.5 * h : h, up[136], um[136];
        *x = x0 + hh;
        sp_face_model_project_landmarks(f->m, &f->p, cam, up, NULL, NULL);
        *x = x0 - hh;
        sp_face_model_project_landmarks(f->m, &f->p, cam, um, NULL, NULL);
        *x = x0;
        for (int r = 0; r < 136; r++)
            d[level][r] = (up[r] - um[r]) / (2 * hh);
    }
    for (int r = 0; r < 136; r++)
        out[r] = (4.0 * d[1][r] - d[0][r]) / 3.0;
}

static double check_landmark_jacobian(fd_setup *f, const sp_face_camera *cam)
{
    const sp_face_model *m = f->m;
    uint32_t np = sp_face_model_n_params(m);
    double uv[136], fd[136], *J = malloc(sizeof(double) * 136 * np), worst = 0;
    uint8_t valid[68];
    CHECK_EQ_INT(sp_face_model_project_landmarks(m, &f->p, cam, uv, valid, J), 68);
    for (uint32_t k = 0; k < np; k++) {
        landmark_fd(f, cam, k, fd);
        for (int r = 0; r < 136; r++) {
            /* below 0.01 pixel per unit of a parameter, relative error is measured against that floor */
            double e = rel_err(J[(size_t)r * np + k], fd[r], 1e-2);
            CHECK_MSG(e < 1e-6, "row %d param %u: J %.12g vs FD %.12g", r, k, J[(size_t)r * np + k], fd[r]);
            worst = fmax(worst, e);
        }
    }
    free(J);
    return worst;
}

static void random_setup(fd_setup *f, const sp_face_model *m, double angle)
{
    f->m = m;
    f->id = malloc(sizeof(double) * m->n_id);
    f->exp = malloc(sizeof(double) * m->n_exp);
    for (uint32_t k = 0; k < m->n_id; k++)
        f->id[k] = urand();
    for (uint32_t k = 0; k < m->n_exp; k++)
        f->exp[k] = 0.5 + 0.5 * urand();
    sp_face_params_init(&f->p);
    f->p.id = f->id;
    f->p.exp = f->exp;
    double axis[3] = { urand(), urand(), urand() }, n = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    for (int k = 0; k < 3; k++) {
        f->p.rotvec[k] = angle * axis[k] / n;
        f->p.t[k] = 0.02 * urand();
    }
    f->p.s = 1.1;
    size_t n3 = (size_t)m->mesh.n_vertices * 3;
    f->w = malloc(sizeof(double) * n3);
    for (size_t i = 0; i < n3; i++)
        f->w[i] = urand();
}

static void free_setup(fd_setup *f)
{
    free(f->id);
    free(f->exp);
    free(f->w);
}

static void test_gradients(const sp_face_model *m)
{
    static const double angles[] = { 0.0, 1e-9, 1e-4, 5e-3, 0.02, 0.4, 1.3, 3.0, PI, 6.0, 25.0 };
    for (size_t i = 0; i < sizeof(angles) / sizeof(angles[0]); i++) {
        fd_setup f;
        random_setup(&f, m, angles[i]);
        double e = check_adjoint(&f);
        printf("adjoint FD check, |r| = %g: worst relative error %.2e\n", angles[i], e);
        free_setup(&f);
    }
    sp_face_camera cam;
    camera_facing(&cam);
    static const double lm_angles[] = { 0.0, 1e-7, 0.05, 0.3 };
    for (size_t i = 0; i < sizeof(lm_angles) / sizeof(lm_angles[0]); i++) {
        fd_setup f;
        random_setup(&f, m, lm_angles[i]);
        double e = check_landmark_jacobian(&f, &cam);
        printf("landmark Jacobian FD check, |r| = %g: worst relative error %.2e\n", lm_angles[i], e);
        free_setup(&f);
    }
}

/* ---- extremes ---- */

static int all_finite(const double *x, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

static void test_extremes(const sp_face_model *m)
{
    size_t n3 = (size_t)m->mesh.n_vertices * 3;
    double *v = malloc(sizeof(double) * n3), *w = malloc(sizeof(double) * n3);
    float *vf = malloc(sizeof(float) * n3);
    double *id = calloc(m->n_id, sizeof(double)), *ex = calloc(m->n_exp, sizeof(double));
    double gid[64], gex[64], uv[136], J[136 * 80];
    uint8_t valid[68];
    for (size_t i = 0; i < n3; i++)
        w[i] = 1.0;
    sp_face_params p;
    sp_face_params_init(&p);
    p.id = id;
    p.exp = ex;
    sp_face_grad g = { .id = gid, .exp = gex };
    sp_face_camera cam;
    camera_facing(&cam);

    /* s = 0: everything collapses onto t, gradients stay finite */
    p.s = 0;
    p.t[2] = 0.1;
    CHECK_EQ_INT(sp_face_model_eval(m, &p, v), 0);
    CHECK(all_finite(v, n3) && v[2] == 0.1 && v[n3 - 1] == 0.1);
    CHECK_EQ_INT(sp_face_model_eval_adjoint(m, &p, w, &g), 0);
    CHECK(all_finite(gid, m->n_id) && gid[0] == 0.0 && isfinite(g.s) && g.t[0] == (double)m->mesh.n_vertices);
    CHECK(sp_face_model_project_landmarks(m, &p, &cam, uv, valid, J) == 68 && all_finite(J, 136 * (size_t)sp_face_model_n_params(m)));

    /* huge but allowed coefficients and a 180 degree turn */
    p.s = 1.0;
    for (uint32_t k = 0; k < m->n_id; k++)
        id[k] = 1e5;
    for (uint32_t k = 0; k < m->n_exp; k++)
        ex[k] = -1e5;
    p.rotvec[1] = PI;
    CHECK_EQ_INT(sp_face_model_eval(m, &p, v), 0);
    CHECK(all_finite(v, n3));
    CHECK_EQ_INT(sp_face_model_eval_float(m, &p, vf), 0);
    int ok = 1;
    for (size_t i = 0; i < n3; i++)
        ok &= isfinite(vf[i]);
    CHECK(ok);
    CHECK_EQ_INT(sp_face_model_eval_adjoint(m, &p, w, &g), 0);
    CHECK(all_finite(gid, m->n_id) && all_finite(gex, m->n_exp) && all_finite(g.rotvec, 3) && isfinite(g.s));
    int nv = sp_face_model_project_landmarks(m, &p, &cam, uv, valid, J);
    CHECK(nv >= 0 && all_finite(uv, 136) && all_finite(J, 136 * (size_t)sp_face_model_n_params(m)));

    /* 180 degrees about y turns the nose to -z; the camera in front then sees no landmark */
    memset(id, 0, sizeof(double) * m->n_id);
    memset(ex, 0, sizeof(double) * m->n_exp);
    p.t[2] = 0;
    CHECK_EQ_INT(sp_face_model_eval(m, &p, v), 0);
    CHECK(v[(size_t)m->landmarks[30] * 3 + 2] < -0.05);
    sp_face_camera_init(&cam, 800, 800, 320, 240); /* camera at the origin: the whole head surrounds it */
    nv = sp_face_model_project_landmarks(m, &p, &cam, uv, valid, J);
    CHECK(nv >= 0 && nv < 68);
    for (int j = 0; j < 68; j++)
        if (!valid[j]) {
            CHECK(uv[2 * j] == 320 && uv[2 * j + 1] == 240);
            CHECK(J[(size_t)(2 * j) * sp_face_model_n_params(m)] == 0);
        }

    /* out of limits and non-finite inputs are refused */
    p.rotvec[1] = 0;
    id[0] = 1e7;
    CHECK_EQ_INT(sp_face_model_eval(m, &p, v), -EINVAL);
    id[0] = NAN;
    CHECK_EQ_INT(sp_face_model_eval_adjoint(m, &p, w, &g), -EINVAL);
    id[0] = 0;
    p.s = INFINITY;
    CHECK_EQ_INT(sp_face_model_eval(m, &p, v), -EINVAL);
    p.s = 1;
    p.rotvec[0] = NAN;
    CHECK_EQ_INT(sp_face_model_project_landmarks(m, &p, &cam, uv, valid, NULL), -EINVAL);
    p.rotvec[0] = 0;
    cam.fx = NAN;
    CHECK_EQ_INT(sp_face_model_project_landmarks(m, &p, &cam, uv, valid, NULL), -EINVAL);
    CHECK_EQ_INT(sp_face_model_eval(NULL, &p, v), -EINVAL);
    CHECK_EQ_INT(sp_face_model_eval(m, &p, NULL), -EINVAL);

    /* rotation sanity: +90 degrees about y takes the nose from +z to +x */
    p.rotvec[1] = PI / 2;
    CHECK_EQ_INT(sp_face_model_eval(m, &p, v), 0);
    const float *nose = vpos(m, m->landmarks[30]);
    CHECK_NEAR(v[(size_t)m->landmarks[30] * 3], (double)nose[2], 1e-9);
    CHECK_NEAR(v[(size_t)m->landmarks[30] * 3 + 2], -(double)nose[0], 1e-9);
    free(v);
    free(w);
    free(vf);
    free(id);
    free(ex);
}

static void test_load_default(void)
{
    setenv("SP_ICT_FACEKIT_DIR", "/nonexistent/ict-facekit", 1);
    sp_face_model m;
    CHECK_EQ_INT(sp_face_model_load_default(&m), 0);
    CHECK(strncmp(m.source, "generic-head", 12) == 0);
    sp_face_model_free(&m);
    CHECK_EQ_INT(sp_face_model_generic(NULL), -EINVAL);
    sp_face_model_free(NULL);
}

int main(void)
{
    sp_face_model m;
    int err = sp_face_model_generic(&m);
    CHECK_EQ_INT(err, 0);
    if (err)
        return check_exit();
    printf("generic head: %u vertices, %u UVs, %u triangles, %u identity + %u expression modes\n",
           m.mesh.n_vertices, m.mesh.n_uvs, m.mesh.n_triangles, m.n_id, m.n_exp);
    test_mesh(&m);
    test_landmarks(&m);
    test_regions(&m);
    test_files(&m);
    test_gradients(&m);
    test_extremes(&m);
    sp_face_model_free(&m);
    test_load_default();
    return check_exit();
}
