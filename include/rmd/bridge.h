/* SPDX-License-Identifier: MIT */
/*
 * The LCM bridge (docs/design.md, layer svc): the policy between LCM and
 * the rt loop, in a thread at SCHED_FIFO opts.rt_priority (below the rt
 * loop's), so that a command never waits for a normal-priority wake-up; 0:
 * normal priority.  It reaches LCM only through its link (rmd/lcm_link.h),
 * which it reads in that thread: on udpm:// the link's own socket, so no
 * LCM receive thread stands between a command and the loop; with other
 * providers LCM's receive threads are raised with the bridge's.  It is the
 * only thread that uses the link.
 *
 * The channels, PREFIX and a suffix of rmd/channels.h:
 *
 *   COMMAND         in   rmd.command_t: decoded, validated, clamped,
 *                        handed to the rt loop as struct rmd_command
 *   STATE           out  rmd.state_t from each struct rmd_snapshot
 *                        (or every state_every-th cycle)
 *   HEALTH          out  rmd.health_t, every health_period_ns, from
 *                        the newest struct rmd_health plus the
 *                        bridge's own command counters
 *   CONFIG          out  rmd.config_t, at start and on request
 *   CONFIG_REQUEST  in   any message: publish config_t again
 *   HOME            in   rmd.home_t: a controller says where a motor
 *                        is (docs/lcm.md "Homing"), handed to the rt
 *                        loop as struct rmd_home; logged
 *
 * The rt loop and the bridge meet only in three triple buffers (rmd/spsc.h)
 * that the daemon owns and passes to both: the bridge writes commands and
 * reads snapshots and health, never blocking the rt thread.
 *
 * A command that breaks a rule is rejected as a whole (never partly
 * applied), counted by enum rmd_reject kind and logged once per kind;
 * setpoints outside a motor's limits are clamped (rmd_motor_clamp(), the
 * rule the rt loop's encoder applies too) and counted.  The rules are in
 * docs/lcm.md.
 *
 * Lifecycle: rmd_bridge_opts_init(), fill in, rmd_bridge_new(),
 * rmd_bridge_start(), ..., rmd_bridge_stop(), rmd_bridge_free().  All of
 * it is non-rt.
 */
#ifndef RMD_BRIDGE_H
#define RMD_BRIDGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "rmd/config.h"
#include "rmd/frame.h"
#include "rmd/lcm_link.h"
#include "rmd/motor.h"
#include "rmd/rmd_motor_state_t.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

/* Longest sleep between looks at the snapshots without notify_fd: half a 1 kHz period. */
#define RMD_BRIDGE_DEFAULT_POLL_NS 500000
/*
 * Kernel receive buffer asked of a udpm:// URL that does not set
 * recv_buf_size: tens of milliseconds of a 20 kHz command flood (a
 * command_t is two datagrams).  The kernel caps it at net.core.rmem_max
 * (docs/lcm.md).
 */
#define RMD_BRIDGE_UDPM_RCVBUF (4 << 20)

#define RMD_BRIDGE_URL_LEN 256
#define RMD_BRIDGE_PREFIX_LEN 32
#define RMD_BRIDGE_NAME_LEN 32
#define RMD_BRIDGE_HOST_LEN 64
#define RMD_BRIDGE_SOURCE_LEN 256

/* How long rmd_bridge_probe() listens by default: three health_t periods. */
#define RMD_BRIDGE_PROBE_NS (300 * 1000000LL)

/* Bit of struct rmd_motor_info.modes for each enum rmd_mode (rmd/motor.h). */
#define RMD_BRIDGE_MODE_BIT(mode) RMD_MOTOR_MODE_BIT(mode)
#define RMD_BRIDGE_MODES_ALL RMD_MOTOR_MODES_ALL

struct rmd_bridge_bus {
	char name[RMD_BRIDGE_NAME_LEN];
	char kind[16]; /* "socketcan", "rs485", "sim" */
	uint32_t bitrate;
};

struct rmd_bridge_opts {
	/* LCM provider URL; udpm:// without recv_buf_size gets RMD_BRIDGE_UDPM_RCVBUF. */
	char url[RMD_BRIDGE_URL_LEN];
	char prefix[RMD_BRIDGE_PREFIX_LEN]; /* channel prefix */
	char version[64]; /* config_t.version: the program's version ("" by default) */
	/*
	 * Which daemon this is, in config_t and health_t: a random non-zero
	 * id, the host name, the process id, the configuration's source.
	 * Messages on the prefix's HEALTH and CONFIG with another instance
	 * are another daemon's: counted in health_t, logged once per episode.
	 */
	int64_t instance;
	char host[RMD_BRIDGE_HOST_LEN];
	int32_t pid;
	char source[RMD_BRIDGE_SOURCE_LEN];

