// SPDX-License-Identifier: MIT
/*
 * Bring-up, before the rt thread starts: probe every configured motor
 * (model 0xB5, version 0xB2, status 0x9A), scan each bus for ids that
 * answer but are not configured, and write each motor's comm-loss
 * protection (0xB3), whose outcome the loop takes over (lifecycle.c).
 * Every request goes through rmd_txn_run(), the one request/reply engine;
 * the result is data (rmd/bringup.h).
 *
 * Non-rt: blocks on the buses for a bounded time.
 */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "rmd/bringup.h"
#include "rmd/time.h"
#include "rmd/txn.h"
#include "loop_state.h"
#include "loop_env.h"

/* What the txn hooks need: the loop's clock, and the bus for stray frames. */
struct probe_ctx {
	struct rmd_loop *l;
	unsigned bus;
};

/* The loop's clock, for rmd_txn_opts.now_ns.  Non-rt. */
static int64_t ctx_now(void *ctx)
{
	return loop_now(((struct probe_ctx *)ctx)->l);
}

/* The loop's sleep, for rmd_txn_opts.sleep_ns (set only with an injected clock).  Non-rt. */
static void ctx_sleep(void *ctx, int64_t ns)
{
	struct probe_ctx *pc = ctx;

	loop_wait_bus(pc->l, pc->l->bus[pc->bus].bus, ns);
}

/* Whether bring-up itself asks motor lm for `cmd` (its probes, 0x9A, V2's 0x92).  Non-rt. */
static bool bringup_asks(const struct lmotor *lm, uint8_t cmd)
{
	for (unsigned k = 0; k < lm->m.d->n_probes; k++)
		if (lm->m.d->probe[k] == cmd)
			return true;
	return cmd == 0x9A || (cmd == RMD_MOTOR_CMD_FINE_POS &&
			       rmd_dialect_has(lm->m.d, RMD_DIALECT_ENCODER_UNWRAP));
}

/*
 * A motor the configuration does not list answered on identifier id: one a
 * 0x280 frame would command (rmd_dialect_takes_280()) is a stray of the
 * bus, the first one's identifier kept.  Non-rt.
 */
static void note_stray(struct lbus *lb, uint32_t id)
{
	uint8_t sid;

	if (!rmd_dialect_takes_280(id, &sid))
		return;
	lb->stray_ids |= 1u << (sid - 1);
	if (!lb->stray_id)
		lb->stray_id = id;
}

