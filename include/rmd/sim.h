/* SPDX-License-Identifier: MIT */
/*
 * Simulated RMD motors and the simulated CAN bus they share (docs/design.md
 * layer 3).  Time is always an injected int64_t nanosecond clock: nothing
 * here reads a real clock, sleeps or allocates, so a test can drive a
 * motor through seconds of simulated time in microseconds, and the
 * in-process sim bus can run inside the daemon's rt loop.
 *
 * struct rmd_sim_motor: one motor behind its frame interface.  Physics at
 * the output shaft, integrated at a fixed step (<= 100 us) whatever the
 * host's command rate; V3, V2 or V4 firmware as configured, V3 and V4
 * taking MIT frames too (V3 §5, V4.2 §5) scaled as their date and model
 * say (V4.4 from firmware 2026042402: rmd/dialect.h).
 *
 * struct rmd_sim_wire (rmd/sim_wire.h): a wire of motors with a wire-time
 * model: every frame, the host's and the motors', occupies the wire for its
 * exact bit-stuffed length in arbitration order; motors answer after a
 * turnaround with jitter; faults (rmd/sim_faults.h) are injected there.
 *
 * The motor model (src/sim/sim_motor.c, the protocol, and
 * src/sim/sim_physics.c) in brief; the files' comments cite the
 * manual section behind each behaviour:
 * - Units: position, speed and torque at the output shaft.  The encoder
 *   sits on the motor rotor (V3 §2.13.4: 16384 lines and gear ratio 6 make
 *   98304 counts per output turn), so one output turn is
 *   2^encoder_bits * gear_ratio multi-turn counts (0x60..0x64), and the
 *   V2 single-turn encoder (0x90, 0x9C) counts one motor turn.
 * - Multi-turn position is RAM: a power cycle or 0x76 wraps the angle into
 *   [-180, 180) deg unless 0x20 index 4 saved it.  Zero offsets written
 *   with 0x63/0x64 (V2 also 0x91/0x19) go to ROM and apply at the next
 *   start (V3 §2.9.1, §2.10.1).
 * - The brake is locked at power-on (V3 §2.27.1).  While it is locked the
 *   shaft does not move and the drive holds its output at zero (it does
 *   not fight its own brake; V2 §3.31 table 2 "motor brake is not open"),
 *   keeping the commanded mode, which resumes when 0x77 releases it.
 * - Faults (V3 §2.12 table 1, levels from §8.2): any active error bit cuts
 *   the output.  Level-1 faults (stall, phase over-current, calibration)
 *   latch and clear the mode until a restart; level-2 faults clear with
 *   their cause and the mode resumes.  Motion commands are answered but
 *   not executed while faulted (V3 §2.17.1).
 * - Comm-loss protection (V3 §2.30, 0xB3, ROM) arms at the first frame
 *   addressed to the motor after a start.  When it trips: output off,
 *   mode cleared, brake locked, a 0xF1 frame at once and then every
 *   second (seen on V4 firmware, docs/design.md; p.comm_loss_f1_ms and
 *   p.comm_loss_silent change it); the first frame after that is echoed on
 *   the reply identifier and not executed (unless p.comm_loss_executes_first).
 * - Personalities (rmd/sim_personality.h): firmware of a model and date
 *   that departs from its manual, by parameters that are off by default.
 * - V4 (docs/protocol-v4.md), read through the dialect's record: one float
 *   gain by index in 0x30..0x32 (RMD_PID_FLOAT_INDEXED), 0x42 by index,
 *   no answer to 0x79; 0x20 index 5 writes the new ID to ROM and is
 *   echoed from the new ID, while requests still go to the old one until
 *   0x76 (RMD_SET_ID_FUNC_20, as firmware 2025070202 does); 0x20 index 6/7
 *   stores the position limits (unit not given, not enforced); 0xB6
 *   pushes a read's reply every n x 10 ms, and that read is no longer
 *   answered (RAM: a reset ends it).
 */
