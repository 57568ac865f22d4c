// SPDX-License-Identifier: MIT
/*
 * Command admission: a command_t or home_t on the prefix's COMMAND or HOME
 * is decoded, checked against the rules of docs/lcm.md (structure, modes,
 * finite values, gain ranges, one controller at a time, sequence and time
 * order), clamped to the motors' limits and handed to the rt loop; a
 * message that breaks a rule is rejected whole, counted by enum rmd_reject
 * kind and logged once per kind.  Bridge thread (rmd/bridge.h).
 */
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/motor.h"
#include "rmd/time.h"
#include "bridge_state.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_home_t.h"

/* The LCM constants are the C enums' values (lcm_types/ and rmd/state.h). */
_Static_assert(RMD_COMMAND_T_MAX_MOTORS == RMD_MAX_MOTORS, "array size");
_Static_assert(RMD_COMMAND_T_MODE_TORQUE == RMD_MODE_TORQUE &&
		       RMD_COMMAND_T_MODE_SPEED == RMD_MODE_SPEED &&
		       RMD_COMMAND_T_MODE_POSITION == RMD_MODE_POSITION &&
		       RMD_COMMAND_T_MODE_MIT == RMD_MODE_MIT && RMD_MODE_COUNT == 4,
	       "modes");

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

	bridge_count(&b->n_rejected[kind]);
	if (b->logged & (1u << kind))
		return kind;
	b->logged |= 1u << kind;
	va_start(ap, fmt);
	vsnprintf(why, sizeof(why), fmt, ap);
	va_end(ap);
	bridge_log(b, 4, "rejected %s: %s; further rejections of this kind are counted in health_t",
		   b->ch_command, why);
	return kind;
}

static void list_modes(unsigned modes, char *buf, size_t len)
{
	size_t n = 0;

	buf[0] = '\0';
	for (unsigned m = 0; m < RMD_MODE_COUNT; m++)
		if (modes & RMD_MOTOR_MODE_BIT(m) && n < len)
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
		if (e->enable && !(m->modes & RMD_MOTOR_MODE_BIT(e->mode))) {
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
 * Decode a command_t in place: msg->motor is the bridge's own array, so a
 * command costs no allocation, and a count beyond MAX_MOTORS is refused
 * (REJ_COUNT) before any entry is read, however long the datagram.
 * lcm-gen's public rmd_command_t_decode() keeps neither promise: it
 * allocates motor[count] for the count the datagram names (up to 32767
 * entries, 1.8 MB, before it finds the datagram short; under rmdd's
 * mlockall the memory is faulted in) and rmd_command_t_decode_cleanup()
 * frees it, two allocator calls per command in the bridge thread
 * (tests/unit/test_bridge.c test_command_decoded_in_place).  So the head's
 * fields are read here with LCM's own field decoders (lcm_coretypes.h) and
 * the entries with lcm-gen's __rmd_motor_command_t_decode_array(), which
 * follows lcm_types/motor_command_t.lcm as it changes.  A field added to
 * command_t's head is added here too (test_command_roundtrip fails until
 * it is).  Returns -1, or the kind it was rejected for.
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
 * (bridge_arrival_ns()).  Returns -1 or RMD_REJ_OWNER.  Bridge thread.
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
		bridge_log(b, 4,
			   "%s: controller %016" PRIx64
			   " takes the motors over from controller %016" PRIx64,
			   b->ch_command, (uint64_t)msg->controller,
			   (uint64_t)(b->owned ? b->owner : b->next_owner));
		bridge_count(&b->n_takeovers);
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
int64_t bridge_arrival_ns(struct rmd_bridge *b, int64_t real_ns, int64_t now)
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

/* A message on COMMAND (bridge_state.h).  Bridge thread. */
void bridge_admit_command(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	struct rmd_bridge_buf *buf = b->buf;
	rmd_command_t *msg = &buf->msg;
	struct clamp_note note = { 0 };
	int64_t at;

	if (!m->data) {
		/* too long to keep: the link handed it over without its bytes */
		reject(b, RMD_REJ_DECODE, "%u bytes: longer than any rmd.command_t",
		       (unsigned)m->size);
		return;
	}
	/* udpm: the kernel's stamp of its last datagram; else LCM's receive time */
	at = bridge_arrival_ns(b, m->rx_real_ns, rmd_now_ns());
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
	bridge_robot_command(b, &buf->cmd);
	buf->cmd.rx_ns = at;
	rmd_latest_put(b->opts.commands, &buf->cmd);
	bridge_count(&b->n_accepted);
	if (note.any) {
		bridge_count(&b->n_clamped);
		if (!b->clamp_logged) {
			b->clamp_logged = true;
			bridge_log(b, 5,
				   "%s: motor %d (%s): %s %g clamped to %g; further clamps are "
				   "counted in health_t",
				   b->ch_command, note.motor, motor_name(b, note.motor),
				   note.what.field, note.what.from, note.what.to);
		}
	}
}

/*
 * rmd.home_t (docs/lcm.md "Homing"): checked, logged, and handed to the rt
 * loop, which applies it (or refuses it: a motor that is enabled, or has
 * no position yet) and logs the outcome.  Rare, human-paced: every one is
 * logged.  A message on HOME (bridge_state.h).  Bridge thread.
 */
void bridge_admit_home(struct rmd_bridge *b, const struct rmd_lcm_msg *m)
{
	rmd_home_t msg;
	unsigned i;

	if (b->probing)
		return;
	if (rmd_home_t_decode(m->data, 0, (int)m->size, &msg) != (int)m->size) {
		bridge_log(b, 4, "%s: refused: not an rmd.home_t (fingerprint or length)",
			   b->ch_home);
		return;
	}
	if (msg.index < 0 || (unsigned)msg.index >= b->opts.nmotors) {
		bridge_log(b, 4, "%s: refused: motor index %d out of range (0..%u)", b->ch_home,
			   msg.index, b->opts.nmotors - 1);
		return;
	}
	i = (unsigned)msg.index;
	if (!msg.as_reported && !isfinite(msg.position)) {
		bridge_log(b, 4, "%s: motor %u (%s): refused: position %g is not finite",
			   b->ch_home, i, motor_name(b, i), msg.position);
		return;
	}
	if (b->owned && msg.controller != b->owner) {
		bridge_log(b, 4,
			   "%s: motor %u (%s): refused: controller %016" PRIx64
			   " does not own the motors (controller %016" PRIx64 " does)",
			   b->ch_home, i, motor_name(b, i), (uint64_t)msg.controller,
			   (uint64_t)b->owner);
		return;
	}
	if (!b->opts.homes) {
		bridge_log(b, 4, "%s: motor %u (%s): refused: this rmdd takes no homing",
			   b->ch_home, i, motor_name(b, i));
		return;
	}
	b->homes.seq[i]++;
	b->homes.as_reported[i] = msg.as_reported;
	b->homes.pos_rad[i] = msg.as_reported ? 0.0 : msg.position;
	rmd_latest_put(b->opts.homes, &b->homes);
	if (msg.as_reported)
		bridge_log(b, 5,
			   "%s: motor %u (%s): controller %016" PRIx64
			   " says its reported position is right",
			   b->ch_home, i, motor_name(b, i), (uint64_t)msg.controller);
	else
		bridge_log(b, 5,
			   "%s: motor %u (%s): controller %016" PRIx64 " says it is at %.6f rad",
			   b->ch_home, i, motor_name(b, i), (uint64_t)msg.controller, msg.position);
}
