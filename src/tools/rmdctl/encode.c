// SPDX-License-Identifier: MIT
/*
 * rmdctl encode: one command in native units -> one frame in cansend syntax,
 * so that `cansend can0 $(rmdctl encode --id 1 torque 1.0)` works.
 *
 * A command is the rows of the protocol's codec table spelled with its word
 * (struct rmd_spelling): which dialects have it, the command byte, which
 * field each argument fills and the ranges the manual gives all come from
 * the row, and a value is converted with the row's scale, so the codec
 * tables stay the one place that knows the wire.  The list below adds the
 * help texts and the commands that parse their own arguments; a word only
 * a table spells is a command too.  Values that do not fit the field, or a
 * range the manual documents, are refused: never wrapped, never clamped.
 * Non-rt.
 */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmd/dialect.h"
#include "rmd/frame.h"
#include "rmd/mit.h"
#include "rmdctl.h"

struct enc_ctx {
	enum rmd_proto proto;	 /* as given (--protocol) */
	enum rmd_proto table;	 /* whose rows: its firmware's (mit uses V3's) */
	int motor_id;		 /* 1..32, or -1 when --id was not given */
	struct rmd_mit_ranges r; /* for `mit` */
};

struct enc_cmd;
typedef int (*enc_custom_fn)(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc,
			     char **argv, struct rmd_frame *out);

struct enc_cmd {
	const char *name;
	const char *args;
	const char *help;
	enc_custom_fn custom; /* parses its own arguments; NULL: the rows spelled name */
};

static int enc_mit(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
		   struct rmd_frame *out);
static int enc_raw(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
		   struct rmd_frame *out);
static int enc_pid_read(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
			struct rmd_frame *out);
static int enc_pid_write(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
			 struct rmd_frame *out);
static int enc_active_reply(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc,
			    char **argv, struct rmd_frame *out);

/* Command bytes: V3 §2.x, V2 §3.x and V4.2 §2.x of the manuals, named in each help text. */
static const struct enc_cmd enc_cmds[] = {
	{ "torque", "AMPS", "torque current setpoint (0xA1)", NULL },
	{ "speed", "DPS", "speed setpoint (0xA2)", NULL },
	{ "position", "DEG [MAX_DPS]",
	  "absolute multi-turn position: V3/V4 0xA4 (MAX_DPS required: the manual\n"
	  "gives no \"unlimited\" value, use position-track); V2 0xA3, or 0xA4 with\n"
	  "MAX_DPS",
	  NULL },
	{ "position-track", "DEG", "position tracking, no speed limit (V3/V2 0xA3; V4 removed it)",
	  NULL },
	{ "position-track-limited", "DEG MAX_DPS", "position tracking with a speed limit (V3 0xA5)",
	  NULL },
	{ "position-single", "DEG MAX_DPS DIR",
	  "single-turn position 0..360 deg at up to MAX_DPS, DIR 0 clockwise or\n"
	  "1 counterclockwise (V4 0xA6)",
	  NULL },
	{ "increment", "DEG [MAX_DPS]",
	  "relative move from the current position: V3/V4 0xA8 (MAX_DPS required);\n"
	  "V2 0xA7, or 0xA8 with MAX_DPS",
	  NULL },
	{ "stop", "", "stop the motor, keep its state (0x81)", NULL },
	{ "off", "", "output off, state cleared (0x80)", NULL },
	{ "run", "", "resume after stop (V2 0x88)", NULL },
	{ "brake-release", "", "release the brake (0x77)", NULL },
	{ "brake-lock", "", "lock the brake (0x78)", NULL },
	{ "reset", "", "reset the motor's controller; no reply (0x76)", NULL },
	{ "status1", "", "read temperature, voltage, brake, errors (0x9A)", NULL },
	{ "status2", "", "read temperature, current, speed, angle (0x9C)", NULL },
	{ "status3", "", "read phase currents (0x9D)", NULL },
	{ "read-angle", "", "read the multi-turn angle (0x92)", NULL },
	{ "read-angle-single", "", "read the single-turn angle (V4 0x94)", NULL },
	{ "read-encoder-single", "", "read the single-turn encoder, raw and offset (V4 0x90)",
	  NULL },
	{ "model", "", "read the model string (V3/V4 0xB5)", NULL },
	{ "version", "", "read the firmware date (V3/V4 0xB2)", NULL },
	{ "runtime", "", "read the time since power-up (V3/V4 0xB1)", NULL },
	{ "mode", "", "read the run mode (0x70)", NULL },
	{ "power", "", "read the power (V3/V2 0x71)", NULL },
	{ "timeout", "MS",
	  "set the comm-loss protection time, 0 = off; stored in ROM, set it once\n"
	  "(V3/V4 0xB3)",
	  NULL },
	{ "accel-read", "[INDEX]",
	  "read the acceleration (0x42); V4 reads the one of INDEX 0..3 (position\n"
	  "accel/decel, speed accel/decel)",
	  NULL },
	{ "accel", "[INDEX] DPS2",
	  "write an acceleration: V3/V4 0x43 takes INDEX 0..3 (position accel/decel,\n"
	  "speed accel/decel) and DPS2 100..60000; V2 0x43 takes DPS2 only",
	  NULL },
	{ "pid-read", "[LOOP]",
	  "read PID gains: V3 0x30 reads all six; V2 reads one, LOOP = position-kp,\n"
	  "position-ki, speed-kp, speed-ki, current-kp or current-ki (0x30..0x35);\n"
	  "V4 0x30 reads one, LOOP as V2's or position-kd",
	  enc_pid_read },
	{ "pid", "LOOP GAIN",
	  "write one gain to RAM, lost at power off (V4 0x31): LOOP as pid-read's,\n"
	  "GAIN a real (a float on the wire)",
	  enc_pid_write },
	{ "pid-rom", "LOOP GAIN", "write one gain to ROM, kept at power off (V4 0x32)",
	  enc_pid_write },
	{ "function", "INDEX VALUE",
	  "function control (V3/V4 0x20): 1 clear multi-turn and save, 2 CAN ID\n"
	  "filter on/off, 3 0x9A error reports on/off, 4 keep multi-turn at power\n"
	  "off; V4 also 5 set the CAN ID (ROM, after a reset), 6/7 positive/negative\n"
	  "position limit (ROM)",
	  NULL },
	{ "active-reply", "CMD ON MS",
	  "have the motor push CMD's reply every MS ms (10 ms steps), ON 1, or\n"
	  "stop, ON 0; CMD in hex: 60 61 62 92 9A 9C 9D 9E; CAN only; no reply\n"
	  "(V4 0xB6)",
	  enc_active_reply },
	{ "multi-torque", "A1 A2 A3 A4",
	  "torque currents of motors 1..4 in one 0x280 frame (V2 only; no --id)", NULL },
	{ "mit", "P V KP KD T",
	  "MIT motion mode on 0x400+ID: position rad, velocity rad/s, kp, kd,\n"
	  "feed-forward torque N·m, each within --mit-ranges (V3 and V4 firmware)",
	  enc_mit },
	{ "raw", "CMD [FIELD=VALUE ...]",
	  "any command of the protocol's table: CMD is its byte in hex (9A or 0x9A)\n"
	  "or its row name (read_status_1); FIELD is a request field key as\n"
	  "`rmdctl decode --json` prints it (current_a, angle_deg, ...), VALUE in\n"
	  "that key's native unit; fields not given are 0",
	  enc_raw },
};
#define NENC (sizeof(enc_cmds) / sizeof(enc_cmds[0]))

