// SPDX-License-Identifier: MIT
/*
 * The codec's interpreter: one encoder and one decoder for every row of
 * every dialect's command table (src/proto/codec_*.c), with the dialect's
 * identifiers from its record (src/proto/dialect.c).
 * Everything here is pure and rt-safe.
 */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "codec_tables.h"

static const char *const field_keys[RMD_FLD_COUNT] = {
	[RMD_FLD_TEMP] = "temperature_c",
	[RMD_FLD_CURRENT] = "current_a",
	[RMD_FLD_SPEED] = "speed_dps",
	[RMD_FLD_ANGLE] = "angle_deg",
	[RMD_FLD_MAX_SPEED] = "max_speed_dps",
	[RMD_FLD_SPIN_DIR] = "spin_direction",
	[RMD_FLD_ENCODER] = "encoder",
	[RMD_FLD_ENCODER_RAW] = "encoder_raw",
	[RMD_FLD_ENCODER_OFF] = "encoder_offset",
	[RMD_FLD_VOLTAGE] = "voltage_v",
	[RMD_FLD_ERROR] = "error_code",
	[RMD_FLD_BRAKE] = "brake_released",
	[RMD_FLD_PHASE_A] = "phase_a_a",
	[RMD_FLD_PHASE_B] = "phase_b_a",
	[RMD_FLD_PHASE_C] = "phase_c_a",
	[RMD_FLD_CURR_KP] = "current_kp",
	[RMD_FLD_CURR_KI] = "current_ki",
	[RMD_FLD_SPD_KP] = "speed_kp",
	[RMD_FLD_SPD_KI] = "speed_ki",
	[RMD_FLD_POS_KP] = "position_kp",
	[RMD_FLD_POS_KI] = "position_ki",
	[RMD_FLD_ACCEL] = "accel_dps2",
	[RMD_FLD_INDEX] = "index",
	[RMD_FLD_VALUE] = "value",
	[RMD_FLD_MODE] = "mode",
	[RMD_FLD_POWER] = "power_w",
	[RMD_FLD_RUNTIME] = "runtime_ms",
	[RMD_FLD_VERSION] = "version_date",
	[RMD_FLD_TIMEOUT] = "timeout_ms",
	[RMD_FLD_BAUD] = "baud_code",
	[RMD_FLD_MODEL] = "model",
	[RMD_FLD_READ_FLAG] = "read_flag",
	[RMD_FLD_CAN_ID] = "can_id_value",
	[RMD_FLD_CURRENT_1] = "current_1_a",
	[RMD_FLD_CURRENT_2] = "current_2_a",
	[RMD_FLD_CURRENT_3] = "current_3_a",
	[RMD_FLD_CURRENT_4] = "current_4_a",
	[RMD_FLD_BATTERY] = "battery_v",
	[RMD_FLD_GAIN] = "gain",
	[RMD_FLD_POS_KD] = "position_kd",
	[RMD_FLD_PARAM] = "param_value",
	[RMD_FLD_MOS_TEMP] = "mos_temperature_c",
	[RMD_FLD_MAX_TORQUE] = "max_torque_pct",
	[RMD_FLD_REPORT_CMD] = "report_command",
	[RMD_FLD_REPORT_ON] = "report_enable",
	[RMD_FLD_REPORT_MS] = "report_interval_ms",
};

const char *rmd_field_key(enum rmd_field fld)
{
	if ((unsigned)fld >= RMD_FLD_COUNT || !field_keys[fld])
		return "unknown";
	return field_keys[fld];
}

enum rmd_proto rmd_proto_table(enum rmd_proto proto)
{
	const struct rmd_dialect *d = rmd_dialect(proto);

	return d ? d->table : proto;
}

size_t rmd_cmd_table(enum rmd_proto proto, const struct rmd_cmd_spec **rows)
{
	const struct rmd_dialect *d = rmd_dialect(rmd_proto_table(proto));

	if (!d) {
		*rows = NULL;
		return 0;
	}
	*rows = d->rows;
	return *d->n_rows;
}

static bool id_in(uint32_t can_id, uint32_t base, uint8_t *motor_id)
{
	if (can_id <= base || can_id > base + RMD_MAX_MOTORS)
		return false;
	*motor_id = (uint8_t)(can_id - base);
	return true;
}

