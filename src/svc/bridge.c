// SPDX-License-Identifier: MIT
/*
 * The LCM bridge thread: commands in (decode, validate, clamp, hand over),
 * state, health and configuration out.  See rmd/bridge.h and docs/lcm.md.
 */
#define _GNU_SOURCE /* pthread_setname_np */

#include <ctype.h>
#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>

#include "rmd/time.h"
#include "rmd/thread.h"
#include "rmd/bridge.h"
#include "rmd/lcm_link.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_home_t.h"
#include "rmd/rmd_motor_config_t.h"
#include "rmd/rmd_state_t.h"

/* The LCM constants are the C enums' values (lcm_types/ and rmd/state.h, rmd/bus.h). */
_Static_assert(RMD_COMMAND_T_MAX_MOTORS == RMD_MAX_MOTORS &&
		       RMD_STATE_T_MAX_MOTORS == RMD_MAX_MOTORS &&
		       RMD_HEALTH_T_MAX_BUSES == RMD_MAX_BUSES,
	       "array sizes");
_Static_assert(RMD_COMMAND_T_MODE_TORQUE == RMD_MODE_TORQUE &&
		       RMD_COMMAND_T_MODE_SPEED == RMD_MODE_SPEED &&
		       RMD_COMMAND_T_MODE_POSITION == RMD_MODE_POSITION &&
		       RMD_COMMAND_T_MODE_MIT == RMD_MODE_MIT && RMD_MODE_COUNT == 4,
	       "modes");
_Static_assert(RMD_STATE_T_LC_PROBE == RMD_LC_PROBE && RMD_STATE_T_LC_READY == RMD_LC_READY &&
		       RMD_STATE_T_LC_ENABLED == RMD_LC_ENABLED &&
		       RMD_STATE_T_LC_FAULT == RMD_LC_FAULT && RMD_STATE_T_LC_LOST == RMD_LC_LOST &&
		       RMD_STATE_T_LC_SAFE == RMD_LC_SAFE &&
		       RMD_STATE_T_LC_STOPPING == RMD_LC_STOPPING && RMD_LC_COUNT == 7,
	       "lifecycle");
_Static_assert(RMD_STATE_T_POS_UNKNOWN == RMD_POS_UNKNOWN &&
		       RMD_STATE_T_POS_AMBIGUOUS == RMD_POS_AMBIGUOUS &&
		       RMD_STATE_T_POS_OUTSIDE == RMD_POS_OUTSIDE &&
		       RMD_STATE_T_POS_SAVED == RMD_POS_SAVED &&
		       RMD_STATE_T_POS_IN_BAND == RMD_POS_IN_BAND &&
		       RMD_STATE_T_POS_HOMED == RMD_POS_HOMED && RMD_POS_TRUST_COUNT == 6,
	       "position trust");
_Static_assert(RMD_HEALTH_T_WD_IDLE == RMD_WD_IDLE && RMD_HEALTH_T_WD_OK == RMD_WD_OK &&
		       RMD_HEALTH_T_WD_TRIPPED == RMD_WD_TRIPPED,
	       "watchdog");
_Static_assert(RMD_HEALTH_T_REJ_DECODE == RMD_REJ_DECODE &&
		       RMD_HEALTH_T_REJ_COUNT == RMD_REJ_COUNT &&
		       RMD_HEALTH_T_REJ_INDEX == RMD_REJ_INDEX &&
		       RMD_HEALTH_T_REJ_NONFINITE == RMD_REJ_NONFINITE &&
		       RMD_HEALTH_T_REJ_MODE == RMD_REJ_MODE &&
		       RMD_HEALTH_T_REJ_LIMIT == RMD_REJ_LIMIT &&
		       RMD_HEALTH_T_REJ_STALE == RMD_REJ_STALE &&
		       RMD_HEALTH_T_REJ_OWNER == RMD_REJ_OWNER &&
		       RMD_HEALTH_T_REJ_KINDS == RMD_REJ_KINDS,
	       "reject kinds");
_Static_assert(RMD_HEALTH_T_IGN_EDGE == RMD_IGN_EDGE &&
		       RMD_HEALTH_T_IGN_NOT_READY == RMD_IGN_NOT_READY &&
		       RMD_HEALTH_T_IGN_TRIPPED == RMD_IGN_TRIPPED &&
		       RMD_HEALTH_T_IGN_POS_UNCERTAIN == RMD_IGN_POS_UNCERTAIN &&
		       RMD_HEALTH_T_IGN_KINDS == RMD_IGN_KINDS,
	       "ignore kinds");
_Static_assert(RMD_BUS_HEALTH_T_BUS_ACTIVE == RMD_BUS_ACTIVE &&
		       RMD_BUS_HEALTH_T_BUS_WARNING == RMD_BUS_WARNING &&
		       RMD_BUS_HEALTH_T_BUS_PASSIVE == RMD_BUS_PASSIVE &&
		       RMD_BUS_HEALTH_T_BUS_OFF == RMD_BUS_OFF &&
		       RMD_BUS_HEALTH_T_BUS_NO_ACK == RMD_BUS_NO_ACK,
	       "bus states");
_Static_assert(RMD_MOTOR_CONFIG_T_MODE_BIT_MIT == RMD_BRIDGE_MODE_BIT(RMD_MODE_MIT) &&
		       RMD_MOTOR_CONFIG_T_MODE_BIT_TORQUE == RMD_BRIDGE_MODE_BIT(RMD_MODE_TORQUE),
	       "mode bits");

/* Messages handled per wake-up at most, so the health timer is never starved. */
#define DRAIN_MAX 4096

/* Not udpm: queued messages LCM keeps for us before it drops (its default is 30). */
#define COMMAND_QUEUE 4096

/* config_t answers a flood of CONFIG_REQUESTs at most this often (each allocates). */
#define CONFIG_INTERVAL_NS (100 * RMD_NS_PER_MS)

/* Room for one encoded state_t or health_t (at most about 2.7 KiB and 1.7 KiB). */
#define ENC_MAX 8192

struct rmd_bridge_buf {
	rmd_command_t msg;
	rmd_motor_command_t msg_motor[RMD_MAX_MOTORS]; /* msg.motor: decoded in place */
	struct rmd_command cmd;
	rmd_state_t state;
	rmd_motor_state_t state_motor[RMD_MAX_MOTORS]; /* state.motor */
	rmd_health_t health;
	int8_t health_cl[RMD_MAX_MOTORS]; /* health_t's per-motor arrays */
	int32_t health_cl_ms[RMD_MAX_MOTORS];
	int64_t health_unarmed[RMD_MAX_MOTORS];
	char bus_name[RMD_MAX_BUSES][RMD_BRIDGE_NAME_LEN];
	rmd_config_t config;
	/* the newest config_t as published, for rmd_bridge_config_copy(); under config_mu */
	unsigned char config_enc[ENC_MAX];
	int config_len;
	rmd_bus_config_t config_bus[RMD_MAX_BUSES];
	rmd_motor_config_t config_motor[RMD_MAX_MOTORS];
	unsigned char enc[ENC_MAX];
};

static const char *const reject_names[RMD_REJ_KINDS] = {
	[RMD_REJ_DECODE] = "decode",	   [RMD_REJ_COUNT] = "count", [RMD_REJ_INDEX] = "index",
	[RMD_REJ_NONFINITE] = "nonfinite", [RMD_REJ_MODE] = "mode",   [RMD_REJ_LIMIT] = "limit",
	[RMD_REJ_STALE] = "stale",	   [RMD_REJ_OWNER] = "owner",
};

static const char *const mode_names[RMD_MODE_COUNT] = {
	[RMD_MODE_TORQUE] = "torque",
	[RMD_MODE_SPEED] = "speed",
	[RMD_MODE_POSITION] = "position",
	[RMD_MODE_MIT] = "mit",
};

const char *rmd_bridge_reject_name(enum rmd_reject kind)
{
	return (unsigned)kind < RMD_REJ_KINDS ? reject_names[kind] : "?";
}

static void count(atomic_uint_fast64_t *c)
{
	atomic_fetch_add_explicit(c, 1, memory_order_relaxed);
}

static uint64_t read_count(atomic_uint_fast64_t *c)
{
	return atomic_load_explicit(c, memory_order_relaxed);
}

