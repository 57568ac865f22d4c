/* SPDX-License-Identifier: MIT */
/*
 * The in-process simulated transport (docs/design.md, layer bus): a struct
 * rmd_sim_wire (rmd/sim_wire.h) with its motors, behind struct rmd_bus_ops,
 * so rmdd and rmdctl run with no hardware and never know it.
 *
 * Time.  The sim bus keeps its own clock, which starts at 0; the caller's
 * now_ns is CLOCK_MONOTONIC.  The first send() or recv() fixes the epoch:
 * sim time = now_ns - (now_ns of that first call), so the motors power on
 * when the bus is first used.  send() runs the wire up to now and queues
 * the frames; recv() runs the wire up to now (motor physics included) and
 * pops what was delivered by then, stamped with its end of frame in the
 * caller's time.  A reply therefore comes a turnaround (0.5 ms +- jitter)
 * plus the wire time of request and reply after the request, never at
 * once, and only to a caller that calls recv() again later: fd() is -1,
 * the caller steps its clock forward (rmd/txn.h sleeps in small steps).
 *
 * Host gaps.  With opts.hold_after_ns, the bus judges the caller in its
 * own time: a send() or recv() that comes more than hold_after_ns after
 * the last one ends a gap the caller did not choose (a busy host, a
 * stopped process), and the motors' comm-loss protection does not count
 * the rest of it (rmd_sim_wire_set_hold_after()).  A caller that keeps
 * calling and sends nothing is silent and trips it as before.  A real
 * wire has no such thing: there a late host is a silent one.
 *
 * Wire tap.  With opts.tap, every frame that finishes on the wire (the
 * host's, the motors', a flood's) is written to that path as a `candump -l`
 * line, "(SECONDS.MICROSECONDS) NAME ID#DATA T|R" (T: the host sent it), stamped with its end of frame
 * in the caller's clock (CLOCK_MONOTONIC for rmdd: the clock of state_t's
 * utime and rx_time_ns).  A regular file is created or truncated and
 * appended to (several buses may share one); a FIFO must have its reader
 * already.  Lines are written whole, PIPE_BUF bytes at a time, with
 * O_NONBLOCK: when a FIFO is full the lines of that write are lost (counted,
 * rmd_bus_sim_tap_lost()).  O_NONBLOCK does not cover the pipe's lock,
 * though: a reader descheduled while it copies holds it, and the loop's
 * write() waits (36 ms on a busy machine here); prefer a regular file.  A
 * test and soak aid: it costs a write() every ~90 frames.
 *
 * Not thread-safe (one owner, like the sim bus).  send/recv/fd are rt-safe
 * (bounded work, no allocation, no syscalls but the tap's non-blocking
 * write()); open and close are not.
 */
#ifndef RMD_BUS_SIM_H
#define RMD_BUS_SIM_H

#include <stddef.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/codec.h"
#include "rmd/sim.h"
#include "rmd/sim_wire.h"

#define RMD_BUS_SIM_BITRATE 1000000 /* default: 1 Mbit/s */
#define RMD_BUS_SIM_SEED 1	    /* default PRNG seed: runs are reproducible */

/* One motor on the simulated bus. */
struct rmd_bus_sim_motor {
	uint8_t id;				   /* 1..32 */
	enum rmd_proto proto;			   /* V3, V2 or MIT */
	const struct rmd_sim_motor_params *params; /* NULL: rmd_sim_motor_params_default() */
	/* with opts.body: its index in rmd_config.motors[], whose joint it drives; < 0: none */
	int cfg_motor;
};

