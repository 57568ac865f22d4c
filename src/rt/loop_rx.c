// SPDX-License-Identifier: MIT
/*
 * The rt loop's receiving side: the requests in flight of each motor (a
 * frame the bus took is booked here, loop_commit()), the matching of a
 * received frame to its motor and request, decoding into the motor's
 * state, and the reply deadlines.  See rmd/loop.h "Matching and
 * deadlines"; the shared state is loop_state.h.
 *
 * Execution context: rt-safe: called from the cycle (and from rmd_loop_stop_motors()
 * and bring-up, which wait for replies); no allocation, no lock, no text.
 */
#include <errno.h>
#include <math.h>
#include <string.h>

#include "rmd/dialect.h"
#include "rmd/loop.h"
#include "rmd/motor.h"
#include "loop_state.h"
#include "loop_env.h"

/*
 * The motor answered something: it is there, and a lost one comes back --
 * unless it is refused, or its dialect is still open (struct lmotor).
 * rt-safe.
 */
static inline void loop_alive(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	lm->consecutive = 0;
	lm->replied = true;
	lm->last_reply_cycle = l->cycle;
	if ((lm->st->lifecycle == RMD_LC_LOST || lm->st->lifecycle == RMD_LC_PROBE) &&
	    !lm->ident.refused && !lm->ident.open)
		loop_enter(l, lm, RMD_LC_STOPPING, now);
}

/* ------------------------------------------------------------------ */
/* Requests in flight */

/*
 * What answers request f of motor m: its reply key (rmd_motor_reply_key())
 * and whether the answer repeats it.  The motor's own 0x140 + ID frames
 * (setpoints, status reads) take the short way: their answer comes on the
 * motor's reply identifier with their command byte.  rt-safe.
 */
static inline uint64_t os_keyof(uint32_t reply_id, uint16_t cmd)
{
	return loop_reply_key(reply_id, cmd);
}

static inline __attribute__((always_inline)) void
os_key(const struct rmd_motor *m, const struct rmd_frame *f, struct outstanding *o)
{
	uint32_t reply_id;
	uint16_t cmd;

	if (f->can_id == RMD_CAN_REQ_BASE + m->id && f->len) {
		o->key = os_keyof(m->reply_id, f->data[0]);
		o->echo_is_reply = rmd_motor_echoes(m, f->data[0]);
		return;
	}
	rmd_motor_reply_key(m, f, &reply_id, &cmd);
	o->key = os_keyof(reply_id, cmd);
	/* 0x280, MIT and empty frames are never echoed */
	o->echo_is_reply = f->can_id != RMD_CAN_MULTI &&
			   f->can_id != RMD_CAN_MIT_REQ_BASE + m->id && f->len &&
			   rmd_motor_echoes(m, f->data[0]);
}

/* Request o of lm is given up: an answer that still comes is late (loop_gone()).  rt-safe. */
static inline void os_give_up(struct lmotor *lm, const struct outstanding *o)
{
	loop_gone(lm, o->key, o->sent_ns);
}

/*
 * Request o of lm went unanswered: a reboot check opens (rmd/reboot.h),
 * unless the motor is lost or not yet found.  rt-safe.
 */
static __attribute__((cold, noinline)) void reboot_missed(struct rmd_loop *l, struct lmotor *lm,
							  const struct outstanding *o, int64_t now)
{
	uint8_t cmd = loop_reboot_cmd(lm);

	if (!cmd || lm->st->lifecycle == RMD_LC_LOST || lm->st->lifecycle == RMD_LC_PROBE ||
	    lm->ident.refused || lm->ident.open)
		return;
	if (rmd_reboot_missed(&lm->rb, o->seq, (o->key & 0xFFFF) == cmd, lm->heard_seq, now,
			      2 * l->bus[lm->m.bus].reply_ns) == RMD_REBOOT_UNCHECKABLE)
		loop_event(l, now, RMD_EV_REBOOT, loop_idx(l, lm), lm->m.bus, RMD_REBOOT_NO_CHECK,
			   cmd);
}

/*
 * The replies the running cycle waits for (loop_awaited()): those to the
 * requests sent at its tick to a motor that answers (it answered its last
 * request, loop_alive()), other than a status read 0x9A (error flags,
 * temperature, voltage: read a few times a second, its answer joins the
 * next cycle's state; the measurements a controller answers come with the
 * setpoints' replies and 0x9C).  A motor answers in order, so it owes
 * nothing once it answered the last of them (heard_seq).  rt-safe.
 */
