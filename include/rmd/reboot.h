/* SPDX-License-Identifier: MIT */
/*
 * Did a motor reboot?  (docs/faults.md "A short power cycle".)
 *
 * A motor that loses power and boots again faster than
 * safety.missed_replies_lost replies is never LOST: it misses a few
 * replies and answers again, with its RAM lost -- its multi-turn count
 * (rmd/multiturn.h), its mode, its brake released -- while rmdd would take
 * it for the motor it was.  A position command for the same target then
 * turns the joint by whole rotor turns.  So every reply a motor misses
 * opens a check (rmd_reboot_missed()): the motor is *pending* until one
 * of its answers tells whether it booted since it was last known running,
 * and meanwhile its control slot carries the read that tells
 * (rmd_reboot_next()) instead of its setpoint: the first frame a motor
 * back from a boot hears is that read, not a motion command.
 *
 * What tells:
 *   - 0xB1, its runtime (V3 §2.28, V4.2 §2.28: ms since power-on or a
 *     reset, uint32): a runtime shorter than the time since the motor was
 *     last known running (found, or its last runtime read) means it
 *     started after that (rmd_reboot_runtime_says()).  No motion, load or
 *     late reply can make it fire: only a clock of the motor's more than
 *     RMD_REBOOT_CLOCK_SLACK slow, or its count wrapping (49.7 days), which
 *     the judgement tells apart.
 *   - the brake, locked by the boot (V3 §2.27: locked without power), in a
 *     status answer (0x9A, V3 §2.12) after the motor reported it released
 *     by rmdd's 0x77 (rmd_reboot_brake_says()): seen at the next status
 *     poll, whether or not a reply was missed.  It opens a check
 *     (rmd_reboot_brake()) rather than deciding: one frame on the motor's
 *     reply identifier may be another node's (a second motor set to the
 *     same ID, a converter that mixes up answers; seen in the soak as a
 *     neighbour's locked brake made an ENABLED motor LOST), and the check
 *     read decides within a cycle or two while its setpoints are held
 *     back.  Only a motor whose firmware answers no check read is judged
 *     by its brake alone.
 *   - V2, which has no 0xB1 (its replies carry the rotor's single-turn
 *     encoder, which rmdd counts from a 0x92 angle, rmd/motor.h): the
 *     motor's own multi-turn angle (0x92, V2 §3.29) against rmdd's count;
 *     they part by whole rotor turns when the motor lost its count
 *     (rmd_reboot_turns_says()).
 * A check read alternates with a status read (0x9C, which every dialect
 * answers): a motor whose firmware does not answer the check read answers
 * that one, so it is not taken for silent.  A motor found (at bring-up,
 * or back from LOST) is checked once at once: the runtime it then answers
 * places its boot, and one that skips RMD_REBOOT_IGNORED_MAX check reads
 * then, answering the status reads between them, does not know the read:
 * the checks end for it (RMD_REBOOT_UNCHECKABLE).  Later, a check read
 * unanswered only keeps the check going: replies slower than their
 * deadline look the same, and its late answer is judged as any.
 *
 * This is a procedure record that decides and never acts (the rt loop
 * acts on the outcomes: lifecycle.c loop_rebooted()).  Pure: no clock,
 * no I/O, no allocation; rt-safe.
 */
#ifndef RMD_REBOOT_H
#define RMD_REBOOT_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/multiturn.h"

/* V3 §2.28 / V4.2 §2.28: read the system runtime, ms since power-on, uint32. */
#define RMD_REBOOT_CMD_RUNTIME 0xB1u
/* V3 §2.13 / V2 §3.32: status 2, the read every dialect answers, beside the check read. */
#define RMD_REBOOT_CMD_STATUS 0x9Cu
/* Check reads unanswered in a row, each while a later request was answered: none any more. */
#define RMD_REBOOT_IGNORED_MAX 3
/* Answers in a row that could not tell (V2 without a count): the check ends undecided. */
#define RMD_REBOOT_UNDECIDED_MAX 3
/*
 * How much slower than the host's the motor's ms clock may run: a runtime
 * is taken for a boot only when, this much faster, it is still shorter
 * than the time since the motor was known running (an MCU's RC oscillator
 * is within 1-2 %; a crystal within 0.01 %).
 */
#define RMD_REBOOT_CLOCK_SLACK 0.03
/* V3 §2.28: the runtime is a uint32 of ms: it wraps after 2^32 ms, 49.7 days. */
#define RMD_REBOOT_RUNTIME_WRAP_NS (INT64_C(4294967296) * 1000000)

/* What a step of the check came to. */
enum rmd_reboot_outcome {
	RMD_REBOOT_WAIT = 0,	/* nothing decided: the check goes on, or none runs */
	RMD_REBOOT_FINE,	/* it did not reboot: the check is over */
	RMD_REBOOT_REBOOTED,	/* it booted since it was known running: lost and back */
	RMD_REBOOT_UNCHECKABLE, /* it does not answer the check read: no checks any more */
	RMD_REBOOT_UNDECIDED,	/* its answers could not tell: the check ends, reported */
};

