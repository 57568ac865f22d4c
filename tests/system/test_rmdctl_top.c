// SPDX-License-Identifier: MIT
/*
 * `rmdctl top` against a running `rmdd --sim 3`, real processes over LCM
 * (UDP multicast on loopback, a URL per test): the test is rmdd's
 * controller and listens to RMD_CONFIG, RMD_HEALTH and RMD_STATE itself.
 *   - --json: one object whose names, buses and ids are config_t's, whose
 *     lifecycles and modes are those of the state_t the test holds (motor1
 *     enabled in position mode by the test, the others ready), and whose
 *     loop and bus counters are those of one health_t the test received;
 *   - without a terminal, the live view prints plain tables (no escape
 *     sequences) until SIGINT, then exits 0;
 *   - without rmdd, --json and --once give up after --wait with a message
 *     that names the URL, and exit 1.
 * Multicast on loopback is routed when root (tests/harness/lcm_loopback.h),
 * else every test skips loudly.  RMD_TEST_FILTER=test_json runs one test.
 */
#define _GNU_SOURCE
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "harness/json.h"
#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "rmd/time.h"
#include "rmd/rmd_command_t.h"

#define NMOTORS 3
#define START_MS 15000 /* rmdd up, every motor ready (sanitizers, a busy machine) */
#define ENABLE_MS 5000
#define CTL_PERIOD_NS INT64_C(5000000) /* the test controller: 200 Hz */
#define MAX_HEALTH 1024

/* What one health_t said: the counters the JSON must repeat. */
struct seen_health {
	int64_t cycles, overruns, accepted, tx0, rx0;
};

struct fixture {
	char url[96];
	lcm_t *lcm;
	struct lcm_rx rx;
	rmd_health_t_subscription_t *hsub;
	struct seen_health health[MAX_HEALTH];
	unsigned n_health;
	struct kid *rmdd;
	bool stream;	 /* publish motor1's setpoint every CTL_PERIOD_NS */
	int64_t next_ns; /* ... next at */
	int64_t seq;
};

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX];
static bool no_multicast;
static unsigned test_no;
static struct fixture *F; /* for service(): run_prog() and kid waits call it */

static void on_health(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_health_t *msg,
		      void *user)
{
	struct fixture *f = user;

	(void)rbuf;
	(void)channel;
	if (f->n_health < MAX_HEALTH && msg->bus_count > 0)
		f->health[f->n_health++] = (struct seen_health){
			.cycles = msg->cycles,
			.overruns = msg->overruns,
			.accepted = msg->commands_accepted,
			.tx0 = msg->bus[0].tx_frames,
			.rx0 = msg->bus[0].rx_frames,
		};
}

/* motor1 (index 0) enabled in position mode, holding 0.3 rad. */
static void publish_command(struct fixture *f)
{
	rmd_motor_command_t m = {
		.index = 0, .enable = 1, .mode = RMD_COMMAND_T_MODE_POSITION, .position = 0.3
	};
	rmd_command_t c = {
		.utime = rmd_now_ns() / 1000,
		.seq = f->seq++,
		.controller = 42,
		.count = 1,
		.motor = &m,
	};

	assert_int_equal(rmd_command_t_publish(f->lcm, "RMD_COMMAND", &c), 0);
}

/* LCM for at most ms, and the controller's stream when on. */
static void service(int ms)
{
	int64_t end = rmd_now_ns() + (int64_t)ms * 1000000;

	do {
		if (F->stream && rmd_now_ns() >= F->next_ns) {
			publish_command(F);
			F->next_ns = rmd_now_ns() + CTL_PERIOD_NS;
		}
		lcm_handle_timeout(F->lcm, ms < 2 ? ms : 2);
	} while (rmd_now_ns() < end);
}

static int group_setup(void **state)
{
	(void)state;
	if (find_prog(rmdd_bin, sizeof(rmdd_bin), "RMDD", "rmdd") < 0 ||
	    find_prog(rmdctl_bin, sizeof(rmdctl_bin), "RMDCTL", "rmdctl") < 0)
		return -1;
	unsetenv("LCM_DEFAULT_URL");
	unsetenv("NOTIFY_SOCKET");
	no_multicast = !lcm_loopback_ready("test_rmdctl_top");
	return 0;
}

static int setup(void **state)
{
	struct fixture *f = lcm_fixture_new(state, sizeof(*f), !no_multicast);

	if (!f)
		return 0;
	lcm_test_url(f->url, sizeof(f->url), 46000, 100, test_no++);
	f->lcm = lcm_create(f->url);
	assert_non_null(f->lcm);
	lcm_rx_listen(&f->rx, f->lcm, "RMD_");
	f->hsub = rmd_health_t_subscribe(f->lcm, "RMD_HEALTH", on_health, f);
	assert_non_null(f->hsub);
	F = f;
	*state = f;
	return 0;
}

