/* SPDX-License-Identifier: MIT */
/*
 * The ".spface" file: a versioned little-endian header, then tagged sections,
 * each with its own CRC-32C. Layout in FACE_MODEL.md. The reader never trusts
 * a size before checking it against the file length.
 */
#include "sunprobe/sp_face_model.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/crc32c.h"
#include "common/file_util.h"
#include "face_internal.h"

#define MAGIC "SPFACEMD"
#define VERSION 1u
#define HEADER_BYTES 192u
#define SECTION_HEAD 16u
#define MAX_FILE ((size_t)1 << 31)

enum { SEC_POS, SEC_UV, SEC_TRIV, SEC_TRIU, SEC_IDB, SEC_EXB, SEC_EXN, SEC_LMK, SEC_MASK, SEC_CLUS, SEC_PART, N_SEC };
static const char section_tags[N_SEC][5] = { "POSI", "UVCO", "TRIV", "TRIU", "IDBS", "EXBS",
                                             "EXNM", "LMRK", "MASK", "CLUS", "PART" };
#define SEC_OPTIONAL SEC_PART /* sections from here on were added within version 1: absent means the default */

/* ---- little-endian helpers ---- */

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put_u64(uint8_t *p, uint64_t v)
{
    put_u32(p, (uint32_t)v);
    put_u32(p + 4, (uint32_t)(v >> 32));
}

static uint64_t get_u64(const uint8_t *p)
{
    return (uint64_t)get_u32(p) | (uint64_t)get_u32(p + 4) << 32;
}

/* Element kinds: 4-byte floats or integers are byte-swapped to little-endian, bytes copied. */
typedef struct section {
    void *data;
    size_t count;
    size_t elem; /* 4 or 1 */
} section;

static void describe(const sp_face_model *m, section s[N_SEC])
{
    size_t nv = m->mesh.n_vertices, n3 = nv * 3, nt3 = (size_t)m->mesh.n_triangles * 3;
    s[SEC_POS] = (section){ m->mesh.positions, n3, 4 };
    s[SEC_UV] = (section){ m->mesh.uvs, (size_t)m->mesh.n_uvs * 2, 4 };
    s[SEC_TRIV] = (section){ m->mesh.tri_vertices, nt3, 4 };
    s[SEC_TRIU] = (section){ m->mesh.tri_uvs, nt3, 4 };
    s[SEC_IDB] = (section){ m->id_basis, n3 * m->n_id, 4 };
    s[SEC_EXB] = (section){ m->exp_basis, n3 * m->n_exp, 4 };
    s[SEC_EXN] = (section){ m->exp_names, (size_t)m->n_exp * SP_FACE_NAME_LEN, 1 };
    s[SEC_LMK] = (section){ (void *)m->landmarks, SP_FACE_N_LANDMARKS, 4 };
    s[SEC_MASK] = (section){ m->face_mask, nv, 1 };
    s[SEC_CLUS] = (section){ m->cluster_map, (size_t)m->cluster_width * m->cluster_height, 1 };
    s[SEC_PART] = (section){ m->part, nv, 1 };
}

static void encode(uint8_t *dst, const section *s)
{
    if (s->elem == 1) {
        memcpy(dst, s->data, s->count);
        return;
    }
    const uint8_t *src = s->data;
    for (size_t i = 0; i < s->count; i++) {
        uint32_t v;
        memcpy(&v, src + i * 4, 4); /* floats travel as their bit patterns */
        put_u32(dst + i * 4, v);
    }
}

static void decode(void *out, const uint8_t *src, const section *s)
{
    if (s->elem == 1) {
        memcpy(out, src, s->count);
        return;
    }
    uint8_t *dst = out;
    for (size_t i = 0; i < s->count; i++) {
        uint32_t v = get_u32(src + i * 4);
        memcpy(dst + i * 4, &v, 4);
    }
}

/* ---- writing ---- */

static void write_header(const sp_face_model *m, uint8_t *h)
{
    memset(h, 0, HEADER_BYTES);
    memcpy(h, MAGIC, 8);
    uint32_t f[] = { VERSION, HEADER_BYTES, m->mesh.n_vertices, m->mesh.n_uvs, m->mesh.n_triangles, m->n_id,
                     m->n_exp, SP_FACE_N_LANDMARKS, m->cluster_width, m->cluster_height, N_SEC };
    for (size_t i = 0; i < sizeof(f) / sizeof(f[0]); i++)
        put_u32(h + 8 + 4 * i, f[i]);
    memcpy(h + 60, m->source, sizeof(m->source));
    put_u32(h + HEADER_BYTES - 4, sp_crc32c(0, h, HEADER_BYTES - 4));
}

