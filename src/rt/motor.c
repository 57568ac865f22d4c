// SPDX-License-Identifier: MIT
/*
 * One motor's units and frames: SI at the output shaft <-> the protocol's
 * native units.  See rmd/motor.h.  Every function is rt-safe.
 *
 * Native values go through the codec's table rows (rmd/codec.h): a field's
 * LSB comes from its row (V3 0xA1 0.01 A, V2 0xA1 32 A / 2000, ...), and a
 * value beyond the field's integer range is clamped to it (and flagged)
 * rather than refused by the encoder.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/motor.h"

#define DEG_PER_RAD (180.0 / M_PI)

/* rt-safe. */
static double clampf(double x, double lo, double hi, unsigned *fl)
{
	if (x < lo) {
		*fl |= RMD_MOTOR_CLAMPED;
		return lo;
	}
	if (x > hi) {
		*fl |= RMD_MOTOR_CLAMPED;
		return hi;
	}
	return x;
}

/*
 * Request field `fld` of `spec` = `native` in the field's unit, by the
 * codec's one rule (rmd_field_from_native()): saturated values flag
 * RMD_MOTOR_CLAMPED.  rt-safe.
 */
static void put(struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_field fld,
		double native, unsigned *fl)
{
	if (rmd_msg_set_native(msg, spec, RMD_DIR_REQUEST, fld, native) == -ERANGE)
		*fl |= RMD_MOTOR_CLAMPED;
}

/* Reply field `fld` in its native unit.  rt-safe. */
static double get(const struct rmd_cmd_spec *spec, const struct rmd_msg *msg, enum rmd_field fld)
{
	return rmd_msg_get_native(msg, spec, RMD_DIR_REPLY, fld, 0.0);
}

/* rt-safe. */
int rmd_motor_init(struct rmd_motor *m, const struct rmd_config_motor *c)
{
	memset(m, 0, sizeof(*m));
	if ((c->direction != 1 && c->direction != -1) || !(c->gear_ratio > 0.0) ||
	    !isfinite(c->gear_ratio) || c->id < 1 || c->id > RMD_MAX_MOTORS ||
	    !isfinite(c->zero_offset_rad))
		return -EINVAL;
	switch (c->proto) {
	case RMD_PROTO_MIT:
		if (!rmd_mit_ranges_valid(&c->mit))
			return -EINVAL;
		break;
	case RMD_PROTO_V2:
	case RMD_PROTO_V3:
		if (!(c->torque_constant_nm_a > 0.0) || !isfinite(c->torque_constant_nm_a))
			return -EINVAL;
		break;
	default:
		return -EINVAL;
	}
	m->name = c->name;
	m->bus = (uint8_t)c->bus;
	m->id = c->id;
	m->proto = c->proto;
	m->mode = c->mode;
	m->dir = c->direction;
	m->gear_ratio = c->gear_ratio;
	m->native_per_output = c->units == RMD_UNITS_ROTOR ? c->gear_ratio : 1.0;
	m->zero_offset_rad = c->zero_offset_rad;
	m->kt_nm_a = c->torque_constant_nm_a > 0.0 ? c->torque_constant_nm_a : 0.0;
	m->limits = c->limits;
	m->mit = c->mit;
	m->damp_kd = RMD_MOTOR_DAMP_KD;
	if (m->proto == RMD_PROTO_MIT) {
		if (m->damp_kd > m->mit.kd_max)
			m->damp_kd = m->mit.kd_max;
		if (m->damp_kd < m->mit.kd_min)
			m->damp_kd = m->mit.kd_min;
	}
	return 0;
}

/* rt-safe. */
unsigned rmd_motor_modes(const struct rmd_motor *m, bool batched)
{
	unsigned modes = 0;

	if (m->kt_nm_a > 0.0)
		modes |= RMD_MOTOR_MODE_BIT(RMD_MODE_TORQUE);
	if (batched)
		return modes;
	modes |= RMD_MOTOR_MODE_BIT(RMD_MODE_SPEED) | RMD_MOTOR_MODE_BIT(RMD_MODE_POSITION);
	if (m->proto == RMD_PROTO_MIT)
		modes |= RMD_MOTOR_MODE_BIT(RMD_MODE_MIT);
	return modes;
}

