// SPDX-License-Identifier: MIT
/*
 * The RS485 transport: libmodbus opens and configures the serial port, and
 * V3 §1.2.2 frames go over its descriptor with non-blocking read(2) and
 * write(2), one request on the wire at a time.
 */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <modbus.h>

#include "rmd/time.h"
#include "rmd/bus_rs485.h"
#include "rmd/rs485.h"

_Static_assert((RMD_RS485_QUEUE & (RMD_RS485_QUEUE - 1)) == 0, "queue is a power-of-two ring");

#define WIRE_DATA 3 /* V3 §1.2.2: header, id, length, then D0..D7 */
#define RX_BUF 256  /* bytes read and not yet parsed */
#define READS_PER_CALL 16
/* Linux devices.txt: UNIX98 pseudo-terminal slaves. */
#define PTY_SLAVE_MAJOR_FIRST 136
#define PTY_SLAVE_MAJOR_LAST 143

struct request {
	uint8_t wire[RMD_RS485_FRAME_LEN];
	uint8_t id; /* RS485 id: 1..32 or 0xCD */
};

enum head_state {
	HEAD_IDLE = 0, /* queue head not started */
	HEAD_WRITING,  /* part of it written, the tty took no more */
	HEAD_WAITING,  /* written, waiting for its answer */
};

struct rs485 {
	modbus_t *ctx;
	int fd;
	int64_t reply_timeout_ns;
	int64_t broadcast_timeout_ns;
	unsigned broadcast_replies;
	bool local_echo;

	/* Requests in order; q[head] is the one on the wire. Free-running indexes. */
	struct request q[RMD_RS485_QUEUE];
	unsigned head, tail;
	enum head_state state;
	unsigned tx_off;  /* bytes of q[head] written */
	int64_t due_ns;	  /* HEAD_WAITING: deadline; HEAD_WRITING: retry */
	unsigned answers; /* broadcast: matching replies so far */
	bool echo_seen;	  /* opts.local_echo: the head's echo came back */
	bool out_of_sync; /* dropping bytes since the last good frame */
	size_t rx_len;
	uint8_t rx[RX_BUF];
	struct rmd_rs485_stats xs;
};

static const struct rmd_bus_ops rs485_ops;

static struct rs485 *priv(const struct rmd_bus *bus)
{
	return bus->priv;
}

int64_t rmd_rs485_frame_ns(uint32_t baud)
{
	const int64_t bits = RMD_RS485_FRAME_BITS;

	if (baud == 0)
		return 0;
	return (bits * RMD_NS_PER_S + baud - 1) / baud;
}

static bool is_pty(int fd, const char *device)
{
	struct stat st;

	if (strncmp(device, "/dev/pts/", 9) == 0)
		return true;
	return fstat(fd, &st) == 0 && S_ISCHR(st.st_mode) &&
	       major(st.st_rdev) >= PTY_SLAVE_MAJOR_FIRST &&
	       major(st.st_rdev) <= PTY_SLAVE_MAJOR_LAST;
}

/* One line that names the device, what went wrong and what to do. */
static void open_error(char *err, size_t errlen, const char *device, int e)
{
	switch (e) {
	case ENOENT:
	case ENODEV:
	case ENXIO:
		snprintf(err, errlen,
			 "%s: no such device: check the adapter is plugged in and the path "
			 "(ls /dev/ttyUSB* /dev/serial/by-id/)",
			 device);
		break;
	case EACCES:
	case EPERM:
		snprintf(err, errlen, "%s: permission denied: add the user to group dialout",
			 device);
		break;
	case EBUSY:
		snprintf(err, errlen,
			 "%s: busy: another program holds the port (fuser -v %s), stop it", device,
			 device);
		break;
	case ENOTTY:
		snprintf(err, errlen, "%s: not a serial port", device);
		break;
	default:
		snprintf(err, errlen, "%s: cannot open: %s", device, strerror(e));
		break;
	}
}

/*
 * libmodbus 3.1.6 maps baud rates it does not list, 2000000 among them, to
 * 9600 without a word: check what the port got and set it ourselves.
 */
