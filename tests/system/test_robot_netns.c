// SPDX-License-Identifier: MIT
/*
 * Several rmdd as one robot across separate machines (issue 30 point 6,
 * docs/robot.md): each PC a network namespace on one bridge
 * (tests/harness/netns.h), LCM udpm with ttl=1 across it.  rmdd "left"
 * (robot PC A) in namespace a, rmdd "right" (B) in b, each the other's
 * peer, on sim buses whose wires are tapped (sim: {tap: FILE}); the test is
 * their controller in namespace c, and a spoofer in d.  Every safe action
 * is judged on the daemon's wire, not only in its state_t: the tap shows the brake
 * safe action (0x80 output off, 0x78 brake locked, docs/lcm.md) to each
 * motor and no torque setpoint (0xA1) after it, while the controller keeps
 * streaming them (the tap read once the daemon ended on SIGTERM, up to that
 * instant), timed by the tap's own stamps (CLOCK_MONOTONIC, one clock for
 * every namespace).
 *
 *   test_kill_a_makes_b_safe  kill -9 of A: B's motors SAFE within
 *                         peer_timeout_ms + 2 heartbeats + 20 ms + what the
 *                         machine held the test off; its health_t says why
 *   test_robot_stop_from_c_stops_both  `rmdctl stop --robot` run in c: both
 *                         daemons' motors SAFE, each within rmdctl's own run
 *                         + 2 loop periods + 20 ms + held off; both wires
 *   test_loss_ridden_out_silence_trips  30 % loss into b for 10 s with
 *                         peer_timeout_ms 250 (LOSS_PCT): no trip; then
 *                         100 % (a real silence): SAFE within the bound
 *   test_spoofer_changes_nothing  heartbeats from d claiming A's name (from
 *                         another host, and from A's host as a second
 *                         process) and a stranger's: B's motors stay
 *                         ENABLED, setpoints keep flowing on its wire, its
 *                         health_t counts them and its log says so
 *   test_kill_a_beside_a_cpu_hog  the first again beside `stress-ng --cpu 2`
 *                         started after bring-up
 *
 * Each test's teardown leaves no namespace in `ip netns list`.  Needs root,
 * ip and nft, and no CAN: without them every test skips saying why.
 * RMD_TEST_FILTER=test_loss runs one test.
 */
#define _GNU_SOURCE
#include <limits.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "harness/lcm_loopback.h"
#include "harness/netns.h"
#include "harness/proc.h"
#include "harness/robot_pair.h"
#include "harness/sleeper.h"
#include "harness/suite.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

#define BASE_PORT 34000 /* + (pid % 100) * 40 + test: 34000..38039 */
#define PIDS 100
#define HOST_A 0
#define HOST_B 1
#define HOST_C 2
#define HOST_D 3
#define LEFT 0
#define RIGHT 1
/*
 * Loss into b: each heartbeat (one datagram) lost at random with p = 0.3.
 * A trip needs a silence of peer_timeout_ms, i.e. at least
 * peer_timeout_ms / heartbeat_ms - 1 heartbeats lost in a row (one period
 * of jitter granted).  With 100 ms that is 9: 0.3^9 = 2.0e-5 per start, and
 * 10 s hold ~1000 starts: a false trip in 2 % of runs.  With 250 ms it is
 * 24: 0.3^24 = 2.8e-13, times 1000 = 2.8e-10 per run (< 1e-6).
 */
#define LOSS_PCT 30
#define LOSS_TIMEOUT_MS 250
#define LOSS_HOLD_MS 10000

static char rmdctl_bin[PATH_MAX];
static const char *skip_why;
static bool multicast; /* on loopback: not this suite's (its multicast crosses the bridge) */
static unsigned test_no;
static struct netns_net net;

static int group_setup(void **state)
{
	(void)state;
	skip_why = netns_unavailable();
	if (skip_why) {
		fprintf(stderr, "\n*** test_robot_netns: SKIPPING every test: %s\n\n", skip_why);
		return 0;
	}
	return robot_pair_group_setup("test_robot_netns", rmdctl_bin, &multicast);
}

