// SPDX-License-Identifier: MIT
/*
 * The incident recorder's ring (rmd/incident.h).  The loop's calls are
 * rt-safe: fixed-size copies into slots allocated and touched before the
 * loop started, and two atomic stores a batch of records.  Reading, allocation and freeing are
 * non-rt.
 *
 * Each ring overwrites its oldest record.  The writer announces the last
 * index it is about to write (`claim`) before it writes and publishes
 * them (`head`) after; a reader copies the slots up to `head` and then keeps
 * only the indices the writer cannot have reached since (index >= claim -
 * capacity), as the sequence locks of loop.c do.
 */
#include <errno.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/err.h"
#include "rmd/incident.h"

struct orec {
	_Alignas(64) atomic_uint_fast64_t claim; /* last index being written + 1 */
	_Alignas(64) atomic_uint_fast64_t head;	 /* records written */
	size_t mask;				 /* slots - 1 */
	size_t size;				 /* bytes per record */
	unsigned char *buf;
};

struct rmd_incident_ring {
	unsigned n_buses;
	struct orec frames[RMD_MAX_BUSES];
	struct orec states;
	struct orec commands;
	struct orec events;
	size_t bytes;
};

/* The smallest power of two >= n (n >= 1).  Pure. */
static size_t pow2_ceil(double n)
{
	size_t p = 1;

	while ((double)p < n && p < ((size_t)1 << 40))
		p <<= 1;
	return p;
}

/* Non-rt. */
static int orec_init(struct orec *o, double slots, size_t size, size_t *bytes)
{
	size_t n = pow2_ceil(slots < 16 ? 16 : slots);

	o->buf = calloc(n, size);
	if (!o->buf)
		return -ENOMEM;
	/* touch every page now: the rt thread must not fault them in */
	memset(o->buf, 0, n * size);
	o->mask = n - 1;
	o->size = size;
	atomic_init(&o->claim, 0);
	atomic_init(&o->head, 0);
	*bytes += n * size;
	return 0;
}

/*
 * The loop's writes, in batches: claim the next n records of o (announce
 * the last index written + 1) before writing them, publish them after.
 * Between the two the loop writes each record's fields straight into its
 * slot (orec_at()), a fixed-size copy the compiler inlines.  rt-safe.
 */
