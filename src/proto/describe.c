// SPDX-License-Identifier: MIT
/*
 * The frame describer (rmd/describe.h): each field kind is spelled in one
 * place, in the three styles.  Pure and rt-safe.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/describe.h"
#include "rmd/dialect.h"

#define MAX_ERROR_NAMES 16

void rmd_text_init(struct rmd_text *t, char *buf, size_t size)
{
	t->buf = buf;
	t->size = size;
	t->len = 0;
	t->items = 0;
	buf[0] = '\0';
}

void rmd_text_add(struct rmd_text *t, const char *fmt, ...)
{
	va_list ap;
	int m;

	if (t->len + 1 >= t->size)
		return;
	va_start(ap, fmt);
	m = vsnprintf(t->buf + t->len, t->size - t->len, fmt, ap);
	va_end(ap);
	if (m > 0)
		t->len = t->len + (size_t)m < t->size ? t->len + (size_t)m : t->size - 1;
}

void rmd_text_json_str(struct rmd_text *t, const char *s, size_t len)
{
	rmd_text_add(t, "\"");
	for (size_t i = 0; i < len; i++) {
		unsigned char c = (unsigned char)s[i];

		if (c == '"' || c == '\\')
			rmd_text_add(t, "\\%c", c);
		else if (c < 0x20 || c >= 0x7f)
			rmd_text_add(t, "\\u%04x", c);
		else
			rmd_text_add(t, "%c", c);
	}
	rmd_text_add(t, "\"");
}

void rmd_text_str(struct rmd_text *t, const char *s, size_t len)
{
	for (size_t i = 0; i < len; i++) {
		unsigned char c = (unsigned char)s[i];

		if (c < 0x20 || c >= 0x7f || c == '\\' || c == '"')
			rmd_text_add(t, "\\x%02X", c);
		else
			rmd_text_add(t, "%c", c);
	}
}

void rmd_fmt_real(char *buf, size_t size, double v, int digits)
{
	if (!isfinite(v)) {
		snprintf(buf, size, "null");
		return;
	}
	if (v == 0)
		v = 0; /* no "-0" */
	snprintf(buf, size, "%.*g", digits, v);
}

/* Key suffixes that carry a unit (see enum rmd_field). */
static const struct {
	const char *suffix;
	const char *unit;
} unit_suffixes[] = {
	{ "_c", "°C" }, { "_a", "A" }, { "_dps", "dps" }, { "_dps2", "dps/s" }, { "_deg", "deg" },
	{ "_v", "V" },	{ "_w", "W" }, { "_ms", "ms" },	  { "_pct", "%" },
};

void rmd_field_label(enum rmd_field fld, char *label, size_t size, const char **unit)
{
	const char *key = rmd_field_key(fld);
	size_t n = strlen(key);

	*unit = "";
	for (size_t i = 0; i < sizeof(unit_suffixes) / sizeof(unit_suffixes[0]); i++) {
		size_t sl = strlen(unit_suffixes[i].suffix);

		if (n > sl && !strcmp(key + n - sl, unit_suffixes[i].suffix)) {
			*unit = unit_suffixes[i].unit;
			n -= sl;
			break;
		}
	}
	if (size == 0)
		return;
	if (n >= size)
		n = size - 1;
	for (size_t i = 0; i < n; i++)
		label[i] = key[i] == '_' ? ' ' : key[i];
	label[n] = '\0';
}

/* ---- one quantity ---------------------------------------------------------------------- */

/* Separator, then the JSON key, "key=" or the human label. */
static void q_begin(struct rmd_text *t, enum rmd_describe_style style, const char *key,
		    const char *label)
{
	switch (style) {
	case RMD_DESCRIBE_JSON:
		rmd_text_add(t, ",");
		rmd_text_json_str(t, key, strlen(key));
		rmd_text_add(t, ":");
		break;
	case RMD_DESCRIBE_KEYS:
		rmd_text_add(t, " %s=", key);
		break;
	case RMD_DESCRIBE_TEXT:
		rmd_text_add(t, "%s", t->items ? ", " : ": ");
		if (label && *label)
			rmd_text_add(t, "%s ", label);
		break;
	}
	t->items++;
}

static void q_unit(struct rmd_text *t, enum rmd_describe_style style, const char *unit)
{
	if (style == RMD_DESCRIBE_TEXT && unit && *unit)
		rmd_text_add(t, " %s", unit);
}

void rmd_describe_real(struct rmd_text *t, enum rmd_describe_style style, const char *key,
		       const char *label, double v, int digits, const char *unit)
{
	char buf[48];

	rmd_fmt_real(buf, sizeof(buf), v, digits);
	q_begin(t, style, key, label);
	rmd_text_add(t, "%s", buf);
	q_unit(t, style, unit);
}

