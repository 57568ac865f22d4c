// SPDX-License-Identifier: MIT
/*
 * rmdctl's device commands, what they share: the command line (bus options
 * and each command's own), opening the bus, --trace, confirmation prompts
 * and transactions.  The commands are read.c (scan, info, status, monitor),
 * settings.c (set-id, set-zero, set-timeout, accel, pid) and motion.c
 * (brake, stop, off, reset, move); output.c prints what they gathered.
 *
 * Every exchange is a transaction of rmd/txn.h: requests are pipelined,
 * each answer is matched by reply identifier and command byte, and a
 * silent motor fails after --tries sends of --timeout each, with a message
 * that names the bus, the motor and the command.  Without --timeout the
 * wait is measured before the first exchange (measure_wait()), so that a
 * motor behind a slow adapter is found and a write goes out once.  Whatever writes ROM or
 * may move a motor asks on the terminal first, unless --yes; with no
 * terminal and no --yes it refuses (exit 2).  Non-rt.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
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
#include "rmd/describe.h"
#include "rmd/personality_load.h"
#include "rmd/sim_params.h"
#include "rmd/txn.h"
#include "rmdctl.h"
#include "tools/common/buslock.h"

#define DEFAULT_BUS "can0"
#define BUS_ENV "RMDCTL_BUS"
#define ERRLEN 256

volatile sig_atomic_t rmdctl_interrupted;

static void on_signal(int sig)
{
	(void)sig;
	rmdctl_interrupted = 1;
}

/* ---- small helpers -------------------------------------------------------------------- */

/* CLOCK_REALTIME in ns: --trace stamps frames with wall-clock time, as candump -l does. */
static int64_t wall_now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_REALTIME, &ts);
	return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

const struct rmd_cmd_spec *rmdctl_spec(const struct dev *d, uint8_t cmd)
{
	return rmd_cmd_find(d->proto, cmd);
}

/* "5", "0.5": a number of ms for messages. */
const char *rmdctl_ms_str(char *buf, size_t size, double ms)
{
	rmd_fmt_real(buf, size, ms, 6);
	return buf;
}

/* A whole-string unsigned integer in [lo, hi].  Returns 0 or -EINVAL. */
int rmdctl_parse_uint(const char *s, uint64_t lo, uint64_t hi, uint64_t *v)
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

int rmdctl_parse_id(const char *s, const char *what, uint8_t *id)
{
	uint64_t v;

	if (rmdctl_parse_uint(s, 1, RMD_MAX_MOTORS, &v) < 0) {
		tool_log(TOOL_LOG_ERR, "bad %s \"%s\" (a motor id 1..%d)", what, s, RMD_MAX_MOTORS);
		return -EINVAL;
	}
	*id = (uint8_t)v;
	return 0;
}

void rmdctl_sleep_until(int64_t t_ns)
{
	struct timespec ts = { .tv_sec = t_ns / 1000000000, .tv_nsec = t_ns % 1000000000 };

	/* EINTR (Ctrl-C) ends the sleep; the caller looks at `rmdctl_interrupted`. */
	clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
}

unsigned rmdctl_all_ids(uint8_t *ids)
{
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++)
		ids[i] = (uint8_t)(i + 1);
	return RMD_MAX_MOTORS;
}

/* ---- confirmation --------------------------------------------------------------------- */

/*
 * Ask "QUESTION? [y/N]" on the terminal, unless --yes.  Returns 0 (go
 * ahead), RMDCTL_EXIT_USAGE (no terminal) or RMDCTL_EXIT_DATA (declined).
 */
__attribute__((format(printf, 2, 3))) int rmdctl_confirm(struct dev *d, const char *fmt, ...)
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
		tool_log(TOOL_LOG_ERR,
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
	tool_log(TOOL_LOG_ERR, "not confirmed: nothing changed");
	return RMDCTL_EXIT_DATA;
}

/* ---- --trace: a bus that prints every frame, then hands it on --------------------------- */

/* The interface column of a trace line: at most 15 characters, no '/' (a tty's basename). */
static const char *trace_iface(const struct dev *d, char *buf, size_t size)
{
	const char *slash = strrchr(d->name, '/');

	snprintf(buf, size, "%.15s", slash ? slash + 1 : d->name);
	return buf;
}

/*
 * --trace: "(1732415033.123456) can0 141#9A00000000000000", exactly a
 * `candump -l` line (wall-clock time), then "# TX read_status_1 ...", a
 * comment canplayer and `rmdctl decode` skip.  One write per frame.
 */
static void trace_frame(struct dev *d, const char *dir, const struct rmd_frame *f, int64_t t_ns)
{
	int64_t wall = d->t0_wall_ns + (t_ns - d->t0_ns);
	char desc[512], iface[16], line[sizeof(desc) + 96];
	int n;

	n = snprintf(line, sizeof(line), "(%010" PRId64 ".%06" PRId64 ") %s %03" PRIX32 "#",
		     wall / 1000000000, (wall % 1000000000) / 1000,
		     trace_iface(d, iface, sizeof(iface)), f->can_id);
	for (unsigned i = 0; i < f->len && i < RMD_FRAME_LEN; i++)
		n += snprintf(line + n, sizeof(line) - (size_t)n, "%02X", f->data[i]);
	/* characterize's log: the `candump -l` line alone */
	if (d->log)
		fprintf(d->log, "%s\n", line);
	if (!d->trace)
		return;
	rmd_describe_frame(desc, sizeof(desc), d->proto,
			   dir[0] == 'T' ? RMD_DIR_REQUEST : RMD_DIR_REPLY, NULL, f);
	snprintf(line + n, sizeof(line) - (size_t)n, "\n# %s %s\n", dir, desc);
	fputs(line, stderr);
}