/* One message to the caller's log sink, at syslog level `level`. */
__attribute__((format(printf, 3, 4))) static void logf_(struct rmd_bridge *b, int level,
							const char *fmt, ...)
{
	char msg[512];
	va_list ap;

	if (!b->opts.log)
		return;
	va_start(ap, fmt);
	vsnprintf(msg, sizeof(msg), fmt, ap);
	va_end(ap);
	b->opts.log(b->opts.log_ctx, level, msg);
}

void rmd_bridge_opts_init(struct rmd_bridge_opts *opts)
{
	memset(opts, 0, sizeof(*opts));
	snprintf(opts->url, sizeof(opts->url), "%s", RMD_CONFIG_DEFAULT_LCM_URL);
	snprintf(opts->prefix, sizeof(opts->prefix), "%s", RMD_CONFIG_DEFAULT_CHANNEL_PREFIX);
	opts->period_ns = 1000000;
	opts->state_every = 1;
	opts->stale_ms = RMD_CONFIG_DEFAULT_STALE_MS;
	opts->command_timeout_ms = RMD_CONFIG_DEFAULT_COMMAND_TIMEOUT_MS;
	opts->health_period_ns = (int64_t)RMD_CONFIG_DEFAULT_HEALTH_PERIOD_MS * RMD_NS_PER_MS;
	opts->poll_ns = RMD_BRIDGE_DEFAULT_POLL_NS;
	opts->notify_fd = -1;
}

/* ---- validation of one command message --------------------------------- */

static const char *motor_name(const struct rmd_bridge *b, unsigned i)
{
	return b->opts.motor[i].name;
}

/*
 * Count a rejection and log the first of its kind.  Returns kind, so the
 * checks read `return reject(...)`.
 */
__attribute__((format(printf, 3, 4))) static int reject(struct rmd_bridge *b, enum rmd_reject kind,
							const char *fmt, ...)
{
	char why[200];
	va_list ap;

	count(&b->n_rejected[kind]);
	if (b->logged & (1u << kind))
		return kind;
	b->logged |= 1u << kind;
	va_start(ap, fmt);
	vsnprintf(why, sizeof(why), fmt, ap);
	va_end(ap);
	logf_(b, 4, "rejected %s: %s; further rejections of this kind are counted in health_t",
	      b->ch_command, why);
	return kind;
}

static void list_modes(unsigned modes, char *buf, size_t len)
{
	size_t n = 0;

	buf[0] = '\0';
	for (unsigned m = 0; m < RMD_MODE_COUNT; m++)
		if (modes & RMD_BRIDGE_MODE_BIT(m) && n < len)
			n += snprintf(buf + n, len - n, "%s%s", n ? ", " : "", mode_names[m]);
}

/* The structural rules: count, indices, modes, finite values, gain ranges. */
static int check_entries(struct rmd_bridge *b, const rmd_command_t *msg)
{
	unsigned n = b->opts.nmotors, seen = 0;

	if (msg->count < 0 || msg->count > RMD_MAX_MOTORS || (unsigned)msg->count > n)
		return reject(b, RMD_REJ_COUNT,
			      "motor count %d out of range (0..%u configured motors)", msg->count,
			      n);
	for (int k = 0; k < msg->count; k++) {
		const rmd_motor_command_t *e = &msg->motor[k];
		const struct rmd_motor_info *m;
		const char *bad = NULL;
		double bad_v = 0;

		if (e->index < 0 || (unsigned)e->index >= n)
			return reject(b, RMD_REJ_INDEX, "motor index %d out of range (0..%u)",
				      e->index, n - 1);
		if (seen & (1u << e->index))
			return reject(b, RMD_REJ_INDEX, "motor index %d (%s) appears twice",
				      e->index, motor_name(b, e->index));
		seen |= 1u << e->index;
		m = &b->opts.motor[e->index];
		if (e->enable != 0 && e->enable != 1)
			return reject(b, RMD_REJ_MODE, "motor %d (%s): enable %d is not 0 or 1",
				      e->index, m->name, e->enable);
		if (e->mode < 0 || e->mode >= RMD_MODE_COUNT)
			return reject(b, RMD_REJ_MODE,
				      "motor %d (%s): unknown mode %d (0 torque, 1 speed, "
				      "2 position, 3 mit)",
				      e->index, m->name, e->mode);
		if (e->enable && !(m->modes & RMD_BRIDGE_MODE_BIT(e->mode))) {
			char allowed[64];

			list_modes(m->modes, allowed, sizeof(allowed));
			return reject(b, RMD_REJ_MODE, "motor %d (%s): mode %s not allowed (%s)",
				      e->index, m->name, mode_names[e->mode], allowed);
		}
		if (!isfinite(e->position))
			bad = "position", bad_v = e->position;
		else if (!isfinite(e->velocity))
			bad = "velocity", bad_v = e->velocity;
		else if (!isfinite(e->torque))
			bad = "torque", bad_v = e->torque;
		else if (!isfinite(e->kp))
			bad = "kp", bad_v = e->kp;
		else if (!isfinite(e->kd))
			bad = "kd", bad_v = e->kd;
		else if (!isfinite(e->max_velocity))
			bad = "max_velocity", bad_v = e->max_velocity;
		if (bad)
			return reject(b, RMD_REJ_NONFINITE, "motor %d (%s): %s is %f", e->index,
				      m->name, bad, bad_v);
		if (e->max_velocity < 0)
			return reject(b, RMD_REJ_LIMIT, "motor %d (%s): max_velocity %g < 0",
				      e->index, m->name, e->max_velocity);
		if (e->mode == RMD_MODE_MIT && (e->kp < m->kp_min || e->kp > m->kp_max))
			return reject(b, RMD_REJ_LIMIT,
				      "motor %d (%s): kp %g outside the MIT range %g..%g", e->index,
				      m->name, e->kp, m->kp_min, m->kp_max);
		if (e->mode == RMD_MODE_MIT && (e->kd < m->kd_min || e->kd > m->kd_max))
			return reject(b, RMD_REJ_LIMIT,
				      "motor %d (%s): kd %g outside the MIT range %g..%g", e->index,
				      m->name, e->kd, m->kd_min, m->kd_max);
	}
	return -1;
}

/*
 * A controller's stamps differ from the newest accepted one by at most this
 * in normal operation; a stamp further away, either way, is a clock jump or a
 * bad stamp (docs/lcm.md, "stale").
 */
#define UTIME_JUMP_US (10 * INT64_C(1000000))

/* a - b, saturated to the int64_t range instead of overflowing. */
static int64_t sub_sat(int64_t a, int64_t b)
{
	int64_t d;

	if (__builtin_sub_overflow(a, b, &d))
		return a < b ? INT64_MIN : INT64_MAX;
	return d;
}

static bool utime_far(int64_t a, int64_t b, int64_t limit_us)
{
	int64_t d = sub_sat(a, b);

	return d > limit_us || d < -limit_us;
}

/*
 * Sequence and timestamp against the newest accepted command.  A stamp more
 * than UTIME_JUMP_US (and stale_ms) from the reference is refused without
 * becoming the reference; a second such stamp near the first one makes it
 * the reference.  So one bad datagram costs at most one good command, and a
 * bad reference (the first stamp after seq 0) is replaced by the next two.
 */
static int check_order(struct rmd_bridge *b, const rmd_command_t *msg)
{
	int64_t stale_us = (int64_t)b->opts.stale_ms * 1000;
	int64_t jump_us = stale_us > UTIME_JUMP_US ? stale_us : UTIME_JUMP_US;
	int64_t age_us;

	if (msg->seq == 0) {
		b->have_utime_jump = false;
		return -1; /* a (re)starting controller */
	}
	if (b->have_seq && msg->seq < b->last_seq)
		return reject(b, RMD_REJ_STALE,
			      "seq %" PRId64 " went back (newest accepted %" PRId64 "; 0 restarts)",
			      msg->seq, b->last_seq);
	if (stale_us <= 0 || msg->utime == 0 || !b->have_utime)
		return -1;
	if (utime_far(msg->utime, b->newest_utime, jump_us)) {
		if (b->have_utime_jump && !utime_far(msg->utime, b->utime_jump, jump_us)) {
			/* the controller's clock did jump: follow it */
			b->have_utime_jump = false;
			b->newest_utime = msg->utime;
			return -1;
		}
		b->have_utime_jump = true;
		b->utime_jump = msg->utime;
		return reject(b, RMD_REJ_STALE,
			      "utime %" PRId64 " is more than %" PRId64
			      " s from the newest accepted "
			      "%" PRId64 ": a clock jump or a bad stamp (a second stamp near it "
			      "is accepted)",
			      msg->utime, jump_us / 1000000, b->newest_utime);
	}
	b->have_utime_jump = false;
	age_us = b->newest_utime - msg->utime; /* no overflow: |age| <= jump_us */
	if (age_us > stale_us)
		return reject(b, RMD_REJ_STALE,
			      "utime %" PRId64 " is %" PRId64 " ms older than the newest "
			      "accepted command (limit %d ms)",
			      msg->utime, age_us / 1000, b->opts.stale_ms);
	return -1;
}

