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
#include "rmd/proc_arm.h"
#include "rmd/reboot.h"

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
 * `native` in the unit of field fs by the codec's one rule
 * (rmd_field_raw_in(): rounded to the LSB, saturated to [lo, hi], the
 * field's integer range); a saturated value flags RMD_MOTOR_CLAMPED.
 * rt-safe.
 */
static inline __attribute__((always_inline)) int64_t
field_raw(const struct rmd_field_spec *fs, int64_t lo, int64_t hi, double native, unsigned *fl)
{
	int64_t raw;

	if (rmd_field_raw_in(fs, lo, hi, native, &raw) == -ERANGE)
		*fl |= RMD_MOTOR_CLAMPED;
	return raw;
}

/* Request field `fld` of `spec` = `native` in the field's unit (field_raw()).  rt-safe. */
static void put(struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_field fld,
		double native, unsigned *fl)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, RMD_DIR_REQUEST, fld);
	int64_t lo, hi;

	if (!fs)
		return;
	rmd_field_range(fs, &lo, &hi);
	rmd_msg_set(msg, fld, field_raw(fs, lo, hi, native, fl));
}

/* Whether command `cmd` rides on the dialect's own set-ID identifier (V3 §4: 0x79 on 0x300). */
static inline bool on_set_id_can(const struct rmd_motor *m, uint8_t cmd)
{
	return cmd == 0x79 && rmd_dialect_set_id_can(m->d);
}

/* Resolve command `cmd`'s row and request fields a, b of the motor's table.  Non-rt. */
static void row_resolve(const struct rmd_motor *m, uint8_t cmd, enum rmd_field a, enum rmd_field b,
			struct rmd_motor_row *row)
{
	enum rmd_field flds[2] = { a, b };

	memset(row, 0, sizeof(*row));
	row->spec = rmd_motor_row(m, cmd);
	if (!row->spec || (row->spec->flags & RMD_CMD_NO_CMD_BYTE))
		return;
	for (unsigned k = 0; k < 2; k++) {
		struct rmd_motor_field *mf = &row->f[k];

		mf->fs = rmd_layout_field(row->spec, RMD_DIR_REQUEST, flds[k]);
		if (mf->fs)
			rmd_field_range(mf->fs, &mf->lo, &mf->hi);
	}
}

/* Request field mf (resolved, or absent) of data = native.  rt-safe. */
static inline __attribute__((always_inline)) void
row_field(const struct rmd_motor_field *mf, uint8_t *data, double native, unsigned *fl)
{
	if (mf->fs)
		rmd_field_write(mf->fs, data, field_raw(mf->fs, mf->lo, mf->hi, native, fl));
}

/*
 * The request of a resolved row with its fields set to a and b (as
 * rmd_encode() of a message holding only them writes it: reserved bytes
 * zero).  rt-safe.
 */
static inline __attribute__((always_inline)) int row_encode(const struct rmd_motor *m,
							    const struct rmd_motor_row *row,
							    double a, double b,
							    struct rmd_frame *out, unsigned *fl)
{
	memset(out, 0, sizeof(*out));
	out->can_id = RMD_CAN_REQ_BASE + m->id;
	out->len = RMD_FRAME_LEN;
	out->data[0] = row->spec->cmd;
	row_field(&row->f[0], out->data, a, fl);
	row_field(&row->f[1], out->data, b, fl);
	return 0;
}

/* Same fields at the same places with the same LSBs.  Non-rt. */
static bool layout_equal(const struct rmd_layout *a, const struct rmd_layout *b)
{
	if (a->n != b->n)
		return false;
	for (unsigned i = 0; i < a->n; i++)
		if (a->f[i].field != b->f[i].field || a->f[i].off != b->f[i].off ||
		    a->f[i].size != b->f[i].size || a->f[i].is_signed != b->f[i].is_signed ||
		    a->f[i].scale != b->f[i].scale)
			return false;
	return true;
}

/* fs's reading (struct rmd_field_rd), or zeros when fs is NULL.  Non-rt. */
static void rd_of(const struct rmd_field_spec *fs, struct rmd_field_rd *rd)
{
	memset(rd, 0, sizeof(*rd));
	if (fs)
		rmd_field_rd_init(fs, rd);
}

/* Resolve the status 2 reply of the motor's table (struct rmd_motor_status2).  Non-rt. */
static void status2_resolve(struct rmd_motor *m)
{
	const struct rmd_cmd_spec *st2 = rmd_cmd_find(m->d->table, 0x9C);
	struct rmd_motor_status2 *s = &m->st2;
	const struct rmd_layout *l;

	memset(s, 0, sizeof(*s));
	if (!st2)
		return;
	l = rmd_cmd_layout(st2, RMD_DIR_REPLY);
	for (unsigned c = 0; c < 256; c++) {
		const struct rmd_cmd_spec *spec = rmd_cmd_find(m->d->table, (uint8_t)c);

		if (spec && !(spec->flags & RMD_CMD_NO_CMD_BYTE) && !on_set_id_can(m, (uint8_t)c) &&
		    layout_equal(rmd_cmd_layout(spec, RMD_DIR_REPLY), l))
			s->cmds[c / 8] |= (uint8_t)(1u << (c % 8));
	}
	s->temp = rmd_layout_field(st2, RMD_DIR_REPLY, RMD_FLD_TEMP);
	s->current = rmd_layout_field(st2, RMD_DIR_REPLY, RMD_FLD_CURRENT);
	s->speed = rmd_layout_field(st2, RMD_DIR_REPLY, RMD_FLD_SPEED);
	s->angle = rmd_layout_field(st2, RMD_DIR_REPLY, RMD_FLD_ANGLE);
	s->encoder = rmd_layout_field(st2, RMD_DIR_REPLY, RMD_FLD_ENCODER);
	rd_of(s->temp, &s->temp_rd);
	rd_of(s->current, &s->current_rd);
	rd_of(s->speed, &s->speed_rd);
	rd_of(s->angle, &s->angle_rd);
	rd_of(s->encoder, &s->encoder_rd);
	/* a layout with other fields, or one field twice, takes the general way */
	if ((s->temp != NULL) + (s->current != NULL) + (s->speed != NULL) + (s->angle != NULL) +
		    (s->encoder != NULL) !=
	    l->n)
		memset(s->cmds, 0, sizeof(s->cmds));
}

