// SPDX-License-Identifier: MIT
/*
 * sim_wire tests: wire time of a cycle against can_timing, arbitration
 * order, an overloaded cycle running late, every fault kind at its rate or
 * in its window, queues and statistics.  Every run is seeded; the seed is
 * printed on failure (RMD_TEST_SEED overrides it).
 *
 * Every frame that crosses the wire goes through a tap, and each test's
 * trace is checked for the two rules of the wire: the wire never idles
 * while a frame is ready, and no frame starts while a lower identifier was
 * ready and waiting.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <sys/stat.h>

#include <cmocka.h>

#include "harness/suite.h"
#include "rmd/can_timing.h"
#include "rmd/codec.h"
#include "rmd/bus_sim.h"
#include "rmd/candump.h"
#include "rmd/sim_wire.h"

#define SEED_DEFAULT 0x51b05eedu
#define US INT64_C(1000)
#define MS INT64_C(1000000)
#define BITRATE 1000000u

static struct rmd_sim_wire bus; /* ~48 KiB: not on the stack */
static uint64_t seed;

/* ---- trace of the wire --------------------------------------------------- */

#define TRACE_MAX 40000

struct trace_entry {
	struct rmd_sim_pending p;
	int64_t start_ns, eof_ns;
};

static struct trace_entry trace[TRACE_MAX];
static unsigned trace_n;

static void tap(void *ctx, const struct rmd_sim_pending *p, int64_t start_ns, int64_t eof_ns)
{
	(void)ctx;
	if (trace_n < TRACE_MAX)
		trace[trace_n++] = (struct trace_entry){ *p, start_ns, eof_ns };
}

static int64_t free_of(const struct trace_entry *e)
{
	return e->eof_ns + rmd_can_wire_ns(RMD_CAN_IFS_BITS, BITRATE);
}

/*
 * The rules of the wire over the whole trace.  work_conserving: frames
 * back to back whenever one was ready (false where bus-off or a lost motor
 * aborted a frame); host_fifo: host frames keep their order.
 */
static void check_trace(bool work_conserving, bool host_fifo)
{
	for (unsigned b = 1; b < trace_n; b++) {
		const struct trace_entry *eb = &trace[b], *ea = &trace[b - 1];
		uint32_t idb = eb->p.f.can_id & 0x7FF;

		if (eb->start_ns < free_of(ea))
			fail_msg("seed %#llx: frame %u (%03x) starts %lld before the wire is free",
				 (unsigned long long)seed, b, idb,
				 (long long)(free_of(ea) - eb->start_ns));
		if (work_conserving && eb->p.ready_ns <= free_of(ea) && eb->start_ns != free_of(ea))
			fail_msg("seed %#llx: frame %u (%03x) was ready but the wire idled",
				 (unsigned long long)seed, b, idb);
		/* Every earlier frame that started while b waited had a lower id. */
		for (unsigned a = b; a-- > 0 && trace[a].start_ns >= eb->p.ready_ns;) {
			uint32_t ida = trace[a].p.f.can_id & 0x7FF;

			if (host_fifo && trace[a].p.src == RMD_SIM_SRC_HOST &&
			    eb->p.src == RMD_SIM_SRC_HOST)
				continue;
			if (ida > idb)
				fail_msg(
					"seed %#llx: %03x (frame %u) won over waiting %03x (frame %u)",
					(unsigned long long)seed, ida, a, idb, b);
		}
	}
}

/* ---- received frames ---------------------------------------------------- */

#define LOG_MAX 40000

struct rx_entry {
	struct rmd_frame f;
	int64_t t_ns;
};

static struct rx_entry rx_log[LOG_MAX];
static unsigned rx_n;

static void drain(void)
{
	struct rmd_frame f[64];
	int64_t t[64];
	int n;

	while ((n = rmd_sim_wire_recv(&bus, f, 64, t)) > 0)
		for (int i = 0; i < n && rx_n < LOG_MAX; i++)
			rx_log[rx_n++] = (struct rx_entry){ f[i], t[i] };
}

static unsigned count_rx(uint32_t can_id, int64_t from_ns, int64_t to_ns)
{
	unsigned n = 0;

	for (unsigned i = 0; i < rx_n; i++)
		if (rx_log[i].f.can_id == can_id && rx_log[i].t_ns >= from_ns &&
		    rx_log[i].t_ns < to_ns)
			n++;
	return n;
}

/* ---- set-up ------------------------------------------------------------- */

static int setup(void **state)
{
	const char *s = getenv("RMD_TEST_SEED");

	(void)state;
	seed = s ? strtoull(s, NULL, 0) : SEED_DEFAULT;
	assert_int_equal(rmd_sim_wire_init(&bus, BITRATE, seed, 0), 0);
	rmd_sim_wire_set_tap(&bus, tap, NULL);
	trace_n = 0;
	rx_n = 0;
	return 0;
}

static int teardown(void **state)
{
	(void)state;
	rmd_sim_wire_fini(&bus);
	return 0;
}

/* V3 motors 1..n with the default turnaround (0.5 ms +- 0.1 ms). */
static void add_motors(unsigned n)
{
	for (unsigned id = 1; id <= n; id++) {
		struct rmd_sim_motor_params p;

		rmd_sim_motor_params_default(&p, (uint8_t)id, RMD_PROTO_V3);
		assert_int_equal(rmd_sim_wire_add_motor(&bus, &p, 0), (int)id - 1);
	}
}

/* A V3 single-motor request with no arguments (0x9A, 0x9C, ...). */
static struct rmd_frame request(uint8_t id, uint8_t cmd)
{
	struct rmd_frame f = { .can_id = RMD_CAN_REQ_BASE + id, .len = RMD_FRAME_LEN };

	f.data[0] = cmd;
	return f;
}

/*
 * Every `period` from t0, `cycles` times: one `cmd` request to each of
 * motors 1..n_ids, then everything that arrived goes to rx_log; in the
 * end the bus runs on `tail` ns.  Returns the requests the bus refused.
 */
static unsigned run_cycles(unsigned n_ids, uint8_t cmd, int64_t t0, int64_t period, unsigned cycles,
			   int64_t tail)
{
	unsigned refused = 0;

	for (unsigned k = 0; k < cycles; k++) {
		struct rmd_frame f[RMD_MAX_MOTORS];
		int r;

		for (unsigned i = 0; i < n_ids; i++)
			f[i] = request((uint8_t)(i + 1), cmd);
		r = rmd_sim_wire_send(&bus, t0 + (int64_t)k * period, f, n_ids);
		refused += r < 0 ? n_ids : n_ids - (unsigned)r;
		drain();
	}
	rmd_sim_wire_advance(&bus, t0 + (int64_t)cycles * period + tail);
	drain();
	return refused;
}

/* |x - n p| <= 4 sigma of a binomial(n, p). */
static void assert_binomial(const char *what, uint64_t x, unsigned n, double p)
{
	double mean = n * p, tol = 4.0 * sqrt(n * p * (1.0 - p));

	print_message("%s: %llu of %u, expected %.0f +- %.0f (4 sigma)\n", what,
		      (unsigned long long)x, n, mean, tol);
	if (fabs((double)x - mean) > tol)
		fail_msg("seed %#llx: %s: %llu of %u, expected %.1f +- %.1f",
			 (unsigned long long)seed, what, (unsigned long long)x, n, mean, tol);
}

/* ---- (a) acceptance: wire time of one cycle ------------------------------ */

/*
 * 8 request + reply pairs of 8-byte frames at 1 Mbit/s: 16 frames of
 * 111..135 bits, so 1.776..2.160 ms of wire time, and exactly the sum of
 * rmd_can_frame_bits() of those frames.
 */
