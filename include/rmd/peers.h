/* SPDX-License-Identifier: MIT */
/*
 * The peers of one daemon of a robot (docs/robot.md, layer svc): what
 * their heartbeats (rmd.heartbeat_t on RMD_ROBOT_HEARTBEAT) say, judged.
 * Pure: heartbeats and times in, a table and verdicts out; no clock, no
 * I/O, no allocation, no log (the bridge logs what the verdicts say, once).
 *
 *  - A peer is an instance named in robot.peers.  Its first heartbeat binds
 *    its host; a heartbeat with its name from another host, or from another
 *    process while the bound one is alive, is a spoof: a fault, counted,
 *    never taken.  A heartbeat naming this daemon's own instance from
 *    anywhere but itself is a spoof too (a duplicate name on the network).
 *  - A sender that is not a peer is ignored, counted, and reported once per
 *    name.
 *  - A peer silent for longer than the timeout is LOST; one that says it is
 *    stopping is LOST at once; one whose own watchdog tripped (its trips
 *    count grew) is a trip to follow.
 *  - Clocks: each heartbeat echoes the newest one the sender took from each
 *    of its peers, so the four stamps of NTP (our send t1, their receive t2,
 *    their send t3, our receive t4) give the offset ((t2 - t1) + (t3 - t4))
 *    / 2 and the round trip (t4 - t1) - (t3 - t2).  Before an echo came, the
 *    one-way difference t3 - t4 stands in.  An offset beyond
 *    RMD_PEERS_CLOCK_WARN_NS is warned about once; beyond max_offset_ns
 *    the peer's states cannot be compared with ours: a trip.
 *
 * All CLOCK_REALTIME stamps are ns since the epoch; everything else is
 * CLOCK_MONOTONIC ns.  Non-rt (the bridge thread), one thread.
 */
#ifndef RMD_PEERS_H
#define RMD_PEERS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/config.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/rmd_robot_peer_t.h"
#include "rmd/time.h"

/* A clock that differs from ours by more than this is warned about (once per peer): unsynced. */
#define RMD_PEERS_CLOCK_WARN_NS (10 * RMD_NS_PER_MS)
/* Unknown senders remembered by name, so that each is reported once. */
#define RMD_PEERS_UNKNOWN_MAX 16
#define RMD_PEERS_HOST_LEN 64
#define RMD_PEERS_REASON_LEN 192

enum rmd_peer_status {
	RMD_PEER_UNSEEN = 0, /* robot_peer_t.PEER_* */
	RMD_PEER_OK,
	RMD_PEER_LOST,
	RMD_PEER_TRIPPED,
	RMD_PEER_STOPPING,
};

struct rmd_peer {
	char instance[RMD_CONFIG_INSTANCE_LEN];
	char host[RMD_PEERS_HOST_LEN]; /* bound by its first heartbeat */
	char prefix[RMD_CONFIG_PREFIX_LEN];
	int32_t pid;
	int64_t boot_id;
	enum rmd_peer_status status;
	int64_t rx_ns; /* its newest heartbeat's arrival (monotonic) */
	int64_t seq;   /* and its seq */
	int64_t trips; /* its own watchdog's trips, as it said last */
	uint64_t heartbeats;
	bool offset_valid; /* from an echo (else offset_ns is one-way) */
	int64_t offset_ns; /* its clock - ours */
	int64_t rtt_ns;
	bool clock_warned;
	/* what our next heartbeat echoes: its newest heartbeat's seq, its t_ns, our receive */
	int64_t echo_seq, echo_sent_ns, echo_recv_ns;
};

struct rmd_peers {
	char self[RMD_CONFIG_INSTANCE_LEN];
	char host[RMD_PEERS_HOST_LEN];
	int64_t boot_id;
	int64_t timeout_ns;
	int64_t max_offset_ns;
	unsigned n;
	struct rmd_peer p[RMD_CONFIG_MAX_PEERS];
	/* our own heartbeats' send stamps by seq, for the echoes (a ring) */
	int64_t sent_ns[8];
	int64_t sent_seq[8];
	uint64_t unknown, spoofs, clock_warnings; /* totals */
	char unknown_name[RMD_PEERS_UNKNOWN_MAX][RMD_CONFIG_INSTANCE_LEN];
	unsigned n_unknown;
};

/* What one heartbeat did (rmd_peers_take()): bits. */
enum {
	RMD_PEERS_TAKEN = 1u << 0,	 /* a peer's, taken into the table */
	RMD_PEERS_FIRST = 1u << 1,	 /* its first since start, or back after LOST */
	RMD_PEERS_TRIP = 1u << 2,	 /* its own watchdog tripped: follow it */
	RMD_PEERS_STOPPED = 1u << 3,	 /* it says it is shutting down: LOST at once */
	RMD_PEERS_UNKNOWN = 1u << 4,	 /* not a peer: ignored */
	RMD_PEERS_UNKNOWN_NEW = 1u << 5, /* ... and its name not seen before: report it */
	RMD_PEERS_SPOOF = 1u << 6,	 /* a peer's or our name from elsewhere: a fault, ignored */
	RMD_PEERS_CLOCK_WARN =
		1u << 7, /* its clock is off by more than RMD_PEERS_CLOCK_WARN_NS (once) */
	RMD_PEERS_CLOCK_TRIP = 1u << 8, /* ... by more than max_offset_ns: a trip */
	RMD_PEERS_STALE = 1u << 9,	/* its seq did not advance (a duplicate): ignored */
	RMD_PEERS_OWN = 1u << 10,	/* our own, looped back: ignored */
};

/*
 * The table for cfg->robot (its peers UNSEEN), this daemon's host and
 * boot id (config_t's random instance number).  Non-rt.
 */
void rmd_peers_init(struct rmd_peers *t, const struct rmd_config_robot *cfg, const char *host,
		    int64_t boot_id);

/* Our heartbeat number seq went out at t_real_ns: kept for the offsets its echoes give. */
void rmd_peers_sent(struct rmd_peers *t, int64_t seq, int64_t t_real_ns);

/*
 * One heartbeat hb that arrived at rx_ns (monotonic) and rx_real_ns
 * (realtime, the kernel's stamp): RMD_PEERS_* bits, and *index the peer
 * it names (when TAKEN or SPOOF of a peer; -1 else).  Non-rt.
 */
unsigned rmd_peers_take(struct rmd_peers *t, const rmd_heartbeat_t *hb, int64_t rx_ns,
			int64_t rx_real_ns, int *index);

/* Peers that went silent longer than the timeout by now: bit i, peer i, newly LOST.  Non-rt. */
uint32_t rmd_peers_expire(struct rmd_peers *t, int64_t now_ns);

/* Whether every peer was seen and is neither LOST nor stopping (no peers: true). */
bool rmd_peers_complete(const struct rmd_peers *t);

/*
 * Our heartbeat's echoes: the newest heartbeat of each peer seen, into
 * out[max] (instance strings point into t): their number.
 */
unsigned rmd_peers_echoes(struct rmd_peers *t, rmd_heartbeat_echo_t *out, unsigned max);

/* Peer i as health_t carries it at now_ns (strings point into t). */
void rmd_peers_report(struct rmd_peers *t, unsigned i, int64_t now_ns, rmd_robot_peer_t *out);

/* "unseen", "ok", "lost", "tripped", "stopping". */
const char *rmd_peer_status_name(enum rmd_peer_status s);

#endif /* RMD_PEERS_H */
