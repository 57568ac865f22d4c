// SPDX-License-Identifier: MIT
/*
 * rmdctl top on a terminal (src/tools/rmdctl/top_screen.c), against
 * `rmdd --sim 12`: the screen as an operator sees it, inside tmux, whose
 * capture-pane gives the terminal's text.  LCM runs over UDP multicast on
 * loopback, a URL per test.
 *
 *   - at 80x24 (the review's terminal, users-2026-11-28 §1.6) the header,
 *     the column heads and every one of the 12 motors show, each motor on
 *     a line of its own, and no line is longer than 80 columns once
 *     tmux joins wrapped lines (capture-pane -J): nothing wraps; q quits
 *     with status 0 and the shell's screen comes back;
 *   - j moves the pick (its details line follows), p pauses, a resize to
 *     140x30 brings back every column, one to 60x16 redraws within 60
 *     columns with the picked motor in view, and
 *     Ctrl-C exits 0 and restores the terminal;
 *   - rmdd stopped while the screen is paused: the title says STALE and
 *     every motor's row is marked '!' and reads STALE, so an operator sees
 *     it without colour too;
 *   - two rmdd of one robot (prefixes A_ and B_, 3 motors each) in one
 *     `top --prefix A_,B_` at 80x24: every motor on its line with its
 *     instance, a line per instance; kill -9 of A: A's line says SILENT
 *     within 2 s (plus what a capture took), its rows STALE, while B's
 *     line keeps counting cycles; --json and --once name each motor's
 *     instance.
 *
 * Without multicast on loopback (routed when root, tests/harness/
 * lcm_loopback.h) or without tmux (`make deps` installs it) every test
 * skips with one loud line, as the other system suites do for their tools.
 */
#define _GNU_SOURCE
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

#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "rmd/time.h"

#define NMOTORS 12
#define START_MS 15000	/* rmdd up, every motor answered (sanitizers, a busy machine) */
#define SCREEN_MS 10000 /* the screen shows what a test waits for */
#define POLL_NS 50000000L

struct fixture {
	char url[96], sock[PATH_MAX];
	struct kid *rmdd, *rmdd_b; /* rmdd_b: the second instance (test_instances) */
	bool tmux_up;
};

static char rmdd_bin[PATH_MAX], rmdctl_bin[PATH_MAX], tmux_bin[PATH_MAX];
static char dir[] = "/tmp/test_top_tty.XXXXXX";
static bool multicast, no_tmux;
static unsigned test_no;

/* tmux from PATH, as a user's shell would find it. */
static bool find_tmux(void)
{
	const char *path = getenv("PATH");
	char buf[PATH_MAX];

	for (const char *p = path ? path : "/usr/bin:/bin"; *p;) {
		size_t len = strcspn(p, ":");

		snprintf(buf, sizeof(buf), "%.*s/tmux", (int)len, p);
		if (len && access(buf, X_OK) == 0) {
			snprintf(tmux_bin, sizeof(tmux_bin), "%s", buf);
			return true;
		}
		p += len + (p[len] == ':');
	}
	return false;
}

static int group_setup(void **state)
{
	(void)state;
	if (lcm_tools_setup("test_top_tty", rmdd_bin, rmdctl_bin, dir, &multicast) < 0)
		return -1;
	unsetenv("TMUX"); /* a run from inside tmux must not reach the user's server */
	no_tmux = !find_tmux();
	if (no_tmux)
		fprintf(stderr,
			"\n*** test_top_tty: SKIPPING every test: no tmux on PATH (make deps "
			"installs it: apt-get install tmux)\n\n");
	return 0;
}

/* tmux with args (NULL-terminated) on the test's own server; its output in r. */
static void tmux_run(struct fixture *f, struct run *r, const char *const *args)
{
	const char *argv[32] = { "-S", f->sock, "-f", "/dev/null" };
	size_t n = 4;

	for (; *args && n < sizeof(argv) / sizeof(argv[0]) - 1; args++)
		argv[n++] = *args;
	argv[n] = NULL;
	run_prog(r, tmux_bin, argv, NULL);
}

