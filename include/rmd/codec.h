/* SPDX-License-Identifier: MIT */
/*
 * RMD protocol codec, V2.0, V3.x and V4.x: bytes <-> decoded messages.
 *
 * Layer 1 of docs/design.md: pure functions, no I/O, clock, globals (other than
 * const tables), allocation or logging.  Every function here is rt-safe.
 *
 * The codec is table driven.  Each command of each protocol has a
 * struct rmd_cmd_spec that names the command and lists, for the request and
 * for the reply, which little-endian integer field sits at which bytes and
 * what one LSB is worth in the protocol's native unit (0.01 A, 1 dps,
 * 0.01 deg, 0.1 V, ...).  One interpreter encodes and decodes all of them,
 * so a command is exactly as right as its table row, and the table rows are
 * checked against the manuals' worked examples in tests/unit/test_codec.c.
 *
 * A decoded message keeps the raw wire integers (struct rmd_msg.v[]), so
 * decode(encode(x)) == x holds exactly; rmd_layout_field() gives a field's
 * row entry, whose scale turns the raw value into the native unit.
 */
#ifndef RMD_CODEC_H
#define RMD_CODEC_H

#include <stdbool.h>
#include <stddef.h>
#include <errno.h>
#include <stdint.h>
#include <string.h>

#include "rmd/frame.h"

/*
 * The firmware dialects, as keys: what each is (its table, identifiers,
 * capabilities) is its record, rmd_dialect() of rmd/dialect.h.  Outside
 * src/proto/ nothing compares these values (tests/check-layers).
 */
enum rmd_proto {
	RMD_PROTO_V3 = 0, /* replies on 0x240 + ID */
	RMD_PROTO_V2,	  /* replies on 0x140 + ID */
	RMD_PROTO_MIT,	  /* 0x400 + ID / 0x500 + ID, see rmd/mit.h */
	RMD_PROTO_V4,	  /* replies on 0x240 + ID; float PID gains by index */
#ifdef RMD_PROTO_MORE
	/*
	 * A build's own keys beyond these, their rows in RMD_DIALECTS_MORE
	 * (dialect.c): tests/unit/test_new_dialect.c adds one so, standing
	 * in for a new value here (docs/design.md "How to add a dialect")
	 */
	RMD_PROTO_MORE,
#endif
	RMD_PROTO_COUNT /* not a dialect: how many there are */
};

enum rmd_dir {
	RMD_DIR_REQUEST = 0, /* host -> motor */
	RMD_DIR_REPLY,	     /* motor -> host */
	RMD_DIR_UNKNOWN,     /* V2 uses 0x140 + ID both ways */
};

/*
 * Every quantity any frame carries.  The value of field F is msg.v[F], the
 * raw integer from the wire (sign-extended where the row says signed).
 * The comment gives the JSON key rmdctl prints (rmd_field_key()).
 */
