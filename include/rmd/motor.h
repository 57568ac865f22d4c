/* SPDX-License-Identifier: MIT */
/*
 * One motor's units, in one place (docs/design.md "Units"): SI at the output
 * shaft, as LCM and the configuration speak them, <-> the protocol's
 * native units on the wire (0.01 A, 0.01 dps, 0.01 deg, MIT codes), with
 * the motor's direction, zero offset, torque constant and gear ratio.
 *
 * Frames of reference.  "Native" is what the motor measures at its output
 * shaft (its rotor, divided by gear_ratio, when the config says units:
 * rotor).  rmdd reports
 *
 *   pos_rad    = direction * (native_rad - zero_offset_rad)
 *   vel_rad_s  = direction * native_rad_s
 *   torque_nm  = direction * native_nm       (= direction * iq * Kt)
 *   current_a  = direction * iq
 *
 * so zero_offset_rad is the native output position that rmdd reports as 0,
 * and commands go the other way: native = direction * pos + zero_offset.
 *
 * Setpoints.  rmd_motor_encode() clamps every value to the motor's limits
 * (config limits: position window, |velocity|, |torque|; MIT ranges) and
 * refuses NaN and Inf BEFORE anything is encoded: a non-finite value never
 * reaches the wire; the caller sends the safe action's frame instead
 * (rmd_motor_encode_safe()) and counts it.  Frames per mode and protocol:
 *
 *   torque    V3 §2.17 / V2 §3.37 0xA1: iq = torque / Kt (V3 0.01 A,
 *             V2 32 A / 2000); V2 §4.1 0x280 for batched motors
 *   speed     V3 §2.18 / V2 §3.38 0xA2: 0.01 dps
 *   position  V3 §2.20 / V2 §3.40 0xA4: 0.01 deg, maxSpeed 1 dps
 *   mit       V3 §5 / V4.2 §5 on 0x400 + ID (rmd_mit_encode_cmd(), the
 *             motor's ranges), only once its MIT scaling is decided
 *
 * MIT is a mode of V3 and V4 firmware (rmd/dialect.h): a motor driven in
 * it (mit_mode) answers its firmware's command set on 0x140 + ID, so every
 * non-MIT frame for it (status reads, 0x80, 0xB3, ...) is a frame of its
 * dialect.  Its MIT ranges are decided from its firmware's date and model
 * (rmd_mit_scaling_decide(), at bring-up): until then (mit_scaled false)
 * no MIT frame is encoded for it, and its damp safe action is 0xA2 speed 0.
 *
 * Replies.  rmd_motor_decode() turns a reply (V3 0x240 + ID, V2 0x140 + ID,
 * MIT 0x500 + ID) into SI values and says which it carried.  V3 control
 * replies carry the output angle in whole degrees (V3 §2.13.3, int16);
 * V2's carry the rotor's single-turn encoder (V2 §3.32, 16 bits a rotor
 * turn), which rmd_motor_decode() unwraps into a multi-turn output angle
 * from a reference: the 0x92 angle (rmd_motor_set_v2_reference() at
 * bring-up, or the first 0x92 answer decoded without one).  Without a
 * reference a V2 reply carries no position: an encoder counts within one
 * rotor turn, and a motor that was silent (LOST) may have turned further
 * or been powered off (rmd_motor_forget_v2_reference()).
 *
 * Everything here is rt-safe: no allocation, no I/O, no clock.
 */
#ifndef RMD_MOTOR_H
#define RMD_MOTOR_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/config.h"
#include "rmd/dialect.h"
#include "rmd/frame.h"
#include "rmd/mit.h"
#include "rmd/multiturn.h"
#include "rmd/state.h"

/*
 * Damping of the MIT "damp" safe action (kp 0, kd this, clamped into the
 * motor's kd range); the configuration has no key for it yet.
 */
#define RMD_MOTOR_DAMP_KD 1.0

