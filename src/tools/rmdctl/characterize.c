// SPDX-License-Identifier: MIT
/*
 * rmdctl characterize: a fixed, safe exchange with one motor that turns it
 * into a test (issue 32 point 12).  It writes PREFIX.log, every frame as a
 * `candump -l` line (the bus's receive times), and PREFIX.personality, the
 * record `rmd-sim --personality` and the sim bus replay (the format and
 * its writer are rmd/sim_personality.h's):
 *
 *   1. identify: 0xB5 model, 0xB2 firmware date, the dialect the date says
 *      (used from then on when it differs from --protocol, said so);
 *   2. every read command of that dialect (its table's rows that change
 *      nothing and take no value), --count times, one outstanding: the
 *      turnaround distribution of each (round trip less the request and
 *      reply on the wire); a command never answered is `ignores`;
 *   3. 0x79 read on the motor's own identifier: an answer shaped as 0xB2
 *      is the answers_79_as_b2 quirk (X4-64 2025070202);
 *   4. 0xB3 written (ROM) and its echo checked (zeros: b3_answer_zeros),
 *      then written 0 (off, the factory setting; rmdd writes its own);
 *   5. 0x76 reset: the time to the first answer is boot_ms;
 *   6. with --move DEG only: 0xA4 by DEG (at most 10) at --speed (at most
 *      10 dps) and back, watched by 0x92, stopped (0x81) on anything odd;
 *   7. with --power-cycle only: the multi-turn angle before and after a
 *      power cycle the user makes, as a comment.
 *
 * The MIT scaling written is the dialect's table's for that date and model
 * (what rmdd would use), not measured: no MIT frame is sent.  CAN and sim
 * buses only: the wire arithmetic is CAN's.  Non-rt.
 */
#include <ctype.h>
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rmd/can_timing.h"
#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmd/sim_personality.h"
#include "rmd/time.h"
#include "rmd/txn.h"
#include "rmdctl.h"

/* The bit rate a bus that does not say one (vcan) is taken to have. */
#define CHAR_ASSUMED_BITRATE 1000000u
/* Step 4: the 0xB3 time written and checked (V3 §2.30: ms). */
#define CHAR_B3_MS 1000
/* Step 5: the longest boot waited for, and the poll. */
#define CHAR_BOOT_WAIT_NS 5000000000LL
#define CHAR_BOOT_POLL_NS 5000000LL
/* Step 6: bounds of --move and --speed. */
#define CHAR_MOVE_MAX_DEG 10.0
#define CHAR_SPEED_MAX_DPS 10.0
/* Step 7: how long a power cycle may take. */
#define CHAR_POWER_WAIT_NS 60000000000LL
/* A read that answers none of its first tries is ignored: no more samples. */
#define CHAR_FIRST_TRIES 3

/* What one read command's samples say. */
struct sampled {
	uint8_t cmd;
	struct rmd_msg msg; /* its request */
	unsigned n, lost;
	bool odd;    /* an answer that does not decode */
	int64_t *ns; /* turnarounds, --count of them */
};

/* Everything one run gathers. */
struct charz {
	struct dev *d;
	uint32_t bitrate;
	bool bitrate_assumed;
	struct rmd_personality p;
	struct sampled s[RMD_PERSONALITY_CMDS_MAX];
	unsigned n_s;
	int64_t *pool; /* every read's turnarounds: `turnaround *` */
	unsigned n_pool;
	char notes[8][160]; /* comment lines of the file */
	unsigned n_notes;
};

__attribute__((format(printf, 2, 3))) static void note(struct charz *c, const char *fmt, ...)
{
	va_list ap;

	if (c->n_notes == sizeof(c->notes) / sizeof(c->notes[0]))
		return;
	va_start(ap, fmt);
	vsnprintf(c->notes[c->n_notes++], sizeof(c->notes[0]), fmt, ap);
	va_end(ap);
}

static int cmp_i64(const void *a, const void *b)
{
	int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;

	return (x > y) - (x < y);
}

/*
 * The turnaround of a first try t that was heard: its round trip (send to
 * the answer's end of frame) less the request's and the answer's time on
 * the wire, at the bus's bit rate, exact stuff bits (rmd/can_timing.h).
 */