static void tmux_ok(struct fixture *f, const char *const *args, const char *what)
{
	struct run r;

	tmux_run(f, &r, args);
	assert_status(&r, 0, what);
	run_free(&r);
}

static int setup(void **state)
{
	struct fixture *f = lcm_fixture_new(state, sizeof(*f), multicast && !no_tmux);

	if (!f)
		return 0;
	lcm_test_url(f->url, sizeof(f->url), 50000, 100, test_no);
	snprintf(f->sock, sizeof(f->sock), "%s/tmux%u.sock", dir, test_no++);
	*state = f;
	return 0;
}

static int teardown(void **state)
{
	struct fixture *f = *state;

	if (f && f->tmux_up) {
		struct run r;

		tmux_run(f, &r, (const char *const[]){ "kill-server", NULL });
		run_free(&r);
	}
	kid_kill_all();
	free(f);
	*state = NULL;
	return 0;
}

static void start_rmdd(struct fixture *f)
{
	char n[8];
	const char *argv[] = { rmdd_bin, "--sim", n, "--lcm-url", f->url, NULL };

	snprintf(n, sizeof(n), "%d", NMOTORS);
	f->rmdd = kid_spawn("rmdd", argv, NULL, 0);
	kid_wait_output(f->rmdd, "running:", START_MS, NULL);
}

/*
 * rmdctl top in a w x h tmux window, as a shell runs it: TERM=screen (in
 * every ncurses-base), Ctrl-C reaches top (the shell traps it and stays),
 * and after top the shell says how it ended and waits, so that the test
 * sees the screen top left behind.
 */
static void start_top_args(struct fixture *f, int w, int h, const char *extra)
{
	char ws[8], hs[8];
	const char *args[] = { "new-session",
			       "-d",
			       "-x",
			       ws,
			       "-y",
			       hs,
			       "-s",
			       "top",
			       "/bin/sh",
			       "-c",
			       "trap : INT; \"$@\"; echo \"top exited $?\"; sleep 600",
			       "sh",
			       "/usr/bin/env",
			       "TERM=screen",
			       rmdctl_bin,
			       "top",
			       "--lcm-url",
			       f->url,
			       extra ? "--prefix" : NULL,
			       extra,
			       NULL };

	snprintf(ws, sizeof(ws), "%d", w);
	snprintf(hs, sizeof(hs), "%d", h);
	tmux_ok(f, args, "tmux new-session");
	f->tmux_up = true;
}

static void start_top(struct fixture *f, int w, int h)
{
	start_top_args(f, w, h, NULL);
}

/* The window's text now, wrapped lines joined (-J), into r->out. */
static void capture(struct fixture *f, struct run *r)
{
	tmux_run(f, r, (const char *const[]){ "capture-pane", "-p", "-J", "-t", "top", NULL });
	assert_status(r, 0, "tmux capture-pane");
}

/* Lines of s holding the whole word w (spaces or line ends around it). */
static unsigned lines_with_word(const char *s, const char *w)
{
	size_t wl = strlen(w);
	unsigned n = 0;

	while (*s) {
		size_t len = strcspn(s, "\n");

		for (const char *p = s; p + wl <= s + len; p++)
			if (!memcmp(p, w, wl) && (p == s || p[-1] == ' ') &&
			    (p + wl == s + len || p[wl] == ' ')) {
				n++;
				break;
			}
		s += len + (s[len] == '\n');
	}
	return n;
}

/* The longest line of s, in columns (the screen is ASCII). */
static size_t longest_line(const char *s)
{
	size_t max = 0;

	while (*s) {
		size_t len = strcspn(s, "\n");

		if (len > max)
			max = len;
		s += len + (s[len] == '\n');
	}
	return max;
}

/* The line starting with prefix, or NULL. */
static const char *line_starting(const char *s, const char *prefix)
{
	for (const char *p = s; p && *p; p = strchr(p, '\n') ? strchr(p, '\n') + 1 : NULL)
		if (!strncmp(p, prefix, strlen(prefix)))
			return p;
	return NULL;
}