	/*
	 * This daemon as a part of a robot (docs/robot.md; src/svc/robot.c):
	 * robot.instance "" (rmd_bridge_opts_init()'s): none, no heartbeat
	 * sent or awaited, robot-wide channels ignored.
	 */
	struct rmd_config_robot robot;

	unsigned nmotors;			     /* 1..RMD_MAX_MOTORS */
	struct rmd_motor_info motor[RMD_MAX_MOTORS]; /* rmd_motor_info() fills them */
	unsigned nbuses;			     /* 0..RMD_MAX_BUSES */
	struct rmd_bridge_bus bus[RMD_MAX_BUSES];

	int64_t period_ns;	/* rt loop period, for config_t */
	unsigned state_every;	/* publish state_t every n-th cycle; 0 or 1: every snapshot */
	int stale_ms;		/* reject utime this much older than the newest; 0: no check */
	int command_timeout_ms; /* validated only: silence no longer ends ownership (issue 20.3) */
	int64_t health_period_ns; /* health_t period */
	int64_t poll_ns;	  /* without notify_fd: longest sleep between looks at snapshots */
	/*
	 * SCHED_FIFO priority of the bridge thread and of LCM's receive
	 * threads (the ones lcm_create/lcm_subscribe started), 1..98, below
	 * the rt loop's; 0: normal priority.  Refused (no CAP_SYS_NICE or
	 * RLIMIT_RTPRIO): both run at normal priority, and the stats say why.
	 */
	unsigned rt_priority;

	/*
	 * The hand-overs, created by the daemon with rmd_latest_init() and
	 * the sizes of struct rmd_command, rmd_snapshot and rmd_health.  The
	 * bridge is the only writer of `commands` and the only reader of the
	 * other two.  snapshots and health may be NULL (nothing published);
	 * health's buffer zeroed, so health_t reads zeros until the rt loop
	 * publishes.
	 */
	struct rmd_latest *commands;
	struct rmd_latest *snapshots;
	struct rmd_latest *health;
	/* struct rmd_home, bridge -> loop (its only writer); NULL: home_t is refused */
	struct rmd_latest *homes;

	/*
	 * An eventfd the rt loop writes after each snapshot: the bridge sleeps
	 * until it (or a command, or the health timer) wakes it, and publishes
	 * the snapshot at once; -1: none, the bridge looks every poll_ns.  On
	 * memq:// nobody can listen to state_t: no state_t is encoded and
	 * notify_fd is not watched.
	 */
	int notify_fd;

	/*
	 * Where rejections and errors go: one call per message, with its
	 * syslog level (3 error, 4 warning, 5 notice) and no prefix or
	 * newline; the caller says whose message it is.  NULL: dropped.
	 */
	void (*log)(void *ctx, int level, const char *msg);
	void *log_ctx;

	/*
	 * A command from a controller that does not own the motors was
	 * rejected (once per intruding controller id, bridge thread): rmdd's
	 * incident recorder.  NULL: nobody is told.
	 */
	void (*on_intruder)(void *ctx, int64_t when_ns, int64_t controller, int64_t owner);
	void *intruder_ctx;
};

/* Counters, totals since rmd_bridge_new(). */
struct rmd_bridge_stats {
	uint64_t accepted;
	uint64_t rejected;
	uint64_t rejected_by_kind[RMD_REJ_KINDS];
	uint64_t clamped; /* accepted commands with at least one clamped setpoint */
	uint64_t states_published;
	uint64_t health_published;
	uint64_t configs_published;
	uint64_t publish_errors;
	uint64_t foreign;     /* another daemon's health_t and config_t on the prefix */
	uint64_t lcm_errors;  /* the link's receive failures */
	uint64_t takeovers;   /* command_t.takeover honoured */
	uint64_t robot_stops; /* robot-wide safe actions handed to the loop (docs/robot.md) */
	bool owned;	      /* a controller owns the motors: */
	int64_t owner;	      /* its command_t.controller */
	int64_t intruder;     /* newest controller rejected for not owning them; 0: none */
	/* After rmd_bridge_start(): */
	unsigned rt_priority;	 /* the bridge thread's SCHED_FIFO priority; 0: normal */
	int rt_error;		 /* 0, or -errno of the refused SCHED_FIFO */
	unsigned lcm_threads;	 /* LCM's receive threads found (udpm: 0, the bridge reads) */
	unsigned lcm_threads_rt; /* of which raised to SCHED_FIFO rt_priority */
	/* udpm: the link's socket drops the bridge's own datagrams in the kernel */
	bool own_dropped;
	uint64_t datagrams; /* udpm: datagrams the bridge read from the link's socket */
};