static void q_int(struct rmd_text *t, enum rmd_describe_style style, const char *key,
		  const char *label, int64_t v, const char *unit)
{
	q_begin(t, style, key, label);
	rmd_text_add(t, "%" PRId64, v);
	q_unit(t, style, unit);
}

/* ---- fields with a name, a list or a truth value --------------------------------------- */

static void field_errors(struct rmd_text *t, enum rmd_describe_style style, enum rmd_proto proto,
			 int64_t raw)
{
	const char *names[MAX_ERROR_NAMES];
	uint16_t code = (uint16_t)raw;
	size_t n = rmd_error_names(proto, code, names, MAX_ERROR_NAMES);
	size_t shown = n < MAX_ERROR_NAMES ? n : MAX_ERROR_NAMES;
	const char *key = rmd_field_key(RMD_FLD_ERROR);

	switch (style) {
	case RMD_DESCRIBE_JSON:
		q_int(t, style, key, NULL, raw, NULL);
		rmd_text_add(t, ",\"errors\":[");
		for (size_t i = 0; i < shown; i++) {
			if (i)
				rmd_text_add(t, ",");
			rmd_text_json_str(t, names[i], strlen(names[i]));
		}
		rmd_text_add(t, "]");
		return;
	case RMD_DESCRIBE_KEYS:
	case RMD_DESCRIBE_TEXT:
		break;
	}
	q_begin(t, style, key, "errors");
	rmd_text_add(t, "0x%04X", (unsigned)code);
	if (shown) {
		const char *sep = style == RMD_DESCRIBE_TEXT ? ", " : "+";

		rmd_text_add(t, " (");
		for (size_t i = 0; i < shown; i++)
			rmd_text_add(t, "%s%s", i ? sep : "", names[i]);
		rmd_text_add(t, "%s", n > shown ? ", ...)" : ")");
	}
}

static void field_mode(struct rmd_text *t, enum rmd_describe_style style, enum rmd_proto proto,
		       int64_t raw)
{
	const char *name = rmd_run_mode_name(proto, (uint8_t)raw);

	q_int(t, style, rmd_field_key(RMD_FLD_MODE), "mode", raw, NULL);
	if (style == RMD_DESCRIBE_JSON) {
		rmd_text_add(t, ",\"mode_name\":");
		if (name)
			rmd_text_json_str(t, name, strlen(name));
		else
			rmd_text_add(t, "null");
	} else if (name) {
		rmd_text_add(t, " (%s)", name);
	}
}

static void field_model(struct rmd_text *t, enum rmd_describe_style style, int64_t raw)
{
	char buf[8];

	rmd_model_string(raw, buf);
	buf[sizeof(buf) - 1] = '\0';
	q_begin(t, style, rmd_field_key(RMD_FLD_MODEL), "model");
	if (style == RMD_DESCRIBE_JSON) {
		rmd_text_json_str(t, buf, strlen(buf));
	} else {
		rmd_text_add(t, "\"");
		rmd_text_str(t, buf, strlen(buf));
		rmd_text_add(t, "\"");
	}
}

static void field_brake(struct rmd_text *t, enum rmd_describe_style style, int64_t raw)
{
	q_begin(t, style, rmd_field_key(RMD_FLD_BRAKE), NULL);
	switch (style) {
	case RMD_DESCRIBE_JSON:
		rmd_text_add(t, "%s", raw ? "true" : "false");
		break;
	case RMD_DESCRIBE_KEYS:
		rmd_text_add(t, "%d", raw ? 1 : 0);
		break;
	case RMD_DESCRIBE_TEXT:
		rmd_text_add(t, "%s", raw ? "brake released" : "brake locked");
		break;
	}
}

static void field(struct rmd_text *t, enum rmd_describe_style style, enum rmd_proto proto,
		  const struct rmd_field_spec *fs, int64_t raw)
{
	enum rmd_field fld = (enum rmd_field)fs->field;
	const char *unit;
	char label[40];

	/* Fields with a name, a list or a truth value rather than a number. */
	if (fld == RMD_FLD_ERROR) {
		field_errors(t, style, proto, raw);
		return;
	}
	if (fld == RMD_FLD_MODE) {
		field_mode(t, style, proto, raw);
		return;
	}
	if (fld == RMD_FLD_MODEL) {
		field_model(t, style, raw);
		return;
	}
	if (fld == RMD_FLD_BRAKE) {
		field_brake(t, style, raw);
		return;
	}
	rmd_field_label(fld, label, sizeof(label), &unit);
	if (fs->scale == 1.0 && !fs->is_float)
		q_int(t, style, rmd_field_key(fld), label, raw, unit);
	else
		rmd_describe_real(t, style, rmd_field_key(fld), label, rmd_field_to_native(fs, raw),
				  RMD_DESCRIBE_DIGITS, unit);
}