#ifndef RMD_SIM_H
#define RMD_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmd/frame.h"
#include "rmd/mit.h"
#include "rmd/sim_personality.h"

#define RMD_SIM_STEP_NS 50000 /* physics step: 50 us */

/* V3 §2.12 table 1 error bits (V2 §3.31 table 1 uses the same values). */
#define RMD_SIM_ERR_STALL 0x0002u	  /* level 1 (§8.2) */
#define RMD_SIM_ERR_LOW_VOLTAGE 0x0004u	  /* level 2 */
#define RMD_SIM_ERR_OVER_VOLTAGE 0x0008u  /* level 2 */
#define RMD_SIM_ERR_PHASE_CURRENT 0x0010u /* level 1 */
#define RMD_SIM_ERR_POWER 0x0040u	  /* level 2 */
#define RMD_SIM_ERR_CALIBRATION 0x0080u	  /* level 1 */
#define RMD_SIM_ERR_OVERSPEED 0x0100u	  /* level 2 */
#define RMD_SIM_ERR_OVER_TEMP 0x1000u	  /* level 2 */
#define RMD_SIM_ERR_ENCODER_CAL 0x2000u	  /* level 2 */
/* Faults that latch until a restart (V3 §8.2 "一级"; V2's 0x0001 too). */
#define RMD_SIM_ERR_LEVEL1 \
	(0x0001u | RMD_SIM_ERR_STALL | RMD_SIM_ERR_PHASE_CURRENT | RMD_SIM_ERR_CALIBRATION)

/* The unsolicited frame after a comm-loss trip: data[0], rest zero. */
#define RMD_SIM_CMD_COMM_LOST 0xF1u

