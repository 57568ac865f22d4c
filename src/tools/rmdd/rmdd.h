/* SPDX-License-Identifier: MIT */
/*
 * rmdd internals: the daemon's parts and what they share.
 *
 *   main.c     options, bring-up's report, the lifecycle (build, start,
 *              serve, tear down)
 *   buses.c    open every configured bus
 *   lcm.c      the LCM bridge's options from the configuration
 *   events.c   what rmdd says of the rt loop's events, and the names the
 *              monitor and the incident writer share
 *   monitor.c  the monitor thread: drains the rt loop's event ring and logs
 *              on change, samples each motor's reply latency
 *   incidents.c  the incident writer: a recording after a safety event
 *   stats.c    the statistics (SIGUSR1, exit) and the STATUS= line
 *   notify.c   systemd: READY=1, STATUS=, WATCHDOG=1, STOPPING=1
 *
 * Logging is src/tools/common/log.c, shared with rmdctl and rmd-sim.
 * Everything here is non-rt: the only rt code of the daemon is the loop
 * (src/rt/), which these parts never call into except through its
 * thread-safe getters.
 */
#ifndef RMDD_H
#define RMDD_H

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "rmd/hist.h"
#include "rmd/incident.h"
#include "rmd/bridge.h"
#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/dialect.h"
#include "rmd/loop.h"
#include "rmd/plan.h"
#include "rmd/spsc.h"
#include "rmd/state.h"
#include "tools/common/log.h"

/* Exit statuses (rmdd --help prints them). */
enum {
	RMDD_EXIT_OK = 0,    /* ran and stopped on SIGTERM/SIGINT, or --check-config fits */
	RMDD_EXIT_FAIL = 1,  /* configuration, plan, bus, bring-up, LCM or rt refused */
	RMDD_EXIT_USAGE = 2, /* bad command line */
};

#define RMDD_ERR_LEN 8192 /* config, plan and bring-up messages */

/* Event ring between the rt loop and the monitor: 4096 records of 32 bytes. */
#define RMDD_EVENT_SLOTS 4096

/* ---- what rmdd says of the loop's events (events.c) ----------------------- */

/* Name of a lifecycle state ("ready", "lost", ...). */
const char *rmdd_lifecycle_name(unsigned lc);

/* "can0: motor 3 (knee_l)" for motor index i ("motor #40" when out of range). */
void rmdd_motor_ctx(const struct rmd_config *cfg, unsigned i, char *buf, size_t len);

/* Bus b's name, "?" when out of range. */
const char *rmdd_bus_name(const struct rmd_config *cfg, unsigned b);

/*
 * Motor i speaks dialect p, as bring-up found it (`protocol: auto`) or the
 * loop's health says (rmd_health.proto[]).  Any thread.
 */
void rmdd_dialect_found(unsigned i, enum rmd_proto p);

/*
 * The dialect motor i was found to speak (rmdd_dialect_found()), its
 * entry's protocol until then: what its error flags, commands and frames
 * are named and decoded by.  Any thread.
 */
enum rmd_proto rmdd_motor_dialect(const struct rmd_config *cfg, unsigned i);

/* A journal line's room: the logger's (tools/common/log.c), so none is cut shorter. */
#define RMDD_EVENT_LINE_LEN 2048

/*
 * What the monitor keeps between the events it words: the rows of
 * RMD_EV_MOTOR_STATE, RMD_EV_SAFE_ACTION, RMD_EV_OVERRUN and RMD_EV_RT note
 * into it (events.c).  Owned by the monitor's thread.
 */
/*
 * Overruns: the first is said at once, the rest summed up in one line
 * every RMDD_OVERRUN_SUMMARY_S while they go on (a busy machine overruns
 * all the time: its lines must not drown the log).
 */
#define RMDD_OVERRUN_SUMMARY_S 10

