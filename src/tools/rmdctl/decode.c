// SPDX-License-Identifier: MIT
/*
 * rmdctl decode: candump text in, one decoded line (text or JSON) per frame out.
 *
 * Walks the codec's table row of each frame, so every command the tables
 * describe is decoded, in the row's field order and native units.  A line
 * that is not can-utils text is reported on stderr with its number and
 * decoding goes on; a well-formed frame the protocol does not know is printed
 * as "unknown" with its bytes.  Non-rt.
 */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/candump.h"
#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmd/mit.h"
#include "rmdctl.h"

/* Longest input line, newline excluded; candump's own lines stay under 120. */
#define LINE_MAX_CHARS 511
/* Digits of MIT values (quantised to 12..16 bits) and of table-scaled fields. */
#define MIT_DIGITS 10
/* One output line: the input line's bytes, escaped, and the quantities. */
#define OUT_LINE_MAX 8192

struct decode_opts {
	enum rmd_proto proto;
	bool json;
	enum rmd_dir dir; /* RMD_DIR_UNKNOWN: from the identifier */
	struct rmd_mit_ranges ranges;
};

/* What one frame turned out to be. */
struct decoded {
	const struct rmd_candump_line *line;
	enum rmd_proto proto; /* V2, V3 or V4 for table rows; MIT */
	bool addr_ok;	      /* the identifier belongs to the protocol */
	struct rmd_addr addr;
	enum rmd_dir dir;
	int cmd;	  /* command byte, or -1 when the frame has none */
	const char *name; /* row name, "mit" or "unknown" */
	char note[96];	  /* why "unknown" */
	const struct rmd_cmd_spec *spec;
	struct rmd_msg msg;
	bool mit_req, mit_rep;
	struct rmd_mit_cmd mc;
	struct rmd_mit_reply mr;
};

void rmdctl_decode_usage(FILE *f)
{
	char keys[64];

	fprintf(f,
		"usage: rmdctl decode [--protocol %s] [--json] [--mit-ranges P,V,T,KP,KD]\n"
		"                     [--direction request|reply] " RMDCTL_DECODE_ARGS "\n"
		"\n"
		"Reads candump output from FILE (or stdin, or \"-\") and prints each frame\n"
		"decoded, one line per frame.  Accepted line shapes (hex in either case):\n"
		"  candump:     \"  can0  241   [8]  9A 32 00 01 E5 01 04 00\"\n"
		"               (with -ta/-td/-tz timestamps, -x and -a columns)\n"
		"  candump -l:  \"(1700000000.000000) can0 241#9A320001E5010400\"\n"
		"  cansend:     \"241#9A320001E5010400\"\n"
		"Blank lines and lines starting with '#' are skipped.\n"
		"\n"
		"  --protocol P    v3 (default): requests 0x140+ID, replies 0x240+ID, and\n"
		"                  MIT frames on 0x400+ID / 0x500+ID; mit: the same;\n"
		"                  v2: 0x140+ID both ways, 0x280 four torques; v4: as v3,\n"
		"                  with V4.2's table (float PID gains by index, 0x90,\n"
		"                  0x94, 0xA6, 0xB6; no 0xA3, 0xA5, 0x71)\n"
		"  --json          one JSON object per frame: can_id, motor_id, direction,\n"
		"                  cmd (null when the frame has no command byte), name, raw,\n"
		"                  then the quantities in native units under the codec's\n"
		"                  field keys (temperature_c, voltage_v, ...), \"errors\" with\n"
		"                  error_code, position_rad, velocity_rad_s, torque_nm, kp,\n"
		"                  kd for MIT frames, and interface and timestamp when the\n"
		"                  line has them; \"note\" says why a frame is \"unknown\"\n"
		"  --mit-ranges P,V,T,KP,KD\n"
		"                  MIT ranges: position ±P rad, velocity ±V rad/s, torque\n"
		"                  ±T N·m, kp 0..KP, kd 0..KD (default 12.5,45,24,500,5)\n"
		"  --direction D   decode every frame as a request or a reply (V2 shares\n"
		"                  identifiers both ways; by default the codec decides)\n"
		"\n"
		"exit status: 0 every line parsed; 1 some line could not be parsed (each is\n"
		"reported on stderr as \"rmdctl decode: line N: reason\") or I/O failed;\n"
		"2 usage error.  Frames the protocol does not know are not errors: they\n"
		"print as \"unknown\" with their bytes.\n",
		rmd_proto_keys_text(keys, sizeof(keys), "|", "|"));
}

