// SPDX-License-Identifier: MIT
/*
 * The incident recorder's ring (rmd/incident.h).  The loop's calls are
 * rt-safe: a memcpy into a slot allocated and touched before the loop
 * started, and two atomic stores.  Reading, allocation and freeing are
 * non-rt.
 *
 * Each ring overwrites its oldest record.  The writer announces the index
 * it is about to write (`claim`) before it writes and publishes it
 * (`head`) after; a reader copies the slots up to `head` and then keeps
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
	_Alignas(64) atomic_uint_fast64_t claim; /* index being written + 1 */
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

/* rt-safe. */
static void orec_push(struct orec *o, const void *rec)
{
	uint_fast64_t h = atomic_load_explicit(&o->head, memory_order_relaxed);

	atomic_store_explicit(&o->claim, h + 1, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
	memcpy(o->buf + (h & o->mask) * o->size, rec, o->size);
	atomic_store_explicit(&o->head, h + 1, memory_order_release);
}

/*
 * Copy the records of o whose first field (int64_t t_ns) is >= from_ns
 * into out (o->mask + 1 records at most), oldest first; the count.
 * Non-rt.
 */
static size_t orec_read(const struct orec *o, int64_t from_ns, void *out)
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
		if (t < from_ns)
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
void rmd_incident_frame(struct rmd_incident_ring *r, unsigned bus, enum rmd_incident_dir dir,
			const struct rmd_frame *f, int64_t t_ns)
{
	struct rmd_incident_frame rec = { .t_ns = t_ns, .dir = (uint8_t)dir, .f = *f };

	if (bus < r->n_buses)
		orec_push(&r->frames[bus], &rec);
}

/* rt-safe. */
void rmd_incident_snapshot(struct rmd_incident_ring *r, const struct rmd_snapshot *s)
{
	for (unsigned i = 0; i < s->n && i < RMD_MAX_MOTORS; i++) {
		const struct rmd_motor_state *m = &s->m[i];
		struct rmd_incident_state rec = {
			.t_ns = s->t_ns,
			.cycle = s->cycle,
			.motor = (uint8_t)i,
			.lifecycle = m->lifecycle,
			.mode = m->mode,
			.error_code = m->error_code,
			.reply_age_cycles = m->reply_age_cycles,
			.pos_rad = m->pos_rad,
			.vel_rad_s = m->vel_rad_s,
			.torque_nm = m->torque_nm,
			.current_a = m->current_a,
			.temp_c = m->temp_c,
			.voltage_v = m->voltage_v,
		};

		orec_push(&r->states, &rec);
	}
}

/* rt-safe. */
void rmd_incident_command(struct rmd_incident_ring *r, const struct rmd_command *c, int64_t t_ns)
{
	for (uint32_t p = c->present; p; p &= p - 1) {
		unsigned i = (unsigned)__builtin_ctz(p);
		struct rmd_incident_command rec = {
			.t_ns = t_ns,
			.rx_ns = c->rx_ns,
			.seq = c->seq,
			.motor = (uint8_t)i,
			.sp = c->m[i],
		};

		orec_push(&r->commands, &rec);
	}
}

/* rt-safe. */
void rmd_incident_event(struct rmd_incident_ring *r, const struct rmd_event *e)
{
	orec_push(&r->events, e);
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
void rmd_incident_read(const struct rmd_incident_ring *r, int64_t from_ns,
		       struct rmd_incident_window *w)
{
	_Static_assert(offsetof(struct rmd_incident_frame, t_ns) == 0 &&
			       offsetof(struct rmd_incident_state, t_ns) == 0 &&
			       offsetof(struct rmd_incident_command, t_ns) == 0 &&
			       offsetof(struct rmd_event, t_ns) == 0,
		       "orec_read() reads each record's time first");
	for (unsigned b = 0; b < r->n_buses && b < w->n_buses; b++)
		w->n_frames[b] = orec_read(&r->frames[b], from_ns, w->frames[b]);
	w->n_states = orec_read(&r->states, from_ns, w->states);
	w->n_commands = orec_read(&r->commands, from_ns, w->commands);
	w->n_events = orec_read(&r->events, from_ns, w->events);
}
