// SPDX-License-Identifier: MIT
/*
 * The rt loop's motor lifecycle: the one state-change function
 * loop_enter() and what decides to call it (missed replies, answers, error
 * flags, the host's commands and the host watchdog), and each motor's
 * comm-loss protection (0xB3), a precondition of leaving READY.  See
 * rmd/loop.h "Lifecycle", "Safe actions" and "Comm-loss protection"; the
 * shared state is loop_state.h.
 *
 * Execution context: rt-safe: called from the cycle (loop_enter() also from bring-up
 * and rmd_loop_stop_motors()); no allocation, no lock, no text.
 */
#include <errno.h>
#include <math.h>
#include <string.h>

#include "rmd/loop.h"
#include "rmd/dialect.h"
#include "rmd/motor.h"
#include "rmd/multiturn.h"
#include "loop_state.h"
#include "loop_env.h"

/* Forget the one-shots waiting and the damp stream.  rt-safe. */
void loop_frames_drop(struct lmotor *lm)
{
	lm->n_oneshot = 0;
	lm->life.damp_stream = false;
}

/* rt-safe. */
static void oneshot_push(struct lmotor *lm, const struct rmd_frame *f)
{
	if (lm->n_oneshot < ONESHOTS)
		lm->oneshot[lm->n_oneshot++] = *f;
}

/* ------------------------------------------------------------------ */
/* Lifecycle and safe actions */

/*
 * Queue the safe action's frames for lm.  stream: a SAFE motor with MIT damp
 * gets the damp frame in every control slot instead of once.
 * rt-safe.
 */
static void queue_safe(struct rmd_loop *l, struct lmotor *lm, bool stream, int64_t now)
{
	enum rmd_safe_action a = loop_safe_action(l);
	struct rmd_frame f[2];
	int n;

	if (a == RMD_SAFE_DAMP && lm->m.mit_scaled && stream) {
		lm->life.damp_stream = true;
	} else {
		n = rmd_motor_encode_safe(&lm->m, a, f);
		for (int k = 0; k < n; k++)
			oneshot_push(lm, &f[k]);
		if (n <= 0 && rmd_motor_encode_cmd(&lm->m, 0x80, &f[0]) == 0)
			oneshot_push(lm, &f[0]);
	}
	l->cnt.safe_actions++;
	loop_event(l, now, RMD_EV_SAFE_ACTION, loop_idx(l, lm), lm->m.bus, a, 0);
}

static void cl_forget(struct rmd_loop *l, struct lmotor *lm);
static void cl_busy(struct rmd_loop *l, struct lmotor *lm);
static void pos_forget(struct lmotor *lm);
static void pos_begin(struct rmd_loop *l, struct lmotor *lm, int64_t now);

/* rt-safe. */
static void push_oneshot_cmd(struct lmotor *lm, uint8_t cmd)
{
	struct rmd_frame f;

	if (rmd_motor_encode_cmd(&lm->m, cmd, &f) == 0)
		oneshot_push(lm, &f);
}

/* ------------------------------------------------------------------ */
/* Owed frames */

/*
 * rmd/proc_owed.h decides what a motor owes and when it paid; here its
 * outcomes are applied: a STOPPING motor that owes nothing more is READY,
 * one that leaves its debt unpaid for RMD_OWED_SENDS_MAX sends is LOST.
 */

/* lm owes the frames of `bits` from now on (those its dialect has).  rt-safe. */
static void owe(struct lmotor *lm, unsigned bits)
{
	struct rmd_frame f;

	if ((bits & RMD_OWE_OFF) && rmd_motor_encode_cmd(&lm->m, 0x80, &f) < 0)
		bits &= ~(unsigned)RMD_OWE_OFF;
	if ((bits & RMD_OWE_BRAKE) && rmd_motor_encode_cmd(&lm->m, 0x78, &f) < 0)
		bits &= ~(unsigned)RMD_OWE_BRAKE;
	rmd_owed_begin(&lm->owed, bits, lm->seq); /* the requests booked from now on */
}

/* The owed frame lm's next control slot carries, if it owes one.  rt-safe. */
bool loop_owed_frame(const struct lmotor *lm, struct rmd_frame *f)
{
	uint8_t cmd = rmd_owed_next(&lm->owed);

	return cmd && rmd_motor_encode_cmd(&lm->m, cmd, f) == 0;
}

/* An owed frame (command byte cmd) of lm was taken by its bus.  rt-safe. */
void loop_owed_sent(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd)
{
	if (rmd_owed_sent(&lm->owed, cmd))
		l->cnt.owed_resends++;
}

/*
 * A request of lm went unanswered, or an owed frame was answered with
 * other bytes than its own: after RMD_OWED_SENDS_MAX owed sends the motor
 * is LOST (loop_rx.c, while it drains or checks deadlines: never while a
 * send is booked, whose one-shots a lifecycle change would reorder).
 * rt-safe.
 */
