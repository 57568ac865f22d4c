// SPDX-License-Identifier: MIT
/*
 * The bridge as one part of a robot (docs/robot.md): its heartbeat out on
 * RMD_ROBOT_HEARTBEAT, the peers' heartbeats in (judged by rmd/peers.h),
 * robot_stop_t in on RMD_ROBOT_STOP, config_t on RMD_ROBOT_CONFIG for the
 * robot's motor names, and the robot-wide stop handed to the rt loop.
 *
 * The stop takes the command path (rmd_command.robot_stops, a count the
 * loop acts on when it changes, as it does on disables[]): it reaches the
 * loop in its next cycle, and a controller's command handed over right
 * behind it cannot hide it.  Bridge thread (bridge_state.h).
 */
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "rmd/time.h"
#include "bridge_state.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/rmd_robot_stop_t.h"

_Static_assert(RMD_HEARTBEAT_T_MAX_ECHOES == RMD_CONFIG_MAX_PEERS &&
		       RMD_HEALTH_T_MAX_PEERS == RMD_CONFIG_MAX_PEERS,
	       "peer arrays");
_Static_assert(RMD_ROBOT_PEER_T_PEER_UNSEEN == RMD_PEER_UNSEEN &&
		       RMD_ROBOT_PEER_T_PEER_OK == RMD_PEER_OK &&
		       RMD_ROBOT_PEER_T_PEER_LOST == RMD_PEER_LOST &&
		       RMD_ROBOT_PEER_T_PEER_TRIPPED == RMD_PEER_TRIPPED &&
		       RMD_ROBOT_PEER_T_PEER_STOPPING == RMD_PEER_STOPPING,
	       "peer status");

/* The rt loop publishes its health every health period: this many missed, it has stopped. */
#define LOOP_QUIET 5

static int64_t realtime_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_REALTIME, &ts);
	return rmd_timespec_ns(&ts);
}

void bridge_robot_init(struct rmd_bridge *b)
{
	const struct rmd_bridge_opts *o = &b->opts;

	b->robot = o->robot.instance[0] != '\0';
	rmd_peers_init(&b->peers, &o->robot, o->host, o->instance);
	b->hb_period_ns = (int64_t)o->robot.heartbeat_ms * RMD_NS_PER_MS;
	b->robot_safe = o->robot.on_peer_lost == RMD_PEER_LOST_SAFE;
}

void bridge_robot_command(const struct rmd_bridge *b, struct rmd_command *cmd)
{
	cmd->robot_stops = b->robot_stops;
	cmd->robot_hold = b->robot && b->robot_safe && !rmd_peers_complete(&b->peers);
}

/*
 * A robot-wide stop for the reason fmt says: logged (once while the same
 * reason stands: rmdctl sends its stop three times, a peer's bad clock
 * comes with every heartbeat); handed to the loop unless `apply` is false
 * (on_peer_lost: report), in a command of its own that carries no setpoint
 * (so it refreshes no motor's command deadline).
 */
__attribute__((format(printf, 5, 0))) static void
robot_vtrip(struct rmd_bridge *b, int64_t now, bool apply, bool own, const char *fmt, va_list ap)
{
	struct rmd_command *cmd = &b->buf->robot_cmd;
	char why[RMD_PEERS_REASON_LEN];
	bool repeat;

	vsnprintf(why, sizeof(why), fmt, ap);
	repeat = !strcmp(why, b->robot_said);
	snprintf(b->robot_said, sizeof(b->robot_said), "%s", why);
	if (!apply) {
		if (!repeat)
			bridge_log(b, 4, "robot: %s (robot.on_peer_lost: report: the motors go on)",
				   why);
		return;
	}
	if (!b->robot_tripped || !repeat)
		bridge_log(b, 3, "robot: %s: the safe action for every driven motor", why);
	snprintf(b->robot_reason, sizeof(b->robot_reason), "%s", why);
	b->robot_tripped = true;
	b->robot_stops++;
	b->own_trips += own;
	bridge_count(&b->n_robot_stops);
	if (!b->opts.commands || b->probing)
		return;
	memset(cmd, 0, sizeof(*cmd));
	cmd->rx_ns = now;
	memcpy(cmd->disables, b->disables, sizeof(cmd->disables));
	bridge_robot_command(b, cmd);
	rmd_latest_put(b->opts.commands, cmd);
}

