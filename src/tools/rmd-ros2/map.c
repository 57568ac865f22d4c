// SPDX-License-Identifier: MIT
/*
 * rmd-ros2's translation between rmdd's LCM types and ROS 2's messages
 * (map.h).  Non-rt.
 */
#include "map.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/time.h"
#include "tools/common/names.h"

static const struct {
	const char *word;
	int mode;
	int bit;
} modes[] = {
	{ "position", RMD_COMMAND_T_MODE_POSITION, RMD_MOTOR_CONFIG_T_MODE_BIT_POSITION },
	{ "velocity", RMD_COMMAND_T_MODE_SPEED, RMD_MOTOR_CONFIG_T_MODE_BIT_SPEED },
	{ "effort", RMD_COMMAND_T_MODE_TORQUE, RMD_MOTOR_CONFIG_T_MODE_BIT_TORQUE },
};

#define N_MODES (sizeof(modes) / sizeof(modes[0]))

int ros2_mode_of(const char *word)
{
	for (size_t i = 0; i < N_MODES; i++)
		if (!strcmp(word, modes[i].word))
			return modes[i].mode;
	return -1;
}

const char *ros2_mode_word(int mode)
{
	for (size_t i = 0; i < N_MODES; i++)
		if (modes[i].mode == mode)
			return modes[i].word;
	return "?";
}

static int mode_bit(int mode)
{
	for (size_t i = 0; i < N_MODES; i++)
		if (modes[i].mode == mode)
			return modes[i].bit;
	return 0;
}

int ros2_map_config(struct ros2_map *map, const rmd_config_t *cfg, int mode, bool enable,
		    double max_jump, char *err, size_t size)
{
	memset(map, 0, sizeof(*map));
	map->mode = (int8_t)mode;
	map->enable = enable;
	map->max_jump = max_jump;
	if (cfg->motor_count < 0 || cfg->motor_count > ROS2_MAX_MOTORS) {
		snprintf(err, size, "config_t has %d motors (at most %d)", cfg->motor_count,
			 ROS2_MAX_MOTORS);
		return -EINVAL;
	}
	for (int i = 0; i < cfg->motor_count; i++) {
		const rmd_motor_config_t *mc = &cfg->motor[i];
		struct ros2_motor *m = &map->m[i];

		if (mc->index != i) {
			snprintf(err, size, "config_t motor %d has index %d", i, mc->index);
			return -EINVAL;
		}
		snprintf(m->name, sizeof(m->name), "%s", mc->name);
		m->modes = mc->modes;
		m->lifecycle = -1;
		m->position = NAN;
		if (!(mc->modes & mode_bit(mode))) {
			snprintf(err, size, "motor %s is not configured for mode %s (--mode)",
				 m->name, ros2_mode_word(mode));
			return -EINVAL;
		}
	}
	map->count = (unsigned)cfg->motor_count;
	return 0;
}

static int find_motor(const struct ros2_map *map, const char *name)
{
	for (unsigned i = 0; i < map->count; i++)
		if (!strcmp(map->m[i].name, name))
			return (int)i;
	return -1;
}

static int refuse(struct ros2_map *map, enum ros2_reject kind)
{
	map->rejected[kind]++;
	return -1 - (int)kind;
}