/*
 * Commands the list above does not name: a word a row of a firmware
 * dialect's table spells (a dialect's own command needs nothing here).
 */
#define UNLISTED_MAX 32
#define WORD_MAX 32

struct unlisted {
	char word[WORD_MAX];
	const struct rmd_cmd_spec *row; /* the first row spelled so */
	const struct rmd_dialect *d;	/* whose table it is in */
};

static const struct enc_cmd *listed(const char *word)
{
	for (size_t i = 0; i < NENC; i++)
		if (!strcmp(enc_cmds[i].name, word))
			return &enc_cmds[i];
	return NULL;
}

/* The words rows spell that enc_cmds does not name, once each, into u[]; their count. */
static size_t unlisted_words(struct unlisted *u, size_t max)
{
	const struct rmd_dialect *dl;
	size_t nd, n = 0;

	dl = rmd_dialect_list(&nd);
	for (size_t i = 0; i < nd; i++) {
		const struct rmd_cmd_spec *rows;
		size_t nr = rmd_dialect_is_firmware(&dl[i]) ? rmd_cmd_table(dl[i].proto, &rows) : 0;

		for (size_t j = 0; j < nr; j++) {
			for (const char *w = rows[j].spell.words; w && *w;) {
				size_t len = strcspn(w, " "), k;

				if (len < WORD_MAX && n < max) {
					memcpy(u[n].word, w, len);
					u[n].word[len] = '\0';
					for (k = 0; k < n && strcmp(u[k].word, u[n].word); k++)
						;
					if (k == n && !listed(u[n].word)) {
						u[n].row = &rows[j];
						u[n].d = &dl[i];
						n++;
					}
				}
				w += len + (w[len] == ' ');
			}
		}
	}
	return n;
}

/* An unlisted word's arguments for usage lines: its row's field keys, "CURRENT_A SPEED_DPS". */
static const char *unlisted_args(const struct unlisted *u, char *buf, size_t size)
{
	size_t k = 0;

	buf[0] = '\0';
	for (unsigned i = 0; i < u->row->spell.n_args && k + 1 < size; i++) {
		const char *key = rmd_field_key((enum rmd_field)u->row->spell.args[i]);

		if (i)
			buf[k++] = ' ';
		for (; *key && k + 1 < size; key++)
			buf[k++] = *key >= 'a' && *key <= 'z' ? (char)(*key - 'a' + 'A') : *key;
		buf[k] = '\0';
	}
	return buf;
}

