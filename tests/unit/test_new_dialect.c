// SPDX-License-Identifier: MIT
/*
 * A dialect with a command table of its own needs its codec rows and its
 * record, and nothing in rmdctl (issue 28, docs/design.md "How to add a
 * dialect").  This suite is built with "V5" added the way the tree adds a
 * dialect (tests/unit/new_dialect/: its key, its table, its row), around
 * the proto layer and rmdctl's encode and decode compiled from their
 * sources as they are; it runs `rmdctl encode` and `rmdctl decode` through
 * their entry points and judges what they print.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "tools/common/log.h"
#include "tools/rmdctl/rmdctl.h"
#include "harness/suite.h"

#define OUT_MAX 16384

/* What one run printed. */
struct run {
	int status;
	char out[OUT_MAX], err[OUT_MAX];
};

static void slurp(FILE *f, char *buf)
{
	size_t n;

	rewind(f);
	n = fread(buf, 1, OUT_MAX - 1, f);
	buf[n] = '\0';
	fclose(f);
}

/* main(argc, argv) of an rmdctl command, its stdout and stderr caught in files. */
static void run_cmd(struct run *r, int (*main_fn)(int, char **), const char *const *args)
{
	char *argv[16];
	int argc = 0, fd_out, fd_err;
	FILE *out = tmpfile(), *err = tmpfile();

	assert_non_null(out);
	assert_non_null(err);
	while (args[argc] && argc < 15) {
		argv[argc] = (char *)args[argc];
		argc++;
	}
	argv[argc] = NULL;
	tool_log_init(args[0], TOOL_LOG_DEBUG, TOOL_LOG_NO_LEVEL);
	fflush(stdout);
	fflush(stderr);
	fd_out = dup(1);
	fd_err = dup(2);
	assert_true(fd_out >= 0 && fd_err >= 0);
	dup2(fileno(out), 1);
	dup2(fileno(err), 2);
	r->status = main_fn(argc, argv);
	fflush(stdout);
	fflush(stderr);
	dup2(fd_out, 1);
	dup2(fd_err, 2);
	close(fd_out);
	close(fd_err);
	slurp(out, r->out);
	slurp(err, r->err);
}

#define ENCODE(r, ...) \
	run_cmd(r, rmdctl_encode_run, (const char *const[]){ "encode", __VA_ARGS__, NULL })
#define DECODE(r, ...) \
	run_cmd(r, rmdctl_decode_run, (const char *const[]){ "decode", __VA_ARGS__, NULL })

static void has(const char *text, const char *want, const char *what)
{
	if (!strstr(text, want))
		fail_msg("%s: \"%s\" not in:\n%s", what, want, text);
}

/* V5 is in the list, with its table: no comparison names it. */
static void test_record(void **state)
{
	const struct rmd_dialect *d = rmd_dialect(RMD_PROTO_V5);
	enum rmd_proto p;

	(void)state;
	assert_int_equal(rmd_proto_parse("V5", &p), 0);
	assert_int_equal(p, RMD_PROTO_V5);
	assert_true(rmd_dialect_is_firmware(d));
	assert_ptr_equal(rmd_cmd_find(RMD_PROTO_V5, 0xC1), &rmd_v5_cmds[3]);
	assert_null(rmd_cmd_find(RMD_PROTO_V5, 0xA2));
}

/* `rmdctl encode ARGS`: its exit status, stdout exactly (or NULL), a part of stderr (or NULL). */
static const struct enc_case {
	const char *args, *out, *err;
	int status;
} enc_cases[] = {
	/* V5 §1: 1 A is 1000 mA at data[2..3], to 0x600 + ID; its range cited from its row */
	{ "--protocol v5 --id 1 torque 1", "601#A100E80300000000\n", NULL, 0 },
	{ "--protocol v5 --id 3 torque -2.5", "603#A1003CF600000000\n", NULL, 0 },
	{ "--protocol v5 --id 1 torque 25", "", "(V5 §1: -20..20 A)", 2 },
	{ "--protocol v5 --id 2 stop", "602#8100000000000000\n", NULL, 0 },
	{ "--protocol v5 --id 1 status1", "601#9A00000000000000\n", NULL, 0 },
	/* commands of V5 alone: rmdctl's list has no word of them */
	{ "--protocol v5 --id 1 board-temp", "601#C100000000000000\n", NULL, 0 },
	{ "--protocol v5 --id 1 current-limit 12.5", "601#C200000000007D00\n", NULL, 0 },
	{ "--protocol v5 --id 1 current-limit 51", "", "(V5 §5: 0..50 A)", 2 },
	{ "--protocol v5 --id 1 raw read_board_temperature", "601#C100000000000000\n", NULL, 0 },
	/* what V5's table lacks, and which tables have it */
	{ "--protocol v5 --id 1 speed 1", "",
	  "speed: not a command of protocol V5 (--protocol v3 or v2 or v4)", 2 },
	{ "--protocol v3 --id 1 board-temp", "",
	  "board-temp: not a command of protocol V3 (--protocol v5)", 2 },
	{ "--protocol v5 --id 1 pid-read", "", "protocol V5 has no PID commands", 2 },
	{ "--protocol v6 --id 1 stop", "", "(v3, v2, mit, v4 or v5)", 2 },
	/* the dialects the tree has, as before */
	{ "--id 1 torque 1", "141#A100000064000000\n", NULL, 0 },
	{ "--protocol v4 --id 1 pid current-kp 1.5", "141#310100000000C03F\n", NULL, 0 },
};