static int trace_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		      int64_t now_ns)
{
	int r = rmd_bus_wrap_send(bus, frames, n, now_ns);
	const struct rmd_bus_wrap *w = bus->priv;

	for (int i = 0; i < r; i++)
		trace_frame(w->ctx, "TX", &frames[i], now_ns);
	return r;
}

static int trace_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	int r = rmd_bus_wrap_recv(bus, out, max, now_ns);
	const struct rmd_bus_wrap *w = bus->priv;

	for (int i = 0; i < r; i++)
		trace_frame(w->ctx, "RX", &out[i].f, out[i].t_ns);
	return r;
}

static const struct rmd_bus_ops trace_ops = RMD_BUS_WRAP_OPS("trace", trace_send, trace_recv);

/* ---- the bus -------------------------------------------------------------------------- */

/*
 * A bus a running rmdd drives (its lock, tools/common/buslock.h) is not
 * rmdctl's to talk on: requests and answers would cross rmdd's, and a
 * write would change a motor under it.  Refused unless --force.  Checked
 * on the open bus, before anything is sent; buses without a descriptor
 * (sim) live in this process.
 */
static int check_owner(struct dev *d)
{
	char key[256], path[TOOL_BUSLOCK_PATH_LEN];
	pid_t pid;

	if (d->force || rmd_bus_fd(&d->bus) < 0 ||
	    tool_buslock_key(key, sizeof(key), d->bus_spec) < 0 ||
	    !tool_buslock_held(key, path, sizeof(path), &pid))
		return 0;
	tool_log(TOOL_LOG_ERR,
		 "%s is in use by a running rmdd (pid %ld, lock %s): its traffic and rmdctl's "
		 "would mix.  Watch it with `rmdctl top`, stop it (systemctl stop rmdd), or add "
		 "--force",
		 d->bus_spec, (long)pid, path);
	return RMDCTL_EXIT_USAGE;
}

/*
 * The simulated motors' model: the defaults of --protocol with each --sim
 * KEY=VALUE applied in order (rmd/sim_params.h, the table rmdd.yaml and
 * rmd-sim read).  Returns 0 or RMDCTL_EXIT_USAGE (reported).
 */
static int sim_model(struct dev *d, struct rmd_sim_motor_params *p)
{
	rmd_sim_motor_params_default(p, 1, d->proto);
	for (unsigned i = 0; i < d->n_sim; i++) {
		const char *kv = d->sim_kv[i], *eq = strchr(kv, '=');
		const struct rmd_sim_param *spec;
		char key[64], allowed[128];

		if (!eq || eq == kv || (size_t)(eq - kv) >= sizeof(key)) {
			tool_log(TOOL_LOG_ERR,
				 "bad --sim \"%s\" (KEY=VALUE, e.g. turnaround_us=20000)", kv);
			return RMDCTL_EXIT_USAGE;
		}
		snprintf(key, sizeof(key), "%.*s", (int)(eq - kv), kv);
		spec = rmd_sim_param_find(key);
		/* protocol and mit are the motor's own: --protocol and the firmware say them */
		if (!spec || spec->flags & RMD_SIM_PARAM_MOTOR_KEY) {
			tool_log(TOOL_LOG_ERR,
				 "--sim: unknown simulator parameter \"%s\" (docs/rmd-sim.md)",
				 key);
			return RMDCTL_EXIT_USAGE;
		}
		/* personality=FILE: a file rmdctl characterize wrote, or a built-in name */
		if (rmd_sim_param_parse_file(p, spec, eq + 1, allowed, sizeof(allowed)) < 0) {
			tool_log(TOOL_LOG_ERR, "--sim %s \"%s\": expected %s", key, eq + 1,
				 allowed);
			return RMDCTL_EXIT_USAGE;
		}
	}
	return 0;
}