static int group_teardown(void **state)
{
	if (skip_why)
		return 0;
	return robot_pair_group_teardown(state);
}

/* Hosts a, b, c, d; rp's daemons in a and b, its controller in c; both wires tapped. */
static int setup(void **state)
{
	static const char *const hosts[] = { "a", "b", "c", "d" };
	char url[128];

	(void)state;
	if (skip_why)
		return 0;
	if (netns_net_up(&net, hosts, 4) < 0)
		return -1;
	rp.net = &net;
	rp.ctl_host = HOST_C;
	rp.host[LEFT] = HOST_A;
	rp.host[RIGHT] = HOST_B;
	rp.safe_action = "brake";
	rp.peer_timeout_ms = 0;
	lcm_test_url_ttl(url, sizeof(url), BASE_PORT, PIDS, test_no, 1);
	robot_pair_url(url);
	for (unsigned i = 0; i < 2; i++)
		snprintf(rp.s[i].tap, sizeof(rp.s[i].tap), "%s/tap.%u.%u.log", rp.dir, test_no, i);
	test_no++;
	return 0;
}

static int teardown(void **state)
{
	char prefix[32], listed[1024];

	(void)state;
	if (skip_why)
		return 0;
	robot_pair_teardown();
	kid_kill_all();
	netns_net_down(&net);
	snprintf(prefix, sizeof(prefix), "rmdt-%ld-", (long)getpid());
	if (netns_listed(prefix, listed, sizeof(listed))) {
		fprintf(stderr, "still in `ip netns list` after the test:\n%s", listed);
		return -1;
	}
	return 0;
}

static void skip_unless_able(void)
{
	if (skip_why) {
		fprintf(stderr, "SKIP: %s\n", skip_why);
		skip();
	}
}

/* What a motor's wire tap shows, from a line on (rmdd's frames only: " T"). */
struct wire {
	unsigned setpoints_before; /* torque setpoints (0xA1) before line `from` */
	unsigned setpoints;	   /* from it on, before its 0x80 */
	bool off, brake;	   /* from it on: 0x80 (output off), 0x78 (brake locked) */
	int64_t off_ns;		   /* the 0x80's time on the wire (the tap's CLOCK_MONOTONIC) */
	unsigned setpoints_after;  /* 0xA1 after the 0x80 */
};

static char tap_buf[32 << 20];

/* Lines in rmdd's wire tap at path so far. */
static unsigned tap_lines(const char *path)
{
	return (unsigned)count_lines(file_text(path, tap_buf, sizeof(tap_buf)));
}

/* A tap line's stamp, ns of CLOCK_MONOTONIC ("(SEC.USEC) ..."); 0 if it has none. */
static int64_t tap_stamp_ns(const char *l)
{
	long long sec, usec;

	return sscanf(l, "(%lld.%6lld)", &sec, &usec) == 2 ? sec * RMD_NS_PER_S + usec * 1000 : 0;
}

/* Motor id's frames on the wire tap at path, with line `from` the mark, stamped before until_ns (0: all). */
static struct wire tap_scan(const char *path, unsigned from, unsigned id, int64_t until_ns)
{
	const char *p = file_text(path, tap_buf, sizeof(tap_buf));
	char off[16], brake[16], setpoint[16];
	struct wire w = { 0 };

	snprintf(off, sizeof(off), " 14%u#80", id);
	snprintf(brake, sizeof(brake), " 14%u#78", id);
	snprintf(setpoint, sizeof(setpoint), " 14%u#A1", id);
	for (unsigned line = 0; *p; line++) {
		const char *nl = strchr(p, '\n');
		char l[128];

		snprintf(l, sizeof(l), "%.*s", nl ? (int)(nl - p) : (int)strlen(p), p);
		p = nl ? nl + 1 : p + strlen(p);
		if (!strstr(l, " T"))
			continue;
		if (until_ns && tap_stamp_ns(l) >= until_ns)
			break;
		if (line >= from && strstr(l, brake))
			w.brake = true; /* in the same cycle as the 0x80, either order */
		if (line >= from && !w.off && strstr(l, off)) {
			w.off = true;
			w.off_ns = tap_stamp_ns(l);
		} else if (strstr(l, setpoint)) {
			*(w.off	      ? &w.setpoints_after :
			  line < from ? &w.setpoints_before :
					&w.setpoints) += 1;
		}
	}
	return w;
}