/* A frame that answers no request: remember ids that are not configured.  Non-rt. */
static void probe_stray(void *ctx, const struct rmd_bus_rx *rx)
{
	struct probe_ctx *pc = ctx;
	uint32_t id = rx->f.can_id;
	unsigned mid = 0;

	struct lmotor *lm = loop_motor_of(pc->l, pc->bus, id);

	if (lm) {
		/*
		 * A configured motor's frame nobody asked for: a pushed reply
		 * (0xB6)?  Not one bring-up asks for itself (0x9A, its
		 * probes): those may be the late answer of an earlier try.
		 */
		int k = rx->f.len ? rmd_silence_pushable(lm->m.d, rx->f.data[0]) : -1;

		if (k >= 0 && !bringup_asks(lm, rx->f.data[0]))
			lm->sil.pushed |= (uint8_t)(1u << k);
		return;
	}
	/* a configured motor answering in another dialect than asked (protocol: auto) */
	for (unsigned i = 0; i < pc->l->n_motors; i++)
		if (pc->l->mot[i].m.bus == pc->bus &&
		    (id == RMD_CAN_REQ_BASE + pc->l->mot[i].m.id ||
		     id == RMD_CAN_V3_REPLY_BASE + pc->l->mot[i].m.id))
			return;
	if (id > RMD_CAN_V3_REPLY_BASE && id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_V3_REPLY_BASE;
	else if (id > RMD_CAN_REQ_BASE && id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_REQ_BASE;
	else if (id > RMD_CAN_MIT_REPLY_BASE && id <= RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_MIT_REPLY_BASE;
	if (mid)
		pc->l->bus[pc->bus].unexpected_ids |= 1u << (mid - 1);
	note_stray(&pc->l->bus[pc->bus], id);
}

/* Options of one bring-up transaction on bus b: the loop's clock, strays noted.  Non-rt. */
static struct rmd_txn_opts txn_opts(struct probe_ctx *pc, unsigned tries, int64_t timeout_ns)
{
	const struct rmd_loop *l = pc->l;

	return (struct rmd_txn_opts){
		.timeout_ns = timeout_ns,
		.tries = tries,
		.now_ns = ctx_now,
		.sleep_ns = l->o.sleep_ns ? ctx_sleep : NULL,
		.clock_ctx = pc,
		.unmatched = probe_stray,
		.unmatched_ctx = pc,
	};
}

/* Round trips a bus's requests wait once it has answered some (RMD_LOOP_PROBE_TIMEOUT_NS at least). */
#define RTT_WAITS 4

/*
 * The wait of one try on bus lb: probe.reply_timeout_ms until motors of
 * the bus answered, then RTT_WAITS of the longest round trip measured on
 * it (no less than RMD_LOOP_PROBE_TIMEOUT_NS, no more than the bound) --
 * except for a ROM write (`rom`), which firmware may take its time over;
 * never less than the transport's own reply timeout plus 1 ms.  Non-rt.
 */
static int64_t probe_timeout_ns(const struct rmd_loop *l, const struct lbus *lb, bool rom)
{
	int64_t bound = (int64_t)l->cfg->probe.reply_timeout_ms * RMD_NS_PER_MS;
	int64_t t = rmd_bus_caps(lb->bus)->reply_timeout_ns, w = bound;

	if (lb->rtt_n && !rom) {
		w = RTT_WAITS * lb->rtt_max_ns;
		if (w < RMD_LOOP_PROBE_TIMEOUT_NS)
			w = RMD_LOOP_PROBE_TIMEOUT_NS;
		if (w > bound)
			w = bound;
	}
	if (t && w < t + RMD_NS_PER_MS)
		w = t + RMD_NS_PER_MS;
	return w;
}

/*
 * The tries of t that were given up -- all of them when it was not
 * answered, all but one when it was -- and the guards sent ahead of them
 * that were not answered (struct rmd_txn.guards_owed) may still be
 * answered: the loop counts such answers late, not unexpected, and
 * bring-up takes no round trip from them (loop_gone()).  Non-rt.
 */
static void give_up_tries(struct lmotor *lm, const struct rmd_txn *t)
{
	unsigned n = t->no_reply ? 0u : t->tries - (t->done ? 1u : 0u);
	uint64_t key = loop_reply_key(t->reply_id, t->reply_cmd);

	for (unsigned k = 0; k < n && k < GONE; k++)
		loop_gone(lm, key, t->first_sent_ns);
	for (unsigned k = 0; k < t->guards_owed && k < GONE; k++)
		loop_gone(lm, loop_reply_key(t->reply_id, RMD_TXN_GUARD_CMD), t->first_sent_ns);
}

/*
 * May lm still owe the answer of a try given up (give_up_tries()) that
 * answers like t?  Bring-up does not tell which of them came (the loop
 * does, loop_rx.c), and a motor answers in order: what answered t may be
 * that one.  Non-rt.
 */
static bool owes_like(const struct lmotor *lm, const struct rmd_txn *t)
{
	uint64_t key = loop_reply_key(t->reply_id, t->reply_cmd);

	for (unsigned k = 0; k < GONE; k++)
		if (lm->gone[k].key == key)
			return true;
	return false;
}

/*
 * What the answer of t, a request to lm, tells of its bus's round trip.
 * Not a measure: an answer after a retry (it may be any try's), one an
 * earlier request's late answer may have stood in for, or a request
 * that went out behind its guard (a half-duplex line writes it only when
 * the guard is answered: the time holds two round trips).  Non-rt.
 */
static void learn_rtt(struct lbus *lb, const struct lmotor *lm, const struct rmd_txn *t)
{
	int64_t rtt = t->rep.t_ns - t->first_sent_ns;

	if (!t->done || t->no_reply || t->tries != 1 || t->guard_sent || rtt < 0 ||
	    owes_like(lm, t))
		return;
	if (!lb->rtt_n || rtt < lb->rtt_min_ns)
		lb->rtt_min_ns = rtt;
	if (!lb->rtt_n || rtt > lb->rtt_max_ns)
		lb->rtt_max_ns = rtt;
	lb->rtt_n++;
}

/*
 * One request msg to motor lm and its answer (t->req, t->rep), tried
 * `tries` times, waiting timeout_ns each.  Returns 0, -ETIMEDOUT, or
 * another -errno.  Non-rt.
 */
static int probe_xfer_as(struct rmd_loop *l, struct lmotor *lm, const struct rmd_msg *msg,
			 struct rmd_txn *t, unsigned tries, int64_t timeout_ns)
{
	struct probe_ctx pc = { .l = l, .bus = lm->m.bus };
	struct lbus *lb = &l->bus[lm->m.bus];
	struct rmd_txn_opts o;
	int r;

	r = rmd_txn_prepare(t, lm->m.proto, lm->m.id, msg);
	if (r < 0)
		return r;
	o = txn_opts(&pc, tries, timeout_ns);
	r = rmd_txn_run(lb->bus, t, 1, &o);
	if (r < 0)
		return r;
	learn_rtt(lb, lm, t);
	give_up_tries(lm, t);
	return t->done ? 0 : -ETIMEDOUT;
}

/* probe_xfer_as() RMD_LOOP_PROBE_TRIES times, the bus's probe wait each.  Non-rt. */
static int probe_xfer(struct rmd_loop *l, struct lmotor *lm, const struct rmd_msg *msg,
		      struct rmd_txn *t)
{
	return probe_xfer_as(l, lm, msg, t, RMD_LOOP_PROBE_TRIES,
			     probe_timeout_ns(l, &l->bus[lm->m.bus], false));
}

/* Ask lm for `cmd` (no arguments), as probe_xfer_as(), and decode the answer.  Non-rt. */
static int probe_cmd_as(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd, unsigned tries,
			int64_t timeout_ns, struct rmd_motor_reply *r)
{
	struct rmd_msg msg = { .cmd = cmd };
	struct rmd_txn t;
	int ret;

	ret = probe_xfer_as(l, lm, &msg, &t, tries, timeout_ns);
	if (ret < 0)
		return ret;
	return rmd_motor_decode(&lm->m, &t.rep.f, r) < 0 ? -EBADMSG : 0;
}

/* Ask lm for `cmd` (no arguments) and decode the answer.  Non-rt. */
static int probe_cmd(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd, struct rmd_motor_reply *r)
{
	return probe_cmd_as(l, lm, cmd, RMD_LOOP_PROBE_TRIES,
			    probe_timeout_ns(l, &l->bus[lm->m.bus], false), r);
}

/*
 * lm's firmware date (0xB2, V3 §2.29) into out->version.  The date decides its dialect and the V4.4 MIT scaling: an answer that
 * came after its tries (a slow adapter, a busy motor) is no reason to go
 * on without it, so it is asked once more, waiting the whole
 * probe.reply_timeout_ms (out->version_again; issue 32 point 17).  Returns
 * 0 when read (r holds the answer).  Non-rt.
 */
static int read_date(struct rmd_loop *l, struct lmotor *lm, struct rmd_bringup_motor *out,
		     struct rmd_motor_reply *r)
{
	if (probe_cmd(l, lm, 0xB2, r) < 0 || !(r->have & RMD_MOTOR_HAVE_VERSION)) {
		out->version_again = true;
		if (probe_cmd_as(l, lm, 0xB2, 1, probe_timeout_ns(l, &l->bus[lm->m.bus], true), r) <
			    0 ||
		    !(r->have & RMD_MOTOR_HAVE_VERSION))
			return -ETIMEDOUT;
	}
	out->version = lm->ident.version = r->version_date;
	/* before its status read: what its 0x9A says depends on them */
	lm->m.quirks = rmd_firmware_quirks(r->version_date);
	return 0;
}

/*
 * The frames debt o owes (rmd/proc_owed.h: 0x80, 0x78), each sent once in
 * its turn and its echo judged; `apply`: o is lm's own, whose outcomes
 * the lifecycle applies (loop_owed_answer()).  Non-rt.
 */
static void send_owed(struct rmd_loop *l, struct lmotor *lm, struct rmd_owed *o, bool apply)
{
	uint8_t cmd;

	for (unsigned k = 0; k < 2 && (cmd = rmd_owed_next(o)); k++) {
		struct rmd_msg msg = { .cmd = cmd };
		struct rmd_txn t;
		bool echo;

		rmd_owed_sent(o, cmd);
		if (probe_xfer(l, lm, &msg, &t) < 0)
			continue;
		echo = rmd_frame_repeats(t.req.data, false, &t.rep.f);
		if (apply)
			loop_owed_answer(l, lm, cmd, o->seq, echo, loop_now(l));
		else
			rmd_owed_answer(o, cmd, o->seq, echo);
	}
}

/*
 * A motor found may run for a previous owner: output off (0x80, V3 §2.15)
 * and brake locked (0x78, V3 §2.27), each awaited for its echo (txn puts
 * a status read ahead of it, rmd/txn.h), pay what STOPPING owes
 * (lifecycle.c "Owed frames"); what bring-up could not get echoed, the
 * loop sends until it is.  Non-rt.
 */
static void stop_found(struct rmd_loop *l, struct lmotor *lm)
{
	loop_enter(l, lm, RMD_LC_STOPPING, loop_now(l));
	send_owed(l, lm, &lm->owed, true);
}

/*
 * Motor i speaks dialect `proto` from now on: its record rebuilt, the
 * loop's routing moved to the identifiers that dialect answers on.
 * Non-rt.
 */
static int use_dialect(struct rmd_loop *l, unsigned i, enum rmd_proto proto)
{
	struct lmotor *lm = &l->mot[i];
	struct lbus *lb = &l->bus[lm->m.bus];
	enum rmd_proto was = lm->m.proto;
	int r;

	if (lm->m.proto == proto)
		return 0;
	*lbus_slot(lb, lm->m.reply_id) = 0;
	*lbus_slot(lb, rmd_motor_ctl_reply_id(&lm->m)) = 0;
	r = rmd_motor_set_dialect(&lm->m, &l->cfg->motors[i], proto);
	/* a record that cannot be built leaves the one it had, not a cleared one */
	if (r < 0)
		rmd_motor_set_dialect(&lm->m, &l->cfg->motors[i], was);
	*lbus_slot(lb, lm->m.reply_id) = (uint8_t)(i + 1);
	*lbus_slot(lb, rmd_motor_ctl_reply_id(&lm->m)) = (uint8_t)(i + 1);
	return r;
}

/*
 * `protocol: auto`: which dialect motor i answers in.  Each firmware
 * dialect (MIT is a way of driving firmware, rmd_dialect_is_firmware())
 * asks its first probe, one request per distinct probe and
 * reply identifier, in the list's order; the first to be answered is the
 * motor's family, and its firmware date (0xB2) picks the generation
 * within it (rmd_dialect_for_firmware()).  Returns 0 with the motor
 * switched, or -ENODEV when nothing answered (the motor stays V3).
 * Non-rt.
 */
static int resolve_auto(struct rmd_loop *l, unsigned i, struct rmd_bringup_motor *out)
{
	struct lmotor *lm = &l->mot[i];
	size_t n;
	const struct rmd_dialect *list = rmd_dialect_list(&n);
	uint32_t tried[RMD_PROTO_COUNT];
	unsigned n_tried = 0;
	struct rmd_motor_reply r;

	for (size_t k = 0; k < n; k++) {
		const struct rmd_dialect *d = &list[k];
		uint32_t key = (uint32_t)d->reply_base << 8 | d->probe[0];
		bool seen = false;

		if (!rmd_dialect_is_firmware(d))
			continue;
		for (unsigned j = 0; j < n_tried; j++)
			seen |= tried[j] == key;
		if (seen)
			continue;
		tried[n_tried++] = key;
		if (use_dialect(l, i, d->proto) < 0)
			continue;
		if (probe_cmd(l, lm, d->probe[0], &r) < 0)
			continue;
		out->auto_certain = !rmd_dialect_has(d, RMD_DIALECT_VERSION_B2);
		if (rmd_dialect_has(d, RMD_DIALECT_VERSION_B2) && read_date(l, lm, out, &r) == 0) {
			const struct rmd_dialect *fw =
				rmd_dialect_for_firmware(r.version_date, &out->auto_certain);

			if (fw->reply_base == d->reply_base)
				use_dialect(l, i, fw->proto);
		}
		return 0;
	}
	use_dialect(l, i, RMD_PROTO_V3);
	return -ENODEV;
}

/*
 * What in the configuration of motor i its dialect cannot do, or
 * RMD_BRINGUP_MISMATCH_NONE: the configured dialect against the one its
 * firmware date says (`protocol: mit` is V3 firmware's); for `protocol:
 * auto`, what the loader would have refused had the file named the
 * dialect found (comm-loss protection, fine feedback, MIT mode).  Non-rt.
 */
static enum rmd_bringup_mismatch mismatch_of(const struct rmd_loop *l, unsigned i,
					     const struct rmd_bringup_motor *bm)
{
	const struct rmd_config_motor *c = &l->cfg->motors[i];
	const struct rmd_dialect *d = l->mot[i].m.d, *fw;

	if (!c->proto_auto && bm->version && rmd_dialect_other_firmware(d, bm->version, &fw))
		return RMD_BRINGUP_MISMATCH_FIRMWARE;
	/*
	 * The loader refuses these for a configured dialect; a program that
	 * builds such a configuration gets the loop's own answer (an
	 * unprotected motor is never enabled: lifecycle.c)
	 */
	if (!c->proto_auto)
		return RMD_BRINGUP_MISMATCH_NONE;
	if (!rmd_dialect_has(d, RMD_DIALECT_COMM_LOSS_B3) && rmd_config_comm_loss_ms(l->cfg, i))
		return RMD_BRINGUP_MISMATCH_NO_COMM_LOSS;
	if (c->feedback.position == RMD_FEEDBACK_MULTI_TURN &&
	    !rmd_dialect_has(d, RMD_DIALECT_FINE_ANGLE))
		return RMD_BRINGUP_MISMATCH_NO_FINE_ANGLE;
	if (rmd_config_mit_mode(c) && !rmd_dialect_offers_mit(d))
		return RMD_BRINGUP_MISMATCH_NO_MIT;
	return RMD_BRINGUP_MISMATCH_NONE;
}

/*
 * Motor i in MIT mode: its MIT scaling, decided from its firmware's date
 * and model as the probes read them (out->version, out->model) and its
 * entry's `mit` ranges (rmd_mit_scaling_decide()), into its record and
 * out->mit; no MIT frame goes out before.  False when none can be
 * decided.  Non-rt.
 */
static bool decide_mit(struct rmd_loop *l, unsigned i, struct rmd_bringup_motor *out)
{
	const struct rmd_config_motor *c = &l->cfg->motors[i];
	struct rmd_motor *m = &l->mot[i].m;

	if (!m->mit_mode)
		return true;
	out->mit_mode = true;
	rmd_mit_scaling_decide(m->d, out->version, out->model, &c->mit, c->mit_given, &out->mit);
	if (rmd_mit_decided(&out->mit) && rmd_motor_set_mit(m, &out->mit.r) == 0)
		return true;
	rmd_motor_set_mit(m, NULL);
	return false;
}

/*
 * V4.2 §2.33: a motor left in active-reply mode (0xB6) by another tool
 * pushes the chosen replies every n x 10 ms and no longer answers those
 * reads.  Turn every one off, in one send, right after the motor answered
 * its first probe (so it is awake: a motor whose comm-loss protection
 * tripped echoes, not executes, the first command it gets, and that was
 * the probe).  No answer is awaited: the manual gives none for off.  True
 * when the bus took all of them.  Non-rt.
 */
static bool reports_off(struct rmd_loop *l, struct lmotor *lm)
{
	struct lbus *lb = &l->bus[lm->m.bus];
	const struct rmd_dialect *d = lm->m.d;
	struct rmd_frame f[8];
	unsigned n = 0;
	int sent = 0;

	for (unsigned k = 0; k < d->n_report_cmds && k < 8; k++)
		if (loop_report_off(lm, k, &f[n]) == 0)
			n++;
	/* the bus takes what it can now, the rest as it drains (bounded) */
	for (unsigned tries = 0; (unsigned)sent < n && tries < 100; tries++) {
		int r = rmd_bus_send(lb->bus, f + sent, n - (unsigned)sent, loop_now(l));

		if (r < 0)
			return false;
		sent += r;
		if ((unsigned)sent < n)
			loop_wait_bus(l, lb->bus, RMD_NS_PER_MS);
	}
	return n == d->n_report_cmds && (unsigned)sent == n;
}

/*
 * lm did not answer its first probe: missing, LOST, probed again by the
 * first cycle -- its firmware date first where its dialect has one, never
 * checked here (struct lmotor.dialect_open).  Returns -ENODEV.  Non-rt.
 */
static int missing(struct rmd_loop *l, struct lmotor *lm, struct rmd_bringup_motor *out)
{
	int64_t now = loop_now(l);

	out->state = RMD_BRINGUP_MISSING;
	loop_enter(l, lm, RMD_LC_LOST, now);
	rmd_ident_open(&lm->ident, lm->m.d);
	/* decided from its firmware when it answers (loop_rx.c settle_dialect()) */
	if (lm->m.mit_mode)
		rmd_motor_set_mit(&lm->m, NULL);
	lm->life.next_probe_ns = now;
	return -ENODEV;
}

/* Probe motor i into *out.  Returns 0, or -ENODEV when it is missing.  Non-rt. */
static int probe_motor(struct rmd_loop *l, unsigned i, struct rmd_bringup_motor *out)
{
	struct lmotor *lm = &l->mot[i];
	const struct rmd_dialect *d;
	struct rmd_motor_reply r;
	int64_t now;

	memset(out, 0, sizeof(*out));
	out->tries = RMD_LOOP_PROBE_TRIES;
	out->timeout_ns = probe_timeout_ns(l, &l->bus[lm->m.bus], false);
	out->proto_auto = l->cfg->motors[i].proto_auto;
	if (out->proto_auto && resolve_auto(l, i, out) < 0) {
		out->probe_cmd = lm->m.d->probe[0];
		return missing(l, lm, out); /* taken for V3 until it answers */
	}
	d = lm->m.d;
	out->proto = lm->m.proto;
	/*
	 * The dialect's probes in order (V3: model 0xB5, firmware date 0xB2,
	 * status 0x9A; V2 has no model or version query: its status answers).
	 * The first tells whether the motor is there.
	 */
	for (unsigned k = 0; k < d->n_probes; k++) {
		uint8_t cmd = d->probe[k];
		int pr = cmd == 0xB2 && k ? read_date(l, lm, out, &r) : probe_cmd(l, lm, cmd, &r);

		if (k == 0) {
			out->probe_cmd = cmd;
			if (pr < 0)
				return missing(l, lm, out);
			/* it is there: what it may push unasked goes off before the reads */
			if (rmd_dialect_has(d, RMD_DIALECT_ACTIVE_REPLY))
				out->reports_off = reports_off(l, lm);
		}
		if (pr < 0)
			continue;
		if (r.have & RMD_MOTOR_HAVE_MODEL) {
			snprintf(lm->ident.model, sizeof(lm->ident.model), "%s", r.model);
			memcpy(out->model, lm->ident.model, sizeof(out->model));
		}
		if (r.have & RMD_MOTOR_HAVE_VERSION)
			out->version = lm->ident.version = r.version_date;
		if (cmd == 0x9A) { /* V3 §2.12 / V2 §3.31 status 1 */
			rmd_motor_apply(&r, lm->st);
			out->status = true;
			out->voltage_v = r.voltage_v;
			out->temp_c = r.temp_c;
			out->error_code = r.error_code;
		}
	}
	if (rmd_dialect_has(d, RMD_DIALECT_ENCODER_UNWRAP)) {
		/* V2 §3.29: the multi-turn angle anchors the unwrapped encoder */
		if (probe_cmd(l, lm, 0x92, &r) == 0 && (r.have & RMD_MOTOR_HAVE_POS)) {
			rmd_motor_set_v2_reference(
				&lm->m, rmd_motor_to_native_pos(&lm->m, r.pos_rad), loop_now(l));
			out->v2_angle = true;
		}
	}
	now = loop_now(l);
	lm->m.quirks = rmd_firmware_quirks(out->version);
	out->pushed = lm->sil.pushed;
	out->mismatch = mismatch_of(l, i, out);
	if (out->mismatch == RMD_BRINGUP_MISMATCH_NONE && !decide_mit(l, i, out))
		out->mismatch = RMD_BRINGUP_MISMATCH_MIT_SCALING;
	if (out->mismatch != RMD_BRINGUP_MISMATCH_NONE) {
		if (lm->m.mit_mode)
			rmd_motor_set_mit(&lm->m, NULL);
		/*
		 * Never driven, never re-probed: the configuration must change.
		 * What it may run for a previous owner stops all the same: the
		 * stop frames are the same in every dialect (V2 §3.34, §3.51),
		 * a debt of its own that no lifecycle applies.
		 */
		struct rmd_owed off;

		rmd_owed_begin(&off, RMD_OWE_OFF | RMD_OWE_BRAKE, lm->seq);
		send_owed(l, lm, &off, false);
		out->state = RMD_BRINGUP_MISMATCH;
		loop_enter(l, lm, RMD_LC_LOST, now);
		lm->ident.refused = true;
		lm->life.next_probe_ns = INT64_MAX;
		return -ENODEV;
	}
	lm->consecutive = 0;
	stop_found(l, lm);
	now = loop_now(l);
	if (lm->st->error_code)
		loop_note_errors(l, lm, 0, now);
	out->state = lm->st->error_code ? RMD_BRINGUP_FAULT : RMD_BRINGUP_FOUND;
	return 0;
}

/*
 * Ask every id that is not configured on bus b for its status (0x9A, read
 * only; V3 §2.12 on 0x140 + ID, which V2 motors take as well), all at
 * once, and note who answers, on whatever identifier.  Bounded: one try,
 * RMD_LOOP_PROBE_TIMEOUT_NS plus the requests' spacing on the bus; on a
 * bus whose V2 motors share a 0x280 frame, which a motor found here would
 * take for its own command, RMD_LOOP_PROBE_TRIES of them: one late answer
 * must not leave a spare motor unseen (issue 33 point 2).  Non-rt.
 */
static int scan_bus(struct rmd_loop *l, unsigned b)
{
	struct lbus *lb = &l->bus[b];
	struct probe_ctx pc = { .l = l, .bus = b };
	struct rmd_txn_opts o = txn_opts(&pc, lb->pb->batched ? RMD_LOOP_PROBE_TRIES : 1,
					 probe_timeout_ns(l, lb, false));
	struct rmd_txn t[RMD_MAX_MOTORS];
	struct rmd_msg msg = { .cmd = 0x9A };
	unsigned n = 0;
	int r;

	for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++) {
		if (lb->by_v3[id] || lb->by_v2[id] || lb->by_mit[id])
			continue;
		if (rmd_txn_prepare(&t[n], RMD_PROTO_V3, (uint8_t)id, &msg) == 0)
			n++;
	}
	r = rmd_txn_run(lb->bus, t, n, &o);
	if (r < 0)
		return r;
	for (unsigned k = 0; k < n; k++) {
		uint32_t bit = 1u << (t[k].req.can_id - RMD_CAN_REQ_BASE - 1);

		if (t[k].done) {
			lb->unexpected_ids |= bit;
			note_stray(lb, t[k].rep.f.can_id);
		} else {
			/* an answer that still comes is late (loop_rx.c) */
			lb->scan_gone_ids |= bit;
			lb->scan_sent_ns = t[k].first_sent_ns;
		}
	}
	return 0;
}

/* What an answer to 0xB3 `req` says, for the report (rep: NULL when none came).  Non-rt. */
static enum rmd_bringup_b3 b3_outcome(const struct rmd_frame *req, const struct rmd_frame *rep)
{
	enum rmd_comm_loss cl;

	if (!rep)
		return RMD_B3_NO_ANSWER;
	cl = rmd_arm_b3_outcome(req->data, rep);
	if (cl == RMD_CL_ARMED)
		return RMD_B3_SET;
	return cl == RMD_CL_ARMED_ZEROS ? RMD_B3_ZEROS : RMD_B3_DIFFERS;
}

/* The loop's protection state after bring-up's write came to b3.  Pure. */
static enum rmd_comm_loss b3_state(enum rmd_bringup_b3 b3)
{
	switch (b3) {
	case RMD_B3_SET:
		return RMD_CL_ARMED;
	case RMD_B3_ZEROS:
		return RMD_CL_ARMED_ZEROS;
	case RMD_B3_DIFFERS:
		return RMD_CL_DIFFERS;
	case RMD_B3_NO_ANSWER:
		return RMD_CL_NO_ANSWER;
	case RMD_B3_NOT_APPLICABLE:
		break;
	}
	return RMD_CL_PENDING;
}

/*
 * The wait of one try of bus b's 0xB3 writes: a ROM write's (V3 §2.30:
 * 0xB3 is stored in ROM), but short enough that the motors armed first
 * in the batch hear the loop's first cycle before their protection
 * trips while a silent one is tried: no more than the bus's shortest
 * comm-loss time over the tries and the cycle that follows them -- and
 * never less than a read's wait.  Non-rt.
 */
static int64_t arm_timeout_ns(const struct rmd_loop *l, unsigned b)
{
	int64_t w = probe_timeout_ns(l, &l->bus[b], true);
	int64_t floor = probe_timeout_ns(l, &l->bus[b], false);

	for (unsigned i = 0; i < l->n_motors; i++) {
		int64_t cl = (int64_t)rmd_config_comm_loss_ms(l->cfg, i) * RMD_NS_PER_MS;
		int64_t most = cl / (RMD_LOOP_PROBE_TRIES + 1) - l->period_ns;

		if (l->mot[i].m.bus == b && cl && most < w)
			w = most;
	}
	return w < floor ? floor : w;
}

/*
 * V3 §2.30: write each motor's comm-loss protection time (ROM) to every
 * motor of bus b that answered the probe, all in one batch, each tried
 * RMD_LOOP_PROBE_TRIES times, and check each answer, as the last step of
 * bring-up: a motor starts counting at the write, and the loop's first
 * cycle follows at once.  The outcome becomes the loop's protection state
 * (lifecycle.c): a motor not armed here is written again by the loop
 * before it may move.  Non-rt.
 */
static void arm_comm_loss(struct rmd_loop *l, unsigned b, struct rmd_bringup *out)
{
	struct probe_ctx pc = { .l = l, .bus = b };
	struct rmd_txn_opts o = txn_opts(&pc, RMD_LOOP_PROBE_TRIES, arm_timeout_ns(l, b));
	struct rmd_txn t[RMD_MAX_MOTORS];
	unsigned idx[RMD_MAX_MOTORS], n = 0;
	int64_t now;
	int r = 0;

	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];
		struct rmd_msg msg;

		out->motor[i].comm_loss_ms = rmd_config_comm_loss_ms(l->cfg, i);
		if (lm->m.bus != b || !rmd_dialect_has(lm->m.d, RMD_DIALECT_COMM_LOSS_B3) ||
		    lm->st->lifecycle == RMD_LC_LOST)
			continue;
		out->motor[i].b3 = RMD_B3_NO_ANSWER;
		rmd_arm_request(out->motor[i].comm_loss_ms, &msg);
		/*
		 * A motor whose protection tripped (it may have, while bring-up
		 * probed the others) only echoes the first command it gets, and
		 * 0xB3's answer is its echo: txn sends a status read right ahead
		 * of it, which takes that echo (rmd/txn.h).
		 */
		if (rmd_txn_prepare(&t[n], lm->m.proto, lm->m.id, &msg) == 0)
			idx[n++] = i;
	}
	if (n)
		r = rmd_txn_run(l->bus[b].bus, t, n, &o);
	now = loop_now(l);
	for (unsigned k = 0; k < n; k++) {
		struct rmd_bringup_motor *bm = &out->motor[idx[k]];
		const struct rmd_txn *w = &t[k];

		bm->b3 = b3_outcome(&w->req, r >= 0 && w->done ? &w->rep.f : NULL);
		give_up_tries(&l->mot[idx[k]], w);
		loop_cl_outcome(l, &l->mot[idx[k]], b3_state(bm->b3), now);
	}
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		if (lm->m.bus != b)
			continue;
		out->motor[i].comm_loss = lm->arm.cl;
		if (!rmd_comm_loss_allows_motion(lm->arm.cl) && lm->st->lifecycle != RMD_LC_LOST)
			out->unarmed++;
	}
}