static int64_t turnaround_of(const struct charz *c, const struct rmd_txn *t)
{
	int64_t rtt = t->heard_ns - t->first_sent_ns;
	struct rmd_frame rep = t->rep.f;

	if (!t->done) /* heard, not taken: a repeat of the request, of its length */
		rep = t->req;
	rtt -= rmd_can_wire_ns(rmd_can_frame_bits(&t->req), c->bitrate);
	rtt -= rmd_can_wire_ns(rmd_can_frame_bits(&rep), c->bitrate);
	return rtt > 0 ? rtt : 0;
}

/* Quantiles of v[0..n) (sorted here) at rmd_personality_quantiles, in µs, into line t. */
static void quantiles(int64_t *v, unsigned n, uint16_t cmd, struct rmd_personality_turnaround *t)
{
	qsort(v, n, sizeof(*v), cmp_i64);
	t->cmd = cmd;
	t->samples = n;
	for (unsigned k = 0; k < RMD_PERSONALITY_NQ; k++) {
		/* linear between the order statistics, as the simulator draws them */
		double pos = rmd_personality_quantiles[k] * (n - 1);
		unsigned lo = (unsigned)pos;
		double f = pos - lo,
		       x = lo + 1 < n ? v[lo] + f * (double)(v[lo + 1] - v[lo]) : v[lo];
		uint32_t us = (uint32_t)llround(x / 1e3);

		t->q_us[k] = k && us < t->q_us[k - 1] ? t->q_us[k - 1] : us;
	}
}

/* The read requests of the dialect: rows that change nothing and take no value but an index. */
static unsigned read_rows(struct charz *c, uint8_t id)
{
	const struct rmd_dialect *dl = rmdctl_dialect(c->d);
	struct req pid[RMD_PID_SLOTS_MAX];
	unsigned n_pid = rmdctl_pid_read_reqs(c->d, id, pid), n = 0;

	for (unsigned i = 0; i < *dl->n_rows && n < RMD_PERSONALITY_CMDS_MAX - 2; i++) {
		const struct rmd_cmd_spec *spec = &dl->rows[i];
		struct sampled *s = &c->s[n];
		bool reads = !spec->flags;

		for (unsigned k = 0; k < spec->req.n; k++)
			reads &= spec->req.f[k].field == RMD_FLD_INDEX;
		if (!reads)
			continue;
		*s = (struct sampled){ .cmd = spec->cmd, .ns = s->ns };
		s->msg.cmd = spec->cmd;
		/* by index: V4.2 §2.1 the first gain's, §2.4 index 0 */
		for (unsigned k = 0; k < n_pid; k++)
			if (pid[k].msg.cmd == spec->cmd) {
				s->msg = pid[k].msg;
				break;
			}
		if (spec->req.n && !rmd_msg_has(&s->msg, RMD_FLD_INDEX))
			rmd_msg_set(&s->msg, RMD_FLD_INDEX, 0);
		n++;
	}
	return n;
}

/* Step 2: --count first tries of s, one outstanding. */
static int sample(struct charz *c, uint8_t id, struct sampled *s)
{
	struct dev *d = c->d;
	struct rmd_txn_opts o = d->txn;
	struct rmd_txn t;
	int r;

	o.tries = 1;
	for (unsigned i = 0; i < d->count && !rmdctl_interrupted; i++) {
		r = rmdctl_txn_prepare(&t, d, id, &s->msg);
		if (r)
			return r;
		r = rmdctl_txn_run(d, &t, 1, &o);
		if (r)
			return r;
		if (t.tries == 1 && t.heard) {
			s->ns[s->n++] = turnaround_of(c, &t);
			if (t.done && rmd_decode_as(d->proto, RMD_DIR_REPLY, s->cmd, &t.rep.f,
						    &(struct rmd_msg){ 0 }) < 0)
				s->odd = true;
		} else {
			s->lost++;
			/* an answer still on its way must not pass for the next one's */
			rmdctl_sleep_until(rmd_now_ns() + o.timeout_ns);
		}
		if (!s->n && s->lost >= CHAR_FIRST_TRIES)
			break;
	}
	return 0;
}

