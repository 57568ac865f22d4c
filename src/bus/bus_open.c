// SPDX-License-Identifier: MIT
/*
 * Bus spec -> transport.  See rmd/bus_open.h.  Non-rt.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/err.h"
#include "rmd/bus_open.h"
#include "rmd/dialect.h"
#include "rmd/can_timing.h"
#include "rmd/bus_rs485.h"
#include "rmd/bus_sim.h"
#include "rmd/bus_socketcan.h"

#define SIM_PREFIX "sim"

/* One decimal id 1..32 at *s; advances *s.  Returns the id or -EINVAL. */
static int parse_id(const char **s)
{
	const char *p = *s;
	int v = 0;

	if (*p < '0' || *p > '9')
		return -EINVAL;
	while (*p >= '0' && *p <= '9') {
		v = v * 10 + (*p - '0');
		if (v > RMD_MAX_MOTORS)
			return -EINVAL;
		p++;
	}
	if (v < 1)
		return -EINVAL;
	*s = p;
	return v;
}

int rmd_bus_open_parse_ids(const char *list, uint8_t ids[RMD_MAX_MOTORS])
{
	bool seen[RMD_MAX_MOTORS + 1] = { false };
	const char *s = list;
	int n = 0;

	if (!s || !*s)
		return -EINVAL;
	for (;;) {
		int lo = parse_id(&s), hi;

		if (lo < 0)
			return -EINVAL;
		hi = lo;
		if (*s == '-') {
			s++;
			hi = parse_id(&s);
			if (hi < lo)
				return -EINVAL;
		}
		for (int id = lo; id <= hi; id++) {
			if (seen[id])
				return -EINVAL;
			seen[id] = true;
		}
		if (*s == '\0')
			break;
		if (*s != ',')
			return -EINVAL;
		s++;
	}
	for (int id = 1; id <= RMD_MAX_MOTORS; id++)
		if (seen[id])
			ids[n++] = (uint8_t)id;
	return n;
}

bool rmd_bus_open_is_sim(const char *spec)
{
	size_t n = strlen(SIM_PREFIX);

	return spec && !strncmp(spec, SIM_PREFIX, n) && (spec[n] == '\0' || spec[n] == ':');
}

/* A sim bus: its motors, powered on, with ctx->sim's wire and faults.  Non-rt. */
static int open_sim(struct rmd_bus *bus, const struct rmd_config_bus *cb,
		    const struct rmd_bus_open_ctx *ctx, char *err, size_t errlen)
{
	static const struct rmd_sim_bus_setup none;
	const struct rmd_sim_bus_setup *sim = ctx->sim ? ctx->sim : &none;
	struct rmd_bus_sim_motor motors[RMD_MAX_MOTORS];
	struct rmd_bus_sim_opts so = {
		.motors = motors,
		.n_motors = ctx->n_motors,
		.bitrate = cb->bitrate,
		.seed = sim->seed,
		.flags = sim->host_fifo ? RMD_SIM_WIRE_HOST_FIFO : 0,
		.txqueuelen = sim->txqueuelen,
		.faults = sim->n_faults ? sim->faults : NULL,
		.n_faults = sim->n_faults,
		.tap = sim->tap[0] ? sim->tap : NULL,
		.burst = ctx->burst,
		.refuse_flush = sim->refuse_flush,
		.body = ctx->body,
		.hold_after_ns = ctx->sim_hold_after_ns,
	};

	for (unsigned i = 0; i < ctx->n_motors; i++)
		motors[i] = (struct rmd_bus_sim_motor){ .cfg_motor = ctx->motors[i].cfg_motor,
							.id = ctx->motors[i].id,
							.proto = ctx->motors[i].proto,
							.params = ctx->motors[i].sim };
	/* the motors on the wire that the configuration does not list */
	for (unsigned k = 0; k < sim->n_strays && so.n_motors < RMD_MAX_MOTORS; k++)
		motors[so.n_motors++] = (struct rmd_bus_sim_motor){ .cfg_motor = -1,
								    .id = sim->strays[k].id,
								    .proto = sim->strays[k].proto,
								    .params = &sim->strays[k] };
	return rmd_bus_sim_open(bus, cb->name, &so, err, errlen);
}

/* An RS485 line of V3 motors.  Non-rt. */
static int open_rs485(struct rmd_bus *bus, const struct rmd_config_bus *cb,
		      const struct rmd_bus_open_ctx *ctx, char *err, size_t errlen)
{
	uint32_t baud = cb->baud ? cb->baud : RMD_BUS_OPEN_BAUD;
	struct rmd_rs485_opts ro = {
		.baud = baud,
		/* the bus's turnaround_us (a slow converter's included) sets the line's timeout */
		.reply_timeout_ns = ctx->reply_timeout_ns ?
					    ctx->reply_timeout_ns :
					    rmd_rs485_reply_timeout_ns(baud, cb->turnaround_ns),
		.broadcast_replies = ctx->broadcast_replies ? ctx->broadcast_replies :
							      ctx->n_motors,
		.local_echo = ctx->local_echo,
		.device = ctx->device,
	};

	/* V3 §1.2: RS485 frames carry the V3 command set; V2 is CAN only. */
	for (unsigned i = 0; i < ctx->n_motors; i++) {
		const struct rmd_dialect *d = rmd_dialect(ctx->motors[i].proto);

		if (d && !rmd_dialect_has(d, RMD_DIALECT_RS485))
			return rmd_errf(err, errlen, -EINVAL,
					"%s: protocol %s has no RS485 interface (%s motors are CAN "
					"only)",
					cb->device, d->name, d->name);
	}
	return rmd_rs485_open(bus, cb->device, &ro, err, errlen);
}