void loop_owed_unpaid(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	if (rmd_owed_exhausted(&lm->owed) && lm->st->lifecycle != RMD_LC_LOST)
		loop_motor_lost(l, lm, now);
}

/*
 * lm answered its request req_seq, command byte cmd, repeating it or not
 * (loop_rx.c; bring-up's own for its frames): the debt's outcome applied.
 * True when the answer was an owed frame's echo (it carries no values).
 * rt-safe.
 */
bool loop_owed_answer(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd, uint64_t req_seq,
		      bool repeats, int64_t now)
{
	switch (rmd_owed_answer(&lm->owed, cmd, req_seq, repeats)) {
	case RMD_OWED_NONE:
		return false;
	case RMD_OWED_UNPAID:
		loop_owed_unpaid(l, lm, now);
		return false;
	case RMD_OWED_CLEAR:
		if (lm->st->lifecycle == RMD_LC_STOPPING)
			loop_enter(l, lm, RMD_LC_READY, now);
		return true;
	case RMD_OWED_PAID:
	case RMD_OWED_AGAIN:
		return true;
	}
	return false;
}

/*
 * The one place a motor changes lifecycle state: RMD_EV_MOTOR_STATE (after
 * the error event that causes or ends FAULT), then the entry actions of lc.  Nothing happens when lm is in lc already.
 * What each state promises about the motor's output and brake is
 * docs/design.md "The life of a motor".
 *
 *   ENABLED   V3 §2.26 / V2 §3.50: the brake opens before the first setpoint.
 *   SAFE      the safe action, streamed (MIT damp in every control slot).
 *   STOPPING  owes 0x80 and 0x78 ("Owed frames"); READY once both are echoed.
 *             Every way to READY goes through it: from ENABLED or SAFE
 *             (enable = 0), FAULT (flags cleared), LOST (it answers again)
 *             and PROBE (found: it may run for a previous owner).
 *   READY     only from STOPPING with nothing owed (asked for from anywhere
 *             else, it is STOPPING); the configured mode.
 *   FAULT     owes 0x80, and 0x78 as rmd_config_fault_brakes() says (a
 *             faulted motor runs no control command, V3 §2.17.1: no 0xA2,
 *             no 0x81); reports the error code.
 *   LOST      the safe action once when it was ENABLED, else nothing
 *             waits; re-probes after RMD_LOOP_REPROBE_NS.
 *
 * Position (rmd/multiturn.h): LOST forgets whether it can be trusted;
 * READY from PROBE or LOST decides it anew (pos_begin()).
 *
 * Comm-loss protection: LOST forgets it (the motor that comes back may have
 * been swapped or reflashed); READY reached from PROBE or LOST (through
 * STOPPING, and FAULT on the way) starts a round of 0xB3 writes (a motor
 * found after bring-up, or back).  FAULT -> READY keeps it: the motor
 * answered all along, and a power cycle makes it miss replies, which is
 * LOST (the time is in its ROM anyway).
 *
 * The enable-edge rule (rmd/loop.h): a motor that enters LOST or FAULT,
 * returns from them, or is made SAFE for any reason, the host watchdog
 * included, takes enable = 1 only after an enable = 0; a motor found at
 * bring-up takes it at once.  Leaving FAULT reports error code 0.
 * rt-safe.
 */
