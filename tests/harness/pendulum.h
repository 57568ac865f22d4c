/* SPDX-License-Identifier: MIT */
/*
 * The truth the physics tests judge against: a rigid pendulum's period.
 */
#ifndef RMD_TEST_PENDULUM_H
#define RMD_TEST_PENDULUM_H

/*
 * The period, seconds, of a rigid pendulum of inertia inertia_kgm2 about
 * its pivot, mass mass_kg at len_m from it, under gravity g, swinging from
 * amplitude_rad: 4 sqrt(I / (m g l)) K(sin(amplitude / 2)), K the complete
 * elliptic integral of the first kind (the large-angle formula).
 */
double pendulum_period_s(double inertia_kgm2, double mass_kg, double len_m, double g,
			 double amplitude_rad);

#endif /* RMD_TEST_PENDULUM_H */
