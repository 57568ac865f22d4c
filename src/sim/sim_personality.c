// SPDX-License-Identifier: MIT
/*
 * Firmware personalities of the simulated motor (rmd/sim_personality.h):
 * the built-in ones from the field reports of issue 32, the file format's
 * parser and writer, and their application to a motor's parameters.
 * Values are read by the parameter table's own parsers (rmd/sim_params.h),
 * so a file spells a model, a date or a flag exactly as rmdd.yaml's `sim:`
 * and rmd-sim do.
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "rmd/sim.h"
#include "rmd/sim_params.h"
#include "rmd/sim_personality.h"

const double rmd_personality_quantiles[RMD_PERSONALITY_NQ] = { 0.0, 0.10, 0.50, 0.90, 0.99, 1.0 };

#define FLAG_ROW(f, k) [RMD_PERSONALITY_##f] = { #k, offsetof(struct rmd_sim_motor_params, k) }
/* The flags' rows, in enum rmd_personality_flag order (test_sim_personality checks them). */
static const struct {
	const char *key;
	size_t off;
} flag_rows[RMD_PERSONALITY_N_FLAGS] = {
	FLAG_ROW(ANSWERS_79_AS_B2, answers_79_as_b2),
	FLAG_ROW(SET_ID_REPLIES_NEW, set_id_replies_new),
	FLAG_ROW(COMM_LOSS_SILENT, comm_loss_silent),
	FLAG_ROW(COMM_LOSS_EXECUTES_FIRST, comm_loss_executes_first),
	FLAG_ROW(A4_IGNORED_AFTER_MIT, a4_ignored_after_mit),
	FLAG_ROW(STATUS1_EXECUTING, status1_executing),
	FLAG_ROW(V2_ANGLE_MAGNITUDE, v2_angle_magnitude),
	FLAG_ROW(B3_ANSWER_ZEROS, b3_answer_zeros),
};
#undef FLAG_ROW

const char *rmd_personality_flag_key(enum rmd_personality_flag f)
{
	return (unsigned)f < RMD_PERSONALITY_N_FLAGS ? flag_rows[f].key : NULL;
}

size_t rmd_personality_flag_offset(enum rmd_personality_flag f)
{
	return (unsigned)f < RMD_PERSONALITY_N_FLAGS ? flag_rows[f].off : 0;
}

void rmd_personality_set_flag(struct rmd_personality *p, enum rmd_personality_flag f, bool on)
{
	uint32_t bit = UINT32_C(1) << f;

	if ((unsigned)f >= RMD_PERSONALITY_N_FLAGS)
		return;
	p->flags_set |= bit;
	p->flags = on ? p->flags | bit : p->flags & ~bit;
}

#define FLAG(f) (UINT32_C(1) << RMD_PERSONALITY_##f)
/* What firmware 2025070202 does after a comm-loss trip (issue 32 point 3, docs/design.md). */
#define COMM_LOSS_2025 (FLAG(COMM_LOSS_SILENT) | FLAG(COMM_LOSS_EXECUTES_FIRST))
#define V4_MOTOR(nm, mdl, date)                                                            \
	.source = RMD_PERSONALITY_BUILTIN, .name = nm, .model = mdl, .version_date = date, \
	.proto = RMD_PROTO_V4
#define HAS_MDP \
	(RMD_PERSONALITY_HAS_MODEL | RMD_PERSONALITY_HAS_VERSION | RMD_PERSONALITY_HAS_PROTO)

/*
 * The firmware seen in the field (issue 32; docs/rmd-sim.md "Personalities"
 * says which report each flag rests on).  A flag a personality gives as
 * off is one the report says the firmware does as the manual, or does not
 * do; flags not given stay as the parameters say.
 */