struct rmdd_event_notes {
	const struct rmd_config *cfg;
	int64_t overrun_window_ns; /* start of the current overrun summary's window */
	uint64_t overruns_logged, overruns_pending, skipped_pending;
	/*
	 * The shutdown's stop or hold sent to a driven motor (RMD_EV_SAFE_ACTION
	 * with b = 1) ahead of its SAFE, which then names it; -1: none
	 */
	int shutdown_sent;
	/* The RMD_EV_RT of one drain: one refused (but CPU_AWAKE), and each one's -errno. */
	bool rt_any;
	int rt_err[RMD_LOOP_RT_CPU_AWAKE + 1];
};

/* Notes of nothing yet, for events of cfg. */
void rmdd_event_notes_init(struct rmdd_event_notes *n, const struct rmd_config *cfg);

/*
 * Event e's journal line into buf (RMDD_EVENT_LINE_LEN holds any), by its
 * kind's row; returns its syslog level, or 0 when it has none now (noted
 * into n, or nothing to say).  A kind without a row: "event K (a A, b B)",
 * debug.
 */
int rmdd_event_journal(struct rmdd_event_notes *n, const struct rmd_event *e, char *buf,
		       size_t len);

/*
 * At now: the line that sums up the overruns after the first of the
 * RMDD_OVERRUN_SUMMARY_S window that ended (level, or 0: none due, or
 * none to sum up).
 */
int rmdd_event_overruns(struct rmdd_event_notes *n, int64_t now, char *buf, size_t len);

/*
 * After a drain, the lines its RMD_EV_RT events come to, one a call, each
 * forgotten once said: the CPU wake-up latency, then the real-time
 * guarantees.  Level, or 0: no more.
 */
int rmdd_event_rt_lines(struct rmdd_event_notes *n, char *buf, size_t len);

/* Event e's line in an incident's summary, in a few words, by its kind's row. */
void rmdd_event_summary(const struct rmd_config *cfg, const struct rmd_event *e, char *buf,
			size_t len);

/*
 * Whether loop event e is a safety event that makes an incident (a motor
 * lost, faulted or made safe, a watchdog trip, a safe action, an overrun
 * of incidents.overrun_burst periods, a bus leaving error-active, a motor
 * the configuration does not list), by its kind's row; its summary line
 * into what and its short name into *kind (untouched when not).
 */
bool rmdd_incident_kind(const struct rmd_config *cfg, const struct rmd_event *e, char *what,
			size_t len, const char **kind);

/* Kind's name in its row ("MOTOR_STATE"); NULL: a kind the table has no row for. */
const char *rmdd_event_name(unsigned kind);

/* ---- the incident writer (incidents.c) ------------------------------------ */

/* Triggers one recording holds (the events of its window are all in it anyway). */
#define RMDD_INCIDENT_TRIGGERS 64

/*
 * After a recording filed as an overrun, overruns alone start no recording
 * for this long (they still join a recording something else started): a
 * machine that overruns again and again would otherwise write one every
 * few seconds, each some MB and a tenth of a second of CPU, and push the
 * recordings worth keeping out of incidents.keep.
 */
#define RMDD_INCIDENT_OVERRUN_HOLDOFF_S 60

/* A safety event that starts (or joins) a recording. */
struct rmdd_trigger {
	int64_t t_ns;	/* CLOCK_MONOTONIC */
	bool outside;	/* not a loop event (an intruding controller): the summary lists it */
	char kind[16];	/* for the directory name: "lost", "watchdog", ... */
	char what[160]; /* for the summary and the log */
};

struct rmdd_incidents {
	const struct rmd_config *cfg;
	struct rmd_incident_ring *ring; /* NULL: incidents.enabled is false */
	struct rmd_incident_window *win;
	char dir[RMD_CONFIG_INCIDENT_DIR_LEN + 32];
	pthread_t thread;
	bool running, inited;
	pthread_mutex_t mu;
	pthread_cond_t cv; /* CLOCK_MONOTONIC */
	/* under mu */
	bool stop;
	unsigned n_trig;
	struct rmdd_trigger trig[RMDD_INCIDENT_TRIGGERS]; /* of the recording being made */
	int64_t covered_ns;	  /* triggers up to this are in the last recording */
	int64_t overrun_quiet_ns; /* overruns alone record nothing before this */
	bool overrun_held;	  /* one was held back since the last overrun recording */
	/* writer thread; read after stop */
	unsigned written;
	/* the config_t of window.lcmlog (rmd_bridge_config_copy); NULL: none.  Set before start. */
	struct rmd_bridge *bridge;
};

