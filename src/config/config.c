// SPDX-License-Identifier: MIT
/*
 * rmdd's configuration model (rmd/config.h): defaults, the names a config
 * file spells, look-ups by name.  The YAML loader is config_yaml.c.
 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <sys/stat.h>

#include "rmd/err.h"
#include "rmd/config.h"
#include "rmd/rs485.h"

const char *const rmd_bus_kind_names[] = { "socketcan", "rs485", "sim", NULL };
const char *const rmd_mode_names[] = { "torque", "speed", "position", "mit", NULL };
const char *const rmd_units_names[] = { "output", "rotor", NULL };
const char *const rmd_safe_action_names[] = { "stop", "hold", "damp", "brake", NULL };
const char *const rmd_lost_action_names[] = { "motor", "all", NULL };
const char *const rmd_shutdown_action_names[] = { "default", "stop", "hold", "damp", "brake", NULL };
const char *const rmd_on_missing_names[] = { "refuse", "start", NULL };
const char *const rmd_feedback_pos_names[] = { "control", "multi_turn", NULL };
const char *const rmd_peer_lost_names[] = { "safe", "report", NULL };
_Static_assert(RMD_MODE_COUNT == 4, "rmd_mode_names[] follows enum rmd_mode");

void rmd_config_defaults(struct rmd_config *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	cfg->loop.rate_hz = RMD_CONFIG_DEFAULT_RATE_HZ;
	cfg->loop.rt_priority = RMD_CONFIG_DEFAULT_PRIORITY;
	cfg->loop.keep_cpus_awake = true;
	cfg->safety.comm_loss_ms = RMD_CONFIG_DEFAULT_COMM_LOSS_MS;
	cfg->safety.missed_replies_lost = RMD_CONFIG_DEFAULT_MISSED_LOST;
	cfg->safety.command_timeout_ms = RMD_CONFIG_DEFAULT_COMMAND_TIMEOUT_MS;
	cfg->safety.safe_action = RMD_SAFE_DAMP;
	cfg->safety.lost_motor_action = RMD_LOST_ALL;
	cfg->safety.shutdown_damp_ms = RMD_CONFIG_DEFAULT_SHUTDOWN_DAMP_MS;
	cfg->probe.on_missing = RMD_MISSING_REFUSE;
	cfg->probe.reply_timeout_ms = RMD_CONFIG_DEFAULT_PROBE_REPLY_TIMEOUT_MS;
	snprintf(cfg->lcm.url, sizeof(cfg->lcm.url), "%s", RMD_CONFIG_DEFAULT_LCM_URL);
	snprintf(cfg->lcm.channel_prefix, sizeof(cfg->lcm.channel_prefix), "%s",
		 RMD_CONFIG_DEFAULT_CHANNEL_PREFIX);
	cfg->lcm.state_every_n = 1;
	cfg->lcm.stale_ms = RMD_CONFIG_DEFAULT_STALE_MS;
	cfg->lcm.health_period_ms = RMD_CONFIG_DEFAULT_HEALTH_PERIOD_MS;
	cfg->lcm.rt_priority = RMD_CONFIG_LCM_PRIO_AUTO;
	cfg->robot.heartbeat_ms = RMD_CONFIG_DEFAULT_HEARTBEAT_MS;
	cfg->robot.peer_timeout_ms = RMD_CONFIG_DEFAULT_PEER_TIMEOUT_MS;
	cfg->robot.on_peer_lost = RMD_PEER_LOST_SAFE;
	cfg->robot.max_clock_offset_ms = RMD_CONFIG_DEFAULT_MAX_CLOCK_OFFSET_MS;
	cfg->incidents.enabled = true;
	cfg->incidents.seconds_before = RMD_CONFIG_DEFAULT_INCIDENT_BEFORE_S;
	cfg->incidents.seconds_after = RMD_CONFIG_DEFAULT_INCIDENT_AFTER_S;
	cfg->incidents.keep = RMD_CONFIG_DEFAULT_INCIDENT_KEEP;
	cfg->incidents.overrun_burst = RMD_CONFIG_DEFAULT_INCIDENT_OVERRUN_BURST;
}

void rmd_config_bus_defaults(struct rmd_config_bus *b)
{
	memset(b, 0, sizeof(*b));
	b->bitrate = RMD_CONFIG_DEFAULT_BITRATE;
	b->baud = RMD_CONFIG_DEFAULT_BAUD;
	b->turnaround_ns = RMD_CONFIG_DEFAULT_RS485_TURNAROUND_NS;
}

const char *rmd_config_proto_keys[RMD_PROTO_COUNT + 2];

__attribute__((constructor)) static void proto_keys_build(void)
{
	for (unsigned p = 0; p < RMD_PROTO_COUNT; p++)
		rmd_config_proto_keys[p] = rmd_proto_key((enum rmd_proto)p);
	rmd_config_proto_keys[RMD_PROTO_COUNT] = "auto";
}

void rmd_config_motor_defaults(struct rmd_config_motor *m)
{
	memset(m, 0, sizeof(*m));
	m->proto = RMD_PROTO_V3;
	m->mode = RMD_MODE_TORQUE;
	m->direction = 1;
	m->gear_ratio = 1.0;
	m->units = RMD_UNITS_OUTPUT;
	m->limits.position_min_rad = -INFINITY;
	m->limits.position_max_rad = INFINITY;
	m->limits.velocity_rad_s = INFINITY;
	m->limits.torque_nm = INFINITY;
	m->mit = rmd_mit_default_ranges;
	m->rate_divisor = 1;
	m->status_poll_hz = RMD_CONFIG_DEFAULT_STATUS_POLL_HZ;
	m->comm_loss_ms = RMD_CONFIG_COMM_LOSS_INHERIT;
}

int rmd_config_bus_find(const struct rmd_config *cfg, const char *name)
{
	for (unsigned i = 0; i < cfg->n_buses; i++)
		if (!strcmp(cfg->buses[i].name, name))
			return (int)i;
	return -ENOENT;
}

const char *rmd_config_bus_wire(const struct rmd_config_bus *b, bool *serial)
{
	switch (b->kind) {
	case RMD_BUS_KIND_SOCKETCAN:
		*serial = false;
		return b->interface;
	case RMD_BUS_KIND_RS485:
		*serial = true;
		return b->device;
	case RMD_BUS_KIND_SIM:
		break;
	}
	return NULL;
}

int rmd_config_motor_find(const struct rmd_config *cfg, const char *name)
{
	for (unsigned i = 0; i < cfg->n_motors; i++)
		if (!strcmp(cfg->motors[i].name, name))
			return (int)i;
	return -ENOENT;
}

const char *rmd_bus_kind_name(enum rmd_bus_kind kind)
{
	return (unsigned)kind < 3 ? rmd_bus_kind_names[kind] : "?";
}

const char *rmd_mode_name(enum rmd_mode mode)
{
	return (unsigned)mode < RMD_MODE_COUNT ? rmd_mode_names[mode] : "?";
}

const char *rmd_safe_action_name(enum rmd_safe_action action)
{
	return (unsigned)action < 4 ? rmd_safe_action_names[action] : "?";
}

/* What a file of mode `mode` is, for "is a FIFO, not a regular file". */
static const char *file_kind(mode_t mode)
{
	switch (mode & S_IFMT) {
	case S_IFDIR:
		return "a directory";
	case S_IFIFO:
		return "a FIFO";
	case S_IFCHR:
		return "a character device";
	case S_IFBLK:
		return "a block device";
	case S_IFSOCK:
		return "a socket";
	default:
		return "a special file";
	}
}