void rmd_describe_fields(struct rmd_text *t, enum rmd_describe_style style, enum rmd_proto proto,
			 const struct rmd_layout *lay, const struct rmd_msg *msg)
{
	for (unsigned i = 0; i < lay->n; i++)
		if (rmd_msg_has(msg, (enum rmd_field)lay->f[i].field))
			field(t, style, proto, &lay->f[i], msg->v[lay->f[i].field]);
}

void rmd_describe_mit_cmd(struct rmd_text *t, enum rmd_describe_style style,
			  const struct rmd_mit_cmd *c, int digits)
{
	rmd_describe_real(t, style, "position_rad", "position", c->p_des_rad, digits, "rad");
	rmd_describe_real(t, style, "velocity_rad_s", "velocity", c->v_des_rad_s, digits, "rad/s");
	rmd_describe_real(t, style, "kp", "kp", c->kp, digits, "N·m/rad");
	rmd_describe_real(t, style, "kd", "kd", c->kd, digits, "N·m·s/rad");
	rmd_describe_real(t, style, "torque_nm", "torque", c->t_ff_nm, digits, "N·m");
}

void rmd_describe_mit_reply(struct rmd_text *t, enum rmd_describe_style style,
			    const struct rmd_mit_reply *r, int digits)
{
	rmd_describe_real(t, style, "position_rad", "position", r->pos_rad, digits, "rad");
	rmd_describe_real(t, style, "velocity_rad_s", "velocity", r->vel_rad_s, digits, "rad/s");
	rmd_describe_real(t, style, "torque_nm", "torque", r->torque_nm, digits, "N·m");
}

/* ---- one frame, key=value -------------------------------------------------------------- */

/* MIT values are 12..16-bit codes: 6 digits are all a reader needs. */
#define MIT_DIGITS 6

static bool describe_mit(struct rmd_text *t, enum rmd_dir dir, const struct rmd_mit_ranges *mit,
			 const struct rmd_frame *f)
{
	if (dir == RMD_DIR_REQUEST) {
		struct rmd_mit_cmd cmd;
		uint8_t id;

		if (rmd_mit_decode_cmd(mit, f, &id, &cmd) < 0)
			return false;
		rmd_text_add(t, "mit_command");
		rmd_describe_mit_cmd(t, RMD_DESCRIBE_KEYS, &cmd, MIT_DIGITS);
	} else {
		struct rmd_mit_reply rep;

		if (rmd_mit_decode_reply(mit, f, &rep) < 0)
			return false;
		rmd_text_add(t, "mit_reply");
		rmd_describe_mit_reply(t, RMD_DESCRIBE_KEYS, &rep, MIT_DIGITS);
	}
	return true;
}

int rmd_describe_frame(char *buf, size_t size, enum rmd_proto proto, enum rmd_dir dir,
		       const struct rmd_mit_ranges *mit, const struct rmd_frame *f)
{
	const struct rmd_dialect *d = rmd_dialect(proto);
	const struct rmd_cmd_spec *spec;
	struct rmd_text t;
	struct rmd_msg msg;
	enum rmd_dir used = dir;
	int r;

	rmd_text_init(&t, buf, size);
	if (d && rmd_dialect_has(d, RMD_DIALECT_MIT) && mit && describe_mit(&t, dir, mit, f))
		return 0;
	/* the rest in its firmware's table: MIT motors also speak V3 */
	proto = rmd_proto_table(proto);
	r = rmd_decode(proto, dir, f, &msg, &used);
	spec = r == 0 ? rmd_cmd_find(proto, msg.cmd) : NULL;
	if (spec) {
		rmd_text_add(&t, "%s", spec->name);
		rmd_describe_fields(&t, RMD_DESCRIBE_KEYS, proto, rmd_cmd_layout(spec, used), &msg);
		return 0;
	}
	if (r == 0)
		r = -ENOENT;
	if (r == -EBADMSG)
		rmd_text_add(&t, "(DLC %u: not a protocol frame)", f->len);
	else if (f->len >= 1)
		rmd_text_add(&t, "(command 0x%02X: not decoded)", f->data[0]);
	else
		rmd_text_add(&t, "(empty)");
	return r;
}
