/* SPDX-License-Identifier: MIT */
/*
 * The real-time loop (docs/design.md, layer rt): one SCHED_FIFO thread that, at
 * every tick of an absolute CLOCK_MONOTONIC schedule,
 *
 *   1. drains every bus (replies that arrived since the last tick, with
 *      their receive times), matches each reply to its motor by
 *      (bus, CAN id, command byte) -- never "the next frame" -- and updates
 *      that motor's state, reply latency and reply age, and reads each
 *      bus's state (a change is an event);
 *   2. counts the requests whose reply deadline passed as missed (N in a
 *      row: the motor is lost and gets the safe action);
 *   3. takes the newest validated command from the bridge, runs the host
 *      watchdog and each motor's lifecycle;
 *   4. sends this cycle's frames (rmd_plan_cycle()) on every bus, setpoints
 *      converted, clamped and encoded by rmd/motor.h; on a bus nobody
 *      acknowledges (RMD_BUS_NO_ACK) none that acts on a motor (below,
 *      "No acknowledgement");
 *   5. waits for the replies to this cycle's requests (a wake when the
 *      last is expected from the motors' recent round trips, then the
 *      buses' readiness) and, as soon as they are in or the next tick is
 *      near, publishes a state snapshot (and ~10 Hz health) to the bridge
 *      and, under a sequence lock, to rmd_loop_get_*(): the controller
 *      can answer a cycle's measurements in the next cycle's frames;
 *   6. sleeps to the next tick; overruns are counted and the schedule skips
 *      ahead, never catching up in a burst.
 *
 * No allocation, no stdio, no locks, no LCM in the thread: events go to an
 * rmd_ring that a normal thread logs.  Everything is allocated and touched
 * by rmd_loop_new() before the thread starts.
 *
 * For tests the same cycle runs without a thread and with an injected
 * clock: rmd_loop_cycle(l, now) does steps 1..5 for the tick at `now`,
 * publishing at once; rmd_loop_tick(), rmd_loop_collect() and
 * rmd_loop_publish() are its parts, as the thread runs them.
 *
 * Matching and deadlines.  Each motor keeps a small ring of its
 * outstanding requests (reply identifier, command byte, send time); a
 * reply takes the oldest one it matches, and its latency is its receive
 * time minus that send time.  A request unanswered by its deadline (send
 * time + the larger of 2 periods and the bus's worst-case cycle plus
 * RMD_LOOP_REPLY_MARGIN_NS; RS485 buses, whose requests wait for one
 * another, thus get longer) is missed, and so is one the bus did not take.  A reply that repeats its request
 * byte for byte where the command does not echo is the "only echoed"
 * first frame after a comm-loss trip: the motor is there, its values are
 * not.  Unmatched frames: 0x9A updates temperature, voltage and errors,
 * 0xF1 (the motor's comm-loss protection tripped) makes the motor lost,
 * anything else is counted and reported (RMD_EV_UNEXPECTED, at most once
 * a second per bus).
 *
 * Lifecycle (docs/design.md "The life of a motor": what each state says
 * of the motor's output and brake).  PROBE until bring-up (or a first
 * reply); a motor becomes READY only through STOPPING: 0x80 output off
 * and 0x78 brake locked, sent in its control slots until the motor echoed
 * each (lifecycle.c "Owed frames"), from whatever state: found at
 * bring-up, enable = 0, back from FAULT or LOST.  READY motors are only
 * read (0x9C in their control slot, 0x9A polls), never moved; a command
 * with enable = 1 makes a READY or SAFE motor ENABLED (0x77 brake release
 * once, V3 §2.26, then its setpoints).  Error flags (0x9A) -> FAULT: 0x80,
 * and 0x78 as rmd_config_fault_brakes() says, until echoed (a faulted motor
 * runs no control command, V3 §2.17.1: no safe action); cleared ->
 * STOPPING.  safety.missed_replies_lost missed replies in a row -> LOST,
 * with the safe action for the motor (and every enabled motor, SAFE, when
 * lost_motor_action is all); a LOST motor is re-probed with 0x9A every
 * RMD_LOOP_REPROBE_NS and returns to STOPPING.  A motor that returns from
 * LOST or FAULT, or was made SAFE (by the host watchdog too), needs an
 * explicit enable = 0 before enable = 1 takes it again, so a controller
 * streaming enable = 1 does not restart it unawares.  The loop keeps only
 * the newest command, so it sees the enable = 0 entries through
 * rmd_command.disables[] (counted by the bridge): a count that changed
 * since the last command is an enable = 0, acted on before the command's
 * own entry, however quickly the enable = 1 followed it.  An enable = 1
 * the loop does not act on is counted by reason (rmd_loop_counters
 * ignored[], rmd_health ignored[]).  Host watchdog, per motor: an ENABLED
 * motor that no command carried with enable = 1 for
 * safety.command_timeout_ms -> the safe action (SAFE), RMD_WD_TRIPPED,
 * latched: the motor takes enable = 1 again only after an enable = 0 (the
 * edge rule), both newer than the trip; RMD_WD_OK once an enable acts.
 *
 * Comm-loss protection.  Each motor's own protection (0xB3, V3 §2.30) is
 * a precondition of motion (enum rmd_comm_loss, rmd/state.h): a READY or
 * SAFE motor that is not armed is not enabled.  Bring-up writes it last;
 * the loop writes it again (rounds of up to 3 writes, one-shots in the
 * control slot behind a 0x9A that takes a tripped motor's echo, matched
 * like the others) when a motor answers after PROBE
 * or LOST (found late, or back and perhaps swapped), and when an enable
 * arrives for a motor that is not armed (at most one round a second: the
 * write goes to ROM).  An enable during a round waits for it and applies
 * once the motor is armed (if commands still arrive); a failed round
 * refuses it, as it does an enable within a second of it: counted (health
 * unarmed_rejects) and reported once per episode (RMD_EV_COMM_LOSS).  FAULT -> READY keeps
 * the protection (the motor answered all along).  A motor whose
 * comm_loss_ms is 0 by config, and a V2 motor (no 0xB3), are not held
 * back.
 *
 * Position after a power cycle (rmd/multiturn.h).  A motor's multi-turn
 * count is RAM, so at bring-up and on every LOST -> READY the loop decides
 * on the first position it receives whether to trust it (struct
 * rmd_motor_state pos_trust, pos_certain): the motor keeps its count, or
 * its travel band admits one position, which it is shifted to (the zero
 * offset moves by whole rotor turns).  For a motor whose position is
 * uncertain, a setpoint that drives to a position (rmd_setpoint_needs_pos():
 * position mode, MIT with kp > 0) is not acted on (RMD_IGN_POS_UNCERTAIN,
 * RMD_EV_POS_REFUSED once per episode), and an ENABLED motor that switches
 * to one gets the safe action (SAFE).  Homing requests (opts.homes, struct
 * rmd_home) make it certain: a shift of the reported frame, never a
 * motion; refused while the motor is ENABLED or has no position yet
 * (RMD_EV_HOME_REFUSED).  On the hot path this is one flag test per enabled
 * motor and per reply.
 *
 * Safe actions, per motor: stop 0x80; hold 0x81; brake 0x80 then 0x78;
 * damp: MIT frames with kp 0, kd > 0 in every control slot (MIT motors),
 * else 0xA2 speed 0 once.  A setpoint with NaN/Inf is never encoded: the
 * first frame of the safe action goes out instead, and is counted.
 *
 * Frames.  Each bus gets exactly the requests rmd_plan_cycle() lists, in
 * one send call; what the bus does not take is counted (plan_misses) and
 * dropped (setpoints are never sent late), except one-shot frames (0x80,
 * 0x78, 0x81, ...), which wait for the next cycle, and owed frames
 * (0x80, 0x78 of a STOPPING or FAULT motor), sent again until echoed.  A
 * control slot of a motor that is not ENABLED carries an owed frame if it
 * owes one, else a one-shot if one waits, else a status read (0x9C on
 * 0x140 + ID; for MIT motors too: it cannot move the motor, while even a
 * zero-gain MIT frame would take it out of its brake-held stand-still).
 * The V2 0x280 frame is a torque command to every batched motor (V2 §4.1:
 * it cannot skip one, and 0 A switches a motor's output on), so it goes
 * out only while every batched motor is ENABLED, past its brake release,
 * in torque mode and owes nothing, and no motor the configuration does
 * not list has answered on the bus (issue 33 points 1 and 2; a bus entry's
 * can_id_filter says such motors ignore the frame).  Otherwise
 * the slot carries the batched motors' own frames, each as its lifecycle
 * says (the control slot above), rmd_plan_bus.batch_own of them a cycle
 * in turn.
 *
 * No acknowledgement (docs/faults.md "E-stop").  A bus whose state is
 * RMD_BUS_NO_ACK (its motors' power is off) takes nothing that acts on a
 * motor: what it takes stays queued and goes out first when power
 * returns.  The first cycle that sees it has the bus flush what it holds
 * (rmd_bus_flush(): SocketCAN restarts the interface; RMD_EV_BUS_FLUSH
 * says how that went).  Each control slot of its motors counts as a
 * missed reply (LOST after missed_replies_lost), their one-shots (a safe
 * action, a brake release, a 0xB3) are dropped, and only the LOST motors'
 * re-probes (0x9A, a read) are written.  Acknowledged again, every motor
 * of the bus that is not LOST is made LOST: all come back as lost motors
 * do (STOPPING, 0x80 and 0x78 echoed, 0xB3 written and verified, the
 * position decided again) before anything moves them.
 *
 * Measured values not yet received are NaN in the snapshot.
 */
