// SPDX-License-Identifier: MIT
/*
 * Firmware personalities of the simulated motor (rmd/sim_personality.h):
 * the field vectors of tests/data/field/ replayed byte for byte against the
 * motor's frame interface, each personality's behaviour, and the
 * personality file's parser (hostile inputs), writer and loader.
 *
 * Data: tests/data/field/ under the repository root (the current
 * directory; $RMD_SRCDIR overrides).
 */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <unistd.h>

#include <cmocka.h>

#include "rmd/candump.h"
#include "rmd/codec.h"
#include "rmd/personality_load.h"
#include "rmd/sim.h"
#include "rmd/sim_params.h"
#include "rmd/sim_personality.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)
#define MAXREP 16

static const char *srcdir = ".";

/* ---- Field vectors (tests/data/field/README.md) -------------------------- */

struct vec {
	const char *path;
	unsigned line;
	char err[512];
	struct rmd_sim_motor m;
	bool have_motor;
	int64_t now;
	struct rmd_frame got[MAXREP]; /* the motor's frames not yet matched by `<` lines */
	int n_got, next;
	bool expect_open; /* a `>` or `wait` whose frames the `<` lines list */
	bool saw_source, saw_captured, needs_personality;
};

__attribute__((format(printf, 2, 3))) static int vfail(struct vec *v, const char *fmt, ...)
{
	char msg[400];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	snprintf(v->err, sizeof(v->err), "%s:%u: %s", v->path, v->line, msg);
	return -1;
}

static void frame_text(const struct rmd_frame *f, char *out, size_t size)
{
	int n = snprintf(out, size, "%03X#", f->can_id);

	for (unsigned i = 0; i < f->len && n > 0 && (size_t)n + 3 <= size; i++)
		n += snprintf(out + n, size - (size_t)n, "%02X", f->data[i]);
}

/* "ID#DATA" with '.' as a wildcard hex digit: the frame and the mask of the digits given. */
static int parse_frame(const char *s, struct rmd_frame *f, uint8_t mask[RMD_FRAME_LEN])
{
	char text[64];
	struct rmd_candump_line l;
	const char *hash = strchr(s, '#');
	size_t n = strlen(s);

	if (!hash || n >= sizeof(text))
		return -EINVAL;
	memcpy(text, s, n + 1);
	memset(mask, 0xFF, RMD_FRAME_LEN);
	for (size_t i = (size_t)(hash - s) + 1, d = 0; i < n; i++, d++) {
		if (text[i] != '.')
			continue;
		text[i] = '0';
		if (d / 2 < RMD_FRAME_LEN)
			mask[d / 2] &= d % 2 ? 0xF0 : 0x0F;
	}
	if (rmd_candump_parse(text, &l) < 0 || l.frame.len != RMD_FRAME_LEN)
		return -EINVAL;
	*f = l.frame;
	return 0;
}

/* Frames the last `>` or `wait` gave that no `<` line took: a failure. */
static int close_expect(struct vec *v)
{
	char t[40];

	if (v->expect_open && v->next < v->n_got) {
		frame_text(&v->got[v->next], t, sizeof(t));
		return vfail(v, "the motor sent %s, which no `<` line expects", t);
	}
	v->n_got = v->next = 0;
	v->expect_open = false;
	return 0;
}

static int motor_line(struct vec *v, char *args, bool no_personality)
{
	struct rmd_sim_motor_params p;
	unsigned id = 1;
	char *tok, *save = NULL;

	if (v->have_motor)
		return vfail(v, "a second `motor` line");
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V4);
	for (tok = strtok_r(args, " \t", &save); tok; tok = strtok_r(NULL, " \t", &save)) {
		char *eq = strchr(tok, '='), allowed[512];
		const struct rmd_sim_param *row;

		if (!eq)
			return vfail(v, "\"%s\": expected KEY=VALUE", tok);
		*eq = '\0';
		if (!strcmp(tok, "id")) {
			id = (unsigned)strtoul(eq + 1, NULL, 0);
			continue;
		}
		row = rmd_sim_param_find(tok);
		if (!row)
			return vfail(v, "\"%s\" is not a motor parameter", tok);
		if (rmd_sim_param_parse_file(&p, row, eq + 1, allowed, sizeof(allowed)) < 0)
			return vfail(v, "%s: \"%s\": expected %s", tok, eq + 1, allowed);
	}
	if (id < 1 || id > RMD_MAX_MOTORS)
		return vfail(v, "id %u: expected 1..%d", id, RMD_MAX_MOTORS);
	p.id = (uint8_t)id;
	p.turnaround_jitter_ns = 0.0;
	if (no_personality)
		p.personality = (struct rmd_personality){ .source = RMD_PERSONALITY_NONE };
	rmd_sim_motor_init(&v->m, &p, 0);
	v->have_motor = true;
	return 0;
}