/* Step 1: model, date, dialect.  Returns 0 or an exit status (reported). */
static int identify(struct charz *c, uint8_t id)
{
	struct dev *d = c->d;
	struct req q[2];
	struct rec rec = { 0 };
	const struct rmd_dialect *fw;
	bool certain;
	char text[64];
	int r;

	if (!rmd_dialect_has(rmdctl_dialect(d), RMD_DIALECT_MODEL_B5 | RMD_DIALECT_VERSION_B2)) {
		tool_log(TOOL_LOG_ERR,
			 "protocol %s has no 0xB5/0xB2: characterize needs a V3 or V4 motor",
			 rmdctl_dialect(d)->name);
		return RMDCTL_EXIT_USAGE;
	}
	rmdctl_req_init(&q[0], id, 0xB5); /* V3 §2.32 */
	rmdctl_req_init(&q[1], id, 0xB2); /* V3 §2.29 */
	r = rmdctl_run_reqs(d, q, 2);
	if (r)
		return r;
	if (rmdctl_report_failed(d, q, 2))
		return RMDCTL_EXIT_DATA;
	rmdctl_rec_add_req(&rec, d, &q[0], true);
	rmdctl_rec_add_req(&rec, d, &q[1], true);
	rmdctl_field_text(d, &rec, RMD_FLD_MODEL, text, sizeof(text));
	snprintf(c->p.model, sizeof(c->p.model), "%.*s", (int)sizeof(c->p.model) - 1, text);
	c->p.version_date = (uint32_t)rec.raw[RMD_FLD_VERSION];
	fw = rmdctl_rec_dialect(d, &rec, &certain);
	if (fw && certain && fw->proto != rmd_dialect_firmware(rmdctl_dialect(d))->proto) {
		tool_log(TOOL_LOG_NOTICE,
			 "%s: motor %u's firmware date %" PRIu32 " says %s: characterizing it as "
			 "%s, not --protocol %s",
			 d->name, id, c->p.version_date, fw->name, fw->key,
			 rmd_proto_key(d->proto));
		d->proto = fw->proto;
	}
	c->p.proto = rmd_dialect_firmware(rmdctl_dialect(d))->proto;
	c->p.set |= RMD_PERSONALITY_HAS_MODEL | RMD_PERSONALITY_HAS_VERSION |
		    RMD_PERSONALITY_HAS_PROTO;
	snprintf(c->p.name, sizeof(c->p.name), "%s-%" PRIu32, c->p.model, c->p.version_date);
	for (char *p = c->p.name; *p; p++)
		*p = (char)tolower((unsigned char)*p);
	printf("%s: motor %u: model %s, firmware %" PRIu32 ", %s\n", d->name, id, c->p.model,
	       c->p.version_date, rmdctl_dialect(d)->name);
	return 0;
}

/*
 * Step 3: 0x79 read on the motor's own identifier (V3 §4's rides on 0x300,
 * V4.2 has none): firmware 2025070202 answers `241#B2...`, the 0xB2 frame.
 * Any frame on the motor's reply identifier is taken.
 */
static int probe_79(struct charz *c, uint8_t id)
{
	struct dev *d = c->d;
	const struct rmd_dialect *dl = rmdctl_dialect(d);
	struct rmd_msg m = { .cmd = 0x79 };
	struct rmd_txn t;
	int r;

	if (!rmdctl_spec(d, 0x79))
		return 0;
	rmd_msg_set(&m, RMD_FLD_READ_FLAG, 1); /* V3 §4.2: read, changes nothing */
	r = rmdctl_txn_prepare(&t, d, id, &m);
	if (r)
		return r;
	t.req.can_id = dl->req_base + id;
	t.reply_id = dl->reply_base + id;
	t.any_cmd = true;
	t.guardable = false;
	r = rmdctl_txn_run(d, &t, 1, &d->txn);
	if (r)
		return r;
	if (t.done && t.rep.f.data[0] == 0xB2) {
		rmd_personality_set_flag(&c->p, RMD_PERSONALITY_ANSWERS_79_AS_B2, true);
		printf("%s: motor %u answers 0x79 with a 0xB2 frame (answers_79_as_b2)\n", d->name,
		       id);
	} else {
		rmd_personality_set_flag(&c->p, RMD_PERSONALITY_ANSWERS_79_AS_B2, false);
	}
	return 0;
}