#ifndef RMD_LOOP_H
#define RMD_LOOP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/motor.h"
#include "rmd/plan.h"
#include "rmd/spsc.h"
#include "rmd/hist.h"
#include "rmd/incident.h"
#include "rmd/state.h"

struct rmd_loop;

struct rmd_loop_opts {
	const struct rmd_config *cfg; /* must outlive the loop */
	const struct rmd_plan *plan;  /* built from cfg, must outlive the loop */
	struct rmd_bus *buses;	      /* cfg->n_buses open buses, in config order */
	struct rmd_latest *commands;  /* bridge -> loop: struct rmd_command */
	struct rmd_latest *homes;     /* bridge -> loop: struct rmd_home; NULL: none */
	struct rmd_latest *snapshots; /* loop -> bridge: struct rmd_snapshot */
	struct rmd_latest *health;    /* loop -> bridge: struct rmd_health */
	struct rmd_ring *events;      /* loop -> logger: struct rmd_event */
	/*
	 * The incident recorder (rmd/incident.h): every frame, state, command
	 * and event is copied in; NULL: none.  Must outlive the loop.
	 */
	struct rmd_incident_ring *incidents;
	/*
	 * An eventfd (non-blocking) the loop writes after each snapshot, so the
	 * bridge publishes it at once instead of at its next poll; -1: none
	 * (0 is a valid descriptor).
	 */
	int snapshot_fd;
	/* Time source; NULL: clock_gettime(CLOCK_MONOTONIC).  Tests inject one. */
	int64_t (*now_ns)(void *ctx);
	void *now_ctx;
	/*
	 * Bring-up and rmd_loop_stop_motors() wait for replies in steps of
	 * this (ctx: now_ctx); NULL: clock_nanosleep(), or poll(2) on a
	 * bus's fd.  A test with an injected clock advances it here.
	 */
	void (*sleep_ns)(void *ctx, int64_t ns);
	bool require_rt; /* refuse to run without SCHED_FIFO and mlockall */
};

