// SPDX-License-Identifier: MIT
/*
 * The rt loop's sending side: one cycle's frames of a bus from its plan
 * slots (setpoints, one-shots, status reads, the V2 0x280 frame) and one
 * send call; loop_commit() (loop_rx.c) books what the bus took.  See
 * rmd/loop.h "Frames"; the shared state is loop_state.h.
 *
 * Execution context: rt-safe: called from the cycle (loop_push_tx() also
 * from rmd_loop_stop_motors()); no allocation, no lock, no text.
 */
#include <errno.h>
#include <string.h>

#include "rmd/loop.h"
#include "rmd/motor.h"
#include "loop_state.h"
#include "loop_env.h"

/* ------------------------------------------------------------------ */
/* Sending */

/* rt-safe. */
void loop_push_tx(struct lbus *lb, const struct rmd_frame *f, unsigned motor, enum req_kind kind)
{
	if (lb->ntx >= TX_MAX)
		return;
	lb->tx[lb->ntx] = *f;
	lb->meta[lb->ntx] = (struct txmeta){ .motor = (uint8_t)motor, .kind = (uint8_t)kind };
	lb->ntx++;
}

/* rt-safe. */
static void push_cmd(struct rmd_loop *l, struct lbus *lb, unsigned i, uint8_t cmd)
{
	struct lmotor *lm = &l->mot[i];
	struct rmd_frame f;

	if (rmd_motor_encode_cmd(&lm->m, cmd, &f) == 0)
		loop_push_tx(lb, &f, i, REQ_STATUS);
}

/*
 * The status read 0x9C (V3 §2.13 / V2 §3.32; MIT motors answer V3), the
 * frame of every control slot of a motor that is not driven: encoded once
 * (rmd_motor.status2_req).  rt-safe.
 */
static inline void push_status2(struct rmd_loop *l, struct lbus *lb, unsigned i)
{
	const struct rmd_frame *f = &l->mot[i].m.status2_req;

	if (__builtin_expect(f->len != 0, 1))
		loop_push_tx(lb, f, i, REQ_STATUS);
}

/*
 * A lost motor's re-probe, when one is due: 0x9A; while its dialect is
 * open (struct lmotor), the firmware date 0xB2 right behind it, whose
 * answer settles it, and ahead of that, in MIT mode, the model 0xB5 that
 * decides its MIT scaling with the date: a motor whose comm-loss
 * protection tripped echoes the first frame it gets, and answers the next
 * (one or two exchanges more than the plan counts, as push_oneshot()'s;
 * what a full cycle does not take is asked at the next re-probe).
 * rt-safe.
 */
static void push_reprobe(struct rmd_loop *l, struct lbus *lb, unsigned i, int64_t now)
{
	struct lmotor *lm = &l->mot[i];
	uint8_t asks[2];
	unsigned n;

	if (now < lm->life.next_probe_ns)
		return;
	lm->life.next_probe_ns = now + RMD_LOOP_REPROBE_NS;
	push_cmd(l, lb, i, 0x9A);
	n = rmd_ident_asks(&lm->ident, lm->m.mit_mode, asks);
	for (unsigned k = 0; k < n; k++)
		push_cmd(l, lb, i, asks[k]);
}

/*
 * The setpoint's frame, or the safe action's first frame instead of a
 * refused one.  Inline, as add_control(): the cycle takes every setpoint
 * through it, and a call costs ~15 instructions a motor (insn-guard).
 * rt-safe.
 */
static inline __attribute__((always_inline)) void push_setpoint(struct rmd_loop *l, struct lbus *lb,
								unsigned i, int64_t now)
{
	struct lmotor *lm = &l->mot[i];
	struct rmd_frame f, safe[2];
	unsigned fl = 0;
	int r = rmd_motor_encode(&lm->m, &lm->sp, &f, &fl);

	if (r == 0) {
		if (fl & RMD_MOTOR_CLAMPED)
			l->cnt.clamped++;
		loop_push_tx(lb, &f, i, REQ_CONTROL);
		return;
	}
	if (r == -EDOM)
		l->cnt.nonfinite++;
	else if (r == -EPERM) /* its firmware does not run the mode now (rmd_motor_runs()) */
		l->cnt.ignored[loop_fw_refuse(l, lm, lm->sp.mode, now)]++;
	else
		l->cnt.unsupported++;
	if (rmd_motor_encode_safe(&lm->m, loop_safe_action(l), safe) > 0)
		loop_push_tx(lb, &safe[0], i, REQ_CONTROL);
	else
		push_cmd(l, lb, i, 0x80);
}

