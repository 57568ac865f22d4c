/* SPDX-License-Identifier: MIT */
/*
 * What the rt loop (layer 5) and the bridge (layer 6) hand each other
 * through rmd/spsc.h: validated setpoints in, state snapshots and health
 * out, and fixed-size event records for the logger.  Plain fixed-size
 * structs, SI units at the output shaft, so the rt side copies and never
 * allocates or parses.
 *
 * Motors are addressed by their index in the configuration (0..n-1), the
 * same index LCM messages use.
 */
#ifndef RMD_STATE_H
#define RMD_STATE_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/frame.h"
#include "rmd/mode.h"

/* Control modes: enum rmd_mode (rmd/mode.h).  The safe actions are enum
 * rmd_safe_action in rmd/config.h. */

/* Motor lifecycle (docs/design.md); the values are those of rmd.state_t. */
enum rmd_lifecycle {
	RMD_LC_PROBE = 0, /* asking model, version, status */
	RMD_LC_READY,	  /* output off and brake locked: both echoed (0x80, 0x78) */
	RMD_LC_ENABLED,	  /* running the commanded mode */
	RMD_LC_FAULT,	  /* error flags set */
	RMD_LC_LOST,	  /* N consecutive missed replies; re-probed slowly */
	RMD_LC_SAFE,	  /* the safe action holds it until re-enabled */
	RMD_LC_STOPPING,  /* on its way to READY: 0x80 and 0x78 sent until echoed */
	RMD_LC_COUNT
};

/*
 * A motor's own comm-loss protection (0xB3, V3 §2.30; docs/design.md): it stops
 * the motor when it hears nothing for the configured time, so it is a
 * precondition of motion.  The values are those of rmd.health_t CL_*.
 * A motor may leave READY only when rmd_comm_loss_allows_motion().
 */
enum rmd_comm_loss {
	RMD_CL_PENDING = 0, /* not armed yet: being written, or the motor is not there */
	RMD_CL_ARMED,	    /* written, and the answer repeats the request (echo-verified) */
	/*
	 * Written, answered with the command byte and zeros: V3 §2.30 example
	 * 2 shows that answer to a write of 1000 ms, and real firmware answers
	 * either way, so it counts as armed; the time is not verified.
	 */
	RMD_CL_ARMED_ZEROS,
	RMD_CL_NO_ANSWER, /* no answer to the bounded writes: cannot be enabled */
	RMD_CL_DIFFERS,	  /* answered with another time than written: cannot be enabled */
	RMD_CL_OFF,	  /* off by the configuration (comm_loss_ms: 0) */
	/*
	 * Protocol V2: it has no 0xB3 and no protection (the V2 manual's
	 * command list, §2), and its comm_loss_ms is not 0: never enabled.  A
	 * loaded configuration refuses this; with comm_loss_ms: 0 it is OFF.
	 */
	RMD_CL_UNSUPPORTED,
	RMD_CL_COUNT
};

/* The protection is set (armed, either answer form).  rt-safe. */
static inline bool rmd_comm_loss_set(uint8_t cl)
{
	return cl == RMD_CL_ARMED || cl == RMD_CL_ARMED_ZEROS;
}

/* The motor may be enabled: armed, or off by config (V2 motors: only so).  rt-safe. */
static inline bool rmd_comm_loss_allows_motion(uint8_t cl)
{
	return rmd_comm_loss_set(cl) || cl == RMD_CL_OFF;
}

/* One motor's setpoint, already validated and clamped to its limits. */
struct rmd_setpoint {
	bool enable;
	uint8_t mode; /* enum rmd_mode */
	double pos_rad;
	double vel_rad_s;
	double torque_nm;
	double kp; /* N·m/rad, MIT */
	double kd; /* N·m·s/rad, MIT */
	double max_vel_rad_s;
};

/*
 * The setpoint drives the motor to a position (position mode, MIT with
 * kp > 0), so it needs a position rmdd trusts (rmd/multiturn.h): the one
 * copy of the rule.  rt-safe.
 */
