/* SPDX-License-Identifier: MIT */
/*
 * The adapter between a simulated bus and the host (docs/design.md, layer
 * sim; issue 21): when a frame that is complete on the wire reaches the
 * program.  Real adapters hold frames back:
 *
 * - a converter's latency timer (FTDI FT232R/FT232H USB-RS485 converters,
 *   16 ms by default): received bytes wait in the chip until the timer,
 *   started by the first byte held, expires; everything that came by then
 *   goes to the host together (a full buffer would go earlier: an RMD
 *   frame is 13 bytes of the chip's 62, so one exchange never fills it);
 * - USB batching (a USB-CAN adapter, full-speed USB): frames go to the host
 *   in the packets of the 1 ms USB frame, at the end of the one they fell in;
 *   an adapter that packs several frames into one packet (PCAN-USB,
 *   adapter_rx_batch) sends a packet at the end of the USB frame after the
 *   one its first frame fell in, or starts a new one when it is full, so
 *   that up to adapter_rx_batch frames, replies to requests sent apart,
 *   reach the host at one instant and a kernel stamps them alike (issue 32
 *   point 9);
 * - a fixed delay: driver, bridge, a slow converter.
 *
 * In that order, each after the one before.  The parameters are simulator
 * parameters (struct rmd_sim_motor_params, rmd/sim_params.h: rmdd.yaml
 * `sim:` and rmd-sim options); the state is the bus's, one per adapter.
 * Pure arithmetic on the caller's time: rt-safe.
 */
#ifndef RMD_SIM_ADAPTER_H
#define RMD_SIM_ADAPTER_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/sim.h"

/* One adapter's state: the latency timer's and the USB packet's. */
struct rmd_sim_adapter {
	bool holding;	   /* bytes are held ... */
	int64_t flush_ns;  /* ... until the timer expires at this time */
	unsigned packet_n; /* frames in the packet being filled ... */
	int64_t packet_ns; /* ... which goes to the host at this time */
};

/* Nothing held.  rt-safe. */
void rmd_sim_adapter_init(struct rmd_sim_adapter *a);

/*
 * When the host gets a frame that is complete on the wire at t_ns, through
 * the adapter p describes (its state in *a).  Calls must come in the order
 * of t_ns; the result never goes back in time from one call to the next
 * for one p.  rt-safe.
 */
int64_t rmd_sim_adapter_ns(struct rmd_sim_adapter *a, const struct rmd_sim_motor_params *p,
			   int64_t t_ns);

#endif /* RMD_SIM_ADAPTER_H */