/* Every motor's name on exactly one line, and the heads: the table is all there. */
static bool all_motors(const char *screen)
{
	char name[16];

	if (!line_starting(screen, "rmdctl top") || !lines_with_word(screen, "NAME") ||
	    !lines_with_word(screen, "STATE"))
		return false;
	for (int i = 1; i <= NMOTORS; i++) {
		snprintf(name, sizeof(name), "motor%d", i);
		if (lines_with_word(screen, name) != 1)
			return false;
	}
	return true;
}

static bool has(const char *screen, const char *text)
{
	return strstr(screen, text) != NULL;
}

/* The line of s holding the whole word w, or NULL. */
static const char *line_with_word(const char *s, const char *w)
{
	size_t wl = strlen(w);

	while (*s) {
		size_t len = strcspn(s, "\n");

		for (const char *p = s; p + wl <= s + len; p++)
			if (!memcmp(p, w, wl) && (p == s || p[-1] == ' ') &&
			    (p + wl == s + len || p[wl] == ' '))
				return s;
		s += len + (s[len] == '\n');
	}
	return NULL;
}

/* name's row is marked picked ('>') and its details line ("name: ...") shows. */
static bool picked(const char *screen, const char *name)
{
	const char *row = line_with_word(screen, name);
	char detail[32];

	snprintf(detail, sizeof(detail), "%s: ", name);
	return row && row[0] == '>' && line_starting(screen, detail);
}

/*
 * Capture until ok(screen, arg) holds, at most SCREEN_MS; fails showing
 * the last screen.  The last capture stays in r.
 */
static void wait_screen(struct fixture *f, struct run *r, bool (*ok)(const char *, const char *),
			const char *arg, const char *what)
{
	int64_t end = rmd_now_ns() + (int64_t)SCREEN_MS * 1000000;

	for (;;) {
		capture(f, r);
		if (ok(r->out, arg))
			return;
		if (rmd_now_ns() > end)
			fail_msg("%s: not within %d ms; the screen:\n%s\nrmdd:\n%s", what,
				 SCREEN_MS, r->out, kid_tail(f->rmdd));
		run_free(r);
		nanosleep(&(struct timespec){ .tv_nsec = POLL_NS }, NULL);
		kid_read(f->rmdd);
	}
}

static bool motors_ok(const char *screen, const char *unused)
{
	(void)unused;
	return all_motors(screen) && has(screen, "ready");
}

static void assert_fits(const char *screen, size_t cols, const char *what)
{
	if (longest_line(screen) > cols)
		fail_msg("%s: a line of %zu columns on a %zu-column terminal (it wrapped):\n%s",
			 what, longest_line(screen), cols, screen);
}

/* rmdd, and top at 80x24 up to its table of every motor, ready (that screen stays in r). */
static void top_up(struct fixture *f, struct run *r, const char *what)
{
	start_rmdd(f);
	start_top(f, 80, 24);
	wait_screen(f, r, motors_ok, NULL, what);
}

/* One key (a tmux send-keys name) typed into top. */
static void press(struct fixture *f, const char *key)
{
	char what[32];

	snprintf(what, sizeof(what), "send %s", key);
	tmux_ok(f, (const char *const[]){ "send-keys", "-t", "top", key, NULL }, what);
}

/* p pauses: the title says PAUSED. */
static void pause_top(struct fixture *f)
{
	struct run r;

	press(f, "p");
	wait_screen(f, &r, has, "PAUSED", "p pauses");
	run_free(&r);
}

/*
 * key ends top with exit status 0 and gives the shell its screen back: no
 * row of motor is left on it.
 */