/* Another daemon on the prefix, as rmd_bridge_probe() or health_t saw it. */
struct rmd_bridge_peer {
	unsigned messages; /* its state_t, health_t and config_t that came */
	int64_t instance;  /* 0: only state_t came, nothing names it */
	char host[RMD_BRIDGE_HOST_LEN];
	int32_t pid;
	char source[RMD_BRIDGE_SOURCE_LEN]; /* "" unless its config_t came */
};

/*
 * The bridge: an object of its own (rmd_bridge_new() .. rmd_bridge_free()),
 * its insides private to src/svc/.
 */
struct rmd_bridge;

/*
 * Defaults: URL, prefix, stale_ms and the health period of rmd/config.h
 * (RMD_CONFIG_DEFAULT_*), a 1 kHz period; no motors, no buses, notify_fd
 * -1, no log.  Non-rt.
 */
void rmd_bridge_opts_init(struct rmd_bridge_opts *opts);

/*
 * Check `opts` (the bridge keeps a copy) and open the link
 * (rmd_lcm_link_new()).  Not udpm: the threads that appear in the process
 * meanwhile are taken for LCM's (and raised by rmd_bridge_start()), so no
 * other thread of the caller's may start during the call.  Returns 0 and
 * *out, or -EINVAL (bad options or URL) / -EIO (the link could not be
 * opened) / -ENOMEM with the reason in err and *out NULL: nothing to undo.
 * Non-rt.
 */
int rmd_bridge_new(struct rmd_bridge **out, const struct rmd_bridge_opts *opts, char *err,
		   size_t errlen);

/*
 * Start the bridge thread (all signals blocked; SCHED_FIFO opts.rt_priority,
 * and LCM's receive threads with it, or SCHED_OTHER whatever the caller's
 * policy when that is 0 or refused: rmd_bridge_get_stats() says which); it
 * publishes config_t first.  Returns 0 or -errno (a refused SCHED_FIFO is
 * not an error).  Non-rt.
 */
int rmd_bridge_start(struct rmd_bridge *b);

/*
 * Before rmd_bridge_start(): ask for config_t (CONFIG_REQUEST) and listen
 * on the prefix's STATE, HEALTH and CONFIG for wait_ns; whatever comes is
 * another daemon's (this one publishes nothing yet).  Returns the number
 * of such messages (0: nobody else), *peer naming the daemon when its
 * health_t or config_t came; or -errno.  memq:// has nobody else: 0 at
 * once.  Commands that arrive meanwhile are dropped.  Non-rt.
 */
int rmd_bridge_probe(struct rmd_bridge *b, int64_t wait_ns, struct rmd_bridge_peer *peer);

/* Wake the thread, wait for it to end.  A bridge that was not started is left as is.  Non-rt. */
void rmd_bridge_stop(struct rmd_bridge *b);

/*
 * The newest config_t the bridge published, in LCM's encoding (the bytes
 * on the wire, without the LCM header), into out[len]: its length, or 0
 * before the first one or when it does not fit.  Any thread (the incident
 * writer puts it into each recording's LCM log).  Non-rt.
 */
int rmd_bridge_config_copy(struct rmd_bridge *b, void *out, size_t len);

/*
 * One message as the link hands it over (rmd_lcm_link_receive(): data NULL
 * for one too long to keep), judged and acted on as the bridge thread
 * does with each: for a bridge that was not started (fuzzers).  Non-rt.
 */
void rmd_bridge_handle(struct rmd_bridge *b, const struct rmd_lcm_msg *m);

/* Stop if running, close the link, free it; NULL is a no-op.  Non-rt. */
void rmd_bridge_free(struct rmd_bridge *b);

/*
 * The options the bridge runs with: its copy of rmd_bridge_new()'s (with
 * state_every 0 read as 1).  Valid until rmd_bridge_free().  Any thread.
 * Non-rt.
 */
const struct rmd_bridge_opts *rmd_bridge_get_opts(const struct rmd_bridge *b);

/*
 * Motor `index`'s state m as state_t carries it, at t_ns (the snapshot's
 * time: brake_releasing).  The bridge publishes every motor so, and rmdd's
 * incident log writes its state_t so.  Pure.  Non-rt.
 */
void rmd_bridge_motor_state(rmd_motor_state_t *o, unsigned index, const struct rmd_motor_state *m,
			    int64_t t_ns);

/* The counters, from any thread.  Non-rt (but lock-free). */
void rmd_bridge_get_stats(struct rmd_bridge *b, struct rmd_bridge_stats *st);

/* Name of a reject kind, for messages: "decode", "count", ...  Non-rt. */
const char *rmd_bridge_reject_name(enum rmd_reject kind);

#endif /* RMD_BRIDGE_H */