/* Non-rt. */
void rmd_motor_info(const struct rmd_motor *m, bool batched, struct rmd_motor_info *out)
{
	bool mit = m->proto == RMD_PROTO_MIT;

	memset(out, 0, sizeof(*out));
	snprintf(out->name, sizeof(out->name), "%s", m->name ? m->name : "");
	out->bus = m->bus;
	out->id = m->id;
	snprintf(out->protocol, sizeof(out->protocol), "%s", rmd_proto_key(m->proto));
	out->modes = (uint8_t)rmd_motor_modes(m, batched);
	out->pos_min_rad = m->limits.position_min_rad;
	out->pos_max_rad = m->limits.position_max_rad;
	out->vel_max_rad_s = m->limits.velocity_rad_s;
	out->torque_max_nm = m->limits.torque_nm;
	/* gains matter to MIT commands only; other motors get an empty range */
	out->kp_min = mit ? m->mit.kp_min : 0;
	out->kp_max = mit ? m->mit.kp_max : 0;
	out->kd_min = mit ? m->mit.kd_min : 0;
	out->kd_max = mit ? m->mit.kd_max : 0;
}

/* x within [lo, hi]; the first change of a rmd_motor_clamp() call goes in *note.  rt-safe. */
static double clamp_value(double x, double lo, double hi, const char *field, unsigned *n,
			  struct rmd_motor_clamp_note *note)
{
	double y = x < lo ? lo : x > hi ? hi : x;

	if (y != x && !(*n)++ && note)
		*note = (struct rmd_motor_clamp_note){ field, x, y };
	return y;
}

/* rt-safe. */
unsigned rmd_motor_clamp(const struct rmd_config_limits *lim, struct rmd_setpoint *sp,
			 struct rmd_motor_clamp_note *note)
{
	double vmax = lim->velocity_rad_s, tmax = lim->torque_nm;
	unsigned n = 0;

	if (rmd_mode_uses_pos(sp->mode))
		sp->pos_rad = clamp_value(sp->pos_rad, lim->position_min_rad, lim->position_max_rad,
					  "position", &n, note);
	if (rmd_mode_uses_vel(sp->mode))
		sp->vel_rad_s = clamp_value(sp->vel_rad_s, -vmax, vmax, "velocity", &n, note);
	if (rmd_mode_uses_torque(sp->mode))
		sp->torque_nm = clamp_value(sp->torque_nm, -tmax, tmax, "torque", &n, note);
	/* 0 asks for the motor's limit; 0 stays when it has none (the firmware's own) */
	if (sp->mode == RMD_MODE_POSITION && isfinite(vmax))
		sp->max_vel_rad_s = sp->max_vel_rad_s == 0 ? vmax :
							     clamp_value(sp->max_vel_rad_s, 0, vmax,
									 "max_velocity", &n, note);
	return n;
}

/* rt-safe. */
double rmd_motor_to_native_pos(const struct rmd_motor *m, double pos_rad)
{
	return m->dir * pos_rad + m->zero_offset_rad;
}

/* rt-safe. */
double rmd_motor_from_native_pos(const struct rmd_motor *m, double native_rad)
{
	return m->dir * (native_rad - m->zero_offset_rad);
}

/* Encode msg on 0x140 + ID with the motor's table.  rt-safe. */
static int encode_msg(const struct rmd_motor *m, const struct rmd_msg *msg, struct rmd_frame *out)
{
	return rmd_encode(m->proto, RMD_DIR_REQUEST, m->id, msg, out);
}

/*
 * Start msg as an empty `cmd` of the motor's protocol: its spec, or NULL
 * (msg untouched) when the protocol has no such command.  rt-safe.
 */
static const struct rmd_cmd_spec *msg_start(const struct rmd_motor *m, uint8_t cmd,
					    struct rmd_msg *msg)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(m->proto, cmd);

	if (spec) {
		memset(msg, 0, sizeof(*msg));
		msg->cmd = cmd;
	}
	return spec;
}

/* rt-safe. */
int rmd_motor_encode_cmd(const struct rmd_motor *m, uint8_t cmd, struct rmd_frame *out)
{
	struct rmd_msg msg;

	if (!msg_start(m, cmd, &msg))
		return -ENOENT;
	return encode_msg(m, &msg, out);
}

