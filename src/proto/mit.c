// SPDX-License-Identifier: MIT
/*
 * MIT motion mode packing (V3 §5), bytes <-> SI values over per-motor ranges.
 *
 * Quantisation divides by 2^bits - 1 (docs/design.md), so code 0 is min and the
 * top code is max.  The manual's worked example (V3 §5.4) divides the 16-bit
 * position by 65536 (58982 / 65536 * 25 - 12.5 = 9.9998, printed "9.99") but
 * every 12-bit field by 4095; with 65536 the top code could never reach
 * p_max.  Both divisors give the manual's 0xE666 for 10.0 rad, and with
 * 65535 that code is an exact half (58981.5) that round-to-nearest lifts to
 * 58982, as the example shows; v (2093.91 -> 0x82E), kp (81.9 -> 0x052) and
 * t_ff (2900.625 -> 0xB55) confirm rounding rather than truncation.
 *
 * Everything here is pure and rt-safe.
 */
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/mit.h"

/* V3 §5.2, §5.3: field widths. */
#define P_BITS RMD_MIT_POS_BITS
#define V_BITS 12
#define KP_BITS 12
#define KD_BITS 12
#define T_BITS 12

const struct rmd_mit_ranges rmd_mit_default_ranges = {
	.p_min = -12.5,
	.p_max = 12.5,
	.v_min = -45.0,
	.v_max = 45.0,
	.t_min = -24.0,
	.t_max = 24.0,
	.kp_min = 0.0,
	.kp_max = 500.0,
	.kd_min = 0.0,
	.kd_max = 5.0,
};

/* The bounds by index (rmd_mit_bound()), in the struct's order. */
static const struct {
	const char *key;
	size_t off;
} bounds[RMD_MIT_BOUNDS] = {
#define BOUND(f)                                       \
	{                                              \
#f, offsetof(struct rmd_mit_ranges, f) \
	}
	BOUND(p_min), BOUND(p_max),  BOUND(v_min),  BOUND(v_max),  BOUND(t_min),
	BOUND(t_max), BOUND(kp_min), BOUND(kp_max), BOUND(kd_min), BOUND(kd_max),
#undef BOUND
};

const char *rmd_mit_bound_key(unsigned k)
{
	return k < RMD_MIT_BOUNDS ? bounds[k].key : "?";
}

double rmd_mit_bound(const struct rmd_mit_ranges *r, unsigned k)
{
	double v;

	if (k >= RMD_MIT_BOUNDS)
		return NAN;
	memcpy(&v, (const char *)r + bounds[k].off, sizeof(v));
	return v;
}

void rmd_mit_bound_set(struct rmd_mit_ranges *r, unsigned k, double v)
{
	if (k < RMD_MIT_BOUNDS)
		memcpy((char *)r + bounds[k].off, &v, sizeof(v));
}

static bool range_ok(double min, double max)
{
	/* !(a <= b) also refuses NaN */
	return min >= -RMD_MIT_RANGE_LIMIT && max <= RMD_MIT_RANGE_LIMIT && min < max;
}

static bool bits_ok(unsigned bits)
{
	return bits >= 1 && bits <= 32;
}

/* 2^bits - 1, for bits 1..32. */
static uint32_t top_code(unsigned bits)
{
	return UINT32_MAX >> (32 - bits);
}

static bool mit_id_ok(uint8_t id)
{
	return id >= 1 && id <= RMD_MAX_MOTORS;
}

bool rmd_mit_ranges_valid(const struct rmd_mit_ranges *r)
{
	return r && range_ok(r->p_min, r->p_max) && range_ok(r->v_min, r->v_max) &&
	       range_ok(r->t_min, r->t_max) && range_ok(r->kp_min, r->kp_max) &&
	       range_ok(r->kd_min, r->kd_max) && r->kp_min >= 0.0 && r->kd_min >= 0.0;
}

/*
 * x quantised over a valid range [min, max] to `top` = 2^bits - 1.  round()
 * of a value >= 0 is its integer part plus one when the fraction is >= 0.5
 * (the fraction of a double is exact), without a libm call per field.
 */