/*
 * A one-shot whose echo the loop takes as proof that the motor did it: the
 * 0xB3 write (V3 §2.30; lifecycle.c "Comm-loss protection").  A motor whose
 * protection tripped only echoes the first command it gets
 * (docs/design.md), and an echo is all 0xB3's answer is.  rt-safe.
 */
static bool oneshot_echo_verified(const struct lmotor *lm, const struct rmd_frame *f)
{
	return f->can_id == RMD_CAN_REQ_BASE + lm->m.id && f->len && f->data[0] == RMD_ARM_CMD;
}

/*
 * The head of lm's one-shot queue.  An echo-verified one goes right behind
 * a status read (0x9A) in the same slot: that read takes the echo of a
 * motor that tripped since its last frame, whatever the gap between its
 * frames, and the write is done.  That is one exchange more than the plan
 * counts, only for these writes (at most RMD_ARM_TRIES in a round; TX_MAX has
 * room for a second frame in every slot).  rt-safe.
 */
static void push_oneshot(struct rmd_loop *l, struct lbus *lb, unsigned i, int64_t now)
{
	struct lmotor *lm = &l->mot[i];

	if (oneshot_echo_verified(lm, &lm->oneshot[0]))
		push_cmd(l, lb, i, 0x9A);
	/*
	 * Issue 20.13: the brake opens over brake_release_ms from its (last)
	 * release; a period more, as this frame leaves later in its cycle than
	 * the first setpoint may in the cycle the wait ends in.
	 */
	if (lm->oneshot[0].data[0] == 0x77 && l->cfg->motors[i].brake_release_ms)
		lm->st->release_until_ns =
			now + (int64_t)l->cfg->motors[i].brake_release_ms * RMD_NS_PER_MS +
			l->period_ns;
	loop_push_tx(lb, &lm->oneshot[0], i, REQ_ONESHOT);
}

/* rt-safe. */
int loop_report_off(const struct lmotor *lm, unsigned k, struct rmd_frame *f)
{
	struct rmd_msg msg;

	rmd_silence_request(lm->m.d, k, &msg);
	return rmd_encode(lm->m.proto, RMD_DIR_REQUEST, lm->m.id, &msg, f);
}

/*
 * One of lm's 0xB6 offs (rmd/proc_silence.h), the lowest first.  The
 * manual gives no answer to it: none is awaited, and one the bus does
 * not take is not sent again (bring-up's are as unchecked).  rt-safe.
 */
static __attribute__((cold)) void push_report_off(struct lbus *lb, struct lmotor *lm, unsigned i)
{
	int k = rmd_silence_next(&lm->sil);
	struct rmd_frame f;

	if (k >= 0 && loop_report_off(lm, (unsigned)k, &f) == 0)
		loop_push_tx(lb, &f, i, REQ_NO_REPLY);
}

/*
 * The read that tells whether lm, which missed a reply, rebooted
 * (rmd/reboot.h), in place of whatever else its slot would carry: a motor
 * back from a boot hears it first, not a motion command.  rt-safe.
 */
static __attribute__((cold, noinline)) void push_reboot_check(struct rmd_loop *l, struct lbus *lb,
							      unsigned i)
{
	uint8_t cmd = rmd_reboot_next(&l->mot[i].rb, loop_reboot_cmd(&l->mot[i]));

	if (cmd)
		push_cmd(l, lb, i, cmd);
}

