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
#include "harness/sleeper.h"
#include "harness/suite.h"
#include "rmd/channels.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/rmd_robot_stop_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

#define NMOT 2
#define HEARTBEAT_MS 10
#define PEER_TIMEOUT_MS 100
#define BASE_PORT 61000 /* 61000 + 100 * 40 = 65000 */
#define PIDS 100

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX], dir[PATH_MAX] = "/tmp/test_robot.XXXXXX";
static bool multicast;
static unsigned test_no;
static struct sleeper ref;

/* One daemon of the robot, as the test sees and drives it. */
struct side {
	const char *inst, *prefix;
	struct kid *kid;
	int64_t controller, seq;
	rmd_state_t_subscription_t *ssub;
	rmd_health_t_subscription_t *hsub;
	int8_t lc[NMOT];    /* the newest state_t's lifecycles */
	int64_t host_utime; /* and its host clock */
	unsigned n_states;
	int64_t safe_rx_ns;   /* when a state_t first showed every motor SAFE (0: not yet) */
	bool left_enabled;    /* a state_t showed a motor not ENABLED after arm() */
	bool armed;	      /* watch for that */
	rmd_health_t *health; /* the newest (a copy) */
	char ch_cmd[64];
};

static struct {
	char url[128];
	lcm_t *lcm;
	struct side s[2];
	rmd_heartbeat_t_subscription_t *hbsub;
	unsigned heartbeats; /* on RMD_ROBOT_HEARTBEAT */
} R;

static void on_state(const lcm_recv_buf_t *rb, const char *ch, const rmd_state_t *m, void *user)
{
	struct side *s = user;
	bool safe = m->count == NMOT;

	(void)rb;
	(void)ch;
	for (int i = 0; i < m->count && i < NMOT; i++) {
		s->lc[i] = m->motor[i].lifecycle;
		safe &= m->motor[i].lifecycle == RMD_STATE_T_LC_SAFE;
		if (s->armed && m->motor[i].lifecycle != RMD_STATE_T_LC_ENABLED)
			s->left_enabled = true;
	}
	s->host_utime = m->host_utime;
	if (safe && !s->safe_rx_ns)
		s->safe_rx_ns = rmd_now_ns();
	s->n_states++;
}

static void on_health(const lcm_recv_buf_t *rb, const char *ch, const rmd_health_t *m, void *user)
{
	struct side *s = user;

	(void)rb;
	(void)ch;
	if (s->health)
		rmd_health_t_destroy(s->health);
	s->health = rmd_health_t_copy(m);
}

static void on_heartbeat(const lcm_recv_buf_t *rb, const char *ch, const rmd_heartbeat_t *m,
			 void *user)
{
	(void)rb;
	(void)ch;
	(void)m;
	(void)user;
	R.heartbeats++;
}

static int group_setup(void **state)
{
	(void)state;
	if (lcm_tools_setup("test_robot_system", rmdd_bin, rmdctl_bin, dir, &multicast) < 0)
		return -1;
	return sleeper_start(&ref, 1000000, 0) < 0 ? -1 : 0;
}

static int group_teardown(void **state)
{
	sleeper_stop(&ref);
	return lcm_tools_teardown(state);
}

/*
 * dir/NAME.yaml: instance inst on prefix, its robot: section `robot` ("" none),
 * its motors `names`_hip and `names`_knee.
 */
static void write_config(char *path, size_t len, const char *inst, const char *prefix,
			 const char *robot, const char *names)
{
	FILE *f;

	snprintf(path, len, "%s/%s.yaml", dir, inst);
	f = fopen(path, "w");
	assert_non_null(f);
	fprintf(f,
		"loop: {rate_hz: 500}\n"
		"safety: {comm_loss_ms: 100, command_timeout_ms: 1000, safe_action: damp}\n"
		"lcm: {channel_prefix: %s, health_period_ms: 50}\n"
		"incidents: {enabled: false}\n"
		"%s"
		"buses:\n"
		"  - {name: s0, type: sim}\n"
		"motors:\n"
		"  - {name: %s_hip, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: %s_knee, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2}\n",
		prefix, robot, names, names);
	assert_int_equal(fclose(f), 0);
}