void rmdctl_encode_usage(FILE *f)
{
	struct unlisted u[UNLISTED_MAX];
	char keys[64], phrase[128];
	size_t n_u;

	fprintf(f,
		"usage: rmdctl encode [--protocol %s] [--id N] [--mit-ranges P,V,T,KP,KD]\n"
		"                     " RMDCTL_ENCODE_ARGS "\n"
		"\n"
		"Prints one request frame in cansend syntax (\"141#A100000064000000\"):\n"
		"  cansend can0 $(rmdctl encode --id 1 torque 1.0)\n"
		"Options come before COMMAND, so negative values need no quoting.\n"
		"\n"
		"  --protocol P    %s\n"
		"  --id N          motor 1..32 (every command but multi-torque)\n"
		"  --mit-ranges P,V,T,KP,KD\n"
		"                  MIT ranges: position ±P rad, velocity ±V rad/s, torque\n"
		"                  ±T N·m, kp 0..KP, kd 0..KD (default 12.5,45,24,500,5)\n"
		"\n"
		"Values are in the unit named (A, dps, deg, ms, dps/s) and are rounded to\n"
		"the protocol's resolution; a value the frame cannot carry is refused.\n"
		"\n"
		"commands:\n",
		rmd_proto_keys_text(keys, sizeof(keys), "|", "|"),
		rmdctl_proto_help(phrase, sizeof(phrase), false));
	for (size_t i = 0; i < NENC; i++) {
		const struct enc_cmd *ec = &enc_cmds[i];
		const char *h = ec->help;

		fprintf(f, "  %s%s%s\n", ec->name, *ec->args ? " " : "", ec->args);
		while (*h) {
			size_t n = strcspn(h, "\n");

			fprintf(f, "      %.*s\n", (int)n, h);
			h += n + (h[n] == '\n');
		}
	}
	n_u = unlisted_words(u, UNLISTED_MAX);
	for (size_t i = 0; i < n_u; i++) {
		char args[96];

		unlisted_args(&u[i], args, sizeof(args));
		fprintf(f, "  %s%s%s\n      %s (0x%02X), protocol %s\n", u[i].word,
			*args ? " " : "", args, u[i].row->name, u[i].row->cmd, u[i].d->name);
	}
	fprintf(f, "\n"
		   "exit status: 0 frame printed; 1 the codec table lacks the command or refused\n"
		   "the frame; 2 usage error (unknown command, bad or out-of-range value).\n");
}

static void cmd_usage(const struct enc_cmd *ec)
{
	fprintf(stderr, "usage: rmdctl encode [OPTIONS] %s%s%s\n", ec->name, *ec->args ? " " : "",
		ec->args);
	fprintf(stderr, "       (`rmdctl encode --help` lists every command)\n");
}

/* A usage error of command ec: the message, then its usage line.  Returns RMDCTL_EXIT_USAGE. */
static int usage_error(const struct enc_cmd *ec, const char *fmt, ...)
	__attribute__((format(printf, 2, 3)));

static int usage_error(const struct enc_cmd *ec, const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	tool_vlog(TOOL_LOG_ERR, fmt, ap);
	va_end(ap);
	cmd_usage(ec);
	return RMDCTL_EXIT_USAGE;
}

/* ---- values -> fields ----------------------------------------------------------------- */

/*
 * Native value v -> raw integer of field `fld` of `spec`'s request, stored in
 * msg.  Refuses what the field cannot carry or the manual rules out.
 */