/* V2 §3.32: the single-turn encoder counts 2^16 a rotor turn. */
#define RMD_MOTOR_V2_ENCODER_COUNTS 65536
/*
 * V2 (docs/feedback.md): an encoder value is counted from the previous one
 * only when the rotor, at the faster of the two replies' speeds, turned
 * less than this many turns between them (the count is ambiguous from
 * half a turn; the margin covers acceleration between the two), and is
 * anchored to a 0x92 angle only when the output turned less than
 * RMD_MOTOR_V2_ANCHOR_RAD between the two answers.  Otherwise the reply
 * carries no position and the reference is dropped: counted again from
 * the next 0x92 angle.
 */
#define RMD_MOTOR_V2_STEP_TURNS 0.25
#define RMD_MOTOR_V2_ANCHOR_RAD 0.00872664625997165 /* 0.5 deg */

/*
 * Pseudo command of MIT replies (0x500 + ID carries no command byte), for
 * matching a reply to its request: command bytes are 0x00..0xFF.
 */
#define RMD_MOTOR_CMD_MIT 0x100u

/* V3 §2.11 / V2 §3.29: read the output shaft's multi-turn angle, 0.01 deg. */
#define RMD_MOTOR_CMD_FINE_POS 0x92u

/* The unsolicited frame of a motor whose comm-loss protection tripped (docs/design.md). */
#define RMD_MOTOR_CMD_COMM_LOST 0xF1u

/* rmd_motor_encode() *flags */
enum {
	RMD_MOTOR_CLAMPED = 1u << 0, /* a value was clamped to a limit or range */
};

/* What a decoded reply carried: struct rmd_motor_reply.have */
enum {
	RMD_MOTOR_HAVE_POS = 1u << 0,
	RMD_MOTOR_HAVE_VEL = 1u << 1,
	RMD_MOTOR_HAVE_TORQUE = 1u << 2, /* torque_nm, and current_a */
	RMD_MOTOR_HAVE_TEMP = 1u << 3,
	RMD_MOTOR_HAVE_VOLTAGE = 1u << 4,
	RMD_MOTOR_HAVE_ERROR = 1u << 5, /* error_code (0x9A) */
	RMD_MOTOR_HAVE_BRAKE = 1u << 6,
	RMD_MOTOR_HAVE_MODEL = 1u << 7,	   /* 0xB5 */
	RMD_MOTOR_HAVE_VERSION = 1u << 8,  /* 0xB2 */
	RMD_MOTOR_HAVE_TIMEOUT = 1u << 9,  /* 0xB3 echo */
	RMD_MOTOR_HAVE_RUNTIME = 1u << 10, /* 0xB1 (rmd/reboot.h) */
	/*
	 * V2: a 0x92 angle, which rmd_motor_take() holds against rmdd's
	 * count of the motor's encoder when it has one
	 * (rmd_reboot_turns_says()): RMD_MOTOR_HAVE_COUNT_SAME, they agree;
	 * RMD_MOTOR_HAVE_COUNT_LOST, they part by whole rotor turns: the
	 * motor lost its count (it rebooted); RMD_MOTOR_HAVE_COUNT_ASTRAY,
	 * they part by other than whole turns: rmdd's count was wrong, it is
	 * dropped and taken again from the next 0x92 angle.
	 */
	RMD_MOTOR_HAVE_COUNT_CHECK = 1u << 11,
	RMD_MOTOR_HAVE_COUNT_SAME = 1u << 12,
	RMD_MOTOR_HAVE_COUNT_LOST = 1u << 13,
	RMD_MOTOR_HAVE_COUNT_ASTRAY = 1u << 14,
};

/* A request field of a control row, resolved once by rmd_motor_init(). */
struct rmd_motor_field {
	const struct rmd_field_spec *fs; /* NULL: the row has no such field */
	int64_t lo, hi;			 /* its integer range */
};

/*
 * A control command of the motor's table (0xA1, 0xA2, 0xA4), resolved once
 * by rmd_motor_init(): its row and the request fields the setpoint fills,
 * so that rmd_motor_encode() writes the frame without a struct rmd_msg.
 * The codec's table stays the one source of the layout and the LSBs.
 */
struct rmd_motor_row {
	const struct rmd_cmd_spec *spec; /* NULL: the protocol has no such command */
	struct rmd_motor_field f[2];
};