/* Physical and firmware parameters of one simulated motor. */
struct rmd_sim_motor_params {
	uint8_t id;	      /* 1..32: the CAN ID at first power-on */
	enum rmd_proto proto; /* V3, V2 or MIT (MIT motors also speak V3) */
	double inertia_kgm2;  /* at the output shaft, rotor reflected */
	double viscous_nm_s_rad;
	double coulomb_nm;
	double kt_nm_a;	   /* output-shaft torque per amp of iq */
	double gear_ratio; /* motor turns per output turn */
	unsigned pole_pairs;
	double max_current_a;
	double load_nm;		 /* constant external torque on the shaft */
	double max_speed_dps;	 /* over-speed fault above this */
	double fw_max_speed_dps; /* the firmware's "Max Speed" (0xA3, V2 0xA5/0xA7) */
	double phase_resistance_ohm;
	double thermal_resistance_c_w; /* winding to ambient */
	double thermal_tau_s;
	double ambient_c;
	double supply_v;
	double over_temp_c;	  /* over-temperature fault above this ... */
	double over_temp_clear_c; /* ... until it cools below this */
	double under_voltage_v;	  /* low-voltage fault below this */
	double over_voltage_v;	  /* over-voltage fault above this */
	double stall_time_s;	  /* near-limit current at ~zero speed this long: stall */
	bool has_brake;		  /* false: 0x77/0x78 echo, the shaft is never held */
	unsigned encoder_bits;	  /* motor-side single-turn resolution, 8..24 */
	/*
	 * MIT ranges of firmware that takes them as set (V3 §5.1's preset,
	 * or an entry's); firmware whose date and model fix its own (V4.4:
	 * rmd_mit_scaling_decide()) scales by those instead
	 */
	struct rmd_mit_ranges mit;
	char model[8];	       /* 0xB5, e.g. "X8S2V10" */
	uint32_t version_date; /* 0xB2, e.g. 20220206 */
	double turnaround_ns;  /* request end to reply start, mean */
	double turnaround_jitter_ns;
	/* a ROM write's answer comes this much later (RMD_CMD_ROM rows: the flash write) */
	double rom_write_ns;
	/*
	 * The adapter between the bus and the host (rmd/sim_adapter.h): a
	 * converter's latency timer, USB frames the replies wait for the end
	 * of, a fixed delay; 0: none.  A bus's adapter: give every motor of
	 * the bus the same values (rmdd.yaml sim.motor, rmd-sim's options).
	 */
	double adapter_latency_timer_ns;
	double adapter_usb_frame_ns;
	double adapter_delay_ns;
	/*
	 * With adapter_usb_frame_ns: frames the adapter packs into one USB
	 * packet, all reaching the host (stamped) at one instant (PCAN-USB);
	 * 0 or 1: none (rmd/sim_adapter.h).
	 */
	unsigned adapter_rx_batch;
	uint64_t seed;		/* PRNG seed; 0: derived from id */
	double start_angle_deg; /* output angle at first power-on (multi-turn, not wrapped) */
	/*
	 * V2 §3.29 0x92 (and §3.21..§3.23): a negative value as its magnitude
	 * and the sign flag 1, instead of two's complement and the flag 1; the
	 * manual's text allows both.
	 */
	bool v2_angle_magnitude;
	/*
	 * A command byte the firmware does not know (an older generation
	 * without it, e.g. V2 firmware without 0x92): requests of it addressed
	 * to this motor get no answer; 0: none.
	 */
	unsigned ignores_cmd;
	/*
	 * V3 §2.30: answer 0xB3 with the command byte and zeros (the manual's
	 * example 2) instead of repeating the request (its text).
	 */
	bool b3_answer_zeros;
	/*
	 * An earlier run's comm-loss protection (V3 §2.30): the 0xB3 time in
	 * ROM at first power-on (ms; 0: off), and whether it has tripped
	 * already (rmdd killed, the motor still powered): the first command
	 * the motor then gets is only echoed (docs/design.md), and 0xF1
	 * frames come each second until then.
	 */
	unsigned comm_loss_rom_ms;
	bool comm_loss_tripped;
	/*
	 * V4.2 §2.33 (0xB6), V4 only: at first power-on the motor already
	 * pushes its 0x9C reply every this many ms (rounded up to 10 ms), as
	 * another tool left it, and does not answer 0x9C reads; 0: off.
	 */
	unsigned active_reply_9c_ms;
	/*
	 * 0x20 index 4 (V3 §2.33.4) already in ROM at first power-on: the
	 * multi-turn count survives power-off and 0x76 (V3.5+ firmware).
	 */
	bool multi_turn_save;
	/*
	 * Where a start without it leaves the angle: false, within +-180 deg of
	 * the output; true, within one rotor turn (+-180 deg / gear_ratio at
	 * the output), as firmware that keeps only its rotor encoder's angle
	 * does (rmd/multiturn.h).
	 */
	bool wrap_rotor;
	/*
	 * Its firmware's boot: from power returning (rmd_sim_motor_power_cycle(),
	 * a DISAPPEAR window with param 1 ending) or a 0x76 reset to its
	 * first answer, ms; meanwhile it hears nothing and says nothing, the
	 * drive off and the brake locked.  0: at once.  A 0x76 reset of an
	 * X-series motor was measured at 1.12 s (docs/rmd-sim.md).
	 */
	unsigned boot_ms;
	/*
	 * Firmware behaviour seen in the field (issue 32), each off by
	 * default; a personality (below) switches them on.
	 * answers_79_as_b2: 0x79, read or write, is answered with the 0xB2
	 * reply and changes nothing (X4-64 on 2025070202).
	 * set_id_replies_new: after 0x20 index 5 every reply comes from the
	 * new ID while requests are still taken on the old one, until 0x76
	 * (X4-36/X4-64 on 2025070202).
	 */
	bool answers_79_as_b2;
	bool set_id_replies_new;
	/*
	 * After a comm-loss trip (V3 §2.30): 0xF1 every comm_loss_f1_ms
	 * (1..60000; 0 taken as 1000, the period seen on V4 firmware), none
	 * with comm_loss_silent; the first command then only echoed unless
	 * comm_loss_executes_first.
	 */
	unsigned comm_loss_f1_ms;
	bool comm_loss_silent;
	bool comm_loss_executes_first;
	/* 0xA4 not executed (answered as it stands) after an MIT frame until a reset (X6-P20) */
	bool a4_ignored_after_mit;
	/* 0x9A data[3]: 1 while a control mode runs, not the brake's state (2025070202) */
	bool status1_executing;
	/*
	 * The firmware's personality (rmd/sim_personality.h): auto (zero, the
	 * default) picks the built-in one of model, version_date and proto;
	 * rmd_sim_motor_init() applies it over the fields above.
	 */
	struct rmd_personality personality;
};