static int vec_line(struct vec *v, char *s, bool no_personality)
{
	struct rmd_frame f;
	uint8_t mask[RMD_FRAME_LEN];
	char t[40];

	if (!strncmp(s, "source ", 7)) {
		v->saw_source = true;
		return 0;
	}
	if (!strncmp(s, "captured ", 9)) {
		s += 9;
		if (strcmp(s, "yes") && strcmp(s, "no") && strcmp(s, "partly"))
			return vfail(v, "captured \"%s\": expected yes, no or partly", s);
		v->saw_captured = true;
		return 0;
	}
	if (!strncmp(s, "without-personality ", 20)) {
		s += 20;
		if (strcmp(s, "fails") && strcmp(s, "passes"))
			return vfail(v, "without-personality \"%s\": expected fails or passes", s);
		v->needs_personality = !strcmp(s, "fails");
		return 0;
	}
	if (!strncmp(s, "motor ", 6))
		return motor_line(v, s + 6, no_personality);
	if (!v->have_motor)
		return vfail(v, "a frame or wait before the `motor` line");
	if (s[0] == '>' || !strncmp(s, "wait ", 5)) {
		if (close_expect(v) < 0)
			return -1;
		if (s[0] == '>') {
			if (parse_frame(s + 1 + strspn(s + 1, " "), &f, mask) < 0)
				return vfail(v, "\"%s\": expected > ID#DATA, 8 bytes", s);
			v->n_got = rmd_sim_motor_receive(&v->m, v->now, &f, v->got, MAXREP);
		} else {
			long ms = strtol(s + 5, NULL, 10);

			if (ms <= 0 || ms > 600000)
				return vfail(v, "\"%s\": expected wait MS, 1..600000", s);
			v->now += ms * MS;
			v->n_got = rmd_sim_motor_poll(&v->m, v->now, v->got, MAXREP);
		}
		v->expect_open = true;
		return 0;
	}
	if (s[0] == '<') {
		const char *want = s + 1 + strspn(s + 1, " ");

		if (!v->expect_open)
			return vfail(v, "a `<` line without a `>` or `wait` before it");
		if (!strcmp(want, "none")) {
			if (v->next < v->n_got) {
				frame_text(&v->got[v->next], t, sizeof(t));
				return vfail(v, "expected nothing, the motor sent %s", t);
			}
			return 0;
		}
		if (parse_frame(want, &f, mask) < 0)
			return vfail(v, "\"%s\": expected < ID#DATA (8 bytes, '.' any digit)", s);
		if (v->next >= v->n_got)
			return vfail(v, "expected %s, the motor sent nothing more", want);
		frame_text(&v->got[v->next], t, sizeof(t));
		if (v->got[v->next].can_id != f.can_id || v->got[v->next].len != f.len)
			return vfail(v, "expected %s, the motor sent %s", want, t);
		for (unsigned i = 0; i < RMD_FRAME_LEN; i++)
			if ((v->got[v->next].data[i] ^ f.data[i]) & mask[i])
				return vfail(v, "expected %s, the motor sent %s", want, t);
		v->next++;
		return 0;
	}
	return vfail(v, "\"%s\": not a directive (tests/data/field/README.md)", s);
}

