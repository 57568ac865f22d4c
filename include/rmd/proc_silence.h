/* SPDX-License-Identifier: MIT */
/*
 * Silencing the replies a motor pushes unasked (0xB6 active reply, V4.2
 * §2.33): a procedure record that decides and never acts.
 *
 * A motor left in active-reply mode by another tool pushes the chosen
 * replies every n x 10 ms and no longer answers those reads.  Every motor
 * found (bring-up) or back from LOST is taken to have been left so, and
 * each of its dialect's pushable replies is turned off (0xB6 with enable
 * 0), one request a report (rmd_silence_request()).  The manual gives no
 * answer to it: none is awaited, and one that did not go out is not sent
 * again.  What bring-up saw pushed is kept for its report.
 *
 * Two drivers: bring-up sends every off in one send right after the
 * motor's first answer (src/rt/bringup.c); the rt loop one per control
 * slot of a motor that came back (src/rt/loop_tx.c).
 *
 * Pure: no clock, no I/O, no allocation; rt-safe.
 */
#ifndef RMD_PROC_SILENCE_H
#define RMD_PROC_SILENCE_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"

struct rmd_silence {
	uint8_t off;	/* offs still to send, bit k: the dialect's report_cmds[k] */
	uint8_t pushed; /* bring-up: replies seen pushed unasked, bit k as off */
};

/*
 * The motor is found or back: every reply its dialect can push is to be
 * turned off (none where the dialect has no active reply).  rt-safe.
 */
void rmd_silence_begin(struct rmd_silence *s, const struct rmd_dialect *d);

/* Lost: nothing is sent until it is back.  rt-safe. */
static inline void rmd_silence_forget(struct rmd_silence *s)
{
	s->off = 0;
}

/* The next off to send, lowest first, taken from what is still to send; -1: none.  rt-safe. */
int rmd_silence_next(struct rmd_silence *s);

/* The request that turns report_cmds[k] of dialect d off (V4.2 §2.33).  rt-safe. */
void rmd_silence_request(const struct rmd_dialect *d, unsigned k, struct rmd_msg *msg);

/* The index of reply `cmd` among what d can push (its report_cmds), or -1.  rt-safe. */
int rmd_silence_pushable(const struct rmd_dialect *d, unsigned cmd);

#endif /* RMD_PROC_SILENCE_H */
