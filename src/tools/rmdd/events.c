// SPDX-License-Identifier: MIT
/*
 * What rmdd says of the rt loop's events (rmd/state.h enum rmd_event_kind),
 * one row per kind (rows[], at the end), as src/sim/sim_params.c holds one
 * row per parameter: the line the monitor logs for it (level and text),
 * its line in an incident's summary (incidents.c), and whether it starts
 * an incident and under which name.  A new kind is its row here and its
 * lines in tests/unit/test_rmdd_events.c: the build refuses a table
 * shorter than the enum, that test a kind without a row.
 *
 * A few rows keep notes between events, in the monitor's struct
 * rmdd_event_notes: the shutdown's stop or hold is said in the SAFE line
 * that follows it, overruns after the first of a window are summed up once
 * every RMDD_OVERRUN_SUMMARY_S (rmdd_event_overruns()), and the real-time refusals of one drain
 * are said together after it (rmdd_event_rt_lines()).
 *
 * Also the names the monitor (monitor.c) and the incident writer
 * (incidents.c) both word events with: a motor's context, a bus's name, a
 * lifecycle's, a reboot check's report.  Both call down into this file; it
 * calls neither.  Everything here is non-rt.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmd/motor.h"
#include "rmd/proc_effect.h"
#include "rmd/time.h"
#include "rmdd.h"
#include "tools/common/names.h"

/* ---- names ------------------------------------------------------------------------ */

const char *rmdd_lifecycle_name(unsigned lc)
{
	return tool_lifecycle_name(lc);
}

void rmdd_motor_ctx(const struct rmd_config *cfg, unsigned i, char *buf, size_t len)
{
	const struct rmd_config_motor *c;

	if (i >= cfg->n_motors) {
		snprintf(buf, len, "motor #%u", i);
		return;
	}
	c = &cfg->motors[i];
	snprintf(buf, len, "%s: motor %u (%s)",
		 c->bus < cfg->n_buses ? cfg->buses[c->bus].name : "?", c->id, c->name);
}

const char *rmdd_bus_name(const struct rmd_config *cfg, unsigned b)
{
	return b < cfg->n_buses ? cfg->buses[b].name : "?";
}

/* The dialect each motor was found to speak, + 1 (0: none yet, its protocol's). */
static _Atomic uint8_t found_dialect[RMD_MAX_MOTORS];

void rmdd_dialect_found(unsigned i, enum rmd_proto p)
{
	if (i < RMD_MAX_MOTORS && rmd_dialect(p))
		found_dialect[i] = (uint8_t)(p + 1);
}

enum rmd_proto rmdd_motor_dialect(const struct rmd_config *cfg, unsigned i)
{
	unsigned f = i < RMD_MAX_MOTORS ? found_dialect[i] : 0;

	if (f)
		return (enum rmd_proto)(f - 1);
	return i < cfg->n_motors ? cfg->motors[i].proto : RMD_PROTO_V3;
}

/* ---- what a row words an event from ------------------------------------------ */

struct ev {
	const struct rmd_config *cfg;
	const struct rmd_event *e;
	const char *ctx;		/* its motor's rmdd_motor_ctx() */
	const char *bus;		/* its bus's rmdd_bus_name() */
	struct rmdd_event_notes *notes; /* the monitor's (NULL but for journal lines) */
};

/* Text into buf; the line's level back. */
__attribute__((format(printf, 4, 5))) static int say(char *buf, size_t len, int level,
						     const char *fmt, ...)
{
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(buf, len, fmt, ap);
	va_end(ap);
	return level;
}

/* ---- RMD_EV_MOTOR_STATE ---------------------------------------------------------- */

/*
 * A motor's change of state.  The shutdown's stop or hold sent to it just
 * before (RMD_EV_SAFE_ACTION, b = 1) is said in its SAFE line.
 */
static int motor_state_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_config *cfg = v->cfg;
	const struct rmd_event *e = v->e;
	const char *action = rmd_safe_action_name(cfg->safety.safe_action), *ctx = v->ctx;
	unsigned from = (unsigned)e->a, to = (unsigned)e->b;
	int shutdown_sent = -1;

	if (to == RMD_LC_SAFE) {
		shutdown_sent = v->notes->shutdown_sent;
		v->notes->shutdown_sent = -1;
	}
	switch ((enum rmd_lifecycle)to) {
	case RMD_LC_LOST:
		if (from == RMD_LC_PROBE)
			return say(buf, len, 4,
				   "%s: not brought up (the report above says why); a missing "
				   "motor is probed again every %d ms",
				   ctx, (int)(RMD_LOOP_REPROBE_NS / 1000000));
		return say(
			buf, len, 4,
			"%s: lost (%u missed replies in a row, or a 0xF1 or a reboot above)%s%s; "
			"probed again every %d ms",
			ctx, cfg->safety.missed_replies_lost,
			from == RMD_LC_ENABLED ? "; safe action " : "",
			from == RMD_LC_ENABLED ? action : "", (int)(RMD_LOOP_REPROBE_NS / 1000000));
	case RMD_LC_FAULT:
		/* lifecycle.c: a faulted motor runs no control command, so no safe action */
		return say(buf, len, 4, "%s: fault (error flags set); output off (0x80)%s", ctx,
			   rmd_config_fault_brakes(cfg) ? ", brake locked (0x78)" : "");
	case RMD_LC_SAFE:
		if (shutdown_sent == RMD_SAFE_HOLD)
			return say(buf, len, 5, "%s: shutdown: hold (0x81) sent, held by its drive",
				   ctx);
		if (shutdown_sent >= 0)
			return say(buf, len, 5,
				   "%s: shutdown: stop (0x80) sent, output off, brake as it was",
				   ctx);
		return say(buf, len, 4,
			   "%s: safe action %s, held until the controller enables it again", ctx,
			   action);
	case RMD_LC_STOPPING:
		if (from == RMD_LC_LOST || from == RMD_LC_FAULT)
			return say(
				buf, len, 5,
				"%s: back (%s -> stopping); send enable 0, then 1, to run it again",
				ctx, rmdd_lifecycle_name(from));
		return say(buf, len, from == RMD_LC_PROBE ? 7 : 6, "%s: %s -> stopping", ctx,
			   rmdd_lifecycle_name(from));
	case RMD_LC_READY:
		/* from STOPPING only: the motor echoed output off and brake locked */
		return say(buf, len, 7, "%s: ready (output off, brake locked)", ctx);
	case RMD_LC_ENABLED:
		return say(buf, len, 6, "%s: enabled", ctx);
	case RMD_LC_PROBE:
	case RMD_LC_COUNT:
		return say(buf, len, 7, "%s: %s -> %s", ctx, rmdd_lifecycle_name(from),
			   rmdd_lifecycle_name(to));
	}
	return 0;
}

