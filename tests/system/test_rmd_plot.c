// SPDX-License-Identifier: MIT
/*
 * rmd-plot (python/rmd/plot.py, installed as a console script by `pip
 * install './python[plot]'`: build/venv/bin/rmd-plot, made by `make
 * python-venv`) against real data:
 *   - log: lcm-logger records a short `rmdd --sim 3` run while the test
 *     moves motor1; rmd-plot --log draws position and wake-up latency into
 *     a PNG and writes its points as CSV, which must hold exactly the
 *     log's state_t and health_t values (the test reads the log itself with
 *     LCM's C event log reader), and the PNG must be a PNG of a figure;
 *   - live: rmd-plot listens to the running daemon for a second, names
 *     the motors from the config_t it asks for, and writes PNG and CSV;
 *   - a bad field or a missing log: exit 2 with the reason.
 * Without the venv's rmd-plot (and matplotlib), lcm-logger, or multicast on
 * loopback (routed when root), every test skips loudly.
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
#include <lcm/eventlog.h>
#include <lcm/lcm.h>

#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "rmd/time.h"
#include "rmd/rmd_command_t.h"

#define START_MS 15000
#define LOG_S 1.5 /* of the run the logger records */
#define MAX_POINTS 20000

static char rmdd_bin[PATH_MAX], plot_bin[PATH_MAX], dir[] = "/tmp/test_rmd_plot.XXXXXX";
static bool skip_all;
static unsigned test_no;

struct fixture {
	char url[96], log[PATH_MAX], png[PATH_MAX], csv[PATH_MAX];
	lcm_t *lcm;
	struct lcm_rx rx;
	int64_t seq;
};

static struct fixture *F;

/* LCM for ms; motor1 (index 0) driven to 0.4 rad in position mode meanwhile. */
static void service(int ms)
{
	int64_t end = rmd_now_ns() + (int64_t)ms * 1000000, next = 0;

	do {
		if (rmd_now_ns() >= next && F->rx.n_states) {
			rmd_motor_command_t m = { .index = 0,
						  .enable = 1,
						  .mode = RMD_COMMAND_T_MODE_POSITION,
						  .position = 0.4,
						  .max_velocity = 2.0 };
			rmd_command_t c = { .utime = rmd_now_ns() / 1000,
					    .seq = F->seq++,
					    .controller = 7,
					    .count = 1,
					    .motor = &m };

			rmd_command_t_publish(F->lcm, "RMD_COMMAND", &c);
			next = rmd_now_ns() + 5000000;
		}
		lcm_handle_timeout(F->lcm, 2);
	} while (rmd_now_ns() < end);
}

static int group_setup(void **state)
{
	const char *build = getenv("BUILD"), *env = getenv("RMD_PLOT");
	char cmd[PATH_MAX + 128];

	(void)state;
	if (!build || !*build)
		build = "build";
	if (find_prog(rmdd_bin, sizeof(rmdd_bin), "RMDD", "rmdd") < 0 || !mkdtemp(dir))
		return -1;
	if (env && *env)
		snprintf(plot_bin, sizeof(plot_bin), "%s", env);
	else
		snprintf(plot_bin, sizeof(plot_bin), "%s/venv/bin/rmd-plot", build);
	if (access(plot_bin, X_OK) != 0) /* build/san: the one venv is build/venv */
		snprintf(plot_bin, sizeof(plot_bin), "build/venv/bin/rmd-plot");
	unsetenv("LCM_DEFAULT_URL");
	unsetenv("NOTIFY_SOCKET");
	unsetenv("PYTHONPATH");
	unsetenv("DISPLAY");
	snprintf(cmd, sizeof(cmd), "'%s' --help >/dev/null 2>&1", plot_bin);
	if (access(plot_bin, X_OK) != 0 || system(cmd) != 0) {
		fprintf(stderr,
			"\n*** test_rmd_plot: SKIPPING every test: no %s (make python-venv "
			"installs it, or set RMD_PLOT)\n\n",
			plot_bin);
		skip_all = true;
	} else if (system("command -v lcm-logger >/dev/null 2>&1") != 0) {
		fprintf(stderr, "\n*** test_rmd_plot: SKIPPING every test: no lcm-logger "
				"(liblcm-bin, make deps)\n\n");
		skip_all = true;
	} else {
		skip_all = !lcm_loopback_ready("test_rmd_plot");
	}
	return 0;
}

static int group_teardown(void **state)
{
	(void)state;
	kid_kill_all();
	return rm_tree(dir);
}

