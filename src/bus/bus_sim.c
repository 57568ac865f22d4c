// SPDX-License-Identifier: MIT
/*
 * The in-process simulated transport: struct rmd_sim_wire behind struct
 * rmd_bus_ops.  See rmd/bus_sim.h.
 */
#define _GNU_SOURCE /* F_SETPIPE_SZ */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rmd/err.h"
#include "rmd/bus_sim.h"
#include "rmd/dialect.h"
#include "rmd/sim_body.h"

/* Frames moved from the sim bus per rmd_sim_wire_recv() call (stack buffer). */
#define RX_CHUNK 32

/* The wire tap (rmd/bus_sim.h): whole candump -l lines, one write() a PIPE_BUF. */
struct bus_tap {
	int fd;		     /* -1: no tap */
	char name[32];	     /* struct rmd_bus.name */
	unsigned len, lines; /* bytes and lines in buf */
	uint64_t lost;	     /* lines lost */
	char buf[PIPE_BUF];
};

/* Sends the adapter refuses (rmd_bus_sim_refuse_tx()), in sim time. */
struct tx_refusal {
	int64_t start_ns, end_ns, hold_ns; /* end_ns 0: open; hold_ns 0: every send */
	bool busy;			   /* a run of refusals is on ... */
	int64_t busy_until_ns;		   /* ... until this time */
};

struct bus_sim {
	struct rmd_sim_wire sim;
	bool refuse_flush; /* opts.refuse_flush */
	bool refusing;	   /* a struct tx_refusal window is set */
	struct tx_refusal refusal;
	bool started;			  /* the epoch is set */
	int64_t epoch_ns;		  /* caller's now_ns at sim time 0 */
	int64_t last_rx_ns, stamp_gap_ns; /* rmd_bus_stamp_seen() */
	struct bus_tap tap;
};

static struct bus_sim *priv(const struct rmd_bus *bus)
{
	return bus->priv;
}

/* Caller time -> sim time; the first call fixes the epoch.  Rt-safe. */
static int64_t to_sim(struct bus_sim *p, int64_t now_ns)
{
	if (!p->started) {
		p->started = true;
		p->epoch_ns = now_ns;
	}
	return now_ns - p->epoch_ns;
}

/* Write the tap's buffered lines; a short or refused write loses them.  Rt-safe. */
static void tap_flush(struct bus_tap *tp)
{
	if (tp->len && write(tp->fd, tp->buf, tp->len) != (ssize_t)tp->len)
		tp->lost += tp->lines;
	tp->len = 0;
	tp->lines = 0;
}

static char *put_dec(char *o, uint64_t v, unsigned min_digits)
{
	char d[20];
	unsigned n = 0;

	do {
		d[n++] = (char)('0' + v % 10);
		v /= 10;
	} while (v || n < min_digits);
	while (n)
		*o++ = d[--n];
	return o;
}

/* rmd_sim_wire_tap_fn: frame p ended at eof_ns (sim time).  Rt-safe. */
static void tap_frame(void *ctx, const struct rmd_sim_pending *p, int64_t start_ns, int64_t eof_ns)
{
	static const char hex[] = "0123456789ABCDEF";
	struct bus_sim *bs = ctx;
	struct bus_tap *tp = &bs->tap;
	uint64_t t_us = (uint64_t)(eof_ns + bs->epoch_ns) / 1000u;
	char line[96], *o = line;

	(void)start_ns;
	*o++ = '(';
	o = put_dec(o, t_us / 1000000u, 1);
	*o++ = '.';
	o = put_dec(o, t_us % 1000000u, 6);
	*o++ = ')';
	*o++ = ' ';
	for (const char *c = tp->name; *c; c++)
		*o++ = *c;
	*o++ = ' ';
	for (int sh = 8; sh >= 0; sh -= 4)
		*o++ = hex[(p->f.can_id >> sh) & 0xFu];
	*o++ = '#';
	for (unsigned i = 0; i < p->f.len && i < RMD_FRAME_LEN; i++) {
		*o++ = hex[p->f.data[i] >> 4];
		*o++ = hex[p->f.data[i] & 0xFu];
	}
	/* candump -l's direction: T the host transmitted it, R it received it */
	*o++ = ' ';
	*o++ = p->src == RMD_SIM_SRC_HOST ? 'T' : 'R';
	*o++ = '\n';
	if (tp->len + (unsigned)(o - line) > sizeof(tp->buf))
		tap_flush(tp);
	memcpy(tp->buf + tp->len, line, (size_t)(o - line));
	tp->len += (unsigned)(o - line);
	tp->lines++;
}

