/* SPDX-License-Identifier: MIT */
/*
 * The incident recorder's ring (docs/design.md "Incidents", layer rt): the
 * last few seconds of every bus's frames, the motors' states, the commands
 * the loop took and the loop's events, kept by the rt loop so that a
 * normal thread can write them out after a safety event.
 *
 * Each kind of record has its own ring (one per bus for frames) that
 * overwrites its oldest record: the loop never waits and never refuses.
 * rmd_incident_ring_new() allocates and touches everything before the
 * loop starts, sized from the window (seconds before + after the event,
 * and slack for the writer's wake-up) times the plan's frames per cycle
 * and the loop rate; the loop's calls only copy a record in.  A reader
 * copies a ring out and keeps only the records the loop cannot have
 * overwritten while it copied (a sequence check, as rmd_loop_get_*()).
 *
 * One writer (the rt loop) and one reader at a time.
 */
#ifndef RMD_INCIDENT_H
#define RMD_INCIDENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/frame.h"
#include "rmd/plan.h"
#include "rmd/state.h"

/* Direction of a recorded frame. */
enum rmd_incident_dir {
	RMD_INCIDENT_RX = 0, /* received, at its receive time */
	RMD_INCIDENT_TX,     /* taken by the bus, at the cycle's start */
};

struct rmd_incident_frame {
	int64_t t_ns; /* CLOCK_MONOTONIC */
	uint8_t dir;  /* enum rmd_incident_dir */
	struct rmd_frame f;
};

/* One motor's state after one cycle (struct rmd_motor_state, the fields a post-mortem reads). */
struct rmd_incident_state {
	int64_t t_ns;
	uint64_t cycle;
	uint8_t motor; /* config index */
	uint8_t lifecycle;
	uint8_t mode;
	uint16_t error_code;
	uint32_t reply_age_cycles;
	double pos_rad, vel_rad_s, torque_nm, current_a, temp_c, voltage_v;
};

/* One motor's entry of a command the loop took. */
struct rmd_incident_command {
	int64_t t_ns;  /* the cycle that took it */
	int64_t rx_ns; /* when it arrived at the bridge (rmd_command.rx_ns) */
	int64_t seq;   /* the controller's sequence number */
	uint8_t motor; /* config index */
	struct rmd_setpoint sp;
};

/* Events kept beside the frames (a window's worth: they come on change only). */
#define RMD_INCIDENT_EVENTS 4096
/* The writer's wake-up and copy may lag the window's end by this much. */
#define RMD_INCIDENT_SLACK_NS 1000000000

struct rmd_incident_ring;

/*
 * A ring for cfg and plan that holds window_ns (the seconds before and
 * after an event) plus RMD_INCIDENT_SLACK_NS.  NULL + err on failure.
 * Non-rt.
 */
struct rmd_incident_ring *rmd_incident_ring_new(const struct rmd_config *cfg,
						const struct rmd_plan *plan, int64_t window_ns,
						char *err, size_t errlen);

/* free(NULL)-style.  Non-rt. */
void rmd_incident_ring_free(struct rmd_incident_ring *r);

/* Bytes the ring holds (what rmdd says it locked for it).  Any thread. */
size_t rmd_incident_ring_bytes(const struct rmd_incident_ring *r);

/*
 * The loop's side: copy records in, overwriting the oldest.  n frames a
 * bus took at t_ns; n frames received (each at its rx time); a motor state
 * a motor of s; a record a motor of c's setpoints.  rt-safe.
 */
void rmd_incident_tx(struct rmd_incident_ring *r, unsigned bus, const struct rmd_frame *f,
		     unsigned n, int64_t t_ns);
void rmd_incident_rx(struct rmd_incident_ring *r, unsigned bus, const struct rmd_bus_rx *rx,
		     unsigned n);
void rmd_incident_snapshot(struct rmd_incident_ring *r, const struct rmd_snapshot *s);
void rmd_incident_command(struct rmd_incident_ring *r, const struct rmd_command *c, int64_t t_ns);
void rmd_incident_event(struct rmd_incident_ring *r, const struct rmd_event *e);

/*
 * A copy of the ring's records from from_ns on, oldest first, for a
 * normal thread to write out.  rmd_incident_window_new() sizes it for r.
 */
struct rmd_incident_window {
	unsigned n_buses;
	struct rmd_incident_frame *frames[RMD_MAX_BUSES];
	size_t n_frames[RMD_MAX_BUSES];
	struct rmd_incident_state *states;
	size_t n_states;
	struct rmd_incident_command *commands;
	size_t n_commands;
	struct rmd_event *events;
	size_t n_events;
	/* Capacities (from the ring). */
	size_t cap_frames[RMD_MAX_BUSES], cap_states, cap_commands, cap_events;
};

/* Non-rt.  NULL on failure (ENOMEM). */
struct rmd_incident_window *rmd_incident_window_new(const struct rmd_incident_ring *r);
void rmd_incident_window_free(struct rmd_incident_window *w);

/*
 * Copy every record with from_ns <= t_ns <= to_ns into w (any thread; one
 * reader at a time, while the loop writes).  Records after to_ns the loop
 * wrote while the reader waited stay out: they belong to the next window.
 * Non-rt.
 */
void rmd_incident_read(const struct rmd_incident_ring *r, int64_t from_ns, int64_t to_ns,
		       struct rmd_incident_window *w);

#endif /* RMD_INCIDENT_H */
