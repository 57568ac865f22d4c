/* SPDX-License-Identifier: MIT */
/*
 * The SocketCAN transport (docs/design.md, layer bus): one raw CAN socket per
 * interface behind struct rmd_bus_ops.
 *
 * The socket is non-blocking and admits, through a kernel filter, only the
 * reply identifiers of the configured motors and the error frames that
 * describe the controller's state; every other frame on the bus is dropped
 * in the kernel, before it costs the rt loop anything.  Frames we send are
 * not looped back to us (CAN_RAW_RECV_OWN_MSGS off), but other programs on
 * the machine (candump) still see them (CAN_RAW_LOOPBACK on).
 *
 * send() writes a batch with one sendmmsg(2); what the queue refuses
 * (ENOBUFS: txqueuelen full; EAGAIN: socket send buffer full) is counted in
 * stats.tx_busy and left to the caller for the next cycle.  recv() drains
 * the socket with recvmmsg(2) and stamps each frame with the kernel's
 * receive time, converted to CLOCK_MONOTONIC.  Error frames are never
 * returned: they move bus->state and count in stats.
 *
 * No acknowledgement (RMD_BUS_NO_ACK; docs/faults.md "E-stop").  With its
 * motors unpowered no node acknowledges: the controller tries its frame
 * again and again and stays error-passive (ISO 11898-1: an ACK error of an
 * error-passive transmitter does not raise its counter, so it never goes
 * bus-off), the kernel keeps what is queued behind it, and all of it goes
 * out when power returns.  The bus says so when its error frames or sends
 * show it: RMD_SOCKETCAN_NO_ACK_ERRORS ACK errors (CAN_ERR_ACK, which
 * needs `berr-reporting on`) with no frame received in between, or one
 * while the transmitter is error-passive (CAN_ERR_CRTL_TX_PASSIVE, which
 * drivers report without berr-reporting), or a send refused (ENOBUFS,
 * EAGAIN) while it is.  It ends when a data frame arrives (a powered node
 * talks, so it acknowledges) or the transmitter leaves error-passive (one
 * of its frames was acknowledged).  Frames we send are not looped back to
 * us: the transport cannot see which of its own frames left.
 * flush (rmd_bus_flush()) restarts the interface (SIOCSIFFLAGS down,
 * then up): going down resets the queue (net/sched/sch_generic.c
 * dev_deactivate_many(): qdisc_reset), and the driver's close stops the
 * controller and frees the frames it held (drivers/net/can/dev
 * close_candev(): can_flush_echo_skb()).  It needs CAP_NET_ADMIN (-EPERM
 * without) and blocks for the interface's restart.
 */
#ifndef RMD_BUS_SOCKETCAN_H
#define RMD_BUS_SOCKETCAN_H

#include <stdbool.h>
#include <stddef.h>

#include "rmd/bus.h"
#include "rmd/codec.h"

/* Most frames one send() or one recvmmsg(2) call moves. */
#define RMD_SOCKETCAN_BATCH 64

/*
 * Default receive buffer.  A CAN frame costs the socket about 1 KiB of
 * buffer (sk_buff overhead), so 1 MiB holds ~1000 frames: 125 ms of a
 * saturated 1 Mbit/s bus, far more than the rt loop may ever fall behind.
 */
#define RMD_SOCKETCAN_RCVBUF_DEFAULT (1 << 20)

/* A motor whose replies the socket admits. */
struct rmd_socketcan_motor {
	uint8_t id;	      /* 1..32 */
	enum rmd_proto proto; /* V3: 0x240 + ID; V2: 0x140 + ID; MIT: 0x500 + ID and 0x240 + ID */
	bool any_dialect;     /* the replies of every dialect (`protocol: auto`) */
};