static int check_speed(int fd, speed_t speed)
{
	struct termios tios;

	if (tcgetattr(fd, &tios) < 0)
		return -errno;
	if (cfgetospeed(&tios) == speed && cfgetispeed(&tios) == speed)
		return 0;
	if (cfsetispeed(&tios, speed) < 0 || cfsetospeed(&tios, speed) < 0)
		return -errno;
	if (tcsetattr(fd, TCSANOW, &tios) < 0)
		return -errno;
	if (tcgetattr(fd, &tios) < 0)
		return -errno;
	if (cfgetospeed(&tios) != speed || cfgetispeed(&tios) != speed)
		return -EINVAL;
	return 0;
}

int rmd_rs485_open(struct rmd_bus *bus, const char *device, const struct rmd_rs485_opts *opts,
		   char *err, size_t errlen)
{
	struct rs485 *p;
	speed_t speed;
	int64_t frame_ns;
	unsigned expect;
	int r;

	if (errlen)
		err[0] = '\0';
	if (!device || !device[0]) {
		snprintf(err, errlen, "rs485: no device given");
		return -EINVAL;
	}
	if (!opts) {
		snprintf(err, errlen, "%s: no RS485 options given", device);
		return -EINVAL;
	}
	if (rmd_rs485_baud_speed(opts->baud, &speed) < 0) {
		snprintf(
			err, errlen,
			"%s: baud %u is not an RMD RS485 rate (V3 §1.2.1): use " RMD_RS485_BAUD_LIST,
			device, opts->baud);
		return -EINVAL;
	}
	if (opts->reply_timeout_ns < 0 || opts->broadcast_timeout_ns < 0) {
		snprintf(err, errlen, "%s: negative reply timeout", device);
		return -EINVAL;
	}

	p = calloc(1, sizeof(*p));
	if (!p) {
		snprintf(err, errlen, "%s: out of memory", device);
		return -ENOMEM;
	}
	p->fd = -1;
	frame_ns = rmd_rs485_frame_ns(opts->baud);
	p->reply_timeout_ns = opts->reply_timeout_ns;
	if (!p->reply_timeout_ns)
		p->reply_timeout_ns = RMD_RS485_TURNAROUND_NS + 2 * frame_ns;
	p->broadcast_replies = opts->broadcast_replies;
	expect = p->broadcast_replies ? p->broadcast_replies : RMD_MAX_MOTORS;
	p->broadcast_timeout_ns = opts->broadcast_timeout_ns;
	if (!p->broadcast_timeout_ns)
		p->broadcast_timeout_ns = p->reply_timeout_ns + (int64_t)expect * frame_ns;
	p->local_echo = opts->local_echo;

	p->ctx = modbus_new_rtu(device, (int)opts->baud, 'N', 8, 1);
	if (!p->ctx) {
		r = -errno;
		snprintf(err, errlen, "%s: cannot create the serial context: %s", device,
			 strerror(errno));
		goto err_free_priv;
	}
	if (modbus_connect(p->ctx) < 0) {
		r = -errno;
		open_error(err, errlen, device, errno);
		goto err_free_ctx;
	}
	p->fd = modbus_get_socket(p->ctx);

	/* Like minicom: a second program writing on the line corrupts every frame. */
	if (ioctl(p->fd, TIOCEXCL) < 0) {
		r = -errno;
		open_error(err, errlen, device, errno);
		goto err_close_ctx;
	}
	r = check_speed(p->fd, speed);
	if (r < 0) {
		snprintf(err, errlen, "%s: the driver refuses %u baud: %s", device, opts->baud,
			 strerror(-r));
		goto err_close_ctx;
	}

	if (modbus_rtu_set_serial_mode(p->ctx, MODBUS_RTU_RS485) < 0) {
		if (errno != ENOTTY && errno != ENOTSUP) {
			r = -errno;
			snprintf(err, errlen, "%s: cannot enable RS485 mode: %s", device,
				 strerror(errno));
			goto err_close_ctx;
		}
		if (is_pty(p->fd, device))
			snprintf(err, errlen,
				 "%s: pseudo-terminal: no RS485 mode or RTS direction control",
				 device);
		else
			snprintf(err, errlen,
				 "%s: no kernel RS485 mode: the adapter must switch direction "
				 "by itself (USB RS485 adapters do)",
				 device);
	}
	/* Whatever arrived before we were listening is no answer of ours. */
	tcflush(p->fd, TCIOFLUSH);

	bus->ops = &rs485_ops;
	snprintf(bus->name, sizeof(bus->name), "%s", device);
	/* Half duplex: each request waits for the previous answer or its timeout. */
	bus->caps = (struct rmd_bus_caps){
		.half_duplex = true,
		.reply_timeout_ns = p->reply_timeout_ns,
		.request_spacing_ns = p->reply_timeout_ns,
		.queue_len = RMD_RS485_QUEUE,
	};
	bus->state = RMD_BUS_ACTIVE;
	memset(&bus->stats, 0, sizeof(bus->stats));
	bus->priv = p;
	return 0;

err_close_ctx:
	modbus_close(p->ctx);
err_free_ctx:
	modbus_free(p->ctx);
err_free_priv:
	free(p);
	return r;
}