static inline uint_fast64_t orec_claim(struct orec *o, size_t n)
{
	uint_fast64_t h = atomic_load_explicit(&o->head, memory_order_relaxed);

	atomic_store_explicit(&o->claim, h + n, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
	return h;
}

static inline void orec_publish(struct orec *o, uint_fast64_t end)
{
	atomic_store_explicit(&o->head, end, memory_order_release);
}

/* Slot of record i of o, a ring of records of type T.  rt-safe. */
#define orec_at(o, T, i) ((T *)(void *)(o)->buf + ((i) & (o)->mask))

/*
 * Copy the records of o whose first field (int64_t t_ns) lies in
 * [from_ns, to_ns] into out (o->mask + 1 records at most), oldest first;
 * the count.  Non-rt.
 */
static size_t orec_read(const struct orec *o, int64_t from_ns, int64_t to_ns, void *out)
{
	size_t cap = o->mask + 1, n = 0;
	uint_fast64_t head = atomic_load_explicit(&o->head, memory_order_acquire);
	uint_fast64_t first = head > cap ? head - cap : 0, claim;
	unsigned char *dst = out;

	for (uint_fast64_t i = first; i < head; i++)
		memcpy(dst + (i - first) * o->size, o->buf + (i & o->mask) * o->size, o->size);
	atomic_thread_fence(memory_order_acquire);
	claim = atomic_load_explicit(&o->claim, memory_order_relaxed);
	/* the writer may have overwritten the slots of indices < claim - cap */
	for (uint_fast64_t i = first; i < head; i++) {
		const unsigned char *rec = dst + (i - first) * o->size;
		int64_t t;

		if (claim > cap && i < claim - cap)
			continue;
		memcpy(&t, rec, sizeof(t));
		if (t < from_ns || t > to_ns)
			continue;
		if (dst + n * o->size != rec)
			memmove(dst + n * o->size, rec, o->size);
		n++;
	}
	return n;
}

/* Non-rt. */
struct rmd_incident_ring *rmd_incident_ring_new(const struct rmd_config *cfg,
						const struct rmd_plan *plan, int64_t window_ns,
						char *err, size_t errlen)
{
	struct rmd_incident_ring *r;
	double cycles, motors;

	if (!cfg || !plan || window_ns <= 0 || plan->n_buses > RMD_MAX_BUSES) {
		rmd_errf(err, errlen, -EINVAL, "incidents: no configuration, plan or window");
		return NULL;
	}
	r = calloc(1, sizeof(*r));
	if (!r) {
		rmd_errf(err, errlen, -ENOMEM, "incidents: out of memory");
		return NULL;
	}
	cycles = ceil((double)(window_ns + RMD_INCIDENT_SLACK_NS) / 1e9 * (double)plan->rate_hz);
	motors = cfg->n_motors ? (double)cfg->n_motors : 1.0;
	r->n_buses = plan->n_buses;
	for (unsigned b = 0; b < r->n_buses; b++) {
		/*
		 * The busiest cycle's frames (requests and replies), plus
		 * one-shots and frames nobody asked for (0x9A reports, echoes).
		 */
		double per_cycle = (double)plan->bus[b].max_frames + 8.0;

		if (orec_init(&r->frames[b], per_cycle * cycles, sizeof(struct rmd_incident_frame),
			      &r->bytes) < 0)
			goto err_free;
	}
	/* one state per motor a cycle; at most one command a cycle */
	if (orec_init(&r->states, motors * cycles, sizeof(struct rmd_incident_state), &r->bytes) <
		    0 ||
	    orec_init(&r->commands, motors * cycles, sizeof(struct rmd_incident_command),
		      &r->bytes) < 0 ||
	    orec_init(&r->events, RMD_INCIDENT_EVENTS, sizeof(struct rmd_event), &r->bytes) < 0)
		goto err_free;
	return r;

err_free:
	rmd_incident_ring_free(r);
	rmd_errf(err, errlen, -ENOMEM, "incidents: out of memory for a %.1f s window",
		 (double)window_ns / 1e9);
	return NULL;
}

/* Non-rt. */
void rmd_incident_ring_free(struct rmd_incident_ring *r)
{
	if (!r)
		return;
	for (unsigned b = 0; b < RMD_MAX_BUSES; b++)
		free(r->frames[b].buf);
	free(r->states.buf);
	free(r->commands.buf);
	free(r->events.buf);
	free(r);
}

size_t rmd_incident_ring_bytes(const struct rmd_incident_ring *r)
{
	return r ? r->bytes : 0;
}

/* rt-safe. */
static inline void frame_rec(struct rmd_incident_frame *rec, enum rmd_incident_dir dir,
			     const struct rmd_frame *f, int64_t t_ns)
{
	rec->t_ns = t_ns;
	rec->dir = (uint8_t)dir;
	rec->f = *f;
}

/*
 * Claim n records of bus's frame ring: the ring, its first index in *h;
 * NULL for a bus the ring does not have, or no record.  rt-safe.
 */
static inline struct orec *frames_claim(struct rmd_incident_ring *r, unsigned bus, unsigned n,
					uint_fast64_t *h)
{
	if (bus >= r->n_buses || !n)
		return NULL;
	*h = orec_claim(&r->frames[bus], n);
	return &r->frames[bus];
}

/* rt-safe. */
void rmd_incident_tx(struct rmd_incident_ring *r, unsigned bus, const struct rmd_frame *f,
		     unsigned n, int64_t t_ns)
{
	uint_fast64_t h;
	struct orec *o = frames_claim(r, bus, n, &h);

	if (!o)
		return;
	for (unsigned k = 0; k < n; k++)
		frame_rec(orec_at(o, struct rmd_incident_frame, h + k), RMD_INCIDENT_TX, &f[k],
			  t_ns);
	orec_publish(o, h + n);
}

/* rt-safe. */
void rmd_incident_rx(struct rmd_incident_ring *r, unsigned bus, const struct rmd_bus_rx *rx,
		     unsigned n)
{
	uint_fast64_t h;
	struct orec *o = frames_claim(r, bus, n, &h);

	if (!o)
		return;
	for (unsigned k = 0; k < n; k++)
		frame_rec(orec_at(o, struct rmd_incident_frame, h + k), RMD_INCIDENT_RX, &rx[k].f,
			  rx[k].t_ns);
	orec_publish(o, h + n);
}

/* rt-safe. */
void rmd_incident_snapshot(struct rmd_incident_ring *r, const struct rmd_snapshot *s)
{
	struct orec *o = &r->states;
	unsigned n = s->n < RMD_MAX_MOTORS ? s->n : RMD_MAX_MOTORS;
	uint_fast64_t h = orec_claim(o, n);

	for (unsigned i = 0; i < n; i++) {
		const struct rmd_motor_state *m = &s->m[i];
		struct rmd_incident_state *rec = orec_at(o, struct rmd_incident_state, h + i);

		rec->t_ns = s->t_ns;
		rec->cycle = s->cycle;
		rec->motor = (uint8_t)i;
		rec->lifecycle = m->lifecycle;
		rec->mode = m->mode;
		rec->error_code = m->error_code;
		rec->reply_age_cycles = m->reply_age_cycles;
		rec->pos_rad = m->pos_rad;
		rec->vel_rad_s = m->vel_rad_s;
		rec->torque_nm = m->torque_nm;
		rec->current_a = m->current_a;
		rec->temp_c = m->temp_c;
		rec->voltage_v = m->voltage_v;
	}
	orec_publish(o, h + n);
}

/* rt-safe. */
void rmd_incident_command(struct rmd_incident_ring *r, const struct rmd_command *c, int64_t t_ns)
{
	struct orec *o = &r->commands;
	uint_fast64_t h = orec_claim(o, (size_t)__builtin_popcount(c->present)), i = h;

	for (uint32_t p = c->present; p; p &= p - 1, i++) {
		unsigned k = (unsigned)__builtin_ctz(p);
		struct rmd_incident_command *rec = orec_at(o, struct rmd_incident_command, i);

		rec->t_ns = t_ns;
		rec->rx_ns = c->rx_ns;
		rec->seq = c->seq;
		rec->motor = (uint8_t)k;
		rec->sp = c->m[k];
	}
	orec_publish(o, i);
}

/* rt-safe. */
void rmd_incident_event(struct rmd_incident_ring *r, const struct rmd_event *e)
{
	struct orec *o = &r->events;
	uint_fast64_t h = orec_claim(o, 1);

	*orec_at(o, struct rmd_event, h) = *e;
	orec_publish(o, h + 1);
}

/* Non-rt. */
struct rmd_incident_window *rmd_incident_window_new(const struct rmd_incident_ring *r)
{
	struct rmd_incident_window *w = calloc(1, sizeof(*w));

	if (!w)
		return NULL;
	w->n_buses = r->n_buses;
	for (unsigned b = 0; b < r->n_buses; b++) {
		w->cap_frames[b] = r->frames[b].mask + 1;
		w->frames[b] = calloc(w->cap_frames[b], sizeof(*w->frames[b]));
		if (!w->frames[b])
			goto err_free;
	}
	w->cap_states = r->states.mask + 1;
	w->cap_commands = r->commands.mask + 1;
	w->cap_events = r->events.mask + 1;
	w->states = calloc(w->cap_states, sizeof(*w->states));
	w->commands = calloc(w->cap_commands, sizeof(*w->commands));
	w->events = calloc(w->cap_events, sizeof(*w->events));
	if (!w->states || !w->commands || !w->events)
		goto err_free;
	return w;

err_free:
	rmd_incident_window_free(w);
	return NULL;
}

/* Non-rt. */
void rmd_incident_window_free(struct rmd_incident_window *w)
{
	if (!w)
		return;
	for (unsigned b = 0; b < RMD_MAX_BUSES; b++)
		free(w->frames[b]);
	free(w->states);
	free(w->commands);
	free(w->events);
	free(w);
}

/* Non-rt. */
void rmd_incident_read(const struct rmd_incident_ring *r, int64_t from_ns, int64_t to_ns,
		       struct rmd_incident_window *w)
{
	_Static_assert(offsetof(struct rmd_incident_frame, t_ns) == 0 &&
			       offsetof(struct rmd_incident_state, t_ns) == 0 &&
			       offsetof(struct rmd_incident_command, t_ns) == 0 &&
			       offsetof(struct rmd_event, t_ns) == 0,
		       "orec_read() reads each record's time first");
	for (unsigned b = 0; b < r->n_buses && b < w->n_buses; b++)
		w->n_frames[b] = orec_read(&r->frames[b], from_ns, to_ns, w->frames[b]);
	w->n_states = orec_read(&r->states, from_ns, to_ns, w->states);
	w->n_commands = orec_read(&r->commands, from_ns, to_ns, w->commands);
	w->n_events = orec_read(&r->events, from_ns, to_ns, w->events);
}