/*
 * SIGTERM to daemon i, waited for: its tap is written whole at exit.  When
 * it was sent (what its shutdown sent after is its own, not a stop's).
 */
static int64_t end_daemon(unsigned i)
{
	struct robot_side *s = &rp.s[i];
	int64_t end_ns = rmd_now_ns();

	assert_int_equal(kill(s->kid->pid, SIGTERM), 0);
	kid_wait_exit(s->kid, 10000, NULL);
	kid_free(s->kid);
	s->kid = NULL;
	return end_ns;
}

/*
 * On daemon i's tap, from line `from` on: each motor (id 1, 2) sent the
 * brake safe action (0x80 and 0x78) and no torque setpoint (0xA1) after
 * its 0x80, and setpoints were flowing before the mark (the check can
 * fail).  rmdd writes its tap a PIPE_BUF at a time, and after the safe
 * action its wire is quiet (status reads): the daemon is ended
 * (end_daemon()) and what its shutdown sent after that instant is not
 * looked at.  The controller streams setpoints until
 * then.  Fails naming what is missing; else when the later 0x80 was on
 * the wire.
 */
static int64_t assert_wire_safe(unsigned i, unsigned from, const char *who)
{
	struct robot_side *s = &rp.s[i];
	int64_t end_ns, last_ns = 0;

	robot_drive_until(true, 200, robot_never);
	end_ns = end_daemon(i);
	for (unsigned id = 1; id <= RP_NMOT; id++) {
		struct wire w = tap_scan(s->tap, from, id, end_ns);

		if (w.setpoints_before < 50)
			fail_msg("%s: motor %u: only %u torque setpoints (0xA1) on the wire before "
				 "the stop (%s)",
				 who, id, w.setpoints_before, s->tap);
		if (!w.off || !w.brake) {
			/* what the wire had, to tell a missing frame from a late one */
			const char *p = file_text(s->tap, tap_buf, sizeof(tap_buf));
			char needle[8];
			unsigned line = 0, shown = 0;

			snprintf(needle, sizeof(needle), " 14%u#", id);
			fprintf(stderr, "%s: motor %u's frames from line %u (end at %.6f s):\n",
				who, id, from, end_ns / 1e9);
			for (; *p && shown < 40; line++) {
				const char *nl = strchr(p, '\n');
				int len = nl ? (int)(nl - p) : (int)strlen(p);

				if (line >= from &&
				    memmem(p, (size_t)len, needle, strlen(needle))) {
					fprintf(stderr, "  %.*s\n", len, p);
					shown++;
				}
				p = nl ? nl + 1 : p + len;
			}
			fail_msg("%s: motor %u: no %s on the wire after line %u (%s)", who, id,
				 w.off ? "0x78 (brake locked)" : "0x80 (output off)", from, s->tap);
		}
		if (w.setpoints_after)
			fail_msg("%s: motor %u: %u torque setpoints (0xA1) on the wire after its "
				 "safe action (%s)",
				 who, id, w.setpoints_after, s->tap);
		if (w.off_ns > last_ns)
			last_ns = w.off_ns;
	}
	return last_ns;
}

/*
 * A silence of A began (in B's ears) between t_began and t0, B's tap at
 * line from:
 * B's motors SAFE, judged on B's wire, within timeout_ms + the heartbeat
 * tick that sees it + a cycle + 20 ms + what the machine held the test off
 * since the mark, and not before the timeout (counted from A's last
 * heartbeat, up to a period or two before t0).  The controller streams on
 * meanwhile: no setpoint of it reaches B's motors after the safe action.
 */