/* rt-safe. */
int rmd_motor_init(struct rmd_motor *m, const struct rmd_config_motor *c)
{
	const struct rmd_dialect *d;

	memset(m, 0, sizeof(*m));
	if ((c->direction != 1 && c->direction != -1) || !(c->gear_ratio > 0.0) ||
	    !isfinite(c->gear_ratio) || c->id < 1 || c->id > RMD_MAX_MOTORS ||
	    !isfinite(c->zero_offset_rad))
		return -EINVAL;
	d = rmd_dialect(c->proto);
	if (!d)
		return -EINVAL;
	/*
	 * MIT is a mode of the firmware (rmd/dialect.h); `mit` names V3's.
	 * Firmware without it (V2, found by `protocol: auto`) gets a record
	 * that sends no MIT frame, which bring-up refuses as a mismatch.
	 */
	d = rmd_dialect_firmware(d);
	if (rmd_config_mit_mode(c)) {
		if (!rmd_mit_ranges_valid(&c->mit))
			return -EINVAL;
	} else if (!(c->torque_constant_nm_a > 0.0) || !isfinite(c->torque_constant_nm_a)) {
		return -EINVAL;
	}
	m->name = c->name;
	m->bus = (uint8_t)c->bus;
	m->id = c->id;
	m->proto = c->proto;
	m->d = d;
	m->mit_mode = rmd_config_mit_mode(c) && rmd_dialect_offers_mit(d);
	m->caps = d->caps;
	m->v2_have_ref = !(m->caps & RMD_DIALECT_ENCODER_UNWRAP); /* the others need none */
	m->table = d->table;
	m->mode = c->mode;
	m->dir = c->direction;
	m->gear_ratio = c->gear_ratio;
	m->native_per_output = c->units == RMD_UNITS_ROTOR ? c->gear_ratio : 1.0;
	m->zero_offset_rad = c->zero_offset_rad;
	m->kt_nm_a = c->torque_constant_nm_a > 0.0 ? c->torque_constant_nm_a : 0.0;
	m->limits = c->limits;
	m->mit = c->mit;
	m->damp_kd = RMD_MOTOR_DAMP_KD;
	m->reply_id = d->reply_base + (uint32_t)m->id;
	m->fine_pos = c->feedback.position == RMD_FEEDBACK_MULTI_TURN;
	m->pos_check = m->fine_pos || (m->caps & RMD_DIALECT_ENCODER_UNWRAP);
	row_resolve(m, 0xA1, RMD_FLD_CURRENT, RMD_FLD_COUNT, &m->torque_row);
	row_resolve(m, 0xA2, RMD_FLD_SPEED, RMD_FLD_COUNT, &m->speed_row);
	row_resolve(m, 0xA4, RMD_FLD_ANGLE, RMD_FLD_MAX_SPEED, &m->pos_row);
	status2_resolve(m);
	for (unsigned k = 0; k < 256; k++) {
		const struct rmd_cmd_spec *spec = rmd_motor_row(m, (uint8_t)k);

		if (spec && (spec->flags & RMD_CMD_ECHO))
			m->echo[k / 8] |= (uint8_t)(1u << (k % 8));
	}
	m->mt.saved = c->multi_turn_saved;
	m->mt.period_rad = rmd_multiturn_period_rad(c->gear_ratio);
	rmd_config_travel(c, &m->mt.lo_rad, &m->mt.hi_rad);
	m->mt.tol_rad = rmd_motor_pos_resolution_rad(m);
	if (rmd_motor_encode_cmd(m, 0x9C, &m->status2_req) < 0)
		m->status2_req.len = 0;
	/* the entry's scaling, decided where no firmware date can change it */
	if (m->mit_mode && !c->proto_auto && !rmd_dialect_mit_dated(d))
		return rmd_motor_set_mit(m, &c->mit);
	return 0;
}