int ros2_map_take(struct ros2_map *map, const sensor_msgs_msg_dds__JointState_ *js, char *why,
		  size_t size)
{
	const dds_sequence_double *field = map->mode == RMD_COMMAND_T_MODE_POSITION ?
						   &js->position :
					   map->mode == RMD_COMMAND_T_MODE_SPEED ? &js->velocity :
										   &js->effort;
	int index[ROS2_MAX_MOTORS];
	bool seen[ROS2_MAX_MOTORS] = { false };
	uint32_t n = js->name._length;

	why[0] = '\0';
	if (!map->enable)
		return refuse(map, ROS2_REJ_DISABLED);
	if (n > map->count) {
		snprintf(why, size, "%" PRIu32 " names, rmdd has %u motors", n, map->count);
		return refuse(map, ROS2_REJ_NAME);
	}
	for (uint32_t i = 0; i < n; i++) {
		const char *name = js->name._buffer[i] ? js->name._buffer[i] : "";
		int k = find_motor(map, name);

		if (k < 0 || seen[k]) {
			snprintf(why, size, "name \"%.64s\": %s", name,
				 k < 0 ? "no motor of rmdd has it" : "named twice");
			return refuse(map, ROS2_REJ_NAME);
		}
		seen[k] = true;
		index[i] = k;
	}
	if (field->_length != n) {
		snprintf(why, size, "%" PRIu32 " names but %" PRIu32 " %s values", n,
			 field->_length, ros2_mode_word(map->mode));
		return refuse(map, ROS2_REJ_SHAPE);
	}
	for (uint32_t i = 0; i < n; i++) {
		if (!isfinite(field->_buffer[i])) {
			snprintf(why, size, "%s of %s is %g", ros2_mode_word(map->mode),
				 map->m[index[i]].name, field->_buffer[i]);
			return refuse(map, ROS2_REJ_NONFINITE);
		}
	}
	for (uint32_t i = 0; i < n && map->mode == RMD_COMMAND_T_MODE_POSITION; i++) {
		const struct ros2_motor *m = &map->m[index[i]];

		if (m->phase == ROS2_IDLE &&
		    !(fabs(field->_buffer[i] - m->position) <= map->max_jump)) {
			snprintf(why, size,
				 "position %g of %s, which is at %g: more than %g rad away",
				 field->_buffer[i], m->name, m->position, map->max_jump);
			return refuse(map, ROS2_REJ_JUMP);
		}
	}
	for (uint32_t i = 0; i < n; i++) {
		struct ros2_motor *m = &map->m[index[i]];

		m->setpoint = field->_buffer[i];
		if (m->phase == ROS2_IDLE)
			m->phase = ROS2_ENABLING;
	}
	map->accepted++;
	return 1;
}

void ros2_map_state(struct ros2_map *map, const rmd_state_t *st)
{
	for (int i = 0; i < st->count && i < (int)map->count; i++) {
		struct ros2_motor *m = &map->m[i];
		int8_t lc = st->motor[i].lifecycle;

		m->lifecycle = lc;
		m->position = st->motor[i].position;
		if (m->phase == ROS2_RUNNING && lc == RMD_STATE_T_LC_ENABLED)
			m->seen_enabled = true;
		if (m->phase == ROS2_RUNNING && m->seen_enabled && lc != RMD_STATE_T_LC_ENABLED) {
			m->phase = ROS2_STOPPED;
			map->stopped_new++;
		}
	}
}

static void entry(rmd_motor_command_t *e, unsigned index, int mode, bool enable, double setpoint)
{
	memset(e, 0, sizeof(*e));
	e->index = (int16_t)index;
	e->mode = (int8_t)mode;
	e->enable = enable;
	if (!enable)
		return;
	if (mode == RMD_COMMAND_T_MODE_POSITION)
		e->position = setpoint;
	else if (mode == RMD_COMMAND_T_MODE_SPEED)
		e->velocity = setpoint;
	else
		e->torque = setpoint;
}

/*
 * ENABLING goes RUNNING here, not in ros2_map_state(): only once a command
 * with its enable = 0 went out and a state_t after it says READY.
 */
unsigned ros2_map_command(struct ros2_map *map, rmd_motor_command_t *e)
{
	unsigned n = 0;

	for (unsigned i = 0; i < map->count; i++) {
		struct ros2_motor *m = &map->m[i];

		switch (m->phase) {
		case ROS2_IDLE:
			break;
		case ROS2_ENABLING:
			entry(&e[n++], i, map->mode, false, 0);
			if (m->lifecycle == RMD_STATE_T_LC_READY)
				m->phase = ROS2_RUNNING;
			break;
		case ROS2_RUNNING:
			entry(&e[n++], i, map->mode, true, m->setpoint);
			break;
		case ROS2_STOPPED:
			entry(&e[n++], i, map->mode, false, 0);
			break;
		}
	}
	return n;
}

unsigned ros2_map_release(struct ros2_map *map, rmd_motor_command_t *e)
{
	unsigned n = 0;

	for (unsigned i = 0; i < map->count; i++) {
		if (map->m[i].phase == ROS2_IDLE)
			continue;
		map->m[i].phase = ROS2_STOPPED;
		entry(&e[n++], i, map->mode, false, 0);
	}
	return n;
}