static void test_acceptance_8_pairs(void **state)
{
	const int64_t t0 = 1 * MS;
	struct rmd_frame req[8], rep[16];
	int64_t t[16], last = 0;
	uint64_t bits = 0;
	int n;

	(void)state;
	add_motors(8);
	for (unsigned i = 0; i < 8; i++)
		req[i] = request((uint8_t)(i + 1), 0x9C);
	assert_int_equal(rmd_sim_wire_send(&bus, t0, req, 8), 8);
	rmd_sim_wire_advance(&bus, t0 + 10 * MS);
	n = rmd_sim_wire_recv(&bus, rep, 16, t);
	assert_int_equal(n, 8);

	for (unsigned i = 0; i < 8; i++)
		bits += rmd_can_frame_bits(&req[i]);
	for (int i = 0; i < n; i++) {
		unsigned seen = 0;

		assert_int_equal(rep[i].len, 8);
		assert_int_equal(rep[i].data[0], 0x9C);
		for (int j = 0; j < n; j++)
			seen += rep[j].can_id == RMD_CAN_V3_REPLY_BASE + (unsigned)i + 1;
		assert_int_equal(seen, 1);
		bits += rmd_can_frame_bits(&rep[i]);
		last = t[i] > last ? t[i] : last;
	}
	assert_int_equal(bus.stats.frames_host, 8);
	assert_int_equal(bus.stats.frames_motor, 8);
	assert_int_equal(bus.stats.bits, bits);
	assert_int_equal(bus.stats.busy_ns, (int64_t)bits * 1000);
	assert_in_range(bus.stats.busy_ns, 1776 * US, 2160 * US);
	/*
	 * The last reply ends after all 16 frames' wire time (but its own
	 * interframe space), and no sooner than a turnaround after the last
	 * request.
	 */
	assert_true(last - t0 + rmd_can_wire_ns(RMD_CAN_IFS_BITS, BITRATE) >= bus.stats.busy_ns);
	assert_true(last - t0 >= 8 * 111 * US + 400 * US + 111 * US);
	print_message("8 pairs: %llu bits, wire %.3f ms (bounds 1.776..2.160), "
		      "last reply %.3f ms after the first request\n",
		      (unsigned long long)bits, (double)bus.stats.busy_ns / MS,
		      (double)(last - t0) / MS);
	assert_int_equal(bus.stats.errors, 0);
	check_trace(true, false);

	/* One pair alone: the turnaround shows, 0.5 +- 0.1 ms. */
	trace_n = 0;
	assert_int_equal(rmd_sim_wire_send(&bus, 20 * MS, req, 1), 1);
	rmd_sim_wire_advance(&bus, 30 * MS);
	assert_int_equal(rmd_sim_wire_recv(&bus, rep, 16, t), 1);
	assert_int_equal(trace_n, 2);
	assert_in_range(trace[1].start_ns - trace[0].eof_ns, 400 * US, 600 * US);
	print_message("1 pair: wire %.3f ms, turnaround %.3f ms, reply end %.3f ms after the "
		      "request\n",
		      (double)(free_of(&trace[0]) - trace[0].start_ns + free_of(&trace[1]) -
			       trace[1].start_ns) /
			      MS,
		      (double)(trace[1].start_ns - trace[0].eof_ns) / MS,
		      (double)(t[0] - 20 * MS) / MS);
}

/* ---- (b) arbitration ------------------------------------------------------ */

/* Frames queued together go out lowest identifier first. */
static void test_arbitration_lowest_id_first(void **state)
{
	static const uint8_t order[8] = { 8, 3, 5, 1, 7, 2, 6, 4 };
	struct rmd_frame f[8];

	(void)state;
	add_motors(8);
	for (unsigned i = 0; i < 8; i++)
		f[i] = request(order[i], 0x9C);
	assert_int_equal(rmd_sim_wire_send(&bus, 1 * MS, f, 8), 8);
	rmd_sim_wire_advance(&bus, 20 * MS);
	assert_int_equal(trace_n, 16);
	for (unsigned i = 0; i < 8; i++) {
		assert_int_equal(trace[i].p.f.can_id, RMD_CAN_REQ_BASE + i + 1);
		assert_int_equal(trace[i].p.src, RMD_SIM_SRC_HOST);
	}
	check_trace(true, false);
}

/*
 * Replies (0x24x) become ready while the host still has low-priority
 * frames (0x7F0) queued: they overtake them.  With RMD_SIM_WIRE_HOST_FIFO
 * the host's own frames leave in the order sent.
 */
static void test_arbitration_replies_overtake(void **state)
{
	struct rmd_frame f[12];
	unsigned last_reply = 0, first_7f0_after = 0;

	(void)state;
	add_motors(4);
	for (unsigned i = 0; i < 4; i++)
		f[i] = request((uint8_t)(i + 1), 0x9C);
	for (unsigned i = 4; i < 12; i++)
		f[i] = (struct rmd_frame){ .can_id = 0x7F0, .len = 8, .data = { (uint8_t)i } };
	assert_int_equal(rmd_sim_wire_send(&bus, 1 * MS, f, 12), 12);
	rmd_sim_wire_advance(&bus, 20 * MS);
	assert_int_equal(trace_n, 16);
	for (unsigned i = 0; i < trace_n; i++)
		if ((trace[i].p.f.can_id & 0x700) == 0x200)
			last_reply = i;
	for (unsigned i = 0; i < last_reply; i++)
		first_7f0_after += trace[i].p.f.can_id == 0x7F0;
	/* Some 0x7F0 went before the replies were ready, not all of them. */
	assert_in_range(first_7f0_after, 1, 7);
	check_trace(true, false);

	/* FIFO host queue: requests sent in reverse order keep that order. */
	assert_int_equal(rmd_sim_wire_init(&bus, BITRATE, seed, RMD_SIM_WIRE_HOST_FIFO), 0);
	rmd_sim_wire_set_tap(&bus, tap, NULL);
	trace_n = 0;
	add_motors(4);
	for (unsigned i = 0; i < 4; i++)
		f[i] = request((uint8_t)(4 - i), 0x9C);
	assert_int_equal(rmd_sim_wire_send(&bus, 1 * MS, f, 4), 4);
	rmd_sim_wire_advance(&bus, 20 * MS);
	for (unsigned i = 0; i < 4; i++)
		assert_int_equal(trace[i].p.f.can_id, RMD_CAN_REQ_BASE + 4 - i);
	check_trace(true, true);
}

/* ---- (c) overload ----------------------------------------------------------- */

/*
 * One request per motor per 1 ms cycle from t0; reply k of a motor answers
 * its request k (its replies share an identifier, so they keep their
 * order).  reply_lat[id][k]: reply end - start of cycle k.
 */
#define MAX_CYCLES 64

static int64_t reply_lat[RMD_MAX_MOTORS + 1][MAX_CYCLES];

static void latencies(unsigned motors, int64_t t0, unsigned cycles)
{
	unsigned seen[RMD_MAX_MOTORS + 1] = { 0 };

	for (unsigned i = 0; i < rx_n; i++) {
		unsigned id = rx_log[i].f.can_id - RMD_CAN_V3_REPLY_BASE;
		unsigned k;

		assert_in_range(id, 1, motors);
		k = seen[id]++;
		assert_true(k < cycles);
		reply_lat[id][k] = rx_log[i].t_ns - (t0 + (int64_t)k * MS);
	}
	for (unsigned id = 1; id <= motors; id++)
		assert_int_equal(seen[id], cycles);
}

/* Worst latency of motors 1..motors over cycles [from, to). */
static int64_t worst_latency(unsigned id_lo, unsigned id_hi, unsigned from, unsigned to)
{
	int64_t w = 0;

	for (unsigned id = id_lo; id <= id_hi; id++)
		for (unsigned k = from; k < to; k++)
			w = reply_lat[id][k] > w ? reply_lat[id][k] : w;
	return w;
}

static void test_overload_runs_late(void **state)
{
	const int64_t t0 = 1 * MS;
	double load;
	int64_t early, late, m1, m5;

	(void)state;
	/* 3 motors at 1 kHz fit (docs/design.md): latency stays put. */
	add_motors(3);
	assert_int_equal(run_cycles(3, 0x9C, t0, MS, 40, 10 * MS), 0);
	latencies(3, t0, 40);
	early = worst_latency(1, 3, 0, 20);
	late = worst_latency(1, 3, 20, 40);
	print_message("3 motors at 1 kHz: worst reply latency %.3f ms, then %.3f ms\n",
		      (double)early / MS, (double)late / MS);
	assert_true(late < 2 * MS);
	assert_true(late < early + 200 * US);
	assert_int_equal(bus.stats.errors, 0);
	check_trace(true, false);

	/*
	 * 5 motors: 10 frames of >= 111 us per 1 ms.  The wire runs flat out
	 * and the replies that lose arbitration, the highest identifiers',
	 * wait for the host to stop: late, not lost.
	 */
	setup(state);
	add_motors(5);
	assert_int_equal(run_cycles(5, 0x9C, t0, MS, 20, 0), 0);
	assert_int_equal(rmd_sim_wire_load(&bus, 10 * MS, &load), 0);
	rmd_sim_wire_advance(&bus, 100 * MS);
	drain();
	assert_int_equal(rx_n, 5 * 20);
	assert_int_equal(bus.stats.errors, 0);
	assert_int_equal(rmd_sim_wire_pending(&bus), 0);
	latencies(5, t0, 20);
	m1 = worst_latency(1, 1, 0, 20);
	m5 = worst_latency(5, 5, 0, 20);
	print_message("5 motors at 1 kHz: load %.1f %%, worst reply latency %.3f ms; motor 1 "
		      "(0x241) %.3f ms, motor 5 (0x245) %.3f ms, %.3f ms in cycle 19; "
		      "motor queue high-water %u\n",
		      load, (double)worst_latency(1, 5, 0, 20) / MS, (double)m1 / MS,
		      (double)m5 / MS, (double)reply_lat[5][19] / MS, bus.stats.motq_hwm);
	assert_true(load > 99.0);
	assert_true(worst_latency(1, 5, 0, 20) > 1 * MS);
	assert_true(m1 < 1500 * US); /* the lowest identifier barely notices */
	assert_true(m5 > 10 * MS);   /* the highest starves while the host asks */
	check_trace(true, false);
}

