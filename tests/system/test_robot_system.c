// SPDX-License-Identifier: MIT
/*
 * Several rmdd as one robot (issue 30, docs/robot.md), through the whole
 * chain: real rmdd processes ($RMDD, else $BUILD/rmdd, else build/rmdd) on
 * sim buses, each with a channel prefix and a robot.instance of its own and
 * the other as its peer, on one LCM URL on loopback (a port of this suite's
 * own); the test is their controller and judges what they publish:
 *
 *   test_kill_one_makes_the_other_safe  kill -9 of one daemon: the other's
 *                         motors SAFE (its state_t) within peer_timeout_ms +
 *                         a heartbeat + what the machine held the test off,
 *                         the time measured and printed; its health_t says
 *                         why; enabling again is refused while the peer is
 *                         gone
 *   test_robot_stop_stops_both  `rmdctl stop --robot`: both daemons' motors
 *                         SAFE, each says who stopped it; each controller's
 *                         enable = 0, then 1, drives them again
 *   test_spoofed_heartbeats_change_nothing  heartbeats naming the peer, or
 *                         the daemon itself, from another host, and one from
 *                         an instance outside robot.peers: the motors stay
 *                         ENABLED; spoofs and unknown senders counted and
 *                         said once
 *   test_future_clock_warns_absurd_trips  a peer 500 ms ahead: a warning,
 *                         nothing moves; an hour ahead (beyond
 *                         max_clock_offset_ms): the safe action, said so
 *   test_motor_names_clash_reported_by_both  two instances with the same
 *                         motor names: both say so, health_t counts them
 *   test_alone_as_before  no robot: section: no heartbeat on the wire, and a
 *                         robot stop is not this daemon's
 *
 * Time bounds are judged against what the run achieved: a reference
 * sleeper measures how long the machine held a thread off, and each bound
 * grows by it.  Multicast on loopback must work (else every test skips,
 * loudly).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "harness/robot_pair.h"
#include "harness/sleeper.h"
#include "harness/suite.h"
#include "rmd/channels.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/rmd_robot_stop_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

#define BASE_PORT 61000 /* 61000 + 100 * 40 = 65000 */
#define PIDS 100

static char rmdctl_bin[PATH_MAX];
static bool multicast;
static unsigned test_no;

static int group_setup(void **state)
{
	(void)state;
	return robot_pair_group_setup("test_robot_system", rmdctl_bin, &multicast);
}

static int group_teardown(void **state)
{
	return robot_pair_group_teardown(state);
}

static void setup_url(void)
{
	char url[128];

	lcm_test_url(url, sizeof(url), BASE_PORT, PIDS, test_no++);
	robot_pair_url(url);
}

/* A test of the pair: skipped without multicast, else both up and driven. */
static void pair_or_skip(void)
{
	if (!multicast)
		skip();
	setup_url();
	robot_pair_enabled();
}

static void test_kill_one_makes_the_other_safe(void **state)
{
	int64_t t0, took, held, bound;
	const rmd_health_t *h;

	(void)state;
	pair_or_skip();
	/* the start says what the daemon is a part of */
	assert_has(rp.s[1].kid->out,
		   "robot: instance right, peers left; a heartbeat every 10 ms on "
		   "RMD_ROBOT_HEARTBEAT, a peer silent 100 ms is lost: the safe action",
		   "right's start");
	/* clocks: both state_t carry the host's clock, within a second of ours */
	assert_true(llabs(rp.s[1].host_utime - (int64_t)time(NULL) * 1000000) < 2000000);

	sleeper_mark(rp.ref);
	rp.s[1].safe_rx_ns = 0;
	t0 = rmd_now_ns();
	kill(rp.s[0].kid->pid, SIGKILL);
	kid_free(rp.s[0].kid);
	rp.s[0].kid = NULL;
	if (!robot_drive_until(true, 5000, robot_right_safe))
		fail_msg("right's motors not SAFE after left was killed:\n%s",
			 kid_tail(rp.s[1].kid));
	took = rp.s[1].safe_rx_ns - t0;
	held = sleeper_held_off_ns(rp.ref);
	/* the timeout, the heartbeat tick that sees it, a cycle, the wire, and what the machine took */
	bound = (RP_PEER_TIMEOUT_MS + 2 * RP_HEARTBEAT_MS + 20) * RMD_NS_PER_MS + held;
	print_message("kill -9 left -> right's motors SAFE in its state_t: %.1f ms (bound %.1f ms: "
		      "peer_timeout_ms %d + 2 heartbeats + 20 ms + %.1f ms held off)\n",
		      took / 1e6, bound / 1e6, RP_PEER_TIMEOUT_MS, held / 1e6);
	/* not before the timeout, counted from left's last heartbeat (up to a period or two before) */
	assert_true(took >= (RP_PEER_TIMEOUT_MS - 2 * RP_HEARTBEAT_MS) * RMD_NS_PER_MS);
	assert_true(took <= bound);
	kid_wait_output(rp.s[1].kid, "robot: peer left (host ", 2000, NULL);
	assert_has(rp.s[1].kid->out, "lost: no heartbeat for 100 ms: the safe action",
		   "right's log");
	robot_pump(200);
	h = rp.s[1].health;
	assert_non_null(h);
	assert_int_equal(h->robot, RMD_HEALTH_T_ROBOT_TRIPPED);
	assert_has(h->robot_reason, "peer left", "health_t robot_reason");
	assert_int_equal(h->peer[0].status, RMD_ROBOT_PEER_T_PEER_LOST);
	/* while the peer is gone, enabling again is refused: the robot is not whole */
	robot_drive_until(false, 300, robot_never);
	rp.s[1].armed = false;
	robot_drive_until(true, 500, robot_never);
	assert_true(robot_all_in(&rp.s[1], RMD_STATE_T_LC_SAFE) ||
		    robot_all_in(&rp.s[1], RMD_STATE_T_LC_READY));
	assert_false(robot_right_enabled());
	robot_pair_teardown();
}