/* ---- one frame ------------------------------------------------------------------------ */

static const char *dir_name(enum rmd_dir dir)
{
	switch (dir) {
	case RMD_DIR_REQUEST:
		return "request";
	case RMD_DIR_REPLY:
		return "reply";
	case RMD_DIR_UNKNOWN:
		break;
	}
	return "unknown";
}

static void print_time(struct rmd_text *t, const struct rmd_candump_line *l)
{
	rmd_text_add(t, "%" PRIu64 ".%0*" PRIu32, l->time_sec, (int)l->time_digits, l->time_frac);
}

static void print_header(struct rmd_text *t, bool json, const struct decoded *d)
{
	const struct rmd_candump_line *l = d->line;
	const struct rmd_frame *f = &l->frame;

	if (json) {
		rmd_text_add(t, "{\"can_id\":%" PRIu32 ",\"motor_id\":", f->can_id);
		if (d->addr_ok)
			rmd_text_add(t, "%u", (unsigned)d->addr.motor_id);
		else
			rmd_text_add(t, "null");
		rmd_text_add(t, ",\"direction\":\"%s\",\"cmd\":", dir_name(d->dir));
		if (d->cmd >= 0)
			rmd_text_add(t, "%d", d->cmd);
		else
			rmd_text_add(t, "null");
		rmd_text_add(t, ",\"name\":");
		rmd_text_json_str(t, d->name, strlen(d->name));
		rmd_text_add(t, ",\"raw\":\"");
		for (unsigned i = 0; i < f->len; i++)
			rmd_text_add(t, "%02X", f->data[i]);
		rmd_text_add(t, "\"");
		if (d->addr_ok && d->addr.broadcast)
			rmd_text_add(t, ",\"broadcast\":true");
		if (d->note[0]) {
			rmd_text_add(t, ",\"note\":");
			rmd_text_json_str(t, d->note, strlen(d->note));
		}
		return;
	}
	if (l->has_time) {
		rmd_text_add(t, "(");
		print_time(t, l);
		rmd_text_add(t, ") ");
	}
	if (l->iface[0]) {
		rmd_text_str(t, l->iface, strlen(l->iface));
		rmd_text_add(t, " ");
	}
	rmd_text_add(t, "%03" PRIX32, f->can_id);
	if (d->addr_ok && d->addr.broadcast)
		rmd_text_add(t, " broadcast");
	else if (d->addr_ok)
		rmd_text_add(t, " motor %u", (unsigned)d->addr.motor_id);
	if (d->dir != RMD_DIR_UNKNOWN)
		rmd_text_add(t, " %s", dir_name(d->dir));
	rmd_text_add(t, " %s", d->name);
	if (d->note[0])
		rmd_text_add(t, " (%s)", d->note);
}

static void print_trailer(struct rmd_text *t, bool json, const struct decoded *d)
{
	const struct rmd_candump_line *l = d->line;
	const struct rmd_frame *f = &l->frame;

	if (!json) {
		if (!d->spec && !d->mit_req && !d->mit_rep) {
			rmd_text_add(t, ":");
			for (unsigned i = 0; i < f->len; i++)
				rmd_text_add(t, " %02X", f->data[i]);
		}
		return;
	}
	if (l->iface[0]) {
		rmd_text_add(t, ",\"interface\":");
		rmd_text_json_str(t, l->iface, strlen(l->iface));
	}
	if (l->has_time) {
		rmd_text_add(t, ",\"timestamp\":");
		print_time(t, l);
	}
	rmd_text_add(t, "}");
}