/* Start daemon i: instance inst on prefix with robot: section robot, motors named after names. */
static void start_side_named(unsigned i, const char *inst, const char *prefix, const char *robot,
			     const char *names)
{
	struct side *s = &R.s[i];
	char cfg[PATH_MAX + 64], ch[64];
	const char *argv[] = { rmdd_bin, "--config", cfg, "--lcm-url", R.url, NULL };

	memset(s, 0, sizeof(*s));
	s->inst = inst;
	s->prefix = prefix;
	s->controller = 0x1000 + i;
	snprintf(s->ch_cmd, sizeof(s->ch_cmd), "%s" RMD_CHANNEL_COMMAND, prefix);
	write_config(cfg, sizeof(cfg), inst, prefix, robot, names);
	snprintf(ch, sizeof(ch), "%s" RMD_CHANNEL_STATE, prefix);
	s->ssub = rmd_state_t_subscribe(R.lcm, ch, on_state, s);
	snprintf(ch, sizeof(ch), "%s" RMD_CHANNEL_HEALTH, prefix);
	s->hsub = rmd_health_t_subscribe(R.lcm, ch, on_health, s);
	s->kid = kid_spawn(inst, argv, NULL, 0);
}

static void start_side(unsigned i, const char *inst, const char *prefix, const char *robot)
{
	start_side_named(i, inst, prefix, robot, inst);
}

static void setup_url(void)
{
	memset(&R, 0, sizeof(R));
	lcm_test_url(R.url, sizeof(R.url), BASE_PORT, PIDS, test_no++);
	R.lcm = lcm_create(R.url);
	assert_non_null(R.lcm);
	R.hbsub = rmd_heartbeat_t_subscribe(R.lcm, RMD_CHANNEL_ROBOT_HEARTBEAT, on_heartbeat, NULL);
}

static void teardown_all(void)
{
	for (unsigned i = 0; i < 2; i++) {
		struct side *s = &R.s[i];

		kid_free(s->kid);
		s->kid = NULL;
		if (s->ssub)
			rmd_state_t_unsubscribe(R.lcm, s->ssub);
		if (s->hsub)
			rmd_health_t_unsubscribe(R.lcm, s->hsub);
		if (s->health)
			rmd_health_t_destroy(s->health);
	}
	if (R.hbsub)
		rmd_heartbeat_t_unsubscribe(R.lcm, R.hbsub);
	lcm_destroy(R.lcm);
	R.lcm = NULL;
}

/* The two daemons: left and right, each the other's peer; motors named after names[i]. */
static void start_pair_named(const char *const names[2])
{
	char rl[256], rr[256];

	snprintf(rl, sizeof(rl),
		 "robot: {instance: left, peers: [right], heartbeat_ms: %d, peer_timeout_ms: %d}\n",
		 HEARTBEAT_MS, PEER_TIMEOUT_MS);
	snprintf(rr, sizeof(rr),
		 "robot: {instance: right, peers: [left], heartbeat_ms: %d, peer_timeout_ms: %d}\n",
		 HEARTBEAT_MS, PEER_TIMEOUT_MS);
	start_side_named(0, "left", "LEFT_", rl, names[0]);
	start_side_named(1, "right", "RIGHT_", rr, names[1]);
}

static void start_pair(void)
{
	start_pair_named((const char *const[]){ "left", "right" });
}

/* Every motor of s: enable as given, torque 0 (torque mode needs no certain position). */
static void send_cmd(struct side *s, bool enable)
{
	rmd_motor_command_t mc[NMOT];
	rmd_command_t m = { .motor = mc, .count = NMOT, .controller = s->controller };

	memset(mc, 0, sizeof(mc));
	m.utime = rmd_now_ns() / 1000;
	m.seq = ++s->seq;
	for (int i = 0; i < NMOT; i++) {
		mc[i].index = (int16_t)i;
		mc[i].enable = enable;
		mc[i].mode = RMD_COMMAND_T_MODE_TORQUE;
	}
	assert_int_equal(rmd_command_t_publish(R.lcm, s->ch_cmd, &m), 0);
}

