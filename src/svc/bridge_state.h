/* SPDX-License-Identifier: MIT */
/*
 * The LCM bridge's state, struct rmd_bridge, and what the files of
 * src/svc/ that make up its behaviour share (rmd/bridge.h is the public
 * face):
 *
 *   bridge.c      the object (new, free, start, stop, probe, stats), the
 *                 bridge thread and its one wait, the messages it drains
 *                 and hands on, another daemon on the prefix
 *   admission.c   command_t and home_t in: decoded, checked, ownership,
 *                 order, clamped, handed to the rt loop
 *   publish.c     state_t, health_t and config_t out
 *
 * bridge.c calls the other two; they call nothing of each other's or of
 * bridge.c's.
 *
 * All of it is non-rt; the bridge thread owns what the struct says it
 * owns.  Nothing outside src/svc/ includes this header.
 */
#ifndef RMD_BRIDGE_STATE_H
#define RMD_BRIDGE_STATE_H

#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "rmd/bridge.h"
#include "rmd/channels.h"
#include "rmd/lcm_link.h"
#include "rmd/peers.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/rmd_robot_peer_t.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_motor_config_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

/* Room for one encoded state_t or health_t (at most about 2.7 KiB and 1.7 KiB). */
#define ENC_MAX 8192

struct rmd_bridge_buf {
	rmd_command_t msg;
	rmd_motor_command_t msg_motor[RMD_MAX_MOTORS]; /* msg.motor: decoded in place */
	struct rmd_command cmd;
	rmd_state_t state;
	rmd_motor_state_t state_motor[RMD_MAX_MOTORS]; /* state.motor */
	rmd_health_t health;
	int8_t health_cl[RMD_MAX_MOTORS]; /* health_t's per-motor arrays */
	int32_t health_cl_ms[RMD_MAX_MOTORS];
	int64_t health_unarmed[RMD_MAX_MOTORS];
	char bus_name[RMD_MAX_BUSES][RMD_BRIDGE_NAME_LEN];
	rmd_config_t config;
	/* the newest config_t as published, for rmd_bridge_config_copy(); under config_mu */
	unsigned char config_enc[ENC_MAX];
	int config_len;
	rmd_bus_config_t config_bus[RMD_MAX_BUSES];
	rmd_motor_config_t config_motor[RMD_MAX_MOTORS];
	unsigned char enc[ENC_MAX];
	/* robot.c: a robot-wide stop's own hand-over, the heartbeat, health_t's peers */
	struct rmd_command robot_cmd;
	rmd_heartbeat_t hb;
	rmd_heartbeat_echo_t hb_echo[RMD_CONFIG_MAX_PEERS];
	rmd_robot_peer_t health_peer[RMD_CONFIG_MAX_PEERS];
	char *config_peers[RMD_CONFIG_MAX_PEERS];
};

struct rmd_bridge {
	struct rmd_bridge_opts opts;
	struct rmd_lcm_link *link; /* LCM: messages in and out */
	int stop_fd;		   /* eventfd: rmd_bridge_stop() wakes the thread */
	pthread_t thread;
	bool running;
	struct rmd_bridge_buf *buf;
	bool state_listeners; /* not memq://: state_t can have a subscriber */
	int ep_fd, timer_fd;  /* the bridge thread's one wait: epoll set, health timer */
	/* Set by rmd_bridge_start(), read by rmd_bridge_get_stats(). */
	unsigned rt_granted;
	int rt_error;

	pthread_mutex_t config_mu; /* the newest config_t's encoding (rmd_bridge_config_copy) */

	char ch_command[RMD_BRIDGE_PREFIX_LEN + RMD_CHANNEL_SUFFIX_SIZE];
	char ch_state[RMD_BRIDGE_PREFIX_LEN + RMD_CHANNEL_SUFFIX_SIZE];
	char ch_health[RMD_BRIDGE_PREFIX_LEN + RMD_CHANNEL_SUFFIX_SIZE];
	char ch_config[RMD_BRIDGE_PREFIX_LEN + RMD_CHANNEL_SUFFIX_SIZE];
	char ch_config_req[RMD_BRIDGE_PREFIX_LEN + RMD_CHANNEL_SUFFIX_SIZE];
	char ch_home[RMD_BRIDGE_PREFIX_LEN + RMD_CHANNEL_SUFFIX_SIZE];

