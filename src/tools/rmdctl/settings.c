// SPDX-License-Identifier: MIT
/*
 * rmdctl set-id, set-zero, set-timeout, accel, pid: commands that write a
 * motor's settings (ROM writes ask for confirmation).  Non-rt.
 */
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/proc_arm.h"
#include "rmd/time.h"
#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmdctl.h"

/* accel: V3 §2.5.1 range */
#define ACCEL_MIN_DPS2 100
#define ACCEL_MAX_DPS2 60000
/* set-id: how long the new id may take to answer (a reset's boot: 1.12 s was measured) */
#define SET_ID_WAIT_NS 3000000000
#define SET_ID_POLL_NS 50000000

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
	m = rmdctl_probe(d, others, k, found, st);
	if (m < 0)
		return -m;
	if ((unsigned)m == k)
		return RMDCTL_EXIT_OK;
	for (unsigned i = 0; i < k; i++)
		if (!st[i].ok)
			tool_log(TOOL_LOG_ERR,
				 "%s: motor %u no longer answers: it took id %u too (its CAN-ID "
				 "filter is off)",
				 d->name, others[i], new_id);
	return RMDCTL_EXIT_DATA;
}

/*
 * What came back to an ID write besides its own answer (cap_frame()): its
 * echo from one of echo_ids[], or a 0xB2-shaped frame on b2_id (X4-64
 * firmware 2025070202 answers 0x79 so: `241#B20000007A1EB478`, its
 * firmware date, for read and write alike; it takes no 0x79).
 */
struct id_cap {
	uint32_t echo_ids[2];
	uint8_t data[RMD_FRAME_LEN]; /* the request: its echo */
	uint32_t from;		     /* the echo came on this identifier; 0: none */
	uint32_t b2_id;		     /* the motor's reply identifier; 0: no 0xB2 is looked for */
	struct rmd_frame b2;	     /* ... the 0xB2 frame that came there (len 0: none) */
};

static void cap_frame(void *ctx, const struct rmd_bus_rx *rx)
{
	struct id_cap *c = ctx;

	if ((rx->f.can_id == c->echo_ids[0] || rx->f.can_id == c->echo_ids[1]) &&
	    rx->f.len == RMD_FRAME_LEN && !memcmp(rx->f.data, c->data, RMD_FRAME_LEN))
		c->from = rx->f.can_id;
	/* V3 §2.29: 0xB2's answer */
	if (c->b2_id && rx->f.can_id == c->b2_id && rx->f.len == RMD_FRAME_LEN &&
	    rx->f.data[0] == 0xB2)
		c->b2 = rx->f;
}

/*
 * Send the ID write t, one try at a time (each writes flash), until its
 * answer, its echo from either id or a 0xB2 frame (cap) came, at most
 * --tries times: the txn matches the request's own answer only, so the
 * others are looked for after each try, and among the frames that came
 * after it (a run with no request takes them) before the next.  A write's
 * answer is the request (V3 §4.3, V4.2 §2.34.3): a repeat the txn holds
 * for an echo (rmd/txn.h check_echo: V3's 0x79 on 0x300 cannot go behind
 * a guard) is the answer too; the motor answered the probe and 0xB2 just
 * before, so it is awake, and check_renumbered() judges what it did.
 * Returns 0 or RMDCTL_EXIT_DATA (a bus error, reported).
 */
static int write_id(struct dev *d, struct rmd_txn *t, struct id_cap *cap)
{
	struct rmd_txn_opts o = d->txn;
	int r = 0;

	memcpy(cap->data, t->req.data, RMD_FRAME_LEN);
	o.unmatched = cap_frame;
	o.unmatched_ctx = cap;
	o.tries = 1;
	for (unsigned k = 0; k < d->tries && !cap->from && !cap->b2.len; k++) {
		r = k ? rmd_txn_run(d->b, t, 0, &o) : 0;
		if (r >= 0 && !cap->from && !cap->b2.len)
			r = rmd_txn_run(d->b, t, 1, &o);
		if (r < 0) {
			tool_log(TOOL_LOG_ERR, "%s: %s", d->name, strerror(-r));
			return RMDCTL_EXIT_DATA;
		}
		if (t->done || t->echo_seen)
			cap->from = t->reply_id;
	}
	return 0;
}

/* A request as messages name it: "0x20 index 5", "0x79". */
static const char *req_name(const struct rmd_msg *m, char *buf, size_t size)
{
	if (rmd_msg_has(m, RMD_FLD_INDEX))
		snprintf(buf, size, "0x%02X index %" PRId64, m->cmd, m->v[RMD_FLD_INDEX]);
	else
		snprintf(buf, size, "0x%02X", m->cmd);
	return buf;
}

/*
 * A write of the ID that holds after a reset (how->then_reset; V4.2
 * §2.34.4: 0x20 index 5, to ROM, then 0x76).  The reply is the request
 * (§2.34.3), but firmware 2025070202 (X4-36, X4-64) sends it from the NEW
 * id (how->echo_from_new), while it still takes requests on the old one
 * until the reset: either is the answer, the first time (each try writes
 * flash).  Then the reset to the old id, whose time goes in *t_reset_ns.
 * Returns an exit status.
 */