/* Open opts->tap (rmd/bus_sim.h).  Non-rt. */
static int tap_open(struct bus_sim *p, const char *name, const char *path, char *err, size_t errlen)
{
	int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_APPEND | O_NONBLOCK | O_CLOEXEC, 0644);

	if (fd < 0)
		return rmd_errf(err, errlen, -errno, "%s: tap %s: %s", name, path,
				errno == ENXIO ? "a FIFO without a reader" : strerror(errno));
	/* a FIFO: room for a second of a busy wire while its reader waits for a CPU */
	(void)fcntl(fd, F_SETPIPE_SZ, 1 << 20);
	p->tap.fd = fd;
	snprintf(p->tap.name, sizeof(p->tap.name), "%s", name);
	rmd_sim_wire_set_tap(&p->sim, tap_frame, p);
	return 0;
}

/* Follow the sim bus's state: bus-off windows, no acknowledgement.  Rt-safe. */
static void sync_state(struct rmd_bus *bus, struct bus_sim *p)
{
	enum rmd_bus_state st = rmd_sim_wire_state(&p->sim);

	if (st != bus->state) {
		bus->state = st;
		bus->stats.state_changes++;
	}
}

/* Whether the adapter refuses a send() at sim time t (rmd_bus_sim_refuse_tx()).  Rt-safe. */
static bool tx_refused(struct tx_refusal *rf, int64_t t)
{
	if (t < rf->start_ns || (rf->end_ns && t >= rf->end_ns)) {
		rf->busy = false;
		return false;
	}
	if (!rf->hold_ns)
		return true;
	if (!rf->busy) {
		rf->busy = true;
		rf->busy_until_ns = t + rf->hold_ns;
		return true;
	}
	if (t < rf->busy_until_ns)
		return true;
	rf->busy = false;
	return false;
}

/* rt-safe */
static int sim_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n, int64_t now_ns)
{
	struct bus_sim *p = priv(bus);
	int64_t t = to_sim(p, now_ns);
	int r;

	if (__builtin_expect(p->refusing, 0) && n && tx_refused(&p->refusal, t)) {
		/* the adapter's queue is full: ENOBUFS, the caller keeps the frames */
		bus->stats.tx_busy += n;
		return 0;
	}
	r = rmd_sim_wire_send(&p->sim, t, frames, n);
	sync_state(bus, p);
	if (r == -ENOBUFS) {
		/* The TX queue is full: the caller keeps the frames, as with SocketCAN. */
		bus->stats.tx_busy += n;
		return 0;
	}
	if (r < 0)
		return r;
	bus->stats.tx_frames += (unsigned)r;
	bus->stats.tx_busy += n - (unsigned)r;
	return r;
}

/* rt-safe */
static int sim_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	struct bus_sim *p = priv(bus);
	struct rmd_frame f[RX_CHUNK];
	int64_t t[RX_CHUNK];
	unsigned count = 0;

	rmd_sim_wire_advance(&p->sim, to_sim(p, now_ns));
	sync_state(bus, p);
	while (count < max) {
		unsigned want = max - count < RX_CHUNK ? max - count : RX_CHUNK;
		int r = rmd_sim_wire_recv(&p->sim, f, want, t);

		for (int i = 0; i < r; i++) {
			out[count].f = f[i];
			out[count].t_ns = t[i] + p->epoch_ns;
			rmd_bus_stamp_seen(&bus->stats, &p->last_rx_ns, out[count].t_ns,
					   p->stamp_gap_ns);
			count++;
		}
		if ((unsigned)r < want)
			break;
	}
	bus->stats.rx_frames += count;
	return (int)count;
}