static const struct rmd_personality builtins[] = {
	{
		/*
		 * X4-64, 0xB2 2025070202: 0x79 read and write answered
		 * `B2 00 00 00 7A 1E B4 78` (myactuator_rmd issue 24); the ID
		 * set by 0x20 index 5, echoed from the new ID, requests on
		 * the old one answered from the new one until 0x76 (PR 28,
		 * seen on an X4-36 of the same date; issue 32 says both); a
		 * 0x76 reset measured at 1.12 s; 0xF1 each second after a
		 * comm-loss trip, the first command only echoed; 0x9A data[3]
		 * 1 while it executes commands.
		 */
		V4_MOTOR("x4-64-2025070202", "X4-64", 2025070202u),
		.set = HAS_MDP | RMD_PERSONALITY_HAS_BOOT | RMD_PERSONALITY_HAS_F1,
		.boot_ms = 1120,
		.comm_loss_f1_ms = 1000,
		.flags_set = FLAG(ANSWERS_79_AS_B2) | FLAG(SET_ID_REPLIES_NEW) | COMM_LOSS_2025 |
			     FLAG(STATUS1_EXECUTING),
		.flags = FLAG(ANSWERS_79_AS_B2) | FLAG(SET_ID_REPLIES_NEW) |
			 FLAG(STATUS1_EXECUTING),
	},
	{
		/*
		 * X4-36, 2025070202 (myactuator_rmd PR 28): 0x79 not taken
		 * (no answer reported), the rest as the X4-64.
		 */
		V4_MOTOR("x4-36-2025070202", "X4-36", 2025070202u),
		.set = HAS_MDP | RMD_PERSONALITY_HAS_BOOT | RMD_PERSONALITY_HAS_F1,
		.boot_ms = 1120,
		.comm_loss_f1_ms = 1000,
		.flags_set = FLAG(ANSWERS_79_AS_B2) | FLAG(SET_ID_REPLIES_NEW) | COMM_LOSS_2025 |
			     FLAG(STATUS1_EXECUTING),
		.flags = FLAG(SET_ID_REPLIES_NEW) | FLAG(STATUS1_EXECUTING),
	},
	{
		/*
		 * X6-P20, 2025070202: 0xA4 ignored after an MIT frame until a
		 * reset (issue 32 point 4); the date's comm-loss and 0x9A
		 * behaviour.  Its boot time was not measured.
		 */
		V4_MOTOR("x6-p20-2025070202", "X6-P20", 2025070202u),
		.set = HAS_MDP | RMD_PERSONALITY_HAS_F1,
		.comm_loss_f1_ms = 1000,
		.flags_set = FLAG(A4_IGNORED_AFTER_MIT) | COMM_LOSS_2025 | FLAG(STATUS1_EXECUTING),
		.flags = FLAG(A4_IGNORED_AFTER_MIT) | FLAG(STATUS1_EXECUTING),
	},
	{
		/*
		 * X8-P20, 2026042402 (V4.4): MIT frames on the X8 series' own
		 * ranges (the dialect's table, rmd_mit_scaling_decide()), and
		 * it switches from MIT to 0xA4 freely (issue 32 point 4).
		 */
		V4_MOTOR("x8-p20-2026042402", "X8-P20", 2026042402u),
		.set = HAS_MDP,
		.flags_set = FLAG(A4_IGNORED_AFTER_MIT),
		.flags = 0,
	},
};
#undef HAS_MDP
#undef V4_MOTOR
#undef COMM_LOSS_2025
#undef FLAG

size_t rmd_personality_builtin_count(void)
{
	return sizeof(builtins) / sizeof(builtins[0]);
}

const struct rmd_personality *rmd_personality_builtin_at(size_t i)
{
	return i < rmd_personality_builtin_count() ? &builtins[i] : NULL;
}

const struct rmd_personality *rmd_personality_builtin(const char *name)
{
	for (size_t i = 0; i < rmd_personality_builtin_count(); i++)
		if (!strcasecmp(name, builtins[i].name))
			return &builtins[i];
	return NULL;
}