/* A lost motor is re-probed (0x9A) this often: 2 Hz. */
#define RMD_LOOP_REPROBE_NS 500000000
/*
 * Reply deadline beyond a bus's worst-case cycle (docs/design.md: a motor answers
 * in 0.5-0.8 ms, USB adapters add ~1 ms): 3 ms at 1 kHz on a full bus.
 */
#define RMD_LOOP_REPLY_MARGIN_NS 2000000
/* Bring-up: tries per request and the wait of one try (RS485: its reply timeout + 1 ms). */
#define RMD_LOOP_PROBE_TRIES 3
#define RMD_LOOP_PROBE_TIMEOUT_NS 5000000
/* Stack the rt thread gets, and how much of it is touched before the first cycle. */
#define RMD_LOOP_STACK_SIZE (1024 * 1024)
#define RMD_LOOP_PREFAULT_STACK (256 * 1024)

/* What RMD_EV_RT (rmd/state.h) reports in b: which real-time request failed. */
enum {
	RMD_LOOP_RT_MLOCK = 1,	   /* mlockall() failed */
	RMD_LOOP_RT_FIFO = 2,	   /* SCHED_FIFO refused: normal priority */
	RMD_LOOP_RT_AFFINITY = 3,  /* the CPU affinity could not be set */
	RMD_LOOP_RT_CPU_AWAKE = 4, /* loop.keep_cpus_awake: /dev/cpu_dma_latency refused */
};