struct rmd_bus_sim_opts {
	const struct rmd_bus_sim_motor *motors;
	unsigned n_motors;   /* 0..RMD_MAX_MOTORS */
	uint32_t bitrate;    /* bit/s; 0: RMD_BUS_SIM_BITRATE */
	uint64_t seed;	     /* faults' and jitter PRNG; 0: RMD_BUS_SIM_SEED */
	unsigned flags;	     /* RMD_SIM_WIRE_* (RMD_SIM_WIRE_HOST_FIFO: like SocketCAN) */
	unsigned txqueuelen; /* host TX queue, 1..RMD_SIM_WIRE_TXQ; 0: the sim bus's default */
	const struct rmd_sim_fault *faults; /* in sim time (see above); may be NULL */
	unsigned n_faults;
	const char *tap; /* wire tap: a file or FIFO (below); NULL: none */
	unsigned burst;	 /* frames per cycle the TX queue must hold; 0: no check */
	/*
	 * flush (rmd_bus_flush()) is refused with -EPERM, as SocketCAN's
	 * without CAP_NET_ADMIN; false: it empties the host queue
	 * (rmd_sim_wire_flush()).
	 */
	bool refuse_flush;
	/*
	 * The world the motors' shafts are joints of (rmd/sim_body.h), shared
	 * with the other buses of the process; NULL: none, each motor turns
	 * its own inertia.  The bus must close before it is freed.
	 */
	struct rmd_sim_body *body;
	/*
	 * Host gaps (rmd/sim_wire.h): a send() or recv() more than this after
	 * the one before ends a gap the caller was held away for (its thread
	 * preempted, the process stopped), which the motors' comm-loss
	 * timers do not count; 0: none, every gap is silence, as on a wire.
	 */
	int64_t hold_after_ns;
};

/*
 * Open a simulated bus called `name` (for messages, e.g. "sim0"; truncated
 * to fit bus->name) as `bus` (caller allocates; zeroed by close) with the
 * motors of opts.  Returns 0, or -errno with a one-line message in err:
 *   -EINVAL  opts NULL, a motor id outside 1..32, a bad bitrate, queue
 *            length or fault entry
 *   -ENOBUFS a TX queue shorter than burst (as SocketCAN's txqueuelen check)
 *   -EEXIST  two motors with one id
 *   -E2BIG   more than RMD_MAX_MOTORS motors or RMD_SIM_MAX_FAULTS faults
 *   -ENOMEM  out of memory
 *   other    the tap could not be opened (-ENXIO: a FIFO without a reader)
 * Non-rt: allocates.
 */
int rmd_bus_sim_open(struct rmd_bus *bus, const char *name, const struct rmd_bus_sim_opts *opts,
		     char *err, size_t errlen);

/*
 * The simulated bus behind `bus`, for fault injection and inspection
 * (motors, statistics), or NULL when `bus` is not a sim bus.  Its times are
 * sim times: see rmd_bus_sim_time_ns().  Rt-safe.
 */
struct rmd_sim_wire *rmd_bus_sim_get(struct rmd_bus *bus);

/*
 * Sim time of the caller's now_ns: now_ns minus the epoch, or 0 before the
 * first send() or recv() (which will make now_ns the epoch).  Rt-safe.
 */
int64_t rmd_bus_sim_time_ns(const struct rmd_bus *bus, int64_t now_ns);

/* Lines of the wire tap lost to a full FIFO or a failed write so far (0: no tap).  Rt-safe. */
uint64_t rmd_bus_sim_tap_lost(const struct rmd_bus *bus);

/*
 * The host's adapter refuses sends (issue 32 point 8), as a USB-CAN
 * adapter sharing its USB with cameras does (gs_usb: every TX URB in
 * flight, the queue full: sendmsg() says ENOBUFS while the bus is
 * healthy).  From start_ns to end_ns (sim time, rmd_bus_sim_time_ns(); 0:
 * open), a send() that finds the adapter busy takes nothing (0 returned,
 * the frames counted in stats.tx_busy, as SocketCAN's ENOBUFS): the first
 * send() of a run is refused and makes it busy for hold_ns; the first
 * send() after that is taken and ends the run, so the next one is refused
 * again (transient: each cycle's first try refused, a try hold_ns later
 * taken).  hold_ns 0: every send() of the window is refused (persistent).
 * Replaces an earlier window; 0 or -EINVAL (not a sim bus, end before
 * start, hold_ns < 0).  Rt-safe.
 */
int rmd_bus_sim_refuse_tx(struct rmd_bus *bus, int64_t start_ns, int64_t end_ns, int64_t hold_ns);

#endif /* RMD_BUS_SIM_H */
