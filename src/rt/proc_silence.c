// SPDX-License-Identifier: MIT
/*
 * Silencing the replies a motor pushes unasked (rmd/proc_silence.h).
 *
 * Execution context: pure, rt-safe.
 */
#include <string.h>

#include "rmd/proc_silence.h"

void rmd_silence_begin(struct rmd_silence *s, const struct rmd_dialect *d)
{
	s->off = rmd_dialect_has(d, RMD_DIALECT_ACTIVE_REPLY) ?
			 (uint8_t)((1u << d->n_report_cmds) - 1u) :
			 0;
}

int rmd_silence_next(struct rmd_silence *s)
{
	unsigned k;

	if (!s->off)
		return -1;
	k = (unsigned)__builtin_ctz(s->off);
	s->off &= (uint8_t) ~(1u << k);
	return (int)k;
}

void rmd_silence_request(const struct rmd_dialect *d, unsigned k, struct rmd_msg *msg)
{
	memset(msg, 0, sizeof(*msg));
	msg->cmd = 0xB6; /* V4.2 §2.33: active reply of one command: off */
	rmd_msg_set(msg, RMD_FLD_REPORT_CMD, d->report_cmds[k]);
	rmd_msg_set(msg, RMD_FLD_REPORT_ON, 0);
	rmd_msg_set(msg, RMD_FLD_REPORT_MS, 0);
}

int rmd_silence_pushable(const struct rmd_dialect *d, unsigned cmd)
{
	for (unsigned k = 0; k < d->n_report_cmds; k++)
		if (cmd == d->report_cmds[k])
			return (int)k;
	return -1;
}
