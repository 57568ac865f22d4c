// SPDX-License-Identifier: MIT
/*
 * The rt loop, the host watchdog and the controller's commands
 * (harness/loop_rig.h): the watchdog trips after command_timeout_ms + 1
 * cycle and a new enable lifts it, per motor, its safe frames not held
 * back by polls; events in cause-before-effect order; brake release
 * holding setpoints back; commands queued in a stall; NaN never reaches
 * the wire; the enable edge and what the loop ignores, by reason.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include <cmocka.h>

#include "harness/loop_rig.h"
#include "harness/suite.h"

static void test_watchdog(void **state)
{
	const struct rmd_health *h;
	const void *p;
	int64_t last_cmd, first80 = INT64_MAX;
	unsigned from;

	(void)state;
	up_at_speed(NULL, 2, 1.0, 150);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_int_equal(h->watchdog, RMD_WD_OK);
	last_cmd = t_now - period();
	from = trace_n;
	/* the controller goes quiet */
	run(200, false);
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].f.data[0] == 0x80 && trace[k].t_ns < first80)
			first80 = trace[k].t_ns;
	/* sent in the first cycle past command_timeout_ms, on the wire right after */
	if (first80 < last_cmd + 100 * MS || first80 > last_cmd + 101 * MS + 300 * US)
		fail_msg("0x80 at +%lld us", (long long)((first80 - last_cmd) / US));
	assert_int_equal(sent_to(0, 0x80, from), 1);
	assert_int_equal(sent_to(1, 0x80, from), 1);
	assert_int_equal(sent_to(2, 0x80, from), 0); /* never enabled */
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	assert_int_equal(lifecycle(2), RMD_LC_READY);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_OFF);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, -1), 2);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_int_equal(h->watchdog, RMD_WD_TRIPPED);
	assert_int_equal(h->safe_action_events, 2);
	/* latched: nothing changes without a command */
	run(300, false);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	/*
	 * Issue 20.3: nor with enable = 1 alone, newer than the trip as it is
	 * (before, the first one restarted the motors): nothing on the wire moves
	 */
	from = trace_n;
	assert_int_equal(ignored_over(150, RMD_IGN_EDGE), 2 * 150);
	for (unsigned k = from; k < trace_n; k++)
		if (moves_frame(&trace[k].f))
			fail_msg("a frame that moves, %03x %02x, from enable = 1 after the trip",
				 trace[k].f.can_id, trace[k].f.data[0]);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	assert_true(rmd_latest_get(&R.io.health, &p));
	assert_int_equal(((const struct rmd_health *)p)->watchdog, RMD_WD_TRIPPED);
	/* enable = 0, then enable = 1, lifts it */
	R.cmd.disables[0]++;
	R.cmd.disables[1]++;
	run(150, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	assert_true(rmd_latest_get(&R.io.health, &p));
	h = p;
	assert_int_equal(h->watchdog, RMD_WD_OK);
	rig_down();
}

/* Index in R.ev[] of the first event of `kind` for motor m from R.ev[from] on, or R.nev. */
static unsigned ev_at(unsigned from, unsigned kind, unsigned m)
{
	for (unsigned k = from; k < R.nev; k++)
		if (R.ev[k].kind == kind && R.ev[k].motor == m)
			return k;
	return R.nev;
}

/*
 * Issue 20.11: the loop reports in the order things happened, which the
 * incident summary keeps: the state change before the safe action it
 * sends, the error flags before the FAULT they cause.
 */