/* A SocketCAN interface that admits the replies of the bus's motors.  Non-rt. */
static int open_socketcan(struct rmd_bus *bus, const struct rmd_config_bus *cb,
			  const struct rmd_bus_open_ctx *ctx, char *err, size_t errlen)
{
	struct rmd_socketcan_motor motors[RMD_MAX_MOTORS];
	struct rmd_socketcan_opts so = {
		.motors = motors,
		.n_motors = ctx->n_motors,
		.set_id_replies = ctx->set_id_replies,
		.watch_strays = ctx->watch_strays,
		.burst = ctx->burst,
		.device = ctx->device,
	};

	for (unsigned i = 0; i < ctx->n_motors; i++) {
		motors[i] =
			(struct rmd_socketcan_motor){ .id = ctx->motors[i].id,
						      .proto = ctx->motors[i].proto,
						      .any_dialect = ctx->motors[i].any_dialect };
		if (ctx->motors[i].mit && ctx->motors[i].id >= 1 &&
		    ctx->motors[i].id <= RMD_MAX_MOTORS)
			so.mit_ids |= UINT32_C(1) << (ctx->motors[i].id - 1);
	}
	return rmd_socketcan_open(bus, cb->interface[0] ? cb->interface : cb->name, &so, err,
				  errlen);
}

int rmd_bus_open(struct rmd_bus *bus, const struct rmd_config_bus *cb,
		 const struct rmd_bus_open_ctx *ctx, char *err, size_t errlen)
{
	static const struct rmd_bus_open_ctx empty;

	memset(bus, 0, sizeof(*bus));
	if (err && errlen)
		err[0] = '\0';
	if (!ctx)
		ctx = &empty;
	if (ctx->n_motors > RMD_MAX_MOTORS || (ctx->n_motors && !ctx->motors))
		return rmd_errf(err, errlen, -EINVAL, "%s: bad motor list (%u motors)", cb->name,
				ctx->n_motors);
	switch (cb->kind) {
	case RMD_BUS_KIND_SOCKETCAN:
		return open_socketcan(bus, cb, ctx, err, errlen);
	case RMD_BUS_KIND_RS485:
		return open_rs485(bus, cb, ctx, err, errlen);
	case RMD_BUS_KIND_SIM:
		return open_sim(bus, cb, ctx, err, errlen);
	}
	return rmd_errf(err, errlen, -EINVAL, "%s: unknown bus kind %d", cb->name, (int)cb->kind);
}

bool rmd_bus_config_motor_in_process(const struct rmd_config *cfg, unsigned i)
{
	return i < cfg->n_motors && cfg->motors[i].bus < cfg->n_buses &&
	       cfg->buses[cfg->motors[i].bus].kind == RMD_BUS_KIND_SIM;
}

void rmd_bus_open_ctx_of(const struct rmd_config *cfg, const struct rmd_sim_setup *sim, unsigned b,
			 struct rmd_bus_open_motor motors[RMD_MAX_MOTORS],
			 struct rmd_bus_open_ctx *ctx)
{
	*ctx = (struct rmd_bus_open_ctx){ .motors = motors };
	if (b >= cfg->n_buses)
		return;
	for (unsigned i = 0; i < cfg->n_motors && ctx->n_motors < RMD_MAX_MOTORS; i++) {
		const struct rmd_config_motor *m = &cfg->motors[i];

		if (m->bus == b)
			motors[ctx->n_motors++] = (struct rmd_bus_open_motor){
				.id = m->id,
				.proto = m->proto,
				.any_dialect = m->proto_auto,
				.mit = rmd_config_mit_mode(m),
				.sim = sim ? &sim->motors[i] : NULL,
				.cfg_motor = (int)i,
			};
	}
	if (sim && cfg->buses[b].kind == RMD_BUS_KIND_SIM)
		ctx->sim = &sim->buses[b];
}

int rmd_bus_config_timing(const struct rmd_config_bus *cb, struct rmd_bus_timing *out)
{
	switch (cb->kind) {
	case RMD_BUS_KIND_SOCKETCAN:
	case RMD_BUS_KIND_SIM:
		*out = (struct rmd_bus_timing){
			.bitrate = cb->bitrate,
			.frame_bits = rmd_can_frame_bits_worst(RMD_FRAME_LEN),
			/* pipelined: replies overlap other frames */
			.port = cb->kind == RMD_BUS_KIND_SOCKETCAN ? cb->interface : NULL,
			.rate_unit = "bit/s",
		};
		return 0;
	case RMD_BUS_KIND_RS485:
		*out = (struct rmd_bus_timing){
			.bitrate = cb->baud,
			.frame_bits = RMD_RS485_FRAME_BITS,
			.turnaround_ns = cb->turnaround_ns,
			.half_duplex = true,
			.port = cb->device,
			.rate_unit = "baud",
		};
		return 0;
	}
	return -EINVAL;
}

