// SPDX-License-Identifier: MIT
/*
 * rmdctl's device commands' output: fields gathered from several answers of
 * a motor (struct rec), printed as "key: value" lines or one JSON object
 * per motor with the keys of `rmdctl decode`.  Non-rt.
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/describe.h"
#include "rmdctl.h"

#define MAX_ERROR_NAMES 16
#define FIELD_DIGITS 15

/* ---- gathered fields ------------------------------------------------------------------ */

bool rmdctl_rec_has(const struct rec *r, enum rmd_field f)
{
	return (r->present >> f) & 1;
}

double rmdctl_rec_val(const struct rec *r, enum rmd_field f)
{
	if ((r->is_float >> f) & 1) {
		uint32_t u = (uint32_t)r->raw[f];
		float x;

		memcpy(&x, &u, sizeof(x));
		return x;
	}
	return (double)r->raw[f] * r->scale[f];
}

void rmdctl_rec_set(struct rec *r, enum rmd_field f, const struct rmd_field_spec *fs, int64_t raw)
{
	r->present |= UINT64_C(1) << f;
	r->raw[f] = raw;
	r->scale[f] = fs->is_float ? 1.0 : fs->scale;
	if (fs->is_float)
		r->is_float |= UINT64_C(1) << f;
	else
		r->is_float &= ~(UINT64_C(1) << f);
}

/* Fold the fields of an answer into r; keep what r has unless overwrite. */
void rmdctl_rec_add(struct rec *r, const struct rmd_cmd_spec *spec, const struct rmd_msg *m,
		    bool overwrite)
{
	const struct rmd_layout *l = rmd_cmd_layout(spec, RMD_DIR_REPLY);

	for (unsigned i = 0; i < l->n; i++) {
		enum rmd_field f = (enum rmd_field)l->f[i].field;

		if (!rmd_msg_has(m, f) || (rmdctl_rec_has(r, f) && !overwrite))
			continue;
		rmdctl_rec_set(r, f, &l->f[i], m->v[f]);
	}
}

void rmdctl_rec_add_gains(struct rec *r, const struct dev *d, const struct rmd_pid_set *g)
{
	const struct rmd_dialect *dl = rmdctl_dialect(d);

	for (unsigned k = 0; k < dl->n_pid_slots && k < RMD_PID_SLOTS_MAX; k++) {
		const struct rmd_field_spec *fs = rmd_pid_spec(dl, k);

		if (fs && (g->slots >> k) & 1)
			rmdctl_rec_set(r, (enum rmd_field)dl->pid_slots[k].field, fs, g->raw[k]);
	}
}

void rmdctl_rec_add_req(struct rec *r, const struct dev *d, const struct req *q, bool overwrite)
{
	const struct rmd_cmd_spec *spec = rmdctl_spec(d, q->msg.cmd);

	if (q->ok && spec)
		rmdctl_rec_add(r, spec, &q->rep, overwrite);
}

/* A JSON string on f, escaped by the describer's one escaper (short strings: names). */
static void json_str(FILE *f, const char *s)
{
	char buf[512];
	struct rmd_text t;

	rmd_text_init(&t, buf, sizeof(buf));
	rmd_text_json_str(&t, s, strlen(s));
	fputs(buf, f);
}

void rmdctl_json_str(const char *s)
{
	json_str(stdout, s);
}

/* ---- output --------------------------------------------------------------------------- */

const char *rmdctl_errors_text(const struct dev *d, int64_t raw, char *buf, size_t size)
{
	const char *names[MAX_ERROR_NAMES];
	size_t n = rmd_error_names(d->proto, (uint16_t)raw, names, MAX_ERROR_NAMES), o;

	if (raw == 0) {
		snprintf(buf, size, "none");
		return buf;
	}
	o = (size_t)snprintf(buf, size, "0x%04X", (unsigned)(uint16_t)raw);
	for (size_t i = 0; i < n && i < MAX_ERROR_NAMES && o < size; i++)
		o += (size_t)snprintf(buf + o, size - o, "%s%s", i ? "," : " ", names[i]);
	return buf;
}

/* A field's value as text (no unit) for tables and "key: value" lines. */
const char *rmdctl_field_text(const struct dev *d, const struct rec *r, enum rmd_field f, char *buf,
			      size_t size)
{
	if (!rmdctl_rec_has(r, f)) {
		snprintf(buf, size, "-");
		return buf;
	}
	if (f == RMD_FLD_ERROR)
		return rmdctl_errors_text(d, r->raw[f], buf, size);
	if (f == RMD_FLD_MODEL) {
		char m[8];

		rmd_model_string(r->raw[f], m);
		m[sizeof(m) - 1] = '\0';
		snprintf(buf, size, "%s", m);
		return buf;
	}
	if (f == RMD_FLD_BRAKE) {
		snprintf(buf, size, "%s", r->raw[f] ? "released" : "locked");
		return buf;
	}
	if (f == RMD_FLD_MODE) {
		const char *name = rmd_run_mode_name(d->proto, (uint8_t)r->raw[f]);

		snprintf(buf, size, "%" PRId64 "%s%s%s", r->raw[f], name ? " (" : "",
			 name ? name : "", name ? ")" : "");
		return buf;
	}
	if ((r->is_float >> f) & 1) /* binary32: 9 digits give it back exactly */
		snprintf(buf, size, "%.9g", rmdctl_rec_val(r, f));
	else if (r->scale[f] == 1.0)
		snprintf(buf, size, "%" PRId64, r->raw[f]);
	else
		rmd_fmt_real(buf, size, rmdctl_rec_val(r, f), FIELD_DIGITS);
	return buf;
}

