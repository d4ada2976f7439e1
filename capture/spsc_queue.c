/* SPDX-License-Identifier: MIT */
/* Bounded SPSC ring: head and tail are free-running counters; acquire/release order the slot contents. */
#include "capture/spsc_queue.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

int sp_spsc_init(sp_spsc *q, size_t capacity, size_t slot_size)
{
    if (!q || capacity == 0 || slot_size == 0 || capacity > SIZE_MAX / slot_size)
        return -EINVAL;
    memset(q, 0, sizeof(*q));
    q->slots = calloc(capacity, slot_size);
    if (!q->slots)
        return -ENOMEM;
    q->capacity = capacity;
    q->slot_size = slot_size;
    atomic_init(&q->head, 0);
    atomic_init(&q->tail, 0);
    return 0;
}

void sp_spsc_free(sp_spsc *q)
{
    if (!q)
        return;
    free(q->slots);
    q->slots = NULL;
}

void *sp_spsc_reserve(sp_spsc *q)
{
    size_t tail = atomic_load_explicit(&q->tail, memory_order_relaxed);
    size_t head = atomic_load_explicit(&q->head, memory_order_acquire); /* the consumer is done with that slot */
    if (tail - head >= q->capacity)
        return NULL;
    return q->slots + (tail % q->capacity) * q->slot_size;
}

void sp_spsc_push(sp_spsc *q)
{
    size_t tail = atomic_load_explicit(&q->tail, memory_order_relaxed);
    atomic_store_explicit(&q->tail, tail + 1, memory_order_release); /* slot contents before the new tail */
}

void *sp_spsc_peek(sp_spsc *q)
{
    size_t head = atomic_load_explicit(&q->head, memory_order_relaxed);
    size_t tail = atomic_load_explicit(&q->tail, memory_order_acquire);
    if (head == tail)
        return NULL;
    return q->slots + (head % q->capacity) * q->slot_size;
}

void sp_spsc_pop(sp_spsc *q)
{
    size_t head = atomic_load_explicit(&q->head, memory_order_relaxed);
    atomic_store_explicit(&q->head, head + 1, memory_order_release);
}

size_t sp_spsc_count(sp_spsc *q)
{
    size_t tail = atomic_load_explicit(&q->tail, memory_order_acquire);
    size_t head = atomic_load_explicit(&q->head, memory_order_acquire);
    return tail - head;
}