/* The first clamp of a command, for the log line. */
struct clamp_note {
	bool any;
	int motor;
	struct rmd_motor_clamp_note what;
};

/* Fill the hand-over from a message that passed every check; clamp as rmd/motor.h says. */
static void fill_command(struct rmd_bridge *b, const rmd_command_t *msg, struct rmd_command *cmd,
			 struct clamp_note *note)
{
	memset(cmd, 0, sizeof(*cmd));
	cmd->stamp_us = msg->utime;
	cmd->seq = msg->seq;
	for (int k = 0; k < msg->count; k++) {
		const rmd_motor_command_t *e = &msg->motor[k];
		const struct rmd_motor_info *m = &b->opts.motor[e->index];
		const struct rmd_config_limits lim = {
			.position_min_rad = m->pos_min_rad,
			.position_max_rad = m->pos_max_rad,
			.velocity_rad_s = m->vel_max_rad_s,
			.torque_nm = m->torque_max_nm,
		};
		struct rmd_setpoint *sp = &cmd->m[e->index];
		struct rmd_motor_clamp_note what;

		cmd->present |= 1u << e->index;
		sp->enable = e->enable;
		sp->mode = (uint8_t)e->mode;
		/* what the mode uses; the rest stays 0 */
		if (rmd_mode_uses_pos(sp->mode))
			sp->pos_rad = e->position;
		if (rmd_mode_uses_vel(sp->mode))
			sp->vel_rad_s = e->velocity;
		if (rmd_mode_uses_torque(sp->mode))
			sp->torque_nm = e->torque;
		if (sp->mode == RMD_MODE_MIT) {
			sp->kp = e->kp;
			sp->kd = e->kd;
		}
		if (sp->mode == RMD_MODE_POSITION)
			sp->max_vel_rad_s = e->max_velocity;
		if (rmd_motor_clamp(&lim, sp, &what) && !note->any)
			*note = (struct clamp_note){ true, e->index, what };
	}
}

/*
 * Decode a command_t in place (msg->motor is the bridge's own array: no
 * allocation, and a count beyond MAX_MOTORS is refused before any entry is
 * read).  Returns -1, or the kind it was rejected for.
 */
static int decode_command(struct rmd_bridge *b, const struct rmd_lcm_msg *m, rmd_command_t *msg)
{
	const void *d = m->data;
	int max = (int)m->size, pos = 0, r = 0;
	int64_t hash = 0, want = __rmd_command_t_get_hash();

	memset(msg, 0, sizeof(*msg));
	msg->motor = b->buf->msg_motor;
	if (m->size < 8)
		return reject(b, RMD_REJ_DECODE, "%u bytes: too short for any LCM type",
			      (unsigned)m->size);
	pos += __int64_t_decode_array(d, pos, max - pos, &hash, 1);
	if (hash != want)
		return reject(b, RMD_REJ_DECODE,
			      "not an rmd.command_t (fingerprint %016" PRIx64
			      ", expected %016" PRIx64 ")",
			      (uint64_t)hash, (uint64_t)want);
#define FIELD(fn, p)                             \
	if (r >= 0) {                            \
		r = fn(d, pos, max - pos, p, 1); \
		pos += r > 0 ? r : 0;            \
	}
	FIELD(__int64_t_decode_array, &msg->utime);
	FIELD(__int64_t_decode_array, &msg->seq);
	FIELD(__int64_t_decode_array, &msg->controller);
	FIELD(__boolean_decode_array, &msg->takeover);
	FIELD(__int16_t_decode_array, &msg->count);
#undef FIELD
	if (r >= 0 && (msg->count < 0 || msg->count > RMD_MAX_MOTORS))
		return check_entries(b, msg); /* the count rule, before any entry is read */
	if (r >= 0)
		r = __rmd_motor_command_t_decode_array(d, pos, max - pos, msg->motor, msg->count);
	if (r < 0) {
		if (msg->count < 0 || msg->count > RMD_MAX_MOTORS)
			msg->count = 0;
		return reject(b, RMD_REJ_DECODE, "truncated: %u bytes, an rmd.command_t has %d",
			      (unsigned)m->size, rmd_command_t_encoded_size(msg));
	}
	pos += r;
	if (pos != max)
		return reject(b, RMD_REJ_DECODE, "%u bytes after the end of an rmd.command_t",
			      (unsigned)(max - pos));
	return -1;
}

/*
 * One controller at a time (docs/lcm.md): a command from another
 * controller than the owner is rejected, unless it takes the motors over.
 * Silence does not end ownership (the watchdog makes the motors SAFE, and
 * they wait for their owner), and free motors that had an owner are
 * enabled only by the controller that released them or one that sent
 * enable = 0 since: a controller rejected while another drove never
 * inherits the motors by waiting.  at: when the command arrived
 * (arrival_ns()).  Returns -1 or RMD_REJ_OWNER.  Bridge thread.
 */
static int check_owner(struct rmd_bridge *b, const rmd_command_t *msg, int64_t at)
{
	bool enables = false;

	if (b->owned && msg->controller == b->owner)
		return -1;
	if (!b->owned) {
		for (int k = 0; k < msg->count; k++)
			enables |= msg->motor[k].enable != 0;
		if (!enables || !b->had_owner || msg->controller == b->next_owner)
			return -1;
	}
	if (msg->takeover) {
		logf_(b, 4,
		      "%s: controller %016" PRIx64
		      " takes the motors over from controller %016" PRIx64,
		      b->ch_command, (uint64_t)msg->controller,
		      (uint64_t)(b->owned ? b->owner : b->next_owner));
		count(&b->n_takeovers);
		b->owned = true;
		b->owner = msg->controller;
		b->owner_on = 0;
		atomic_store_explicit(&b->pub_owner, b->owner, memory_order_relaxed);
		atomic_store_explicit(&b->pub_owned, true, memory_order_relaxed);
		return -1;
	}
	/* a new intruder is an incident (rmdd's recorder) */
	if (b->opts.on_intruder &&
	    atomic_load_explicit(&b->pub_intruder, memory_order_relaxed) != msg->controller)
		b->opts.on_intruder(b->opts.intruder_ctx, at, msg->controller,
				    b->owned ? b->owner : b->next_owner);
	atomic_store_explicit(&b->pub_intruder, msg->controller, memory_order_relaxed);
	if (!b->owned)
		return reject(b, RMD_REJ_OWNER,
			      "controller %016" PRIx64 ": the motors were released by controller "
			      "%016" PRIx64 "; another controller sends enable = 0 first, then "
			      "enable = 1 (docs/lcm.md)",
			      (uint64_t)msg->controller, (uint64_t)b->next_owner);
	return reject(b, RMD_REJ_OWNER,
		      "controller %016" PRIx64 ": the motors are owned by controller %016" PRIx64
		      " (a supervisor takes them over with takeover = true: docs/lcm.md)",
		      (uint64_t)msg->controller, (uint64_t)b->owner);
}

/*
 * An accepted command: who owns the motors now (said in state_t and
 * health_t, not logged: a controller's start and end are routine), and the
 * enable = 0 counts.  Bridge thread.
 */
static void note_accepted(struct rmd_bridge *b, const rmd_command_t *msg)
{
	uint32_t on = 0, off = 0;

	for (int k = 0; k < msg->count; k++) {
		const rmd_motor_command_t *e = &msg->motor[k];

		if (e->enable) {
			on |= 1u << e->index;
		} else {
			off |= 1u << e->index;
			b->disables[e->index]++;
		}
	}
	if (!b->owned && on) {
		b->owned = true;
		b->owner = msg->controller;
		b->owner_on = 0;
		atomic_store_explicit(&b->pub_owner, b->owner, memory_order_relaxed);
		atomic_store_explicit(&b->pub_owned, true, memory_order_relaxed);
	} else if (!b->owned && off) {
		b->next_owner = msg->controller; /* it meant it: it may enable next */
	}
	if (!b->owned || msg->controller != b->owner)
		return;
	b->owner_on = (b->owner_on | on) & ~off;
	if (!b->owner_on) {
		b->owned = false;
		b->had_owner = true;
		b->next_owner = b->owner;
		atomic_store_explicit(&b->pub_owned, false, memory_order_relaxed);
	}
}