const struct rmd_personality *rmd_personality_match(const char *model, uint32_t version_date,
						    enum rmd_proto proto)
{
	for (size_t i = 0; i < rmd_personality_builtin_count(); i++) {
		const struct rmd_personality *b = &builtins[i];

		if (b->version_date == version_date && b->proto == proto &&
		    !strncasecmp(model, b->model, sizeof(b->model)))
			return b;
	}
	return NULL;
}

const char *rmd_personality_names(char *buf, size_t size)
{
	size_t at = 0;

	if (!size)
		return buf;
	buf[0] = '\0';
	for (size_t i = 0; i < rmd_personality_builtin_count() && at < size; i++) {
		int n = snprintf(buf + at, size - at, "%s%s", i ? ", " : "", builtins[i].name);

		if (n < 0)
			break;
		at += (size_t)n;
	}
	return buf;
}

void rmd_personality_apply(struct rmd_sim_motor_params *p)
{
	const struct rmd_personality *b;
	struct rmd_personality rec;

	switch (p->personality.source) {
	case RMD_PERSONALITY_AUTO:
		b = rmd_personality_match(p->model, p->version_date, p->proto);
		if (!b)
			return;
		rec = *b;
		break;
	case RMD_PERSONALITY_BUILTIN:
	case RMD_PERSONALITY_FILE:
		rec = p->personality;
		break;
	case RMD_PERSONALITY_NONE:
	default:
		return;
	}
	if (rec.set & RMD_PERSONALITY_HAS_MODEL)
		memcpy(p->model, rec.model, sizeof(p->model));
	if (rec.set & RMD_PERSONALITY_HAS_VERSION)
		p->version_date = rec.version_date;
	if (rec.set & RMD_PERSONALITY_HAS_PROTO)
		p->proto = rec.proto;
	if (rec.set & RMD_PERSONALITY_HAS_BOOT)
		p->boot_ms = rec.boot_ms;
	if (rec.set & RMD_PERSONALITY_HAS_MIT)
		p->mit = rec.mit;
	if (rec.set & RMD_PERSONALITY_HAS_F1)
		p->comm_loss_f1_ms = rec.comm_loss_f1_ms;
	for (unsigned f = 0; f < RMD_PERSONALITY_N_FLAGS; f++) {
		bool on = rec.flags & (UINT32_C(1) << f);

		if (rmd_personality_gives(&rec, (enum rmd_personality_flag)f))
			memcpy((char *)p + flag_rows[f].off, &on, sizeof(on));
	}
	p->personality = rec;
}

/* -------------------------------------------------------------------------- */
/* Turnaround                                                                 */

const struct rmd_personality_turnaround *
rmd_personality_turnaround_for(const struct rmd_personality *p, unsigned cmd)
{
	const struct rmd_personality_turnaround *any = NULL;

	for (unsigned i = 0; i < p->n_turnaround && i < RMD_PERSONALITY_CMDS_MAX; i++) {
		if (p->turnaround[i].cmd == cmd)
			return &p->turnaround[i];
		if (p->turnaround[i].cmd == RMD_PERSONALITY_CMD_ANY)
			any = &p->turnaround[i];
	}
	return any;
}

int64_t rmd_personality_turnaround_ns(const struct rmd_personality_turnaround *t, double u)
{
	const double *q = rmd_personality_quantiles;
	unsigned k = 1;
	double lo, hi;

	if (!(u >= 0.0))
		u = 0.0;
	if (u > 1.0)
		u = 1.0;
	while (k < RMD_PERSONALITY_NQ - 1 && u > q[k])
		k++;
	lo = t->q_us[k - 1];
	hi = t->q_us[k];
	return (int64_t)llround((lo + (hi - lo) * (u - q[k - 1]) / (q[k] - q[k - 1])) * 1000.0);
}

/* -------------------------------------------------------------------------- */
/* The file format                                                            */

#define FORMAT_LINE "rmd-personality 1"
#define LINE_MAX_CHARS 255

