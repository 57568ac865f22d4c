/* SPDX-License-Identifier: MIT */
/*
 * Per-bus cycle plans (docs/design.md, layer rt): which requests go out on which
 * bus in which cycle, and what that costs on the wire in the worst case.
 *
 * Each cycle the rt loop sends, on every bus, the requests of
 * rmd_plan_cycle(), all at the start of the cycle; the replies come back
 * in the same or the next cycle.  A bus's budget per cycle is the worst-
 * case wire time of all those frames, requests and replies:
 *
 *   CAN and sim buses: frames * rmd_can_frame_bits_worst(8) bits at the
 *     bitrate (worst-case stuffing, interframe space included): 135 us per
 *     frame at 1 Mbit/s, so a motor (request + reply) costs 270 us.
 *   RS485: half duplex, one request at a time: per request, the request and
 *     its reply (13 bytes of 10 bits each at the baud) plus the bus's
 *     turnaround (the motor's answer time, during which the line is idle).
 *
 * A bus whose busiest cycle does not fit in the cycle is refused with the
 * numbers and what would fit:
 *
 *   can0: 5 motors at 1000 Hz need 1350 µs per cycle worst case, the cycle
 *   is 1000 µs: use ≤ 3 motors, or a rate ≤ 740 Hz
 *
 * How the requests are chosen:
 * - Control frames.  A motor is commanded every rate_divisor-th cycle; the
 *   planner gives each motor a phase so that motors with divisors > 1 take
 *   turns.  The pattern repeats every `hc` cycles (the lcm of the bus's
 *   divisors, at most RMD_PLAN_MAX_HC).
 * - V2 0x280 (V2 §4.1): one frame carries the torques of motors 1..4, each
 *   of which answers on 0x140 + ID.  Every V2 motor with ID 1..4 on a bus
 *   takes that frame, so the planner batches them when there are at least
 *   two, all in torque mode with one rate divisor, and no V3 or MIT motor
 *   shares the bus (a V3 motor whose CAN-ID filter is off takes 0x280 as a
 *   broadcast command, V3 §3, and would read a torque byte as the command).
 *   4 V2 motors then cost 5 frames instead of 8.  The frame is a torque
 *   command to each of them, so it goes out only while all of them are
 *   driven in torque mode; otherwise the cycle gives them their own
 *   frames, batch_own of them a cycle, in turn, whose extra frames the
 *   budget counts (4 motors at 1 kHz: 2 or 3 a cycle).
 * - Status polls: 0x9A (V3 §2.12, V2 §3.31: temperature, voltage, error
 *   flags; MIT replies carry none of these, V2/V3 control replies carry
 *   only the temperature) at each motor's status_poll_hz.  A poll cycle
 *   comes every `poll_every` cycles (a multiple of hc) and takes the next
 *   `poll_burst` entries of a weighted round robin (`polls`): one when
 *   that keeps every motor's rate, else as few as do, always of different
 *   motors (3 motors polled at 10 Hz in a 25 Hz loop: 2 a cycle).  Each
 *   poll is an extra request when its cycle has room for it, the poll
 *   cycle's other polls counted; otherwise it takes the place of the
 *   polled motor's control frame in that cycle (the motor keeps its last
 *   setpoint for one more cycle).  A poll for a motor in a 0x280 frame
 *   cannot take its place, so it needs the room.
 * - Fine position reads (motors[].feedback.position: multi_turn,
 *   docs/feedback.md): 0x92 (V3 §2.11, 0.01 deg) every `fine_divisor`-th
 *   cycle, the largest divisor that keeps feedback.rate_hz (default: the
 *   motor's command rate).  They are planned like control frames, each
 *   motor's reads a unit with its own phase, so they count in the busiest
 *   cycle that must fit, and never take a setpoint's place.
 *
 * The plan holds fixed arrays only; rmd_plan_cycle() reads it without
 * allocating.
 */
#ifndef RMD_PLAN_H
#define RMD_PLAN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "rmd/codec.h"
#include "rmd/config.h"
#include "rmd/frame.h"