static int teardown(void **state)
{
	struct fixture *f = *state;

	kid_kill_all();
	if (!f)
		return 0;
	rmd_health_t_unsubscribe(f->lcm, f->hsub);
	lcm_rx_free(&f->rx);
	lcm_destroy(f->lcm);
	free(f);
	F = NULL;
	*state = NULL;
	return 0;
}

/* Every motor of state_t in lifecycle lc (or motor 0 only, when first). */
static bool lifecycles(const struct fixture *f, int lc0, int lc_rest)
{
	if (f->rx.n_states == 0 || f->rx.state.count != NMOTORS)
		return false;
	for (int i = 0; i < NMOTORS; i++)
		if (f->rx.state.motor[i].lifecycle != (i == 0 ? lc0 : lc_rest))
			return false;
	return true;
}

/* Service until cond(f) holds, at most ms; fails showing rmdd's output. */
static void wait_for(struct fixture *f, bool (*cond)(const struct fixture *f), int ms,
		     const char *what)
{
	int64_t end = rmd_now_ns() + (int64_t)ms * 1000000;

	while (!cond(f)) {
		if (rmd_now_ns() > end || kid_poll_exit(f->rmdd))
			fail_msg("%s: not within %d ms; rmdd:\n%s", what, ms, kid_tail(f->rmdd));
		service(10);
		kid_read(f->rmdd);
	}
}

static bool all_ready(const struct fixture *f)
{
	return f->rx.config && f->rx.health &&
	       lifecycles(f, RMD_STATE_T_LC_READY, RMD_STATE_T_LC_READY);
}

static bool first_enabled(const struct fixture *f)
{
	return lifecycles(f, RMD_STATE_T_LC_ENABLED, RMD_STATE_T_LC_READY) &&
	       f->rx.state.motor[0].mode == RMD_COMMAND_T_MODE_POSITION;
}

static void start_rmdd(struct fixture *f)
{
	const char *argv[] = { rmdd_bin, "--sim", "3", "--lcm-url", f->url, NULL };

	f->rmdd = kid_spawn("rmdd", argv, NULL, 0);
	wait_for(f, all_ready, START_MS, "rmdd --sim 3: config, health, every motor ready");
}

/* The object of motor `index` in top's JSON, from its "{\"index\":N" on, into buf. */
static const char *motor_obj(const char *json, int index, char *buf, size_t size)
{
	char key[32];
	const char *p, *e;

	snprintf(key, sizeof(key), "{\"index\":%d,", index);
	p = strstr(json, key);
	if (!p)
		fail_msg("no motor %d in:\n%s", index, json);
	e = strchr(p, '}');
	assert_non_null(e);
	snprintf(buf, size, "%.*s", (int)(e - p + 1), p);
	return buf;
}

static void test_json(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	const char *args[] = { "top", "--json", "--lcm-url", f->url, NULL };
	static const char *const lc_want[NMOTORS] = { "enabled", "ready", "ready" };
	struct run r;
	char obj[2048], s[128];
	int64_t accepted_before, cycle_before;
	bool matched = false;

	start_rmdd(f);
	f->stream = true;
	wait_for(f, first_enabled, ENABLE_MS, "motor1 enabled in position mode");
	accepted_before = f->rx.health->commands_accepted;
	cycle_before = f->rx.state.cycle;

	run_prog(&r, rmdctl_bin, args, &(struct run_opts){ .service = service });
	assert_status(&r, 0, "rmdctl top --json");
	assert_int_equal(count_lines(r.out), 1);
	print_message("%s", r.out);

	/* the configuration: config_t's names, buses, ids and protocols */
	json_str(r.out, "prefix", s, sizeof(s));
	assert_string_equal(s, "RMD_");
	assert_int_equal((int)json_num(r.out, "period_us"), f->rx.config->period_us);
	assert_int_equal(f->rx.config->motor_count, NMOTORS);
	for (int i = 0; i < NMOTORS; i++) {
		const rmd_motor_config_t *mc = &f->rx.config->motor[i];

		motor_obj(r.out, i, obj, sizeof(obj));
		json_str(obj, "name", s, sizeof(s));
		assert_string_equal(s, mc->name);
		json_str(obj, "bus", s, sizeof(s));
		assert_string_equal(s, f->rx.config->bus[mc->bus].name);
		assert_int_equal((int)json_num(obj, "id"), mc->id);
		json_str(obj, "protocol", s, sizeof(s));
		assert_string_equal(s, mc->protocol);
		/* the state: the test's controller enabled motor1 only, and keeps it so */
		json_str(obj, "lifecycle", s, sizeof(s));
		assert_string_equal(s, lc_want[i]);
		assert_int_equal(f->rx.state.motor[i].lifecycle,
				 i == 0 ? RMD_STATE_T_LC_ENABLED : RMD_STATE_T_LC_READY);
		if (i == 0) {
			json_str(obj, "mode", s, sizeof(s));
			assert_string_equal(s, "position");
		}
		/* missed replies only grow: top's are at most the newest state_t's */
		assert_true(json_num(obj, "missed_replies") <= f->rx.state.motor[i].missed_replies);
		assert_true(isfinite(json_num(obj, "position")));
		json_str(obj, "comm_loss", s, sizeof(s));
		assert_string_equal(s, "armed");
		assert_int_equal((int)json_num(obj, "comm_loss_ms"), f->rx.health->comm_loss_ms[i]);
	}
	/* the state top read is one of those the test saw during its run */
	assert_true(json_num(r.out, "cycle") >= cycle_before);
	assert_true(json_num(r.out, "cycle") <= f->rx.state.cycle);
	/* its counters are one health_t's, all of them together */
	for (unsigned i = 0; i < f->n_health && !matched; i++) {
		const struct seen_health *h = &f->health[i];

		matched = h->cycles == (int64_t)json_num(r.out, "cycles") &&
			  h->overruns == (int64_t)json_num(r.out, "overruns") &&
			  h->accepted == (int64_t)json_num(r.out, "commands_accepted") &&
			  h->tx0 == (int64_t)json_num(r.out, "tx_frames") &&
			  h->rx0 == (int64_t)json_num(r.out, "rx_frames");
	}
	if (!matched)
		fail_msg("no health_t of the %u received has top's counters:\n%s", f->n_health,
			 r.out);
	assert_true(json_num(r.out, "commands_accepted") >= accepted_before);
	assert_true(json_num(r.out, "commands_accepted") > 0);
	json_str(r.out, "watchdog", s, sizeof(s));
	assert_string_equal(s, "ok");
	json_str(r.out, "name", s, sizeof(s)); /* the first "name": bus 0's */
	assert_string_equal(s, f->rx.config->bus[0].name);
	run_free(&r);
}

