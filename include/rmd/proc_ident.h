/* SPDX-License-Identifier: MIT */
/*
 * Identifying a motor's firmware (docs/protocol-v4.md): a procedure record
 * that decides and never acts.
 *
 * A motor is driven only in a dialect its firmware speaks.  Its firmware
 * date (0xB2, V3 §2.29) says which generation it runs
 * (rmd_dialect_for_firmware()); a date that certainly names another
 * firmware than the motor's dialect's is a mismatch
 * (rmd_dialect_other_firmware(), rmd/dialect.h, the one copy of that
 * rule, which rmdctl shares): bring-up refuses the motor, the loop leaves
 * one found late out for good.  A motor in MIT mode has its MIT scaling
 * decided from the same date and its model (0xB5, V3 §2.32) before any MIT
 * frame (rmd_mit_scaling_decide(), rmd/dialect.h).
 *
 * A motor missing at bring-up was never asked: its identity stays *open*
 * (rmd_ident_open()) and its re-probe asks the model (in MIT mode) and the
 * date (rmd_ident_asks()) until an answer with a date settles it
 * (rmd_ident_answer()).  Dialects without 0xB2 (V2) have nothing to ask.
 *
 * Two drivers: bring-up (src/rt/bringup.c), which also finds the family
 * of a `protocol: auto` motor by which dialect's probe it answers; the rt
 * loop's re-probes of a motor found late (src/rt/loop_tx.c, loop_rx.c),
 * which never switch its dialect.
 *
 * Pure: no clock, no I/O, no allocation; rt-safe.
 */
#ifndef RMD_PROC_IDENT_H
#define RMD_PROC_IDENT_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/dialect.h"
#include "rmd/motor.h"

struct rmd_ident {
	bool open;	 /* missing at bring-up: its re-probe asks until a date settles it */
	bool refused;	 /* left out for good: a dialect or an MIT scaling it cannot be driven in */
	bool mit_warned; /* an MIT enable was refused, its scaling not decided: reported */
	char model[8];	 /* 0xB5's answer, "" when none */
	uint32_t version; /* 0xB2's answer (yyyymmdd[NN]); 0: none */
};

/* A motor of dialect d missing at bring-up: open when d has a date to ask.  rt-safe. */
void rmd_ident_open(struct rmd_ident *id, const struct rmd_dialect *d);

/*
 * The reads a re-probe of an open motor asks after its status read, in
 * order, into cmds: the model (0xB5) in MIT mode, then the date (0xB2).
 * Their count (0: the identity is not open).  rt-safe.
 */
unsigned rmd_ident_asks(const struct rmd_ident *id, bool mit_mode, uint8_t cmds[2]);

/* What an answer of an open motor came to (rmd_ident_answer()). */
enum rmd_ident_outcome {
	RMD_IDENT_WAIT = 0, /* no date in it (a model is kept): asked again */
	RMD_IDENT_SAME,	    /* settled: the date agrees, or tells nothing certain */
	RMD_IDENT_OTHER, /* settled: the date names another firmware (rmd_dialect_other_firmware()) */
};

/*
 * An open motor of dialect d answered r (a decoded 0xB5 or 0xB2 reply);
 * *fw: RMD_IDENT_OTHER's firmware.  rt-safe.
 */
enum rmd_ident_outcome rmd_ident_answer(struct rmd_ident *id, const struct rmd_dialect *d,
					const struct rmd_motor_reply *r,
					const struct rmd_dialect **fw);

/* True the first time an MIT enable is refused for an undecided scaling: report it.  rt-safe. */
bool rmd_ident_mit_warn_once(struct rmd_ident *id);

#endif /* RMD_PROC_IDENT_H */