static void motor_state_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: %s -> %s", v->ctx, rmdd_lifecycle_name((unsigned)v->e->a),
		 rmdd_lifecycle_name((unsigned)v->e->b));
}

/* A motor lost, faulted or made safe; one missing at bring-up is the report's, not an incident. */
static const char *motor_state_incident(const struct ev *v)
{
	if (v->e->b == RMD_LC_LOST && v->e->a != RMD_LC_PROBE)
		return "lost";
	if (v->e->b == RMD_LC_FAULT)
		return "fault";
	if (v->e->b == RMD_LC_SAFE)
		return "safe";
	return NULL;
}

/* ---- RMD_EV_MOTOR_ERROR ---------------------------------------------------------- */

/* "0xA2", or "an MIT frame": the command whose echo told a trip (RMD_EV_TRIP_ECHOED). */
static const char *echoed_name(int64_t a, char *buf, size_t len)
{
	if ((a & 0x1FF) == RMD_MOTOR_CMD_MIT)
		return "an MIT frame";
	snprintf(buf, len, "0x%02X", (unsigned)(a & 0xFF));
	return buf;
}

static int motor_error_line(const struct ev *v, char *buf, size_t len)
{
	char cmd[16];
	const struct rmd_config *cfg = v->cfg;
	const struct rmd_event *e = v->e;
	const char *names[8];
	char list[256];
	uint16_t code = (uint16_t)e->a;
	size_t n, used = 0;

	/* docs/design.md: the motor heard nothing for its 0xB3 time */
	if (e->b == RMD_MOTOR_CMD_COMM_LOST && (e->a & RMD_EV_TRIP_ECHOED))
		return say(buf, len, 4,
			   "%s: its comm-loss protection tripped: it echoed %s instead of running "
			   "it (its 0xF1 not heard): output off, brake locked; treated as lost",
			   v->ctx, echoed_name(e->a, cmd, sizeof(cmd)));
	if (e->b == RMD_MOTOR_CMD_COMM_LOST)
		return say(buf, len, 4,
			   "%s: its comm-loss protection tripped (0xF1): output off, brake locked; "
			   "treated as lost",
			   v->ctx);
	if (!code)
		return say(buf, len, 5, "%s: error flags cleared", v->ctx);
	n = rmd_error_names(rmdd_motor_dialect(cfg, e->motor), code, names, 8);
	list[0] = '\0';
	for (size_t k = 0; k < n && k < 8 && used < sizeof(list); k++)
		used += (size_t)snprintf(list + used, sizeof(list) - used, "%s%s", k ? ", " : "",
					 names[k]);
	return say(buf, len, 4, "%s: error flags 0x%04X (%s)", v->ctx, code,
		   n ? list : "unknown bits");
}

static void motor_error_text(const struct ev *v, char *buf, size_t len)
{
	char cmd[16];

	if (v->e->b == RMD_MOTOR_CMD_COMM_LOST && (v->e->a & RMD_EV_TRIP_ECHOED))
		snprintf(buf, len, "%s: its comm-loss protection tripped (%s echoed)", v->ctx,
			 echoed_name(v->e->a, cmd, sizeof(cmd)));
	else if (v->e->b == RMD_MOTOR_CMD_COMM_LOST)
		snprintf(buf, len, "%s: 0xF1, its comm-loss protection tripped", v->ctx);
	else if (v->e->a)
		snprintf(buf, len, "%s: error flags 0x%04X", v->ctx, (unsigned)(uint16_t)v->e->a);
	else
		snprintf(buf, len, "%s: error flags cleared", v->ctx);
}

/* ---- RMD_EV_BUS_STATE ------------------------------------------------------------ */

static int bus_state_line(const struct ev *v, char *buf, size_t len)
{
	enum rmd_bus_state s = (enum rmd_bus_state)v->e->a;

	switch (s) {
	case RMD_BUS_OFF:
		return say(buf, len, 3,
			   "%s: bus-off: the controller left the bus (a CAN interface needs "
			   "restart-ms, see systemd/80-can.network)",
			   v->bus);
	case RMD_BUS_PASSIVE:
	case RMD_BUS_WARNING:
		return say(buf, len, 4, "%s: error %s", v->bus, rmd_bus_state_name(s));
	case RMD_BUS_ACTIVE:
		return say(buf, len, 5, "%s: error active again", v->bus);
	case RMD_BUS_NO_ACK:
		return say(buf, len, 3,
			   "%s: no node acknowledges (the motors' power is off: an e-stop?): no "
			   "frame that acts on a motor is written to it; its motors are lost, and "
			   "each moves again only after it answered, echoed 0x80 and 0x78 and its "
			   "0xB3 (docs/faults.md \"E-stop\")",
			   v->bus);
	}
	return 0;
}