int rmd_addr_from_id(enum rmd_proto proto, uint32_t can_id, struct rmd_addr *addr)
{
	const struct rmd_dialect *d = rmd_dialect(proto);

	memset(addr, 0, sizeof(*addr));
	if (!d)
		return -EINVAL;
	/* MIT frames (V3 §5): the dialect's own control identifiers, nothing else */
	if (rmd_dialect_has(d, RMD_DIALECT_MIT)) {
		if (id_in(can_id, d->ctl_req_base, &addr->motor_id)) {
			addr->dir = RMD_DIR_REQUEST;
			return 0;
		}
		if (id_in(can_id, d->ctl_reply_base, &addr->motor_id)) {
			addr->dir = RMD_DIR_REPLY;
			return 0;
		}
		return -EINVAL;
	}
	if (id_in(can_id, d->req_base, &addr->motor_id)) {
		/* V2 §1: requests and replies share 0x140 + ID. */
		addr->dir = rmd_dialect_shared_ids(d) ? RMD_DIR_UNKNOWN : RMD_DIR_REQUEST;
		return 0;
	}
	if (id_in(can_id, d->reply_base, &addr->motor_id)) {
		addr->dir = RMD_DIR_REPLY;
		return 0;
	}
	/* V3 §4: the 0x79 request and its reply both use 0x300. */
	if (can_id && can_id == rmd_dialect_set_id_can(d)) {
		addr->dir = RMD_DIR_UNKNOWN;
		addr->broadcast = true;
		return 0;
	}
	if (can_id == RMD_CAN_MULTI) {
		addr->dir = RMD_DIR_REQUEST;
		addr->broadcast = true;
		return 0;
	}
	return -EINVAL;
}

bool rmd_cmd_spelled(const struct rmd_cmd_spec *spec, const char *word)
{
	size_t n = strlen(word);

	for (const char *w = spec->spell.words; n && w && *w;) {
		size_t len = strcspn(w, " ");

		if (len == n && !strncmp(w, word, n))
			return true;
		w += len + (w[len] == ' ');
	}
	return false;
}

const struct rmd_field_range *rmd_cmd_range(const struct rmd_cmd_spec *spec, enum rmd_field fld)
{
	for (unsigned i = 0; i < spec->n_ranges; i++)
		if (spec->ranges[i].field == fld)
			return &spec->ranges[i];
	return NULL;
}

const struct rmd_layout *rmd_cmd_layout(const struct rmd_cmd_spec *spec, enum rmd_dir dir)
{
	if (dir == RMD_DIR_REPLY && !(spec->flags & RMD_CMD_ECHO))
		return &spec->rep;
	return &spec->req;
}

const struct rmd_field_spec *rmd_layout_field(const struct rmd_cmd_spec *spec, enum rmd_dir dir,
					      enum rmd_field fld)
{
	const struct rmd_layout *l = rmd_cmd_layout(spec, dir);

	for (unsigned i = 0; i < l->n; i++)
		if (l->f[i].field == fld)
			return &l->f[i];
	return NULL;
}

void rmd_msg_set(struct rmd_msg *msg, enum rmd_field fld, int64_t raw)
{
	msg->v[fld] = raw;
	msg->present |= UINT64_C(1) << fld;
}

bool rmd_msg_has(const struct rmd_msg *msg, enum rmd_field fld)
{
	return (unsigned)fld < RMD_FLD_COUNT && (msg->present >> fld) & 1;
}

void rmd_field_range(const struct rmd_field_spec *fs, int64_t *lo, int64_t *hi)
{
	unsigned bits = 8u * fs->size; /* 8..56 */

	if (fs->is_signed) {
		*lo = -(INT64_C(1) << (bits - 1));
		*hi = (INT64_C(1) << (bits - 1)) - 1;
	} else {
		*lo = 0;
		*hi = (INT64_C(1) << bits) - 1;
	}
}

static bool fits(const struct rmd_field_spec *fs, int64_t raw)
{
	int64_t lo, hi;

	rmd_field_range(fs, &lo, &hi);
	return raw >= lo && raw <= hi;
}

static double lsb(const struct rmd_field_spec *fs)
{
	return fs->scale > 0.0 ? fs->scale : 1.0;
}

/* V4.2 §2.1: a float field's 32 bits, little-endian on the wire, as a float. */
static float float_of(int64_t raw)
{
	uint32_t u = (uint32_t)raw;
	float x;

	memcpy(&x, &u, sizeof(x));
	return x;
}

static int64_t float_bits(float x)
{
	uint32_t u;

	memcpy(&u, &x, sizeof(u));
	return (int64_t)u;
}

double rmd_field_to_native(const struct rmd_field_spec *fs, int64_t raw)
{
	if (fs->is_float)
		return (double)float_of(raw);
	return (double)raw * lsb(fs);
}