/* Replay one vector file: 0, or -1 with v->err naming the file and line. */
static int run_vector(struct vec *v, const char *path, bool no_personality)
{
	char buf[512];
	FILE *f = fopen(path, "r");
	int r = 0;

	memset(v, 0, sizeof(*v));
	v->path = path;
	if (!f)
		return vfail(v, "cannot open: %s", strerror(errno));
	while (r == 0 && fgets(buf, sizeof(buf), f)) {
		char *s = buf, *hash = strchr(buf, '#'), *e;

		v->line++;
		/* a comment: '#' at the start or after a blank (frames have '#' inside) */
		if (hash && (hash == buf || hash[-1] == ' ' || hash[-1] == '\t'))
			*hash = '\0';
		while (*s == ' ' || *s == '\t')
			s++;
		e = s + strlen(s);
		while (e > s && (e[-1] == '\n' || e[-1] == '\r' || e[-1] == ' ' || e[-1] == '\t'))
			*--e = '\0';
		if (*s)
			r = vec_line(v, s, no_personality);
	}
	fclose(f);
	if (r == 0)
		r = close_expect(v);
	if (r == 0 && (!v->saw_source || !v->saw_captured || !v->have_motor))
		r = vfail(v, "a vector needs `source`, `captured` and `motor` lines");
	return r;
}

/* The vector files, sorted; returns their count. */
static unsigned vector_files(char paths[][768], unsigned max)
{
	char dir[256];
	struct dirent *e;
	unsigned n = 0;
	DIR *d;

	snprintf(dir, sizeof(dir), "%s/tests/data/field", srcdir);
	d = opendir(dir);
	if (!d)
		fail_msg("%s: %s", dir, strerror(errno));
	while ((e = readdir(d)) && n < max) {
		size_t len = strlen(e->d_name);

		if (len > 4 && !strcmp(e->d_name + len - 4, ".txt"))
			snprintf(paths[n++], 768, "%s/%s", dir, e->d_name);
	}
	closedir(d);
	qsort(paths, n, 768, (int (*)(const void *, const void *))strcmp);
	return n;
}

static struct vec vec;
static char paths[32][768];

/* Every vector of tests/data/field/ replays exactly. */
static void test_field_vectors(void **state)
{
	unsigned n = vector_files(paths, 32);

	(void)state;
	assert_true(n >= 6);
	for (unsigned i = 0; i < n; i++)
		if (run_vector(&vec, paths[i], false) < 0)
			fail_msg("%s", vec.err);
}

/* A vector that says so fails with personality=none: it judges the personality. */
static void test_field_vectors_need_personality(void **state)
{
	unsigned n = vector_files(paths, 32), needing = 0;

	(void)state;
	for (unsigned i = 0; i < n; i++) {
		bool needs;

		run_vector(&vec, paths[i], false);
		needs = vec.needs_personality;
		if (run_vector(&vec, paths[i], true) == 0) {
			if (needs)
				fail_msg("%s: passes without its personality", paths[i]);
		} else if (!needs) {
			fail_msg("%s (personality=none): %s", paths[i], vec.err);
		}
		needing += needs;
	}
	assert_true(needing >= 4);
}

/* The runner itself refuses a wrong expectation, a missing one and an extra frame. */
static void test_field_runner_judges(void **state)
{
	static const struct {
		const char *text;
		const char *err;
	} cases[] = {
		{ "source t\ncaptured no\nmotor personality=x4-64-2025070202\n"
		  "> 141#B200000000000000\n< 241#B20000007A1EB479\n",
		  ":5: expected 241#B20000007A1EB479, the motor sent 241#B20000007A1EB478" },
		{ "source t\ncaptured no\nmotor personality=x4-64-2025070202\n"
		  "> 141#B200000000000000\n",
		  ":4: the motor sent 241#B20000007A1EB478, which no `<` line expects" },
		{ "source t\ncaptured no\nmotor personality=x4-64-2025070202\n"
		  "> 142#B200000000000000\n< 242#B20000007A1EB478\n",
		  ":5: expected 242#B20000007A1EB478, the motor sent nothing more" },
		{ "source t\ncaptured no\n> 141#B200000000000000\n",
		  ":3: a frame or wait before the `motor` line" },
		{ "captured no\nmotor id=1\n", "needs `source`" },
	};
	char path[] = "/tmp/rmd-test-field-XXXXXX";

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		int fd = mkstemp(path);

		assert_true(fd >= 0);
		assert_int_equal(write(fd, cases[i].text, strlen(cases[i].text)),
				 (ssize_t)strlen(cases[i].text));
		close(fd);
		if (run_vector(&vec, path, false) == 0)
			fail_msg("case %zu passes", i);
		if (!strstr(vec.err, cases[i].err))
			fail_msg("case %zu: %s (want %s)", i, vec.err, cases[i].err);
		unlink(path);
		strcpy(path, "/tmp/rmd-test-field-XXXXXX");
	}
}