void ros2_stamp(builtin_interfaces_msg_dds__Time_ *t, int64_t mono_ns, int64_t realtime_offset_ns)
{
	int64_t ns = mono_ns + realtime_offset_ns;

	if (ns < 0)
		ns = 0;
	t->sec = (int32_t)(ns / RMD_NS_PER_S);
	t->nanosec = (uint32_t)(ns % RMD_NS_PER_S);
}

/* A Cyclone DDS sequence (any element type: they share the four fields) lent n of buf. */
#define SEQ_LEND(seq, buf, n)           \
	do {                            \
		(seq)._buffer = (buf);  \
		(seq)._length = (n);    \
		(seq)._maximum = (n);   \
		(seq)._release = false; \
	} while (0)

void ros2_joint_state(const struct ros2_map *map, const rmd_state_t *st, int64_t realtime_offset_ns,
		      struct ros2_js_buf *buf, sensor_msgs_msg_dds__JointState_ *js)
{
	uint32_t n = 0;

	memset(js, 0, sizeof(*js));
	for (int i = 0; i < st->count && i < (int)map->count; i++, n++) {
		const rmd_motor_state_t *ms = &st->motor[i];

		buf->names[n] = (char *)map->m[i].name;
		buf->position[n] = ms->position;
		buf->velocity[n] = ms->velocity;
		buf->effort[n] = ms->torque;
	}
	ros2_stamp(&js->header.stamp, st->utime * RMD_NS_PER_US, realtime_offset_ns);
	js->header.frame_id = (char *)"";
	SEQ_LEND(js->name, buf->names, n);
	SEQ_LEND(js->position, buf->position, n);
	SEQ_LEND(js->velocity, buf->velocity, n);
	SEQ_LEND(js->effort, buf->effort, n);
}

/* One key/value of status s. */
static void kv(struct ros2_diag_buf *buf, unsigned s, const char *key, const char *fmt, ...)
	__attribute__((format(printf, 4, 5)));

static void kv(struct ros2_diag_buf *buf, unsigned s, const char *key, const char *fmt, ...)
{
	diagnostic_msgs_msg_dds__DiagnosticStatus_ *st = &buf->status[s];
	uint32_t k = st->values._length;
	va_list ap;

	if (k >= ROS2_DIAG_VALUES)
		return;
	snprintf(buf->text[s][k][0], sizeof(buf->text[s][k][0]), "%s", key);
	va_start(ap, fmt);
	vsnprintf(buf->text[s][k][1], sizeof(buf->text[s][k][1]), fmt, ap);
	va_end(ap);
	buf->kv[s][k].key = buf->text[s][k][0];
	buf->kv[s][k].value = buf->text[s][k][1];
	st->values._length = k + 1;
	st->values._maximum = k + 1;
}

static uint8_t motor_level(int lc)
{
	switch (lc) {
	case RMD_STATE_T_LC_READY:
	case RMD_STATE_T_LC_ENABLED:
		return ROS2_DIAG_OK;
	case RMD_STATE_T_LC_FAULT:
	case RMD_STATE_T_LC_LOST:
		return ROS2_DIAG_ERROR;
	case -1:
		return ROS2_DIAG_STALE;
	default:
		return ROS2_DIAG_WARN;
	}
}

static const char *phase_word(enum ros2_phase p)
{
	switch (p) {
	case ROS2_IDLE:
		return "idle";
	case ROS2_ENABLING:
		return "enabling";
	case ROS2_RUNNING:
		return "running";
	case ROS2_STOPPED:
		return "stopped";
	}
	return "?";
}