/* ---- (d) faults ----------------------------------------------------------- */

/* A window of kind for motor_id (0: bus-wide) over [start_ns, end_ns), with param. */
static struct rmd_sim_fault window(enum rmd_sim_fault_kind kind, uint8_t motor_id, int64_t start_ns,
				   int64_t end_ns, int64_t param)
{
	return (struct rmd_sim_fault){ .kind = kind,
				       .motor_id = motor_id,
				       .start_ns = start_ns,
				       .end_ns = end_ns,
				       .param = param };
}

/* Frames on can_id every period_ns during [start_ns, end_ns). */
static struct rmd_sim_fault flood(uint32_t can_id, int64_t period_ns, int64_t start_ns,
				  int64_t end_ns)
{
	struct rmd_sim_fault f = window(RMD_SIM_FAULT_FLOOD, 0, start_ns, end_ns, period_ns);

	f.can_id = can_id;
	return f;
}

static void set_faults(const struct rmd_sim_fault *f, size_t n)
{
	assert_int_equal(rmd_sim_wire_set_faults(&bus, f, n), 0);
}

/* drop p = 0.2 on motor 1 over 5000 requests; motor 2 is not hit. */
static void test_fault_drop_rate(void **state)
{
	const struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_DROP,
					 .motor_id = 1,
					 .probability = 0.2 };
	const unsigned n = 5000;
	unsigned got1;

	(void)state;
	add_motors(2);
	set_faults(&f, 1);
	assert_int_equal(run_cycles(2, 0x9C, MS, MS, n, 5 * MS), 0);
	got1 = count_rx(RMD_CAN_V3_REPLY_BASE + 1, 0, INT64_MAX);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 0, INT64_MAX), n);
	assert_int_equal(got1 + bus.stats.faults[RMD_SIM_FAULT_DROP], n);
	assert_binomial("dropped", bus.stats.faults[RMD_SIM_FAULT_DROP], n, 0.2);
	check_trace(true, false);
}

/* delay p = 0.5 by 2 ms: half the replies arrive 2 ms late. */
static void test_fault_delay_rate(void **state)
{
	const struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_DELAY,
					 .probability = 0.5,
					 .param = 2 * MS };
	const unsigned n = 2000;
	const int64_t period = 5 * MS;
	unsigned late = 0;

	(void)state;
	add_motors(1);
	set_faults(&f, 1);
	assert_int_equal(run_cycles(1, 0x9C, MS, period, n, 5 * MS), 0);
	assert_int_equal(rx_n, n);
	for (unsigned i = 0; i < rx_n; i++) {
		int64_t lat = (rx_log[i].t_ns - MS) % period;

		/* 0.5 +- 0.1 ms turnaround + 2 frames, plus 2 ms when delayed. */
		if (lat > 2 * MS)
			late++;
		else
			assert_true(lat < 1 * MS);
	}
	assert_int_equal(late, bus.stats.faults[RMD_SIM_FAULT_DELAY]);
	assert_binomial("delayed", late, n, 0.5);
	check_trace(true, false);
}

/* bad DLC p = 0.1 and garbage p = 0.1, both on every motor. */
static void test_fault_corrupt_rate(void **state)
{
	const struct rmd_sim_fault f[] = {
		{ .kind = RMD_SIM_FAULT_BAD_DLC, .probability = 0.1, .param = 3 },
		{ .kind = RMD_SIM_FAULT_GARBAGE, .probability = 0.1 },
	};
	const unsigned n = 3000;
	struct rmd_frame good;
	unsigned short_len = 0, garbage = 0;

	(void)state;
	add_motors(1);
	/* A clean reply of the idle motor first: every clean one equals it. */
	assert_int_equal(run_cycles(1, 0x9C, MS, MS, 1, 2 * MS), 0);
	assert_int_equal(rx_n, 1);
	good = rx_log[0].f;
	rx_n = 0;
	set_faults(f, 2);
	assert_int_equal(run_cycles(1, 0x9C, 10 * MS, MS, n, 5 * MS), 0);
	assert_int_equal(rx_n, n);
	for (unsigned i = 0; i < rx_n; i++) {
		short_len += rx_log[i].f.len == 3;
		garbage += memcmp(rx_log[i].f.data, good.data, 8) != 0;
		assert_int_equal(rx_log[i].f.can_id, good.can_id);
	}
	assert_int_equal(short_len, bus.stats.faults[RMD_SIM_FAULT_BAD_DLC]);
	assert_int_equal(garbage, bus.stats.faults[RMD_SIM_FAULT_GARBAGE]);
	assert_binomial("bad dlc", short_len, n, 0.1);
	assert_binomial("garbage", garbage, n, 0.1);
	check_trace(true, false);
}

/* Motor 1 answers as motor 2 during [10 ms, 20 ms). */
static void test_fault_wrong_id_window(void **state)
{
	const struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_WRONG_ID,
					 .motor_id = 1,
					 .probability = 1.0,
					 .start_ns = 10 * MS,
					 .end_ns = 20 * MS,
					 .param = 2 };

	(void)state;
	add_motors(2);
	set_faults(&f, 1);
	/* Requests to motor 1 only, at 1, 2, ..., 30 ms. */
	assert_int_equal(run_cycles(1, 0x9C, MS, MS, 30, 5 * MS), 0);
	assert_int_equal(rx_n, 30);
	/* The requests of 10..19 ms end inside the window: 10 replies moved. */
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 0, INT64_MAX), 10);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 10 * MS, 21 * MS), 10);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 0, INT64_MAX), 20);
	assert_int_equal(bus.stats.faults[RMD_SIM_FAULT_WRONG_ID], 10);
	check_trace(true, false);
}

/*
 * Motor 1 loses power during [200.4 ms, 400.4 ms) and boots at its end;
 * motor 2's cable is cut during [300.4 ms, 500.4 ms) and it runs on.
 * Requests go every 2 ms and are on the wire until ~0.37 ms after; replies
 * are ready from ~0.52 ms and done by ~1.1 ms: a window opening at .4
 * takes that cycle's replies, one closing at .4 missed its request.
 */
static void test_fault_disappear_window(void **state)
{
	const struct rmd_sim_fault f[] = {
		window(RMD_SIM_FAULT_DISAPPEAR, 1, 200400 * US, 400400 * US, 1),
		window(RMD_SIM_FAULT_DISAPPEAR, 2, 300400 * US, 500400 * US, 0),
	};

	(void)state;
	add_motors(3);
	set_faults(f, 2);
	assert_int_equal(run_cycles(3, 0x9C, 0, 2 * MS, 300, 5 * MS), 0);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 0, 200400 * US), 100);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 200400 * US, 400400 * US), 0);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 400400 * US, INT64_MAX), 99);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 0, 300400 * US), 150);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 300400 * US, 500400 * US), 0);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 500400 * US, INT64_MAX), 49);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 3, 0, INT64_MAX), 300);
	assert_int_equal(bus.stats.faults[RMD_SIM_FAULT_DISAPPEAR], 2);
	assert_int_equal(bus.stats.absent_lost, 2); /* the replies of 200 and 300 ms */
	assert_int_equal(rmd_sim_wire_motor(&bus, 1)->boot_ns, 400400 * US);
	assert_int_equal(rmd_sim_wire_motor(&bus, 2)->boot_ns, 0);
	assert_int_equal(rmd_sim_wire_motor(&bus, 3)->boot_ns, 0);
	check_trace(true, false);
}

/*
 * A glitch: motor 1 loses power during [100.4 ms, 105.4 ms); with
 * boot_ms 20 it answers nothing until 125.4 ms, then its runtime (0xB1)
 * counts from the power's return; with 0 (motor 2, the same glitch) at
 * once.  Requests every 1 ms.
 */
