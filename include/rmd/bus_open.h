/* SPDX-License-Identifier: MIT */
/*
 * The one bus factory: rmd_bus_open() opens any transport from a config
 * entry (struct rmd_config_bus) and the bus's motors.  A one-word spec, as
 * a command line names it, parses into the same entry (rmd_bus_spec_parse())
 * and takes the same path (rmd_bus_open_spec()); the spec picks the
 * transport:
 *
 *   "sim"            in-process simulated bus (rmd/bus_sim.h), motors 1..4
 *   "sim:1-3,7"      ... with motors 1, 2, 3 and 7
 *   "/dev/ttyUSB0"   a path (starts with '/'): RS485 line (rmd/bus_rs485.h)
 *   "can0"           anything else: a SocketCAN interface (rmd/bus_socketcan.h)
 *
 * Simulated motors power on fresh at every open: nothing they were told
 * outlives the process that opened them.
 */
#ifndef RMD_BUS_OPEN_H
#define RMD_BUS_OPEN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/codec.h"
#include "rmd/config.h"
#include "rmd/sim_setup.h"

/* Motors of a plain "sim" spec: ids 1..RMD_BUS_OPEN_SIM_MOTORS. */
#define RMD_BUS_OPEN_SIM_MOTORS 4
/* RS485 baud when opts.baud is 0 (V3 §1.2.1 lists 115200 .. 2000000). */
#define RMD_BUS_OPEN_BAUD 1000000

struct rmd_bus_open_opts {
	enum rmd_proto proto; /* the motors' protocol (V2 has no RS485 interface) */
	/*
	 * Motors whose replies SocketCAN admits (its kernel filter); n_ids 0:
	 * every id 1..32.  The sim bus takes its motors from the spec instead.
	 */
	const uint8_t *ids;
	unsigned n_ids;
	bool set_id_replies; /* SocketCAN: also admit 0x300 (V3 §4: 0x79 replies) */
	/*
	 * SocketCAN: also admit the replies of motors the caller does not
	 * drive that a V2 0x280 frame would command (struct
	 * rmd_socketcan_opts.watch_strays): a bus whose plan batches
	 */
	bool watch_strays;
	unsigned burst; /* SocketCAN: frames per cycle the txqueuelen must hold; 0: no check */
	uint32_t baud;	/* RS485; 0: RMD_BUS_OPEN_BAUD */
	int64_t reply_timeout_ns;   /* RS485; 0: its default */
	unsigned broadcast_replies; /* RS485: see struct rmd_rs485_opts */
	bool local_echo;	    /* RS485: the adapter hears itself (struct rmd_rs485_opts) */
	uint32_t sim_bitrate;	    /* sim; 0: 1 Mbit/s */
	uint64_t sim_seed;	    /* sim; 0: the default seed */
	/*
	 * sim: every motor's model (rmd/sim_params.h: the motors' and the
	 * adapter's timing among it), its id replaced by each motor's; NULL:
	 * rmd_sim_motor_params_default() with opts.proto.
	 */
	const struct rmd_sim_motor_params *sim_motor;
	bool device; /* the motors' side of the wire (rmd-sim): see struct rmd_bus_open_ctx */
};

/* A motor on the bus being opened. */
struct rmd_bus_open_motor {
	uint8_t id;	      /* 1..32 */
	enum rmd_proto proto; /* its dialect (rmd/dialect.h) */
	bool any_dialect;     /* `protocol: auto`: the replies of every dialect are admitted */
	bool mit;	      /* driven in MIT mode: its MIT replies (0x500 + ID) are admitted */
	/* sim buses: the simulated motor; NULL: rmd_sim_motor_params_default() */
	const struct rmd_sim_motor_params *sim;
	int cfg_motor; /* its index in rmd_config.motors[] (rmd_bus_open_ctx_of()), < 0: none */
};

/* What rmd_bus_open() needs beside the config entry. */
struct rmd_bus_open_ctx {
	/*
	 * The bus's motors: SocketCAN admits their replies (its kernel
	 * filter), the sim bus powers them on, RS485 refuses V2 among them.
	 */
	const struct rmd_bus_open_motor *motors;
	unsigned n_motors;
	unsigned burst;	     /* SocketCAN: frames per cycle the txqueuelen must hold; 0: no check */
	bool set_id_replies; /* SocketCAN: also admit 0x300 (V3 §4: 0x79 replies) */
	/*
	 * SocketCAN: also admit the replies of motors the caller does not
	 * drive that a V2 0x280 frame would command (struct
	 * rmd_socketcan_opts.watch_strays): a bus whose plan batches
	 */
	bool watch_strays;
	int64_t reply_timeout_ns;   /* RS485; 0: its default */
	unsigned broadcast_replies; /* RS485 (struct rmd_rs485_opts); 0: n_motors */
	bool local_echo;	    /* RS485: the adapter hears itself (struct rmd_rs485_opts) */
	/* sim buses: wire settings and faults (sim time); NULL: the defaults */
	const struct rmd_sim_bus_setup *sim;
	/* sim buses: the world of sim.physics (rmd/sim_body.h); NULL: none */
	struct rmd_sim_body *body;
	/* sim buses: gaps the caller was held away for (struct rmd_bus_sim_opts); 0: none */
	int64_t sim_hold_after_ns;
	/*
	 * The motors' side of the wire, for a simulator of them (rmd-sim):
	 * SocketCAN admits the requests to every id instead of the motors'
	 * replies and opens an interface that is down; RS485 reads requests
	 * and writes replies, with no queue (rmd/bus_rs485.h).  Not for sim
	 * buses.
	 */
	bool device;
};

