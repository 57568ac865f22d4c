/* SPDX-License-Identifier: MIT */
/*
 * One frame describer: a decoded frame's quantities as text, for
 * `rmdctl decode` (human text and JSON), `rmdctl --trace` and `rmd-sim -v`
 * (key=value).  Every field is spelled the same way in all three: the
 * codec's JSON key (rmd_field_key()), the native unit of its table row,
 * error flags and run modes by name, the 0xB5 model as a string.
 *
 * Writes into caller-owned buffers; no allocation, I/O or logging.  Pure
 * and rt-safe.
 */
#ifndef RMD_DESCRIBE_H
#define RMD_DESCRIBE_H

#include <stddef.h>

#include "rmd/codec.h"
#include "rmd/frame.h"
#include "rmd/mit.h"

/* Significant digits of table-scaled fields. */
#define RMD_DESCRIBE_DIGITS 15

/* A line under construction: appends that do not fit are cut, always NUL-terminated. */
struct rmd_text {
	char *buf;
	size_t size; /* > 0 */
	size_t len;
	unsigned items; /* quantities written (for separators) */
};

void rmd_text_init(struct rmd_text *t, char *buf, size_t size);
void rmd_text_add(struct rmd_text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* s[0..len) as a JSON string: quotes, backslashes, control and non-ASCII bytes escaped. */
void rmd_text_json_str(struct rmd_text *t, const char *s, size_t len);
/* s[0..len) for humans: non-printable bytes, quotes and backslashes as \xNN. */
void rmd_text_str(struct rmd_text *t, const char *s, size_t len);

/* How quantities are spelled. */
enum rmd_describe_style {
	RMD_DESCRIBE_TEXT, /* ": temperature 25 °C, brake locked, voltage 48.5 V" */
	RMD_DESCRIBE_JSON, /* ",\"temperature_c\":25,\"brake_released\":false,..." */
	RMD_DESCRIBE_KEYS, /* " temperature_c=25 brake_released=0 voltage_v=48.5" */
};

/*
 * A number as JSON and humans want it: no exponent noise ("48.5"), no
 * "-0", NaN/Inf as "null".
 */
void rmd_fmt_real(char *buf, size_t size, double v, int digits);

/*
 * Human label and unit of a field, from its JSON key: "voltage_v" ->
 * "voltage", "V"; "encoder" -> "encoder", "".  label gets at most size - 1 chars.
 */
void rmd_field_label(enum rmd_field fld, char *label, size_t size, const char **unit);

/* The fields of `msg` that `lay` lists and that are present, in wire order. */
void rmd_describe_fields(struct rmd_text *t, enum rmd_describe_style style, enum rmd_proto proto,
			 const struct rmd_layout *lay, const struct rmd_msg *msg);

/* One quantity: the key (JSON and key=value), the human label and unit. */
void rmd_describe_real(struct rmd_text *t, enum rmd_describe_style style, const char *key,
		       const char *label, double v, int digits, const char *unit);

/* V3 §5 MIT frames: set points and gains, or position, velocity and torque. */
void rmd_describe_mit_cmd(struct rmd_text *t, enum rmd_describe_style style,
			  const struct rmd_mit_cmd *c, int digits);
void rmd_describe_mit_reply(struct rmd_text *t, enum rmd_describe_style style,
			    const struct rmd_mit_reply *r, int digits);

/*
 * One frame as "name key=value ...": "read_status_1 temperature_c=25
 * brake_released=0 voltage_v=48 error_code=0x0000 (none)".  MIT frames under
 * RMD_PROTO_MIT with `mit` given; MIT motors also speak V3, so other frames
 * decode as V3.  Returns 0, or rmd_decode()'s error when the frame did not
 * decode (buf then says why: "(DLC 5: not a protocol frame)", "(command
 * 0x12: not decoded)", "(empty)").
 */
int rmd_describe_frame(char *buf, size_t size, enum rmd_proto proto, enum rmd_dir dir,
		       const struct rmd_mit_ranges *mit, const struct rmd_frame *f);

#endif /* RMD_DESCRIBE_H */