static void judge_silence(const char *what, int timeout_ms, int64_t t_began, int64_t t0,
			  unsigned from)
{
	int64_t on_wire, held, bound;
	char why[64];

	if (!robot_drive_until(true, 5000, robot_right_safe))
		fail_msg("B's motors not SAFE after %s:\n%s", what, kid_tail(rp.s[RIGHT].kid));
	held = sleeper_held_off_ns(rp.ref);
	snprintf(why, sizeof(why), "lost: no heartbeat for %d ms: the safe action", timeout_ms);
	kid_wait_output(rp.s[RIGHT].kid, why, 2000, NULL);
	assert_has(rp.s[RIGHT].kid->out, "robot: peer left (host ", "B's log");
	robot_pump(100);
	assert_non_null(rp.s[RIGHT].health);
	assert_int_equal(rp.s[RIGHT].health->robot, RMD_HEALTH_T_ROBOT_TRIPPED);
	assert_has(rp.s[RIGHT].health->robot_reason, "peer left", "B's health_t robot_reason");
	assert_int_equal(rp.s[RIGHT].health->peer[0].status, RMD_ROBOT_PEER_T_PEER_LOST);
	snprintf(why, sizeof(why), "B after %s", what);
	on_wire = assert_wire_safe(RIGHT, from, why) - t0;
	bound = (timeout_ms + 2 * RP_HEARTBEAT_MS + 20) * RMD_NS_PER_MS + held;
	print_message("%s -> B's safe action on its wire %.1f ms, its state_t SAFE in c %.1f ms "
		      "(bound %.1f ms: peer_timeout_ms %d + 2 heartbeats + 20 ms + %.1f ms held "
		      "off)\n",
		      what, on_wire / 1e6, (rp.s[RIGHT].safe_rx_ns - t0) / 1e6, bound / 1e6,
		      timeout_ms, held / 1e6);
	assert_true(on_wire + (t0 - t_began) >= (timeout_ms - 2 * RP_HEARTBEAT_MS) * RMD_NS_PER_MS);
	assert_true(on_wire <= bound);
}

/* kill -9 of A (the pair driven): judge_silence(). */
static void kill_a_judged(bool hog)
{
	const char *hog_argv[] = { "stress-ng", "--cpu", "2", "--timeout", "120", NULL };
	unsigned from;
	int64_t t0;

	robot_pair_enabled();
	if (hog) {
		assert_non_null(kid_spawn("stress-ng", hog_argv, NULL, 0));
		robot_drive_until(true, 1000, robot_never);
	}
	robot_drive_until(true, 300, robot_never);
	from = tap_lines(rp.s[RIGHT].tap);
	sleeper_mark(rp.ref);
	rp.s[RIGHT].safe_rx_ns = 0;
	t0 = rmd_now_ns();
	kill(rp.s[LEFT].kid->pid, SIGKILL);
	kid_free(rp.s[LEFT].kid);
	rp.s[LEFT].kid = NULL;
	judge_silence(hog ? "kill -9 of A beside stress-ng --cpu 2" : "kill -9 of A",
		      RP_PEER_TIMEOUT_MS, t0, t0, from);
}

static void test_kill_a_makes_b_safe(void **state)
{
	(void)state;
	skip_unless_able();
	kill_a_judged(false);
}

static void test_kill_a_beside_a_cpu_hog(void **state)
{
	(void)state;
	skip_unless_able();
	kill_a_judged(true);
}