/* ---- Selection ---------------------------------------------------------- */

static void init_motor(struct rmd_sim_motor *m, struct rmd_sim_motor_params *p)
{
	rmd_sim_motor_init(m, p, 0);
}

/* A motor without a personality behaves as before: none is picked by default. */
static void test_default_picks_none(void **state)
{
	static const enum rmd_proto protos[] = { RMD_PROTO_V3, RMD_PROTO_V2, RMD_PROTO_MIT,
						 RMD_PROTO_V4 };
	static struct rmd_sim_motor m;

	(void)state;
	for (size_t i = 0; i < sizeof(protos) / sizeof(protos[0]); i++) {
		struct rmd_sim_motor_params p;

		rmd_sim_motor_params_default(&p, 1, protos[i]);
		init_motor(&m, &p);
		assert_int_equal(m.p.personality.source, RMD_PERSONALITY_AUTO);
		assert_false(m.p.answers_79_as_b2 || m.p.set_id_replies_new ||
			     m.p.comm_loss_silent || m.p.comm_loss_executes_first ||
			     m.p.a4_ignored_after_mit || m.p.status1_executing);
		assert_int_equal(m.p.boot_ms, 0);
		assert_int_equal(m.p.comm_loss_f1_ms, 1000);
	}
}

/* auto picks by model, date and dialect; a name picks one; none picks nothing. */
static void test_selection(void **state)
{
	static struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	char allowed[256];

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V4);
	strcpy(p.model, "x4-64");
	p.version_date = 2025070202;
	init_motor(&m, &p);
	assert_string_equal(m.p.personality.name, "x4-64-2025070202");
	assert_true(m.p.answers_79_as_b2 && m.p.set_id_replies_new && m.p.status1_executing);
	assert_int_equal(m.p.boot_ms, 1120);
	/* the same model and date on V3 tables: not that firmware */
	p.proto = RMD_PROTO_V3;
	init_motor(&m, &p);
	assert_int_equal(m.p.personality.source, RMD_PERSONALITY_AUTO);
	assert_false(m.p.answers_79_as_b2);
	/* another date: none */
	p.proto = RMD_PROTO_V4;
	p.version_date = 2026042402;
	init_motor(&m, &p);
	assert_int_equal(m.p.personality.source, RMD_PERSONALITY_AUTO);
	/* named: its model, date and dialect come with it */
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	assert_int_equal(rmd_sim_param_parse(&p, rmd_sim_param_find("personality"),
					     "X6-P20-2025070202", allowed, sizeof(allowed)),
			 0);
	init_motor(&m, &p);
	assert_string_equal(m.p.model, "X6-P20");
	assert_int_equal(m.p.version_date, 2025070202);
	assert_true(m.d == rmd_dialect(RMD_PROTO_V4));
	assert_true(m.p.a4_ignored_after_mit);
	/* none over a matching model and date */
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V4);
	strcpy(p.model, "X4-64");
	p.version_date = 2025070202;
	assert_int_equal(rmd_sim_param_parse(&p, rmd_sim_param_find("personality"), "none", allowed,
					     sizeof(allowed)),
			 0);
	init_motor(&m, &p);
	assert_int_equal(m.p.personality.source, RMD_PERSONALITY_NONE);
	assert_false(m.p.answers_79_as_b2);
	/* a name that is neither a personality nor a file */
	assert_int_equal(rmd_sim_param_parse_file(&p, rmd_sim_param_find("personality"),
						  "x4-64-20250702", allowed, sizeof(allowed)),
			 -EINVAL);
	assert_non_null(strstr(allowed, "x4-64-2025070202, x4-36-2025070202"));
	assert_non_null(strstr(allowed, "(no such file)"));
}

/* Each flag is a bool row of the parameter table, at the offset the personality writes. */
static void test_flag_rows(void **state)
{
	(void)state;
	for (unsigned f = 0; f < RMD_PERSONALITY_N_FLAGS; f++) {
		const char *key = rmd_personality_flag_key((enum rmd_personality_flag)f);
		const struct rmd_sim_param *row = key ? rmd_sim_param_find(key) : NULL;

		assert_non_null(row);
		assert_int_equal(row->type, RMD_SIM_PARAM_BOOL);
		assert_int_equal(row->off,
				 rmd_personality_flag_offset((enum rmd_personality_flag)f));
	}
}