enum rmd_field {
	RMD_FLD_TEMP = 0,    /* temperature_c */
	RMD_FLD_CURRENT,     /* current_a: iq, measured or setpoint */
	RMD_FLD_SPEED,	     /* speed_dps: measured or setpoint */
	RMD_FLD_ANGLE,	     /* angle_deg: measured or setpoint */
	RMD_FLD_MAX_SPEED,   /* max_speed_dps: speed limit of a move */
	RMD_FLD_SPIN_DIR,    /* spin_direction: V2 0xA5/0xA6, 0 = cw */
	RMD_FLD_ENCODER,     /* encoder: counts */
	RMD_FLD_ENCODER_RAW, /* encoder_raw: counts, without offset */
	RMD_FLD_ENCODER_OFF, /* encoder_offset: counts */
	RMD_FLD_VOLTAGE,     /* voltage_v */
	RMD_FLD_ERROR,	     /* error_code (+ "errors": names) */
	RMD_FLD_BRAKE,	     /* brake_released: 1 released, 0 locked */
	RMD_FLD_PHASE_A,     /* phase_a_a */
	RMD_FLD_PHASE_B,     /* phase_b_a */
	RMD_FLD_PHASE_C,     /* phase_c_a */
	RMD_FLD_CURR_KP,     /* current_kp */
	RMD_FLD_CURR_KI,     /* current_ki */
	RMD_FLD_SPD_KP,	     /* speed_kp */
	RMD_FLD_SPD_KI,	     /* speed_ki */
	RMD_FLD_POS_KP,	     /* position_kp */
	RMD_FLD_POS_KI,	     /* position_ki */
	RMD_FLD_ACCEL,	     /* accel_dps2 */
	RMD_FLD_INDEX,	     /* index: 0x43 accel index, 0x20 function, V4 0xC0 parameter */
	RMD_FLD_VALUE,	     /* value: 0x20 function parameter */
	RMD_FLD_MODE,	     /* mode: 0x70 run mode (rmd_run_mode_name) */
	RMD_FLD_POWER,	     /* power_w */
	RMD_FLD_RUNTIME,     /* runtime_ms */
	RMD_FLD_VERSION,     /* version_date: yyyymmdd */
	RMD_FLD_TIMEOUT,     /* timeout_ms: 0xB3 comm-loss protection */
	RMD_FLD_BAUD,	     /* baud_code: 0xB4 */
	RMD_FLD_MODEL,	     /* model: up to 7 ASCII bytes, first in LSB */
	RMD_FLD_READ_FLAG,   /* read_flag: 0x79 and V4 0xC0, 1 read, 0 write */
	RMD_FLD_CAN_ID,	     /* can_id_value: 0x79 */
	RMD_FLD_CURRENT_1,   /* current_1_a: V2 0x280, motor 1 */
	RMD_FLD_CURRENT_2,   /* current_2_a */
	RMD_FLD_CURRENT_3,   /* current_3_a */
	RMD_FLD_CURRENT_4,   /* current_4_a */
	RMD_FLD_BATTERY,     /* battery_v: V2 0x72 */
	RMD_FLD_GAIN,	     /* gain: V4 0x30..0x32, one PID gain (float) */
	RMD_FLD_MOS_TEMP,    /* mos_temperature_c: V4.3 0x9A (one source, unverified) */
	RMD_FLD_MAX_TORQUE,  /* max_torque_pct: V4.3 0xA2, 0xA9, % rated current (unverified) */
	RMD_FLD_REPORT_CMD,  /* report_command: V4 0xB6, the reply pushed */
	RMD_FLD_REPORT_ON,   /* report_enable: V4 0xB6, 1 on, 0 off */
	RMD_FLD_REPORT_MS,   /* report_interval_ms: V4 0xB6, 10 ms a step */
	RMD_FLD_POS_KD,	     /* position_kd: V4 0x30 index 9 (as a struct rmd_pid_slot's field) */
	RMD_FLD_PARAM,	     /* param_value: V4 0xC0, a parameter (float; one source, unverified) */
	RMD_FLD_COUNT
};

/*
 * One field of a frame's data: little-endian, `size` bytes from `off`.
 *
 * sign_byte: the byte after the field is a sign flag (V2 §3.21 .. §3.25,
 * §3.29: "int64_t, valid data is 6 bytes, the seventh byte represents
 * positive and negative, 0 positive, 1 negative").  The manual allows two
 * readings of a negative value, and both decode right:
 *   - the field's bytes are the low bytes of the int64 (two's complement),
 *     the flag 1 (or 0xFF, the int64's next byte): the field's top bit is
 *     set, and the field read as two's complement is the value;
 *   - the field's bytes are the magnitude, the flag nonzero: the field's
 *     top bit is clear, and the value is minus the field.
 * So: top bit set -> two's complement (whatever the flag: no magnitude
 * reaches 2^(8 size - 1)); top bit clear -> the field, negated when the flag
 * is nonzero.  Encoding writes the manual's own form: two's complement and
 * the flag 1 for a negative value (e.g. -50.00 deg is 78 EC FF FF FF FF 01).
 *
 * is_float: the field is a little-endian IEEE 754 binary32 (V4.2 §2.1 ..
 * §2.3: a PID gain, 0x3F800000 = 1.0).  Its raw value is the 32 bits
 * (size 4, unsigned, scale 1.0), so encode, decode and decode(encode(x))
 * stay integer; rmd_field_to_native() and rmd_field_from_native() convert
 * through float.  No float field is on the rt loop's path: the rt loop
 * reads fields through rmd_field_rd_*, which know integers only.
 */
struct rmd_field_spec {
	uint8_t field; /* enum rmd_field */
	uint8_t off;   /* first byte in data[] */
	uint8_t size;  /* 1..7 */
	bool is_signed;
	double scale;	/* native unit per LSB (1.0 for counts and codes) */
	bool sign_byte; /* data[off + size] is a sign flag (above); is_signed too */
	bool is_float;	/* IEEE 754 binary32, raw = its bits (above) */
};

