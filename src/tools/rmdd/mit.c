// SPDX-License-Identifier: MIT
/*
 * A motor's MIT scaling in words (rmd/dialect.h rmd_mit_scaling_decide()):
 * what the bring-up report and the monitor say of a motor in MIT mode --
 * the ranges chosen and why, or why MIT is refused and what to write.
 * docs/protocol-v4.md "MIT scaling".  Non-rt.
 */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/dialect.h"
#include "rmd/mit.h"
#include "rmdd.h"

/* buf[*n..] += the formatted text, never past len. */
__attribute__((format(printf, 4, 5))) static void add(char *buf, size_t len, size_t *n,
						      const char *fmt, ...)
{
	va_list ap;
	int k;

	if (*n + 1 >= len)
		return;
	va_start(ap, fmt);
	k = vsnprintf(buf + *n, len - *n, fmt, ap);
	va_end(ap);
	if (k > 0)
		*n += (size_t)k;
	if (*n >= len)
		*n = len - 1;
}

/* One range: "±12.5" when symmetric, "0..500" or "-1..2" otherwise. */
static void range(char *buf, size_t len, size_t *n, const char *name, double lo, double hi,
		  const char *unit)
{
	if (lo == -hi)
		add(buf, len, n, "%s ±%g%s", name, hi, unit);
	else
		add(buf, len, n, "%s %g..%g%s", name, lo, hi, unit);
}

void rmdd_mit_ranges_text(const struct rmd_mit_ranges *r, char *buf, size_t len)
{
	size_t n = 0;

	buf[0] = '\0';
	range(buf, len, &n, "p", r->p_min, r->p_max, " rad");
	range(buf, len, &n, ", v", r->v_min, r->v_max, " rad/s");
	range(buf, len, &n, ", t", r->t_min, r->t_max, " N·m");
	range(buf, len, &n, ", kp", r->kp_min, r->kp_max, "");
	range(buf, len, &n, ", kd", r->kd_min, r->kd_max, "");
}

/* The bounds of mask as "p_min, t_max, ...". */
static void bounds(char *buf, size_t len, size_t *n, unsigned mask)
{
	for (unsigned k = 0, first = 1; k < RMD_MIT_BOUNDS; k++)
		if (mask & RMD_MIT_BOUND(k)) {
			add(buf, len, n, "%s%s", first ? "" : ", ", rmd_mit_bound_key(k));
			first = 0;
		}
}

/* The firmware date from which the scaling of fw's motors goes by model (0: never). */
static uint32_t by_model_since(const struct rmd_dialect *fw)
{
	uint32_t since = 0;

	for (unsigned k = 0; k < fw->n_mit_scaling; k++)
		if (fw->mit_scaling[k].series && fw->mit_scaling[k].since > since)
			since = fw->mit_scaling[k].since;
	return since;
}

/* The series rmdd knows from `since` on: "X6, X8". */
static void known_series(char *buf, size_t len, size_t *n, const struct rmd_dialect *fw,
			 uint32_t since)
{
	for (unsigned k = 0, first = 1; k < fw->n_mit_scaling; k++)
		if (fw->mit_scaling[k].series && fw->mit_scaling[k].since == since) {
			add(buf, len, n, "%sX%u", first ? "" : ", ", fw->mit_scaling[k].series);
			first = 0;
		}
}

/* "firmware 2026042402, model X6S2V3" (or what is not known of them). */
static void facts(char *buf, size_t len, size_t *n, uint32_t version, const char *model)
{
	if (version)
		add(buf, len, n, "firmware %u", (unsigned)version);
	else
		add(buf, len, n, "no firmware date (no answer to 0xB2)");
	if (model && model[0])
		add(buf, len, n, ", model %s", model);
	else
		add(buf, len, n, ", no model (no answer to 0xB5)");
}