void loop_enter(struct rmd_loop *l, struct lmotor *lm, enum rmd_lifecycle lc, int64_t now)
{
	enum rmd_lifecycle old = (enum rmd_lifecycle)lm->st->lifecycle;

	/* READY is STOPPING's debt paid, never a jump */
	if (lc == RMD_LC_READY && (old != RMD_LC_STOPPING || lm->owed.bits))
		lc = RMD_LC_STOPPING;
	if (old == lc)
		return;
	lm->st->release_until_ns = 0; /* ENABLED's brake release sets it anew (loop_tx.c) */
	if (lc != RMD_LC_READY) {
		/* READY keeps what waits: STOPPING queued nothing but a 0xB3 round's writes */
		loop_frames_drop(lm);
		rmd_owed_drop(&lm->owed);
	}
	/*
	 * The events in the order things happened (issue 20.11): the error
	 * flags that cause FAULT, or their clearing that ends it, then the
	 * change of state, then what the entry sends (the safe action).
	 */
	if (lc == RMD_LC_FAULT)
		loop_event(l, now, RMD_EV_MOTOR_ERROR, loop_idx(l, lm), lm->m.bus,
			   lm->st->error_code, 0);
	else if (old == RMD_LC_FAULT && lc == RMD_LC_STOPPING)
		loop_event(l, now, RMD_EV_MOTOR_ERROR, loop_idx(l, lm), lm->m.bus, 0, 0);
	loop_event(l, now, RMD_EV_MOTOR_STATE, loop_idx(l, lm), lm->m.bus, old, lc);
	switch (lc) {
	case RMD_LC_ENABLED:
		push_oneshot_cmd(lm, 0x77);
		break;
	case RMD_LC_SAFE:
		if (!l->stopping) /* rmd_loop_stop_motors() sent its own */
			queue_safe(l, lm, true, now);
		lm->life.need_edge = true; /* the host watchdog's too: the latch (rmd/loop.h) */
		break;
	case RMD_LC_STOPPING:
		owe(lm, RMD_OWE_OFF | RMD_OWE_BRAKE);
		if (old != RMD_LC_FAULT) /* FAULT on the way keeps where it came from */
			lm->life.stop_from = (uint8_t)old;
		if (old == RMD_LC_PROBE)
			lm->life.need_edge = false;
		else if (old == RMD_LC_LOST || old == RMD_LC_FAULT)
			lm->life.need_edge = true;
		/* found, or back: running in a boot its runtime places (rmd/reboot.h) */
		if (old == RMD_LC_PROBE || old == RMD_LC_LOST)
			rmd_reboot_found(&lm->rb, now,
					 loop_reboot_cmd(lm) == RMD_REBOOT_CMD_RUNTIME);
		/* back: pushes another tool may have left on go off, as at bring-up */
		if (old == RMD_LC_LOST)
			rmd_silence_begin(&lm->sil, lm->m.d);
		break;
	case RMD_LC_READY:
		lm->st->mode = (uint8_t)lm->m.mode;
		if (lm->life.stop_from == RMD_LC_PROBE || lm->life.stop_from == RMD_LC_LOST) {
			cl_forget(l, lm);
			if (rmd_arm_pending(&lm->arm)) {
				rmd_arm_start_round(&lm->arm);
				cl_busy(l, lm);
			}
			pos_begin(l, lm, now); /* it may have been powered off */
		}
		lm->life.stop_from = RMD_LC_READY;
		break;
	case RMD_LC_LOST:
	case RMD_LC_FAULT:
		lm->life.need_edge = true;
		lm->arm.want = false;
		if (lc == RMD_LC_LOST) {
			if (old == RMD_LC_ENABLED)
				queue_safe(l, lm, false, now);
			lm->life.next_probe_ns = now + RMD_LOOP_REPROBE_NS;
			rmd_reboot_forget(&lm->rb);   /* back is found anew */
			rmd_silence_forget(&lm->sil); /* sent again when it is back */
			cl_forget(l, lm);
			pos_forget(lm);
			/* V2: the encoder cannot tell what turned while it was silent */
			rmd_motor_forget_v2_reference(&lm->m);
		} else {
			owe(lm,
			    RMD_OWE_OFF | (rmd_config_fault_brakes(l->cfg) ? RMD_OWE_BRAKE : 0));
		}
		break;
	case RMD_LC_PROBE:
	case RMD_LC_COUNT:
		break;
	}
	lm->st->lifecycle = (uint8_t)lc;
}

/* An ENABLED motor gets the safe action and becomes SAFE.  rt-safe. */
static void make_safe(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	if (lm->st->lifecycle == RMD_LC_ENABLED)
		loop_enter(l, lm, RMD_LC_SAFE, now);
}

/* rt-safe. */
void loop_motor_lost(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	if (lm->st->lifecycle == RMD_LC_LOST)
		return;
	loop_enter(l, lm, RMD_LC_LOST, now);
	if (l->cfg->safety.lost_motor_action == RMD_LOST_ALL)
		for (unsigned j = 0; j < l->n_motors; j++)
			if (&l->mot[j] != lm)
				make_safe(l, &l->mot[j], now);
}

/*
 * lm rebooted, its answers say (rmd/reboot.h): reported, then lost -- its
 * safe action if it was ENABLED, `lost_motor_action: all` as for any loss,
 * its comm-loss protection, position and V2 count forgotten -- and, as it
 * answers, probed at once: back, it is STOPPING, READY once it echoed
 * output off and brake locked, its 0xB3 written and verified again and
 * its position decided again before anything moves it, and the
 * controller enables it again with enable = 0, then 1 (loop_enter()).
 * rt-safe.
 */
void loop_rebooted(struct rmd_loop *l, struct lmotor *lm, unsigned how, int64_t what, int64_t now)
{
	loop_event(l, now, RMD_EV_REBOOT, loop_idx(l, lm), lm->m.bus, how, what);
	/* a boot resets what its firmware remembers of MIT frames (RMD_QUIRK_A4_AFTER_MIT) */
	lm->m.mit_sent = false;
	lm->m.fw_warned = false;
	loop_motor_lost(l, lm, now);
	lm->life.next_probe_ns = now;
}