/*
 * When the message being handled arrived, on CLOCK_MONOTONIC: its receive
 * stamp real_ns (CLOCK_REALTIME; 0: none, then now) moved onto
 * CLOCK_MONOTONIC by the offset drain() measured, and held to what
 * is certain whatever the realtime clock did in between: not after now
 * (it is being handled), not before the drain that last found nothing
 * queued began (it would have been read then: b->rx_seen_ns), and after
 * the previous message's (they are read in the order they came).  So a
 * clock step moves a stamp at most to those bounds, and each command's
 * rx_ns is its own.  Bridge thread.
 */
static int64_t arrival_ns(struct rmd_bridge *b, int64_t real_ns, int64_t now)
{
	int64_t t = real_ns > 0 ? sub_sat(real_ns, b->rx_off_ns) : now;

	if (t < b->rx_seen_ns)
		t = b->rx_seen_ns;
	if (t <= b->rx_at_ns)
		t = b->rx_at_ns + 1;
	if (t > now)
		t = now;
	b->rx_at_ns = t;
	return t;
}

static void on_command(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	struct rmd_bridge_buf *buf = b->buf;
	rmd_command_t *msg = &buf->msg;
	struct clamp_note note = { 0 };
	/* udpm: the kernel's stamp of its last datagram; else LCM's receive time */
	int64_t at = arrival_ns(b, m->rx_real_ns, rmd_now_ns());

	if (b->probing)
		return;
	if (decode_command(b, m, msg) >= 0 || check_entries(b, msg) >= 0 ||
	    check_owner(b, msg, at) >= 0)
		return;
	/* a different controller starts its own sequence */
	if (!b->have_controller || msg->controller != b->last_controller)
		b->have_seq = b->have_utime = false;
	if (check_order(b, msg) >= 0)
		return;
	b->have_controller = true;
	b->last_controller = msg->controller;

	if (msg->seq == 0)
		b->have_seq = b->have_utime = false;
	if (!b->have_seq || msg->seq > b->last_seq)
		b->last_seq = msg->seq;
	b->have_seq = true;
	if (msg->utime != 0 && (!b->have_utime || msg->utime > b->newest_utime)) {
		b->newest_utime = msg->utime;
		b->have_utime = true;
	}

	note_accepted(b, msg);
	fill_command(b, msg, &buf->cmd, &note);
	memcpy(buf->cmd.disables, b->disables, sizeof(buf->cmd.disables));
	buf->cmd.rx_ns = at;
	rmd_latest_put(b->opts.commands, &buf->cmd);
	count(&b->n_accepted);
	if (note.any) {
		count(&b->n_clamped);
		if (!b->clamp_logged) {
			b->clamp_logged = true;
			logf_(b, 5,
			      "%s: motor %d (%s): %s %g clamped to %g; further clamps are "
			      "counted in health_t",
			      b->ch_command, note.motor, motor_name(b, note.motor), note.what.field,
			      note.what.from, note.what.to);
		}
	}
}

/*
 * rmd.home_t (docs/lcm.md "Homing"): checked, logged, and handed to the rt
 * loop, which applies it (or refuses it: a motor that is enabled, or has
 * no position yet) and logs the outcome.  Rare, human-paced: every one is
 * logged.  Bridge thread.
 */
static void on_home(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	rmd_home_t msg;
	unsigned i;

	if (b->probing)
		return;
	if (rmd_home_t_decode(m->data, 0, (int)m->size, &msg) != (int)m->size) {
		logf_(b, 4, "%s: refused: not an rmd.home_t (fingerprint or length)", b->ch_home);
		return;
	}
	if (msg.index < 0 || (unsigned)msg.index >= b->opts.nmotors) {
		logf_(b, 4, "%s: refused: motor index %d out of range (0..%u)", b->ch_home,
		      msg.index, b->opts.nmotors - 1);
		return;
	}
	i = (unsigned)msg.index;
	if (!msg.as_reported && !isfinite(msg.position)) {
		logf_(b, 4, "%s: motor %u (%s): refused: position %g is not finite", b->ch_home, i,
		      motor_name(b, i), msg.position);
		return;
	}
	if (b->owned && msg.controller != b->owner) {
		logf_(b, 4,
		      "%s: motor %u (%s): refused: controller %016" PRIx64
		      " does not own the motors (controller %016" PRIx64 " does)",
		      b->ch_home, i, motor_name(b, i), (uint64_t)msg.controller,
		      (uint64_t)b->owner);
		return;
	}
	if (!b->opts.homes) {
		logf_(b, 4, "%s: motor %u (%s): refused: this rmdd takes no homing", b->ch_home, i,
		      motor_name(b, i));
		return;
	}
	b->homes.seq[i]++;
	b->homes.as_reported[i] = msg.as_reported;
	b->homes.pos_rad[i] = msg.as_reported ? 0.0 : msg.position;
	rmd_latest_put(b->opts.homes, &b->homes);
	if (msg.as_reported)
		logf_(b, 5,
		      "%s: motor %u (%s): controller %016" PRIx64
		      " says its reported position is right",
		      b->ch_home, i, motor_name(b, i), (uint64_t)msg.controller);
	else
		logf_(b, 5, "%s: motor %u (%s): controller %016" PRIx64 " says it is at %.6f rad",
		      b->ch_home, i, motor_name(b, i), (uint64_t)msg.controller, msg.position);
}

static void on_config_request(struct rmd_bridge *b)
{
	if (!b->probing)
		b->config_wanted = true;
}

/* ---- another daemon on the prefix (docs/lcm.md "One daemon per prefix") ---- */

/* A message of another daemon's arrived (instance 0: a state_t, which names nobody). */
static void note_foreign(struct rmd_bridge *b, int64_t instance, const char *host, int32_t pid,
			 const char *source)
{
	struct rmd_bridge_peer *f = &b->foreign;

	f->messages++;
	b->foreign_ns = rmd_now_ns();
	if (instance) {
		f->instance = instance;
		snprintf(f->host, sizeof(f->host), "%s", host ? host : "");
		f->pid = pid;
		if (source)
			snprintf(f->source, sizeof(f->source), "%s", source);
	}
	if (b->probing)
		return;
	count(&b->n_foreign);
	if (b->foreign_episode)
		return;
	b->foreign_episode = true;
	logf_(b, 4,
	      "another rmdd publishes on %s*: instance %016" PRIx64
	      " on host %s, pid %d%s%s; controllers on this prefix see both daemons' state and "
	      "drive both: stop one, or give one another lcm.channel_prefix (its messages are "
	      "counted in health_t foreign_messages)",
	      b->opts.prefix, (uint64_t)f->instance, f->host[0] ? f->host : "?", (int)f->pid,
	      f->source[0] ? ", configuration " : "", f->source);
}

/* An episode ends when nothing foreign came for this long (ten health_t periods). */
#define FOREIGN_QUIET_NS (1000 * RMD_NS_PER_MS)

static void foreign_expire(struct rmd_bridge *b, int64_t now)
{
	if (!b->foreign_episode || now - b->foreign_ns < FOREIGN_QUIET_NS)
		return;
	b->foreign_episode = false;
	logf_(b, 5, "the other rmdd on %s* (instance %016" PRIx64 ", host %s, pid %d) went quiet",
	      b->opts.prefix, (uint64_t)b->foreign.instance, b->foreign.host, (int)b->foreign.pid);
}

/*
 * A message on the prefix's STATE (probing only), HEALTH or CONFIG: ours
 * (LCM loops them back unless the link's filter drops them) or another
 * daemon's.
 * health_t at ~10 Hz and config_t on request: decoding them is cheap.
 */