static void test_fault_disappear_boot(void **state)
{
	const struct rmd_sim_fault f[] = {
		window(RMD_SIM_FAULT_DISAPPEAR, 1, 100400 * US, 105400 * US, 1),
		window(RMD_SIM_FAULT_DISAPPEAR, 2, 100400 * US, 105400 * US, 1),
	};
	struct rmd_sim_motor_params p;
	int64_t first = 0;

	(void)state;
	for (unsigned id = 1; id <= 2; id++) {
		rmd_sim_motor_params_default(&p, (uint8_t)id, RMD_PROTO_V3);
		p.boot_ms = id == 1 ? 20 : 0;
		assert_int_equal(rmd_sim_wire_add_motor(&bus, &p, 0), (int)id - 1);
	}
	set_faults(f, 2);
	assert_int_equal(run_cycles(2, 0xB1, 0, 1 * MS, 200, 5 * MS), 0);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 100400 * US, 125400 * US), 0);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 100400 * US, 105400 * US), 0);
	/* requested at 106..124 ms (the 105 ms request fell in the window) */
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 105400 * US, 125400 * US), 19);
	/* requested at 126..199 ms: the 125 ms request reached it still booting */
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 125400 * US, INT64_MAX), 74);
	for (unsigned k = 0; k < rx_n && !first; k++) {
		struct rmd_msg msg;

		if (rx_log[k].f.can_id != RMD_CAN_V3_REPLY_BASE + 1 || rx_log[k].t_ns < 125400 * US)
			continue;
		assert_int_equal(rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, &rx_log[k].f, &msg, NULL),
				 0);
		/* asked at 126 ms: 20.7 ms since the power returned */
		assert_int_equal(msg.v[RMD_FLD_RUNTIME], 20);
		first = rx_log[k].t_ns;
	}
	assert_true(first);
	assert_int_equal(rmd_sim_wire_motor(&bus, 1)->boot_ns, 105400 * US);
	assert_int_equal(rmd_sim_wire_motor(&bus, 1)->awake_ns, 125400 * US);
}

/* Error bits of the 0x9A replies of motor 1 (V3 §2.12). */
static uint16_t status1_error(const struct rmd_frame *f)
{
	struct rmd_msg msg;

	assert_int_equal(rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, f, &msg, NULL), 0);
	assert_int_equal(msg.cmd, 0x9A);
	return (uint16_t)msg.v[RMD_FLD_ERROR];
}

/* Low voltage reported during [50 ms, 80 ms), via rmd_sim_motor_set_error(). */
static void test_fault_error_flag_window(void **state)
{
	const struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_ERROR_FLAG,
					 .motor_id = 1,
					 .start_ns = 50 * MS,
					 .end_ns = 80 * MS,
					 .param = RMD_SIM_ERR_LOW_VOLTAGE };
	unsigned flagged = 0;

	(void)state;
	add_motors(1);
	set_faults(&f, 1);
	assert_int_equal(run_cycles(1, 0x9A, 0, MS, 100, 5 * MS), 0);
	assert_int_equal(rx_n, 100);
	for (unsigned i = 0; i < rx_n; i++) {
		uint16_t err = status1_error(&rx_log[i].f);
		/* The request of cycle k ends ~0.1 ms after k ms. */
		int64_t req_ms = rx_log[i].t_ns / MS;
		bool in = req_ms >= 50 && req_ms < 80;

		if (in != ((err & RMD_SIM_ERR_LOW_VOLTAGE) != 0))
			fail_msg("seed %#llx: reply at %.3f ms: error %#x",
				 (unsigned long long)seed, (double)rx_log[i].t_ns / MS, err);
		flagged += in;
	}
	assert_int_equal(flagged, 30);
	assert_int_equal(bus.stats.faults[RMD_SIM_FAULT_ERROR_FLAG], 1);
	assert_int_equal(rmd_sim_wire_motor(&bus, 1)->errors_injected, 0);
	check_trace(true, false);
}

/* Bus-off during [10 ms, 20 ms): nothing sent, nothing received. */
static void test_fault_bus_off_window(void **state)
{
	const struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_BUS_OFF,
					 .start_ns = 10 * MS,
					 .end_ns = 20 * MS };

	(void)state;
	add_motors(2);
	set_faults(&f, 1);
	assert_int_equal(rmd_sim_wire_state(&bus), RMD_BUS_ACTIVE);
	/*
	 * Requests at 0.5, 1.5, ..., 29.5 ms: the ten inside are refused, and
	 * the replies to those of 9.5 ms, ready after 10 ms, are lost.
	 */
	assert_int_equal(run_cycles(2, 0x9C, 500 * US, MS, 30, 5 * MS), 2 * 10);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 9500 * US, 20 * MS), 0);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 2, 9500 * US, 20 * MS), 0);
	assert_int_equal(rx_n, 2 * 19);
	for (unsigned i = 0; i < trace_n; i++)
		assert_false(trace[i].eof_ns >= 10 * MS && trace[i].start_ns < 20 * MS);
	assert_int_equal(bus.stats.faults[RMD_SIM_FAULT_BUS_OFF], 1);
	assert_int_equal(bus.stats.busoff_lost, 2 * 10 + 2);
	assert_int_equal(bus.stats.errors, bus.stats.busoff_lost);
	assert_int_equal(rmd_sim_wire_state(&bus), RMD_BUS_ACTIVE);
	check_trace(false, false);

	/* The state a host sees inside the window, and the refusal. */
	setup(state);
	add_motors(1);
	set_faults(&f, 1);
	rmd_sim_wire_advance(&bus, 15 * MS);
	assert_int_equal(rmd_sim_wire_state(&bus), RMD_BUS_OFF);
	{
		struct rmd_frame r = request(1, 0x9C);

		assert_int_equal(rmd_sim_wire_send(&bus, 15 * MS, &r, 1), -ENETDOWN);
		assert_int_equal(rmd_sim_wire_send(&bus, 20 * MS, &r, 1), 1);
	}
	assert_int_equal(rmd_sim_wire_state(&bus), RMD_BUS_ACTIVE);
}

/*
 * The motors' supply cut during [10.4 ms, 30.4 ms) (an e-stop): no node
 * acknowledges, so the host's requests of 11..30 ms are tried again and
 * again and never complete; they wait in its FIFO queue (16 frames, and
 * the one being tried) and the rest is refused, as SocketCAN's queue
 * refuses with ENOBUFS.  The bus says RMD_BUS_NO_ACK from the first try
 * on.  At power's return the motors boot, and the frames held go out
 * first, in the order they were written: the replay a restart of the
 * interface (rmd_sim_wire_flush()) prevents.
 */
/* Host frames done on the wire in [from, to). */
static unsigned count_host(int64_t from_ns, int64_t to_ns)
{
	unsigned n = 0;

	for (unsigned k = 0; k < trace_n; k++)
		n += trace[k].p.src == RMD_SIM_SRC_HOST && trace[k].eof_ns >= from_ns &&
		     trace[k].eof_ns < to_ns;
	return n;
}

static unsigned bus_power_cycles(unsigned from, unsigned to, unsigned *taken_in_window)
{
	unsigned refused = 0;

	for (unsigned k = from; k < to; k++) {
		struct rmd_frame f[2] = { request(1, 0x9C), request(2, 0x9C) };
		int r = rmd_sim_wire_send(&bus, (int64_t)k * MS, f, 2);

		if (k >= 11 && k <= 30)
			*taken_in_window += r > 0 ? (unsigned)r : 0;
		refused += r < 0 ? 2 : 2 - (unsigned)r;
		rmd_sim_wire_advance(&bus, (int64_t)k * MS + 300 * US);
		/*
		 * The state a host sees: no acknowledgement from the first try
		 * in the window until the first frame after it is done (30.5 ms).
		 */
		assert_int_equal(rmd_sim_wire_state(&bus),
				 k >= 11 && k <= 30 ? RMD_BUS_NO_ACK : RMD_BUS_ACTIVE);
		drain();
	}
	return refused;
}

/* A host FIFO bus of two motors, its queue 16 frames, without power in [10.4 ms, 30.4 ms). */
static void bus_power_rig(void)
{
	const struct rmd_sim_fault f =
		window(RMD_SIM_FAULT_BUS_POWER, 0, 10400 * US, 30400 * US, 0);

	assert_int_equal(rmd_sim_wire_init(&bus, BITRATE, seed, RMD_SIM_WIRE_HOST_FIFO), 0);
	rmd_sim_wire_set_tap(&bus, tap, NULL);
	assert_int_equal(rmd_sim_wire_set_txqueuelen(&bus, 16), 0);
	add_motors(2);
	set_faults(&f, 1);
}

