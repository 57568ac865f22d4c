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

static int open_sim(struct rmd_bus *bus, const char *spec, const struct rmd_bus_open_opts *o,
		    char *err, size_t errlen)
{
	struct rmd_bus_sim_motor motors[RMD_MAX_MOTORS];
	struct rmd_bus_sim_opts so = { 0 };
	uint8_t ids[RMD_MAX_MOTORS];
	const char *list = spec + strlen(SIM_PREFIX);
	int n;

	if (*list == '\0') {
		n = RMD_BUS_OPEN_SIM_MOTORS;
		for (int i = 0; i < n; i++)
			ids[i] = (uint8_t)(i + 1);
	} else {
		n = rmd_bus_open_parse_ids(list + 1, ids);
		if (n < 0)
			return rmd_errf(
				err, errlen, -EINVAL,
				"\"%s\": bad motor list after \"sim:\" (ids 1..%d, each once, "
				"e.g. sim:1-3,7)",
				spec, RMD_MAX_MOTORS);
	}
	for (int i = 0; i < n; i++)
		motors[i] = (struct rmd_bus_sim_motor){ .id = ids[i], .proto = o->proto };
	so.motors = motors;
	so.n_motors = (unsigned)n;
	so.bitrate = o->sim_bitrate;
	so.seed = o->sim_seed;
	/* Host frames leave in order, as from SocketCAN's single queue. */
	so.flags = RMD_SIM_WIRE_HOST_FIFO;
	return rmd_bus_sim_open(bus, spec, &so, err, errlen);
}

static int open_rs485(struct rmd_bus *bus, const char *spec, const struct rmd_bus_open_opts *o,
		      char *err, size_t errlen)
{
	struct rmd_rs485_opts ro = {
		.baud = o->baud ? o->baud : RMD_BUS_OPEN_BAUD,
		.reply_timeout_ns = o->reply_timeout_ns,
		.broadcast_replies = o->broadcast_replies,
	};

	/* V3 §1.2: RS485 frames carry the V3 command set; V2 is CAN only. */
	if (o->proto == RMD_PROTO_V2)
		return rmd_errf(err, errlen, -EINVAL,
				"%s: protocol V2 has no RS485 interface (V2 motors are CAN only)",
				spec);
	return rmd_rs485_open(bus, spec, &ro, err, errlen);
}

static int open_socketcan(struct rmd_bus *bus, const char *spec, const struct rmd_bus_open_opts *o,
			  char *err, size_t errlen)
{
	struct rmd_socketcan_motor motors[RMD_MAX_MOTORS];
	struct rmd_socketcan_opts so = { 0 };
	unsigned n = 0;

	if (o->n_ids > RMD_MAX_MOTORS || (o->n_ids && !o->ids))
		return rmd_errf(err, errlen, -EINVAL, "%s: bad motor list (%u ids)", spec,
				o->n_ids);
	if (o->n_ids) {
		for (unsigned i = 0; i < o->n_ids; i++)
			motors[n++] =
				(struct rmd_socketcan_motor){ .id = o->ids[i], .proto = o->proto };
	} else {
		for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++)
			motors[n++] = (struct rmd_socketcan_motor){ .id = (uint8_t)id,
								    .proto = o->proto };
	}
	so.motors = motors;
	so.n_motors = n;
	so.set_id_replies = o->set_id_replies;
	so.burst = o->burst;
	return rmd_socketcan_open(bus, spec, &so, err, errlen);
}

int rmd_bus_open_spec(struct rmd_bus *bus, const char *spec, const struct rmd_bus_open_opts *opts,
		      char *err, size_t errlen)
{
	static const struct rmd_bus_open_opts defaults = { .proto = RMD_PROTO_V3 };
	const struct rmd_bus_open_opts *o = opts ? opts : &defaults;

	memset(bus, 0, sizeof(*bus));
	if (err && errlen)
		err[0] = '\0';
	if (!spec || !*spec)
		return rmd_errf(
			err, errlen, -EINVAL,
			"empty bus name (a CAN interface, a serial device path or \"sim\")");
	if (o->proto != RMD_PROTO_V3 && o->proto != RMD_PROTO_V2 && o->proto != RMD_PROTO_MIT)
		return rmd_errf(err, errlen, -EINVAL, "%s: unknown protocol %d", spec,
				(int)o->proto);
	if (rmd_bus_open_is_sim(spec))
		return open_sim(bus, spec, o, err, errlen);
	if (spec[0] == '/')
		return open_rs485(bus, spec, o, err, errlen);
	return open_socketcan(bus, spec, o, err, errlen);
}