static inline bool rmd_setpoint_needs_pos(const struct rmd_setpoint *sp)
{
	return sp->mode == RMD_MODE_POSITION || (sp->mode == RMD_MODE_MIT && sp->kp > 0.0);
}

/* A controller's command, as the bridge hands it to the rt loop. */
struct rmd_command {
	int64_t rx_ns;	  /* CLOCK_MONOTONIC when it arrived (its receive stamp), not when read */
	int64_t stamp_us; /* the controller's own timestamp */
	int64_t seq;	  /* the controller's sequence number */
	uint32_t present; /* bit i: m[i] carries a setpoint for motor i */
	struct rmd_setpoint m[RMD_MAX_MOTORS];
	/*
	 * enable = 0 entries the bridge accepted for motor i, total: the rt
	 * loop keeps only the newest command, so an enable = 0 followed at
	 * once by enable = 1 reaches it as a change of this count (an edge
	 * latched until the loop consumes it).
	 */
	uint32_t disables[RMD_MAX_MOTORS];
	/*
	 * Robot-wide stops (docs/robot.md) the bridge decided on, total: a
	 * peer lost or tripped, a robot_stop_t.  A change is the stop, latched
	 * as disables[] is, so a command handed over right behind it does not
	 * hide it: the loop gives every ENABLED motor the safe action and
	 * latches the trip as its watchdog does.  robot_hold: a peer is lost,
	 * unseen or stopping (robot.on_peer_lost: safe): enable = 1 entries
	 * are not acted on.
	 */
	uint32_t robot_stops;
	bool robot_hold;
};

/*
 * Homing requests, as the bridge hands them to the rt loop (rmd.home_t,
 * docs/lcm.md "Homing"): per motor, how many were accepted so far (the
 * loop acts on a change, so one is never lost however fast they come) and
 * the newest one's content.
 */
struct rmd_home {
	uint32_t seq[RMD_MAX_MOTORS];
	bool as_reported[RMD_MAX_MOTORS]; /* the reported position is right */
	double pos_rad[RMD_MAX_MOTORS];	  /* else: the motor is here now */
};

struct rmd_motor_state {
	uint8_t lifecycle; /* enum rmd_lifecycle */
	uint8_t mode;	   /* enum rmd_mode in force */
	/*
	 * Whether pos_rad can be trusted after the motor was powered off or
	 * reset (rmd/multiturn.h): pos_trust is enum rmd_pos_trust,
	 * pos_certain is rmd_pos_trusted(pos_trust), the one flag the loop
	 * checks.
	 */
	uint8_t pos_trust;
	bool pos_certain;
	double pos_rad;
	double vel_rad_s;
	double torque_nm;
	double current_a;
	double temp_c;
	double voltage_v;
	uint16_t error_code;
	bool brake_released;	   /* its brake as the status answer of error_code says (0x9A) */
	uint32_t reply_age_cycles; /* cycles since the last reply (0: this cycle) */
	int64_t reply_latency_ns;  /* request sent -> reply received, last reply */
	uint64_t missed_replies;   /* replies that never came, total */
	int64_t rx_ns;		   /* receive time of the reply vel/torque came from; 0: none yet */
	int64_t pos_rx_ns;	   /* receive time of the reply pos_rad came from; 0: none yet */
	int64_t status_rx_ns;	   /* ... error_code and voltage_v came from (0x9A); 0: none yet */
	/*
	 * ENABLED with a brake_release_ms: setpoints are held back until this
	 * time (the last brake release sent + brake_release_ms); 0: none.
	 */
	int64_t release_until_ns;
};

/* State of every motor after one cycle. */
struct rmd_snapshot {
	int64_t t_ns;
	uint64_t cycle;
	uint32_t n;
	struct rmd_motor_state m[RMD_MAX_MOTORS];
};

struct rmd_loop_stats {
	uint64_t cycles;
	uint64_t overruns; /* cycles whose wake-up came after the next deadline */
	int64_t wake_min_ns; /* wake-up lateness: actual - intended wake-up, skipped periods included */
	int64_t wake_avg_ns;
	int64_t wake_p99_ns;
	int64_t wake_max_ns;
	int64_t cycle_max_ns; /* longest time from wake-up to going back to sleep */
	uint64_t plan_misses; /* cycles whose frames could not all be sent */
};