static unsigned count_of(const char *hay, const char *needle)
{
	unsigned n = 0;

	for (const char *p = hay; (p = strstr(p, needle)); p += strlen(needle))
		n++;
	return n;
}

static bool all_in(const struct side *s, int lc)
{
	if (!s->n_states)
		return false;
	for (int i = 0; i < NMOT; i++)
		if (s->lc[i] != lc)
			return false;
	return true;
}

/* Handle LCM and read the children for ms; a daemon that exits unasked fails the test. */
static void pump(int ms)
{
	int64_t end = rmd_now_ns() + ms * RMD_NS_PER_MS;

	do {
		lcm_handle_timeout(R.lcm, 5);
		for (unsigned i = 0; i < 2; i++)
			if (R.s[i].kid) {
				kid_read(R.s[i].kid);
				if (kid_poll_exit(R.s[i].kid))
					fail_msg("%s exited (%d):\n%s", R.s[i].inst,
						 R.s[i].kid->status, kid_tail(R.s[i].kid));
			}
	} while (rmd_now_ns() < end);
}

/* Stream enable to the running sides (20 ms apart) until done(), at most ms of held time. */
static bool drive_until(bool enable, int ms, bool (*done)(void))
{
	struct held_deadline d;

	held_deadline_start(&d, &ref, ms);
	while (!held_deadline_passed(&d)) {
		for (unsigned i = 0; i < 2; i++)
			if (R.s[i].kid)
				send_cmd(&R.s[i], enable);
		pump(20);
		if (done())
			return true;
	}
	return false;
}

static bool both_enabled(void)
{
	return all_in(&R.s[0], RMD_STATE_T_LC_ENABLED) && all_in(&R.s[1], RMD_STATE_T_LC_ENABLED);
}

static bool right_enabled(void)
{
	return all_in(&R.s[1], RMD_STATE_T_LC_ENABLED);
}

static bool both_safe(void)
{
	return R.s[0].safe_rx_ns && R.s[1].safe_rx_ns;
}

static bool right_safe(void)
{
	return R.s[1].safe_rx_ns != 0;
}

static bool peers_ok(void)
{
	for (unsigned i = 0; i < 2; i++) {
		const rmd_health_t *h = R.s[i].health;

		if (R.s[i].kid && (!h || h->robot != RMD_HEALTH_T_ROBOT_OK || h->n_peers < 1 ||
				   h->peer[0].status != RMD_ROBOT_PEER_T_PEER_OK))
			return false;
	}
	return true;
}

static bool never(void)
{
	return false;
}

/* Both up, each seeing the other, every motor ENABLED. */
static void pair_enabled(void)
{
	start_pair();
	if (!drive_until(false, 20000, peers_ok))
		fail_msg("the peers never saw each other:\nleft:\n%s\nright:\n%s",
			 kid_tail(R.s[0].kid), kid_tail(R.s[1].kid));
	if (!drive_until(true, 20000, both_enabled))
		fail_msg("motors not ENABLED:\nleft:\n%s\nright:\n%s", kid_tail(R.s[0].kid),
			 kid_tail(R.s[1].kid));
}

/* A test of the pair: skipped without multicast, else both up and driven. */
static void pair_or_skip(void)
{
	if (!multicast)
		skip();
	setup_url();
	pair_enabled();
}

