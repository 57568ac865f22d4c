// SPDX-License-Identifier: MIT
/*
 * The LCM bridge's command path (src/svc/admission.c): datagrams on its
 * COMMAND channel are decoded as rmd.command_t and validated (structure,
 * modes, finite values, gain ranges, sequence and timestamp order) before
 * a command reaches the rt loop's hand-over.  The decoder and validator are
 * static, so they are driven through rmd_bridge_handle(), the step the
 * bridge thread takes for each message its LCM link hands over: a bridge
 * on an in-process LCM (memq://), not started, given each datagram as a
 * message on its COMMAND channel in this thread.
 *
 * Every accepted command must hand over only finite setpoints inside the
 * motor's limits (the rule rmd_motor_clamp() applies).
 *
 * The bridge is a part of a robot (instance "fuzz", peer "peer";
 * docs/robot.md): a raw datagram with tag bit 2 goes to RMD_ROBOT_HEARTBEAT
 * instead (src/svc/peers.c judges it), with bit 3 to RMD_ROBOT_STOP; a
 * structured record with tag bit 2 is a heartbeat_t built from the input
 * (its name, host and echo's name from small sets, so that peers, spoofs
 * and this daemon's own name all come up; the numbers full width).  None
 * is a command (not counted as one); whatever they hand over (a robot-wide
 * stop) must pass the same checks.
 *
 * Input: a sequence of datagrams, each a tag byte, then
 *   tag bit 0 set:   a length byte and that many raw bytes (any datagram);
 *   tag bit 0 clear: a command_t built from the input and encoded: utime
 *                    and seq (8 bytes each, full width), count (1 byte),
 *                    then per entry index, enable, mode (1 byte each) and
 *                    six doubles; tag bit 1 asks for small seq/utime
 *                    deltas (1 byte each) instead of full-width values.
 * One bridge serves every input (creating one costs more than an input):
 * each input starts with the command a restarting controller sends
 * (seq 0, utime 0, no entries), which forgets the sequence and timestamp
 * of the input before, so an input's verdicts do not depend on its
 * predecessors.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/bridge.h"
#include "rmd/channels.h"
#include "rmd/motor.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

#include "fuzz.h"

#define NMOTORS 6
#define PREFIX "FUZZ_"
#define MAX_DATAGRAMS 16

static struct rmd_bridge_opts opts;
static struct rmd_latest commands;
static struct rmd_command cmd_buf[3];
static rmd_command_t msg;
static uint8_t enc[16384]; /* a command_t with up to 127 entries */

static void sink(void *ctx, int level, const char *text)
{
	(void)ctx;
	FUZZ_CHECK(level >= 3 && level <= 5 && text[0] != '\0');
}

/*
 * The motors: limits of each kind the configuration allows, MIT on the
 * first two (the second with a narrow gain range), none on position for
 * the last.
 */
static const struct {
	double pos_min, pos_max, vel_max, torque_max, kp_max, kd_max;
	bool mit;
} motors[NMOTORS] = {
	{ -3, 3, 10, 5, 500, 5, true },	    { -0.5, 0.5, 1, 0.1, 1, 0.01, true },
	{ -3, 3, 10, 5, 0, 0, false },	    { 0, 6.28, 20, 30, 0, 0, false },
	{ -100, -99, 0.5, 1, 0, 0, false }, { -INFINITY, INFINITY, 50, 12, 0, 0, false },
};

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
	(void)argc;
	(void)argv;
	rmd_bridge_opts_init(&opts);
	snprintf(opts.url, sizeof(opts.url), "memq://");
	snprintf(opts.prefix, sizeof(opts.prefix), PREFIX);
	opts.nmotors = NMOTORS;
	for (unsigned i = 0; i < NMOTORS; i++) {
		struct rmd_motor_info *m = &opts.motor[i];

		snprintf(m->name, sizeof(m->name), "fuzz%u", i);
		m->id = (uint8_t)(i + 1);
		snprintf(m->protocol, sizeof(m->protocol), motors[i].mit ? "mit" : "v3");
		m->modes = motors[i].mit ?
				   RMD_BRIDGE_MODES_ALL :
				   RMD_BRIDGE_MODES_ALL & ~RMD_BRIDGE_MODE_BIT(RMD_MODE_MIT);
		m->pos_min_rad = motors[i].pos_min;
		m->pos_max_rad = motors[i].pos_max;
		m->vel_max_rad_s = motors[i].vel_max;
		m->torque_max_nm = motors[i].torque_max;
		m->kp_max = motors[i].kp_max;
		m->kd_max = motors[i].kd_max;
	}
	opts.nbuses = 1;
	snprintf(opts.bus[0].name, sizeof(opts.bus[0].name), "fuzzbus");
	snprintf(opts.bus[0].kind, sizeof(opts.bus[0].kind), "sim");
	opts.bus[0].bitrate = 1000000;
	snprintf(opts.robot.instance, sizeof(opts.robot.instance), "fuzz");
	snprintf(opts.robot.peers[0], sizeof(opts.robot.peers[0]), "peer");
	opts.robot.n_peers = 1;
	opts.commands = &commands;
	opts.log = sink;
	return 0;
}

