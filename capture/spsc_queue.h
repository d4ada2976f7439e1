/* SPDX-License-Identifier: MIT */
/*
 * Internal: a bounded lock-free single-producer/single-consumer ring of
 * fixed-size slots. The producer fills a slot in place and publishes it; the
 * consumer reads it in place and releases it. Neither side ever waits.
 */
#ifndef SUNPROBE_CAPTURE_SPSC_QUEUE_H
#define SUNPROBE_CAPTURE_SPSC_QUEUE_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

typedef struct sp_spsc {
    _Alignas(64) atomic_size_t tail; /* written by the producer: slots published */
    _Alignas(64) atomic_size_t head; /* written by the consumer: slots released */
    _Alignas(64) size_t capacity;
    size_t slot_size;
    uint8_t *slots;
} sp_spsc;

/* capacity slots of slot_size bytes each (both > 0). */
int sp_spsc_init(sp_spsc *q, size_t capacity, size_t slot_size);
void sp_spsc_free(sp_spsc *q);
/* Producer: the next free slot, or NULL when the ring is full. Publish it with sp_spsc_push. */
void *sp_spsc_reserve(sp_spsc *q);
void sp_spsc_push(sp_spsc *q);
/* Consumer: the oldest published slot, or NULL when empty. Release it with sp_spsc_pop. */
void *sp_spsc_peek(sp_spsc *q);
void sp_spsc_pop(sp_spsc *q);
/* Published, not yet released (exact from either side for its own view). */
size_t sp_spsc_count(sp_spsc *q);

#endif