static void test_kill_one_makes_the_other_safe(void **state)
{
	int64_t t0, took, held, bound;
	const rmd_health_t *h;

	(void)state;
	pair_or_skip();
	/* the start says what the daemon is a part of */
	assert_has(R.s[1].kid->out,
		   "robot: instance right, peers left; a heartbeat every 10 ms on "
		   "RMD_ROBOT_HEARTBEAT, a peer silent 100 ms is lost: the safe action",
		   "right's start");
	/* clocks: both state_t carry the host's clock, within a second of ours */
	assert_true(llabs(R.s[1].host_utime - (int64_t)time(NULL) * 1000000) < 2000000);

	sleeper_mark(&ref);
	R.s[1].safe_rx_ns = 0;
	t0 = rmd_now_ns();
	kill(R.s[0].kid->pid, SIGKILL);
	kid_free(R.s[0].kid);
	R.s[0].kid = NULL;
	if (!drive_until(true, 5000, right_safe))
		fail_msg("right's motors not SAFE after left was killed:\n%s",
			 kid_tail(R.s[1].kid));
	took = R.s[1].safe_rx_ns - t0;
	held = sleeper_held_off_ns(&ref);
	/* the timeout, the heartbeat tick that sees it, a cycle, the wire, and what the machine took */
	bound = (PEER_TIMEOUT_MS + 2 * HEARTBEAT_MS + 20) * RMD_NS_PER_MS + held;
	print_message("kill -9 left -> right's motors SAFE in its state_t: %.1f ms (bound %.1f ms: "
		      "peer_timeout_ms %d + 2 heartbeats + 20 ms + %.1f ms held off)\n",
		      took / 1e6, bound / 1e6, PEER_TIMEOUT_MS, held / 1e6);
	/* not before the timeout, counted from left's last heartbeat (up to a period or two before) */
	assert_true(took >= (PEER_TIMEOUT_MS - 2 * HEARTBEAT_MS) * RMD_NS_PER_MS);
	assert_true(took <= bound);
	kid_wait_output(R.s[1].kid, "robot: peer left (host ", 2000, NULL);
	assert_has(R.s[1].kid->out, "lost: no heartbeat for 100 ms: the safe action",
		   "right's log");
	pump(200);
	h = R.s[1].health;
	assert_non_null(h);
	assert_int_equal(h->robot, RMD_HEALTH_T_ROBOT_TRIPPED);
	assert_has(h->robot_reason, "peer left", "health_t robot_reason");
	assert_int_equal(h->peer[0].status, RMD_ROBOT_PEER_T_PEER_LOST);
	/* while the peer is gone, enabling again is refused: the robot is not whole */
	drive_until(false, 300, never);
	R.s[1].armed = false;
	drive_until(true, 500, never);
	assert_true(all_in(&R.s[1], RMD_STATE_T_LC_SAFE) || all_in(&R.s[1], RMD_STATE_T_LC_READY));
	assert_false(right_enabled());
	teardown_all();
}

static void test_robot_stop_stops_both(void **state)
{
	const char *args[] = { "stop",	   "--robot",	  "--lcm-url", R.url,
			       "--reason", "e-stop test", NULL };
	const struct run_opts o = { .service = pump };
	struct run r;
	int64_t t0;

	(void)state;
	pair_or_skip();
	R.s[0].safe_rx_ns = R.s[1].safe_rx_ns = 0;
	t0 = rmd_now_ns();
	run_prog(&r, rmdctl_bin, args, &o);
	assert_status(&r, 0, "rmdctl stop --robot");
	assert_has(r.out, "robot stop sent on RMD_ROBOT_STOP", "rmdctl's output");
	/* and it names both daemons as tripped, heard on their heartbeats */
	for (unsigned i = 0; i < 2; i++) {
		char line[128];

		snprintf(line, sizeof(line), "  %s (host ", R.s[i].inst);
		assert_has(r.out, line, "rmdctl's output");
	}
	assert_int_equal(count_of(r.out, "): tripped: robot stop from rmdctl@"), 2);
	run_free(&r);
	if (!drive_until(true, 3000, both_safe))
		fail_msg("not both SAFE after rmdctl stop --robot:\nleft:\n%s\nright:\n%s",
			 kid_tail(R.s[0].kid), kid_tail(R.s[1].kid));
	print_message("rmdctl stop --robot -> both SAFE: %.1f / %.1f ms after rmdctl started\n",
		      (R.s[0].safe_rx_ns - t0) / 1e6, (R.s[1].safe_rx_ns - t0) / 1e6);
	for (unsigned i = 0; i < 2; i++) {
		kid_wait_output(R.s[i].kid, "robot: robot stop from rmdctl@", 2000, NULL);
		assert_has(R.s[i].kid->out, "e-stop test: the safe action", R.s[i].inst);
		/* rmdctl sends it three times: said once */
		assert_int_equal(count_of(R.s[i].kid->out, "robot stop from rmdctl@"), 1);
	}
	pump(150);
	for (unsigned i = 0; i < 2; i++) {
		assert_non_null(R.s[i].health);
		assert_true(R.s[i].health->robot_stops >= 1);
		assert_has(R.s[i].health->robot_reason, "robot stop from rmdctl@",
			   "health_t robot_reason");
	}
	/* enabling again is each controller's enable: 0, then 1 */
	drive_until(false, 200, never);
	if (!drive_until(true, 5000, both_enabled))
		fail_msg("not enabled again after the robot stop:\nleft:\n%s\nright:\n%s",
			 kid_tail(R.s[0].kid), kid_tail(R.s[1].kid));
	/* the stop's own time: one robot_stop_t from here to both state_t SAFE */
	{
		rmd_robot_stop_t s = { .who = "test", .reason = "timed", .t_ns = 0 };
		int64_t took, held, bound;

		R.s[0].safe_rx_ns = R.s[1].safe_rx_ns = 0;
		sleeper_mark(&ref);
		t0 = rmd_now_ns();
		assert_int_equal(rmd_robot_stop_t_publish(R.lcm, RMD_CHANNEL_ROBOT_STOP, &s), 0);
		if (!drive_until(true, 3000, both_safe))
			fail_msg("not both SAFE after one robot_stop_t");
		took = (R.s[0].safe_rx_ns > R.s[1].safe_rx_ns ? R.s[0].safe_rx_ns :
								R.s[1].safe_rx_ns) -
		       t0;
		held = sleeper_held_off_ns(&ref);
		/* two loop periods (500 Hz), the wire both ways, and what the machine took */
		bound = 4 * RMD_NS_PER_MS + 20 * RMD_NS_PER_MS + held;
		print_message("robot_stop_t -> both daemons' state_t SAFE: %.2f ms (bound %.1f ms, "
			      "%.1f ms held off)\n",
			      took / 1e6, bound / 1e6, held / 1e6);
		assert_true(took <= bound);
	}
	teardown_all();
}

