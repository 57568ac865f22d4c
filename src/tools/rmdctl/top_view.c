// SPDX-License-Identifier: MIT
/*
 * What rmdctl top shows (top_view.h): the names and checks that its plain
 * table, its JSON (top.c) and its terminal screen (top_screen.c) share.
 * Non-rt.
 */
#include <inttypes.h>
#include <stdio.h>

#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/time.h"
#include "top_view.h"

const char *top_mode_name(int mode)
{
	return mode >= 0 && mode < RMD_MODE_COUNT ? rmd_mode_name((enum rmd_mode)mode) : "?";
}

const char *top_bus_state_name(int s)
{
	return s >= RMD_BUS_ACTIVE && s <= RMD_BUS_NO_ACK ?
		       rmd_bus_state_name((enum rmd_bus_state)s) :
		       "?";
}

/* The state's motor i, by index (state_t.motor[i] is motor i, but check). */
const char *top_instance_name(const struct top_view *v)
{
	if (v->cfg && v->cfg->instance_name && v->cfg->instance_name[0])
		return v->cfg->instance_name;
	if (v->health && v->health->instance_name && v->health->instance_name[0])
		return v->health->instance_name;
	return v->prefix;
}

const rmd_motor_state_t *top_motor_state(const struct top_view *v, int i)
{
	if (v->state && i < v->state->count && v->state->motor[i].index == i)
		return &v->state->motor[i];
	return NULL;
}

bool top_stale(const struct top_view *v)
{
	int64_t now = rmd_now_ns();

	return now - v->health_rx_ns > TOP_STALE_NS || now - v->state_rx_ns > TOP_STALE_NS;
}

bool top_silent(const struct top_view *v)
{
	return !v->health || rmd_now_ns() - v->health_rx_ns > TOP_STALE_NS;
}

void top_mixed_line(const struct top_view *v, char *buf, size_t len)
{
	snprintf(buf, len,
		 "MIXED: two rmdd on this prefix: shown instance %016" PRIx64
		 " (host %s, pid %d); also instance %016" PRIx64
		 " (host %s, pid %d%s%s); state_t mixes both: stop one, or give one another "
		 "lcm.channel_prefix",
		 (uint64_t)v->instance,
		 v->cfg	   ? v->cfg->host :
		 v->health ? v->health->host :
			     "?",
		 v->cfg	   ? (int)v->cfg->pid :
		 v->health ? (int)v->health->pid :
			     0,
		 (uint64_t)v->other_instance, v->other_host, (int)v->other_pid,
		 v->other_source[0] ? ", " : "", v->other_source);
}