static void test_events_cause_before_effect(void **state)
{
	struct rmd_sim_fault flag = { .kind = RMD_SIM_FAULT_ERROR_FLAG,
				      .motor_id = 2,
				      .param = RMD_SIM_ERR_LOW_VOLTAGE };
	unsigned from, st, sa, er;

	(void)state;
	up_at_speed(NULL, 2, 1.0, 150);
	events_pump();
	from = R.nev;
	run(200, false); /* the watchdog trips: ENABLED -> SAFE, the safe action */
	events_pump();
	st = ev_at(from, RMD_EV_MOTOR_STATE, 0);
	sa = ev_at(from, RMD_EV_SAFE_ACTION, 0);
	if (st == R.nev || sa == R.nev || st > sa)
		fail_msg("watchdog: state change at event %u, its safe action at %u", st, sa);
	from = R.nev;
	fault_now(&flag, 0);
	run(300, false);
	events_pump();
	er = ev_at(from, RMD_EV_MOTOR_ERROR, 1);
	st = ev_at(from, RMD_EV_MOTOR_STATE, 1);
	if (er == R.nev || st == R.nev || er > st)
		fail_msg("fault: error flags at event %u, the state change at %u", er, st);
	rig_down();
}

/*
 * Issue 20.8: three motors at 1 kHz fill their bus, so a status poll takes
 * a motor's control slot now and then.  Whichever cycle the controller
 * goes quiet in, every enabled motor's safe frame is on the wire within
 * command_timeout_ms and one cycle: a poll never holds it back a cycle.
 */
static void test_safe_frames_take_polls_place(void **state)
{
	(void)state;
	for (unsigned off = 0; off < 40; off++) {
		int64_t last_cmd, first80[3] = { INT64_MAX, INT64_MAX, INT64_MAX };
		unsigned from;

		up_at_speed(NULL, 3, 1.0, 150 + off);
		last_cmd = t_now - period();
		from = trace_n;
		run(200, false);
		for (unsigned k = from; k < trace_n; k++)
			for (unsigned i = 0; i < 3; i++)
				if (trace[k].f.can_id == RMD_CAN_REQ_BASE + i + 1 &&
				    trace[k].f.data[0] == 0x80 && trace[k].t_ns < first80[i])
					first80[i] = trace[k].t_ns;
		for (unsigned i = 0; i < 3; i++)
			/* sent in the trip's cycle: on the wire before the next one starts */
			if (first80[i] < last_cmd + 100 * MS ||
			    first80[i] >= last_cmd + 101 * MS + period())
				fail_msg("quiet after %u cycles: motor %u's 0x80 at +%lld us",
					 150 + off, i + 1,
					 (long long)((first80[i] - last_cmd) / US));
		rig_down();
	}
}

/* The first frame to motor i with command byte cmd since trace[from]: its time, or INT64_MAX. */
static int64_t first_to(unsigned i, int cmd, unsigned from)
{
	const struct rmd_config_motor *m = &R.io.cfg.motors[i];

	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].bus == m->bus && trace[k].f.can_id == 0x140u + m->id &&
		    trace[k].f.data[0] == cmd)
			return trace[k].t_ns;
	return INT64_MAX;
}

/*
 * Motor i's safe action (0x80) since trace[from], sent 100..101 ms (+ a
 * frame's time) after its last command at last_ns, in 300 ms of `what`;
 * its time.
 */
static int64_t safe_action_at(unsigned i, int64_t last_ns, unsigned from, const char *what)
{
	int64_t t80 = first_to(i, 0x80, from);

	if (t80 == INT64_MAX)
		fail_msg("motor %u: no safe action (0x80) in 300 ms of %s", i, what);
	if (t80 < last_ns + 100 * MS || t80 > last_ns + 101 * MS + 300 * US)
		fail_msg("motor %u: 0x80 at +%lld us after its last command (want +100..101 ms)", i,
			 (long long)((t80 - last_ns) / US));
	return t80;
}

/*
 * Issue 20.2: the host watchdog is per motor.  A controller that keeps
 * streaming commands which carry only motor 0 (its arms loop died) keeps
 * motor 0 driven, but motor 1 gets the safe action command_timeout_ms
 * after the last command that carried it, and no setpoint reaches it after
 * that; commands that carry no motor (count = 0) then trip motor 0 too.
 * Judged on the wire.
 */