static void bus_state_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: bus %s", v->bus, rmd_bus_state_name((enum rmd_bus_state)v->e->a));
}

/* A bus leaving error-active. */
static const char *bus_state_incident(const struct ev *v)
{
	return v->e->a == RMD_BUS_ACTIVE ? NULL : "bus";
}

/* ---- RMD_EV_BUS_FLUSH ------------------------------------------------------------ */

/*
 * What a bus nobody acknowledges still held was dropped, or (refused) what
 * stays queued and what to do (docs/faults.md "E-stop";
 * docs/troubleshooting.md quotes both).
 */
static int bus_flush_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_config *cfg = v->cfg;
	const struct rmd_event *e = v->e;
	const struct rmd_config_bus *cb = e->bus < cfg->n_buses ? &cfg->buses[e->bus] : NULL;
	uint64_t b = (uint64_t)e->b;
	unsigned frames = (unsigned)(b & UINT32_MAX);
	uint32_t driven = (uint32_t)(b >> 32);
	char motors[256], advice[160];
	const char *iface;
	bool serial = false;
	size_t used = (size_t)snprintf(motors, sizeof(motors), "%s",
				       driven ? "among them the last setpoints of" :
						"no motor was driven");

	for (unsigned i = 0, k = 0; i < cfg->n_motors && i < 32 && used < sizeof(motors); i++)
		if (driven >> i & 1)
			used += (size_t)snprintf(motors + used, sizeof(motors) - used, "%s %s",
						 k++ ? "," : "", cfg->motors[i].name);
	if (!e->a)
		return say(
			buf, len, 5,
			"%s: the frames it still held are dropped (up to %u): none goes out when "
			"power returns",
			v->bus, frames);
	iface = cb ? rmd_config_bus_wire(cb, &serial) : NULL;
	if (iface && !serial)
		snprintf(advice, sizeof(advice),
			 "restart the interface before power returns (ip link set %s down; ip "
			 "link set %s up), or give rmdd CAP_NET_ADMIN",
			 iface, iface);
	else
		snprintf(advice, sizeof(advice),
			 "stop rmdd before power returns (its transport's queue goes with it)");
	return say(buf, len, 3,
		   "%s: the frames it holds could not be dropped (%s): up to %u, written before "
		   "the bus was found unacknowledged, go out when power returns (%s); %s "
		   "(docs/faults.md \"E-stop\")",
		   v->bus, strerror((int)-e->a), frames, motors, advice);
}

static void bus_flush_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: queued frames %s", v->bus,
		 v->e->a ? "could not be dropped" : "dropped");
}

/* ---- RMD_EV_OVERRUN -------------------------------------------------------------- */

/* The first of each RMDD_OVERRUN_SUMMARY_S now, the rest summed up by rmdd_event_overruns(). */
static int overrun_line(const struct ev *v, char *buf, size_t len)
{
	struct rmdd_event_notes *n = v->notes;
	const struct rmd_event *e = v->e;

	if (!n->overruns_pending && !n->overruns_logged) {
		n->overruns_logged = 1;
		n->overrun_window_ns = e->t_ns;
		return say(buf, len, 4,
			   "rt loop: overrun: woke %" PRId64 " period(s) late, skipped them", e->a);
	}
	n->overruns_pending++;
	n->skipped_pending += (uint64_t)(e->a > 0 ? e->a : 0);
	return 0;
}

int rmdd_event_overruns(struct rmdd_event_notes *n, int64_t now, char *buf, size_t len)
{
	int level = 0;

	if (!n->overruns_logged ||
	    now - n->overrun_window_ns < RMDD_OVERRUN_SUMMARY_S * RMD_NS_PER_S)
		return 0;
	if (n->overruns_pending)
		level = say(buf, len, 4,
			    "rt loop: %" PRIu64 " more overrun(s) in the last %d s, %" PRIu64
			    " period(s) skipped",
			    n->overruns_pending, RMDD_OVERRUN_SUMMARY_S, n->skipped_pending);
	n->overrun_window_ns = now;
	n->overruns_logged = n->overruns_pending ? 1 : 0;
	n->overruns_pending = 0;
	n->skipped_pending = 0;
	return level;
}

static void overrun_text(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;

	if (e->b > 0 && e->b < e->a)
		snprintf(buf, len,
			 "rt loop: overrun, %" PRId64 " period(s) skipped, at most %" PRId64
			 " at once",
			 e->a, e->b);
	else
		snprintf(buf, len, "rt loop: overrun, %" PRId64 " period(s) skipped", e->a);
}

/* An overrun of incidents.overrun_burst periods at once. */
static const char *overrun_incident(const struct ev *v)
{
	return v->e->b < (int64_t)v->cfg->incidents.overrun_burst ? NULL : "overrun";
}

/* ---- RMD_EV_WATCHDOG ------------------------------------------------------------- */

static int watchdog_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_config *cfg = v->cfg;

	switch ((enum rmd_watchdog_state)v->e->a) {
	case RMD_WD_TRIPPED:
		return say(
			buf, len, 4,
			"controller: no command for %u ms for an enabled motor: safe action %s on "
			"each such motor (each has its own deadline), held until its owner sends "
			"enable = 0, then enable = 1",
			(unsigned)cfg->safety.command_timeout_ms,
			rmd_safe_action_name(cfg->safety.safe_action));
	case RMD_WD_OK:
		return say(buf, len, 5, "controller: commands arrive, motors enabled");
	case RMD_WD_IDLE:
		return say(buf, len, 6, "controller: idle");
	}
	return 0;
}

