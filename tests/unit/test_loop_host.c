// SPDX-License-Identifier: MIT
/*
 * The rt loop on USB adapters and hosts as they are (issue 32 points 8, 9
 * and 11; harness/loop_rig.h, cycles as the rt thread runs them):
 * transient ENOBUFS on a healthy bus retried within the cycle, persistent
 * refusal still a bus fault; an adapter that batches its receive stamps;
 * a host stall of 40 ms at 1 kHz.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "harness/loop_rig.h"
#include "harness/suite.h"
#include "rmd/sim_adapter.h"

/* Three motors on bus 0, cycles as the rt thread runs them, in speed mode at 1 rad/s. */
static void three_rt_at_speed(tweak_fn *tweak)
{
	rig_up(3, tweak);
	R.rt = true;
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < 3; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(300, true);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
}

/* Bus b's health as the loop last filled it. */
static struct rmd_bus_health bus_health(unsigned b)
{
	struct rmd_health h;

	assert_true(rmd_loop_get_health(R.l, &h));
	return h.bus[b];
}

/* ---- point 8: ENOBUFS on a healthy bus ------------------------------------------- */

/*
 * The adapter refuses each cycle's first send (a gs_usb adapter whose
 * URBs wait behind a camera's), and takes a try 50 us later: every motor
 * still gets its setpoint every cycle on the wire, runs, and nothing calls
 * it a bus fault; the retries are counted in the bus's health.
 */
static void test_enobufs_transient_retried(void **state)
{
	struct rmd_loop_counters c0, c1;
	struct rmd_loop_stats st0, st1;
	struct rmd_bus_health bh, bh0;
	unsigned from, failed;

	(void)state;
	three_rt_at_speed(NULL);
	rmd_loop_get_counters(R.l, &c0);
	rmd_loop_get_stats(R.l, &st0);
	failed = count_ev(RMD_EV_SEND_FAILED, -1);
	bh0 = bus_health(0);
	assert_int_equal(rmd_bus_sim_refuse_tx(&R.io.buses[0], sim_time(0), 0, 50 * US), 0);
	from = trace_n;
	run(500, true);
	rmd_loop_get_counters(R.l, &c1);
	rmd_loop_get_stats(R.l, &st1);
	/* the wire: a setpoint to every motor in (nearly) every cycle */
	for (unsigned i = 0; i < 3; i++) {
		unsigned n = sent_to(i, 0xA2, from);

		if (n < 495)
			fail_msg("motor %u: %u setpoints on the wire in 500 cycles", i, n);
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
		assert_int_equal(sim_motor(i)->ctrl, RMD_SIM_SPEED);
		assert_float_equal(sim_motor(i)->vel_rad_s, 1.0, 0.05);
	}
	/* not a bus fault: no miss, no event, no plan miss */
	assert_int_equal(c1.missed - c0.missed, 0);
	assert_int_equal(c1.frames_not_sent - c0.frames_not_sent, 0);
	assert_int_equal(st1.plan_misses - st0.plan_misses, 0);
	assert_int_equal(count_ev(RMD_EV_SEND_FAILED, -1), failed);
	/* counted: refused, and taken on a retry (the health is ~100 cycles old at most) */
	bh = bus_health(0);
	assert_true(bh.stats.tx_busy - bh0.stats.tx_busy >= 3 * 390);
	assert_int_equal(bh.stats.tx_retried - bh0.stats.tx_retried,
			 bh.stats.tx_busy - bh0.stats.tx_busy);
	rig_down();
}

/*
 * The adapter refuses every send: after the first cycle's retries nothing
 * is heard, nothing is retried, the frames count as not sent, the failure
 * is reported (RMD_EV_SEND_FAILED) and the motors are LOST, as before.
 */
static void test_enobufs_persistent_is_bus_fault(void **state)
{
	struct rmd_loop_counters c0, c1;
	struct rmd_bus_health bh0, bh1;
	unsigned from;
	int64_t t0;

	(void)state;
	three_rt_at_speed(NULL);
	rmd_loop_get_counters(R.l, &c0);
	bh0 = bus_health(0);
	assert_int_equal(rmd_bus_sim_refuse_tx(&R.io.buses[0], sim_time(0), 0, 0), 0);
	from = trace_n;
	t0 = t_now;
	run(100, true);
	rmd_loop_get_counters(R.l, &c1);
	bh1 = bus_health(0);
	/* the wire: nothing left the host */
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].t_ns >= t0)
			fail_msg("%03x %02x on the wire %lld us after the refusals began",
				 trace[k].f.can_id, trace[k].f.data[0],
				 (long long)((trace[k].t_ns - t0) / US));
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_LOST);
	assert_true(count_ev(RMD_EV_SEND_FAILED, -1) >= 1);
	assert_true(c1.frames_not_sent - c0.frames_not_sent >= 3 * 90);
	assert_true(c1.missed - c0.missed >= 3 * 10);
	assert_int_equal(bh1.stats.tx_retried, bh0.stats.tx_retried);
	/* the adapter takes frames again: the motors come back */
	assert_int_equal(rmd_bus_sim_refuse_tx(&R.io.buses[0], 0, 1, 0), 0);
	run(1500, false);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_READY);
	rig_down();
}