/* Whether the head of lm's one-shot queue releases its brake (0x77, V3 §2.26).  rt-safe. */
static bool oneshot_releases(const struct lmotor *lm)
{
	return lm->oneshot[0].can_id == RMD_CAN_REQ_BASE + lm->m.id && lm->oneshot[0].len &&
	       lm->oneshot[0].data[0] == 0x77;
}

/*
 * What waits for lm's control slot: an owed 0x80 or 0x78 first (the
 * motor's output and brake, lifecycle.c "Owed frames"), else the read of
 * a reboot check, unless the head of its one-shot queue goes first -- a
 * safe action's frames, which stop the motor in whatever frame it counts,
 * and a comm-loss round's 0xB3 writes, which move nothing and which a
 * motor tripping between two frames answers only right behind the read
 * that takes its echo; a brake release (0x77) waits -- else that head,
 * else a 0xB6 off.  rt-safe.
 */
static void push_due(struct rmd_loop *l, struct lbus *lb, unsigned i, int64_t now)
{
	struct lmotor *lm = &l->mot[i];
	struct rmd_frame f;

	if (loop_owed_frame(lm, &f))
		loop_push_tx(lb, &f, i, REQ_OWED);
	else if (lm->rb.pending && (!lm->n_oneshot || oneshot_releases(lm)))
		push_reboot_check(l, lb, i);
	else if (lm->n_oneshot)
		push_oneshot(l, lb, i, now);
	else if (lm->sil.off)
		push_report_off(lb, lm, i);
}

/*
 * Whether this read of lm asks its 0x92 angle: a V2 motor whose encoder
 * has no reference (rmd/motor.h), every other read.  rt-safe.
 */
static inline bool ask_v2_angle(struct lmotor *lm)
{
	if (__builtin_expect(!rmd_motor_needs_v2_reference(&lm->m), 1))
		return false;
	lm->v2_ask_angle = !lm->v2_ask_angle;
	return lm->v2_ask_angle;
}

/*
 * A motor's control slot.  Inline into both its callers, the cycle's loop
 * over the plan's control slots and batch_own(): as a call it costs the
 * cycle ~15 instructions a motor (bench/insn-guard.sh).  rt-safe.
 */
static inline __attribute__((always_inline)) void add_control(struct rmd_loop *l, struct lbus *lb,
							      unsigned i, int64_t now)
{
	struct lmotor *lm = &l->mot[i];
	struct rmd_frame f[2];

	/*
	 * owed frames, a reboot check's read and one-shots first: an ENABLED
	 * motor's brake release, the others' stops
	 */
	if (lm->n_oneshot || lm->sil.off || lm->owed.bits || lm->rb.pending) {
		push_due(l, lb, i, now);
		return;
	}
	if (lm->st->lifecycle == RMD_LC_ENABLED) {
		/* issue 20.13: while the brake opens, status reads keep the motor fed */
		if (__builtin_expect(now < lm->st->release_until_ns, 0))
			push_status2(l, lb, i);
		else
			push_setpoint(l, lb, i, now);
		return;
	}
	switch ((enum rmd_lifecycle)lm->st->lifecycle) {
	case RMD_LC_SAFE:
		if (lm->life.damp_stream && rmd_motor_encode_safe(&lm->m, RMD_SAFE_DAMP, f) == 1) {
			loop_push_tx(lb, &f[0], i, REQ_CONTROL);
			break;
		}
		push_status2(l, lb, i);
		break;
	case RMD_LC_PROBE:
	case RMD_LC_READY:
	case RMD_LC_STOPPING:
	case RMD_LC_FAULT:
		/*
		 * read only: V3 §2.13 / V2 §3.32 status 2 (MIT motors answer
		 * V3); a V2 motor without its encoder's reference asks its
		 * 0x92 angle every other time (firmware that never answers it
		 * misses half, never ten in a row)
		 */
		if (ask_v2_angle(lm))
			push_cmd(l, lb, i, RMD_MOTOR_CMD_FINE_POS);
		else
			push_status2(l, lb, i);
		break;
	case RMD_LC_LOST:
		push_reprobe(l, lb, i, now);
		break;
	case RMD_LC_ENABLED:
	case RMD_LC_COUNT:
		break;
	}
}