static void test_robot_stop_stops_both(void **state)
{
	const char *args[] = { "stop",	   "--robot",	  "--lcm-url", rp.url,
			       "--reason", "e-stop test", NULL };
	const struct run_opts o = { .service = robot_pump };
	struct run r;
	int64_t t0;

	(void)state;
	pair_or_skip();
	rp.s[0].safe_rx_ns = rp.s[1].safe_rx_ns = 0;
	t0 = rmd_now_ns();
	run_prog(&r, rmdctl_bin, args, &o);
	assert_status(&r, 0, "rmdctl stop --robot");
	assert_has(r.out, "robot stop sent on RMD_ROBOT_STOP", "rmdctl's output");
	/* and it names both daemons as tripped, heard on their heartbeats */
	for (unsigned i = 0; i < 2; i++) {
		char line[128];

		snprintf(line, sizeof(line), "  %s (host ", rp.s[i].inst);
		assert_has(r.out, line, "rmdctl's output");
	}
	assert_int_equal(robot_count_of(r.out, "): tripped: robot stop from rmdctl@"), 2);
	run_free(&r);
	if (!robot_drive_until(true, 3000, robot_both_safe))
		fail_msg("not both SAFE after rmdctl stop --robot:\nleft:\n%s\nright:\n%s",
			 kid_tail(rp.s[0].kid), kid_tail(rp.s[1].kid));
	print_message("rmdctl stop --robot -> both SAFE: %.1f / %.1f ms after rmdctl started\n",
		      (rp.s[0].safe_rx_ns - t0) / 1e6, (rp.s[1].safe_rx_ns - t0) / 1e6);
	for (unsigned i = 0; i < 2; i++) {
		kid_wait_output(rp.s[i].kid, "robot: robot stop from rmdctl@", 2000, NULL);
		assert_has(rp.s[i].kid->out, "e-stop test: the safe action", rp.s[i].inst);
		/* rmdctl sends it three times: said once */
		assert_int_equal(robot_count_of(rp.s[i].kid->out, "robot stop from rmdctl@"), 1);
	}
	robot_pump(150);
	for (unsigned i = 0; i < 2; i++) {
		assert_non_null(rp.s[i].health);
		assert_true(rp.s[i].health->robot_stops >= 1);
		assert_has(rp.s[i].health->robot_reason, "robot stop from rmdctl@",
			   "health_t robot_reason");
	}
	/* enabling again is each controller's enable: 0, then 1 */
	robot_drive_until(false, 200, robot_never);
	if (!robot_drive_until(true, 5000, robot_both_enabled))
		fail_msg("not enabled again after the robot stop:\nleft:\n%s\nright:\n%s",
			 kid_tail(rp.s[0].kid), kid_tail(rp.s[1].kid));
	/* the stop's own time: one robot_stop_t from here to both state_t SAFE */
	{
		rmd_robot_stop_t s = { .who = "test", .reason = "timed", .t_ns = 0 };
		int64_t took, held, bound;

		rp.s[0].safe_rx_ns = rp.s[1].safe_rx_ns = 0;
		sleeper_mark(rp.ref);
		t0 = rmd_now_ns();
		assert_int_equal(rmd_robot_stop_t_publish(rp.lcm, RMD_CHANNEL_ROBOT_STOP, &s), 0);
		if (!robot_drive_until(true, 3000, robot_both_safe))
			fail_msg("not both SAFE after one robot_stop_t");
		took = (rp.s[0].safe_rx_ns > rp.s[1].safe_rx_ns ? rp.s[0].safe_rx_ns :
								  rp.s[1].safe_rx_ns) -
		       t0;
		held = sleeper_held_off_ns(rp.ref);
		/* two loop periods (500 Hz), the wire both ways, and what the machine took */
		bound = 4 * RMD_NS_PER_MS + 20 * RMD_NS_PER_MS + held;
		print_message("robot_stop_t -> both daemons' state_t SAFE: %.2f ms (bound %.1f ms, "
			      "%.1f ms held off)\n",
			      took / 1e6, bound / 1e6, held / 1e6);
		assert_true(took <= bound);
	}
	robot_pair_teardown();
}

