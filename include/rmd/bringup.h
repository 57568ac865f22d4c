/* SPDX-License-Identifier: MIT */
/*
 * Bring-up, before the rt thread starts (non-rt, blocks for a bounded
 * time), on the one request/reply engine (rmd/txn.h): probe every motor
 * (0xB5 model, 0xB2 version, 0x9A status), ask every id that is not
 * configured on a bus for its status (0x9A) once, and write the configured
 * 0xB3 comm-loss time to every motor that answered, last, checking its
 * answer; the outcome is the loop's protection state (enum rmd_comm_loss,
 * rmd/loop.h "Comm-loss protection").  V2 has no 0xB5, 0xB2 or 0xB3: V2 motors are probed with 0x9A,
 * and 0x92 anchors their unwrapped encoder position.  Each probe is tried
 * RMD_LOOP_PROBE_TRIES times, RMD_LOOP_PROBE_TIMEOUT_NS each (a transport
 * with a reply timeout of its own: that plus 1 ms).
 *
 * The result is data, struct rmd_bringup: the caller words it and picks
 * its log levels.  Found motors are READY (FAULT with error flags),
 * missing ones LOST (re-probed by the cycle).
 */
#ifndef RMD_BRINGUP_H
#define RMD_BRINGUP_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/loop.h"

/* What the probe found. */
enum rmd_bringup_state {
	RMD_BRINGUP_FOUND = 0, /* answered, no error flags */
	RMD_BRINGUP_MISSING,   /* no answer to the first probe */
	RMD_BRINGUP_FAULT,     /* answered, with error flags (error_code) */
	/*
	 * answered, but cannot be what its configuration says (mismatch):
	 * never driven, and bring-up fails whatever probe.on_missing says
	 */
	RMD_BRINGUP_MISMATCH,
};

/* Why a motor's configuration does not fit what it answered. */
enum rmd_bringup_mismatch {
	RMD_BRINGUP_MISMATCH_NONE = 0,
	/* its firmware date says another dialect than its protocol (docs/protocol-v4.md) */
	RMD_BRINGUP_MISMATCH_FIRMWARE,
	/* its dialect has no 0xB3 (V2), and its comm_loss_ms is not 0 */
	RMD_BRINGUP_MISMATCH_NO_COMM_LOSS,
	/* feedback.position multi_turn, and its dialect's 0x92 is not the fine position */
	RMD_BRINGUP_MISMATCH_NO_FINE_ANGLE,
	/* mode mit, and its dialect has no MIT mode (V2, found by `protocol: auto`) */
	RMD_BRINGUP_MISMATCH_NO_MIT,
	/*
	 * mode mit, and its MIT scaling cannot be decided: the firmware's
	 * date or model is unknown, or the entry's `mit` ranges contradict
	 * the firmware's (struct rmd_bringup_motor.mit says which)
	 */
	RMD_BRINGUP_MISMATCH_MIT_SCALING,
};

/* What came of the 0xB3 write (V3 §2.30). */
enum rmd_bringup_b3 {
	RMD_B3_NOT_APPLICABLE = 0, /* not written: a V2 motor (no 0xB3) or a missing one */
	RMD_B3_SET,		   /* written, and the answer repeats the request */
	/*
	 * Answered with the command byte and zeros: V3 §2.30 example 2 shows
	 * that answer to a write of 1000 ms, real firmware answers either way,
	 * so the time is not verified.
	 */
	RMD_B3_ZEROS,
	RMD_B3_NO_ANSWER, /* no answer in RMD_LOOP_PROBE_TRIES tries */
	RMD_B3_DIFFERS,	  /* answered with other values than written */
};

