// SPDX-License-Identifier: MIT
/*
 * The dump/restore round trip (settings_trip.h).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "settings_trip.h"

#define TEXT_MAX 8192

struct trip {
	settings_run_fn *run;
	void *ctx;
	const char *const *bus_args;
	int status;
	const char *out, *err;
};

/* rmdctl args... bus_args...; must exit `status`. */
static void trip_run(struct trip *t, int status, const char *const *args)
{
	const char *argv[32];
	size_t n = 0;

	for (; *args && n < 16; args++)
		argv[n++] = *args;
	for (const char *const *b = t->bus_args; *b && n < 31; b++)
		argv[n++] = *b;
	argv[n] = NULL;
	t->run(t->ctx, argv, &t->status, &t->out, &t->err);
	if (t->status != status)
		fail_msg("rmdctl %s %s: exit %d, expected %d\nstdout:\n%s\nstderr:\n%s", argv[0],
			 argv[1] ? argv[1] : "", t->status, status, t->out, t->err);
}
#define TRIP(t, status, ...) trip_run((t), (status), (const char *const[]){ __VA_ARGS__, NULL })

static void has(const struct trip *t, const char *hay, const char *needle)
{
	if (!strstr(hay, needle))
		fail_msg("\"%s\" missing from:\n%s\nstderr:\n%s", needle, hay, t->err);
}

/* The dump from "motors:" on (the header has the time), into buf. */
static void motors_of(const struct trip *t, char *buf)
{
	const char *m = strstr(t->out, "\nmotors:\n");

	if (!m)
		fail_msg("no motors: list in the dump:\n%s", t->out);
	snprintf(buf, TEXT_MAX, "%s", m);
}

static void write_file(const char *path, const char *text)
{
	FILE *f = fopen(path, "w");

	assert_non_null(f);
	assert_int_equal(fputs(text, f) >= 0, 1);
	assert_int_equal(fclose(f), 0);
}

/* s with the first `from` after `after` replaced by `to`, into buf. */
static void edit(char *buf, const char *s, const char *after, const char *from, const char *to)
{
	const char *a = strstr(s, after), *p = a ? strstr(a, from) : NULL;

	if (!p)
		fail_msg("no \"%s\" after \"%s\" in:\n%s", from, after, s);
	snprintf(buf, TEXT_MAX, "%.*s%s%s", (int)(p - s), s, to, p + strlen(from));
}

/*
 * path[0] = dir/<name>.yaml, path[1] = dir/<name>-edited.yaml (a round
 * trip's own two files); the dump of both motors as it starts, into orig
 * and written to path[0].
 */
static void first_dump(struct trip *t, const char *dir, const char *name, char path[2][512],
		       char *orig)
{
	snprintf(path[0], 512, "%s/%s.yaml", dir, name);
	snprintf(path[1], 512, "%s/%s-edited.yaml", dir, name);
	TRIP(t, 0, "dump", "1-2");
	snprintf(orig, TEXT_MAX, "%s", t->out);
	write_file(path[0], orig);
}

/* A dump of both motors now holds the motors of the dump `want` (a and b: scratch buffers). */
static void dump_is(struct trip *t, const char *want, char *a, char *b)
{
	TRIP(t, 0, "dump", "1-2");
	motors_of(t, a);
	motors_of(&(struct trip){ .out = want }, b);
	assert_string_equal(a, b);
}

/* The motors hold the first dump again (a, b: scratch); the round trip's files go. */
static void back_to_first(struct trip *t, char path[2][512], const char *orig, char *a, char *b)
{
	dump_is(t, orig, a, b);
	assert_int_equal(remove(path[0]), 0);
	assert_int_equal(remove(path[1]), 0);
}