/* The RS485 id a request maps to (see rmd/rs485.h), or -EINVAL. */
static int tx_id(const struct rmd_frame *f)
{
	if (f->len != RMD_FRAME_LEN)
		return -EINVAL;
	return rmd_rs485_id_of_can(f->can_id, true);
}

static unsigned queued(const struct rs485 *p)
{
	return p->tail - p->head;
}

static void pop_head(struct rs485 *p)
{
	p->head++;
	p->state = HEAD_IDLE;
}

/*
 * Move the queue on at now_ns: end a request whose time is up (only when
 * `expire`: after reading what has arrived, lest an answer that waits
 * unread in the tty count as missing), and start or continue writing the
 * next.  Returns 0 or -errno of write(2).
 */
static int pump(struct rmd_bus *bus, int64_t now_ns, bool expire)
{
	struct rs485 *p = priv(bus);
	const struct request *rq;
	ssize_t w;

	if (p->state == HEAD_WAITING) {
		if (!expire || now_ns < p->due_ns)
			return 0;
		if (p->q[p->head % RMD_RS485_QUEUE].id != RMD_RS485_BROADCAST)
			p->xs.reply_timeouts++;
		else if (p->broadcast_replies)
			p->xs.broadcasts_short++;
		pop_head(p);
	}
	if (p->state == HEAD_IDLE) {
		if (!queued(p))
			return 0;
		p->state = HEAD_WRITING;
		p->tx_off = 0;
		p->answers = 0;
		p->echo_seen = false;
	}

	rq = &p->q[p->head % RMD_RS485_QUEUE];
	w = write(p->fd, rq->wire + p->tx_off, RMD_RS485_FRAME_LEN - p->tx_off);
	if (w < 0) {
		if (errno != EAGAIN && errno != EINTR)
			return -errno;
		w = 0;
	}
	p->tx_off += (unsigned)w;
	if (p->tx_off < RMD_RS485_FRAME_LEN) {
		p->due_ns = now_ns; /* retry at the next call */
		return 0;
	}
	bus->stats.tx_frames++;
	p->state = HEAD_WAITING;
	p->due_ns = now_ns +
		    (rq->id == RMD_RS485_BROADCAST ? p->broadcast_timeout_ns : p->reply_timeout_ns);
	return 0;
}

/* Rt-safe. */
static int rs485_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		      int64_t now_ns)
{
	struct rs485 *p = priv(bus);
	unsigned taken = 0;
	int r;

	/* All or nothing for bad frames: a short count would have the caller retry them. */
	for (unsigned i = 0; i < n; i++)
		if (tx_id(&frames[i]) < 0)
			return -EINVAL;

	while (taken < n && queued(p) < RMD_RS485_QUEUE) {
		struct request *rq = &p->q[p->tail % RMD_RS485_QUEUE];

		rq->id = (uint8_t)tx_id(&frames[taken]);
		rmd_rs485_build(rq->id, frames[taken].data, rq->wire, sizeof(rq->wire));
		p->tail++;
		taken++;
	}
	bus->stats.tx_busy += n - taken;

	/* A failing write stays at the head of the queue and fails again next call. */
	r = pump(bus, now_ns, false);
	if (r < 0 && taken == 0)
		return r;
	return (int)taken;
}

/*
 * A good frame from the line: does it answer the request in flight?  Returns
 * false for the echo of our own request, which is not passed on.
 */
static bool rx_frame(struct rs485 *p, uint8_t id, const uint8_t data[RMD_FRAME_LEN])
{
	const struct request *rq = &p->q[p->head % RMD_RS485_QUEUE];
	const uint8_t *rq_data = rq->wire + WIRE_DATA;

	if (p->state != HEAD_WAITING)
		return true;
	if (p->local_echo && !p->echo_seen && id == rq->id &&
	    memcmp(data, rq_data, RMD_FRAME_LEN) == 0) {
		p->echo_seen = true;
		p->xs.echoes++;
		return false;
	}
	if (data[0] != rq_data[0])
		return true;
	if (rq->id == RMD_RS485_BROADCAST) {
		p->answers++;
		if (p->broadcast_replies && p->answers >= p->broadcast_replies)
			pop_head(p);
	} else if (id == rq->id) {
		pop_head(p);
	}
	return true;
}