/* ---- Behaviour beyond the vectors --------------------------------------- */

static int rx(struct rmd_sim_motor *m, int64_t t, uint32_t id, const uint8_t d[8],
	      struct rmd_frame *out)
{
	struct rmd_frame f = { .can_id = id, .len = 8 };

	memcpy(f.data, d, 8);
	return rmd_sim_motor_receive(m, t, &f, out, MAXREP);
}

/* comm_loss_f1_ms, comm_loss_silent and comm_loss_executes_first on V3 and V4 alike. */
static void test_comm_loss_flags(void **state)
{
	static const enum rmd_proto protos[] = { RMD_PROTO_V3, RMD_PROTO_MIT, RMD_PROTO_V4 };
	static const uint8_t status[8] = { 0x9A };
	static struct rmd_sim_motor m;
	struct rmd_frame out[MAXREP];

	(void)state;
	for (size_t i = 0; i < sizeof(protos) / sizeof(protos[0]); i++) {
		struct rmd_sim_motor_params p;
		uint32_t req = rmd_dialect(protos[i])->req_base + 1;
		int n;

		/* a 250 ms period */
		rmd_sim_motor_params_default(&p, 1, protos[i]);
		p.comm_loss_rom_ms = 100;
		p.comm_loss_f1_ms = 250;
		init_motor(&m, &p);
		assert_int_equal(rx(&m, 0, req, status, out), 1);
		assert_int_equal(rmd_sim_motor_poll(&m, 101 * MS, out, MAXREP), 1);
		assert_int_equal(out[0].data[0], 0xF1);
		assert_int_equal(rmd_sim_motor_poll(&m, 350 * MS, out, MAXREP), 0);
		assert_int_equal(rmd_sim_motor_poll(&m, 351 * MS, out, MAXREP), 1);
		/* the first command only echoed */
		assert_int_equal(rx(&m, 352 * MS, req, status, out), 1);
		assert_memory_equal(out[0].data, status, 8);
		/* silent, and the first command executed */
		p.comm_loss_silent = true;
		p.comm_loss_executes_first = true;
		init_motor(&m, &p);
		assert_int_equal(rx(&m, 0, req, status, out), 1);
		assert_int_equal(rmd_sim_motor_poll(&m, 5000 * MS, out, MAXREP), 0);
		assert_int_equal(rmd_sim_motor_next_event_ns(&m), INT64_MAX);
		n = rx(&m, 5001 * MS, req, status, out);
		assert_int_equal(n, 1);
		assert_int_equal(out[0].data[0], 0x9A);
		assert_int_equal(out[0].data[1], 25); /* a status, not the echo */
	}
}

/* A recording's turnaround lines: the draws follow its quantiles, per command. */
static void test_turnaround_quantiles(void **state)
{
	static const char text[] = "format = rmd-personality 1\n"
				   "turnaround 0x9C = 400 500 600 900 1500 2000 n=1000\n"
				   "turnaround * = 100 100 100 100 100 100\n";
	static struct rmd_sim_motor m;
	static int64_t t[20000];
	struct rmd_sim_motor_params p;
	struct rmd_frame r9c = { .can_id = 0x141, .len = 8, .data = { 0x9C } };
	struct rmd_frame r9a = { .can_id = 0x141, .len = 8, .data = { 0x9A } };
	char err[256];
	int n = 20000, below50 = 0, below90 = 0;

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V4);
	assert_int_equal(rmd_personality_parse(text, strlen(text), "t", &p.personality, err,
					       sizeof(err)),
			 0);
	init_motor(&m, &p);
	for (int i = 0; i < n; i++) {
		int64_t at = (int64_t)i * 100 * MS;

		t[i] = rmd_sim_motor_reply_due(&m, at, &r9c) - at;
		assert_true(t[i] >= 400000 && t[i] <= 2000000);
		below50 += t[i] <= 600000;
		below90 += t[i] <= 900000;
	}
	assert_true(abs(below50 - n / 2) < n / 50);
	assert_true(abs(below90 - n * 9 / 10) < n / 50);
	assert_int_equal(rmd_sim_motor_reply_due(&m, INT64_C(1) << 50, &r9a) - (INT64_C(1) << 50),
			 100000);
}

