/* SPDX-License-Identifier: MIT */
/*
 * Injected faults of the simulator (docs/design.md, layer sim): one engine for the
 * in-process wire (rmd/sim_wire.h, simulated time) and rmd-sim on a real
 * wire (CLOCK_MONOTONIC).
 *
 * The engine never reads a clock: every time it is given is on the fault
 * table's own axis, nanoseconds from the table's start (the wire's time
 * for the in-process wire; time since start-up for rmd-sim, which
 * subtracts its start).  Times it only shifts (a DELAY's ready time) may be
 * on any axis.  What a window does to the motors or the wire when it opens
 * or closes is the caller's (it owns them); the engine says which windows
 * changed, what is in force now, and what happens to a frame.
 *
 * rt-safe: fixed arrays, loops bounded by RMD_SIM_MAX_FAULTS, no clock, no
 * allocation.  Not thread-safe: one owner.
 */
#ifndef RMD_SIM_FAULTS_H
#define RMD_SIM_FAULTS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/frame.h"

#define RMD_SIM_MAX_FAULTS 32 /* entries of a fault table (a bit each in a uint32_t) */

/*
 * Kinds of injected faults.  "Per frame" kinds act on each frame a
 * matching motor transmits (replies and unsolicited frames) while the
 * fault's window is open, with the fault's probability; "window" kinds act
 * for the whole window and ignore the probability.
 */
enum rmd_sim_fault_kind {
	RMD_SIM_FAULT_DROP = 0,	  /* per frame: the frame is lost */
	RMD_SIM_FAULT_DELAY,	  /* per frame: ready param ns later (>= 0) */
	RMD_SIM_FAULT_BAD_DLC,	  /* per frame: the DLC becomes param (0..7) */
	RMD_SIM_FAULT_GARBAGE,	  /* per frame: the data bytes become random bytes */
	RMD_SIM_FAULT_WRONG_ID,	  /* per frame: sent on the identifier of motor param (1..32) */
	RMD_SIM_FAULT_DISAPPEAR,  /* window: the motor hears and sends nothing
				   * (param 0: cable cut, it runs on); param 1:
				   * power lost, output off and brake locked at the
				   * start, it boots again at the end */
	RMD_SIM_FAULT_ERROR_FLAG, /* window: the motor reports error bits param
				   * (RMD_SIM_ERR_*), via rmd_sim_motor_set_error() */
	RMD_SIM_FAULT_BUS_OFF,	  /* window: bus-off, nothing is sent or received */
	RMD_SIM_FAULT_FLOOD,	  /* window: a foreign node sends a frame on can_id
				   * every param ns (it wins arbitration if can_id
				   * is low) */
	RMD_SIM_FAULT_BUS_POWER,  /* window: the motors' supply is cut (an e-stop):
				   * every motor is unpowered (hears and sends
				   * nothing, output off and brake locked) and
				   * boots at the end; no node acknowledges, so
				   * the host's frames stay queued (rmd/sim_wire.h) */
	RMD_SIM_FAULT_COUNT
};

/*
 * One entry of the fault table.  The window is [start_ns, end_ns); an
 * end_ns of 0 leaves it open.  Entries apply in table order, and a drop
 * ends the list for that frame.
 */
struct rmd_sim_fault {
	enum rmd_sim_fault_kind kind;
	uint8_t motor_id;   /* params id 1..32; 0: every motor (bus-wide kinds: must be 0) */
	double probability; /* per-frame kinds: chance per frame, 0..1 */
	int64_t start_ns;
	int64_t end_ns;
	int64_t param;	 /* see enum rmd_sim_fault_kind */
	uint32_t can_id; /* FLOOD: the foreign frames' 11-bit identifier */
	/*
	 * Per-frame kinds: only frames whose data[0] is cmd (a reply to that
	 * command, e.g. 0xB3); 0: every frame.  count: the fault hits at most
	 * this many frames (e.g. drop the first 0xB3 answer); 0: no limit.
	 */
	uint8_t cmd;
	uint32_t count;
};

/*
 * A fault table and the state of its windows.  Read the fields; change
 * them only through the functions below.
 */
struct rmd_sim_faults {
	struct rmd_sim_fault f[RMD_SIM_MAX_FAULTS];
	unsigned n;
	bool open[RMD_SIM_MAX_FAULTS];		   /* window kinds: open now */
	int64_t flood_next_ns[RMD_SIM_MAX_FAULTS]; /* FLOOD: its next frame is due */
	/* What the open windows do, kept at each change (a wire asks per frame). */
	bool bus_off;
	bool bus_unpowered;		     /* a BUS_POWER window is open */
	uint32_t absent;		     /* bit id - 1: an open DISAPPEAR hits motor id */
	uint32_t unpowered;		     /* ... one with param 1 (power lost) */
	uint16_t error_bits[RMD_MAX_MOTORS]; /* open ERROR_FLAG bits of motor id at [id - 1] */
	uint32_t hits[RMD_SIM_MAX_FAULTS];   /* per-frame kinds: frames hit, against count */
	/* The windows' next edge after last_ns, so an update between edges is a no-op. */
	int64_t last_ns, next_edge_ns;
};

/*
 * The kind's name ("drop", "delay", "bad_dlc", "garbage", "wrong_id",
 * "disappear", "error_flag", "bus_off", "flood", "bus_power"), the same in rmdd.yaml's
 * fault list and rmd-sim's --fault; NULL for an unknown kind.  rt-safe.
 */