/* Not a terminal: plain tables, one per --interval, until SIGINT. */
static void test_live_plain(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	const char *argv[] = { rmdctl_bin, "top", "--interval", "50", "--lcm-url", f->url, NULL };
	struct kid *top;
	const char *p;
	unsigned tables = 0;

	start_rmdd(f);
	top = kid_spawn("rmdctl top", argv, NULL, 0);
	kid_wait_output(top, "motor3 ", 10000, NULL);
	/* several refreshes */
	for (int64_t end = rmd_now_ns() + INT64_C(10000000000); rmd_now_ns() < end;) {
		kid_read(top);
		tables = 0;
		for (p = top->out; (p = strstr(p, "IDX NAME")); p++)
			tables++;
		if (tables >= 3)
			break;
		service(10);
	}
	if (tables < 3)
		fail_msg("%u tables in 10 s at --interval 50:\n%s", tables, kid_tail(top));
	kill(top->pid, SIGINT);
	assert_int_equal(kid_wait_exit(top, 5000, NULL), 0);
	assert_null(strchr(top->out, '\033'));
	ASSERT_HAS_ALL(top->out, "plain top", "motor1 ", "motor2 ", "sim0", "ready", "armed 100ms",
		       "wake-up us");
}

static void test_no_rmdd(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	char want[160];
	const struct run_case c[] = {
		{ .args = { "top", "--json", "--wait", "0.5", "--lcm-url", f->url },
		  .status = 1,
		  .out_has = { "" },
		  .err_has = { "no complete RMD_CONFIG, RMD_HEALTH and RMD_STATE within 0.5 s",
			       "config no, health no, state no", want } },
		{ .args = { "top", "--once", "--wait", "0.5", "--prefix", "X_", "--lcm-url",
			    f->url },
		  .status = 1,
		  .out_has = { "" },
		  .err_has = { "no complete X_CONFIG" } },
		{ .args = { "top", "--json", "--once" },
		  .status = 2,
		  .err_has = { "--json and --once exclude each other", "usage: rmdctl top" } },
		{ .args = { "top", "--interval", "1" },
		  .status = 2,
		  .err_has = { "bad --interval" } },
		{ .args = { "top", "extra" }, .status = 2, .err_has = { "unexpected argument" } },
		{ .args = { "top", "--help" }, .status = 0, .out_has = { "--json", "--lcm-url" } },
	};

	snprintf(want, sizeof(want), "is rmdd running, with --lcm-url %s and prefix RMD_?", f->url);
	run_cases(rmdctl_bin, c, sizeof(c) / sizeof(c[0]), NULL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown(test_json, setup, teardown),
		cmocka_unit_test_setup_teardown(test_live_plain, setup, teardown),
		cmocka_unit_test_setup_teardown(test_no_rmdd, setup, teardown),
	};

	return cmocka_run_group_tests_name("rmdctl_top", tests, group_setup, NULL);
}
