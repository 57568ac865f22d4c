/* SPDX-License-Identifier: MIT */
/*
 * The RS485 transport (docs/design.md, layer bus): one serial line of V3 motors
 * behind struct rmd_bus_ops, framed as V3 §1.2.2 (rmd/rs485.h).
 *
 * libmodbus opens and configures the port (RTU context: 8N1 raw termios,
 * the kernel's RS485 mode where the driver has one); the frames themselves
 * are read and written non-blocking on its descriptor, never through
 * libmodbus's request functions, which speak Modbus and block in select().
 *
 * Identifiers.  The layers above see the same identifiers as on CAN:
 *   send  0x140 + ID (ID 1..32)  ->  RS485 id ID                 (V3 §1.2.2)
 *   send  0x280                  ->  RS485 id 0xCD, every motor  (V3 §3, §6)
 *   send  0x300 (0x79 set ID)    ->  RS485 id 0xCD               (V3 §4, §7)
 *   recv  RS485 id ID (1..32)    ->  0x240 + ID                  (V3 §1.1.2)
 *   recv  RS485 id 0xCD          ->  0x300: only the 0x79 reply comes from
 *                                    0xCD (V3 §7.3), as it comes on 0x300 on
 *                                    CAN (V3 §4.3)
 * Every other identifier (MIT 0x400 + ID has no RS485 form) and any length
 * but 8 (V3 §1.2.2) is refused.  V2 motors have no RS485 interface.
 *
 * Half duplex.  The line is one shared pair of wires: send() queues frames
 * and the transport writes the next request only when the previous one was
 * answered or its reply timeout expired.  A unicast request is answered by
 * the first frame from its id whose command byte (D0) is the request's; a
 * broadcast (0xCD) request by opts.broadcast_replies such frames from any
 * id, or ends at its own timeout.  Every valid frame is returned by recv(),
 * answer or not (unsolicited 0x9A reports, late replies); the caller
 * matches replies to motors by identifier and command byte, as on CAN.
 *
 * Nothing blocks or sleeps: the queue advances inside send() and recv(),
 * at their now_ns; timeouts are judged only in recv(), after it has read
 * what arrived, so a caller that sends and never receives stalls the
 * queue rather than losing answers.  Between calls a caller waits on fd()
 * for replies and until rmd_bus_next_due_ns() for timeouts.  bus->caps:
 * half_duplex, reply_timeout_ns and request_spacing_ns both the reply
 * timeout.
 *
 * Receive time.  Every received frame's t_ns is the now_ns of the recv()
 * call that read it (a tty has no receive stamp), so it is late by up to
 * the caller's polling interval.
 *
 * Device role (opts.device: the motors' side, for a simulator of them,
 * rmd-sim).  The same port set-up, framing, resynchronisation and noise
 * counting, with the identifiers seen from the other end:
 *   recv  RS485 id ID (1..32)    ->  0x140 + ID
 *   recv  RS485 id 0xCD          ->  0x300 when D0 is 0x79 (V3 §7), else 0x280
 *   send  0x240 + ID or 0x140 + ID  ->  RS485 id ID
 *   send  0x300                  ->  RS485 id 0xCD (V3 §7.3); the read's
 *                                    reply carries the ID itself where CAN
 *                                    carries 0x240 + ID (V3 §7.4 example 2
 *                                    answers "0x0002"): rmd_rs485_from_can()
 * Replies have no queue to wait in: send() appends them to an output
 * buffer (RMD_RS485_DEVICE_TXBUF bytes) and writes what the tty takes;
 * while bytes wait, next_due_ns() is the time of the write the tty refused
 * and the caller calls send() again (with no frames: n 0) when fd() turns
 * writable.  A frame whose len is below 8 goes out as it is, its length
 * byte saying len and the CRC after its len bytes: the simulator's BAD_DLC
 * fault.
 * With opts.local_echo, a frame equal to one sent in the last
 * RMD_RS485_ECHO_EXPIRY_NS is its echo: dropped once, in order, and counted
 * in stats.echoes.  bus->caps: all 0 (no queue, no timeout).
 */
#ifndef RMD_BUS_RS485_H
#define RMD_BUS_RS485_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/rs485.h"

/* Requests one bus queues; send() takes what fits and counts the rest in stats.tx_busy. */
#define RMD_RS485_QUEUE 64

/* One frame on the wire, 8N1 (10 bits a byte: start, 8 data, stop). */
#define RMD_RS485_FRAME_BITS (RMD_RS485_FRAME_LEN * 10u)

/* Fixed part of the default reply timeout (a motor answers within 0.5-0.8 ms, docs/design.md). */
#define RMD_RS485_TURNAROUND_NS 2000000
/*
 * The latency timer a USB converter's (FTDI) is set to at open, in ms:
 * the chip holds received bytes until it expires (16 ms by default).
 */
#define RMD_RS485_LATENCY_TIMER_MS 1

/* Device role: bytes of replies not yet written. */
#define RMD_RS485_DEVICE_TXBUF 16384
/* Device role, local echo: frames sent whose echo may still come, and for how long. */
#define RMD_RS485_ECHO_RING 64
#define RMD_RS485_ECHO_EXPIRY_NS 500000000