static void test_spoofed_heartbeats_change_nothing(void **state)
{
	const rmd_health_t *h;

	(void)state;
	pair_or_skip();
	robot_pump(100);
	rp.s[0].armed = rp.s[1].armed = true;
	/* 300 ms: the peer's name from elsewhere, the daemon's own name, a stranger */
	for (int k = 0; k < 30; k++) {
		robot_send_heartbeat(rp.lcm, "left", "evil", 42, 1000 + k, 0);
		robot_send_heartbeat(rp.lcm, "right", "evil", 43, 1000 + k, 0);
		robot_send_heartbeat(rp.lcm, "stranger", "evil", 44, k, 0);
		robot_send_cmd(&rp.s[0], true);
		robot_send_cmd(&rp.s[1], true);
		robot_pump(10);
	}
	robot_pump(150);
	for (unsigned i = 0; i < 2; i++) {
		robot_send_cmd(&rp.s[i], true);
		if (rp.s[i].left_enabled)
			fail_msg("%s: a motor left ENABLED during the spoofs:\n%s", rp.s[i].inst,
				 kid_tail(rp.s[i].kid));
		h = rp.s[i].health;
		assert_non_null(h);
		assert_int_equal(h->robot, RMD_HEALTH_T_ROBOT_OK);
		assert_true(h->spoofs >= 30);
		assert_true(h->unknown_senders >= 30);
		assert_int_equal(h->peer[0].status, RMD_ROBOT_PEER_T_PEER_OK);
		assert_int_equal(h->robot_stops, 0);
		assert_has(rp.s[i].kid->out, "robot: heartbeat from \"stranger\" (host evil",
			   rp.s[i].inst);
		assert_int_equal(robot_count_of(rp.s[i].kid->out, "heartbeat from \"stranger\""),
				 1);
	}
	assert_has(rp.s[1].kid->out, "heartbeat naming peer \"left\" from host evil", "right");
	assert_has(rp.s[0].kid->out, "heartbeat naming peer \"right\" from host evil", "left");
	/* its own name from elsewhere: a duplicate instance on the network */
	assert_has(rp.s[1].kid->out,
		   "heartbeat naming this daemon, \"right\" from host evil, pid 4242: another "
		   "daemon uses this instance name (duplicate robot.instance on the network)",
		   "right");
	robot_pair_teardown();
}

static bool right_ready_or_enabled(void)
{
	return rp.s[1].health && rp.s[1].health->n_peers == 1 &&
	       rp.s[1].health->peer[0].status == RMD_ROBOT_PEER_T_PEER_OK;
}