struct rmd_bus_health {
	char name[32];
	uint8_t state; /* enum rmd_bus_state */
	double load;   /* fraction of wire time used, last window */
	struct rmd_bus_stats stats;
};

/* Why the rt loop did not act on a command's enable = 1 for a motor (counted in rmd_health). */
enum rmd_ignore {
	RMD_IGN_EDGE = 0,  /* the motor waits for an enable = 0 first */
	RMD_IGN_NOT_READY, /* the motor is in PROBE, STOPPING, FAULT or LOST */
	RMD_IGN_TRIPPED,   /* the command is older than the watchdog trip */
	/*
	 * the setpoint drives to a position (rmd_setpoint_needs_pos()) and
	 * the motor's position is uncertain (rmd/multiturn.h)
	 */
	RMD_IGN_POS_UNCERTAIN,
	/*
	 * MIT for a motor in MIT mode whose MIT scaling is not decided (its
	 * firmware's date and model not read yet: rmd/dialect.h
	 * rmd_mit_scaling_decide())
	 */
	RMD_IGN_MIT_SCALING,
	/*
	 * a mode the motor's firmware does not run now: position (0xA4) after
	 * an MIT frame on firmware that ignores it until a reset
	 * (RMD_QUIRK_A4_AFTER_MIT, rmd/dialect.h)
	 */
	RMD_IGN_FIRMWARE,
	RMD_IGN_KINDS
};

enum rmd_watchdog_state {
	RMD_WD_IDLE = 0, /* no controller has enabled anything yet */
	RMD_WD_OK,	 /* commands arrive in time */
	RMD_WD_TRIPPED,	 /* safe action latched until re-enable */
};

struct rmd_health {
	int64_t t_ns;
	struct rmd_loop_stats loop;
	uint32_t nbuses;
	struct rmd_bus_health bus[RMD_MAX_BUSES];
	uint8_t watchdog;		 /* enum rmd_watchdog_state */
	uint64_t safe_action_events;	 /* times a safe action was applied */
	uint64_t watchdog_trips;	 /* the command watchdog's own trips (not robot stops) */
	uint32_t robot_stops;		 /* rmd_command.robot_stops the loop acted on, newest */
	uint64_t ignored[RMD_IGN_KINDS]; /* command entries not acted on, by enum rmd_ignore */
	uint64_t homes_refused;		 /* homing requests refused (RMD_EV_HOME_REFUSED) */
	/* per motor, config order, nmotors of them */
	uint32_t nmotors;
	uint8_t comm_loss[RMD_MAX_MOTORS];	  /* enum rmd_comm_loss */
	uint32_t comm_loss_ms[RMD_MAX_MOTORS];	  /* what 0xB3 writes (0: off) */
	uint64_t unarmed_rejects[RMD_MAX_MOTORS]; /* enables refused: protection not set */
	/*
	 * The dialect it speaks (enum rmd_proto: its protocol's, or what
	 * `protocol: auto` found at bring-up), and its 0xB2 firmware version
	 * (0: none, or not read yet)
	 */
	uint8_t proto[RMD_MAX_MOTORS];
	uint32_t firmware[RMD_MAX_MOTORS];
};

/* Why the bridge refused a command message (counted in rmd_health). */
enum rmd_reject {
	RMD_REJ_DECODE = 0, /* not a command_t (fingerprint, truncated) */
	RMD_REJ_COUNT,	    /* motor count out of range */
	RMD_REJ_INDEX,	    /* motor index out of range or repeated */
	RMD_REJ_NONFINITE,  /* NaN or Inf */
	RMD_REJ_MODE,	    /* unknown mode, or one the motor cannot do */
	RMD_REJ_LIMIT,	    /* gains or limits out of range (setpoints are clamped, not refused) */
	RMD_REJ_STALE,	    /* timestamp too old, or sequence went back */
	RMD_REJ_OWNER,	    /* another controller owns the motors */
	RMD_REJ_KINDS
};