#define RMD_LAYOUT_MAX 7

struct rmd_layout {
	uint8_t n;
	struct rmd_field_spec f[RMD_LAYOUT_MAX];
};

/* struct rmd_cmd_spec.flags */
enum {
	RMD_CMD_NO_REPLY = 1u << 0,	/* V3 §2.25: 0x76 resets, does not answer */
	RMD_CMD_ECHO = 1u << 1,		/* reply repeats the request's data */
	RMD_CMD_RANDOM_REPLY = 1u << 2, /* V3 §2.31: 0xB4 reply is noise */
	RMD_CMD_NO_CMD_BYTE = 1u << 3,	/* data[0] is not the command byte */
	RMD_CMD_ROM = 1u << 4,		/* writes the motor's ROM (flash) */
	RMD_CMD_MOVES = 1u << 5,	/* may move the motor */
};

/*
 * A range the manual gives a request field within its width (V2 §3.37:
 * iqControl -2000..2000), in the field's native unit: what tools let a
 * user ask for (rmdctl encode refuses a value outside it, citing it).
 */
struct rmd_field_range {
	uint8_t field; /* enum rmd_field */
	double lo, hi;
	const char *cite; /* "V2 §3.37: iqControl -2000..2000 is -32..32 A" */
};

#define RMD_SPELL_ARGS_MAX 4

/*
 * How tools spell a row (`rmdctl encode WORD ARGS...`): the words that name
 * it, and the request fields its arguments fill, in order (the rest are 0).
 * Rows of one table may share a word, told apart by their argument count
 * (V2 "position DEG" 0xA3, "position DEG MAX_DPS" 0xA4); a dialect has the
 * command a word names when a row of its table is spelled so.
 */
struct rmd_spelling {
	const char *words; /* "torque", or several: "position position-track"; NULL: none */
	uint8_t n_args;
	uint8_t args[RMD_SPELL_ARGS_MAX]; /* enum rmd_field */
};

struct rmd_cmd_spec {
	uint8_t cmd;	  /* command byte, data[0] */
	const char *name; /* short snake_case name, e.g. "read_status_1" */
	uint8_t flags;
	struct rmd_layout req;	   /* fields of the host's request */
	struct rmd_layout rep;	   /* fields of the motor's reply */
	struct rmd_spelling spell; /* tools' words for it */
	/* the manual's ranges of request fields (rmd_cmd_range()), n_ranges of them */
	const struct rmd_field_range *ranges;
	uint8_t n_ranges;
};

/* Whether `word` is one of spec's words (struct rmd_spelling).  Pure. */
bool rmd_cmd_spelled(const struct rmd_cmd_spec *spec, const char *word);

/* The manual's range of request field `fld` of spec, or NULL when it gives none. */
const struct rmd_field_range *rmd_cmd_range(const struct rmd_cmd_spec *spec, enum rmd_field fld);

/*
 * A decoded message.  `present` has bit F set when v[F] was decoded; encode
 * reads v[F] for every field the layout lists and ignores `present`.
 */
struct rmd_msg {
	uint8_t cmd;
	uint64_t present;
	int64_t v[RMD_FLD_COUNT];
};

/*
 * Whether rx, which matched a request of data `req` (RMD_FRAME_LEN bytes),
 * repeats that request byte for byte when the command's answer is no echo
 * (`reply_echoes`: RMD_CMD_ECHO): the echo of a motor whose comm-loss
 * protection tripped (docs/design.md: it echoes the first command it gets
 * next and does not execute it) -- or a real answer whose values are all
 * zero where the request has zeros (V3 §2.8: 0x62 with offset 0), which
 * only the time the request reached the motor tells apart (rmd/txn.h).
 * The one copy of the rule: the rt loop and txn both ask it.  rt-safe.
 */
static inline bool rmd_frame_repeats(const uint8_t *req, bool reply_echoes,
				     const struct rmd_frame *rx)
{
	return !reply_echoes && rx->len == RMD_FRAME_LEN && !memcmp(rx->data, req, RMD_FRAME_LEN);
}

/* Where a frame goes: from its CAN identifier. */
struct rmd_addr {
	enum rmd_dir dir;
	uint8_t motor_id; /* 1..32; 0 for 0x280 and 0x300 */
	bool broadcast;	  /* 0x280 (both protocols) or 0x300 (V3) */
};

/*
 * Pseudo command byte of the V2 0x280 four-torque frame (V2 §4.1), whose
 * data carries no command byte.  Its row is found with this value.
 */