/*
 * The host queue emptied, as restarting a CAN interface empties its queue
 * and controller (rmd_sim_wire_flush()); -EPERM with opts.refuse_flush,
 * as SocketCAN without CAP_NET_ADMIN.  rt-safe.
 */
static int sim_flush(struct rmd_bus *bus)
{
	struct bus_sim *p = priv(bus);

	if (p->refuse_flush)
		return -EPERM;
	rmd_sim_wire_flush(&p->sim);
	return 0;
}

static int sim_fd(const struct rmd_bus *bus)
{
	(void)bus;
	return -1;
}

static void sim_close(struct rmd_bus *bus)
{
	struct bus_sim *p = priv(bus);

	if (p) {
		if (p->tap.fd >= 0) {
			tap_flush(&p->tap);
			close(p->tap.fd);
		}
		rmd_sim_wire_fini(&p->sim);
		free(p);
	}
	memset(bus, 0, sizeof(*bus));
}

static const struct rmd_bus_ops sim_ops = RMD_BUS_OPS_FLUSH(sim, rmd_bus_never_due_ns);

/* Power on the motors of opts at sim time 0.  Non-rt. */
static int add_motors(struct bus_sim *p, const char *name, const struct rmd_bus_sim_opts *opts,
		      char *err, size_t errlen)
{
	for (unsigned i = 0; i < opts->n_motors; i++) {
		const struct rmd_bus_sim_motor *m = &opts->motors[i];
		struct rmd_sim_motor_params params;
		int r;

		if (m->id < 1 || m->id > RMD_MAX_MOTORS)
			return rmd_errf(err, errlen, -EINVAL, "%s: motor id %u out of range 1..%d",
					name, m->id, RMD_MAX_MOTORS);
		if (!rmd_dialect(m->proto))
			return rmd_errf(err, errlen, -EINVAL, "%s: motor %u: unknown protocol %d",
					name, m->id, (int)m->proto);
		/* the simulated firmware: its model's (config: motors[].sim.firmware), else the host's */
		if (m->params)
			params = *m->params;
		else
			rmd_sim_motor_params_default(&params, m->id, m->proto);
		params.id = m->id;
		r = rmd_sim_wire_add_motor(&p->sim, &params, 0);
		if (r == -EEXIST)
			return rmd_errf(err, errlen, r, "%s: motor id %u given twice", name, m->id);
		if (r < 0)
			return rmd_errf(err, errlen, r, "%s: motor %u: %s", name, m->id,
					strerror(-r));
		if (opts->body && m->cfg_motor >= 0) {
			r = rmd_sim_body_attach(opts->body, (unsigned)m->cfg_motor,
						rmd_sim_wire_motor(&p->sim, m->id));
			if (r < 0)
				return rmd_errf(err, errlen, r,
						"%s: motor %u: its joint has a motor already", name,
						m->id);
		}
	}
	return 0;
}

/* An option list of n `what`s: at most max, and there when n > 0.  Returns 0 or -errno. */
static int check_list(const char *name, const char *what, unsigned n, unsigned max,
		      const void *list, char *err, size_t errlen)
{
	if (n > max)
		return rmd_errf(err, errlen, -E2BIG, "%s: %u %ss, at most %u", name, n, what, max);
	if (n && !list)
		return rmd_errf(err, errlen, -EINVAL, "%s: %u %ss but no %s list", name, n, what,
				what);
	return 0;
}