struct rmd_bringup_motor {
	enum rmd_bringup_state state;
	/*
	 * The dialect it was probed in: its protocol's, or with `protocol:
	 * auto` (proto_auto) the one it answered in, auto_certain false when
	 * its firmware date could not tell the generation (V3 taken).
	 */
	enum rmd_proto proto;
	bool proto_auto, auto_certain;
	enum rmd_bringup_mismatch mismatch; /* RMD_BRINGUP_MISMATCH: why */
	/*
	 * Replies it pushed unasked during bring-up (0xB6 active reply, V4.2
	 * §2.33, left on by another tool), bit k: its dialect's report_cmds[k];
	 * and whether bring-up turned every one off (0xB6, enable 0).
	 */
	uint8_t pushed;
	bool reports_off;
	/* MISSING: the request that went unanswered, its tries and their wait */
	uint8_t probe_cmd;
	unsigned tries;
	int64_t timeout_ns;
	char model[8];	  /* 0xB5 (V3, MIT); "" when it answered none */
	uint32_t version; /* 0xB2 firmware date yyyymmdd; 0: no answer (or V2) */
	/* its 0xB2 went unanswered in its tries and was asked once more, waiting longer */
	bool version_again;
	bool status; /* 0x9A answered: voltage, temperature and errors below */
	double voltage_v;
	double temp_c;
	uint16_t error_code;
	bool v2_angle; /* V2: 0x92 answered, positions continue from the motor's angle */
	/*
	 * Driven in MIT mode: the MIT scaling decided from its firmware's
	 * date and model and its entry (rmd/dialect.h rmd_mit_scaling_decide()),
	 * or why none could be (then mismatch is RMD_BRINGUP_MISMATCH_MIT_SCALING)
	 */
	bool mit_mode;
	struct rmd_mit_decision mit;
	enum rmd_bringup_b3 b3;
	uint32_t comm_loss_ms; /* what 0xB3 wrote (its own key or safety.comm_loss_ms; 0: off) */
	/*
	 * The protection's state as the loop takes it over (enum
	 * rmd_comm_loss): a motor that is not armed here is written again by
	 * the loop before it may leave READY.
	 */
	uint8_t comm_loss;
};

struct rmd_bringup {
	unsigned n_motors, n_buses; /* of the configuration */
	uint32_t comm_loss_ms; /* safety.comm_loss_ms (a motor's own key: motor[].comm_loss_ms) */
	unsigned missing;      /* motors MISSING */
	unsigned mismatched;   /* motors MISMATCH */
	/*
	 * Motors found whose protection is not set (0xB3 unanswered or
	 * answered with another time), and not off by config: they cannot be
	 * enabled until the loop arms them; probe.on_missing: refuse counts
	 * them as missing.
	 */
	unsigned unarmed;
	struct rmd_bringup_motor motor[RMD_MAX_MOTORS]; /* config order */
	/* per bus: ids that answered but are not configured, bit id - 1 */
	uint32_t unexpected_ids[RMD_MAX_BUSES];
	/*
	 * per bus whose V2 motors share a 0x280 frame (and whose entry does not
	 * say can_id_filter): those of them that answered as firmware the
	 * frame would command (rmd_dialect_takes_280(): a V3/V4/MIT motor, a
	 * V2 one with ID 1..4), bit id - 1; the bus then sends no 0x280
	 * frame (issue 33 point 2)
	 */
	uint32_t stray_ids[RMD_MAX_BUSES];
	/* buses refused for them (struct rmd_bringup_bus.stray_refused) */
	unsigned strays_refused;
	/* per bus: what its answers took */
	struct rmd_bringup_bus {
		/*
		 * Round trips, request sent to answer received, of the n
		 * requests answered at their first try (0: none).
		 */
		unsigned n;
		int64_t rtt_min_ns, rtt_max_ns;
		/*
		 * The plan's promise needs every reply in by the next cycle:
		 * rtt_max_ns beyond the period (which a cycle's own sends
		 * also take from) means replies will be missed.
		 */
		bool exceeds_period;
		/* the identifier the first of stray_ids[] answered on */
		uint32_t stray_id;
		/*
		 * Without the 0x280 frame the cycle cannot give each of the
		 * bus's batched motors its own frames (rmd_plan_bus.batch_own):
		 * refused, whatever probe.on_missing says.
		 */
		bool stray_refused;
	} bus[RMD_MAX_BUSES];
};

/*
 * Bring the motors of l up (see the top of this file) and describe what
 * was found in *out.  Returns 0, -EPROTO when a motor's configuration does
 * not fit what it answered (RMD_BRINGUP_MISMATCH) or a stray motor refused
 * a bus (struct rmd_bringup_bus.stray_refused), -ENODEV when a motor
 * is missing or unarmed and probe.on_missing is refuse (out is filled all
 * the same), or -EBUSY while the thread runs.  Non-rt.
 */
int rmd_loop_bringup(struct rmd_loop *l, struct rmd_bringup *out);

#endif /* RMD_BRINGUP_H */