static void quit_top(struct fixture *f, const char *key, const char *motor)
{
	char what[64];
	struct run r;

	press(f, key);
	snprintf(what, sizeof(what), "%s ends top", key);
	wait_screen(f, &r, has, "top exited", what);
	snprintf(what, sizeof(what), "%s: exit status 0", key);
	assert_has(r.out, "top exited 0", what);
	/* endwin() left the alternate screen: no table is left on the shell's */
	snprintf(what, sizeof(what), "the terminal restored after %s", key);
	assert_lacks(r.out, motor, what);
	run_free(&r);
}

/* The whole table at 80x24, nothing wrapped; q quits and gives the shell its screen back. */
static void test_fits_80x24(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	struct run r;

	top_up(f, &r, "12 motors, each on its own line, at 80x24");
	assert_fits(r.out, 80, "80x24");
	assert_true(count_lines(r.out) <= 24);
	/* the first motor is picked: its row is marked, its details follow the table */
	assert_true(picked(r.out, "motor1"));
	run_free(&r);

	quit_top(f, "q", "motor1");
}

static bool fits_60(const char *screen, const char *name)
{
	return longest_line(screen) <= 60 && line_starting(screen, "rmdctl top") &&
	       lines_with_word(screen, "NAME") && picked(screen, name);
}

/* j picks the next motor, p pauses, a resize redraws to the new width, Ctrl-C restores. */
static void test_keys_resize(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	struct run r;

	top_up(f, &r, "12 motors at 80x24");
	run_free(&r);

	tmux_ok(f, (const char *const[]){ "send-keys", "-t", "top", "j", "j", "j", NULL },
		"send j j j");
	wait_screen(f, &r, picked, "motor4", "j j j picks motor4");
	assert_fits(r.out, 80, "after j");
	run_free(&r);

	pause_top(f);

	/* wider: the columns 80 had no room for come back */
	tmux_ok(f,
		(const char *const[]){ "resize-window", "-t", "top", "-x", "140", "-y", "30",
				       NULL },
		"resize-window 140x30");
	wait_screen(f, &r, has, "LAT_US", "all columns at 140x30");
	ASSERT_HAS_ALL(r.out, "140x30", " IDX ", " BUS ", " AGE_MS ", " MISSED ", " TEMP ");
	assert_fits(r.out, 140, "140x30");
	assert_true(picked(r.out, "motor4"));
	run_free(&r);

	/* 16 rows: the table scrolls; motor4 stays in view, with its details */
	tmux_ok(f,
		(const char *const[]){ "resize-window", "-t", "top", "-x", "60", "-y", "16", NULL },
		"resize-window 60x16");
	wait_screen(f, &r, fits_60, "motor4", "redrawn within 60 columns, motor4 picked");
	assert_true(count_lines(r.out) <= 16);
	run_free(&r);

	quit_top(f, "C-c", "motor4");
}

/* Every motor's row marked '!' and STALE, and the title says so. */
static bool all_stale(const char *screen, const char *unused)
{
	char name[16];

	(void)unused;
	if (!line_starting(screen, "rmdctl top") || !has(screen, "STALE: no health or state"))
		return false;
	for (int i = 1; i <= NMOTORS; i++) {
		const char *row;
		char line[256];

		snprintf(name, sizeof(name), "motor%d", i);
		row = line_with_word(screen, name);
		if (!row)
			return false;
		snprintf(line, sizeof(line), "%.*s", (int)strcspn(row, "\n"), row);
		if (line[1] != '!' || !strstr(line, " STALE "))
			return false;
	}
	return true;
}

/* rmdd gone (the view paused): STALE in the title and on every motor's row, each marked. */
static void test_stale(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	struct run r;

	top_up(f, &r, "12 motors at 80x24");
	run_free(&r);
	/* paused: the view is kept, but a daemon gone is still news */
	pause_top(f);
	kill(f->rmdd->pid, SIGTERM);
	assert_int_equal(kid_wait_exit(f->rmdd, 10000, NULL), 0);
	wait_screen(f, &r, all_stale, NULL, "STALE on every motor after rmdd stopped");
	assert_fits(r.out, 80, "stale");
	run_free(&r);
}

/* ---- several instances (--prefix A_,B_) ------------------------------------------------ */

