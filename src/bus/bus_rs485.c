// SPDX-License-Identifier: MIT
/*
 * The RS485 transport: libmodbus opens and configures the serial port, and
 * V3 §1.2.2 frames go over its descriptor with non-blocking read(2) and
 * write(2): on the host's side one request on the wire at a time, on the
 * motors' side (device role, rmd-sim) replies as they come.  Opening,
 * framing, resynchronisation and the noise count are the same code for both.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
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

#include <linux/serial.h>
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

/* Device role: a frame we sent, whose echo may come until t_ns + RMD_RS485_ECHO_EXPIRY_NS. */
struct echo {
	uint8_t wire[RMD_RS485_FRAME_LEN];
	int64_t t_ns;
};

/* Device role: replies out, with no queue of requests. */
struct device {
	uint8_t tx[RMD_RS485_DEVICE_TXBUF]; /* bytes not written yet */
	size_t txn;
	int64_t retry_ns; /* txn > 0: the time of the write the tty refused */
	struct echo echo[RMD_RS485_ECHO_RING];
	unsigned echo_head, echo_n;
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
	struct device *dev; /* the device role's state; NULL: the host's side */

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
	struct rmd_rs485_stats xs; /* but dropped_bytes, echoes: in bus->stats */
};

static const struct rmd_bus_ops rs485_ops, rs485_device_ops;
static bool own_echo(struct rmd_bus *bus, const uint8_t *wire, int64_t now_ns);

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