/* rt-safe. */
int rmd_motor_set_mit(struct rmd_motor *m, const struct rmd_mit_ranges *r)
{
	struct rmd_mit_valid_ranges ok;

	if (!m->mit_mode)
		return -EINVAL;
	if (!r) {
		m->mit_scaled = false;
		return 0;
	}
	if (rmd_mit_ranges_validate(r, &ok) < 0)
		return -EINVAL;
	m->mit = *r;
	m->mit_ok = ok;
	m->mit_kp = m->mit_kd = NAN; /* no gains' codes yet (encode_mit()) */
	m->damp_kd = RMD_MOTOR_DAMP_KD;
	if (m->damp_kd > m->mit.kd_max)
		m->damp_kd = m->mit.kd_max;
	if (m->damp_kd < m->mit.kd_min)
		m->damp_kd = m->mit.kd_min;
	m->mit_scaled = true;
	m->mt.tol_rad = rmd_motor_pos_resolution_rad(m);
	return 0;
}

/* Non-rt. */
int rmd_motor_set_dialect(struct rmd_motor *m, const struct rmd_config_motor *c,
			  enum rmd_proto proto)
{
	struct rmd_config_motor as = *c;
	int r;

	as.proto = proto;
	r = rmd_motor_init(m, &as);
	m->name = c->name; /* the entry's, which outlives the motor; not the copy's */
	return r;
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
	if (m->mit_mode)
		modes |= RMD_MOTOR_MODE_BIT(RMD_MODE_MIT);
	return modes;
}