/*
 * The reply most frames of a cycle carry, resolved once by
 * rmd_motor_init(): status 2 (V3 §2.13, V2 §3.32), the answer to 0x9C and
 * to every control command.  cmds has bit c set when command c's reply row
 * has exactly 0x9C's reply layout; the field specs are that layout's (NULL:
 * absent), so rmd_motor_decode() reads such a reply without walking the row.
 */
struct rmd_motor_status2 {
	uint8_t cmds[32];
	const struct rmd_field_spec *temp, *current, *speed, *angle, *encoder;
	/* their readings, worked out once (rmd_field_rd_init()) */
	struct rmd_field_rd temp_rd, current_rd, speed_rd, angle_rd, encoder_rd;
};

/*
 * The one record of a motor, built once from its config entry by
 * rmd_motor_init(): identity, conversions, limits, MIT ranges; and its
 * decode state.  The plan, the loop and (through struct rmd_motor_info)
 * the bridge read it; nothing else keeps a copy of these facts.
 */
struct rmd_motor {
	const char *name; /* the config entry's, which outlives the motor */
	uint8_t bus;	  /* index into cfg->buses[] */
	uint8_t id;
	enum rmd_proto proto;
	/* the motor's dialect (rmd/dialect.h): its table, ids and capabilities */
	const struct rmd_dialect *d;
	uint32_t caps;	      /* d->caps, beside the fields the cycle reads */
	enum rmd_proto table; /* d->table: the rows of its 0x140 + ID frames (rmd_motor_row()) */
	enum rmd_mode mode;
	double dir;		  /* +1 or -1 */
	double native_per_output; /* 1, or gear_ratio when the protocol speaks the rotor */
	double gear_ratio;	  /* rotor turns per output turn (encoder counts) */
	/* the config's; the rt loop moves it (rmd_motor_shift_pos()) after a power cycle */
	double zero_offset_rad;
	double kt_nm_a; /* output N·m per A of iq; 0: unknown */
	struct rmd_config_limits limits;
	/* driven in MIT mode: `mode: mit`, on firmware that offers it (rmd_dialect_offers_mit()) */
	bool mit_mode;
	/* what its firmware does that no manual says: rmd_firmware_quirks() of its 0xB2 date */
	unsigned quirks;
	/* an MIT frame was encoded for it since it was found or rebooted (RMD_QUIRK_A4_AFTER_MIT) */
	bool mit_sent;
	bool fw_warned; /* its RMD_EV_FW_REFUSED was reported since then */
	/*
	 * mit holds its decided MIT scaling (rmd_motor_set_mit()): MIT frames
	 * may be encoded and decoded.  rmd_motor_init() decides it from the
	 * entry alone only where no firmware date changes the scaling (V3,
	 * not `protocol: auto`); bring-up decides every motor again.
	 */
	bool mit_scaled;
	struct rmd_mit_ranges mit;
	struct rmd_mit_valid_ranges mit_ok; /* mit, validated once (mit_scaled) */
	/*
	 * MIT encode state: the last setpoint's gains (NaN: none yet), their
	 * codes and whether clamping them changed them (RMD_MOTOR_CLAMPED).
	 * Gains seldom change between setpoints; their codes are kept.
	 */
	double mit_kp, mit_kd;
	struct rmd_mit_gain_codes mit_gains;
	unsigned mit_gains_fl;
	double damp_kd;
	uint32_t reply_id;		 /* replies to 0x140 + ID: d->reply_base + ID */
	struct rmd_motor_row torque_row; /* 0xA1: current */
	struct rmd_motor_row speed_row;	 /* 0xA2: speed */
	struct rmd_motor_row pos_row;	 /* 0xA4: angle, max speed */
	struct rmd_motor_status2 st2;	 /* replies with 0x9C's layout */
	uint8_t echo[32]; /* bit c: command c's answer repeats it (RMD_CMD_ECHO of its row) */
	/* feedback.position multi_turn: the position comes from 0x92 replies only */
	bool fine_pos;
	/* fine_pos or V2: take() looks at a reply's position first (pos_check()) */
	bool pos_check;
	/* V2 position: the rotor encoder unwrapped from a reference */
	bool v2_have_ref;      /* a reference angle was set, or none is needed (not V2) */
	double v2_ref_rad;     /* native output angle at the anchor */
	bool v2_anchored;      /* the first encoder value after the reference is seen */
	uint8_t v2_took;       /* what decoding the last reply did with it: V2_TOOK_* (motor.c) */
	uint16_t v2_enc_last;  /* last encoder value */
	int64_t v2_enc_counts; /* unwrapped counts since the anchor */
	/* whether its position survives a power cycle (rmd/multiturn.h), from the config */
	struct rmd_multiturn mt;
	/*
	 * V2: whether the count can be trusted (RMD_MOTOR_V2_STEP_TURNS): when
	 * the reference angle and the last encoder value counted were
	 * received, and that reply's rotor speed (rad/s).
	 */
	int64_t v2_ref_ns;
	int64_t v2_enc_ns;
	double v2_rotor_speed;
	/* the count's position the last 0x92 angle was held against (RMD_MOTOR_HAVE_COUNT_*) */
	double v2_checked_rad;
	/*
	 * The status read 0x9C (V3 §2.13, V2 §3.32), encoded once: the frame a
	 * motor that is not driven gets in every control slot (len 0: none).
	 */
	struct rmd_frame status2_req;
};