/* Parameters of a typical X8 actuator; id and proto set by the caller. */
void rmd_sim_motor_params_default(struct rmd_sim_motor_params *p, uint8_t id, enum rmd_proto proto);

/*
 * Resolve p->personality (auto: the built-in one of p's model, version_date
 * and proto, if any) and give p what it sets: model, date, dialect, boot
 * time, MIT ranges, 0xF1 period, flags.  p->personality is then the record
 * applied (source auto left: none matched).  rmd_sim_motor_init() calls it.
 * rt-safe (no allocation), not cheap.
 */
void rmd_personality_apply(struct rmd_sim_motor_params *p);

enum rmd_sim_ctrl {
	RMD_SIM_OFF = 0,   /* output off (0x80, power-on, comm-loss) */
	RMD_SIM_HOLD,	   /* 0x81 stop: decelerate, then hold position */
	RMD_SIM_TORQUE,	   /* 0xA1 (and V2 0x280) */
	RMD_SIM_SPEED,	   /* 0xA2 */
	RMD_SIM_POS_TRACK, /* V3 0xA3 (and V3 0xA5 with a speed limit) */
	RMD_SIM_POS_ABS,   /* 0xA4, 0xA8, V2 0xA3/0xA5..0xA7: planned trapezoid */
	RMD_SIM_MIT,	   /* 0x400 + ID */
};

/* PI gains, in the order of enum rmd_field RMD_FLD_CURR_KP..RMD_FLD_POS_KI. */
#define RMD_SIM_NPID 6
/* V4.2 §2.1.4: float gains by 0x30..0x32 index, 1..9 (0, 3, 6 unused). */
#define RMD_SIM_NGAIN 10

/* Settings the firmware keeps: one copy in ROM (flash), one running in RAM. */
struct rmd_sim_settings {
	uint8_t can_id;			/* V3 §4 / V2 §3.52 */
	int64_t pid[RMD_SIM_NPID];	/* V3 uint8 units (§2.1), V2 Q24 (§3.1) */
	float gain[RMD_SIM_NGAIN];	/* V4.2 §2.1: by index (RMD_PID_FLOAT_INDEXED) */
	int32_t angle_limit[2];		/* V4.2 §2.34.4 index 6, 7: positive, negative */
	uint32_t accel_dps2[4];		/* 0x43 index 0..3 (V3 §2.5.4); 0: no limit */
	int64_t encoder_offset;		/* multi-turn zero, counts (0x62..0x64) */
	uint16_t encoder_offset_single; /* V2 0x90/0x91/0x19 */
	uint32_t comm_timeout_ms;	/* 0xB3; 0 = off */
	uint8_t baud_code;		/* 0xB4 */
	bool can_filter;		/* 0x20 index 2: ignore 0x280 and 0x300 */
	bool multiturn_save;		/* 0x20 index 4: keep multi-turn at power-off */
};

/*
 * Rom/ram settings and live state of one motor.  Caller allocates.  The
 * fields are readable for the sim bus and tools; change them only through
 * the functions below (params p may be tuned between calls: ambient_c,
 * supply_v and load_nm are read at every step).
 */