struct parser {
	const char *file;
	unsigned line;
	char *err;
	size_t errsize;
	uint32_t seen; /* keys given: key_rows, then the flags, then name and ignores */
};

__attribute__((format(printf, 3, 4))) static int fail(struct parser *ps, const char *key,
						      const char *fmt, ...)
{
	char msg[256];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	if (key)
		snprintf(ps->err, ps->errsize, "%s:%u: %s: %s", ps->file, ps->line, key, msg);
	else
		snprintf(ps->err, ps->errsize, "%s:%u: %s", ps->file, ps->line, msg);
	return -EINVAL;
}

/* The scalar keys of the file: a parameter row each, whose parser reads it. */
enum key_kind { K_MODEL, K_VERSION, K_PROTO, K_BOOT, K_MIT, K_F1 };
static const struct {
	const char *key; /* the file's spelling */
	const char *row; /* the parameter row */
	enum key_kind kind;
	uint32_t has;
} key_rows[] = {
	{ "model", "model", K_MODEL, RMD_PERSONALITY_HAS_MODEL },
	{ "version_date", "version_date", K_VERSION, RMD_PERSONALITY_HAS_VERSION },
	{ "dialect", "firmware", K_PROTO, RMD_PERSONALITY_HAS_PROTO },
	{ "boot_ms", "boot_ms", K_BOOT, RMD_PERSONALITY_HAS_BOOT },
	{ "mit_ranges", "mit_ranges", K_MIT, RMD_PERSONALITY_HAS_MIT },
	{ "comm_loss_f1_ms", "comm_loss_f1_ms", K_F1, RMD_PERSONALITY_HAS_F1 },
};
#define N_KEY_ROWS (sizeof(key_rows) / sizeof(key_rows[0]))
#define SEEN_NAME (N_KEY_ROWS + RMD_PERSONALITY_N_FLAGS)
#define SEEN_IGNORES (SEEN_NAME + 1)

static char *trim(char *s)
{
	char *e;

	while (*s == ' ' || *s == '\t')
		s++;
	e = s + strlen(s);
	while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r'))
		*--e = '\0';
	return s;
}

static int once(struct parser *ps, const char *key, unsigned bit)
{
	if (ps->seen & (UINT32_C(1) << bit))
		return fail(ps, key, "given twice");
	ps->seen |= UINT32_C(1) << bit;
	return 0;
}

/* A parameter row's value into the record, by the row's own parser. */
static int scalar(struct parser *ps, struct rmd_personality *out, unsigned k, const char *key,
		  const char *value)
{
	const struct rmd_sim_param *row = rmd_sim_param_find(key_rows[k].row);
	struct rmd_sim_motor_params s;
	char allowed[192];

	if (once(ps, key, k) < 0)
		return -EINVAL;
	rmd_sim_motor_params_default(&s, 1, RMD_PROTO_V4);
	if (!row || rmd_sim_param_parse(&s, row, value, allowed, sizeof(allowed)) < 0)
		return fail(ps, key, "\"%s\": expected %s", value, row ? allowed : "?");
	switch (key_rows[k].kind) {
	case K_MODEL:
		memcpy(out->model, s.model, sizeof(out->model));
		break;
	case K_VERSION:
		out->version_date = s.version_date;
		break;
	case K_PROTO:
		out->proto = s.proto;
		break;
	case K_BOOT:
		out->boot_ms = s.boot_ms;
		break;
	case K_MIT:
		out->mit = s.mit;
		break;
	case K_F1:
		out->comm_loss_f1_ms = s.comm_loss_f1_ms;
		break;
	}
	out->set |= key_rows[k].has;
	return 0;
}

static int flag(struct parser *ps, struct rmd_personality *out, unsigned f, const char *key,
		const char *value)
{
	bool b;

	if (once(ps, key, (unsigned)N_KEY_ROWS + f) < 0)
		return -EINVAL;
	if (rmd_sim_parse_bool(value, &b) < 0)
		return fail(ps, key, "\"%s\": expected yes or no (true/false, on/off, 1/0)", value);
	rmd_personality_set_flag(out, (enum rmd_personality_flag)f, b);
	return 0;
}