/*
 * A status poll's slot; where the plan put it in place of the motor's
 * control slot (a full bus), a safe action, owed 0x80/0x78 or one-shot
 * waiting for the motor takes it: safety frames go before polls (issue
 * 20.8).  rt-safe.
 */
static void add_status(struct rmd_loop *l, struct lbus *lb, unsigned i, int64_t now)
{
	struct lmotor *lm = &l->mot[i];

	if (__builtin_expect(lm->owed.bits || lm->n_oneshot, 0)) {
		push_due(l, lb, i, now);
		return;
	}
	if (lm->st->lifecycle == RMD_LC_LOST)
		push_reprobe(l, lb, i, now);
	else if (ask_v2_angle(lm)) /* as in add_control() */
		push_cmd(l, lb, i, RMD_MOTOR_CMD_FINE_POS);
	else
		push_cmd(l, lb, i, 0x9A);
}

/*
 * A fine position read (rmd/plan.h, docs/feedback.md): 0x92 in every
 * lifecycle but LOST, whose re-probe is the control slot's.  rt-safe.
 */
static void add_fine(struct rmd_loop *l, struct lbus *lb, unsigned i)
{
	struct lmotor *lm = &l->mot[i];

	if (lm->st->lifecycle != RMD_LC_LOST)
		push_cmd(l, lb, i, RMD_MOTOR_CMD_FINE_POS);
}

/*
 * Whether bus lb's 0x280 frame may go out this cycle.  It is a torque
 * command to every V2 motor with ID 1..4 on the bus (V2 §4.1; 0 A is a
 * torque too: it switches the output on), and a command of its own to a
 * V3/V4 motor whose CAN-ID filter is off (V3 §3.1): so only while every
 * batched motor is ENABLED, past its brake release, in torque mode and
 * owes no frame of its own, and no motor the configuration does not list
 * answered on the bus (struct lbus.stray).  rt-safe.
 */
static bool batch_allowed(const struct rmd_loop *l, const struct lbus *lb, int64_t now)
{
	const struct rmd_plan_bus *pb = lb->pb;

	if (__builtin_expect(lb->stray, 0))
		return false;
	for (uint32_t m = pb->batched; m; m &= m - 1) {
		const struct lmotor *lm = &l->mot[pb->motors[__builtin_ctz(m)]];

		if (lm->st->lifecycle != RMD_LC_ENABLED || now < lm->st->release_until_ns ||
		    lm->sp.mode != RMD_MODE_TORQUE || lm->owed.bits || lm->n_oneshot ||
		    lm->sil.off || lm->rb.pending)
			return false;
	}
	return true;
}

/*
 * Instead of the 0x280 frame: the batched motors' own frames, as their
 * lifecycle says (add_control()), batch_own of them a cycle (what the plan
 * has room for), in turn; a motor that has nothing to send (LOST between
 * its re-probes) does not take a turn.  rt-safe.
 */
static void batch_own(struct rmd_loop *l, struct lbus *lb, int64_t now)
{
	const struct rmd_plan_bus *pb = lb->pb;
	unsigned served = 0;

	for (unsigned n = 0; n < pb->n_motors && served < pb->batch_own; n++) {
		unsigned k = lb->batch_rr++ % pb->n_motors, before = lb->ntx;

		if (!(pb->batched & (1u << k)))
			continue;
		add_control(l, lb, pb->motors[k], now);
		served += lb->ntx != before;
	}
}