/* ---- point 9: adapters that batch receive stamps ------------------------------------ */

/* The host's adapter of every motor: PCAN-USB-like, 8 frames to a packet of the 1 ms USB frame. */
static void pcan_usb(struct rmd_sim_setup *sim)
{
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++) {
		sim->motors[i].adapter_usb_frame_ns = 1.0 * MS;
		sim->motors[i].adapter_rx_batch = 8;
	}
}

/*
 * The adapter's arithmetic (rmd/sim_adapter.h): a packet of 3 goes at the
 * end of the USB frame after its first frame's; a full one, or one gone,
 * leaves the next frame to a new packet; never back in time.
 */
static void test_sim_adapter_rx_batch(void **state)
{
	static const struct {
		int64_t wire_us, host_us;
	} v[] = {
		{ 200, 2000 },	{ 500, 2000 },	{ 900, 2000 },	/* one packet, full */
		{ 1100, 3000 }, { 1500, 3000 }, { 2500, 3000 }, /* the next, full */
		{ 2900, 4000 }, { 4100, 6000 },			/* one gone at 4000: a new one */
	};
	struct rmd_sim_motor_params p;
	struct rmd_sim_adapter a;

	(void)state;
	memset(&p, 0, sizeof(p));
	p.adapter_usb_frame_ns = 1.0 * MS;
	p.adapter_rx_batch = 3;
	rmd_sim_adapter_init(&a);
	for (size_t k = 0; k < sizeof(v) / sizeof(v[0]); k++) {
		int64_t t = rmd_sim_adapter_ns(&a, &p, v[k].wire_us * US);

		if (t != v[k].host_us * US)
			fail_msg(
				"frame %zu, on the wire at %lld us: to the host at %lld us, not %lld",
				k, (long long)v[k].wire_us, (long long)(t / US),
				(long long)v[k].host_us);
	}
}

/* Motor i's reply latencies so far. */
static struct rmd_latency latency(unsigned i)
{
	struct rmd_latency lat;

	assert_true(rmd_loop_get_reply_latency(R.l, i, &lat));
	return lat;
}

/*
 * Replies reach the host in packets, several stamped at one instant,
 * replies to requests a cycle apart among them: the motors run (the wire:
 * their setpoints, what they do), no reply is missed, every latency lies
 * between the send and the reply deadline, and the shared stamps are
 * counted in the bus's health.
 */
static void test_batched_stamps(void **state)
{
	struct rmd_loop_counters c0, c1;
	struct rmd_bus_health bh;
	unsigned from;

	(void)state;
	rig_sim_tweak = pcan_usb;
	three_rt_at_speed(NULL);
	rig_sim_tweak = NULL;
	rmd_loop_get_counters(R.l, &c0);
	from = trace_n;
	run(500, true);
	rmd_loop_get_counters(R.l, &c1);
	assert_int_equal(c1.missed - c0.missed, 0);
	for (unsigned i = 0; i < 3; i++) {
		struct rmd_latency lat = latency(i);

		assert_true(sent_to(i, 0xA2, from) >= 490); /* status polls take a few slots */
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
		assert_float_equal(sim_motor(i)->vel_rad_s, 1.0, 0.05);
		if (lat.min_ns < 0 || lat.max_ns > 3 * MS)
			fail_msg("motor %u: reply latency %lld..%lld us", i,
				 (long long)(lat.min_ns / US), (long long)(lat.max_ns / US));
	}
	bh = bus_health(0);
	assert_true(bh.stats.rx_stamps_shared > 3 * 300);
	assert_int_equal(bh.stats.rx_stamps_early, 0);
	rig_down();
}

/*
 * A decorator over the sim bus: every receive stamp 1.5 ms early, as an
 * adapter's hardware stamps converted by a clock estimate that lags
 * (stamps a packet's frames with its first one's time).
 */
static struct rmd_bus early_inner;
static struct rmd_bus_wrap early_wrap = { .inner = &early_inner };

static int early_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now)
{
	int n = rmd_bus_wrap_recv(bus, out, max, now);

	for (int k = 0; k < n; k++)
		out[k].t_ns -= 1500 * US;
	return n;
}

static const struct rmd_bus_ops early_ops =
	RMD_BUS_WRAP_OPS("early", rmd_bus_wrap_send, early_recv);