/* rt-safe. */
void loop_miss(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	unsigned n = l->cfg->safety.missed_replies_lost ? l->cfg->safety.missed_replies_lost : 1;

	lm->st->missed_replies++;
	l->cnt.missed++;
	lm->consecutive++;
	if (lm->consecutive >= n && lm->st->lifecycle != RMD_LC_LOST)
		loop_motor_lost(l, lm, now);
}

/* Error flags from a 0x9A answer or report.  prev: the code before it.  rt-safe. */
void loop_note_errors(struct rmd_loop *l, struct lmotor *lm, uint16_t prev, int64_t now)
{
	uint16_t code = lm->st->error_code;

	if (lm->st->lifecycle != RMD_LC_FAULT) {
		if (code)
			loop_enter(l, lm, RMD_LC_FAULT, now);
	} else if (!code) {
		loop_enter(l, lm, RMD_LC_STOPPING, now);
	} else if (code != prev) {
		loop_event(l, now, RMD_EV_MOTOR_ERROR, loop_idx(l, lm), lm->m.bus, code, 0);
	}
}

/* ------------------------------------------------------------------ */
/* Commands and the host watchdog */

static void cl_enable_wanted(struct rmd_loop *l, struct lmotor *lm, const struct rmd_setpoint *sp,
			     int64_t now);

/* sp is in force (ENABLED).  rt-safe. */
static inline void take_setpoint(struct lmotor *lm, const struct rmd_setpoint *sp)
{
	lm->sp = *sp;
	lm->st->mode = sp->mode;
}

/*
 * A setpoint that drives to a position, for a motor whose position is
 * uncertain: not taken (an ENABLED motor gets the safe action and waits
 * for an enable = 0, as after any refusal while it runs); reported once
 * per episode.  Returns RMD_IGN_POS_UNCERTAIN.  rt-safe.
 */
static __attribute__((cold, noinline)) int pos_refuse(struct rmd_loop *l, struct lmotor *lm,
						      const struct rmd_setpoint *sp, int64_t now)
{
	if (rmd_settle_warn_once(&lm->settle)) {
		loop_event(l, now, RMD_EV_POS_REFUSED, loop_idx(l, lm), lm->m.bus,
			   lm->st->pos_trust, sp->mode);
	}
	if (lm->st->lifecycle == RMD_LC_ENABLED)
		loop_enter(l, lm, RMD_LC_SAFE, now);
	return RMD_IGN_POS_UNCERTAIN;
}

/*
 * An MIT setpoint for a motor in MIT mode whose MIT scaling is not decided
 * (rmd/motor.h mit_scaled): never enabled, as no MIT frame may go out over
 * ranges its firmware may not scale by; reported once.  Returns
 * RMD_IGN_MIT_SCALING.  rt-safe.
 */
static __attribute__((cold, noinline)) int mit_refuse(struct rmd_loop *l, struct lmotor *lm,
						      int64_t now)
{
	if (rmd_ident_mit_warn_once(&lm->ident)) {
		loop_event(l, now, RMD_EV_MIT_REFUSED, loop_idx(l, lm), lm->m.bus,
			   lm->ident.version, 0);
	}
	return RMD_IGN_MIT_SCALING;
}

/*
 * Whether lm's firmware does not run sp's mode now (rmd_motor_runs()):
 * position (0xA4) after an MIT frame, on firmware that ignores it until
 * it is reset (RMD_QUIRK_A4_AFTER_MIT: a field report).  rt-safe.
 */
static inline bool fw_cannot(const struct lmotor *lm, const struct rmd_setpoint *sp)
{
	return !rmd_motor_runs(&lm->m, sp->mode);
}

int loop_fw_refuse(struct rmd_loop *l, struct lmotor *lm, enum rmd_mode mode, int64_t now)
{
	if (!lm->m.fw_warned) {
		lm->m.fw_warned = true;
		loop_event(l, now, RMD_EV_FW_REFUSED, loop_idx(l, lm), lm->m.bus, lm->ident.version,
			   mode);
	}
	if (lm->st->lifecycle == RMD_LC_ENABLED)
		loop_enter(l, lm, RMD_LC_SAFE, now);
	return RMD_IGN_FIRMWARE;
}

/*
 * An ENABLED motor's setpoint while its position is uncertain or its
 * firmware has quirks: refused when its firmware does not run its mode
 * now (fw_refuse()), or when it needs a trusted position the motor has not
 * (pos_refuse()); else taken.  Returns -1 or the enum rmd_ignore reason.
 * rt-safe.
 */