/* One line: header, the quantities (rmd/describe.h), trailer. */
static void print_decoded(FILE *f, bool json, const struct decoded *d)
{
	enum rmd_describe_style style = json ? RMD_DESCRIBE_JSON : RMD_DESCRIBE_TEXT;
	/* MIT values are 12..16-bit codes: 6 digits are all a human needs. */
	int mit_digits = json ? MIT_DIGITS : 6;
	char line[OUT_LINE_MAX];
	struct rmd_text t;

	rmd_text_init(&t, line, sizeof(line));
	print_header(&t, json, d);
	if (d->spec)
		rmd_describe_fields(&t, style, d->proto, rmd_cmd_layout(d->spec, d->dir), &d->msg);
	else if (d->mit_req)
		rmd_describe_mit_cmd(&t, style, &d->mc, mit_digits);
	else if (d->mit_rep)
		rmd_describe_mit_reply(&t, style, &d->mr, mit_digits);
	print_trailer(&t, json, d);
	fprintf(f, "%s\n", line);
}

static bool dlc_ok(struct decoded *d)
{
	if (d->line->frame.len == RMD_FRAME_LEN)
		return true;
	snprintf(d->note, sizeof(d->note), "DLC %u; RMD frames carry 8 bytes",
		 (unsigned)d->line->frame.len);
	return false;
}

/* V3 §5: MIT frames, 0x400 + ID requests and 0x500 + ID replies. */
static void decode_mit(const struct decode_opts *opts, struct decoded *d)
{
	const struct rmd_frame *f = &d->line->frame;
	uint8_t id;

	d->proto = RMD_PROTO_MIT;
	d->dir = d->addr.dir;
	if (opts->dir != RMD_DIR_UNKNOWN && opts->dir != d->addr.dir) {
		snprintf(d->note, sizeof(d->note), "identifier %03" PRIX32 " carries MIT %ss",
			 f->can_id, dir_name(d->addr.dir));
		return;
	}
	if (!dlc_ok(d))
		return;
	if (d->addr.dir == RMD_DIR_REQUEST) {
		if (rmd_mit_decode_cmd(&opts->ranges, f, &id, &d->mc) == 0) {
			d->mit_req = true;
			d->name = "mit";
			return;
		}
	} else if (rmd_mit_decode_reply(&opts->ranges, f, &d->mr) == 0) {
		d->mit_rep = true;
		d->name = "mit";
		return;
	}
	snprintf(d->note, sizeof(d->note), "not a valid MIT %s%s", dir_name(d->addr.dir),
		 d->addr.dir == RMD_DIR_REPLY ? ": D0 is not the motor id" : "");
}

/* A frame of a V2, V3 or V4 table. */
static void decode_table(enum rmd_proto proto, const struct decode_opts *opts, struct decoded *d)
{
	const struct rmd_frame *f = &d->line->frame;
	enum rmd_dir dir = RMD_DIR_UNKNOWN;
	int r;

	d->proto = proto;
	d->dir = d->addr.dir != RMD_DIR_UNKNOWN ? d->addr.dir : opts->dir;
	if (f->len > 0 && !(rmd_dialect_has(rmd_dialect(proto), RMD_DIALECT_BATCH_280) &&
			    f->can_id == RMD_CAN_MULTI))
		d->cmd = f->data[0];
	if (opts->dir != RMD_DIR_UNKNOWN && d->addr.dir != RMD_DIR_UNKNOWN &&
	    opts->dir != d->addr.dir) {
		snprintf(d->note, sizeof(d->note), "identifier %03" PRIX32 " carries %s %ss",
			 f->can_id, rmd_proto_name(proto), dir_name(d->addr.dir));
		return;
	}
	if (!dlc_ok(d))
		return;
	r = rmd_decode(proto, opts->dir, f, &d->msg, &dir);
	if (r == -ENOENT) {
		snprintf(d->note, sizeof(d->note), "command 0x%02X is not in the %s table",
			 (unsigned)f->data[0], rmd_proto_name(proto));
		return;
	}
	if (r < 0) {
		snprintf(d->note, sizeof(d->note), "the %s codec refused it: %s",
			 rmd_proto_name(proto), strerror(-r));
		return;
	}
	d->spec = rmd_cmd_find(proto, d->msg.cmd);
	if (!d->spec) {
		snprintf(d->note, sizeof(d->note), "no table row for command 0x%02X",
			 (unsigned)d->msg.cmd);
		return;
	}
	d->dir = dir;
	d->name = d->spec->name;
	d->cmd = d->spec->flags & RMD_CMD_NO_CMD_BYTE ? -1 : d->spec->cmd;
	if (d->spec->flags & RMD_CMD_RANDOM_REPLY && dir == RMD_DIR_REPLY)
		snprintf(d->note, sizeof(d->note), "this command's reply content is meaningless");
}

