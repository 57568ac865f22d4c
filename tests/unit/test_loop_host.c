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

SUITE_MAIN("loop_host", NULL, NULL,
	   {
		   cmocka_unit_test(test_enobufs_transient_retried),
		   cmocka_unit_test(test_enobufs_persistent_is_bus_fault),
	   })
