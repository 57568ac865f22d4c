/* SPDX-License-Identifier: MIT */
/*
 * Transports behind one ops table (DESIGN.md layer 2), like libmodbus
 * backends: SocketCAN, RS485 serial, and the in-process simulated bus.
 * The rest of the program never knows which one it holds.
 *
 * Every op is non-blocking.  send() queues what the transport can take
 * now and returns how many frames it took; the caller keeps the rest for
 * the next cycle (ENOBUFS/EAGAIN are counted, never waited on).  recv()
 * returns what has arrived by now.  A caller that wants to sleep until
 * frames arrive waits on fd() (-1 when the transport has no descriptor,
 * like the sim bus, whose time advances on each call with now_ns).
 */
#ifndef RMD_BUS_H
#define RMD_BUS_H

#include <stdint.h>

#include "rmd/frame.h"

struct rmd_bus_rx {
	struct rmd_frame f;
	int64_t t_ns; /* receive time, CLOCK_MONOTONIC (kernel stamp where there is one) */
};

struct rmd_bus_stats {
	uint64_t tx_frames;
	uint64_t rx_frames;
	uint64_t tx_busy;    /* frames refused with ENOBUFS/EAGAIN, resent later */
	uint64_t rx_errors;  /* bad CRC, bad framing, short reads */
	uint64_t bus_errors; /* error frames / state events */
	uint64_t state_changes;
};

struct rmd_bus;

struct rmd_bus_ops {
	const char *kind; /* "socketcan", "rs485", "sim" */
	/* Queue up to n frames; returns how many were taken (0..n) or -errno. */
	int (*send)(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		    int64_t now_ns);
	/* Store up to max frames that have arrived by now_ns; returns the count or -errno. */
	int (*recv)(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns);
	/* Descriptor that becomes readable when frames arrive, or -1. */
	int (*fd)(const struct rmd_bus *bus);
	void (*close)(struct rmd_bus *bus);
};

struct rmd_bus {
	const struct rmd_bus_ops *ops;
	char name[32]; /* "can0", "/dev/ttyUSB0", "sim0": for messages */
	enum rmd_bus_state state;
	struct rmd_bus_stats stats;
	void *priv; /* the backend's own state */
};

static inline int rmd_bus_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
			       int64_t now_ns)
{
	return bus->ops->send(bus, frames, n, now_ns);
}

static inline int rmd_bus_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max,
			       int64_t now_ns)
{
	return bus->ops->recv(bus, out, max, now_ns);
}

static inline int rmd_bus_fd(const struct rmd_bus *bus)
{
	return bus->ops->fd(bus);
}

/* Close the transport; NULL and an unopened bus are no-ops. */
static inline void rmd_bus_close(struct rmd_bus *bus)
{
	if (bus && bus->ops)
		bus->ops->close(bus);
}

const char *rmd_bus_state_name(enum rmd_bus_state state);

#endif /* RMD_BUS_H */
