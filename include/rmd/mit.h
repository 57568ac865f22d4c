/* SPDX-License-Identifier: MIT */
/*
 * MIT "motion mode" (V3 §5): requests on 0x400 + ID carry p_des (16 bits),
 * v_des, kp, kd and t_ff (12 bits each) as big-endian bit fields; replies on
 * 0x500 + ID carry the motor's ID, position (16), velocity (12) and
 * torque (12).  u = (x - min) * (2^bits - 1) / (max - min), clamped first,
 * rounded to nearest (halves away from zero).  Ranges are per motor
 * (firmware differ).
 *
 * Request data field (V3 §5.2), p/v/kp/kd/t being the unsigned codes:
 *   D0 = p[15:8]   D1 = p[7:0]
 *   D2 = v[11:4]   D3 = v[3:0] << 4 | kp[11:8]   D4 = kp[7:0]
 *   D5 = kd[11:4]  D6 = kd[3:0] << 4 | t[11:8]   D7 = t[7:0]
 * Reply data field (V3 §5.3):
 *   D0 = motor ID (1..32, equal to the CAN ID - 0x500)
 *   D1 = p[15:8]   D2 = p[7:0]
 *   D3 = v[11:4]   D4 = v[3:0] << 4 | t[11:8]    D5 = t[7:0]
 *   D6, D7 unused (0 when we encode, ignored when we decode)
 *
 * Every function here writes its outputs only when it succeeds.
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

/*
 * The ten bounds of struct rmd_mit_ranges by index, in its order (p_min,
 * p_max, v_min, .. kd_max): a config entry says which it names as a mask
 * of RMD_MIT_BOUND(k) bits, and a firmware's scaling is compared with it
 * bound by bound (rmd/dialect.h rmd_mit_scaling_decide()).
 */
#define RMD_MIT_BOUNDS 10
#define RMD_MIT_BOUND(k) (1u << (k))
#define RMD_MIT_BOUNDS_ALL ((1u << RMD_MIT_BOUNDS) - 1)

/* The config key of bound k ("p_min" .. "kd_max"), or "?" for k out of range.  Pure. */
const char *rmd_mit_bound_key(unsigned k);

/* Bound k of r (NaN for k out of range), and r's bound k set to v (ignored out of range).  Pure. */
double rmd_mit_bound(const struct rmd_mit_ranges *r, unsigned k);
void rmd_mit_bound_set(struct rmd_mit_ranges *r, unsigned k, double v);

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

/*
 * The largest magnitude of any range bound.  Beyond it min + u * span / top
 * and (x - min) * top overflow a double (fuzz_mit's F1); no firmware range
 * comes near it.  The one copy of the rule: rmdd's and rmd-sim's YAML and
 * rmdctl's --mit-ranges all refuse bounds past it through here.
 */
#define RMD_MIT_RANGE_LIMIT 1e6

/*
 * True when every pair has min < max, both within +-RMD_MIT_RANGE_LIMIT, and the
 * gains cannot go negative (kp_min >= 0, kd_min >= 0: a negative gain is a
 * destabilising command no firmware range needs).
 */
bool rmd_mit_ranges_valid(const struct rmd_mit_ranges *r);

/*
 * Ranges that passed rmd_mit_ranges_valid() once, so that the per-frame
 * pack and unpack below need not check them again (issue 11: the rt loop
 * encodes and decodes MIT frames every cycle).  Only
 * rmd_mit_ranges_validate() fills one; its first member is the ranges.
 */
struct rmd_mit_valid_ranges {
	struct rmd_mit_ranges r;
};

/* Copy r into *out when rmd_mit_ranges_valid(r).  Returns 0 or -EINVAL. */
int rmd_mit_ranges_validate(const struct rmd_mit_ranges *r, struct rmd_mit_valid_ranges *out);

/*
 * Ranges from their maxima "P,V,T,KP,KD" (e.g. "12.5,45,24,500,5", V3
 * §5.1): position, velocity and torque symmetric, kp and kd from 0; each a
 * number > 0 and at most RMD_MIT_RANGE_LIMIT.  Returns 0 or -EINVAL (r
 * untouched on error).
 */