/* The command_t of one structured record (motor[count]: storage for any int8_t count). */
static int build(struct fuzz_in *in, uint8_t tag, int64_t *utime, int64_t *seq)
{
	static rmd_motor_command_t entries[128];

	memset(&msg, 0, sizeof(msg));
	memset(entries, 0, sizeof(entries));
	msg.motor = entries;
	if (tag & 2) {
		/* steps from the previous values, wrapping as a controller's counters might */
		*utime = (int64_t)((uint64_t)*utime + (uint64_t)((int8_t)fuzz_u8(in) * 1000));
		*seq = (int64_t)((uint64_t)*seq + (uint64_t)(int8_t)fuzz_u8(in));
	} else {
		*utime = (int64_t)fuzz_u64(in);
		*seq = (int64_t)fuzz_u64(in);
	}
	msg.utime = *utime;
	msg.seq = *seq;
	msg.count = (int8_t)fuzz_u8(in);
	for (int k = 0; k < msg.count; k++) {
		rmd_motor_command_t *e = &msg.motor[k];

		e->index = (int8_t)fuzz_u8(in);
		e->enable = (int8_t)fuzz_u8(in);
		e->mode = (int8_t)fuzz_u8(in);
		e->position = fuzz_f64(in);
		e->velocity = fuzz_f64(in);
		e->torque = fuzz_f64(in);
		e->kp = fuzz_f64(in);
		e->kd = fuzz_f64(in);
		e->max_velocity = fuzz_f64(in);
	}
	return rmd_command_t_encode(enc, 0, sizeof(enc), &msg);
}

/* A heartbeat_t of one structured record. */
static int build_heartbeat(struct fuzz_in *in)
{
	static char *const names[] = { "fuzz", "peer", "other", "" };
	static char *const hosts[] = { "host-a", "host-b" };
	rmd_heartbeat_echo_t echo[2];
	rmd_heartbeat_t hb = { .prefix = "P_", .reason = "fuzz" };

	hb.instance = names[fuzz_u8(in) & 3];
	hb.host = hosts[fuzz_u8(in) & 1];
	hb.boot_id = (int64_t)(fuzz_u8(in) & 3);
	hb.seq = (int64_t)fuzz_u64(in);
	hb.t_ns = (int64_t)fuzz_u64(in);
	hb.state = (int8_t)fuzz_u8(in);
	hb.trips = (int64_t)fuzz_u64(in);
	hb.n_echoes = (int16_t)(fuzz_u8(in) % 3);
	hb.echo = echo;
	for (int k = 0; k < hb.n_echoes; k++)
		echo[k] = (rmd_heartbeat_echo_t){ .instance = names[fuzz_u8(in) & 3],
						  .seq = (int64_t)fuzz_u64(in),
						  .t_sent_ns = (int64_t)fuzz_u64(in),
						  .t_recv_ns = (int64_t)fuzz_u64(in) };
	return rmd_heartbeat_t_encode(enc, 0, sizeof(enc), &hb);
}