int64_t rmd_rs485_reply_timeout_ns(uint32_t baud, int64_t turnaround_ns)
{
	int64_t t = 2 * turnaround_ns;

	if (t < RMD_RS485_TURNAROUND_NS)
		t = RMD_RS485_TURNAROUND_NS;
	return t + 2 * rmd_rs485_frame_ns(baud);
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

/* Append "; " and a formatted note to err[0..errlen) (a notice for the caller to log). */
__attribute__((format(printf, 3, 4))) static void add_note(char *err, size_t errlen,
							   const char *fmt, ...)
{
	size_t used = strnlen(err, errlen);
	va_list ap;

	if (used + 3 >= errlen)
		return;
	if (used) {
		memcpy(err + used, "; ", 3);
		used += 2;
	}
	va_start(ap, fmt);
	vsnprintf(err + used, errlen - used, fmt, ap);
	va_end(ap);
}

/* A small number from a sysfs file, or -errno. */
static int read_sysfs_uint(const char *path)
{
	char buf[16];
	ssize_t n;
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	long v;
	char *end;

	if (fd < 0)
		return -errno;
	n = read(fd, buf, sizeof(buf) - 1);
	close(fd);
	if (n <= 0)
		return n < 0 ? -errno : -EINVAL;
	buf[n] = '\0';
	v = strtol(buf, &end, 10);
	if (end == buf || v < 0 || v > 1000)
		return -EINVAL;
	return (int)v;
}

/*
 * USB-serial converters hold received bytes back before they pass them to
 * the host: an FTDI chip until its latency timer expires (16 ms by
 * default, docs/troubleshooting.md "Slow answers"), and the tty layer may
 * defer them to a work queue.  Ask the driver for low latency
 * (ASYNC_LOW_LATENCY, what `setserial DEV low_latency` sets) and set an
 * FTDI's latency_timer (sysfs, through the port's device number, so a
 * /dev/serial/by-id/ link works too) to RMD_RS485_LATENCY_TIMER_MS.  A
 * pseudo-terminal or a plain UART has neither (ENOTTY, EINVAL, no such
 * file): nothing to do.  What could not be done, and what to do about it,
 * goes into err as a notice.  Non-rt.
 */
static void set_low_latency(int fd, const char *device, const char *sysfs, char *err, size_t errlen)
{
	struct serial_struct ss;
	struct stat st;
	char path[256];
	int ms, wfd;

	if (ioctl(fd, TIOCGSERIAL, &ss) == 0 && !(ss.flags & ASYNC_LOW_LATENCY)) {
		ss.flags |= ASYNC_LOW_LATENCY;
		if (ioctl(fd, TIOCSSERIAL, &ss) < 0 && errno != ENOTTY && errno != EINVAL)
			add_note(err, errlen,
				 "%s: the driver refuses low-latency mode (%s): answers may wait "
				 "in its buffers; try `setserial %s low_latency` as root",
				 device, strerror(errno), device);
	}

	if (fstat(fd, &st) < 0 || !S_ISCHR(st.st_mode))
		return;
	snprintf(path, sizeof(path), "%s/dev/char/%u:%u/device/latency_timer",
		 sysfs ? sysfs : "/sys", major(st.st_rdev), minor(st.st_rdev));
	ms = read_sysfs_uint(path);
	if (ms <= RMD_RS485_LATENCY_TIMER_MS) /* no such timer, or already short */
		return;
	wfd = open(path, O_WRONLY | O_CLOEXEC);
	if (wfd >= 0) {
		static const char one[] = "1\n";
		ssize_t w = write(wfd, one, sizeof(one) - 1);
		int e = errno;

		close(wfd);
		errno = e;
		if (w == (ssize_t)sizeof(one) - 1 &&
		    read_sysfs_uint(path) == RMD_RS485_LATENCY_TIMER_MS)
			return;
		if (w >= 0)
			errno = EIO;
	}
	add_note(err, errlen,
		 "%s: the converter's latency timer is %d ms and could not be set to %d (%s): "
		 "every answer may come up to %d ms late; as root `echo 1 > %s`, or a udev "
		 "rule ATTR{device/latency_timer}=\"1\" (docs/troubleshooting.md), and "
		 "measure with `rmdctl rtt`",
		 device, ms, RMD_RS485_LATENCY_TIMER_MS, strerror(errno), ms, path);
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
		p->reply_timeout_ns = rmd_rs485_reply_timeout_ns(opts->baud, 0);
	p->broadcast_replies = opts->broadcast_replies;
	expect = p->broadcast_replies ? p->broadcast_replies : RMD_MAX_MOTORS;
	p->broadcast_timeout_ns = opts->broadcast_timeout_ns;
	if (!p->broadcast_timeout_ns)
		p->broadcast_timeout_ns = p->reply_timeout_ns + (int64_t)expect * frame_ns;
	p->local_echo = opts->local_echo;
	if (opts->device) {
		p->dev = calloc(1, sizeof(*p->dev));
		if (!p->dev) {
			r = -ENOMEM;
			snprintf(err, errlen, "%s: out of memory", device);
			goto err_free_priv;
		}
	}

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
	/* The motors' side (rmd-sim) answers on time too: both roles. */
	set_low_latency(p->fd, device, opts->sysfs_root, err, errlen);
	/* Whatever arrived before we were listening is no answer of ours. */
	tcflush(p->fd, TCIOFLUSH);

	bus->ops = p->dev ? &rs485_device_ops : &rs485_ops;
	snprintf(bus->name, sizeof(bus->name), "%s", device);
	/* Half duplex: each request waits for the previous answer or its timeout. */
	if (!p->dev)
		bus->caps = (struct rmd_bus_caps){
			.half_duplex = true,
			.reply_timeout_ns = p->reply_timeout_ns,
			.request_spacing_ns = p->reply_timeout_ns,
			.queue_len = RMD_RS485_QUEUE,
			.bitrate = opts->baud,
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
	free(p->dev);
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
static bool rx_frame(struct rmd_bus *bus, uint8_t id, const uint8_t data[RMD_FRAME_LEN])
{
	struct rs485 *p = priv(bus);
	const struct request *rq = &p->q[p->head % RMD_RS485_QUEUE];
	const uint8_t *rq_data = rq->wire + WIRE_DATA;

	if (p->state != HEAD_WAITING)
		return true;
	if (p->local_echo && !p->echo_seen && id == rq->id &&
	    memcmp(data, rq_data, RMD_FRAME_LEN) == 0) {
		p->echo_seen = true;
		bus->stats.echoes++;
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
	bus->stats.rx_noise_bytes += k;
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
	bool keep;
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
		keep = p->dev ? !own_echo(bus, p->rx, now_ns) : rx_frame(bus, id, data);
		p->rx_len -= (size_t)r;
		memmove(p->rx, p->rx + r, p->rx_len);
		p->out_of_sync = false;
		if (!keep)
			continue;

		/* The host hears replies, the motors' side requests. */
		out[*n].f.can_id = rmd_rs485_can_id(id, p->dev != NULL, data[0]);
		out[*n].f.len = RMD_FRAME_LEN;
		memcpy(out[*n].f.data, data, RMD_FRAME_LEN);
		out[*n].t_ns = now_ns;
		bus->stats.rx_frames++;
		(*n)++;
	}
}

/*
 * Read what has arrived and parse frames out of it into out[0..max): sets
 * *count and returns 0, or -errno of read(2).  Both roles.  Rt-safe.
 */
static int read_frames(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned *count, unsigned max,
		       int64_t now_ns)
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
	*count = n;
	return r;
}

/* Rt-safe. */
static int rs485_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	unsigned n;
	int r = read_frames(bus, out, &n, max, now_ns);

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

/* ---- device role: the motors' side ----------------------------------------------------- */

/*
 * With opts.local_echo: is the frame at wire our own, heard back?  Entries
 * older than RMD_RS485_ECHO_EXPIRY_NS are no echo any more.  Rt-safe.
 */
static bool own_echo(struct rmd_bus *bus, const uint8_t *wire, int64_t now_ns)
{
	struct rs485 *p = priv(bus);
	struct device *d = p->dev;

	if (!p->local_echo)
		return false;
	while (d->echo_n && now_ns - d->echo[d->echo_head].t_ns > RMD_RS485_ECHO_EXPIRY_NS) {
		d->echo_head = (d->echo_head + 1) % RMD_RS485_ECHO_RING;
		d->echo_n--;
	}
	if (!d->echo_n || memcmp(d->echo[d->echo_head].wire, wire, RMD_RS485_FRAME_LEN))
		return false;
	d->echo_head = (d->echo_head + 1) % RMD_RS485_ECHO_RING;
	d->echo_n--;
	bus->stats.echoes++;
	return true;
}

/* A frame we sent, whose echo may come: the oldest gives way when the ring is full. */
static void remember_echo(struct device *d, const uint8_t *wire, int64_t now_ns)
{
	struct echo *e;

	if (d->echo_n == RMD_RS485_ECHO_RING) {
		d->echo_head = (d->echo_head + 1) % RMD_RS485_ECHO_RING;
		d->echo_n--;
	}
	e = &d->echo[(d->echo_head + d->echo_n) % RMD_RS485_ECHO_RING];
	memcpy(e->wire, wire, RMD_RS485_FRAME_LEN);
	e->t_ns = now_ns;
	d->echo_n++;
}

int rmd_rs485_from_can(const struct rmd_frame *f, bool request, struct rmd_frame *out)
{
	int id = rmd_rs485_id_of_can(f->can_id, request);
	unsigned v;

	if (id < 0)
		return id;
	*out = *f;
	if (request || f->can_id != RMD_CAN_SET_ID || f->data[0] != RMD_RS485_CMD_SET_ID ||
	    f->data[2] != 1)
		return id;
	/* V3 §7.4 example 2: the RS485 read answers the ID itself, not 0x240 + ID. */
	v = (unsigned)f->data[6] | (unsigned)f->data[7] << 8;
	if (v > RMD_CAN_V3_REPLY_BASE && v <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS) {
		out->data[6] = (uint8_t)(v - RMD_CAN_V3_REPLY_BASE);
		out->data[7] = 0;
	}
	return id;
}

/* A reply's RS485 form (see the top of rmd/bus_rs485.h) into *out: its id, or -EINVAL. */
static int reply_form(const struct rmd_frame *f, struct rmd_frame *out)
{
	if (f->len > RMD_FRAME_LEN)
		return -EINVAL;
	return rmd_rs485_from_can(f, false, out);
}

/* Bytes on the wire of a frame of len data bytes: header, id, length, data, CRC. */
static size_t wire_len(unsigned len)
{
	return RMD_RS485_FRAME_LEN - RMD_FRAME_LEN + len;
}

/*
 * f's RS485 form into b (wire_len(f->len) bytes).  A frame shorter than 8
 * bytes (the simulator's BAD_DLC fault) goes out as the 8-byte frame cut
 * after its data, its length byte saying len and the CRC over what is left.
 */
static void build_reply(uint8_t *b, uint8_t id, const struct rmd_frame *f)
{
	uint8_t data[RMD_FRAME_LEN] = { 0 };
	uint16_t crc;

	memcpy(data, f->data, f->len);
	rmd_rs485_build(id, data, b, RMD_RS485_FRAME_LEN);
	if (f->len == RMD_FRAME_LEN)
		return;
	b[WIRE_DATA - 1] = f->len;
	crc = rmd_crc16_modbus(b, WIRE_DATA + f->len);
	b[WIRE_DATA + f->len] = (uint8_t)crc;
	b[WIRE_DATA + f->len + 1] = (uint8_t)(crc >> 8);
}

/*
 * Write what the tty takes of the output buffer.  Returns 0, or -errno of
 * write(2), which loses what was waiting.  Rt-safe.
 */
static int device_flush(struct rmd_bus *bus, int64_t now_ns)
{
	struct device *d = priv(bus)->dev;
	size_t off = 0;
	int r = 0;

	while (off < d->txn) {
		ssize_t w = write(priv(bus)->fd, d->tx + off, d->txn - off);

		if (w < 0) {
			if (errno == EINTR)
				continue;
			if (errno != EAGAIN)
				r = -errno;
			break;
		}
		off += (size_t)w;
	}
	if (r < 0)
		off = d->txn;
	d->txn -= off;
	memmove(d->tx, d->tx + off, d->txn);
	d->retry_ns = now_ns;
	return r;
}

/*
 * Replies out: appended to the output buffer as far as it has room, then
 * written as far as the tty takes.  Returns the frames taken, -EINVAL
 * (nothing taken) when one has no RS485 form, or -errno of a write that
 * failed, losing what waited unwritten, these frames among them.  Rt-safe.
 */
static int device_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		       int64_t now_ns)
{
	struct rs485 *p = priv(bus);
	struct device *d = p->dev;
	struct rmd_frame f;
	unsigned taken = 0;
	int r;

	for (unsigned i = 0; i < n; i++)
		if (reply_form(&frames[i], &f) < 0)
			return -EINVAL;

	for (; taken < n; taken++) {
		uint8_t *b = d->tx + d->txn;
		size_t k = wire_len(frames[taken].len);
		int id = reply_form(&frames[taken], &f);

		if (k > sizeof(d->tx) - d->txn)
			break;
		build_reply(b, (uint8_t)id, &f);
		if (p->local_echo && k == RMD_RS485_FRAME_LEN)
			remember_echo(d, b, now_ns);
		d->txn += k;
		bus->stats.tx_frames++;
	}
	bus->stats.tx_busy += n - taken;

	r = device_flush(bus, now_ns);
	return r < 0 ? r : (int)taken;
}

/* Requests in; no queue to time out.  Rt-safe. */
static int device_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	unsigned n;
	int r = read_frames(bus, out, &n, max, now_ns);

	return r < 0 && n == 0 ? r : (int)n;
}