/* rt-safe. */
int rmd_motor_encode_comm_timeout(const struct rmd_motor *m, uint32_t ms, struct rmd_frame *out)
{
	struct rmd_msg msg;

	/* V3 §2.30; V2 has no comm-loss protection command. */
	if (m->proto == RMD_PROTO_V2)
		return -EOPNOTSUPP;
	memset(&msg, 0, sizeof(msg));
	msg.cmd = 0xB3;
	rmd_msg_set(&msg, RMD_FLD_TIMEOUT, ms);
	return encode_msg(m, &msg, out);
}

/* Native torque -> iq in A, for a motor with a torque constant.  rt-safe. */
static double torque_to_iq(const struct rmd_motor *m, double torque_nm)
{
	return m->dir * torque_nm / m->kt_nm_a;
}

/* 0xA1 with `torque_nm` (reported frame, within the limit).  rt-safe. */
static int encode_torque(const struct rmd_motor *m, double torque_nm, struct rmd_frame *out,
			 unsigned *fl)
{
	struct rmd_msg msg;
	const struct rmd_cmd_spec *spec = msg_start(m, 0xA1, &msg);

	if (!spec || !(m->kt_nm_a > 0.0))
		return -EOPNOTSUPP;
	put(&msg, spec, RMD_FLD_CURRENT, torque_to_iq(m, torque_nm), fl);
	return encode_msg(m, &msg, out);
}

/* 0xA2 at vel_rad_s (reported frame, within the limit).  rt-safe. */
static int encode_speed(const struct rmd_motor *m, double vel_rad_s, struct rmd_frame *out,
			unsigned *fl)
{
	struct rmd_msg msg;
	const struct rmd_cmd_spec *spec = msg_start(m, 0xA2, &msg);

	if (!spec)
		return -EOPNOTSUPP;
	put(&msg, spec, RMD_FLD_SPEED, m->dir * vel_rad_s * DEG_PER_RAD * m->native_per_output, fl);
	return encode_msg(m, &msg, out);
}

/*
 * 0xA4 to pos_rad at up to mv_rad_s (both within the limits; maxSpeed 0
 * leaves the speed to the firmware's own limit).  rt-safe.
 */
static int encode_position(const struct rmd_motor *m, double pos_rad, double mv_rad_s,
			   struct rmd_frame *out, unsigned *fl)
{
	double native = rmd_motor_to_native_pos(m, pos_rad);
	struct rmd_msg msg;
	const struct rmd_cmd_spec *spec = msg_start(m, 0xA4, &msg);

	if (!spec)
		return -EOPNOTSUPP;
	put(&msg, spec, RMD_FLD_ANGLE, native * DEG_PER_RAD * m->native_per_output, fl);
	put(&msg, spec, RMD_FLD_MAX_SPEED, mv_rad_s * DEG_PER_RAD * m->native_per_output, fl);
	return encode_msg(m, &msg, out);
}

/*
 * MIT frame (V3 §5.2) from reported-frame values within the limits; the
 * MIT ranges clamp too (rmd_mit_encode_cmd()).  rt-safe.
 */
static int encode_mit(const struct rmd_motor *m, const struct rmd_setpoint *sp,
		      struct rmd_frame *out, unsigned *fl)
{
	const struct rmd_mit_ranges *r = &m->mit;
	struct rmd_mit_cmd c;

	if (m->proto != RMD_PROTO_MIT)
		return -EOPNOTSUPP;
	c.p_des_rad = clampf(rmd_motor_to_native_pos(m, sp->pos_rad), r->p_min, r->p_max, fl);
	c.v_des_rad_s = clampf(m->dir * sp->vel_rad_s, r->v_min, r->v_max, fl);
	c.t_ff_nm = clampf(m->dir * sp->torque_nm, r->t_min, r->t_max, fl);
	c.kp = clampf(sp->kp, r->kp_min, r->kp_max, fl);
	c.kd = clampf(sp->kd, r->kd_min, r->kd_max, fl);
	return rmd_mit_encode_cmd(r, m->id, &c, out) < 0 ? -EOPNOTSUPP : 0;
}

/* rt-safe. */
int rmd_motor_encode(const struct rmd_motor *m, const struct rmd_setpoint *sp,
		     struct rmd_frame *out, unsigned *flags)
{
	struct rmd_setpoint c = *sp; /* clamped to the limits */
	unsigned fl = 0;
	int r;

