// SPDX-License-Identifier: MIT
/*
 * The in-process simulated transport: struct rmd_sim_wire behind struct
 * rmd_bus_ops.  See rmd/bus_sim.h.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/err.h"
#include "rmd/bus_sim.h"

/* Frames moved from the sim bus per rmd_sim_wire_recv() call (stack buffer). */
#define RX_CHUNK 32

struct bus_sim {
	struct rmd_sim_wire sim;
	bool started;	  /* the epoch is set */
	int64_t epoch_ns; /* caller's now_ns at sim time 0 */
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

/* Follow the sim bus's bus-off windows.  Rt-safe. */
static void sync_state(struct rmd_bus *bus, struct bus_sim *p)
{
	enum rmd_bus_state st = rmd_sim_wire_state(&p->sim);

	if (st != bus->state) {
		bus->state = st;
		bus->stats.state_changes++;
	}
}

/* rt-safe */
static int sim_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n, int64_t now_ns)
{
	struct bus_sim *p = priv(bus);
	int r;

	r = rmd_sim_wire_send(&p->sim, to_sim(p, now_ns), frames, n);
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
			count++;
		}
		if ((unsigned)r < want)
			break;
	}
	bus->stats.rx_frames += count;
	return (int)count;
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
		rmd_sim_wire_fini(&p->sim);
		free(p);
	}
	memset(bus, 0, sizeof(*bus));
}

static const struct rmd_bus_ops sim_ops = RMD_BUS_OPS(sim, rmd_bus_never_due_ns);

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
		if (m->proto != RMD_PROTO_V3 && m->proto != RMD_PROTO_V2 &&
		    m->proto != RMD_PROTO_MIT)
			return rmd_errf(err, errlen, -EINVAL, "%s: motor %u: unknown protocol %d",
					name, m->id, (int)m->proto);
		if (m->params)
			params = *m->params;
		else
			rmd_sim_motor_params_default(&params, m->id, m->proto);
		params.id = m->id;
		params.proto = m->proto;
		r = rmd_sim_wire_add_motor(&p->sim, &params, 0);
		if (r == -EEXIST)
			return rmd_errf(err, errlen, r, "%s: motor id %u given twice", name, m->id);
		if (r < 0)
			return rmd_errf(err, errlen, r, "%s: motor %u: %s", name, m->id,
					strerror(-r));
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

	bus->ops = &sim_ops;
	snprintf(bus->name, sizeof(bus->name), "%s", name);
	/* A CAN bus in a box: the same caps as SocketCAN. */
	bus->caps = (struct rmd_bus_caps){ .request_spacing_ns = RMD_BUS_CAN_SPACING_NS };
	bus->state = RMD_BUS_ACTIVE;
	bus->priv = p;
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