static inline void await_add(struct rmd_loop *l, struct lmotor *lm, const struct outstanding *o)
{
	if (loop_answers(lm) & ((o->key & 0xFFFF) != 0x9A)) {
		/* when it comes: the motor's mean round trip, each request an eighth of the last */
		lm->rtt_est_ns += (lm->st->reply_latency_ns - lm->rtt_est_ns) >> 3;
		lm->await_seq = o->seq + 1;
		if (o->sent_ns + lm->rtt_est_ns > l->await_due_ns)
			l->await_due_ns = o->sent_ns + lm->rtt_est_ns;
	}
}

/*
 * Every slot of lm is in flight: the oldest request has waited longest,
 * it counts as missed; its slot is returned.  rt-safe.
 */
static __attribute__((cold, noinline)) unsigned os_evict(struct rmd_loop *l, struct lmotor *lm,
							 int64_t now)
{
	unsigned k = 0;

	for (unsigned j = 1; j < OUTSTANDING; j++)
		if (lm->os[j].seq < lm->os[k].seq)
			k = j;
	lm->os_used &= (uint8_t) ~(1u << k);
	os_give_up(lm, &lm->os[k]);
	loop_miss(l, lm, now);
	reboot_missed(l, lm, &lm->os[k], now);
	return k;
}

/* Request f of lm, sent at now, is in flight.  rt-safe. */
static inline __attribute__((always_inline)) void os_add(struct rmd_loop *l, struct lmotor *lm,
							 const struct rmd_frame *f, int64_t now)
{
	unsigned free_mask = ~(unsigned)lm->os_used & ((1u << OUTSTANDING) - 1);
	unsigned k;
	struct outstanding *o;

	if (free_mask)
		k = (unsigned)__builtin_ctz(free_mask);
	else
		k = os_evict(l, lm, now);
	o = &lm->os[k];
	os_key(&lm->m, f, o);
	o->seq = lm->seq++;
	o->sent_ns = now;
	await_add(l, lm, o);
	memcpy(o->data, f->data, sizeof(o->data));
	lm->os_used |= (uint8_t)(1u << k);
}

/* rt-safe. */
static void oneshot_pop(struct lmotor *lm)
{
	if (!lm->n_oneshot)
		return;
	for (unsigned k = 1; k < lm->n_oneshot; k++)
		lm->oneshot[k - 1] = lm->oneshot[k];
	lm->n_oneshot--;
}

/* Book frames from..to-1 of lb's cycle, which the bus took.  rt-safe. */
void loop_commit(struct rmd_loop *l, struct lbus *lb, unsigned from, unsigned to, int64_t now)
{
	/* incident recorder: every frame a bus took */
	if (l->o.incidents && to > from)
		rmd_incident_tx(l->o.incidents, (unsigned)(lb - l->bus), &lb->tx[from], to - from,
				now);
	for (unsigned k = from; k < to; k++) {
		const struct txmeta *mt = &lb->meta[k];
		const struct rmd_frame *f = &lb->tx[k];

		/* setpoints and status reads take the short way */
		if (__builtin_expect(mt->kind > REQ_STATUS, 0)) {
			if (mt->kind == REQ_BATCH) {
				for (unsigned j = 0; j < lb->pb->n_motors; j++)
					if (lb->pb->batched & (1u << j))
						os_add(l, &l->mot[lb->pb->motors[j]], f, now);
				continue;
			}
			if (mt->kind == REQ_NO_REPLY)
				continue;
			if (mt->kind == REQ_ONESHOT) {
				struct lmotor *lm = &l->mot[mt->motor];

				/* V3 §2.26: its brake released from this request on (rmd/reboot.h) */
				if (f->len && f->data[0] == 0x77)
					rmd_reboot_released(&lm->rb, lm->seq);
				oneshot_pop(lm);
			} else if (mt->kind == REQ_OWED)
				loop_owed_sent(l, &l->mot[mt->motor], f->data[0]);
		}
		os_add(l, &l->mot[mt->motor], f, now);
	}
}

/* The slot of lm's oldest request that frame f (id, cmd) answers, or -1.  rt-safe. */
static int os_match(const struct lmotor *lm, uint32_t id, uint16_t cmd)
{
	uint64_t key = os_keyof(id, cmd);
	int best = -1;

	for (unsigned m = lm->os_used; m; m &= m - 1) {
		int k = __builtin_ctz(m);
		const struct outstanding *e = &lm->os[k];

		if (e->key == key && (best < 0 || e->seq < lm->os[best].seq))
			best = k;
	}
	return best;
}

/* Request in slot k of lm is answered or given up.  rt-safe. */
static void os_done(struct lmotor *lm, unsigned k)
{
	lm->os_used &= (uint8_t) ~(1u << k);
}

/* ------------------------------------------------------------------ */
/* Receiving */