static void test_watchdog_per_motor(void **state)
{
	int64_t last1, last0, t80;
	unsigned from;

	(void)state;
	up_at_speed(NULL, 2, 1.0, 150);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	last1 = t_now - period();
	/* the commands carry motor 0 only */
	R.cmd.present = 1u << 0;
	from = trace_n;
	run(300, true);
	t80 = safe_action_at(1, last1, from, "commands without it");
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].t_ns > t80 && trace[k].f.can_id == 0x140u + R.io.cfg.motors[1].id &&
		    trace[k].f.data[0] == 0xA2)
			fail_msg("motor 1: 0xA2 at +%lld us, after its safe action",
				 (long long)((trace[k].t_ns - t80) / US));
	assert_int_equal(lifecycle(1), RMD_LC_SAFE);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_OFF);
	/* motor 0 kept its setpoint all along */
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	assert_int_equal(sent_to(0, 0x80, from), 0);
	assert_true(sent_to(0, 0xA2, from) >= 250);

	/* commands that carry no motor keep nothing enabled */
	last0 = t_now - period();
	R.cmd.present = 0;
	from = trace_n;
	run(300, true);
	t80 = safe_action_at(0, last0, from, "commands with no motor");
	for (unsigned k = from; k < trace_n; k++)
		if (trace[k].t_ns > t80 && moves_frame(&trace[k].f))
			fail_msg(
				"a frame that moves (0x%03x %02x) at +%lld us, after the safe action",
				trace[k].f.can_id, trace[k].f.data[0],
				(long long)((trace[k].t_ns - t80) / US));
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_OFF);
	rig_down();
}

static void brake_100ms(struct rmd_config *cfg)
{
	cfg->motors[0].brake_release_ms = 100;
}

/*
 * Issue 20.13: brake release takes time.  Motor 0 (brake_release_ms 100)
 * gets its brake release (0x77), then status reads only -- no setpoint --
 * for 100 ms from the 0x77, while its snapshot says the brake is opening
 * (state_t.brake_releasing); then its setpoints.  Motor 1 (no brake time)
 * gets its setpoints from the next slot.  Judged on the wire.
 */
