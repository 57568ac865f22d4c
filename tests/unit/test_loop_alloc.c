// SPDX-License-Identifier: MIT
/*
 * The rt cycle allocates nothing (STYLE.md "Tests", issue 5 acceptance).
 *
 * Linked with -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free
 * (the Makefile's rule for the suites): every call from rmdd's code goes
 * through the counter of harness/alloc_count.c.  After set-up (config, plan, sim buses, loop,
 * bring-up) counting starts, and 12 000 cycles run with commands flowing
 * and everything the cycle can do happening at least once: setpoints in
 * every mode, MIT frames, NaN setpoints, clamping, status polls, a motor
 * lost and found again, an error flag, the host watchdog tripping and
 * lifted, an overrun, health snapshots, events drained, the V2 0x280 frame,
 * a position settled into its travel band, position enables refused for an
 * uncertain one until it is homed, a bus nobody acknowledges (its queue
 * flushed, its motors lost and back),
 * the incident recorder's ring filled and wrapped (rmd/incident.h), and
 * rmd_loop_stop_motors().  Not one allocation may happen.
 *
 * AddressSanitizer intercepts malloc itself, so under SANITIZE=1 the test
 * is skipped with a message.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/bringup.h"
#include "rmd/bus_sim.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/incident.h"
#include "rmd/loop.h"
#include "rmd/multiturn.h"
#include "rmd/plan.h"
#include "rmd/sim_wire.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

#include "harness/alloc_count.h"
#include "harness/clock.h"
#include "harness/loop_io.h"
#include "harness/rig.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)
#define CYCLES 12000

/* ---- the rig ----------------------------------------------------------------------- */

static struct rig_loop R; /* configuration, plan, buses, channels */
static struct rmd_command cmd;
static struct rmd_snapshot snap;
static struct rmd_bringup report;
static struct rmd_home homes;

/* sim0: V3 position, V3 speed, MIT; sim1: V3 torque x3; sim2: four V2 in one 0x280 frame */
static void make_config(void)
{
	assert_int_equal(rmd_config_sim_default(&R.cfg, &R.sim, 10), 0);
	R.cfg.safety.safe_action = RMD_SAFE_DAMP;
	R.cfg.safety.lost_motor_action = RMD_LOST_ALL;
	R.cfg.motors[0].mode = RMD_MODE_POSITION;
	R.cfg.motors[0].limits.position_min_rad = -1.0;
	R.cfg.motors[0].limits.position_max_rad = 1.0;
	R.cfg.motors[1].mode = RMD_MODE_SPEED;
	R.cfg.motors[2].proto = RMD_PROTO_MIT;
	R.cfg.motors[2].mode = RMD_MODE_MIT;
	/* rmd/multiturn.h: motor 4 settled into its travel band, motor 5 uncertain until homed */
	R.cfg.motors[4].multi_turn_saved = false;
	R.cfg.motors[4].n_travel = 2;
	R.cfg.motors[4].travel_rad[0] = -0.4;
	R.cfg.motors[4].travel_rad[1] = 0.4;
	R.cfg.motors[5].multi_turn_saved = false;
	R.cfg.motors[5].mode = RMD_MODE_POSITION;
	for (unsigned i = 6; i < 10; i++) {
		R.cfg.motors[i].bus = 2;
		R.cfg.motors[i].id = (uint8_t)(i - 5);
		R.cfg.motors[i].proto = RMD_PROTO_V2;
		R.cfg.motors[i].status_poll_hz = 0;
		R.cfg.motors[i].comm_loss_ms = 0; /* V2: no 0xB3, off by config */
	}
	R.cfg.n_buses = 3;
	for (unsigned i = 0; i < R.cfg.n_motors; i++) {
		R.sim.motors[i].id = R.cfg.motors[i].id;
		R.sim.motors[i].proto = R.cfg.motors[i].proto;
	}
	for (unsigned b = 0; b < R.cfg.n_buses; b++)
		R.sim.buses[b].host_fifo = true;
}