static int setup(void **state)
{
	struct fixture *f = lcm_fixture_new(state, sizeof(*f), !skip_all);

	if (!f)
		return 0;
	lcm_test_url(f->url, sizeof(f->url), 47000, 100, test_no++);
	snprintf(f->log, sizeof(f->log), "%s/run%u.lcmlog", dir, test_no);
	snprintf(f->png, sizeof(f->png), "%s/plot%u.png", dir, test_no);
	snprintf(f->csv, sizeof(f->csv), "%s/plot%u.csv", dir, test_no);
	f->lcm = lcm_create(f->url);
	assert_non_null(f->lcm);
	lcm_rx_listen(&f->rx, f->lcm, "RMD_");
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
	lcm_rx_free(&f->rx);
	lcm_destroy(f->lcm);
	free(f);
	F = NULL;
	return 0;
}

static struct kid *start_rmdd(struct fixture *f)
{
	const char *argv[] = { rmdd_bin, "--sim", "3", "--lcm-url", f->url, NULL };
	struct kid *k = kid_spawn("rmdd", argv, NULL, 0);
	int64_t end = rmd_now_ns() + (int64_t)START_MS * 1000000;

	while (!(f->rx.n_states && f->rx.state.count == 3 &&
		 f->rx.state.motor[2].lifecycle == RMD_STATE_T_LC_READY)) {
		if (rmd_now_ns() > end || kid_poll_exit(k))
			fail_msg("rmdd --sim 3 not ready; its output:\n%s", kid_tail(k));
		lcm_handle_timeout(f->lcm, 10);
		kid_read(k);
	}
	return k;
}

/* A PNG: signature, IHDR first, a figure's size. */
static void check_png(const char *path, unsigned min_w, unsigned min_h)
{
	unsigned char b[24];
	FILE *fp = fopen(path, "rb");
	unsigned w, h;

	if (!fp)
		fail_msg("%s: not written", path);
	assert_int_equal(fread(b, 1, sizeof(b), fp), sizeof(b));
	fclose(fp);
	assert_memory_equal(b, "\x89PNG\r\n\x1a\n", 8);
	assert_memory_equal(b + 12, "IHDR", 4);
	w = (unsigned)b[16] << 24 | (unsigned)b[17] << 16 | (unsigned)b[18] << 8 | b[19];
	h = (unsigned)b[20] << 24 | (unsigned)b[21] << 16 | (unsigned)b[22] << 8 | b[23];
	if (w < min_w || h < min_h)
		fail_msg("%s: %ux%u, want at least %ux%u", path, w, h, min_w, min_h);
}

/* What the log holds, as the test reads it: motor1's positions, wake_max_us, their times. */
struct logged {
	unsigned n_pos, n_wake;
	int64_t t_pos[MAX_POINTS], t_wake[MAX_POINTS / 10];
	double pos[MAX_POINTS], wake[MAX_POINTS / 10];
	int64_t t0_us; /* the first state_t's or health_t's, in log order: rmd-plot's time 0 */
	bool config;
};

static void read_log(const char *path, struct logged *l)
{
	lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
	lcm_eventlog_event_t *ev;

	assert_non_null(log);
	while ((ev = lcm_eventlog_read_next_event(log))) {
		rmd_state_t s;
		rmd_health_t h;

		if (!strcmp(ev->channel, "RMD_STATE") &&
		    rmd_state_t_decode(ev->data, 0, (int)ev->datalen, &s) >= 0) {
			if (!l->n_pos && !l->n_wake)
				l->t0_us = s.utime;
			if (s.count > 0 && l->n_pos < MAX_POINTS) {
				l->t_pos[l->n_pos] = s.utime;
				l->pos[l->n_pos++] = s.motor[0].position;
			}
			rmd_state_t_decode_cleanup(&s);
		} else if (!strcmp(ev->channel, "RMD_HEALTH") &&
			   rmd_health_t_decode(ev->data, 0, (int)ev->datalen, &h) >= 0) {
			if (!l->n_pos && !l->n_wake)
				l->t0_us = h.utime;
			if (l->n_wake < MAX_POINTS / 10) {
				l->t_wake[l->n_wake] = h.utime;
				l->wake[l->n_wake++] = h.wake_max_us;
			}
			rmd_health_t_decode_cleanup(&h);
		} else if (!strcmp(ev->channel, "RMD_CONFIG")) {
			l->config = true;
		}
		lcm_eventlog_free_event(ev);
	}
	lcm_eventlog_destroy(log);
}

