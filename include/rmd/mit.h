/* SPDX-License-Identifier: MIT */
/*
 * MIT "motion mode" (V3 §5): requests on 0x400 + ID carry p_des (16 bits),
 * v_des, kp, kd and t_ff (12 bits each) as big-endian bit fields; replies on
 * 0x500 + ID carry the motor's ID, position (16), velocity (12) and
 * torque (12).  u = (x - min) * (2^bits - 1) / (max - min), clamped first,
 * rounded to nearest.  Ranges are per motor (firmware differ).
 *
 * Pure and rt-safe.
 */
#ifndef RMD_MIT_H
#define RMD_MIT_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/frame.h"

struct rmd_mit_ranges {
	double p_min, p_max;   /* rad */
	double v_min, v_max;   /* rad/s */
	double t_min, t_max;   /* N·m */
	double kp_min, kp_max; /* N·m/rad */
	double kd_min, kd_max; /* N·m·s/rad */
};

/* V3 §5.1: p ±12.5 rad, v ±45 rad/s, t ±24 N·m, kp 0..500, kd 0..5. */
extern const struct rmd_mit_ranges rmd_mit_default_ranges;

struct rmd_mit_cmd {
	double p_des_rad;
	double v_des_rad_s;
	double kp;
	double kd;
	double t_ff_nm;
};

struct rmd_mit_reply {
	uint8_t motor_id;
	double pos_rad;
	double vel_rad_s;
	double torque_nm;
};

/* Ranges with min < max and all finite: true. */
bool rmd_mit_ranges_valid(const struct rmd_mit_ranges *r);

/* Quantise x into `bits` over [min, max]: clamp (NaN -> min), round. */
uint32_t rmd_mit_to_uint(double x, double min, double max, unsigned bits);
double rmd_mit_from_uint(uint32_t u, double min, double max, unsigned bits);

/* Encode a request for motor_id (1..32).  Returns 0 or -EINVAL. */
int rmd_mit_encode_cmd(const struct rmd_mit_ranges *r, uint8_t motor_id,
		       const struct rmd_mit_cmd *cmd, struct rmd_frame *out);
/* Decode a request frame (0x401..0x420).  Returns 0, -EBADMSG or -EINVAL. */
int rmd_mit_decode_cmd(const struct rmd_mit_ranges *r, const struct rmd_frame *f, uint8_t *motor_id,
		       struct rmd_mit_cmd *cmd);
/* Encode a reply (0x500 + ID).  Returns 0 or -EINVAL. */
int rmd_mit_encode_reply(const struct rmd_mit_ranges *r, const struct rmd_mit_reply *rep,
			 struct rmd_frame *out);
/* Decode a reply (0x501..0x520).  Returns 0, -EBADMSG or -EINVAL. */
int rmd_mit_decode_reply(const struct rmd_mit_ranges *r, const struct rmd_frame *f,
			 struct rmd_mit_reply *rep);

#endif /* RMD_MIT_H */