/* RMD_EV_MOTOR_ERROR's a of a trip told by the echo of a command (a's low 9 bits). */
#define RMD_EV_TRIP_ECHOED 0x10000

/* Things the rt loop reports; a normal thread logs them on change. */
enum rmd_event_kind {
	RMD_EV_MOTOR_STATE = 0, /* a = old lifecycle, b = new lifecycle */
	/*
	 * a = error code; b = RMD_MOTOR_CMD_COMM_LOST (0xF1): its comm-loss
	 * protection tripped, a = RMD_EV_TRIP_ECHOED | the command byte (or
	 * RMD_MOTOR_CMD_MIT, 0x100) when an echo of that command told it (its
	 * 0xF1 unheard)
	 */
	RMD_EV_MOTOR_ERROR,
	RMD_EV_BUS_STATE, /* a = enum rmd_bus_state */
	RMD_EV_OVERRUN,	  /* a = cycles skipped, b = the most of them at once */
	RMD_EV_WATCHDOG,  /* a = enum rmd_watchdog_state */
	/*
	 * a = enum rmd_safe_action (rmd/config.h); b = 1: the shutdown's stop
	 * or hold that rmd_loop_stop_motors() sent, right before the motor's
	 * ENABLED -> SAFE (else 0)
	 */
	RMD_EV_SAFE_ACTION,
	RMD_EV_SEND_FAILED, /* a = -errno, b = frames not sent */
	RMD_EV_UNEXPECTED,  /* a = CAN id, b = first data byte */
	RMD_EV_RT, /* real-time scheduling not granted, once: a = -errno, b = RMD_LOOP_RT_* */
	/*
	 * A motor's comm-loss protection: a = enum rmd_comm_loss, b = 1 when
	 * an enable was refused for it (once per episode: until it is armed or
	 * lost), else 0 (armed by the loop, or the bounded writes failed).
	 */
	RMD_EV_COMM_LOSS,
	/*
	 * The answer to a request of rmdd's that was given up (a reply past
	 * its deadline, an earlier try of bring-up): a = ns since it was
	 * sent, b = its command byte (or RMD_MOTOR_CMD_MIT); at most one a
	 * second per bus.
	 */
	RMD_EV_LATE,
	/*
	 * A motor's position after it (re)appeared, or homed: a = enum
	 * rmd_pos_trust (rmd/multiturn.h); b = the shift applied, in
	 * microradians (0: none).
	 */
	RMD_EV_POSITION,
	/*
	 * A setpoint that drives to a position was refused, the position being
	 * uncertain (once per episode: until the motor's position is trusted
	 * or it is lost): a = enum rmd_pos_trust, b = the setpoint's mode.
	 */
	RMD_EV_POS_REFUSED,
	/*
	 * A setpoint in a mode the motor's firmware does not run now was
	 * refused (RMD_IGN_FIRMWARE), once until it is reset: a = its firmware
	 * version, b = the mode (position after MIT, RMD_QUIRK_A4_AFTER_MIT).
	 */
	RMD_EV_FW_REFUSED,
	/*
	 * A motor driven to a position does not move (rmd/proc_effect.h):
	 * a = how far its target is, microradians; b = for how long, ms.
	 */
	RMD_EV_NO_EFFECT,
	/*
	 * A homing request was refused: a = enum rmd_home_refusal, b = the
	 * position it asked for, in microradians (RMD_HOME_OUTSIDE; else 0).
	 */
	RMD_EV_HOME_REFUSED,
	/*
	 * A motor missing at bring-up answered the loop's re-probe with
	 * firmware of another dialect than its own (its entry's, or V3, which
	 * `protocol: auto` takes it for): a = its firmware version (0xB2; 0:
	 * none, a V2 motor's status answer told), b = that dialect (enum
	 * rmd_proto).  It stays out until rmdd restarts.
	 */
	RMD_EV_DIALECT,
	/*
	 * A motor the configuration does not list answered, on a bus whose V2
	 * motors share a 0x280 frame, as firmware the frame would command
	 * (rmd_dialect_takes_280()): a = the identifier, b = its ID.  The bus
	 * sends each batched motor its own frames from then on (issue 33 point 2).
	 */
	RMD_EV_STRAY,
	/*
	 * A motor in MIT mode missing at bring-up answered the loop's
	 * re-probe, and its MIT scaling cannot be decided (rmd/dialect.h
	 * rmd_mit_scaling_decide()): a = its firmware version (0xB2), b =
	 * why (enum rmd_mit_source) | the X series its model names << 8.
	 * It stays out until rmdd restarts.
	 */
	RMD_EV_MIT_SCALING,
	/*
	 * MIT was refused for a motor whose MIT scaling is not decided
	 * (RMD_IGN_MIT_SCALING), once: a = its firmware version as read (0:
	 * none), b = 0.
	 */
	RMD_EV_MIT_REFUSED,
	/*
	 * A motor's reboot check (rmd/reboot.h): a = enum rmd_reboot_report;
	 * b: RMD_REBOOT_BY_RUNTIME, its 0xB1 runtime in ms << 32 | the ms
	 * from its last answer to the read (what it would have run at
	 * least); RMD_REBOOT_BY_TURNS and RMD_REBOOT_COUNT_ASTRAY, its 0x92
	 * angle << 32 | rmdd's count (int32 each, 0.01 deg, reported frame); RMD_REBOOT_BY_BRAKE, 0;
	 * the others, the check's command byte.  A reboot makes it lost and
	 * back at once.
	 */
	RMD_EV_REBOOT,
	/*
	 * A bus nobody acknowledges (RMD_BUS_NO_ACK), at the start of the
	 * episode: a = what flushing the frames it still held came to (0, or
	 * -errno: -EPERM, SocketCAN without CAP_NET_ADMIN, -EOPNOTSUPP);
	 * b = the frames it may have held (low 32 bits; when a != 0 they go
	 * out when power returns) | the motors of the bus that were driven
	 * (ENABLED or SAFE, bit = config index) << 32.
	 */
	RMD_EV_BUS_FLUSH,
	/*
	 * How many kinds there are (a new one goes above): rmdd words each
	 * by its row, one per kind (src/tools/rmdd/events.c).
	 */
	RMD_EV_COUNT
};