#define RMD_PLAN_MAX_HC 64     /* control pattern of one bus: lcm of its rate divisors */
#define RMD_PLAN_MAX_POLLS 256 /* entries of one bus's poll round robin */
/*
 * Requests of one bus in one cycle: a 0x280 frame, every motor, its 0x92
 * read and its status poll.
 */
#define RMD_PLAN_MAX_SLOTS (3 * RMD_MAX_MOTORS + 1)

enum rmd_slot_kind {
	RMD_SLOT_CONTROL = 0, /* a motor's setpoint: V2/V3 0x140 + ID, MIT 0x400 + ID */
	RMD_SLOT_V2_TORQUES,  /* V2 §4.1 0x280: the torques of the batched motors */
	RMD_SLOT_STATUS,      /* 0x9A on 0x140 + ID (MIT motors speak V3 too) */
	RMD_SLOT_FINE,	      /* 0x92 on 0x140 + ID: the fine position read */
};

/* One request of a cycle. */
struct rmd_plan_slot {
	enum rmd_slot_kind kind;
	uint8_t motor;	 /* CONTROL, STATUS: index into cfg->motors[]; V2_TORQUES: 0 */
	uint8_t replies; /* frames that answer it */
	uint16_t can_id; /* identifier of the request */
};

/* Why a bus with two or more V2 motors with ID 1..4 has no 0x280 frame. */
enum rmd_plan_batch {
	RMD_BATCH_NONE = 0,  /* fewer than two candidates */
	RMD_BATCH_ON,	     /* batched */
	RMD_BATCH_MODES,     /* a candidate is not in torque mode */
	RMD_BATCH_DIVISORS,  /* the candidates' rate divisors differ */
	RMD_BATCH_V3_ON_BUS, /* a V3 or MIT motor shares the bus */
};

/* One entry of a bus's poll round robin. */
struct rmd_plan_poll {
	uint8_t motor; /* index into cfg->motors[] */
	uint8_t cycle; /* goes in the cycles n with n % poll_every == cycle (< hc) */
	bool replaces; /* takes the place of the motor's control frame */
};

/* What the plan knows of a motor. */
struct rmd_plan_motor {
	uint8_t bus;   /* index into cfg->buses[] and plan->bus[] */
	uint8_t local; /* bit of the motor in its bus's masks */
	uint8_t id;
	enum rmd_proto proto;
	unsigned divisor;
	unsigned phase;	       /* commanded in cycles n with n % divisor == phase */
	bool batched;	       /* in the bus's 0x280 frame */
	double poll_hz;	       /* status polls per second it gets */
	unsigned polls;	       /* its entries in the round robin */
	unsigned replacing;    /* of those, how many take a control frame's place */
	unsigned fine_divisor; /* 0x92 read in cycles n % fine_divisor == fine_phase; 0: none */
	unsigned fine_phase;
	double pos_hz; /* new positions per second: 0x92 reads, else the command rate */
};