/* A heartbeat_t as another process would send it, of instance inst from host, t_ns ahead. */
static void send_heartbeat(const char *inst, const char *host, int64_t boot, int64_t seq,
			   int64_t ahead_ns)
{
	struct timespec ts;
	rmd_heartbeat_t hb = { .instance = (char *)inst,
			       .host = (char *)host,
			       .pid = 4242,
			       .boot_id = boot,
			       .prefix = "EVIL_",
			       .seq = seq,
			       .period_ms = HEARTBEAT_MS,
			       .timeout_ms = PEER_TIMEOUT_MS,
			       .reason = "" };

	clock_gettime(CLOCK_REALTIME, &ts);
	hb.t_ns = rmd_timespec_ns(&ts) + ahead_ns;
	assert_int_equal(rmd_heartbeat_t_publish(R.lcm, RMD_CHANNEL_ROBOT_HEARTBEAT, &hb), 0);
}

static void test_spoofed_heartbeats_change_nothing(void **state)
{
	const rmd_health_t *h;

	(void)state;
	pair_or_skip();
	pump(100);
	R.s[0].armed = R.s[1].armed = true;
	/* 300 ms: the peer's name from elsewhere, the daemon's own name, a stranger */
	for (int k = 0; k < 30; k++) {
		send_heartbeat("left", "evil", 42, 1000 + k, 0);
		send_heartbeat("right", "evil", 43, 1000 + k, 0);
		send_heartbeat("stranger", "evil", 44, k, 0);
		send_cmd(&R.s[0], true);
		send_cmd(&R.s[1], true);
		pump(10);
	}
	pump(150);
	for (unsigned i = 0; i < 2; i++) {
		send_cmd(&R.s[i], true);
		if (R.s[i].left_enabled)
			fail_msg("%s: a motor left ENABLED during the spoofs:\n%s", R.s[i].inst,
				 kid_tail(R.s[i].kid));
		h = R.s[i].health;
		assert_non_null(h);
		assert_int_equal(h->robot, RMD_HEALTH_T_ROBOT_OK);
		assert_true(h->spoofs >= 30);
		assert_true(h->unknown_senders >= 30);
		assert_int_equal(h->peer[0].status, RMD_ROBOT_PEER_T_PEER_OK);
		assert_int_equal(h->robot_stops, 0);
		assert_has(R.s[i].kid->out, "robot: heartbeat from \"stranger\" (host evil",
			   R.s[i].inst);
		assert_int_equal(count_of(R.s[i].kid->out, "heartbeat from \"stranger\""), 1);
	}
	assert_has(R.s[1].kid->out, "heartbeat naming peer \"left\" from host evil", "right");
	assert_has(R.s[0].kid->out, "heartbeat naming peer \"right\" from host evil", "left");
	/* its own name from elsewhere: a duplicate instance on the network */
	assert_has(R.s[1].kid->out,
		   "heartbeat naming this daemon, \"right\" from host evil, pid 4242: another "
		   "daemon uses this instance name (duplicate robot.instance on the network)",
		   "right");
	teardown_all();
}