int rmd_field_from_native(const struct rmd_field_spec *fs, double native, int64_t *raw)
{
	int64_t lo, hi;

	if (fs->is_float) {
		if (isnan(native)) {
			*raw = 0;
			return -ERANGE;
		}
		if (fabs(native) > FLT_MAX) {
			*raw = float_bits(native < 0 ? -FLT_MAX : FLT_MAX);
			return -ERANGE;
		}
		*raw = float_bits((float)native);
		return 0;
	}
	rmd_field_range(fs, &lo, &hi);
	return rmd_field_raw_in(fs, lo, hi, native, raw);
}

int rmd_msg_set_native(struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_dir dir,
		       enum rmd_field fld, double native)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, dir, fld);
	int64_t raw;
	int r;

	if (!fs)
		return -ENOENT;
	r = rmd_field_from_native(fs, native, &raw);
	rmd_msg_set(msg, fld, raw);
	return r;
}

double rmd_msg_get_native(const struct rmd_msg *msg, const struct rmd_cmd_spec *spec,
			  enum rmd_dir dir, enum rmd_field fld, double def)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, dir, fld);

	if (!fs || !rmd_msg_has(msg, fld))
		return def;
	return rmd_field_to_native(fs, msg->v[fld]);
}

/* Whether `spec` rides on the dialect's own set-ID identifier (V3 §4: 0x79 on 0x300). */
static bool on_set_id_can(const struct rmd_dialect *d, const struct rmd_cmd_spec *spec)
{
	return rmd_dialect_set_id_can(d) && spec->cmd == 0x79;
}

static uint32_t frame_id(const struct rmd_dialect *d, enum rmd_dir dir, uint8_t motor_id,
			 const struct rmd_cmd_spec *spec)
{
	/* V3 §4: 0x79 is addressed to every motor on 0x300, both ways. */
	if (on_set_id_can(d, spec))
		return rmd_dialect_set_id_can(d);
	if (dir == RMD_DIR_REQUEST)
		return motor_id ? d->req_base + motor_id : RMD_CAN_MULTI;
	return d->reply_base + (uint32_t)motor_id;
}

/*
 * The layout of a frame of spec in direction dir: its own, but V3 §4.3,
 * V4.2 §4.3: the reply to a 0x79 write (read flag 0) is the write itself,
 * the ID at data[7]; only a read's reply carries the reply identifier.
 * The read flag: frame f's (decoding) or msg's (encoding).
 */
static const struct rmd_layout *layout_for(const struct rmd_cmd_spec *spec, enum rmd_dir dir,
					   const struct rmd_frame *f, const struct rmd_msg *msg)
{
	const struct rmd_layout *l = rmd_cmd_layout(spec, dir);

	for (unsigned i = 0; dir == RMD_DIR_REPLY && i < l->n; i++)
		if (l->f[i].field == RMD_FLD_READ_FLAG &&
		    (f ? rmd_field_read(&l->f[i], f->data) : msg->v[RMD_FLD_READ_FLAG]) == 0)
			return rmd_cmd_layout(spec, RMD_DIR_REQUEST);
	return l;
}

int rmd_encode(enum rmd_proto proto, enum rmd_dir dir, uint8_t motor_id, const struct rmd_msg *msg,
	       struct rmd_frame *out)
{
	const struct rmd_dialect *d = rmd_dialect(rmd_proto_table(proto));
	const struct rmd_cmd_spec *spec;
	const struct rmd_layout *l;

	if (!d || motor_id > RMD_MAX_MOTORS || (dir != RMD_DIR_REQUEST && dir != RMD_DIR_REPLY))
		return -EINVAL;
	spec = rmd_cmd_find(d->proto, msg->cmd);
	if (!spec)
		return -ENOENT;
	/* A reply always comes from one motor; V2's 0x280 carries only torques. */
	if (motor_id == 0 && dir == RMD_DIR_REPLY && !on_set_id_can(d, spec))
		return -EINVAL;
	if (rmd_dialect_has(d, RMD_DIALECT_BATCH_280) &&
	    (motor_id == 0) != (spec->cmd == RMD_V2_CMD_MULTI_TORQUE))
		return -EINVAL;

	l = layout_for(spec, dir, NULL, msg);
	memset(out, 0, sizeof(*out));
	out->can_id = frame_id(d, dir, motor_id, spec);
	out->len = RMD_FRAME_LEN;
	if (!(spec->flags & RMD_CMD_NO_CMD_BYTE))
		out->data[0] = spec->cmd;
	for (unsigned i = 0; i < l->n; i++) {
		const struct rmd_field_spec *fs = &l->f[i];

		if (!fits(fs, msg->v[fs->field]))
			return -ERANGE;
		rmd_field_write(fs, out->data, msg->v[fs->field]);
	}
	return 0;
}