static int set_id_then_reset(struct dev *d, uint8_t old_id, uint8_t new_id,
			     const struct rmd_set_id_req *how, int64_t *t_reset_ns)
{
	const struct rmd_dialect *dl = rmdctl_dialect(d);
	uint8_t echo_id = how->echo_from_new ? new_id :
					       old_id; /* the other id it may answer from */
	struct id_cap cap = { .echo_ids = { dl->reply_base + (uint32_t)old_id,
					    dl->reply_base + (uint32_t)echo_id } };
	struct rmd_txn t;
	struct req rst;
	char what[32], rname[16];
	int r;

	req_name(&how->write, what, sizeof(what));
	req_name(&how->reset, rname, sizeof(rname));
	r = rmdctl_confirm(
		d,
		"write CAN id %u to motor %u on %s (%s, ROM), then reset it (%s) so that "
		"it takes the id",
		new_id, old_id, d->name, what, rname);
	if (r)
		return r;
	r = rmd_txn_prepare(&t, d->proto, old_id, &how->write);
	if (r < 0) {
		tool_log(TOOL_LOG_ERR, "motor %u: cannot encode %s: %s", old_id, what,
			 strerror(-r));
		return RMDCTL_EXIT_DATA;
	}
	r = write_id(d, &t, &cap);
	if (r)
		return r;
	if (!cap.from) {
		tool_log(TOOL_LOG_ERR,
			 "%s: motor %u did not answer %s (from id %u or %u): the id may not have "
			 "changed; not reset",
			 d->name, old_id, what, old_id, echo_id);
		return RMDCTL_EXIT_DATA;
	}
	tool_log(TOOL_LOG_INFO,
		 "%s: motor %u took id %u (echoed from id %u; until the reset it still takes "
		 "requests on id %u); resetting it",
		 d->name, old_id, new_id, (unsigned)(cap.from - dl->reply_base), old_id);
	/* V4.2 §2.25: 0x76 does not answer */
	rmdctl_req_init(&rst, old_id, how->reset.cmd);
	rst.msg = how->reset;
	r = rmdctl_run_reqs(d, &rst, 1);
	*t_reset_ns = rmd_now_ns();
	return r;
}

/*
 * The ID rule of motor id's firmware: when --protocol's dialect has 0xB2
 * and the date it answers names (certainly) a dialect that sets IDs
 * another way (firmware 2025070202: 0x20 index 5, not 0x79), that
 * dialect's requests in *how and d->proto, said on stderr.  No answer:
 * --protocol's rule stays.  Returns 0 or an exit status.
 */
static int firmware_rule(struct dev *d, uint8_t id, uint8_t new_id, struct rmd_set_id_req *how)
{
	const struct rmd_dialect *fw;
	struct rec rec = { 0 };
	struct req q;
	bool certain;
	int r;

	if (!rmd_dialect_has(rmdctl_dialect(d), RMD_DIALECT_VERSION_B2))
		return 0;
	rmdctl_req_init(&q, id, 0xB2); /* V3 §2.29, V4.2 §2.30 */
	r = rmdctl_run_reqs(d, &q, 1);
	if (r || !q.ok)
		return r;
	rmdctl_rec_add_req(&rec, d, &q, true);
	fw = rmdctl_rec_dialect(d, &rec, &certain);
	if (!fw || !certain || fw->set_id == rmdctl_dialect(d)->set_id ||
	    rmd_set_id_request(fw, new_id, how) < 0)
		return 0;
	tool_log(TOOL_LOG_NOTICE,
		 "%s: motor %u's firmware (date %" PRId64 ") is %s: it sets its id as %s does, "
		 "not as --protocol %s (docs/protocol-v4.md)",
		 d->name, id, q.rep.v[RMD_FLD_VERSION], fw->name, fw->key, rmd_proto_key(d->proto));
	d->proto = fw->proto;
	return 0;
}

/*
 * A 0x79 write answered by a 0xB2 frame (struct id_cap): firmware that
 * takes no 0x79.  The dialect its date names, when that one sets IDs
 * otherwise, in *how and d->proto (said); returns false when the date
 * names none.
 */
static bool b2_rule(struct dev *d, uint8_t id, uint8_t new_id, const struct rmd_frame *b2,
		    struct rmd_set_id_req *how)
{
	const struct rmd_dialect *fw;
	struct rmd_msg m;
	bool certain;
	char hex[2 * RMD_FRAME_LEN + 1];

