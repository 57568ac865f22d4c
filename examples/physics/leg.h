/* SPDX-License-Identifier: MIT */
/*
 * The kinematics of examples/physics/leg.xml, for its controllers and its
 * test (tests/system/test_physics_leg.c): the hip's height above the floor
 * from the two joint angles, with the foot on the floor, and the pose that
 * stands the hip at a height with the foot under it.  The numbers are the
 * model's: change them together.
 */
#ifndef RMD_EXAMPLE_LEG_H
#define RMD_EXAMPLE_LEG_H

#include <math.h>

#define LEG_LINK_M 0.20	  /* thigh and shank, hip to knee and knee to foot */
#define LEG_FOOT_R_M 0.02 /* the foot's radius */
#define LEG_STAND_M 0.35  /* the height the model starts at (hip 0.60, knee -1.20 rad) */

/* The hip's height above the floor with the foot on it, m. */
static inline double leg_height_m(double hip_rad, double knee_rad)
{
	return LEG_FOOT_R_M + LEG_LINK_M * cos(hip_rad) + LEG_LINK_M * cos(hip_rad + knee_rad);
}

/* The pose with the foot under the hip at height_m (clamped to what the leg reaches). */
static inline void leg_pose(double height_m, double *hip_rad, double *knee_rad)
{
	double c = (height_m - LEG_FOOT_R_M) / (2.0 * LEG_LINK_M);

	c = c < 0.05 ? 0.05 : c > 0.995 ? 0.995 : c;
	*hip_rad = acos(c);
	*knee_rad = -2.0 * *hip_rad;
}

#endif /* RMD_EXAMPLE_LEG_H */
