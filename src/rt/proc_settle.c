// SPDX-License-Identifier: MIT
/*
 * The position after a power cycle, and homing (rmd/proc_settle.h).
 *
 * Execution context: pure, rt-safe.
 */
#include <math.h>

#include "rmd/proc_settle.h"

void rmd_settle_forget(struct rmd_settle *s)
{
	s->on = false;
	s->cand_trust = RMD_POS_UNKNOWN;
	s->warned = false;
}

enum rmd_pos_trust rmd_settle_begin(struct rmd_settle *s, const struct rmd_multiturn *mt,
				    int64_t now_ns)
{
	rmd_settle_forget(s);
	if (mt->saved)
		return RMD_POS_SAVED;
	s->on = true;
	s->due_ns = now_ns;
	return RMD_POS_UNKNOWN;
}

enum rmd_pos_trust rmd_settle_reading(struct rmd_settle *s, const struct rmd_multiturn *mt,
				      double pos_rad, int64_t pos_rx_ns, double *shift_rad)
{
	double shift;
	enum rmd_pos_trust t = rmd_multiturn_settle(mt, pos_rad, &shift);

	*shift_rad = 0.0;
	/* two readings in a row decide, when they come to the same */
	if (s->cand_trust != (uint8_t)t || s->cand_shift != shift) {
		s->cand_trust = (uint8_t)t; /* never RMD_POS_UNKNOWN */
		s->cand_shift = shift;
		s->due_ns = pos_rx_ns + 1; /* a later reading */
		return RMD_POS_UNKNOWN;
	}
	*shift_rad = shift;
	return t;
}

void rmd_settle_decided(struct rmd_settle *s, enum rmd_pos_trust t)
{
	s->on = false;
	s->cand_trust = RMD_POS_UNKNOWN;
	if (rmd_pos_trusted(t))
		s->warned = false;
}

bool rmd_settle_warn_once(struct rmd_settle *s)
{
	if (s->warned)
		return false;
	s->warned = true;
	return true;
}

int rmd_settle_home(const struct rmd_settle *s, const struct rmd_multiturn *mt,
		    const struct rmd_settle_home_facts *f, bool as_reported, double pos_rad,
		    double *shift_rad, double *at_rad)
{
	*shift_rad = 0.0;
	*at_rad = 0.0;
	if (f->enabled)
		return RMD_HOME_ENABLED;
	if (s->on || !f->have_pos || !isfinite(f->reported) || !f->reachable)
		return RMD_HOME_NO_POS;
	*at_rad = as_reported ? f->reported : pos_rad;
	if (!rmd_multiturn_in_band(mt, *at_rad))
		return RMD_HOME_OUTSIDE;
	*shift_rad = *at_rad - f->reported;
	return 0;
}