#define RMD_V2_CMD_MULTI_TORQUE 0x00u

/*
 * The dialect whose command table a dialect's 0x140 + ID frames use
 * (struct rmd_dialect.table): itself, or V3 for MIT (V3 §5: MIT motors
 * also speak V3).  Every function below that takes a proto reads the
 * table through the dialect, so RMD_PROTO_MIT means "the V3 table"
 * everywhere in the codec.  Out of range: itself.
 */
enum rmd_proto rmd_proto_table(enum rmd_proto proto);

/* The rows by command byte, [proto][cmd] (src/proto/dialect.c); read through rmd_cmd_find(). */
extern const struct rmd_cmd_spec *rmd_cmd_by_byte[RMD_PROTO_COUNT][256];

/* The row for `cmd` in the table of `proto`, or NULL if there is none.  O(1). */
static inline const struct rmd_cmd_spec *rmd_cmd_find(enum rmd_proto proto, uint8_t cmd)
{
	return (unsigned)proto < RMD_PROTO_COUNT ? rmd_cmd_by_byte[proto][cmd] : NULL;
}

/*
 * All rows of a protocol's table, for tools and tests that walk every
 * command.  Returns the count and stores the array in *rows.
 */
size_t rmd_cmd_table(enum rmd_proto proto, const struct rmd_cmd_spec **rows);

/*
 * Classify a CAN identifier.  Returns 0, or -EINVAL when the identifier is
 * not one the protocol uses (e.g. 0x240 + ID under V2, or ID 0 or > 32).
 */
int rmd_addr_from_id(enum rmd_proto proto, uint32_t can_id, struct rmd_addr *addr);

/*
 * Encode `msg` as a frame for motor `motor_id` (1..32).  For a request,
 * motor_id 0 means the 0x280 frame: the V3 broadcast of one command, or,
 * with msg->cmd == RMD_V2_CMD_MULTI_TORQUE under V2, the four-torque frame.
 * V3 0x79 goes to 0x300 whatever the motor_id.
 * Fields that do not fit their width give -ERANGE; an unknown command
 * -ENOENT; a bad motor_id or direction -EINVAL.  Reserved bytes are zero.
 */
int rmd_encode(enum rmd_proto proto, enum rmd_dir dir, uint8_t motor_id, const struct rmd_msg *msg,
	       struct rmd_frame *out);

/*
 * Decode the data of `f` in direction `dir` (RMD_DIR_UNKNOWN: decided from
 * the identifier, and for V2's shared identifiers by which layout the
 * reserved bytes fit, request first).  Fills msg->cmd, ->present and ->v;
 * stores the direction used in *dir_out when not NULL.
 * Returns 0; -EBADMSG when the DLC is not 8; -EINVAL for an identifier the
 * protocol does not use; -ENOENT for an unknown command (msg->cmd is still
 * set, nothing is present).
 */
int rmd_decode(enum rmd_proto proto, enum rmd_dir dir, const struct rmd_frame *f,
	       struct rmd_msg *msg, enum rmd_dir *dir_out);

/*
 * Decode the data of `f` as command `cmd` in direction `dir`, without
 * looking at data[0]: for replies that carry no command byte (V2 §3.48,
 * the 0x73 TF reply), matched by the caller to the request it sent.
 * Returns 0, -EBADMSG, -EINVAL or -ENOENT as rmd_decode().
 */
int rmd_decode_as(enum rmd_proto proto, enum rmd_dir dir, uint8_t cmd, const struct rmd_frame *f,
		  struct rmd_msg *msg);

/* Set field `fld` of `msg` to the raw value `raw` and mark it present. */
void rmd_msg_set(struct rmd_msg *msg, enum rmd_field fld, int64_t raw);

/* True when field `fld` was decoded. */
bool rmd_msg_has(const struct rmd_msg *msg, enum rmd_field fld);

/* The layout of `spec` in direction `dir` (an echoing row's reply is its request). */
const struct rmd_layout *rmd_cmd_layout(const struct rmd_cmd_spec *spec, enum rmd_dir dir);

/* The field spec of `fld` in the request or reply layout of `spec`, or NULL. */
const struct rmd_field_spec *rmd_layout_field(const struct rmd_cmd_spec *spec, enum rmd_dir dir,
					      enum rmd_field fld);