void settings_round_trip(settings_run_fn *run, void *ctx, const char *const *bus_args,
			 const char *dir)
{
	static char orig[TEXT_MAX], text[TEXT_MAX], a[TEXT_MAX], b[TEXT_MAX], path[2][512];
	struct trip t = { .run = run, .ctx = ctx, .bus_args = bus_args };

	/* dump: both motors, rmd-sim's defaults (src/sim) */
	first_dump(&t, dir, "motors", path, orig);
	has(&t, orig, "protocol: v3\n");
	has(&t, orig, "  - id: 1\n");
	has(&t, orig, "  - id: 2\n");
	has(&t, orig,
	    "    pid: {current_kp: 85, current_ki: 25, speed_kp: 85, speed_ki: 25, "
	    "position_kp: 85, position_ki: 25}\n");
	has(&t, orig, "    accel_dps2: 10000\n");
	has(&t, orig, "    zero_offset: 0\n");
	has(&t, orig, "# Not readable");

	/* edit: motor 1's speed kp, acceleration and zero; motor 2's comm-loss time */
	edit(a, orig, "id: 1", "speed_kp: 85", "speed_kp: 60");
	edit(b, a, "id: 1", "accel_dps2: 10000", "accel_dps2: 2500");
	edit(a, b, "id: 1", "zero_offset: 0", "zero_offset: 1234");
	edit(text, a, "id: 2", "zero_offset: 0\n", "zero_offset: 0\n    comm_loss_ms: 300\n");
	write_file(path[1], text);

	/* without a terminal and --yes: the diff, a refusal, nothing written */
	TRIP(&t, 2, "restore", path[1]);
	has(&t, t.out, "motor 1: pid: speed_kp 85 -> 60\n");
	has(&t, t.out, "motor 1: accel_dps2 10000 -> 2500\n");
	has(&t, t.out, "motor 1: zero_offset 0 -> 1234 (used after `rmdctl reset 1`)\n");
	has(&t, t.out, "motor 2: comm_loss_ms -> 300 (cannot be read back: written as given)\n");
	if (strstr(t.out, "motor 2: pid") || strstr(t.out, "motor 2: accel"))
		fail_msg("motor 2's unchanged values in the diff:\n%s", t.out);
	has(&t, t.err, "refusing to write these 4 changes to 2 motors on ");
	dump_is(&t, orig, a, b);

	/*
	 * --yes: written; read back; the zero offset after a reset.  A runner
	 * that retries a run the busy machine made too slow (the RS485 suite)
	 * shows the retry's output, which writes what the first try did not:
	 * fewer changes, the same result, which the dumps below judge.
	 */
	TRIP(&t, 0, "restore", path[1], "--yes");
	if (!strstr(t.out, ": 4 changes to 2 motors written to ROM, each answered\n") &&
	    !(strstr(t.err, "busy machine") && strstr(t.out, "written to ROM, each answered\n")))
		fail_msg("restore --yes: not \"4 changes to 2 motors written\":\n%s\nstderr:\n%s",
			 t.out, t.err);
	TRIP(&t, 0, "dump", "1-2");
	has(&t, t.out, "speed_kp: 60, ");
	has(&t, t.out, "accel_dps2: 2500\n    zero_offset: 0\n"); /* ROM: after a reset */
	TRIP(&t, 0, "reset", "1");
	TRIP(&t, 0, "dump", "1-2");
	motors_of(&t, a);
	motors_of(&(struct trip){ .out = text }, b);
	/* the edited file less motor 2's comm_loss_ms line, which a dump cannot hold */
	edit(text, b, "id: 2", "    comm_loss_ms: 300\n", "");
	assert_string_equal(a, text);

	/* again: only what a dump cannot read is written */
	TRIP(&t, 0, "restore", path[1], "--yes");
	has(&t, t.out, "motor 1: unchanged\n");
	has(&t, t.out, ": 1 change to 1 motor written to ROM, each answered\n");

	/* and back to the first dump */
	TRIP(&t, 0, "restore", path[0], "--yes");
	has(&t, t.out, "motor 2: unchanged\n");
	TRIP(&t, 0, "reset", "1");
	back_to_first(&t, path, orig, a, b);
}

void settings_round_trip_v4(settings_run_fn *run, void *ctx, const char *const *bus_args,
			    const char *const *v3_bus_args, const char *dir)
{
	static char orig[TEXT_MAX], text[TEXT_MAX], a[TEXT_MAX], b[TEXT_MAX], path[2][512];
	struct trip t = { .run = run, .ctx = ctx, .bus_args = bus_args };
	struct trip t3 = { .run = run, .ctx = ctx, .bus_args = v3_bus_args };

	/* dump: the simulator's gains, 1.0 each, seven of them (V4.2 §2.1.4) */
	first_dump(&t, dir, "v4", path, orig);
	has(&t, orig, "protocol: v4\n");
	has(&t, orig, "    firmware: 2025070202  # not restored\n");
	has(&t, orig,
	    "    pid: {current_kp: 1, current_ki: 1, speed_kp: 1, speed_ki: 1, "
	    "position_kp: 1, position_ki: 1, position_kd: 1}\n");

	/* 0.123456789 is no binary32: the nearest is 0.123456791, and that is what stays */
	edit(text, orig, "id: 1", "speed_kp: 1,", "speed_kp: 0.123456789,");
	edit(a, text, "id: 1", "position_kd: 1}", "position_kd: 2.5e-3}");
	write_file(path[1], a);
	TRIP(&t, 0, "restore", path[1], "--yes");
	has(&t, t.out, "motor 1: pid: speed_kp 1 -> 0.123456791\n");
	has(&t, t.out, "motor 1: pid: position_kd 1 -> 0.00249999994\n");
	has(&t, t.out, "motor 2: unchanged\n");
	TRIP(&t, 0, "dump", "1-2");
	has(&t, t.out, "speed_kp: 0.123456791, ");
	has(&t, t.out, "position_kd: 0.00249999994}");
	/* the dump restores to itself: every gain exactly as it was read */
	snprintf(b, sizeof(b), "%s", t.out);
	write_file(path[1], b);
	TRIP(&t, 0, "restore", path[1], "--yes");
	has(&t, t.out, "motor 1: unchanged\n");
	has(&t, t.out, "motor 2: unchanged\n");

	/* a V4 file for motors said to be V3: refused, nothing written */
	TRIP(&t3, 2, "restore", path[1], "--yes");
	has(&t3, t3.err, "dumped from protocol v4 motors, these are v3");

	/* and back to the first dump */
	TRIP(&t, 0, "restore", path[0], "--yes");
	back_to_first(&t, path, orig, a, b);
}