/* The next token of a list (blanks or commas between), NUL-terminated in place; NULL at the end. */
static char *next_token(char **s)
{
	char *t = *s, *e;

	while (*t == ' ' || *t == '\t' || *t == ',')
		t++;
	if (!*t)
		return NULL;
	e = t;
	while (*e && *e != ' ' && *e != '\t' && *e != ',')
		e++;
	*s = *e ? e + 1 : e;
	*e = '\0';
	return t;
}

static int byte_value(const char *s, unsigned *v)
{
	uint64_t u;

	if (rmd_sim_parse_u64(s, &u) < 0 || u > 0xFF)
		return -EINVAL;
	*v = (unsigned)u;
	return 0;
}

static int ignores(struct parser *ps, struct rmd_personality *out, char *value)
{
	char *t;
	unsigned c;

	if (once(ps, "ignores", SEEN_IGNORES) < 0)
		return -EINVAL;
	while ((t = next_token(&value))) {
		if (byte_value(t, &c) < 0)
			return fail(ps, "ignores", "\"%s\": expected command bytes 0x00..0xFF", t);
		out->ignores[c >> 3] |= (uint8_t)(1u << (c & 7));
	}
	return 0;
}

static int turnaround(struct parser *ps, struct rmd_personality *out, const char *key,
		      const char *which, char *value)
{
	struct rmd_personality_turnaround t = { 0 };
	const struct rmd_personality_turnaround *had;
	unsigned n = 0, c;
	char *tok;

	if (!strcasecmp(which, "mit"))
		t.cmd = RMD_PERSONALITY_CMD_MIT;
	else if (!strcmp(which, "*"))
		t.cmd = RMD_PERSONALITY_CMD_ANY;
	else if (byte_value(which, &c) == 0)
		t.cmd = (uint16_t)c;
	else
		return fail(ps, key,
			    "\"%s\" is not a command: expected a byte (0x9C), mit or * (every "
			    "other)",
			    which);
	had = rmd_personality_turnaround_for(out, t.cmd);
	if (had && had->cmd == t.cmd)
		return fail(ps, key, "given twice");
	if (out->n_turnaround >= RMD_PERSONALITY_CMDS_MAX)
		return fail(ps, key, "more than %d turnaround lines", RMD_PERSONALITY_CMDS_MAX);
	while ((tok = next_token(&value))) {
		uint64_t u;

		if (!strncmp(tok, "n=", 2)) {
			if (n != RMD_PERSONALITY_NQ || rmd_sim_parse_u64(tok + 2, &u) < 0 ||
			    u > UINT32_MAX || t.samples)
				return fail(ps, key,
					    "\"%s\": n=COUNT comes once, after the %d quantiles",
					    tok, RMD_PERSONALITY_NQ);
			t.samples = (uint32_t)u;
			continue;
		}
		if (n >= RMD_PERSONALITY_NQ || t.samples)
			return fail(ps, key,
				    "more than %d quantiles (p0 p10 p50 p90 p99 p100, µs; then "
				    "n=COUNT)",
				    RMD_PERSONALITY_NQ);
		if (rmd_sim_parse_u64(tok, &u) < 0 || u > RMD_PERSONALITY_TURNAROUND_MAX_US)
			return fail(ps, key, "\"%s\": expected whole µs 0..%u", tok,
				    RMD_PERSONALITY_TURNAROUND_MAX_US);
		if (n && u < t.q_us[n - 1])
			return fail(ps, key, "%s µs is below the quantile before it (%u µs)", tok,
				    t.q_us[n - 1]);
		t.q_us[n++] = (uint32_t)u;
	}
	if (n != RMD_PERSONALITY_NQ)
		return fail(ps, key, "%u quantiles: expected %d (p0 p10 p50 p90 p99 p100, µs)", n,
			    RMD_PERSONALITY_NQ);
	out->turnaround[out->n_turnaround++] = t;
	return 0;
}