/*
 * Bus b's strays (note_stray()), where its V2 motors share a 0x280 frame
 * and its entry does not say such motors have their CAN-ID filter on: the
 * frame never goes out (struct lbus.stray); and when the cycle cannot give
 * each batched motor its own frames instead (the plan's batch_own), the
 * bus is refused: its motors would run slower than configured for good.
 * Non-rt.
 */
static void strays_of(struct rmd_loop *l, unsigned b, struct rmd_bringup *out)
{
	struct lbus *lb = &l->bus[b];
	unsigned n = (unsigned)__builtin_popcount(lb->pb->batched);

	if (!n || !lb->stray_ids || lb->cb->can_id_filter)
		return;
	lb->stray = true;
	out->stray_ids[b] = lb->stray_ids;
	out->bus[b].stray_id = lb->stray_id;
	if (lb->pb->batch_own < n) {
		out->bus[b].stray_refused = true;
		out->strays_refused++;
	}
}

/* Every bus: what came before the first request answers none of them.  Non-rt. */
static void flush_buses(struct rmd_loop *l)
{
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];
		int64_t now = loop_now(l);

		lb->unexpected_ids = 0;
		lb->stray_ids = 0;
		lb->stray_id = 0;
		while (rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now) == RX_BATCH)
			;
	}
}