struct rmd_sim_motor {
	struct rmd_sim_motor_params p;
	const struct rmd_dialect *d; /* of p.proto: what the simulated firmware speaks */
	struct rmd_sim_settings rom;
	struct rmd_sim_settings ram; /* ram.can_id is the motor's ID now */
	bool clear_multiturn;	     /* 0x20 index 1: wrap at the next start (ROM) */
	bool error_reports;	     /* 0x20 index 3: 0x9A every 100 ms while faulted */
	/* V4.2 §2.33 (0xB6): d->report_cmds[k] pushed every report_steps[k] x 10 ms; 0 off */
	uint16_t report_steps[RMD_DIALECT_REPORTS_MAX];
	int64_t report_next_ns[RMD_DIALECT_REPORTS_MAX];
	/* RMD_PID_FLOAT_INDEXED: the gain index of pid[i]'s gain (same key), or -1 */
	int8_t gain_index[RMD_SIM_NPID];
	/* mechanics, output shaft */
	double pos_rad; /* multi-turn, from the encoder's raw zero; RAM only */
	double vel_rad_s;
	double iq_a;
	double temp_c;
	int64_t t_ns;	     /* physics time reached */
	int64_t boot_ns;     /* last power-on or reset: 0xB1's runtime counts from it */
	int64_t awake_ns;    /* its firmware answers from then on (boot_ns + p.boot_ms) */
	int64_t last_due_ns; /* when its latest reply was due (rmd_sim_motor_reply_due()) */
	/* control */
	enum rmd_sim_ctrl ctrl;
	enum rmd_sim_ctrl ctrl_stopped; /* V2 0x81 keeps the mode for 0x88 */
	double sp_current_a;
	double sp_speed_rad_s;	 /* 0xA2 target */
	double ramp_speed_rad_s; /* 0xA2 reference under the 0x43 limits */
	double ramp_acc_rad_s2;
	double sp_pos_rad; /* target, in the pos_rad frame */
	double sp_max_speed_rad_s;
	double hold_pos_rad; /* where 0x81 stops; the mode's target stays for V2 0x88 */
	double traj_pos_rad, traj_vel_rad_s, traj_acc_rad_s2; /* planner state */
	double speed_int_a;				      /* speed-loop integrator */
	double tf_current_a;				      /* V2 0x73 feed-forward */
	struct rmd_mit_cmd mit;
	/*
	 * What its firmware scales MIT frames by (V3 §5, V4.2 §5): its
	 * dialect's own for its version_date and model (V4.4), else p.mit
	 */
	struct rmd_mit_ranges mit_ranges;
	bool brake_locked;
	/* faults */
	uint16_t errors;	 /* reported: live | latched | injected */
	uint16_t errors_live;	 /* level-2 conditions present now */
	uint16_t errors_latched; /* level-1 faults, until restart */
	uint16_t errors_injected;
	double stall_s;
	/* comm-loss protection (V3 §2.30) */
	bool comm_armed;
	int64_t last_rx_ns;
	bool comm_lost;
	bool echo_next; /* first command after a trip only echoed */
	int64_t next_f1_ns;
	int64_t next_9a_ns;
	bool present; /* false: disappeared, answers nothing */
	/* p.set_id_replies_new: the ID its replies come from after 0x20 index 5; 0 its own */
	uint8_t reply_as;
	bool mit_seen; /* an MIT frame was executed since the last start (p.a4_ignored_after_mit) */
	/* p.personality's turnaround line index + 1 by command byte (256: MIT); 0 none */
	uint8_t turnaround_row[257];
	uint64_t rng;
	/*
	 * The world whose joint is this motor's shaft (rmd/sim_body.h), and
	 * its slot there; NULL: the motor turns its own inertia.  Set by
	 * rmd_sim_body_attach() after rmd_sim_motor_init().
	 */
	struct rmd_sim_body *body;
	unsigned body_slot;
};

/* Power the motor on at now_ns: ROM defaults, brake locked.  rt-safe. */
void rmd_sim_motor_init(struct rmd_sim_motor *m, const struct rmd_sim_motor_params *p,
			int64_t now_ns);