int rmdctl_open_bus(struct dev *d)
{
	struct rmd_sim_motor_params sim;
	struct rmd_bus_open_opts o = {
		.proto = d->proto,
		.set_id_replies = true, /* set-id reads 0x79 answers on 0x300 */
		.baud = d->baud,
	};
	char err[ERRLEN];
	int r;

	if (d->n_sim && !rmd_bus_open_is_sim(d->bus_spec))
		tool_log(TOOL_LOG_WARNING, "--sim: %s is no simulated bus: ignored", d->bus_spec);
	else if (d->n_sim) {
		r = sim_model(d, &sim);
		if (r)
			return r;
		o.sim_motor = &sim;
	}
	/*
	 * An RS485 line holds the next request until the answer or the
	 * transport's own timeout (its default: a motor's 2 ms); rtt waits
	 * for slow converters, and the line must wait as long, lest requests
	 * go out while a motor answers.
	 */
	if (d->line_timeout)
		o.reply_timeout_ns = (int64_t)llround(d->timeout_ms * 1e6);
	r = rmd_bus_open_spec(&d->bus, d->bus_spec, &o, err, sizeof(err));
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "%s", err[0] ? err : strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	r = check_owner(d);
	if (r) {
		rmd_bus_close(&d->bus);
		return r;
	}
	if (err[0])
		tool_log(TOOL_LOG_ERR, "note: %s", err);
	snprintf(d->name, sizeof(d->name), "%s", d->bus.name);
	d->b = &d->bus;
	/*
	 * No --timeout: the wait is measured before the first exchange
	 * (measure_wait()), unless the command waits its own (rtt:
	 * line_timeout) or the transport has a reply timeout of its own
	 * (RS485: the line waits that long for every answer).
	 */
	if (!d->wait_known)
		d->wait_auto = !d->timeout_set && !d->line_timeout &&
			       !rmd_bus_caps(&d->bus)->reply_timeout_ns;
	d->txn.timeout_ns = (int64_t)llround(d->timeout_ms * 1e6);
	d->txn.tries = d->tries;
	d->txn.stop = &rmdctl_interrupted;
	/* Half duplex RS485 queues requests behind each other's answers. */
	d->txn.spacing_ns = rmd_bus_caps(&d->bus)->request_spacing_ns;
	if (d->trace || d->log) {
		d->twrap = (struct rmd_bus_wrap){ .inner = &d->bus, .ctx = d };
		rmd_bus_wrap_init(&d->tbus, &trace_ops, &d->twrap);
		d->b = &d->tbus;
	}
	return 0;
}

int rmdctl_open_bus_for(struct dev *d, bool confirm, const char *fmt, ...)
{
	char what[256];
	va_list ap;

	/* Before anything is sent: without --yes a terminal must be there to ask. */
	if (confirm && !d->yes && !isatty(STDIN_FILENO)) {
		va_start(ap, fmt);
		vsnprintf(what, sizeof(what), fmt, ap);
		va_end(ap);
		tool_log(TOOL_LOG_ERR,
			 "refusing to %s without confirmation: stdin is not a terminal (add --yes)",
			 what);
		return RMDCTL_EXIT_USAGE;
	}
	return rmdctl_open_bus(d);
}

void rmdctl_close_bus(struct dev *d)
{
	if (d->b == &d->tbus)
		rmd_bus_close(&d->tbus);
	rmd_bus_close(&d->bus);
	d->b = NULL;
}

/* ---- transactions --------------------------------------------------------------------- */

void rmdctl_req_init(struct req *q, uint8_t id, uint8_t cmd)
{
	memset(q, 0, sizeof(*q));
	q->id = id;
	q->msg.cmd = cmd;
}

/*
 * "motor 3 did not answer 0x9A within 5 ms (3 tries)" + more, or why it was
 * not sent, or that the motor only echoed it (rmd/txn.h: the echo of a
 * tripped comm-loss protection is not taken as the answer).
 */
void rmdctl_report_missing(struct dev *d, const struct req *q, const char *more)
{
	char ms[32], first[64] = "";

	if (q->t.echo_seen) {
		tool_log(TOOL_LOG_ERR,
			 "%s: motor %u only echoed 0x%02X (%u %s): it repeated the request, as a "
			 "motor whose comm-loss protection (0xB3) tripped does instead of "
			 "answering; not taken as the answer",
			 d->name, q->id, q->msg.cmd, q->t.tries, q->t.tries == 1 ? "try" : "tries");
		return;
	}
	if (q->t.tries == 0) {
		tool_log(TOOL_LOG_ERR,
			 "%s: could not send 0x%02X to motor %u: the bus took no frame (%s)",
			 d->name, q->msg.cmd, q->id, rmd_bus_state_name(rmd_bus_state(d->b)));
		return;
	}
	/* the wait was measured: its 0x9A waited longer, and said so */
	if (q->probed)
		snprintf(first, sizeof(first), ", the first %d ms", RMDCTL_WAIT_PROBE_MS);
	else if (d->wait_auto && d->wait_known && !d->wait_rtt_ns)
		snprintf(first, sizeof(first), "; nor 0x9A in %d ms before", RMDCTL_WAIT_PROBE_MS);
	tool_log(TOOL_LOG_ERR, "%s: motor %u did not answer 0x%02X within %s ms (%u %s%s)%s",
		 d->name, q->id, q->msg.cmd, rmdctl_ms_str(ms, sizeof(ms), d->timeout_ms),
		 q->t.tries, q->t.tries == 1 ? "try" : "tries", first, more);
}

static void report_bad(struct dev *d, const struct req *q)
{
	const struct rmd_frame *f = &q->t.rep.f;
	char hex[3 * RMD_FRAME_LEN + 1] = "";

	for (unsigned i = 0; i < f->len && i < RMD_FRAME_LEN; i++)
		snprintf(hex + 2 * i, sizeof(hex) - 2 * i, "%02X", f->data[i]);
	tool_log(TOOL_LOG_ERR, "%s: motor %u answered 0x%02X with %03" PRIX32 "#%s, which %s",
		 d->name, q->id, q->msg.cmd, f->can_id, hex,
		 rmdctl_spec(d, q->msg.cmd) && rmdctl_spec(d, q->msg.cmd)->flags & RMD_CMD_ECHO ?
			 "is not the echo of the request" :
			 "does not decode");
}