#define INST_MOTORS 3

/*
 * rmdd on the test's URL with channel prefix P_ (p = 'A': "A_") and 3
 * simulated motors, a_m1 .. a_m3, from a configuration file (--sim has no
 * prefix).
 */
static struct kid *start_instance(struct fixture *f, char p, const char *robot)
{
	char path[PATH_MAX], yaml[1024], name[16], rob[96] = "";
	char lo = (char)(p - 'A' + 'a');
	struct kid *k;

	snprintf(path, sizeof(path), "%s/%c%u.XXXXXX", dir, p, test_no);
	if (robot)
		snprintf(rob, sizeof(rob), "robot: {instance: %s}\n", robot);
	snprintf(yaml, sizeof(yaml),
		 "loop: {rate_hz: 1000, rt_priority: 40}\n"
		 "%s"
		 "lcm: {channel_prefix: %c_}\n"
		 "buses:\n"
		 "  - {name: sim0, type: sim, sim: {seed: 1}}\n"
		 "motors:\n"
		 "  - {name: %c_m1, bus: sim0, id: 1, mode: position, torque_constant_nm_a: 2}\n"
		 "  - {name: %c_m2, bus: sim0, id: 2, mode: position, torque_constant_nm_a: 2}\n"
		 "  - {name: %c_m3, bus: sim0, id: 3, mode: position, torque_constant_nm_a: 2}\n",
		 rob, p, lo, lo, lo);
	temp_file(path, yaml);
	snprintf(name, sizeof(name), "rmdd %c_", p);
	k = kid_spawn(name,
		      (const char *const[]){ rmdd_bin, "--config", path, "--lcm-url", f->url,
					     NULL },
		      NULL, 0);
	kid_wait_output(k, "running:", START_MS, NULL);
	return k;
}

/* Motor m (1..3) of instance p (the row "... A_ a_m1 ..."): the row, or NULL. */
static const char *inst_row(const char *screen, char p, int m)
{
	char name[16];
	const char *row;

	snprintf(name, sizeof(name), "%c_m%d", p - 'A' + 'a', m);
	if (lines_with_word(screen, name) != 1)
		return NULL;
	row = line_with_word(screen, name);
	snprintf(name, sizeof(name), " %c_ ", p);
	return row && strstr(row, name) && strstr(row, name) < strchr(row, '\n') ? row : NULL;
}

/* The line of instance p ("A_  1000 Hz ..."), copied into buf; NULL when none. */
static const char *inst_line(const char *screen, char p, char *buf, size_t size)
{
	char head[8];
	const char *l;

	snprintf(head, sizeof(head), "%c_ ", p);
	l = line_starting(screen, head);
	if (!l)
		return NULL;
	snprintf(buf, size, "%.*s", (int)strcspn(l, "\n"), l);
	return buf;
}

/* Instance p's "cycles N" on its line; -1 when not shown. */
static long long inst_cycles(const char *screen, char p)
{
	char line[256];
	const char *c;

	if (!inst_line(screen, p, line, sizeof(line)) || !(c = strstr(line, "cycles ")))
		return -1;
	return atoll(c + strlen("cycles "));
}

/* Both instances' lines and all 6 motors, ready, each row naming its instance. */
static bool instances_ok(const char *screen, const char *unused)
{
	char line[256];

	(void)unused;
	if (!line_starting(screen, "rmdctl top") || !has(screen, "2 instances") ||
	    !lines_with_word(screen, "INST") || has(screen, "SILENT"))
		return false;
	for (char p = 'A'; p <= 'B'; p++) {
		if (!inst_line(screen, p, line, sizeof(line)) || !strstr(line, "watchdog") ||
		    !strstr(line, "sim0") || inst_cycles(screen, p) < 0)
			return false;
		for (int m = 1; m <= INST_MOTORS; m++) {
			const char *row = inst_row(screen, p, m);

			if (!row || !strstr(row, " ready "))
				return false;
		}
	}
	return true;
}