/* Counters beyond struct rmd_loop_stats (rmd_loop_get_counters()). */
struct rmd_loop_counters {
	uint64_t replies;     /* matched to a request */
	uint64_t missed;      /* requests whose deadline passed */
	uint64_t echoes;      /* requests echoed instead of answered (after a comm-loss trip) */
	uint64_t unsolicited; /* used without a request: 0x9A reports, 0xF1 */
	uint64_t unexpected;  /* neither matched nor used, nor the answer of a request given up */
	/*
	 * answers of rmdd's own requests that came after their deadline (a
	 * reply the cycle gave up on, a bring-up try retried): counted, not used
	 */
	uint64_t late;
	int64_t late_max_ns;	  /* the latest of them, request sent to answer received */
	uint64_t bad_replies;	  /* matched, but could not be decoded */
	uint64_t nonfinite;	  /* setpoints with NaN/Inf: safe frame sent instead */
	uint64_t unsupported;	  /* setpoints in a mode the motor cannot take: same */
	uint64_t clamped;	  /* setpoints clamped to a limit */
	uint64_t frames_not_sent; /* frames a bus did not take */
	uint64_t commands;	  /* commands taken from the bridge */
	uint64_t safe_actions;	  /* safe actions applied, per motor */
	uint64_t watchdog_trips;  /* the command watchdog tripped (robot stops not counted) */
	uint64_t owed_resends;	  /* owed 0x80/0x78 sent again: no echo yet (lifecycle.c) */
	uint64_t ignored[RMD_IGN_KINDS]; /* enable = 1 entries not acted on, by enum rmd_ignore */
	uint64_t homes_refused;		 /* homing requests refused (RMD_EV_HOME_REFUSED) */
};

/* Allocate and prefault everything the loop will touch.  NULL + err on failure.  Non-rt. */
struct rmd_loop *rmd_loop_new(const struct rmd_loop_opts *opts, char *err, size_t errlen);

/* free(NULL)-style: a NULL loop is a no-op.  Non-rt. */
void rmd_loop_free(struct rmd_loop *l);

/* Bring-up, before the thread starts: rmd_loop_bringup() in rmd/bringup.h. */

/*
 * One cycle for the tick at now_ns (steps 1..5 above), its state published
 * at once, before any reply to its requests can be in: rmd_loop_tick() +
 * rmd_loop_publish().  rt-safe.  Tests call it with their own clock.
 */
void rmd_loop_cycle(struct rmd_loop *l, int64_t now_ns);

/* The cycle's steps 1..4 for the tick at now_ns; nothing published.  rt-safe. */
void rmd_loop_tick(struct rmd_loop *l, int64_t now_ns);

/*
 * Step 5's receive: take every frame the buses have by now_ns.  True when
 * no reply this cycle's tick asked for is awaited any more: each motor
 * that answers (it answered its last request) has answered.  rt-safe.
 */
bool rmd_loop_collect(struct rmd_loop *l, int64_t now_ns);

/*
 * Step 5's wait, as the thread decides it at now_ns: 0 when no reply of
 * the cycle is awaited (publish now); the time the last awaited one is
 * expected (collect then); -1 when it is expected too close to the next
 * tick for a controller to answer it in time, or the state is out: the
 * next tick publishes after its receive.  rt-safe.
 */