/* One reply latency into lat (under stat_begin()).  rt-safe. */
static void lat_add(struct rmd_latency *lat, int64_t ns)
{
	if (!lat->n) {
		lat->min_ns = ns;
		lat->max_ns = ns;
	} else if (ns < lat->min_ns) {
		lat->min_ns = ns;
	} else if (ns > lat->max_ns) {
		lat->max_ns = ns;
	}
	lat->n++;
	lat->sum_ns += ns;
	lat->hist[rmd_hist_bucket(ns)]++;
}

/* rt-safe. */
void loop_unexpected(struct rmd_loop *l, unsigned b, const struct rmd_frame *f, int64_t now)
{
	struct lbus *lb = &l->bus[b];

	l->cnt.unexpected++;
	if (lb->ev_unexpected_any && now - lb->ev_unexpected_ns < EVENT_INTERVAL_NS)
		return;
	lb->ev_unexpected_any = true;
	lb->ev_unexpected_ns = now;
	loop_event(l, now, RMD_EV_UNEXPECTED, 0xFF, b, f->can_id, f->len ? f->data[0] : -1);
}

/*
 * Is f (id, cmd) the answer of a request of lm given up?  Then it is
 * counted late, with its delay, and the entry used up; *sent_ns: when
 * that request was sent.  rt-safe.
 */
static bool took_late(struct rmd_loop *l, unsigned b, struct lmotor *lm, uint32_t id, uint16_t cmd,
		      int64_t *sent_ns, int64_t now)
{
	uint64_t key = os_keyof(id, cmd);
	struct lbus *lb = &l->bus[b];
	int best = -1;

	for (unsigned k = 0; k < GONE; k++)
		if (lm->gone[k].key == key &&
		    (best < 0 || lm->gone[k].sent_ns < lm->gone[best].sent_ns))
			best = (int)k;
	if (best < 0)
		return false;
	lm->gone[best].key = 0;
	*sent_ns = lm->gone[best].sent_ns;
	l->cnt.late++;
	if (now - lm->gone[best].sent_ns > l->cnt.late_max_ns)
		l->cnt.late_max_ns = now - lm->gone[best].sent_ns;
	if (!lb->ev_late_any || now - lb->ev_late_ns >= EVENT_INTERVAL_NS) {
		lb->ev_late_any = true;
		lb->ev_late_ns = now;
		loop_event(l, now, RMD_EV_LATE, loop_idx(l, lm), b, now - lm->gone[best].sent_ns,
			   cmd);
	}
	return true;
}

/*
 * Is f the late answer of bring-up's scan (0x9A to an id that is not
 * configured, rmd/bringup.h), on V3's or V2's reply identifier?  Counted
 * late once per id; the bring-up report named the ids that answered in
 * time.  rt-safe.
 */