static void drop(struct rmd_bus *bus, size_t k)
{
	struct rs485 *p = priv(bus);

	if (!p->out_of_sync)
		bus->stats.rx_errors++;
	p->out_of_sync = true;
	p->xs.dropped_bytes += k;
	p->rx_len -= k;
	memmove(p->rx, p->rx + k, p->rx_len);
}

/*
 * Parse frames out of the receive buffer into out[*n..max).  Returns when
 * out is full or the buffer holds no complete frame.
 */
static void parse(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned *n, unsigned max,
		  int64_t now_ns)
{
	struct rs485 *p = priv(bus);
	uint8_t id, data[RMD_FRAME_LEN];
	int r;

	while (*n < max && p->rx_len > 0) {
		if (p->rx[0] != RMD_RS485_HEADER) {
			const uint8_t *h = memchr(p->rx, RMD_RS485_HEADER, p->rx_len);

			drop(bus, h ? (size_t)(h - p->rx) : p->rx_len);
			continue;
		}
		r = rmd_rs485_parse(p->rx, p->rx_len, &id, data);
		if (r == -EAGAIN)
			return;
		if (r < 0) {
			drop(bus, 1);
			continue;
		}
		p->rx_len -= (size_t)r;
		memmove(p->rx, p->rx + r, p->rx_len);
		p->out_of_sync = false;
		if (!rx_frame(p, id, data))
			continue;

		out[*n].f.can_id = rmd_rs485_can_id(id, false, data[0]);
		out[*n].f.len = RMD_FRAME_LEN;
		memcpy(out[*n].f.data, data, RMD_FRAME_LEN);
		out[*n].t_ns = now_ns;
		bus->stats.rx_frames++;
		(*n)++;
	}
}

/* Rt-safe. */
static int rs485_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	struct rs485 *p = priv(bus);
	unsigned n = 0;
	int r = 0;

	for (int i = 0; i < READS_PER_CALL; i++) {
		ssize_t got;

		parse(bus, out, &n, max, now_ns);
		if (n == max)
			break;
		/* Here the buffer holds less than one frame, so there is room. */
		got = read(p->fd, p->rx + p->rx_len, sizeof(p->rx) - p->rx_len);
		if (got < 0) {
			if (errno != EAGAIN && errno != EINTR)
				r = -errno;
			break;
		}
		if (got == 0) /* a raw tty with VMIN = VTIME = 0 reads 0 when empty */
			break;
		p->rx_len += (size_t)got;
	}
	parse(bus, out, &n, max, now_ns);

	/* With out full, an answer may still wait in the buffer: judge no timeout. */
	if (r == 0)
		r = pump(bus, now_ns, n < max);
	if (r < 0 && n == 0)
		return r;
	return (int)n;
}

static int rs485_fd(const struct rmd_bus *bus)
{
	return priv(bus)->fd;
}

/*
 * The deadline of the request in flight, the time of a write that the tty
 * refused (retry; 0 after a write error), or INT64_MAX when nothing is
 * queued.  Rt-safe.
 */
static int64_t rs485_next_due_ns(const struct rmd_bus *bus)
{
	const struct rs485 *p = priv(bus);

	if (p->state == HEAD_IDLE)
		return queued(p) ? 0 : INT64_MAX; /* 0: a failed write to retry */
	return p->due_ns;
}

/* Non-rt: frees. */
static void rs485_close(struct rmd_bus *bus)
{
	struct rs485 *p = priv(bus);

	if (p) {
		/* Restores the port's settings; pending output still drains. */
		modbus_close(p->ctx);
		modbus_free(p->ctx);
		free(p);
	}
	memset(bus, 0, sizeof(*bus));
}

static const struct rmd_bus_ops rs485_ops = RMD_BUS_OPS(rs485, rs485_next_due_ns);

int rmd_rs485_stats(const struct rmd_bus *bus, struct rmd_rs485_stats *out)
{
	const struct rs485 *p;

	if (!bus || bus->ops != &rs485_ops)
		return -EINVAL;
	p = priv(bus);
	*out = p->xs;
	out->pending = queued(p);
	return 0;
}