int64_t rmd_loop_reply_due(const struct rmd_loop *l, int64_t now_ns);

/*
 * Step 5's publish: the cycle's state snapshot (and health when due) to
 * the bridge and rmd_loop_get_*(), stamped now_ns; then the next cycle
 * may tick.  Once per cycle: a second call is a no-op.  rt-safe.
 */
void rmd_loop_publish(struct rmd_loop *l, int64_t now_ns);

/*
 * Stop every motor with safety.shutdown_action (rmd/config.h): stop, 0x80
 * (output off) to every motor; brake, 0x80 and 0x78 (brake locked) to
 * every motor; hold, 0x81 (stop and hold the position) to the motors that
 * are ENABLED or SAFE and 0x80 to the others; damp, the damp safe action
 * to the ENABLED and SAFE motors once a period for shutdown_damp_ms, then
 * brake; default, brake when safe_action is brake, else stop.  One frame
 * of each kind per motor.  With brake (and damp) the driven motors are
 * STOPPING, READY once they echoed both frames; with stop and hold they
 * are SAFE (their brakes stay open).  The V3 0x280 broadcast would do it in one frame,
 * but it reaches only motors whose CAN-ID filter is off (V3 §3, 0x20
 * index 2), and the configuration cannot promise that, so it is not used.
 * The motors' 0xB3 protection stays in place.  Frames the bus refuses are
 * sent again for at most ~10 ms (opts.sleep_ns or clock_nanosleep between
 * tries), and then their echoes are awaited for at most one reply
 * deadline, so they are on the wire when it returns.  Bounded, blocking
 * (it sleeps between tries; no allocation): not for the cycle, but fine at
 * the end of the rt thread or in a test.
 */
void rmd_loop_stop_motors(struct rmd_loop *l, int64_t now_ns);

/*
 * After rmd_loop_stop_motors(): whether motor i's final frames were taken
 * by its bus and answered (false: a bus that took nothing, bus-off, or a
 * motor that did not answer them: not known to be stopped).  Non-rt.
 */
bool rmd_loop_stop_reached(const struct rmd_loop *l, unsigned i);

/*
 * mlockall(MCL_CURRENT | MCL_FUTURE), once.  rmd_loop_start() does it if
 * nobody did; the daemon calls it before bring-up, because locking a big
 * process can take long and must not fall between the 0xB3 writes and the
 * first cycle.  Without the privilege it says so through the event ring
 * and returns 0, unless require_rt (then -EPERM).  Non-rt.
 */
int rmd_loop_lock_memory(struct rmd_loop *l);

/*
 * Start the SCHED_FIFO thread (priority and CPU affinity from the config,
 * mlockall, prefaulted stack).  Without the privilege it says so once
 * through the event ring (RMD_EV_RT) and runs at normal priority,
 * unless require_rt: then -EPERM.  Between ticks the thread collects
 * replies from the buses that have a descriptor (poll(2)), so RS485 queues
 * advance and replies are stamped as they come; buses without one (sim)
 * are read at the next tick.  The thread runs on CLOCK_MONOTONIC: -EINVAL
 * when opts.now_ns was given; -EBUSY when it runs already.  Returns 0 or
 * -errno.  Non-rt.
 */
int rmd_loop_start(struct rmd_loop *l);

/*
 * Ask the thread to stop the motors and exit; async-signal-safe.  Then
 * rmd_loop_join() waits for it.  Returns 0 or -errno.
 */
void rmd_loop_request_stop(struct rmd_loop *l);
int rmd_loop_join(struct rmd_loop *l);

/*
 * Cycles completed so far (an atomic counter): the systemd watchdog is fed
 * only while it advances, so a stuck loop is not kept alive by a timer.
 * rt-safe.
 */
uint64_t rmd_loop_heartbeat(const struct rmd_loop *l);

/* Copy of the loop's statistics so far; safe from any thread. */
void rmd_loop_get_stats(const struct rmd_loop *l, struct rmd_loop_stats *out);