/* While replies wait unwritten: the write the tty refused, to retry; else INT64_MAX. */
static int64_t device_next_due_ns(const struct rmd_bus *bus)
{
	const struct device *d = priv(bus)->dev;

	return d->txn ? d->retry_ns : INT64_MAX;
}

/* Non-rt: frees. */
static void rs485_close(struct rmd_bus *bus)
{
	struct rs485 *p = priv(bus);

	if (p) {
		/* Restores the port's settings; pending output still drains. */
		modbus_close(p->ctx);
		modbus_free(p->ctx);
		free(p->dev);
		free(p);
	}
	memset(bus, 0, sizeof(*bus));
}

static const struct rmd_bus_ops rs485_ops = RMD_BUS_OPS(rs485, rs485_next_due_ns);

static const struct rmd_bus_ops rs485_device_ops = {
	.kind = "rs485",
	.send = device_send,
	.recv = device_recv,
	.fd = rs485_fd,
	.next_due_ns = device_next_due_ns,
	.close = rs485_close,
};

int rmd_rs485_stats(const struct rmd_bus *bus, struct rmd_rs485_stats *out)
{
	const struct rs485 *p;

	if (!bus || (bus->ops != &rs485_ops && bus->ops != &rs485_device_ops))
		return -EINVAL;
	p = priv(bus);
	*out = p->xs;
	out->dropped_bytes = bus->stats.rx_noise_bytes;
	out->echoes = bus->stats.echoes;
	out->pending = queued(p);
	return 0;
}