static void test_robot_stop_from_c_stops_both(void **state)
{
	const char *args[] = { "stop",	   "--robot",	   "--lcm-url", rp.url,
			       "--reason", "netns e-stop", NULL };
	const struct run_opts o = { .service = robot_pump };
	unsigned from[2];
	int64_t t0, ran, held;
	struct run r;

	(void)state;
	skip_unless_able();
	robot_pair_enabled();
	robot_drive_until(true, 300, robot_never);
	for (unsigned i = 0; i < 2; i++) {
		from[i] = tap_lines(rp.s[i].tap);
		rp.s[i].safe_rx_ns = 0;
	}
	sleeper_mark(rp.ref);
	assert_int_equal(netns_enter(&net, HOST_C), 0);
	t0 = rmd_now_ns();
	run_prog(&r, rmdctl_bin, args, &o);
	ran = rmd_now_ns() - t0;
	assert_int_equal(netns_leave(), 0);
	assert_status(&r, 0, "rmdctl stop --robot in c");
	assert_has(r.out, "robot stop sent on RMD_ROBOT_STOP", "rmdctl's output");
	run_free(&r);
	if (!robot_drive_until(true, 3000, robot_both_safe))
		fail_msg("not both SAFE after rmdctl stop --robot in c:\nA:\n%s\nB:\n%s",
			 kid_tail(rp.s[LEFT].kid), kid_tail(rp.s[RIGHT].kid));
	held = sleeper_held_off_ns(rp.ref);
	robot_pump(100);
	for (unsigned i = 0; i < 2; i++) {
		kid_wait_output(rp.s[i].kid, "robot: robot stop from rmdctl@", 2000, NULL);
		assert_has(rp.s[i].kid->out, "netns e-stop: the safe action", rp.s[i].inst);
		assert_non_null(rp.s[i].health);
		assert_true(rp.s[i].health->robot_stops >= 1);
	}
	for (unsigned i = 0; i < 2; i++) {
		const char *who = i == LEFT ? "A" : "B";
		/* judged on each wire: rmdctl's own run (it sends its first stop before it exits), two loop periods at 500 Hz, 20 ms */
		int64_t on_wire = assert_wire_safe(i, from[i], who) - t0,
			bound = ran + 24 * RMD_NS_PER_MS + held;

		print_message(
			"rmdctl stop --robot (ns c) -> %s's safe action on its wire %.1f ms, "
			"its state_t SAFE in c %.1f ms after rmdctl started (bound %.1f ms: its "
			"run %.1f ms + 2 loop periods + 20 ms + %.1f ms held off)\n",
			who, on_wire / 1e6, (rp.s[i].safe_rx_ns - t0) / 1e6, bound / 1e6, ran / 1e6,
			held / 1e6);
		assert_true(on_wire > 0 && on_wire <= bound);
	}
}

static void test_loss_ridden_out_silence_trips(void **state)
{
	int64_t t_began, t0;
	const rmd_health_t *h;
	unsigned from;

	(void)state;
	skip_unless_able();
	rp.peer_timeout_ms = LOSS_TIMEOUT_MS;
	robot_pair_enabled();
	assert_int_equal(netns_loss(&net, HOST_B, LOSS_PCT), 0);
	rp.s[RIGHT].armed = true;
	robot_drive_until(true, LOSS_HOLD_MS, robot_never);
	h = rp.s[RIGHT].health;
	assert_non_null(h);
	if (rp.s[RIGHT].left_enabled || h->robot != RMD_HEALTH_T_ROBOT_OK)
		fail_msg("B tripped under %d %% loss with peer_timeout_ms %d (robot %d: %s):\n%s",
			 LOSS_PCT, LOSS_TIMEOUT_MS, h->robot, h->robot_reason,
			 kid_tail(rp.s[RIGHT].kid));
	assert_int_equal(h->peer[0].status, RMD_ROBOT_PEER_T_PEER_OK);
	assert_lacks(rp.s[RIGHT].kid->out, "lost: no heartbeat", "B's log under loss");
	print_message("%d %% loss into b for %.0f s, peer_timeout_ms %d: B drove on\n", LOSS_PCT,
		      LOSS_HOLD_MS / 1e3, LOSS_TIMEOUT_MS);

	/* a real silence */
	from = tap_lines(rp.s[RIGHT].tap);
	rp.s[RIGHT].armed = false;
	rp.s[RIGHT].safe_rx_ns = 0;
	sleeper_mark(rp.ref);
	t_began = rmd_now_ns();
	assert_int_equal(netns_loss(&net, HOST_B, 100), 0);
	t0 = rmd_now_ns(); /* the rule holds from nft's commit, before it exits */
	judge_silence("100 % loss into b", LOSS_TIMEOUT_MS, t_began, t0, from);
}