/* Step 4: 0xB3 = CHAR_B3_MS, its echo checked, then 0.  Returns 0 or an exit status. */
static int comm_loss(struct charz *c, uint8_t id)
{
	struct dev *d = c->d;
	struct req q;
	int r;

	if (!rmd_dialect_has(rmdctl_dialect(d), RMD_DIALECT_COMM_LOSS_B3))
		return 0;
	rmdctl_req_init(&q, id, 0xB3);
	rmd_msg_set(&q.msg, RMD_FLD_TIMEOUT, CHAR_B3_MS);
	r = rmdctl_run_reqs(d, &q, 1);
	if (r)
		return r;
	if (!q.answered) {
		rmdctl_report_missing(d, &q, "");
		return RMDCTL_EXIT_DATA;
	}
	/* V3 §2.30 example 2: a firmware that answers zeros */
	if (!q.ok && !memcmp(q.t.rep.f.data + 1, (uint8_t[7]){ 0 }, 7)) {
		rmd_personality_set_flag(&c->p, RMD_PERSONALITY_B3_ANSWER_ZEROS, true);
		printf("%s: motor %u answers 0xB3 with zeros (b3_answer_zeros)\n", d->name, id);
	} else if (!q.ok) {
		return rmdctl_ask_check(d, &q);
	} else {
		rmd_personality_set_flag(&c->p, RMD_PERSONALITY_B3_ANSWER_ZEROS, false);
	}
	note(c, "0xB3 written %d ms (echo %s), then 0 (off): rmdd writes its own at bring-up",
	     CHAR_B3_MS, q.ok ? "verified" : "zeros");
	rmdctl_req_init(&q, id, 0xB3);
	rmd_msg_set(&q.msg, RMD_FLD_TIMEOUT, 0);
	r = rmdctl_run_reqs(d, &q, 1);
	if (r)
		return r;
	return q.answered ? 0 : (rmdctl_report_missing(d, &q, ""), RMDCTL_EXIT_DATA);
}

/*
 * Step 5: 0x76, then 0xB1 until the runtime it answers restarted (V3
 * §2.28; an answer owed from before the reset, such as the guard's of the
 * 0x76, is not taken): boot_ms.  Returns 0 or an exit status.
 */
static int reboot_time(struct charz *c, uint8_t id)
{
	struct dev *d = c->d;
	struct rmd_txn_opts o = d->txn;
	int64_t t0, until;
	struct req q;
	int r;

	if (!rmdctl_spec(d, 0xB1))
		return 0;

	rmdctl_req_init(&q, id, 0x76); /* V3 §2.25 */
	r = rmdctl_run_reqs(d, &q, 1);
	if (r)
		return r;
	t0 = rmd_now_ns();
	until = t0 + CHAR_BOOT_WAIT_NS;
	o.tries = 1;
	o.timeout_ns = CHAR_BOOT_POLL_NS;
	do {
		struct rmd_txn t;
		struct rmd_msg m = { .cmd = 0xB1 }, rep;

		r = rmdctl_txn_prepare(&t, d, id, &m);
		if (!r)
			r = rmdctl_txn_run(d, &t, 1, &o);
		if (r)
			return r;
		if (t.done && !rmd_decode_as(d->proto, RMD_DIR_REPLY, 0xB1, &t.rep.f, &rep) &&
		    rep.v[RMD_FLD_RUNTIME] <= (t.rep.t_ns - t0) / 1000000 + 1) {
			int64_t boot = t.first_sent_ns - t0;

			c->p.boot_ms = (unsigned)(boot < 0 ? 0 : boot / 1000000);
			c->p.set |= RMD_PERSONALITY_HAS_BOOT;
			printf("%s: motor %u: reset (0x76), answering again after %u ms\n", d->name,
			       id, c->p.boot_ms);
			return 0;
		}
	} while (rmd_now_ns() < until && !rmdctl_interrupted);
	tool_log(TOOL_LOG_ERR, "%s: motor %u did not answer within %.0f s of its reset (0x76)",
		 d->name, id, CHAR_BOOT_WAIT_NS / 1e9);
	return RMDCTL_EXIT_DATA;
}