static void on_foreign(struct rmd_bridge *b, const char *channel, const void *data, uint32_t size)
{
	if (!strcmp(channel, b->ch_health)) {
		rmd_health_t h;

		if (rmd_health_t_decode(data, 0, (int)size, &h) < 0)
			return;
		if (h.instance != b->opts.instance)
			note_foreign(b, h.instance, h.host, h.pid, NULL);
		rmd_health_t_decode_cleanup(&h);
	} else if (!strcmp(channel, b->ch_config)) {
		rmd_config_t c;

		if (rmd_config_t_decode(data, 0, (int)size, &c) < 0)
			return;
		if (c.instance != b->opts.instance)
			note_foreign(b, c.instance, c.host, c.pid, c.source);
		rmd_config_t_decode_cleanup(&c);
	} else if (b->probing && !strcmp(channel, b->ch_state)) {
		note_foreign(b, 0, NULL, 0, NULL);
	}
}

/* ---- publishing --------------------------------------------------------- */

static int32_t sat32(int64_t v)
{
	return v > INT32_MAX ? INT32_MAX : v < INT32_MIN ? INT32_MIN : (int32_t)v;
}

static int64_t sat64(uint64_t v)
{
	return v > INT64_MAX ? INT64_MAX : (int64_t)v;
}

/* Encoding into our own buffer spares the allocation of the generated X_publish(). */
static bool publish_encoded(struct rmd_bridge *b, const char *channel, int n)
{
	if (n < 0 || rmd_lcm_link_publish(b->link, channel, b->buf->enc, (size_t)n) < 0) {
		count(&b->n_publish_errors);
		return false;
	}
	return true;
}

static void publish_state(struct rmd_bridge *b)
{
	const struct rmd_snapshot *s;
	rmd_state_t *st = &b->buf->state;
	int n;

	if (!b->state_listeners || !b->opts.snapshots ||
	    !rmd_latest_get(b->opts.snapshots, (const void **)&s))
		return;
	if (b->state_sent && s->cycle - b->last_state_cycle < b->opts.state_every)
		return;
	b->state_sent = true;
	b->last_state_cycle = s->cycle;

	st->utime = s->t_ns / 1000;
	st->cycle = sat64(s->cycle);
	st->owned = b->owned;
	st->owner = b->owned ? b->owner : 0;
	st->count = (int16_t)(s->n < RMD_MAX_MOTORS ? s->n : RMD_MAX_MOTORS);
	st->motor = b->buf->state_motor;
	for (int i = 0; i < st->count; i++) {
		const struct rmd_motor_state *m = &s->m[i];
		rmd_motor_state_t *o = &st->motor[i];

		o->index = (int16_t)i;
		o->lifecycle = (int8_t)m->lifecycle;
		o->mode = (int8_t)m->mode;
		o->position = m->pos_rad;
		o->velocity = m->vel_rad_s;
		o->torque = m->torque_nm;
		o->current = m->current_a;
		o->temperature = m->temp_c;
		o->voltage = m->voltage_v;
		o->error_code = m->error_code;
		o->reply_age_cycles = sat32(m->reply_age_cycles);
		o->reply_latency_us = sat32(m->reply_latency_ns / 1000);
		o->missed_replies = sat64(m->missed_replies);
		o->rx_time_ns = m->rx_ns;
		o->position_rx_time_ns = m->pos_rx_ns;
		o->status_rx_time_ns = m->status_rx_ns;
		o->position_certain = m->pos_certain;
		o->position_trust = (int8_t)m->pos_trust;
		o->brake_releasing = m->release_until_ns > s->t_ns;
	}
	n = rmd_state_t_encode(b->buf->enc, 0, ENC_MAX, st);
	if (publish_encoded(b, b->ch_state, n))
		count(&b->n_states);
}

static void publish_health(struct rmd_bridge *b, int64_t now)
{
	static const struct rmd_health none;
	const struct rmd_health *h = &none;
	rmd_health_t *o = &b->buf->health;
	int n;

	if (b->opts.health)
		rmd_latest_get(b->opts.health, (const void **)&h);
	/* bring-up found a motor's dialect or firmware (protocol auto): config_t says it again */
	for (unsigned i = 0; i < h->nmotors && i < b->opts.nmotors; i++)
		if (h->proto[i] != b->config_proto[i] || h->firmware[i] != b->config_firmware[i])
			b->config_wanted = true;
	o->utime = now / 1000;
	o->instance = b->opts.instance;
	o->host = b->opts.host;
	o->pid = b->opts.pid;
	foreign_expire(b, now);
	o->foreign_messages = sat64(read_count(&b->n_foreign));
	o->foreign_instance = b->foreign.instance;
	o->foreign_host = b->foreign.host;
	o->foreign_pid = b->foreign.pid;
	o->cycles = sat64(h->loop.cycles);
	o->overruns = sat64(h->loop.overruns);
	o->plan_misses = sat64(h->loop.plan_misses);
	o->wake_min_us = h->loop.wake_min_ns / 1e3;
	o->wake_avg_us = h->loop.wake_avg_ns / 1e3;
	o->wake_p99_us = h->loop.wake_p99_ns / 1e3;
	o->wake_max_us = h->loop.wake_max_ns / 1e3;
	o->cycle_max_us = h->loop.cycle_max_ns / 1e3;
	o->bus_count = (int16_t)(h->nbuses < RMD_MAX_BUSES ? h->nbuses : RMD_MAX_BUSES);
	for (int i = 0; i < RMD_MAX_BUSES; i++) {
		const struct rmd_bus_health *bh = &h->bus[i];
		rmd_bus_health_t *ob = &o->bus[i];
		char *name = b->buf->bus_name[i];

		if (i >= o->bus_count) {
			name[0] = '\0';
			*ob = (rmd_bus_health_t){ .name = name };
			continue;
		}
		/* The rt loop's name, else the configured one; never unterminated. */
		snprintf(name, RMD_BRIDGE_NAME_LEN, "%.*s", (int)sizeof(bh->name),
			 bh->name[0] ? bh->name :
				       ((unsigned)i < b->opts.nbuses ? b->opts.bus[i].name : ""));
		ob->name = name;
		ob->state = (int8_t)bh->state;
		ob->load = bh->load;
		ob->tx_frames = sat64(bh->stats.tx_frames);
		ob->rx_frames = sat64(bh->stats.rx_frames);
		ob->tx_busy = sat64(bh->stats.tx_busy);
		ob->rx_errors = sat64(bh->stats.rx_errors);
		ob->bus_errors = sat64(bh->stats.bus_errors);
		ob->state_changes = sat64(bh->stats.state_changes);
	}
	o->watchdog = (int8_t)h->watchdog;
	o->safe_action_events = sat64(h->safe_action_events);

	/* The bridge is the one that counts commands. */
	o->commands_accepted = sat64(read_count(&b->n_accepted));
	o->commands_rejected = 0;
	for (int k = 0; k < RMD_REJ_KINDS; k++) {
		o->rejected_by_kind[k] = sat64(read_count(&b->n_rejected[k]));
		o->commands_rejected += o->rejected_by_kind[k];
	}
	o->commands_clamped = sat64(read_count(&b->n_clamped));
	for (int k = 0; k < RMD_IGN_KINDS; k++)
		o->ignored_by_kind[k] = sat64(h->ignored[k]);
	o->owned = b->owned;
	o->owner = b->owned ? b->owner : 0;
	o->intruder = atomic_load_explicit(&b->pub_intruder, memory_order_relaxed);
	o->takeovers = sat64(read_count(&b->n_takeovers));
	/*
	 * Every configured motor, always (config_t's count): before the loop's
	 * first health its entries read "pending", and a C subscriber never
	 * decodes an empty int8_t array (LCM 1.3.1's generated decode passes
	 * NULL to memcpy for one).
	 */
	o->motor_count =
		(int16_t)(b->opts.nmotors < RMD_MAX_MOTORS ? b->opts.nmotors : RMD_MAX_MOTORS);
	o->comm_loss = b->buf->health_cl;
	o->comm_loss_ms = b->buf->health_cl_ms;
	o->unarmed_rejects = b->buf->health_unarmed;
	for (int i = 0; i < o->motor_count; i++) {
		bool known = (unsigned)i < h->nmotors;

		o->comm_loss[i] = known ? (int8_t)h->comm_loss[i] : 0;
		o->comm_loss_ms[i] = known ? sat32(h->comm_loss_ms[i]) : 0;
		o->unarmed_rejects[i] = known ? sat64(h->unarmed_rejects[i]) : 0;
	}

	n = rmd_health_t_encode(b->buf->enc, 0, ENC_MAX, o);
	if (publish_encoded(b, b->ch_health, n))
		count(&b->n_health);
}