	c.max_vel_rad_s = fabs(c.max_vel_rad_s);
	if (rmd_motor_clamp(&m->limits, &c, NULL))
		fl |= RMD_MOTOR_CLAMPED;
	switch ((enum rmd_mode)sp->mode) {
	case RMD_MODE_TORQUE:
		if (!isfinite(sp->torque_nm))
			return -EDOM;
		r = encode_torque(m, c.torque_nm, out, &fl);
		break;
	case RMD_MODE_SPEED:
		if (!isfinite(sp->vel_rad_s))
			return -EDOM;
		r = encode_speed(m, c.vel_rad_s, out, &fl);
		break;
	case RMD_MODE_POSITION:
		if (!isfinite(sp->pos_rad) || !isfinite(sp->max_vel_rad_s))
			return -EDOM;
		r = encode_position(m, c.pos_rad, c.max_vel_rad_s, out, &fl);
		break;
	case RMD_MODE_MIT:
		if (!isfinite(sp->pos_rad) || !isfinite(sp->vel_rad_s) ||
		    !isfinite(sp->torque_nm) || !isfinite(sp->kp) || !isfinite(sp->kd))
			return -EDOM;
		r = encode_mit(m, &c, out, &fl);
		break;
	case RMD_MODE_COUNT:
	default:
		return -EOPNOTSUPP;
	}
	if (r == 0 && flags)
		*flags = fl;
	return r < 0 ? -EOPNOTSUPP : 0;
}

/* rt-safe. */
int rmd_motor_encode_safe(const struct rmd_motor *m, enum rmd_safe_action a,
			  struct rmd_frame out[2])
{
	unsigned fl = 0;

	switch (a) {
	case RMD_SAFE_STOP:
		return rmd_motor_encode_cmd(m, 0x80, &out[0]) < 0 ? -EINVAL : 1;
	case RMD_SAFE_HOLD:
		return rmd_motor_encode_cmd(m, 0x81, &out[0]) < 0 ? -EINVAL : 1;
	case RMD_SAFE_DAMP:
		if (m->proto == RMD_PROTO_MIT) {
			/* kp 0: no position target; kd > 0 resists motion; no torque. */
			struct rmd_mit_cmd c = { .kd = m->damp_kd };

			return rmd_mit_encode_cmd(&m->mit, m->id, &c, &out[0]) < 0 ? -EINVAL : 1;
		}
		{
			struct rmd_frame f;

			/* zero speed: the drive brakes to a stand-still and holds it */
			if (encode_speed(m, 0.0, &f, &fl) < 0)
				return -EINVAL;
			out[0] = f;
		}
		return 1;
	case RMD_SAFE_BRAKE:
		if (rmd_motor_encode_cmd(m, 0x80, &out[0]) < 0 ||
		    rmd_motor_encode_cmd(m, 0x78, &out[1]) < 0)
			return -EINVAL;
		return 2;
	}
	return -EINVAL;
}

/* rt-safe. */
int rmd_motor_encode_v2_batch(const struct rmd_motor *const m[4], const double torque_nm[4],
			      struct rmd_frame *out, unsigned *flags, unsigned *nonfinite)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(RMD_PROTO_V2, RMD_V2_CMD_MULTI_TORQUE);
	struct rmd_msg msg;
	unsigned fl = 0, bad = 0;

	if (!spec)
		return -EINVAL;
	memset(&msg, 0, sizeof(msg));
	msg.cmd = RMD_V2_CMD_MULTI_TORQUE;
	for (unsigned k = 0; k < 4; k++) {
		enum rmd_field fld = (enum rmd_field)(RMD_FLD_CURRENT_1 + k);
		const struct rmd_motor *mk = m[k];
		struct rmd_setpoint t = { .mode = RMD_MODE_TORQUE };

		rmd_msg_set(&msg, fld, 0);
		if (!mk)
			continue;
		if (mk->proto != RMD_PROTO_V2 || mk->id != k + 1 || !(mk->kt_nm_a > 0.0))
			return -EINVAL;
		if (!isfinite(torque_nm[k])) {
			bad++;
			continue;
		}
		t.torque_nm = torque_nm[k];
		if (rmd_motor_clamp(&mk->limits, &t, NULL))
			fl |= RMD_MOTOR_CLAMPED;
		put(&msg, spec, fld, torque_to_iq(mk, t.torque_nm), &fl);
	}
	if (rmd_encode(RMD_PROTO_V2, RMD_DIR_REQUEST, 0, &msg, out) < 0)
		return -EINVAL;
	if (flags)
		*flags = fl;
	if (nonfinite)
		*nonfinite = bad;
	return 0;
}