/* One daemon whose peer is the test itself: "fake", with a clock ahead of ours. */
static void test_future_clock_warns_absurd_trips(void **state)
{
	char robot[256];
	int64_t seq = 0;
	struct held_deadline d;

	(void)state;
	if (!multicast)
		skip();
	setup_url();
	snprintf(robot, sizeof(robot),
		 "robot: {instance: right, peers: [fake], heartbeat_ms: %d, peer_timeout_ms: "
		 "1000, max_clock_offset_ms: 1000}\n",
		 RP_HEARTBEAT_MS);
	robot_side_start(1, "right", "RIGHT_", robot);
	/* the fake peer 500 ms ahead: within max_clock_offset_ms */
	held_deadline_start(&d, rp.ref, 20000);
	while (!robot_right_enabled() && !held_deadline_passed(&d)) {
		robot_send_heartbeat(rp.lcm, "fake", "faker", 7, seq++, 500 * RMD_NS_PER_MS);
		robot_send_cmd(&rp.s[1], right_ready_or_enabled());
		robot_pump(20);
	}
	if (!robot_right_enabled())
		fail_msg("not enabled beside a peer 500 ms ahead:\n%s", kid_tail(rp.s[1].kid));
	rp.s[1].armed = true;
	for (int k = 0; k < 20; k++) {
		robot_send_heartbeat(rp.lcm, "fake", "faker", 7, seq++, 500 * RMD_NS_PER_MS);
		robot_send_cmd(&rp.s[1], true);
		robot_pump(20);
	}
	assert_false(rp.s[1].left_enabled);
	{
		/* 500 ms ahead, as the daemon estimates it (a one-way delay off: 499.9 was seen) */
		const char *w = strstr(rp.s[1].kid->out,
				       "robot: peer fake: its clock differs from this host's by ");
		double ms = w ? strtod(w + strlen("robot: peer fake: its clock differs from this "
						  "host's by "),
				       NULL) :
				-1.0;

		if (ms < 480.0 || ms > 520.0)
			fail_msg("right's log: no clock offset of 500 +- 20 ms (%.1f):\n%s", ms,
				 kid_tail(rp.s[1].kid));
	}
	assert_int_equal(robot_count_of(rp.s[1].kid->out, "its clock differs"), 1);
	/* an hour ahead: its states cannot be compared with ours */
	rp.s[1].safe_rx_ns = 0;
	for (int k = 0; k < 100 && !rp.s[1].safe_rx_ns; k++) {
		robot_send_heartbeat(rp.lcm, "fake", "faker", 7, seq++, 3600 * RMD_NS_PER_S);
		robot_send_cmd(&rp.s[1], true);
		robot_pump(20);
	}
	if (!rp.s[1].safe_rx_ns)
		fail_msg("not SAFE beside a peer an hour ahead:\n%s", kid_tail(rp.s[1].kid));
	kid_wait_output(rp.s[1].kid,
			"differs from this host's by more than robot.max_clock_offset_ms", 2000,
			NULL);
	/* with every heartbeat, but said once */
	for (int k = 0; k < 10; k++) {
		robot_send_heartbeat(rp.lcm, "fake", "faker", 7, seq++, 3600 * RMD_NS_PER_S);
		robot_pump(20);
	}
	assert_int_equal(robot_count_of(rp.s[1].kid->out, "by more than robot.max_clock_offset_ms"),
			 1);
	robot_pair_teardown();
}

/*
 * A one-way split: left watches right and a third part, "ghost" (this test's
 * heartbeats), right watches left only.  When ghost falls silent left alone
 * judges it lost and stops; right, which never watched ghost and still hears
 * left, must follow left's trip: half a robot stopped while the other half
 * drives is the split the heartbeats are there to prevent.
 */
static void test_one_way_split_stops_both(void **state)
{
	char rl[256], rr[256];
	struct held_deadline d;
	int64_t seq = 0, t0, took, held, bound;
	const rmd_health_t *h;

	(void)state;
	if (!multicast)
		skip();
	setup_url();
	snprintf(rl, sizeof(rl),
		 "robot: {instance: left, peers: [right, ghost], heartbeat_ms: %d, "
		 "peer_timeout_ms: %d}\n",
		 RP_HEARTBEAT_MS, RP_PEER_TIMEOUT_MS);
	snprintf(rr, sizeof(rr),
		 "robot: {instance: right, peers: [left], heartbeat_ms: %d, peer_timeout_ms: %d}\n",
		 RP_HEARTBEAT_MS, RP_PEER_TIMEOUT_MS);
	robot_side_start(0, "left", "LEFT_", rl);
	robot_side_start(1, "right", "RIGHT_", rr);
	held_deadline_start(&d, rp.ref, 20000);
	while (!robot_both_enabled() && !held_deadline_passed(&d)) {
		robot_send_heartbeat(rp.lcm, "ghost", "ghosthost", 9, seq++, 0);
		robot_send_cmd(&rp.s[0], robot_peers_ok());
		robot_send_cmd(&rp.s[1], robot_peers_ok());
		robot_pump(RP_HEARTBEAT_MS);
	}
	if (!robot_both_enabled())
		fail_msg("not both ENABLED beside ghost:\nleft:\n%s\nright:\n%s",
			 kid_tail(rp.s[0].kid), kid_tail(rp.s[1].kid));
	/* ghost falls silent; the controllers drive on */
	sleeper_mark(rp.ref);
	rp.s[0].safe_rx_ns = rp.s[1].safe_rx_ns = 0;
	t0 = rmd_now_ns();
	if (!robot_drive_until(true, 5000, robot_both_safe))
		fail_msg("not both SAFE after ghost went silent (right %s):\nleft:\n%s\nright:\n%s",
			 rp.s[1].safe_rx_ns ? "SAFE" : "still driven", kid_tail(rp.s[0].kid),
			 kid_tail(rp.s[1].kid));
	took = rp.s[1].safe_rx_ns - t0;
	held = sleeper_held_off_ns(rp.ref);
	/* left's timeout and the tick that sees it, then one heartbeat of left's to right */
	bound = (RP_PEER_TIMEOUT_MS + 3 * RP_HEARTBEAT_MS + 20) * RMD_NS_PER_MS + held;
	print_message("ghost silent -> left SAFE %.1f ms, right SAFE %.1f ms (bound %.1f ms)\n",
		      (rp.s[0].safe_rx_ns - t0) / 1e6, took / 1e6, bound / 1e6);
	assert_true(took <= bound);
	kid_wait_output(rp.s[1].kid, "robot: peer left tripped: peer ghost", 2000, NULL);
	robot_pump(200);
	h = rp.s[1].health;
	assert_non_null(h);
	assert_int_equal(h->robot, RMD_HEALTH_T_ROBOT_TRIPPED);
	assert_has(h->robot_reason, "peer left tripped: peer ghost", "right's robot_reason");
	/* and it does not echo: left took no trip back from right's */
	assert_int_equal(robot_count_of(rp.s[0].kid->out, "peer right tripped"), 0);
	robot_pair_teardown();
}