static void publish_config(struct rmd_bridge *b)
{
	struct rmd_bridge_opts *op = &b->opts;
	rmd_config_t *c = &b->buf->config;
	static const struct rmd_health none;
	const struct rmd_health *h = &none;

	c->utime = rmd_now_ns() / 1000;
	c->prefix = op->prefix;
	c->version = op->version;
	c->instance = op->instance;
	c->host = op->host;
	c->pid = op->pid;
	c->source = op->source;
	c->period_us = sat32(op->period_ns / 1000);
	c->state_every = sat32(op->state_every);
	c->stale_ms = op->stale_ms;
	c->bus_count = (int16_t)op->nbuses;
	c->bus = b->buf->config_bus;
	for (unsigned i = 0; i < op->nbuses; i++) {
		c->bus[i].name = op->bus[i].name;
		c->bus[i].kind = op->bus[i].kind;
		c->bus[i].bitrate = sat32(op->bus[i].bitrate);
	}
	c->motor_count = (int16_t)op->nmotors;
	c->motor = b->buf->config_motor;
	/* the protection's state and time come from the loop's newest health */
	if (op->health)
		rmd_latest_get(op->health, (const void **)&h);
	for (unsigned i = 0; i < h->nmotors && i < RMD_MAX_MOTORS; i++) {
		b->config_proto[i] = h->proto[i];
		b->config_firmware[i] = h->firmware[i];
	}
	for (unsigned i = 0; i < op->nmotors; i++) {
		const struct rmd_motor_info *m = &op->motor[i];

		c->motor[i] = (rmd_motor_config_t){
			.index = (int16_t)i,
			.name = op->motor[i].name,
			.bus = m->bus,
			.id = m->id,
			/* bring-up's answer for protocol auto, and the firmware date */
			.protocol = i < h->nmotors ?
					    (char *)rmd_proto_key((enum rmd_proto)h->proto[i]) :
					    op->motor[i].protocol,
			.firmware = i < h->nmotors ? sat32(h->firmware[i]) : 0,
			.modes = (int8_t)m->modes,
			.position_min = m->pos_min_rad,
			.position_max = m->pos_max_rad,
			.velocity_max = m->vel_max_rad_s,
			.torque_max = m->torque_max_nm,
			.kp_min = m->kp_min,
			.kp_max = m->kp_max,
			.kd_min = m->kd_min,
			.kd_max = m->kd_max,
			.comm_loss_ms = i < h->nmotors ? sat32(h->comm_loss_ms[i]) : -1,
			.comm_loss = i < h->nmotors ? (int8_t)h->comm_loss[i] : 0,
			.position_resolution = m->pos_resolution_rad,
			.position_rate_hz = m->pos_rate_hz,
			.multi_turn_saved = m->multi_turn_saved,
			.travel_min = m->travel_min_rad,
			.travel_max = m->travel_max_rad,
			.turn_period = m->turn_period_rad,
		};
	}
	/*
	 * Encoded once: the bytes published are the ones rmd_bridge_config_copy()
	 * hands out.  Only this thread writes them, so reading them unlocked
	 * here is safe; the lock keeps a copier from seeing them half-written.
	 */
	pthread_mutex_lock(&b->config_mu);
	b->buf->config_len = rmd_config_t_encode(b->buf->config_enc, 0, ENC_MAX, c);
	pthread_mutex_unlock(&b->config_mu);
	if (b->buf->config_len < 0 ||
	    rmd_lcm_link_publish(b->link, b->ch_config, b->buf->config_enc,
				 (size_t)b->buf->config_len) < 0)
		count(&b->n_publish_errors);
	else
		count(&b->n_configs);
}

/* ---- the thread --------------------------------------------------------- */

void rmd_bridge_handle(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	if (!m->data) {
		/* too long to keep: LCM handed these to the bridge, which refused them */
		if (!strcmp(m->channel, b->ch_command))
			reject(b, RMD_REJ_DECODE, "%u bytes: longer than any rmd.command_t",
			       (unsigned)m->size);
		return;
	}
	if (!strcmp(m->channel, b->ch_command))
		on_command(b, m);
	else if (!strcmp(m->channel, b->ch_config_req))
		on_config_request(b);
	else if (!strcmp(m->channel, b->ch_home))
		on_home(b, m);
	else
		on_foreign(b, m->channel, m->data, m->size);
}

/*
 * Take what the link has, looking at the snapshots after each datagram or
 * message; true when it found nothing more.
 */
static bool drain_link(struct rmd_bridge *b)
{
	for (int n = 0; n < DRAIN_MAX; n++) {
		struct rmd_lcm_msg m;
		int r = rmd_lcm_link_receive(b->link, &m);

		if (r == -EAGAIN)
			return true;
		if (r == -EINTR)
			return false;
		if (r == 1 || r == -EMSGSIZE) {
			rmd_bridge_handle(b, &m);
		} else if (r < 0) {
			if (read_count(&b->n_lcm_errors) == 0)
				logf_(b, 4, "LCM receive failed (%s); further failures are counted",
				      strerror(-r));
			count(&b->n_lcm_errors);
			return false;
		}
		publish_state(b);
	}
	return false;
}

/*
 * Handle what has queued, and look at the snapshots after each message
 * (an atomic load when there is none): a flood of commands never holds
 * back the state.  Messages are judged by when they arrived
 * (arrival_ns()): the offset of CLOCK_REALTIME, on which receive stamps
 * come, is measured here, and a drain that finds the queue empty makes
 * its start b->rx_seen_ns, up to when every message has been looked at
 * (a drain cut short by DRAIN_MAX or an error leaves it).  Bridge thread.
 */
static void drain(struct rmd_bridge *b)
{
	int64_t start, off = rmd_realtime_offset_ns(&start);

	/*
	 * A clock step since the last drain: each stamp of this one is right
	 * with one of the two offsets.  The smaller makes it the later: a step
	 * never makes a controller look silent (the bounds hold either way).
	 */
	b->rx_off_ns = off < b->rx_off_last_ns ? off : b->rx_off_last_ns;
	b->rx_off_last_ns = off;
	if (drain_link(b))
		b->rx_seen_ns = start;
}

/*
 * How long the bridge may sleep: until the health timer or a pending
 * config_t is due; a state_t is due when the loop's notify_fd says so, and
 * only without one does the bridge look every poll_ns.
 */
static int64_t sleep_ns(const struct rmd_bridge *b, int64_t now, bool notified)
{
	int64_t due = b->next_health_ns;

	if (b->config_wanted && b->config_sent_ns + CONFIG_INTERVAL_NS < due)
		due = b->config_sent_ns + CONFIG_INTERVAL_NS;
	if (!notified && b->state_listeners && b->opts.snapshots && now + b->opts.poll_ns < due)
		due = now + b->opts.poll_ns;
	return due > now ? due - now : 0;
}

/* What woke the bridge: epoll_event.data.u32. */
enum { WAKE_STOP, WAKE_RX, WAKE_SNAPSHOT, WAKE_TIMER };

/*
 * The bridge's one wait, set up once (rmd_bridge_init): an epoll set of
 * rmd_bridge_stop()'s eventfd, the link's descriptor (rmd/lcm_link.h),
 * the loop's notify_fd and a timerfd for the health
 * timer and a pending config_t.  The registrations persist, and notify_fd
 * is edge-triggered and never read: a snapshot costs one epoll_wait, not a
 * poll set built and torn down, a timer armed and cancelled and a read.
 * 0 or -errno.
 */
static int wait_setup(struct rmd_bridge *b)
{
	struct {
		int fd;
		uint32_t events, what;
	} w[] = {
		{ b->stop_fd, EPOLLIN, WAKE_STOP },
		{ rmd_lcm_link_fd(b->link), EPOLLIN, WAKE_RX },
		{ -1, EPOLLIN, WAKE_TIMER },
		/* no state_t to publish: the loop's pokes need not wake us */
		{ b->state_listeners ? b->opts.notify_fd : -1, EPOLLIN | EPOLLET, WAKE_SNAPSHOT },
	};

	b->ep_fd = epoll_create1(EPOLL_CLOEXEC);
	b->timer_fd = timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
	if (b->ep_fd < 0 || b->timer_fd < 0)
		return -errno;
	w[2].fd = b->timer_fd;
	for (unsigned k = 0; k < sizeof(w) / sizeof(w[0]); k++) {
		struct epoll_event ev = { .events = w[k].events, .data.u32 = w[k].what };

		if (w[k].fd >= 0 && epoll_ctl(b->ep_fd, EPOLL_CTL_ADD, w[k].fd, &ev) < 0)
			return -errno;
	}
	return 0;
}