static bool right_ready_or_enabled(void)
{
	return R.s[1].health && R.s[1].health->n_peers == 1 &&
	       R.s[1].health->peer[0].status == RMD_ROBOT_PEER_T_PEER_OK;
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
		 HEARTBEAT_MS);
	start_side(1, "right", "RIGHT_", robot);
	/* the fake peer 500 ms ahead: within max_clock_offset_ms */
	held_deadline_start(&d, &ref, 20000);
	while (!right_enabled() && !held_deadline_passed(&d)) {
		send_heartbeat("fake", "faker", 7, seq++, 500 * RMD_NS_PER_MS);
		send_cmd(&R.s[1], right_ready_or_enabled());
		pump(20);
	}
	if (!right_enabled())
		fail_msg("not enabled beside a peer 500 ms ahead:\n%s", kid_tail(R.s[1].kid));
	R.s[1].armed = true;
	for (int k = 0; k < 20; k++) {
		send_heartbeat("fake", "faker", 7, seq++, 500 * RMD_NS_PER_MS);
		send_cmd(&R.s[1], true);
		pump(20);
	}
	assert_false(R.s[1].left_enabled);
	assert_has(R.s[1].kid->out, "robot: peer fake: its clock differs from this host's by 5",
		   "right's log");
	assert_int_equal(count_of(R.s[1].kid->out, "its clock differs"), 1);
	/* an hour ahead: its states cannot be compared with ours */
	R.s[1].safe_rx_ns = 0;
	for (int k = 0; k < 100 && !R.s[1].safe_rx_ns; k++) {
		send_heartbeat("fake", "faker", 7, seq++, 3600 * RMD_NS_PER_S);
		send_cmd(&R.s[1], true);
		pump(20);
	}
	if (!R.s[1].safe_rx_ns)
		fail_msg("not SAFE beside a peer an hour ahead:\n%s", kid_tail(R.s[1].kid));
	kid_wait_output(R.s[1].kid,
			"differs from this host's by more than robot.max_clock_offset_ms", 2000,
			NULL);
	/* with every heartbeat, but said once */
	for (int k = 0; k < 10; k++) {
		send_heartbeat("fake", "faker", 7, seq++, 3600 * RMD_NS_PER_S);
		pump(20);
	}
	assert_int_equal(count_of(R.s[1].kid->out, "by more than robot.max_clock_offset_ms"), 1);
	teardown_all();
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
		 HEARTBEAT_MS, PEER_TIMEOUT_MS);
	snprintf(rr, sizeof(rr),
		 "robot: {instance: right, peers: [left], heartbeat_ms: %d, peer_timeout_ms: %d}\n",
		 HEARTBEAT_MS, PEER_TIMEOUT_MS);
	start_side(0, "left", "LEFT_", rl);
	start_side(1, "right", "RIGHT_", rr);
	held_deadline_start(&d, &ref, 20000);
	while (!both_enabled() && !held_deadline_passed(&d)) {
		send_heartbeat("ghost", "ghosthost", 9, seq++, 0);
		send_cmd(&R.s[0], peers_ok());
		send_cmd(&R.s[1], peers_ok());
		pump(HEARTBEAT_MS);
	}
	if (!both_enabled())
		fail_msg("not both ENABLED beside ghost:\nleft:\n%s\nright:\n%s",
			 kid_tail(R.s[0].kid), kid_tail(R.s[1].kid));
	/* ghost falls silent; the controllers drive on */
	sleeper_mark(&ref);
	R.s[0].safe_rx_ns = R.s[1].safe_rx_ns = 0;
	t0 = rmd_now_ns();
	if (!drive_until(true, 5000, both_safe))
		fail_msg("not both SAFE after ghost went silent (right %s):\nleft:\n%s\nright:\n%s",
			 R.s[1].safe_rx_ns ? "SAFE" : "still driven", kid_tail(R.s[0].kid),
			 kid_tail(R.s[1].kid));
	took = R.s[1].safe_rx_ns - t0;
	held = sleeper_held_off_ns(&ref);
	/* left's timeout and the tick that sees it, then one heartbeat of left's to right */
	bound = (PEER_TIMEOUT_MS + 3 * HEARTBEAT_MS + 20) * RMD_NS_PER_MS + held;
	print_message("ghost silent -> left SAFE %.1f ms, right SAFE %.1f ms (bound %.1f ms)\n",
		      (R.s[0].safe_rx_ns - t0) / 1e6, took / 1e6, bound / 1e6);
	assert_true(took <= bound);
	kid_wait_output(R.s[1].kid, "robot: peer left tripped: peer ghost", 2000, NULL);
	pump(200);
	h = R.s[1].health;
	assert_non_null(h);
	assert_int_equal(h->robot, RMD_HEALTH_T_ROBOT_TRIPPED);
	assert_has(h->robot_reason, "peer left tripped: peer ghost", "right's robot_reason");
	/* and it does not echo: left took no trip back from right's */
	assert_int_equal(count_of(R.s[0].kid->out, "peer right tripped"), 0);
	teardown_all();
}