/*
 * Open the bus cb describes (its kind, name, interface or device, bitrate
 * or baud) as `bus` (caller allocates; rmd_bus_close() releases it).  cb->sim
 * is not read: a sim bus takes its wire settings from ctx->sim.  Returns 0
 * (err may hold a notice to log, e.g. an RS485 port without kernel RS485
 * mode) or the transport's -errno with a one-line message in err.  Non-rt:
 * allocates.
 */
int rmd_bus_open(struct rmd_bus *bus, const struct rmd_config_bus *cb,
		 const struct rmd_bus_open_ctx *ctx, char *err, size_t errlen);

/*
 * Fill *ctx for bus b of cfg: the motors configured on it (id, proto and,
 * from sim, their simulated model, stored in motors[]) and, for a sim bus,
 * its wire settings and faults from sim (NULL: the simulator's defaults).
 * burst, set_id_replies and the RS485 settings are left 0 for the caller.
 * Pure.
 */
void rmd_bus_open_ctx_of(const struct rmd_config *cfg, const struct rmd_sim_setup *sim, unsigned b,
			 struct rmd_bus_open_motor motors[RMD_MAX_MOTORS],
			 struct rmd_bus_open_ctx *ctx);

/*
 * Parse `spec` (see the top of this file) into *cb: kind, name, interface
 * or device, and opts' baud and sim bitrate (opts NULL: the defaults).  A
 * sim spec's motor ids go to ids[] (ascending; "sim": 1..4).  Returns the
 * number of ids (0 for a CAN interface or a serial device), or -EINVAL
 * with a message in err.  Pure.
 */
int rmd_bus_spec_parse(const char *spec, const struct rmd_bus_open_opts *opts,
		       struct rmd_config_bus *cb, uint8_t ids[RMD_MAX_MOTORS], char *err,
		       size_t errlen);

/*
 * How the planner must count a bus cb describes: its rate, the worst-case
 * bits of one 8-byte frame, and the turnaround each request costs (RS485:
 * half duplex; 0 on CAN, where replies overlap other frames).  Returns 0,
 * or -EINVAL for an unknown kind.  Pure.
 */
struct rmd_bus_timing {
	uint32_t bitrate;      /* bit/s on the wire (RS485: its baud) */
	unsigned frame_bits;   /* one 8-byte frame, worst case, gaps included */
	int64_t turnaround_ns; /* request end to reply start, per request; 0: none */
	bool half_duplex;      /* one request at a time (turnaround_ns counts) */
	const char *port;      /* for messages: the interface or device; NULL: none (sim) */
	const char *rate_unit; /* for messages: "bit/s" or "baud" */
};
int rmd_bus_config_timing(const struct rmd_config_bus *cb, struct rmd_bus_timing *out);

/*
 * Open the bus `spec` names as `bus` (caller allocates; rmd_bus_close()
 * releases it): rmd_bus_spec_parse(), then rmd_bus_open() with the
 * motors of the spec (sim), of opts (ids), or every id 1..32 with
 * opts.proto.  opts NULL: V3 motors, every id, the defaults above.
 * Returns 0 (err may hold a notice to log, e.g. an RS485 port without
 * kernel RS485 mode) or the transport's -errno with a one-line message in
 * err; a spec that cannot be parsed gives -EINVAL.  Non-rt: allocates.
 */
int rmd_bus_open_spec(struct rmd_bus *bus, const char *spec, const struct rmd_bus_open_opts *opts,
		      char *err, size_t errlen);

/*
 * Parse a motor id list "1-3,7" (ids 1..32, ranges low-high, commas, no
 * spaces, each id once) into ids[] (ascending).  Returns the count (1..32)
 * or -EINVAL.  Pure.
 */
int rmd_bus_open_parse_ids(const char *list, uint8_t ids[RMD_MAX_MOTORS]);

/* True when spec names the simulated bus ("sim" or "sim:..."). Pure. */
bool rmd_bus_open_is_sim(const char *spec);

/*
 * True when motor i of cfg is simulated in this process: its bus is an
 * in-process sim bus (rmd/bus_sim.h), not a wire rmd-sim answers on.  Pure.
 */
bool rmd_bus_config_motor_in_process(const struct rmd_config *cfg, unsigned i);

/*
 * A simulated bus's time 0 in the caller's clock (now_ns's, CLOCK_MONOTONIC
 * for rmdd), from which its fault windows count (rmd/bus_sim.h "Time"); 0
 * for a bus with no time of its own (SocketCAN, RS485).  A sim bus not used
 * yet starts at its first use: now_ns.  Rt-safe.
 */
int64_t rmd_bus_open_time_zero_ns(struct rmd_bus *bus, int64_t now_ns);

#endif /* RMD_BUS_OPEN_H */
