// SPDX-License-Identifier: MIT
/*
 * The peers of one daemon of a robot, from their heartbeats (rmd/peers.h,
 * docs/robot.md).  Pure.
 */
#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "rmd/peers.h"

#define SENT_RING (sizeof(((struct rmd_peers *)0)->sent_ns) / sizeof(int64_t))

void rmd_peers_init(struct rmd_peers *t, const struct rmd_config_robot *cfg, const char *host,
		    int64_t boot_id)
{
	memset(t, 0, sizeof(*t));
	snprintf(t->self, sizeof(t->self), "%s", cfg->instance);
	snprintf(t->host, sizeof(t->host), "%s", host);
	t->boot_id = boot_id;
	t->timeout_ns = (int64_t)cfg->peer_timeout_ms * RMD_NS_PER_MS;
	t->max_offset_ns = (int64_t)cfg->max_clock_offset_ms * RMD_NS_PER_MS;
	for (unsigned i = 0; i < cfg->n_peers && i < RMD_CONFIG_MAX_PEERS; i++) {
		/* the loader refuses itself in the list; a table never holds it */
		if (!strcmp(cfg->peers[i], cfg->instance))
			continue;
		snprintf(t->p[t->n].instance, sizeof(t->p[t->n].instance), "%s", cfg->peers[i]);
		t->p[t->n].echo_seq = -1;
		t->n++;
	}
	for (unsigned k = 0; k < SENT_RING; k++)
		t->sent_seq[k] = -1;
}

void rmd_peers_sent(struct rmd_peers *t, int64_t seq, int64_t t_real_ns)
{
	unsigned k = (unsigned)(seq % (int64_t)SENT_RING);

	t->sent_seq[k] = seq;
	t->sent_ns[k] = t_real_ns;
}

static int find_peer(const struct rmd_peers *t, const char *name)
{
	for (unsigned i = 0; i < t->n; i++)
		if (!strcmp(t->p[i].instance, name))
			return (int)i;
	return -1;
}

/* Not a peer: counted; true when its name is new (reported once, up to RMD_PEERS_UNKNOWN_MAX names). */
static bool note_unknown(struct rmd_peers *t, const char *name)
{
	t->unknown++;
	for (unsigned k = 0; k < t->n_unknown; k++)
		if (!strcmp(t->unknown_name[k], name))
			return false;
	if (t->n_unknown == RMD_PEERS_UNKNOWN_MAX)
		return false;
	snprintf(t->unknown_name[t->n_unknown], sizeof(t->unknown_name[0]), "%s", name);
	t->n_unknown++;
	return true;
}

/* The offset from our echoed heartbeat in hb, when it carries one we still know. */
static void offset_from_echo(struct rmd_peers *t, struct rmd_peer *p, const rmd_heartbeat_t *hb,
			     int64_t rx_real_ns)
{
	for (int k = 0; k < hb->n_echoes; k++) {
		const rmd_heartbeat_echo_t *e = &hb->echo[k];
		unsigned slot;
		int64_t t1, t2 = e->t_recv_ns, t3 = hb->t_ns, t4 = rx_real_ns;

		if (!e->instance || strcmp(e->instance, t->self) || e->seq < 0)
			continue;
		slot = (unsigned)(e->seq % (int64_t)SENT_RING);
		/* our own send stamp, not the one it echoes: a forged echo cannot move it */
		if (t->sent_seq[slot] != e->seq)
			return;
		t1 = t->sent_ns[slot];
		p->offset_ns = ((t2 - t1) + (t3 - t4)) / 2;
		p->rtt_ns = (t4 - t1) - (t3 - t2);
		p->offset_valid = true;
		return;
	}
}

static int64_t abs64(int64_t v)
{
	return v < 0 ? -v : v;
}