static __attribute__((noinline)) int slow_setpoint(struct rmd_loop *l, struct lmotor *lm,
						   const struct rmd_setpoint *sp, int64_t now)
{
	if (fw_cannot(lm, sp))
		return loop_fw_refuse(l, lm, sp->mode, now);
	if (!lm->st->pos_certain && rmd_setpoint_needs_pos(sp))
		return pos_refuse(l, lm, sp, now);
	take_setpoint(lm, sp);
	return -1;
}

/* Returns -1 when acted on, else the enum rmd_ignore reason it was not.  rt-safe. */
static int enable_motor(struct rmd_loop *l, struct lmotor *lm, const struct rmd_setpoint *sp,
			int64_t now)
{
	switch ((enum rmd_lifecycle)lm->st->lifecycle) {
	case RMD_LC_READY:
	case RMD_LC_SAFE:
		if (lm->life.need_edge)
			return RMD_IGN_EDGE;
		if (sp->mode == RMD_MODE_MIT && lm->m.mit_mode && !lm->m.mit_scaled)
			return mit_refuse(l, lm, now);
		if (!lm->st->pos_certain && rmd_setpoint_needs_pos(sp))
			return pos_refuse(l, lm, sp, now);
		if (__builtin_expect(fw_cannot(lm, sp), 0))
			return loop_fw_refuse(l, lm, sp->mode, now);
		if (!rmd_comm_loss_allows_motion(lm->arm.cl)) {
			/* armed first, then enabled, or refused with a reason (unarmed_rejects) */
			cl_enable_wanted(l, lm, sp, now);
			return -1;
		}
		take_setpoint(lm, sp);
		loop_enter(l, lm, RMD_LC_ENABLED, now);
		break;
	case RMD_LC_ENABLED:
		return slow_setpoint(l, lm, sp, now);
	case RMD_LC_PROBE:
	case RMD_LC_STOPPING:
	case RMD_LC_FAULT:
	case RMD_LC_LOST:
	case RMD_LC_COUNT:
		return RMD_IGN_NOT_READY;
	}
	return -1;
}

/* rt-safe. */
static void disable_motor(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	lm->life.need_edge = false; /* the enable = 0 the edge rule waits for */
	lm->arm.want = false;
	switch ((enum rmd_lifecycle)lm->st->lifecycle) {
	case RMD_LC_ENABLED:
	case RMD_LC_SAFE:
		loop_enter(l, lm, RMD_LC_STOPPING, now);
		break;
	case RMD_LC_READY:
	case RMD_LC_STOPPING:
	case RMD_LC_PROBE:
	case RMD_LC_FAULT:
	case RMD_LC_LOST:
	case RMD_LC_COUNT:
		break;
	}
}

/* rt-safe. */
static void set_watchdog(struct rmd_loop *l, enum rmd_watchdog_state s, int64_t now)
{
	if (l->wd == s)
		return;
	l->wd = (uint8_t)s;
	loop_event(l, now, RMD_EV_WATCHDOG, 0xFF, 0xFF, s, 0);
}

/*
 * A robot-wide stop (rmd_command.robot_stops, docs/robot.md): every
 * ENABLED motor gets the safe action, and the trip is latched as the
 * watchdog's is, so a command that arrived before it lifts nothing and
 * each motor takes enable = 1 only after an enable = 0.  rt-safe.
 */
static __attribute__((cold, noinline)) void robot_stop(struct rmd_loop *l, int64_t now)
{
	l->trip_ns = now;
	set_watchdog(l, RMD_WD_TRIPPED, now);
	for (unsigned i = 0; i < l->n_motors; i++)
		make_safe(l, &l->mot[i], now);
}

/*
 * The newest command.  An enable = 0 the loop did not see (the bridge
 * handed a newer command over before this cycle) shows as a change of
 * disables[]: it is acted on first, so enable = 0 then enable = 1 works
 * however fast they come, and always, whenever it arrived.  rx_ns is
 * when the command arrived: after rmdd was held off, the bridge hands
 * over what queued meanwhile with its old stamps, so a command from
 * before a trip does not lift it, and one that is older than the command
 * timeout already moves nothing (the watchdog trips on it this cycle).
 * The watchdog is per motor: an enable = 1 entry gives its motor until
 * rx_ns + command_timeout_ms (cmd_due_ns); a command that does not carry
 * a motor gives it nothing.
 * rt-safe.
 */
