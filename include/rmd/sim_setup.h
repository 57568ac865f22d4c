/* SPDX-License-Identifier: MIT */
/*
 * The simulator's settings for a configuration (docs/design.md, layer sim): per
 * sim bus its wire (seed, host queue), its motor model and its fault
 * table; per motor its own model.  rmdd's YAML loader fills it from the
 * `sim:` sections (rmd/config_yaml.h) beside struct rmd_config, which
 * knows nothing of the simulator; the bus layer opens a sim bus from both.
 *
 * Plain fixed-size structs, no pointers: the caller allocates (about 35 KiB).
 */
#ifndef RMD_SIM_SETUP_H
#define RMD_SIM_SETUP_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/frame.h"
#include "rmd/sim.h"
#include "rmd/sim_faults.h"

/* SocketCAN's default txqueuelen (docs/design.md), a sim bus's host queue too. */
#define RMD_SIM_DEFAULT_TXQUEUELEN 10

/* Motors of a sim bus that the configuration does not list (struct rmd_sim_bus_setup.strays). */
#define RMD_SIM_MAX_STRAYS 8

/* Room for a wire tap's path (struct rmd_sim_bus_setup.tap), NUL included. */
#define RMD_SIM_TAP_PATH_LEN 128

/* One sim bus's simulator: wire (rmd/sim_wire.h), motor model, faults (rmd/sim_faults.h). */
struct rmd_sim_bus_setup {
	uint64_t seed;	     /* faults' and motors' PRNG; 0: 1 */
	unsigned txqueuelen; /* host TX queue, 1..RMD_SIM_WIRE_TXQ */
	bool host_fifo;	     /* RMD_SIM_WIRE_HOST_FIFO: frames leave in send order */
	/* its flush refused, as SocketCAN's without CAP_NET_ADMIN (rmd/bus_sim.h) */
	bool refuse_flush;
	/*
	 * The model of every motor on this bus (id, proto, kt_nm_a, gear_ratio
	 * and mit are the motor's own: see struct rmd_sim_setup.motors).
	 */
	struct rmd_sim_motor_params motor;
	struct rmd_sim_fault faults[RMD_SIM_MAX_FAULTS];
	unsigned n_faults;
	/*
	 * Motors on this wire that the configuration does not list (a spare, an
	 * entry commented out): the simulator's default motor with the keys
	 * each gives (its id, its firmware, ...).  rmdd does not drive them; a
	 * V2 0x280 frame would (issue 33 point 2).
	 */
	struct rmd_sim_motor_params strays[RMD_SIM_MAX_STRAYS];
	unsigned n_strays;
	/*
	 * Wire tap (rmd/bus_sim.h): every frame on this bus's wire, as a
	 * `candump -l` line, to this file or FIFO; "" (default): none.
	 */
	char tap[RMD_SIM_TAP_PATH_LEN];
};

/* Room for a physics model's path (struct rmd_sim_physics_setup.model), NUL included. */
#define RMD_SIM_MODEL_PATH_LEN 256
/* Room for a joint's name in the model, NUL included. */
#define RMD_SIM_JOINT_NAME_LEN 64
/* The physics rate when the configuration gives none (docs/physics.md "Rate"). */
#define RMD_SIM_PHYSICS_RATE_HZ 2000

/* One motor driving one joint of the model (sim.physics.joints). */
struct rmd_sim_physics_joint {
	unsigned motor; /* index in rmd_config.motors[] */
	char joint[RMD_SIM_JOINT_NAME_LEN];
	unsigned line; /* of its entry in the configuration, for messages */
};

/*
 * The physics behind the simulated motors (docs/physics.md): an MJCF
 * model, the joints the motors drive, the rate the world and the motors
 * exchange torque and state at, and the model's integration steps in each
 * exchange.  model "" (the default): none, each motor turns its own
 * inertia.  The model is loaded (and its joints checked) when the
 * simulator starts (rmd/sim_body.h), not by the configuration's loader.
 */
struct rmd_sim_physics_setup {
	char model[RMD_SIM_MODEL_PATH_LEN]; /* resolved against the configuration's folder */
	unsigned model_line;
	char source[256];   /* the configuration file, for messages */
	unsigned rate_hz;   /* exchanges per second; 20 kHz divisible by it */
	unsigned substeps;  /* integration steps of the model per exchange, >= 1 */
	unsigned rate_line; /* 0: rate_hz not given */
	struct rmd_sim_physics_joint joints[RMD_MAX_MOTORS];
	unsigned n_joints;
};

struct rmd_sim_setup {
	struct rmd_sim_bus_setup buses[RMD_MAX_BUSES]; /* as rmd_config.buses[] */
	/*
	 * The simulated motor of rmd_config.motors[i]: its bus's model with
	 * the motor's overrides, id, proto, kt (when given), gear ratio and MIT
	 * ranges.  rmdd runs those of its sim buses; rmd-sim those of the
	 * socketcan or rs485 bus it simulates.
	 */
	struct rmd_sim_motor_params motors[RMD_MAX_MOTORS];
	/* sim.physics: one world for every simulated motor of the process that maps a joint */
	struct rmd_sim_physics_setup physics;
};

/*
 * A sim bus's defaults: `seed`, SocketCAN's queue length, FIFO host queue,
 * the default motor model (rmd_sim_motor_params_default(), id 1, V3), no
 * faults.  rt-safe.
 */
void rmd_sim_bus_setup_default(struct rmd_sim_bus_setup *b, uint64_t seed);

#endif /* RMD_SIM_SETUP_H */