/* The V2 0x280 slot (rmd/loop.h "Frames").  rt-safe. */
static __attribute__((noinline)) void add_batch(struct rmd_loop *l, struct lbus *lb, int64_t now)
{
	const struct rmd_plan_bus *pb = lb->pb;
	const struct rmd_motor *ms[4] = { NULL };
	double torque[4] = { 0 };
	struct rmd_frame f;
	unsigned fl = 0, bad = 0;

	if (!batch_allowed(l, lb, now)) {
		batch_own(l, lb, now);
		return;
	}
	for (uint32_t m = pb->batched; m; m &= m - 1) {
		const struct lmotor *lm = &l->mot[pb->motors[__builtin_ctz(m)]];

		ms[lm->m.id - 1] = &lm->m;
		torque[lm->m.id - 1] = lm->sp.torque_nm;
	}
	if (rmd_motor_encode_v2_batch(ms, torque, &f, &fl, &bad) == 0) {
		l->cnt.nonfinite += bad;
		if (fl & RMD_MOTOR_CLAMPED)
			l->cnt.clamped++;
		loop_push_tx(lb, &f, 0, REQ_BATCH);
	}
}

/* ------------------------------------------------------------------ */
/* No acknowledgement */

/*
 * A bus nobody acknowledges (RMD_BUS_NO_ACK: its motors' power is off, an
 * e-stop; docs/faults.md "E-stop").  Whatever is written to it stays
 * queued, and goes out first when power returns: the setpoints of the
 * moment power died would reach motors that just booted.  So, from the
 * first cycle the bus says so:
 *   - once, what it still holds is dropped (rmd_bus_flush(): SocketCAN
 *     restarts the interface); RMD_EV_BUS_FLUSH says how that went and,
 *     when it could not, how many frames stay queued;
 *   - nothing that acts on a motor is written: no setpoint, safe action,
 *     owed 0x80/0x78, brake release or 0xB3.  Each control slot counts as
 *     a missed reply, as a request a bus-off bus does not take, so the
 *     motors are LOST within missed_replies_lost slots; their one-shots
 *     are dropped (a LOST motor's safe action among them: its output went
 *     off and its brake locked with the power);
 *   - a LOST motor's re-probe (0x9A, a read, every RMD_LOOP_REPROBE_NS)
 *     is written: the frame whose acknowledgement says power is back.
 * When the bus is acknowledged again, every motor of it that was not LOST
 * in the episode is made LOST (a cut shorter than missed_replies_lost is a
 * power cycle too), its one-shots dropped: each comes back as a lost motor
 * does, through STOPPING and a verified 0xB3, before anything moves it
 * (lifecycle.c loop_enter()); one LOST in it is on that way already (its
 * answer may be what ended the episode).  rt-safe (the flush may block:
 * rmd/bus.h).
 */

/* Every motor of lb: the one-shots dropped; those driven, as a mask.  rt-safe. */
static uint32_t unacked_drop(struct rmd_loop *l, struct lbus *lb)
{
	uint32_t driven = 0;

	for (unsigned k = 0; k < lb->pb->n_motors; k++) {
		unsigned i = lb->pb->motors[k];
		struct lmotor *lm = &l->mot[i];

		if (lm->st->lifecycle == RMD_LC_ENABLED || lm->st->lifecycle == RMD_LC_SAFE)
			driven |= UINT32_C(1) << i;
		loop_frames_drop(lm);
	}
	return driven;
}

/* The episode begins: the bus's state said, what it held flushed.  rt-safe. */
static void unacked_begin(struct rmd_loop *l, unsigned b, int64_t now)
{
	struct lbus *lb = &l->bus[b];
	uint32_t driven = unacked_drop(l, lb);
	int r = rmd_bus_flush(lb->bus);

	lb->unacked = true;
	lb->unacked_lost = 0;
	loop_event(l, now, RMD_EV_BUS_FLUSH, 0xFF, b, r,
		   (int64_t)((uint64_t)driven << 32 | lb->tx_unheard));
	lb->tx_unheard = lb->tx_last = 0;
}

/*
 * Bus b's cycle while its episode is open.  False when the episode just
 * ended: the caller sends the cycle as usual.  rt-safe.
 */
