/* SPDX-License-Identifier: MIT */
/*
 * The real-time loop (DESIGN.md layer 5): one SCHED_FIFO thread that, at
 * every tick of an absolute CLOCK_MONOTONIC schedule,
 *
 *   1. drains every bus (replies that arrived since the last tick, with
 *      their receive times), matches each reply to its motor by
 *      (bus, CAN id, command byte) -- never "the next frame" -- and updates
 *      that motor's state, reply latency and reply age;
 *   2. counts the requests whose reply deadline passed as missed (N in a
 *      row: the motor is lost and gets the safe action);
 *   3. takes the newest validated command from the bridge, runs the host
 *      watchdog and each motor's lifecycle;
 *   4. sends this cycle's frames (rmd_plan_cycle()) on every bus, setpoints
 *      converted, clamped and encoded by rmd/motor.h;
 *   5. publishes a state snapshot (and ~10 Hz health) to the bridge;
 *   6. sleeps to the next tick; overruns are counted and the schedule skips
 *      ahead, never catching up in a burst.
 *
 * No allocation, no stdio, no locks, no LCM in the thread: events go to an
 * rmd_ring that a normal thread logs.  Everything is allocated and touched
 * by rmd_loop_new() before the thread starts.
 *
 * For tests the same cycle runs without a thread and with an injected
 * clock: rmd_loop_cycle(l, now) does steps 1..5 for the tick at `now`.
 */
#ifndef RMD_LOOP_H
#define RMD_LOOP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/plan.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

struct rmd_loop;

struct rmd_loop_opts {
	const struct rmd_config *cfg; /* must outlive the loop */
	const struct rmd_plan *plan;  /* built from cfg, must outlive the loop */
	struct rmd_bus *buses;	      /* cfg->n_buses open buses, in config order */
	struct rmd_latest *commands;  /* bridge -> loop: struct rmd_command */
	struct rmd_latest *snapshots; /* loop -> bridge: struct rmd_snapshot */
	struct rmd_latest *health;    /* loop -> bridge: struct rmd_health */
	struct rmd_ring *events;      /* loop -> logger: struct rmd_event */
	/* Time source; NULL: clock_gettime(CLOCK_MONOTONIC).  Tests inject one. */
	int64_t (*now_ns)(void *ctx);
	void *now_ctx;
	bool require_rt; /* refuse to run without SCHED_FIFO and mlockall */
};

/* Allocate and prefault everything the loop will touch.  NULL + err on failure.  Non-rt. */
struct rmd_loop *rmd_loop_new(const struct rmd_loop_opts *opts, char *err, size_t errlen);

/* free(NULL)-style: a NULL loop is a no-op.  Non-rt. */
void rmd_loop_free(struct rmd_loop *l);

/*
 * Bring-up, before the thread starts (non-rt, may block for a bounded
 * time): probe every motor (0xB5 model, 0xB2 version, 0x9A status), write
 * the configured 0xB3 comm-loss time once and check its echo.  Fills
 * `report` with one line per motor (found, missing, unexpected).  Returns
 * 0, or -ENODEV when a motor is missing and the config says refuse.
 */
int rmd_loop_bringup(struct rmd_loop *l, char *report, size_t len);

/*
 * One cycle for the tick at now_ns (steps 1..5 above).  rt-safe.  The
 * thread calls it; tests call it directly with their own clock.
 */
void rmd_loop_cycle(struct rmd_loop *l, int64_t now_ns);

/*
 * Stop every motor: V3 0x280 broadcast of 0x81/0x80 where every motor on a
 * bus is V3 with the CAN filter off, else one frame per motor; brakes if
 * configured.  The motors' 0xB3 protection stays in place.  rt-safe.
 */
void rmd_loop_stop_motors(struct rmd_loop *l, int64_t now_ns);

/*
 * Start the SCHED_FIFO thread (priority and CPU affinity from the config,
 * mlockall, prefaulted stack).  Without the privilege it says so once
 * through the event ring and runs at normal priority, unless require_rt.
 * Returns 0 or -errno.  Non-rt.
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

#endif /* RMD_LOOP_H */