/* A stop this daemon takes from others: a peer's trip, its shutdown, an all-stop. */
__attribute__((format(printf, 4, 5))) static void robot_trip(struct rmd_bridge *b, int64_t now,
							     bool apply, const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	robot_vtrip(b, now, apply, false, fmt, ap);
	va_end(ap);
}

/*
 * A stop of this daemon's own judgment (a peer lost, a peer's clock): when
 * applied it counts in the heartbeat's trips, so the peers that still hear
 * this daemon follow it (bridge_state.h own_trips).
 */
__attribute__((format(printf, 3, 4))) static void robot_trip_own(struct rmd_bridge *b, int64_t now,
								 const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	robot_vtrip(b, now, b->robot_safe, true, fmt, ap);
	va_end(ap);
}

static const char *peer_desc(const struct rmd_peer *p, char *out, size_t len)
{
	snprintf(out, len, "%s (host %s, pid %d, prefix %s)", p->instance,
		 p->host[0] ? p->host : "?", (int)p->pid, p->prefix);
	return out;
}

void bridge_robot_heartbeat_in(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	rmd_heartbeat_t hb;
	int64_t now = rmd_now_ns();
	int64_t real = m->rx_real_ns > 0 ? m->rx_real_ns : realtime_ns();
	int64_t at = bridge_arrival_ns(b, m->rx_real_ns, now);
	char d[192];
	unsigned v;
	int i;

	if (!b->robot || b->probing)
		return;
	if (rmd_heartbeat_t_decode(m->data, 0, (int)m->size, &hb) < 0) {
		if (!b->hb_bad_logged)
			bridge_log(b, 4,
				   "robot: a message on %s that is not a heartbeat_t; "
				   "further ones are dropped unsaid",
				   m->channel);
		b->hb_bad_logged = true;
		return;
	}
	v = rmd_peers_take(&b->peers, &hb, at, real, &i);
	if (v & RMD_PEERS_UNKNOWN_NEW)
		bridge_log(b, 4,
			   "robot: heartbeat from \"%s\" (host %s, pid %d) ignored: not in "
			   "robot.peers; further ones are counted in health_t unknown_senders",
			   hb.instance, hb.host, (int)hb.pid);
	if (v & RMD_PEERS_SPOOF) {
		bool self = i < 0;

		if (!b->spoof_logged[self])
			bridge_log(b, 3,
				   "robot: heartbeat naming %s \"%s\" from host %s, pid %d: %s; "
				   "ignored, a fault (further ones are counted in health_t spoofs)",
				   self ? "this daemon," : "peer", hb.instance, hb.host,
				   (int)hb.pid,
				   self ? "another daemon uses this instance name (duplicate "
					  "robot.instance on the network)" :
					  "the peer runs elsewhere (its first heartbeat bound its "
					  "host) or twice");
		b->spoof_logged[self] = true;
	}
	if (i >= 0 && (v & RMD_PEERS_TAKEN)) {
		struct rmd_peer *p = &b->peers.p[i];

		peer_desc(p, d, sizeof(d));
		if (v & RMD_PEERS_FIRST) {
			bridge_log(b, 5, "robot: peer %s is here", d);
			b->robot_said[0] = '\0'; /* what it does next is news */
			b->config_robot_wanted = true;
		}
		if (v & RMD_PEERS_CLOCK_WARN)
			bridge_log(b, 4,
				   "robot: peer %s: its clock differs from this host's by %.1f ms "
				   "(said once; sync the robot's PCs: docs/robot.md \"Clocks\")",
				   p->instance, p->offset_ns / 1e6);
		if (v & RMD_PEERS_CLOCK_TRIP)
			robot_trip_own(b, now,
				       "peer %s: its clock differs from this host's by more than "
				       "robot.max_clock_offset_ms (%u)",
				       p->instance, b->opts.robot.max_clock_offset_ms);
		if (v & RMD_PEERS_TRIP)
			robot_trip(b, now, b->robot_safe, "peer %s tripped: %s", p->instance,
				   hb.reason && hb.reason[0] ? hb.reason : "its command watchdog");
		if (v & RMD_PEERS_STOPPED)
			robot_trip(b, now, b->robot_safe, "peer %s is shutting down", d);
	}
	rmd_heartbeat_t_decode_cleanup(&hb);
}