static void test_encode(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(enc_cases) / sizeof(enc_cases[0]); i++) {
		const struct enc_case *c = &enc_cases[i];
		char words[160], *argv[12] = { "encode" }, *save = NULL;
		struct run r;
		size_t n = 1;

		snprintf(words, sizeof(words), "%s", c->args);
		for (char *w = strtok_r(words, " ", &save); w && n < 11;
		     w = strtok_r(NULL, " ", &save))
			argv[n++] = w;
		argv[n] = NULL;
		run_cmd(&r, rmdctl_encode_run, (const char *const *)argv);
		if (r.status != c->status || (c->out && strcmp(r.out, c->out)) ||
		    (c->err && !strstr(r.err, c->err)))
			fail_msg("encode %s: exit %d (want %d), printed \"%s\" (want \"%s\"), "
				 "said:\n%s",
				 c->args, r.status, c->status, r.out, c->out ? c->out : "", r.err);
	}
}

/* --help names the key and the command the list never heard of. */
static void test_encode_help(void **state)
{
	struct run r;

	(void)state;
	ENCODE(&r, "--help");
	assert_int_equal(r.status, 0);
	has(r.out, "[--protocol v3|v2|mit|v4|v5]", "encode --help");
	has(r.out, "v3 (default), v2, mit (= v3 tables plus `mit`), v4 or v5", "encode --help");
	has(r.out, "\n  board-temp\n      read_board_temperature (0xC1), protocol V5\n",
	    "encode --help");
	has(r.out, "\n  current-limit CURRENT_A\n      current_limit (0xC2), protocol V5\n",
	    "encode --help");
	DECODE(&r, "--help");
	has(r.out, "[--protocol v3|v2|mit|v4|v5]", "decode --help");
}

static const char frames[] = "601#A100E80300000000\n"
			     "681#A11A3CF600000000\n"
			     "681#9A1A4C1D01010000\n"
			     "681#C12A000000000000\n"
			     "601#9B00000000000000\n"
			     "141#9A00000000000000\n";

static void test_decode(void **state)
{
	char path[] = "/tmp/rmd-test-new-dialect-XXXXXX";
	int fd = mkstemp(path);
	struct run r;

	(void)state;
	assert_true(fd >= 0);
	assert_int_equal(write(fd, frames, sizeof(frames) - 1), (ssize_t)(sizeof(frames) - 1));
	close(fd);
	DECODE(&r, "--protocol", "v5", path);
	assert_int_equal(r.status, 0);
	has(r.out, "601 motor 1 request torque: current 1 A\n", "torque request");
	has(r.out, "681 motor 1 reply torque: temperature 26 °C, current -2.5 A\n", "torque reply");
	has(r.out,
	    "681 motor 1 reply read_status_1: temperature 26 °C, voltage 75 V, errors 0x0101 "
	    "(board_over_temperature, supply_low)\n",
	    "status reply");
	has(r.out, "681 motor 1 reply read_board_temperature: temperature 42 °C\n", "board");
	has(r.out, "601 motor 1 request unknown (command 0x9B is not in the V5 table)", "unknown");
	has(r.out, "141 unknown (not an identifier of protocol V5)", "V3's identifier");
	DECODE(&r, "--protocol", "v5", "--json", path);
	assert_int_equal(r.status, 0);
	has(r.out,
	    "{\"can_id\":1537,\"motor_id\":1,\"direction\":\"request\",\"cmd\":161,"
	    "\"name\":\"torque\",\"raw\":\"A100E80300000000\",\"current_a\":1}",
	    "json");
	/* the same frames are no V3 frames */
	DECODE(&r, "--protocol", "v3", path);
	has(r.out, "601 unknown (not an identifier of protocol V3)", "as V3");
	unlink(path);
}

SUITE_MAIN("new_dialect", NULL, NULL,
	   {
		   cmocka_unit_test(test_record),
		   cmocka_unit_test(test_encode),
		   cmocka_unit_test(test_encode_help),
		   cmocka_unit_test(test_decode),
	   })