static bool spoofs_counted(void)
{
	const rmd_health_t *h = rp.s[RIGHT].health;

	return h && h->spoofs >= 60 && h->unknown_senders >= 30;
}

static void test_spoofer_changes_nothing(void **state)
{
	char host[256] = "";
	const rmd_health_t *h;
	int64_t t_spoof, end_ns;
	lcm_t *spoofer;
	unsigned from;

	(void)state;
	skip_unless_able();
	robot_pair_enabled();
	assert_int_equal(gethostname(host, sizeof(host) - 1), 0);
	assert_int_equal(netns_enter(&net, HOST_D), 0);
	spoofer = lcm_create(rp.url);
	assert_int_equal(netns_leave(), 0);
	assert_non_null(spoofer);
	robot_pump(100);
	from = tap_lines(rp.s[RIGHT].tap);
	t_spoof = rmd_now_ns();
	rp.s[RIGHT].armed = true;
	/* 300 ms: A's name from another host and from A's host (a second process), a stranger */
	for (int k = 0; k < 30; k++) {
		robot_send_heartbeat(spoofer, "left", "pc-d", 42, 1000 + k, 0);
		robot_send_heartbeat(spoofer, "left", host, 43, 100000 + k, 0);
		robot_send_heartbeat(spoofer, "stranger", "pc-d", 44, k, 0);
		robot_send_cmd(&rp.s[LEFT], true);
		robot_send_cmd(&rp.s[RIGHT], true);
		robot_pump(10);
	}
	robot_drive_until(true, 150, robot_never);
	lcm_destroy(spoofer);
	if (rp.s[RIGHT].left_enabled)
		fail_msg("B: a motor left ENABLED during the spoofs:\n%s",
			 kid_tail(rp.s[RIGHT].kid));
	/* every spoof B took is counted: 60 naming A, 30 of the stranger (UDP may drop a few under load) */
	robot_drive_until(true, 1000, spoofs_counted);
	h = rp.s[RIGHT].health;
	assert_non_null(h);
	assert_int_equal(h->robot, RMD_HEALTH_T_ROBOT_OK);
	print_message("spoofer in d: B's health_t: spoofs %lld, unknown_senders %lld\n",
		      (long long)h->spoofs, (long long)h->unknown_senders);
	assert_true(h->spoofs >= 30);
	assert_true(h->unknown_senders >= 15);
	assert_int_equal(h->peer[0].status, RMD_ROBOT_PEER_T_PEER_OK);
	assert_int_equal(h->robot_stops, 0);
	assert_false(rp.s[RIGHT].left_enabled);
	assert_has(rp.s[RIGHT].kid->out, "robot: heartbeat from \"stranger\" (host pc-d",
		   "B's log");
	assert_has(rp.s[RIGHT].kid->out, "heartbeat naming peer \"left\" from host pc-d",
		   "B's log");
	/* its wire, written whole once it ends: setpoints kept flowing to both motors, no safe action */
	end_ns = end_daemon(RIGHT);
	for (unsigned id = 1; id <= RP_NMOT; id++) {
		struct wire w = tap_scan(rp.s[RIGHT].tap, from, id, end_ns);

		print_message("spoofer in d: B's wire to motor %u: %u setpoints (0xA1), %s 0x80, "
			      "in the %.0f ms from the first spoof to its end\n",
			      id, w.setpoints, w.off ? "a" : "no", (end_ns - t_spoof) / 1e6);
		assert_false(w.off);
		assert_true(w.setpoints > 100);
	}
}

SUITE_MAIN_FIXTURE("robot_netns", setup, teardown, group_setup, group_teardown,
		   {
			   cmocka_unit_test(test_kill_a_makes_b_safe),
			   cmocka_unit_test(test_robot_stop_from_c_stops_both),
			   cmocka_unit_test(test_loss_ridden_out_silence_trips),
			   cmocka_unit_test(test_spoofer_changes_nothing),
			   cmocka_unit_test(test_kill_a_beside_a_cpu_hog),
		   })