int rmd_config_file_read(const char *path, char **buf, size_t *len, unsigned *line, char *why,
			 size_t whylen)
{
	struct stat st;
	size_t got = 0;
	char *b, *nul;
	int fd, r;

	*buf = NULL;
	*len = 0;
	*line = 0;
	fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
	if (fd < 0) {
		r = -errno;
		snprintf(why, whylen, "cannot open: %s", strerror(-r));
		return r;
	}
	if (fstat(fd, &st) < 0) {
		r = -errno;
		snprintf(why, whylen, "cannot stat: %s", strerror(-r));
		goto err_close;
	}
	if (!S_ISREG(st.st_mode)) {
		r = S_ISDIR(st.st_mode) ? -EISDIR : -EINVAL;
		snprintf(why, whylen, "is %s, not a regular file", file_kind(st.st_mode));
		goto err_close;
	}
	if (st.st_size > RMD_CONFIG_FILE_MAX) {
		r = -EFBIG;
		snprintf(why, whylen,
			 "%lld bytes: larger than the limit of %s (%d bytes); configuration files "
			 "are a few kB",
			 (long long)st.st_size, RMD_CONFIG_FILE_MAX_TEXT, RMD_CONFIG_FILE_MAX);
		goto err_close;
	}
	/* one byte more than the limit tells a file that grew since fstat() */
	b = malloc(RMD_CONFIG_FILE_MAX + 2);
	if (!b) {
		r = -ENOMEM;
		snprintf(why, whylen, "out of memory");
		goto err_close;
	}
	while (got <= RMD_CONFIG_FILE_MAX) {
		ssize_t n = read(fd, b + got, RMD_CONFIG_FILE_MAX + 1 - got);

		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0) {
			r = -errno;
			snprintf(why, whylen, "read error: %s", strerror(-r));
			goto err_free;
		}
		if (n == 0)
			break;
		got += (size_t)n;
	}
	if (got > RMD_CONFIG_FILE_MAX) {
		r = -EFBIG;
		snprintf(why, whylen, "larger than the limit of %s (%d bytes)",
			 RMD_CONFIG_FILE_MAX_TEXT, RMD_CONFIG_FILE_MAX);
		goto err_free;
	}
	b[got] = '\0';
	nul = memchr(b, '\0', got);
	if (nul) {
		*line = 1;
		for (const char *p = b; p < nul; p++)
			*line += *p == '\n';
		r = -EILSEQ;
		snprintf(why, whylen, "a NUL byte: a configuration file is text");
		goto err_free;
	}
	close(fd);
	*buf = b;
	*len = got;
	return 0;

err_free:
	free(b);
err_close:
	close(fd);
	return r;
}