static void test_fault_bus_power_window(void **state)
{
	unsigned taken = 0, refused, replayed = 0, k;

	(void)state;
	bus_power_rig();
	refused = bus_power_cycles(0, 32, &taken);
	assert_int_equal(refused, 40 - taken);
	/* the queue's 16 frames, and the one a try holds when the next cycle's send comes */
	if (taken < 16 || taken > 17)
		fail_msg("seed %#llx: %u frames taken while nobody acknowledged",
			 (unsigned long long)seed, taken);
	assert_true(bus.stats.acks_missed > 100); /* tried back to back for 20 ms */
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 10400 * US, 30400 * US), 0);
	rmd_sim_wire_advance(&bus, 40 * MS);
	/* every motor lost power and booted at the end */
	assert_int_equal(rmd_sim_wire_motor(&bus, 1)->boot_ns, 30400 * US);
	assert_int_equal(rmd_sim_wire_motor(&bus, 2)->boot_ns, 30400 * US);
	assert_int_equal(bus.stats.faults[RMD_SIM_FAULT_BUS_POWER], 1);
	/* what was held went out first, in order: written in the window, done after it */
	for (k = 0; k < trace_n && trace[k].eof_ns < 30400 * US; k++)
		assert_true(trace[k].p.src != RMD_SIM_SRC_HOST || trace[k].p.ready_ns < 10400 * US);
	assert_int_equal(count_host(0, 10400 * US), 2 * 11); /* cycles 0..10 */
	for (; k < trace_n; k++) {
		if (trace[k].p.src != RMD_SIM_SRC_HOST)
			continue;
		if (trace[k].p.ready_ns >= 30400 * US)
			break;
		replayed++;
	}
	assert_int_equal(replayed, taken);
	assert_int_equal(rmd_sim_wire_state(&bus), RMD_BUS_ACTIVE);
	check_trace(false, true);
}

/* The same cut with the host queue flushed at 20 ms: nothing written before it goes out. */
static void test_fault_bus_power_flush(void **state)
{
	unsigned taken = 0, after = 0, n;

	(void)state;
	bus_power_rig();
	bus_power_cycles(0, 20, &taken);
	rmd_sim_wire_advance(&bus, 20500 * US);
	n = rmd_sim_wire_flush(&bus);
	assert_int_equal(n, taken); /* the frame being tried too */
	assert_int_equal(bus.stats.flushed, n);
	/* flushed, still nobody acknowledges: the state stays */
	assert_int_equal(rmd_sim_wire_state(&bus), RMD_BUS_NO_ACK);
	bus_power_cycles(21, 40, &after);
	rmd_sim_wire_advance(&bus, 45 * MS);
	for (unsigned k = 0; k < trace_n; k++)
		if (trace[k].p.src == RMD_SIM_SRC_HOST && trace[k].eof_ns >= 10400 * US)
			assert_true(trace[k].p.ready_ns > 20500 * US);
	assert_int_equal(rmd_sim_wire_flush(&bus), 0);
	assert_int_equal(bus.stats.flushed, n);
}

/*
 * A flood on 0x000 every 50 us during [10 ms, 30 ms) wins every
 * arbitration: it takes the whole wire, the host's requests wait, and
 * their replies come after the window.  Late, not lost.
 */
static void test_fault_flood_low_id_steals_wire(void **state)
{
	const struct rmd_sim_fault f = flood(0x000, 50 * US, 10 * MS, 30 * MS);
	double load;

	(void)state;
	add_motors(1);
	set_faults(&f, 1);
	assert_int_equal(run_cycles(1, 0x9C, 0, MS, 25, 0), 0);
	rmd_sim_wire_advance(&bus, 25 * MS);
	assert_int_equal(rmd_sim_wire_load(&bus, 10 * MS, &load), 0);
	rmd_sim_wire_advance(&bus, 60 * MS);
	drain();
	/* One frame already on the wire at 10 ms may finish. */
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 10 * MS + 200 * US, 30 * MS), 0);
	assert_int_equal(count_rx(RMD_CAN_V3_REPLY_BASE + 1, 0, INT64_MAX), 25);
	assert_int_equal(count_rx(0x000, 10 * MS, 30 * MS + 200 * US), bus.stats.frames_foreign);
	assert_int_equal(bus.stats.faults[RMD_SIM_FAULT_FLOOD], bus.stats.frames_foreign);
	/* 20 ms of back-to-back frames of 111..135 bits. */
	assert_in_range(bus.stats.frames_foreign, 20 * MS / (135 * US), 20 * MS / (111 * US) + 1);
	print_message("flood 0x000: %llu foreign frames in 20 ms, load %.1f %%\n",
		      (unsigned long long)bus.stats.frames_foreign, load);
	assert_true(load > 99.0);
	check_trace(true, false);
}

/*
 * A flood on 0x7FF every 200 us loses every arbitration: it only fills idle
 * time, and a request or reply waits at most for one foreign frame on the
 * wire.  Same seed as a clean run: the motors' jitter is identical.
 */
static void test_fault_flood_high_id_yields(void **state)
{
	const struct rmd_sim_fault f = flood(0x7FF, 200 * US, 10 * MS, 30 * MS);
	static int64_t clean[40];
	int64_t worst = 0;
	unsigned k = 0;

	(void)state;
	add_motors(1);
	assert_int_equal(run_cycles(1, 0x9C, 0, MS, 40, 5 * MS), 0);
	assert_int_equal(rx_n, 40);
	for (unsigned i = 0; i < 40; i++)
		clean[i] = rx_log[i].t_ns;

	setup(state);
	add_motors(1);
	set_faults(&f, 1);
	assert_int_equal(run_cycles(1, 0x9C, 0, MS, 40, 5 * MS), 0);
	for (unsigned i = 0; i < rx_n; i++) {
		if (rx_log[i].f.can_id != RMD_CAN_V3_REPLY_BASE + 1)
			continue;
		assert_true(rx_log[i].t_ns >= clean[k]);
		if (rx_log[i].t_ns - clean[k] > worst)
			worst = rx_log[i].t_ns - clean[k];
		k++;
	}
	assert_int_equal(k, 40);
	print_message("flood 0x7FF: %llu foreign frames, replies at most %.0f us later\n",
		      (unsigned long long)bus.stats.frames_foreign, (double)worst / US);
	/* The request and the reply may each wait out one foreign frame. */
	assert_true(worst <= 2 * rmd_can_wire_ns(rmd_can_frame_bits_worst(8), BITRATE));
	assert_in_range(bus.stats.frames_foreign, 95, 100);
	check_trace(true, false);
}

/* ---- queues, statistics, configuration ------------------------------------ */

/* docs/design.md: txqueuelen 10 refuses a 32-frame burst with ENOBUFS. */
static void test_txqueuelen_enobufs(void **state)
{
	struct rmd_frame f[32];

	(void)state;
	add_motors(1);
	assert_int_equal(rmd_sim_wire_set_txqueuelen(&bus, 10), 0);
	assert_int_equal(rmd_sim_wire_set_txqueuelen(&bus, 0), -EINVAL);
	assert_int_equal(rmd_sim_wire_set_txqueuelen(&bus, RMD_SIM_WIRE_TXQ + 1), -EINVAL);
	for (unsigned i = 0; i < 32; i++)
		f[i] = (struct rmd_frame){ .can_id = 0x600 + i, .len = 8 };
	assert_int_equal(rmd_sim_wire_send(&bus, MS, f, 32), 10);
	assert_int_equal(rmd_sim_wire_send(&bus, MS, f + 10, 22), -ENOBUFS);
	assert_int_equal(bus.stats.tx_refused, 22 + 22);
	assert_int_equal(bus.stats.txq_hwm, 10);
	/*
	 * 200 us later one frame is done and the second on the wire: both
	 * left the queue (as a frame in the controller leaves the qdisc).
	 */
	assert_int_equal(rmd_sim_wire_send(&bus, MS + 200 * US, f + 10, 22), 2);
	rmd_sim_wire_advance(&bus, 10 * MS);
	assert_int_equal(bus.stats.frames_host, 12);
}

/* Only classical 2.0A frames go on this wire; none at all is fine. */
static void test_send_rejects_bad_frames(void **state)
{
	struct rmd_frame f[3] = {
		{ .can_id = 0x141, .len = 8 },
		{ .can_id = 0x800, .len = 8 },
		{ .can_id = 0x142, .len = 9 },
	};

	(void)state;
	assert_int_equal(rmd_sim_wire_send(&bus, 0, f, 0), 0);
	assert_int_equal(rmd_sim_wire_send(&bus, 0, f, 3), 1);
	assert_int_equal(rmd_sim_wire_send(&bus, 0, f + 1, 2), -EINVAL);
	assert_int_equal(rmd_sim_wire_send(&bus, 0, f + 2, 1), -EINVAL);
	assert_int_equal(bus.stats.errors, 0);
	assert_int_equal(rmd_sim_wire_pending(&bus), 1);
}

/*
 * Unsolicited frames take the same way as replies, at the time they fall
 * due: V3 §2.30 comm-loss protection set to 100 ms, then silence.  The
 * motor trips 100 ms after the last frame it heard and sends 0xF1 then and
 * every second (docs/design.md, V4 firmware).
 */