int rmd_bus_spec_parse(const char *spec, const struct rmd_bus_open_opts *opts,
		       struct rmd_config_bus *cb, uint8_t ids[RMD_MAX_MOTORS], char *err,
		       size_t errlen)
{
	const char *list;
	int n;

	memset(cb, 0, sizeof(*cb));
	if (!spec || !*spec)
		return rmd_errf(
			err, errlen, -EINVAL,
			"empty bus name (a CAN interface, a serial device path or \"sim\")");
	snprintf(cb->name, sizeof(cb->name), "%s", spec);
	if (spec[0] == '/') {
		cb->kind = RMD_BUS_KIND_RS485;
		snprintf(cb->device, sizeof(cb->device), "%s", spec);
		cb->baud = opts ? opts->baud : 0;
		return 0;
	}
	if (!rmd_bus_open_is_sim(spec)) {
		cb->kind = RMD_BUS_KIND_SOCKETCAN;
		snprintf(cb->interface, sizeof(cb->interface), "%s", spec);
		return 0;
	}
	cb->kind = RMD_BUS_KIND_SIM;
	cb->bitrate = opts ? opts->sim_bitrate : 0;
	list = spec + strlen(SIM_PREFIX);
	if (*list == '\0') {
		for (n = 0; n < RMD_BUS_OPEN_SIM_MOTORS; n++)
			ids[n] = (uint8_t)(n + 1);
		return n;
	}
	n = rmd_bus_open_parse_ids(list + 1, ids);
	if (n < 0)
		return rmd_errf(err, errlen, -EINVAL,
				"\"%s\": bad motor list after \"sim:\" (ids 1..%d, each once, "
				"e.g. sim:1-3,7)",
				spec, RMD_MAX_MOTORS);
	return n;
}

int rmd_bus_open_spec(struct rmd_bus *bus, const char *spec, const struct rmd_bus_open_opts *opts,
		      char *err, size_t errlen)
{
	static const struct rmd_bus_open_opts defaults = { .proto = RMD_PROTO_V3 };
	const struct rmd_bus_open_opts *o = opts ? opts : &defaults;
	struct rmd_bus_open_motor motors[RMD_MAX_MOTORS];
	struct rmd_sim_bus_setup *sim = NULL;
	struct rmd_bus_open_ctx ctx = {
		.motors = motors,
		.set_id_replies = o->set_id_replies,
		.burst = o->burst,
		.reply_timeout_ns = o->reply_timeout_ns,
		.broadcast_replies = o->broadcast_replies,
		.local_echo = o->local_echo,
		.device = o->device,
	};
	struct rmd_config_bus cb;
	uint8_t ids[RMD_MAX_MOTORS];
	int n, r;

	memset(bus, 0, sizeof(*bus));
	if (err && errlen)
		err[0] = '\0';
	n = rmd_bus_spec_parse(spec, o, &cb, ids, err, errlen);
	if (n < 0)
		return n;
	if (!rmd_dialect(o->proto))
		return rmd_errf(err, errlen, -EINVAL, "%s: unknown protocol %d", spec,
				(int)o->proto);
	if (cb.kind == RMD_BUS_KIND_SIM) {
		/* Host frames leave in order, as from SocketCAN's single queue. */
		sim = calloc(1, sizeof(*sim));
		if (!sim)
			return rmd_errf(err, errlen, -ENOMEM, "%s: out of memory", spec);
		sim->seed = o->sim_seed;
		sim->host_fifo = true;
		ctx.sim = sim;
	} else if (o->n_ids > RMD_MAX_MOTORS || (o->n_ids && !o->ids)) {
		return rmd_errf(err, errlen, -EINVAL, "%s: bad motor list (%u ids)", spec,
				o->n_ids);
	} else if (o->n_ids) {
		memcpy(ids, o->ids, o->n_ids);
		n = (int)o->n_ids;
	} else {
		/* No list: every id may answer. */
		for (n = 0; n < RMD_MAX_MOTORS; n++)
			ids[n] = (uint8_t)(n + 1);
	}
	for (int i = 0; i < n; i++)
		motors[i] = (struct rmd_bus_open_motor){
			.cfg_motor = -1, .id = ids[i], .proto = o->proto, .sim = o->sim_motor
		};
	ctx.n_motors = (unsigned)n;
	r = rmd_bus_open(bus, &cb, &ctx, err, errlen);
	free(sim);
	return r;
}

int64_t rmd_bus_open_time_zero_ns(struct rmd_bus *bus, int64_t now_ns)
{
	if (!rmd_bus_sim_get(bus))
		return 0;
	return now_ns - rmd_bus_sim_time_ns(bus, now_ns);
}