/* The multi-turn angle (0x92), deg.  Returns 0 or an exit status (reported). */
static int angle(struct dev *d, uint8_t id, double *deg)
{
	struct rec rec = { 0 };
	struct req q;
	int r;

	rmdctl_req_init(&q, id, 0x92);
	r = rmdctl_ask(d, &q);
	if (r)
		return r;
	rmdctl_rec_add_req(&rec, d, &q, true);
	*deg = rmdctl_rec_val(&rec, RMD_FLD_ANGLE);
	return 0;
}

/* 0xA4 to target at --speed, waited for; stopped (0x81) on anything odd. */
static int move_to(struct charz *c, uint8_t id, double from, double target)
{
	struct dev *d = c->d;
	const struct rmd_cmd_spec *spec = rmdctl_spec(d, 0xA4);
	const char *why = "";
	double final;
	struct req q;
	int r;

	rmdctl_req_init(&q, id, 0xA4); /* V3 §2.20 */
	if (!spec ||
	    rmd_msg_set_native(&q.msg, spec, RMD_DIR_REQUEST, RMD_FLD_MAX_SPEED, d->speed_dps) <
		    0 ||
	    rmd_msg_set_native(&q.msg, spec, RMD_DIR_REQUEST, RMD_FLD_ANGLE, target) < 0) {
		tool_log(TOOL_LOG_ERR, "cannot encode 0xA4 to %g deg", target);
		return RMDCTL_EXIT_DATA;
	}
	r = rmdctl_ask(d, &q);
	if (!r)
		r = rmdctl_move_wait(d, id, from, target, &final, &why);
	if (r) {
		rmdctl_stop_motor(d, id);
		tool_log(TOOL_LOG_ERR, "%s: motor %u: %s on the way to %.2f deg", d->name, id,
			 why[0] ? why : "no answer", target);
		return r;
	}
	printf("%s: motor %u: at %.2f deg (target %.2f)\n", d->name, id, final, target);
	return 0;
}

/* Step 6: --move DEG and back.  Returns 0 or an exit status. */
static int motion(struct charz *c, uint8_t id)
{
	struct dev *d = c->d;
	double from;
	struct req q;
	int r;

	r = angle(d, id, &from);
	if (r)
		return r;
	rmdctl_req_init(&q, id, 0x77); /* V3 §2.26: release the brake */
	r = rmdctl_ask(d, &q);
	if (!r)
		r = move_to(c, id, from, from + d->move_deg);
	if (!r)
		r = move_to(c, id, from + d->move_deg, from);
	rmdctl_req_init(&q, id, 0x80); /* V3 §2.15: output off */
	rmdctl_ask(d, &q);
	rmdctl_req_init(&q, id, 0x78); /* V3 §2.27: brake locked */
	rmdctl_ask(d, &q);
	if (!r)
		note(c, "moved %+.2f deg and back at %g dps from %.2f deg", d->move_deg,
		     d->speed_dps, from);
	return r;
}

/* Step 7: the angle before and after a power cycle the user makes. */
static int power_cycle(struct charz *c, uint8_t id)
{
	struct dev *d = c->d;
	struct rmd_txn_opts o = d->txn;
	double before, after;
	char line[16];
	int64_t until;
	int r;

	r = angle(d, id, &before);
	if (r)
		return r;
	fprintf(stderr, "Power motor %u off, wait 3 s, power it on, then press Enter: ", id);
	fflush(stderr);
	if (!fgets(line, sizeof(line), stdin))
		return RMDCTL_EXIT_DATA;
	until = rmd_now_ns() + CHAR_POWER_WAIT_NS;
	o.tries = 1;
	do {
		struct rmd_txn t;
		struct rmd_msg m = { .cmd = 0x9A };

		r = rmdctl_txn_prepare(&t, d, id, &m);
		if (!r)
			r = rmdctl_txn_run(d, &t, 1, &o);
		if (r)
			return r;
		if (t.done)
			break;
	} while (rmd_now_ns() < until && !rmdctl_interrupted);
	r = angle(d, id, &after);
	if (r)
		return r;
	printf("%s: motor %u: multi-turn angle %.2f deg before the power cycle, %.2f after\n",
	       d->name, id, before, after);
	note(c, "power cycle: multi-turn angle %.2f deg before, %.2f after", before, after);
	return 0;
}