/* What an answer of the motor says. */
enum rmd_reboot_verdict {
	RMD_REBOOT_SAYS_NOTHING = 0, /* it cannot tell (V2: no count; a runtime about to wrap) */
	RMD_REBOOT_SAYS_RUNNING,     /* it has run since it was known running */
	RMD_REBOOT_SAYS_BOOTED,	     /* it booted since */
	/*
	 * V2: its angle and rmdd's count part by other than whole rotor turns,
	 * which no boot does: the count is wrong (a gear ratio not the
	 * motor's, a step it missed); it tells nothing of a boot
	 */
	RMD_REBOOT_SAYS_COUNT_ASTRAY,
};

/* One motor's check (in struct lmotor). */
struct rmd_reboot {
	bool pending;	   /* a reply was missed (or it was found) and no answer told yet */
	bool off;	   /* it does not answer the check read: no checks any more */
	bool boot_known;   /* boot_ns is known (a runtime answer) */
	bool first;	   /* the episode is the check of a motor just found */
	uint8_t tries;	   /* reads sent this episode (rmd_reboot_next()) */
	uint8_t ignored;   /* check reads unanswered in a row, a later request answered */
	uint8_t undecided; /* answers in a row this episode that could not tell */
	/* it was running, in the boot rmdd knows, at this time (0: not found) */
	int64_t since_ns;
	/* that boot, as its last runtime answer puts it (boot_known): the latest it can be */
	int64_t boot_ns;
	/* a miss of a request before this sequence number belongs to an episode already told */
	uint64_t told_seq;
	/* its newest answer that came after its request's deadline, received then (0: none) */
	int64_t slow_ns;
	/* rmdd's last brake release (0x77) went out as this request; since, it reported it open */
	uint64_t release_seq;
	bool brake_open;
	/* V2: its count went astray since it was found: it judges no boot, no check opens */
	bool astray;
};

/*
 * V2: what a count check's verdict v (rmd_reboot_turns_says()) tells the
 * check.  A count gone astray judges no boot from then on: a wrong scale
 * (a gear_ratio not the motor's) would in time part by whole turns by
 * chance and be taken for one.  So the episode ends, no check opens and
 * every count verdict says nothing until the motor is found again
 * (rmd_reboot_found()); *news is true the first time (to report it).
 * rt-safe.
 */
enum rmd_reboot_verdict rmd_reboot_count(struct rmd_reboot *r, enum rmd_reboot_verdict v,
					 bool *news);

/* Not found, no check.  rt-safe. */
void rmd_reboot_init(struct rmd_reboot *r);

/*
 * The motor was found (bring-up) or is back from LOST, answering at now:
 * it is running then.  first_check: its check read is a runtime, whose
 * first answer places its boot: checked at once.  rt-safe.
 */
void rmd_reboot_found(struct rmd_reboot *r, int64_t now_ns, bool first_check);

/* The motor is lost: nothing is known of it, no check runs until it is found.  rt-safe. */
void rmd_reboot_forget(struct rmd_reboot *r);

/*
 * Request `seq` of the motor got no answer by its deadline.  check: it was
 * a check read.  heard_seq: the newest answered request's sequence number
 * + 1.  Opens an episode (pending) once the motor is found, unless it
 * answered a later request (it was there after this one: no silence) or
 * answered late within slow_hold_ns before now_ns (rmd_reboot_slow()), or,
 * in the check of a motor just found, counts a check read it skipped while
 * it answered a later request: RMD_REBOOT_UNCHECKABLE when that makes
 * RMD_REBOOT_IGNORED_MAX, else RMD_REBOOT_WAIT.  rt-safe.
 */
enum rmd_reboot_outcome rmd_reboot_missed(struct rmd_reboot *r, uint64_t seq, bool check,
					  uint64_t heard_seq, int64_t now_ns, int64_t slow_hold_ns);

/*
 * An answer of the motor came after its request's deadline, at now_ns: it
 * is slow, not silent, and a miss within slow_hold_ns of such an answer
 * opens no check (rmd_reboot_missed()): every one would hold its setpoints
 * back until its own late answer.  rt-safe.
 */
void rmd_reboot_slow(struct rmd_reboot *r, int64_t now_ns);

/*
 * The read the motor's control slot carries while pending: `cmd`, its
 * check read, on the episode's even tries, RMD_REBOOT_CMD_STATUS on the
 * odd ones (counted as sent); 0 when none is pending.  rt-safe.
 */
uint8_t rmd_reboot_next(struct rmd_reboot *r, uint8_t cmd);