	/* Owned by the bridge thread. */
	int64_t last_seq;
	int64_t newest_utime;
	bool have_seq;
	bool have_utime;
	unsigned logged; /* bit per enum rmd_reject already logged */
	bool clamp_logged;
	bool state_sent;
	uint64_t last_state_cycle;
	int64_t next_health_ns;
	bool config_wanted;
	/* one controller at a time (docs/lcm.md) */
	bool owned;
	int64_t owner;	   /* command_t.controller of the owner */
	uint32_t owner_on; /* motors the owner enabled and has not disabled */
	/*
	 * Free motors (!owned) after an owner: the controller that may enable
	 * them next (the owner that released them, or the newest controller
	 * to send enable = 0 since).  Before any owner (!had_owner): anyone.
	 */
	bool had_owner;
	int64_t next_owner;
	bool have_controller;		   /* last_controller is set: */
	int64_t last_controller;	   /* whose sequence last_seq and newest_utime are */
	uint32_t disables[RMD_MAX_MOTORS]; /* enable = 0 entries accepted, per motor */
	struct rmd_home homes;		   /* homing requests accepted (home_t) */

	/*
	 * Another daemon on the prefix: rmd_bridge_probe() sets probing (no
	 * command, home or config request is acted on meanwhile); the bridge
	 * thread owns the rest once started.  foreign_ns: the newest foreign
	 * message's arrival; foreign_episode: logged, not yet over.
	 */
	bool probing;
	struct rmd_bridge_peer foreign;
	int64_t foreign_ns;
	bool foreign_episode;

	/* Written by the bridge thread, read by anyone (rmd_bridge_get_stats). */
	atomic_uint_fast64_t n_foreign;
	atomic_uint_fast64_t n_accepted;
	atomic_uint_fast64_t n_rejected[RMD_REJ_KINDS];
	atomic_uint_fast64_t n_clamped;
	atomic_uint_fast64_t n_states;
	atomic_uint_fast64_t n_health;
	atomic_uint_fast64_t n_configs;
	atomic_uint_fast64_t n_publish_errors;
	atomic_uint_fast64_t n_lcm_errors;
	atomic_uint_fast64_t n_takeovers;
	atomic_bool pub_owned;
	_Atomic int64_t pub_owner;
	_Atomic int64_t pub_intruder;

	/*
	 * The robot (robot.c), owned by the bridge thread: whether this daemon
	 * is a part of one, its peers, its heartbeat, the stops handed to the
	 * loop (rmd_command.robot_stops) and whether the newest is not over
	 * yet (and why), per peer the motor names it shares with this daemon.
	 */
	bool robot;
	bool robot_safe; /* on_peer_lost: safe */
	struct rmd_peers peers;
	int64_t hb_period_ns;
	int64_t next_hb_ns;
	int64_t hb_seq;
	uint32_t robot_stops;
	/*
	 * Robot-wide trips this daemon judged itself (a peer lost, a peer's
	 * clock): they go in the heartbeat's trips beside its watchdog's, so
	 * a peer that still hears it follows (a one-way split stops both
	 * sides); a trip it took from a peer or an all-stop is not counted.
	 */
	uint32_t own_trips;
	bool robot_tripped;
	char robot_reason[RMD_PEERS_REASON_LEN];
	char robot_said[RMD_PEERS_REASON_LEN]; /* the newest reason logged: said once */
	bool hb_bad_logged;
	bool spoof_logged[2]; /* [0] a peer's name, [1] this daemon's */
	bool config_robot_wanted;
	int32_t clash[RMD_CONFIG_MAX_PEERS];
	atomic_uint_fast64_t n_robot_stops;