static uint32_t to_uint(double x, double min, double max, uint32_t top)
{
	double u;
	uint32_t i;

	/* Clamp first; !(x > min) also catches NaN. */
	if (!(x > min))
		return 0;
	if (x >= max)
		return top;
	/* Multiply before dividing, as the formula reads: exact halves stay exact. */
	u = (x - min) * (double)top / (max - min);
	if (u >= (double)top)
		return top;
	i = (uint32_t)u;
	return u - (double)i >= 0.5 ? i + 1 : i;
}

static double from_uint(uint32_t u, double min, double max, uint32_t top)
{
	if (u == 0)
		return min;
	if (u >= top)
		return max;
	return min + (double)u * (max - min) / (double)top;
}

uint32_t rmd_mit_to_uint(double x, double min, double max, unsigned bits)
{
	if (!bits_ok(bits) || !range_ok(min, max))
		return 0;
	return to_uint(x, min, max, top_code(bits));
}

double rmd_mit_from_uint(uint32_t u, double min, double max, unsigned bits)
{
	if (!bits_ok(bits) || !range_ok(min, max))
		return NAN;
	return from_uint(u, min, max, top_code(bits));
}

int rmd_mit_ranges_validate(const struct rmd_mit_ranges *r, struct rmd_mit_valid_ranges *out)
{
	if (!rmd_mit_ranges_valid(r))
		return -EINVAL;
	out->r = *r;
	return 0;
}

static bool cmd_finite(const struct rmd_mit_cmd *c)
{
	return isfinite(c->p_des_rad) && isfinite(c->v_des_rad_s) && isfinite(c->kp) &&
	       isfinite(c->kd) && isfinite(c->t_ff_nm);
}

static int pack_cmd(const struct rmd_mit_ranges *r, uint8_t motor_id, const struct rmd_mit_cmd *cmd,
		    struct rmd_frame *out);
static int unpack_reply(const struct rmd_mit_ranges *r, const struct rmd_frame *f,
			struct rmd_mit_reply *rep);

int rmd_mit_encode_cmd(const struct rmd_mit_ranges *r, uint8_t motor_id,
		       const struct rmd_mit_cmd *cmd, struct rmd_frame *out)
{
	if (!rmd_mit_ranges_valid(r))
		return -EINVAL;
	return pack_cmd(r, motor_id, cmd, out);
}

int rmd_mit_pack_cmd(const struct rmd_mit_valid_ranges *vr, uint8_t motor_id,
		     const struct rmd_mit_cmd *cmd, struct rmd_frame *out)
{
	return pack_cmd(&vr->r, motor_id, cmd, out);
}

/* V3 §5.2's layout of the five codes. */
static inline __attribute__((always_inline)) void put(uint8_t motor_id, uint32_t p, uint32_t v,
						      uint32_t kp, uint32_t kd, uint32_t t,
						      struct rmd_frame *out)
{
	out->can_id = RMD_CAN_MIT_REQ_BASE + motor_id;
	out->len = RMD_FRAME_LEN;
	out->data[0] = (uint8_t)(p >> 8);
	out->data[1] = (uint8_t)p;
	out->data[2] = (uint8_t)(v >> 4);
	out->data[3] = (uint8_t)((v & 0xFu) << 4 | kp >> 8);
	out->data[4] = (uint8_t)kp;
	out->data[5] = (uint8_t)(kd >> 4);
	out->data[6] = (uint8_t)((kd & 0xFu) << 4 | t >> 8);
	out->data[7] = (uint8_t)t;
}

/* V3 §5.2 over ranges known to be valid, of a good id and finite fields. */
static inline __attribute__((always_inline)) void pack(const struct rmd_mit_ranges *r,
						       uint8_t motor_id,
						       const struct rmd_mit_cmd *cmd,
						       struct rmd_frame *out)
{
	put(motor_id, to_uint(cmd->p_des_rad, r->p_min, r->p_max, top_code(P_BITS)),
	    to_uint(cmd->v_des_rad_s, r->v_min, r->v_max, top_code(V_BITS)),
	    to_uint(cmd->kp, r->kp_min, r->kp_max, top_code(KP_BITS)),
	    to_uint(cmd->kd, r->kd_min, r->kd_max, top_code(KD_BITS)),
	    to_uint(cmd->t_ff_nm, r->t_min, r->t_max, top_code(T_BITS)), out);
}