/* rt-safe. */
void rmd_motor_reply_key(const struct rmd_motor *m, const struct rmd_frame *req, uint32_t *reply_id,
			 uint16_t *cmd)
{
	if (req->can_id == RMD_CAN_MIT_REQ_BASE + m->id) {
		*reply_id = RMD_CAN_MIT_REPLY_BASE + m->id;
		*cmd = RMD_MOTOR_CMD_MIT;
		return;
	}
	if (req->can_id == RMD_CAN_MULTI) {
		/* V2 §4.2: each motor of the frame answers like 0xA1 */
		*reply_id = RMD_CAN_REQ_BASE + m->id;
		*cmd = 0xA1;
		return;
	}
	*reply_id = (m->proto == RMD_PROTO_V2 ? RMD_CAN_REQ_BASE : RMD_CAN_V3_REPLY_BASE) + m->id;
	*cmd = req->len ? req->data[0] : 0;
}

/* rt-safe. */
void rmd_motor_set_v2_reference(struct rmd_motor *m, double native_rad)
{
	m->v2_have_ref = true;
	m->v2_ref_rad = native_rad;
	m->v2_anchored = false;
}

/* V2 §3.32: rotor single-turn encoder -> native multi-turn output angle.  rt-safe. */
static double v2_unwrap(struct rmd_motor *m, uint16_t enc)
{
	if (!m->v2_anchored) {
		m->v2_anchored = true;
		m->v2_enc_counts = 0;
	} else {
		m->v2_enc_counts += (int16_t)(uint16_t)(enc - m->v2_enc_last);
	}
	m->v2_enc_last = enc;
	return m->v2_ref_rad + (double)m->v2_enc_counts / RMD_MOTOR_V2_ENCODER_COUNTS *
				       (2.0 * M_PI) / m->gear_ratio;
}

/* rt-safe. */
static int decode_mit(struct rmd_motor *m, const struct rmd_frame *f, struct rmd_motor_reply *r)
{
	struct rmd_mit_reply rep;
	int ret;

	if (m->proto != RMD_PROTO_MIT)
		return -EINVAL;
	ret = rmd_mit_decode_reply(&m->mit, f, &rep);
	if (ret < 0)
		return ret;
	r->pos_rad = rmd_motor_from_native_pos(m, rep.pos_rad);
	r->vel_rad_s = m->dir * rep.vel_rad_s;
	r->torque_nm = m->dir * rep.torque_nm;
	r->current_a = m->kt_nm_a > 0.0 ? r->torque_nm / m->kt_nm_a : NAN;
	r->have = RMD_MOTOR_HAVE_POS | RMD_MOTOR_HAVE_VEL | RMD_MOTOR_HAVE_TORQUE;
	return 0;
}