void loop_take_command(struct rmd_loop *l, int64_t now)
{
	int64_t timeout = (int64_t)l->cfg->safety.command_timeout_ms * RMD_NS_PER_MS;
	int64_t due, first = INT64_MAX;
	const struct rmd_command *c;
	const void *p;
	bool any_enable = false;
	uint32_t present;

	if (!l->o.commands || !rmd_latest_get(l->o.commands, &p))
		return;
	c = p;
	l->cnt.commands++;
	l->cmd = c;
	/* c is not the loop's to write: its mask read once */
	present = c->present;
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		if (c->disables[i] != lm->life.disables_seen) {
			lm->life.disables_seen = c->disables[i];
			disable_motor(l, lm, now);
		}
	}
	if (__builtin_expect(c->robot_stops != l->robot_stops_seen, 0)) {
		l->robot_stops_seen = c->robot_stops;
		robot_stop(l, now);
	}
	if (c->robot_hold || (l->wd == RMD_WD_TRIPPED && c->rx_ns <= l->trip_ns) ||
	    (timeout > 0 && now - c->rx_ns > timeout)) {
		for (unsigned i = 0; i < l->n_motors; i++)
			if (present & (1u << i) && c->m[i].enable)
				l->cnt.ignored[RMD_IGN_TRIPPED]++;
		return;
	}
	due = timeout > 0 ? c->rx_ns + timeout : INT64_MAX;
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		if (!(present & (1u << i))) {
			if (lm->st->lifecycle == RMD_LC_ENABLED && l->cmd_due_ns[i] < first)
				first = l->cmd_due_ns[i];
			continue;
		}
		if (c->m[i].enable) {
			int why = -1;

			l->cmd_due_ns[i] = due;
			if (lm->st->lifecycle ==
			    RMD_LC_ENABLED) { /* enable_motor()'s, every cycle */
				if (__builtin_expect(lm->st->pos_certain, 1))
					take_setpoint(lm, &c->m[i]);
				else
					why = slow_setpoint(l, lm, &c->m[i], now);
			} else {
				why = enable_motor(l, lm, &c->m[i], now);
			}
			if (why >= 0)
				l->cnt.ignored[why]++;
			else
				any_enable = true;
		} else {
			disable_motor(l, lm, now);
		}
	}
	/* every entry acted on has `due`; early is harmless: loop_watchdog() only looks again */
	if (any_enable) {
		if (due < first)
			first = due;
		set_watchdog(l, RMD_WD_OK, now);
	}
	l->wd_due_ns = first;
}

/*
 * The ENABLED motors whose command deadline passed get the safe action
 * (SAFE); the others' earliest deadline is the next to watch.  rt-safe.
 */
static __attribute__((cold, noinline)) void watchdog_expire(struct rmd_loop *l, int64_t now)
{
	int64_t first = INT64_MAX;
	bool trip = false;

	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		if (lm->st->lifecycle != RMD_LC_ENABLED)
			continue;
		if (now > l->cmd_due_ns[i])
			trip = true;
		else if (l->cmd_due_ns[i] < first)
			first = l->cmd_due_ns[i];
	}
	l->wd_due_ns = first;
	if (!trip)
		return;
	l->trip_ns = now;
	l->cnt.watchdog_trips++;
	set_watchdog(l, RMD_WD_TRIPPED, now);
	for (unsigned i = 0; i < l->n_motors; i++)
		if (now > l->cmd_due_ns[i])
			make_safe(l, &l->mot[i], now);
}

/*
 * The host watchdog, per motor: an ENABLED motor that no command carried
 * for command_timeout_ms gets the safe action.  One compare a cycle: the
 * motors are looked at only when the earliest deadline passed.  rt-safe.
 */
void loop_watchdog(struct rmd_loop *l, int64_t now)
{
	if (__builtin_expect(now > l->wd_due_ns, 0))
		watchdog_expire(l, now);
}

/* ------------------------------------------------------------------ */
/* Comm-loss protection */

/*
 * Each motor's 0xB3 (V3 §2.30) is a precondition of motion (enum
 * rmd_comm_loss, rmd/state.h).  Bring-up writes it last and hands its
 * outcome to loop_cl_outcome().  The loop writes it again, in rounds of up
 * to RMD_ARM_TRIES writes (each a one-shot in the motor's control slot, its
 * answer awaited for the bus's reply deadline after the slot comes; a
 * status read goes ahead of it in that slot, loop_tx.c, so that a motor
 * that tripped since its last frame echoes the read, not the write):
 *   - when a motor answers after PROBE or LOST (loop_enter()): found after
 *     bring-up, or back, and perhaps swapped or reflashed;
 *   - when an enable arrives for a motor that is not armed, at most one
 *     round per RMD_ARM_ROUND_NS: 0xB3 writes the motor's ROM, so it is never
 *     written in a loop of its own.
 * An enable that arrives during a round waits for it and is applied once
 * the motor is armed, unless the controller has gone quiet for
 * command_timeout_ms meanwhile or the watchdog tripped; a round that fails
 * refuses it.  An enable for a motor whose round failed less than
 * RMD_ARM_ROUND_NS ago is refused (a later one starts a new round).  A
 * refusal is counted per motor (unarmed_rejects, in health) and reported
 * through the event ring once per episode (until the motor is armed or
 * lost).  Motors whose protection is off by config are not written by
 * the loop and never held back.  V2 motors have none (no 0xB3): they move
 * only when their config turns it off (comm_loss_ms: 0, OFF as any other);
 * else (UNSUPPORTED: a configuration the loader refuses) every enable is
 * refused, and nothing is written.
 */