struct rmd_rs485_opts {
	/* V3 §1.2.1: 115200, 500000, 1000000, 1500000 or 2000000 bit/s. */
	uint32_t baud;
	/*
	 * Time from our write() of a request to the end of its answer.  0:
	 * rmd_rs485_reply_timeout_ns(baud, 0): RMD_RS485_TURNAROUND_NS plus
	 * the wire time of the request and of the reply at this baud (4.26 ms
	 * at 115200, 2.26 ms at 1000000).
	 */
	int64_t reply_timeout_ns;
	/*
	 * Replies a broadcast request waits for before the next request goes
	 * out: the number of motors on the line.  0: unknown, every broadcast
	 * lasts its whole timeout.
	 */
	unsigned broadcast_replies;
	/*
	 * Timeout of a broadcast request.  0: reply_timeout_ns plus one reply's
	 * wire time per expected reply (RMD_MAX_MOTORS when broadcast_replies
	 * is 0), since the motors answer one after the other.
	 */
	int64_t broadcast_timeout_ns;
	/*
	 * The adapter hears its own transmission (a two-wire transceiver whose
	 * receiver stays enabled): the first frame equal to the request in
	 * flight is that echo, dropped and counted in stats.echoes (device
	 * role: see the top of this file).  Leave it off otherwise: several
	 * replies (0x80, 0xB3, 0x79 write) are byte for byte the request.
	 */
	bool local_echo;
	/*
	 * The motors' side of the line (see the top of this file): of the
	 * fields above only baud and local_echo are read.
	 */
	bool device;
	/* Where sysfs is (the converter's latency_timer); NULL: "/sys".  For tests. */
	const char *sysfs_root;
};

/* Counters of this transport beyond struct rmd_bus_stats. */
struct rmd_rs485_stats {
	uint64_t reply_timeouts;   /* requests whose answer did not come in time */
	uint64_t broadcasts_short; /* broadcasts that ended with fewer than broadcast_replies */
	uint64_t dropped_bytes;	   /* stats.rx_noise_bytes: skipped while resynchronising */
	uint64_t echoes;	   /* stats.echoes: own frames heard back, with opts.local_echo */
	uint64_t pending;	   /* requests queued or in flight now (a gauge) */
};

/*
 * Open serial device `device` (e.g. "/dev/ttyUSB0") as `bus` (caller
 * allocates; zeroed by close) and configure it: opts->baud 8N1 raw, and the
 * kernel's RS485 mode, in which the driver drives RTS (the transceiver's
 * direction) around each of our writes.  libmodbus's own RTS switching
 * only runs inside its Modbus send path, which this transport bypasses, so
 * a port without kernel RS485 mode must switch direction by itself, as
 * USB RS485 adapters do.  The port is opened exclusively (TIOCEXCL).
 *
 * Returns 0, with err holding "" or a one-line notice for the caller to
 * log (no kernel RS485 mode: a pseudo-terminal, or an adapter that must
 * switch direction itself).  Otherwise returns -errno with a one-line
 * message in err that names the device and what to do:
 *   -EINVAL   opts NULL, a baud V3 §1.2.1 does not list, a negative timeout
 *   -ENOENT   no such device
 *   -EACCES   permission denied (group dialout)
 *   -EBUSY    the port is held by another program
 *   -ENOTTY   not a serial port
 * Non-rt: allocates.
 */
int rmd_rs485_open(struct rmd_bus *bus, const char *device, const struct rmd_rs485_opts *opts,
		   char *err, size_t errlen);

/* Wire time of one 13-byte frame at `baud`, 8N1 (10 bits a byte), rounded up. Pure. */
int64_t rmd_rs485_frame_ns(uint32_t baud);

/*
 * The reply timeout of a line whose turnaround (request end to reply
 * start, the bus's turnaround_us) is turnaround_ns: twice that, at least
 * RMD_RS485_TURNAROUND_NS, plus the request's and the reply's wire time.
 * A converter that holds answers back (a 16 ms latency timer) needs a
 * turnaround_us that includes it, or every request times out and the next
 * goes out while a motor answers; `rmdctl rtt` measures it.  Pure.
 */
int64_t rmd_rs485_reply_timeout_ns(uint32_t baud, int64_t turnaround_ns);

/*
 * Frame f, in the CAN identifiers the layers above speak, as an RS485 line
 * carries it in direction request (host to motor) or reply: returns its
 * RS485 id (rmd_rs485_id_of_can()), or -EINVAL when it has none, and puts
 * the frame as sent in *out (f may be out).  The data are f's, but for the
 * reply to the read of V3 §7.4 (0x79 on 0x300, D2 = 1), whose value, the
 * motor's CAN reply identifier 0x240 + ID, goes out as ID.  The device
 * role sends every reply so; rmd-sim logs what it wrote by it.  Pure.
 */
int rmd_rs485_from_can(const struct rmd_frame *f, bool request, struct rmd_frame *out);

/*
 * Copy this transport's own counters.  Returns 0, or -EINVAL when bus is
 * not an RS485 bus.  Rt-safe.
 */
int rmd_rs485_stats(const struct rmd_bus *bus, struct rmd_rs485_stats *out);

#endif /* RMD_BUS_RS485_H */
