/* SPDX-License-Identifier: MIT */
/*
 * Simulated RMD motors and the simulated CAN bus they share (DESIGN.md
 * layer 3).  Time is always an injected int64_t nanosecond clock: nothing
 * here reads a real clock, sleeps or allocates, so a test can drive a
 * motor through seconds of simulated time in microseconds, and the
 * in-process sim bus can run inside the daemon's rt loop.
 *
 * struct rmd_sim_motor: one motor behind its frame interface.  Physics at
 * the output shaft, integrated at a fixed step (<= 100 us) whatever the
 * host's command rate; V3, V2 or MIT protocol as configured.
 *
 * struct rmd_sim_bus: a bus of motors with a wire-time model: every frame,
 * the host's and the motors', occupies the wire for its exact bit-stuffed
 * length in arbitration order; motors answer after a turnaround with
 * jitter; faults are injected here.
 */
#ifndef RMD_SIM_H
#define RMD_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/frame.h"
#include "rmd/mit.h"

#define RMD_SIM_STEP_NS 50000 /* physics step: 50 us */

/* Physical and firmware parameters of one simulated motor. */
struct rmd_sim_motor_params {
	uint8_t id;	      /* 1..32 */
	enum rmd_proto proto; /* V3, V2 or MIT (MIT motors also speak V3) */
	double inertia_kgm2;  /* at the output shaft, rotor reflected */
	double viscous_nm_s_rad;
	double coulomb_nm;
	double kt_nm_a;	   /* output-shaft torque per amp of iq */
	double gear_ratio; /* motor turns per output turn */
	double max_current_a;
	double load_nm;	      /* constant external torque on the shaft */
	double max_speed_dps; /* over-speed fault above this */
	double phase_resistance_ohm;
	double thermal_resistance_c_w; /* winding to ambient */
	double thermal_tau_s;
	double ambient_c;
	double supply_v;
	unsigned encoder_bits; /* single-turn resolution, e.g. 16 */
	struct rmd_mit_ranges mit;
	char model[8];	       /* 0xB5, e.g. "X8S2V10" */
	uint32_t version_date; /* 0xB2, e.g. 20220206 */
	double turnaround_ns;  /* request end to reply start, mean */
	double turnaround_jitter_ns;
};

/* Parameters of a typical X8 actuator; id and proto set by the caller. */
void rmd_sim_motor_params_default(struct rmd_sim_motor_params *p, uint8_t id, enum rmd_proto proto);

enum rmd_sim_ctrl {
	RMD_SIM_OFF = 0,   /* output off (0x80, power-on, comm-loss) */
	RMD_SIM_HOLD,	   /* 0x81 stop: hold position */
	RMD_SIM_TORQUE,	   /* 0xA1 */
	RMD_SIM_SPEED,	   /* 0xA2 */
	RMD_SIM_POS_TRACK, /* 0xA3 (and V3 0xA5 with a speed limit) */
	RMD_SIM_POS_ABS,   /* 0xA4 (V2 0xA6), planned trapezoid */
	RMD_SIM_MIT,	   /* 0x400 + ID */
};

/* Rom/ram settings and live state of one motor.  Caller allocates. */
struct rmd_sim_motor {
	struct rmd_sim_motor_params p;
	/* mechanics, output shaft */
	double pos_rad; /* multi-turn, RAM only */
	double vel_rad_s;
	double iq_a;
	double temp_c;
	int64_t t_ns; /* physics time reached */
	/* control */
	enum rmd_sim_ctrl ctrl;
	double sp_current_a, sp_speed_rad_s, sp_pos_rad, sp_max_speed_rad_s;
	double traj_pos_rad, traj_vel_rad_s; /* planner state of 0xA4 */
	struct rmd_mit_cmd mit;
	bool brake_locked;
	uint16_t errors; /* V3 §2.12 table 1 bits */
	/* RAM / ROM settings */
	uint8_t pid[6];		  /* V3 0x30..0x32 */
	uint32_t accel_dps2[4];	  /* V3 0x43 index 0..3 */
	int32_t encoder_offset;	  /* ROM */
	uint32_t comm_timeout_ms; /* 0xB3, ROM; 0 = off */
	bool can_filter;	  /* 0x20 index 2, ROM */
	bool error_reports;	  /* 0x20 index 3 */
	/* comm-loss protection (V3 §2.30) */
	int64_t last_rx_ns;
	bool comm_lost;
	bool echo_next; /* first command after recovery only echoed */
	int64_t next_f1_ns;
	int64_t next_9a_ns;
	int64_t boot_ns;
	bool present; /* false: disappeared, answers nothing */
	uint64_t rng;
};

void rmd_sim_motor_init(struct rmd_sim_motor *m, const struct rmd_sim_motor_params *p,
			int64_t now_ns);

/* Advance physics to now_ns in fixed steps. */
void rmd_sim_motor_step(struct rmd_sim_motor *m, int64_t now_ns);

/*
 * The motor sees frame f (any identifier: it picks what is addressed to it,
 * 0x140 + ID, 0x280, 0x300, 0x400 + ID) at now_ns.  Replies go to out[]
 * (at most `max`); returns their count (0 when the frame is not for it or
 * is not answered).
 */
int rmd_sim_motor_receive(struct rmd_sim_motor *m, int64_t now_ns, const struct rmd_frame *f,
			  struct rmd_frame *out, int max);

/* Unsolicited frames due by now_ns (0xF1 each second after a comm-loss trip, 0x9A error reports every 100 ms). */
int rmd_sim_motor_poll(struct rmd_sim_motor *m, int64_t now_ns, struct rmd_frame *out, int max);

/* Power cycle: RAM lost (multi-turn wraps to +-180 deg), ROM kept, brake locked. */
void rmd_sim_motor_power_cycle(struct rmd_sim_motor *m, int64_t now_ns);

#endif /* RMD_SIM_H */
