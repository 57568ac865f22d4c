// SPDX-License-Identifier: MIT
/*
 * rmdctl device commands: talk to motors over any bus (SocketCAN, RS485,
 * or the in-process simulated bus) for bench work.
 *
 *   scan, info, status, monitor           read
 *   set-id, set-zero, set-timeout,        write (ROM: confirmed)
 *   accel, pid, brake, stop, off, reset
 *   move                                  moves (confirmed)
 *
 * Every exchange is a transaction of rmd/txn.h: requests are pipelined,
 * each answer is matched by reply identifier and command byte, and a
 * silent motor fails after --tries sends of --timeout each, with a message
 * that names the bus, the motor and the command.  Whatever writes ROM or
 * may move a motor asks on the terminal first, unless --yes; with no
 * terminal and no --yes it refuses (exit 2).  Non-rt.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rmd/time.h"
#include "rmd/bus.h"
#include "rmd/bus_open.h"
#include "rmd/codec.h"
#include "rmd/txn.h"
#include "rmdctl.h"

#define DEFAULT_BUS "can0"
#define BUS_ENV "RMDCTL_BUS"
#define ERRLEN 256
/* Requests in one batch: three reads for each of 32 motors. */
#define MAX_REQS (3 * RMD_MAX_MOTORS)
#define MAX_ERROR_NAMES 16
#define FIELD_DIGITS 15

/* monitor */
#define MONITOR_INTERVAL_MS 200.0
/* move: a bench move is small and slow unless --force */
#define MOVE_SPEED_DPS 30.0
#define MOVE_SPEED_CAP_DPS 90.0
#define MOVE_TRAVEL_CAP_DEG 360.0
#define MOVE_TOL_DEG 0.2
#define MOVE_POLL_NS 20000000
#define MOVE_SETTLE_NS 1000000000 /* no progress this long: it stopped short */
#define MOVE_SLACK_NS 3000000000  /* beyond travel / speed * 1.5 */
/* accel: V3 §2.5.1 range */
#define ACCEL_MIN_DPS2 100
#define ACCEL_MAX_DPS2 60000
/* reset: how long a motor may take to answer again */
#define RESET_WAIT_NS 3000000000
#define RESET_POLL_NS 50000000
/* set-id: how long the new id may take to answer */
#define SET_ID_WAIT_NS 1000000000

/* Options beyond the common ones, per command. */
enum {
	O_JSON = 1u << 0,
	O_YES = 1u << 1,
	O_ROM = 1u << 2,
	O_SPEED = 1u << 3,
	O_FORCE = 1u << 4,
	O_NOWAIT = 1u << 5,
	O_ONCE = 1u << 6,
	O_INTERVAL = 1u << 7,
};

struct dev;

struct dev_cmd {
	const char *name;
	const char *args; /* positional arguments, for usage */
	unsigned min_args, max_args;
	unsigned opts;
	int (*run)(struct dev *d, int argc, char **argv);
	const char *help;
};

/* Everything one run of a device command holds. */
struct dev {
	const struct dev_cmd *cmd;
	const char *sub; /* command name for messages */
	/* options */
	const char *bus_spec;
	uint32_t baud;
	enum rmd_proto proto;
	double timeout_ms;
	unsigned tries;
	bool json, yes, rom, force, no_wait, once, trace;
	double speed_dps;
	double interval_ms;
	/* the bus */
	struct rmd_bus bus;  /* the transport */
	struct rmd_bus tbus; /* --trace: prints every frame, then calls bus */
	struct rmd_bus *b;   /* what the commands use: &bus or &tbus */
	char name[sizeof(((struct rmd_bus *)0)->name)]; /* the bus's, kept after close */
	struct rmd_txn_opts txn;
	int64_t t0_ns; /* start, for --trace and monitor times */
};

/* One request to one motor and what came of it. */
struct req {
	uint8_t id;
	struct rmd_msg msg; /* request */
	struct rmd_txn t;
	bool answered;	    /* a frame matched */
	bool ok;	    /* ... and decoded (echo rows: equal to the request) */
	struct rmd_msg rep; /* decoded answer */
};

/* Fields gathered from several answers of one motor, in native units. */
struct rec {
	uint64_t present;
	int64_t raw[RMD_FLD_COUNT];
	double scale[RMD_FLD_COUNT];
};

static volatile sig_atomic_t interrupted;

static void on_signal(int sig)
{
	(void)sig;
	interrupted = 1;
}

/* ---- small helpers -------------------------------------------------------------------- */

static const struct rmd_cmd_spec *spec_of(const struct dev *d, uint8_t cmd)
{
	return rmd_cmd_find(d->proto, cmd);
}

/* "5", "0.5": a number of ms for messages. */
static const char *ms_str(char *buf, size_t size, double ms)
{
	rmdctl_fmt_real(buf, size, ms, 6);
	return buf;
}

static bool has(const struct rec *r, enum rmd_field f)
{
	return (r->present >> f) & 1;
}

static double val(const struct rec *r, enum rmd_field f)
{
	return (double)r->raw[f] * r->scale[f];
}

/* Fold the fields of an answer into r; keep what r has unless overwrite. */
static void rec_add(struct rec *r, const struct rmd_cmd_spec *spec, const struct rmd_msg *m,
		    bool overwrite)
{
	const struct rmd_layout *l = rmd_cmd_layout(spec, RMD_DIR_REPLY);

	for (unsigned i = 0; i < l->n; i++) {
		enum rmd_field f = (enum rmd_field)l->f[i].field;

		if (!rmd_msg_has(m, f) || (has(r, f) && !overwrite))
			continue;
		r->present |= UINT64_C(1) << f;
		r->raw[f] = m->v[f];
		r->scale[f] = l->f[i].scale;
	}
}

static void rec_add_req(struct rec *r, const struct dev *d, const struct req *q, bool overwrite)
{
	const struct rmd_cmd_spec *spec = spec_of(d, q->msg.cmd);

	if (q->ok && spec)
		rec_add(r, spec, &q->rep, overwrite);
}

/* Set field f of a request to `value` in native units (the row's scale); -ERANGE if it cannot. */
static int set_native(struct rmd_msg *m, const struct rmd_cmd_spec *spec, enum rmd_field f,
		      double value)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, RMD_DIR_REQUEST, f);
	double raw;

	if (!fs || !(fs->scale > 0))
		return -EINVAL;
	raw = round(value / fs->scale);
	if (!isfinite(raw) || fabs(raw) > 9e15)
		return -ERANGE;
	rmd_msg_set(m, f, (int64_t)raw);
	return 0;
}

static void json_str(FILE *f, const char *s)
{
	fputc('"', f);
	for (; *s; s++) {
		unsigned char c = (unsigned char)*s;

		if (c == '"' || c == '\\')
			fprintf(f, "\\%c", c);
		else if (c < 0x20 || c >= 0x7f)
			fprintf(f, "\\u%04x", c);
		else
			fputc(c, f);
	}
	fputc('"', f);
}

/* A whole-string unsigned integer in [lo, hi].  Returns 0 or -EINVAL. */
static int parse_uint(const char *s, uint64_t lo, uint64_t hi, uint64_t *v)
{
	char *end;
	unsigned long long x;

	if (!s || *s < '0' || *s > '9')
		return -EINVAL;
	errno = 0;
	x = strtoull(s, &end, 10);
	if (*end || errno == ERANGE || x < lo || x > hi)
		return -EINVAL;
	*v = x;
	return 0;
}

static int parse_id(struct dev *d, const char *s, const char *what, uint8_t *id)
{
	uint64_t v;

	if (parse_uint(s, 1, RMD_MAX_MOTORS, &v) < 0) {
		rmdctl_err(d->sub, "bad %s \"%s\" (a motor id 1..%d)", what, s, RMD_MAX_MOTORS);
		return -EINVAL;
	}
	*id = (uint8_t)v;
	return 0;
}

static void sleep_until(int64_t t_ns)
{
	struct timespec ts = { .tv_sec = t_ns / 1000000000, .tv_nsec = t_ns % 1000000000 };

	/* EINTR (Ctrl-C) ends the sleep; the caller looks at `interrupted`. */
	clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
}

/* ---- confirmation --------------------------------------------------------------------- */

/*
 * Before anything is sent: without --yes a terminal must be there to ask.
 * Returns 0 or RMDCTL_EXIT_USAGE (message printed).
 */
__attribute__((format(printf, 2, 3))) static int can_confirm(struct dev *d, const char *fmt, ...)
{
	char what[256];
	va_list ap;

	if (d->yes || isatty(STDIN_FILENO))
		return 0;
	va_start(ap, fmt);
	vsnprintf(what, sizeof(what), fmt, ap);
	va_end(ap);
	rmdctl_err(d->sub,
		   "refusing to %s without confirmation: stdin is not a terminal (add --yes)",
		   what);
	return RMDCTL_EXIT_USAGE;
}

/*
 * Ask "QUESTION? [y/N]" on the terminal, unless --yes.  Returns 0 (go
 * ahead), RMDCTL_EXIT_USAGE (no terminal) or RMDCTL_EXIT_DATA (declined).
 */
__attribute__((format(printf, 2, 3))) static int confirm(struct dev *d, const char *fmt, ...)
{
	char q[320], line[64];
	va_list ap;
	size_t n;

	va_start(ap, fmt);
	vsnprintf(q, sizeof(q), fmt, ap);
	va_end(ap);
	if (d->yes)
		return 0;
	if (!isatty(STDIN_FILENO)) {
		rmdctl_err(d->sub,
			   "refusing to %s without confirmation: stdin is not a terminal "
			   "(add --yes)",
			   q);
		return RMDCTL_EXIT_USAGE;
	}
	fprintf(stderr, "%s? [y/N] ", q);
	fflush(stderr);
	if (!fgets(line, sizeof(line), stdin))
		line[0] = '\0';
	n = strcspn(line, "\r\n");
	line[n] = '\0';
	if (!strcmp(line, "y") || !strcmp(line, "Y") || !strcmp(line, "yes")) {
		return 0;
	}
	rmdctl_err(d->sub, "not confirmed: nothing changed");
	return RMDCTL_EXIT_DATA;
}

/* ---- --trace: a bus that prints every frame, then hands it on --------------------------- */