int sp_face_model_write(const sp_face_model *model, const char *path)
{
    if (!path)
        return -EINVAL;
    int err = sp_face_model_validate(model);
    if (err)
        return err;
    section s[N_SEC];
    describe(model, s);
    size_t total = HEADER_BYTES;
    for (int i = 0; i < N_SEC; i++)
        total += SECTION_HEAD + s[i].count * s[i].elem;
    uint8_t *buf = malloc(total);
    if (!buf)
        return -ENOMEM;
    write_header(model, buf);
    size_t off = HEADER_BYTES;
    for (int i = 0; i < N_SEC; i++) {
        size_t bytes = s[i].count * s[i].elem;
        memcpy(buf + off, section_tags[i], 4);
        encode(buf + off + SECTION_HEAD, &s[i]);
        put_u32(buf + off + 4, sp_crc32c(0, buf + off + SECTION_HEAD, bytes));
        put_u64(buf + off + 8, bytes);
        off += SECTION_HEAD + bytes;
    }
    err = sp_write_whole_file_atomic(path, buf, total);
    free(buf);
    return err;
}

/* ---- reading ---- */

typedef struct header {
    uint32_t nv, nuv, nt, nid, nexp, nlm, cw, ch, nsec;
    char source[128];
} header;

static int parse_header(const uint8_t *d, size_t size, header *h)
{
    if (size < 8 || memcmp(d, MAGIC, 8) != 0)
        return SP_EFORMAT;
    if (size < 16)
        return SP_ETRUNCATED;
    uint32_t version = get_u32(d + 8), hbytes = get_u32(d + 12);
    if (version > VERSION)
        return SP_EVERSION;
    if (version == 0 || hbytes != HEADER_BYTES)
        return SP_ECORRUPT;
    if (size < HEADER_BYTES)
        return SP_ETRUNCATED;
    if (get_u32(d + HEADER_BYTES - 4) != sp_crc32c(0, d, HEADER_BYTES - 4))
        return SP_ECORRUPT;
    uint32_t *f[] = { &h->nv, &h->nuv, &h->nt, &h->nid, &h->nexp, &h->nlm, &h->cw, &h->ch, &h->nsec };
    for (size_t i = 0; i < sizeof(f) / sizeof(f[0]); i++)
        *f[i] = get_u32(d + 16 + 4 * i);
    memcpy(h->source, d + 60, sizeof(h->source));
    if (h->nlm != SP_FACE_N_LANDMARKS || h->nsec > 4096 || memchr(h->source, 0, sizeof(h->source)) == NULL)
        return SP_ECORRUPT;
    return 0;
}

/* Sizes promised by the header must fit in the file before anything is allocated. */
static int header_fits(const header *h, size_t size)
{
    size_t n3 = (size_t)h->nv * 3;
    double need = (double)n3 * 4.0 * (1.0 + h->nid + h->nexp) + (double)h->nuv * 8.0 + (double)h->nt * 24.0 +
                  (double)h->cw * h->ch;
    return need <= (double)size;
}

static int read_sections(sp_face_model *m, const uint8_t *d, size_t size)
{
    section s[N_SEC];
    describe(m, s);
    int seen[N_SEC] = { 0 };
    size_t off = HEADER_BYTES;
    while (off < size) {
        if (size - off < SECTION_HEAD)
            return SP_ETRUNCATED;
        uint64_t bytes = get_u64(d + off + 8);
        if (bytes > size - off - SECTION_HEAD)
            return SP_ETRUNCATED;
        const uint8_t *payload = d + off + SECTION_HEAD;
        if (get_u32(d + off + 4) != sp_crc32c(0, payload, (size_t)bytes))
            return SP_ECORRUPT;
        for (int i = 0; i < N_SEC; i++) {
            if (memcmp(d + off, section_tags[i], 4) != 0)
                continue;
            if (seen[i]++ || bytes != s[i].count * s[i].elem)
                return SP_ECORRUPT;
            decode(s[i].data, payload, &s[i]);
        }
        off += SECTION_HEAD + (size_t)bytes; /* unknown tags: skipped, for additions within version 1 */
    }
    for (int i = 0; i < SEC_OPTIONAL; i++)
        if (!seen[i])
            return SP_ECORRUPT;
    return 0; /* a file without PART: every vertex is skin (the allocation's zeros) */
}

int sp_face_model_read_memory(sp_face_model *model, const void *data, size_t size)
{
    if (!model || (!data && size))
        return -EINVAL;
    memset(model, 0, sizeof(*model));
    header h;
    int err = parse_header(data, size, &h);
    if (err)
        return err;
    if (!header_fits(&h, size))
        return SP_ETRUNCATED;
    err = sp_face_model_alloc(model, h.nv, h.nuv, h.nt, h.nid, h.nexp, h.cw, h.ch);
    if (err)
        return err == -EINVAL ? SP_ECORRUPT : err;
    memcpy(model->source, h.source, sizeof(model->source));
    err = read_sections(model, data, size);
    if (!err)
        err = sp_face_model_validate(model);
    if (err)
        sp_face_model_free(model);
    return err;
}

int sp_face_model_read(sp_face_model *model, const char *path)
{
    if (!model || !path)
        return -EINVAL;
    memset(model, 0, sizeof(*model));
    void *buf = NULL;
    size_t size = 0;
    int err = sp_read_whole_file(path, MAX_FILE, &buf, &size);
    if (err)
        return err;
    err = sp_face_model_read_memory(model, buf, size);
    free(buf);
    return err;
}