static int set_field(const struct enc_ctx *ctx, const char *what, const struct rmd_cmd_spec *spec,
		     enum rmd_field fld, double v, struct rmd_msg *msg)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, RMD_DIR_REQUEST, fld);
	const struct rmd_field_range *lim = rmd_cmd_range(spec, fld);
	const char *unit;
	char label[40], vs[48], los[48], his[48];
	unsigned bits;
	int64_t lo, hi;
	double q;

	if (!fs) {
		tool_log(TOOL_LOG_ERR, "%s: the %s table row 0x%02X (%s) has no request field %s",
			 what, rmd_proto_name(ctx->table), spec->cmd, spec->name,
			 rmd_field_key(fld));
		return RMDCTL_EXIT_DATA;
	}
	if (fs->is_float) {
		int64_t raw;

		/* V4.2 §2.1: a binary32, any finite value (the manual gives no range) */
		if (!isfinite(v) || rmd_field_from_native(fs, v, &raw) < 0) {
			rmd_fmt_real(vs, sizeof(vs), v, 15);
			tool_log(TOOL_LOG_ERR, "%s: %s = %s is not a finite float", what,
				 rmd_field_key(fld), vs);
			return RMDCTL_EXIT_USAGE;
		}
		rmd_msg_set(msg, fld, raw);
		return 0;
	}
	bits = 8u * fs->size;
	lo = fs->is_signed ? -(INT64_C(1) << (bits - 1)) : 0;
	hi = fs->is_signed ? (INT64_C(1) << (bits - 1)) - 1 : (INT64_C(1) << bits) - 1;
	if (lim) {
		int64_t llo = (int64_t)ceil(lim->lo / fs->scale - 1e-9);
		int64_t lhi = (int64_t)floor(lim->hi / fs->scale + 1e-9);

		lo = llo > lo ? llo : lo;
		hi = lhi < hi ? lhi : hi;
	}
	q = v / fs->scale;
	if (isfinite(q) && q > (double)lo - 0.5 && q < (double)hi + 0.5) {
		rmd_msg_set(msg, fld, (int64_t)llround(q));
		return 0;
	}
	rmd_field_label(fld, label, sizeof(label), &unit);
	rmd_fmt_real(vs, sizeof(vs), v, 15);
	rmd_fmt_real(los, sizeof(los), (double)lo * fs->scale, 15);
	rmd_fmt_real(his, sizeof(his), (double)hi * fs->scale, 15);
	if (lim)
		tool_log(TOOL_LOG_ERR, "%s: %s = %s%s%s is out of range %s..%s%s%s (%s)", what,
			 rmd_field_key(fld), vs, *unit ? " " : "", unit, los, his, *unit ? " " : "",
			 unit, lim->cite);
	else
		tool_log(TOOL_LOG_ERR,
			 "%s: %s = %s%s%s is out of range %s..%s%s%s (a %s %u-bit field of 0x%02X)",
			 what, rmd_field_key(fld), vs, *unit ? " " : "", unit, los, his,
			 *unit ? " " : "", unit, fs->is_signed ? "signed" : "unsigned", bits,
			 spec->cmd);
	return RMDCTL_EXIT_USAGE;
}

static int need_id(const struct enc_ctx *ctx, const struct enc_cmd *ec)
{
	if (ctx->motor_id > 0)
		return 0;
	return usage_error(ec, "%s needs --id N (motor 1..%d)", ec->name, RMD_MAX_MOTORS);
}

static const struct rmd_cmd_spec *find_row(const struct enc_ctx *ctx, const char *what, uint8_t cmd)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(ctx->table, cmd);

	if (!spec)
		tool_log(TOOL_LOG_ERR, "%s: command 0x%02X is not in the %s codec table", what, cmd,
			 rmd_proto_name(ctx->table));
	return spec;
}

static int finish(const struct enc_ctx *ctx, const char *what, const struct rmd_cmd_spec *spec,
		  bool multi, const struct rmd_msg *msg, struct rmd_frame *out)
{
	int r = rmd_encode(ctx->table, RMD_DIR_REQUEST, multi ? 0 : (uint8_t)ctx->motor_id, msg,
			   out);

	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "%s: the %s codec refused 0x%02X (%s): %s", what,
			 rmd_proto_name(ctx->table), spec->cmd, spec->name, strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	return 0;
}

static int parse_value(const struct enc_cmd *ec, const char *s, double *v)
{
	if (rmdctl_parse_double(s, v) == 0)
		return 0;
	return usage_error(ec, "%s: \"%s\" is not a number", ec->name, s);
}

/* ---- commands ------------------------------------------------------------------------- */

/* The row of `table` spelled `word` with n_args arguments (any count: -1), or NULL. */
static const struct rmd_cmd_spec *spelled_row(enum rmd_proto table, const char *word, int n_args)
{
	const struct rmd_cmd_spec *rows;
	size_t n = rmd_cmd_table(table, &rows);

	for (size_t i = 0; i < n; i++)
		if (rmd_cmd_spelled(&rows[i], word) &&
		    (n_args < 0 || rows[i].spell.n_args == n_args))
			return &rows[i];
	return NULL;
}

/* A command of the rows spelled ec->name (struct rmd_spelling). */
static int enc_spelled(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
		       struct rmd_frame *out)
{
	const struct rmd_cmd_spec *spec = spelled_row(ctx->table, ec->name, argc);
	struct rmd_msg msg = { 0 };
	bool multi;
	int r;