static void decode_frame(const struct decode_opts *opts, const struct rmd_candump_line *line,
			 struct decoded *d)
{
	enum rmd_proto proto = rmd_proto_table(opts->proto);

	memset(d, 0, sizeof(*d));
	d->line = line;
	d->cmd = -1;
	d->name = "unknown";
	d->dir = opts->dir;
	d->proto = proto;
	/* firmware that takes MIT frames (v3, mit, v4): 0x4xx/0x5xx are MIT. */
	if (rmd_dialect_has(rmd_dialect(proto), RMD_DIALECT_MIT_FRAMES) &&
	    rmd_addr_from_id(RMD_PROTO_MIT, line->frame.can_id, &d->addr) == 0) {
		d->addr_ok = true;
		decode_mit(opts, d);
		return;
	}
	if (rmd_addr_from_id(proto, line->frame.can_id, &d->addr) < 0) {
		if (line->frame.len > 0)
			d->cmd = line->frame.data[0];
		snprintf(d->note, sizeof(d->note), "not an identifier of protocol %s",
			 rmd_proto_name(opts->proto));
		return;
	}
	d->addr_ok = true;
	decode_table(proto, opts, d);
}

/* ---- input ---------------------------------------------------------------------------- */

enum line_status {
	LINE_OK,
	LINE_EOF,
	LINE_TOO_LONG, /* the rest of it was read and dropped */
	LINE_NUL,      /* holds a NUL byte */
};

/* One line into buf (LINE_MAX_CHARS + 1 bytes), newline stripped. */
static enum line_status read_line(FILE *in, char *buf, size_t *len)
{
	enum line_status st = LINE_OK;
	size_t n = 0;
	int c;

	while ((c = getc(in)) != EOF && c != '\n') {
		if (c == '\0' && st == LINE_OK)
			st = LINE_NUL;
		if (n < LINE_MAX_CHARS)
			buf[n++] = (char)c;
		else
			st = LINE_TOO_LONG;
	}
	buf[n] = '\0';
	*len = n;
	if (c == EOF && n == 0 && st == LINE_OK)
		return LINE_EOF;
	return st;
}

static bool skip_line(const char *s)
{
	s += strspn(s, " \t\r");
	return *s == '\0' || *s == '#';
}

/* The offending text of a refused line, quoted, at most 40 characters. */
static void bad_line(unsigned long lineno, const char *buf, const struct rmd_candump_line *l)
{
	char tok[48];
	size_t n = l->err_len < 40 ? l->err_len : 40, o = 0;

	for (size_t i = 0; i < n && o + 5 < sizeof(tok); i++) {
		unsigned char c = (unsigned char)buf[l->err_off + i];

		if (c < 0x20 || c >= 0x7f || c == '"' || c == '\\')
			o += (size_t)snprintf(tok + o, sizeof(tok) - o, "\\x%02X", c);
		else
			tok[o++] = (char)c;
	}
	tok[o] = '\0';
	if (l->err_len)
		tool_log(TOOL_LOG_ERR, "line %lu: %s \"%s%s\"", lineno,
			 rmd_candump_strerror(l->err), tok, l->err_len > n ? "..." : "");
	else
		tool_log(TOOL_LOG_ERR, "line %lu: %s", lineno, rmd_candump_strerror(l->err));
}

