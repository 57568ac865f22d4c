// SPDX-License-Identifier: MIT
/*
 * The LCM bridge's options from rmdd's configuration: URL, channel prefix,
 * periods, and what the bridge checks commands against (each motor's
 * modes, limits and MIT gain ranges, from the loop's motor records by
 * rmd_motor_info()).  Non-rt.
 */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <sys/random.h>

#include "rmd/channels.h"
#include "rmd/time.h"
#include "rmd_version.h"
#include "rmdd.h"

/* The bridge's messages, as rmdd's own; whatever -q says, as before. */
static void bridge_log(void *ctx, int level, const char *msg)
{
	(void)ctx;
	tool_log_always(level, "%s", msg);
}

void rmdd_lcm_opts(struct rmd_bridge_opts *o, const struct rmd_config *cfg,
		   const struct rmd_plan *plan, const struct rmd_loop *loop,
		   struct rmd_latest *commands, struct rmd_latest *snapshots,
		   struct rmd_latest *health)
{
	rmd_bridge_opts_init(o);
	snprintf(o->url, sizeof(o->url), "%s", cfg->lcm.url);
	snprintf(o->prefix, sizeof(o->prefix), "%s", cfg->lcm.channel_prefix);
	snprintf(o->version, sizeof(o->version), "%s", RMD_VERSION);
	/* which daemon this is: random, so a restart on the same pid is another one */
	while (!o->instance)
		if (getrandom(&o->instance, sizeof(o->instance), 0) != sizeof(o->instance))
			o->instance = (int64_t)rmd_now_ns() ^ ((int64_t)getpid() << 32);
	if (gethostname(o->host, sizeof(o->host)) < 0)
		snprintf(o->host, sizeof(o->host), "?");
	o->host[sizeof(o->host) - 1] = '\0';
	o->pid = (int32_t)getpid();
	snprintf(o->source, sizeof(o->source), "%s", cfg->source);
	o->nmotors = cfg->n_motors;
	for (unsigned i = 0; i < cfg->n_motors && i < RMD_MAX_MOTORS; i++) {
		rmd_motor_info(rmd_loop_motor(loop, i), plan->motor[i].batched, &o->motor[i]);
		o->motor[i].pos_rate_hz = plan->motor[i].pos_hz;
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
	o->command_timeout_ms = (int)cfg->safety.command_timeout_ms;
	o->robot = cfg->robot; /* instance "": alone, as before (docs/robot.md) */
	if (cfg->lcm.health_period_ms)
		o->health_period_ns = (int64_t)cfg->lcm.health_period_ms * 1000000;
	/* one below the loop unless configured: never holds the loop off */
	o->rt_priority = cfg->lcm.rt_priority == RMD_CONFIG_LCM_PRIO_AUTO ?
				 cfg->loop.rt_priority - 1 :
				 cfg->lcm.rt_priority;
	o->commands = commands;
	o->snapshots = snapshots;
	o->health = health;
	o->log = bridge_log;
	o->log_ctx = NULL;
}

void rmdd_robot_note(const struct rmd_config *cfg, char *buf, size_t len)
{
	const struct rmd_config_robot *r = &cfg->robot;
	size_t n;

	buf[0] = '\0';
	if (!r->instance[0])
		return;
	n = (size_t)snprintf(buf, len, "robot: instance %s, peers", r->instance);
	for (unsigned i = 0; i < r->n_peers && n < len; i++)
		n += (size_t)snprintf(buf + n, len - n, "%s %s", i ? "," : "", r->peers[i]);
	if (n < len)
		snprintf(buf + n, len - n,
			 "%s; a heartbeat every %u ms on " RMD_CHANNEL_ROBOT_HEARTBEAT
			 ", a peer silent %u ms is lost: %s; " RMD_CHANNEL_ROBOT_STOP
			 " stops every driven motor (docs/robot.md)",
			 r->n_peers ? "" : " none", r->heartbeat_ms, r->peer_timeout_ms,
			 r->on_peer_lost == RMD_PEER_LOST_SAFE ? "the safe action" :
								 "reported only");
}

/* What the bridge's threads were granted, at info level: refused, commands wait longer. */
void rmdd_lcm_started(struct rmd_bridge *b)
{
	const struct rmd_bridge_opts *o = rmd_bridge_get_opts(b);
	struct rmd_bridge_stats st;

	rmd_bridge_get_stats(b, &st);
	if (st.rt_error)
		tool_log(6,
			 "LCM bridge: SCHED_FIFO %u refused (%s): commands wait for "
			 "normal-priority wake-ups (docs/design.md, Threads)",
			 o->rt_priority, strerror(-st.rt_error));
}

/* The bridge rejected a controller that does not own the motors: an incident. */
static void bridge_intruder(void *ctx, int64_t when_ns, int64_t controller, int64_t owner)
{
	char what[160];

	snprintf(what, sizeof(what),
		 "controller %016" PRIx64
		 " rejected: the motors are owned by controller %016" PRIx64,
		 (uint64_t)controller, (uint64_t)owner);
	rmdd_incidents_trigger(ctx, when_ns, "intruder", what, true);
}

void rmdd_lcm_incidents(struct rmd_bridge_opts *o, struct rmdd_incidents *in)
{
	o->on_intruder = in ? bridge_intruder : NULL;
	o->intruder_ctx = in;
}

int rmdd_lcm_alone(struct rmd_bridge *b, bool force)
{
	const struct rmd_bridge_opts *o = rmd_bridge_get_opts(b);
	struct rmd_bridge_peer p;
	char who[400];
	int r = rmd_bridge_probe(b, RMD_BRIDGE_PROBE_NS, &p);

	if (r < 0) {
		tool_log(4, "LCM: could not look for another rmdd on %s* (%s); starting", o->prefix,
			 strerror(-r));
		return 0;
	}
	tool_log(7, "LCM: instance %016" PRIx64 " on host %s, pid %d", (uint64_t)o->instance,
		 o->host, (int)o->pid);
	if (r == 0)
		return 0;
	if (p.instance)
		snprintf(who, sizeof(who), "instance %016" PRIx64 " on host %s, pid %d%s%s",
			 (uint64_t)p.instance, p.host, (int)p.pid,
			 p.source[0] ? ", configuration " : "", p.source);
	else
		snprintf(who, sizeof(who), "its state_t names no instance: an older rmdd?");
	if (force) {
		tool_log(4,
			 "another rmdd publishes on %s* of %s (%s); starting anyway (--force): "
			 "controllers on this prefix will see both daemons and drive both",
			 o->prefix, o->url, who);
		return 0;
	}
	tool_log(3,
		 "another rmdd publishes on %s* of %s (%s); two daemons on one prefix take the "
		 "same controller's commands. Give this one another lcm.channel_prefix, stop "
		 "the other, or start with --force",
		 o->prefix, o->url, who);
	return -EEXIST;
}