/*
 * Advance physics to now_ns in fixed steps (earlier times: no-op); a motor
 * on a world (m->body) steps with it, and may step its other motors and
 * the world too (rmd/sim_body.h).  rt-safe.
 */
void rmd_sim_motor_step(struct rmd_sim_motor *m, int64_t now_ns);

/*
 * The motor sees frame f (any identifier: it picks what is addressed to it,
 * 0x140 + ID, 0x280, 0x300, 0x400 + ID) at now_ns.  Replies go to out[]
 * (at most `max`); returns their count (0 when the frame is not for it or
 * is not answered).  Never fails on any input.  rt-safe.
 */
int rmd_sim_motor_receive(struct rmd_sim_motor *m, int64_t now_ns, const struct rmd_frame *f,
			  struct rmd_frame *out, int max);

/*
 * Unsolicited frames due by now_ns (0xF1 each second after a comm-loss
 * trip, 0x9A error reports every 100 ms, V4 0xB6 active replies).  Frames that did not fit in
 * `max` stay due.  rt-safe.
 */
int rmd_sim_motor_poll(struct rmd_sim_motor *m, int64_t now_ns, struct rmd_frame *out, int max);

/*
 * When the next unsolicited frame falls due if nothing else happens
 * (INT64_MAX: none scheduled), so a bus can step to exactly that time.
 * rt-safe.
 */
int64_t rmd_sim_motor_next_event_ns(const struct rmd_sim_motor *m);

/*
 * The host was away for held_ns, not silent (rmd/sim_wire.h "Host gaps"):
 * the comm-loss timer (V3 §2.30) does not count that time, as if the last
 * frame had come held_ns later.  A tripped or unarmed protection is left
 * as it is.  rt-safe.
 */
void rmd_sim_motor_hold_comm(struct rmd_sim_motor *m, int64_t held_ns);

/*
 * Power cycle: RAM lost (multi-turn wraps to +-180 deg), ROM kept, brake
 * locked; the firmware boots for p.boot_ms before it answers.  rt-safe.
 */
void rmd_sim_motor_power_cycle(struct rmd_sim_motor *m, int64_t now_ns);

/*
 * Fault injection: these error bits (RMD_SIM_ERR_*) are reported and act
 * like real faults until another call replaces them (0 clears).  rt-safe.
 */
void rmd_sim_motor_set_error(struct rmd_sim_motor *m, uint16_t bits);

/* Reseed the motor's PRNG (0: derive from the ID).  rt-safe. */
void rmd_sim_motor_seed(struct rmd_sim_motor *m, uint64_t seed);

/* Next value of the motor's PRNG (xorshift64*).  rt-safe. */
uint64_t rmd_sim_motor_rand(struct rmd_sim_motor *m);

/* A turnaround for the next reply: mean +- uniform jitter, >= 0.  rt-safe. */
int64_t rmd_sim_motor_turnaround_ns(struct rmd_sim_motor *m);

/*
 * What the motor adds to its turnaround (rmd_sim_motor_turnaround_ns())
 * for request `req`: rom_write_ns when the command writes ROM
 * (RMD_CMD_ROM in its dialect's codec row: the firmware answers after
 * the flash write), else 0.  rt-safe.
 */
int64_t rmd_sim_motor_rom_extra_ns(const struct rmd_sim_motor *m, const struct rmd_frame *req);

/*
 * When the reply to `req`, received at t_ns, is ready: a turnaround later
 * (rmd_sim_motor_turnaround_ns(), plus rmd_sim_motor_rom_extra_ns()), and
 * never before the motor's previous reply: firmware answers its requests
 * one after the other, in order, whatever the jitter.  Call it once per
 * reply.  rt-safe.
 */
int64_t rmd_sim_motor_reply_due(struct rmd_sim_motor *m, int64_t t_ns, const struct rmd_frame *req);

#endif /* RMD_SIM_H */