static int decode_stream(FILE *in, const struct decode_opts *opts)
{
	char buf[LINE_MAX_CHARS + 1];
	unsigned long lineno = 0;
	int status = RMDCTL_EXIT_OK;
	enum line_status st;
	size_t len;

	while ((st = read_line(in, buf, &len)) != LINE_EOF) {
		struct rmd_candump_line line;
		struct decoded d;

		lineno++;
		if (st == LINE_TOO_LONG) {
			tool_log(TOOL_LOG_ERR, "line %lu: longer than %d characters", lineno,
				 LINE_MAX_CHARS);
			status = RMDCTL_EXIT_DATA;
			continue;
		}
		if (st == LINE_NUL) {
			tool_log(TOOL_LOG_ERR, "line %lu: contains a NUL byte", lineno);
			status = RMDCTL_EXIT_DATA;
			continue;
		}
		if (skip_line(buf))
			continue;
		if (rmd_candump_parse(buf, &line) < 0) {
			bad_line(lineno, buf, &line);
			status = RMDCTL_EXIT_DATA;
			continue;
		}
		decode_frame(opts, &line, &d);
		print_decoded(stdout, opts->json, &d);
	}
	if (ferror(in)) {
		tool_log(TOOL_LOG_ERR, "read error after line %lu", lineno);
		status = RMDCTL_EXIT_DATA;
	}
	return status;
}

/* decode's own options: --json, --direction. */
static int decode_opt(int c, void *ctx)
{
	struct decode_opts *opts = ctx;

	if (c == 'j') {
		opts->json = true;
		return 0;
	}
	/* 'd' */
	if (strcmp(optarg, "request") && strcmp(optarg, "reply")) {
		tool_log(TOOL_LOG_ERR, "bad --direction \"%s\" (request or reply)", optarg);
		return -1;
	}
	opts->dir = !strcmp(optarg, "request") ? RMD_DIR_REQUEST : RMD_DIR_REPLY;
	return 0;
}

const struct tool_opt rmdctl_decode_opts[] = {
	RMDCTL_CODEC_OPTS,
	{ .name = "json", .shortc = 'j', .help = "" },
	{ .name = "direction",
	  .shortc = 'd',
	  .has_arg = required_argument,
	  .arg = "D",
	  .help = "",
	  .value = TOOL_VAL_WORDS,
	  .words = "request reply" },
};
#define NOPTS (sizeof(rmdctl_decode_opts) / sizeof(rmdctl_decode_opts[0]))
const size_t rmdctl_n_decode_opts = NOPTS;

/* name, operands, options, whether options end at the first operand, --help */
static const struct rmdctl_codec_cmd decode_cmd = {
	"decode", RMDCTL_DECODE_ARGS, rmdctl_decode_opts, NOPTS, false, rmdctl_decode_usage
};

int rmdctl_decode_run(int argc, char **argv)
{
	struct decode_opts opts = {
		.proto = RMDCTL_PROTO_DEFAULT,
		.dir = RMD_DIR_UNKNOWN,
		.ranges = rmd_mit_default_ranges,
	};
	const char *path = NULL;
	FILE *in = stdin;
	int r, status;

	r = rmdctl_codec_getopt(argc, argv, &decode_cmd, &opts.proto, &opts.ranges, decode_opt,
				&opts);
	if (r >= 0)
		return r;
	if (argc - optind > 1) {
		tool_log(TOOL_LOG_ERR, "one FILE at most");
		goto usage;
	}
	if (optind < argc && strcmp(argv[optind], "-")) {
		path = argv[optind];
		in = fopen(path, "r");
		if (!in) {
			tool_log(TOOL_LOG_ERR, "%s: %s", path, strerror(errno));
			return RMDCTL_EXIT_DATA;
		}
	}
	/* Live use (candump can0 | rmdctl decode | ...) wants each line as it comes. */
	setvbuf(stdout, NULL, _IOLBF, 0);
	status = decode_stream(in, &opts);
	if (path)
		fclose(in);
	if (fflush(stdout) != 0 || ferror(stdout)) {
		tool_log(TOOL_LOG_ERR, "write error: %s", strerror(errno));
		status = RMDCTL_EXIT_DATA;
	}
	return status;

usage:
	rmdctl_usage_hint_args(decode_cmd.name, decode_cmd.args);
	return RMDCTL_EXIT_USAGE;
}
