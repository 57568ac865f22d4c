/* SPDX-License-Identifier: MIT */
/*
 * rmd-sim internals: the configuration the command line and the config
 * file build (rmd-sim_config.c), the log helpers (rmd-sim.c) and the event
 * loop that runs the motors on a real wire (rmd-sim_loop.c).
 * Everything here is non-rt: a normal process with an event loop.
 */
#ifndef RMD_SIM_TOOL_H
#define RMD_SIM_TOOL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/codec.h"
#include "rmd/frame.h"
#include "rmd/mit.h"
#include "rmd/sim.h"
#include "rmd/sim_setup.h"
#include "rmd/sim_wire.h"
#include "tools/common/log.h"

/* Exit statuses (documented in docs/rmd-sim.md and --help). */
enum {
	SIM_EXIT_OK = 0,    /* stopped by SIGINT/SIGTERM */
	SIM_EXIT_RUN = 1,   /* the wire could not be opened, or went away */
	SIM_EXIT_USAGE = 2, /* bad argument or configuration value */
};

/*
 * -q: errors and warnings; default: + startup and exit summaries; -v: + every
 * frame.  Each is the most verbose log level it shows (tool_log_set_level()).
 */
enum sim_verbosity {
	SIM_QUIET = TOOL_LOG_WARNING,
	SIM_NORMAL = TOOL_LOG_INFO,
	SIM_FRAMES = TOOL_LOG_DEBUG,
};

enum sim_wire {
	SIM_WIRE_NONE = 0,
	SIM_WIRE_CAN,	 /* SocketCAN raw socket */
	SIM_WIRE_SERIAL, /* RS485 line (V3 §1.2.2 framing) */
};

/* Settings recorded in order, replayed onto each motor's parameters. */
#define SIM_MAX_SETTINGS 512
#define SIM_KEY_MAX 32
#define SIM_VALUE_MAX 128
#define SIM_WHERE_MAX 160

struct sim_setting {
	uint8_t motor; /* 0: every motor; else the motor with this params id */
	char key[SIM_KEY_MAX];
	char value[SIM_VALUE_MAX];
	char where[SIM_WHERE_MAX]; /* "--load" or "rmd-sim.conf:12", for messages */
};

struct sim_config {
	enum sim_wire wire;
	char device[256];		/* interface name or serial device path */
	uint32_t baud;			/* serial only */
	bool local_echo;		/* serial: the adapter hears its own transmission */
	char baud_where[SIM_WHERE_MAX]; /* where baud / local-echo were set: CAN refuses them */
	char echo_where[SIM_WHERE_MAX];
	uint32_t motors; /* bit id - 1 set for each simulated motor */
	uint64_t seed;
	enum sim_verbosity verbosity;

	struct sim_setting settings[SIM_MAX_SETTINGS];
	unsigned n_settings;
	/* Per-motor sections and --set ID:..., checked against `motors` at the end. */
	uint32_t motor_refs;
	char motor_ref_where[RMD_MAX_MOTORS][SIM_WHERE_MAX];

	struct rmd_sim_fault faults[RMD_SIM_MAX_FAULTS];
	char fault_text[RMD_SIM_MAX_FAULTS][SIM_VALUE_MAX]; /* as written, for the summary */
	char fault_where[RMD_SIM_MAX_FAULTS][SIM_WHERE_MAX];
	unsigned n_faults;

	/*
	 * An rmdd.yaml (sim_config_yaml()): the model of motor id i + 1 there,
	 * for the ids in base_set; the settings above apply on top of it.
	 */
	struct rmd_sim_motor_params base[RMD_MAX_MOTORS];
	uint32_t base_set;
	char yaml_bus[512]; /* "rmdd.yaml: bus rs0, motors 1 pan, 2 tilt", for the startup log */
	/*
	 * The rmdd.yaml's sim.physics for this bus's motors (docs/physics.md):
	 * its joints' .motor is the motor's id - 1 here; n_joints 0: none.
	 */
	struct rmd_sim_physics_setup physics;

	/* Filled by sim_config_finish(): the parameters of motor id i + 1. */
	struct rmd_sim_motor_params params[RMD_MAX_MOTORS];
};

/* ---- rmd-sim_config.c --------------------------------------------------------------------- */

/* Defaults: no wire, motor 1, V3, seed 1, 115200 baud. */
void sim_config_init(struct sim_config *c);

/*
 * One KEY = VALUE from `where` (an option name or FILE:LINE), for every motor
 * (motor 0) or one.  Keys are the long option names without "--" ('_' and
 * '-' alike).  Returns 0, or -EINVAL after logging a message that names
 * `where`, the value and what is allowed.
 */
int sim_config_set(struct sim_config *c, uint8_t motor, const char *key, const char *value,
		   const char *where);

/* "[ID:]KEY=VALUE" (--set).  Returns 0 or -EINVAL (logged). */
int sim_config_set_arg(struct sim_config *c, const char *arg, const char *where);

/*
 * Read a KEY = VALUE config file (format in docs/rmd-sim.md, kept as an
 * alias of an rmdd.yaml's sim: sections).  Returns 0 or -errno (logged).
 */
int sim_config_file(struct sim_config *c, const char *path);

/* Whether path names an rmdd.yaml (".yaml", ".yml"), not a KEY = VALUE file. */
bool sim_config_is_yaml(const char *path);

/*
 * An rmdd.yaml, read by rmdd's loader (docs/rmd-sim.md "One file for rmdd
 * and rmd-sim"): the wire of one of its socketcan or rs485 buses, that
 * bus's motors (ids, protocols and models from motors[] and the sim:
 * sections), its sim.seed and sim.faults.  The bus: `bus` when not NULL;
 * else the one whose interface or device is `wire` (--can or --serial,
 * may be NULL); else the file's only such bus.  Settings recorded before or
 * after apply on top.  Returns 0 or -errno, logged: a file's errors name
 * its line and key.
 */
int sim_config_yaml(struct sim_config *c, const char *path, const char *bus, const char *wire);

/* Cross-checks, and params[] of every motor.  Returns 0 or -EINVAL (logged). */
int sim_config_finish(struct sim_config *c);

/*
 * Setting key i (0, 1, ... until NULL; "" for none at this index), for the
 * long options of rmd-sim.c: the globals, then each motor parameter's
 * canonical name, its '-' spelling and its alias; *is_flag when the option
 * takes no value on the command line (local-echo).
 */
const char *sim_config_key(unsigned i, bool *is_flag);
/* Key i is a setting's own name (listed by --help), not its '-' spelling or its alias. */
bool sim_config_key_listed(unsigned i);

/* Option help: one line per setting key, for --help. */
void sim_config_help(void);

/* A set of motor ids (bit id - 1) as "1-3,5", for messages. */
void sim_format_motors(uint32_t mask, char *buf, size_t size);

/* ---- rmd-sim_loop.c ----------------------------------------------------------------------- */

/* Open the wire, run until SIGINT/SIGTERM, report.  Returns an exit status. */
int sim_run(const struct sim_config *c);

#endif /* RMD_SIM_TOOL_H */