static void watchdog_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "host watchdog: %s",
		 v->e->a == RMD_WD_TRIPPED ? "tripped (no command in time)" :
		 v->e->a == RMD_WD_OK	   ? "ok (commands arrive)" :
					     "idle");
}

static const char *watchdog_incident(const struct ev *v)
{
	return v->e->a == RMD_WD_TRIPPED ? "watchdog" : NULL;
}

/* ---- RMD_EV_SAFE_ACTION ---------------------------------------------------------- */

/* The shutdown's (b = 1) is noted: its SAFE line, next, says it. */
static int safe_action_line(const struct ev *v, char *buf, size_t len)
{
	if (v->e->b == 1) {
		v->notes->shutdown_sent = (int)v->e->a;
		return 0;
	}
	return say(buf, len, 7, "%s: safe action %s sent", v->ctx,
		   rmd_safe_action_name((enum rmd_safe_action)v->e->a));
}

static void safe_action_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: %s %s sent", v->ctx, v->e->b == 1 ? "shutdown:" : "safe action",
		 rmd_safe_action_name((enum rmd_safe_action)v->e->a));
}

/* The shutdown's stop or hold is not a safety event. */
static const char *safe_action_incident(const struct ev *v)
{
	return v->e->b == 1 ? NULL : "safe";
}

/* ---- RMD_EV_SEND_FAILED ---------------------------------------------------------- */

static int send_failed_line(const struct ev *v, char *buf, size_t len)
{
	return say(buf, len, 4, "%s: send failed (%s): %" PRId64 " frame(s) not sent", v->bus,
		   v->e->a ? strerror((int)-v->e->a) : "queue full", v->e->b);
}

static void send_failed_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: send failed (%s), %" PRId64 " frame(s) not sent", v->bus,
		 v->e->a ? strerror((int)-v->e->a) : "queue full", v->e->b);
}

/* ---- RMD_EV_UNEXPECTED ----------------------------------------------------------- */

static int unexpected_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;

	if (e->b >= 0)
		return say(buf, len, 5,
			   "%s: unexpected frame 0x%03" PRIX64 " command 0x%02" PRIX64
			   " (neither a reply nor a report; at most one such line a second)",
			   v->bus, (uint64_t)e->a, (uint64_t)e->b);
	return say(buf, len, 5, "%s: unexpected empty frame 0x%03" PRIX64, v->bus, (uint64_t)e->a);
}

static void unexpected_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: unexpected frame 0x%03" PRIX64, v->bus, (uint64_t)v->e->a);
}

/* ---- RMD_EV_RT ------------------------------------------------------------------- */

/* Noted: the refusals of one drain are said together after it (rmdd_event_rt_lines()). */
static int rt_line(const struct ev *v, char *buf, size_t len)
{
	struct rmdd_event_notes *n = v->notes;
	const struct rmd_event *e = v->e;

	(void)buf;
	(void)len;
	if (e->b == RMD_LOOP_RT_CPU_AWAKE) {
		n->rt_err[e->b] = e->a ? (int)e->a : -EPERM;
	} else if (e->b > 0 && e->b < RMD_LOOP_RT_CPU_AWAKE) {
		n->rt_any = true;
		n->rt_err[e->b] = e->a ? (int)e->a : -EPERM;
	}
	return 0;
}

/* Take refusal k's error out of the notes (0: none). */
static int rt_take(struct rmdd_event_notes *n, unsigned k)
{
	int err = n->rt_err[k];

	n->rt_err[k] = 0;
	return err;
}

/*
 * One line a refusal, in this order, each saying what follows from it and
 * what gives it (docs/troubleshooting.md "Real-time limits": limits.d for a
 * user, the unit's limits under systemd).
 */
int rmdd_event_rt_lines(struct rmdd_event_notes *n, char *buf, size_t len)
{
	int err;

	if ((err = rt_take(n, RMD_LOOP_RT_CPU_AWAKE)))
		return say(
			buf, len, 5,
			"CPU wake-up latency not held at 0 us (/dev/cpu_dma_latency: %s): on an "
			"idle machine the loop and the bridge wake from idle states later. Give "
			"rmdd write access to it, or set loop.keep_cpus_awake: false to keep this "
			"power saving",
			strerror(-err));
	if (!n->rt_any) {
		memset(n->rt_err, 0, sizeof(n->rt_err));
		return 0;
	}
	if ((err = rt_take(n, RMD_LOOP_RT_FIFO)))
		return say(
			buf, len, 4,
			"no real-time priority: SCHED_FIFO refused (%s): the loop runs at normal "
			"priority, so a busy machine wakes it late (overruns, slower replies; "
			"the simulated motors are not lost for it). Give the user rtprio 49 in "
			"/etc/security/limits.d/ and log in again (docs/troubleshooting.md "
			"\"Real-time limits\"), or run it as rmdd.service (LimitRTPRIO=49); "
			"--require-rt refuses to run without it",
			strerror(-err));
	if ((err = rt_take(n, RMD_LOOP_RT_MLOCK)))
		return say(buf, len, 4,
			   "no memory lock: mlockall failed (%s): a page of the loop's that the "
			   "kernel pages out stalls it when touched again. Give the user memlock "
			   "unlimited in /etc/security/limits.d/ and log in again "
			   "(docs/troubleshooting.md \"Real-time limits\"), or run it as "
			   "rmdd.service (LimitMEMLOCK=infinity); --require-rt refuses to run "
			   "without it",
			   strerror(-err));
	if ((err = rt_take(n, RMD_LOOP_RT_AFFINITY)))
		return say(buf, len, 4,
			   "no CPU affinity: it was refused (%s): the loop runs on whichever CPU "
			   "the kernel picks. loop.cpu_affinity must name CPUs rmdd may use "
			   "(taskset -cp $$ lists them)",
			   strerror(-err));
	n->rt_any = false;
	memset(n->rt_err, 0, sizeof(n->rt_err));
	return 0;
}