/* The personality's turnaround lines and ignores from the samples. */
static void summarize(struct charz *c)
{
	struct rmd_personality *p = &c->p;

	for (unsigned i = 0; i < c->n_s; i++) {
		struct sampled *s = &c->s[i];

		if (!s->n) {
			p->ignores[s->cmd >> 3] |= (uint8_t)(1u << (s->cmd & 7));
			printf("%s: 0x%02X never answered (%u tries): ignores\n", c->d->name,
			       s->cmd, s->lost);
			continue;
		}
		memcpy(c->pool + c->n_pool, s->ns, s->n * sizeof(*s->ns));
		c->n_pool += s->n;
		quantiles(s->ns, s->n, s->cmd, &p->turnaround[p->n_turnaround++]);
		if (s->odd)
			note(c, "0x%02X: an answer that does not decode", s->cmd);
	}
	if (c->n_pool)
		quantiles(c->pool, c->n_pool, RMD_PERSONALITY_CMD_ANY,
			  &p->turnaround[p->n_turnaround++]);
}

/* The MIT scaling rmdd would use for this date and model (not measured). */
static void mit_scaling(struct charz *c)
{
	const struct rmd_dialect *dl = rmdctl_dialect(c->d);
	struct rmd_mit_decision dec;

	if (!rmd_dialect_has(dl, RMD_DIALECT_MIT_FRAMES))
		return;
	rmd_mit_scaling_decide(dl, c->p.version_date, c->p.model, &(struct rmd_mit_ranges){ 0 }, 0,
			       &dec);
	if (!rmd_mit_decided(&dec))
		return;
	c->p.mit = dec.r;
	c->p.set |= RMD_PERSONALITY_HAS_MIT;
	note(c, "mit ranges: %s's table for this date and model (%s), not measured", dl->name,
	     dec.row && dec.row->source ? dec.row->source : "preset");
}

/* Write PREFIX.personality.  Returns 0 or RMDCTL_EXIT_DATA (reported). */
static int write_file(struct charz *c, const char *path, const char *log_path)
{
	char comment[sizeof(c->notes) + 512], stamp[32];
	time_t now = time(NULL);
	size_t k = 0;
	FILE *f;
	int r;

	strftime(stamp, sizeof(stamp), "%Y-%m-%dT%H:%M:%SZ", gmtime(&now));
	k += (size_t)snprintf(comment + k, sizeof(comment) - k,
			      "recorded by rmdctl characterize on %s, %s (log: %s)\n"
			      "turnaround: round trip less the frames' wire time at %" PRIu32
			      " bit/s%s, %u first tries per command",
			      c->d->name, stamp, log_path, c->bitrate,
			      c->bitrate_assumed ? " (assumed)" : "", c->d->count);
	for (unsigned i = 0; i < c->n_notes && k < sizeof(comment); i++)
		k += (size_t)snprintf(comment + k, sizeof(comment) - k, "\n%s", c->notes[i]);
	f = fopen(path, "w");
	if (!f) {
		tool_log(TOOL_LOG_ERR, "%s: %s", path, strerror(errno));
		return RMDCTL_EXIT_DATA;
	}
	r = rmd_personality_write(f, &c->p, comment);
	if (fclose(f) != 0 || r < 0) {
		tool_log(TOOL_LOG_ERR, "%s: write error", path);
		return RMDCTL_EXIT_DATA;
	}
	return 0;
}

/* --move and --speed within bounds.  0 or RMDCTL_EXIT_USAGE (reported). */
static int check_motion(struct dev *d)
{
	if (!d->move_deg)
		return 0;
	if (fabs(d->move_deg) > CHAR_MOVE_MAX_DEG) {
		tool_log(TOOL_LOG_ERR, "refusing --move %g: characterize moves at most %g deg",
			 d->move_deg, CHAR_MOVE_MAX_DEG);
		return RMDCTL_EXIT_USAGE;
	}
	if (!d->speed_set)
		d->speed_dps = CHAR_SPEED_MAX_DPS;
	if (!(d->speed_dps >= 1) || d->speed_dps > CHAR_SPEED_MAX_DPS) {
		tool_log(TOOL_LOG_ERR, "refusing --speed %g: characterize moves at 1..%g dps",
			 d->speed_dps, CHAR_SPEED_MAX_DPS);
		return RMDCTL_EXIT_USAGE;
	}
	return 0;
}