/*
 * Replies stamped before their requests were sent: no latency is negative
 * (each is taken as received at its send), they are counted, and the
 * motors run on without a missed reply.
 */
static void test_stamps_before_send_bounded(void **state)
{
	struct rmd_loop_counters c0, c1;
	struct rmd_latency lat0[3];
	struct rmd_bus_health bh;
	unsigned from;

	(void)state;
	three_rt_at_speed(NULL);
	for (unsigned i = 0; i < 3; i++)
		lat0[i] = latency(i);
	early_inner = R.io.buses[0];
	rmd_bus_wrap_init(&R.io.buses[0], &early_ops, &early_wrap);
	rmd_loop_get_counters(R.l, &c0);
	from = trace_n;
	run(300, true);
	rmd_loop_get_counters(R.l, &c1);
	R.io.buses[0] = early_inner;
	assert_int_equal(c1.missed - c0.missed, 0);
	for (unsigned i = 0; i < 3; i++) {
		struct rmd_latency lat = latency(i);

		assert_true(sent_to(i, 0xA2, from) >= 290);
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
		assert_true(lat.n - lat0[i].n >= 299);
		if (lat.min_ns < 0)
			fail_msg("motor %u: a reply latency of %lld us", i,
				 (long long)(lat.min_ns / US));
	}
	bh = bus_health(0);
	assert_true(bh.stats.rx_stamps_early >= 3 * 150); /* the health is ~100 cycles old */
	rig_down();
}

/* ---- point 11: host stalls ---------------------------------------------------------- */

/*
 * The host stalls 40 ms at 1 kHz right after a cycle's send (a dataset
 * writer flushing): the replies of that cycle wait in the bus's queue with
 * their receive stamps.  The next tick skips the 40 periods, never catches
 * up: on the wire, one setpoint a motor per period from then on, none
 * within half a period of the one before; the delayed replies are matched
 * (no miss, no motor LOST or out of ENABLED); the stall is reported once
 * (RMD_EV_OVERRUN, the 39 ticks missed at once), in the overruns and the wake-up
 * lateness.
 */
static void test_host_stall_40ms(void **state)
{
	struct rmd_loop_counters c0, c1;
	struct rmd_loop_stats st;
	int64_t stall_end, last[3] = { 0 };
	unsigned from, n_ev = 0;

	(void)state;
	three_rt_at_speed(NULL);
	rmd_loop_get_counters(R.l, &c0);
	events_pump();
	R.nev = 0;
	/* a cycle, then nothing of rmdd runs for 40 ms */
	rmd_loop_tick(R.l, t_now);
	t_now += 40 * MS;
	stall_end = t_now;
	from = trace_n;
	run(200, true);
	rmd_loop_get_counters(R.l, &c1);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(lifecycle(i), RMD_LC_ENABLED);
	assert_int_equal(c1.missed - c0.missed, 0);
	assert_int_equal(c1.late - c0.late, 0);
	/* the wire after the stall: at most a frame a motor a period, no burst */
	for (unsigned k = from; k < trace_n; k++) {
		unsigned id = trace[k].f.can_id - 0x141;

		if (trace[k].t_ns < stall_end || id >= 3 || trace[k].f.data[0] != 0xA2)
			continue;
		/* a catch-up would put several a period, a frame's wire time apart */
		if (last[id] && trace[k].t_ns - last[id] < period() / 2)
			fail_msg("motor %u: frames %lld us apart, %lld us after the stall", id,
				 (long long)((trace[k].t_ns - last[id]) / US),
				 (long long)((trace[k].t_ns - stall_end) / US));
		last[id] = trace[k].t_ns;
	}
	for (unsigned i = 0; i < 3; i++)
		assert_true(sent_to(i, 0xA2, from) >= 190);
	/* reported: one overrun event for the 40 periods, the lateness measured */
	for (unsigned k = 0; k < R.nev; k++)
		if (R.ev[k].kind == RMD_EV_OVERRUN) {
			n_ev++;
			assert_int_equal(R.ev[k].b, 39); /* the ticks 1..39 ms after the last */
		}
	assert_int_equal(n_ev, 1);
	rmd_loop_get_stats(R.l, &st);
	assert_true(st.overruns >= 39);
	assert_true(st.wake_max_ns >= 39 * MS);
	rig_down();
}

SUITE_MAIN("loop_host", NULL, NULL,
	   {
		   cmocka_unit_test(test_enobufs_transient_retried),
		   cmocka_unit_test(test_enobufs_persistent_is_bus_fault),
		   cmocka_unit_test(test_sim_adapter_rx_batch),
		   cmocka_unit_test(test_batched_stamps),
		   cmocka_unit_test(test_stamps_before_send_bounded),
		   cmocka_unit_test(test_host_stall_40ms),
	   })