	if (!spelled_row(ctx->table, ec->name, -1)) {
		char keys[64] = "";
		size_t nd, k = 0;
		const struct rmd_dialect *dl = rmd_dialect_list(&nd);

		/* the dialects whose tables have it */
		for (size_t i = 0; i < nd && k < sizeof(keys); i++)
			if (rmd_dialect_is_firmware(&dl[i]) &&
			    spelled_row(dl[i].proto, ec->name, -1))
				k += (size_t)snprintf(keys + k, sizeof(keys) - k, "%s%s",
						      k ? " or " : "", dl[i].key);
		return usage_error(ec, "%s: not a command of protocol %s (--protocol %s)", ec->name,
				   rmd_proto_name(ctx->proto), keys);
	}
	if (!spec)
		return usage_error(ec, "%s: wrong number of arguments for protocol %s", ec->name,
				   rmd_proto_name(ctx->proto));
	/* V2 §4.1: the 0x280 frame carries no command byte and goes to no one motor */
	multi = spec->flags & RMD_CMD_NO_CMD_BYTE;
	if (!multi && (r = need_id(ctx, ec)) != 0)
		return r;
	msg.cmd = spec->cmd;
	for (unsigned i = 0; i < spec->spell.n_args; i++) {
		double val;

		r = parse_value(ec, argv[i], &val);
		if (r)
			return r;
		r = set_field(ctx, ec->name, spec, (enum rmd_field)spec->spell.args[i], val, &msg);
		if (r)
			return r;
	}
	return finish(ctx, ec->name, spec, multi, &msg, out);
}

/* The slot of gain LOOP ("position-kd" or "position_kd") of a dialect, or -1. */
static int gain_slot(const struct rmd_dialect *dl, const char *loop)
{
	for (size_t i = 0; i < dl->n_pid_slots; i++) {
		const char *a = rmd_field_key((enum rmd_field)dl->pid_slots[i].field), *b = loop;

		while (*a && (*a == *b || (*a == '_' && *b == '-'))) {
			a++;
			b++;
		}
		if (!*a && !*b)
			return (int)i;
	}
	return -1;
}

static int bad_loop(const struct enc_ctx *ctx, const struct enc_cmd *ec, const char *loop)
{
	const struct rmd_dialect *dl = rmd_dialect(ctx->table);

	tool_log(TOOL_LOG_ERR, "%s: unknown LOOP \"%s\"", ec->name, loop);
	fprintf(stderr, "LOOPs of %s:", dl->name);
	for (size_t i = 0; i < dl->n_pid_slots; i++) {
		fputc(' ', stderr);
		for (const char *c = rmd_field_key((enum rmd_field)dl->pid_slots[i].field); *c; c++)
			fputc(*c == '_' ? '-' : *c, stderr);
	}
	fputc('\n', stderr);
	return RMDCTL_EXIT_USAGE;
}

/* The request that does op to gain `slot` alone (rmd_pid_requests()), or -1 when none does. */
static int one_gain(const struct rmd_dialect *dl, enum rmd_pid_op op, int slot, struct rmd_msg *m)
{
	struct rmd_pid_set set = { 0 }, carried;
	struct rmd_msg reqs[RMD_PID_SLOTS_MAX];
	uint32_t named;

	if (slot < 0 || slot >= 32)
		return -1; /* not a gain of dl (UB to shift by) */
	set.slots = UINT32_C(1) << slot;
	if (rmd_pid_requests(dl, op, &set, reqs) != 1 ||
	    !rmd_pid_parse(dl, &reqs[0], &op, &named, &carried) || named != set.slots)
		return -1;
	*m = reqs[0];
	return 0;
}

static int enc_pid_read(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
			struct rmd_frame *out)
{
	const struct rmd_dialect *dl = rmd_dialect(ctx->table);
	struct rmd_pid_set all = { .slots = UINT32_MAX };
	struct rmd_msg reqs[RMD_PID_SLOTS_MAX];
	const struct rmd_cmd_spec *spec;
	int r, n = rmd_pid_requests(dl, RMD_PID_READ, &all, reqs);
	/* V2 §3.1: a command a gain; V4.2 §2.1: 0x30 and the gain's index; V3 §2.1: all six */
	bool one = n > 1;

	if (n < 1)
		return usage_error(ec, "%s: protocol %s has no PID commands", ec->name,
				   rmd_proto_name(ctx->proto));
	if (argc != (one ? 1 : 0))
		return usage_error(ec, "%s: protocol %s takes %s", ec->name,
				   rmd_proto_name(ctx->proto), one ? "one LOOP" : "no argument");
	if (argc == 1 && one_gain(dl, RMD_PID_READ, gain_slot(dl, argv[0]), &reqs[0]) < 0)
		return bad_loop(ctx, ec, argv[0]);
	if ((r = need_id(ctx, ec)) != 0)
		return r;
	spec = find_row(ctx, ec->name, reqs[0].cmd);
	if (!spec)
		return RMDCTL_EXIT_DATA;
	return finish(ctx, ec->name, spec, false, &reqs[0], out);
}

/*
 * V4.2 §2.2 (pid, 0x31, RAM) and §2.3 (pid-rom, 0x32, ROM): one gain alone,
 * a real (a float on the wire); a dialect that writes its gains otherwise
 * is refused.
 */
