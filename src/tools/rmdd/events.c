// SPDX-License-Identifier: MIT
/*
 * What rmdd says of the rt loop's events (rmd/state.h enum rmd_event_kind),
 * and the names its monitor (monitor.c) and incident writer (incidents.c)
 * both word them with: a motor's context, a bus's name, a lifecycle's, a
 * reboot check's report.  Both call down into this file; it calls neither.
 * Everything here is non-rt.
 */
#include <inttypes.h>
#include <stdio.h>

#include "rmdd.h"
#include "tools/common/names.h"

const char *rmdd_lifecycle_name(unsigned lc)
{
	return tool_lifecycle_name(lc);
}

void rmdd_motor_ctx(const struct rmd_config *cfg, unsigned i, char *buf, size_t len)
{
	const struct rmd_config_motor *c;

	if (i >= cfg->n_motors) {
		snprintf(buf, len, "motor #%u", i);
		return;
	}
	c = &cfg->motors[i];
	snprintf(buf, len, "%s: motor %u (%s)",
		 c->bus < cfg->n_buses ? cfg->buses[c->bus].name : "?", c->id, c->name);
}

const char *rmdd_bus_name(const struct rmd_config *cfg, unsigned b)
{
	return b < cfg->n_buses ? cfg->buses[b].name : "?";
}

/* An event's b of int32 of 0.01 deg, high and low half, in degrees. */
static double cdeg_hi(int64_t b)
{
	return (double)(int32_t)(uint32_t)((uint64_t)b >> 32) / 100.0;
}

static double cdeg_lo(int64_t b)
{
	return (double)(int32_t)(uint32_t)b / 100.0;
}

void rmdd_reboot_text(const struct rmd_event *e, char *buf, size_t len)
{
	switch ((enum rmd_reboot_report)e->a) {
	case RMD_REBOOT_BY_RUNTIME:
		snprintf(buf, len,
			 "rebooted (runtime %" PRIu32 " ms, it would have run at least %" PRIu32
			 " ms: 0xB1)",
			 (uint32_t)((uint64_t)e->b >> 32), (uint32_t)e->b);
		break;
	case RMD_REBOOT_BY_TURNS:
		snprintf(buf, len,
			 "rebooted (its multi-turn angle %.2f deg, rmdd's count of its encoder "
			 "%.2f deg: its count lost, 0x92)",
			 cdeg_hi(e->b), cdeg_lo(e->b));
		break;
	case RMD_REBOOT_BY_BRAKE:
		snprintf(buf, len,
			 "rebooted (its brake locked after it reported it released: 0x9A)");
		break;
	case RMD_REBOOT_NO_CHECK:
		snprintf(buf, len,
			 "does not answer 0x%02" PRIX64
			 ": a short power cycle is seen only by its brake (0x9A) from now on",
			 (uint64_t)e->b);
		break;
	case RMD_REBOOT_UNTOLD:
		snprintf(buf, len,
			 "whether it rebooted is untold: its answers to 0x%02" PRIX64
			 " could not tell",
			 (uint64_t)e->b);
		break;
	default:
		snprintf(buf, len, "reboot check %" PRId64, e->a);
		break;
	}
}