static void test_brake_release_holds_setpoints(void **state)
{
	int64_t t77, ta2, t77b, ta2b;
	unsigned from;

	(void)state;
	rig_up(3, brake_100ms);
	bring_up();
	cmd_clear();
	from = trace_n;
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(50, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	t77 = first_to(0, 0x77, from);
	if (t77 == INT64_MAX)
		fail_msg("motor 0: no brake release (0x77) after enable");
	if (first_to(0, 0xA2, from) != INT64_MAX)
		fail_msg("motor 0: a speed setpoint %lld us after its brake release",
			 (long long)((first_to(0, 0xA2, from) - t77) / US));
	assert_true(snap().m[0].release_until_ns > t_now);
	assert_int_not_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	/* the other motor, without a brake time, runs at once */
	t77b = first_to(1, 0x77, from);
	ta2b = first_to(1, 0xA2, from);
	if (t77b == INT64_MAX || ta2b == INT64_MAX || ta2b - t77b > 3 * MS)
		fail_msg("motor 1: 0x77 at %lld, first 0xA2 at %lld (want within 3 ms)",
			 (long long)t77b, (long long)ta2b);
	run(100, true);
	ta2 = first_to(0, 0xA2, from);
	if (ta2 < t77 + 100 * MS || ta2 > t77 + 100 * MS + 2 * period())
		fail_msg("motor 0: first setpoint %lld us after its brake release (want 100 ms)",
			 (long long)((ta2 - t77) / US));
	assert_true(sent_to(0, 0x9C, from) >= 90); /* fed by status reads meanwhile */
	assert_int_equal(snap().m[0].release_until_ns > t_now, false);
	assert_int_equal(sim_motor(0)->ctrl, RMD_SIM_SPEED);
	rig_down();
}

/* R.cmd handed over stamped rx_ns (when it arrived), then one cycle. */
static void cycle_with_cmd_at(int64_t rx_ns)
{
	R.cmd.rx_ns = rx_ns;
	R.cmd.seq++;
	rmd_latest_put(&R.io.cmds, &R.cmd);
	rmd_loop_cycle(R.l, t_now);
	t_now += period();
}

/*
 * Issue 10: rx_ns is when a command arrived, so after rmdd was held off the
 * bridge hands over what queued meanwhile with old stamps.  One from before
 * a trip does not lift it, but its enable = 0 is acted on (SAFE -> READY);
 * one from after the trip that is older than the command timeout when the
 * loop takes it moves nothing (before, it enabled the motor, released its
 * brake and tripped again in the same cycle); a fresh one enables.
 */
static void test_commands_queued_in_a_stall(void **state)
{
	struct rmd_loop_counters c0, c1;
	int64_t last_cmd, trip;
	unsigned from;

	(void)state;
	up_at_speed(NULL, 1, 1.0, 150);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	last_cmd = t_now - period();
	/* the controller's commands stop reaching the loop: it trips */
	run(300, false);
	trip = last_cmd + 101 * MS;
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);

	/* from before the trip: motor 0 enable = 0 (acted on), motor 1 enable = 1 (not) */
	rmd_loop_get_counters(R.l, &c0);
	from = trace_n;
	cmd_clear();
	cmd_motor(0, false, RMD_MODE_SPEED);
	R.cmd.disables[0]++;
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	cycle_with_cmd_at(trip - 50 * MS);
	rmd_loop_get_counters(R.l, &c1);
	assert_int_equal(lifecycle(0), RMD_LC_STOPPING); /* READY once 0x80, 0x78 are echoed */
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_int_equal(c1.ignored[RMD_IGN_TRIPPED] - c0.ignored[RMD_IGN_TRIPPED], 1);

	/* from after the trip, 150 ms old when taken (timeout 100 ms): nothing moves */
	cmd_clear();
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	cycle_with_cmd_at(t_now - 150 * MS);
	run(20, false);
	assert_true(t_now - 170 * MS > trip);
	rmd_loop_get_counters(R.l, &c1);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_int_equal(c1.ignored[RMD_IGN_TRIPPED] - c0.ignored[RMD_IGN_TRIPPED], 2);
	for (unsigned k = from; k < trace_n; k++)
		if (moves_frame(&trace[k].f))
			fail_msg("a frame that moves, %03x %02x, from a command of the stall",
				 trace[k].f.can_id, trace[k].f.data[0]);

	/* a fresh command enables */
	run(20, true);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	rig_down();
}

static void mit_third(struct rmd_config *cfg)
{
	cfg->motors[2].proto = RMD_PROTO_MIT;
	cfg->motors[2].mode = RMD_MODE_MIT;
}