struct rmd_plan_bus {
	enum rmd_bus_kind kind;
	unsigned n_motors;
	uint8_t motors[RMD_MAX_MOTORS]; /* cfg->motors[] indices, in file order */
	/* by local bit: the identifier of the control request (0x140 or 0x400 + ID), and 0x140 + ID */
	uint16_t ctl_id[RMD_MAX_MOTORS];
	uint16_t req_id[RMD_MAX_MOTORS];
	/* Control pattern: repeats every hc cycles. */
	unsigned hc;
	uint32_t due[RMD_PLAN_MAX_HC];	    /* bit `local`: commanded in cycles n % hc == c */
	uint32_t fine[RMD_PLAN_MAX_HC];	    /* bit `local`: its 0x92 read in cycles n % hc == c */
	uint16_t frames[RMD_PLAN_MAX_HC];   /* wire frames of cycle c, without polls */
	uint16_t requests[RMD_PLAN_MAX_HC]; /* requests of cycle c, without polls */
	uint32_t batched;		    /* bits of the motors in the 0x280 frame */
	enum rmd_plan_batch batch;
	/*
	 * Status polls: a poll cycle every poll_every cycles (0: none) takes
	 * the next poll_burst entries of the round robin (n_polls, a multiple
	 * of poll_burst).
	 */
	unsigned poll_every;
	unsigned poll_burst;
	unsigned n_polls;
	struct rmd_plan_poll polls[RMD_PLAN_MAX_POLLS];
	uint64_t hyperperiod; /* the whole schedule repeats every this many cycles */
	/* Budget, worst case. */
	uint32_t bitrate;      /* bit/s (RS485: baud) */
	unsigned frame_bits;   /* per frame, worst case */
	int64_t turnaround_ns; /* per request (RS485); 0 for CAN */
	int64_t control_ns;    /* busiest cycle without polls */
	int64_t worst_ns;      /* busiest cycle, polls included */
	unsigned max_frames;   /* frames of the busiest cycle */
	unsigned max_requests; /* most requests in one cycle: the TX burst */
	unsigned n_fine;       /* motors with 0x92 reads */
	double avg_frames;     /* frames per cycle over the hyperperiod */
	double avg_ns;	       /* wire time per cycle over the hyperperiod */
	bool feasible;
	/*
	 * The batched motors that a cycle of the 0x280 frame gives their own
	 * frames instead (a request and its reply each), in turn, while the
	 * frame must not go out (rmd/loop.h "Frames": one of them is not
	 * driven in torque mode): the most that fit in the cycle, never fewer
	 * than the frame's own 1 + n frames hold.  Its extra frames are in
	 * the budget below.
	 */
	unsigned batch_own;
};

struct rmd_plan {
	unsigned rate_hz;
	int64_t period_ns; /* 1e9 / rate_hz, rounded down */
	unsigned n_buses;
	struct rmd_plan_bus bus[RMD_MAX_BUSES];
	unsigned n_motors;
	struct rmd_plan_motor motor[RMD_MAX_MOTORS];
	bool feasible; /* every bus fits */
};

/*
 * Plan every bus of a validated configuration.  Returns 0 when every bus
 * fits; -ENOSPC when one does not (the plan is still filled in for
 * rmd_plan_print(), with that bus's feasible false), with one line per
 * problem in err, as above; -EINVAL for a configuration the loader would
 * not have produced, or rate divisors whose pattern is longer than
 * RMD_PLAN_MAX_HC cycles.  Non-rt.
 */
int rmd_plan_build(const struct rmd_config *cfg, struct rmd_plan *plan, char *err, size_t errlen);

/* The plan and budget of every bus, for `rmdd --check-config`.  Non-rt. */
void rmd_plan_print(const struct rmd_plan *plan, const struct rmd_config *cfg, FILE *out);

/*
 * The requests of bus `bus` in cycle `n` (counted from 0 at the loop's
 * start) into out[]: the 0x280 frame first, then control frames in file
 * order, then 0x92 reads in file order, then the status polls in round-robin order.
 * Returns the count (0 for a bus out of range).  rt-safe: no allocation, bounded by RMD_PLAN_MAX_SLOTS.
 */
unsigned rmd_plan_cycle(const struct rmd_plan *plan, unsigned bus, uint64_t n,
			struct rmd_plan_slot out[RMD_PLAN_MAX_SLOTS]);

/*
 * The same requests as the plan's masks, which the rt loop walks without
 * a slot array: bit `local` of a mask is the bus's motors[local].
 */
struct rmd_plan_due {
	bool batch;	  /* the 0x280 frame (RMD_SLOT_V2_TORQUES) */
	uint32_t control; /* control frames, the batched motors' excluded */
	uint32_t fine;	  /* 0x92 reads */
	/* status reads: the entries of polls[0..n_polls - 1] whose cycle is `at` */
	const struct rmd_plan_poll *polls;
	unsigned n_polls;
	unsigned at;
};

/* Bus `bus`'s requests of cycle n into *d; false when it has none planned.  rt-safe. */
bool rmd_plan_due(const struct rmd_plan *plan, unsigned bus, uint64_t n, struct rmd_plan_due *d);

/* Worst-case wire time of `frames` frames and `requests` requests on bus b.  rt-safe. */
int64_t rmd_plan_cost_ns(const struct rmd_plan_bus *b, unsigned frames, unsigned requests);

#endif /* RMD_PLAN_H */