static bool name_ok(const char *s)
{
	size_t n = strlen(s);

	if (n < 1 || n >= RMD_PERSONALITY_NAME_MAX)
		return false;
	for (size_t i = 0; i < n; i++)
		if (!isalnum((unsigned char)s[i]) && s[i] != '-' && s[i] != '_' && s[i] != '.')
			return false;
	return true;
}

/* One `key = value` line (comment and blanks already gone). */
static int parse_line(struct parser *ps, struct rmd_personality *out, char *s, bool *format_seen)
{
	char *eq = strchr(s, '='), *key, *value;

	if (!eq)
		return fail(ps, NULL, "\"%s\": expected key = value", s);
	*eq = '\0';
	key = trim(s);
	value = trim(eq + 1);
	if (!*key)
		return fail(ps, NULL, "a value without a key");
	if (!*format_seen) {
		if (strcmp(key, "format") || strcmp(value, FORMAT_LINE))
			return fail(ps, key,
				    "the first line must be `format = " FORMAT_LINE
				    "` (not a personality file?)");
		*format_seen = true;
		return 0;
	}
	if (!strcmp(key, "format"))
		return fail(ps, key, "given twice");
	if (!strcmp(key, "name")) {
		if (once(ps, key, SEEN_NAME) < 0)
			return -EINVAL;
		if (!name_ok(value))
			return fail(ps, key,
				    "\"%s\": expected 1..%d letters, digits, '-', '_' or '.'",
				    value, RMD_PERSONALITY_NAME_MAX - 1);
		snprintf(out->name, sizeof(out->name), "%s", value);
		return 0;
	}
	if (!strcmp(key, "ignores"))
		return ignores(ps, out, value);
	if (!strncmp(key, "turnaround", 10) && (key[10] == ' ' || key[10] == '\t'))
		return turnaround(ps, out, key, trim(key + 10), value);
	for (unsigned k = 0; k < N_KEY_ROWS; k++)
		if (!strcmp(key, key_rows[k].key))
			return scalar(ps, out, k, key, value);
	for (unsigned f = 0; f < RMD_PERSONALITY_N_FLAGS; f++)
		if (!strcmp(key, flag_rows[f].key))
			return flag(ps, out, f, key, value);
	return fail(ps, key, "not a personality key (docs/rmd-sim.md \"Personality files\")");
}

/* The last component of a path, as a record's name: name_ok()'s characters, else "file". */
static void name_from_path(char *name, const char *path)
{
	const char *s = strrchr(path, '/');

	snprintf(name, RMD_PERSONALITY_NAME_MAX, "%s", s ? s + 1 : path);
	if (!name_ok(name))
		snprintf(name, RMD_PERSONALITY_NAME_MAX, "file");
}

int rmd_personality_parse(const char *text, size_t len, const char *file,
			  struct rmd_personality *out, char *err, size_t errsize)
{
	struct parser ps = { .file = file ? file : "personality", .err = err, .errsize = errsize };
	bool format_seen = false;
	size_t at = 0;