static void test_nan_never_on_wire(void **state)
{
	struct rmd_loop_counters c;
	struct rmd_setpoint *sp;
	unsigned from;

	(void)state;
	rig_up(3, mit_third);
	bring_up();
	/* a READY MIT motor is read with V3 0x9C, never sent an MIT frame */
	run(100, false);
	assert_int_equal(sent_to(2, 0x400, 0), 0);
	assert_true(sent_to(2, 0x9C, 0) > 50);
	cmd_clear();
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = NAN;
	cmd_motor(1, true, RMD_MODE_SPEED)->vel_rad_s = INFINITY;
	sp = cmd_motor(2, true, RMD_MODE_MIT);
	sp->kp = NAN;
	sp->kd = 1.0;
	from = trace_n;
	run(100, true);
	/* the safe action's frame (stop) instead, every control slot */
	assert_int_equal(sent_to(0, 0xA1, from), 0);
	assert_int_equal(sent_to(1, 0xA2, from), 0);
	assert_int_equal(sent_to(2, 0x400, from), 0);
	assert_true(sent_to(0, 0x80, from) >= 90);
	assert_true(sent_to(2, 0x80, from) >= 90);
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.nonfinite >= 270);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(sim_motor(i)->ctrl, RMD_SIM_OFF);
	/* finite again: the frames go out */
	cmd_motor(0, true, RMD_MODE_TORQUE)->torque_nm = 0.1;
	sp = cmd_motor(2, true, RMD_MODE_MIT);
	sp->kd = 0.5;
	from = trace_n;
	run(50, true);
	assert_true(sent_to(0, 0xA1, from) >= 45);
	assert_true(sent_to(2, 0x400, from) >= 45);
	assert_int_equal(sim_motor(2)->ctrl, RMD_SIM_MIT);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
	/* MIT replies: position, speed, torque */
	assert_true(isfinite(snap().m[2].torque_nm));
	rig_down();
}

/*
 * Issue 13: an enable = 0 the loop never saw as a command of its own (the
 * bridge handed enable = 1 over before the next cycle) still counts: its
 * trace is rmd_command.disables[].  What the loop does not act on is
 * counted by reason.
 */
static void test_enable_edge_latched(void **state)
{
	struct rmd_sim_fault drop = { .kind = RMD_SIM_FAULT_DROP,
				      .motor_id = 2,
				      .probability = 1.0 };
	struct rmd_snapshot s;
	struct rmd_health h;

	(void)state;
	three_at_speed();
	/* measurement times: the reply each value came from, at most a cycle old */
	s = snap();
	for (unsigned i = 0; i < 3; i++) {
		assert_true(s.m[i].rx_ns > s.t_ns - 2 * period());
		assert_true(s.m[i].rx_ns <= t_now);
	}

	drop.start_ns = sim_time(0);
	set_faults(0, &drop, 1);
	for (unsigned k = 0; k < 30 && lifecycle(1) != RMD_LC_LOST; k++)
		run(1, true);
	assert_int_equal(lifecycle(1), RMD_LC_LOST);
	assert_int_equal(ignored_over(10, RMD_IGN_NOT_READY), 10);
	/* its values stay those of its last reply, and say so */
	s = snap();
	assert_true(s.m[1].rx_ns < s.t_ns - 10 * period());

	/* back: READY; enable = 1 alone is ignored, and counted */
	set_faults(0, NULL, 0);
	run(1200, true);
	assert_int_equal(lifecycle(1), RMD_LC_READY);
	assert_int_equal(ignored_over(5, RMD_IGN_EDGE), 5);
	assert_int_equal(lifecycle(1), RMD_LC_READY);

	/* enable = 0 then enable = 1 within one cycle: the loop sees only the second */
	R.cmd.disables[1]++;
	run(20, true);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_SPEED);
	/* the others never left ENABLED: an enable = 0 they did not get is not theirs */
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
	/* health carries the counts (the bridge puts them in health_t) */
	run(200, true);
	assert_true(rmd_loop_get_health(R.l, &h));
	assert_true(h.ignored[RMD_IGN_EDGE] >= 5);
	assert_true(h.ignored[RMD_IGN_NOT_READY] >= 10);
	rig_down();
}

SUITE_MAIN("loop_commands", NULL, NULL,
	   {
		   cmocka_unit_test(test_watchdog),
		   cmocka_unit_test(test_safe_frames_take_polls_place),
		   cmocka_unit_test(test_events_cause_before_effect),
		   cmocka_unit_test(test_watchdog_per_motor),
		   cmocka_unit_test(test_brake_release_holds_setpoints),
		   cmocka_unit_test(test_commands_queued_in_a_stall),
		   cmocka_unit_test(test_nan_never_on_wire),
		   cmocka_unit_test(test_enable_edge_latched),
	   })