/* rt-safe. */
static uint32_t cl_ms(const struct rmd_loop *l, const struct lmotor *lm)
{
	return rmd_config_comm_loss_ms(l->cfg, loop_idx(l, lm));
}

/* Forget the protection: the motor may not be the one that was armed.  rt-safe. */
static void cl_forget(struct rmd_loop *l, struct lmotor *lm)
{
	rmd_arm_forget(&lm->arm, cl_ms(l, lm), lm->m.caps & RMD_DIALECT_COMM_LOSS_B3);
}

/* lm's round runs, or an enable waits for one: loop_comm_loss() looks at it.  rt-safe. */
static void cl_busy(struct rmd_loop *l, struct lmotor *lm)
{
	l->arm_busy |= UINT32_C(1) << loop_idx(l, lm);
}

/* An enable refused for lm: counted, reported once per episode.  rt-safe. */
static void cl_refuse(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	if (rmd_arm_refused(&lm->arm))
		loop_event(l, now, RMD_EV_COMM_LOSS, loop_idx(l, lm), lm->m.bus, lm->arm.cl, 1);
}

/* An enable for a READY or SAFE motor that is not armed (enable_motor()).  rt-safe. */
static void cl_enable_wanted(struct rmd_loop *l, struct lmotor *lm, const struct rmd_setpoint *sp,
			     int64_t now)
{
	if (rmd_arm_enable_wanted(&lm->arm, sp, now) == RMD_ARM_REFUSE)
		cl_refuse(l, lm, now);
	else
		cl_busy(l, lm);
}

/* Queue the next write of lm's round.  False when its one-shot queue is full.  rt-safe. */
static bool cl_push(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	unsigned div = l->cfg->motors[loop_idx(l, lm)].rate_divisor;
	struct rmd_frame f;

	if (lm->n_oneshot >= ONESHOTS ||
	    rmd_motor_encode_comm_timeout(&lm->m, cl_ms(l, lm), &f) < 0)
		return false;
	oneshot_push(lm, &f);
	/* it goes out after the one-shots before it, one per control slot */
	rmd_arm_written(&lm->arm, now + l->bus[lm->m.bus].reply_ns +
					  (int64_t)lm->n_oneshot * (div ? div : 1u) * l->period_ns);
	return true;
}

/* One step of lm's round: the next write, or its end.  rt-safe. */
static void cl_round_step(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	bool reachable = lm->st->lifecycle != RMD_LC_LOST && lm->st->lifecycle != RMD_LC_PROBE;

	switch (rmd_arm_step(&lm->arm, reachable, now)) {
	case RMD_ARM_IDLE:
		break;
	case RMD_ARM_WRITE:
		cl_push(l, lm, now);
		break;
	case RMD_ARM_FAILED:
		if (lm->arm.want) {
			lm->arm.want = false;
			cl_refuse(l, lm, now);
		} else {
			loop_event(l, now, RMD_EV_COMM_LOSS, loop_idx(l, lm), lm->m.bus, lm->arm.cl,
				   0);
		}
		break;
	}
}

/* The enable that waited for lm's round, now that it is armed.  rt-safe. */
static void cl_apply_enable(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	int64_t due = l->cmd_due_ns[loop_idx(l, lm)];

	lm->arm.want = false;
	if (l->wd == RMD_WD_TRIPPED || now > due)
		return; /* the controller went quiet meanwhile */
	enable_motor(l, lm, &lm->arm.sp, now);
	if (lm->st->lifecycle == RMD_LC_ENABLED && due < l->wd_due_ns)
		l->wd_due_ns = due;
}

/*
 * Every motor's round, and the enables waiting for one: step 3 of the
 * cycle; only the motors that have either are looked at (arm_busy).
 * rt-safe.
 */
void loop_comm_loss(struct rmd_loop *l, int64_t now)
{
	for (uint32_t m = l->arm_busy; m; m &= m - 1) {
		unsigned i = (unsigned)__builtin_ctz(m);
		struct lmotor *lm = &l->mot[i];

		if (lm->arm.round)
			cl_round_step(l, lm, now);
		else if (lm->arm.want)
			cl_apply_enable(l, lm, now);
		if (!lm->arm.round && !lm->arm.want)
			l->arm_busy &= ~(UINT32_C(1) << i);
	}
}