/*
 * The ring (sized from cfg and plan) and the writer's copy of it; nothing
 * when incidents.enabled is false.  0 or -errno with err set.
 */
int rmdd_incidents_init(struct rmdd_incidents *in, const struct rmd_config *cfg,
			const struct rmd_plan *plan, char *err, size_t errlen);
int rmdd_incidents_start(struct rmdd_incidents *in);
/* Write what is pending at once (a shorter tail), join the thread. */
void rmdd_incidents_stop(struct rmdd_incidents *in);
void rmdd_incidents_fini(struct rmdd_incidents *in);

/*
 * A safety event at t_ns: a recording of [first trigger - seconds_before,
 * first trigger + seconds_after] follows; triggers until then join it, and
 * triggers already inside a written recording are not recorded twice.
 * Any thread.  in may be NULL.
 */
void rmdd_incidents_trigger(struct rmdd_incidents *in, int64_t t_ns, const char *kind,
			    const char *what, bool outside);

/* Where recordings go: incidents.dir, else $STATE_DIRECTORY/incidents, $XDG_STATE_HOME/rmdd/... */
void rmdd_incidents_dir(const struct rmd_config *cfg, char *out, size_t len);

/* ---- the monitor thread (monitor.c) ------------------------------------- */

struct rmdd_monitor {
	const struct rmd_config *cfg;
	struct rmd_loop *loop;
	struct rmd_ring *events;
	struct rmdd_incidents *incidents; /* told of each safety event; NULL: none */

	pthread_t thread;
	bool running;
	int stop_fd; /* eventfd: rmdd_monitor_stop() wakes the thread */
	int wake_fd; /* eventfd: the loop wakes the thread when it pushed events */

	/* Owned by the thread. */
	uint64_t ring_dropped;
	struct rmdd_event_notes notes; /* what events.c's rows note between events */
};

/* Set up (no thread yet).  Returns 0 or -errno. */
int rmdd_monitor_init(struct rmdd_monitor *m, const struct rmd_config *cfg, struct rmd_loop *loop,
		      struct rmd_ring *events);

/* Drain the event ring now, in the caller's thread (before the thread starts, after it stops). */
void rmdd_monitor_drain(struct rmdd_monitor *m);

/* Start the thread (SCHED_OTHER, every signal blocked).  Returns 0 or -errno. */
int rmdd_monitor_start(struct rmdd_monitor *m);

/* Wake the thread, join it, drain what is left.  A monitor not started: a drain. */
void rmdd_monitor_stop(struct rmdd_monitor *m);

void rmdd_monitor_fini(struct rmdd_monitor *m);

/* MIT ranges in a few words: "p ±12.566 rad, v ±45 rad/s, t ±60 N·m, kp 0..500, kd 0..50". */
void rmdd_mit_ranges_text(const struct rmd_mit_ranges *r, char *buf, size_t len);

/*
 * What was decided of the MIT scaling of a motor of dialect d in MIT mode
 * (dec, for firmware `version` and model `model`; mit.c), as a clause of
 * its line: "MIT scaling ...: ..." and why, or "MIT refused ..." and what
 * to write.  Non-rt.
 */
void rmdd_mit_text(const struct rmd_dialect *d, const struct rmd_mit_decision *dec,
		   uint32_t version, const char *model, char *buf, size_t len);

/*
 * What `rmdd --check-config` can say of motor i's MIT scaling, which
 * bring-up decides from the firmware it reads: what its entry names, and
 * what each firmware of its dialect would make of it (mit.c).  Non-rt.
 */