/* ,"key":value for one field; null when it is missing. */
void rmdctl_json_field(const struct dev *d, const struct rec *r, enum rmd_field f)
{
	char buf[64];

	printf(",\"%s\":", rmd_field_key(f));
	if (!rmdctl_rec_has(r, f)) {
		fputs("null", stdout);
		if (f == RMD_FLD_ERROR)
			fputs(",\"errors\":null", stdout);
		if (f == RMD_FLD_MODE)
			fputs(",\"mode_name\":null", stdout);
		return;
	}
	if (f == RMD_FLD_ERROR) {
		const char *names[MAX_ERROR_NAMES];
		size_t n = rmd_error_names(d->proto, (uint16_t)r->raw[f], names, MAX_ERROR_NAMES);

		printf("%" PRId64 ",\"errors\":[", r->raw[f]);
		for (size_t i = 0; i < n && i < MAX_ERROR_NAMES; i++) {
			if (i)
				fputc(',', stdout);
			json_str(stdout, names[i]);
		}
		fputc(']', stdout);
	} else if (f == RMD_FLD_MODEL) {
		json_str(stdout, rmdctl_field_text(d, r, f, buf, sizeof(buf)));
	} else if (f == RMD_FLD_BRAKE) {
		fputs(r->raw[f] ? "true" : "false", stdout);
	} else if (f == RMD_FLD_MODE) {
		const char *name = rmd_run_mode_name(d->proto, (uint8_t)r->raw[f]);

		printf("%" PRId64 ",\"mode_name\":", r->raw[f]);
		if (name)
			json_str(stdout, name);
		else
			fputs("null", stdout);
	} else {
		fputs(rmdctl_field_text(d, r, f, buf, sizeof(buf)), stdout);
	}
}

void rmdctl_json_begin(const struct dev *d, uint8_t id)
{
	fputs("{\"bus\":", stdout);
	json_str(stdout, d->name);
	/* the key, as rmdd.yaml and --protocol spell it */
	printf(",\"motor_id\":%u,\"protocol\":\"%s\"", id, rmd_proto_key(d->proto));
}

const struct rmd_dialect *rmdctl_rec_dialect(const struct dev *d, const struct rec *r,
					     bool *certain)
{
	*certain = false;
	if (!(r->present & (UINT64_C(1) << RMD_FLD_VERSION)) ||
	    !rmd_dialect_has(rmdctl_dialect(d), RMD_DIALECT_VERSION_B2))
		return NULL;
	return rmd_dialect_for_firmware((uint32_t)r->raw[RMD_FLD_VERSION], certain);
}

/* ,"dialect":"v4","dialect_certain":true: what r's firmware date says, when it has one. */
static void json_dialect(const struct dev *d, const struct rec *r)
{
	bool certain;
	const struct rmd_dialect *fw = rmdctl_rec_dialect(d, r, &certain);

	if (fw)
		printf(",\"dialect\":\"%s\",\"dialect_certain\":%s", fw->key,
		       certain ? "true" : "false");
}

/* "  label:   value unit" */
static void text_field(const struct dev *d, const struct rec *r, enum rmd_field f)
{
	char label[40], buf[128];
	const char *unit;

	rmd_field_label(f, label, sizeof(label), &unit);
	if (f == RMD_FLD_ERROR)
		snprintf(label, sizeof(label), "errors");
	else if (f == RMD_FLD_BRAKE)
		snprintf(label, sizeof(label), "brake");
	else if (f == RMD_FLD_VERSION)
		snprintf(label, sizeof(label), "firmware date");
	rmdctl_field_text(d, r, f, buf, sizeof(buf));
	printf("  %-16s %s%s%s\n", label, buf, rmdctl_rec_has(r, f) && *unit ? " " : "",
	       rmdctl_rec_has(r, f) ? unit : "");
}

/* One motor: a JSON line, or a header and one line per field. */
void rmdctl_print_rec(const struct dev *d, uint8_t id, const struct rec *r,
		      const enum rmd_field *order, size_t n)
{
	bool certain;
	const struct rmd_dialect *fw = rmdctl_rec_dialect(d, r, &certain);

	if (d->json) {
		rmdctl_json_begin(d, id);
		json_dialect(d, r);
		for (size_t i = 0; i < n; i++)
			rmdctl_json_field(d, r, order[i]);
		fputs("}\n", stdout);
		return;
	}
	printf("%s motor %u (%s", d->name, id, rmd_proto_key(d->proto));
	if (fw &&
	    rmd_dialect_other_firmware(rmdctl_dialect(d), (uint32_t)r->raw[RMD_FLD_VERSION], &fw))
		printf("; its firmware date says %s: --protocol %s", fw->key, fw->key);
	else if (fw && !certain)
		printf("; its firmware date tells no generation");
	printf(")\n");
	for (size_t i = 0; i < n; i++)
		text_field(d, r, order[i]);
}