int rmd_loop_bringup(struct rmd_loop *l, struct rmd_bringup *out)
{
	memset(out, 0, sizeof(*out));
	if (l->running)
		return -EBUSY;
	out->n_motors = l->n_motors;
	out->n_buses = l->n_buses;
	out->comm_loss_ms = l->cfg->safety.comm_loss_ms;
	flush_buses(l);
	for (unsigned i = 0; i < l->n_motors; i++)
		if (probe_motor(l, i, &out->motor[i]) < 0) {
			if (out->motor[i].state == RMD_BRINGUP_MISMATCH)
				out->mismatched++;
			else
				out->missing++;
		}
	for (unsigned b = 0; b < l->n_buses; b++) {
		/* late answers tell of ids too: the scan's txn hands them to probe_stray() */
		scan_bus(l, b);
		out->unexpected_ids[b] = l->bus[b].unexpected_ids;
	}
	/* last, so that no motor goes quiet between its 0xB3 and the first cycle */
	for (unsigned b = 0; b < l->n_buses; b++) {
		const struct lbus *lb = &l->bus[b];

		arm_comm_loss(l, b, out);
		out->bus[b] = (struct rmd_bringup_bus){
			.n = lb->rtt_n,
			.rtt_min_ns = lb->rtt_min_ns,
			.rtt_max_ns = lb->rtt_max_ns,
			.exceeds_period = lb->rtt_n && lb->rtt_max_ns >= l->period_ns,
		};
		strays_of(l, b, out);
	}
	/* what bring-up found is the state before the first cycle */
	loop_fill_snapshot(l, loop_now(l));
	loop_fill_health(l, loop_now(l)); /* each motor's protection, for config_t at once */
	loop_pub_write(l);
	if (l->o.health)
		rmd_latest_put(l->o.health, &l->health);
	if (out->mismatched || out->strays_refused)
		return -EPROTO; /* whatever probe.on_missing says: the configuration is wrong */
	if ((out->missing || out->unarmed) && l->cfg->probe.on_missing == RMD_MISSING_REFUSE)
		return -ENODEV;
	return 0;
}