static void trace_frame(struct dev *d, const char *dir, const struct rmd_frame *f, int64_t t_ns)
{
	int64_t rel = t_ns - d->t0_ns;

	fprintf(stderr, "(%" PRId64 ".%06" PRId64 ") %s %s %03" PRIX32 "#", rel / 1000000000,
		(rel % 1000000000) / 1000, d->name, dir, f->can_id);
	for (unsigned i = 0; i < f->len && i < RMD_FRAME_LEN; i++)
		fprintf(stderr, "%02X", f->data[i]);
	fputc('\n', stderr);
}

static int trace_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		      int64_t now_ns)
{
	struct dev *d = bus->priv;
	int r = rmd_bus_send(&d->bus, frames, n, now_ns);

	for (int i = 0; i < r; i++)
		trace_frame(d, "TX", &frames[i], now_ns);
	return r;
}

static int trace_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	struct dev *d = bus->priv;
	int r = rmd_bus_recv(&d->bus, out, max, now_ns);

	for (int i = 0; i < r; i++)
		trace_frame(d, "RX", &out[i].f, out[i].t_ns);
	return r;
}

static int trace_fd(const struct rmd_bus *bus)
{
	const struct dev *d = bus->priv;

	return rmd_bus_fd(&d->bus);
}

static int64_t trace_next_due_ns(const struct rmd_bus *bus)
{
	const struct dev *d = bus->priv;

	return rmd_bus_next_due_ns(&d->bus);
}

static enum rmd_bus_state trace_state(const struct rmd_bus *bus)
{
	const struct dev *d = bus->priv;

	return rmd_bus_state(&d->bus);
}

static const struct rmd_bus_stats *trace_stats(const struct rmd_bus *bus)
{
	const struct dev *d = bus->priv;

	return rmd_bus_stats(&d->bus);
}

static void trace_close(struct rmd_bus *bus)
{
	memset(bus, 0, sizeof(*bus));
}

static const struct rmd_bus_ops trace_ops = {
	.kind = "trace",
	.send = trace_send,
	.recv = trace_recv,
	.fd = trace_fd,
	.next_due_ns = trace_next_due_ns,
	.state = trace_state,
	.stats = trace_stats,
	.close = trace_close,
};

/* ---- the bus -------------------------------------------------------------------------- */