static bool scan_late(struct rmd_loop *l, unsigned b, const struct rmd_frame *f, int64_t now)
{
	struct lbus *lb = &l->bus[b];
	uint32_t id = f->can_id, mid = 0;

	if (!lb->scan_gone_ids || !f->len || f->data[0] != 0x9A)
		return false;
	if (id > RMD_CAN_V3_REPLY_BASE && id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_V3_REPLY_BASE;
	else if (id > RMD_CAN_REQ_BASE && id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_REQ_BASE;
	if (!mid || !(lb->scan_gone_ids & (1u << (mid - 1))))
		return false;
	lb->scan_gone_ids &= ~(1u << (mid - 1));
	l->cnt.late++;
	if (now - lb->scan_sent_ns > l->cnt.late_max_ns)
		l->cnt.late_max_ns = now - lb->scan_sent_ns;
	return true;
}

/* Give up every request of lm in flight: an answer that still comes is late.  rt-safe. */
static void os_give_up_all(struct lmotor *lm)
{
	for (unsigned m = lm->os_used; m; m &= m - 1)
		os_give_up(lm, &lm->os[__builtin_ctz(m)]);
	lm->os_used = 0;
}

/* An angle in the reported frame as the event's int32 of 0.01 deg.  rt-safe. */
static int64_t centideg(double rad)
{
	double c = rad * (18000.0 / M_PI);

	if (!(c > INT32_MIN))
		c = INT32_MIN;
	if (c > INT32_MAX)
		c = INT32_MAX;
	return (int64_t)(uint32_t)(int32_t)c;
}

/*
 * An answer f of lm that tells whether it rebooted (rmd/reboot.h): 0xB1's
 * runtime, its brake in 0x9A, or V2's 0x92 angle held against the count
 * (have), to the request `seq`, sent at `sent`.  A reboot gives up its
 * requests in flight, whose answers would bring it back before the safe
 * action went out, and makes it lost and back (loop_rebooted()).
 * rt-safe.
 */
static __attribute__((cold, noinline)) void reboot_answer(struct rmd_loop *l, struct lmotor *lm,
							  const struct rmd_frame *f, unsigned have,
							  uint64_t seq, int64_t sent, int64_t now)
{
	enum rmd_reboot_verdict v = RMD_REBOOT_SAYS_NOTHING;
	unsigned how = RMD_REBOOT_BY_TURNS;
	enum rmd_reboot_outcome out;
	struct rmd_motor_reply r;
	int64_t what = 0;
	bool news;

	if (lm->st->lifecycle == RMD_LC_LOST || lm->st->lifecycle == RMD_LC_PROBE)
		return;
	if (have & RMD_MOTOR_HAVE_RUNTIME) {
		int64_t least = 0;

		if (rmd_motor_decode(&lm->m, f, &r) < 0)
			return;
		out = rmd_reboot_runtime(&lm->rb, seq, r.runtime_ms, sent, now, &least);
		how = RMD_REBOOT_BY_RUNTIME;
		what = (int64_t)((uint64_t)r.runtime_ms << 32) |
		       (uint32_t)(least < 0	     ? 0 :
				  least > UINT32_MAX ? UINT32_MAX :
						       least);
	} else if (have & RMD_MOTOR_HAVE_BRAKE) {
		/* 0x9A: its brake, after the flags that may have made it FAULT; a check decides */
		how = RMD_REBOOT_BY_BRAKE;
		v = rmd_reboot_brake_says(&lm->rb, lm->st->lifecycle == RMD_LC_ENABLED, seq,
					  lm->st->brake_released);
		out = rmd_reboot_brake(&lm->rb, seq, v, loop_reboot_cmd(lm) != 0);
	} else {
		what = (int64_t)((uint64_t)centideg(lm->st->pos_rad) << 32 |
				 (uint64_t)centideg(lm->m.v2_checked_rad));
		if (have & RMD_MOTOR_HAVE_COUNT_LOST) {
			v = RMD_REBOOT_SAYS_BOOTED;
		} else if (have & RMD_MOTOR_HAVE_COUNT_SAME) {
			v = RMD_REBOOT_SAYS_RUNNING;
		} else if (have & RMD_MOTOR_HAVE_COUNT_ASTRAY) {
			v = RMD_REBOOT_SAYS_COUNT_ASTRAY;
		}
		v = rmd_reboot_count(&lm->rb, v, &news);
		if (news)
			loop_event(l, now, RMD_EV_REBOOT, loop_idx(l, lm), lm->m.bus,
				   RMD_REBOOT_COUNT_ASTRAY, what);
		out = rmd_reboot_answer(&lm->rb, seq, v);
	}
	switch (out) {
	case RMD_REBOOT_REBOOTED:
		os_give_up_all(lm);
		loop_rebooted(l, lm, how, what, now);
		break;
	case RMD_REBOOT_UNDECIDED:
		loop_event(l, now, RMD_EV_REBOOT, loop_idx(l, lm), lm->m.bus, RMD_REBOOT_UNTOLD,
			   loop_reboot_cmd(lm));
		break;
	case RMD_REBOOT_WAIT:
	case RMD_REBOOT_FINE:
	case RMD_REBOOT_UNCHECKABLE:
		break;
	}
}

/*
 * What a reply carries besides the values taken: error flags (0x9A), and
 * what tells a reboot.  Its request is the newest answered (heard_seq,
 * heard_sent_ns): handle_frame() books it first; the reads that tell are
 * never pushed unasked (a 0x9A pushed by 0xB6 tells its brake all the
 * same).  Out of line: few replies carry either.  rt-safe.
 */
static __attribute__((cold, noinline)) void take_rare(struct rmd_loop *l, struct lmotor *lm,
						      const struct rmd_frame *f, unsigned have,
						      uint16_t prev, int64_t now)
{
	if (have & RMD_MOTOR_HAVE_ERROR) {
		loop_note_errors(l, lm, prev, now);
		/* a status poll: do its position commands show an effect (rmd/proc_effect.h) */
		if (rmd_effect_watch(&lm->effect,
				     lm->st->lifecycle == RMD_LC_ENABLED &&
					     lm->sp.mode == RMD_MODE_POSITION,
				     lm->sp.pos_rad, lm->sp.max_vel_rad_s, lm->st->pos_rad, now))
			loop_event(l, now, RMD_EV_NO_EFFECT, loop_idx(l, lm), lm->m.bus,
				   (int64_t)lround(fabs(lm->sp.pos_rad - lm->st->pos_rad) * 1e6),
				   (now - lm->effect.since_ns) / RMD_NS_PER_MS);
	}
	if ((have & (RMD_MOTOR_HAVE_RUNTIME | RMD_MOTOR_HAVE_COUNT_CHECK | RMD_MOTOR_HAVE_BRAKE)) &&
	    lm->heard_seq)
		reboot_answer(l, lm, f, have, lm->heard_seq - 1, lm->heard_sent_ns, now);
}

/*
 * The late answer f of lm's request given up, sent at sent_ns: a check's
 * runtime (0xB1) is judged all the same (replies slower than their
 * deadline would keep every check from being told).  rt-safe.
 */
static __attribute__((cold, noinline)) void reboot_late(struct rmd_loop *l, struct lmotor *lm,
							const struct rmd_frame *f, int64_t sent_ns,
							int64_t now)
{
	reboot_answer(l, lm, f, RMD_MOTOR_HAVE_RUNTIME, lm->rb.told_seq, sent_ns, now);
}

/*
 * Decode f into lm's state; false when it cannot be decoded.  Inline: the
 * cycle takes every reply through it.  rt-safe.
 */
static inline __attribute__((always_inline)) bool
take_values(struct rmd_loop *l, struct lmotor *lm, const struct rmd_frame *f, int64_t now)
{
	uint16_t prev = lm->st->error_code;
	unsigned have;

	/* now: the reply's rmd_bus_rx.t_ns */
	if (rmd_motor_receive(&lm->m, f, now, lm->st, &have) < 0)
		return false;
	if (__builtin_expect(rmd_settle_due(&lm->settle, lm->st->pos_rx_ns), 0))
		loop_pos_settle(l, lm, now);
	if (__builtin_expect(have & (RMD_MOTOR_HAVE_ERROR | RMD_MOTOR_HAVE_BRAKE |
				     RMD_MOTOR_HAVE_RUNTIME | RMD_MOTOR_HAVE_COUNT_CHECK),
			     0))
		take_rare(l, lm, f, have, prev, now);
	return true;
}

/*
 * Did the request right ahead of o, to the same motor in the same send,
 * get its answer or echo?  Then o reached an awake motor, and a repeat of
 * o is its answer (V3 §2.8: 0x62, V3 §2.11: 0x92 at exactly 0.00 deg), as
 * txn judges (rmd/txn.h): a motor answers in order.  rt-safe.
 */
static bool ahead_heard(const struct lmotor *lm, const struct outstanding *o)
{
	return o->seq && lm->heard_seq == o->seq && lm->heard_sent_ns == o->sent_ns;
}

/*
 * f, matched to lm's request o whose answer is its echo, is the echo of
 * an owed 0x80 or 0x78 (lifecycle.c "Owed frames": output off, brake
 * locked): paid.  Out of line: the setpoints' answers never come here.
 * rt-safe.
 */
static __attribute__((noinline)) bool owed_echo(struct rmd_loop *l, struct lmotor *lm,
						const struct outstanding *o,
						const struct rmd_frame *f, int64_t now)
{
	if (!lm->owed.bits || f->can_id > RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS)
		return false;
	return loop_owed_answer(l, lm, f->data[0], o->seq, rmd_frame_repeats(o->data, false, f),
				now);
}

/*
 * lm, found late, speaks dialect `proto` (firmware version `version`, 0:
 * none read), not its own: left out for good, reported (RMD_EV_DIALECT).
 * rt-safe.
 */
static void refuse_dialect(struct rmd_loop *l, unsigned b, struct lmotor *lm, int64_t version,
			   enum rmd_proto proto, int64_t now)
{
	lm->ident.refused = true;
	lm->life.next_probe_ns = INT64_MAX;
	loop_event(l, now, RMD_EV_DIALECT, loop_idx(l, lm), b, version, proto);
}

/*
 * The MIT scaling of lm, a motor in MIT mode found late, from its firmware
 * version and the model its re-probe's 0xB5 answered (rmd/dialect.h
 * rmd_mit_scaling_decide(), bring-up's rule): decided, or it is left out
 * for good, reported (RMD_EV_MIT_SCALING): no MIT frame goes out over
 * ranges its firmware may not scale by.  True when decided.  rt-safe.
 */
static bool settle_mit(struct rmd_loop *l, unsigned b, struct lmotor *lm, uint32_t version,
		       int64_t now)
{
	const struct rmd_config_motor *c = &l->cfg->motors[loop_idx(l, lm)];
	struct rmd_mit_decision dec;

	rmd_mit_scaling_decide(lm->m.d, version, lm->ident.model, &c->mit, c->mit_given, &dec);
	if (rmd_mit_decided(&dec) && rmd_motor_set_mit(&lm->m, &dec.r) == 0)
		return true;
	lm->ident.refused = true;
	lm->life.next_probe_ns = INT64_MAX;
	loop_event(l, now, RMD_EV_MIT_SCALING, loop_idx(l, lm), b, version,
		   dec.source | (int64_t)(dec.series & 0xFF) << 8);
	return false;
}

/*
 * Answer f of a motor whose dialect is open (struct lmotor:
 * missing at bring-up) to its re-probe: a model (0xB5) is kept for its
 * MIT scaling, the firmware date 0xB2 settles it.  The rule is bring-up's
 * (rmd_ident_answer(), rmd/proc_ident.h), and the loop does not switch dialects: a
 * date that says the motor's dialect, or that tells none (0), lets the
 * next re-probe (0x9A) bring it back as any lost motor -- in MIT mode once
 * its MIT scaling is decided (settle_mit()); one that says another dialect
 * leaves it out for good, reported (RMD_EV_DIALECT): a motor is never
 * driven in a dialect its firmware does not speak.  An answer with no
 * date is asked again.  rt-safe.
 */
static __attribute__((cold, noinline)) void settle_dialect(struct rmd_loop *l, unsigned b,
							   struct lmotor *lm,
							   const struct rmd_frame *f, int64_t now)
{
	struct rmd_motor_reply r;
	const struct rmd_dialect *fw;

	/* answers on the motor's reply identifier (an MIT reply carries no command byte) */
	if (f->can_id != lm->m.reply_id || (f->data[0] != 0xB2 && f->data[0] != 0xB5) ||
	    rmd_motor_decode(&lm->m, f, &r) < 0)
		return;
	switch (rmd_ident_answer(&lm->ident, lm->m.d, &r, &fw)) {
	case RMD_IDENT_WAIT:
		break;
	case RMD_IDENT_OTHER:
		refuse_dialect(l, b, lm, (int64_t)r.version_date, fw->proto, now);
		break;
	case RMD_IDENT_SAME:
		lm->m.quirks = rmd_firmware_quirks(r.version_date);
		if (!lm->m.mit_mode || settle_mit(l, b, lm, r.version_date, now))
			lm->life.next_probe_ns = now; /* the next cycle's 0x9A brings it back */
		break;
	}
}

/*
 * Is f the status answer (0x9A) of a `protocol: auto` motor still taken
 * for V3 (its dialect open, struct lmotor), on the reply identifier of
 * another dialect of the list -- V2's is the request's own, V2 §1, so a
 * frame of zeros after its command byte is a request, not an answer?
 * Such a motor has no firmware date to ask (V2); its answer tells the
 * dialect.  Left out for good, reported (RMD_EV_DIALECT, no date): the
 * loop does not switch dialects.  rt-safe.
 */
static __attribute__((cold, noinline)) bool
other_dialect_answer(struct rmd_loop *l, unsigned b, const struct rmd_frame *f, int64_t now)
{
	size_t nd;
	const struct rmd_dialect *list = rmd_dialect_list(&nd);
	bool zeros = true;

	if (f->len != RMD_FRAME_LEN || f->data[0] != 0x9A)
		return false;
	for (unsigned k = 1; k < RMD_FRAME_LEN; k++)
		zeros &= !f->data[k];
	if (zeros)
		return false;
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		if (lm->m.bus != b || !lm->ident.open || !l->cfg->motors[i].proto_auto)
			continue;
		for (size_t k = 0; k < nd; k++) {
			const struct rmd_dialect *d = &list[k];

			/* MIT is a way of driving V3 firmware, not a dialect of its own */
			if (!rmd_dialect_is_firmware(d) || d->reply_base == lm->m.d->reply_base ||
			    f->can_id != d->reply_base + (uint32_t)lm->m.id)
				continue;
			lm->ident.open = false;
			refuse_dialect(l, b, lm, 0, d->proto, now);
			return true;
		}
	}
	return false;
}

/*
 * f came on bus b from no motor the configuration lists.  One whose
 * firmware takes the 0x280 frame for a command of its own
 * (rmd_dialect_takes_280()), on a bus whose V2 motors share that frame,
 * stops the frame at once and for good (struct lbus.stray), reported --
 * unless the bus's entry says such motors have their CAN-ID filter on.
 * rt-safe.
 */
static __attribute__((cold, noinline)) void stray_answered(struct rmd_loop *l, unsigned b,
							   const struct rmd_frame *f, int64_t now)
{
	struct lbus *lb = &l->bus[b];
	uint8_t id;

	if (lb->stray || !lb->pb->batched || lb->cb->can_id_filter ||
	    !rmd_dialect_takes_280(f->can_id, &id))
		return;
	lb->stray = true;
	lb->stray_id = f->can_id;
	loop_event(l, now, RMD_EV_STRAY, 0xFF, b, f->can_id, id);
}

/*
 * An answer (its request's echo) to lm's `cmd`, of firmware with quirks:
 * where 0x9A DATA[3] tells that it runs commands, not its brake, the
 * brake is what it acknowledged: 0x77 released, 0x78 locked (V3 §2.26,
 * §2.27).  rt-safe.
 */
static __attribute__((cold, noinline)) void quirk_answer(struct lmotor *lm, uint16_t cmd)
{
	if ((lm->m.quirks & RMD_QUIRK_9A_BYTE3_RUNNING) && (cmd == 0x77 || cmd == 0x78))
		lm->st->brake_released = cmd == 0x77;
}

/*
 * lm echoed its request `cmd` instead of running it: the first command a
 * motor hears after its comm-loss protection tripped (docs/design.md).
 * From a motor driven with its protection armed that is the trip itself,
 * its 0xF1 unheard (lost on the wire, or firmware that sends none): its
 * output went off, so it is lost, as for the 0xF1 -- never taken for
 * running, and never driven again before the controller enables it anew
 * (issue 32 point 3).  A motor coming back (the read ahead of its 0xB3
 * round takes such an echo, proc_arm.c) is not driven: nothing to tell.
 * Left: a setpoint whose real answer is all zeros where it has zeros (0
 * degC, at rest at 0.00 deg) is taken for a trip too -- lost, the safe
 * side.  rt-safe.
 */
static __attribute__((cold, noinline)) void echo_tripped(struct rmd_loop *l, struct lmotor *lm,
							 uint16_t cmd, int64_t now)
{
	const struct rmd_cmd_spec *row = cmd <= 0xFF ? rmd_motor_row(&lm->m, (uint8_t)cmd) : NULL;

	/*
	 * A read's answer may repeat it for real (0xB1 just after a boot:
	 * runtime 0), and tells nothing run or not: only a command with
	 * arguments (a setpoint, a safe action; an MIT frame, answered on
	 * 0x500 + ID) is judged
	 */
	if ((lm->st->lifecycle != RMD_LC_ENABLED && lm->st->lifecycle != RMD_LC_SAFE) ||
	    lm->arm.cl != RMD_CL_ARMED || (cmd != RMD_MOTOR_CMD_MIT && (!row || !row->req.n)))
		return;
	loop_event(l, now, RMD_EV_MOTOR_ERROR, loop_idx(l, lm), lm->m.bus,
		   RMD_EV_TRIP_ECHOED | (cmd & 0x1FF), RMD_MOTOR_CMD_COMM_LOST);
	loop_motor_lost(l, lm, now);
}

/*
 * A reply stamped before its request o was sent (issue 32 point 9: an
 * adapter that stamps a packet of frames with one time, a clock
 * conversion that lags): counted, and taken as received at the send, so
 * that no latency is negative and no round-trip estimate (await_add())
 * runs ahead of the replies.  rt-safe.
 */
static __attribute__((cold, noinline)) int64_t stamp_early(struct rmd_loop *l, unsigned b,
							   const struct outstanding *o)
{
	l->bus[b].rx_early++;
	return o->sent_ns;
}

/* rt-safe. */
static void handle_frame(struct rmd_loop *l, unsigned b, const struct rmd_bus_rx *rx)
{
	const struct rmd_frame *f = &rx->f;
	struct lmotor *lm = loop_motor_of(l, b, f->can_id);
	int64_t now = rx->t_ns;
	const struct outstanding *o;
	int64_t sent_ns;
	uint16_t cmd;
	int k;

	if (!lm || !f->len) {
		if (!lm && l->bus[b].pb->batched)
			stray_answered(l, b, f, now);
		if (!lm && (scan_late(l, b, f, now) || other_dialect_answer(l, b, f, now)))
			return;
		loop_unexpected(l, b, f, now);
		return;
	}
	cmd = f->can_id > RMD_CAN_MIT_REPLY_BASE ? RMD_MOTOR_CMD_MIT : f->data[0];
	k = os_match(lm, f->can_id, cmd);
	if (k >= 0) {
		int64_t latency_ns;
		bool echo;

		o = &lm->os[k];
		if (__builtin_expect(now < o->sent_ns, 0))
			now = stamp_early(l, b, o);
		/*
		 * only a motor with a comm-loss protection echoes (after a
		 * trip); a V2 motor's answer that repeats its request (0x92 at
		 * exactly 0.00 deg) is its answer
		 */
		echo = (lm->m.caps & RMD_DIALECT_COMM_LOSS_B3) &&
		       rmd_frame_repeats(o->data, o->echo_is_reply, f) && !ahead_heard(lm, o);
		lm->heard_seq = o->seq + 1;
		lm->heard_sent_ns = o->sent_ns;
		os_done(lm, (unsigned)k);
		l->cnt.replies++;
		latency_ns = now - o->sent_ns;
		lm->st->reply_latency_ns = latency_ns;
		lat_add(&lm->lat, latency_ns);
		loop_alive(l, lm, now);
		if (echo) {
			/* docs/design.md: after a comm-loss trip the first command is only echoed */
			l->cnt.echoes++;
			echo_tripped(l, lm, cmd, now);
			return;
		}
		if (__builtin_expect(lm->ident.open, 0)) {
			/* the 0x9A ahead of its 0xB5 and 0xB2 tells nothing (settle_dialect()) */
			settle_dialect(l, b, lm, f, now);
			return;
		}
		if (o->echo_is_reply) {
			if (lm->m.quirks)
				quirk_answer(lm, cmd);
			if (owed_echo(l, lm, o, f, now))
				return;
		}
		if (cmd == RMD_ARM_CMD && f->can_id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS) {
			/* V3 §2.30: the loop's own write of the comm-loss time */
			loop_cl_answer(l, lm, o->data, f, now);
			return;
		}
		if (!take_values(l, lm, f, now))
			l->cnt.bad_replies++;
		return;
	}
	if (cmd == RMD_MOTOR_CMD_COMM_LOST) {
		/* docs/design.md: the motor's comm-loss protection tripped; its output is off */
		l->cnt.unsolicited++;
		if (lm->st->lifecycle != RMD_LC_LOST) {
			loop_event(l, now, RMD_EV_MOTOR_ERROR, loop_idx(l, lm), b,
				   lm->st->error_code, RMD_MOTOR_CMD_COMM_LOST);
			loop_motor_lost(l, lm, now);
		}
		return;
	}
	if (took_late(l, b, lm, f->can_id, cmd, &sent_ns, now)) {
		/*
		 * It answers, slowly: no silence.  Not LOST for its late
		 * answers (while a reboot check holds its setpoints back, no
		 * newer setpoint is in flight for them to match), and no check
		 * opens for a while (rmd/reboot.h).
		 */
		if (lm->st->lifecycle != RMD_LC_LOST)
			lm->consecutive = 0;
		rmd_reboot_slow(&lm->rb, now);
		if (cmd == RMD_REBOOT_CMD_RUNTIME && lm->rb.pending)
			reboot_late(l, lm, f, sent_ns, now);
		return;
	}
	/*
	 * V3 §2.33.4 index 3: error reports (0x9A) every 100 ms, unasked; V4.2
	 * §2.33: the replies 0xB6 has the motor push, if another tool left it
	 * on after bring-up turned it off.  What they say is the motor's.
	 */
	if (cmd == 0x9A || rmd_silence_pushable(lm->m.d, cmd) >= 0) {
		l->cnt.unsolicited++;
		loop_alive(l, lm, now);
		if (!take_values(l, lm, f, now))
			l->cnt.bad_replies++;
		return;
	}
	loop_unexpected(l, b, f, now);
}

/* Take every frame that has arrived on bus b by now.  Bounded.  rt-safe. */
void loop_drain(struct rmd_loop *l, unsigned b, int64_t now)
{
	struct lbus *lb = &l->bus[b];

	for (unsigned round = 0; round < RX_ROUNDS; round++) {
		int n = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now);

		if (n <= 0)
			return;
		/* the bus carries frames: what the last send put on it may still wait */
		lb->tx_unheard = lb->tx_last;
		lb->heard_ns = now;
		/* incident recorder: every frame received */
		if (l->o.incidents)
			rmd_incident_rx(l->o.incidents, b, lb->rx, (unsigned)n);
		stat_begin(l);
		for (int k = 0; k < n; k++)
			handle_frame(l, b, &lb->rx[k]);
		stat_end(l);
		if (n < RX_BATCH)
			return;
	}
}

/* rt-safe. */
void loop_check_deadlines(struct rmd_loop *l, int64_t now)
{
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		for (unsigned m = lm->os_used; m; m &= m - 1) {
			unsigned k = (unsigned)__builtin_ctz(m);

			/* a request's deadline: its bus's reply_ns after it was sent */
			if (lm->os[k].sent_ns <= now - l->bus[lm->m.bus].reply_ns) {
				os_done(lm, k);
				os_give_up(lm, &lm->os[k]);
				loop_miss(l, lm, now);
				reboot_missed(l, lm, &lm->os[k], now);
				loop_owed_unpaid(l, lm, now);
			}
		}
	}
}

/*
 * The buses (bit b) on which the running cycle still waits for a reply
 * (await_add()).  rt-safe.
 */
unsigned loop_awaited(const struct rmd_loop *l)
{
	unsigned buses = 0;

	for (unsigned i = 0; i < l->n_motors; i++) {
		const struct lmotor *lm = &l->mot[i];

		if (loop_answers(lm) && lm->heard_seq < lm->await_seq)
			buses |= 1u << lm->m.bus;
	}
	return buses;
}