/* V3 §5.2 over ranges known to be valid. */
static int pack_cmd(const struct rmd_mit_ranges *r, uint8_t motor_id, const struct rmd_mit_cmd *cmd,
		    struct rmd_frame *out)
{
	if (!mit_id_ok(motor_id) || !cmd_finite(cmd))
		return -EINVAL;
	pack(r, motor_id, cmd, out);
	return 0;
}

void rmd_mit_gain_codes(const struct rmd_mit_valid_ranges *vr, double kp, double kd,
			struct rmd_mit_gain_codes *g)
{
	const struct rmd_mit_ranges *r = &vr->r;

	g->kp = (uint16_t)to_uint(kp, r->kp_min, r->kp_max, top_code(KP_BITS));
	g->kd = (uint16_t)to_uint(kd, r->kd_min, r->kd_max, top_code(KD_BITS));
}

void rmd_mit_pack_gains(const struct rmd_mit_valid_ranges *vr, uint8_t motor_id,
			const struct rmd_mit_cmd *cmd, const struct rmd_mit_gain_codes *g,
			struct rmd_frame *out)
{
	const struct rmd_mit_ranges *r = &vr->r;

	put(motor_id, to_uint(cmd->p_des_rad, r->p_min, r->p_max, top_code(P_BITS)),
	    to_uint(cmd->v_des_rad_s, r->v_min, r->v_max, top_code(V_BITS)), g->kp, g->kd,
	    to_uint(cmd->t_ff_nm, r->t_min, r->t_max, top_code(T_BITS)), out);
}

int rmd_mit_decode_cmd(const struct rmd_mit_ranges *r, const struct rmd_frame *f, uint8_t *motor_id,
		       struct rmd_mit_cmd *cmd)
{
	const uint8_t *d = f->data;
	uint32_t p, v, kp, kd, t;

	if (!rmd_mit_ranges_valid(r) || f->can_id <= RMD_CAN_MIT_REQ_BASE ||
	    f->can_id > RMD_CAN_MIT_REQ_BASE + RMD_MAX_MOTORS)
		return -EINVAL;
	if (f->len != RMD_FRAME_LEN)
		return -EBADMSG;

	p = (uint32_t)d[0] << 8 | d[1];
	v = (uint32_t)d[2] << 4 | d[3] >> 4;
	kp = (uint32_t)(d[3] & 0xFu) << 8 | d[4];
	kd = (uint32_t)d[5] << 4 | d[6] >> 4;
	t = (uint32_t)(d[6] & 0xFu) << 8 | d[7];

	*motor_id = (uint8_t)(f->can_id - RMD_CAN_MIT_REQ_BASE);
	cmd->p_des_rad = rmd_mit_from_uint(p, r->p_min, r->p_max, P_BITS);
	cmd->v_des_rad_s = rmd_mit_from_uint(v, r->v_min, r->v_max, V_BITS);
	cmd->kp = rmd_mit_from_uint(kp, r->kp_min, r->kp_max, KP_BITS);
	cmd->kd = rmd_mit_from_uint(kd, r->kd_min, r->kd_max, KD_BITS);
	cmd->t_ff_nm = rmd_mit_from_uint(t, r->t_min, r->t_max, T_BITS);
	return 0;
}

/*
 * V3 §5.3.  The reply table names its fields p_des, v_des and t_ff but they
 * are the measured position, velocity and torque.  The §5.4 reply example
 * is garbled: it prints D2 = 0x65 while its own text says p = 0xE666, and it
 * has no D3 row.  The layout table and the example's field values (p 0xE666,
 * v 0x82E, t 0xB55, D4 = 0xEB = v[3:0] << 4 | t[11:8]) agree on
 * 501#01E66682EB550000, which is what this encodes.
 */
int rmd_mit_encode_reply(const struct rmd_mit_ranges *r, const struct rmd_mit_reply *rep,
			 struct rmd_frame *out)
{
	uint32_t p, v, t;