/* The row of command `cmd` in the motor's table, or NULL (rmd_cmd_find(), checked at init).  rt-safe. */
static inline const struct rmd_cmd_spec *rmd_motor_row(const struct rmd_motor *m, uint8_t cmd)
{
	return rmd_cmd_by_byte[m->table][cmd];
}

/* Whether the answer to command `cmd` of the motor's table repeats the request.  rt-safe. */
static inline bool rmd_motor_echoes(const struct rmd_motor *m, uint8_t cmd)
{
	return (m->echo[cmd / 8] >> (cmd % 8)) & 1;
}

/* Bit of a modes mask (rmd_motor_modes()) for each enum rmd_mode. */
#define RMD_MOTOR_MODE_BIT(mode) (1u << (mode))
#define RMD_MOTOR_MODES_ALL ((1u << RMD_MODE_COUNT) - 1)

#define RMD_MOTOR_NAME_LEN 32

/*
 * What a motor is, for those that check commands against it (the LCM
 * bridge) and describe it (config_t), filled by rmd_motor_info().
 */
struct rmd_motor_info {
	char name[RMD_MOTOR_NAME_LEN];
	uint8_t bus;		   /* index into the buses */
	uint8_t id;		   /* 1..32 on its bus */
	char protocol[8];	   /* "v2", "v3", "mit": informational, for config_t */
	uint8_t modes;		   /* RMD_MOTOR_MODE_BIT()s the motor may be commanded in */
	double pos_min_rad;	   /* setpoints are clamped to [pos_min_rad, pos_max_rad] */
	double pos_max_rad;	   /*   (+-INFINITY: no limit) */
	double vel_max_rad_s;	   /* |velocity| and max_velocity clamp (INFINITY: none) */
	double torque_max_nm;	   /* |torque| clamp (INFINITY: none) */
	double kp_min, kp_max;	   /* MIT stiffness range, N·m/rad: outside is rejected */
	double kd_min, kd_max;	   /* MIT damping range, N·m·s/rad: outside is rejected */
	double pos_resolution_rad; /* step of the reported position (rmd_motor_pos_resolution_rad()) */
	double pos_rate_hz;	   /* new positions planned per second (the plan's pos_hz) */
	/* rmd/multiturn.h: its facts for trusting its position after a power cycle */
	bool multi_turn_saved; /* it keeps its multi-turn count at power-off */
	double travel_min_rad; /* the travel band (+-INFINITY: none) */
	double travel_max_rad;
	double turn_period_rad; /* one rotor turn at the output: 2 pi / gear_ratio */
};