static void rt_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "rt loop: real-time request %" PRId64 " refused", v->e->b);
}

/* ---- RMD_EV_COMM_LOSS ------------------------------------------------------------ */

/* Armed by the loop (info), or not, and an enable refused (warning). */
static int comm_loss_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;
	uint32_t ms = e->motor < v->cfg->n_motors ? rmd_config_comm_loss_ms(v->cfg, e->motor) : 0;
	const char *why = e->a == RMD_CL_DIFFERS ? "it answered 0xB3 with another time" :
						   "it did not answer 0xB3";

	if (e->a == RMD_CL_ARMED || e->a == RMD_CL_ARMED_ZEROS)
		return say(buf, len, 6, "%s: comm-loss protection (0xB3) %u ms set, %s", v->ctx,
			   (unsigned)ms,
			   e->a == RMD_CL_ARMED ? "echo verified" :
						  "answered zeros, not verified (V3 §2.30)");
	if (e->b)
		return say(buf, len, 4,
			   "%s: enable refused: its comm-loss protection (0xB3) is not set (%s); "
			   "further refusals are counted in health_t",
			   v->ctx, why);
	return say(buf, len, 4,
		   "%s: comm-loss protection (0xB3) not set: %s; it cannot be enabled until it is",
		   v->ctx, why);
}

/* enum rmd_comm_loss in a few words. */
static const char *comm_loss_words(int64_t cl)
{
	static const char *const names[RMD_CL_COUNT] = {
		[RMD_CL_PENDING] = "pending",
		[RMD_CL_ARMED] = "armed (echo verified)",
		[RMD_CL_ARMED_ZEROS] = "armed (answered zeros)",
		[RMD_CL_NO_ANSWER] = "not set: no answer",
		[RMD_CL_DIFFERS] = "not set: answered another time",
		[RMD_CL_OFF] = "off by config",
		[RMD_CL_UNSUPPORTED] = "unsupported (V2)",
	};

	return cl >= 0 && cl < RMD_CL_COUNT ? names[cl] : "?";
}

static void comm_loss_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: comm-loss protection %s%s", v->ctx, comm_loss_words(v->e->a),
		 v->e->b ? ", enable refused" : "");
}

/* ---- RMD_EV_LATE ----------------------------------------------------------------- */

static int late_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;

	if (e->b == RMD_MOTOR_CMD_MIT)
		return say(
			buf, len, 6,
			"%s: the answer to an MIT frame came %.1f ms after it was sent, after "
			"rmdd gave it up: counted late, not used (at most one such line a second)",
			v->ctx, (double)e->a / 1e6);
	return say(buf, len, 6,
		   "%s: the answer to 0x%02" PRIX64 " came %.1f ms after it was sent, after rmdd "
		   "gave it up: counted late, not used (at most one such line a second)",
		   v->ctx, (uint64_t)e->b, (double)e->a / 1e6);
}

static void late_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: a late answer, %.1f ms after its request", v->ctx,
		 (double)v->e->a / 1e6);
}

/* ---- RMD_EV_POSITION, RMD_EV_POS_REFUSED, RMD_EV_HOME_REFUSED -------------------- */

/* One rotor turn at the motor's output, in degrees (360 for a motor out of range). */
static double turn_deg(const struct ev *v)
{
	return v->e->motor < v->cfg->n_motors ? 360.0 / v->cfg->motors[v->e->motor].gear_ratio :
						360.0;
}

/*
 * Whether a motor's position can be trusted after it (re)appeared, or was
 * homed.  docs/faults.md "Position uncertain after power-off".
 */
static int position_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;

	switch ((enum rmd_pos_trust)e->a) {
	case RMD_POS_SAVED:
		return say(buf, len, 6,
			   "%s: position certain: the motor keeps its multi-turn count", v->ctx);
	case RMD_POS_IN_BAND:
		/* a shift is news (the motor was powered off, or first seen off by turns) */
		if (e->b)
			return say(buf, len, 5,
				   "%s: position certain: one position in its travel band fits; "
				   "shifted by %.6f rad (whole rotor turns)",
				   v->ctx, (double)e->b * 1e-6);
		return say(buf, len, 6,
			   "%s: position certain: one position in its travel band fits", v->ctx);
	case RMD_POS_HOMED:
		return say(buf, len, 5, "%s: homed: position certain, shifted by %.6f rad", v->ctx,
			   (double)e->b * 1e-6);
	case RMD_POS_AMBIGUOUS: /* notice: a torque-only robot never needs more */
		return say(buf, len, 5,
			   "%s: position uncertain: its travel band is not narrower than one rotor "
			   "turn at the output (%g deg); position mode and MIT with kp > 0 are "
			   "refused until it is homed (docs/faults.md)",
			   v->ctx, turn_deg(v));
	case RMD_POS_OUTSIDE:
		return say(
			buf, len, 4,
			"%s: position uncertain: no position in its travel band fits what it "
			"reports (outside its travel, or travel_rad wrong); home it (docs/faults.md)",
			v->ctx);
	case RMD_POS_UNKNOWN:
	case RMD_POS_TRUST_COUNT:
		break;
	}
	return 0;
}

/* A setpoint that drives to a position refused for an uncertain one (once per episode). */
static int pos_refused_line(const struct ev *v, char *buf, size_t len)
{
	return say(
		buf, len, 4,
		"%s: %s refused: its position is uncertain (it may have been powered off: the "
		"multi-turn count is lost). Torque, speed and MIT with kp = 0 still run. Home it "
		"(rmd.home_t on the HOME channel), or set travel_rad narrower than %g deg or "
		"multi_turn_saved (docs/faults.md); further refusals are counted in health_t",
		v->ctx, rmd_mode_name((enum rmd_mode)v->e->b), turn_deg(v));
}