/* What RMD_EV_REBOOT reports (its a). */
enum rmd_reboot_report {
	RMD_REBOOT_BY_RUNTIME =
		1,	     /* 0xB1: its runtime is shorter than the time since it answered */
	RMD_REBOOT_BY_TURNS, /* V2: its 0x92 angle parts from rmdd's count by whole turns */
	RMD_REBOOT_BY_BRAKE, /* 0x9A: its brake locked after it reported rmdd's release */
	RMD_REBOOT_NO_CHECK, /* it does not answer the check read: no checks any more */
	RMD_REBOOT_UNTOLD,   /* its answers could not tell (no count yet): this check ends */
	/* V2: its 0x92 angle parts from rmdd's count by other than whole turns: count dropped */
	RMD_REBOOT_COUNT_ASTRAY,
};

/* Why the rt loop refused a homing request (RMD_EV_HOME_REFUSED). */
enum rmd_home_refusal {
	RMD_HOME_ENABLED = 1, /* the motor is enabled: its position must not jump under it */
	RMD_HOME_NO_POS,      /* it has not reported a position since it (re)appeared */
	/*
	 * the position it would be homed at lies outside its travel band
	 * (travel_rad, else its position limits, widened by the reading's step):
	 * in-limit setpoints would then drive it past them (issue 33 point 6)
	 */
	RMD_HOME_OUTSIDE,
};

struct rmd_event {
	int64_t t_ns;
	uint16_t kind; /* enum rmd_event_kind */
	uint8_t motor; /* config index, or 0xFF */
	uint8_t bus;   /* config index, or 0xFF */
	int64_t a;
	int64_t b;
};

#endif /* RMD_STATE_H */