static __attribute__((cold, noinline)) bool send_unacked(struct rmd_loop *l, unsigned b,
							 const struct rmd_plan_due *d, int64_t now)
{
	struct lbus *lb = &l->bus[b];
	unsigned held = 0, taken;
	int r;

	if (lb->state_seen != RMD_BUS_NO_ACK) {
		if (!lb->unacked)
			return false;
		/* acknowledged again: its motors lost power, whatever they missed */
		for (unsigned k = 0; k < lb->pb->n_motors; k++)
			if (!(lb->unacked_lost >> k & 1))
				loop_motor_lost(l, &l->mot[lb->pb->motors[k]], now);
		unacked_drop(l, lb);
		lb->unacked = false;
		return false;
	}
	if (!lb->unacked)
		unacked_begin(l, b, now);
	for (unsigned k = 0; k < lb->pb->n_motors; k++) {
		unsigned i = lb->pb->motors[k];
		struct lmotor *lm = &l->mot[i];
		bool slot = (d->control >> k & 1) || (d->batch && (lb->pb->batched >> k & 1));

		if (lm->st->lifecycle == RMD_LC_LOST) {
			push_reprobe(l, lb, i, now);
		} else if (slot) {
			held++;
			loop_miss(l, lm, now);
		}
		if (lm->st->lifecycle == RMD_LC_LOST)
			lb->unacked_lost |= UINT32_C(1) << k;
	}
	/* a motor lost just now queued its safe action: it stays unsent */
	unacked_drop(l, lb);
	l->cnt.frames_not_sent += held;
	if (!lb->ntx)
		return true;
	r = rmd_bus_send(lb->bus, lb->tx, lb->ntx, now);
	taken = r > 0 ? (unsigned)r : 0;
	if (taken > lb->ntx)
		taken = lb->ntx;
	loop_commit(l, lb, 0, taken, now);
	lb->tx_last = taken;
	lb->tx_unheard += taken;
	l->cnt.frames_not_sent += lb->ntx - taken;
	for (unsigned k = taken; k < lb->ntx; k++)
		loop_miss(l, &l->mot[lb->meta[k].motor], now);
	return true;
}

/* ------------------------------------------------------------------ */

/*
 * Frames from..ntx-1 of bus b's cycle never left (r: what the send said):
 * the next cycle sends fresh setpoints; one-shots stay queued.  A request
 * that never left gets no reply either: it counts as missed, so a bus that
 * takes nothing (bus-off) loses its motors.  rt-safe.
 */
static void send_failed(struct rmd_loop *l, unsigned b, unsigned from, int r, int64_t now)
{
	struct lbus *lb = &l->bus[b];

	l->cnt.frames_not_sent += lb->ntx - from;
	for (unsigned k = from; k < lb->ntx; k++) {
		if (lb->meta[k].kind != REQ_BATCH) {
			loop_miss(l, &l->mot[lb->meta[k].motor], now);
			continue;
		}
		for (unsigned j = 0; j < lb->pb->n_motors; j++)
			if (lb->pb->batched & (1u << j))
				loop_miss(l, &l->mot[lb->pb->motors[j]], now);
	}
	/* what the send found first: a bus-off is the cause of the failure (issue 33 point 7) */
	loop_bus_state(l, b, now);
	if (!lb->failing || !lb->ev_send_any || now - lb->ev_send_ns >= EVENT_INTERVAL_NS) {
		lb->ev_send_any = true;
		lb->ev_send_ns = now;
		loop_event(l, now, RMD_EV_SEND_FAILED, 0xFF, b, r < 0 ? r : -ENOBUFS,
			   lb->ntx - from);
	}
	lb->failing = true;
}

/*
 * Whether bus b's refusal (r frames taken, r >= 0: ENOBUFS/EAGAIN, the
 * queue full) is worth a retry within the cycle: the bus is error-active
 * or warning and frames came from it within a reply deadline, so the queue
 * drains (a USB adapter whose transfers wait behind a camera's).  A bus
 * that stays silent, goes passive or off, or that nobody acknowledges is
 * not retried: its frames would only wait there for the motors' power to
 * return (loop_tx.c "No acknowledgement").  rt-safe.
 */