static void test_unsolicited_frames(void **state)
{
	struct rmd_msg msg = { .cmd = 0xB3 };
	struct rmd_frame f;
	int64_t last_rx;

	(void)state;
	add_motors(1);
	rmd_msg_set(&msg, RMD_FLD_TIMEOUT, 100);
	assert_int_equal(rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, 1, &msg, &f), 0);
	assert_int_equal(rmd_sim_wire_send(&bus, 10 * MS, &f, 1), 1);
	rmd_sim_wire_advance(&bus, 2500 * MS);
	drain();
	last_rx = trace[0].eof_ns;
	assert_int_equal(rx_n, 1 + 3);
	assert_int_equal(rx_log[0].f.data[0], 0xB3); /* the echo */
	for (unsigned i = 1; i < 4; i++) {
		int64_t due = last_rx + 100 * MS + (int64_t)(i - 1) * 1000 * MS;

		assert_int_equal(rx_log[i].f.can_id, RMD_CAN_V3_REPLY_BASE + 1);
		assert_int_equal(rx_log[i].f.data[0], RMD_SIM_CMD_COMM_LOST);
		/* Due at the first 50 us physics step past the deadline; alone on the wire. */
		assert_in_range(rx_log[i].t_ns, due, due + RMD_SIM_STEP_NS + 135 * US);
	}
	assert_int_equal(bus.stats.frames_motor, 4);
	check_trace(true, false);
}

/* ---- the host's adapter and slow firmware (rmd/sim_adapter.h) ------------ */

/* V3 motors 1..n answering in exactly 500 us, through the adapter of *tpl. */
static void add_adapter_motors(unsigned n, const struct rmd_sim_motor_params *tpl)
{
	for (unsigned id = 1; id <= n; id++) {
		struct rmd_sim_motor_params p = *tpl;

		p.id = (uint8_t)id;
		p.turnaround_ns = 500.0 * US;
		p.turnaround_jitter_ns = 0;
		assert_int_equal(rmd_sim_wire_add_motor(&bus, &p, 0), (int)id - 1);
	}
}

/* The end of frame of the k-th motor frame on the wire (trace order). */
static int64_t motor_eof(unsigned k)
{
	for (unsigned i = 0; i < trace_n; i++)
		if (trace[i].p.src >= 0 && k-- == 0)
			return trace[i].eof_ns;
	fail_msg("no motor frame %u on the wire", k);
	return 0;
}

/*
 * A 16 ms latency timer: the three replies, all within 16 ms of the
 * first, wait in the converter and reach the host together, 16 ms after
 * the first one's end of frame; before then the host gets nothing.
 */
static void test_adapter_latency_timer(void **state)
{
	struct rmd_sim_motor_params p;
	struct rmd_frame f[3];
	int64_t t[3], flush;

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.adapter_latency_timer_ns = 16.0 * MS;
	add_adapter_motors(3, &p);
	for (unsigned i = 0; i < 3; i++)
		f[i] = request((uint8_t)(i + 1), 0x9A);
	assert_int_equal(rmd_sim_wire_send(&bus, 1 * MS, f, 3), 3);
	rmd_sim_wire_advance(&bus, 5 * MS);
	assert_int_equal(bus.stats.frames_motor, 3);
	flush = motor_eof(0) + 16 * MS;
	rmd_sim_wire_advance(&bus, flush - 1);
	assert_int_equal(rmd_sim_wire_recv(&bus, f, 3, t), 0);
	rmd_sim_wire_advance(&bus, flush);
	assert_int_equal(rmd_sim_wire_recv(&bus, f, 3, t), 3);
	for (unsigned i = 0; i < 3; i++) {
		assert_int_equal(f[i].data[0], 0x9A);
		assert_int_equal(t[i], flush);
	}
	/* the timer starts again with the next reply held, not from the old flush */
	f[0] = request(1, 0x9C);
	assert_int_equal(rmd_sim_wire_send(&bus, 40 * MS, f, 1), 1);
	rmd_sim_wire_advance(&bus, 80 * MS);
	assert_int_equal(rmd_sim_wire_recv(&bus, f, 3, t), 1);
	assert_int_equal(t[0], motor_eof(3) + 16 * MS);
	check_trace(true, false);
}

/*
 * USB batching into 1 ms frames, then a fixed 300 us: each reply reaches
 * the host at the end of the USB frame its end of frame fell in, plus
 * 300 us; replies keep their order.
 */
static void test_adapter_usb_frames_and_delay(void **state)
{
	struct rmd_sim_motor_params p;
	struct rmd_frame f[8];
	int64_t t[8];

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.adapter_usb_frame_ns = 1.0 * MS;
	p.adapter_delay_ns = 300.0 * US;
	add_adapter_motors(8, &p);
	for (unsigned i = 0; i < 8; i++)
		f[i] = request((uint8_t)(i + 1), 0x9C);
	assert_int_equal(rmd_sim_wire_send(&bus, 1 * MS + 123 * US, f, 8), 8);
	rmd_sim_wire_advance(&bus, 20 * MS);
	assert_int_equal(rmd_sim_wire_recv(&bus, f, 8, t), 8);
	for (unsigned i = 0; i < 8; i++) {
		int64_t eof = motor_eof(i), usb = (eof + MS - 1) / MS * MS;

		assert_int_equal(t[i], usb + 300 * US);
		assert_true(t[i] - eof >= 300 * US && t[i] - eof < 1300 * US);
		assert_true(i == 0 || t[i] >= t[i - 1]);
	}
	check_trace(true, false);
}

/*
 * Slow firmware: a ROM write (V3 §2.3 0x32, RMD_CMD_ROM) answers
 * rom_write_us after the turnaround; a read (0x9A) on the same motor does
 * not wait for it.
 */
static void test_rom_write_answers_late(void **state)
{
	struct rmd_sim_motor_params p;
	struct rmd_frame f[2];
	struct rmd_msg w = { .cmd = 0x32 };
	int64_t t[2];

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.rom_write_ns = 40.0 * MS;
	add_adapter_motors(2, &p);
	assert_int_equal(rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, 1, &w, &f[0]), 0);
	f[1] = request(2, 0x9A);
	assert_int_equal(rmd_sim_wire_send(&bus, 1 * MS, f, 2), 2);
	rmd_sim_wire_advance(&bus, 100 * MS);
	assert_int_equal(rmd_sim_wire_recv(&bus, f, 2, t), 2);
	/* the read's answer first, a turnaround after its request */
	assert_int_equal(f[0].can_id, RMD_CAN_V3_REPLY_BASE + 2);
	assert_int_equal(trace[2].p.ready_ns, trace[1].eof_ns + 500 * US);
	assert_int_equal(f[1].can_id, RMD_CAN_V3_REPLY_BASE + 1);
	assert_int_equal(f[1].data[0], 0x32);
	assert_int_equal(trace[3].p.ready_ns, trace[0].eof_ns + 500 * US + 40 * MS);
	check_trace(true, false);
}

/* A host that never reads loses frames at the receive queue, counted. */
static void test_rx_overflow_counted(void **state)
{
	const struct rmd_sim_fault f = flood(0x7FF, 200 * US, 0, 100 * MS);

	(void)state;
	set_faults(&f, 1);
	rmd_sim_wire_advance(&bus, 100 * MS);
	assert_int_equal(bus.stats.frames_foreign, 500);
	assert_int_equal(bus.stats.rxq_hwm, RMD_SIM_WIRE_RXQ);
	assert_int_equal(bus.stats.rxq_dropped, 500 - RMD_SIM_WIRE_RXQ);
	assert_int_equal(bus.stats.errors, 500 - RMD_SIM_WIRE_RXQ);
	drain();
	assert_int_equal(rx_n, RMD_SIM_WIRE_RXQ);
}

static void test_load_window(void **state)
{
	double pct = -1.0;

	(void)state;
	add_motors(1);
	rmd_sim_wire_advance(&bus, 10 * MS);
	assert_int_equal(rmd_sim_wire_load(&bus, 5 * MS, &pct), 0);
	assert_true(pct == 0.0);
	assert_int_equal(rmd_sim_wire_load(&bus, 0, &pct), -EINVAL);
	/* One pair per ms: 2 x 111..135 us busy per 1000 us. */
	assert_int_equal(run_cycles(1, 0x9C, 10 * MS, MS, 100, 0), 0);
	assert_int_equal(rmd_sim_wire_load(&bus, 50 * MS, &pct), 0);
	print_message("one pair per ms: load %.2f %%\n", pct);
	assert_true(pct >= 22.2 && pct <= 27.0);
	/* Past the frames kept: refused rather than wrong. */
	assert_int_equal(run_cycles(1, 0x9C, 110 * MS, MS, RMD_SIM_WIRE_HIST, 0), 0);
	assert_int_equal(rmd_sim_wire_load(&bus, 2 * RMD_SIM_WIRE_HIST * MS, &pct), -ERANGE);
}

