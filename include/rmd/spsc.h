/* SPDX-License-Identifier: MIT */
/*
 * Lock-free single-producer/single-consumer hand-overs between the rt loop
 * and normal threads (docs/design.md, layers rt and svc).  Neither side ever
 * blocks, allocates or takes a lock; the caller provides the storage.
 *
 * struct rmd_ring: a power-of-two queue of fixed-size records (events from
 * the rt thread to the logger; nothing is overwritten: a full ring refuses
 * the record and counts it).
 *
 * struct rmd_latest: a triple buffer for "the newest value wins" (setpoints
 * from the bridge to the rt loop, state snapshots back): the writer never
 * waits for the reader and the reader always gets a whole, consistent
 * value, never a torn one.
 *
 * All functions are rt-safe.
 */
#ifndef RMD_SPSC_H
#define RMD_SPSC_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

struct rmd_ring {
	_Alignas(64) atomic_size_t head; /* written by the producer */
	_Alignas(64) atomic_size_t tail; /* written by the consumer */
	_Alignas(64) atomic_uint_fast64_t dropped;
	size_t mask;	 /* slots - 1 */
	size_t rec_size; /* bytes per record */
	unsigned char *buf;
};

/* slots must be a power of two; buf holds slots * rec_size bytes. Returns 0 or -EINVAL. */
int rmd_ring_init(struct rmd_ring *r, void *buf, size_t slots, size_t rec_size);

/* Producer: copy one record in; false (and counted) when the ring is full. */
static inline bool rmd_ring_push(struct rmd_ring *r, const void *rec)
{
	size_t head = atomic_load_explicit(&r->head, memory_order_relaxed);
	size_t tail = atomic_load_explicit(&r->tail, memory_order_acquire);

	if (head - tail > r->mask) {
		atomic_fetch_add_explicit(&r->dropped, 1, memory_order_relaxed);
		return false;
	}
	memcpy(r->buf + (head & r->mask) * r->rec_size, rec, r->rec_size);
	atomic_store_explicit(&r->head, head + 1, memory_order_release);
	return true;
}

/* Consumer: copy the oldest record out; false when the ring is empty. */
static inline bool rmd_ring_pop(struct rmd_ring *r, void *rec)
{
	size_t tail = atomic_load_explicit(&r->tail, memory_order_relaxed);
	size_t head = atomic_load_explicit(&r->head, memory_order_acquire);

	if (tail == head)
		return false;
	memcpy(rec, r->buf + (tail & r->mask) * r->rec_size, r->rec_size);
	atomic_store_explicit(&r->tail, tail + 1, memory_order_release);
	return true;
}

/* Records refused because the ring was full. */
static inline uint64_t rmd_ring_dropped(struct rmd_ring *r)
{
	return atomic_load_explicit(&r->dropped, memory_order_relaxed);
}

/*
 * Triple buffer.  Three slots of `size` bytes: one the writer fills, one
 * the reader holds, one ready to swap.  `state` packs the index of the
 * ready slot and a "new value" bit.
 */
struct rmd_latest {
	_Alignas(64) atomic_uint state; /* bits 0-1 ready slot, bit 2 fresh */
	unsigned write_idx;		/* owned by the writer */
	unsigned read_idx;		/* owned by the reader */
	size_t size;
	unsigned char *slot[3];
	_Alignas(64) atomic_uint_fast64_t published;
};

/* buf holds 3 * size bytes, zeroed by the caller if the first read must see zeros. */
void rmd_latest_init(struct rmd_latest *l, void *buf, size_t size);

/* Writer: the slot to fill next (valid until rmd_latest_publish). */
static inline void *rmd_latest_write_slot(struct rmd_latest *l)
{
	return l->slot[l->write_idx];
}

/* Writer: make the filled slot the newest value. */
static inline void rmd_latest_publish(struct rmd_latest *l)
{
	unsigned old = atomic_exchange_explicit(&l->state, l->write_idx | 4u, memory_order_acq_rel);

	l->write_idx = old & 3u;
	atomic_fetch_add_explicit(&l->published, 1, memory_order_relaxed);
}

/* Writer: copy `value` in and publish it. */
static inline void rmd_latest_put(struct rmd_latest *l, const void *value)
{
	memcpy(rmd_latest_write_slot(l), value, l->size);
	rmd_latest_publish(l);
}

/*
 * Reader: true and the newest value in *out (a pointer valid until the next
 * call) when one was published since the last call; false otherwise (*out
 * then points at the previous value).
 */
static inline bool rmd_latest_get(struct rmd_latest *l, const void **out)
{
	bool fresh = atomic_load_explicit(&l->state, memory_order_relaxed) & 4u;

	if (fresh) {
		unsigned old =
			atomic_exchange_explicit(&l->state, l->read_idx, memory_order_acq_rel);
		l->read_idx = old & 3u;
	}
	*out = l->slot[l->read_idx];
	return fresh;
}

#endif /* RMD_SPSC_H */