static int home_refused_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;
	double lo = -INFINITY, hi = INFINITY;

	if (e->a == RMD_HOME_OUTSIDE) {
		if (e->motor < v->cfg->n_motors)
			rmd_config_travel(&v->cfg->motors[e->motor], &lo, &hi);
		return say(buf, len, 4,
			   "%s: homing refused: %g rad (%g deg) is outside its travel [%g, %g] rad "
			   "(travel_rad, else its position limits): the frame would move so that "
			   "setpoints within its limits drive it past them (degrees sent for "
			   "radians?); refusals are counted in health_t",
			   v->ctx, (double)e->b / 1e6, (double)e->b / 1e6 * 180.0 / M_PI, lo, hi);
	}
	return say(buf, len, 4, "%s: homing refused: %s", v->ctx,
		   e->a == RMD_HOME_ENABLED ?
			   "the motor is enabled (disable it first: its position must not jump "
			   "under a running loop)" :
			   "it has not reported a position since it (re)appeared; try again");
}

static void position_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: position %s", v->ctx,
		 rmd_pos_trusted((unsigned)v->e->a) ? "certain" : "uncertain");
}

static void pos_refused_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: %s refused, position uncertain", v->ctx,
		 rmd_mode_name((enum rmd_mode)v->e->b));
}

/* docs/protocol-v4.md "Firmware in the field": 0xA4 ignored after an MIT frame */
static int fw_refused_line(const struct ev *v, char *buf, size_t len)
{
	return say(buf, len, 4,
		   "%s: %s refused: its firmware (%" PRId64 ") ignores 0xA4 after an MIT frame "
		   "until it is reset (a field report), and it has had MIT frames: reset it "
		   "(rmdctl reset, or a power cycle) to run position mode, or keep to MIT, "
		   "torque and speed; further refusals are counted in "
		   "health_t.ignored_by_kind[IGN_FIRMWARE]",
		   v->ctx, rmd_mode_name((enum rmd_mode)v->e->b), v->e->a);
}

static void fw_refused_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: %s refused, its firmware ignores 0xA4 after MIT", v->ctx,
		 rmd_mode_name((enum rmd_mode)v->e->b));
}

/* rmd/proc_effect.h: a motor driven to a position that does not move */
static int no_effect_line(const struct ev *v, char *buf, size_t len)
{
	return say(buf, len, 4,
		   "%s: its position commands show no effect: it has not moved %.1f deg in %" PRId64
		   " ms while its target is %.1f deg away (blocked, or firmware that takes 0xA4 "
		   "and does not run it: docs/faults.md); state_t says where it is, not the target",
		   v->ctx, RMD_EFFECT_MOVE_RAD * 180.0 / M_PI, v->e->b,
		   (double)v->e->a / 1e6 * 180.0 / M_PI);
}

static void no_effect_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: position commands show no effect (%.1f deg from its target)",
		 v->ctx, (double)v->e->a / 1e6 * 180.0 / M_PI);
}

static void home_refused_text(const struct ev *v, char *buf, size_t len)
{
	if (v->e->a == RMD_HOME_OUTSIDE)
		snprintf(buf, len, "%s: homing at %g rad refused, outside its travel", v->ctx,
			 (double)v->e->b / 1e6);
	else
		snprintf(buf, len, "%s: homing refused", v->ctx);
}

/* ---- RMD_EV_DIALECT -------------------------------------------------------------- */

/*
 * A motor missing at bring-up answered with firmware of another dialect
 * than its own: it stays out (warning).  docs/protocol-v4.md "Which dialect
 * a motor speaks".
 */
static int dialect_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;
	const struct rmd_config_motor *c = e->motor < v->cfg->n_motors ? &v->cfg->motors[e->motor] :
									 NULL;
	const struct rmd_dialect *d = rmd_dialect((enum rmd_proto)e->b); /* what it speaks */
	const char *key = rmd_proto_key((enum rmd_proto)e->b);
	char how[96];

	/* a firmware date said it, or (none) its status answer on that dialect's identifier */
	if (e->a || !d)
		snprintf(how, sizeof(how), ": its firmware %" PRId64 " is %s", e->a, key);
	else
		snprintf(how, sizeof(how), ", in %s (its status on 0x%03X)", key,
			 d->reply_base + (c ? c->id : 0u));
	if (!c || c->proto_auto)
		return say(
			buf, len, 4,
			"%s: answered at last%s, but with protocol: auto a motor missing at "
			"bring-up is taken for v3; left out: restart rmdd to bring it up (or set "
			"protocol: %s)",
			v->ctx, how, key);
	return say(buf, len, 4,
		   "%s: answered at last%s, but its protocol is %s; left out (set protocol: %s, or "
		   "auto)",
		   v->ctx, how, rmd_proto_key(c->proto), key);
}

static void dialect_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: left out, its firmware (%" PRId64 ") is %s", v->ctx, v->e->a,
		 rmd_proto_key((enum rmd_proto)v->e->b));
}

/* ---- RMD_EV_STRAY ---------------------------------------------------------------- */

static int stray_line(const struct ev *v, char *buf, size_t len)
{
	return say(
		buf, len, 4,
		"%s: motor %" PRId64 " answered on 0x%03" PRIX64
		", and the configuration does not list it: a 0x280 frame would command it; %s "
		"sends each batched motor frames of its own from now on (fewer a cycle: rmdd "
		"--check-config says how many); add it to the file, take it off the bus, or turn "
		"its CAN-ID filter on (0x20 index 2 = 1) and set can_id_filter: true for the bus",
		v->bus, v->e->b, (uint64_t)v->e->a, v->bus);
}