unsigned rmd_peers_take(struct rmd_peers *t, const rmd_heartbeat_t *hb, int64_t rx_ns,
			int64_t rx_real_ns, int *index)
{
	const char *name = hb->instance ? hb->instance : "";
	const char *host = hb->host ? hb->host : "";
	struct rmd_peer *p;
	unsigned out = 0;
	int64_t off;
	int i;

	*index = -1;
	if (t->self[0] && !strcmp(name, t->self)) {
		if (!strcmp(host, t->host) && hb->boot_id == t->boot_id)
			return RMD_PEERS_OWN;
		t->spoofs++;
		return RMD_PEERS_SPOOF;
	}
	i = find_peer(t, name);
	if (i < 0)
		return RMD_PEERS_UNKNOWN | (note_unknown(t, name) ? RMD_PEERS_UNKNOWN_NEW : 0);
	*index = i;
	p = &t->p[i];
	if (p->status != RMD_PEER_UNSEEN) {
		bool alive = p->status != RMD_PEER_LOST && p->status != RMD_PEER_STOPPING;

		/* its host is bound for the run; another process only once the bound one is gone */
		if (strcmp(host, p->host) || (hb->boot_id != p->boot_id && alive)) {
			t->spoofs++;
			return RMD_PEERS_SPOOF;
		}
		if (hb->boot_id == p->boot_id && hb->seq <= p->seq)
			return RMD_PEERS_STALE;
	}
	if (p->status == RMD_PEER_UNSEEN || p->status == RMD_PEER_LOST ||
	    p->status == RMD_PEER_STOPPING || hb->boot_id != p->boot_id) {
		out |= RMD_PEERS_FIRST;
		p->trips = hb->trips; /* what it tripped before we saw it is its past */
		p->offset_valid = false;
	} else if (hb->trips > p->trips) {
		out |= RMD_PEERS_TRIP;
	}
	snprintf(p->host, sizeof(p->host), "%s", host);
	snprintf(p->prefix, sizeof(p->prefix), "%s", hb->prefix ? hb->prefix : "");
	p->pid = hb->pid;
	p->boot_id = hb->boot_id;
	p->trips = hb->trips;
	p->seq = hb->seq;
	p->rx_ns = rx_ns;
	p->heartbeats++;
	p->echo_seq = hb->seq;
	p->echo_sent_ns = hb->t_ns;
	p->echo_recv_ns = rx_real_ns;
	switch (hb->state) {
	case RMD_HEARTBEAT_T_HB_STOPPING:
		p->status = RMD_PEER_STOPPING;
		out |= RMD_PEERS_STOPPED;
		break;
	case RMD_HEARTBEAT_T_HB_TRIPPED:
		p->status = RMD_PEER_TRIPPED;
		break;
	default:
		p->status = RMD_PEER_OK;
		break;
	}
	offset_from_echo(t, p, hb, rx_real_ns);
	off = p->offset_valid ? p->offset_ns : hb->t_ns - rx_real_ns;
	if (!p->offset_valid)
		p->offset_ns = off;
	if (abs64(off) > t->max_offset_ns || hb->t_ns <= 0) {
		out |= RMD_PEERS_CLOCK_TRIP;
		t->clock_warnings++;
	} else if (abs64(off) > RMD_PEERS_CLOCK_WARN_NS && !p->clock_warned) {
		p->clock_warned = true;
		out |= RMD_PEERS_CLOCK_WARN;
		t->clock_warnings++;
	}
	return out | RMD_PEERS_TAKEN;
}

uint32_t rmd_peers_expire(struct rmd_peers *t, int64_t now_ns)
{
	uint32_t lost = 0;

	for (unsigned i = 0; i < t->n; i++) {
		struct rmd_peer *p = &t->p[i];

		if ((p->status == RMD_PEER_OK || p->status == RMD_PEER_TRIPPED) &&
		    now_ns - p->rx_ns > t->timeout_ns) {
			p->status = RMD_PEER_LOST;
			lost |= 1u << i;
		}
	}
	return lost;
}

bool rmd_peers_complete(const struct rmd_peers *t)
{
	for (unsigned i = 0; i < t->n; i++)
		if (t->p[i].status != RMD_PEER_OK && t->p[i].status != RMD_PEER_TRIPPED)
			return false;
	return true;
}

unsigned rmd_peers_echoes(struct rmd_peers *t, rmd_heartbeat_echo_t *out, unsigned max)
{
	unsigned n = 0;

	for (unsigned i = 0; i < t->n && n < max; i++) {
		struct rmd_peer *p = &t->p[i];

		if (p->echo_seq < 0)
			continue;
		out[n++] = (rmd_heartbeat_echo_t){ .instance = p->instance,
						   .seq = p->echo_seq,
						   .t_sent_ns = p->echo_sent_ns,
						   .t_recv_ns = p->echo_recv_ns };
	}
	return n;
}

void rmd_peers_report(struct rmd_peers *t, unsigned i, int64_t now_ns, rmd_robot_peer_t *out)
{
	struct rmd_peer *p = &t->p[i];
	int64_t age = (now_ns - p->rx_ns) / RMD_NS_PER_MS;

	*out = (rmd_robot_peer_t){
		.instance = p->instance,
		.host = p->host,
		.prefix = p->prefix,
		.status = (int8_t)p->status,
		.age_ms = p->status == RMD_PEER_UNSEEN ?
				  -1 :
				  (age > INT32_MAX ? INT32_MAX : (int32_t)age),
		.offset_valid = p->offset_valid,
		.offset_ns = p->offset_ns,
		.rtt_ns = p->offset_valid ? p->rtt_ns : 0,
		.heartbeats = (int64_t)p->heartbeats,
	};
}

const char *rmd_peer_status_name(enum rmd_peer_status s)
{
	switch (s) {
	case RMD_PEER_UNSEEN:
		return "unseen";
	case RMD_PEER_OK:
		return "ok";
	case RMD_PEER_LOST:
		return "lost";
	case RMD_PEER_TRIPPED:
		return "tripped";
	case RMD_PEER_STOPPING:
		return "stopping";
	}
	return "?";
}