/*
 * Whether the motor's firmware runs `mode` now: not position (0xA4) after
 * an MIT frame on firmware that ignores it until it is reset
 * (RMD_QUIRK_A4_AFTER_MIT, rmd/dialect.h; mit_sent).  rmd_motor_encode()
 * refuses such a setpoint (-EPERM).  rt-safe.
 */
static inline bool rmd_motor_runs(const struct rmd_motor *m, enum rmd_mode mode)
{
	return mode != RMD_MODE_POSITION || !m->mit_sent || !(m->quirks & RMD_QUIRK_A4_AFTER_MIT);
}

/* Which setpoint values a mode uses (the others are not read).  rt-safe. */
static inline bool rmd_mode_uses_pos(unsigned mode)
{
	return mode == RMD_MODE_POSITION || mode == RMD_MODE_MIT;
}

static inline bool rmd_mode_uses_vel(unsigned mode)
{
	return mode == RMD_MODE_SPEED || mode == RMD_MODE_MIT;
}

static inline bool rmd_mode_uses_torque(unsigned mode)
{
	return mode == RMD_MODE_TORQUE || mode == RMD_MODE_MIT;
}

/* The first value rmd_motor_clamp() changed, for a log line. */
struct rmd_motor_clamp_note {
	const char *field; /* "position", "velocity", "torque", "max_velocity" */
	double from, to;
};

/* A reply in SI at the output shaft (see the top of this file). */
struct rmd_motor_reply {
	uint16_t cmd;  /* command byte, or RMD_MOTOR_CMD_MIT */
	unsigned have; /* RMD_MOTOR_HAVE_* */
	double pos_rad;
	double vel_rad_s;
	double torque_nm; /* NaN when Kt is unknown and the frame carries current */
	double current_a; /* NaN when Kt is unknown and the frame carries torque (MIT) */
	double temp_c;
	double voltage_v;
	uint16_t error_code;
	bool brake_released;
	char model[8];		  /* 0xB5, NUL-terminated */
	uint32_t version_date;	  /* 0xB2, yyyymmdd */
	uint32_t comm_timeout_ms; /* 0xB3 */
	uint32_t runtime_ms;	  /* 0xB1: ms since power-on */
};

/*
 * Take a validated config entry.  Returns 0, or -EINVAL for a direction
 * other than +-1, a gear ratio <= 0, an id outside 1..32, invalid MIT
 * ranges for an entry in mode mit, or one in another mode without torque
 * constant.  `mode: mit` on firmware without MIT (V2, as `protocol: auto`
 * may find) is not in MIT mode: no MIT frame is encoded for it.
 */
int rmd_motor_init(struct rmd_motor *m, const struct rmd_config_motor *c);

/*
 * The motor's MIT scaling is decided: r (rmd_mit_scaling_decide()) from now
 * on, for its frames, its damping and its position's resolution; or, with
 * r NULL, not decided (no MIT frame is encoded).  Returns 0, or -EINVAL for
 * a motor not driven in MIT or invalid ranges (nothing changed).  rt-safe.
 */
int rmd_motor_set_mit(struct rmd_motor *m, const struct rmd_mit_ranges *r);

/* The identifier of the replies to the motor's setpoints: 0x500 + ID in MIT mode.  rt-safe. */
static inline uint32_t rmd_motor_ctl_reply_id(const struct rmd_motor *m)
{
	return m->mit_mode ? RMD_CAN_MIT_REPLY_BASE + (uint32_t)m->id : m->reply_id;
}

/*
 * Rebuild the record for dialect `proto` from the same config entry c:
 * bring-up's answer to `protocol: auto` (rmd/bringup.h).  Returns what
 * rmd_motor_init() returns.  Non-rt (before the loop runs).
 */
int rmd_motor_set_dialect(struct rmd_motor *m, const struct rmd_config_motor *c,
			  enum rmd_proto proto);

/*
 * The modes the motor can be commanded in, RMD_MOTOR_MODE_BIT()s: torque
 * only with a torque constant; speed and position unless `batched` (a
 * motor in a V2 0x280 frame takes torques only: the frame carries nothing
 * else); MIT only in MIT mode.  rmd_motor_encode() refuses the others.
 */