/* An answer to a 0xB3 the loop wrote (loop_rx.c).  rt-safe. */
void loop_cl_answer(struct rmd_loop *l, struct lmotor *lm, const uint8_t *req,
		    const struct rmd_frame *rep, int64_t now)
{
	if (rmd_arm_answer(&lm->arm, req, rep, now) == RMD_ARM_NOW_ARMED)
		loop_event(l, now, RMD_EV_COMM_LOSS, loop_idx(l, lm), lm->m.bus, lm->arm.cl, 0);
}

/* Bring-up's outcome for lm (bringup.c): what its own writes came to.  rt-safe. */
void loop_cl_outcome(struct rmd_loop *l, struct lmotor *lm, enum rmd_comm_loss cl, int64_t now)
{
	rmd_arm_took_over(&lm->arm, cl_ms(l, lm), lm->m.caps & RMD_DIALECT_COMM_LOSS_B3, cl, now);
}

uint8_t rmd_loop_comm_loss(const struct rmd_loop *l, unsigned i)
{
	return i < l->n_motors ? l->mot[i].arm.cl : RMD_CL_PENDING;
}

/* ------------------------------------------------------------------ */
/* Position after a power cycle */

/*
 * rmd/proc_settle.h decides whether a motor that appears (bring-up) or
 * returns from LOST can trust its position, on the rule of
 * rmd/multiturn.h; here its decisions are applied: the state's trust, the
 * reported frame's shift into the travel band, the events.
 */

/* Decision t of lm's position applied, shifted by shift.  rt-safe. */
static void pos_set(struct rmd_loop *l, struct lmotor *lm, enum rmd_pos_trust t, double shift,
		    int64_t now)
{
	rmd_settle_decided(&lm->settle, t);
	lm->st->pos_trust = (uint8_t)t;
	lm->st->pos_certain = rmd_pos_trusted(t);
	loop_event(l, now, RMD_EV_POSITION, loop_idx(l, lm), lm->m.bus, t,
		   (int64_t)llround(shift * 1e6));
}

/* Lost: nothing is known of its position any more.  rt-safe. */
static void pos_forget(struct lmotor *lm)
{
	rmd_settle_forget(&lm->settle);
	lm->st->pos_trust = RMD_POS_UNKNOWN;
	lm->st->pos_certain = false;
}

/* READY from PROBE or LOST.  rt-safe. */
static void pos_begin(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	pos_forget(lm);
	if (rmd_settle_begin(&lm->settle, &lm->m.mt, now) == RMD_POS_SAVED)
		pos_set(l, lm, RMD_POS_SAVED, 0.0, now);
}

void loop_pos_settle(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	double shift;
	enum rmd_pos_trust t = rmd_settle_reading(&lm->settle, &lm->m.mt, lm->st->pos_rad,
						  lm->st->pos_rx_ns, &shift);

	if (t == RMD_POS_UNKNOWN)
		return; /* the first of two readings */
	if (t == RMD_POS_IN_BAND && shift != 0.0) {
		rmd_motor_shift_pos(&lm->m, shift);
		lm->st->pos_rad += shift;
	}
	pos_set(l, lm, t, shift, now);
}

/*
 * A controller homed lm (rmd.home_t): it is at pos_rad now, or where it
 * reports (as_reported).  The reported frame shifts, the motor does not
 * move; a refusal (rmd_settle_home()) is reported and counted.  rt-safe.
 */
static void pos_home(struct rmd_loop *l, struct lmotor *lm, bool as_reported, double pos_rad,
		     int64_t now)
{
	const struct rmd_settle_home_facts f = {
		.enabled = lm->st->lifecycle == RMD_LC_ENABLED,
		.reachable = lm->st->lifecycle != RMD_LC_LOST && lm->st->lifecycle != RMD_LC_PROBE,
		.have_pos = lm->st->pos_rx_ns != 0,
		.reported = lm->st->pos_rad,
	};
	double shift, at;
	int why = rmd_settle_home(&lm->settle, &lm->m.mt, &f, as_reported, pos_rad, &shift, &at);

	if (why) {
		l->cnt.homes_refused++;
		loop_event(l, now, RMD_EV_HOME_REFUSED, loop_idx(l, lm), lm->m.bus, why,
			   why == RMD_HOME_OUTSIDE ? (int64_t)llround(at * 1e6) : 0);
		return;
	}
	rmd_motor_shift_pos(&lm->m, shift);
	lm->st->pos_rad += shift;
	pos_set(l, lm, RMD_POS_HOMED, shift, now);
}

void loop_take_homes(struct rmd_loop *l, int64_t now)
{
	const struct rmd_home *h;
	const void *p;

	if (!l->o.homes || !rmd_latest_get(l->o.homes, &p))
		return;
	h = p;
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		if (h->seq[i] == lm->life.homes_seen)
			continue;
		lm->life.homes_seen = h->seq[i];
		pos_home(l, lm, h->as_reported[i], h->pos_rad[i], now);
	}
}