	/* Owned by the bridge thread: a stamp refused as a clock jump (check_order). */
	int64_t utime_jump;
	bool have_utime_jump;
	/* Owned by the bridge thread: when the last config_t went out, and with what dialects. */
	int64_t config_sent_ns;
	uint8_t config_proto[RMD_MAX_MOTORS];
	uint32_t config_firmware[RMD_MAX_MOTORS];
	/*
	 * Owned by the bridge thread: when messages arrived (arrival_ns() in
	 * admission.c, from what drain() in bridge.c measured), CLOCK_MONOTONIC
	 * unless said.  rx_seen_ns: every message
	 * that arrived before it has been looked at; rx_at_ns: the arrival of
	 * the newest one; rx_off_last_ns: CLOCK_REALTIME - CLOCK_MONOTONIC
	 * at the last drain, rx_off_ns: the one its stamps are moved by (the
	 * smaller of it and the one before).
	 */
	int64_t rx_seen_ns;
	int64_t rx_at_ns;
	int64_t rx_off_ns;
	int64_t rx_off_last_ns;
};

/* Counters written by the bridge thread, read by anyone (rmd_bridge_get_stats()). */
static inline void bridge_count(atomic_uint_fast64_t *c)
{
	atomic_fetch_add_explicit(c, 1, memory_order_relaxed);
}

static inline uint64_t bridge_counted(atomic_uint_fast64_t *c)
{
	return atomic_load_explicit(c, memory_order_relaxed);
}

/* One message to the caller's log sink (opts.log), at syslog level `level`. */
__attribute__((format(printf, 3, 4))) static inline void bridge_log(struct rmd_bridge *b, int level,
								    const char *fmt, ...)
{
	char msg[512];
	va_list ap;

	if (!b->opts.log)
		return;
	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	b->opts.log(b->opts.log_ctx, level, msg);
}

/*
 * admission.c: a message on the prefix's COMMAND (m->data NULL: one too long
 * to keep, refused) or HOME, judged and handed to the rt loop; while
 * rmd_bridge_probe() listens nothing is handed on.  Bridge thread.
 */
void bridge_admit_command(struct rmd_bridge *b, const struct rmd_lcm_msg *m);
void bridge_admit_home(struct rmd_bridge *b, const struct rmd_lcm_msg *m);

/*
 * publish.c: the newest snapshot as state_t, when one came that is due
 * (opts.state_every; not on memq://); health_t as of now; config_t (its
 * encoding kept for rmd_bridge_config_copy()).  A failed publish is
 * counted in n_publish_errors.  Bridge thread.
 */
void bridge_publish_state(struct rmd_bridge *b);
void bridge_publish_health(struct rmd_bridge *b, int64_t now);
void bridge_publish_config(struct rmd_bridge *b);

/*
 * admission.c: when a message that arrived at real_ns (CLOCK_REALTIME,
 * 0: none) did, on CLOCK_MONOTONIC, bounded as its comment says.
 */
int64_t bridge_arrival_ns(struct rmd_bridge *b, int64_t real_ns, int64_t now);

/*
 * robot.c (docs/robot.md): set up from opts.robot; a command hand-over's
 * robot fields; RMD_ROBOT_HEARTBEAT, RMD_ROBOT_STOP and RMD_ROBOT_CONFIG
 * in; every heartbeat period, the peers' timeouts and our heartbeat; a
 * last heartbeat that says this daemon stops; health_t's robot fields.
 * Bridge thread (init: rmd_bridge_new()).
 */
void bridge_robot_init(struct rmd_bridge *b);
void bridge_robot_command(const struct rmd_bridge *b, struct rmd_command *cmd);
void bridge_robot_heartbeat_in(struct rmd_bridge *b, const struct rmd_lcm_msg *m);
void bridge_robot_stop_in(struct rmd_bridge *b, const struct rmd_lcm_msg *m);
void bridge_robot_config_in(struct rmd_bridge *b, const struct rmd_lcm_msg *m);
void bridge_robot_tick(struct rmd_bridge *b, int64_t now);
void bridge_robot_goodbye(struct rmd_bridge *b);
void bridge_robot_health(struct rmd_bridge *b, int64_t now, rmd_health_t *o);

#endif /* RMD_BRIDGE_STATE_H */
