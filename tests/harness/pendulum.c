// SPDX-License-Identifier: MIT
#include "harness/pendulum.h"

#include <math.h>

/* The complete elliptic integral of the first kind K(k), by the arithmetic-geometric mean. */
static double ellip_k(double k)
{
	double a = 1.0, g = sqrt(1.0 - k * k);

	for (int i = 0; i < 40; i++) {
		double an = 0.5 * (a + g);

		g = sqrt(a * g);
		a = an;
	}
	return M_PI / (2.0 * a);
}

double pendulum_period_s(double inertia_kgm2, double mass_kg, double len_m, double g,
			 double amplitude_rad)
{
	return 4.0 * sqrt(inertia_kgm2 / (mass_kg * g * len_m)) * ellip_k(sin(amplitude_rad / 2.0));
}
