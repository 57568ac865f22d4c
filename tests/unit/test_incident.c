// SPDX-License-Identifier: MIT
/*
 * The incident recorder's ring (rmd/incident.h): sized from the plan and
 * the window, oldest records overwritten, a window read from a time on,
 * and no torn or out-of-order record while a real second thread writes
 * as fast as it can (the sequence check of the reader).  That the loop
 * fills it without allocating is tests/unit/test_loop_alloc.c.
 */
#include <errno.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/incident.h"
#include "rmd/plan.h"
#include "rmd/sim_setup.h"
#include "rmd/time.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)

static struct rmd_config cfg;
static struct rmd_sim_setup sim;
static struct rmd_plan plan;

static int setup(void **state)
{
	char err[512];

	(void)state;
	if (rmd_config_sim_default(&cfg, &sim, 3) || rmd_plan_build(&cfg, &plan, err, sizeof(err)))
		return -1;
	return 0;
}

/* A frame whose bytes all derive from k: a torn copy shows. */
static struct rmd_frame frame_of(uint64_t k)
{
	struct rmd_frame f = { .can_id = 0x141, .len = 8 };

	for (unsigned j = 0; j < 8; j++)
		f.data[j] = (uint8_t)(k >> (8 * j));
	return f;
}

static uint64_t index_of(const struct rmd_frame *f)
{
	uint64_t k = 0;

	for (unsigned j = 0; j < 8; j++)
		k |= (uint64_t)f->data[j] << (8 * j);
	return k;
}

static void test_sized_from_the_plan_and_window(void **state)
{
	struct rmd_incident_ring *r1, *r4;
	struct rmd_incident_window *w;
	char err[256];

	(void)state;
	assert_null(rmd_incident_ring_new(&cfg, &plan, 0, err, sizeof(err)));
	r1 = rmd_incident_ring_new(&cfg, &plan, 1000 * MS, err, sizeof(err));
	r4 = rmd_incident_ring_new(&cfg, &plan, 4000 * MS, err, sizeof(err));
	assert_non_null(r1);
	assert_non_null(r4);
	assert_true(rmd_incident_ring_bytes(r4) > rmd_incident_ring_bytes(r1));
	w = rmd_incident_window_new(r1);
	assert_non_null(w);
	/* (1 s + slack) at 1 kHz: every motor's state each cycle, the busiest cycle's frames */
	assert_true(w->cap_states >= 2000u * cfg.n_motors);
	assert_true(w->cap_frames[0] >= 2000u * plan.bus[0].max_frames);
	assert_true(w->cap_commands >= 2000u * cfg.n_motors);
	rmd_incident_window_free(w);
	rmd_incident_ring_free(r1);
	rmd_incident_ring_free(r4);
	rmd_incident_ring_free(NULL);
}

/* A ring of a 100 ms window and a window to read it into; *cap: bus 0's frames it holds. */
static struct rmd_incident_ring *ring_100ms(struct rmd_incident_window **w, size_t *cap)
{
	struct rmd_incident_ring *r = rmd_incident_ring_new(&cfg, &plan, 100 * MS, NULL, 0);

	assert_non_null(r);
	*w = rmd_incident_window_new(r);
	assert_non_null(*w);
	*cap = (*w)->cap_frames[0];
	return r;
}