struct rmd_socketcan_opts {
	const struct rmd_socketcan_motor *motors;
	unsigned n_motors;
	/*
	 * Bit id - 1: that motor is driven in MIT mode (V3 §5, V4.2 §5), its
	 * MIT replies on 0x500 + ID are admitted too
	 */
	uint32_t mit_ids;
	bool set_id_replies; /* also admit 0x300 (V3 §4: 0x79 replies on 0x300) */
	/*
	 * Also admit the replies of every ID that a V2 0x280 frame would
	 * command (rmd_dialect_takes_280()), the motors' own or not: a bus
	 * whose V2 motors share that frame must see a motor it does not drive
	 * (issue 33 point 2).  Nothing more is received while none answers.
	 */
	bool watch_strays;
	/*
	 * Most frames the caller sends on this bus in one cycle.  The
	 * interface's txqueuelen must hold them or the tail of every burst
	 * is refused; 0 skips the check.
	 */
	unsigned burst;
	int rcvbuf_bytes; /* SO_RCVBUF request; 0: RMD_SOCKETCAN_RCVBUF_DEFAULT */
	/*
	 * The motors' side of the wire (rmd-sim): admit the requests to every
	 * id (0x140 + ID, 0x280, 0x300, MIT 0x400 + ID; motors is not read)
	 * instead of replies, and open an interface that is down (bus->state
	 * RMD_BUS_OFF: frames are refused with -ENETDOWN until it is up).
	 */
	bool device;
};

/*
 * Open CAN interface `ifname` as `bus` (caller allocates; zeroed by
 * close).  Checks that the interface exists, is a CAN interface, is up and
 * that its txqueuelen holds opts->burst frames; otherwise returns -errno
 * and stores in err a one-line message that names the command fixing it:
 *   -EAFNOSUPPORT / -EPROTONOSUPPORT  the kernel has no SocketCAN (CAN_RAW)
 *   -ENODEV       no such interface, or not a CAN interface
 *   -ENETDOWN     interface down
 *   -ENOBUFS      txqueuelen below opts->burst
 *   -EINVAL       bad name or motor list
 * opts NULL admits every standard data frame (a sniffer) and skips the
 * txqueuelen check.  An interface that is up without carrier (a controller
 * left bus-off with no restart-ms) opens with bus->state RMD_BUS_OFF.
 * Non-rt: allocates.
 */
int rmd_socketcan_open(struct rmd_bus *bus, const char *ifname,
		       const struct rmd_socketcan_opts *opts, char *err, size_t errlen);

/*
 * The receive buffer the kernel granted, in bytes (it may cap the request),
 * or -EINVAL when bus is not a SocketCAN bus.  Non-rt.
 */
int rmd_socketcan_rcvbuf(const struct rmd_bus *bus);

struct can_frame;

/*
 * ACK errors in a row, with no frame received between them, that make a
 * bus RMD_BUS_NO_ACK: what takes an error-active transmitter to
 * error-passive (ISO 11898-1: 8 a transmit error, passive at 128).
 */
#define RMD_SOCKETCAN_NO_ACK_ERRORS 16

/* What a bus's error frames and sends told (rmd_socketcan_error_frame()). */
struct rmd_socketcan_errs {
	enum rmd_bus_state ctrl; /* the controller's: RMD_BUS_ACTIVE .. RMD_BUS_OFF */
	bool tx_passive;	 /* its transmitter is error-passive */
	unsigned ack_errors;	 /* ACK errors since the last frame received */
	bool no_ack;		 /* nobody acknowledges (above) */
};

/*
 * Apply one error frame (CAN_ERR_FLAG set) to *e, bus->state (bus-off,
 * else no-ack, else the controller's state) and bus->stats: every error
 * frame counts in stats.bus_errors, every change of state in
 * stats.state_changes.  Exposed for tests, which cannot make vcan go
 * bus-off or miss an acknowledgement.  Rt-safe.
 */
void rmd_socketcan_error_frame(struct rmd_bus *bus, struct rmd_socketcan_errs *e,
			       const struct can_frame *cf);

#endif /* RMD_BUS_SOCKETCAN_H */