	if (!mit_id_ok(rep->motor_id) || !rmd_mit_ranges_valid(r) || !isfinite(rep->pos_rad) ||
	    !isfinite(rep->vel_rad_s) || !isfinite(rep->torque_nm))
		return -EINVAL;

	p = rmd_mit_to_uint(rep->pos_rad, r->p_min, r->p_max, P_BITS);
	v = rmd_mit_to_uint(rep->vel_rad_s, r->v_min, r->v_max, V_BITS);
	t = rmd_mit_to_uint(rep->torque_nm, r->t_min, r->t_max, T_BITS);

	out->can_id = RMD_CAN_MIT_REPLY_BASE + rep->motor_id;
	out->len = RMD_FRAME_LEN;
	out->data[0] = rep->motor_id;
	out->data[1] = (uint8_t)(p >> 8);
	out->data[2] = (uint8_t)p;
	out->data[3] = (uint8_t)(v >> 4);
	out->data[4] = (uint8_t)((v & 0xFu) << 4 | t >> 8);
	out->data[5] = (uint8_t)t;
	out->data[6] = 0;
	out->data[7] = 0;
	return 0;
}

int rmd_mit_decode_reply(const struct rmd_mit_ranges *r, const struct rmd_frame *f,
			 struct rmd_mit_reply *rep)
{
	if (!rmd_mit_ranges_valid(r))
		return -EINVAL;
	return unpack_reply(r, f, rep);
}

int rmd_mit_unpack_reply(const struct rmd_mit_valid_ranges *vr, const struct rmd_frame *f,
			 struct rmd_mit_reply *rep)
{
	return unpack_reply(&vr->r, f, rep);
}

/* V3 §5.3 over ranges known to be valid. */
static int unpack_reply(const struct rmd_mit_ranges *r, const struct rmd_frame *f,
			struct rmd_mit_reply *rep)
{
	const uint8_t *d = f->data;
	uint32_t p, v, t;
	uint8_t id;

	if (f->can_id <= RMD_CAN_MIT_REPLY_BASE ||
	    f->can_id > RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS)
		return -EINVAL;
	id = (uint8_t)(f->can_id - RMD_CAN_MIT_REPLY_BASE);
	/* A D0 that disagrees with the CAN ID cannot be matched to one motor. */
	if (f->len != RMD_FRAME_LEN || d[0] != id)
		return -EBADMSG;

	p = (uint32_t)d[1] << 8 | d[2];
	v = (uint32_t)d[3] << 4 | d[4] >> 4;
	t = (uint32_t)(d[4] & 0xFu) << 8 | d[5];

	rep->motor_id = id;
	rep->pos_rad = from_uint(p, r->p_min, r->p_max, top_code(P_BITS));
	rep->vel_rad_s = from_uint(v, r->v_min, r->v_max, top_code(V_BITS));
	rep->torque_nm = from_uint(t, r->t_min, r->t_max, top_code(T_BITS));
	return 0;
}

int rmd_mit_ranges_parse(const char *s, struct rmd_mit_ranges *r)
{
	struct rmd_mit_ranges out;
	double m[5];
	const char *p = s;

	for (unsigned i = 0; i < 5; i++) {
		char num[64], *end;
		size_t n = strcspn(p, ",");

		if (n == 0 || n >= sizeof(num) || (i < 4 && p[n] != ',') || (i == 4 && p[n]))
			return -EINVAL;
		memcpy(num, p, n);
		num[n] = '\0';
		errno = 0;
		m[i] = strtod(num, &end);
		if (end == num || *end || errno == ERANGE || !isfinite(m[i]) || !(m[i] > 0))
			return -EINVAL;
		p += n + (i < 4);
	}
	out = (struct rmd_mit_ranges){
		.p_min = -m[0],
		.p_max = m[0],
		.v_min = -m[1],
		.v_max = m[1],
		.t_min = -m[2],
		.t_max = m[2],
		.kp_min = 0,
		.kp_max = m[3],
		.kd_min = 0,
		.kd_max = m[4],
	};
	if (!rmd_mit_ranges_valid(&out))
		return -EINVAL;
	*r = out;
	return 0;
}
