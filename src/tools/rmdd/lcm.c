// SPDX-License-Identifier: MIT
/*
 * The LCM bridge's options from rmdd's configuration: URL, channel prefix,
 * periods, and what the bridge checks commands against (each motor's
 * modes, limits and MIT gain ranges).  Non-rt.
 */
#include <stdio.h>
#include <string.h>

#include "rmdd.h"

/* The bridge and the loop speak rmd_mode; the configuration rmd_ctrl_mode: one numbering. */
_Static_assert((int)RMD_MODE_TORQUE == (int)RMD_CTRL_TORQUE &&
		       (int)RMD_MODE_SPEED == (int)RMD_CTRL_SPEED &&
		       (int)RMD_MODE_POSITION == (int)RMD_CTRL_POSITION &&
		       (int)RMD_MODE_MIT == (int)RMD_CTRL_MIT,
	       "enum rmd_mode and enum rmd_ctrl_mode disagree");

/*
 * The modes a motor can be commanded in (rmd/motor.h): MIT only on an MIT
 * motor; torque only with a torque constant; a motor in a V2 0x280 frame
 * takes torques only (the frame carries nothing else).
 */
static unsigned motor_modes(const struct rmd_config_motor *c, const struct rmd_plan_motor *pm)
{
	unsigned modes = 0;

	if (c->torque_constant_nm_a > 0)
		modes |= RMD_BRIDGE_MODE_BIT(RMD_MODE_TORQUE);
	if (pm->batched)
		return modes;
	modes |= RMD_BRIDGE_MODE_BIT(RMD_MODE_SPEED) | RMD_BRIDGE_MODE_BIT(RMD_MODE_POSITION);
	if (c->proto == RMD_PROTO_MIT)
		modes |= RMD_BRIDGE_MODE_BIT(RMD_MODE_MIT);
	return modes;
}

void rmdd_lcm_opts(struct rmd_bridge_opts *o, const struct rmd_config *cfg,
		   const struct rmd_plan *plan, struct rmd_latest *commands,
		   struct rmd_latest *snapshots, struct rmd_latest *health)
{
	rmd_bridge_opts_init(o);
	snprintf(o->url, sizeof(o->url), "%s", cfg->lcm.url);
	snprintf(o->prefix, sizeof(o->prefix), "%s", cfg->lcm.channel_prefix);
	o->nmotors = cfg->n_motors;
	for (unsigned i = 0; i < cfg->n_motors && i < RMD_MAX_MOTORS; i++) {
		const struct rmd_config_motor *c = &cfg->motors[i];
		struct rmd_bridge_motor *m = &o->motor[i];
		bool mit = c->proto == RMD_PROTO_MIT;

		snprintf(m->name, sizeof(m->name), "%s", c->name);
		m->bus = (uint8_t)c->bus;
		m->id = c->id;
		snprintf(m->protocol, sizeof(m->protocol), "%s", rmd_proto_key(c->proto));
		m->modes = (uint8_t)motor_modes(c, &plan->motor[i]);
		m->pos_min_rad = c->limits.position_min_rad;
		m->pos_max_rad = c->limits.position_max_rad;
		m->vel_max_rad_s = c->limits.velocity_rad_s;
		m->torque_max_nm = c->limits.torque_nm;
		/* gains matter to MIT commands only; other motors get an empty range */
		m->kp_min = mit ? c->mit.kp_min : 0;
		m->kp_max = mit ? c->mit.kp_max : 0;
		m->kd_min = mit ? c->mit.kd_min : 0;
		m->kd_max = mit ? c->mit.kd_max : 0;
	}
	o->nbuses = cfg->n_buses;
	for (unsigned b = 0; b < cfg->n_buses && b < RMD_MAX_BUSES; b++) {
		const struct rmd_config_bus *cb = &cfg->buses[b];
		struct rmd_bridge_bus *bb = &o->bus[b];

		snprintf(bb->name, sizeof(bb->name), "%s", cb->name);
		snprintf(bb->kind, sizeof(bb->kind), "%s", rmd_bus_kind_name(cb->kind));
		bb->bitrate = plan->bus[b].bitrate; /* RS485: its baud */
	}
	o->period_ns = plan->period_ns;
	o->state_every = cfg->lcm.state_every_n;
	o->stale_ms = (int)cfg->lcm.stale_ms;
	if (cfg->lcm.health_period_ms)
		o->health_period_ns = (int64_t)cfg->lcm.health_period_ms * 1000000;
	o->commands = commands;
	o->snapshots = snapshots;
	o->health = health;
	o->log = stderr;
}