void rmdd_mit_text(const struct rmd_dialect *d, const struct rmd_mit_decision *dec,
		   uint32_t version, const char *model, char *buf, size_t len)
{
	const struct rmd_dialect *fw = rmd_dialect_firmware(d);
	uint32_t since = by_model_since(fw);
	char r[160];
	size_t n = 0;

	buf[0] = '\0';
	rmdd_mit_ranges_text(&dec->r, r, sizeof(r));
	switch (dec->source) {
	case RMD_MIT_FROM_PRESET:
		add(buf, len, &n, "MIT scaling %s: the %s preset (no mit ranges in its entry", r,
		    dec->row->source);
		if (since)
			add(buf, len, &n, "; firmware before %u", (unsigned)since);
		add(buf, len, &n, ")");
		break;
	case RMD_MIT_FROM_ENTRY:
		add(buf, len, &n, "MIT scaling %s: its entry's mit ranges", r);
		if (dec->row) {
			add(buf, len, &n, " over the %s preset", dec->row->source);
			break;
		}
		add(buf, len, &n, ", all ten given (rmdd knows no scaling of its firmware: ");
		facts(buf, len, &n, version, model);
		add(buf, len, &n, ")");
		break;
	case RMD_MIT_FROM_FIRMWARE:
		add(buf, len, &n, "MIT scaling %s: its firmware's own (%s, from firmware %u)", r,
		    dec->row->source, (unsigned)dec->row->since);
		if (dec->overrides) {
			add(buf, len, &n, "; ");
			bounds(buf, len, &n, dec->overrides);
			add(buf, len, &n,
			    " from its entry, where the public sources disagree "
			    "(docs/protocol-v4.md)");
		}
		break;
	case RMD_MIT_NO_MIT:
		add(buf, len, &n,
		    "MIT refused: %s firmware has no MIT mode (mode mit is for v3 and v4)",
		    fw->name);
		break;
	case RMD_MIT_NO_DATE:
	case RMD_MIT_NO_MODEL:
		add(buf, len, &n, "MIT refused, its scaling unknown: ");
		facts(buf, len, &n, version, model);
		if (dec->source == RMD_MIT_NO_DATE && since)
			add(buf, len, &n, "; firmware from %u scales MIT by model",
			    (unsigned)since);
		else if (dec->source == RMD_MIT_NO_DATE)
			add(buf, len, &n, "; MIT scaling goes by firmware date");
		if (dec->source == RMD_MIT_NO_MODEL) {
			add(buf, len, &n,
			    "; from %u %s firmware scales MIT by model and rmdd knows ",
			    (unsigned)since, fw->name);
			known_series(buf, len, &n, fw, since);
			add(buf, len, &n, " only");
		}
		add(buf, len, &n,
		    ": give its entry all ten mit ranges as its firmware scales them (missing: ");
		bounds(buf, len, &n, dec->missing);
		add(buf, len, &n, ")");
		break;
	case RMD_MIT_CONTRADICTS: {
		unsigned k = dec->bound;
		double fw_v = rmd_mit_bound(&dec->row->r, k);

		add(buf, len, &n,
		    "MIT refused: its entry's mit %s %g contradicts its firmware's %g (%s, from "
		    "firmware %u; this one: ",
		    rmd_mit_bound_key(k), dec->entry_value, fw_v, dec->row->source,
		    (unsigned)dec->row->since);
		facts(buf, len, &n, version, model);
		add(buf, len, &n, "): set %s: %g or leave it out", rmd_mit_bound_key(k), fw_v);
		break;
	}
	}
}

void rmdd_mit_config_note(const struct rmd_config *cfg, unsigned i, char *buf, size_t len)
{
	const struct rmd_config_motor *c = &cfg->motors[i];
	const struct rmd_dialect *fw = rmd_dialect_firmware(rmd_dialect(c->proto));
	uint32_t later = 0;
	size_t n = 0;
	char r[160];

	/* protocol: auto may find any firmware: the one whose scaling goes by date says most */
	if (c->proto_auto) {
		size_t nd;
		const struct rmd_dialect *list = rmd_dialect_list(&nd);

		for (size_t k = 0; k < nd; k++)
			if (rmd_dialect_is_firmware(&list[k]) && rmd_dialect_offers_mit(&list[k]) &&
			    list[k].n_mit_scaling > fw->n_mit_scaling)
				fw = &list[k];
	}
	for (unsigned k = 0; k < fw->n_mit_scaling; k++)
		if (fw->mit_scaling[k].since && (!later || fw->mit_scaling[k].since < later))
			later = fw->mit_scaling[k].since;

	buf[0] = '\0';
	add(buf, len, &n, "%s: ", c->name);
	if (c->mit_given == RMD_MIT_BOUNDS_ALL) {
		rmdd_mit_ranges_text(&c->mit, r, sizeof(r));
		add(buf, len, &n, "its entry's mit ranges (%s)", r);
	} else if (c->mit_given) {
		add(buf, len, &n, "its entry's mit ");
		bounds(buf, len, &n, c->mit_given);
	} else {
		add(buf, len, &n, "no mit ranges in its entry");
	}
	/* what each row of its firmware's table would make of them */
	for (unsigned k = 0; k < fw->n_mit_scaling; k++) {
		const struct rmd_mit_scaling *row = &fw->mit_scaling[k];

		rmdd_mit_ranges_text(&row->r, r, sizeof(r));
		if (row->kind == RMD_MIT_ROW_PRESET && later)
			add(buf, len, &n, "; %s%s firmware before %u: %s%s",
			    c->proto_auto ? "v3 firmware, and " : "", fw->key, (unsigned)later,
			    c->mit_given ? "over the preset " : "the preset ", r);
		else if (row->kind == RMD_MIT_ROW_PRESET)
			add(buf, len, &n, "; %s firmware: %s%s", fw->key,
			    c->mit_given ? "over the preset " : "the preset ", r);
		else
			add(buf, len, &n, "; from firmware %u, X%u: %s, %s", (unsigned)row->since,
			    row->series, r,
			    c->mit_given ? "the entry must agree" : "the firmware's");
	}
	if (rmd_dialect_mit_dated(fw) || c->proto_auto)
		add(buf, len, &n, "; %s",
		    c->mit_given == RMD_MIT_BOUNDS_ALL ?
			    "other models of such firmware: the entry's" :
			    "other models of such firmware, or no firmware date: refused at "
			    "bring-up");
	else if (c->mit_given != RMD_MIT_BOUNDS_ALL)
		add(buf, len, &n, "; no firmware date: refused at bring-up");
}