void rmdd_mit_config_note(const struct rmd_config *cfg, unsigned i, char *buf, size_t len);

/* ---- buses (rmdd_buses.c) ----------------------------------------------- */

/*
 * Open every bus of cfg into buses[] (cfg->n_buses of them, in config
 * order; sim buses with their simulator settings in sim), with the plan's burst for SocketCAN.  On failure logs which bus
 * and how to fix it, closes what it opened and returns -errno.
 */
struct rmd_sim_setup;
int rmdd_buses_open(const struct rmd_config *cfg, const struct rmd_sim_setup *sim,
		    const struct rmd_plan *plan, struct rmd_bus buses[RMD_MAX_BUSES]);

/* Close n buses (rmd_bus_close() on each). */
void rmdd_buses_close(struct rmd_bus *buses, unsigned n);

/* ---- LCM (rmdd_lcm.c) ----------------------------------------------------- */

/* Fill bridge options from the configuration, the plan and the hand-overs. */
void rmdd_lcm_opts(struct rmd_bridge_opts *o, const struct rmd_config *cfg,
		   const struct rmd_plan *plan, const struct rmd_loop *loop,
		   struct rmd_latest *commands, struct rmd_latest *snapshots,
		   struct rmd_latest *health);

/* Tell the incident recorder of intruding controllers (in NULL: nobody). */
void rmdd_lcm_incidents(struct rmd_bridge_opts *o, struct rmdd_incidents *in);

/* After rmd_bridge_start(): says, at info level, when SCHED_FIFO was refused. */
void rmdd_lcm_started(struct rmd_bridge *b);
/*
 * One line on cfg's robot: section (docs/robot.md), for the start and
 * --check-config; "" for a daemon alone.  Non-rt.
 */
void rmdd_robot_note(const struct rmd_config *cfg, char *buf, size_t len);

/*
 * Before bring-up: listen for another daemon on the URL and prefix.
 * Alone: 0.  Another one: without force, log an error naming it and the
 * ways out, -EEXIST; with force, log a warning, 0.  Non-rt.
 */
int rmdd_lcm_alone(struct rmd_bridge *b, bool force);

/* ---- statistics (rmdd_stats.c) --------------------------------------------- */

struct rmdd_stats_src {
	const struct rmd_config *cfg;
	const struct rmd_plan *plan;
	struct rmd_loop *loop;
	struct rmdd_monitor *mon;
	struct rmd_bridge *bridge; /* NULL: no LCM */
	struct rmd_ring *events;
	int64_t start_ns; /* CLOCK_MONOTONIC when the loop started */
};

/* The statistics on stderr, whatever -q says; `why` heads them ("SIGUSR1", "exit"). */
void rmdd_stats_print(const struct rmdd_stats_src *s, const char *why);

/*
 * The one-line STATUS= summary: "12 motors: enabled 0, ready 12; loop 1000 Hz,
 * p99 45 us, 0 overruns; controller idle; loop ok".  hz: measured cycles per
 * second; stalled: the heartbeat did not advance.
 */
void rmdd_stats_status(const struct rmdd_stats_src *s, double hz, bool stalled, char *buf,
		       size_t len);

/* ---- systemd (rmdd_notify.c) --------------------------------------------- */

struct rmdd_notify {
	bool active;	       /* NOTIFY_SOCKET is set */
	int64_t watchdog_ns;   /* WATCHDOG_USEC for this process; 0: no watchdog */
	int64_t ping_every_ns; /* half of it, as sd_watchdog_enabled(3) advises */
};

/* Read the environment.  Nothing is ever sent when NOTIFY_SOCKET is unset. */
void rmdd_notify_init(struct rmdd_notify *n);
void rmdd_notify_ready(const struct rmdd_notify *n, const char *status);
void rmdd_notify_status(const struct rmdd_notify *n, const char *status);
void rmdd_notify_watchdog(const struct rmdd_notify *n);
void rmdd_notify_stopping(const struct rmdd_notify *n, const char *status);

#endif /* RMDD_H */
