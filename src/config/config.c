// SPDX-License-Identifier: MIT
/*
 * rmdd's configuration model (rmd/config.h): defaults, the names a config
 * file spells, look-ups by name.  The YAML loader is config_yaml.c.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "rmd/err.h"
#include "rmd/config.h"

const char *const rmd_bus_kind_names[] = { "socketcan", "rs485", "sim", NULL };
const char *const rmd_proto_keys[] = { "v3", "v2", "mit", NULL };
const char *const rmd_mode_names[] = { "torque", "speed", "position", "mit", NULL };
const char *const rmd_units_names[] = { "output", "rotor", NULL };
const char *const rmd_safe_action_names[] = { "stop", "hold", "damp", "brake", NULL };
const char *const rmd_lost_action_names[] = { "motor", "all", NULL };
const char *const rmd_on_missing_names[] = { "refuse", "start", NULL };
_Static_assert(RMD_PROTO_V3 == 0 && RMD_PROTO_V2 == 1 && RMD_PROTO_MIT == 2,
	       "rmd_proto_keys[] follows enum rmd_proto");
_Static_assert(RMD_MODE_COUNT == 4, "rmd_mode_names[] follows enum rmd_mode");

void rmd_config_defaults(struct rmd_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	cfg->loop.rate_hz = RMD_CONFIG_DEFAULT_RATE_HZ;
	cfg->loop.rt_priority = RMD_CONFIG_DEFAULT_PRIORITY;
	cfg->safety.comm_loss_ms = RMD_CONFIG_DEFAULT_COMM_LOSS_MS;
	cfg->safety.missed_replies_lost = RMD_CONFIG_DEFAULT_MISSED_LOST;
	cfg->safety.command_timeout_ms = RMD_CONFIG_DEFAULT_COMMAND_TIMEOUT_MS;
	cfg->safety.safe_action = RMD_SAFE_DAMP;
	cfg->safety.lost_motor_action = RMD_LOST_ALL;
	cfg->probe.on_missing = RMD_MISSING_REFUSE;
	snprintf(cfg->lcm.url, sizeof(cfg->lcm.url), "%s", RMD_CONFIG_DEFAULT_LCM_URL);
	snprintf(cfg->lcm.channel_prefix, sizeof(cfg->lcm.channel_prefix), "%s",
		 RMD_CONFIG_DEFAULT_CHANNEL_PREFIX);
	cfg->lcm.state_every_n = 1;
	cfg->lcm.stale_ms = RMD_CONFIG_DEFAULT_STALE_MS;
	cfg->lcm.health_period_ms = RMD_CONFIG_DEFAULT_HEALTH_PERIOD_MS;
}

void rmd_config_bus_defaults(struct rmd_config_bus *b)
{
	memset(b, 0, sizeof(*b));
	b->bitrate = RMD_CONFIG_DEFAULT_BITRATE;
	b->baud = RMD_CONFIG_DEFAULT_BAUD;
	b->turnaround_ns = RMD_CONFIG_DEFAULT_RS485_TURNAROUND_NS;
}

void rmd_config_motor_defaults(struct rmd_config_motor *m)
{
	memset(m, 0, sizeof(*m));
	m->proto = RMD_PROTO_V3;
	m->mode = RMD_MODE_TORQUE;
	m->direction = 1;
	m->gear_ratio = 1.0;
	m->units = RMD_UNITS_OUTPUT;
	m->limits.position_min_rad = -INFINITY;
	m->limits.position_max_rad = INFINITY;
	m->limits.velocity_rad_s = INFINITY;
	m->limits.torque_nm = INFINITY;
	m->mit = rmd_mit_default_ranges;
	m->rate_divisor = 1;
	m->status_poll_hz = RMD_CONFIG_DEFAULT_STATUS_POLL_HZ;
	m->comm_loss_ms = RMD_CONFIG_COMM_LOSS_INHERIT;
}

int rmd_config_bus_find(const struct rmd_config *cfg, const char *name)
{
	for (unsigned i = 0; i < cfg->n_buses; i++)
		if (!strcmp(cfg->buses[i].name, name))
			return (int)i;
	return -ENOENT;
}

int rmd_config_motor_find(const struct rmd_config *cfg, const char *name)
{
	for (unsigned i = 0; i < cfg->n_motors; i++)
		if (!strcmp(cfg->motors[i].name, name))
			return (int)i;
	return -ENOENT;
}

const char *rmd_bus_kind_name(enum rmd_bus_kind kind)
{
	return (unsigned)kind < 3 ? rmd_bus_kind_names[kind] : "?";
}

const char *rmd_proto_key(enum rmd_proto proto)
{
	return (unsigned)proto < 3 ? rmd_proto_keys[proto] : "?";
}

const char *rmd_mode_name(enum rmd_mode mode)
{
	return (unsigned)mode < RMD_MODE_COUNT ? rmd_mode_names[mode] : "?";
}

const char *rmd_safe_action_name(enum rmd_safe_action action)
{
	return (unsigned)action < 4 ? rmd_safe_action_names[action] : "?";
}