static bool may_retry(const struct rmd_loop *l, const struct lbus *lb, int r, int64_t now)
{
	enum rmd_bus_state st = rmd_bus_state(lb->bus);

	return r >= 0 && (st == RMD_BUS_ACTIVE || st == RMD_BUS_WARNING) && lb->heard_ns &&
	       now - lb->heard_ns <= lb->reply_ns && l->period_ns > 0;
}

/* Send the cycle's frames of bus b in one call.  False when it did not take them all.  rt-safe. */
bool loop_send_bus(struct rmd_loop *l, unsigned b, int64_t now)
{
	struct lbus *lb = &l->bus[b];
	struct rmd_plan_due d;
	unsigned taken;
	int r;

	lb->ntx = 0;
	if (!rmd_plan_due(l->plan, b, l->cycle, &d))
		return true;
	if (__builtin_expect(lb->unacked | (lb->state_seen == RMD_BUS_NO_ACK), 0) &&
	    send_unacked(l, b, &d, now))
		return false;
	/* in rmd_plan_cycle()'s order: 0x280, control, 0x92 reads, status reads */
	if (d.batch)
		add_batch(l, lb, now);
	for (uint32_t m = d.control; m; m &= m - 1)
		add_control(l, lb, lb->pb->motors[__builtin_ctz(m)], now);
	for (uint32_t m = d.fine; m; m &= m - 1)
		add_fine(l, lb, lb->pb->motors[__builtin_ctz(m)]);
	for (unsigned j = 0; j < d.n_polls; j++)
		if (d.polls[j].cycle == d.at)
			add_status(l, lb, d.polls[j].motor, now);
	if (!lb->ntx)
		return true;
	r = rmd_bus_send(lb->bus, lb->tx, lb->ntx, now);
	taken = r > 0 ? (unsigned)r : 0;
	if (taken > lb->ntx)
		taken = lb->ntx;
	loop_commit(l, lb, 0, taken, now);
	lb->tx_last = taken;
	lb->tx_unheard += taken;
	if (taken >= lb->ntx) {
		lb->failing = false;
		return true;
	}
	if (__builtin_expect(may_retry(l, lb, r, now), 1)) {
		/* issue 32 point 8: a full queue on a bus that carries frames drains; try again */
		lb->tx_off = taken;
		lb->retry_until_ns = now + l->period_ns / RETRY_SHARE;
		l->retry_buses |= 1u << b;
		l->retry_next_ns = now + RETRY_STEP_NS;
		return true;
	}
	send_failed(l, b, taken, r, now);
	return false;
}

/*
 * Issue 32 point 8.  Within a period / RETRY_SHARE of its tick, so that a
 * frame sent late leaves half a period ahead of its motor's next: no two
 * frames to one motor bunch up.  rt-safe.
 */
void loop_retry_sends(struct rmd_loop *l, int64_t now, bool give_up)
{
	l->retry_next_ns = now + RETRY_STEP_NS;
	for (unsigned m = l->retry_buses; m; m &= m - 1) {
		unsigned b = (unsigned)__builtin_ctz(m);
		struct lbus *lb = &l->bus[b];
		int r = 0;

		if (!give_up) {
			unsigned taken;

			r = rmd_bus_send(lb->bus, lb->tx + lb->tx_off, lb->ntx - lb->tx_off, now);
			taken = r > 0 ? (unsigned)r : 0;
			if (taken > lb->ntx - lb->tx_off)
				taken = lb->ntx - lb->tx_off;
			loop_commit(l, lb, lb->tx_off, lb->tx_off + taken, now);
			lb->tx_off += taken;
			lb->tx_last += taken;
			lb->tx_unheard += taken;
			lb->tx_retried += taken;
			if (lb->tx_off >= lb->ntx) {
				lb->failing = false;
				l->retry_buses &= ~(1u << b);
				continue;
			}
			if (r >= 0 && now < lb->retry_until_ns)
				continue;
		}
		/* still refused at the end of its share of the cycle: a failed send */
		l->retry_buses &= ~(1u << b);
		l->stats.plan_misses++;
		send_failed(l, b, lb->tx_off, r, now);
	}
}