void ros2_diagnostics(const struct ros2_map *map, const rmd_config_t *cfg, const rmd_health_t *h,
		      const rmd_state_t *st, int64_t realtime_offset_ns, struct ros2_diag_buf *buf,
		      diagnostic_msgs_msg_dds__DiagnosticArray_ *da)
{
	diagnostic_msgs_msg_dds__DiagnosticStatus_ *d = &buf->status[0];
	uint8_t level = ROS2_DIAG_OK;
	unsigned n = 1;

	memset(da, 0, sizeof(*da));
	memset(buf->status, 0, sizeof(buf->status));
	for (unsigned s = 0; s <= ROS2_MAX_MOTORS; s++)
		buf->status[s].values._buffer = buf->kv[s];
	if (h->watchdog == RMD_HEALTH_T_WD_TRIPPED)
		level = ROS2_DIAG_WARN;
	for (int b = 0; b < h->bus_count && b < RMD_HEALTH_T_MAX_BUSES; b++) {
		uint8_t bl = h->bus[b].state >= RMD_BUS_HEALTH_T_BUS_PASSIVE ? ROS2_DIAG_ERROR :
			     h->bus[b].state == RMD_BUS_HEALTH_T_BUS_WARNING ? ROS2_DIAG_WARN :
									       ROS2_DIAG_OK;

		if (bl > level)
			level = bl;
	}
	d->level = level;
	snprintf(buf->name[0], sizeof(buf->name[0]), "rmdd");
	snprintf(buf->message[0], sizeof(buf->message[0]), "watchdog %s, %d buses",
		 tool_watchdog_name((unsigned)h->watchdog), h->bus_count);
	snprintf(buf->hwid[0], sizeof(buf->hwid[0]), "%s pid %d", h->host, h->pid);
	d->name = buf->name[0];
	d->message = buf->message[0];
	d->hardware_id = buf->hwid[0];
	kv(buf, 0, "cycles", "%" PRId64, h->cycles);
	kv(buf, 0, "overruns", "%" PRId64, h->overruns);
	kv(buf, 0, "wake_p99_us", "%.1f", h->wake_p99_us);
	kv(buf, 0, "safe_action_events", "%" PRId64, h->safe_action_events);
	kv(buf, 0, "commands_accepted", "%" PRId64, h->commands_accepted);
	kv(buf, 0, "commands_rejected", "%" PRId64, h->commands_rejected);
	kv(buf, 0, "ros_commands_accepted", "%" PRId64, map->accepted);
	kv(buf, 0, "ros_rejected_name", "%" PRId64, map->rejected[ROS2_REJ_NAME]);
	kv(buf, 0, "ros_rejected_shape", "%" PRId64, map->rejected[ROS2_REJ_SHAPE]);
	kv(buf, 0, "ros_rejected_nonfinite", "%" PRId64, map->rejected[ROS2_REJ_NONFINITE]);
	kv(buf, 0, "ros_rejected_disabled", "%" PRId64, map->rejected[ROS2_REJ_DISABLED]);
	kv(buf, 0, "ros_rejected_jump", "%" PRId64, map->rejected[ROS2_REJ_JUMP]);
	for (unsigned i = 0; i < map->count; i++, n++) {
		const struct ros2_motor *m = &map->m[i];
		const rmd_motor_state_t *ms = st && (int)i < st->count ? &st->motor[i] : NULL;
		int lc = ms ? ms->lifecycle : -1;

		d = &buf->status[n];
		d->level = motor_level(lc);
		snprintf(buf->name[n], sizeof(buf->name[n]), "rmdd/%s", m->name);
		snprintf(buf->message[n], sizeof(buf->message[n]), "%s, ros %s",
			 lc < 0 ? "no state yet" : tool_lifecycle_name((unsigned)lc),
			 phase_word(m->phase));
		if (cfg && (int)i < cfg->motor_count && cfg->motor[i].bus >= 0 &&
		    cfg->motor[i].bus < cfg->bus_count)
			snprintf(buf->hwid[n], sizeof(buf->hwid[n]), "%.24s id %d",
				 cfg->bus[cfg->motor[i].bus].name, cfg->motor[i].id);
		else
			buf->hwid[n][0] = '\0';
		d->name = buf->name[n];
		d->message = buf->message[n];
		d->hardware_id = buf->hwid[n];
		if (!ms)
			continue;
		kv(buf, n, "lifecycle", "%s", tool_lifecycle_name((unsigned)lc));
		kv(buf, n, "temperature_c", "%.1f", ms->temperature);
		kv(buf, n, "voltage_v", "%.2f", ms->voltage);
		kv(buf, n, "error_code", "0x%" PRIx32, (uint32_t)ms->error_code);
		kv(buf, n, "position_certain", "%s", ms->position_certain ? "true" : "false");
		kv(buf, n, "missed_replies", "%" PRId64, ms->missed_replies);
	}
	ros2_stamp(&da->header.stamp, h->utime * RMD_NS_PER_US, realtime_offset_ns);
	da->header.frame_id = (char *)"";
	SEQ_LEND(da->status, buf->status, n);
}