/* A silent: its line says SILENT, its rows STALE, each marked; B's rows not. */
static bool a_silent(const char *screen, const char *unused)
{
	char line[256];

	(void)unused;
	if (!inst_line(screen, 'A', line, sizeof(line)) || !strstr(line, "SILENT"))
		return false;
	for (int m = 1; m <= INST_MOTORS; m++) {
		const char *a = inst_row(screen, 'A', m), *b = inst_row(screen, 'B', m);

		if (!a || !b)
			return false;
		snprintf(line, sizeof(line), "%.*s", (int)strcspn(a, "\n"), a);
		if (line[1] != '!' || !strstr(line, " STALE "))
			return false;
		snprintf(line, sizeof(line), "%.*s", (int)strcspn(b, "\n"), b);
		if (strstr(line, "STALE") || !strstr(line, " ready "))
			return false;
	}
	return true;
}

/*
 * Two rmdd of one robot in one screen at 80x24; kill -9 of one: its line
 * says SILENT within 2 s while the other's keeps updating.
 */
static void test_instances(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	int64_t t0, t_cap, cap_ns, max_cap_ns = 0, end;
	long long b0, b1;
	char line[256];
	struct run r;

	f->rmdd = start_instance(f, 'A', NULL);
	f->rmdd_b = start_instance(f, 'B', NULL);
	start_top_args(f, 80, 24, "A_,B_");
	wait_screen(f, &r, instances_ok, NULL, "both instances and their 6 motors at 80x24");
	assert_fits(r.out, 80, "two instances at 80x24");
	assert_true(count_lines(r.out) <= 24);
	b0 = inst_cycles(r.out, 'B');
	run_free(&r);

	kill(f->rmdd->pid, SIGKILL);
	t0 = rmd_now_ns();
	end = t0 + (int64_t)SCREEN_MS * 1000000;
	for (;;) {
		t_cap = rmd_now_ns();
		capture(f, &r);
		cap_ns = rmd_now_ns() - t_cap;
		if (cap_ns > max_cap_ns)
			max_cap_ns = cap_ns;
		if (a_silent(r.out, NULL))
			break;
		if (rmd_now_ns() > end)
			fail_msg("A killed: its line not SILENT within %d ms; the screen:\n%s",
				 SCREEN_MS, r.out);
		run_free(&r);
		nanosleep(&(struct timespec){ .tv_nsec = POLL_NS }, NULL);
		kid_read(f->rmdd_b);
	}
	/* 1 s of silence, a 100 ms redraw: 2 s, plus the slowest capture of this run (twice) */
	if (rmd_now_ns() - t0 > 2000000000 + 2 * max_cap_ns + POLL_NS)
		fail_msg("SILENT after %.2f s (a capture took up to %.2f s):\n%s",
			 (double)(rmd_now_ns() - t0) / 1e9, (double)max_cap_ns / 1e9, r.out);
	assert_fits(r.out, 80, "one instance silent");
	b1 = inst_cycles(r.out, 'B');
	assert_non_null(inst_line(r.out, 'B', line, sizeof(line)));
	assert_null(strstr(line, "SILENT"));
	if (b1 <= b0)
		fail_msg("B's cycles did not move (%lld then %lld):\n%s", b0, b1, r.out);
	run_free(&r);
	/* and B keeps updating after A went */
	nanosleep(&(struct timespec){ .tv_nsec = 300000000 }, NULL);
	capture(f, &r);
	if (inst_cycles(r.out, 'B') <= b1 || !a_silent(r.out, NULL))
		fail_msg("B's line stopped with A silent (cycles %lld):\n%s", b1, r.out);
	run_free(&r);
}

/* `rmdctl top --prefix A_,B_ mode` (--json, --once) to its end, exit status 0, into r. */
static void top_both(struct fixture *f, struct run *r, const char *mode)
{
	run_prog(r, rmdctl_bin,
		 (const char *const[]){ "top", "--lcm-url", f->url, "--prefix", "A_,B_", mode,
					"--wait", "10", NULL },
		 NULL);
	assert_status(r, 0, mode);
}