/* Both daemons name their motors leg_hip and leg_knee: both say so; nothing else changes. */
static void test_motor_names_clash_reported_by_both(void **state)
{
	(void)state;
	if (!multicast)
		skip();
	setup_url();
	robot_pair_start_named((const char *const[]){ "leg", "leg" });
	if (!robot_drive_until(false, 20000, robot_peers_ok))
		fail_msg("the peers robot_never saw each other");
	for (unsigned i = 0; i < 2; i++)
		kid_wait_output(rp.s[i].kid, "robot: 2 motor name(s) of this daemon are peer ",
				5000, NULL);
	assert_has(rp.s[0].kid->out, "are peer right's too (\"leg_hip\"...)", "left");
	assert_has(rp.s[1].kid->out, "are peer left's too (\"leg_hip\"...)", "right");
	robot_pump(150);
	for (unsigned i = 0; i < 2; i++) {
		assert_non_null(rp.s[i].health);
		assert_int_equal(rp.s[i].health->name_clashes, 2);
	}
	robot_pair_teardown();
}

static void test_alone_as_before(void **state)
{
	const char *args[] = { "stop", "--robot", "--lcm-url", rp.url, NULL };
	const struct run_opts o = { .service = robot_pump };
	struct run r;

	(void)state;
	if (!multicast)
		skip();
	setup_url();
	robot_side_start(1, "alone", "RMD_", "");
	if (!robot_drive_until(true, 20000, robot_right_enabled))
		fail_msg("not enabled:\n%s", kid_tail(rp.s[1].kid));
	rp.s[1].armed = true;
	rp.heartbeats = 0;
	run_prog(&r, rmdctl_bin, args, &o);
	/* sent, and said to have reached no one: a daemon alone takes no robot stop */
	assert_status(&r, 1, "rmdctl stop --robot");
	assert_has(r.err, "no rmdd of a robot heard within 300 ms: nothing confirmed the stop",
		   "rmdctl's errors");
	run_free(&r);
	robot_drive_until(true, 300, robot_never);
	assert_false(rp.s[1].left_enabled);
	assert_int_equal(rp.heartbeats, 0);
	assert_non_null(rp.s[1].health);
	assert_int_equal(rp.s[1].health->robot, RMD_HEALTH_T_ROBOT_NONE);
	assert_int_equal(rp.s[1].health->n_peers, 0);
	assert_lacks(rp.s[1].kid->out, "robot:", "a daemon alone");
	robot_pair_teardown();
}

SUITE_MAIN("robot_system", group_setup, group_teardown,
	   {
		   cmocka_unit_test(test_kill_one_makes_the_other_safe),
		   cmocka_unit_test(test_robot_stop_stops_both),
		   cmocka_unit_test(test_one_way_split_stops_both),
		   cmocka_unit_test(test_spoofed_heartbeats_change_nothing),
		   cmocka_unit_test(test_future_clock_warns_absurd_trips),
		   cmocka_unit_test(test_motor_names_clash_reported_by_both),
		   cmocka_unit_test(test_alone_as_before),
	   })