static int enc_pid_write(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
			 struct rmd_frame *out)
{
	const struct rmd_dialect *dl = rmd_dialect(ctx->table);
	enum rmd_pid_op op = strcmp(ec->name, "pid-rom") ? RMD_PID_WRITE_RAM : RMD_PID_WRITE_ROM;
	const struct rmd_field_spec *fs = rmd_pid_spec(dl, 0);
	const struct rmd_cmd_spec *spec;
	struct rmd_msg msg;
	double gain;
	int r, slot;

	if (!fs || !fs->is_float || one_gain(dl, op, 0, &msg) < 0)
		return usage_error(
			ec,
			"%s: protocol %s writes its gains otherwise (`raw`: six in 0x31 in V3, "
			"one a command from 0x36 in V2)",
			ec->name, rmd_proto_name(ctx->proto));
	if (argc != 2)
		return usage_error(ec, "%s: needs LOOP and GAIN", ec->name);
	slot = gain_slot(dl, argv[0]);
	if (one_gain(dl, op, slot, &msg) < 0)
		return bad_loop(ctx, ec, argv[0]);
	if ((r = parse_value(ec, argv[1], &gain)) != 0)
		return r;
	if ((r = need_id(ctx, ec)) != 0)
		return r;
	spec = find_row(ctx, ec->name, msg.cmd);
	if (!spec)
		return RMDCTL_EXIT_DATA;
	r = set_field(ctx, ec->name, spec, rmd_pid_field(dl, (unsigned)slot), gain, &msg);
	if (r)
		return r;
	return finish(ctx, ec->name, spec, false, &msg, out);
}

/* V4.2 §2.33: CMD (hex) one whose reply the motor can push; ON 0/1; MS in 10 ms steps. */
static int enc_active_reply(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc,
			    char **argv, struct rmd_frame *out)
{
	const struct rmd_dialect *dl = rmd_dialect(ctx->table);
	const struct rmd_cmd_spec *spec;
	struct rmd_msg msg = { .cmd = 0xB6 };
	unsigned long cmd;
	double on, ms;
	bool known = false;
	char *end;
	int r;

	if (!rmd_dialect_has(dl, RMD_DIALECT_ACTIVE_REPLY))
		return usage_error(ec, "%s: protocol %s has no active reply (V4.2 §2.33: 0xB6)",
				   ec->name, rmd_proto_name(ctx->proto));
	if (argc != 3)
		return usage_error(ec, "%s: needs CMD, ON and MS", ec->name);
	errno = 0;
	cmd = strtoul(argv[0], &end, 16);
	for (unsigned i = 0; i < dl->n_report_cmds; i++)
		known |= dl->report_cmds[i] == cmd;
	if (end == argv[0] || *end || errno || *argv[0] == '-' || *argv[0] == '+' || !known) {
		tool_log(TOOL_LOG_ERR, "%s: CMD \"%s\" is not one the motor pushes", ec->name,
			 argv[0]);
		fprintf(stderr, "CMDs of %s:", dl->name);
		for (unsigned i = 0; i < dl->n_report_cmds; i++)
			fprintf(stderr, " %02X", dl->report_cmds[i]);
		fputc('\n', stderr);
		return RMDCTL_EXIT_USAGE;
	}
	if ((r = parse_value(ec, argv[1], &on)) != 0 || (r = parse_value(ec, argv[2], &ms)) != 0)
		return r;
	if ((r = need_id(ctx, ec)) != 0)
		return r;
	spec = find_row(ctx, ec->name, 0xB6);
	if (!spec)
		return RMDCTL_EXIT_DATA;
	if ((r = set_field(ctx, ec->name, spec, RMD_FLD_REPORT_CMD, (double)cmd, &msg)) != 0 ||
	    (r = set_field(ctx, ec->name, spec, RMD_FLD_REPORT_ON, on, &msg)) != 0 ||
	    (r = set_field(ctx, ec->name, spec, RMD_FLD_REPORT_MS, ms, &msg)) != 0)
		return r;
	return finish(ctx, ec->name, spec, false, &msg, out);
}

static int enc_mit(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
		   struct rmd_frame *out)
{
	static const char *const names[] = { "position", "velocity", "kp", "kd", "torque" };
	static const char *const units[] = { " rad", " rad/s", "", "", " N·m" };
	const struct rmd_mit_ranges *r = &ctx->r;
	const double lo[] = { r->p_min, r->v_min, r->kp_min, r->kd_min, r->t_min };
	const double hi[] = { r->p_max, r->v_max, r->kp_max, r->kd_max, r->t_max };
	double v[5];
	struct rmd_mit_cmd mc;
	int ret;

