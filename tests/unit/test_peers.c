// SPDX-License-Identifier: MIT
/*
 * The peers of one daemon of a robot (rmd/peers.h, docs/robot.md), from
 * heartbeats built here, on times given here:
 *
 *   test_first_lost_back         a peer seen, lost past the timeout (not
 *                                before), back with its next heartbeat
 *   test_unknown_sender          not in robot.peers: ignored, counted,
 *                                reported once per name
 *   test_spoofs                  a peer's name from another host, or from
 *                                another process while it lives; this
 *                                daemon's own name from elsewhere; its own
 *                                looped back is not a spoof
 *   test_self_never_a_peer       robot.peers naming the daemon itself (which
 *                                the loader refuses) never makes a peer
 *   test_offset_from_echo        NTP's four stamps: the offset and round trip
 *                                of two clocks 5 ms apart, 100 us of wire
 *   test_forged_echo_moves_nothing an echo of a heartbeat we never sent
 *   test_clock_warn_and_trip     off by 50 ms: warned once; beyond
 *                                max_clock_offset_ms, or no clock: a trip
 *   test_trips_followed          a peer's watchdog trips count that grows
 *                                is a trip; the one it came with is not
 *   test_stale_and_stopping      a repeated seq is dropped; a peer that says
 *                                it stops is LOST at once
 *   test_echoes_and_report       what our heartbeat echoes, what health_t says
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/peers.h"
#include "harness/suite.h"

#define MS RMD_NS_PER_MS
#define T0_REAL (INT64_C(1780000000) * RMD_NS_PER_S) /* a wall clock in 2026 */

static struct rmd_config_robot robot_cfg(const char *self, const char *p0, const char *p1)
{
	struct rmd_config_robot c = { .heartbeat_ms = 10,
				      .peer_timeout_ms = 100,
				      .max_clock_offset_ms = 1000 };

	snprintf(c.instance, sizeof(c.instance), "%s", self);
	if (p0)
		snprintf(c.peers[c.n_peers++], sizeof(c.peers[0]), "%s", p0);
	if (p1)
		snprintf(c.peers[c.n_peers++], sizeof(c.peers[0]), "%s", p1);
	return c;
}

/* The table most tests use: this daemon "left" on host pc1 (boot 1), its one peer "right". */
static void left_table(struct rmd_peers *t)
{
	struct rmd_config_robot c = robot_cfg("left", "right", NULL);

	rmd_peers_init(t, &c, "pc1", 1);
}

static rmd_heartbeat_t hb_of(const char *inst, const char *host, int64_t boot, int64_t seq,
			     int64_t t_ns)
{
	return (rmd_heartbeat_t){ .instance = (char *)inst,
				  .host = (char *)host,
				  .pid = 100,
				  .boot_id = boot,
				  .prefix = "R_",
				  .seq = seq,
				  .t_ns = t_ns,
				  .period_ms = 10,
				  .timeout_ms = 100,
				  .state = RMD_HEARTBEAT_T_HB_OK,
				  .reason = "" };
}

