/* SPDX-License-Identifier: MIT */
/*
 * Open a bus from a one-word spec, as a command line or a config file
 * names it; the spec picks the transport:
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
	unsigned burst;	     /* SocketCAN: frames per cycle the txqueuelen must hold; 0: no check */
	uint32_t baud;	     /* RS485; 0: RMD_BUS_OPEN_BAUD */
	int64_t reply_timeout_ns;   /* RS485; 0: its default */
	unsigned broadcast_replies; /* RS485: see struct rmd_rs485_opts */
	uint32_t sim_bitrate;	    /* sim; 0: 1 Mbit/s */
	uint64_t sim_seed;	    /* sim; 0: the default seed */
};

/*
 * Open the bus `spec` names as `bus` (caller allocates; rmd_bus_close()
 * releases it).  opts NULL: V3 motors, every id, the defaults above.
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

#endif /* RMD_BUS_OPEN_H */
