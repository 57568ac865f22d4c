// SPDX-License-Identifier: MIT
/*
 * The frames a motor owes an echo of (rmd/proc_owed.h).
 *
 * Execution context: pure, rt-safe.
 */
#include "rmd/proc_owed.h"

/* The owed bit of command byte cmd (0x80, 0x78), else 0.  rt-safe. */
static unsigned owed_bit(uint8_t cmd)
{
	return cmd == 0x80 ? RMD_OWE_OFF : cmd == 0x78 ? RMD_OWE_BRAKE : 0;
}

void rmd_owed_begin(struct rmd_owed *o, unsigned bits, uint64_t seq)
{
	o->bits = (uint8_t)(bits & (RMD_OWE_OFF | RMD_OWE_BRAKE));
	o->sent = 0;
	o->sends = 0;
	o->seq = seq;
}

uint8_t rmd_owed_next(const struct rmd_owed *o)
{
	unsigned bit = o->bits;

	if (!bit)
		return 0;
	if (bit == (RMD_OWE_OFF | RMD_OWE_BRAKE)) /* in turn */
		bit = o->sends % 2 ? RMD_OWE_BRAKE : RMD_OWE_OFF;
	return bit == RMD_OWE_OFF ? 0x80 : 0x78;
}

bool rmd_owed_sent(struct rmd_owed *o, uint8_t cmd)
{
	unsigned bit = owed_bit(cmd);
	bool again = o->sent & bit;

	o->sends++;
	o->sent |= (uint8_t)bit;
	return again;
}

enum rmd_owed_outcome rmd_owed_answer(struct rmd_owed *o, uint8_t cmd, uint64_t req_seq,
				      bool repeats)
{
	unsigned bit = owed_bit(cmd);

	if (!o->bits || !bit || req_seq < o->seq)
		return RMD_OWED_NONE;
	if (!repeats)
		return RMD_OWED_UNPAID;
	if (!(o->bits & bit))
		return RMD_OWED_AGAIN;
	o->bits &= (uint8_t)~bit;
	return o->bits ? RMD_OWED_PAID : RMD_OWED_CLEAR;
}