static void test_overwrites_and_reads_from_a_time(void **state)
{
	struct rmd_incident_window *w;
	size_t cap;
	struct rmd_incident_ring *r = ring_100ms(&w, &cap);
	struct rmd_snapshot s = { .n = 3 };
	struct rmd_command c = { .present = 0x5, .seq = 7 };
	struct rmd_event e = { .kind = RMD_EV_OVERRUN, .a = 12 };
	uint64_t total;

	(void)state;
	total = 3 * cap + 17;
	for (uint64_t k = 0; k < total; k++) {
		struct rmd_bus_rx rx = { .f = frame_of(k), .t_ns = (int64_t)k * 1000 };

		if (k % 2)
			rmd_incident_rx(r, 0, &rx, 1);
		else
			rmd_incident_tx(r, 0, &rx.f, 1, rx.t_ns);
	}
	s.t_ns = 5;
	s.cycle = 42;
	rmd_incident_snapshot(r, &s);
	rmd_incident_command(r, &c, 6);
	e.t_ns = 7;
	rmd_incident_event(r, &e);
	/* a frame on a bus the ring does not have is ignored */
	{
		struct rmd_frame f = frame_of(1);

		rmd_incident_tx(r, RMD_MAX_BUSES - 1, &f, 1, 1);
	}

	rmd_incident_read(r, 0, INT64_MAX, w);
	assert_int_equal(w->n_frames[0], cap);
	for (size_t k = 0; k < cap; k++) {
		uint64_t want = total - cap + k;

		assert_int_equal(index_of(&w->frames[0][k].f), want);
		assert_int_equal(w->frames[0][k].t_ns, (int64_t)want * 1000);
		assert_int_equal(w->frames[0][k].dir, want % 2 ? RMD_INCIDENT_RX : RMD_INCIDENT_TX);
	}
	assert_int_equal(w->n_frames[1], 0);
	assert_int_equal(w->n_states, 3);
	assert_int_equal(w->states[2].motor, 2);
	assert_int_equal(w->states[2].cycle, 42);
	assert_int_equal(w->n_commands, 2); /* motors 0 and 2 */
	assert_int_equal(w->commands[1].motor, 2);
	assert_int_equal(w->commands[1].seq, 7);
	assert_int_equal(w->n_events, 1);
	assert_int_equal(w->events[0].a, 12);

	/* from a time on: only the newer records */
	rmd_incident_read(r, (int64_t)(total - 10) * 1000, INT64_MAX, w);
	assert_int_equal(w->n_frames[0], 10);
	assert_int_equal(index_of(&w->frames[0][0].f), total - 10);
	assert_int_equal(w->n_states, 0);
	/* up to a time: what the loop wrote after it is the next window's */
	rmd_incident_read(r, (int64_t)(total - 10) * 1000, (int64_t)(total - 5) * 1000, w);
	assert_int_equal(w->n_frames[0], 6);
	assert_int_equal(index_of(&w->frames[0][5].f), total - 5);
	rmd_incident_read(r, 0, 6, w);
	assert_int_equal(w->n_states, 3);   /* at 5 */
	assert_int_equal(w->n_commands, 2); /* at 6 */
	assert_int_equal(w->n_events, 0);   /* at 7 */
	rmd_incident_window_free(w);
	rmd_incident_ring_free(r);
}

/*
 * issue 11: the loop writes a bus's frames in batches (rmd_incident_tx(),
 * rmd_incident_rx()); batches of uneven sizes, across the ring's wrap,
 * read back as the same records one at a time would: in order, each with
 * its direction and time (a frame taken at the batch's time, a received
 * one at its own).
 */
static void test_batches_read_as_single_records(void **state)
{
	struct rmd_incident_window *w;
	size_t cap;
	struct rmd_incident_ring *r = ring_100ms(&w, &cap);
	uint64_t k = 0;
	int64_t *t_of;
	uint8_t *dir_of;

	(void)state;
	assert_true(cap >= 16);
	/* each frame's expected time and direction */
	t_of = calloc(2 * cap + 16, sizeof(*t_of));
	dir_of = calloc(2 * cap + 16, sizeof(*dir_of));
	assert_true(t_of && dir_of);
	/* none for a bus the ring does not have, none for an empty batch */
	rmd_incident_tx(r, RMD_MAX_BUSES - 1, &(struct rmd_frame){ 0 }, 1, 1);
	rmd_incident_rx(r, 0, NULL, 0);
	for (unsigned b = 0; k < 2 * cap + 5; b++) {
		unsigned n = 1 + b % 7;
		struct rmd_frame tx[8];
		struct rmd_bus_rx rx[8];

		/* even batches taken at the time of their first frame, odd ones received */
		for (unsigned j = 0; j < n; j++, k++) {
			tx[j] = frame_of(k);
			rx[j] = (struct rmd_bus_rx){ .f = frame_of(k), .t_ns = (int64_t)k * 1000 };
			dir_of[k] = b % 2 ? RMD_INCIDENT_RX : RMD_INCIDENT_TX;
			t_of[k] = b % 2 ? (int64_t)k * 1000 : (int64_t)(k - j) * 1000;
		}
		if (b % 2)
			rmd_incident_rx(r, 0, rx, n);
		else
			rmd_incident_tx(r, 0, tx, n, (int64_t)(k - n) * 1000);
	}
	rmd_incident_read(r, 0, INT64_MAX, w);
	assert_int_equal(w->n_frames[0], cap);
	for (size_t j = 0; j < cap; j++) {
		const struct rmd_incident_frame *f = &w->frames[0][j];
		uint64_t want = k - cap + j;

		if (index_of(&f->f) != want || f->f.can_id != 0x141 || f->f.len != 8)
			fail_msg("record %zu: frame %llu, want %llu", j,
				 (unsigned long long)index_of(&f->f), (unsigned long long)want);
		if (f->dir != dir_of[want] || f->t_ns != t_of[want])
			fail_msg("record %zu (frame %llu): dir %u time %lld, want %u %lld", j,
				 (unsigned long long)want, f->dir, (long long)f->t_ns, dir_of[want],
				 (long long)t_of[want]);
	}
	free(t_of);
	free(dir_of);
	rmd_incident_window_free(w);
	rmd_incident_ring_free(r);
}

