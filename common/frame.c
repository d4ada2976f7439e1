/* SPDX-License-Identifier: MIT */
/* Refcounted frames from fixed-size pools, and pixel-format facts. */
#include "sunprobe/sp_frame.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <pthread.h>

struct sp_frame_pool {
    pthread_mutex_t lock;
    unsigned count;
    unsigned free_count;
    size_t max_bytes;
    int refs;        /* one for the owner plus one per frame handed out */
    sp_frame *frames;
    sp_frame **free_list;
    uint8_t *storage;
};

static const struct {
    const char *name;
} pixfmt_info[SP_PIXFMT_COUNT] = {
    [SP_PIXFMT_NONE] = { "none" },   [SP_PIXFMT_GRAY8] = { "gray8" }, [SP_PIXFMT_RGB24] = { "rgb24" },
    [SP_PIXFMT_YUYV] = { "yuyv" },   [SP_PIXFMT_NV12] = { "nv12" },   [SP_PIXFMT_MJPEG] = { "mjpeg" },
};

const char *sp_pixfmt_name(enum sp_pixfmt fmt)
{
    if ((unsigned)fmt >= SP_PIXFMT_COUNT)
        return "invalid";
    return pixfmt_info[fmt].name;
}

enum sp_pixfmt sp_pixfmt_from_name(const char *name)
{
    if (!name)
        return SP_PIXFMT_NONE;
    for (unsigned i = 1; i < SP_PIXFMT_COUNT; i++)
        if (strcmp(pixfmt_info[i].name, name) == 0)
            return (enum sp_pixfmt)i;
    if (strcmp(name, "jpeg") == 0)
        return SP_PIXFMT_MJPEG;
    return SP_PIXFMT_NONE;
}

uint32_t sp_pixfmt_min_stride(enum sp_pixfmt fmt, uint32_t width)
{
    switch (fmt) {
    case SP_PIXFMT_GRAY8:
        return width;
    case SP_PIXFMT_NV12: /* the interleaved UV row holds a full pair for an odd last column */
        return width > UINT32_MAX - 1 ? 0 : (width + 1) & ~1u;
    case SP_PIXFMT_RGB24:
        return width > UINT32_MAX / 3 ? 0 : width * 3;
    case SP_PIXFMT_YUYV:
        return width > UINT32_MAX / 2 ? 0 : ((width + 1) & ~1u) * 2;
    default:
        return 0;
    }
}

size_t sp_pixfmt_image_size(enum sp_pixfmt fmt, uint32_t width, uint32_t height, uint32_t stride)
{
    uint32_t min = sp_pixfmt_min_stride(fmt, width);
    if (min == 0 || stride < min || width == 0 || height == 0)
        return 0;
    size_t rows = height;
    if (fmt == SP_PIXFMT_NV12)
        rows = (size_t)height + (height + 1) / 2;
    if (rows > SIZE_MAX / stride)
        return 0;
    return rows * (size_t)stride;
}

static void pool_drop(sp_frame_pool *pool)
{
    pthread_mutex_lock(&pool->lock);
    int left = --pool->refs;
    pthread_mutex_unlock(&pool->lock);
    if (left > 0)
        return;
    pthread_mutex_destroy(&pool->lock);
    free(pool->storage);
    free(pool->free_list);
    free(pool->frames);
    free(pool);
}

int sp_frame_pool_open(sp_frame_pool **out, unsigned count, size_t max_bytes)
{
    if (!out || count == 0 || max_bytes == 0 || max_bytes > SIZE_MAX / count)
        return -EINVAL;
    *out = NULL;
    sp_frame_pool *pool = calloc(1, sizeof(*pool));
    if (!pool)
        return -ENOMEM;
    pool->frames = calloc(count, sizeof(*pool->frames));
    pool->free_list = calloc(count, sizeof(*pool->free_list));
    pool->storage = malloc(count * max_bytes);
    if (!pool->frames || !pool->free_list || !pool->storage) {
        free(pool->frames);
        free(pool->free_list);
        free(pool->storage);
        free(pool);
        return -ENOMEM;
    }
    pthread_mutex_init(&pool->lock, NULL);
    pool->count = count;
    pool->max_bytes = max_bytes;
    pool->refs = 1;
    for (unsigned i = 0; i < count; i++) {
        sp_frame *f = &pool->frames[i];
        f->data = pool->storage + (size_t)i * max_bytes;
        f->capacity = max_bytes;
        f->pool = pool;
        pool->free_list[i] = f;
    }
    pool->free_count = count;
    *out = pool;
    return 0;
}

void sp_frame_pool_close(sp_frame_pool **pool)
{
    if (!pool || !*pool)
        return;
    pool_drop(*pool);
    *pool = NULL;
}

int sp_frame_pool_get(sp_frame_pool *pool, sp_frame **out)
{
    if (!pool || !out)
        return -EINVAL;
    pthread_mutex_lock(&pool->lock);
    if (pool->free_count == 0) {
        pthread_mutex_unlock(&pool->lock);
        return -EAGAIN;
    }
    sp_frame *f = pool->free_list[--pool->free_count];
    pool->refs++;
    pthread_mutex_unlock(&pool->lock);

    uint8_t *data = f->data;
    size_t capacity = f->capacity;
    memset(f, 0, sizeof(*f));
    f->data = data;
    f->capacity = capacity;
    f->pool = pool;
    f->exposure_us = NAN;
    f->gain = NAN;
    f->refcount = 1;
    *out = f;
    return 0;
}

size_t sp_frame_pool_max_bytes(const sp_frame_pool *pool)
{
    return pool ? pool->max_bytes : 0;
}

unsigned sp_frame_pool_free_count(const sp_frame_pool *pool)
{
    if (!pool)
        return 0;
    pthread_mutex_lock((pthread_mutex_t *)&pool->lock);
    unsigned n = pool->free_count;
    pthread_mutex_unlock((pthread_mutex_t *)&pool->lock);
    return n;
}

sp_frame *sp_frame_ref(sp_frame *frame)
{
    if (frame)
        __atomic_add_fetch(&frame->refcount, 1, __ATOMIC_RELAXED);
    return frame;
}

void sp_frame_unref(sp_frame **frame)
{
    if (!frame || !*frame)
        return;
    sp_frame *f = *frame;
    *frame = NULL;
    if (__atomic_sub_fetch(&f->refcount, 1, __ATOMIC_ACQ_REL) != 0)
        return;
    sp_frame_pool *pool = f->pool;
    pthread_mutex_lock(&pool->lock);
    pool->free_list[pool->free_count++] = f;
    pthread_mutex_unlock(&pool->lock);
    pool_drop(pool);
}