/*
 * An answer to the motor's request `seq` said `v`: it ends the episode
 * (FINE, REBOOTED; UNDECIDED after RMD_REBOOT_UNDECIDED_MAX answers that
 * said nothing), and a miss of any request before `seq` is no new
 * episode.  RMD_REBOOT_SAYS_BOOTED is REBOOTED even when no episode runs
 * (V2's count checked by a fine read).  rt-safe.
 */
enum rmd_reboot_outcome rmd_reboot_answer(struct rmd_reboot *r, uint64_t seq,
					  enum rmd_reboot_verdict v);

/*
 * 0xB1's answer, runtime_ms, to request `seq` sent at sent_ns, received at
 * recv_ns: rmd_reboot_runtime_says(), then rmd_reboot_answer(); the boot
 * it places (recv_ns - runtime_ms) and recv_ns, when it says running or
 * nothing, are what the next answer is held against.  *least_ms (may be
 * NULL): how long it would have run at least had it not rebooted.
 * Answers while nothing is pending are not taken.  rt-safe.
 */
enum rmd_reboot_outcome rmd_reboot_runtime(struct rmd_reboot *r, uint64_t seq, uint32_t runtime_ms,
					   int64_t sent_ns, int64_t recv_ns, int64_t *least_ms);

/*
 * What a runtime of runtime_ms (0xB1), read by a request sent at sent_ns,
 * says of r's motor, known running at r->since_ns: booted since when even
 * RMD_REBOOT_CLOCK_SLACK faster, plus its LSB (1 ms), it is no longer
 * than sent_ns - r->since_ns, the least it has run since if it did not
 * reboot; running otherwise -- unless its count may have wrapped since r's
 * last answer placed its boot (r->boot_ns, within the slack of a multiple
 * of RMD_REBOOT_RUNTIME_WRAP_NS): nothing.  Without a boot placed (the
 * first answer after the motor was found) a short runtime is a boot.
 * rt-safe.
 */
enum rmd_reboot_verdict rmd_reboot_runtime_says(const struct rmd_reboot *r, uint32_t runtime_ms,
						int64_t sent_ns);

/*
 * rmdd's brake release (0x77, V3 §2.26) for the motor went out as request
 * `seq`: the brake's state in answers to later requests is held against
 * it (rmd_reboot_brake_says()).  rt-safe.
 */
void rmd_reboot_released(struct rmd_reboot *r, uint64_t seq);

/*
 * A status answer (0x9A, V3 §2.12 DATA[3]: the brake's command state, 1
 * released, 0 locked) to request `seq`: `released`; held: rmdd holds the
 * brake released now (ENABLED, which sends no 0x78).  Booted when it says
 * locked after an answer to a request since rmdd's release said released:
 * the brake locks without power (V3 §2.27) and only a 0x77 releases it.
 * Firmware that never reports it released never makes it fire.  Running
 * when it says released after the release; nothing otherwise.  rt-safe.
 */
enum rmd_reboot_verdict rmd_reboot_brake_says(struct rmd_reboot *r, bool held, uint64_t seq,
					      bool released);

/*
 * What a brake verdict v (rmd_reboot_brake_says()) of the answer to
 * request `seq` does.  Booted opens an episode (its setpoints are held
 * back and the check read decides, rmd_reboot_next()) and forgets the
 * release's report, so the next locked answer opens none; with
 * `checkable` false (the motor answers no check read, or its firmware has
 * none) or the checks off, it decides: RMD_REBOOT_REBOOTED.  Anything else
 * is RMD_REBOOT_WAIT.  rt-safe.
 */
enum rmd_reboot_outcome rmd_reboot_brake(struct rmd_reboot *r, uint64_t seq,
					 enum rmd_reboot_verdict v, bool checkable);

/*
 * A position reading: where (rad at the output, reported frame), when
 * (ns), how fast (rad/s), and how far off it may be besides its step
 * (rad; rmdd's V2 count: the motion its anchor allows).
 */
struct rmd_reboot_reading {
	double pos_rad;
	int64_t t_ns;
	double vel_rad_s;
	double err_rad;
};

/*
 * The motor's own multi-turn angle `now` against rmdd's count `before`
 * (V2).  What the readings may part by while it runs: twice the faster
 * of the two readings' speeds over the time between them, twice the
 * reading's step (mt->tol_rad) and both readings' err_rad.  Running when
 * they part by no more, or by less than half a rotor turn at the output
 * (mt->period_rad / 2) plus twice the step.  Otherwise a lost count
 * shifts the angle by whole periods: booted when they part by whole
 * periods give or take what they may part by; by anything else, the
 * count went astray (RMD_REBOOT_SAYS_COUNT_ASTRAY), which no boot
 * explains.  Says nothing without a period, with a reading not finite,
 * or `now` before `before`.  rt-safe.
 */
enum rmd_reboot_verdict rmd_reboot_turns_says(const struct rmd_multiturn *mt,
					      const struct rmd_reboot_reading *before,
					      const struct rmd_reboot_reading *now);

#endif /* RMD_REBOOT_H */