/* Same seed, same wire, to the nanosecond; another seed, other jitter. */
static void test_deterministic(void **state)
{
	static struct trace_entry first[64];
	unsigned n, same = 1;

	(void)state;
	add_motors(4);
	run_cycles(4, 0x9C, 0, MS, 5, 5 * MS);
	n = trace_n;
	assert_true(n <= 64);
	memcpy(first, trace, n * sizeof(trace[0]));

	setup(state);
	add_motors(4);
	run_cycles(4, 0x9C, 0, MS, 5, 5 * MS);
	assert_int_equal(trace_n, n);
	for (unsigned i = 0; i < n; i++) {
		assert_int_equal(trace[i].start_ns, first[i].start_ns);
		assert_memory_equal(&trace[i].p.f, &first[i].p.f, sizeof(struct rmd_frame));
	}

	assert_int_equal(rmd_sim_wire_init(&bus, BITRATE, seed + 1, 0), 0);
	rmd_sim_wire_set_tap(&bus, tap, NULL);
	trace_n = 0;
	add_motors(4);
	run_cycles(4, 0x9C, 0, MS, 5, 5 * MS);
	for (unsigned i = 0; i < n && i < trace_n; i++)
		same &= trace[i].start_ns == first[i].start_ns;
	assert_false(same);
}

static void test_config_validation(void **state)
{
	static const struct rmd_sim_fault bad[] = {
		{ .kind = RMD_SIM_FAULT_COUNT },
		{ .kind = RMD_SIM_FAULT_DROP, .probability = 1.5 },
		{ .kind = RMD_SIM_FAULT_DROP, .probability = NAN },
		{ .kind = RMD_SIM_FAULT_DROP, .motor_id = 33, .probability = 0.5 },
		{ .kind = RMD_SIM_FAULT_DELAY, .probability = 1, .param = -1 },
		{ .kind = RMD_SIM_FAULT_BAD_DLC, .probability = 1, .param = 8 },
		{ .kind = RMD_SIM_FAULT_WRONG_ID, .probability = 1, .param = 0 },
		{ .kind = RMD_SIM_FAULT_DISAPPEAR, .param = 2 },
		{ .kind = RMD_SIM_FAULT_ERROR_FLAG, .param = 0x10000 },
		{ .kind = RMD_SIM_FAULT_BUS_OFF, .motor_id = 1 },
		{ .kind = RMD_SIM_FAULT_FLOOD, .param = 0 },
		{ .kind = RMD_SIM_FAULT_FLOOD, .param = 100, .can_id = 0x800 },
		{ .kind = RMD_SIM_FAULT_BUS_OFF, .start_ns = 5, .end_ns = 5 },
	};
	struct rmd_sim_fault many[RMD_SIM_MAX_FAULTS + 1] = { 0 };
	struct rmd_sim_motor_params p;

	(void)state;
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++)
		if (rmd_sim_wire_set_faults(&bus, &bad[i], 1) != -EINVAL)
			fail_msg("bad fault %zu accepted", i);
	assert_int_equal(rmd_sim_wire_set_faults(&bus, many, RMD_SIM_MAX_FAULTS + 1), -E2BIG);
	assert_int_equal(rmd_sim_wire_set_faults(&bus, many, RMD_SIM_MAX_FAULTS), 0);
	for (int k = 0; k < RMD_SIM_FAULT_COUNT; k++)
		assert_int_equal(rmd_sim_fault_kind_from_name(rmd_sim_fault_kind_name(k)), k);
	assert_int_equal(rmd_sim_fault_kind_from_name("nope"), -EINVAL);
	assert_null(rmd_sim_fault_kind_name(RMD_SIM_FAULT_COUNT));

	assert_int_equal(rmd_sim_wire_init(&bus, 0, 1, 0), -EINVAL);
	assert_int_equal(rmd_sim_wire_init(&bus, BITRATE, 1, 0x80), -EINVAL);
	assert_int_equal(rmd_sim_wire_init(&bus, BITRATE, 1, 0), 0);
	rmd_sim_motor_params_default(&p, 0, RMD_PROTO_V3);
	assert_int_equal(rmd_sim_wire_add_motor(&bus, &p, 0), -EINVAL);
	rmd_sim_motor_params_default(&p, 7, RMD_PROTO_V3);
	assert_int_equal(rmd_sim_wire_add_motor(&bus, &p, 0), 0);
	assert_int_equal(rmd_sim_wire_add_motor(&bus, &p, 0), -EEXIST);
	assert_null(rmd_sim_wire_motor(&bus, 8));
	assert_non_null(rmd_sim_wire_motor(&bus, 7));
}

/* One line of a tap file, parsed; its direction token (T: the host sent it) in *dir. */
static void tap_line(FILE *in, struct rmd_candump_line *c, char *dir)
{
	char line[128];
	size_t n;

	assert_non_null(fgets(line, sizeof(line), in));
	n = strlen(line);
	assert_true(n > 3 && line[n - 1] == '\n' && line[n - 3] == ' ');
	*dir = line[n - 2];
	assert_int_equal(rmd_candump_parse(line, c), 0);
}

/*
 * sim.tap (rmd/bus_sim.h): the host's request and the motor's reply, as
 * candump -l lines in the caller's clock, T and R; a FIFO with no reader is
 * refused at open.
 */
static void test_bus_sim_tap(void **state)
{
	char path[] = "/tmp/rmd-test-tap.XXXXXX";
	const struct rmd_bus_sim_motor m = { .id = 3, .proto = RMD_PROTO_V3 };
	struct rmd_bus_sim_opts o = { .motors = &m, .n_motors = 1, .tap = path };
	const struct rmd_frame req = { .can_id = 0x143, .len = 8, .data = { 0x9A } };
	const int64_t t0 = 5000000000; /* the caller's clock: 5 s */
	struct rmd_candump_line c1, c2;
	struct rmd_bus_rx rx[4];
	struct rmd_bus b;
	char err[256], d1, d2;
	double s1, s2;
	FILE *in;
	int fd;

	(void)state;
	fd = mkstemp(path);
	assert_true(fd >= 0);
	close(fd);
	assert_int_equal(rmd_bus_sim_open(&b, "s0", &o, err, sizeof(err)), 0);
	assert_int_equal(rmd_bus_send(&b, &req, 1, t0), 1);
	assert_int_equal(rmd_bus_recv(&b, rx, 4, t0 + 5000000), 1);
	assert_int_equal(rx[0].f.can_id, 0x243);
	assert_int_equal(rmd_bus_sim_tap_lost(&b), 0);
	rmd_bus_close(&b); /* writes what is buffered */

	in = fopen(path, "r");
	assert_non_null(in);
	tap_line(in, &c1, &d1);
	tap_line(in, &c2, &d2);
	assert_string_equal(c1.iface, "s0");
	assert_int_equal(c1.frame.can_id, 0x143);
	assert_memory_equal(c1.frame.data, req.data, 8);
	assert_int_equal(d1, 'T');
	assert_int_equal(c2.frame.can_id, 0x243);
	assert_memory_equal(c2.frame.data, rx[0].f.data, 8);
	assert_int_equal(d2, 'R');
	/* end of frame, in the caller's clock: the reply's is its receive time */
	s1 = (double)c1.time_sec + c1.time_frac / 1e6;
	s2 = (double)c2.time_sec + c2.time_frac / 1e6;
	assert_int_equal(c1.time_digits, 6);
	assert_true(s1 > 5.0 && s1 < s2 && s2 < 5.005);
	assert_true(fabs(s2 - (double)rx[0].t_ns / 1e9) < 1.5e-6);
	assert_int_equal(fgetc(in), EOF);
	fclose(in);

	/* a FIFO must have its reader first: rmdd's loop never waits for one */
	unlink(path);
	assert_int_equal(mkfifo(path, 0600), 0);
	assert_int_equal(rmd_bus_sim_open(&b, "s0", &o, err, sizeof(err)), -ENXIO);
	assert_non_null(strstr(err, "without a reader"));
	unlink(path);
}

/*
 * A cycle's burst that the host TX queue cannot hold is refused at open,
 * as SocketCAN's txqueuelen is (bench/vs-blocking found 12 requests a
 * cycle on the default 10-frame queue planned "fits" and then missing).
 */
static void test_bus_sim_burst_needs_queue(void **state)
{
	const struct rmd_bus_sim_motor m = { .id = 1, .proto = RMD_PROTO_V3 };
	struct rmd_bus_sim_opts o = { .motors = &m, .n_motors = 1, .txqueuelen = 10, .burst = 12 };
	struct rmd_bus b;
	char err[256];

	(void)state;
	assert_int_equal(rmd_bus_sim_open(&b, "s0", &o, err, sizeof(err)), -ENOBUFS);
	assert_non_null(strstr(err, "s0: TX queue of 10 frames cannot hold a 12-frame cycle: "
				    "set its sim.txqueuelen to 12 or more"));
	o.txqueuelen = 12;
	assert_int_equal(rmd_bus_sim_open(&b, "s0", &o, err, sizeof(err)), 0);
	rmd_bus_close(&b);
}