	for (unsigned i = 0; i < RMD_FRAME_LEN; i++)
		snprintf(hex + 2 * i, sizeof(hex) - 2 * i, "%02X", b2->data[i]);
	tool_log(TOOL_LOG_ERR,
		 "%s: motor %u answered 0x79 with %03" PRIX32 "#%s, a 0xB2 frame (firmware "
		 "2025070202 does): it takes no 0x79, the id did not change",
		 d->name, id, b2->can_id, hex);
	if (rmd_decode_as(d->proto, RMD_DIR_REPLY, 0xB2, b2, &m) < 0 ||
	    !rmd_msg_has(&m, RMD_FLD_VERSION))
		return false;
	fw = rmd_dialect_for_firmware((uint32_t)m.v[RMD_FLD_VERSION], &certain);
	if (!certain || fw->set_id == rmdctl_dialect(d)->set_id ||
	    rmd_set_id_request(fw, new_id, how) < 0)
		return false;
	tool_log(TOOL_LOG_NOTICE, "%s: its date %" PRId64 " says %s: setting the id as %s does",
		 d->name, m.v[RMD_FLD_VERSION], fw->name, fw->key);
	d->proto = fw->proto;
	return true;
}

/*
 * After the ID write (and the reset, t_reset_ns; 0: none): NEW answers and
 * OLD does not, within SET_ID_WAIT_NS (the boot after a reset: 1.12 s was
 * measured); after a reset NEW's runtime (0xB1, where the dialect has it)
 * must have restarted, so that an answer from before the reset is not
 * taken.  Says which.  Returns an exit status.
 */
static int check_renumbered(struct dev *d, uint8_t old_id, uint8_t new_id, int64_t t_reset_ns)
{
	bool runtime = t_reset_ns && rmd_cmd_find(d->proto, 0xB1);
	int64_t t0 = rmd_now_ns(), until = t0 + SET_ID_WAIT_NS, now;
	bool new_ok = false, old_ok = true;

	do {
		struct req v[2];

		/* V3 §2.28: the runtime restarts at 0 with the firmware */
		rmdctl_req_init(&v[0], new_id, runtime ? 0xB1 : 0x9A);
		rmdctl_req_init(&v[1], old_id, 0x9A);
		if (rmdctl_run_reqs(d, v, 2))
			return RMDCTL_EXIT_DATA;
		now = rmd_now_ns();
		new_ok = v[0].ok && (!runtime || v[0].rep.v[RMD_FLD_RUNTIME] <=
							 (now - t_reset_ns) / 1000000 + 100);
		old_ok = v[1].ok;
		if (new_ok && !old_ok) {
			if (t_reset_ns)
				printf("%s: motor %u is now motor %u (ROM): after the reset id %u "
				       "answers (%.0f ms later%s) and id %u no longer does\n",
				       d->name, old_id, new_id, new_id,
				       (double)(now - t_reset_ns) / 1e6,
				       runtime ? ", its runtime restarted" : "", old_id);
			else
				printf("%s: motor %u is now motor %u (ROM): id %u answers and id %u "
				       "no longer does\n",
				       d->name, old_id, new_id, new_id, old_id);
			return RMDCTL_EXIT_OK;
		}
		if (!new_ok)
			rmdctl_sleep_until(now + SET_ID_POLL_NS);
	} while (now < until && !rmdctl_interrupted);
	tool_log(TOOL_LOG_ERR,
		 "%s: motor %u echoed the new id %u, but within %.1f s%s id %u %s and id %u %s",
		 d->name, old_id, new_id, SET_ID_WAIT_NS / 1e9, t_reset_ns ? " of the reset" : "",
		 new_id, new_ok ? "answers" : "does not answer", old_id,
		 old_ok ? "still answers" : "does not");
	return RMDCTL_EXIT_DATA;
}

