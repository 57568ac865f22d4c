// SPDX-License-Identifier: MIT
/*
 * The lock-free hand-overs: order and refusal in the ring, newest-wins and
 * no torn values in the triple buffer, both with a real second thread.
 */
#include <errno.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/spsc.h"
#include "harness/suite.h"

struct rec {
	uint64_t seq;
	uint64_t check; /* ~seq: a torn copy shows as a mismatch */
};

static void test_ring_order_and_full(void **state)
{
	struct rec buf[8], r;
	struct rmd_ring ring;

	(void)state;
	assert_int_equal(rmd_ring_init(&ring, buf, 6, sizeof(r)), -EINVAL);
	assert_int_equal(rmd_ring_init(&ring, buf, 8, sizeof(r)), 0);
	assert_false(rmd_ring_pop(&ring, &r));
	for (uint64_t i = 0; i < 8; i++) {
		r = (struct rec){ i, ~i };
		assert_true(rmd_ring_push(&ring, &r));
	}
	r = (struct rec){ 99, ~UINT64_C(99) };
	assert_false(rmd_ring_push(&ring, &r));
	assert_int_equal(rmd_ring_dropped(&ring), 1);
	for (uint64_t i = 0; i < 8; i++) {
		assert_true(rmd_ring_pop(&ring, &r));
		assert_int_equal(r.seq, i);
	}
	assert_false(rmd_ring_pop(&ring, &r));
}

#define N_THREADED 200000

static void *ring_producer(void *arg)
{
	struct rmd_ring *ring = arg;

	for (uint64_t i = 0; i < N_THREADED;) {
		struct rec r = { i, ~i };

		if (rmd_ring_push(ring, &r))
			i++;
	}
	return NULL;
}

static void test_ring_threads(void **state)
{
	static struct rec buf[64];
	struct rmd_ring ring;
	pthread_t t;
	uint64_t expect = 0;

	(void)state;
	assert_int_equal(rmd_ring_init(&ring, buf, 64, sizeof(struct rec)), 0);
	assert_int_equal(pthread_create(&t, NULL, ring_producer, &ring), 0);
	while (expect < N_THREADED) {
		struct rec r;

		if (!rmd_ring_pop(&ring, &r))
			continue;
		if (r.seq != expect || r.check != ~expect)
			fail_msg("ring: got %llu (check %llx), expected %llu",
				 (unsigned long long)r.seq, (unsigned long long)r.check,
				 (unsigned long long)expect);
		expect++;
	}
	assert_int_equal(pthread_join(t, NULL), 0);
}

static void test_latest_newest_wins(void **state)
{
	struct rec buf[3] = { 0 };
	struct rmd_latest l;
	const void *p;

	(void)state;
	rmd_latest_init(&l, buf, sizeof(struct rec));
	assert_false(rmd_latest_get(&l, &p));
	for (uint64_t i = 1; i <= 3; i++)
		rmd_latest_put(&l, &(struct rec){ i, ~i });
	assert_true(rmd_latest_get(&l, &p));
	assert_int_equal(((const struct rec *)p)->seq, 3);
	assert_false(rmd_latest_get(&l, &p));
	assert_int_equal(((const struct rec *)p)->seq, 3);
	rmd_latest_put(&l, &(struct rec){ 4, ~UINT64_C(4) });
	assert_true(rmd_latest_get(&l, &p));
	assert_int_equal(((const struct rec *)p)->seq, 4);
}

static void *latest_writer(void *arg)
{
	struct rmd_latest *l = arg;

	for (uint64_t i = 1; i <= N_THREADED; i++) {
		struct rec *slot = rmd_latest_write_slot(l);

		/* Written field by field: a reader sharing the slot would see a mix. */
		slot->seq = i;
		slot->check = ~i;
		rmd_latest_publish(l);
	}
	return NULL;
}

static void test_latest_threads(void **state)
{
	struct rec buf[3] = { 0 };
	struct rmd_latest l;
	pthread_t t;
	uint64_t last = 0, fresh = 0;

	(void)state;
	rmd_latest_init(&l, buf, sizeof(struct rec));
	assert_int_equal(pthread_create(&t, NULL, latest_writer, &l), 0);
	while (last < N_THREADED) {
		const struct rec *r;

		if (!rmd_latest_get(&l, (const void **)&r))
			continue;
		fresh++;
		if (r->check != ~r->seq)
			fail_msg("latest: torn value seq %llu check %llx",
				 (unsigned long long)r->seq, (unsigned long long)r->check);
		if (r->seq <= last)
			fail_msg("latest: went back from %llu to %llu", (unsigned long long)last,
				 (unsigned long long)r->seq);
		last = r->seq;
	}
	assert_int_equal(pthread_join(t, NULL), 0);
	assert_true(fresh >= 1);
}

SUITE_MAIN("spsc", NULL, NULL,
	   {
		   cmocka_unit_test(test_ring_order_and_full),
		   cmocka_unit_test(test_ring_threads),
		   cmocka_unit_test(test_latest_newest_wins),
		   cmocka_unit_test(test_latest_threads),
	   })