/*
 * Native units (the row's LSB: 0.01 A, 1 dps, 0.01 deg, 0.1 V, ...; a row
 * without a scale counts 1).  One rule for every caller, host and
 * simulator: native / LSB rounded to the nearest integer (halves away from
 * zero), then saturated to the field's integer range (rmd_field_range():
 * signed or unsigned, 8 * size bits).  rmd_field_from_native() stores the
 * result in *raw and returns 0, or -ERANGE when the rounded value lay
 * outside the range (*raw saturated) or native was NaN (*raw 0).
 * A float field (is_float) is native rounded to the nearest binary32, its
 * bits in *raw: -ERANGE for NaN (*raw 0) or beyond the largest finite
 * float (*raw that largest, with native's sign).
 */
void rmd_field_range(const struct rmd_field_spec *fs, int64_t *lo, int64_t *hi);
double rmd_field_to_native(const struct rmd_field_spec *fs, int64_t raw);
int rmd_field_from_native(const struct rmd_field_spec *fs, double native, int64_t *raw);

/*
 * rmd_field_from_native() with the field's range [lo, hi] given (resolved
 * once by a caller on the rt path): the one rounding rule, without libm.
 * rt-safe.
 */
static inline int rmd_field_raw_in(const struct rmd_field_spec *fs, int64_t lo, int64_t hi,
				   double native, int64_t *raw)
{
	double x = native / (fs->scale > 0.0 ? fs->scale : 1.0);
	int64_t v;

	if (x != x) { /* NaN */
		*raw = 0;
		return -ERANGE;
	}
	/*
	 * lo <= 0 <= hi: half an LSB beyond an end rounds away from zero, out.
	 * (double)hi may round up to 2^bits: compare, never convert, above it.
	 */
	if (x <= (double)lo) {
		*raw = lo;
		return x < (double)lo && (double)lo - x >= 0.5 ? -ERANGE : 0;
	}
	if (x >= (double)hi) {
		*raw = hi;
		return x > (double)hi && x - (double)hi >= 0.5 ? -ERANGE : 0;
	}
	v = (int64_t)x; /* towards zero; the fraction x - v is exact */
	if (x - (double)v >= 0.5)
		v++;
	else if (x - (double)v <= -0.5)
		v--;
	*raw = v;
	return 0;
}

/*
 * Field `fld` of the `dir` layout of `spec` set to `native` and marked
 * present: 0, -ERANGE (saturated, as above) or -ENOENT when the layout has
 * no such field (msg untouched).
 */
int rmd_msg_set_native(struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_dir dir,
		       enum rmd_field fld, double native);

/* Field `fld` of `msg` in native units; `def` when the layout lacks it or msg does not have it. */
double rmd_msg_get_native(const struct rmd_msg *msg, const struct rmd_cmd_spec *spec,
			  enum rmd_dir dir, enum rmd_field fld, double def);

/*
 * One field of a row, read from or written into a frame's data (8 bytes):
 * the interpreter above uses them, and so do callers that resolved a row's
 * fields once and handle each frame without a struct rmd_msg (the rt
 * loop's motors, rmd/motor.h).  A sign_byte field takes both of the
 * manual's readings and is written in its form (V2 §3.29).  rmd_field_write() does not check that raw
 * fits: rmd_field_range() gives the field's integer range.
 */
/*
 * A field's reading worked out once (rmd_field_rd_init()), for callers
 * that read the same field of many frames: rmd_field_read() is
 * rmd_field_rd_raw() of the spec, and scale is the field's native unit per
 * LSB (1.0 for counts and codes), so that raw * scale is its native value.
 */
struct rmd_field_rd {
	uint8_t shl, shr; /* the field's top byte to the word's top, then its size down */
	bool is_signed;
	bool sign_byte; /* data[sign_at] is the field's sign flag */
	uint8_t sign_at;
	double scale;
};

static inline void rmd_field_rd_init(const struct rmd_field_spec *fs, struct rmd_field_rd *rd)
{
	rd->shl = (uint8_t)(64u - 8u * (fs->off + fs->size));
	rd->shr = (uint8_t)(64u - 8u * fs->size);
	rd->is_signed = fs->is_signed;
	rd->sign_byte = fs->sign_byte;
	rd->sign_at = (uint8_t)(fs->off + fs->size);
	rd->scale = fs->scale > 0.0 ? fs->scale : 1.0;
}