/* Non-rt. */
void rmd_motor_info(const struct rmd_motor *m, bool batched, struct rmd_motor_info *out)
{
	bool mit = m->mit_mode;

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
	out->pos_resolution_rad = rmd_motor_pos_resolution_rad(m);
	out->multi_turn_saved = m->mt.saved;
	out->travel_min_rad = m->mt.lo_rad;
	out->travel_max_rad = m->mt.hi_rad;
	out->turn_period_rad = m->mt.period_rad;
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

/*
 * rmd_motor_clamp() of sp as if in `mode`: inlined where the mode is known,
 * only that mode's fields are looked at.  rt-safe.
 */
static inline __attribute__((always_inline)) unsigned
clamp_mode(const struct rmd_config_limits *lim, unsigned mode, struct rmd_setpoint *sp,
	   struct rmd_motor_clamp_note *note)
{
	double vmax = lim->velocity_rad_s, tmax = lim->torque_nm;
	unsigned n = 0;

	if (rmd_mode_uses_pos(mode))
		sp->pos_rad = clamp_value(sp->pos_rad, lim->position_min_rad, lim->position_max_rad,
					  "position", &n, note);
	if (rmd_mode_uses_vel(mode))
		sp->vel_rad_s = clamp_value(sp->vel_rad_s, -vmax, vmax, "velocity", &n, note);
	if (rmd_mode_uses_torque(mode))
		sp->torque_nm = clamp_value(sp->torque_nm, -tmax, tmax, "torque", &n, note);
	/* 0 asks for the motor's limit; 0 stays when it has none (the firmware's own) */
	if (mode == RMD_MODE_POSITION && isfinite(vmax))
		sp->max_vel_rad_s = sp->max_vel_rad_s == 0 ? vmax :
							     clamp_value(sp->max_vel_rad_s, 0, vmax,
									 "max_velocity", &n, note);
	return n;
}

/* rt-safe. */
unsigned rmd_motor_clamp(const struct rmd_config_limits *lim, struct rmd_setpoint *sp,
			 struct rmd_motor_clamp_note *note)
{
	return clamp_mode(lim, sp->mode, sp, note);
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

/* rt-safe. */
void rmd_motor_shift_pos(struct rmd_motor *m, double shift_rad)
{
	m->zero_offset_rad -= m->dir * shift_rad;
}

/* Encode msg on 0x140 + ID with the motor's table.  rt-safe. */
static int encode_msg(const struct rmd_motor *m, const struct rmd_msg *msg, struct rmd_frame *out)
{
	return rmd_encode(m->proto, RMD_DIR_REQUEST, m->id, msg, out);
}

/* rt-safe. */
int rmd_motor_encode_cmd(const struct rmd_motor *m, uint8_t cmd, struct rmd_frame *out)
{
	const struct rmd_cmd_spec *spec = rmd_motor_row(m, cmd);
	struct rmd_msg msg;

	if (!spec)
		return -ENOENT;
	/* a row without fields on 0x140 + ID: the command byte and zeros */
	if (!(spec->flags & RMD_CMD_NO_CMD_BYTE) && !on_set_id_can(m, cmd)) {
		memset(out, 0, sizeof(*out));
		out->can_id = RMD_CAN_REQ_BASE + m->id;
		out->len = RMD_FRAME_LEN;
		out->data[0] = cmd;
		return 0;
	}
	memset(&msg, 0, sizeof(msg));
	msg.cmd = cmd;
	return encode_msg(m, &msg, out);
}

/* rt-safe. */
int rmd_motor_encode_comm_timeout(const struct rmd_motor *m, uint32_t ms, struct rmd_frame *out)
{
	struct rmd_msg msg;

	/* V3 §2.30; V2 has no comm-loss protection command. */
	if (!(m->caps & RMD_DIALECT_COMM_LOSS_B3))
		return -EOPNOTSUPP;
	rmd_arm_request(ms, &msg);
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
	if (!m->torque_row.spec)
		return -EOPNOTSUPP;
	if (!(m->kt_nm_a > 0.0))
		return -EOPNOTSUPP;
	return row_encode(m, &m->torque_row, torque_to_iq(m, torque_nm), 0, out, fl);
}

/* 0xA2 at vel_rad_s (reported frame, within the limit).  rt-safe. */
static int encode_speed(const struct rmd_motor *m, double vel_rad_s, struct rmd_frame *out,
			unsigned *fl)
{
	if (!m->speed_row.spec)
		return -EOPNOTSUPP;
	return row_encode(m, &m->speed_row, m->dir * vel_rad_s * DEG_PER_RAD * m->native_per_output,
			  0, out, fl);
}

/*
 * 0xA4 to pos_rad at up to mv_rad_s (both within the limits; maxSpeed 0
 * leaves the speed to the firmware's own limit).  rt-safe.
 */
static int encode_position(const struct rmd_motor *m, double pos_rad, double mv_rad_s,
			   struct rmd_frame *out, unsigned *fl)
{
	double native = rmd_motor_to_native_pos(m, pos_rad);

	if (!m->pos_row.spec)
		return -EOPNOTSUPP;
	return row_encode(m, &m->pos_row, native * DEG_PER_RAD * m->native_per_output,
			  mv_rad_s * DEG_PER_RAD * m->native_per_output, out, fl);
}

/*
 * MIT frame (V3 §5.2) from reported-frame values within the limits; the
 * MIT ranges clamp too (rmd_mit_encode_cmd()).  The gains' codes are
 * worked out again only when a gain changed (m->mit_kp, mit_kd).  rt-safe.
 */
static int encode_mit(struct rmd_motor *m, const struct rmd_setpoint *sp, struct rmd_frame *out,
		      unsigned *fl)
{
	const struct rmd_mit_ranges *r = &m->mit_ok.r;
	struct rmd_mit_cmd c;

	/* never a frame over ranges the motor's firmware may not scale by */
	if (!m->mit_scaled)
		return -EOPNOTSUPP;
	c.p_des_rad = clampf(rmd_motor_to_native_pos(m, sp->pos_rad), r->p_min, r->p_max, fl);
	c.v_des_rad_s = clampf(m->dir * sp->vel_rad_s, r->v_min, r->v_max, fl);
	c.t_ff_nm = clampf(m->dir * sp->torque_nm, r->t_min, r->t_max, fl);
	if (sp->kp != m->mit_kp || sp->kd != m->mit_kd) {
		m->mit_gains_fl = 0;
		rmd_mit_gain_codes(&m->mit_ok,
				   clampf(sp->kp, r->kp_min, r->kp_max, &m->mit_gains_fl),
				   clampf(sp->kd, r->kd_min, r->kd_max, &m->mit_gains_fl),
				   &m->mit_gains);
		m->mit_kp = sp->kp;
		m->mit_kd = sp->kd;
	}
	*fl |= m->mit_gains_fl;
	/* id 1..32 (rmd_motor_init()); every field finite: sp's are, the clamps keep them */
	rmd_mit_pack_gains(&m->mit_ok, m->id, &c, &m->mit_gains, out);
	return 0;
}

/* rt-safe. */
int rmd_motor_encode(struct rmd_motor *m, const struct rmd_setpoint *sp, struct rmd_frame *out,
		     unsigned *flags)
{
	struct rmd_setpoint c = *sp; /* clamped to the limits (rmd_motor_clamp()) */
	unsigned fl = 0;
	int r;

	switch ((enum rmd_mode)sp->mode) {
	case RMD_MODE_TORQUE:
		if (!isfinite(sp->torque_nm))
			return -EDOM;
		if (clamp_mode(&m->limits, RMD_MODE_TORQUE, &c, NULL))
			fl |= RMD_MOTOR_CLAMPED;
		r = encode_torque(m, c.torque_nm, out, &fl);
		break;
	case RMD_MODE_SPEED:
		if (!isfinite(sp->vel_rad_s))
			return -EDOM;
		if (clamp_mode(&m->limits, RMD_MODE_SPEED, &c, NULL))
			fl |= RMD_MOTOR_CLAMPED;
		r = encode_speed(m, c.vel_rad_s, out, &fl);
		break;
	case RMD_MODE_POSITION:
		if (!isfinite(sp->pos_rad) || !isfinite(sp->max_vel_rad_s))
			return -EDOM;
		if (__builtin_expect(m->mit_sent, 0) && !rmd_motor_runs(m, RMD_MODE_POSITION))
			return -EPERM;
		c.max_vel_rad_s = fabs(c.max_vel_rad_s);
		if (clamp_mode(&m->limits, RMD_MODE_POSITION, &c, NULL))
			fl |= RMD_MOTOR_CLAMPED;
		r = encode_position(m, c.pos_rad, c.max_vel_rad_s, out, &fl);
		break;
	case RMD_MODE_MIT:
		if (!isfinite(sp->pos_rad) || !isfinite(sp->vel_rad_s) ||
		    !isfinite(sp->torque_nm) || !isfinite(sp->kp) || !isfinite(sp->kd))
			return -EDOM;
		if (clamp_mode(&m->limits, RMD_MODE_MIT, &c, NULL))
			fl |= RMD_MOTOR_CLAMPED;
		r = encode_mit(m, &c, out, &fl);
		m->mit_sent = true;
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
		if (m->mit_scaled) {
			/* kp 0: no position target; kd > 0 resists motion; no torque. */
			struct rmd_mit_cmd c = { .kd = m->damp_kd };

			return rmd_mit_pack_cmd(&m->mit_ok, m->id, &c, &out[0]) < 0 ? -EINVAL : 1;
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
	const struct rmd_dialect *d = NULL;
	const struct rmd_cmd_spec *spec;
	struct rmd_msg msg;
	unsigned fl = 0, bad = 0;

	/* the frame is the dialect's of its motors (V2 §4.1), all of which must batch */
	for (unsigned k = 0; k < 4 && !d; k++)
		d = m[k] ? m[k]->d : NULL;
	if (!d || !rmd_dialect_has(d, RMD_DIALECT_BATCH_280))
		return -EINVAL;
	spec = rmd_cmd_find(d->proto, RMD_V2_CMD_MULTI_TORQUE);
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
		if (mk->d != d || mk->id != k + 1 || !(mk->kt_nm_a > 0.0))
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
	if (rmd_encode(d->proto, RMD_DIR_REQUEST, 0, &msg, out) < 0)
		return -EINVAL;
	if (flags)
		*flags = fl;
	if (nonfinite)
		*nonfinite = bad;
	return 0;
}

/* What take_position() did with a V2 reply's position (rmd_motor.v2_took). */
enum { V2_TOOK_NONE, V2_TOOK_REF, V2_TOOK_ANCHOR, V2_TOOK_STEP };

/* rt-safe. */
void rmd_motor_set_v2_reference(struct rmd_motor *m, double native_rad, int64_t t_ns)
{
	m->v2_have_ref = true;
	m->v2_ref_rad = native_rad;
	m->v2_ref_ns = t_ns;
	m->v2_anchored = false;
	m->v2_took = V2_TOOK_NONE;
}

/* rt-safe. */
void rmd_motor_forget_v2_reference(struct rmd_motor *m)
{
	if (!(m->caps & RMD_DIALECT_ENCODER_UNWRAP))
		return;
	m->v2_have_ref = false;
	m->v2_anchored = false;
	m->v2_took = V2_TOOK_NONE;
}

/* V2 §3.32: rotor single-turn encoder -> native multi-turn output angle.  rt-safe. */
static __attribute__((noinline)) double v2_unwrap(struct rmd_motor *m, uint16_t enc)
{
	if (!m->v2_anchored) {
		m->v2_anchored = true;
		m->v2_enc_counts = 0;
		m->v2_took = V2_TOOK_ANCHOR;
	} else {
		m->v2_enc_counts += (int16_t)(uint16_t)(enc - m->v2_enc_last);
		m->v2_took = V2_TOOK_STEP;
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

	if (!m->mit_scaled)
		return -EINVAL;
	ret = rmd_mit_unpack_reply(&m->mit_ok, f, &rep);
	if (ret < 0)
		return ret;
	r->pos_rad = rmd_motor_from_native_pos(m, rep.pos_rad);
	r->vel_rad_s = m->dir * rep.vel_rad_s;
	r->torque_nm = m->dir * rep.torque_nm;
	r->current_a = m->kt_nm_a > 0.0 ? r->torque_nm / m->kt_nm_a : NAN;
	r->have = RMD_MOTOR_HAVE_POS | RMD_MOTOR_HAVE_VEL | RMD_MOTOR_HAVE_TORQUE;
	return 0;
}

/* The native iq x (A) of a reply, in the reported frame.  rt-safe. */
static void take_current(const struct rmd_motor *m, double x, struct rmd_motor_reply *r)
{
	r->current_a = m->dir * x;
	r->torque_nm = m->kt_nm_a > 0.0 ? r->current_a * m->kt_nm_a : NAN;
	r->have |= RMD_MOTOR_HAVE_TORQUE;
}

/* The native speed x (dps) of a reply, in the reported frame.  rt-safe. */
static void take_speed(const struct rmd_motor *m, double x, struct rmd_motor_reply *r)
{
	r->vel_rad_s = m->dir * x / DEG_PER_RAD / m->native_per_output;
	r->have |= RMD_MOTOR_HAVE_VEL;
}

/*
 * The position of a reply: its angle (V3 status 2 in whole degrees, 0x92 in
 * 0.01 deg: the output angle), else a V2 encoder value unwrapped (not the
 * 0x60 raw read) from a reference; a V2 0x92 angle is the reference when
 * there is none.  rt-safe.
 */
static inline __attribute__((always_inline)) void
take_position(struct rmd_motor *m, bool have_angle, double angle_deg, bool have_enc, uint16_t enc,
	      uint8_t cmd, struct rmd_motor_reply *r)
{
	if (have_angle) {
		double native = angle_deg / DEG_PER_RAD / m->native_per_output;

		if (__builtin_expect(!m->v2_have_ref, 0) && cmd == RMD_MOTOR_CMD_FINE_POS) {
			rmd_motor_set_v2_reference(m, native, 0); /* its time: pos_check() */
			m->v2_took = V2_TOOK_REF;
		}
		r->pos_rad = rmd_motor_from_native_pos(m, native);
		r->have |= RMD_MOTOR_HAVE_POS;
	} else if ((m->caps & RMD_DIALECT_ENCODER_UNWRAP) && have_enc && cmd != 0x60 &&
		   m->v2_have_ref) {
		r->pos_rad = rmd_motor_from_native_pos(m, v2_unwrap(m, enc));
		r->have |= RMD_MOTOR_HAVE_POS;
	}
}

/* The field rd reads of data, in its native unit.  rt-safe. */
static inline double native_of(const struct rmd_field_rd *rd, const uint8_t *data)
{
	return (double)rmd_field_rd_raw(rd, data) * rd->scale;
}

/*
 * A reply with the status 2 layout (struct rmd_motor_status2), its fields
 * read in their known roles: what reply_fields() below gives for it.
 * rt-safe.
 */
static inline __attribute__((always_inline)) void
status2_read(struct rmd_motor *m, const struct rmd_frame *f, struct rmd_motor_reply *r)
{
	const struct rmd_motor_status2 *s = &m->st2;

	if (s->temp) {
		r->temp_c = native_of(&s->temp_rd, f->data);
		r->have |= RMD_MOTOR_HAVE_TEMP;
	}
	if (s->current)
		take_current(m, native_of(&s->current_rd, f->data), r);
	if (s->speed)
		take_speed(m, native_of(&s->speed_rd, f->data), r);
	take_position(m, s->angle, s->angle ? native_of(&s->angle_rd, f->data) : 0, s->encoder,
		      s->encoder ? (uint16_t)rmd_field_rd_raw(&s->encoder_rd, f->data) : 0,
		      f->data[0], r);
}

/*
 * The reply of a 0x140 + ID command row, decoded in one pass over the
 * row's reply layout into r (what rmd_decode() and a walk over its struct
 * rmd_msg gave, without the message zeroed and searched per frame).
 * Returns 0, or -ENOENT / -EINVAL as rmd_decode().  rt-safe.
 */
/*
 * What a reply field stored as it comes (reply_fields() below) says the
 * reply has; 0 for the fields taken in their own way (current, speed,
 * position) or not carried.
 */
static const unsigned field_have[256] = {
	[RMD_FLD_TEMP] = RMD_MOTOR_HAVE_TEMP,	    [RMD_FLD_VOLTAGE] = RMD_MOTOR_HAVE_VOLTAGE,
	[RMD_FLD_ERROR] = RMD_MOTOR_HAVE_ERROR,	    [RMD_FLD_BRAKE] = RMD_MOTOR_HAVE_BRAKE,
	[RMD_FLD_MODEL] = RMD_MOTOR_HAVE_MODEL,	    [RMD_FLD_VERSION] = RMD_MOTOR_HAVE_VERSION,
	[RMD_FLD_TIMEOUT] = RMD_MOTOR_HAVE_TIMEOUT, [RMD_FLD_RUNTIME] = RMD_MOTOR_HAVE_RUNTIME,
};

static __attribute__((noinline)) int reply_fields(struct rmd_motor *m, const struct rmd_frame *f,
						  struct rmd_motor_reply *r)
{
	const struct rmd_cmd_spec *spec = rmd_motor_row(m, f->data[0]);
	const struct rmd_layout *l;
	bool have_angle = false, have_enc = false;
	double angle = 0;
	uint16_t enc = 0;

	if (!spec || (spec->flags & RMD_CMD_NO_CMD_BYTE))
		return -ENOENT;
	/* V3 §4: 0x79 travels on 0x300 only, never on 0x240 + ID */
	if (on_set_id_can(m, spec->cmd))
		return -EINVAL;
	l = rmd_cmd_layout(spec, RMD_DIR_REPLY);
	for (unsigned i = 0; i < l->n; i++) {
		const struct rmd_field_spec *fs = &l->f[i];
		int64_t raw = rmd_field_read(fs, f->data);
		double x = (double)raw * (fs->scale > 0.0 ? fs->scale : 1.0); /* native unit */

		switch (fs->field) { /* uint8_t: the fields a state carries */
		case RMD_FLD_TEMP:
			r->temp_c = x;
			break;
		case RMD_FLD_CURRENT:
			take_current(m, x, r);
			break;
		case RMD_FLD_SPEED:
			take_speed(m, x, r);
			break;
		case RMD_FLD_ANGLE:
			have_angle = true;
			angle = x;
			break;
		case RMD_FLD_ENCODER:
			have_enc = true;
			enc = (uint16_t)raw;
			break;
		case RMD_FLD_VOLTAGE:
			r->voltage_v = x;
			break;
		case RMD_FLD_ERROR:
			r->error_code = (uint16_t)raw;
			break;
		case RMD_FLD_BRAKE:
			r->brake_released = raw != 0;
			break;
		case RMD_FLD_MODEL:
			rmd_model_string(raw, r->model);
			break;
		case RMD_FLD_VERSION:
			r->version_date = (uint32_t)raw;
			break;
		case RMD_FLD_TIMEOUT:
			r->comm_timeout_ms = (uint32_t)raw;
			break;
		case RMD_FLD_RUNTIME:
			r->runtime_ms = (uint32_t)raw;
			break;
		default: /* fields a motor's state does not carry */
			break;
		}
		r->have |= field_have[fs->field];
	}
	/* docs/protocol-v4.md "Firmware in the field": its DATA[3] says it runs, not its brake */
	if (m->quirks & RMD_QUIRK_9A_BYTE3_RUNNING)
		r->have &= ~(unsigned)RMD_MOTOR_HAVE_BRAKE;
	take_position(m, have_angle, angle, have_enc, enc, spec->cmd, r);
	return 0;
}

/*
 * rmd_motor_decode(), inlined into its two callers.  `zero`: r is zeroed
 * first, as rmd_motor_decode() promises; without it only r->have is, and
 * only the values it names are set (all rmd_motor_receive() reads).
 * rt-safe.
 */
static inline __attribute__((always_inline)) int
decode(struct rmd_motor *m, const struct rmd_frame *f, struct rmd_motor_reply *r, bool zero)
{
	if (zero)
		memset(r, 0, sizeof(*r));
	else
		r->have = 0;
	if (f->can_id == RMD_CAN_MIT_REPLY_BASE + m->id) {
		r->cmd = RMD_MOTOR_CMD_MIT;
		return decode_mit(m, f, r);
	}
	if (f->can_id != m->reply_id)
		return -EINVAL;
	if (f->len != RMD_FRAME_LEN)
		return -EBADMSG;
	r->cmd = f->data[0];
	if ((m->st2.cmds[f->data[0] / 8] >> (f->data[0] % 8)) & 1) {
		status2_read(m, f, r);
		return 0;
	}
	return reply_fields(m, f, r);
}

/* rt-safe. */
int rmd_motor_decode(struct rmd_motor *m, const struct rmd_frame *f, struct rmd_motor_reply *r)
{
	return decode(m, f, r, true);
}

/*
 * The values of r that `have` names into st; with `stamp`, the receive
 * times of those that have one (t_ns).  rt-safe.
 */
static inline __attribute__((always_inline)) void apply_have(const struct rmd_motor_reply *r,
							     unsigned have, bool stamp,
							     int64_t t_ns,
							     struct rmd_motor_state *st)
{
	if (have & RMD_MOTOR_HAVE_POS) {
		st->pos_rad = r->pos_rad;
		if (stamp)
			st->pos_rx_ns = t_ns;
	}
	if (have & RMD_MOTOR_HAVE_VEL) {
		st->vel_rad_s = r->vel_rad_s;
		if (stamp)
			st->rx_ns = t_ns;
	}
	if (have & RMD_MOTOR_HAVE_TORQUE) {
		st->torque_nm = r->torque_nm;
		st->current_a = r->current_a;
		if (stamp)
			st->rx_ns = t_ns;
	}
	if (have & RMD_MOTOR_HAVE_TEMP)
		st->temp_c = r->temp_c;
	if (have & RMD_MOTOR_HAVE_VOLTAGE) {
		st->voltage_v = r->voltage_v;
		if (stamp)
			st->status_rx_ns = t_ns;
	}
	if (have & RMD_MOTOR_HAVE_ERROR) {
		st->error_code = r->error_code;
		/* V3 §2.12: the brake rides in the status answer beside the flags (not V2's) */
		if (have & RMD_MOTOR_HAVE_BRAKE)
			st->brake_released = r->brake_released;
		if (stamp)
			st->status_rx_ns = t_ns;
	}
}

/* rt-safe. */
void rmd_motor_apply(const struct rmd_motor_reply *r, struct rmd_motor_state *st)
{
	apply_have(r, r->have, false, 0, st);
}

/*
 * Whether the V2 position v2_unwrap() just gave reply r (received at t_ns)
 * can be trusted (RMD_MOTOR_V2_STEP_TURNS, RMD_MOTOR_V2_ANCHOR_RAD): the
 * rotor speeds of the replies bound how far it turned between them.
 * A reply without a speed cannot tell.  rt-safe.
 */
static bool v2_count_trusted(struct rmd_motor *m, const struct rmd_motor_reply *r, uint8_t took,
			     int64_t t_ns)
{
	double speed = fabs(r->vel_rad_s) * m->gear_ratio, before = m->v2_rotor_speed;
	double dt = (double)(t_ns - (took == V2_TOOK_ANCHOR ? m->v2_ref_ns : m->v2_enc_ns)) * 1e-9;
	bool known = (r->have & RMD_MOTOR_HAVE_VEL) && isfinite(speed) && dt >= 0.0;

	m->v2_enc_ns = t_ns;
	m->v2_rotor_speed = known ? speed : INFINITY;
	if (!known)
		return false;
	if (took == V2_TOOK_ANCHOR)
		return speed / m->gear_ratio * dt <= RMD_MOTOR_V2_ANCHOR_RAD;
	return (speed > before ? speed : before) * dt <= RMD_MOTOR_V2_STEP_TURNS * 2.0 * M_PI;
}

/*
 * V2: the 0x92 angle of reply r (received at t_ns) against the count's
 * last position: the motor's own multi-turn angle and rmdd's count of its
 * encoder part by whole rotor turns when the motor lost its count
 * (rmd/reboot.h).  RMD_MOTOR_HAVE_COUNT_SAME or RMD_MOTOR_HAVE_COUNT_LOST;
 * RMD_MOTOR_HAVE_COUNT_ASTRAY when they part by what no boot explains:
 * the count is dropped (the next 0x92 angle is its reference).  0 when
 * there is no count to hold it against (none yet, or this angle is the
 * count's new reference).  rt-safe.
 */
static unsigned v2_count_check(struct rmd_motor *m, const struct rmd_motor_reply *r, uint8_t took,
			       int64_t t_ns)
{
	struct rmd_reboot_reading count, angle = { r->pos_rad, t_ns, 0.0, 0.0 };
	double native;

	if (took != V2_TOOK_NONE || !m->v2_have_ref || !m->v2_anchored || !m->v2_enc_ns)
		return 0;
	native = m->v2_ref_rad + (double)m->v2_enc_counts / RMD_MOTOR_V2_ENCODER_COUNTS *
					 (2.0 * M_PI) / m->gear_ratio;
	count.pos_rad = rmd_motor_from_native_pos(m, native);
	count.t_ns = m->v2_enc_ns;
	count.vel_rad_s = m->v2_rotor_speed / m->gear_ratio;
	count.err_rad = RMD_MOTOR_V2_ANCHOR_RAD; /* the motion its anchor allows */
	angle.vel_rad_s = (r->have & RMD_MOTOR_HAVE_VEL) ? r->vel_rad_s : count.vel_rad_s;
	m->v2_checked_rad = count.pos_rad;
	switch (rmd_reboot_turns_says(&m->mt, &count, &angle)) {
	case RMD_REBOOT_SAYS_BOOTED:
		return RMD_MOTOR_HAVE_COUNT_LOST;
	case RMD_REBOOT_SAYS_RUNNING:
		return RMD_MOTOR_HAVE_COUNT_SAME;
	case RMD_REBOOT_SAYS_COUNT_ASTRAY:
		rmd_motor_forget_v2_reference(m);
		return RMD_MOTOR_HAVE_COUNT_ASTRAY;
	case RMD_REBOOT_SAYS_NOTHING:
		break;
	}
	return 0;
}

/*
 * The position checks of a fine_pos or V2 motor, on the RMD_MOTOR_HAVE_*
 * of reply r: what take() applies.  Out of line: most motors need none.
 * rt-safe.
 */
static __attribute__((noinline)) unsigned
pos_check(struct rmd_motor *m, const struct rmd_motor_reply *r, unsigned have, int64_t t_ns)
{
	uint8_t took = m->v2_took;

	/* V3 §2.11: 0x92 is the one reply with the 0.01 deg multi-turn angle */
	if (m->fine_pos && r->cmd != RMD_MOTOR_CMD_FINE_POS)
		have &= ~(unsigned)RMD_MOTOR_HAVE_POS;
	m->v2_took = V2_TOOK_NONE;
	if ((m->caps & RMD_DIALECT_ENCODER_UNWRAP) && r->cmd == RMD_MOTOR_CMD_FINE_POS &&
	    (have & RMD_MOTOR_HAVE_POS))
		have |= RMD_MOTOR_HAVE_COUNT_CHECK | v2_count_check(m, r, took, t_ns);
	if (took == V2_TOOK_REF) {
		m->v2_ref_ns = t_ns;
	} else if (took != V2_TOOK_NONE && !v2_count_trusted(m, r, took, t_ns)) {
		/* ambiguous: no position until the next 0x92 angle anchors the count */
		rmd_motor_forget_v2_reference(m);
		have &= ~(unsigned)RMD_MOTOR_HAVE_POS;
	}
	return have;
}

/*
 * rmd_motor_take(), inlined into its two callers: what r carried into st;
 * returns the RMD_MOTOR_HAVE_* taken.  rt-safe.
 */
static inline __attribute__((always_inline)) unsigned
take(struct rmd_motor *m, const struct rmd_motor_reply *r, int64_t t_ns, struct rmd_motor_state *st)
{
	unsigned have = r->have;

	if (__builtin_expect(m->pos_check, 0))
		have = pos_check(m, r, have, t_ns);
	apply_have(r, have, true, t_ns, st);
	return have;
}

/* rt-safe. */
void rmd_motor_take(struct rmd_motor *m, const struct rmd_motor_reply *r, int64_t t_ns,
		    struct rmd_motor_state *st)
{
	take(m, r, t_ns, st);
}

/* rt-safe. */
int rmd_motor_receive(struct rmd_motor *m, const struct rmd_frame *f, int64_t t_ns,
		      struct rmd_motor_state *st, unsigned *have)
{
	struct rmd_motor_reply r;
	int ret = decode(m, f, &r, false);

	if (ret < 0)
		return ret;
	*have = take(m, &r, t_ns, st);
	return 0;
}

/* rt-safe. */
double rmd_motor_pos_resolution_rad(const struct rmd_motor *m)
{
	const struct rmd_cmd_spec *spec;
	const struct rmd_field_spec *fs = NULL;

	if (m->fine_pos) {
		spec = rmd_motor_row(m, RMD_MOTOR_CMD_FINE_POS);
		fs = spec ? rmd_layout_field(spec, RMD_DIR_REPLY, RMD_FLD_ANGLE) : NULL;
	} else if (m->mit_mode) {
		return (m->mit.p_max - m->mit.p_min) / (double)((1u << RMD_MIT_POS_BITS) - 1);
	} else if (m->st2.angle) {
		fs = m->st2.angle;
	} else if (m->st2.encoder) {
		/* V2 §3.32: one count of the rotor encoder, unwrapped by v2_unwrap() */
		return 2.0 * M_PI / RMD_MOTOR_V2_ENCODER_COUNTS / m->gear_ratio;
	}
	if (!fs || !(fs->scale > 0.0))
		return NAN;
	return fs->scale / DEG_PER_RAD / m->native_per_output;
}