/* This cycle's command: every mode, now and then NaN, a pause for the watchdog. */
static void command_for(unsigned k)
{
	memset(&cmd, 0, sizeof(cmd));
	cmd.rx_ns = t_now;
	cmd.seq = k;
	for (unsigned i = 0; i < R.cfg.n_motors; i++) {
		struct rmd_setpoint *sp = &cmd.m[i];

		cmd.present |= 1u << i;
		/* a disable now and then: the motors brought back from LOST take it as the edge */
		sp->enable = k % 1000 != 500;
		sp->mode = (uint8_t)R.cfg.motors[i].mode;
		sp->pos_rad = 2.0 * sin(k * 0.001); /* beyond the window: clamped */
		sp->vel_rad_s = 0.5 * cos(k * 0.002);
		sp->torque_nm = 0.2 * sin(k * 0.003);
		sp->kp = 5.0;
		sp->kd = 0.2;
		sp->max_vel_rad_s = 2.0;
		if (k % 97 == 0)
			sp->torque_nm = NAN;
		if (k % 89 == 0)
			sp->pos_rad = INFINITY;
	}
}

static void test_cycle_allocates_nothing(void **state)
{
	struct rmd_sim_fault drop = { .kind = RMD_SIM_FAULT_DROP,
				      .motor_id = 2,
				      .probability = 1.0 };
	struct rmd_sim_fault hot = { .kind = RMD_SIM_FAULT_ERROR_FLAG,
				     .motor_id = 1,
				     .param = RMD_SIM_ERR_OVER_TEMP };
	struct rmd_sim_fault estop = { .kind = RMD_SIM_FAULT_BUS_POWER };
	struct rmd_loop_counters c;
	struct rmd_loop_stats st;
	struct rmd_loop_opts o;
	struct rmd_loop *l;
	struct rmd_incident_ring *inc;
	struct rmd_incident_window *w;
	struct rmd_event ev;
	unsigned long n;
	unsigned nev = 0;
	char err[1024];
	int r;

	(void)state;
	if (!alloc_count_available()) {
		print_message("skipped: ASan owns malloc, so allocations are not counted here\n");
		skip();
	}
	t_now = 1000 * MS;
	make_config();
	r = rmd_plan_build(&R.cfg, &R.plan, err, sizeof(err));
	if (r)
		fail_msg("%s", err);
	assert_int_equal(R.plan.bus[2].batch, RMD_BATCH_ON);
	rig_open_buses(&R.cfg, &R.sim, R.buses);
	assert_int_equal(rig_loop_opts(&R, &o), 0);
	/* a 1 s window (+ slack): 12 s of cycles wrap it many times */
	inc = rmd_incident_ring_new(&R.cfg, &R.plan, 1000 * MS, err, sizeof(err));
	if (!inc)
		fail_msg("%s", err);
	o.incidents = inc;
	l = rmd_loop_new(&o, err, sizeof(err));
	if (!l)
		fail_msg("%s", err);
	r = rmd_loop_bringup(l, &report);
	if (r)
		fail_msg("bring-up %d", r);
	t_now = (t_now / MS + 1) * MS;

	/* the wrap is in place: the counters see a call */
	alloc_count_reset();
	alloc_count_start();
	{
		void *volatile p = malloc(16);

		free(p);
	}
	assert_int_equal(alloc_count_stop(), 2);
	alloc_count_reset();

	alloc_count_start();
	for (unsigned k = 0; k < CYCLES; k++) {
		const void *p;

		if (k == 2000) {
			drop.start_ns = rmd_bus_sim_time_ns(&R.buses[0], t_now);
			drop.end_ns = drop.start_ns + 50 * MS;
			rmd_sim_wire_set_faults(rmd_bus_sim_get(&R.buses[0]), &drop, 1);
		}
		if (k == 4000) {
			hot.start_ns = rmd_bus_sim_time_ns(&R.buses[1], t_now);
			hot.end_ns = hot.start_ns + 300 * MS;
			rmd_sim_wire_set_faults(rmd_bus_sim_get(&R.buses[1]), &hot, 1);
		}
		if (k ==
		    5000) { /* sim0's motors lose power: nobody acknowledges, the queue is flushed */
			estop.start_ns = rmd_bus_sim_time_ns(&R.buses[0], t_now) + 20000;
			estop.end_ns = estop.start_ns + 100 * MS;
			rmd_sim_wire_set_faults(rmd_bus_sim_get(&R.buses[0]), &estop, 1);
		}
		if (k == 3000) { /* motor 5's position-mode enables were refused until now */
			homes.seq[5]++;
			homes.as_reported[5] = true;
			rmd_latest_put(&R.homes, &homes);
		}
		if (k == 7000)
			t_now += 5 * MS; /* an overrun */
		/* the controller is silent for 300 ms from 8000 */
		if (k < 8000 || k >= 8300) {
			command_for(k);
			rmd_latest_put(&R.cmds, &cmd);
		}
		if (k % 2) {
			rmd_loop_cycle(l, t_now);
		} else { /* as the thread runs it: the state published when the replies are in */
			rig_loop_cycle(l, t_now, R.plan.period_ns);
		}
		t_now += R.plan.period_ns;
		while (rmd_ring_pop(&R.events, &ev))
			nev++;
		rmd_latest_get(&R.snaps, &p);
		rmd_latest_get(&R.health, &p);
	}
	rmd_loop_get_snapshot(l, &snap);
	rmd_loop_get_stats(l, &st);
	rmd_loop_get_counters(l, &c);
	rmd_loop_stop_motors(l, t_now);
	n = alloc_count_stop();

	if (n)
		fail_msg("%lu allocator calls in %d cycles", n, CYCLES);
	/* and it did all of that */
	assert_int_equal(st.cycles, CYCLES);
	assert_int_equal(st.overruns, 5);
	assert_true(c.nonfinite > 0);
	assert_true(c.clamped > 0);
	assert_true(c.missed >= R.cfg.safety.missed_replies_lost);
	assert_true(c.safe_actions >= 3);
	assert_true(c.replies > 40000);
	assert_true(nev > 20);
	assert_true(c.ignored[RMD_IGN_POS_UNCERTAIN] > 1000);
	assert_int_equal(rmd_bus_sim_get(&R.buses[0])->stats.faults[RMD_SIM_FAULT_BUS_POWER], 1);
	assert_true(rmd_bus_sim_get(&R.buses[0])->stats.flushed > 0);
	assert_int_equal(snap.m[4].pos_trust, RMD_POS_IN_BAND);
	assert_int_equal(snap.m[5].pos_trust, RMD_POS_HOMED);
	for (unsigned i = 0; i < R.cfg.n_motors; i++)
		if (snap.m[i].lifecycle != RMD_LC_ENABLED)
			fail_msg("motor %u ends in lifecycle %u", i, snap.m[i].lifecycle);
	/* the recorder took every kind of record, and kept the newest when it wrapped */
	w = rmd_incident_window_new(inc);
	assert_non_null(w);
	rmd_incident_read(inc, 0, INT64_MAX, w);
	for (unsigned b = 0; b < R.cfg.n_buses; b++)
		assert_true(w->n_frames[b] > w->cap_frames[b] / 2);
	assert_true(w->n_states > w->cap_states / 2);
	assert_true(w->states[0].cycle > CYCLES / 2);
	assert_int_equal(w->states[w->n_states - 1].cycle, CYCLES - 1);
	assert_true(w->n_commands > 0);
	assert_true(w->n_events > 0);
	print_message("%d cycles, %llu replies, %llu missed, %u events, 0 allocations; incident "
		      "ring %.1f MB: %zu states from cycle %llu\n",
		      CYCLES, (unsigned long long)c.replies, (unsigned long long)c.missed, nev,
		      rmd_incident_ring_bytes(inc) / 1e6, w->n_states,
		      (unsigned long long)w->states[0].cycle);
	rmd_incident_window_free(w);
	rmd_loop_free(l);
	rmd_incident_ring_free(inc);
	for (unsigned b = 0; b < R.cfg.n_buses; b++)
		rmd_bus_close(&R.buses[b]);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_cycle_allocates_nothing),
	};

	if (!alloc_count_available())
		fprintf(stderr, "test_loop_alloc: AddressSanitizer intercepts malloc; "
				"skipped (run the build without SANITIZE=1)\n");
	return SUITE_RUN("loop_alloc", tests, NULL, NULL);
}