/* The "loop" of the torn-record test: writes frame k at time k until told to stop. */
static struct rmd_incident_ring *torn_ring;
static atomic_bool torn_stop;
static atomic_uint_fast64_t torn_written;

static void *torn_loop(void *arg)
{
	(void)arg;
	for (uint64_t k = 0; !atomic_load(&torn_stop); k++) {
		struct rmd_frame f = frame_of(k);

		rmd_incident_tx(torn_ring, 0, &f, 1, (int64_t)k);
		atomic_store_explicit(&torn_written, k + 1, memory_order_relaxed);
	}
	return NULL;
}

/* The loop writes while the writer thread reads: never a torn record, always in order. */
static void test_no_torn_record_while_the_loop_writes(void **state)
{
	struct rmd_incident_window *w;
	pthread_t t;
	unsigned reads = 0, wrapped = 0;
	size_t kept = 0;

	(void)state;
	torn_ring = rmd_incident_ring_new(&cfg, &plan, 10 * MS, NULL, 0);
	assert_non_null(torn_ring);
	w = rmd_incident_window_new(torn_ring);
	assert_non_null(w);
	atomic_init(&torn_stop, false);
	atomic_init(&torn_written, 0);
	assert_int_equal(pthread_create(&t, NULL, torn_loop, NULL), 0);
	/* until the ring wrapped under the reader 20 times (2 CPUs shared: a deadline, not a count) */
	for (int64_t end = rmd_now_ns() + 20 * RMD_NS_PER_S;
	     (reads < 2000 || wrapped < 20) && rmd_now_ns() < end; reads++) {
		rmd_incident_read(torn_ring, 0, INT64_MAX, w);
		for (size_t k = 0; k < w->n_frames[0]; k++) {
			const struct rmd_incident_frame *fr = &w->frames[0][k];

			/* every byte agrees with the time it was written with */
			if (index_of(&fr->f) != (uint64_t)fr->t_ns)
				fail_msg("read %u: record %zu torn: data %llu, time %lld", reads, k,
					 (unsigned long long)index_of(&fr->f), (long long)fr->t_ns);
			if (k && fr->t_ns != w->frames[0][k - 1].t_ns + 1)
				fail_msg("read %u: record %zu out of order", reads, k);
		}
		if (w->n_frames[0] && w->frames[0][0].t_ns > (int64_t)w->cap_frames[0])
			wrapped++;
		kept += w->n_frames[0];
	}
	atomic_store(&torn_stop, true);
	pthread_join(t, NULL);
	print_message("%u reads of a %zu-frame ring while %llu frames were written (%u after it "
		      "wrapped), %.0f frames kept a read\n",
		      reads, w->cap_frames[0], (unsigned long long)atomic_load(&torn_written),
		      wrapped, (double)kept / reads);
	assert_true(wrapped >= 20);
	rmd_incident_window_free(w);
	rmd_incident_ring_free(torn_ring);
}

SUITE_MAIN("incident", setup, NULL,
	   {
		   cmocka_unit_test(test_sized_from_the_plan_and_window),
		   cmocka_unit_test(test_overwrites_and_reads_from_a_time),
		   cmocka_unit_test(test_batches_read_as_single_records),
		   cmocka_unit_test(test_no_torn_record_while_the_loop_writes),
	   })
