/* SPDX-License-Identifier: MIT */
/*
 * Transports behind one ops table (docs/design.md, layer bus), like libmodbus
 * backends: SocketCAN, RS485 serial, and the in-process simulated bus.
 * The rest of the program never asks which one it holds: what it needs to
 * know (half duplex, the transport's reply timeout, how far apart queued
 * requests go out, when the transport's own queue must be serviced) is in
 * bus->caps, filled at open, and in the next_due_ns op; what it may count
 * is in struct rmd_bus_stats, whose fields a transport without them leaves
 * 0.  The one downcast, each transport's typed accessor (rmd_rs485_stats(),
 * ...), checks the ops table first, like the kernel's safe_candev_priv().
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

#include <errno.h>
#include <stdbool.h>
#include <stdint.h>

#include "rmd/frame.h"

/*
 * Wire time a request and its reply add to the requests queued behind them
 * on CAN: 2 frames of at most 135 bits (docs/design.md) at 500 kbit/s, rounded up.
 */
#define RMD_BUS_CAN_SPACING_NS 300000

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
	/* Byte-stream transports (RS485); 0 on the others: */
	uint64_t rx_noise_bytes; /* skipped to find the next frame (a run is one rx_error) */
	uint64_t echoes;	 /* own frames heard back and dropped (local echo) */
	/*
	 * Of tx_busy, frames the rt loop got onto the bus by trying again
	 * within their cycle (a full queue on a bus that carries frames,
	 * issue 32 point 8); kept by the loop, in its health's copy: the
	 * transports leave it 0.
	 */
	uint64_t tx_retried;
	/*
	 * Receive stamps (issue 32 point 9).  rx_stamps_shared, the
	 * transport's (CAN): frames stamped closer to the frame before them
	 * than RMD_BUS_STAMP_GAP_BITS bit times, which no two frames on the
	 * wire can be: the adapter hands them over in batches (PCAN-USB), its
	 * reply latencies are its packets'.  rx_stamps_early, kept by the rt
	 * loop as tx_retried: replies stamped before their request was sent
	 * (taken as received at the send).
	 */
	uint64_t rx_stamps_shared;
	uint64_t rx_stamps_early;
};

/* No two frames end closer on a CAN wire: an RMD frame is 108 bits and more (docs/design.md). */
#define RMD_BUS_STAMP_GAP_BITS 100

/* The gap of rmd_bus_stamp_seen() at bitrate bit/s (0: unknown, none).  Rt-safe. */
static inline int64_t rmd_bus_stamp_gap_ns(uint32_t bitrate)
{
	return bitrate ? (int64_t)RMD_BUS_STAMP_GAP_BITS * 1000000000 / bitrate : 0;
}

/*
 * A frame received, stamped t_ns: counted in stats->rx_stamps_shared when
 * it is closer than gap_ns to the one before (*last_ns, updated).  For
 * the transports.  Rt-safe.
 */
static inline void rmd_bus_stamp_seen(struct rmd_bus_stats *stats, int64_t *last_ns, int64_t t_ns,
				      int64_t gap_ns)
{
	stats->rx_stamps_shared += (uint64_t)(t_ns - *last_ns) < (uint64_t)gap_ns;
	*last_ns = t_ns;
}

/* What a caller needs to know of a transport, filled by its open. */
struct rmd_bus_caps {
	/*
	 * One request on the wire at a time: the transport queues requests
	 * and writes the next only after the previous one's answer or its
	 * reply timeout (RS485).  false: requests and replies overlap (CAN).
	 */
	bool half_duplex;
	/* The transport's own reply timeout; 0: it has none, the caller picks one. */
	int64_t reply_timeout_ns;
	/*
	 * Time one queued request holds up the next: a caller waiting for the
	 * k-th request of a batch allows k times this on top of its timeout.
	 */
	int64_t request_spacing_ns;
	/* Requests the transport queues itself (see next_due_ns); 0: none. */
	unsigned queue_len;
	/*
	 * Bit rate on the wire (RS485: its baud), for callers that count wire
	 * time (rmdctl rtt); 0: the transport does not know (vcan).
	 */
	uint32_t bitrate;
};

struct rmd_bus;

struct rmd_bus_ops {
	const char *kind; /* "socketcan", "rs485", "sim": for messages only */
	/* Queue up to n frames; returns how many were taken (0..n) or -errno. */
	int (*send)(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		    int64_t now_ns);
	/* Store up to max frames that have arrived by now_ns; returns the count or -errno. */
	int (*recv)(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns);
	/* Descriptor that becomes readable when frames arrive, or -1. */
	int (*fd)(const struct rmd_bus *bus);
	/*
	 * When send() or recv() must run again for the transport's own queue
	 * to advance without a frame arriving (RS485: the deadline of the
	 * request in flight, 0 for a write to retry); INT64_MAX when it has
	 * nothing queued, and always for CAN and sim.  Rt-safe.
	 */
	int64_t (*next_due_ns)(const struct rmd_bus *bus);
	/*
	 * Optional: the state and counters, for a bus that wraps another (a
	 * decorator forwards to the bus it wraps).  NULL: the bus's own
	 * state and stats fields, which the backend keeps.
	 */
	enum rmd_bus_state (*state)(const struct rmd_bus *bus);
	const struct rmd_bus_stats *(*stats)(const struct rmd_bus *bus);
	/*
	 * Optional: drop every frame the transport still holds for the wire
	 * (its own queue, the controller's buffers), so that none of them
	 * goes out later.  What a caller does when nobody acknowledges
	 * (RMD_BUS_NO_ACK): the frames it wrote meanwhile must not reach the
	 * motors when their power returns.  Returns 0 or -errno (-EPERM: the
	 * transport may not, as SocketCAN without CAP_NET_ADMIN).  NULL: the
	 * transport cannot (rmd_bus_flush() says -EOPNOTSUPP).  May block
	 * for as long as the transport takes (SocketCAN restarts the
	 * interface: milliseconds); rare by contract (once per episode).
	 */
	int (*flush)(struct rmd_bus *bus);
	void (*close)(struct rmd_bus *bus);
};