	if (!rmd_dialect_has(rmd_dialect(ctx->proto), RMD_DIALECT_MIT_FRAMES))
		return usage_error(ec, "mit: MIT mode is V3 firmware's (use --protocol v3 or mit)");
	if (argc != 5)
		return usage_error(ec, "mit: needs 5 values");
	if ((ret = need_id(ctx, ec)) != 0)
		return ret;
	for (int i = 0; i < 5; i++) {
		char vs[48], los[48], his[48];

		ret = parse_value(ec, argv[i], &v[i]);
		if (ret)
			return ret;
		if (v[i] >= lo[i] && v[i] <= hi[i])
			continue;
		/* rmd_mit_encode_cmd() would clamp: say so instead. */
		rmd_fmt_real(vs, sizeof(vs), v[i], 10);
		rmd_fmt_real(los, sizeof(los), lo[i], 10);
		rmd_fmt_real(his, sizeof(his), hi[i], 10);
		tool_log(TOOL_LOG_ERR, "mit: %s %s%s is out of range %s..%s%s (--mit-ranges)",
			 names[i], vs, units[i], los, his, units[i]);
		return RMDCTL_EXIT_USAGE;
	}
	mc = (struct rmd_mit_cmd){
		.p_des_rad = v[0], .v_des_rad_s = v[1], .kp = v[2], .kd = v[3], .t_ff_nm = v[4]
	};
	ret = rmd_mit_encode_cmd(r, (uint8_t)ctx->motor_id, &mc, out);
	if (ret < 0) {
		tool_log(TOOL_LOG_ERR, "mit: the MIT codec refused it: %s", strerror(-ret));
		return RMDCTL_EXIT_DATA;
	}
	return 0;
}

/* Row of `table` by name ("read_status_1", '-' for '_' allowed) or hex byte ("9A", "0x9A"). */
static const struct rmd_cmd_spec *raw_row(const struct enc_ctx *ctx, const char *s)
{
	const struct rmd_cmd_spec *rows;
	size_t n = rmd_cmd_table(ctx->table, &rows);
	unsigned long cmd;
	char *end;

	for (size_t i = 0; i < n; i++) {
		const char *a = rows[i].name, *b = s;

		while (*a && (*a == *b || (*a == '_' && *b == '-'))) {
			a++;
			b++;
		}
		if (!*a && !*b)
			return &rows[i];
	}
	errno = 0;
	cmd = strtoul(s, &end, 16);
	if (end == s || *end || errno || cmd > 0xFF || *s == '-' || *s == '+') {
		tool_log(TOOL_LOG_ERR, "raw: \"%s\" is neither a command byte nor a %s row name", s,
			 rmd_proto_name(ctx->table));
		return NULL;
	}
	return find_row(ctx, "raw", (uint8_t)cmd);
}

static int enc_raw(const struct enc_ctx *ctx, const struct enc_cmd *ec, int argc, char **argv,
		   struct rmd_frame *out)
{
	const struct rmd_cmd_spec *spec;
	struct rmd_msg msg = { 0 };
	uint64_t given = 0;
	bool multi;
	int r;

	if (argc < 1)
		return usage_error(ec, "raw: needs CMD");
	spec = raw_row(ctx, argv[0]);
	if (!spec)
		return RMDCTL_EXIT_USAGE;
	multi = spec->flags & RMD_CMD_NO_CMD_BYTE;
	if (!multi && (r = need_id(ctx, ec)) != 0)
		return r;
	msg.cmd = spec->cmd;
	for (int i = 1; i < argc; i++) {
		const char *eq = strchr(argv[i], '=');
		const struct rmd_field_spec *fs = NULL;
		size_t klen = eq ? (size_t)(eq - argv[i]) : 0;
		double v;

		for (unsigned j = 0; eq && j < spec->req.n; j++) {
			const char *key = rmd_field_key((enum rmd_field)spec->req.f[j].field);

			if (strlen(key) == klen && !strncmp(key, argv[i], klen))
				fs = &spec->req.f[j];
		}
		if (!fs) {
			tool_log(TOOL_LOG_ERR,
				 "raw: \"%s\" is not FIELD=VALUE with a request field of %s",
				 argv[i], spec->name);
			fprintf(stderr, "request fields of %s:", spec->name);
			for (unsigned j = 0; j < spec->req.n; j++)
				fprintf(stderr, " %s",
					rmd_field_key((enum rmd_field)spec->req.f[j].field));
			fprintf(stderr, "%s\n", spec->req.n ? "" : " none");
			return RMDCTL_EXIT_USAGE;
		}
		if (given & (UINT64_C(1) << fs->field)) {
			tool_log(TOOL_LOG_ERR, "raw: %s given twice",
				 rmd_field_key((enum rmd_field)fs->field));
			return RMDCTL_EXIT_USAGE;
		}
		given |= UINT64_C(1) << fs->field;
		if (fs->field == RMD_FLD_MODEL) {
			/* V3 §2.32: up to 7 ASCII characters. */
			if (strlen(eq + 1) > 7) {
				tool_log(TOOL_LOG_ERR, "raw: model is at most 7 characters");
				return RMDCTL_EXIT_USAGE;
			}
			rmd_msg_set(&msg, RMD_FLD_MODEL, rmd_model_raw(eq + 1));
			continue;
		}
		if (fs->field == RMD_FLD_BRAKE &&
		    (!strcmp(eq + 1, "true") || !strcmp(eq + 1, "false")))
			v = !strcmp(eq + 1, "true");
		else if ((r = parse_value(ec, eq + 1, &v)) != 0)
			return r;
		r = set_field(ctx, "raw", spec, (enum rmd_field)fs->field, v, &msg);
		if (r)
			return r;
	}
	return finish(ctx, "raw", spec, multi, &msg, out);
}