/* A recording's ignored commands get no answer. */
static void test_ignores(void **state)
{
	static const char text[] = "format = rmd-personality 1\nignores = 0x92, 0xB5\n";
	static struct rmd_sim_motor m;
	struct rmd_sim_motor_params p;
	struct rmd_frame out[MAXREP];
	char err[256];

	(void)state;
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	assert_int_equal(rmd_personality_parse(text, strlen(text), "t", &p.personality, err,
					       sizeof(err)),
			 0);
	init_motor(&m, &p);
	assert_int_equal(rx(&m, 0, 0x141, (const uint8_t[8]){ 0x92 }, out), 0);
	assert_int_equal(rx(&m, 0, 0x141, (const uint8_t[8]){ 0xB5 }, out), 0);
	assert_int_equal(rx(&m, 0, 0x141, (const uint8_t[8]){ 0x9A }, out), 1);
}

/* ---- The file format ---------------------------------------------------- */

/* Written and read back, a record is the same: the built-ins and a recording. */
static void test_write_parse_roundtrip(void **state)
{
	static struct rmd_personality recs[8], back;
	static char text[RMD_PERSONALITY_FILE_MAX];
	size_t n = 0;
	char err[256];

	(void)state;
	for (size_t i = 0; i < rmd_personality_builtin_count(); i++)
		recs[n++] = *rmd_personality_builtin_at(i);
	memset(&recs[n], 0, sizeof(recs[n]));
	recs[n].source = RMD_PERSONALITY_FILE;
	strcpy(recs[n].name, "bench-x8");
	recs[n].set = RMD_PERSONALITY_HAS_MIT | RMD_PERSONALITY_HAS_BOOT;
	recs[n].mit = rmd_mit_default_ranges;
	recs[n].mit.t_min = -18.1;
	recs[n].mit.t_max = 18.1;
	recs[n].boot_ms = 987;
	recs[n].ignores[0x92 >> 3] = 1u << (0x92 & 7);
	recs[n].ignores[31] = 0x80;
	rmd_personality_set_flag(&recs[n], RMD_PERSONALITY_B3_ANSWER_ZEROS, true);
	recs[n].n_turnaround = 2;
	recs[n].turnaround[0] = (struct rmd_personality_turnaround){ .cmd = 0x9C,
								     .samples = 200,
								     .q_us = { 1, 2, 3, 4, 5, 6 } };
	recs[n].turnaround[1] =
		(struct rmd_personality_turnaround){ .cmd = RMD_PERSONALITY_CMD_MIT,
						     .q_us = { 7, 7, 7, 8, 9, 10000000 } };
	n++;
	for (size_t i = 0; i < n; i++) {
		FILE *f = fmemopen(text, sizeof(text), "w");

		assert_non_null(f);
		assert_int_equal(rmd_personality_write(f, &recs[i], "a test\nof two lines"), 0);
		fclose(f);
		if (rmd_personality_parse(text, strlen(text), "mem", &back, err, sizeof(err)))
			fail_msg("%s: %s\n%s", recs[i].name, err, text);
		recs[i].source = RMD_PERSONALITY_FILE;
		if (memcmp(&back, &recs[i], sizeof(back)))
			fail_msg("%s: read back differs:\n%s", recs[i].name, text);
	}
}