int rmdctl_run_set_id(struct dev *d, int argc, char **argv)
{
	uint8_t old_id, new_id, all[RMD_MAX_MOTORS], found[RMD_MAX_MOTORS];
	struct req st[RMD_MAX_MOTORS];
	struct rmd_set_id_req how;
	struct id_cap cap = { 0 };
	struct rmd_txn t;
	bool old_seen = false, new_seen = false;
	int64_t t_reset = 0;
	int m, r;

	(void)argc;
	if (rmdctl_parse_id(argv[0], "OLD id", &old_id) < 0 ||
	    rmdctl_parse_id(argv[1], "NEW id", &new_id) < 0)
		return RMDCTL_EXIT_USAGE;
	if (old_id == new_id) {
		tool_log(TOOL_LOG_ERR, "OLD and NEW are both %u", old_id);
		return RMDCTL_EXIT_USAGE;
	}
	if (rmd_set_id_request(rmdctl_dialect(d), new_id, &how) < 0) {
		tool_log(TOOL_LOG_ERR, "protocol %s sets no CAN ID", rmdctl_dialect(d)->name);
		return RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_open_bus_for(d, true, "write CAN id %u to motor %u on %s", new_id, old_id,
				d->bus_spec);
	if (r)
		return r;
	/* Who is on the bus: V3 §4 sends 0x79 on 0x300, and every motor hears it. */
	m = rmdctl_probe(d, all, rmdctl_all_ids(all), found, st);
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
		tool_log(TOOL_LOG_ERR, "%s: motor %u does not answer 0x9A: nothing to renumber",
			 d->name, old_id);
		goto out;
	}
	if (new_seen) {
		tool_log(TOOL_LOG_ERR, "%s: id %u is taken: a motor answers on it", d->name,
			 new_id);
		goto out;
	}
	r = firmware_rule(d, old_id, new_id, &how);
	if (r)
		goto out;
	/* V3 §4: 0x79 rides on 0x300, to every motor */
	if (how.every_motor) {
		tool_log(TOOL_LOG_ERR,
			 "warning: V3 §4 sends 0x79 on 0x300: every motor on %s whose CAN-ID "
			 "filter is off (0x20 index 2) takes id %u, not only motor %u",
			 d->name, new_id, old_id);
		if (m > 1 && !d->force) {
			tool_log(TOOL_LOG_ERR,
				 "%s: %d motors answer; connect motor %u alone, or turn the "
				 "others' CAN-ID filter on and add --force",
				 d->name, m, old_id);
			r = RMDCTL_EXIT_DATA;
			goto out;
		}
	}
	if (how.then_reset) {
		r = set_id_then_reset(d, old_id, new_id, &how, &t_reset);
		if (r)
			goto out;
		goto renumbered;
	}
	r = rmdctl_confirm(d, "write CAN id %u to motor %u on %s (ROM%s)", new_id, old_id, d->name,
			   how.every_motor ? "; every motor with the CAN-ID filter off hears it" :
					     "");
	if (r)
		goto out;
	r = rmdctl_txn_prepare(&t, d, old_id, &how.write);
	if (r)
		goto out;
	cap.b2_id = rmdctl_dialect(d)->reply_base + old_id;
	r = write_id(d, &t, &cap);
	if (r)
		goto out;
	if (!cap.from && cap.b2.len) {
		r = RMDCTL_EXIT_DATA;
		if (!b2_rule(d, old_id, new_id, &cap.b2, &how) || !how.then_reset)
			goto out;
		r = set_id_then_reset(d, old_id, new_id, &how, &t_reset);
		if (r)
			goto out;
		goto renumbered;
	}
	/* V3 §4.3, V2 §3.52: a write is answered with the request itself (the row's reply layout is a read's). */
	if (!cap.from) {
		struct req q = { .id = old_id, .msg = how.write, .t = t };

		rmdctl_report_missing(d, &q, "");
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (t.done && memcmp(t.rep.f.data, t.req.data, RMD_FRAME_LEN)) {
		tool_log(TOOL_LOG_ERR,
			 "%s: the answer to 0x%02X is not the echo of the request: the id "
			 "may not have changed",
			 d->name, how.write.cmd);
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
renumbered:
	r = check_renumbered(d, old_id, new_id, t_reset);
	if (!r)
		r = others_renumbered(d, found, (unsigned)m, old_id, new_id);
out:
	rmdctl_close_bus(d);
	return r;
}

/*
 * 0x20 function `index` = value to motor id (V3 §2.33, V4.2 §2.34), after
 * a confirmation saying `what`; the reply is the request (§2.34.3).
 * Returns an exit status.
 */
static int function_write(struct dev *d, uint8_t id, uint8_t index, int32_t value, const char *what)
{
	struct req q;
	int r;

	r = rmdctl_open_bus_for(d, true, "%s", what);
	if (r)
		return r;
	r = rmdctl_confirm(d, "%s", what);
	if (r)
		goto out;
	rmdctl_req_init(&q, id, 0x20);
	rmd_msg_set(&q.msg, RMD_FLD_INDEX, index);
	rmd_msg_set(&q.msg, RMD_FLD_VALUE, value);
	r = rmdctl_ask(d, &q);
out:
	rmdctl_close_bus(d);
	return r;
}

/* d's dialect has caps; else "protocol P has no WHAT" is reported.  0 or RMDCTL_EXIT_USAGE. */
static int need_caps(struct dev *d, uint32_t caps, const char *what)
{
	if (rmd_dialect_has(rmdctl_dialect(d), caps))
		return 0;
	tool_log(TOOL_LOG_ERR, "protocol %s has no %s", rmdctl_dialect(d)->name, what);
	return RMDCTL_EXIT_USAGE;
}

/*
 * The WORD argument of a 0x20 function that d's dialect has when it has
 * caps: 0 for word a, 1 for word b; minus the exit status after a refusal
 * ("protocol P has no WHAT", "bad "ARG" (A or B)").
 */
static int function_word(struct dev *d, uint32_t caps, const char *what, const char *arg,
			 const char *a, const char *b)
{
	int r = need_caps(d, caps, what);

	if (r)
		return -r;
	if (!strcmp(arg, a))
		return 0;
	if (!strcmp(arg, b))
		return 1;
	tool_log(TOOL_LOG_ERR, "bad \"%s\" (%s or %s)", arg, a, b);
	return -RMDCTL_EXIT_USAGE;
}

/*
 * V3 §2.33.4 / V4.2 §2.34.4 index 4: the motor keeps its multi-turn count
 * across power off (1), or starts single-turn (0); either after a restart.
 * No command reads it back.
 */
int rmdctl_run_multiturn_save(struct dev *d, int argc, char **argv)
{
	char what[160];
	bool on;
	int r;

	(void)argc;
	r = function_word(d, RMD_DIALECT_MULTI_TURN_SAVE, "multi-turn save (0x20 index 4)", argv[1],
			  "on", "off");
	if (r < 0)
		return -r;
	on = r == 0;
	snprintf(what, sizeof(what),
		 "%s multi-turn save at power off of motor %u on %s (0x20 index 4, ROM; after "
		 "a restart)",
		 on ? "turn on" : "turn off", d->id, d->bus_spec);
	r = function_write(d, d->id, 4, on, what);
	if (!r)
		printf("%s: motor %u: multi-turn save %s; it applies after `rmdctl reset %u` or a "
		       "power cycle (no command reads it back: say multi_turn_saved: %s in "
		       "rmdd.yaml)\n",
		       d->name, d->id, on ? "on" : "off", d->id, on ? "true" : "false");
	return r;
}

/*
 * V4.2 §2.34.4 index 6 / 7: the most positive / negative angle the
 * position modes go to, ROM, at once.  The manual gives no unit: taken as
 * its position commands' 0.01 deg (unverified); no command reads it back.
 */
int rmdctl_run_angle_limit(struct dev *d, int argc, char **argv)
{
	char what[200];
	double deg;
	uint8_t index;
	int r;

	(void)argc;
	r = function_word(d, RMD_DIALECT_ANGLE_LIMITS, "angle limits (V4.2 0x20 index 6/7)",
			  argv[1], "positive", "negative");
	if (r < 0)
		return -r;
	index = (uint8_t)(6 + r);
	if (rmdctl_parse_double(argv[2], &deg) < 0 || !(fabs(deg) <= 2e7)) {
		tool_log(TOOL_LOG_ERR, "bad DEG \"%s\" (degrees at the output)", argv[2]);
		return RMDCTL_EXIT_USAGE;
	}
	snprintf(what, sizeof(what),
		 "set the %s angle limit of motor %u on %s to %.2f deg (0x20 index %u, ROM, at "
		 "once; unit 0.01 deg unverified)",
		 argv[1], d->id, d->bus_spec, deg, index);
	r = function_write(d, d->id, index, (int32_t)llround(deg * 100.0), what);
	if (!r)
		printf("%s: motor %u: %s angle limit %.2f deg written (the manual gives no unit: "
		       "check it with a slow move)\n",
		       d->name, d->id, argv[1], deg);
	return r;
}

int rmdctl_run_set_zero(struct dev *d, int argc, char **argv)
{
	struct req q;
	uint8_t id = d->id;
	int r;

	(void)argc;
	(void)argv;
	r = rmdctl_open_bus_for(d, true, "write the zero of motor %u on %s", id, d->bus_spec);
	if (r)
		return r;
	r = rmdctl_confirm(d, "make the current position of motor %u on %s its zero (ROM)", id,
			   d->name);
	if (r)
		goto out;
	/* V3 §2.10 / V2 §3.25: the current position becomes the zero, in ROM, after a restart. */
	rmdctl_req_init(&q, id, 0x64);
	r = rmdctl_ask(d, &q);
	if (r)
		goto out;
	printf("%s: motor %u: zero offset %" PRId64 " counts written to ROM; it applies after a "
	       "reset (`rmdctl reset %u`) or a power cycle\n",
	       d->name, id, q.rep.v[RMD_FLD_ENCODER_OFF], id);
out:
	rmdctl_close_bus(d);
	return r;
}

int rmdctl_run_set_timeout(struct dev *d, int argc, char **argv)
{
	struct req q;
	uint64_t ms;
	uint8_t id = d->id;
	int r;

	(void)argc;
	if (rmdctl_parse_uint(argv[1], 0, UINT32_MAX, &ms) < 0) {
		tool_log(TOOL_LOG_ERR, "bad MS \"%s\" (0..%" PRIu32 "; 0 turns the protection off)",
			 argv[1], UINT32_MAX);
		return RMDCTL_EXIT_USAGE;
	}
	r = need_caps(d, RMD_DIALECT_COMM_LOSS_B3, "comm-loss protection (0xB3 is V3 §2.30)");
	if (r)
		return r;
	r = rmdctl_open_bus_for(d, true, "write the comm timeout of motor %u on %s", id,
				d->bus_spec);
	if (r)
		return r;
	r = rmdctl_confirm(d,
			   "set the comm-loss protection of motor %u on %s to %" PRIu64 " ms (ROM)",
			   id, d->name, ms);
	if (r)
		goto out;
	/*
	 * V3 §2.30: stored in ROM; the answer echoes the request, or (example
	 * 2) is zeros: the same request and judgement as rmdd's (rmd/proc_arm.h).
	 */
	rmdctl_req_init(&q, id, 0);
	rmd_arm_request((uint32_t)ms, &q.msg);
	r = rmdctl_run_reqs(d, &q, 1);
	if (!r && q.answered && !q.ok &&
	    rmd_arm_b3_outcome(q.t.req.data, &q.t.rep.f) == RMD_CL_ARMED_ZEROS) {
		printf("%s: motor %u: comm-loss protection written to ROM; answered with zeros "
		       "(V3 §2.30 example 2): accepted, the time is not verified\n",
		       d->name, id);
		goto out;
	}
	r = r ? r : rmdctl_ask_check(d, &q);
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
	rmdctl_close_bus(d);
	return r;
}

/* ---- accel, pid ----------------------------------------------------------------------- */

static const char *const accel_names[4] = { "position-accel", "position-decel", "speed-accel",
					    "speed-decel" };

int rmdctl_run_accel(struct dev *d, int argc, char **argv)
{
	const struct rmd_cmd_spec *w = rmd_cmd_find(d->proto, 0x43);
	/* V3 §2.5 writes by index; V2 §3.20 writes its one acceleration */
	bool one_accel = w && !rmd_layout_field(w, RMD_DIR_REQUEST, RMD_FLD_INDEX);
	struct rec rec = { 0 };
	uint64_t index = 0, dps2;
	const char *sval;
	struct req q;
	uint8_t id = d->id;
	int r;

	if (argc == 1) {
		/* V3 §2.4: the position-planning acceleration; V2 §3.19: the one there is. */
		rmdctl_req_init(&q, id, 0x42);
		r = rmdctl_open_bus(d);
		if (r)
			return r;
		r = rmdctl_ask(d, &q);
		rmdctl_close_bus(d);
		if (r)
			return r;
		rmdctl_rec_add_req(&rec, d, &q, true);
		rmdctl_print_rec(d, id, &rec, (const enum rmd_field[]){ RMD_FLD_ACCEL }, 1);
		return RMDCTL_EXIT_OK;
	}
	if (one_accel != (argc == 2)) {
		tool_log(TOOL_LOG_ERR, one_accel ? "V2 writes one acceleration: accel ID DPS2" :
						   "V3 writes by index: accel ID INDEX DPS2");
		return RMDCTL_EXIT_USAGE;
	}
	if (!one_accel) {
		for (index = 0; index < 4 && strcmp(argv[1], accel_names[index]); index++)
			;
		if (index == 4 && rmdctl_parse_uint(argv[1], 0, 3, &index) < 0) {
			tool_log(TOOL_LOG_ERR,
				 "bad INDEX \"%s\" (0 position-accel, 1 position-decel, 2 "
				 "speed-accel, 3 speed-decel)",
				 argv[1]);
			return RMDCTL_EXIT_USAGE;
		}
	}
	sval = argv[argc - 1];
	if (rmdctl_parse_uint(sval, 0, INT32_MAX, &dps2) < 0 ||
	    (!d->force && (dps2 < ACCEL_MIN_DPS2 || dps2 > ACCEL_MAX_DPS2))) {
		tool_log(TOOL_LOG_ERR,
			 "bad DPS2 \"%s\" (%d..%d dps/s, V3 §2.5.1; --force for others)", sval,
			 ACCEL_MIN_DPS2, ACCEL_MAX_DPS2);
		return RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_open_bus_for(d, !one_accel, "write an acceleration of motor %u on %s", id,
				d->bus_spec);
	if (r)
		return r;
	if (!one_accel) {
		r = rmdctl_confirm(d, "set %s of motor %u on %s to %" PRIu64 " dps/s (RAM and ROM)",
				   accel_names[index], id, d->name, dps2);
		if (r)
			goto out;
	}
	/* V3 §2.5: RAM and ROM, by index; V2 §3.20: RAM.  Both echo. */
	rmdctl_req_init(&q, id, 0x43);
	if (!one_accel)
		rmd_msg_set(&q.msg, RMD_FLD_INDEX, (int64_t)index);
	rmd_msg_set(&q.msg, RMD_FLD_ACCEL, (int64_t)dps2);
	r = rmdctl_ask(d, &q);
	if (r)
		goto out;
	if (d->json)
		printf("{\"bus\":\"%s\",\"motor_id\":%u,\"protocol\":\"%s\",\"index\":%" PRIu64
		       ",\"accel_dps2\":%" PRIu64 "}\n",
		       d->name, id, rmd_proto_name(d->proto), index, dps2);
	else
		printf("%s: motor %u: %s %" PRIu64 " dps/s written (%s), echo verified\n", d->name,
		       id, one_accel ? "acceleration" : accel_names[index], dps2,
		       one_accel ? "RAM" : "RAM and ROM");
out:
	rmdctl_close_bus(d);
	return r;
}

unsigned rmdctl_pid_read_reqs(const struct dev *d, uint8_t id, struct req *q)
{
	struct rmd_pid_set all = { .slots = UINT32_MAX };
	struct rmd_msg m[RMD_PID_SLOTS_MAX];
	int n = rmd_pid_requests(rmdctl_dialect(d), RMD_PID_READ, &all, m);

	for (int i = 0; i < n; i++) {
		rmdctl_req_init(&q[i], id, m[i].cmd);
		q[i].msg = m[i];
	}
	return n > 0 ? (unsigned)n : 0;
}

unsigned rmdctl_pid_gather(struct dev *d, const struct req *q, unsigned n, struct rmd_pid_set *got)
{
	const struct rmd_dialect *dl = rmdctl_dialect(d);
	unsigned bad = 0;

	got->slots = 0;
	for (unsigned i = 0; i < n; i++) {
		struct rmd_pid_set asked, carried;
		uint32_t named, has;
		enum rmd_pid_op op;

		if (!q[i].ok || !rmd_pid_parse(dl, &q[i].msg, &op, &named, &asked) ||
		    op != RMD_PID_READ)
			continue;
		rmd_pid_parse(dl, &q[i].rep, &op, &has, &carried);
		if (named & ~carried.slots) {
			/* V4.2 §2.1.3: the answer names its index: it must be the one asked */
			if (rmd_msg_has(&q[i].msg, RMD_FLD_INDEX))
				tool_log(TOOL_LOG_ERR,
					 "%s: motor %u answered 0x%02X index %" PRId64
					 " with index %" PRId64,
					 d->name, q[i].id, q[i].msg.cmd, q[i].msg.v[RMD_FLD_INDEX],
					 q[i].rep.v[RMD_FLD_INDEX]);
			else
				tool_log(TOOL_LOG_ERR,
					 "%s: motor %u answered 0x%02X without its gains", d->name,
					 q[i].id, q[i].msg.cmd);
			bad++;
			continue;
		}
		for (unsigned k = 0; k < dl->n_pid_slots && k < RMD_PID_SLOTS_MAX; k++)
			if (named & (UINT32_C(1) << k))
				got->raw[k] = carried.raw[k];
		got->slots |= named;
	}
	return bad;
}

/* The fields of the dialect's gains, in its order, into f; their count. */
static unsigned pid_order(const struct rmd_dialect *dl, enum rmd_field f[RMD_PID_SLOTS_MAX])
{
	unsigned n = 0;

	for (unsigned i = 0; i < dl->n_pid_slots && n < RMD_PID_SLOTS_MAX; i++)
		f[n++] = (enum rmd_field)dl->pid_slots[i].field;
	return n;
}

/* V3 §2.1 (one 0x30), V2 §3.1 (a read a gain), V4.2 §2.1 (0x30 by index): every gain. */
static int pid_read(struct dev *d, uint8_t id)
{
	enum rmd_field order[RMD_PID_SLOTS_MAX];
	struct req q[RMD_PID_SLOTS_MAX];
	struct rmd_pid_set got;
	struct rec rec = { 0 };
	unsigned n = rmdctl_pid_read_reqs(d, id, q);
	int r;

	if (!n) {
		tool_log(TOOL_LOG_ERR, "protocol %s has no PID commands", rmdctl_dialect(d)->name);
		return RMDCTL_EXIT_USAGE;
	}
	r = rmdctl_exchange(d, q, n);
	if (r)
		return r;
	if (rmdctl_report_failed(d, q, n) || rmdctl_pid_gather(d, q, n, &got))
		return RMDCTL_EXIT_DATA;
	rmdctl_rec_add_gains(&rec, d, &got);
	rmdctl_print_rec(d, id, &rec, order, pid_order(rmdctl_dialect(d), order));
	return RMDCTL_EXIT_OK;
}

/* Whether dl's gains go one a frame by index (V4.2 §2.1.4): its messages count them. */
static bool gains_by_index(const struct rmd_dialect *dl)
{
	return dl->n_pid_slots && dl->pid_slots[0].index;
}

/*
 * Gain g in the unit of field fs: V4.2 §2.2.2 a binary32 (negative or
 * non-finite gains make no sense), V3 §2.2 uint8 integers, V2 §3.7 Q24
 * reals; what is allowed in `allowed` when it is not.
 */
static bool gain_ok(const struct rmd_field_spec *fs, double g, char *allowed, size_t size)
{
	int64_t lo, hi;

	if (fs->is_float) {
		snprintf(allowed, size, "a real >= 0");
		return g >= 0 && g <= 3.4e38;
	}
	rmd_field_range(fs, &lo, &hi);
	if (fs->scale == 1.0) {
		snprintf(allowed, size, "an integer 0..%" PRId64, hi);
		return g >= 0 && g <= (double)hi && g == floor(g);
	}
	snprintf(allowed, size, "a real 0..%" PRId64 " (Q%.0f)",
		 (int64_t)floor((double)hi * fs->scale), -log2(fs->scale));
	return g >= 0 && g < ((double)hi + 1.0) * fs->scale;
}

int rmdctl_run_pid(struct dev *d, int argc, char **argv)
{
	const struct rmd_dialect *dl = rmdctl_dialect(d);
	/* V4.2 §2.1.4: the seventh gain, the position KD, may be left out */
	bool kd_optional = dl->n_pid_slots &&
			   dl->pid_slots[dl->n_pid_slots - 1].field == RMD_FLD_POS_KD;
	enum rmd_field order[RMD_PID_SLOTS_MAX];
	struct rmd_msg m[RMD_PID_SLOTS_MAX];
	struct req q[RMD_PID_SLOTS_MAX];
	double g[RMD_PID_SLOTS_MAX];
	struct rmd_pid_set set = { 0 };
	int n = argc - 1, nq;
	uint8_t id = d->id;
	int r;

	if (argc == 1) {
		if (d->rom) {
			tool_log(TOOL_LOG_ERR, "--rom applies to writing gains");
			return RMDCTL_EXIT_USAGE;
		}
		return pid_read(d, id);
	}
	if (!dl->n_pid_slots) {
		tool_log(TOOL_LOG_ERR, "protocol %s has no PID commands", dl->name);
		return RMDCTL_EXIT_USAGE;
	}
	if (n != (int)dl->n_pid_slots && !(kd_optional && n == (int)dl->n_pid_slots - 1)) {
		if (kd_optional)
			tool_log(TOOL_LOG_ERR,
				 "give the gains: CURR_KP CURR_KI SPD_KP SPD_KI POS_KP POS_KI "
				 "[POS_KD] (%s: reals)",
				 dl->name);
		else
			tool_log(TOOL_LOG_ERR,
				 "give all six gains: CURR_KP CURR_KI SPD_KP SPD_KI POS_KP POS_KI");
		return RMDCTL_EXIT_USAGE;
	}
	for (int i = 0; i < n; i++) {
		const struct rmd_field_spec *fs = rmd_pid_spec(dl, (unsigned)i);
		char allowed[48] = "";

		if (rmdctl_parse_double(argv[1 + i], &g[i]) < 0 || !fs ||
		    !gain_ok(fs, g[i], allowed, sizeof(allowed))) {
			tool_log(TOOL_LOG_ERR, "bad gain \"%s\" (%s)", argv[1 + i], allowed);
			return RMDCTL_EXIT_USAGE;
		}
	}
	for (int i = 0; i < n; i++) {
		if (rmd_field_from_native(rmd_pid_spec(dl, (unsigned)i), g[i], &set.raw[i]) < 0) {
			tool_log(TOOL_LOG_ERR, "gain %g does not fit 0x%02X", g[i],
				 dl->pid_slots[i]
					 .cmd[d->rom ? RMD_PID_WRITE_ROM : RMD_PID_WRITE_RAM]);
			return RMDCTL_EXIT_USAGE;
		}
		set.slots |= UINT32_C(1) << i;
	}
	/* V3 §2.2 / §2.3: six in one frame; V2 §3.7 .. §3.18, V4.2 §2.2 / §2.3: one a frame */
	nq = rmd_pid_requests(dl, d->rom ? RMD_PID_WRITE_ROM : RMD_PID_WRITE_RAM, &set, m);
	for (int i = 0; i < nq; i++) {
		rmdctl_req_init(&q[i], id, m[i].cmd);
		q[i].msg = m[i];
	}
	r = rmdctl_open_bus_for(d, d->rom, "write the PID gains of motor %u on %s to ROM", id,
				d->bus_spec);
	if (r)
		return r;
	if (d->rom && (gains_by_index(dl) || n != 6))
		r = rmdctl_confirm(d, "write %d PID gains to motor %u on %s (ROM)", n, id, d->name);
	else if (d->rom)
		r = rmdctl_confirm(d, "write PID gains %g %g %g %g %g %g to motor %u on %s (ROM)",
				   g[0], g[1], g[2], g[3], g[4], g[5], id, d->name);
	if (r)
		goto out;
	r = rmdctl_run_reqs(d, q, (unsigned)nq);
	if (r)
		goto out;
	if (rmdctl_report_failed(d, q, (unsigned)nq)) {
		r = RMDCTL_EXIT_DATA;
		goto out;
	}
	if (d->json) {
		struct rec rec = { 0 };

		rmdctl_rec_add_gains(&rec, d, &set);
		pid_order(dl, order);
		rmdctl_print_rec(d, id, &rec, order, (size_t)n);
	} else if (gains_by_index(dl)) {
		printf("%s: motor %u: %d PID gains written to %s, each echoed\n", d->name, id, n,
		       d->rom ? "RAM and ROM" : "RAM (lost at power off; --rom keeps them)");
	} else {
		printf("%s: motor %u: PID gains written to %s, echo verified\n", d->name, id,
		       d->rom ? "RAM and ROM" : "RAM (lost at power off; --rom keeps them)");
	}
out:
	rmdctl_close_bus(d);
	return r;
}