static int open_bus(struct dev *d)
{
	struct rmd_bus_open_opts o = {
		.proto = d->proto,
		.set_id_replies = true, /* set-id reads 0x79 answers on 0x300 */
		.baud = d->baud,
	};
	char err[ERRLEN];
	int r;

	r = rmd_bus_open_spec(&d->bus, d->bus_spec, &o, err, sizeof(err));
	if (r < 0) {
		rmdctl_err(d->sub, "%s", err[0] ? err : strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	if (err[0])
		rmdctl_err(d->sub, "note: %s", err);
	snprintf(d->name, sizeof(d->name), "%s", d->bus.name);
	d->b = &d->bus;
	d->txn.timeout_ns = (int64_t)llround(d->timeout_ms * 1e6);
	d->txn.tries = d->tries;
	d->txn.stop = &interrupted;
	/* Half duplex RS485 queues requests behind each other's answers. */
	d->txn.spacing_ns = rmd_bus_caps(&d->bus)->request_spacing_ns;
	if (d->trace) {
		d->tbus = d->bus;
		d->tbus.ops = &trace_ops;
		d->tbus.priv = d;
		d->b = &d->tbus;
	}
	return 0;
}

static void close_bus(struct dev *d)
{
	if (d->b == &d->tbus)
		rmd_bus_close(&d->tbus);
	rmd_bus_close(&d->bus);
	d->b = NULL;
}

/* ---- transactions --------------------------------------------------------------------- */

static void req_init(struct req *q, uint8_t id, uint8_t cmd)
{
	memset(q, 0, sizeof(*q));
	q->id = id;
	q->msg.cmd = cmd;
}

/* "motor 3 did not answer 0x9A within 5 ms (3 tries)" + more, or why it was not sent. */
static void report_missing(struct dev *d, const struct req *q, const char *more)
{
	char ms[32];

	if (q->t.tries == 0) {
		rmdctl_err(d->sub,
			   "%s: could not send 0x%02X to motor %u: the bus took no frame (%s)",
			   d->name, q->msg.cmd, q->id, rmd_bus_state_name(rmd_bus_state(d->b)));
		return;
	}
	rmdctl_err(d->sub, "%s: motor %u did not answer 0x%02X within %s ms (%u %s)%s", d->name,
		   q->id, q->msg.cmd, ms_str(ms, sizeof(ms), d->timeout_ms), q->t.tries,
		   q->t.tries == 1 ? "try" : "tries", more);
}

static void report_bad(struct dev *d, const struct req *q)
{
	const struct rmd_frame *f = &q->t.rep.f;
	char hex[3 * RMD_FRAME_LEN + 1] = "";

	for (unsigned i = 0; i < f->len && i < RMD_FRAME_LEN; i++)
		snprintf(hex + 2 * i, sizeof(hex) - 2 * i, "%02X", f->data[i]);
	rmdctl_err(d->sub, "%s: motor %u answered 0x%02X with %03" PRIX32 "#%s, which %s", d->name,
		   q->id, q->msg.cmd, f->can_id, hex,
		   spec_of(d, q->msg.cmd) && spec_of(d, q->msg.cmd)->flags & RMD_CMD_ECHO ?
			   "is not the echo of the request" :
			   "does not decode");
}

/*
 * Run q[0..n) as one pipelined batch.  Returns 0 when the bus worked
 * (each q[i].ok says whether its motor answered), RMDCTL_EXIT_DATA on a
 * bus error or Ctrl-C (message printed).
 */
static int run_reqs(struct dev *d, struct req *q, unsigned n)
{
	struct rmd_txn t[MAX_REQS];
	int r;

	if (n > MAX_REQS)
		n = MAX_REQS;
	for (unsigned i = 0; i < n; i++) {
		r = rmd_txn_prepare(&t[i], d->proto, q[i].id, &q[i].msg);
		if (r < 0) {
			rmdctl_err(d->sub, "motor %u: cannot encode 0x%02X: %s", q[i].id,
				   q[i].msg.cmd, strerror(-r));
			return RMDCTL_EXIT_DATA;
		}
	}
	r = rmd_txn_run(d->b, t, n, &d->txn);
	if (r == -EINTR) {
		rmdctl_err(d->sub, "interrupted");
		return RMDCTL_EXIT_DATA;
	}
	if (r < 0) {
		rmdctl_err(d->sub, "%s: %s", d->name, strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	for (unsigned i = 0; i < n; i++) {
		const struct rmd_cmd_spec *spec = spec_of(d, q[i].msg.cmd);
		const struct rmd_frame *f = &t[i].rep.f;

		q[i].t = t[i];
		q[i].answered = t[i].done && !t[i].no_reply;
		q[i].ok = t[i].done;
		if (!q[i].answered)
			continue;
		if (spec->flags & RMD_CMD_ECHO)
			q[i].ok = f->len == t[i].req.len &&
				  !memcmp(f->data, t[i].req.data, RMD_FRAME_LEN);
		if (q[i].ok)
			q[i].ok = rmd_decode_as(d->proto, RMD_DIR_REPLY, q[i].msg.cmd, f,
						&q[i].rep) == 0;
	}
	return 0;
}

/* The answer run_reqs() got for one request; reports failure.  Returns 0 or RMDCTL_EXIT_DATA. */
static int ask_check(struct dev *d, struct req *q)
{
	if (!q->answered && !q->ok) {
		report_missing(d, q, "");
		return RMDCTL_EXIT_DATA;
	}
	if (!q->ok) {
		report_bad(d, q);
		return RMDCTL_EXIT_DATA;
	}
	return 0;
}

/* One request; reports failure.  Returns 0 or RMDCTL_EXIT_DATA. */
static int ask(struct dev *d, struct req *q)
{
	int r = run_reqs(d, q, 1);

	return r ? r : ask_check(d, q);
}

/*
 * Every failed request of a batch, reported; a motor that answered none of
 * its requests gets one line.  Returns how many requests failed.
 */
static unsigned report_failed(struct dev *d, const struct req *q, unsigned n)
{
	unsigned bad = 0;

	for (unsigned i = 0; i < n; i++) {
		bool told = false;
		char more[64] = "";
		size_t o = 0;

		if (q[i].ok)
			continue;
		bad++;
		if (q[i].answered) {
			report_bad(d, &q[i]);
			continue;
		}
		for (unsigned j = 0; j < i; j++)
			told |= q[j].id == q[i].id && !q[j].answered && !q[j].ok;
		if (told)
			continue;
		for (unsigned j = i + 1; j < n && o < sizeof(more); j++)
			if (q[j].id == q[i].id && !q[j].answered && !q[j].ok)
				o += (size_t)snprintf(more + o, sizeof(more) - o, "%s0x%02X",
						      o ? ", " : ", nor ", q[j].msg.cmd);
		report_missing(d, &q[i], more);
	}
	return bad;
}

/* Probe ids[0..n) with 0x9A; found[] gets those that answered.  Returns the count or -exit. */
static int probe(struct dev *d, const uint8_t *ids, unsigned n, uint8_t *found, struct req *st)
{
	int r, m = 0;

	for (unsigned i = 0; i < n; i++)
		req_init(&st[i], ids[i], 0x9A);
	r = run_reqs(d, st, n);
	if (r)
		return -r;
	for (unsigned i = 0; i < n; i++)
		if (st[i].ok)
			found[m++] = ids[i];
	return m;
}

/* ---- output --------------------------------------------------------------------------- */

static const char *errors_text(const struct dev *d, int64_t raw, char *buf, size_t size)
{
	const char *names[MAX_ERROR_NAMES];
	size_t n = rmd_error_names(d->proto, (uint16_t)raw, names, MAX_ERROR_NAMES), o;

	if (raw == 0) {
		snprintf(buf, size, "none");
		return buf;
	}
	o = (size_t)snprintf(buf, size, "0x%04X", (unsigned)(uint16_t)raw);
	for (size_t i = 0; i < n && i < MAX_ERROR_NAMES && o < size; i++)
		o += (size_t)snprintf(buf + o, size - o, "%s%s", i ? "," : " ", names[i]);
	return buf;
}

/* A field's value as text (no unit) for tables and "key: value" lines. */
static const char *field_text(const struct dev *d, const struct rec *r, enum rmd_field f, char *buf,
			      size_t size)
{
	if (!has(r, f)) {
		snprintf(buf, size, "-");
		return buf;
	}
	if (f == RMD_FLD_ERROR)
		return errors_text(d, r->raw[f], buf, size);
	if (f == RMD_FLD_MODEL) {
		char m[8];

		rmd_model_string(r->raw[f], m);
		m[sizeof(m) - 1] = '\0';
		snprintf(buf, size, "%s", m);
		return buf;
	}
	if (f == RMD_FLD_BRAKE) {
		snprintf(buf, size, "%s", r->raw[f] ? "released" : "locked");
		return buf;
	}
	if (f == RMD_FLD_MODE) {
		const char *name = rmd_run_mode_name(d->proto, (uint8_t)r->raw[f]);

		snprintf(buf, size, "%" PRId64 "%s%s%s", r->raw[f], name ? " (" : "",
			 name ? name : "", name ? ")" : "");
		return buf;
	}
	if (r->scale[f] == 1.0)
		snprintf(buf, size, "%" PRId64, r->raw[f]);
	else
		rmdctl_fmt_real(buf, size, val(r, f), FIELD_DIGITS);
	return buf;
}

/* ,"key":value for one field; null when it is missing. */
static void json_field(const struct dev *d, const struct rec *r, enum rmd_field f)
{
	char buf[64];

	printf(",\"%s\":", rmd_field_key(f));
	if (!has(r, f)) {
		fputs("null", stdout);
		if (f == RMD_FLD_ERROR)
			fputs(",\"errors\":null", stdout);
		if (f == RMD_FLD_MODE)
			fputs(",\"mode_name\":null", stdout);
		return;
	}
	if (f == RMD_FLD_ERROR) {
		const char *names[MAX_ERROR_NAMES];
		size_t n = rmd_error_names(d->proto, (uint16_t)r->raw[f], names, MAX_ERROR_NAMES);

		printf("%" PRId64 ",\"errors\":[", r->raw[f]);
		for (size_t i = 0; i < n && i < MAX_ERROR_NAMES; i++) {
			if (i)
				fputc(',', stdout);
			json_str(stdout, names[i]);
		}
		fputc(']', stdout);
	} else if (f == RMD_FLD_MODEL) {
		json_str(stdout, field_text(d, r, f, buf, sizeof(buf)));
	} else if (f == RMD_FLD_BRAKE) {
		fputs(r->raw[f] ? "true" : "false", stdout);
	} else if (f == RMD_FLD_MODE) {
		const char *name = rmd_run_mode_name(d->proto, (uint8_t)r->raw[f]);

		printf("%" PRId64 ",\"mode_name\":", r->raw[f]);
		if (name)
			json_str(stdout, name);
		else
			fputs("null", stdout);
	} else {
		fputs(field_text(d, r, f, buf, sizeof(buf)), stdout);
	}
}

static void json_begin(const struct dev *d, uint8_t id)
{
	fputs("{\"bus\":", stdout);
	json_str(stdout, d->name);
	printf(",\"motor_id\":%u,\"protocol\":\"%s\"", id, rmdctl_proto_name(d->proto));
}

/* "  label:   value unit" */
static void text_field(const struct dev *d, const struct rec *r, enum rmd_field f)
{
	char label[40], buf[128];
	const char *unit;

	rmdctl_field_label(f, label, sizeof(label), &unit);
	if (f == RMD_FLD_ERROR)
		snprintf(label, sizeof(label), "errors");
	else if (f == RMD_FLD_BRAKE)
		snprintf(label, sizeof(label), "brake");
	else if (f == RMD_FLD_VERSION)
		snprintf(label, sizeof(label), "firmware date");
	field_text(d, r, f, buf, sizeof(buf));
	printf("  %-16s %s%s%s\n", label, buf, has(r, f) && *unit ? " " : "",
	       has(r, f) ? unit : "");
}

/* One motor: a JSON line, or a header and one line per field. */
static void print_rec(const struct dev *d, uint8_t id, const struct rec *r,
		      const enum rmd_field *order, size_t n)
{
	if (d->json) {
		json_begin(d, id);
		for (size_t i = 0; i < n; i++)
			json_field(d, r, order[i]);
		fputs("}\n", stdout);
		return;
	}
	printf("%s motor %u (%s)\n", d->name, id, rmdctl_proto_name(d->proto));
	for (size_t i = 0; i < n; i++)
		text_field(d, r, order[i]);
}

/* ---- scan ----------------------------------------------------------------------------- */

static int ids_arg(struct dev *d, const char *s, uint8_t *ids)
{
	int n = rmd_bus_open_parse_ids(s, ids);

	if (n < 0)
		rmdctl_err(d->sub, "bad motor list \"%s\" (ids 1..%d, e.g. 1-3,7)", s,
			   RMD_MAX_MOTORS);
	return n;
}

static unsigned all_ids(uint8_t *ids)
{
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++)
		ids[i] = (uint8_t)(i + 1);
	return RMD_MAX_MOTORS;
}

static int run_scan(struct dev *d, int argc, char **argv)
{
	static const enum rmd_field cols[] = { RMD_FLD_MODEL,	RMD_FLD_VERSION, RMD_FLD_TEMP,
					       RMD_FLD_VOLTAGE, RMD_FLD_BRAKE,	 RMD_FLD_ERROR };
	uint8_t ids[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS], info[2 * RMD_MAX_MOTORS];
	bool v3 = d->proto != RMD_PROTO_V2;
	int64_t t0 = rmd_now_ns();
	unsigned n, ni = 0;
	int m, r;
	char ms[32];

	if (argc > 0) {
		m = ids_arg(d, argv[0], ids);
		if (m < 0)
			return RMDCTL_EXIT_USAGE;
		n = (unsigned)m;
	} else {
		n = all_ids(ids);
	}
	r = open_bus(d);
	if (r)
		return r;
	/* 0x9A first: every protocol has it.  Then model and version of those that answered. */
	m = probe(d, ids, n, found, st);
	if (m < 0) {
		close_bus(d);
		return -m;
	}
	if (v3) {
		for (int i = 0; i < m; i++) {
			req_init(&info[ni++], found[i], 0xB5);
			req_init(&info[ni++], found[i], 0xB2);
		}
		r = run_reqs(d, info, ni);
		if (r) {
			close_bus(d);
			return r;
		}
		report_failed(d, info, ni);
	}
	if (!d->json && m > 0)
		printf("%3s  %-8s %-9s %-5s %6s %9s  %-8s %s\n", "ID", "MODEL", "FIRMWARE", "PROTO",
		       "TEMP_C", "VOLTAGE_V", "BRAKE", "ERRORS");
	for (unsigned i = 0, k = 0; i < n; i++) {
		struct rec rec = { 0 };
		char c[6][64];

		if (!st[i].ok)
			continue;
		rec_add_req(&rec, d, &st[i], true);
		for (; k < ni && info[k].id <= ids[i]; k++)
			if (info[k].id == ids[i])
				rec_add_req(&rec, d, &info[k], true);
		if (d->json) {
			print_rec(d, ids[i], &rec, cols, sizeof(cols) / sizeof(cols[0]));
			continue;
		}
		for (unsigned j = 0; j < 6; j++)
			field_text(d, &rec, cols[j], c[j], sizeof(c[j]));
		printf("%3u  %-8s %-9s %-5s %6s %9s  %-8s %s\n", ids[i], c[0], c[1],
		       rmdctl_proto_name(d->proto), c[2], c[3], c[4], c[5]);
	}
	if (m == 0)
		rmdctl_err(d->sub,
			   "%s: no motor answered 0x9A (%u ids probed, %s, %s ms x %u tries)",
			   d->name, n, rmdctl_proto_name(d->proto),
			   ms_str(ms, sizeof(ms), d->timeout_ms), d->tries);
	else if (!d->json)
		printf("%s: %d motor%s answered (%u ids probed in %.0f ms)\n", d->name, m,
		       m == 1 ? "" : "s", n, (double)(rmd_now_ns() - t0) / 1e6);
	close_bus(d);
	return m > 0 ? RMDCTL_EXIT_OK : RMDCTL_EXIT_DATA;
}

/* ---- info, status --------------------------------------------------------------------- */

/* V2 §3.1 .. §3.6: one Q24 gain per command, in the order of enum rmd_field CURR_KP.. */
static const uint8_t v2_pid_read[6] = { 0x34, 0x35, 0x32, 0x33, 0x30, 0x31 };

static int run_info(struct dev *d, int argc, char **argv)
{
	static const enum rmd_field order[] = {
		RMD_FLD_MODEL,	 RMD_FLD_VERSION, RMD_FLD_RUNTIME, RMD_FLD_ACCEL,
		RMD_FLD_CURR_KP, RMD_FLD_CURR_KI, RMD_FLD_SPD_KP,  RMD_FLD_SPD_KI,
		RMD_FLD_POS_KP,	 RMD_FLD_POS_KI,  RMD_FLD_MODE,
	};
	struct req q[12];
	struct rec rec = { 0 };
	unsigned n = 0, bad;
	uint8_t id;
	int r;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (d->proto != RMD_PROTO_V2) {
		req_init(&q[n++], id, 0xB5); /* V3 §2.32 */
		req_init(&q[n++], id, 0xB2); /* V3 §2.29 */
		req_init(&q[n++], id, 0xB1); /* V3 §2.28 */
		req_init(&q[n++], id, 0x30); /* V3 §2.1: six gains */
	} else {
		for (unsigned i = 0; i < 6; i++)
			req_init(&q[n++], id, v2_pid_read[i]);
	}
	req_init(&q[n++], id, 0x42); /* V3 §2.4 / V2 §3.19 */
	req_init(&q[n++], id, 0x70); /* V3 §2.23 / V2 §3.45 */
	r = open_bus(d);
	if (r)
		return r;
	r = run_reqs(d, q, n);
	close_bus(d);
	if (r)
		return r;
	bad = report_failed(d, q, n);
	if (bad == n)
		return RMDCTL_EXIT_DATA;
	for (unsigned i = 0; i < n; i++)
		rec_add_req(&rec, d, &q[i], true);
	if (d->json) {
		json_begin(d, id);
		for (size_t i = 0; i < sizeof(order) / sizeof(order[0]); i++)
			json_field(d, &rec, order[i]);
		/* V3 §2.30: 0xB3 only writes; nothing reads the timeout back. */
		fputs(",\"timeout_ms\":null}\n", stdout);
	} else {
		print_rec(d, id, &rec, order, sizeof(order) / sizeof(order[0]));
		printf("  %-16s %s\n", "comm timeout",
		       "not readable (0xB3 only writes it; see `rmdctl set-timeout`)");
	}
	return bad ? RMDCTL_EXIT_DATA : RMDCTL_EXIT_OK;
}

static const enum rmd_field status_fields[] = {
	RMD_FLD_TEMP,  RMD_FLD_VOLTAGE, RMD_FLD_ERROR,	 RMD_FLD_BRAKE,
	RMD_FLD_ANGLE, RMD_FLD_SPEED,	RMD_FLD_CURRENT,
};

/* Status reads of one motor. */
static void status_reqs(struct req *q, uint8_t id)
{
	req_init(&q[0], id, 0x9A); /* V3 §2.12 / V2 §3.31 */
	req_init(&q[1], id, 0x92); /* V3 §2.11 / V2 §3.29 */
	req_init(&q[2], id, 0x9C); /* V3 §2.13 / V2 §3.32 */
}

/* 0x92's angle (0.01 deg) goes in first, so 0x9C's whole degrees do not replace it. */
static void status_rec(const struct dev *d, const struct req *q, struct rec *rec)
{
	memset(rec, 0, sizeof(*rec));
	rec_add_req(rec, d, &q[1], false);
	rec_add_req(rec, d, &q[0], false);
	rec_add_req(rec, d, &q[2], false);
}

static int run_status(struct dev *d, int argc, char **argv)
{
	struct req q[3];
	struct rec rec;
	unsigned bad;
	uint8_t id;
	int r;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	status_reqs(q, id);
	r = open_bus(d);
	if (r)
		return r;
	r = run_reqs(d, q, 3);
	close_bus(d);
	if (r)
		return r;
	bad = report_failed(d, q, 3);
	if (bad == 3)
		return RMDCTL_EXIT_DATA;
	status_rec(d, q, &rec);
	print_rec(d, id, &rec, status_fields, sizeof(status_fields) / sizeof(status_fields[0]));
	return bad ? RMDCTL_EXIT_DATA : RMDCTL_EXIT_OK;
}

/* ---- monitor -------------------------------------------------------------------------- */

static void monitor_table(struct dev *d, const uint8_t *ids, unsigned n, const struct req *q,
			  bool clear)
{
	static const enum rmd_field cols[] = { RMD_FLD_TEMP,  RMD_FLD_VOLTAGE, RMD_FLD_ANGLE,
					       RMD_FLD_SPEED, RMD_FLD_CURRENT, RMD_FLD_BRAKE,
					       RMD_FLD_ERROR };
	double t_s = (double)(rmd_now_ns() - d->t0_ns) / 1e9;
	char ms[32];

	if (d->json) {
		for (unsigned i = 0; i < n; i++) {
			struct rec rec;

			status_rec(d, &q[3 * i], &rec);
			json_begin(d, ids[i]);
			printf(",\"time_s\":%.3f,\"answered\":%s", t_s,
			       q[3 * i].ok || q[3 * i + 1].ok || q[3 * i + 2].ok ? "true" :
										   "false");
			for (size_t j = 0; j < sizeof(cols) / sizeof(cols[0]); j++)
				json_field(d, &rec, cols[j]);
			fputs("}\n", stdout);
		}
		fflush(stdout);
		return;
	}
	if (clear)
		fputs("\033[H\033[2J", stdout);
	printf("%s (%s)  %u motor%s  every %s ms  t=%.1f s%s\n", d->name,
	       rmdctl_proto_name(d->proto), n, n == 1 ? "" : "s",
	       ms_str(ms, sizeof(ms), d->interval_ms), t_s, d->once ? "" : "  (Ctrl-C quits)");
	printf("%3s %7s %10s %11s %10s %10s  %-8s %s\n", "ID", "TEMP_C", "VOLTAGE_V", "ANGLE_DEG",
	       "SPEED_DPS", "CURRENT_A", "BRAKE", "ERRORS");
	for (unsigned i = 0; i < n; i++) {
		const struct req *mq = &q[3 * i];
		struct rec rec;
		char c[7][64];

		if (!mq[0].ok && !mq[1].ok && !mq[2].ok) {
			printf("%3u %s\n", ids[i], "no answer");
			continue;
		}
		status_rec(d, mq, &rec);
		for (unsigned j = 0; j < 7; j++)
			field_text(d, &rec, cols[j], c[j], sizeof(c[j]));
		printf("%3u %7s %10s %11s %10s %10s  %-8s %s\n", ids[i], c[0], c[1], c[2], c[3],
		       c[4], c[5], c[6]);
	}
	fflush(stdout);
}

static int run_monitor(struct dev *d, int argc, char **argv)
{
	uint8_t ids[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req q[MAX_REQS];
	bool clear = !d->once && isatty(STDOUT_FILENO);
	int64_t period = (int64_t)llround(d->interval_ms * 1e6), next;
	unsigned n;
	int m, r, status = RMDCTL_EXIT_OK;

	if (argc > 0) {
		m = ids_arg(d, argv[0], ids);
		if (m < 0)
			return RMDCTL_EXIT_USAGE;
		n = (unsigned)m;
	} else {
		n = all_ids(ids);
	}
	r = open_bus(d);
	if (r)
		return r;
	if (argc == 0) {
		/* No list: the motors that answer a probe. */
		m = probe(d, ids, n, found, q);
		if (m <= 0) {
			if (m == 0)
				rmdctl_err(d->sub, "%s: no motor answered 0x9A (ids 1..%d)",
					   d->name, RMD_MAX_MOTORS);
			close_bus(d);
			return m < 0 ? -m : RMDCTL_EXIT_DATA;
		}
		n = (unsigned)m;
		memcpy(ids, found, n);
	}
	next = rmd_now_ns();
	while (!interrupted) {
		for (unsigned i = 0; i < n; i++)
			status_reqs(&q[3 * i], ids[i]);
		r = run_reqs(d, q, 3 * n);
		if (r) {
			status = interrupted ? RMDCTL_EXIT_OK : r;
			break;
		}
		monitor_table(d, ids, n, q, clear);
		if (d->once) {
			if (report_failed(d, q, 3 * n))
				status = RMDCTL_EXIT_DATA;
			break;
		}
		next += period;
		if (next < rmd_now_ns())
			next = rmd_now_ns(); /* late: skip, never catch up in a burst */
		sleep_until(next);
	}
	close_bus(d);
	return status;
}

/* ---- set-id, set-zero, set-timeout ---------------------------------------------------- */

/* After a V3 0x79 with --force: the other motors that took the new id too. */
static int others_renumbered(struct dev *d, const uint8_t *before, unsigned n, uint8_t old_id,
			     uint8_t new_id)
{
	uint8_t others[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS];
	unsigned k = 0;
	int m;

	for (unsigned i = 0; i < n; i++)
		if (before[i] != old_id)
			others[k++] = before[i];
	if (k == 0)
		return RMDCTL_EXIT_OK;
	m = probe(d, others, k, found, st);
	if (m < 0)
		return -m;
	if ((unsigned)m == k)
		return RMDCTL_EXIT_OK;
	for (unsigned i = 0; i < k; i++)
		if (!st[i].ok)
			rmdctl_err(d->sub,
				   "%s: motor %u no longer answers: it took id %u too (its CAN-ID "
				   "filter is off)",
				   d->name, others[i], new_id);
	return RMDCTL_EXIT_DATA;
}

static int run_set_id(struct dev *d, int argc, char **argv)
{
	uint8_t old_id, new_id, all[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS], q;
	bool v3 = d->proto != RMD_PROTO_V2, old_seen = false, new_seen = false;
	int64_t until;
	int m, r;

	(void)argc;
	if (parse_id(d, argv[0], "OLD id", &old_id) < 0 ||
	    parse_id(d, argv[1], "NEW id", &new_id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (old_id == new_id) {
		rmdctl_err(d->sub, "OLD and NEW are both %u", old_id);
		return RMDCTL_EXIT_USAGE;
	}
	r = can_confirm(d, "write CAN id %u to motor %u on %s", new_id, old_id, d->bus_spec);
	if (r)
		return r;
	r = open_bus(d);
	if (r)
		return r;
	/* Who is on the bus: V3 §4 sends 0x79 on 0x300, and every motor hears it. */
	m = probe(d, all, all_ids(all), found, st);
	if (m < 0) {
		r = -m;
		goto out;
	}
	for (int i = 0; i < m; i++) {
		old_seen |= found[i] == old_id;
		new_seen |= found[i] == new_id;
	}
	r = RMDCTL_EXIT_DATA;
	if (!old_seen) {
		rmdctl_err(d->sub, "%s: motor %u does not answer 0x9A: nothing to renumber",
			   d->name, old_id);
		goto out;
	}
	if (new_seen) {
		rmdctl_err(d->sub, "%s: id %u is taken: a motor answers on it", d->name, new_id);
		goto out;
	}
	if (v3) {
		rmdctl_err(d->sub,
			   "warning: V3 §4 sends 0x79 on 0x300: every motor on %s whose CAN-ID "
			   "filter is off (0x20 index 2) takes id %u, not only motor %u",
			   d->name, new_id, old_id);
		if (m > 1 && !d->force) {
			rmdctl_err(d->sub,
				   "%s: %d motors answer; connect motor %u alone, or turn the "
				   "others' CAN-ID filter on and add --force",
				   d->name, m, old_id);
			goto out;
		}
	}
	r = confirm(d, "write CAN id %u to motor %u on %s (ROM%s)", new_id, old_id, d->name,
		    v3 ? "; every motor with the CAN-ID filter off hears it" : "");
	if (r)
		goto out;
	req_init(&q, old_id, 0x79);
	rmd_msg_set(&q.msg, RMD_FLD_READ_FLAG, 0); /* V3 §4.2 / V2 §3.52: 0 writes */
	rmd_msg_set(&q.msg, RMD_FLD_CAN_ID, new_id);
	r = run_reqs(d, &q, 1);
	if (r)
		goto out;
	/* V3 §4.3: the answer of a write is the request itself (the row's reply layout is a read's). */
	if (!q.answered) {
		report_missing(d, &q, "");
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (memcmp(q.t.rep.f.data, q.t.req.data, RMD_FRAME_LEN)) {
		rmdctl_err(d->sub,
			   "%s: the answer to 0x79 is not the echo of the request: the id "
			   "may not have changed",
			   d->name);
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	/* The new id answers, the old one no longer does. */
	until = rmd_now_ns() + SET_ID_WAIT_NS;
	do {
		struct req v[2];

		req_init(&v[0], new_id, 0x9A);
		req_init(&v[1], old_id, 0x9A);
		r = run_reqs(d, v, 2);
		if (r)
			goto out;
		if (v[0].ok && !v[1].ok) {
			printf("%s: motor %u is now motor %u (ROM)\n", d->name, old_id, new_id);
			r = others_renumbered(d, found, (unsigned)m, old_id, new_id);
			goto out;
		}
	} while (rmd_now_ns() < until && !interrupted);
	rmdctl_err(d->sub, "%s: motor %u echoed the new id %u, but id %u %s and id %u %s", d->name,
		   old_id, new_id, new_id, "does not answer as expected", old_id,
		   "may still answer");
	r = RMDCTL_EXIT_DATA;
out:
	close_bus(d);
	return r;
}

static int run_set_zero(struct dev *d, int argc, char **argv)
{
	struct req q;
	uint8_t id;
	int r;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	r = can_confirm(d, "write the zero of motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	r = open_bus(d);
	if (r)
		return r;
	r = confirm(d, "make the current position of motor %u on %s its zero (ROM)", id, d->name);
	if (r)
		goto out;
	/* V3 §2.10 / V2 §3.25: the current position becomes the zero, in ROM, after a restart. */
	req_init(&q, id, 0x64);
	r = ask(d, &q);
	if (r)
		goto out;
	printf("%s: motor %u: zero offset %" PRId64 " counts written to ROM; it applies after a "
	       "reset (`rmdctl reset %u`) or a power cycle\n",
	       d->name, id, q.rep.v[RMD_FLD_ENCODER_OFF], id);
out:
	close_bus(d);
	return r;
}

static int run_set_timeout(struct dev *d, int argc, char **argv)
{
	struct req q;
	uint64_t ms;
	uint8_t id;
	int r;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (parse_uint(argv[1], 0, UINT32_MAX, &ms) < 0) {
		rmdctl_err(d->sub, "bad MS \"%s\" (0..%" PRIu32 "; 0 turns the protection off)",
			   argv[1], UINT32_MAX);
		return RMDCTL_EXIT_USAGE;
	}
	if (d->proto == RMD_PROTO_V2) {
		rmdctl_err(d->sub, "protocol V2 has no comm-loss protection (0xB3 is V3 §2.30)");
		return RMDCTL_EXIT_USAGE;
	}
	r = can_confirm(d, "write the comm timeout of motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	r = open_bus(d);
	if (r)
		return r;
	r = confirm(d, "set the comm-loss protection of motor %u on %s to %" PRIu64 " ms (ROM)", id,
		    d->name, ms);
	if (r)
		goto out;
	/* V3 §2.30: stored in ROM; the answer echoes the request, or (example 2) is zeros. */
	req_init(&q, id, 0xB3);
	rmd_msg_set(&q.msg, RMD_FLD_TIMEOUT, (int64_t)ms);
	r = run_reqs(d, &q, 1);
	if (!r && q.answered && !q.ok && !memcmp(q.t.rep.f.data, "\xB3\0\0\0\0\0\0", 8)) {
		printf("%s: motor %u: comm-loss protection written to ROM; answered with zeros "
		       "(V3 §2.30 example 2): accepted, the time is not verified\n",
		       d->name, id);
		goto out;
	}
	r = r ? r : ask_check(d, &q);
	if (r)
		goto out;
	if (ms)
		printf("%s: motor %u: comm-loss protection %" PRIu64
		       " ms written to ROM, echo verified; the motor turns its output off when it "
		       "hears nothing for %" PRIu64 " ms\n",
		       d->name, id, ms, ms);
	else
		printf("%s: motor %u: comm-loss protection off (ROM), echo verified\n", d->name,
		       id);
out:
	close_bus(d);
	return r;
}

/* ---- accel, pid ----------------------------------------------------------------------- */

static const char *const accel_names[4] = { "position-accel", "position-decel", "speed-accel",
					    "speed-decel" };

static int run_accel(struct dev *d, int argc, char **argv)
{
	bool v2 = d->proto == RMD_PROTO_V2;
	struct rec rec = { 0 };
	uint64_t index = 0, dps2;
	const char *sval;
	struct req q;
	uint8_t id;
	int r;

	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (argc == 1) {
		/* V3 §2.4: the position-planning acceleration; V2 §3.19: the one there is. */
		req_init(&q, id, 0x42);
		r = open_bus(d);
		if (r)
			return r;
		r = ask(d, &q);
		close_bus(d);
		if (r)
			return r;
		rec_add_req(&rec, d, &q, true);
		print_rec(d, id, &rec, (const enum rmd_field[]){ RMD_FLD_ACCEL }, 1);
		return RMDCTL_EXIT_OK;
	}
	if (v2 != (argc == 2)) {
		rmdctl_err(d->sub, v2 ? "V2 writes one acceleration: accel ID DPS2" :
					"V3 writes by index: accel ID INDEX DPS2");
		return RMDCTL_EXIT_USAGE;
	}
	if (!v2) {
		for (index = 0; index < 4 && strcmp(argv[1], accel_names[index]); index++)
			;
		if (index == 4 && parse_uint(argv[1], 0, 3, &index) < 0) {
			rmdctl_err(d->sub,
				   "bad INDEX \"%s\" (0 position-accel, 1 position-decel, 2 "
				   "speed-accel, 3 speed-decel)",
				   argv[1]);
			return RMDCTL_EXIT_USAGE;
		}
	}
	sval = argv[argc - 1];
	if (parse_uint(sval, 0, INT32_MAX, &dps2) < 0 ||
	    (!d->force && (dps2 < ACCEL_MIN_DPS2 || dps2 > ACCEL_MAX_DPS2))) {
		rmdctl_err(d->sub, "bad DPS2 \"%s\" (%d..%d dps/s, V3 §2.5.1; --force for others)",
			   sval, ACCEL_MIN_DPS2, ACCEL_MAX_DPS2);
		return RMDCTL_EXIT_USAGE;
	}
	if (!v2) {
		r = can_confirm(d, "write an acceleration of motor %u on %s", id, d->bus_spec);
		if (r)
			return r;
	}
	r = open_bus(d);
	if (r)
		return r;
	if (!v2) {
		r = confirm(d, "set %s of motor %u on %s to %" PRIu64 " dps/s (RAM and ROM)",
			    accel_names[index], id, d->name, dps2);
		if (r)
			goto out;
	}
	/* V3 §2.5: RAM and ROM, by index; V2 §3.20: RAM.  Both echo. */
	req_init(&q, id, 0x43);
	if (!v2)
		rmd_msg_set(&q.msg, RMD_FLD_INDEX, (int64_t)index);
	rmd_msg_set(&q.msg, RMD_FLD_ACCEL, (int64_t)dps2);
	r = ask(d, &q);
	if (r)
		goto out;
	if (d->json)
		printf("{\"bus\":\"%s\",\"motor_id\":%u,\"protocol\":\"%s\",\"index\":%" PRIu64
		       ",\"accel_dps2\":%" PRIu64 "}\n",
		       d->name, id, rmdctl_proto_name(d->proto), index, dps2);
	else
		printf("%s: motor %u: %s %" PRIu64 " dps/s written (%s), echo verified\n", d->name,
		       id, v2 ? "acceleration" : accel_names[index], dps2,
		       v2 ? "RAM" : "RAM and ROM");
out:
	close_bus(d);
	return r;
}

static const enum rmd_field pid_fields[6] = { RMD_FLD_CURR_KP, RMD_FLD_CURR_KI, RMD_FLD_SPD_KP,
					      RMD_FLD_SPD_KI,  RMD_FLD_POS_KP,	RMD_FLD_POS_KI };

static int pid_read(struct dev *d, uint8_t id)
{
	struct rec rec = { 0 };
	struct req q[6];
	unsigned n = 0;
	int r;

	if (d->proto == RMD_PROTO_V2)
		for (unsigned i = 0; i < 6; i++)
			req_init(&q[n++], id, v2_pid_read[i]);
	else
		req_init(&q[n++], id, 0x30);
	r = open_bus(d);
	if (r)
		return r;
	r = run_reqs(d, q, n);
	close_bus(d);
	if (r)
		return r;
	if (report_failed(d, q, n))
		return RMDCTL_EXIT_DATA;
	for (unsigned i = 0; i < n; i++)
		rec_add_req(&rec, d, &q[i], true);
	print_rec(d, id, &rec, pid_fields, 6);
	return RMDCTL_EXIT_OK;
}

static int run_pid(struct dev *d, int argc, char **argv)
{
	bool v2 = d->proto == RMD_PROTO_V2;
	double g[6];
	struct req q[6];
	unsigned n = 0;
	uint8_t id;
	int r;

	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (argc == 1) {
		if (d->rom) {
			rmdctl_err(d->sub, "--rom applies to writing gains");
			return RMDCTL_EXIT_USAGE;
		}
		return pid_read(d, id);
	}
	if (argc != 7) {
		rmdctl_err(d->sub,
			   "give all six gains: CURR_KP CURR_KI SPD_KP SPD_KI POS_KP POS_KI");
		return RMDCTL_EXIT_USAGE;
	}
	for (unsigned i = 0; i < 6; i++) {
		/* V3 §2.2: uint8 gains; V2 §3.7: Q24 reals. */
		if (rmdctl_parse_double(argv[1 + i], &g[i]) < 0 || g[i] < 0 ||
		    (!v2 && (g[i] > 255 || g[i] != floor(g[i]))) || (v2 && g[i] >= 128)) {
			rmdctl_err(d->sub, "bad gain \"%s\" (%s)", argv[1 + i],
				   v2 ? "a real 0..127 (Q24)" : "an integer 0..255");
			return RMDCTL_EXIT_USAGE;
		}
	}
	if (d->rom) {
		r = can_confirm(d, "write the PID gains of motor %u on %s to ROM", id, d->bus_spec);
		if (r)
			return r;
	}
	if (v2) {
		for (unsigned i = 0; i < 6; i++) {
			/* V2 §3.7 .. §3.18: RAM 0x36.., ROM 0x3C.., six after each read. */
			uint8_t cmd = (uint8_t)(v2_pid_read[i] + (d->rom ? 12 : 6));

			req_init(&q[n], id, cmd);
			if (set_native(&q[n].msg, spec_of(d, cmd), pid_fields[i], g[i]) < 0) {
				rmdctl_err(d->sub, "gain %g does not fit 0x%02X", g[i], cmd);
				return RMDCTL_EXIT_USAGE;
			}
			n++;
		}
	} else {
		/* V3 §2.2 (0x31, RAM) / §2.3 (0x32, ROM). */
		req_init(&q[n], id, d->rom ? 0x32 : 0x31);
		for (unsigned i = 0; i < 6; i++)
			rmd_msg_set(&q[n].msg, pid_fields[i], (int64_t)g[i]);
		n++;
	}
	r = open_bus(d);
	if (r)
		return r;
	if (d->rom) {
		r = confirm(d, "write PID gains %g %g %g %g %g %g to motor %u on %s (ROM)", g[0],
			    g[1], g[2], g[3], g[4], g[5], id, d->name);
		if (r)
			goto out;
	}
	r = run_reqs(d, q, n);
	if (r)
		goto out;
	if (report_failed(d, q, n)) {
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (d->json) {
		struct rec rec = { 0 };

		for (unsigned i = 0; i < n; i++)
			rec_add(&rec, spec_of(d, q[i].msg.cmd), &q[i].msg, true);
		print_rec(d, id, &rec, pid_fields, 6);
	} else {
		printf("%s: motor %u: PID gains written to %s, echo verified\n", d->name, id,
		       d->rom ? "RAM and ROM" : "RAM (lost at power off; --rom keeps them)");
	}
out:
	close_bus(d);
	return r;
}

/* ---- brake, stop, off, reset ---------------------------------------------------------- */

/* One echoing command with a one-line report. */
static int simple(struct dev *d, uint8_t id, uint8_t cmd, const char *done)
{
	struct req q;
	int r;

	r = open_bus(d);
	if (r)
		return r;
	req_init(&q, id, cmd);
	r = ask(d, &q);
	if (!r)
		printf("%s: motor %u: %s (0x%02X)\n", d->name, id, done, cmd);
	close_bus(d);
	return r;
}

static int run_brake(struct dev *d, int argc, char **argv)
{
	bool lock;
	struct req q;
	uint8_t id;
	int r;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (!strcmp(argv[1], "on") || !strcmp(argv[1], "lock")) {
		lock = true;
	} else if (!strcmp(argv[1], "off") || !strcmp(argv[1], "release")) {
		lock = false;
	} else {
		rmdctl_err(d->sub, "bad state \"%s\" (on = locked, off = released)", argv[1]);
		return RMDCTL_EXIT_USAGE;
	}
	/* V3 §2.27 / V2 §3.51: locking moves nothing. */
	if (lock)
		return simple(d, id, 0x78, "brake locked");
	/* V3 §2.26: a released brake lets the load move the shaft. */
	r = can_confirm(d, "release the brake of motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	r = open_bus(d);
	if (r)
		return r;
	r = confirm(d, "release the brake of motor %u on %s (the load may move the shaft)", id,
		    d->name);
	if (!r) {
		req_init(&q, id, 0x77);
		r = ask(d, &q);
		if (!r)
			printf("%s: motor %u: brake released (0x77)\n", d->name, id);
	}
	close_bus(d);
	return r;
}

static int run_stop(struct dev *d, int argc, char **argv)
{
	uint8_t id;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	/* V3 §2.16 / V2 §3.35: decelerate and hold. */
	return simple(d, id, 0x81, "stopped, holding position");
}

static int run_off(struct dev *d, int argc, char **argv)
{
	uint8_t id;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	/* V3 §2.15 / V2 §3.34: output off, state cleared. */
	return simple(d, id, 0x80, "output off");
}

static int run_reset(struct dev *d, int argc, char **argv)
{
	bool v2 = d->proto == RMD_PROTO_V2;
	int64_t t_reset, until;
	struct req q;
	uint8_t id;
	int r;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	r = open_bus(d);
	if (r)
		return r;
	/* V3 §2.25: no answer; V2 §3.49: echoes, then resets. */
	req_init(&q, id, 0x76);
	r = v2 ? ask(d, &q) : run_reqs(d, &q, 1);
	if (r)
		goto out;
	t_reset = rmd_now_ns();
	until = t_reset + RESET_WAIT_NS;
	/* Back when it answers again: V3 runtime (0xB1) restarts at 0; V2 has only 0x9A. */
	r = RMDCTL_EXIT_DATA;
	do {
		int64_t now;

		req_init(&q, id, v2 ? 0x9A : 0xB1);
		if (run_reqs(d, &q, 1))
			goto out;
		now = rmd_now_ns();
		if (q.ok && (v2 || q.rep.v[RMD_FLD_RUNTIME] <= (now - t_reset) / 1000000 + 100)) {
			printf("%s: motor %u: reset (0x76), answering again after %.0f ms%s\n",
			       d->name, id, (double)(now - t_reset) / 1e6,
			       v2 ? "" : "; multi-turn position restarts within +-180 deg");
			r = RMDCTL_EXIT_OK;
			goto out;
		}
		sleep_until(now + RESET_POLL_NS);
	} while (rmd_now_ns() < until && !interrupted);
	rmdctl_err(d->sub, "%s: motor %u: sent 0x76, but it did not answer again within %.0f s",
		   d->name, id, RESET_WAIT_NS / 1e9);
out:
	close_bus(d);
	return r;
}

/* ---- move ----------------------------------------------------------------------------- */

/* The multi-turn angle (0x92), in deg.  Returns 0 or RMDCTL_EXIT_DATA (reported). */
static int read_angle(struct dev *d, uint8_t id, double *deg)
{
	struct rec rec = { 0 };
	struct req q;
	int r;

	req_init(&q, id, 0x92);
	r = ask(d, &q);
	if (r)
		return r;
	rec_add_req(&rec, d, &q, true);
	if (!has(&rec, RMD_FLD_ANGLE))
		return RMDCTL_EXIT_DATA;
	*deg = val(&rec, RMD_FLD_ANGLE);
	return 0;
}

/* Ctrl-C or a move gone wrong: V3 §2.16 stop and hold, whatever interrupted the rest. */
static void stop_motor(struct dev *d, uint8_t id)
{
	struct rmd_txn_opts o = d->txn;
	struct rmd_txn t;
	struct rmd_msg m = { .cmd = 0x81 };

	o.stop = NULL;
	if (rmd_txn_prepare(&t, d->proto, id, &m) == 0 && rmd_txn_run(d->b, &t, 1, &o) == 1)
		rmdctl_err(d->sub, "%s: motor %u stopped (0x81), holding position", d->name, id);
	else
		rmdctl_err(d->sub, "%s: motor %u: stop (0x81) not acknowledged", d->name, id);
}

/* Poll 0x92 until the motor is within MOVE_TOL_DEG of target, stops short, or time runs out. */
static int move_wait(struct dev *d, uint8_t id, double from, double target, double *final,
		     const char **why)
{
	double travel = fabs(target - from), last = from;
	int64_t t0 = rmd_now_ns(), last_progress = t0;
	int64_t limit = t0 + (int64_t)(travel / d->speed_dps * 1.5e9) + MOVE_SLACK_NS;
	unsigned near = 0;
	int r;

	*final = from;
	for (;;) {
		int64_t now;

		sleep_until(rmd_now_ns() + MOVE_POLL_NS);
		if (interrupted) {
			*why = "interrupted";
			return RMDCTL_EXIT_DATA;
		}
		r = read_angle(d, id, final);
		if (r) {
			*why = interrupted ? "interrupted" : "lost contact";
			return r;
		}
		now = rmd_now_ns();
		/* Two polls in a row within tolerance: arrived and settled. */
		near = fabs(*final - target) <= MOVE_TOL_DEG ? near + 1 : 0;
		if (near >= 2)
			return 0;
		if (fabs(*final - last) > 0.05) {
			last = *final;
			last_progress = now;
		} else if (now - last_progress > MOVE_SETTLE_NS) {
			*why = "stopped short";
			return RMDCTL_EXIT_DATA;
		}
		if (now > limit) {
			*why = "timed out";
			return RMDCTL_EXIT_DATA;
		}
	}
}

static int run_move(struct dev *d, int argc, char **argv)
{
	const struct rmd_cmd_spec *spec = spec_of(d, 0xA4);
	double target, from, final;
	struct rec rec = { 0 };
	struct req q[2];
	const char *why = "";
	bool release;
	int64_t t0;
	uint8_t id;
	int r;

	(void)argc;
	if (parse_id(d, argv[0], "ID", &id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (rmdctl_parse_double(argv[1], &target) < 0 || fabs(target) > 1e6) {
		rmdctl_err(d->sub, "bad DEG \"%s\" (an angle in degrees)", argv[1]);
		return RMDCTL_EXIT_USAGE;
	}
	if (!(d->speed_dps >= 1) || d->speed_dps > UINT16_MAX) {
		rmdctl_err(d->sub, "bad --speed %g (1..%u dps)", d->speed_dps, UINT16_MAX);
		return RMDCTL_EXIT_USAGE;
	}
	if (d->speed_dps > MOVE_SPEED_CAP_DPS && !d->force) {
		rmdctl_err(
			d->sub,
			"refusing --speed %g dps: bench moves are capped at %g dps (add --force)",
			d->speed_dps, MOVE_SPEED_CAP_DPS);
		return RMDCTL_EXIT_USAGE;
	}
	r = can_confirm(d, "move motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	r = open_bus(d);
	if (r)
		return r;
	/* Where it is, and whether its brake would hold it (V3 §2.12: data[3]). */
	req_init(&q[0], id, 0x92);
	req_init(&q[1], id, 0x9A);
	r = run_reqs(d, q, 2);
	if (r)
		goto out;
	if (report_failed(d, q, 2)) {
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	rec_add_req(&rec, d, &q[0], true);
	rec_add_req(&rec, d, &q[1], true);
	from = val(&rec, RMD_FLD_ANGLE);
	/* V2 §3.31 does not report the brake: release it anyway (0x77 only echoes without one). */
	release = !has(&rec, RMD_FLD_BRAKE) || rec.raw[RMD_FLD_BRAKE] == 0;
	if (has(&rec, RMD_FLD_ERROR) && rec.raw[RMD_FLD_ERROR] && !d->force) {
		char e[128];

		rmdctl_err(d->sub, "%s: motor %u reports errors %s: not moving it (add --force)",
			   d->name, id, errors_text(d, rec.raw[RMD_FLD_ERROR], e, sizeof(e)));
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (fabs(target - from) > MOVE_TRAVEL_CAP_DEG && !d->force) {
		rmdctl_err(d->sub,
			   "refusing to move motor %u by %.2f deg (from %.2f to %.2f): bench "
			   "moves are capped at %g deg (add --force)",
			   id, target - from, from, target, MOVE_TRAVEL_CAP_DEG);
		r = RMDCTL_EXIT_USAGE;
		goto out;
	}
	r = confirm(d, "move motor %u on %s from %.2f to %.2f deg at %g dps%s", id, d->name, from,
		    target, d->speed_dps, release ? " (releases its brake)" : "");
	if (r)
		goto out;
	if (release) {
		/* The sim and braked motors hold the shaft while the brake is locked (V3 §2.26). */
		req_init(&q[0], id, 0x77);
		r = ask(d, &q[0]);
		if (r)
			goto out;
	}
	/* V3 §2.20 / V2 §3.40: absolute position, speed limited. */
	req_init(&q[0], id, 0xA4);
	if (set_native(&q[0].msg, spec, RMD_FLD_MAX_SPEED, d->speed_dps) < 0 ||
	    set_native(&q[0].msg, spec, RMD_FLD_ANGLE, target) < 0) {
		rmdctl_err(d->sub, "cannot encode 0xA4 to %g deg at %g dps", target, d->speed_dps);
		r = RMDCTL_EXIT_USAGE;
		goto out;
	}
	t0 = rmd_now_ns();
	r = ask(d, &q[0]);
	if (r)
		goto out;
	if (d->no_wait) {
		if (d->json) {
			json_begin(d, id);
			printf(",\"from_deg\":%.2f,\"target_deg\":%.2f,\"waited\":false}\n", from,
			       target);
		} else {
			printf("%s: motor %u: moving from %.2f to %.2f deg at %g dps (not waiting)\n",
			       d->name, id, from, target, d->speed_dps);
		}
		goto out;
	}
	r = move_wait(d, id, from, target, &final, &why);
	if (r) {
		/* Make sure nothing keeps moving after we stop watching. */
		stop_motor(d, id);
		rmdctl_err(d->sub, "%s: motor %u: %s at %.2f deg (target %.2f deg)", d->name, id,
			   why, final, target);
		goto out;
	}
	if (d->json) {
		json_begin(d, id);
		printf(",\"from_deg\":%.2f,\"target_deg\":%.2f,\"angle_deg\":%.2f,\"arrived\":true,"
		       "\"elapsed_s\":%.3f}\n",
		       from, target, final, (double)(rmd_now_ns() - t0) / 1e9);
	} else {
		printf("%s: motor %u: at %.2f deg (target %.2f, from %.2f) after %.2f s, holding "
		       "position\n",
		       d->name, id, final, target, from, (double)(rmd_now_ns() - t0) / 1e9);
	}
out:
	close_bus(d);
	return r;
}

/* ---- the table and the command line --------------------------------------------------- */

static const struct dev_cmd dev_cmds[] = {
	{ "scan", "[IDS]", 0, 1, O_JSON, run_scan,
	  "Probes ids 1..32 (or IDS, e.g. 1-8) with 0x9A status, pipelined, then asks\n"
	  "the motors that answered for their model (0xB5) and firmware date (0xB2;\n"
	  "V3 only).  Lists id, model, firmware date, protocol, temperature, voltage,\n"
	  "brake and errors.  Exit 1 when no motor answers.\n" },
	{ "info", "ID", 1, 1, O_JSON, run_info,
	  "Model (0xB5), firmware date (0xB2), runtime (0xB1), acceleration (0x42), PI\n"
	  "gains (0x30; V2 0x30..0x35) and run mode (0x70).  The comm-loss timeout\n"
	  "(0xB3) cannot be read back: the protocol only writes it.\n" },
	{ "status", "ID", 1, 1, O_JSON, run_status,
	  "Temperature, voltage, error flags by name and brake (0x9A), multi-turn\n"
	  "angle (0x92), speed and current (0x9C).\n" },
	{ "monitor", "[IDS]", 0, 1, O_JSON | O_ONCE | O_INTERVAL, run_monitor,
	  "A live table of the status of every motor (IDS, or those that answer a\n"
	  "probe of 1..32), refreshed every 200 ms until Ctrl-C; on a terminal the\n"
	  "screen is cleared each time.  --once prints one table and exits (1 if a\n"
	  "motor did not answer).\n" },
	{ "set-id", "OLD NEW", 2, 2, O_YES | O_FORCE, run_set_id,
	  "Renumbers motor OLD to NEW (0x79, ROM) and checks that NEW answers.  V3\n"
	  "sends 0x79 on 0x300, which every motor on the bus with its CAN-ID filter\n"
	  "off (0x20 index 2) obeys: with other motors answering, set-id refuses\n"
	  "unless --force.  Asks for confirmation.\n" },
	{ "set-zero", "ID", 1, 1, O_YES, run_set_zero,
	  "Makes the current position the zero (0x64, ROM).  It applies after a reset\n"
	  "(`rmdctl reset ID`, 0x76) or a power cycle.  Asks for confirmation.\n" },
	{ "set-timeout", "ID MS", 2, 2, O_YES, run_set_timeout,
	  "Sets the comm-loss protection time (0xB3, ROM; 0 turns it off) and checks\n"
	  "the echo.  V3 only.  Asks for confirmation.\n" },
	{ "accel", "ID [INDEX DPS2]", 1, 3, O_JSON | O_YES | O_FORCE, run_accel,
	  "Reads the acceleration (0x42), or writes one (0x43): V3 by INDEX, 0\n"
	  "position-accel, 1 position-decel, 2 speed-accel, 3 speed-decel (RAM and\n"
	  "ROM: asks for confirmation), DPS2 100..60000 dps/s; V2 `accel ID DPS2`\n"
	  "(RAM).\n" },
	{ "pid", "ID [CURR_KP CURR_KI SPD_KP SPD_KI POS_KP POS_KI]", 1, 7, O_JSON | O_YES | O_ROM,
	  run_pid,
	  "Reads the PI gains of the current, speed and position loops (0x30), or\n"
	  "writes all six: V3 integers 0..255 (units of 1/256 of a model-dependent\n"
	  "maximum) with 0x31 (RAM) or, with --rom, 0x32 (ROM: asks for\n"
	  "confirmation); V2 Q24 reals with 0x36..0x3B / 0x3C..0x41.\n" },
	{ "brake", "ID on|off", 2, 2, O_YES, run_brake,
	  "on (or lock): brake locked (0x78).  off (or release): brake released\n"
	  "(0x77); the load may move the shaft, so it asks for confirmation.\n" },
	{ "stop", "ID", 1, 1, 0, run_stop, "Stops the motor and holds its position (0x81).\n" },
	{ "off", "ID", 1, 1, 0, run_off,
	  "Turns the output off and clears the running mode (0x80); the shaft is then\n"
	  "free (a brake, if any, holds it only when locked).\n" },
	{ "reset", "ID", 1, 1, 0, run_reset,
	  "Resets the motor (0x76) and waits until it answers again.  Multi-turn\n"
	  "position is RAM: it restarts within +-180 deg.  ROM writes (set-zero)\n"
	  "take effect.\n" },
	{ "move", "ID DEG", 2, 2, O_JSON | O_YES | O_SPEED | O_FORCE | O_NOWAIT, run_move,
	  "Moves to the absolute multi-turn angle DEG at --speed (default 30 dps) with\n"
	  "0xA4, releasing the brake first if it is locked, then polls the angle\n"
	  "(0x92) every 20 ms until the motor is within 0.2 deg of DEG and reports\n"
	  "the final angle (--no-wait: return at once).  Refuses speeds above 90 dps,\n"
	  "moves longer than 360 deg and motors reporting errors unless --force.\n"
	  "Ctrl-C, a stall or a timeout stops the motor (0x81).  Asks for\n"
	  "confirmation.\n" },
};
#define NDEV (sizeof(dev_cmds) / sizeof(dev_cmds[0]))

static const struct dev_cmd *find_dev(const char *name)
{
	for (size_t i = 0; i < NDEV; i++)
		if (!strcmp(dev_cmds[i].name, name))
			return &dev_cmds[i];
	return NULL;
}

static void dev_usage(FILE *f, const char *name)
{
	const struct dev_cmd *c = find_dev(name);

	if (!c)
		return;
	fprintf(f, "usage: rmdctl %s [OPTIONS] %s\n\n%s\n", c->name, c->args, c->help);
	fprintf(f, "bus options (every device command):\n"
		   "  --bus SPEC       can0 (SocketCAN interface), /dev/ttyUSB0 (RS485, any path\n"
		   "                   starting with /), sim (simulated motors 1..4 in this\n"
		   "                   process) or sim:1-3,7 (simulated motors 1, 2, 3, 7).\n"
		   "                   Default: $" BUS_ENV ", else " DEFAULT_BUS
		   ".  Simulated motors\n"
		   "                   power on fresh in every rmdctl run: nothing persists.\n"
		   "  --baud N         RS485 bit rate (default 1000000)\n"
		   "  --protocol P     v3 (default) or v2\n"
		   "  --timeout MS     wait per try for each answer (default 5)\n"
		   "  --tries N        sends per request before giving up (default 3)\n"
		   "  --trace          print every frame sent and received on stderr\n");
	if (c->opts) {
		fprintf(f, "%s options:\n", c->name);
		if (c->opts & O_JSON)
			fprintf(f, "  --json           one JSON object per motor and line (keys of "
				   "`rmdctl decode`)\n");
		if (c->opts & O_YES)
			fprintf(f, "  -y, --yes        do not ask for confirmation (needed without "
				   "a terminal)\n");
		if (c->opts & O_ROM)
			fprintf(f, "  --rom            write to ROM (kept at power off)\n");
		if (c->opts & O_SPEED)
			fprintf(f, "  --speed DPS      maximum speed of the move (default 30)\n");
		if (c->opts & O_FORCE)
			fprintf(f, "  --force          skip the safety limits described above\n");
		if (c->opts & O_NOWAIT)
			fprintf(f, "  --no-wait        do not wait for the motor to arrive\n");
		if (c->opts & O_ONCE)
			fprintf(f, "  --once           print one table and exit\n");
		if (c->opts & O_INTERVAL)
			fprintf(f, "  --interval MS    refresh period (default 200)\n");
	}
	fprintf(f, "\nexit status: 0 ok; 1 the bus or a motor failed (each failure names the\n"
		   "bus, the motor and the command), or confirmation was declined; 2 usage\n"
		   "error, or a confirmation that could not be asked (no terminal, no --yes)\n"
		   "or a safety limit.\n");
}

void rmdctl_scan_usage(FILE *f)
{
	dev_usage(f, "scan");
}

void rmdctl_info_usage(FILE *f)
{
	dev_usage(f, "info");
}

void rmdctl_status_usage(FILE *f)
{
	dev_usage(f, "status");
}

void rmdctl_monitor_usage(FILE *f)
{
	dev_usage(f, "monitor");
}

void rmdctl_set_id_usage(FILE *f)
{
	dev_usage(f, "set-id");
}

void rmdctl_set_zero_usage(FILE *f)
{
	dev_usage(f, "set-zero");
}

void rmdctl_set_timeout_usage(FILE *f)
{
	dev_usage(f, "set-timeout");
}

void rmdctl_accel_usage(FILE *f)
{
	dev_usage(f, "accel");
}

void rmdctl_pid_usage(FILE *f)
{
	dev_usage(f, "pid");
}

void rmdctl_brake_usage(FILE *f)
{
	dev_usage(f, "brake");
}

void rmdctl_stop_usage(FILE *f)
{
	dev_usage(f, "stop");
}

void rmdctl_off_usage(FILE *f)
{
	dev_usage(f, "off");
}

void rmdctl_reset_usage(FILE *f)
{
	dev_usage(f, "reset");
}

void rmdctl_move_usage(FILE *f)
{
	dev_usage(f, "move");
}

/* Options: name, short letter (0: none), takes a value, O_* flag (0: every command). */
static const struct {
	const char *name;
	char shortc;
	bool arg;
	unsigned flag;
} optdefs[] = {
	{ "bus", 'b', true, 0 },
	{ "baud", 0, true, 0 },
	{ "protocol", 'p', true, 0 },
	{ "timeout", 0, true, 0 },
	{ "tries", 0, true, 0 },
	{ "trace", 0, false, 0 },
	{ "help", 'h', false, 0 },
	{ "json", 'j', false, O_JSON },
	{ "yes", 'y', false, O_YES },
	{ "rom", 0, false, O_ROM },
	{ "speed", 0, true, O_SPEED },
	{ "force", 0, false, O_FORCE },
	{ "no-wait", 0, false, O_NOWAIT },
	{ "once", 0, false, O_ONCE },
	{ "interval", 0, true, O_INTERVAL },
};
#define NOPTS (sizeof(optdefs) / sizeof(optdefs[0]))

/* A negative number ("-10", "-.5") is an argument, not an option. */
static bool is_number(const char *s)
{
	return s[0] == '-' &&
	       ((s[1] >= '0' && s[1] <= '9') || (s[1] == '.' && s[2] >= '0' && s[2] <= '9'));
}

/* Apply option k with value v.  Returns 0, 1 (--help printed) or -EINVAL (reported). */
static int set_option(struct dev *d, size_t k, const char *v)
{
	const char *name = optdefs[k].name;
	uint64_t u;
	double x;

	if (!strcmp(name, "bus")) {
		d->bus_spec = v;
	} else if (!strcmp(name, "baud")) {
		if (parse_uint(v, 1, UINT32_MAX, &u) < 0)
			goto bad;
		d->baud = (uint32_t)u;
	} else if (!strcmp(name, "protocol")) {
		if (rmdctl_parse_proto(v, &d->proto) < 0 || d->proto == RMD_PROTO_MIT) {
			rmdctl_err(d->sub, "bad --protocol \"%s\" (v3 or v2; MIT motors answer v3)",
				   v);
			return -EINVAL;
		}
	} else if (!strcmp(name, "timeout")) {
		if (rmdctl_parse_double(v, &x) < 0 || x < 0.1 || x > 60000)
			goto bad;
		d->timeout_ms = x;
	} else if (!strcmp(name, "tries")) {
		if (parse_uint(v, 1, 100, &u) < 0)
			goto bad;
		d->tries = (unsigned)u;
	} else if (!strcmp(name, "trace")) {
		d->trace = true;
	} else if (!strcmp(name, "help")) {
		dev_usage(stdout, d->cmd->name);
		return 1;
	} else if (!strcmp(name, "json")) {
		d->json = true;
	} else if (!strcmp(name, "yes")) {
		d->yes = true;
	} else if (!strcmp(name, "rom")) {
		d->rom = true;
	} else if (!strcmp(name, "speed")) {
		if (rmdctl_parse_double(v, &x) < 0)
			goto bad;
		d->speed_dps = x;
	} else if (!strcmp(name, "force")) {
		d->force = true;
	} else if (!strcmp(name, "no-wait")) {
		d->no_wait = true;
	} else if (!strcmp(name, "once")) {
		d->once = true;
	} else if (!strcmp(name, "interval")) {
		if (rmdctl_parse_double(v, &x) < 0 || x < 10 || x > 3600000)
			goto bad;
		d->interval_ms = x;
	}
	return 0;
bad:
	rmdctl_err(d->sub, "bad --%s \"%s\"", name, v);
	return -EINVAL;
}

/* Options anywhere, arguments in order.  Returns argument count, -1 usage, -2 help shown. */
static int parse_args(struct dev *d, int argc, char **argv, char **pos)
{
	int npos = 0;
	bool only_args = false;

	for (int i = 1; i < argc; i++) {
		const char *a = argv[i], *v = NULL, *eq;
		size_t k, len;
		int r;

		if (only_args || a[0] != '-' || a[1] == '\0' || is_number(a)) {
			pos[npos++] = argv[i];
			continue;
		}
		if (!strcmp(a, "--")) {
			only_args = true;
			continue;
		}
		if (a[1] == '-') {
			eq = strchr(a + 2, '=');
			len = eq ? (size_t)(eq - a - 2) : strlen(a + 2);
			for (k = 0; k < NOPTS; k++)
				if (strlen(optdefs[k].name) == len &&
				    !strncmp(optdefs[k].name, a + 2, len))
					break;
			if (eq)
				v = eq + 1;
		} else {
			for (k = 0; k < NOPTS; k++)
				if (optdefs[k].shortc && optdefs[k].shortc == a[1] && !a[2])
					break;
		}
		if (k == NOPTS) {
			rmdctl_err(d->sub, "unknown option \"%s\"", a);
			return -1;
		}
		if (optdefs[k].flag && !(d->cmd->opts & optdefs[k].flag)) {
			rmdctl_err(d->sub, "option --%s does not apply to %s", optdefs[k].name,
				   d->cmd->name);
			return -1;
		}
		if (optdefs[k].arg && !v) {
			if (i + 1 >= argc) {
				rmdctl_err(d->sub, "option \"%s\" needs a value", a);
				return -1;
			}
			v = argv[++i];
		} else if (!optdefs[k].arg && v) {
			rmdctl_err(d->sub, "option --%s takes no value", optdefs[k].name);
			return -1;
		}
		r = set_option(d, k, v);
		if (r < 0)
			return -1;
		if (r > 0)
			return -2;
	}
	return npos;
}

int rmdctl_dev_run(int argc, char **argv)
{
	struct sigaction sa;
	struct dev d;
	char **pos;
	int npos, r;

	memset(&d, 0, sizeof(d));
	d.cmd = find_dev(argv[0]);
	if (!d.cmd) {
		rmdctl_err(argv[0], "not a device command");
		return RMDCTL_EXIT_USAGE;
	}
	d.sub = d.cmd->name;
	d.bus_spec = getenv(BUS_ENV) && *getenv(BUS_ENV) ? getenv(BUS_ENV) : DEFAULT_BUS;
	d.proto = RMD_PROTO_V3;
	d.timeout_ms = RMD_TXN_TIMEOUT_NS / 1e6;
	d.tries = RMD_TXN_TRIES;
	d.speed_dps = MOVE_SPEED_DPS;
	d.interval_ms = MONITOR_INTERVAL_MS;
	d.t0_ns = rmd_now_ns();

	pos = calloc((size_t)argc + 1, sizeof(*pos));
	if (!pos) {
		rmdctl_err(d.sub, "out of memory");
		return RMDCTL_EXIT_DATA;
	}
	npos = parse_args(&d, argc, argv, pos);
	if (npos == -2) {
		free(pos);
		return RMDCTL_EXIT_OK;
	}
	if (npos >= 0 && ((unsigned)npos < d.cmd->min_args || (unsigned)npos > d.cmd->max_args)) {
		rmdctl_err(d.sub, "%s arguments: %s",
			   (unsigned)npos < d.cmd->min_args ? "missing" : "too many", d.cmd->args);
		npos = -1;
	}
	if (npos < 0) {
		free(pos);
		dev_usage(stderr, d.cmd->name);
		return RMDCTL_EXIT_USAGE;
	}

	/* Ctrl-C ends waits early, so move can stop the motor and monitor can exit cleanly. */
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);

	setvbuf(stdout, NULL, _IOLBF, 0);
	r = d.cmd->run(&d, npos, pos);
	free(pos);
	if (fflush(stdout) != 0 || ferror(stdout)) {
		rmdctl_err(d.sub, "write error: %s", strerror(errno));
		r = RMDCTL_EXIT_DATA;
	}
	return r;
}