int rmd_bus_sim_open(struct rmd_bus *bus, const char *name, const struct rmd_bus_sim_opts *opts,
		     char *err, size_t errlen)
{
	struct bus_sim *p;
	int r;

	memset(bus, 0, sizeof(*bus));
	if (err && errlen)
		err[0] = '\0';
	if (!name || !name[0])
		name = "sim";
	if (!opts)
		return rmd_errf(err, errlen, -EINVAL, "%s: no options", name);
	r = check_list(name, "motor", opts->n_motors, RMD_MAX_MOTORS, opts->motors, err, errlen);
	if (r < 0)
		return r;
	r = check_list(name, "fault", opts->n_faults, RMD_SIM_MAX_FAULTS, opts->faults, err,
		       errlen);
	if (r < 0)
		return r;

	p = calloc(1, sizeof(*p));
	if (!p)
		return rmd_errf(err, errlen, -ENOMEM, "%s: out of memory", name);
	p->tap.fd = -1;
	p->refuse_flush = opts->refuse_flush;
	r = rmd_sim_wire_init(&p->sim, opts->bitrate ? opts->bitrate : RMD_BUS_SIM_BITRATE,
			      opts->seed ? opts->seed : RMD_BUS_SIM_SEED, opts->flags);
	if (r < 0) {
		r = rmd_errf(err, errlen, r, "%s: bad bitrate %u or flags 0x%x", name,
			     opts->bitrate, opts->flags);
		goto err_free;
	}
	if (opts->txqueuelen) {
		r = rmd_sim_wire_set_txqueuelen(&p->sim, opts->txqueuelen);
		if (r < 0) {
			r = rmd_errf(err, errlen, r, "%s: TX queue length %u out of range 1..%d",
				     name, opts->txqueuelen, RMD_SIM_WIRE_TXQ);
			goto err_fini;
		}
	}
	/* the check a CAN interface's txqueuelen gets (bus_socketcan.c): a cycle's burst fits */
	if (opts->burst && p->sim.txq_len < opts->burst) {
		r = rmd_errf(err, errlen, -ENOBUFS,
			     "%s: TX queue of %u frames cannot hold a %u-frame cycle: set its "
			     "sim.txqueuelen to %u or more (up to %d)",
			     name, p->sim.txq_len, opts->burst, opts->burst, RMD_SIM_WIRE_TXQ);
		goto err_fini;
	}
	r = add_motors(p, name, opts, err, errlen);
	if (r < 0)
		goto err_fini;
	if (opts->n_faults) {
		r = rmd_sim_wire_set_faults(&p->sim, opts->faults, opts->n_faults);
		if (r < 0) {
			r = rmd_errf(err, errlen, r, "%s: bad fault table: %s", name, strerror(-r));
			goto err_fini;
		}
	}
	rmd_sim_wire_set_hold_after(&p->sim, opts->hold_after_ns);
	if (opts->tap) {
		r = tap_open(p, name, opts->tap, err, errlen);
		if (r < 0)
			goto err_fini;
	}

	bus->ops = &sim_ops;
	snprintf(bus->name, sizeof(bus->name), "%s", name);
	/* A CAN bus in a box: the same caps as SocketCAN. */
	bus->caps = (struct rmd_bus_caps){ .request_spacing_ns = RMD_BUS_CAN_SPACING_NS,
					   .bitrate = p->sim.bitrate };
	bus->state = RMD_BUS_ACTIVE;
	bus->priv = p;
	p->stamp_gap_ns = rmd_bus_stamp_gap_ns(p->sim.bitrate);
	return 0;

err_fini:
	rmd_sim_wire_fini(&p->sim);
err_free:
	free(p);
	return r;
}

struct rmd_sim_wire *rmd_bus_sim_get(struct rmd_bus *bus)
{
	if (!bus || bus->ops != &sim_ops)
		return NULL;
	return &priv(bus)->sim;
}

int64_t rmd_bus_sim_time_ns(const struct rmd_bus *bus, int64_t now_ns)
{
	const struct bus_sim *p;

	if (!bus || bus->ops != &sim_ops)
		return 0;
	p = priv(bus);
	return p->started ? now_ns - p->epoch_ns : 0;
}

uint64_t rmd_bus_sim_tap_lost(const struct rmd_bus *bus)
{
	if (!bus || bus->ops != &sim_ops)
		return 0;
	return priv(bus)->tap.lost;
}

int rmd_bus_sim_refuse_tx(struct rmd_bus *bus, int64_t start_ns, int64_t end_ns, int64_t hold_ns)
{
	struct bus_sim *p;

	if (!bus || bus->ops != &sim_ops || hold_ns < 0 || (end_ns && end_ns < start_ns))
		return -EINVAL;
	p = priv(bus);
	p->refusal =
		(struct tx_refusal){ .start_ns = start_ns, .end_ns = end_ns, .hold_ns = hold_ns };
	p->refusing = true;
	return 0;
}