/* Hostile and malformed files: a clear error naming the line and the key. */
static void test_parse_hostile(void **state)
{
	static const struct {
		const char *text;
		int r;
		const char *err;
	} cases[] = {
		{ "", -EINVAL, "f: empty: expected `format = rmd-personality 1` first" },
		{ "model = X4-64\n", -EINVAL, "f:1: model: the first line must be `format" },
		{ "format = rmd-personality 2\n", -EINVAL, "f:1: format: the first line" },
		{ "format = rmd-personality 1\nformat = rmd-personality 1\n", -EINVAL,
		  "f:2: format: given twice" },
		{ "format = rmd-personality 1\nmodel\n", -EINVAL, "f:2: \"model\": expected key" },
		{ "format = rmd-personality 1\n= 3\n", -EINVAL, "f:2: a value without a key" },
		{ "format = rmd-personality 1\nmodel = X4 64\n", -EINVAL,
		  "f:2: model: \"X4 64\": expected 1..7 printable" },
		{ "format = rmd-personality 1\nmodel = X4-64\nmodel = X4-36\n", -EINVAL,
		  "f:3: model: given twice" },
		{ "format = rmd-personality 1\nversion_date = 20251399\n", -EINVAL,
		  "f:2: version_date: \"20251399\": expected a date" },
		{ "format = rmd-personality 1\ndialect = v5\n", -EINVAL,
		  "f:2: dialect: \"v5\": expected v3, v2, mit" },
		{ "format = rmd-personality 1\nboot_ms = -1\n", -EINVAL,
		  "f:2: boot_ms: \"-1\": expected an integer 0..600000" },
		{ "format = rmd-personality 1\nmit_ranges = 1,2,3\n", -EINVAL,
		  "f:2: mit_ranges: \"1,2,3\": expected P,V,T,KP,KD" },
		{ "format = rmd-personality 1\nanswers_79_as_b2 = maybe\n", -EINVAL,
		  "f:2: answers_79_as_b2: \"maybe\": expected yes or no" },
		{ "format = rmd-personality 1\ninertia_kgm2 = 1\n", -EINVAL,
		  "f:2: inertia_kgm2: not a personality key" },
		{ "format = rmd-personality 1\nignores = 0x92 0x100\n", -EINVAL,
		  "f:2: ignores: \"0x100\": expected command bytes" },
		{ "format = rmd-personality 1\nturnaround 0x9C = 1 2 3 4 5\n", -EINVAL,
		  "f:2: turnaround 0x9C: 5 quantiles: expected 6" },
		{ "format = rmd-personality 1\nturnaround 0x9C = 1 2 3 4 5 6 7\n", -EINVAL,
		  "f:2: turnaround 0x9C: more than 6 quantiles" },
		{ "format = rmd-personality 1\nturnaround 0x9C = 1 2 3 2 5 6\n", -EINVAL,
		  "f:2: turnaround 0x9C: 2 µs is below the quantile before it (3 µs)" },
		{ "format = rmd-personality 1\nturnaround 0x9C = 1 2 3 4 5 10000001\n", -EINVAL,
		  "f:2: turnaround 0x9C: \"10000001\": expected whole µs" },
		{ "format = rmd-personality 1\nturnaround 0x9C = 1 2 3 4 5 -6\n", -EINVAL,
		  "expected whole µs" },
		{ "format = rmd-personality 1\nturnaround 0x9C = 1 2 3 4 5 6 n=3 n=4\n", -EINVAL,
		  "f:2: turnaround 0x9C: \"n=4\": n=COUNT comes once" },
		{ "format = rmd-personality 1\nturnaround 0x1FF = 1 2 3 4 5 6\n", -EINVAL,
		  "f:2: turnaround 0x1FF: \"0x1FF\" is not a command" },
		{ "format = rmd-personality 1\nturnaround mit = 1 2 3 4 5 6\n"
		  "turnaround MIT = 1 2 3 4 5 6\n",
		  -EINVAL, "f:3: turnaround MIT: given twice" },
		{ "format = rmd-personality 1\nname = a/b\n", -EINVAL,
		  "f:2: name: \"a/b\": expected 1..31 letters" },
		{ "format = rmd-personality 1\nmodel = X\0-64\n", -EINVAL, "f:2: a NUL byte" },
		{ "format = rmd-personality 1 # ok\n   # only a comment\n\n\r\nmodel = X4 # c\n", 0,
		  "" },
	};
	static char err[512];
	static struct rmd_personality out;

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		size_t len = strlen(cases[i].text);
		int r;

		if (!strcmp(cases[i].text, "format = rmd-personality 1\nmodel = X"))
			len += sizeof("\0-64\n") - 1; /* the NUL case: the bytes after it too */
		r = rmd_personality_parse(cases[i].text, len, "f", &out, err, sizeof(err));
		if (r != cases[i].r || !strstr(err, cases[i].err))
			fail_msg("case %zu: %d \"%s\" (want %d \"%s\")", i, r, err, cases[i].r,
				 cases[i].err);
	}
}

