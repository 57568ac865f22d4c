// SPDX-License-Identifier: MIT
/* Two rmdd as one robot, driven by the test (robot_pair.h). */
#define _GNU_SOURCE
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>

#include "harness/lcm_loopback.h"
#include "harness/netns.h"
#include "harness/proc.h"
#include "harness/robot_pair.h"
#include "harness/sleeper.h"
#include "rmd/channels.h"
#include "rmd/rmd_command_t.h"
#include "rmd/time.h"

struct robot_pair rp;
static char rmdd_bin[PATH_MAX], tmp_dir[PATH_MAX];
static struct sleeper ref;

int robot_pair_group_setup(const char *suite, char *rmdctl, bool *multicast)
{
	snprintf(tmp_dir, sizeof(tmp_dir), "/tmp/%s.XXXXXX", suite);
	if (lcm_tools_setup(suite, rmdd_bin, rmdctl, tmp_dir, multicast) < 0)
		return -1;
	rp.rmdd = rmdd_bin;
	rp.dir = tmp_dir;
	rp.ref = &ref;
	return sleeper_start(&ref, 1000000, 0) < 0 ? -1 : 0;
}

int robot_pair_group_teardown(void **state)
{
	sleeper_stop(&ref);
	return lcm_tools_teardown(state);
}