int rmdctl_txn_prepare(struct rmd_txn *t, const struct dev *d, uint8_t id, const struct rmd_msg *m)
{
	int r = rmd_txn_prepare(t, d->proto, id, m);

	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "motor %u: cannot encode 0x%02X: %s", id, m->cmd,
			 strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	return 0;
}

int rmdctl_txn_run(struct dev *d, struct rmd_txn *t, unsigned n, const struct rmd_txn_opts *o)
{
	int r = rmd_txn_run(d->b, t, n, o);

	if (r == -EINTR) {
		tool_log(TOOL_LOG_ERR, "interrupted");
		return RMDCTL_EXIT_DATA;
	}
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "%s: %s", d->name, strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	return 0;
}

/* rmdctl_run_reqs() with opts o. */
static int run_batch(struct dev *d, struct req *q, unsigned n, const struct rmd_txn_opts *o)
{
	struct rmd_txn t[MAX_REQS];
	int r;

	if (n > MAX_REQS)
		n = MAX_REQS;
	for (unsigned i = 0; i < n; i++) {
		r = rmdctl_txn_prepare(&t[i], d, q[i].id, &q[i].msg);
		if (r)
			return r;
	}
	r = rmdctl_txn_run(d, t, n, o);
	if (r)
		return r;
	for (unsigned i = 0; i < n; i++) {
		const struct rmd_cmd_spec *spec = rmdctl_spec(d, q[i].msg.cmd);
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

/*
 * No --timeout (d->wait_auto): the wait per try, measured.  One 0x9A to
 * each of ids[0..n) (st[] gets the results), one try that waits up to
 * RMDCTL_WAIT_PROBE_MS; then the wait per try is RMDCTL_WAIT_RTTS times
 * the slowest round trip heard (an echo counts: rmd/txn.h heard_ns) plus
 * RMDCTL_WAIT_SLACK_MS, at least the default and at most
 * RMDCTL_WAIT_PROBE_MS, said on stderr when it is longer than the default.
 * Nothing heard: the default stays.  Returns 0 or RMDCTL_EXIT_DATA.
 */
/* The wait per try for answers that took rtt_ns: RMDCTL_WAIT_RTTS of them and the slack, bounded. */
static int64_t wait_of(int64_t rtt_ns)
{
	int64_t wait = RMDCTL_WAIT_RTTS * rtt_ns + (int64_t)RMDCTL_WAIT_SLACK_MS * 1000000;

	return wait < (int64_t)RMDCTL_WAIT_PROBE_MS * 1000000 ?
		       wait :
		       (int64_t)RMDCTL_WAIT_PROBE_MS * 1000000;
}

static int measure_wait(struct dev *d, const uint8_t *ids, unsigned n, struct req *st)
{
	struct rmd_txn_opts o = d->txn;
	int64_t worst = 0, wait;
	uint8_t worst_id = 0;
	char ms[2][32];
	int r;

	o.tries = 1;
	o.timeout_ns = (int64_t)RMDCTL_WAIT_PROBE_MS * 1000000;
	for (unsigned i = 0; i < n; i++) {
		rmdctl_req_init(&st[i], ids[i], 0x9A); /* V3 §2.12, V2 §3.31, V4.2 §2.13 */
		st[i].probed = true;
	}
	r = run_batch(d, st, n, &o);
	if (r)
		return r;
	d->wait_known = true;
	for (unsigned i = 0; i < n; i++) {
		int64_t rtt = st[i].t.heard_ns - st[i].t.first_sent_ns;

		if (st[i].t.heard && rtt > worst) {
			worst = rtt;
			worst_id = ids[i];
		}
	}
	/*
	 * In a batch the answers wait for the wire to carry every request
	 * (theirs lose the arbitration, V3 §1.1): a round trip of the slowest
	 * motor alone says what the motor and the adapter add.
	 */
	if (n > 1 && worst && wait_of(worst) > d->txn.timeout_ns) {
		struct req lone;

		rmdctl_req_init(&lone, worst_id, 0x9A);
		r = run_batch(d, &lone, 1, &o);
		if (r)
			return r;
		if (lone.t.heard)
			worst = lone.t.heard_ns - lone.t.first_sent_ns;
	}
	d->wait_rtt_ns = worst;
	d->wait_rtt_id = worst_id;
	if (!worst)
		return 0;
	wait = wait_of(worst);
	if (wait <= d->txn.timeout_ns)
		return 0;
	d->txn.timeout_ns = wait;
	d->timeout_ms = (double)wait / 1e6;
	tool_log(TOOL_LOG_NOTICE,
		 "%s: motor %u answered 0x9A after %s ms (a slow adapter or converter?): waiting "
		 "%s ms per try (--timeout sets it)",
		 d->name, worst_id, rmdctl_ms_str(ms[0], sizeof(ms[0]), round(worst / 1e4) / 100),
		 rmdctl_ms_str(ms[1], sizeof(ms[1]), round(d->timeout_ms * 10) / 10));
	return 0;
}

/* Before the first exchange of a run without --timeout: measure_wait() on q's motors. */
static int need_wait(struct dev *d, const struct req *q, unsigned n)
{
	uint8_t ids[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS];
	uint64_t seen = 0;
	unsigned k = 0;

	if (!d->wait_auto || d->wait_known)
		return 0;
	for (unsigned i = 0; i < n && k < RMD_MAX_MOTORS; i++) {
		if (q[i].id < 1 || q[i].id > RMD_MAX_MOTORS || seen & (1ull << q[i].id))
			continue;
		seen |= 1ull << q[i].id;
		ids[k++] = q[i].id;
	}
	return k ? measure_wait(d, ids, k, st) : 0;
}

/*
 * Run q[0..n) as one pipelined batch.  Returns 0 when the bus worked
 * (each q[i].ok says whether its motor answered), RMDCTL_EXIT_DATA on a
 * bus error or Ctrl-C (message printed).
 */
int rmdctl_run_reqs(struct dev *d, struct req *q, unsigned n)
{
	int r = need_wait(d, q, n);

	return r ? r : run_batch(d, q, n, &d->txn);
}

int rmdctl_exchange(struct dev *d, struct req *q, unsigned n)
{
	int r = rmdctl_open_bus(d);

	if (r)
		return r;
	r = rmdctl_run_reqs(d, q, n);
	rmdctl_close_bus(d);
	return r;
}

/* The answer rmdctl_run_reqs() got for one request; reports failure.  Returns 0 or RMDCTL_EXIT_DATA. */
int rmdctl_ask_check(struct dev *d, struct req *q)
{
	if (!q->answered && !q->ok) {
		rmdctl_report_missing(d, q, "");
		return RMDCTL_EXIT_DATA;
	}
	if (!q->ok) {
		report_bad(d, q);
		return RMDCTL_EXIT_DATA;
	}
	return 0;
}

/* One request; reports failure.  Returns 0 or RMDCTL_EXIT_DATA. */
int rmdctl_ask(struct dev *d, struct req *q)
{
	int r = rmdctl_run_reqs(d, q, 1);

	return r ? r : rmdctl_ask_check(d, q);
}

/* q got no frame at all (not even its echo). */
static bool silent(const struct req *q)
{
	return !q->answered && !q->ok && !q->t.echo_seen;
}

/*
 * Every failed request of a batch, reported; a motor that answered none of
 * its requests gets one line.  Returns how many requests failed.
 */
unsigned rmdctl_report_failed(struct dev *d, const struct req *q, unsigned n)
{
	unsigned bad = 0;

	for (unsigned i = 0; i < n; i++) {
		bool told = false;
		char more[128] =
			""; /* ", nor 0x.." for the others of a batch to the motor (12 at most) */
		size_t o = 0;

		if (q[i].ok)
			continue;
		bad++;
		if (q[i].answered) {
			report_bad(d, &q[i]);
			continue;
		}
		for (unsigned j = 0; j < i; j++)
			told |= q[j].id == q[i].id && silent(&q[j]);
		if (told && silent(&q[i]))
			continue;
		for (unsigned j = i + 1; j < n && o < sizeof(more) && silent(&q[i]); j++)
			if (q[j].id == q[i].id && silent(&q[j]))
				o += (size_t)snprintf(more + o, sizeof(more) - o, "%s0x%02X",
						      o ? ", " : ", nor ", q[j].msg.cmd);
		rmdctl_report_missing(d, &q[i], more);
	}
	return bad;
}

/*
 * rmdctl_probe()'s 0x9A as measure_wait() sends it, then the ids that did
 * not answer it again, the tries left at the wait it measured; st[] gets
 * the last result of each id, its tries counting the first.
 */
static int probe_measured(struct dev *d, const uint8_t *ids, unsigned n, struct req *st)
{
	struct req again[RMD_MAX_MOTORS];
	unsigned idx[RMD_MAX_MOTORS], k = 0;
	struct rmd_txn_opts o = d->txn;
	int r = measure_wait(d, ids, n, st);

	if (r || d->tries < 2)
		return r;
	o.tries = d->tries - 1;
	for (unsigned i = 0; i < n && k < RMD_MAX_MOTORS; i++) {
		if (st[i].ok)
			continue;
		idx[k] = i;
		rmdctl_req_init(&again[k++], ids[i], 0x9A);
	}
	if (!k)
		return 0;
	r = run_batch(d, again, k, &o);
	if (r)
		return r;
	for (unsigned j = 0; j < k; j++) {
		struct req *q = &st[idx[j]];
		unsigned tries = q->t.tries + again[j].t.tries;

		*q = again[j];
		q->t.tries = tries;
		q->probed = true;
	}
	return 0;
}

/* Probe ids[0..n) with 0x9A; found[] gets those that answered (one that only echoed is reported).  Returns the count or -exit. */
int rmdctl_probe(struct dev *d, const uint8_t *ids, unsigned n, uint8_t *found, struct req *st)
{
	int r, m = 0;

	if (d->wait_auto && !d->wait_known) {
		/* the 0x9A that measures the wait is the probe's first try */
		r = probe_measured(d, ids, n, st);
		if (r)
			return -r;
	} else {
		for (unsigned i = 0; i < n; i++)
			rmdctl_req_init(&st[i], ids[i], 0x9A);
		r = rmdctl_run_reqs(d, st, n);
		if (r)
			return -r;
	}
	for (unsigned i = 0; i < n; i++) {
		if (st[i].ok)
			found[m++] = ids[i];
		else if (st[i].t.echo_seen) /* there, but tripped: say so */
			rmdctl_report_missing(d, &st[i], "");
	}
	return m;
}

int rmdctl_ids_open(struct dev *d, int argc, char **argv, uint8_t *ids)
{
	int n = argc ? rmd_bus_open_parse_ids(argv[0], ids) : (int)rmdctl_all_ids(ids);
	int r;

	if (n < 0) {
		tool_log(TOOL_LOG_ERR, "bad motor list \"%s\" (ids 1..%d, e.g. 1-3,7)", argv[0],
			 RMD_MAX_MOTORS);
		return -RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_open_bus(d);
	return r ? -r : n;
}

int rmdctl_ids_probe(struct dev *d, int argc, char **argv, uint8_t *found, struct req *st,
		     const char *none)
{
	uint8_t ids[RMD_MAX_MOTORS];
	int m = rmdctl_ids_open(d, argc, argv, ids);

	if (m < 0)
		return m;
	m = rmdctl_probe(d, ids, (unsigned)m, found, st);

	if (m > 0)
		return m;
	if (m == 0)
		tool_log(TOOL_LOG_ERR, "%s: no motor answered 0x9A%s", d->name, none);
	rmdctl_close_bus(d);
	return m < 0 ? m : -RMDCTL_EXIT_DATA;
}

/* ---- the command line ----------------------------------------------------------------- */

/*
 * The options of the device commands: those with flag 0 every command
 * has, the others the commands whose opts share a bit with their flag.
 * The same rows make getopt-like parsing (parse_args), --help and the bash
 * completion.
 */
const struct tool_opt rmdctl_dev_opts[] = {
	{ .name = "bus",
	  .shortc = 'b',
	  .has_arg = required_argument,
	  .arg = "SPEC",
	  .help = "can0 (SocketCAN interface), /dev/ttyUSB0 (RS485,\n"
		  "any path starting with /), sim (simulated motors\n"
		  "1..4 in this process) or sim:1-3,7 (simulated\n"
		  "motors 1, 2, 3, 7).  Default: $" BUS_ENV ", else\n" DEFAULT_BUS
		  ".  Simulated motors power on fresh in every\n"
		  "rmdctl run: nothing persists.",
	  .value = TOOL_VAL_BUS },
	{ .name = "baud",
	  .has_arg = required_argument,
	  .arg = "N",
	  .help = "RS485 bit rate (default 1000000)",
	  .value = TOOL_VAL_WORDS,
	  .words = "115200 500000 1000000 1500000 2000000" },
	{ .name = "protocol",
	  .shortc = 'p',
	  .has_arg = required_argument,
	  .arg = "P",
	  .help = "", /* the firmware keys (rmdctl_dev_usage()) */
	  .value = TOOL_VAL_FIRMWARE },
	TOOL_OPT_ARG("timeout", "MS",
		     "wait per try for each answer.  Default: measured;\n"
		     "the first 0x9A of a run waits up to 100 ms, then\n"
		     "each try twice the slowest round trip it heard\n"
		     "plus 1 ms, 5..100 ms (a slow USB adapter is\n"
		     "found; a silent motor costs 100 ms more)"),
	TOOL_OPT_ARG("tries", "N", "sends per request before giving up (default 3)"),
	TOOL_OPT_ARG("sim", "KEY=VALUE",
		     "simulated buses: set a parameter of every\n"
		     "simulated motor, as rmdd.yaml's sim.motor and\n"
		     "rmd-sim spell it (docs/rmd-sim.md), e.g.\n"
		     "turnaround_us=20000 or adapter_latency_timer_us=16000;\n"
		     "repeatable"),
	{ .name = "trace",
	  .help = "print every frame sent and received on stderr as\n"
		  "`candump -l` lines (canplayer and `rmdctl decode`\n"
		  "read them), each followed by a '#' comment line\n"
		  "that decodes it" },
	{ .name = "yes",
	  .shortc = 'y',
	  .help = "do not ask for confirmation (needed without a\n"
		  "terminal; commands that ask nothing accept it too)" },
	{ .name = "force",
	  .help = "talk on a bus that a running rmdd drives (refused\n"
		  "otherwise); set-id, accel and move: also skip their\n"
		  "safety limits described above" },
	TOOL_OPT_HELP,
	{ .name = "json",
	  .shortc = 'j',
	  .help = "one JSON object per motor and line (keys of\n"
		  "`rmdctl decode`)",
	  .flag = O_JSON },
	{ .name = "rom", .help = "write to ROM (kept at power off)", .flag = O_ROM },
	TOOL_OPT_ARG_FLAG("speed", "DPS", "maximum speed of the move (default 30)", O_SPEED),
	{ .name = "no-wait", .help = "do not wait for the motor to arrive", .flag = O_NOWAIT },
	{ .name = "once", .help = "print one table and exit", .flag = O_ONCE },
	TOOL_OPT_ARG_FLAG("interval", "MS", "refresh period (default 200)", O_INTERVAL),
	TOOL_OPT_ARG_FLAG("count", "N", "requests per motor and command (default 200)", O_COUNT),
	TOOL_OPT_ARG_FLAG("out", "PREFIX",
			  "write PREFIX.log (candump -l) and PREFIX.personality\n"
			  "(default: rmd-ID)",
			  O_OUT),
	TOOL_OPT_ARG_FLAG("move", "DEG",
			  "also move the motor DEG degrees (at most 10) and\n"
			  "back, at --speed (at most 10 dps); without it\n"
			  "nothing moves",
			  O_MOVE),
	{ .name = "power-cycle",
	  .help = "also ask (on the terminal) for a power cycle, for\n"
		  "the position after power off",
	  .flag = O_POWER },
};
const size_t rmdctl_n_dev_opts = sizeof(rmdctl_dev_opts) / sizeof(rmdctl_dev_opts[0]);
#define NOPTS rmdctl_n_dev_opts

void rmdctl_dev_usage(FILE *f, const struct rmdctl_cmd *c)
{
	struct tool_opt every[sizeof(rmdctl_dev_opts) / sizeof(rmdctl_dev_opts[0])];
	struct tool_opt own[sizeof(rmdctl_dev_opts) / sizeof(rmdctl_dev_opts[0])];
	size_t n_every = 0, n_own = 0;
	char keys[96];

	fprintf(f, "usage: rmdctl %s [OPTIONS] %s\n\n%s\n", c->name, c->args, c->help);
	for (size_t k = 0; k < NOPTS; k++) {
		every[k] = rmdctl_dev_opts[k];
		/* --protocol: the firmware dialects' keys, from the list */
		if (every[k].value == TOOL_VAL_FIRMWARE)
			every[k].help = rmdctl_proto_help(keys, sizeof(keys), true);
		if (!every[k].flag)
			n_every = k + 1;
		else if (c->opts & every[k].flag)
			own[n_own++] = every[k];
	}
	fprintf(f, "options of every device command:\n");
	tool_opts_help(f, every, n_every);
	if (n_own) {
		fprintf(f, "%s options:\n", c->name);
		tool_opts_help(f, own, n_own);
	}
	fprintf(f, "\nexit status: 0 ok; 1 the bus or a motor failed (each failure names the\n"
		   "bus, the motor and the command), or confirmation was declined; 2 usage\n"
		   "error, or a confirmation that could not be asked (no terminal, no --yes)\n"
		   "or a safety limit.\n");
}

/* A negative number ("-10", "-.5") is an argument, not an option. */
static bool is_number(const char *s)
{
	return s[0] == '-' &&
	       ((s[1] >= '0' && s[1] <= '9') || (s[1] == '.' && s[2] >= '0' && s[2] <= '9'));
}

/* The struct dev bool a switch sets, or NULL. */
static bool *switch_of(struct dev *d, const char *name)
{
	static const struct {
		const char *name;
		size_t off;
	} sw[] = {
		{ "trace", offsetof(struct dev, trace) },
		{ "json", offsetof(struct dev, json) },
		{ "yes", offsetof(struct dev, yes) },
		{ "rom", offsetof(struct dev, rom) },
		{ "force", offsetof(struct dev, force) },
		{ "no-wait", offsetof(struct dev, no_wait) },
		{ "once", offsetof(struct dev, once) },
		{ "power-cycle", offsetof(struct dev, power_cycle) },
	};

	for (size_t i = 0; i < sizeof(sw) / sizeof(sw[0]); i++)
		if (!strcmp(sw[i].name, name))
			return (bool *)((char *)d + sw[i].off);
	return NULL;
}

/* "bad --protocol "v9" (v3, v2 or v4; MIT motors answer v3)": the firmware keys, from the list. */
static void bad_protocol(const char *v)
{
	const struct rmd_dialect *list;
	char keys[64], more[96] = "";
	size_t n, k = 0;

	list = rmd_dialect_list(&n);
	for (size_t i = 0; i < n && k < sizeof(more); i++) {
		int w;

		if (rmd_dialect_is_firmware(&list[i]))
			continue;
		w = snprintf(more + k, sizeof(more) - k, "; %s motors answer %s", list[i].name,
			     rmd_dialect_firmware(&list[i])->key);
		if (w > 0)
			k += (size_t)w;
	}
	tool_log(TOOL_LOG_ERR, "bad --protocol \"%s\" (%s%s)", v,
		 rmd_firmware_keys_text(keys, sizeof(keys), ", ", " or "), more);
}

/* Apply option k with value v.  Returns 0, 1 (--help printed) or -EINVAL (reported). */
static int set_option(struct dev *d, size_t k, const char *v)
{
	const char *name = rmdctl_dev_opts[k].name;
	bool *sw = switch_of(d, name);
	uint64_t u;
	double x;

	if (sw) {
		*sw = true;
	} else if (!strcmp(name, "bus")) {
		d->bus_spec = v;
	} else if (!strcmp(name, "baud")) {
		if (rmdctl_parse_uint(v, 1, UINT32_MAX, &u) < 0)
			goto bad;
		d->baud = (uint32_t)u;
	} else if (!strcmp(name, "protocol")) {
		if (rmd_proto_parse(v, &d->proto) < 0 ||
		    !rmd_dialect_is_firmware(rmd_dialect(d->proto))) {
			bad_protocol(v);
			return -EINVAL;
		}
	} else if (!strcmp(name, "timeout")) {
		if (rmdctl_parse_double(v, &x) < 0 || x < 0.1 || x > 60000)
			goto bad;
		d->timeout_ms = x;
		d->timeout_set = true;
	} else if (!strcmp(name, "tries")) {
		if (rmdctl_parse_uint(v, 1, 100, &u) < 0)
			goto bad;
		d->tries = (unsigned)u;
	} else if (!strcmp(name, "sim")) {
		if (d->n_sim == MAX_SIM_SETTINGS) {
			tool_log(TOOL_LOG_ERR, "more than %d --sim settings", MAX_SIM_SETTINGS);
			return -EINVAL;
		}
		d->sim_kv[d->n_sim++] = v;
	} else if (!strcmp(name, "count")) {
		if (rmdctl_parse_uint(v, 1, RMDCTL_RTT_MAX_COUNT, &u) < 0)
			goto bad;
		d->count = (unsigned)u;
	} else if (!strcmp(name, "help")) {
		rmdctl_dev_usage(stdout, d->cmd);
		return 1;
	} else if (!strcmp(name, "speed")) {
		if (rmdctl_parse_double(v, &x) < 0)
			goto bad;
		d->speed_dps = x;
		d->speed_set = true;
	} else if (!strcmp(name, "out")) {
		if (!*v)
			goto bad;
		d->out = v;
	} else if (!strcmp(name, "move")) {
		if (rmdctl_parse_double(v, &x) < 0 || x == 0)
			goto bad;
		d->move_deg = x;
	} else if (!strcmp(name, "interval")) {
		if (rmdctl_parse_double(v, &x) < 0 || x < 10 || x > 3600000)
			goto bad;
		d->interval_ms = x;
	}
	return 0;
bad:
	tool_log(TOOL_LOG_ERR, "bad --%s \"%s\"", name, v);
	return -EINVAL;
}

/* Options anywhere, arguments in order.  Returns argument count, -1 usage, -2 help shown. */
static int parse_args(struct dev *d, int argc, char **argv, char **pos)
{
	int npos = 0;
	bool only_args = false;

	for (int i = 1; i < argc; i++) {
		const char *a = argv[i], *v = NULL, *eq;
		const struct tool_opt *opt;
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
				if (strlen(rmdctl_dev_opts[k].name) == len &&
				    !strncmp(rmdctl_dev_opts[k].name, a + 2, len))
					break;
			if (eq)
				v = eq + 1;
		} else {
			for (k = 0; k < NOPTS; k++)
				if (rmdctl_dev_opts[k].shortc &&
				    rmdctl_dev_opts[k].shortc == a[1] && !a[2])
					break;
		}
		if (k == NOPTS) {
			const char *near = tool_nearest_opt(a, rmdctl_dev_opts, NOPTS);

			if (a[1] == '-' && near)
				tool_log(TOOL_LOG_ERR, "unknown option \"%s\" (did you mean --%s?)",
					 a, near);
			else
				tool_log(TOOL_LOG_ERR, "unknown option \"%s\"", a);
			return -1;
		}
		opt = &rmdctl_dev_opts[k];
		if (opt->flag && !(d->cmd->opts & opt->flag)) {
			tool_log(TOOL_LOG_ERR, "option --%s does not apply to %s", opt->name,
				 d->cmd->name);
			return -1;
		}
		if (opt->has_arg && !v) {
			if (i + 1 >= argc) {
				tool_log(TOOL_LOG_ERR, "option \"%s\" needs a value", a);
				return -1;
			}
			v = argv[++i];
		} else if (!opt->has_arg && v) {
			tool_log(TOOL_LOG_ERR, "option --%s takes no value", opt->name);
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

int rmdctl_dev_run(const struct rmdctl_cmd *cmd, int argc, char **argv)
{
	struct sigaction sa;
	struct dev d;
	char **pos;
	int npos, r;

	memset(&d, 0, sizeof(d));
	d.cmd = cmd;
	d.bus_spec = getenv(BUS_ENV) && *getenv(BUS_ENV) ? getenv(BUS_ENV) : DEFAULT_BUS;
	d.proto = RMDCTL_PROTO_DEFAULT;
	d.timeout_ms = RMD_TXN_TIMEOUT_NS / 1e6;
	d.tries = RMD_TXN_TRIES;
	d.count = RMDCTL_RTT_COUNT;
	d.speed_dps = MOVE_SPEED_DPS;
	d.interval_ms = MONITOR_INTERVAL_MS;
	d.t0_ns = rmd_now_ns();
	d.t0_wall_ns = wall_now_ns();

	pos = calloc((size_t)argc + 1, sizeof(*pos));
	if (!pos) {
		tool_log(TOOL_LOG_ERR, "out of memory");
		return RMDCTL_EXIT_DATA;
	}
	npos = parse_args(&d, argc, argv, pos);
	if (npos == -2) {
		free(pos);
		return RMDCTL_EXIT_OK;
	}
	if (npos >= 0 && ((unsigned)npos < d.cmd->min_args || (unsigned)npos > d.cmd->max_args)) {
		tool_log(TOOL_LOG_ERR, "%s arguments: %s",
			 (unsigned)npos < d.cmd->min_args ? "missing" : "too many", d.cmd->args);
		npos = -1;
	}
	if (npos < 0) {
		free(pos);
		rmdctl_usage_hint(d.cmd);
		return RMDCTL_EXIT_USAGE;
	}
	/* "ID ...": every such command's motor, checked once here. */
	if (!strncmp(cmd->args, "ID", 2) && (cmd->args[2] == ' ' || !cmd->args[2]) &&
	    rmdctl_parse_id(pos[0], "ID", &d.id) < 0) {
		free(pos);
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
		tool_log(TOOL_LOG_ERR, "write error: %s", strerror(errno));
		r = RMDCTL_EXIT_DATA;
	}
	return r;
}
