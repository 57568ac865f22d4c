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
		add(buf, len, &n, "MIT scaling %s: the %s preset for ", r, dec->row->source);
		facts(buf, len, &n, version, model);
		add(buf, len, &n, " (no mit ranges in its entry)");
		break;
	case RMD_MIT_FROM_ENTRY:
		add(buf, len, &n, "MIT scaling %s: its entry's mit ranges", r);
		if (dec->row)
			add(buf, len, &n, " over the %s preset", dec->row->source);
		else
			add(buf, len, &n,
			    ", all ten given (rmdd knows no scaling of this firmware)");
		add(buf, len, &n, ", for ");
		facts(buf, len, &n, version, model);
		break;
	case RMD_MIT_FROM_FIRMWARE:
		add(buf, len, &n, "MIT scaling %s: its firmware's own, %s, for ", r,
		    dec->row->source);
		facts(buf, len, &n, version, model);
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
		    "MIT refused: its entry's mit %s %g contradicts its firmware's %g (%s; ",
		    rmd_mit_bound_key(k), dec->entry_value, fw_v, dec->row->source);
		facts(buf, len, &n, version, model);
		add(buf, len, &n, "): set %s: %g or leave it out", rmd_mit_bound_key(k), fw_v);
		break;
	}
	}
}