const char *rmd_sim_fault_kind_name(enum rmd_sim_fault_kind kind);

/* Those names by kind, NULL-terminated (for a config schema's enum). */
extern const char *const rmd_sim_fault_kind_names[RMD_SIM_FAULT_COUNT + 1];

/*
 * The kind called `name`: its name, or an old spelling kept as an alias
 * ("bad-dlc", "wrong-id", "error-flag", "bus-off"); -EINVAL otherwise.
 * rt-safe.
 */
int rmd_sim_fault_kind_from_name(const char *name);

/*
 * What a kind is, beside its name: the one copy rmd_sim_fault_check(),
 * rmd-sim's --fault and rmdd.yaml's faults are held to.
 */
struct rmd_sim_fault_rule {
	bool window;   /* acts over its window, not per frame (its probability ignored) */
	bool bus_wide; /* acts on the whole bus: its motor_id must be 0 */
	/* the param it takes, lo..hi, and what it is; param_what NULL: it takes none, ignored */
	int64_t param_lo, param_hi;
	const char *param_what;
};

/* The rule of `kind`, or NULL for an unknown kind.  rt-safe. */
const struct rmd_sim_fault_rule *rmd_sim_fault_rule(enum rmd_sim_fault_kind kind);

/* Whether the kind acts over a window (DISAPPEAR..BUS_POWER) rather than per frame.  rt-safe. */
bool rmd_sim_fault_is_window(enum rmd_sim_fault_kind kind);

/*
 * 0 when the entry makes sense (kind, motor, window, probability, and the
 * param and can_id its kind allows), else -EINVAL.  rt-safe.
 */
int rmd_sim_fault_check(const struct rmd_sim_fault *f);

/* Whether fault f acts on the motor with params id `motor_id`.  rt-safe. */
bool rmd_sim_fault_hits(const struct rmd_sim_fault *f, uint8_t motor_id);

/* An empty table.  rt-safe. */
void rmd_sim_faults_init(struct rmd_sim_faults *fs);

/*
 * Replace the table by n entries, every window closed (the caller closes
 * what the old table's open windows did first).  Returns 0, -E2BIG, or
 * -EINVAL for an entry rmd_sim_fault_check() refuses (the table is then
 * unchanged).  rt-safe.
 */
int rmd_sim_faults_set(struct rmd_sim_faults *fs, const struct rmd_sim_fault *faults, size_t n);

/*
 * Open and close the windows as of time t: returns the mask (bit k: entry
 * k) of windows that changed; fs->open[k] says which way.  A window that
 * opens is counted in counts[kind] (a FLOOD counts frames instead, and its
 * first frame is due at its start).  rt-safe.
 */
uint32_t rmd_sim_faults_update(struct rmd_sim_faults *fs, int64_t t, uint64_t *counts);

/*
 * The per-frame faults on frame f that motor `motor_id` transmits,
 * produced at t: may change f, add a delay to *ready_ns (on any axis), and
 * draw from *rng.  Returns false when the frame is dropped.  Each hit is
 * counted in counts[kind].  rt-safe.
 */
bool rmd_sim_faults_frame(struct rmd_sim_faults *fs, uint64_t *rng, uint8_t motor_id, int64_t t,
			  struct rmd_frame *f, int64_t *ready_ns, uint64_t *counts);

/* What the open windows do now (motor_id 1..32).  rt-safe. */
static inline bool rmd_sim_faults_bus_off(const struct rmd_sim_faults *fs)
{
	return fs->bus_off;
}

static inline bool rmd_sim_faults_bus_unpowered(const struct rmd_sim_faults *fs)
{
	return fs->bus_unpowered;
}

static inline bool rmd_sim_faults_absent(const struct rmd_sim_faults *fs, uint8_t motor_id)
{
	return motor_id >= 1 && motor_id <= RMD_MAX_MOTORS && (fs->absent >> (motor_id - 1)) & 1;
}

static inline bool rmd_sim_faults_unpowered(const struct rmd_sim_faults *fs, uint8_t motor_id)
{
	return motor_id >= 1 && motor_id <= RMD_MAX_MOTORS && (fs->unpowered >> (motor_id - 1)) & 1;
}

static inline uint16_t rmd_sim_faults_error_bits(const struct rmd_sim_faults *fs, uint8_t motor_id)
{
	return motor_id >= 1 && motor_id <= RMD_MAX_MOTORS ? fs->error_bits[motor_id - 1] : 0;
}

/* Whether entry k is an open FLOOD whose next frame is due by t.  rt-safe. */
bool rmd_sim_faults_flood_due(const struct rmd_sim_faults *fs, unsigned k, int64_t t);

/*
 * FLOOD entry k's next frame (its can_id, 8 random data bytes from *rng),
 * due at the time returned; its next one falls due param ns later.
 * Counted in counts[RMD_SIM_FAULT_FLOOD].  rt-safe.
 */
int64_t rmd_sim_faults_flood_take(struct rmd_sim_faults *fs, unsigned k, uint64_t *rng,
				  struct rmd_frame *f, uint64_t *counts);

/*
 * The first time after t at which a window opens or closes, or an open
 * FLOOD's next frame falls due; INT64_MAX: none.  rt-safe.
 */
int64_t rmd_sim_faults_next_ns(const struct rmd_sim_faults *fs, int64_t t);

#endif /* RMD_SIM_FAULTS_H */