int rmdctl_run_characterize(struct dev *d, int argc, char **argv)
{
	static struct charz c;
	char prefix[256], log_path[300], file_path[300];
	int64_t *samples;
	uint8_t id = d->id;
	int r;

	(void)argc;
	(void)argv;
	memset(&c, 0, sizeof(c));
	c.d = d;
	r = check_motion(d);
	if (r)
		return r;
	if (d->power_cycle && !isatty(STDIN_FILENO)) {
		tool_log(TOOL_LOG_ERR, "--power-cycle asks on the terminal: stdin is not one");
		return RMDCTL_EXIT_USAGE;
	}
	snprintf(prefix, sizeof(prefix), "%s", d->out ? d->out : "");
	if (!d->out)
		snprintf(prefix, sizeof(prefix), "rmd-%u", id);
	snprintf(log_path, sizeof(log_path), "%s.log", prefix);
	snprintf(file_path, sizeof(file_path), "%s.personality", prefix);
	/* each command's samples, and all of them again for `turnaround *` */
	samples = calloc((size_t)d->count * RMD_PERSONALITY_CMDS_MAX, sizeof(*samples));
	c.pool = calloc((size_t)d->count * RMD_PERSONALITY_CMDS_MAX, sizeof(*c.pool));
	for (unsigned i = 0; samples && i < RMD_PERSONALITY_CMDS_MAX; i++)
		c.s[i].ns = samples + (size_t)i * d->count;
	if (!c.pool || !samples) {
		tool_log(TOOL_LOG_ERR, "out of memory");
		r = RMDCTL_EXIT_DATA;
		goto out_free;
	}
	r = rmdctl_open_bus_for(d, true, "characterize motor %u on %s", id, d->bus_spec);
	if (r)
		goto out_free;
	if (rmd_bus_caps(d->b)->half_duplex) {
		tool_log(TOOL_LOG_ERR, "%s: characterize needs a CAN or simulated bus", d->name);
		r = RMDCTL_EXIT_USAGE;
		goto out_close;
	}
	r = rmdctl_confirm(
		d,
		"characterize motor %u on %s: reads, 0xB3 written to ROM (%d ms, then 0), "
		"a reset (0x76)%s",
		id, d->name, CHAR_B3_MS,
		d->move_deg ? ", and a move of a few degrees and back" : "");
	if (r)
		goto out_close;
	c.bitrate = rmd_bus_caps(d->b)->bitrate;
	if (!c.bitrate) {
		c.bitrate = CHAR_ASSUMED_BITRATE;
		c.bitrate_assumed = true;
	}
	/* every frame from here on, as the bus stamped it, in the log */
	rmdctl_close_bus(d);
	d->log = fopen(log_path, "w");
	if (!d->log) {
		tool_log(TOOL_LOG_ERR, "%s: %s", log_path, strerror(errno));
		r = RMDCTL_EXIT_DATA;
		goto out_free;
	}
	r = rmdctl_open_bus(d);
	if (r)
		goto out_log;
	r = identify(&c, id);
	if (r)
		goto out_close;
	c.n_s = read_rows(&c, id);
	for (unsigned i = 0; i < c.n_s && !r; i++)
		r = sample(&c, id, &c.s[i]);
	if (!r)
		r = probe_79(&c, id);
	if (!r)
		r = comm_loss(&c, id);
	if (!r)
		r = reboot_time(&c, id);
	if (!r && d->move_deg)
		r = motion(&c, id);
	if (!r && d->power_cycle)
		r = power_cycle(&c, id);
	if (r)
		goto out_close;
	summarize(&c);
	mit_scaling(&c);
	r = write_file(&c, file_path, log_path);
	if (!r)
		printf("%s: motor %u: wrote %s and %s\n", d->name, id, file_path, log_path);
out_close:
	rmdctl_close_bus(d);
out_log:
	if (d->log && fclose(d->log) != 0 && !r) {
		tool_log(TOOL_LOG_ERR, "%s: write error", log_path);
		r = RMDCTL_EXIT_DATA;
	}
	d->log = NULL;
out_free:
	free(samples);
	free(c.pool);
	return r;
}
