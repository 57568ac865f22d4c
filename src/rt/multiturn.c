// SPDX-License-Identifier: MIT
/*
 * Whether a motor's reported multi-turn position can be trusted after a
 * power cycle, and the shift into its travel band (rmd/multiturn.h).
 *
 * Execution context: pure, rt-safe.
 */
#include <math.h>

#include "rmd/multiturn.h"

double rmd_multiturn_period_rad(double gear_ratio)
{
	return gear_ratio > 0.0 ? 2.0 * M_PI / gear_ratio : 0.0;
}

bool rmd_multiturn_band_unique(const struct rmd_multiturn *mt)
{
	double w = (mt->hi_rad - mt->lo_rad) + 2.0 * mt->tol_rad;

	return isfinite(w) && w >= 0.0 && mt->period_rad > 0.0 && w < mt->period_rad;
}

bool rmd_multiturn_in_band(const struct rmd_multiturn *mt, double pos_rad)
{
	return isfinite(pos_rad) && pos_rad >= mt->lo_rad - mt->tol_rad &&
	       pos_rad <= mt->hi_rad + mt->tol_rad;
}

enum rmd_pos_trust rmd_multiturn_settle(const struct rmd_multiturn *mt, double pos_rad,
					double *shift_rad)
{
	double lo, k, p;

	*shift_rad = 0.0;
	if (mt->saved)
		return RMD_POS_SAVED;
	if (!isfinite(pos_rad) || !rmd_multiturn_band_unique(mt))
		return RMD_POS_AMBIGUOUS;
	p = mt->period_rad;
	lo = mt->lo_rad - mt->tol_rad;
	/* the smallest whole number of periods that brings pos to lo or above */
	k = ceil((lo - pos_rad) / p);
	if (pos_rad + (k - 1.0) * p >= lo) /* ceil's rounding, one period either way */
		k -= 1.0;
	else if (pos_rad + k * p < lo)
		k += 1.0;
	if (pos_rad + k * p > mt->hi_rad + mt->tol_rad)
		return RMD_POS_OUTSIDE;
	*shift_rad = k * p;
	return RMD_POS_IN_BAND;
}