unsigned rmd_motor_modes(const struct rmd_motor *m, bool batched);

/* The motor as the bridge sees it (modes as rmd_motor_modes()).  Non-rt. */
void rmd_motor_info(const struct rmd_motor *m, bool batched, struct rmd_motor_info *out);

/*
 * Clamp the values mode sp->mode uses to the limits (docs/lcm.md "What
 * rmdd does with a command"): position to [min, max]; velocity and torque
 * to +-their limit; in position mode max_vel_rad_s to [0, velocity limit],
 * 0 meaning the limit (and staying 0 without one).  Gains are not touched.
 * Returns how many values changed; the first in *note (may be NULL).  The
 * one copy of the rule: the bridge clamps (and counts) with it, and so
 * does rmd_motor_encode().
 */
unsigned rmd_motor_clamp(const struct rmd_config_limits *lim, struct rmd_setpoint *sp,
			 struct rmd_motor_clamp_note *note);

/*
 * Encode setpoint sp for the motor, in the setpoint's mode (sp->mode, enum
 * rmd_mode), as one frame; m keeps its encode state (the MIT gains' codes).
 * Values are clamped (RMD_MOTOR_CLAMPED in *flags, which may be NULL).  Returns 0; -EDOM when a value the mode uses
 * is NaN or infinite (nothing encoded); -EOPNOTSUPP for a mode the
 * motor cannot do (MIT out of MIT mode or before its scaling is decided,
 * an unknown mode) or torque without a torque constant.
 */
int rmd_motor_encode(struct rmd_motor *m, const struct rmd_setpoint *sp, struct rmd_frame *out,
		     unsigned *flags);

/*
 * The frames of safe action `a` for this motor (1 or 2, returned):
 * stop 0x80 (V3 §2.15, V2 §3.34); hold 0x81 (V3 §2.16, V2 §3.35); damp: MIT
 * kp 0, kd RMD_MOTOR_DAMP_KD, zero velocity and torque on 0x400 + ID for
 * motors in MIT mode whose scaling is decided, 0xA2 speed 0 for the others
 * (neither V2 nor V3 0xA2 has a torque limit); brake 0x80 then 0x78 (V3
 * §2.27, V2 §3.51).
 */
int rmd_motor_encode_safe(const struct rmd_motor *m, enum rmd_safe_action a,
			  struct rmd_frame out[2]);

/*
 * A request without fields (0x80, 0x81, 0x78, 0x9A, 0x9C, 0x92, 0xB2,
 * 0xB5, ...) on 0x140 + ID, from the motor's table.
 * Returns 0, or -ENOENT when the protocol has no such command.
 */
int rmd_motor_encode_cmd(const struct rmd_motor *m, uint8_t cmd, struct rmd_frame *out);

/* V3 §2.30 0xB3 comm-loss time (ms, 0: off).  -EOPNOTSUPP for V2, which has none. */
int rmd_motor_encode_comm_timeout(const struct rmd_motor *m, uint32_t ms, struct rmd_frame *out);

/*
 * V2 §4.1 0x280: the torques of motors with ID 1..4.  m[k] is the motor
 * with ID k + 1 on the bus, or NULL (its slot carries 0 A); torque_nm[k] is
 * clamped to that motor's limit (RMD_MOTOR_CLAMPED in *flags) and
 * converted with its Kt and direction.  A non-finite torque is sent as 0 A,
 * the frame's only "no torque", and counted in *nonfinite.  flags and
 * nonfinite may be NULL.  Returns 0, or -EINVAL when a motor is not a V2
 * motor with that ID and a torque constant.
 */
int rmd_motor_encode_v2_batch(const struct rmd_motor *const m[4], const double torque_nm[4],
			      struct rmd_frame *out, unsigned *flags, unsigned *nonfinite);

/*
 * The identifier and command a reply to `req` (a frame of this motor)
 * comes with: V3 and V4 on 0x240 + ID, V2 on 0x140 + ID, MIT on
 * 0x500 + ID (cmd RMD_MOTOR_CMD_MIT); a V2 0x280 frame is answered like
 * 0xA1 (V2 §4.2).  rt-safe (inline: the loop books every frame with it).
 */