/* True when every byte that no field of `l` covers (the command byte aside) is zero. */
static bool reserved_bytes_zero(const struct rmd_cmd_spec *spec, const struct rmd_layout *l,
				const uint8_t *data)
{
	bool used[RMD_FRAME_LEN] = { false };

	if (!(spec->flags & RMD_CMD_NO_CMD_BYTE))
		used[0] = true;
	for (unsigned i = 0; i < l->n; i++)
		for (unsigned b = 0; b < l->f[i].size + (l->f[i].sign_byte ? 1u : 0u); b++)
			used[l->f[i].off + b] = true;
	for (unsigned b = 0; b < RMD_FRAME_LEN; b++)
		if (!used[b] && data[b])
			return false;
	return true;
}

static void decode_fields(const struct rmd_cmd_spec *spec, enum rmd_dir dir,
			  const struct rmd_frame *f, struct rmd_msg *msg)
{
	const struct rmd_layout *l = layout_for(spec, dir, f, NULL);

	msg->cmd = spec->cmd;
	for (unsigned i = 0; i < l->n; i++) {
		const struct rmd_field_spec *fs = &l->f[i];

		rmd_msg_set(msg, fs->field, rmd_field_read(fs, f->data));
	}
}

/*
 * What rmd_decode() and rmd_decode_as() start with: msg cleared, an 8-byte
 * frame, the dialect's table, the identifier's address, and a direction
 * asked (not RMD_DIR_UNKNOWN) that is the identifier's.  0 or -errno.
 */
static int decode_begin(enum rmd_proto *proto, enum rmd_dir dir, const struct rmd_frame *f,
			struct rmd_msg *msg, struct rmd_addr *addr)
{
	int r;

	memset(msg, 0, sizeof(*msg));
	if (f->len != RMD_FRAME_LEN)
		return -EBADMSG;
	*proto = rmd_proto_table(*proto);
	r = rmd_addr_from_id(*proto, f->can_id, addr);
	if (r < 0)
		return r;
	if (dir != RMD_DIR_UNKNOWN && addr->dir != RMD_DIR_UNKNOWN && addr->dir != dir)
		return -EINVAL;
	return 0;
}

int rmd_decode(enum rmd_proto proto, enum rmd_dir dir, const struct rmd_frame *f,
	       struct rmd_msg *msg, enum rmd_dir *dir_out)
{
	const struct rmd_dialect *d;
	const struct rmd_cmd_spec *spec;
	struct rmd_addr addr;
	int r = decode_begin(&proto, dir, f, msg, &addr);

	if (r < 0)
		return r;
	d = rmd_dialect(proto);
	if (dir == RMD_DIR_UNKNOWN)
		dir = addr.dir;

	if (rmd_dialect_has(d, RMD_DIALECT_BATCH_280) && f->can_id == RMD_CAN_MULTI)
		spec = rmd_cmd_find(proto, RMD_V2_CMD_MULTI_TORQUE);
	else
		spec = rmd_cmd_find(proto, f->data[0]);
	if (!spec || (spec->flags & RMD_CMD_NO_CMD_BYTE && f->can_id != RMD_CAN_MULTI)) {
		msg->cmd = f->data[0];
		return -ENOENT;
	}
	/* V3 §4: 0x300 carries 0x79 and nothing else, and 0x79 travels only there. */
	if (rmd_dialect_set_id_can(d) &&
	    (f->can_id == rmd_dialect_set_id_can(d)) != (spec->cmd == 0x79)) {
		msg->cmd = spec->cmd;
		return -EINVAL;
	}
	if (dir == RMD_DIR_UNKNOWN)
		dir = reserved_bytes_zero(spec, &spec->req, f->data) ? RMD_DIR_REQUEST :
								       RMD_DIR_REPLY;
	if (dir_out)
		*dir_out = dir;

	decode_fields(spec, dir, f, msg);
	return 0;
}

int rmd_decode_as(enum rmd_proto proto, enum rmd_dir dir, uint8_t cmd, const struct rmd_frame *f,
		  struct rmd_msg *msg)
{
	const struct rmd_cmd_spec *spec;
	struct rmd_addr addr;
	int r = decode_begin(&proto, dir, f, msg, &addr);

	if (r < 0)
		return r;
	if (dir != RMD_DIR_REQUEST && dir != RMD_DIR_REPLY)
		return -EINVAL;
	spec = rmd_cmd_find(proto, cmd);
	if (!spec) {
		msg->cmd = cmd;
		return -ENOENT;
	}
	decode_fields(spec, dir, f, msg);
	return 0;
}