struct rmd_bus {
	const struct rmd_bus_ops *ops;
	char name[32];		  /* "can0", "/dev/ttyUSB0", "sim0": for messages */
	struct rmd_bus_caps caps; /* filled by open; read with rmd_bus_caps() */
	/* Written by the backend; read with rmd_bus_state() and rmd_bus_stats(). */
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

/* See rmd_bus_ops.next_due_ns.  Rt-safe. */
static inline int64_t rmd_bus_next_due_ns(const struct rmd_bus *bus)
{
	return bus->ops->next_due_ns(bus);
}

/* What the transport is (see struct rmd_bus_caps).  Rt-safe. */
static inline const struct rmd_bus_caps *rmd_bus_caps(const struct rmd_bus *bus)
{
	return &bus->caps;
}

/* The bus's state (error-active ... bus-off).  Rt-safe. */
static inline enum rmd_bus_state rmd_bus_state(const struct rmd_bus *bus)
{
	return bus->ops->state ? bus->ops->state(bus) : bus->state;
}

/* The bus's counters.  Rt-safe. */
static inline const struct rmd_bus_stats *rmd_bus_stats(const struct rmd_bus *bus)
{
	return bus->ops->stats ? bus->ops->stats(bus) : &bus->stats;
}

/* See rmd_bus_ops.flush: 0, -errno, or -EOPNOTSUPP when the transport has no flush. */
static inline int rmd_bus_flush(struct rmd_bus *bus)
{
	return bus->ops->flush ? bus->ops->flush(bus) : -EOPNOTSUPP;
}

/* Close the transport; NULL and an unopened bus are no-ops. */
static inline void rmd_bus_close(struct rmd_bus *bus)
{
	if (bus && bus->ops)
		bus->ops->close(bus);
}

const char *rmd_bus_state_name(enum rmd_bus_state state);

/* next_due_ns of a transport without a queue of its own (CAN, sim): INT64_MAX.  Rt-safe. */
int64_t rmd_bus_never_due_ns(const struct rmd_bus *bus);

/*
 * A transport's ops table (src/bus/bus_*.c): its functions are PREFIX_send,
 * PREFIX_recv, PREFIX_fd and PREFIX_close, its kind "PREFIX"; its state and
 * stats are the bus's own fields.
 */
#define RMD_BUS_OPS(prefix, next_due_ns_)                                                         \
	{                                                                                         \
		.kind = #prefix, .send = prefix##_send, .recv = prefix##_recv, .fd = prefix##_fd, \
		.next_due_ns = (next_due_ns_), .close = prefix##_close,                           \
	}

/* The same with a flush, PREFIX_flush (rmd_bus_ops.flush). */
#define RMD_BUS_OPS_FLUSH(prefix, next_due_ns_)                                                   \
	{                                                                                         \
		.kind = #prefix, .send = prefix##_send, .recv = prefix##_recv, .fd = prefix##_fd, \
		.next_due_ns = (next_due_ns_), .flush = prefix##_flush, .close = prefix##_close,  \
	}

/*
 * A decorator: a bus that hands frames on to another and may look at or
 * change them on the way (rmdctl --trace, tests).  Its priv is a struct
 * rmd_bus_wrap; RMD_BUS_WRAP_OPS() gives it ops that forward fd,
 * next_due_ns, state, stats and flush to the wrapped bus, and a close that
 * leaves the wrapped bus to its owner.  send_/recv_ may be
 * rmd_bus_wrap_send/recv.
 */
struct rmd_bus_wrap {
	struct rmd_bus *inner; /* the bus it forwards to */
	void *ctx;	       /* the decorator's own state */
};

#define RMD_BUS_WRAP_OPS(kind_, send_, recv_)                                             \
	{                                                                                 \
		.kind = (kind_), .send = (send_), .recv = (recv_), .fd = rmd_bus_wrap_fd, \
		.next_due_ns = rmd_bus_wrap_next_due_ns, .state = rmd_bus_wrap_state,     \
		.stats = rmd_bus_wrap_stats, .flush = rmd_bus_wrap_flush,                 \
		.close = rmd_bus_wrap_close,                                              \
	}

/* Make `bus` the decorator `ops` over w->inner: its name and caps, priv = w. */
void rmd_bus_wrap_init(struct rmd_bus *bus, const struct rmd_bus_ops *ops, struct rmd_bus_wrap *w);

/* The forwarding ops (rt-safe). */
int rmd_bus_wrap_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		      int64_t now_ns);
int rmd_bus_wrap_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns);
int rmd_bus_wrap_fd(const struct rmd_bus *bus);
int64_t rmd_bus_wrap_next_due_ns(const struct rmd_bus *bus);
enum rmd_bus_state rmd_bus_wrap_state(const struct rmd_bus *bus);
const struct rmd_bus_stats *rmd_bus_wrap_stats(const struct rmd_bus *bus);
int rmd_bus_wrap_flush(struct rmd_bus *bus);
void rmd_bus_wrap_close(struct rmd_bus *bus);

#endif /* RMD_BUS_H */