/* ---- main ----------------------------------------------------------------------------- */

static void print_frame(const struct rmd_frame *f)
{
	/* can-utils cansend: 3 hex digits of standard id, '#', two per byte. */
	printf("%03" PRIX32 "#", f->can_id);
	for (unsigned i = 0; i < f->len; i++)
		printf("%02X", f->data[i]);
	putchar('\n');
}

/* encode's own option: --id. */
static int encode_opt(int c, void *p)
{
	struct enc_ctx *ctx = p;
	char *end;
	long id;

	(void)c; /* 'i' */
	errno = 0;
	id = strtol(optarg, &end, 10);
	if (end == optarg || *end || errno || id < 1 || id > RMD_MAX_MOTORS) {
		tool_log(TOOL_LOG_ERR, "bad --id \"%s\" (motor 1..%d)", optarg, RMD_MAX_MOTORS);
		return -1;
	}
	ctx->motor_id = (int)id;
	return 0;
}

const struct tool_opt rmdctl_encode_opts[] = {
	RMDCTL_CODEC_OPTS,
	{ .name = "id", .shortc = 'i', .has_arg = required_argument, .arg = "N", .help = "" },
};
#define NOPTS (sizeof(rmdctl_encode_opts) / sizeof(rmdctl_encode_opts[0]))
const size_t rmdctl_n_encode_opts = NOPTS;

/* Options end at COMMAND, so "torque -1.5" is a value, not an option. */
static const struct rmdctl_codec_cmd encode_cmd = {
	"encode", RMDCTL_ENCODE_ARGS, rmdctl_encode_opts, NOPTS, true, rmdctl_encode_usage
};

int rmdctl_encode_run(int argc, char **argv)
{
	struct enc_ctx ctx = {
		.proto = RMDCTL_PROTO_DEFAULT,
		.motor_id = -1,
		.r = rmd_mit_default_ranges,
	};
	struct unlisted u[UNLISTED_MAX];
	const struct enc_cmd *ec = NULL;
	struct enc_cmd own = { 0 };
	struct tool_near near;
	struct rmd_frame frame;
	char args[96];
	size_t n;
	int r;

	r = rmdctl_codec_getopt(argc, argv, &encode_cmd, &ctx.proto, &ctx.r, encode_opt, &ctx);
	if (r >= 0)
		return r;
	ctx.table = rmd_proto_table(ctx.proto);
	if (optind >= argc) {
		tool_log(TOOL_LOG_ERR, "missing COMMAND");
		goto usage;
	}
	tool_near_init(&near, argv[optind]);
	for (size_t i = 0; i < NENC; i++) {
		if (!strcmp(enc_cmds[i].name, argv[optind]))
			ec = &enc_cmds[i];
		tool_near_try(&near, enc_cmds[i].name);
	}
	n = unlisted_words(u, UNLISTED_MAX);
	for (size_t i = 0; i < n; i++) {
		if (!ec && !strcmp(u[i].word, argv[optind])) {
			own = (struct enc_cmd){ .name = u[i].word,
						.args = unlisted_args(&u[i], args, sizeof(args)),
						.help = "" };
			ec = &own;
		}
		tool_near_try(&near, u[i].word);
	}
	if (!ec && near.best) {
		tool_log(TOOL_LOG_ERR, "unknown command \"%s\" (did you mean %s?)", argv[optind],
			 near.best);
		goto usage;
	}
	if (!ec) {
		tool_log(TOOL_LOG_ERR, "unknown command \"%s\"", argv[optind]);
		goto usage;
	}
	optind++;
	if (ec->custom)
		r = ec->custom(&ctx, ec, argc - optind, argv + optind, &frame);
	else
		r = enc_spelled(&ctx, ec, argc - optind, argv + optind, &frame);
	if (r)
		return r;
	print_frame(&frame);
	if (fflush(stdout) != 0) {
		tool_log(TOOL_LOG_ERR, "write error: %s", strerror(errno));
		return RMDCTL_EXIT_DATA;
	}
	return RMDCTL_EXIT_OK;

usage:
	rmdctl_usage_hint_args(encode_cmd.name, encode_cmd.args);
	return RMDCTL_EXIT_USAGE;
}