static void test_first_lost_back(void **state)
{
	struct rmd_peers t;
	rmd_heartbeat_t hb = hb_of("right", "pc2", 7, 0, T0_REAL);
	int i;

	(void)state;
	left_table(&t);
	assert_false(rmd_peers_complete(&t)); /* unseen: the robot is not whole yet */
	assert_int_equal(rmd_peers_take(&t, &hb, 1000 * MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_FIRST);
	assert_int_equal(i, 0);
	assert_true(rmd_peers_complete(&t));
	assert_int_equal(rmd_peers_expire(&t, 1100 * MS), 0); /* exactly the timeout: not yet */
	hb.seq = 1;
	hb.t_ns = T0_REAL + 90 * MS;
	assert_int_equal(rmd_peers_take(&t, &hb, 1090 * MS, T0_REAL + 90 * MS, &i),
			 RMD_PEERS_TAKEN);
	assert_int_equal(rmd_peers_expire(&t, 1190 * MS), 0);
	assert_int_equal(rmd_peers_expire(&t, 1191 * MS), 1u);
	assert_int_equal(t.p[0].status, RMD_PEER_LOST);
	assert_false(rmd_peers_complete(&t));
	assert_int_equal(rmd_peers_expire(&t, 1300 * MS), 0); /* lost once, not every look */
	hb.seq = 2;
	hb.t_ns = T0_REAL + 400 * MS;
	assert_int_equal(rmd_peers_take(&t, &hb, 1400 * MS, T0_REAL + 400 * MS, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_FIRST);
	assert_true(rmd_peers_complete(&t));
}

static void test_unknown_sender(void **state)
{
	struct rmd_peers t;
	rmd_heartbeat_t hb = hb_of("stranger", "pc9", 9, 0, T0_REAL);
	int i;

	(void)state;
	left_table(&t);
	assert_int_equal(rmd_peers_take(&t, &hb, MS, T0_REAL, &i),
			 RMD_PEERS_UNKNOWN | RMD_PEERS_UNKNOWN_NEW);
	assert_int_equal(i, -1);
	hb.seq = 1;
	assert_int_equal(rmd_peers_take(&t, &hb, 2 * MS, T0_REAL, &i), RMD_PEERS_UNKNOWN);
	assert_int_equal(t.unknown, 2);
	assert_int_equal(t.p[0].status, RMD_PEER_UNSEEN);
	assert_false(rmd_peers_complete(&t));
}

static void test_spoofs(void **state)
{
	struct rmd_peers t;
	rmd_heartbeat_t real = hb_of("right", "pc2", 7, 0, T0_REAL);
	rmd_heartbeat_t other_host = hb_of("right", "evil", 7, 5, T0_REAL);
	rmd_heartbeat_t other_proc = hb_of("right", "pc2", 8, 0, T0_REAL);
	rmd_heartbeat_t me_elsewhere = hb_of("left", "pc3", 3, 0, T0_REAL);
	rmd_heartbeat_t me = hb_of("left", "pc1", 1, 0, T0_REAL);
	int i;

	(void)state;
	left_table(&t);
	assert_true(rmd_peers_take(&t, &real, 10 * MS, T0_REAL, &i) & RMD_PEERS_TAKEN);
	assert_int_equal(rmd_peers_take(&t, &other_host, 11 * MS, T0_REAL, &i), RMD_PEERS_SPOOF);
	assert_int_equal(i, 0);
	assert_int_equal(rmd_peers_take(&t, &other_proc, 12 * MS, T0_REAL, &i), RMD_PEERS_SPOOF);
	assert_int_equal(rmd_peers_take(&t, &me_elsewhere, 13 * MS, T0_REAL, &i), RMD_PEERS_SPOOF);
	assert_int_equal(i, -1);
	assert_int_equal(rmd_peers_take(&t, &me, 14 * MS, T0_REAL, &i), RMD_PEERS_OWN);
	assert_int_equal(t.spoofs, 3);
	/* the spoofs took nothing: the real peer's seq and host stand */
	assert_int_equal(t.p[0].seq, 0);
	assert_string_equal(t.p[0].host, "pc2");
	assert_int_equal(t.p[0].boot_id, 7);
	/* the bound peer gone, a restart on its host is the peer again; another host never is */
	assert_int_equal(rmd_peers_expire(&t, 200 * MS), 1u);
	assert_int_equal(rmd_peers_take(&t, &other_host, 201 * MS, T0_REAL, &i), RMD_PEERS_SPOOF);
	assert_int_equal(rmd_peers_take(&t, &other_proc, 202 * MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_FIRST);
	assert_int_equal(t.p[0].boot_id, 8);
}

static void test_self_never_a_peer(void **state)
{
	struct rmd_peers t;
	struct rmd_config_robot c = robot_cfg("left", "left", "right");

	(void)state;
	rmd_peers_init(&t, &c, "pc1", 1);
	assert_int_equal(t.n, 1);
	assert_string_equal(t.p[0].instance, "right");
}

/*
 * B's clock runs 5 ms ahead of A's; each datagram takes 100 us; B answers
 * 3 ms after A's heartbeat came.  A's estimate: +5 ms, round trip 200 us.
 */
static void test_offset_from_echo(void **state)
{
	struct rmd_peers a, bt;
	struct rmd_config_robot ca = robot_cfg("a", "b", NULL), cb = robot_cfg("b", "a", NULL);
	const int64_t skew = 5 * MS, wire = 100000;
	int64_t t1 = T0_REAL, t2 = t1 + wire + skew, t3 = t2 + 3 * MS, t4 = t3 - skew + wire;
	rmd_heartbeat_t ha = hb_of("a", "pca", 1, 0, t1), hb = hb_of("b", "pcb", 2, 0, t3);
	rmd_heartbeat_echo_t echo[RMD_CONFIG_MAX_PEERS];
	int i;

	(void)state;
	rmd_peers_init(&a, &ca, "pca", 1);
	rmd_peers_init(&bt, &cb, "pcb", 2);
	rmd_peers_sent(&a, 0, t1);
	assert_true(rmd_peers_take(&bt, &ha, 50 * MS, t2, &i) & RMD_PEERS_TAKEN);
	hb.n_echoes = (int16_t)rmd_peers_echoes(&bt, echo, RMD_CONFIG_MAX_PEERS);
	hb.echo = echo;
	assert_int_equal(hb.n_echoes, 1);
	assert_int_equal(echo[0].t_sent_ns, t1);
	assert_int_equal(echo[0].t_recv_ns, t2);
	assert_true(rmd_peers_take(&a, &hb, 53 * MS, t4, &i) & RMD_PEERS_TAKEN);
	assert_true(a.p[0].offset_valid);
	assert_int_equal(a.p[0].offset_ns, skew);
	assert_int_equal(a.p[0].rtt_ns, 2 * wire);
	/* 5 ms is within the warning's 10 ms: not warned */
	assert_int_equal(a.clock_warnings, 0);
}

static void test_forged_echo_moves_nothing(void **state)
{
	struct rmd_peers a;
	struct rmd_config_robot ca = robot_cfg("a", "b", NULL);
	rmd_heartbeat_echo_t forged = { .instance = "a",
					.seq = 3,
					.t_sent_ns = T0_REAL - 3600 * RMD_NS_PER_S,
					.t_recv_ns = T0_REAL };
	rmd_heartbeat_t hb = hb_of("b", "pcb", 2, 0, T0_REAL);
	int i;

	(void)state;
	rmd_peers_init(&a, &ca, "pca", 1);
	hb.n_echoes = 1;
	hb.echo = &forged;
	assert_int_equal(rmd_peers_take(&a, &hb, MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_FIRST);
	assert_false(a.p[0].offset_valid); /* seq 3 was never sent */
	assert_int_equal(a.p[0].offset_ns, 0);
}

static void test_clock_warn_and_trip(void **state)
{
	struct rmd_peers t;
	rmd_heartbeat_t hb = hb_of("right", "pc2", 7, 0, T0_REAL + 50 * MS);
	int i;

	(void)state;
	left_table(&t);
	assert_int_equal(rmd_peers_take(&t, &hb, MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_FIRST | RMD_PEERS_CLOCK_WARN);
	assert_int_equal(t.p[0].offset_ns, 50 * MS);
	hb.seq = 1;
	assert_int_equal(rmd_peers_take(&t, &hb, 2 * MS, T0_REAL, &i), RMD_PEERS_TAKEN);
	hb.seq = 2;
	hb.t_ns = T0_REAL + 1001 * MS; /* beyond max_clock_offset_ms */
	assert_int_equal(rmd_peers_take(&t, &hb, 3 * MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_CLOCK_TRIP);
	hb.seq = 3;
	hb.t_ns = T0_REAL - 2000 * MS; /* the past as well */
	assert_int_equal(rmd_peers_take(&t, &hb, 4 * MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_CLOCK_TRIP);
	hb.seq = 4;
	hb.t_ns = 0; /* no clock at all */
	assert_true(rmd_peers_take(&t, &hb, 5 * MS, T0_REAL, &i) & RMD_PEERS_CLOCK_TRIP);
	assert_int_equal(t.clock_warnings, 4);
	/* still a live peer: a clock is no silence */
	assert_true(rmd_peers_complete(&t));
}

static void test_trips_followed(void **state)
{
	struct rmd_peers t;
	rmd_heartbeat_t hb = hb_of("right", "pc2", 7, 0, T0_REAL);
	int i;

	(void)state;
	left_table(&t);
	hb.trips = 5; /* before we saw it: its past */
	assert_int_equal(rmd_peers_take(&t, &hb, MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_FIRST);
	hb.seq = 1;
	hb.trips = 6;
	hb.state = RMD_HEARTBEAT_T_HB_TRIPPED;
	assert_int_equal(rmd_peers_take(&t, &hb, 2 * MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_TRIP);
	assert_int_equal(t.p[0].status, RMD_PEER_TRIPPED);
	assert_true(rmd_peers_complete(&t)); /* tripped is there: enabling again is allowed */
	/* lost heartbeats in between: the count still says it */
	hb.seq = 5;
	hb.trips = 8;
	assert_true(rmd_peers_take(&t, &hb, 3 * MS, T0_REAL, &i) & RMD_PEERS_TRIP);
	hb.seq = 6;
	assert_false(rmd_peers_take(&t, &hb, 4 * MS, T0_REAL, &i) & RMD_PEERS_TRIP);
}

static void test_stale_and_stopping(void **state)
{
	struct rmd_peers t;
	rmd_heartbeat_t hb = hb_of("right", "pc2", 7, 3, T0_REAL);
	int i;

	(void)state;
	left_table(&t);
	assert_true(rmd_peers_take(&t, &hb, MS, T0_REAL, &i) & RMD_PEERS_TAKEN);
	assert_int_equal(rmd_peers_take(&t, &hb, 50 * MS, T0_REAL, &i), RMD_PEERS_STALE);
	/* a replayed heartbeat does not keep a silent peer alive */
	assert_int_equal(rmd_peers_expire(&t, 102 * MS), 1u);
	assert_int_equal(rmd_peers_take(&t, &hb, 103 * MS, T0_REAL, &i), RMD_PEERS_STALE);
	hb.seq = 4;
	assert_true(rmd_peers_take(&t, &hb, 104 * MS, T0_REAL, &i) & RMD_PEERS_FIRST);
	hb.seq = 5;
	hb.state = RMD_HEARTBEAT_T_HB_STOPPING;
	assert_int_equal(rmd_peers_take(&t, &hb, 105 * MS, T0_REAL, &i),
			 RMD_PEERS_TAKEN | RMD_PEERS_STOPPED);
	assert_false(rmd_peers_complete(&t));
	assert_int_equal(rmd_peers_expire(&t, 500 * MS), 0); /* said once, not lost again */
}

static void test_echoes_and_report(void **state)
{
	struct rmd_peers t;
	struct rmd_config_robot c = robot_cfg("left", "right", "torso");
	rmd_heartbeat_t hb = hb_of("torso", "pc3", 7, 9, T0_REAL + 2 * MS);
	rmd_heartbeat_echo_t echo[RMD_CONFIG_MAX_PEERS];
	rmd_robot_peer_t r;
	int i;

	(void)state;
	rmd_peers_init(&t, &c, "pc1", 1);
	assert_int_equal(rmd_peers_echoes(&t, echo, RMD_CONFIG_MAX_PEERS), 0);
	rmd_peers_take(&t, &hb, 10 * MS, T0_REAL, &i);
	assert_int_equal(rmd_peers_echoes(&t, echo, RMD_CONFIG_MAX_PEERS), 1);
	assert_string_equal(echo[0].instance, "torso");
	assert_int_equal(echo[0].seq, 9);
	rmd_peers_report(&t, 0, 20 * MS, &r);
	assert_string_equal(r.instance, "right");
	assert_int_equal(r.status, RMD_ROBOT_PEER_T_PEER_UNSEEN);
	assert_int_equal(r.age_ms, -1);
	rmd_peers_report(&t, 1, 25 * MS, &r);
	assert_string_equal(r.host, "pc3");
	assert_string_equal(r.prefix, "R_");
	assert_int_equal(r.status, RMD_ROBOT_PEER_T_PEER_OK);
	assert_int_equal(r.age_ms, 15);
	assert_false(r.offset_valid);
	assert_int_equal(r.offset_ns, 2 * MS);
	assert_int_equal(r.heartbeats, 1);
	assert_string_equal(rmd_peer_status_name(RMD_PEER_LOST), "lost");
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_first_lost_back),
		cmocka_unit_test(test_unknown_sender),
		cmocka_unit_test(test_spoofs),
		cmocka_unit_test(test_self_never_a_peer),
		cmocka_unit_test(test_offset_from_echo),
		cmocka_unit_test(test_forged_echo_moves_nothing),
		cmocka_unit_test(test_clock_warn_and_trip),
		cmocka_unit_test(test_trips_followed),
		cmocka_unit_test(test_stale_and_stopping),
		cmocka_unit_test(test_echoes_and_report),
	};

	return SUITE_RUN("peers", tests, NULL, NULL);
}