static void wait_close(struct rmd_bridge *b)
{
	if (b->ep_fd >= 0)
		close(b->ep_fd);
	if (b->timer_fd >= 0)
		close(b->timer_fd);
	b->ep_fd = b->timer_fd = -1;
}

/* The timer to CLOCK_MONOTONIC due_ns (already past: at once).  Bridge thread. */
static void arm_timer(struct rmd_bridge *b, int64_t due_ns)
{
	struct itimerspec its = { .it_value = { .tv_sec = due_ns / RMD_NS_PER_S,
						.tv_nsec = due_ns % RMD_NS_PER_S } };

	if (due_ns <= 0) /* 0 would disarm it */
		its.it_value.tv_nsec = 1;
	timerfd_settime(b->timer_fd, TFD_TIMER_ABSTIME, &its, NULL);
}

static void *bridge_main(void *arg)
{
	struct rmd_bridge *b = arg;
	int64_t now = rmd_now_ns(), armed_ns = -1;
	bool stop = false;

	pthread_setname_np(pthread_self(), "rmd-bridge");
	publish_config(b);
	b->config_sent_ns = now;
	b->next_health_ns = now + b->opts.health_period_ns;
	while (!stop) {
		struct epoll_event ev[4];
		bool readable = false;
		int64_t due;
		int n;

		now = rmd_now_ns();
		due = now + sleep_ns(b, now, b->opts.notify_fd >= 0);
		if (due != armed_ns) {
			arm_timer(b, due);
			armed_ns = due;
		}
		n = epoll_wait(b->ep_fd, ev, 4, -1);
		if (n < 0 && errno != EINTR) {
			logf_(b, 3, "LCM bridge: poll: %s; the bridge stops", strerror(errno));
			break;
		}
		for (int k = 0; k < n; k++) {
			uint64_t v;

			if (ev[k].data.u32 == WAKE_STOP)
				stop = true;
			readable |= ev[k].data.u32 == WAKE_RX;
			if (ev[k].data.u32 == WAKE_TIMER && read(b->timer_fd, &v, sizeof(v)) >= 0)
				armed_ns = -1; /* expired: armed again for what is due next */
		}
		if (stop)
			break;
		if (readable)
			drain(b);
		publish_state(b);
		now = rmd_now_ns();
		if (now >= b->next_health_ns) {
			drain(b); /* health_t's owner: judged on every message that came */
			publish_health(b, now);
			b->next_health_ns += b->opts.health_period_ns;
			if (b->next_health_ns <= now) /* late: skip, never catch up in a burst */
				b->next_health_ns = now + b->opts.health_period_ns;
		}
		/* at most one config_t a CONFIG_INTERVAL_NS; a request in between waits for it */
		if (b->config_wanted && now - b->config_sent_ns >= CONFIG_INTERVAL_NS) {
			b->config_wanted = false;
			b->config_sent_ns = now;
			publish_config(b);
		}
	}
	return NULL;
}

/* ---- lifecycle ----------------------------------------------------------- */

static bool prefix_ok(const char *p)
{
	for (; *p; p++)
		if (!isalnum((unsigned char)*p) && !strchr("_-./", *p))
			return false;
	return true;
}

static bool latest_ok(const struct rmd_latest *l, size_t size, bool optional)
{
	return l ? l->size == size : optional;
}

static int check_opts(const struct rmd_bridge_opts *o, char *err, size_t errlen)
{
	if (!o->url[0] || strnlen(o->url, sizeof(o->url)) == sizeof(o->url))
		return snprintf(err, errlen, "LCM url empty or too long"), -EINVAL;
	if (strnlen(o->prefix, sizeof(o->prefix)) == sizeof(o->prefix) || !prefix_ok(o->prefix))
		return snprintf(err, errlen,
				"LCM channel prefix \"%.*s\": up to %d of A-Z a-z 0-9 _ - . /",
				(int)sizeof(o->prefix), o->prefix, RMD_BRIDGE_PREFIX_LEN - 1),
		       -EINVAL;
	if (o->nmotors < 1 || o->nmotors > RMD_MAX_MOTORS)
		return snprintf(err, errlen, "%u motors (1..%d)", o->nmotors, RMD_MAX_MOTORS),
		       -EINVAL;
	if (o->nbuses > RMD_MAX_BUSES)
		return snprintf(err, errlen, "%u buses (0..%d)", o->nbuses, RMD_MAX_BUSES), -EINVAL;
	if (!latest_ok(o->commands, sizeof(struct rmd_command), false) ||
	    !latest_ok(o->snapshots, sizeof(struct rmd_snapshot), true) ||
	    !latest_ok(o->health, sizeof(struct rmd_health), true))
		return snprintf(err, errlen, "hand-over buffers missing or of the wrong size"),
		       -EINVAL;
	if (o->stale_ms < 0 || o->command_timeout_ms < 0 || o->health_period_ns <= 0 ||
	    o->poll_ns <= 0)
		return snprintf(err, errlen,
				"stale_ms or command_timeout_ms < 0, or a period <= 0"),
		       -EINVAL;
	if (o->rt_priority > 98)
		return snprintf(err, errlen, "rt_priority %u (0..98)", o->rt_priority), -EINVAL;
	for (unsigned i = 0; i < o->nbuses; i++)
		if (strnlen(o->bus[i].name, RMD_BRIDGE_NAME_LEN) == RMD_BRIDGE_NAME_LEN ||
		    strnlen(o->bus[i].kind, sizeof(o->bus[i].kind)) == sizeof(o->bus[i].kind))
			return snprintf(err, errlen, "bus %u: name or kind unterminated", i),
			       -EINVAL;
	for (unsigned i = 0; i < o->nmotors; i++) {
		const struct rmd_motor_info *m = &o->motor[i];

		if (strnlen(m->name, RMD_BRIDGE_NAME_LEN) == RMD_BRIDGE_NAME_LEN ||
		    strnlen(m->protocol, sizeof(m->protocol)) == sizeof(m->protocol))
			return snprintf(err, errlen, "motor %u: name or protocol unterminated", i),
			       -EINVAL;
		if (!m->modes || m->modes & ~RMD_BRIDGE_MODES_ALL)
			return snprintf(err, errlen, "motor %u (%s): modes 0x%x", i, m->name,
					m->modes),
			       -EINVAL;
		/* Written so that NaN fails each comparison. */
		if (!(m->pos_min_rad <= m->pos_max_rad) || !(m->vel_max_rad_s >= 0) ||
		    !(m->torque_max_nm >= 0) || !(m->kp_min <= m->kp_max) ||
		    !(m->kd_min <= m->kd_max))
			return snprintf(err, errlen,
					"motor %u (%s): limits: position min > max, a negative "
					"maximum, a gain range min > max, or NaN",
					i, m->name),
			       -EINVAL;
	}
	return 0;
}

/* ---- threads -------------------------------------------------------------- */

/*
 * The bridge thread, and LCM's receive threads with it (the link's: not on
 * udpm), to SCHED_FIFO rt_priority.  Refused: all stay at normal
 * priority, and rt_error says why.
 */
static void raise_threads(struct rmd_bridge *b)
{
	struct sched_param sp = { .sched_priority = (int)b->opts.rt_priority };
	int r;

	b->rt_granted = 0; /* a restart starts over */
	b->rt_error = 0;
	if (!b->opts.rt_priority)
		return;
	r = pthread_setschedparam(b->thread, SCHED_FIFO, &sp);
	if (r) {
		b->rt_error = -r;
		return;
	}
	b->rt_granted = b->opts.rt_priority;
	r = rmd_lcm_link_raise(b->link, b->opts.rt_priority);
	if (r < 0)
		b->rt_error = r;
}

/*
 * Once, at start: the link's protections that are not in place, and why
 * (rmd/lcm_link.h).  memq:// has no socket and no other sender: nothing
 * to say.
 */