static inline int64_t rmd_field_rd_raw(const struct rmd_field_rd *rd, const uint8_t *data)
{
	uint64_t u;

	/* the 8 data bytes as one little-endian word: the field is bytes off..off+size-1 */
	__builtin_memcpy(&u, data, sizeof(u));
#if __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
	u = __builtin_bswap64(u);
#endif
	u <<= rd->shl;
	int64_t v = rd->is_signed ? (int64_t)u >> rd->shr : (int64_t)(u >> rd->shr);

	/* a sign_byte field's second reading: a magnitude and the flag (V2 §3.29) */
	if (rd->sign_byte && v > 0 && data[rd->sign_at])
		return -v;
	return v;
}

/* Field fs's value in the frame's data[] (raw, in LSBs).  rt-safe. */
static inline int64_t rmd_field_read(const struct rmd_field_spec *fs, const uint8_t *data)
{
	struct rmd_field_rd rd;

	rmd_field_rd_init(fs, &rd);
	return rmd_field_rd_raw(&rd, data);
}

static inline void rmd_field_write(const struct rmd_field_spec *fs, uint8_t *data, int64_t raw)
{
	unsigned at = 8u * fs->off;
	uint64_t u, mask = (UINT64_MAX >> (64u - 8u * fs->size)) << at;

	/* bytes off..off+size-1 of the data as one little-endian word (rmd_field_read()) */
	__builtin_memcpy(&u, data, sizeof(u));
#if __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
	u = __builtin_bswap64(u);
#endif
	u = (u & ~mask) | (((uint64_t)raw << at) & mask);
#if __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
	u = __builtin_bswap64(u);
#endif
	__builtin_memcpy(data, &u, sizeof(u));
	if (fs->sign_byte) /* the manual's form: two's complement, and the flag 1 when negative */
		data[fs->off + fs->size] = raw < 0;
}

/* JSON key of a field (see enum rmd_field). */
const char *rmd_field_key(enum rmd_field fld);

/*
 * Error flags -> names, for the protocol's error table (V3 §2.12 table 1,
 * V2 §3.31 tables 1 and 2).  Stores up to `max` static snake_case names in
 * names[] and returns how many flags are set (may exceed max).
 */
size_t rmd_error_names(enum rmd_proto proto, uint16_t code, const char **names, size_t max);

/*
 * Protocol names, from the dialects' records.  Keys "v3", "v2", "mit", "v4"
 * (config files and command lines; rmd_proto_keys[] is NULL-terminated,
 * in enum order, filled before main()); names "V3", "V2", "MIT", "V4" (the
 * manuals' spelling, for messages); "?" out of range.  rmd_proto_parse()
 * takes a key in any letter case ("v3", "V3", "Mit") and returns 0, or
 * -EINVAL for anything else (*proto untouched).
 */
extern const char *rmd_proto_keys[RMD_PROTO_COUNT + 1];
const char *rmd_proto_key(enum rmd_proto proto);
const char *rmd_proto_name(enum rmd_proto proto);
int rmd_proto_parse(const char *s, enum rmd_proto *proto);

/*
 * The keys as a phrase for messages, "v3, v2, mit or v4" (sep ", " and
 * last " or "), or with sep " " and last " " a word list; in buf, which
 * it returns (cut short when small).  Non-rt.
 */
const char *rmd_proto_keys_text(char *buf, size_t size, const char *sep, const char *last);
/* The same of the firmware dialects only, "v3, v2 or v4" (not `mit`: rmd_dialect_is_firmware()). */
const char *rmd_firmware_keys_text(char *buf, size_t size, const char *sep, const char *last);

/* Name of a 0x70 run mode value ("current_loop", ...), or NULL. */
const char *rmd_run_mode_name(enum rmd_proto proto, uint8_t mode);

/* 0xB5 model field -> NUL-terminated string (buf of >= 8 bytes). */
void rmd_model_string(int64_t raw, char buf[8]);

/* String of up to 7 ASCII characters -> 0xB5 model field value. */
int64_t rmd_model_raw(const char *s);

/*
 * 0xB2 version: yyyymmdd (V3 §2.29, V4.2 §2.29: 20220206), or on newer
 * firmware yyyymmddNN, a build number after the date (2025070202 from an
 * X4-36, 2025).  rmd_version_date() gives the date yyyymmdd of either
 * form, or 0 when it is no plausible calendar date in 2000..2099;
 * rmd_version_date_valid() tells whether there is one.
 */
uint32_t rmd_version_date(uint32_t version);
bool rmd_version_date_valid(uint32_t version);

#endif /* RMD_CODEC_H */
