/* SPDX-License-Identifier: MIT */
/*
 * Arming a motor's comm-loss protection (0xB3, V3 §2.30): a procedure
 * record that decides and never acts.
 *
 * Each motor's 0xB3 is a precondition of motion (enum rmd_comm_loss,
 * rmd/state.h: it may leave READY only when rmd_comm_loss_allows_motion()).
 * The value lives in the motor's ROM: it is written at bring-up and again
 * only when it must, in a *round* of up to RMD_ARM_TRIES writes, each
 * answer awaited for a deadline the driver gives (rmd_arm_written()):
 *   - when a motor answers after PROBE or LOST: found after bring-up, or
 *     back, and perhaps swapped or reflashed;
 *   - when an enable arrives for a motor that is not armed, at most one
 *     round per RMD_ARM_ROUND_NS: 0xB3 writes the motor's ROM, so it is
 *     never written in a loop of its own.
 * An answer that repeats the request arms it (echo-verified), one of the
 * command byte and zeros too (V3 §2.30 example 2: the time is not
 * verified); another answer means it holds another time.  A motor whose
 * protection tripped echoes only the first command it gets, and an echo is
 * all 0xB3's answer is: the drivers send a status read right ahead of
 * each write, which takes that echo.
 * An enable that arrives during a round waits for it (the setpoint is kept
 * here); a round that fails refuses it, and so is an enable for a motor
 * whose round failed less than RMD_ARM_ROUND_NS ago.  A refusal is counted
 * and reported once per episode (until the motor is armed or forgotten).
 * A motor whose protection is off by its configuration is never written
 * nor held back; a V2 motor has none (no 0xB3): unless it is off, every
 * enable is refused and nothing is written.
 *
 * Two drivers: bring-up, through its request/reply engine, all the
 * motors of a bus in one batch (src/rt/bringup.c); the rt loop, through
 * one-shot frames in the motor's control slots (src/rt/lifecycle.c
 * applies the outcomes: the events, the enable that waited).
 *
 * Pure: no clock, no I/O, no allocation; rt-safe.
 */
#ifndef RMD_PROC_ARM_H
#define RMD_PROC_ARM_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/frame.h"
#include "rmd/state.h"

#define RMD_ARM_CMD 0xB3 /* V3 §2.30: write the comm-loss time, ms; kept in ROM */
#define RMD_ARM_TRIES 3	 /* writes of one round */
#define RMD_ARM_ROUND_NS \
	(INT64_C(1000000000)) /* a refused enable starts a new round this long after */

struct rmd_arm {
	uint8_t cl;		/* enum rmd_comm_loss */
	bool round;		/* a round of writes runs */
	bool differs;		/* this round had an answer with another time */
	bool warned;		/* this episode's refusal was reported */
	bool want;		/* an enable waits for the round ... */
	uint8_t tries;		/* writes of this round */
	int64_t try_end_ns;	/* the current write's answer is awaited until then */
	int64_t round_end_ns;	/* when the last round ended (or bring-up's writes) */
	uint64_t rejects;	/* enables refused: protection not set */
	struct rmd_setpoint sp; /* ... with this setpoint */
};

/*
 * Forget the protection: the motor may not be the one that was armed.  It
 * is off (comm_loss_ms 0), unsupported (no 0xB3: has_b3 false) or pending;
 * no round, nothing waits, a new episode.  rt-safe.
 */
void rmd_arm_forget(struct rmd_arm *a, uint32_t comm_loss_ms, bool has_b3);

/* Whether a round must be written: the protection is pending.  rt-safe. */
static inline bool rmd_arm_pending(const struct rmd_arm *a)
{
	return a->cl == RMD_CL_PENDING;
}

/* A round of writes begins; its first write goes at the next step.  rt-safe. */
void rmd_arm_start_round(struct rmd_arm *a);

/* What an enable for a motor that is not armed comes to (rmd_arm_enable_wanted()). */
enum rmd_arm_want {
	RMD_ARM_REFUSE = 0, /* refused now: nothing to write, or its last round failed lately */
	RMD_ARM_WAIT,	    /* it waits for the round (started now, or running) */
};

/* An enable with setpoint sp at now, the motor not armed.  rt-safe. */
enum rmd_arm_want rmd_arm_enable_wanted(struct rmd_arm *a, const struct rmd_setpoint *sp,
					int64_t now_ns);

/* An enable was refused: counted; true the first time this episode (report it).  rt-safe. */
bool rmd_arm_refused(struct rmd_arm *a);

/* What a round's step comes to (rmd_arm_step()). */
enum rmd_arm_step {
	RMD_ARM_IDLE = 0, /* no round, or its write's answer is awaited, or the motor is away */
	RMD_ARM_WRITE,	  /* queue the next write now (rmd_arm_request()), then rmd_arm_written() */
	RMD_ARM_FAILED,	  /* the round ended unanswered, or with another time: cl says which */
};

/*
 * The round's next step at now; reachable: the motor is neither LOST nor
 * in PROBE (a round waits for it).  After RMD_ARM_FAILED an enable that
 * waited is still wanted: the driver refuses it (rmd_arm_refused()), or
 * reports the failure.  rt-safe.
 */
enum rmd_arm_step rmd_arm_step(struct rmd_arm *a, bool reachable, int64_t now_ns);

/* The write RMD_ARM_WRITE asked for went into the queue; its answer is awaited until due.  rt-safe. */
void rmd_arm_written(struct rmd_arm *a, int64_t answer_due_ns);

/*
 * What an answer to the 0xB3 request `req` (its 8 bytes) says: the
 * request repeated (armed), the command byte and zeros (V3 §2.30 example
 * 2), or something else (another time).  Pure.
 */
enum rmd_comm_loss rmd_arm_b3_outcome(const uint8_t *req, const struct rmd_frame *rep);

/* What an answer to a write came to (rmd_arm_answer()). */
enum rmd_arm_answer {
	RMD_ARM_NOTHING = 0, /* off or unsupported: not the loop's to judge */
	RMD_ARM_OTHER_TIME,  /* it holds another time (a round goes on) */
	RMD_ARM_NOW_ARMED,   /* armed, it was not: report it */
	RMD_ARM_STILL_ARMED, /* armed, as it was */
};

/* An answer rep to the write `req` (8 bytes) at now.  rt-safe. */
enum rmd_arm_answer rmd_arm_answer(struct rmd_arm *a, const uint8_t *req,
				   const struct rmd_frame *rep, int64_t now_ns);

/*
 * What bring-up's own writes came to (cl: RMD_CL_ARMED, _ARMED_ZEROS,
 * _NO_ANSWER, _DIFFERS; RMD_CL_PENDING: none written), taken over at now
 * as the motor's state; a motor not pending keeps its off or unsupported.
 * rt-safe.
 */
void rmd_arm_took_over(struct rmd_arm *a, uint32_t comm_loss_ms, bool has_b3, enum rmd_comm_loss cl,
		       int64_t now_ns);

/* The request that writes comm_loss_ms (V3 §2.30), for the codec or rmd_txn_prepare().  rt-safe. */
void rmd_arm_request(uint32_t comm_loss_ms, struct rmd_msg *msg);

#endif /* RMD_PROC_ARM_H */