static void check_handover(void)
{
	const struct rmd_command *c;

	if (!rmd_latest_get(&commands, (const void **)&c))
		return;
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++) {
		const struct rmd_setpoint *sp = &c->m[i];
		const struct rmd_motor_info *m = &opts.motor[i];

		if (!(c->present & (1u << i)))
			continue;
		FUZZ_CHECK(i < NMOTORS);
		FUZZ_CHECK(sp->mode < RMD_MODE_COUNT);
		FUZZ_CHECK(isfinite(sp->pos_rad) && isfinite(sp->vel_rad_s) &&
			   isfinite(sp->torque_nm) && isfinite(sp->kp) && isfinite(sp->kd) &&
			   isfinite(sp->max_vel_rad_s));
		/* What the mode uses is within the limits; the rest is 0. */
		if (rmd_mode_uses_pos(sp->mode))
			FUZZ_CHECK(sp->pos_rad >= m->pos_min_rad && sp->pos_rad <= m->pos_max_rad);
		else
			FUZZ_CHECK(sp->pos_rad == 0);
		FUZZ_CHECK(fabs(sp->vel_rad_s) <= m->vel_max_rad_s);
		FUZZ_CHECK(fabs(sp->torque_nm) <= m->torque_max_nm);
		FUZZ_CHECK(sp->max_vel_rad_s >= 0 && sp->max_vel_rad_s <= m->vel_max_rad_s);
		if (sp->mode == RMD_MODE_MIT) {
			FUZZ_CHECK(sp->kp >= m->kp_min && sp->kp <= m->kp_max);
			FUZZ_CHECK(sp->kd >= m->kd_min && sp->kd <= m->kd_max);
		}
	}
}

static struct rmd_bridge *b;

static void publish_on(const char *channel, const void *buf, int len)
{
	struct rmd_lcm_msg m = { .channel = channel, .data = buf, .size = (uint32_t)len };

	rmd_bridge_handle(b, &m);
	check_handover();
}

static void publish(const void *buf, int len)
{
	publish_on(PREFIX RMD_CHANNEL_COMMAND, buf, len);
}

/* Accepted plus rejected commands so far. */
static uint64_t handled(void)
{
	struct rmd_bridge_stats st;

	rmd_bridge_get_stats(b, &st);
	return st.accepted + st.rejected;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct fuzz_in in = { data, size };
	int64_t utime = 0, seq = 0;
	uint64_t sent = 0, before;
	char err[256];
	int len;

	if (!b) {
		rmd_latest_init(&commands, cmd_buf, sizeof(cmd_buf[0]));
		FUZZ_CHECK(rmd_bridge_new(&b, &opts, err, sizeof(err)) == 0);
	}
	memset(&msg, 0, sizeof(msg));
	len = rmd_command_t_encode(enc, 0, sizeof(enc), &msg);
	FUZZ_CHECK(len > 0);
	before = handled();
	publish(enc, len);
	FUZZ_CHECK(handled() == before + 1);
	before = handled();
	for (int i = 0; i < MAX_DATAGRAMS && in.n > 0; i++) {
		uint8_t tag = fuzz_u8(&in);

		if (tag & 1) {
			len = fuzz_u8(&in);
			if ((size_t)len > in.n)
				len = (int)in.n;
			memcpy(enc, in.p, (size_t)len);
			in.p += len;
			in.n -= (size_t)len;
			if (tag & 12) {
				publish_on(tag & 4 ? RMD_CHANNEL_ROBOT_HEARTBEAT :
						     RMD_CHANNEL_ROBOT_STOP,
					   enc, len);
				continue;
			}
		} else if (tag & 4) {
			len = build_heartbeat(&in);
			FUZZ_CHECK(len > 0);
			publish_on(RMD_CHANNEL_ROBOT_HEARTBEAT, enc, len);
			continue;
		} else {
			len = build(&in, tag, &utime, &seq);
			FUZZ_CHECK(len > 0);
		}
		publish(enc, len);
		sent++;
	}
	FUZZ_CHECK(handled() == before + sent);
	return 0;
}