static inline void rmd_motor_reply_key(const struct rmd_motor *m, const struct rmd_frame *req,
				       uint32_t *reply_id, uint16_t *cmd)
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
	*reply_id = m->reply_id;
	*cmd = req->len ? req->data[0] : 0;
}

/*
 * Decode a reply of this motor into r.  Returns 0; -EINVAL when the frame
 * is not a reply of this motor; -EBADMSG for a bad length or MIT id byte;
 * -ENOENT for a command the codec does not know (r->cmd is still set: the
 * 0xF1 comm-loss frame comes back this way).  Updates the V2 unwrap state.
 */
int rmd_motor_decode(struct rmd_motor *m, const struct rmd_frame *f, struct rmd_motor_reply *r);

/* Copy what r carried into the state (position, speed, torque, ...).  rt-safe. */
void rmd_motor_apply(const struct rmd_motor_reply *r, struct rmd_motor_state *st);

/*
 * Fuse reply r, received at t_ns, into the state (docs/feedback.md
 * "Fusion"): every value is the newest the motor said, with the time of
 * the reply it came from: pos_rx_ns for the position, rx_ns for velocity,
 * torque and current.  A motor with fine position feedback (fine_pos)
 * takes its position from 0x92 replies only: a control reply's coarser
 * angle never replaces it, and nothing is extrapolated.  rt-safe.
 */
void rmd_motor_take(struct rmd_motor *m, const struct rmd_motor_reply *r, int64_t t_ns,
		    struct rmd_motor_state *st);

/*
 * rmd_motor_decode() and rmd_motor_take() of one reply in one call, as the
 * rt loop takes every reply: returns what rmd_motor_decode() returns, and
 * on 0 the RMD_MOTOR_HAVE_* taken into st in *have (a position the checks
 * of rmd_motor_take() refused is not; st untouched on an error).
 * rt-safe.
 */
int rmd_motor_receive(struct rmd_motor *m, const struct rmd_frame *f, int64_t t_ns,
		      struct rmd_motor_state *st, unsigned *have);

/*
 * The step of the position rmd_motor_take() reports, rad at the output
 * shaft: the 0x92 angle's LSB (0.01 deg) with fine_pos, else the control
 * replies' (V3 whole degrees, V2 one encoder count, MIT its 16-bit code
 * over [p_min, p_max]).  rt-safe.
 */
double rmd_motor_pos_resolution_rad(const struct rmd_motor *m);

/*
 * V2: the native output angle (rad) read with 0x92 at bring-up, received
 * at t_ns; the next encoder value decoded is taken to be there (when the
 * motor cannot have moved more than RMD_MOTOR_V2_ANCHOR_RAD since).
 */
void rmd_motor_set_v2_reference(struct rmd_motor *m, double native_rad, int64_t t_ns);

/*
 * V2: the encoder no longer continues from the reference (the motor was
 * silent: it may have turned more than half a rotor turn, or lost its
 * count): no position until the next 0x92 angle.
 */
void rmd_motor_forget_v2_reference(struct rmd_motor *m);

/* Whether m is a V2 motor whose replies carry no position until a 0x92 angle.  rt-safe. */
static inline bool rmd_motor_needs_v2_reference(const struct rmd_motor *m)
{
	return !m->v2_have_ref;
}

/* The native output position (rad) of a reported position, and back. */
double rmd_motor_to_native_pos(const struct rmd_motor *m, double pos_rad);
double rmd_motor_from_native_pos(const struct rmd_motor *m, double native_rad);

/*
 * Report every position shift_rad further from now on, and take commands
 * in the same frame: the motor's zero offset moves by -direction *
 * shift_rad.  The multi-turn unwrap after a power cycle and homing do it
 * (rmd/multiturn.h); nothing moves the motor.  rt-safe.
 */
void rmd_motor_shift_pos(struct rmd_motor *m, double shift_rad);

#endif /* RMD_MOTOR_H */