static void stray_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len,
		 "%s: motor %" PRId64 ", not in the configuration, answered on 0x%03" PRIX64
		 ": no 0x280 frame from now on",
		 v->bus, v->e->b, (uint64_t)v->e->a);
}

/* It may have taken a 0x280 frame for its own command. */
static const char *stray_incident(const struct ev *v)
{
	(void)v;
	return "stray";
}

/* ---- RMD_EV_MIT_SCALING, RMD_EV_MIT_REFUSED -------------------------------------- */

/* An MIT enable refused while its scaling is not decided.  docs/protocol-v4.md "MIT scaling". */
static int mit_refused_line(const struct ev *v, char *buf, size_t len)
{
	return say(buf, len, 4,
		   "%s: MIT refused: its MIT scaling is not decided (its firmware's date and model "
		   "not read: bring-up decides it); counted in "
		   "health_t.ignored_by_kind[IGN_MIT_SCALING]",
		   v->ctx);
}

/* A motor in MIT mode missing at bring-up: its MIT scaling undecided when it answered at last. */
static int mit_scaling_line(const struct ev *v, char *buf, size_t len)
{
	const struct rmd_event *e = v->e;
	const struct rmd_config_motor *c = e->motor < v->cfg->n_motors ? &v->cfg->motors[e->motor] :
									 NULL;
	const struct rmd_dialect *d;
	struct rmd_mit_decision dec;
	char model[8], why[512];
	unsigned series = (unsigned)(e->b >> 8) & 0xFF;

	if (!c)
		return mit_refused_line(v, buf, len);
	/* the loop's decision again, on the series it saw */
	model[0] = '\0';
	if (series)
		snprintf(model, sizeof(model), "X%u", series % 1000u);
	d = rmd_dialect(rmdd_motor_dialect(v->cfg, e->motor));
	rmd_mit_scaling_decide(d, (uint32_t)e->a, model, &c->mit, c->mit_given, &dec);
	rmdd_mit_text(d, &dec, (uint32_t)e->a, model, why, sizeof(why));
	return say(buf, len, 4,
		   "%s: answered at last, %s; left out (restart rmdd once its entry says it)",
		   v->ctx, why);
}

static void mit_scaling_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: left out, its MIT scaling undecided (firmware %" PRId64 ")", v->ctx,
		 v->e->a);
}

static void mit_refused_text(const struct ev *v, char *buf, size_t len)
{
	snprintf(buf, len, "%s: MIT refused, its MIT scaling not decided", v->ctx);
}

/* ---- RMD_EV_REBOOT --------------------------------------------------------------- */

/* An event's b of int32 of 0.01 deg, high and low half, in degrees. */
static double cdeg_hi(int64_t b)
{
	return (double)(int32_t)(uint32_t)((uint64_t)b >> 32) / 100.0;
}

static double cdeg_lo(int64_t b)
{
	return (double)(int32_t)(uint32_t)b / 100.0;
}

/*
 * What an RMD_EV_REBOOT says and the signal that saw it, in a few words:
 * "rebooted (runtime 3 ms, it would have run at least 5 ms: 0xB1)".
 */
static void reboot_text(const struct rmd_event *e, char *buf, size_t len)
{
	bool lost, no_check;

	switch ((enum rmd_reboot_report)e->a) {
	case RMD_REBOOT_BY_RUNTIME:
		snprintf(buf, len,
			 "rebooted (runtime %" PRIu32 " ms, it would have run at least %" PRIu32
			 " ms: 0xB1)",
			 (uint32_t)((uint64_t)e->b >> 32), (uint32_t)e->b);
		break;
	case RMD_REBOOT_BY_TURNS:
	case RMD_REBOOT_COUNT_ASTRAY:
		lost = e->a == RMD_REBOOT_BY_TURNS;
		snprintf(
			buf, len,
			"%s (its multi-turn angle %.2f deg, rmdd's count of its encoder "
			"%.2f deg: %s)",
			lost ? "rebooted" : "count astray", cdeg_hi(e->b), cdeg_lo(e->b),
			lost ? "its count lost, 0x92" :
			       "not whole turns apart, so no reboot; none judged by it until found "
			       "again (gear_ratio?)");
		break;
	case RMD_REBOOT_BY_BRAKE:
		snprintf(buf, len,
			 "rebooted (its brake locked after it reported it released: 0x9A)");
		break;
	case RMD_REBOOT_NO_CHECK:
	case RMD_REBOOT_UNTOLD:
		no_check = e->a == RMD_REBOOT_NO_CHECK;
		snprintf(
			buf, len, "%s0x%02" PRIX64 "%s",
			no_check ? "does not answer " :
				   "whether it rebooted is untold: its answers to ",
			(uint64_t)e->b,
			no_check ?
				": a short power cycle is seen only by its brake (0x9A) from now on" :
				" could not tell");
		break;
	default:
		snprintf(buf, len, "reboot check %" PRId64, e->a);
		break;
	}
}

/*
 * A motor's reboot check (rmd/reboot.h): a reboot is lost and back at
 * once (the state events that follow); a check that cannot run.
 */
static int reboot_line(const struct ev *v, char *buf, size_t len)
{
	char what[320];

	reboot_text(v->e, what, sizeof(what));
	if (v->e->a == RMD_REBOOT_NO_CHECK || v->e->a == RMD_REBOOT_UNTOLD ||
	    v->e->a == RMD_REBOOT_COUNT_ASTRAY)
		return say(buf, len, 4, "%s: %s", v->ctx, what);
	return say(buf, len, 4,
		   "%s: %s; treated as lost and back: its position and 0xB3 decided again before "
		   "anything moves it",
		   v->ctx, what);
}