static void on_state(const lcm_recv_buf_t *rb, const char *ch, const rmd_state_t *m, void *user)
{
	struct robot_side *s = user;
	bool safe = m->count == RP_NMOT;

	(void)rb;
	(void)ch;
	for (int i = 0; i < m->count && i < RP_NMOT; i++) {
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
	struct robot_side *s = user;

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
	rp.heartbeats++;
}

/* The calling thread into the controller's host (with rp.net). */
static void into_controller(void)
{
	if (rp.net)
		assert_int_equal(netns_enter(rp.net, rp.ctl_host), 0);
}

static void out_of_controller(void)
{
	if (rp.net)
		assert_int_equal(netns_leave(), 0);
}

/*
 * dir/NAME.yaml: instance inst on prefix, its robot: section `robot` ("" none),
 * its motors `names`_hip and `names`_knee, its sim wire tapped into tap ("" not).
 */
static void write_config(char *path, size_t len, const char *inst, const char *prefix,
			 const char *robot, const char *names, const char *tap)
{
	char sim[PATH_MAX + 128] = "";
	FILE *f;

	if (tap[0])
		snprintf(sim, sizeof(sim), ", sim: {tap: '%s'}", tap);
	snprintf(path, len, "%s/%s.yaml", rp.dir, inst);
	f = fopen(path, "w");
	assert_non_null(f);
	fprintf(f,
		"loop: {rate_hz: 500}\n"
		"safety: {comm_loss_ms: 100, command_timeout_ms: 1000, safe_action: %s}\n"
		"lcm: {channel_prefix: %s, health_period_ms: 50}\n"
		"incidents: {enabled: false}\n"
		"%s"
		"buses:\n"
		"  - {name: s0, type: sim%s}\n"
		"motors:\n"
		"  - {name: %s_hip, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: %s_knee, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 2}\n",
		rp.safe_action ? rp.safe_action : "damp", prefix, robot, sim, names, names);
	assert_int_equal(fclose(f), 0);
}

void robot_side_start_named(unsigned i, const char *inst, const char *prefix, const char *robot,
			    const char *names)
{
	struct robot_side *s = &rp.s[i];
	char cfg[PATH_MAX + 64], ch[64], tap[PATH_MAX + 64];
	const char *argv[] = { rp.rmdd, "--config", cfg, "--lcm-url", rp.url, NULL };

	snprintf(tap, sizeof(tap), "%s", s->tap);
	memset(s, 0, sizeof(*s));
	snprintf(s->tap, sizeof(s->tap), "%s", tap);
	s->inst = inst;
	s->prefix = prefix;
	s->controller = 0x1000 + i;
	snprintf(s->ch_cmd, sizeof(s->ch_cmd), "%s" RMD_CHANNEL_COMMAND, prefix);
	write_config(cfg, sizeof(cfg), inst, prefix, robot, names, s->tap);
	into_controller();
	snprintf(ch, sizeof(ch), "%s" RMD_CHANNEL_STATE, prefix);
	s->ssub = rmd_state_t_subscribe(rp.lcm, ch, on_state, s);
	snprintf(ch, sizeof(ch), "%s" RMD_CHANNEL_HEALTH, prefix);
	s->hsub = rmd_health_t_subscribe(rp.lcm, ch, on_health, s);
	out_of_controller();
	if (rp.net)
		s->kid = netns_kid_spawn(rp.net, rp.host[i], inst, argv, NULL);
	else
		s->kid = kid_spawn(inst, argv, NULL, 0);
	assert_non_null(s->kid);
}

void robot_side_start(unsigned i, const char *inst, const char *prefix, const char *robot)
{
	robot_side_start_named(i, inst, prefix, robot, inst);
}

void robot_pair_url(const char *url)
{
	memset(rp.s, 0, sizeof(rp.s));
	rp.heartbeats = 0;
	snprintf(rp.url, sizeof(rp.url), "%s", url);
	into_controller();
	rp.lcm = lcm_create(rp.url);
	assert_non_null(rp.lcm);
	rp.hbsub =
		rmd_heartbeat_t_subscribe(rp.lcm, RMD_CHANNEL_ROBOT_HEARTBEAT, on_heartbeat, NULL);
	out_of_controller();
}

void robot_pair_teardown(void)
{
	for (unsigned i = 0; i < 2; i++) {
		struct robot_side *s = &rp.s[i];

		kid_free(s->kid);
		s->kid = NULL;
		if (s->ssub)
			rmd_state_t_unsubscribe(rp.lcm, s->ssub);
		if (s->hsub)
			rmd_health_t_unsubscribe(rp.lcm, s->hsub);
		if (s->health)
			rmd_health_t_destroy(s->health);
		s->ssub = NULL;
		s->hsub = NULL;
		s->health = NULL;
	}
	if (rp.hbsub)
		rmd_heartbeat_t_unsubscribe(rp.lcm, rp.hbsub);
	rp.hbsub = NULL;
	if (rp.lcm)
		lcm_destroy(rp.lcm);
	rp.lcm = NULL;
}

void robot_pair_start_named(const char *const names[2])
{
	int timeout = rp.peer_timeout_ms ? rp.peer_timeout_ms : RP_PEER_TIMEOUT_MS;
	char rl[256], rr[256];

	snprintf(rl, sizeof(rl),
		 "robot: {instance: left, peers: [right], heartbeat_ms: %d, peer_timeout_ms: %d}\n",
		 RP_HEARTBEAT_MS, timeout);
	snprintf(rr, sizeof(rr),
		 "robot: {instance: right, peers: [left], heartbeat_ms: %d, peer_timeout_ms: %d}\n",
		 RP_HEARTBEAT_MS, timeout);
	robot_side_start_named(0, "left", "LEFT_", rl, names[0]);
	robot_side_start_named(1, "right", "RIGHT_", rr, names[1]);
}

void robot_pair_start(void)
{
	robot_pair_start_named((const char *const[]){ "left", "right" });
}

void robot_send_cmd(struct robot_side *s, bool enable)
{
	rmd_motor_command_t mc[RP_NMOT];
	rmd_command_t m = { .motor = mc, .count = RP_NMOT, .controller = s->controller };

	memset(mc, 0, sizeof(mc));
	m.utime = rmd_now_ns() / 1000;
	m.seq = ++s->seq;
	for (int i = 0; i < RP_NMOT; i++) {
		mc[i].index = (int16_t)i;
		mc[i].enable = enable;
		mc[i].mode = RMD_COMMAND_T_MODE_TORQUE;
	}
	assert_int_equal(rmd_command_t_publish(rp.lcm, s->ch_cmd, &m), 0);
}

void robot_send_heartbeat(lcm_t *l, const char *inst, const char *host, int64_t boot, int64_t seq,
			  int64_t ahead_ns)
{
	struct timespec ts;
	rmd_heartbeat_t hb = { .instance = (char *)inst,
			       .host = (char *)host,
			       .pid = 4242,
			       .boot_id = boot,
			       .prefix = "EVIL_",
			       .seq = seq,
			       .period_ms = RP_HEARTBEAT_MS,
			       .timeout_ms = RP_PEER_TIMEOUT_MS,
			       .reason = "" };

	clock_gettime(CLOCK_REALTIME, &ts);
	hb.t_ns = rmd_timespec_ns(&ts) + ahead_ns;
	assert_int_equal(rmd_heartbeat_t_publish(l, RMD_CHANNEL_ROBOT_HEARTBEAT, &hb), 0);
}

unsigned robot_count_of(const char *hay, const char *needle)
{
	unsigned n = 0;

	for (const char *p = hay; (p = strstr(p, needle)); p += strlen(needle))
		n++;
	return n;
}

bool robot_all_in(const struct robot_side *s, int lc)
{
	if (!s->n_states)
		return false;
	for (int i = 0; i < RP_NMOT; i++)
		if (s->lc[i] != lc)
			return false;
	return true;
}

void robot_pump(int ms)
{
	int64_t end = rmd_now_ns() + ms * RMD_NS_PER_MS;

	do {
		lcm_handle_timeout(rp.lcm, 5);
		for (unsigned i = 0; i < 2; i++)
			if (rp.s[i].kid) {
				kid_read(rp.s[i].kid);
				if (kid_poll_exit(rp.s[i].kid))
					fail_msg("%s exited (%d):\n%s", rp.s[i].inst,
						 rp.s[i].kid->status, kid_tail(rp.s[i].kid));
			}
	} while (rmd_now_ns() < end);
}

bool robot_drive_until(bool enable, int ms, bool (*done)(void))
{
	struct held_deadline d;

	held_deadline_start(&d, rp.ref, ms);
	while (!held_deadline_passed(&d)) {
		for (unsigned i = 0; i < 2; i++)
			if (rp.s[i].kid)
				robot_send_cmd(&rp.s[i], enable);
		robot_pump(20);
		if (done())
			return true;
	}
	return false;
}

bool robot_both_enabled(void)
{
	return robot_all_in(&rp.s[0], RMD_STATE_T_LC_ENABLED) &&
	       robot_all_in(&rp.s[1], RMD_STATE_T_LC_ENABLED);
}

bool robot_right_enabled(void)
{
	return robot_all_in(&rp.s[1], RMD_STATE_T_LC_ENABLED);
}

bool robot_both_safe(void)
{
	return rp.s[0].safe_rx_ns && rp.s[1].safe_rx_ns;
}

bool robot_right_safe(void)
{
	return rp.s[1].safe_rx_ns != 0;
}

bool robot_peers_ok(void)
{
	for (unsigned i = 0; i < 2; i++) {
		const rmd_health_t *h = rp.s[i].health;

		if (rp.s[i].kid && (!h || h->robot != RMD_HEALTH_T_ROBOT_OK || h->n_peers < 1 ||
				    h->peer[0].status != RMD_ROBOT_PEER_T_PEER_OK))
			return false;
	}
	return true;
}

bool robot_never(void)
{
	return false;
}

/* Each running daemon hears its peer, whatever its robot state. */
static bool peers_seen(void)
{
	for (unsigned i = 0; i < 2; i++) {
		const rmd_health_t *h = rp.s[i].health;

		if (rp.s[i].kid &&
		    (!h || h->n_peers < 1 || h->peer[0].status != RMD_ROBOT_PEER_T_PEER_OK))
			return false;
	}
	return true;
}

static bool enabled_and_ok(void)
{
	return robot_both_enabled() && robot_peers_ok();
}

void robot_pair_enabled(void)
{
	robot_pair_start();
	if (!robot_drive_until(false, 20000, peers_seen)) {
		for (unsigned i = 0; i < 2; i++) {
			const rmd_health_t *h = rp.s[i].health;

			fprintf(stderr,
				"%s: %u state_t, health_t %s, peer status %d; its log:\n%s\n",
				rp.s[i].inst, rp.s[i].n_states, h ? "heard" : "never heard",
				h && h->n_peers ? h->peer[0].status : -1, kid_tail(rp.s[i].kid));
		}
		fail_msg("the peers never saw each other (above)");
	}
	/*
	 * A peer seen during its bring-up and then silent for peer_timeout_ms
	 * (a loaded machine) trips the other at start; no motor was driven,
	 * and the controller's enable = 0, then 1, lifts it (docs/robot.md).
	 * Said, so that a run shows it.
	 */
	for (unsigned i = 0; i < 2; i++)
		if (rp.s[i].health->robot != RMD_HEALTH_T_ROBOT_OK)
			print_message("note: %s at start: robot %d (%s); enable = 0, then 1\n",
				      rp.s[i].inst, rp.s[i].health->robot,
				      rp.s[i].health->robot_reason);
	robot_drive_until(false, 100, robot_never);
	if (!robot_drive_until(true, 20000, enabled_and_ok))
		fail_msg("motors not ENABLED:\nleft:\n%s\nright:\n%s", kid_tail(rp.s[0].kid),
			 kid_tail(rp.s[1].kid));
}
