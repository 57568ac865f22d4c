/* SPDX-License-Identifier: MIT */
/*
 * The frames a motor owes an echo of (docs/design.md "The life of a
 * motor"): a procedure record that decides and never acts.
 *
 * A motor is READY only after it echoed output off (0x80, V3 §2.15 / V2
 * §3.34) and brake locked (0x78, V3 §2.27 / V2 §3.51), and a FAULT motor
 * gets output off (and the brake, rmd_config_fault_brakes()) the same way:
 * those frames are *owed* from the entry of STOPPING or FAULT on.  Each
 * control slot of the motor carries one of them (0x80 and 0x78 in turn,
 * rmd_owed_next()) until the motor's echo of it comes: a reply on its own
 * reply identifier, matched to that request by the loop's matching,
 * repeating it byte for byte, to a request sent after the debt began (an
 * older 0x80 proves nothing about the setpoints that followed it).  An
 * echo a motor whose comm-loss protection tripped gives without executing
 * the frame is still true: the trip cut its output and locked its brake
 * (V3 §2.30.1).  Bounded: RMD_OWED_SENDS_MAX sends without the debt paid
 * and the motor does not do what rmdd asks (rmd_owed_exhausted(): LOST);
 * every send after a frame's first is a resend.
 *
 * Two drivers: the rt loop, through the motor's control slots
 * (src/rt/loop_tx.c, loop_rx.c), and bring-up, through its request/reply
 * engine (src/rt/bringup.c); src/rt/lifecycle.c applies the outcomes
 * (READY once nothing is owed, LOST when exhausted).
 *
 * Pure: no clock, no I/O, no allocation; rt-safe.
 */
#ifndef RMD_PROC_OWED_H
#define RMD_PROC_OWED_H

#include <stdbool.h>
#include <stdint.h>

/* The owed frames (struct rmd_owed.bits). */
enum {
	RMD_OWE_OFF = 1u << 0,	 /* 0x80 output off, V3 §2.15 / V2 §3.34 */
	RMD_OWE_BRAKE = 1u << 1, /* 0x78 brake locked, V3 §2.27 / V2 §3.51 */
};

/* Owed sends without the debt paid: the motor does not do what it is asked. */
#define RMD_OWED_SENDS_MAX 16

struct rmd_owed {
	uint8_t bits;	/* RMD_OWE_* not yet echoed */
	uint8_t sent;	/* RMD_OWE_* sent at least once since the debt began */
	uint32_t sends; /* owed frames sent since then */
	uint64_t seq;	/* an echo pays only for a request booked from this sequence on */
};

/* What an answer to an owed frame came to (rmd_owed_answer()). */
enum rmd_owed_outcome {
	RMD_OWED_NONE = 0, /* not an answer to an owed frame of this debt */
	RMD_OWED_PAID,	   /* its echo: that frame is paid, another is still owed */
	RMD_OWED_CLEAR,	   /* its echo: nothing is owed any more */
	RMD_OWED_AGAIN,	   /* an echo of a frame of this debt paid before: nothing changes */
	RMD_OWED_UNPAID,   /* answered with other bytes than its own: not paid */
};

/*
 * From now on the motor owes the frames of `bits` (those its dialect can
 * send: the caller keeps only those); `seq`: the sequence number its next
 * request will be booked with.  rt-safe.
 */
void rmd_owed_begin(struct rmd_owed *o, unsigned bits, uint64_t seq);

/* Nothing is owed any more (another state's entry).  rt-safe. */
static inline void rmd_owed_drop(struct rmd_owed *o)
{
	o->bits = 0;
}

/* The command byte the next control slot carries (0x80 or 0x78), 0: none owed.  rt-safe. */
uint8_t rmd_owed_next(const struct rmd_owed *o);

/* The owed frame `cmd` was sent.  True when that frame had been sent before (a resend).  rt-safe. */
bool rmd_owed_sent(struct rmd_owed *o, uint8_t cmd);

/*
 * An answer to the motor's request `req_seq` with command byte `cmd`,
 * repeating the request byte for byte or not (`repeats`).  rt-safe.
 */
enum rmd_owed_outcome rmd_owed_answer(struct rmd_owed *o, uint8_t cmd, uint64_t req_seq,
				      bool repeats);

/* Something is owed and RMD_OWED_SENDS_MAX sends did not pay it.  rt-safe. */
static inline bool rmd_owed_exhausted(const struct rmd_owed *o)
{
	return o->bits && o->sends >= RMD_OWED_SENDS_MAX;
}

#endif /* RMD_PROC_OWED_H */