static void reboot_summary(const struct ev *v, char *buf, size_t len)
{
	char what[320];

	reboot_text(v->e, what, sizeof(what));
	snprintf(buf, len, "%s: %s", v->ctx, what);
}

/* ---- the table ------------------------------------------------------------------- */

struct row {
	const char *name;
	/* The journal line: its level (0: none) and text; stateful rows note into v->notes. */
	int (*journal)(const struct ev *v, char *buf, size_t len);
	/* Its line in an incident's summary ("what happened"), in a few words. */
	void (*summary)(const struct ev *v, char *buf, size_t len);
	/* Whether it starts an incident: the recording's kind ("lost"), or NULL; NULL: never. */
	const char *(*incident)(const struct ev *v);
};

#define ROW(kind, j, s, i) \
	[RMD_EV_##kind] = { .name = #kind, .journal = j, .summary = s, .incident = i }

static const struct row rows[] = {
	ROW(MOTOR_STATE, motor_state_line, motor_state_text, motor_state_incident),
	/* the FAULT or LOST that follows is the incident */
	ROW(MOTOR_ERROR, motor_error_line, motor_error_text, NULL),
	ROW(BUS_STATE, bus_state_line, bus_state_text, bus_state_incident),
	ROW(OVERRUN, overrun_line, overrun_text, overrun_incident),
	ROW(WATCHDOG, watchdog_line, watchdog_text, watchdog_incident),
	ROW(SAFE_ACTION, safe_action_line, safe_action_text, safe_action_incident),
	ROW(SEND_FAILED, send_failed_line, send_failed_text, NULL),
	ROW(UNEXPECTED, unexpected_line, unexpected_text, NULL),
	ROW(RT, rt_line, rt_text, NULL),
	ROW(COMM_LOSS, comm_loss_line, comm_loss_text, NULL),
	ROW(LATE, late_line, late_text, NULL),
	ROW(POSITION, position_line, position_text, NULL),
	ROW(POS_REFUSED, pos_refused_line, pos_refused_text, NULL),
	ROW(FW_REFUSED, fw_refused_line, fw_refused_text, NULL),
	ROW(NO_EFFECT, no_effect_line, no_effect_text, NULL),
	ROW(HOME_REFUSED, home_refused_line, home_refused_text, NULL),
	ROW(DIALECT, dialect_line, dialect_text, NULL),
	ROW(STRAY, stray_line, stray_text, stray_incident),
	ROW(MIT_SCALING, mit_scaling_line, mit_scaling_text, NULL),
	ROW(MIT_REFUSED, mit_refused_line, mit_refused_text, NULL),
	/* the LOST a reboot makes is the incident */
	ROW(REBOOT, reboot_line, reboot_summary, NULL),
	/* its RMD_EV_BUS_STATE is the incident */
	ROW(BUS_FLUSH, bus_flush_line, bus_flush_text, NULL),
};

_Static_assert(sizeof(rows) / sizeof(rows[0]) == RMD_EV_COUNT,
	       "one row per enum rmd_event_kind (rmd/state.h)");

/* Kind k's row; NULL for a kind the table has no (whole) row for. */
static const struct row *row_of(unsigned k)
{
	return k < RMD_EV_COUNT && rows[k].journal && rows[k].summary ? &rows[k] : NULL;
}

/* What e is worded from, into *v; ctx: CTX_LEN bytes for its motor's context. */
#define CTX_LEN 96
static void ev_init(struct ev *v, const struct rmd_config *cfg, const struct rmd_event *e,
		    struct rmdd_event_notes *n, char *ctx)
{
	rmdd_motor_ctx(cfg, e->motor, ctx, CTX_LEN);
	*v = (struct ev){
		.cfg = cfg,
		.e = e,
		.ctx = ctx,
		.bus = rmdd_bus_name(cfg, e->bus),
		.notes = n,
	};
}

/* A kind without a row, in the journal (debug) and in a summary. */
static int no_row(const struct rmd_event *e, char *buf, size_t len)
{
	return say(buf, len, 7, "event %u (a %" PRId64 ", b %" PRId64 ")", e->kind, e->a, e->b);
}

const char *rmdd_event_name(unsigned kind)
{
	const struct row *r = row_of(kind);

	return r ? r->name : NULL;
}

void rmdd_event_notes_init(struct rmdd_event_notes *n, const struct rmd_config *cfg)
{
	memset(n, 0, sizeof(*n));
	n->cfg = cfg;
	n->shutdown_sent = -1;
}

int rmdd_event_journal(struct rmdd_event_notes *n, const struct rmd_event *e, char *buf, size_t len)
{
	const struct row *r = row_of(e->kind);
	char ctx[CTX_LEN];
	struct ev v;

	if (!r)
		return no_row(e, buf, len);
	ev_init(&v, n->cfg, e, n, ctx);
	return r->journal(&v, buf, len);
}

void rmdd_event_summary(const struct rmd_config *cfg, const struct rmd_event *e, char *buf,
			size_t len)
{
	const struct row *r = row_of(e->kind);
	char ctx[CTX_LEN];
	struct ev v;

	if (!r) {
		no_row(e, buf, len);
		return;
	}
	ev_init(&v, cfg, e, NULL, ctx);
	r->summary(&v, buf, len);
}

bool rmdd_incident_kind(const struct rmd_config *cfg, const struct rmd_event *e, char *what,
			size_t len, const char **kind)
{
	const struct row *r = row_of(e->kind);
	const char *k;
	char ctx[CTX_LEN];
	struct ev v;

	if (!r || !r->incident)
		return false;
	ev_init(&v, cfg, e, NULL, ctx);
	k = r->incident(&v);
	if (!k)
		return false;
	*kind = k;
	r->summary(&v, what, len);
	return true;
}