void bridge_robot_stop_in(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	rmd_robot_stop_t s;
	int64_t now = rmd_now_ns();

	if (!b->robot || b->probing)
		return;
	/* any message on the channel stops: an e-stop node need not speak robot_stop_t */
	if (!m->data || rmd_robot_stop_t_decode(m->data, 0, (int)m->size, &s) < 0) {
		robot_trip(b, now, true, "robot stop on %s (%u bytes, not a robot_stop_t)",
			   m->channel, m->size);
		return;
	}
	robot_trip(b, now, true, "robot stop from %s: %s", s.who && s.who[0] ? s.who : "?",
		   s.reason && s.reason[0] ? s.reason : "(no reason given)");
	rmd_robot_stop_t_decode_cleanup(&s);
}

/* Motor names of a peer's config_t that are ours too: counted per peer, said once. */
void bridge_robot_config_in(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	rmd_config_t c;
	int clashes = 0, i;
	const char *first = NULL;

	if (!b->robot || b->probing || !m->data ||
	    rmd_config_t_decode(m->data, 0, (int)m->size, &c) < 0)
		return;
	for (i = 0; i < (int)b->peers.n; i++)
		if (c.instance_name && !strcmp(c.instance_name, b->peers.p[i].instance))
			break;
	if (c.instance != b->opts.instance && i < (int)b->peers.n) {
		for (int k = 0; k < c.motor_count; k++)
			for (unsigned j = 0; j < b->opts.nmotors; j++)
				if (c.motor[k].name &&
				    !strcmp(c.motor[k].name, b->opts.motor[j].name)) {
					clashes++;
					first = first ? first : b->opts.motor[j].name;
				}
		if (clashes && !b->clash[i])
			bridge_log(b, 3,
				   "robot: %d motor name(s) of this daemon are peer %s's too "
				   "(\"%s\"...): motor names must be unique across the robot, "
				   "or a controller cannot tell the motors apart",
				   clashes, c.instance_name, first);
		b->clash[i] = clashes;
	}
	rmd_config_t_decode_cleanup(&c);
}

static void publish_heartbeat(struct rmd_bridge *b, const struct rmd_health *h, int8_t state)
{
	rmd_heartbeat_t *hb = &b->buf->hb;
	int n;

	hb->instance = b->opts.robot.instance;
	hb->host = b->opts.host;
	hb->pid = b->opts.pid;
	hb->boot_id = b->opts.instance;
	hb->prefix = b->opts.prefix;
	hb->seq = b->hb_seq;
	hb->period_ms = (int32_t)b->opts.robot.heartbeat_ms;
	hb->timeout_ms = (int32_t)b->opts.robot.peer_timeout_ms;
	hb->state = state;
	hb->reason = b->robot_tripped			  ? b->robot_reason :
		     h->watchdog == RMD_WD_TRIPPED	  ? "command watchdog" :
		     state == RMD_HEARTBEAT_T_HB_STOPPING ? "shutting down" :
							    "";
	hb->trips = (int64_t)h->watchdog_trips + b->own_trips;
	hb->echo = b->buf->hb_echo;
	hb->n_echoes = (int16_t)rmd_peers_echoes(&b->peers, hb->echo, RMD_CONFIG_MAX_PEERS);
	hb->t_ns = realtime_ns();
	n = rmd_heartbeat_t_encode(b->buf->enc, 0, ENC_MAX, hb);
	if (n < 0 ||
	    rmd_lcm_link_publish(b->link, RMD_CHANNEL_ROBOT_HEARTBEAT, b->buf->enc, (size_t)n) < 0)
		bridge_count(&b->n_publish_errors);
	rmd_peers_sent(&b->peers, b->hb_seq, hb->t_ns);
	b->hb_seq++;
}

