// SPDX-License-Identifier: MIT
/*
 * Whether a motor's position commands have an effect (rmd/proc_effect.h).
 *
 * Execution context: pure, rt-safe.
 */
#include <math.h>

#include "rmd/proc_effect.h"

bool rmd_effect_watch(struct rmd_effect *e, bool driven, double target_rad, double max_vel_rad_s,
		      double pos_rad, int64_t now_ns)
{
	double hold_s = (double)RMD_EFFECT_HOLD_NS / 1e9;

	/* not driven to a position, or near it, or asked too slow to tell: a new episode */
	if (!driven || !(fabs(target_rad - pos_rad) > RMD_EFFECT_FAR_RAD) ||
	    (max_vel_rad_s > 0.0 && max_vel_rad_s * hold_s < 4.0 * RMD_EFFECT_MOVE_RAD)) {
		e->since_ns = 0;
		e->told = false;
		return false;
	}
	if (!e->since_ns || !(fabs(pos_rad - e->pos_rad) < RMD_EFFECT_MOVE_RAD)) {
		/* it moves: watched from here (told stays: it was told until it came near) */
		e->since_ns = now_ns;
		e->pos_rad = pos_rad;
		return false;
	}
	if (e->told || now_ns - e->since_ns < RMD_EFFECT_HOLD_NS)
		return false;
	e->told = true;
	return true;
}