/* Every CSV row of `series`, against the log's values and times (t0: the first point's). */
static void check_csv(const char *csv, const char *series, const int64_t *t_us, const double *v,
		      unsigned n, int64_t t0_us)
{
	char key[64];
	unsigned k = 0;

	snprintf(key, sizeof(key), ",%s,", series);
	for (const char *p = strstr(csv, key); p; p = strstr(p + 1, key)) {
		const char *line = p;
		double t, x;

		while (line > csv && line[-1] != '\n')
			line--;
		t = strtod(line, NULL);
		x = strtod(p + strlen(key), NULL);
		if (k >= n)
			fail_msg("%s: more CSV rows than the log's %u", series, n);
		/* repr() of a double reads back exactly */
		if (!(x == v[k] || (isnan(x) && isnan(v[k]))) ||
		    fabs(t - (double)(t_us[k] - t0_us) / 1e6) > 1e-6)
			fail_msg("%s row %u: %.9f s %.17g, the log has %.9f s %.17g", series, k, t,
				 x, (double)(t_us[k] - t0_us) / 1e6, v[k]);
		k++;
	}
	if (k != n)
		fail_msg("%s: %u CSV rows, the log has %u", series, k, n);
}

static void test_log_to_png_and_csv(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	char url_opt[128];
	const char *logger_argv[] = { "lcm-logger", "-f", url_opt, f->log, NULL };
	const char *args[] = { "--log",	  f->log,   "--field", "position",
			       "--motor", "motor1", "--field", "health.wake_max_us",
			       "--out",	  f->png,   "--csv",   f->csv,
			       NULL };
	static struct logged l;
	struct kid *logger;
	struct run r;
	double moved = 0;

	memset(&l, 0, sizeof(l));
	snprintf(url_opt, sizeof(url_opt), "--lcm-url=%s", f->url);
	/* the logger first: it records rmdd's config_t at start */
	logger = kid_spawn("lcm-logger", logger_argv, NULL, 0);
	service(200);
	start_rmdd(f);
	service((int)(LOG_S * 1000));
	kill(logger->pid, SIGINT);
	assert_int_equal(kid_wait_exit(logger, 5000, NULL), 0);
	kid_kill_all();

	read_log(f->log, &l);
	assert_true(l.config);
	assert_true(l.n_pos > 100);
	assert_true(l.n_wake >= 5);
	for (unsigned i = 0; i < l.n_pos; i++)
		moved = fmax(moved, fabs(l.pos[i]));
	assert_true(moved > 0.05); /* the plot has a motion to show */

	run_prog(&r, plot_bin, args, NULL);
	assert_status(&r, 0, "rmd-plot --log");
	check_png(f->png, 400, 300);
	run_free(&r);
	{
		struct run c;
		const char *cat[] = { f->csv, NULL };

		run_prog(&c, "/bin/cat", cat, NULL);
		assert_status(&c, 0, "cat csv");
		assert_has(c.out, "t_s,series,value\n", "csv header");
		check_csv(c.out, "motor1.position", l.t_pos, l.pos, l.n_pos, l.t0_us);
		check_csv(c.out, "health.wake_max_us", l.t_wake, l.wake, l.n_wake, l.t0_us);
		assert_lacks(c.out, "motor2.", "--motor motor1");
		run_free(&c);
	}
}

static void test_live(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	const char *args[] = { "--lcm-url", f->url, "--seconds", "1",	 "--field", "velocity",
			       "--out",	    f->png, "--csv",	 f->csv, NULL };
	const char *cat[] = { f->csv, NULL };
	struct run r, c;

	start_rmdd(f);
	run_prog(&r, plot_bin, args, &(struct run_opts){ .service = service });
	assert_status(&r, 0, "rmd-plot live");
	check_png(f->png, 400, 200);
	run_prog(&c, "/bin/cat", cat, NULL);
	/* names from the config_t rmd-plot asked for; all three motors */
	ASSERT_HAS_ALL(c.out, "live csv", ",motor1.velocity,", ",motor2.velocity,",
		       ",motor3.velocity,");
	assert_true(count_lines(c.out) > 100);
	run_free(&r);
	run_free(&c);
}

static void test_errors(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	const struct run_case c[] = {
		{ .args = { "--log", f->log, "--field", "bogus" },
		  .status = 2,
		  .err_has = { "rmd-plot: unknown field 'bogus'" } },
		{ .args = { "--log", "/nonexistent.lcmlog", "--out", f->png },
		  .status = 2,
		  .err_has = { "rmd-plot: /nonexistent.lcmlog" } },
		{ .args = { "--lcm-url", f->url, "--seconds", "0.3", "--csv", "-" },
		  .status = 2,
		  .err_has = { "nothing from rmdd on", "is it running?" } },
	};

	run_cases(plot_bin, c, sizeof(c) / sizeof(c[0]), NULL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown(test_log_to_png_and_csv, setup, teardown),
		cmocka_unit_test_setup_teardown(test_live, setup, teardown),
		cmocka_unit_test_setup_teardown(test_errors, setup, teardown),
	};

	return cmocka_run_group_tests_name("rmd_plot", tests, group_setup, group_teardown);
}