/* rt-safe. */
int rmd_motor_decode(struct rmd_motor *m, const struct rmd_frame *f, struct rmd_motor_reply *r)
{
	const struct rmd_cmd_spec *spec;
	enum rmd_proto proto = rmd_proto_table(m->proto);
	struct rmd_msg msg;
	int ret;

	memset(r, 0, sizeof(*r));
	if (f->can_id == RMD_CAN_MIT_REPLY_BASE + m->id) {
		r->cmd = RMD_MOTOR_CMD_MIT;
		return decode_mit(m, f, r);
	}
	if (f->can_id != (proto == RMD_PROTO_V2 ? RMD_CAN_REQ_BASE : RMD_CAN_V3_REPLY_BASE) + m->id)
		return -EINVAL;
	if (f->len != RMD_FRAME_LEN)
		return -EBADMSG;
	r->cmd = f->data[0];
	ret = rmd_decode(proto, RMD_DIR_REPLY, f, &msg, NULL);
	if (ret < 0)
		return ret;
	spec = rmd_cmd_find(proto, msg.cmd);
	if (!spec)
		return -ENOENT;
	if (rmd_msg_has(&msg, RMD_FLD_TEMP)) {
		r->temp_c = get(spec, &msg, RMD_FLD_TEMP);
		r->have |= RMD_MOTOR_HAVE_TEMP;
	}
	if (rmd_msg_has(&msg, RMD_FLD_CURRENT)) {
		double iq = get(spec, &msg, RMD_FLD_CURRENT);

		r->current_a = m->dir * iq;
		r->torque_nm = m->kt_nm_a > 0.0 ? r->current_a * m->kt_nm_a : NAN;
		r->have |= RMD_MOTOR_HAVE_TORQUE;
	}
	if (rmd_msg_has(&msg, RMD_FLD_SPEED)) {
		double dps = get(spec, &msg, RMD_FLD_SPEED);

		r->vel_rad_s = m->dir * dps / DEG_PER_RAD / m->native_per_output;
		r->have |= RMD_MOTOR_HAVE_VEL;
	}
	if (rmd_msg_has(&msg, RMD_FLD_ANGLE)) {
		/* V3 status 2 (whole degrees) or 0x92 (0.01 deg): the output angle */
		double native = get(spec, &msg, RMD_FLD_ANGLE) / DEG_PER_RAD / m->native_per_output;

		r->pos_rad = rmd_motor_from_native_pos(m, native);
		r->have |= RMD_MOTOR_HAVE_POS;
	} else if (proto == RMD_PROTO_V2 && rmd_msg_has(&msg, RMD_FLD_ENCODER) && msg.cmd != 0x60) {
		r->pos_rad = rmd_motor_from_native_pos(
			m, v2_unwrap(m, (uint16_t)msg.v[RMD_FLD_ENCODER]));
		r->have |= RMD_MOTOR_HAVE_POS;
	}
	if (rmd_msg_has(&msg, RMD_FLD_VOLTAGE)) {
		r->voltage_v = get(spec, &msg, RMD_FLD_VOLTAGE);
		r->have |= RMD_MOTOR_HAVE_VOLTAGE;
	}
	if (rmd_msg_has(&msg, RMD_FLD_ERROR)) {
		r->error_code = (uint16_t)msg.v[RMD_FLD_ERROR];
		r->have |= RMD_MOTOR_HAVE_ERROR;
	}
	if (rmd_msg_has(&msg, RMD_FLD_BRAKE)) {
		r->brake_released = msg.v[RMD_FLD_BRAKE] != 0;
		r->have |= RMD_MOTOR_HAVE_BRAKE;
	}
	if (rmd_msg_has(&msg, RMD_FLD_MODEL)) {
		rmd_model_string(msg.v[RMD_FLD_MODEL], r->model);
		r->have |= RMD_MOTOR_HAVE_MODEL;
	}
	if (rmd_msg_has(&msg, RMD_FLD_VERSION)) {
		r->version_date = (uint32_t)msg.v[RMD_FLD_VERSION];
		r->have |= RMD_MOTOR_HAVE_VERSION;
	}
	if (rmd_msg_has(&msg, RMD_FLD_TIMEOUT)) {
		r->comm_timeout_ms = (uint32_t)msg.v[RMD_FLD_TIMEOUT];
		r->have |= RMD_MOTOR_HAVE_TIMEOUT;
	}
	return 0;
}

/* rt-safe. */
void rmd_motor_apply(const struct rmd_motor_reply *r, struct rmd_motor_state *st)
{
	if (r->have & RMD_MOTOR_HAVE_POS)
		st->pos_rad = r->pos_rad;
	if (r->have & RMD_MOTOR_HAVE_VEL)
		st->vel_rad_s = r->vel_rad_s;
	if (r->have & RMD_MOTOR_HAVE_TORQUE) {
		st->torque_nm = r->torque_nm;
		st->current_a = r->current_a;
	}
	if (r->have & RMD_MOTOR_HAVE_TEMP)
		st->temp_c = r->temp_c;
	if (r->have & RMD_MOTOR_HAVE_VOLTAGE)
		st->voltage_v = r->voltage_v;
	if (r->have & RMD_MOTOR_HAVE_ERROR)
		st->error_code = r->error_code;
}
