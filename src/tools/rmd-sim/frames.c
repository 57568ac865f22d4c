// SPDX-License-Identifier: MIT
/*
 * rmd-sim: one frame as a line of text for -v, with the codec's names:
 * "read_status_1 temperature_c=25 brake_released=0 voltage_v=48 error_code=0x0000".
 * Values are in the protocol's native units (each table row's LSB).
 * Non-rt.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/mit.h"
#include "rmd/sim.h"
#include "rmd-sim.h"

struct out {
	char *buf;
	size_t size, n;
};

static void put(struct out *o, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void put(struct out *o, const char *fmt, ...)
{
	va_list ap;
	int m;

	if (o->n >= o->size)
		return;
	va_start(ap, fmt);
	m = vsnprintf(o->buf + o->n, o->size - o->n, fmt, ap);
	va_end(ap);
	if (m > 0)
		o->n = o->n + (size_t)m < o->size ? o->n + (size_t)m : o->size;
}

static void put_fields(struct out *o, enum rmd_proto proto, enum rmd_dir dir,
		       const struct rmd_msg *msg)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(proto, msg->cmd);

	for (int i = 0; i < RMD_FLD_COUNT; i++) {
		enum rmd_field fld = (enum rmd_field)i;
		const struct rmd_field_spec *fs;
		int64_t raw = msg->v[fld];

		if (!rmd_msg_has(msg, fld))
			continue;
		if (fld == RMD_FLD_MODEL) {
			char model[8];

			rmd_model_string(raw, model);
			put(o, " %s=\"%s\"", rmd_field_key(fld), model);
			continue;
		}
		if (fld == RMD_FLD_ERROR) {
			const char *names[16];
			size_t n = rmd_error_names(proto, (uint16_t)raw, names, 16);

			put(o, " %s=0x%04x", rmd_field_key(fld), (unsigned)(raw & 0xFFFF));
			for (size_t k = 0; k < n && k < 16; k++)
				put(o, "%s%s", k ? "+" : " (", names[k]);
			if (n)
				put(o, ")");
			continue;
		}
		fs = spec ? rmd_layout_field(spec, dir, fld) : NULL;
		if (fs && fs->scale != 1.0)
			put(o, " %s=%.10g", rmd_field_key(fld), (double)raw * fs->scale);
		else
			put(o, " %s=%lld", rmd_field_key(fld), (long long)raw);
	}
}

void sim_describe(char *buf, size_t size, enum rmd_proto proto, enum rmd_dir dir,
		  const struct rmd_mit_ranges *mit, const struct rmd_frame *f)
{
	struct out o = { buf, size, 0 };
	struct rmd_msg msg;
	int r;

	buf[0] = '\0';
	if (proto == RMD_PROTO_MIT && mit) {
		if (dir == RMD_DIR_REQUEST) {
			struct rmd_mit_cmd cmd;
			uint8_t id;

			if (rmd_mit_decode_cmd(mit, f, &id, &cmd) == 0) {
				put(&o,
				    "mit_command p_des_rad=%.4f v_des_rad_s=%.3f kp=%.3f kd=%.4f "
				    "t_ff_nm=%.3f",
				    cmd.p_des_rad, cmd.v_des_rad_s, cmd.kp, cmd.kd, cmd.t_ff_nm);
				return;
			}
		} else {
			struct rmd_mit_reply rep;

			if (rmd_mit_decode_reply(mit, f, &rep) == 0) {
				put(&o, "mit_reply pos_rad=%.4f vel_rad_s=%.3f torque_nm=%.3f",
				    rep.pos_rad, rep.vel_rad_s, rep.torque_nm);
				return;
			}
		}
		proto = rmd_proto_table(proto); /* MIT motors also speak V3 */
	}
	r = rmd_decode(proto, dir, f, &msg, NULL);
	if (r == 0) {
		const struct rmd_cmd_spec *spec = rmd_cmd_find(proto, msg.cmd);

		put(&o, "%s", spec ? spec->name : "?");
		put_fields(&o, proto, dir, &msg);
		return;
	}
	if (dir == RMD_DIR_REPLY && f->len >= 1 && f->data[0] == RMD_SIM_CMD_COMM_LOST) {
		put(&o, "comm_lost (0xF1, unsolicited)");
		return;
	}
	if (r == -EBADMSG)
		put(&o, "(DLC %u: not a protocol frame)", f->len);
	else if (f->len >= 1)
		put(&o, "(command 0x%02X: not decoded)", f->data[0]);
	else
		put(&o, "(empty)");
}