int rmd_mit_ranges_parse(const char *maxima, struct rmd_mit_ranges *r);

/*
 * Quantise x into `bits` (1..32) over [min, max]: clamp (NaN -> min),
 * round to nearest, halves away from zero.  Returns 0 for bits outside 1..32
 * or an invalid range.  The encoders below refuse NaN and ±Inf before they
 * get here; this primitive alone has no error channel.
 */
/* V3 §5: bits of the position in requests and replies. */
#define RMD_MIT_POS_BITS 16

uint32_t rmd_mit_to_uint(double x, double min, double max, unsigned bits);
/*
 * The value of code u: min + u * (max - min) / (2^bits - 1); code 0 gives
 * exactly min and code 2^bits - 1 exactly max, a larger u is clamped to it.
 * NaN for bits outside 1..32 or an invalid range.
 */
double rmd_mit_from_uint(uint32_t u, double min, double max, unsigned bits);

/*
 * Encode a request for motor_id (1..32).  Values outside the ranges are
 * clamped.  Returns 0, or -EINVAL for a bad id, invalid ranges, or any NaN
 * or infinite field (never a silent "min" command).
 */
int rmd_mit_encode_cmd(const struct rmd_mit_ranges *r, uint8_t motor_id,
		       const struct rmd_mit_cmd *cmd, struct rmd_frame *out);
/* rmd_mit_encode_cmd() over validated ranges: -EINVAL for a bad id or a non-finite field. */
int rmd_mit_pack_cmd(const struct rmd_mit_valid_ranges *r, uint8_t motor_id,
		     const struct rmd_mit_cmd *cmd, struct rmd_frame *out);
/*
 * The codes of a command's gains, kp and kd (clamped to their ranges as
 * rmd_mit_pack_cmd() does), which a caller keeps while the gains do not
 * change: they are two of a frame's five quantised fields.  rt-safe.
 */
struct rmd_mit_gain_codes {
	uint16_t kp, kd;
};
void rmd_mit_gain_codes(const struct rmd_mit_valid_ranges *r, double kp, double kd,
			struct rmd_mit_gain_codes *g);
/*
 * rmd_mit_pack_cmd() of a command its caller checked: motor_id 1..32 and
 * every field finite (rmd_motor_encode() checks both first), its gains
 * given as their codes g (cmd->kp and cmd->kd are not read).  Values
 * outside the ranges are clamped all the same.  rt-safe.
 */
void rmd_mit_pack_gains(const struct rmd_mit_valid_ranges *r, uint8_t motor_id,
			const struct rmd_mit_cmd *cmd, const struct rmd_mit_gain_codes *g,
			struct rmd_frame *out);
/*
 * Decode a request frame (0x401..0x420).  Returns 0, -EINVAL for another
 * CAN ID or invalid ranges, -EBADMSG for a DLC other than 8.
 */
int rmd_mit_decode_cmd(const struct rmd_mit_ranges *r, const struct rmd_frame *f, uint8_t *motor_id,
		       struct rmd_mit_cmd *cmd);
/*
 * Encode a reply (0x500 + ID).  Returns 0, or -EINVAL for an id outside
 * 1..32, invalid ranges, or a NaN or infinite field.
 */
int rmd_mit_encode_reply(const struct rmd_mit_ranges *r, const struct rmd_mit_reply *rep,
			 struct rmd_frame *out);
/*
 * Decode a reply (0x501..0x520).  Returns 0, -EINVAL for another CAN ID or
 * invalid ranges, -EBADMSG for a DLC other than 8 or a D0 that is not the
 * motor ID of the CAN ID.
 */
int rmd_mit_decode_reply(const struct rmd_mit_ranges *r, const struct rmd_frame *f,
			 struct rmd_mit_reply *rep);
/* rmd_mit_decode_reply() over validated ranges. */
int rmd_mit_unpack_reply(const struct rmd_mit_valid_ranges *r, const struct rmd_frame *f,
			 struct rmd_mit_reply *rep);

#endif /* RMD_MIT_H */