/* Both daemons name their motors leg_hip and leg_knee: both say so; nothing else changes. */
static void test_motor_names_clash_reported_by_both(void **state)
{
	(void)state;
	if (!multicast)
		skip();
	setup_url();
	start_pair_named((const char *const[]){ "leg", "leg" });
	if (!drive_until(false, 20000, peers_ok))
		fail_msg("the peers never saw each other");
	for (unsigned i = 0; i < 2; i++)
		kid_wait_output(R.s[i].kid, "robot: 2 motor name(s) of this daemon are peer ", 5000,
				NULL);
	assert_has(R.s[0].kid->out, "are peer right's too (\"leg_hip\"...)", "left");
	assert_has(R.s[1].kid->out, "are peer left's too (\"leg_hip\"...)", "right");
	pump(150);
	for (unsigned i = 0; i < 2; i++) {
		assert_non_null(R.s[i].health);
		assert_int_equal(R.s[i].health->name_clashes, 2);
	}
	teardown_all();
}

static void test_alone_as_before(void **state)
{
	const char *args[] = { "stop", "--robot", "--lcm-url", R.url, NULL };
	const struct run_opts o = { .service = pump };
	struct run r;

	(void)state;
	if (!multicast)
		skip();
	setup_url();
	start_side(1, "alone", "RMD_", "");
	if (!drive_until(true, 20000, right_enabled))
		fail_msg("not enabled:\n%s", kid_tail(R.s[1].kid));
	R.s[1].armed = true;
	R.heartbeats = 0;
	run_prog(&r, rmdctl_bin, args, &o);
	/* sent, and said to have reached no one: a daemon alone takes no robot stop */
	assert_status(&r, 1, "rmdctl stop --robot");
	assert_has(r.err, "no rmdd of a robot heard within 300 ms: nothing confirmed the stop",
		   "rmdctl's errors");
	run_free(&r);
	drive_until(true, 300, never);
	assert_false(R.s[1].left_enabled);
	assert_int_equal(R.heartbeats, 0);
	assert_non_null(R.s[1].health);
	assert_int_equal(R.s[1].health->robot, RMD_HEALTH_T_ROBOT_NONE);
	assert_int_equal(R.s[1].health->n_peers, 0);
	assert_lacks(R.s[1].kid->out, "robot:", "a daemon alone");
	teardown_all();
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