static void log_link(struct rmd_bridge *b)
{
	struct rmd_lcm_link_info in;

	rmd_lcm_link_info(b->link, &in);
	if (!in.udpm) {
		if (b->state_listeners)
			logf_(b, 5,
			      "LCM %s: not udpm://: commands come through LCM's own receive path "
			      "(handled in the bridge thread; of LCM's threads %u found, %u at "
			      "SCHED_FIFO), stamped by LCM, and our own messages come back to us",
			      b->opts.url, in.lcm_threads, in.lcm_threads_rt);
		return;
	}
	if (!in.filter)
		logf_(b, 4,
		      "LCM %s: the kernel refused the filter that drops our own datagrams (%s): "
		      "the bridge reads back and drops each message it sends",
		      b->opts.url, strerror(-in.filter_error));
	if (!in.stamps)
		logf_(b, 4,
		      "LCM %s: no kernel receive stamps (%s): a command's arrival is when the "
		      "bridge reads it",
		      b->opts.url, strerror(-in.stamps_error));
}

/* ---- lifecycle, continued ------------------------------------------------- */

int rmd_bridge_init(struct rmd_bridge *b, const struct rmd_bridge_opts *opts, char *err,
		    size_t errlen)
{
	struct rmd_lcm_link_opts lo = { .url = opts->url,
					.prefix = opts->prefix,
					.recv_buf_size = RMD_BRIDGE_UDPM_RCVBUF,
					.queue = COMMAND_QUEUE };
	int r;

	memset(b, 0, sizeof(*b));
	b->config_mu = (pthread_mutex_t)PTHREAD_MUTEX_INITIALIZER;
	b->rx_off_last_ns = rmd_realtime_offset_ns(&b->rx_seen_ns);
	b->rx_at_ns = b->rx_seen_ns; /* nothing can have come before */
	b->stop_fd = -1;
	b->ep_fd = -1;
	b->timer_fd = -1;
	r = check_opts(opts, err, errlen);
	if (r < 0)
		return r;
	b->opts = *opts;
	if (b->opts.state_every == 0)
		b->opts.state_every = 1;
	snprintf(b->ch_command, sizeof(b->ch_command), "%sCOMMAND", opts->prefix);
	snprintf(b->ch_state, sizeof(b->ch_state), "%sSTATE", opts->prefix);
	snprintf(b->ch_health, sizeof(b->ch_health), "%sHEALTH", opts->prefix);
	snprintf(b->ch_config, sizeof(b->ch_config), "%sCONFIG", opts->prefix);
	snprintf(b->ch_config_req, sizeof(b->ch_config_req), "%sCONFIG_REQUEST", opts->prefix);
	snprintf(b->ch_home, sizeof(b->ch_home), "%sHOME", opts->prefix);

	b->buf = calloc(1, sizeof(*b->buf));
	if (!b->buf) {
		snprintf(err, errlen, "out of memory");
		return -ENOMEM;
	}
	b->stop_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (b->stop_fd < 0) {
		r = -errno;
		snprintf(err, errlen, "eventfd: %s", strerror(-r));
		goto err_free_buf;
	}
	b->state_listeners = strncmp(opts->url, "memq://", 7) != 0;
	r = rmd_lcm_link_new(&b->link, &lo, err, errlen);
	if (r < 0)
		goto err_close_stop;
	r = wait_setup(b);
	if (r == 0)
		return 0;
	snprintf(err, errlen, "epoll, timerfd: %s", strerror(-r));
	wait_close(b);
	rmd_lcm_link_free(b->link);
	b->link = NULL;
err_close_stop:
	close(b->stop_fd);
	b->stop_fd = -1;
err_free_buf:
	free(b->buf);
	b->buf = NULL;
	return r;
}

int rmd_bridge_probe(struct rmd_bridge *b, int64_t wait_ns, struct rmd_bridge_peer *peer)
{
	rmd_config_request_t req = { .utime = rmd_now_ns() / 1000 };
	int64_t end = rmd_now_ns() + wait_ns;
	struct pollfd pfd = { .fd = rmd_lcm_link_fd(b->link), .events = POLLIN };
	int n;

	memset(peer, 0, sizeof(*peer));
	if (!b->state_listeners || b->running)
		return 0;
	memset(&b->foreign, 0, sizeof(b->foreign));
	b->probing = true;
	/* a daemon answers with config_t (within CONFIG_INTERVAL_NS): it names its source */
	n = rmd_config_request_t_encode(b->buf->enc, 0, ENC_MAX, &req);
	if (n < 0 || rmd_lcm_link_publish(b->link, b->ch_config_req, b->buf->enc, (size_t)n) < 0) {
		b->probing = false;
		return -EIO;
	}
	for (;;) {
		int64_t now = rmd_now_ns();
		int ms;

		/* named by its config_t: nothing more to learn */
		if (now >= end || b->foreign.source[0])
			break;
		ms = (int)((end - now + RMD_NS_PER_MS - 1) / RMD_NS_PER_MS);
		if (poll(&pfd, 1, ms) < 0 && errno != EINTR) {
			b->probing = false;
			return -errno;
		}
		drain(b);
	}
	b->probing = false;
	*peer = b->foreign;
	/* the running bridge tells its own episode (it logs once) */
	memset(&b->foreign, 0, sizeof(b->foreign));
	return (int)(peer->messages > INT_MAX ? INT_MAX : peer->messages);
}

int rmd_bridge_start(struct rmd_bridge *b)
{
	int r;

	if (b->running)
		return -EALREADY;
	r = rmd_thread_start_normal(&b->thread, bridge_main, b);
	if (r)
		return r;
	b->running = true;
	raise_threads(b);
	log_link(b);
	return 0;
}

void rmd_bridge_stop(struct rmd_bridge *b)
{
	uint64_t one = 1;

	if (!b->running)
		return;
	if (write(b->stop_fd, &one, sizeof(one)) < 0) {
		/* an eventfd write fails only on overflow: already signalled */
	}
	pthread_join(b->thread, NULL);
	b->running = false;
	if (read(b->stop_fd, &one, sizeof(one)) < 0) {
		/* nothing to clear */
	}
}

int rmd_bridge_config_copy(struct rmd_bridge *b, void *out, size_t len)
{
	int n = 0;

	if (!b->buf)
		return 0;
	pthread_mutex_lock(&b->config_mu);
	if (b->buf->config_len > 0 && (size_t)b->buf->config_len <= len) {
		n = b->buf->config_len;
		memcpy(out, b->buf->config_enc, (size_t)n);
	}
	pthread_mutex_unlock(&b->config_mu);
	return n;
}

void rmd_bridge_fini(struct rmd_bridge *b)
{
	rmd_bridge_stop(b);
	wait_close(b);
	rmd_lcm_link_free(b->link);
	b->link = NULL;
	if (b->stop_fd >= 0)
		close(b->stop_fd);
	b->stop_fd = -1;
	free(b->buf);
	b->buf = NULL;
}

void rmd_bridge_get_stats(struct rmd_bridge *b, struct rmd_bridge_stats *st)
{
	struct rmd_lcm_link_info in = { 0 };

	if (b->link)
		rmd_lcm_link_info(b->link, &in);
	memset(st, 0, sizeof(*st));
	st->accepted = read_count(&b->n_accepted);
	for (int k = 0; k < RMD_REJ_KINDS; k++) {
		st->rejected_by_kind[k] = read_count(&b->n_rejected[k]);
		st->rejected += st->rejected_by_kind[k];
	}
	st->clamped = read_count(&b->n_clamped);
	st->states_published = read_count(&b->n_states);
	st->health_published = read_count(&b->n_health);
	st->configs_published = read_count(&b->n_configs);
	st->publish_errors = read_count(&b->n_publish_errors);
	st->foreign = read_count(&b->n_foreign);
	st->lcm_errors = read_count(&b->n_lcm_errors);
	st->takeovers = read_count(&b->n_takeovers);
	st->owned = atomic_load_explicit(&b->pub_owned, memory_order_relaxed);
	st->owner = atomic_load_explicit(&b->pub_owner, memory_order_relaxed);
	st->intruder = atomic_load_explicit(&b->pub_intruder, memory_order_relaxed);
	st->rt_priority = b->rt_granted;
	st->rt_error = b->rt_error;
	st->lcm_threads = in.lcm_threads;
	st->lcm_threads_rt = in.lcm_threads_rt;
	st->own_dropped = in.filter;
	st->datagrams = in.datagrams;
}