/* Copy of the newest snapshot; safe from any thread (non-rt). */
void rmd_loop_get_snapshot(const struct rmd_loop *l, struct rmd_snapshot *out);

/* Copy of the counters so far; safe from any thread. */
void rmd_loop_get_counters(const struct rmd_loop *l, struct rmd_loop_counters *out);

/*
 * Wake-up lateness (issue 11): how late each cycle started after its
 * intended tick, counting every period a stall skipped (a 30 ms stall at
 * 1 kHz is one wake-up 30 ms late, plus 29 overruns), as cyclictest counts
 * its own.  Buckets of 1 us as cyclictest -h: us[k] counts wake-ups late
 * by k us to k + 1 us (exclusive), k < RMD_LOOP_WAKE_US_BUCKETS; `over`
 * the later ones.  struct rmd_loop_stats' wake_* figures are the same
 * samples (p99 to 1 us below RMD_LOOP_WAKE_US_BUCKETS us, to 25 % above:
 * rmd/hist.h).
 */
#define RMD_LOOP_WAKE_US_BUCKETS 1000
/*
 * The health's wake_p99_ns (struct rmd_health, health_t.wake_p99_us) is the
 * p99 of the wake-ups of the last RMD_LOOP_WAKE_WIN_S seconds (whole
 * seconds of CLOCK_MONOTONIC: the current one and the nine before it), so
 * that it follows the load; the stats' (rmd_loop_get_stats(), the exit
 * statistics) is since start.
 */
#define RMD_LOOP_WAKE_WIN_S 10
struct rmd_loop_wake_hist {
	uint64_t n;
	uint64_t us[RMD_LOOP_WAKE_US_BUCKETS];
	uint64_t over;
};

/*
 * One motor's reply latency, from the loop's own stamps: the request's
 * send (the cycle's start) to the reply's receive time (the kernel's stamp
 * on SocketCAN), every matched reply; hist[] in rmd/hist.h's buckets (4
 * an octave: a percentile within 25 %).
 */
struct rmd_latency {
	uint64_t n;
	int64_t min_ns, max_ns, sum_ns;
	uint32_t hist[RMD_HIST_BUCKETS];
};

/*
 * An eventfd (non-blocking) the loop writes at the end of a cycle that
 * pushed events into opts->events, so that their reader sleeps until there
 * is something to read; -1: none.  Non-rt: before the loop's thread starts,
 * or after it stopped.
 */
void rmd_loop_set_events_fd(struct rmd_loop *l, int fd);

/* Copies of the histograms so far; safe from any thread (non-rt; spins while the loop writes). */
void rmd_loop_get_wake_hist(const struct rmd_loop *l, struct rmd_loop_wake_hist *out);
/* Motor i's reply latency; false for i out of range. */
bool rmd_loop_get_reply_latency(const struct rmd_loop *l, unsigned i, struct rmd_latency *out);

/* The 99th percentile of lat (rounded up to its bucket's bound, at most max_ns); 0 without samples. */
int64_t rmd_latency_p99(const struct rmd_latency *lat);

/*
 * Motor i's record (rmd/motor.h), built by rmd_loop_new(): its identity,
 * limits and ranges do not change, so any thread may read them; NULL for
 * i out of range.  Non-rt.
 */
const struct rmd_motor *rmd_loop_motor(const struct rmd_loop *l, unsigned i);

/*
 * Motor i's comm-loss protection (enum rmd_comm_loss) as the loop holds it
 * now; RMD_CL_PENDING for i out of range.  Not synchronised with the
 * thread: call it before rmd_loop_start() or after rmd_loop_join() (the
 * health carries it while the thread runs).  Non-rt.
 */
uint8_t rmd_loop_comm_loss(const struct rmd_loop *l, unsigned i);

/*
 * Copy of the newest health (the one the loop also puts in opts.health,
 * every lcm.health_period_ms); safe from any thread (non-rt).  Returns
 * false, *out untouched, before the loop has made one.
 */
bool rmd_loop_get_health(const struct rmd_loop *l, struct rmd_health *out);

#endif /* RMD_LOOP_H */