/*
 * The sim bus behind the ops table: its state says no acknowledgement, its
 * flush empties the host queue (nothing held goes out at power's return),
 * or is refused as SocketCAN's without CAP_NET_ADMIN (refuse_flush).
 */
static void test_bus_sim_flush(void **state)
{
	const struct rmd_bus_sim_motor m = { .id = 1, .proto = RMD_PROTO_V3 };
	const struct rmd_sim_fault f = { .kind = RMD_SIM_FAULT_BUS_POWER,
					 .start_ns = 0,
					 .end_ns = 50 * MS };
	struct rmd_bus_sim_opts o = { .motors = &m,
				      .n_motors = 1,
				      .flags = RMD_SIM_WIRE_HOST_FIFO,
				      .txqueuelen = 16,
				      .faults = &f,
				      .n_faults = 1 };
	const struct rmd_frame req = request(1, 0x9C);
	struct rmd_bus_rx rx[4];
	struct rmd_bus b;
	char err[256];
	int64_t t0 = 5000 * MS;

	(void)state;
	for (int refuse = 0; refuse <= 1; refuse++) {
		o.refuse_flush = refuse;
		assert_int_equal(rmd_bus_sim_open(&b, "s0", &o, err, sizeof(err)), 0);
		assert_int_equal(rmd_bus_state(&b), RMD_BUS_ACTIVE);
		assert_int_equal(rmd_bus_send(&b, &req, 1, t0), 1);
		assert_int_equal(rmd_bus_recv(&b, rx, 4, t0 + MS), 0);
		assert_int_equal(rmd_bus_state(&b), RMD_BUS_NO_ACK);
		assert_int_equal(rmd_bus_flush(&b), refuse ? -EPERM : 0);
		assert_int_equal(rmd_bus_sim_get(&b)->stats.flushed, refuse ? 0 : 1);
		/* power back: what the queue still holds goes out (the motor may still boot) */
		assert_true(rmd_bus_recv(&b, rx, 4, t0 + 60 * MS) >= 0);
		assert_int_equal(rmd_bus_sim_get(&b)->stats.frames_host, refuse ? 1 : 0);
		assert_int_equal(rmd_bus_state(&b), refuse ? RMD_BUS_ACTIVE : RMD_BUS_NO_ACK);
		rmd_bus_close(&b);
	}
}

/*
 * Host gaps (issue 31 point 3, rmd/sim_wire.h): the bus in rmdd's own
 * process judges rmdd in its own time.  Motor 1 armed at 100 ms, then a
 * host that calls every millisecond with a request, then a 300 ms gap in
 * which it never calls (its thread preempted, the process stopped):
 * with hold_after_ns the motor does not trip, the request sent just
 * before the gap is answered in time, and the gap is counted; then the
 * host keeps calling but sends nothing (a silence it chose): 0xF1 100 ms
 * after the last frame, as on a wire.  hold_after_ns 0 is a wire: the
 * same gap trips the motor (what rmdd --sim did beside two CPU hogs).
 */
static void test_bus_sim_host_gap(void **state)
{
	const struct rmd_bus_sim_motor m = { .id = 1, .proto = RMD_PROTO_V3 };
	struct rmd_bus_sim_opts o = { .motors = &m, .n_motors = 1 };
	const struct rmd_frame req = request(1, 0x9C);
	struct rmd_msg msg = { .cmd = 0xB3 };
	struct rmd_frame arm;
	char err[256];

	(void)state;
	rmd_msg_set(&msg, RMD_FLD_TIMEOUT, 100);
	assert_int_equal(rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, 1, &msg, &arm), 0);
	for (int hold = 0; hold <= 1; hold++) {
		struct rmd_bus_rx rx[16];
		struct rmd_bus b;
		struct rmd_sim_wire *w;
		int64_t t0 = 1000 * MS, t = t0, sent, last_heard = 0, f1_at = 0;
		unsigned f1 = 0, answered = 0;

		o.hold_after_ns = hold ? 2 * MS : 0;
		assert_int_equal(rmd_bus_sim_open(&b, "s0", &o, err, sizeof(err)), 0);
		w = rmd_bus_sim_get(&b);
		assert_int_equal(rmd_bus_send(&b, &arm, 1, t), 1);
		for (; t < t0 + 50 * MS; t += MS) {
			assert_true(rmd_bus_recv(&b, rx, 16, t) >= 0);
			assert_int_equal(rmd_bus_send(&b, &req, 1, t), 1);
		}
		sent = t - MS;
		/* the gap: no call for 300 ms */
		t = sent + 300 * MS;
		for (int n = rmd_bus_recv(&b, rx, 16, t), i = 0; i < n; i++) {
			f1 += rx[i].f.data[0] == RMD_SIM_CMD_COMM_LOST;
			if (rx[i].f.data[0] == 0x9C) {
				answered++;
				/* its reply in time: a turnaround after the request, not at the call */
				assert_in_range(rx[i].t_ns, sent, sent + 2 * MS);
			}
		}
		assert_int_equal(answered, 1);
		if (!hold) {
			/* a wire: 300 ms of silence, the motor tripped (0xF1) */
			assert_true(f1 >= 1);
			assert_true(w->motors[0].comm_lost);
			assert_int_equal(w->stats.host_gaps, 0);
			rmd_bus_close(&b);
			continue;
		}
		assert_int_equal(f1, 0);
		assert_false(w->motors[0].comm_lost);
		assert_int_equal(w->stats.host_gaps, 1);
		assert_int_equal(w->stats.host_held_ns, 298 * MS);
		/* the host keeps calling, sends one request, then nothing: a silence it chose */
		assert_int_equal(rmd_bus_send(&b, &req, 1, t), 1);
		last_heard = t;
		for (t += MS; t < last_heard + 400 * MS && !f1; t += MS) {
			int n = rmd_bus_recv(&b, rx, 16, t);

			for (int i = 0; i < n; i++)
				if (rx[i].f.data[0] == RMD_SIM_CMD_COMM_LOST && !f1++)
					f1_at = rx[i].t_ns;
		}
		assert_int_equal(f1, 1);
		/* 100 ms after the request reached it, at a physics step, alone on the wire */
		assert_in_range(f1_at, last_heard + 100 * MS, last_heard + 100 * MS + 500 * US);
		assert_int_equal(w->stats.host_gaps, 1);
		rmd_bus_close(&b);
	}
}

SUITE_MAIN_FIXTURE("sim_wire", setup, teardown, NULL, NULL,
		   {
			   cmocka_unit_test(test_acceptance_8_pairs),
			   cmocka_unit_test(test_arbitration_lowest_id_first),
			   cmocka_unit_test(test_arbitration_replies_overtake),
			   cmocka_unit_test(test_overload_runs_late),
			   cmocka_unit_test(test_fault_drop_rate),
			   cmocka_unit_test(test_fault_delay_rate),
			   cmocka_unit_test(test_fault_corrupt_rate),
			   cmocka_unit_test(test_fault_wrong_id_window),
			   cmocka_unit_test(test_fault_disappear_window),
			   cmocka_unit_test(test_fault_disappear_boot),
			   cmocka_unit_test(test_fault_error_flag_window),
			   cmocka_unit_test(test_fault_bus_off_window),
			   cmocka_unit_test(test_fault_bus_power_window),
			   cmocka_unit_test(test_fault_bus_power_flush),
			   cmocka_unit_test(test_fault_flood_low_id_steals_wire),
			   cmocka_unit_test(test_fault_flood_high_id_yields),
			   cmocka_unit_test(test_txqueuelen_enobufs),
			   cmocka_unit_test(test_send_rejects_bad_frames),
			   cmocka_unit_test(test_unsolicited_frames),
			   cmocka_unit_test(test_adapter_latency_timer),
			   cmocka_unit_test(test_adapter_usb_frames_and_delay),
			   cmocka_unit_test(test_rom_write_answers_late),
			   cmocka_unit_test(test_rx_overflow_counted),
			   cmocka_unit_test(test_load_window),
			   cmocka_unit_test(test_deterministic),
			   cmocka_unit_test(test_config_validation),
			   cmocka_unit_test(test_bus_sim_tap),
			   cmocka_unit_test(test_bus_sim_burst_needs_queue),
			   cmocka_unit_test(test_bus_sim_flush),
			   cmocka_unit_test(test_bus_sim_host_gap),
		   })