/* Bounded: size, lines, line length, rows; time linear (a 64 KiB file parses at once). */
static void test_parse_bounds(void **state)
{
	static char text[RMD_PERSONALITY_FILE_MAX + 2];
	static char err[512];
	static struct rmd_personality out;
	size_t n;

	(void)state;
	memset(text, '\n', sizeof(text));
	memcpy(text, "format = rmd-personality 1\n", 27);
	assert_int_equal(rmd_personality_parse(text, RMD_PERSONALITY_FILE_MAX + 1, "f", &out, err,
					       sizeof(err)),
			 -EFBIG);
	assert_non_null(strstr(err, "larger than the limit of 64 KiB"));
	/* 1024 lines pass, 1025 do not */
	assert_int_equal(rmd_personality_parse(text, 27 + 1023, "f", &out, err, sizeof(err)), 0);
	assert_int_equal(rmd_personality_parse(text, 27 + 1024, "f", &out, err, sizeof(err)),
			 -EFBIG);
	assert_non_null(strstr(err, "f:1025: more than 1024 lines"));
	/* a 64 KiB line */
	memset(text + 27, 'x', RMD_PERSONALITY_FILE_MAX - 27);
	assert_int_equal(rmd_personality_parse(text, RMD_PERSONALITY_FILE_MAX, "f", &out, err,
					       sizeof(err)),
			 -EINVAL);
	assert_non_null(strstr(err, "f:2: line longer than 255 characters"));
	/* 65 turnaround lines */
	n = (size_t)sprintf(text, "format = rmd-personality 1\n");
	for (unsigned c = 0; c <= RMD_PERSONALITY_CMDS_MAX; c++)
		n += (size_t)sprintf(text + n, "turnaround 0x%02X = 1 1 1 1 1 1\n", c);
	assert_int_equal(rmd_personality_parse(text, n, "f", &out, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "f:66: turnaround 0x40: more than 64 turnaround lines"));
}

/* The loader: a file, a directory, a missing file, and a file's error with its line. */
static void test_load(void **state)
{
	static const char good[] = "format = rmd-personality 1\nmodel = X4-64\n";
	static const char bad[] = "format = rmd-personality 1\n\nboot_ms = soon\n";
	char path[] = "/tmp/rmd-test-pers-XXXXXX", err[512], allowed[512];
	struct rmd_sim_motor_params p;
	static struct rmd_personality out;
	int fd;

	(void)state;
	fd = mkstemp(path);
	assert_true(fd >= 0);
	assert_int_equal(write(fd, good, sizeof(good) - 1), (ssize_t)sizeof(good) - 1);
	close(fd);
	assert_int_equal(rmd_personality_load(path, &out, err, sizeof(err)), 0);
	assert_string_equal(out.model, "X4-64");
	assert_int_equal(out.source, RMD_PERSONALITY_FILE);
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V4);
	assert_int_equal(rmd_sim_param_parse_file(&p, rmd_sim_param_find("personality"), path,
						  allowed, sizeof(allowed)),
			 0);
	assert_string_equal(p.personality.model, "X4-64");
	fd = open(path, O_WRONLY | O_TRUNC);
	assert_true(fd >= 0);
	assert_int_equal(write(fd, bad, sizeof(bad) - 1), (ssize_t)sizeof(bad) - 1);
	close(fd);
	assert_int_equal(rmd_sim_param_parse_file(&p, rmd_sim_param_find("personality"), path,
						  allowed, sizeof(allowed)),
			 -EINVAL);
	assert_non_null(strstr(allowed, ":3: boot_ms: \"soon\": expected an integer"));
	unlink(path);
	assert_int_equal(rmd_personality_load("/tmp", &out, err, sizeof(err)), -EISDIR);
	assert_non_null(strstr(err, "/tmp: is a directory"));
	assert_int_equal(rmd_personality_load("/nonexistent/p", &out, err, sizeof(err)), -ENOENT);
}

int main(void)
{
	const char *env = getenv("RMD_SRCDIR");
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_field_vectors),
		cmocka_unit_test(test_field_vectors_need_personality),
		cmocka_unit_test(test_field_runner_judges),
		cmocka_unit_test(test_default_picks_none),
		cmocka_unit_test(test_selection),
		cmocka_unit_test(test_flag_rows),
		cmocka_unit_test(test_comm_loss_flags),
		cmocka_unit_test(test_turnaround_quantiles),
		cmocka_unit_test(test_ignores),
		cmocka_unit_test(test_write_parse_roundtrip),
		cmocka_unit_test(test_parse_hostile),
		cmocka_unit_test(test_parse_bounds),
		cmocka_unit_test(test_load),
	};

	if (env && *env)
		srcdir = env;
	return SUITE_RUN("sim_personality", tests, NULL, NULL);
}