	memset(out, 0, sizeof(*out));
	if (errsize)
		err[0] = '\0';
	if (len > RMD_PERSONALITY_FILE_MAX) {
		snprintf(err, errsize, "%s: %zu bytes: larger than the limit of %s", ps.file, len,
			 RMD_PERSONALITY_FILE_MAX_TEXT);
		return -EFBIG;
	}
	while (at < len) {
		char line[LINE_MAX_CHARS + 1], *s, *hash;
		size_t n = 0;

		if (++ps.line > RMD_PERSONALITY_LINES_MAX) {
			snprintf(err, errsize, "%s:%u: more than %d lines", ps.file, ps.line,
				 RMD_PERSONALITY_LINES_MAX);
			return -EFBIG;
		}
		for (; at < len && text[at] != '\n'; at++, n++) {
			if (text[at] == '\0')
				return fail(&ps, NULL, "a NUL byte");
			if (n < LINE_MAX_CHARS)
				line[n] = text[at];
		}
		at++; /* the newline */
		if (n > LINE_MAX_CHARS)
			return fail(&ps, NULL, "line longer than %d characters", LINE_MAX_CHARS);
		line[n] = '\0';
		hash = strchr(line, '#');
		if (hash)
			*hash = '\0';
		s = trim(line);
		if (*s && parse_line(&ps, out, s, &format_seen) < 0)
			return -EINVAL;
	}
	if (!format_seen) {
		snprintf(err, errsize, "%s: empty: expected `format = " FORMAT_LINE "` first",
			 ps.file);
		return -EINVAL;
	}
	out->source = RMD_PERSONALITY_FILE;
	if (!out->name[0])
		name_from_path(out->name, ps.file);
	return 0;
}

static void write_turnaround(FILE *f, const struct rmd_personality_turnaround *t)
{
	if (t->cmd == RMD_PERSONALITY_CMD_MIT)
		fprintf(f, "turnaround mit =");
	else if (t->cmd == RMD_PERSONALITY_CMD_ANY)
		fprintf(f, "turnaround * =");
	else
		fprintf(f, "turnaround 0x%02X =", t->cmd);
	for (unsigned k = 0; k < RMD_PERSONALITY_NQ; k++)
		fprintf(f, " %u", t->q_us[k]);
	if (t->samples)
		fprintf(f, " n=%u", t->samples);
	fprintf(f, "\n");
}

int rmd_personality_write(FILE *f, const struct rmd_personality *p, const char *comment)
{
	const char *c = comment;
	unsigned n = 0;

	while (c && *c) {
		size_t len = strcspn(c, "\n");

		fprintf(f, "# %.*s\n", (int)len, c);
		c += len + (c[len] == '\n');
	}
	fprintf(f, "format = " FORMAT_LINE "\n");
	if (name_ok(p->name))
		fprintf(f, "name = %s\n", p->name);
	if (p->set & RMD_PERSONALITY_HAS_MODEL)
		fprintf(f, "model = %.7s\n", p->model);
	if (p->set & RMD_PERSONALITY_HAS_VERSION)
		fprintf(f, "version_date = %u\n", p->version_date);
	if (p->set & RMD_PERSONALITY_HAS_PROTO)
		fprintf(f, "dialect = %s\n", rmd_proto_key(p->proto));
	if (p->set & RMD_PERSONALITY_HAS_BOOT)
		fprintf(f, "boot_ms = %u\n", p->boot_ms);
	if (p->set & RMD_PERSONALITY_HAS_MIT)
		fprintf(f, "mit_ranges = %.17g,%.17g,%.17g,%.17g,%.17g\n", p->mit.p_max,
			p->mit.v_max, p->mit.t_max, p->mit.kp_max, p->mit.kd_max);
	if (p->set & RMD_PERSONALITY_HAS_F1)
		fprintf(f, "comm_loss_f1_ms = %u\n", p->comm_loss_f1_ms);
	for (unsigned k = 0; k < RMD_PERSONALITY_N_FLAGS; k++)
		if (rmd_personality_gives(p, (enum rmd_personality_flag)k))
			fprintf(f, "%s = %s\n", flag_rows[k].key,
				p->flags & (UINT32_C(1) << k) ? "yes" : "no");
	for (unsigned b = 0; b < 256; b++)
		if (rmd_personality_ignores(p, (uint8_t)b))
			fprintf(f, "%s 0x%02X", n++ ? "" : "ignores =", b);
	if (n)
		fprintf(f, "\n");
	for (unsigned i = 0; i < p->n_turnaround && i < RMD_PERSONALITY_CMDS_MAX; i++)
		write_turnaround(f, &p->turnaround[i]);
	fflush(f);
	return ferror(f) ? -EIO : 0;
}