/* --json and --once with two prefixes: every motor with its instance. */
static void test_instances_json(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	struct run r;
	const char *p;
	int na = 0, nb = 0;

	f->rmdd = start_instance(f, 'A', NULL);
	/* B is a part of a robot: named by its robot.instance, A by its prefix */
	f->rmdd_b = start_instance(f, 'B', "b_part");
	top_both(f, &r, "--json");
	assert_has(r.out, ",\"instances\":[{", "--json: the instances");
	for (p = r.out; (p = strstr(p, "\"instance\":\"A_\",\"name\":\"a_m")); p++)
		na++;
	for (p = r.out; (p = strstr(p, "\"instance\":\"b_part\",\"name\":\"b_m")); p++)
		nb++;
	if (na != INST_MOTORS || nb != INST_MOTORS)
		fail_msg("--json: %d motors of A_, %d of b_part, not %d each:\n%s", na, nb,
			 INST_MOTORS, r.out);
	assert_int_equal(count_lines(r.out), 1);
	run_free(&r);

	top_both(f, &r, "--once");
	assert_has(r.out, "INST     IDX NAME", "--once: the INST column");
	for (int m = 1; m <= INST_MOTORS; m++) {
		char row[32];

		snprintf(row, sizeof(row), "A_         %d a_m%d", m - 1, m);
		assert_has(r.out, row, "--once: A_'s motor");
		snprintf(row, sizeof(row), "b_part     %d b_m%d", m - 1, m);
		assert_has(r.out, row, "--once: B_'s motor");
	}
	run_free(&r);

	/* --robot: the instances heard on the robot's heartbeats, B alone (A is no robot part) */
	run_prog(&r, rmdctl_bin,
		 (const char *const[]){ "top", "--lcm-url", f->url, "--robot", "--once", "--wait",
					"10", NULL },
		 NULL);
	assert_status(&r, 0, "--robot --once");
	assert_has(r.out, "prefix B_,", "--robot: B, found by its heartbeat");
	assert_lacks(r.out, "prefix A_,", "--robot: A sends no heartbeat");
	assert_has(r.out, "b_part     0 b_m1", "--robot: B's motor by its instance name");
	run_free(&r);

	/* a prefix nobody publishes on: the error names that instance, not the others */
	const struct run_case bad[] = {
		{ .args = { "top", "--lcm-url", f->url, "--prefix", "A_,C_", "--json", "--wait",
			    "1", NULL },
		  .status = 1,
		  .err_has = { "C_ (config no, health no, state no)" },
		  .err_lacks = "A_ (config" },
		{ .args = { "top", "--prefix", "A_,,B_", "--json", NULL },
		  .status = 2,
		  .err_has = { "an empty prefix" } },
		{ .args = { "top", "--prefix", "A_,A_", "--json", NULL },
		  .status = 2,
		  .err_has = { "\"A_\" twice" } },
		{ .args = { "top", "--prefix", "A_,", "--json", NULL },
		  .status = 2,
		  .err_has = { "an empty prefix" } },
		/* "" alone stays a prefix (lcm.channel_prefix may be empty): nobody there, exit 1 */
		{ .args = { "top", "--lcm-url", f->url, "--prefix", "", "--json", "--wait", "0.5",
			    NULL },
		  .status = 1,
		  .err_has = { "no complete CONFIG" } },
	};

	run_cases(rmdctl_bin, bad, sizeof(bad) / sizeof(bad[0]), NULL);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown(test_fits_80x24, setup, teardown),
		cmocka_unit_test_setup_teardown(test_keys_resize, setup, teardown),
		cmocka_unit_test_setup_teardown(test_stale, setup, teardown),
		cmocka_unit_test_setup_teardown(test_instances, setup, teardown),
		cmocka_unit_test_setup_teardown(test_instances_json, setup, teardown),
	};

	return cmocka_run_group_tests_name("top_tty", tests, group_setup, lcm_tools_teardown);
}