static const struct rmd_health *loop_health(struct rmd_bridge *b)
{
	static const struct rmd_health none;
	const struct rmd_health *h = &none;

	if (b->opts.health)
		rmd_latest_get(b->opts.health, (const void **)&h);
	return h;
}

void bridge_robot_tick(struct rmd_bridge *b, int64_t now)
{
	const struct rmd_health *h = loop_health(b);
	uint32_t lost = rmd_peers_expire(&b->peers, now);
	bool tripped;

	for (unsigned i = 0; i < b->peers.n; i++) {
		char d[192];

		if (!(lost & (1u << i)))
			continue;
		robot_trip_own(b, now, "peer %s lost: no heartbeat for %u ms",
			       peer_desc(&b->peers.p[i], d, sizeof(d)),
			       b->opts.robot.peer_timeout_ms);
	}
	/* the loop acted on every stop, and a controller enabled since: the trip is over */
	if (b->robot_tripped && h->robot_stops == b->robot_stops && h->watchdog == RMD_WD_OK) {
		b->robot_tripped = false;
		b->robot_reason[0] = b->robot_said[0] = '\0';
		bridge_log(b, 5, "robot: enabled again after the robot-wide stop");
	}
	tripped = b->robot_tripped || h->watchdog == RMD_WD_TRIPPED;
	/*
	 * The heartbeat says the daemon runs, not just its bridge: while the rt
	 * loop's health is missing or older than LOOP_QUIET health periods it is
	 * withheld, and the peers lose this daemon.
	 */
	if (h->t_ns > 0 && now - h->t_ns <= LOOP_QUIET * b->opts.health_period_ns)
		publish_heartbeat(b, h,
				  tripped ? RMD_HEARTBEAT_T_HB_TRIPPED : RMD_HEARTBEAT_T_HB_OK);
	if (b->config_robot_wanted) {
		b->config_robot_wanted = false;
		if (b->buf->config_len > 0 &&
		    rmd_lcm_link_publish(b->link, RMD_CHANNEL_ROBOT_CONFIG, b->buf->config_enc,
					 (size_t)b->buf->config_len) < 0)
			bridge_count(&b->n_publish_errors);
	}
}

void bridge_robot_goodbye(struct rmd_bridge *b)
{
	if (b->robot)
		publish_heartbeat(b, loop_health(b), RMD_HEARTBEAT_T_HB_STOPPING);
}

void bridge_robot_health(struct rmd_bridge *b, int64_t now, rmd_health_t *o)
{
	int32_t clashes = 0;

	o->instance_name = b->opts.robot.instance;
	o->robot = !b->robot	    ? RMD_HEALTH_T_ROBOT_NONE :
		   b->robot_tripped ? RMD_HEALTH_T_ROBOT_TRIPPED :
				      RMD_HEALTH_T_ROBOT_OK;
	o->robot_reason = b->robot_reason;
	o->robot_stops = (int64_t)bridge_counted(&b->n_robot_stops);
	o->unknown_senders = (int64_t)b->peers.unknown;
	o->spoofs = (int64_t)b->peers.spoofs;
	o->clock_warnings = (int64_t)b->peers.clock_warnings;
	for (unsigned i = 0; i < b->peers.n; i++)
		clashes += b->clash[i];
	o->name_clashes = clashes;
	o->n_peers = (int16_t)b->peers.n;
	o->peer = b->buf->health_peer;
	for (unsigned i = 0; i < b->peers.n; i++)
		rmd_peers_report(&b->peers, i, now, &o->peer[i]);
}
