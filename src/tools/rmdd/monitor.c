// SPDX-License-Identifier: MIT
/*
 * rmdd's monitor thread (it logs through tools/common/log.h: one line per
 * call on stderr, "<N>rmdd: ..." with the syslog level N, STYLE.md).
 *
 * The monitor is a normal-priority thread that sleeps until the rt loop
 * writes its eventfd (at the end of a cycle that pushed events; issue 11:
 * no polling) and then drains the loop's event ring and logs each event
 * with its context ("can0: motor 3 (knee_l): lost (10 missed replies in a
 * row)"); the loop sends events only on change, and overruns are summed up
 * to one line a second here (the only timed wake-up, while a summary is
 * open).  Reply latencies are the loop's own (rmd_loop_get_reply_latency()).
 * Everything here is non-rt.
 */
#define _GNU_SOURCE /* pthread_setname_np */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/eventfd.h>

#include "rmd/time.h"
#include "rmd/hist.h"
#include "rmd/motor.h"
#include "rmd/thread.h"
#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmdd.h"

/* ---- events ---------------------------------------------------------------- */

/*
 * A motor's reboot check (rmd/reboot.h): a reboot is lost and back at
 * once (the state events that follow); a check that cannot run.
 */
static void log_reboot(const struct rmd_config *cfg, const struct rmd_event *e)
{
	char ctx[96], what[192];

	rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
	rmdd_reboot_text(e, what, sizeof(what));
	if (e->a == RMD_REBOOT_NO_CHECK || e->a == RMD_REBOOT_UNTOLD)
		tool_log(4, "%s: %s", ctx, what);
	else
		tool_log(4,
			 "%s: %s; treated as lost and back: its position and 0xB3 decided "
			 "again before anything moves it",
			 ctx, what);
}

/*
 * A motor's change of state.  shutdown_sent: the shutdown's stop or hold
 * sent to it just before (enum rmd_safe_action), or -1.
 */
static void log_motor_state(const struct rmd_config *cfg, const struct rmd_event *e,
			    int shutdown_sent)
{
	const char *action = rmd_safe_action_name(cfg->safety.safe_action);
	unsigned from = (unsigned)e->a, to = (unsigned)e->b;
	char ctx[96];

	rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
	switch ((enum rmd_lifecycle)to) {
	case RMD_LC_LOST:
		if (from == RMD_LC_PROBE)
			tool_log(4,
				 "%s: not brought up (the report above says why); a missing motor "
				 "is probed again every %d ms",
				 ctx, (int)(RMD_LOOP_REPROBE_NS / 1000000));
		else
			tool_log(4,
				 "%s: lost (%u missed replies in a row, or a 0xF1 or a reboot "
				 "above)%s%s; probed again every %d ms",
				 ctx, cfg->safety.missed_replies_lost,
				 from == RMD_LC_ENABLED ? "; safe action " : "",
				 from == RMD_LC_ENABLED ? action : "",
				 (int)(RMD_LOOP_REPROBE_NS / 1000000));
		break;
	case RMD_LC_FAULT:
		/* lifecycle.c: a faulted motor runs no control command, so no safe action */
		tool_log(4, "%s: fault (error flags set); output off (0x80)%s", ctx,
			 rmd_config_fault_brakes(cfg) ? ", brake locked (0x78)" : "");
		break;
	case RMD_LC_SAFE:
		if (shutdown_sent == RMD_SAFE_HOLD)
			tool_log(5, "%s: shutdown: hold (0x81) sent, held by its drive", ctx);
		else if (shutdown_sent >= 0)
			tool_log(5, "%s: shutdown: stop (0x80) sent, output off, brake as it was",
				 ctx);
		else
			tool_log(4,
				 "%s: safe action %s, held until the controller enables it again",
				 ctx, action);
		break;
	case RMD_LC_STOPPING:
		if (from == RMD_LC_LOST || from == RMD_LC_FAULT)
			tool_log(
				5,
				"%s: back (%s -> stopping); send enable 0, then 1, to run it again",
				ctx, rmdd_lifecycle_name(from));
		else
			tool_log(from == RMD_LC_PROBE ? 7 : 6, "%s: %s -> stopping", ctx,
				 rmdd_lifecycle_name(from));
		break;
	case RMD_LC_READY:
		/* from STOPPING only: the motor echoed output off and brake locked */
		tool_log(7, "%s: ready (output off, brake locked)", ctx);
		break;
	case RMD_LC_ENABLED:
		tool_log(6, "%s: enabled", ctx);
		break;
	case RMD_LC_PROBE:
	case RMD_LC_COUNT:
		tool_log(7, "%s: %s -> %s", ctx, rmdd_lifecycle_name(from),
			 rmdd_lifecycle_name(to));
		break;
	}
}

static void log_motor_error(const struct rmd_config *cfg, const struct rmd_event *e)
{
	const char *names[8];
	char ctx[96], list[256];
	uint16_t code = (uint16_t)e->a;
	enum rmd_proto proto = RMD_PROTO_V3;
	size_t n, used = 0;

	rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
	if (e->b == RMD_MOTOR_CMD_COMM_LOST) {
		/* docs/design.md: the motor heard nothing for its 0xB3 time */
		tool_log(4,
			 "%s: its comm-loss protection tripped (0xF1): output off, brake locked; "
			 "treated as lost",
			 ctx);
		return;
	}
	if (!code) {
		tool_log(5, "%s: error flags cleared", ctx);
		return;
	}
	if (e->motor < cfg->n_motors)
		proto = cfg->motors[e->motor].proto; /* its dialect's flags */
	n = rmd_error_names(proto, code, names, 8);
	list[0] = '\0';
	for (size_t k = 0; k < n && k < 8 && used < sizeof(list); k++)
		used += (size_t)snprintf(list + used, sizeof(list) - used, "%s%s", k ? ", " : "",
					 names[k]);
	tool_log(4, "%s: error flags 0x%04X (%s)", ctx, code, n ? list : "unknown bits");
}

/* RMD_EV_COMM_LOSS: armed by the loop (info), or not, and an enable refused (warning). */
static void log_comm_loss(const struct rmd_config *cfg, const struct rmd_event *e)
{
	uint32_t ms = e->motor < cfg->n_motors ? rmd_config_comm_loss_ms(cfg, e->motor) : 0;
	const char *why = e->a == RMD_CL_DIFFERS ? "it answered 0xB3 with another time" :
						   "it did not answer 0xB3";
	char ctx[96];

	rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
	if (e->a == RMD_CL_ARMED || e->a == RMD_CL_ARMED_ZEROS) {
		tool_log(6, "%s: comm-loss protection (0xB3) %u ms set, %s", ctx, (unsigned)ms,
			 e->a == RMD_CL_ARMED ? "echo verified" :
						"answered zeros, not verified (V3 §2.30)");
		return;
	}
	if (e->b)
		tool_log(4,
			 "%s: enable refused: its comm-loss protection (0xB3) is not set (%s); "
			 "further refusals are counted in health_t",
			 ctx, why);
	else
		tool_log(4,
			 "%s: comm-loss protection (0xB3) not set: %s; it cannot be enabled "
			 "until it is",
			 ctx, why);
}

/*
 * RMD_EV_POSITION: whether a motor's position can be trusted after it
 * (re)appeared, or was homed; RMD_EV_POS_REFUSED: a setpoint that drives to
 * a position refused for an uncertain one (once per episode: warning).
 * docs/faults.md "Position uncertain after power-off".
 */
static void log_position(const struct rmd_config *cfg, const struct rmd_event *e)
{
	const struct rmd_config_motor *c = e->motor < cfg->n_motors ? &cfg->motors[e->motor] : NULL;
	double turn_deg = c ? 360.0 / c->gear_ratio : 360.0;
	char ctx[96];

	rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
	if (e->kind == RMD_EV_HOME_REFUSED && e->a == RMD_HOME_OUTSIDE) {
		double lo = -INFINITY, hi = INFINITY;

		if (c)
			rmd_config_travel(c, &lo, &hi);
		tool_log(4,
			 "%s: homing refused: %g rad (%g deg) is outside its travel [%g, %g] rad "
			 "(travel_rad, else its position limits): the frame would move so that "
			 "setpoints within its limits drive it past them (degrees sent for "
			 "radians?); refusals are counted in health_t",
			 ctx, (double)e->b / 1e6, (double)e->b / 1e6 * 180.0 / M_PI, lo, hi);
		return;
	}
	if (e->kind == RMD_EV_HOME_REFUSED) {
		tool_log(4, "%s: homing refused: %s", ctx,
			 e->a == RMD_HOME_ENABLED ?
				 "the motor is enabled (disable it first: its position must not "
				 "jump under a running loop)" :
				 "it has not reported a position since it (re)appeared; try again");
		return;
	}
	if (e->kind == RMD_EV_POS_REFUSED) {
		tool_log(4,
			 "%s: %s refused: its position is uncertain (it may have been powered "
			 "off: the multi-turn count is lost). Torque, speed and MIT with kp = 0 "
			 "still run. Home it (rmd.home_t on the HOME channel), or set travel_rad "
			 "narrower than %g deg or multi_turn_saved (docs/faults.md); further "
			 "refusals are counted in health_t",
			 ctx, rmd_mode_name((enum rmd_mode)e->b), turn_deg);
		return;
	}
	switch ((enum rmd_pos_trust)e->a) {
	case RMD_POS_SAVED:
		tool_log(6, "%s: position certain: the motor keeps its multi-turn count", ctx);
		break;
	case RMD_POS_IN_BAND:
		/* a shift is news (the motor was powered off, or first seen off by turns) */
		if (e->b)
			tool_log(5,
				 "%s: position certain: one position in its travel band fits; "
				 "shifted by %.6f rad (whole rotor turns)",
				 ctx, (double)e->b * 1e-6);
		else
			tool_log(6, "%s: position certain: one position in its travel band fits",
				 ctx);
		break;
	case RMD_POS_HOMED:
		tool_log(5, "%s: homed: position certain, shifted by %.6f rad", ctx,
			 (double)e->b * 1e-6);
		break;
	case RMD_POS_AMBIGUOUS: /* notice: a torque-only robot never needs more */
		tool_log(5,
			 "%s: position uncertain: its travel band is not narrower than one rotor "
			 "turn at the output (%g deg); position mode and MIT with kp > 0 are "
			 "refused until it is homed (docs/faults.md)",
			 ctx, turn_deg);
		break;
	case RMD_POS_OUTSIDE:
		tool_log(
			4,
			"%s: position uncertain: no position in its travel band fits what it "
			"reports (outside its travel, or travel_rad wrong); home it (docs/faults.md)",
			ctx);
		break;
	case RMD_POS_UNKNOWN:
	case RMD_POS_TRUST_COUNT:
		break;
	}
}

static void log_bus_state(const struct rmd_config *cfg, const struct rmd_event *e)
{
	enum rmd_bus_state s = (enum rmd_bus_state)e->a;
	const char *name = rmdd_bus_name(cfg, e->bus);

	switch (s) {
	case RMD_BUS_OFF:
		tool_log(3,
			 "%s: bus-off: the controller left the bus (a CAN interface needs "
			 "restart-ms, see systemd/80-can.network)",
			 name);
		break;
	case RMD_BUS_PASSIVE:
	case RMD_BUS_WARNING:
		tool_log(4, "%s: error %s", name, rmd_bus_state_name(s));
		break;
	case RMD_BUS_ACTIVE:
		tool_log(5, "%s: error active again", name);
		break;
	case RMD_BUS_NO_ACK:
		tool_log(3,
			 "%s: no node acknowledges (the motors' power is off: an e-stop?): no "
			 "frame that acts on a motor is written to it; its motors are lost, and "
			 "each moves again only after it answered, echoed 0x80 and 0x78 and its "
			 "0xB3 (docs/faults.md \"E-stop\")",
			 name);
		break;
	}
}

/*
 * RMD_EV_BUS_FLUSH: what a bus nobody acknowledges still held was dropped,
 * or (refused) what stays queued and what to do (docs/faults.md "E-stop";
 * docs/troubleshooting.md quotes both).
 */
static void log_bus_flush(const struct rmd_config *cfg, const struct rmd_event *e)
{
	const struct rmd_config_bus *cb = e->bus < cfg->n_buses ? &cfg->buses[e->bus] : NULL;
	const char *name = rmdd_bus_name(cfg, e->bus);
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
	if (!e->a) {
		tool_log(5,
			 "%s: the frames it still held are dropped (up to %u): none goes out when "
			 "power returns",
			 name, frames);
		return;
	}
	iface = cb ? rmd_config_bus_wire(cb, &serial) : NULL;
	if (iface && !serial)
		snprintf(advice, sizeof(advice),
			 "restart the interface before power returns (ip link set %s down; ip "
			 "link set %s up), or give rmdd CAP_NET_ADMIN",
			 iface, iface);
	else
		snprintf(advice, sizeof(advice),
			 "stop rmdd before power returns (its transport's queue goes with it)");
	tool_log(3,
		 "%s: the frames it holds could not be dropped (%s): up to %u, written before "
		 "the bus was found unacknowledged, go out when power returns (%s); %s "
		 "(docs/faults.md \"E-stop\")",
		 name, strerror((int)-e->a), frames, motors, advice);
}

static void log_watchdog(const struct rmd_config *cfg, const struct rmd_event *e)
{
	switch ((enum rmd_watchdog_state)e->a) {
	case RMD_WD_TRIPPED:
		tool_log(4,
			 "controller: no command for %u ms for an enabled motor: safe action %s on "
			 "each such motor (each has its own deadline), held until its owner "
			 "sends enable = 0, then enable = 1",
			 (unsigned)cfg->safety.command_timeout_ms,
			 rmd_safe_action_name(cfg->safety.safe_action));
		break;
	case RMD_WD_OK:
		tool_log(5, "controller: commands arrive, motors enabled");
		break;
	case RMD_WD_IDLE:
		tool_log(6, "controller: idle");
		break;
	}
}

/* The RMD_EV_RT events of one drain, said in one line. */
struct rt_note {
	bool any;
	int err[RMD_LOOP_RT_CPU_AWAKE + 1];
};

static void log_rt(const struct rt_note *rt)
{
	char what[256];
	size_t used = 0;

	if (rt->err[RMD_LOOP_RT_CPU_AWAKE])
		tool_log(5,
			 "CPU wake-up latency not held at 0 us (/dev/cpu_dma_latency: %s): on an "
			 "idle machine the loop and the bridge wake from idle states later. Give "
			 "rmdd write access to it, or set loop.keep_cpus_awake: false to keep this "
			 "power saving",
			 strerror(-rt->err[RMD_LOOP_RT_CPU_AWAKE]));
	if (!rt->any)
		return;
	what[0] = '\0';
	if (rt->err[RMD_LOOP_RT_FIFO])
		used += (size_t)snprintf(
			what + used, sizeof(what) - used,
			"SCHED_FIFO refused (%s), the loop runs at normal priority",
			strerror(-rt->err[RMD_LOOP_RT_FIFO]));
	if (rt->err[RMD_LOOP_RT_MLOCK] && used < sizeof(what))
		used += (size_t)snprintf(what + used, sizeof(what) - used, "%smlockall failed (%s)",
					 used ? "; " : "", strerror(-rt->err[RMD_LOOP_RT_MLOCK]));
	if (rt->err[RMD_LOOP_RT_AFFINITY] && used < sizeof(what))
		snprintf(what + used, sizeof(what) - used, "%sCPU affinity refused (%s)",
			 used ? "; " : "", strerror(-rt->err[RMD_LOOP_RT_AFFINITY]));
	tool_log(4,
		 "no real-time guarantees: %s. Run as root, or with LimitRTPRIO=49 and "
		 "LimitMEMLOCK=infinity (systemd/rmdd.service); --require-rt refuses to run "
		 "without them",
		 what);
}

/*
 * A motor missing at bring-up answered with firmware of another dialect
 * than its own: it stays out (warning).  docs/protocol-v4.md "Which dialect
 * a motor speaks".
 */
static void log_dialect(const struct rmd_config *cfg, const struct rmd_event *e)
{
	const struct rmd_config_motor *c = e->motor < cfg->n_motors ? &cfg->motors[e->motor] : NULL;
	const struct rmd_dialect *d = rmd_dialect((enum rmd_proto)e->b); /* what it speaks */
	const char *key = rmd_proto_key((enum rmd_proto)e->b);
	char ctx[96], how[96];

	rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
	/* a firmware date said it, or (none) its status answer on that dialect's identifier */
	if (e->a || !d)
		snprintf(how, sizeof(how), ": its firmware %" PRId64 " is %s", e->a, key);
	else
		snprintf(how, sizeof(how), ", in %s (its status on 0x%03X)", key,
			 d->reply_base + (c ? c->id : 0u));
	if (!c || c->proto_auto)
		tool_log(4,
			 "%s: answered at last%s, but with protocol: auto a motor missing at "
			 "bring-up is taken for v3; left out: restart rmdd to bring it up (or set "
			 "protocol: %s)",
			 ctx, how, key);
	else
		tool_log(
			4,
			"%s: answered at last%s, but its protocol is %s; left out (set protocol: %s, or auto)",
			ctx, how, rmd_proto_key(c->proto), key);
}

/*
 * A motor in MIT mode: missing at bring-up, its MIT scaling undecided when
 * it answered at last (left out), or an MIT enable refused while its
 * scaling is not decided.  docs/protocol-v4.md "MIT scaling".
 */
static void log_mit(const struct rmd_config *cfg, const struct rmd_event *e)
{
	const struct rmd_config_motor *c = e->motor < cfg->n_motors ? &cfg->motors[e->motor] : NULL;
	struct rmd_mit_decision dec;
	char ctx[96], model[8], why[512];
	unsigned series = (unsigned)(e->b >> 8) & 0xFF;

	rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
	if (e->kind == RMD_EV_MIT_REFUSED || !c) {
		tool_log(4,
			 "%s: MIT refused: its MIT scaling is not decided (its firmware's date and "
			 "model not read: bring-up decides it); counted in "
			 "health_t.ignored_by_kind[IGN_MIT_SCALING]",
			 ctx);
		return;
	}
	/* the loop's decision again, on the series it saw (RMD_EV_MIT_SCALING) */
	model[0] = '\0';
	if (series)
		snprintf(model, sizeof(model), "X%u", series % 1000u);
	rmd_mit_scaling_decide(rmd_dialect(c->proto), (uint32_t)e->a, model, &c->mit, c->mit_given,
			       &dec);
	rmdd_mit_text(rmd_dialect(c->proto), &dec, (uint32_t)e->a, model, why, sizeof(why));
	tool_log(4, "%s: answered at last, %s; left out (restart rmdd once its entry says it)", ctx,
		 why);
}

static void log_event(struct rmdd_monitor *m, const struct rmd_event *e, struct rt_note *rt)
{
	const struct rmd_config *cfg = m->cfg;
	char ctx[96];

	switch ((enum rmd_event_kind)e->kind) {
	case RMD_EV_RT:
		if (e->b == RMD_LOOP_RT_CPU_AWAKE) {
			rt->err[e->b] = e->a ? (int)e->a : -EPERM;
		} else if (e->b > 0 && e->b < RMD_LOOP_RT_CPU_AWAKE) {
			rt->any = true;
			rt->err[e->b] = e->a ? (int)e->a : -EPERM;
		}
		break;
	case RMD_EV_MOTOR_STATE:
		log_motor_state(cfg, e, e->b == RMD_LC_SAFE ? m->shutdown_sent : -1);
		if (e->b == RMD_LC_SAFE)
			m->shutdown_sent = -1;
		break;
	case RMD_EV_MOTOR_ERROR:
		log_motor_error(cfg, e);
		break;
	case RMD_EV_BUS_STATE:
		log_bus_state(cfg, e);
		break;
	case RMD_EV_BUS_FLUSH:
		log_bus_flush(cfg, e);
		break;
	case RMD_EV_COMM_LOSS:
		log_comm_loss(cfg, e);
		break;
	case RMD_EV_POSITION:
	case RMD_EV_POS_REFUSED:
	case RMD_EV_HOME_REFUSED:
		log_position(cfg, e);
		break;
	case RMD_EV_DIALECT:
		log_dialect(cfg, e);
		break;
	case RMD_EV_STRAY:
		tool_log(4,
			 "%s: motor %" PRId64 " answered on 0x%03" PRIX64
			 ", and the configuration does not list it: a 0x280 frame would command "
			 "it; %s sends each batched motor frames of its own from now on (fewer "
			 "a cycle: rmdd --check-config says how many); add it to the file, take it "
			 "off the bus, or turn its CAN-ID filter on (0x20 index 2 = 1) and set "
			 "can_id_filter: true for the bus",
			 rmdd_bus_name(cfg, e->bus), e->b, (uint64_t)e->a,
			 rmdd_bus_name(cfg, e->bus));
		break;
	case RMD_EV_MIT_SCALING:
	case RMD_EV_MIT_REFUSED:
		log_mit(cfg, e);
		break;
	case RMD_EV_REBOOT:
		log_reboot(cfg, e);
		break;
	case RMD_EV_OVERRUN:
		/* the first of each second now, the rest summed up by overrun_summary() */
		if (!m->overruns_pending && !m->overruns_logged) {
			tool_log(4,
				 "rt loop: overrun: woke %" PRId64 " period(s) late, skipped them",
				 e->a);
			m->overruns_logged = 1;
			m->overrun_window_ns = e->t_ns;
		} else {
			m->overruns_pending++;
			m->skipped_pending += (uint64_t)(e->a > 0 ? e->a : 0);
		}
		break;
	case RMD_EV_WATCHDOG:
		log_watchdog(cfg, e);
		break;
	case RMD_EV_SAFE_ACTION:
		if (e->b == 1) { /* the shutdown's: its SAFE line, next, says it */
			m->shutdown_sent = (int)e->a;
			break;
		}
		rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
		tool_log(7, "%s: safe action %s sent", ctx,
			 rmd_safe_action_name((enum rmd_safe_action)e->a));
		break;
	case RMD_EV_SEND_FAILED:
		tool_log(4, "%s: send failed (%s): %" PRId64 " frame(s) not sent",
			 rmdd_bus_name(cfg, e->bus), e->a ? strerror((int)-e->a) : "queue full",
			 e->b);
		break;
	case RMD_EV_LATE:
		rmdd_motor_ctx(cfg, e->motor, ctx, sizeof(ctx));
		if (e->b == RMD_MOTOR_CMD_MIT)
			tool_log(6,
				 "%s: the answer to an MIT frame came %.1f ms after it was sent, "
				 "after rmdd gave it up: counted late, not used (at most one such "
				 "line a second)",
				 ctx, (double)e->a / 1e6);
		else
			tool_log(6,
				 "%s: the answer to 0x%02" PRIX64
				 " came %.1f ms after it was sent, "
				 "after rmdd gave it up: counted late, not used (at most one such "
				 "line a second)",
				 ctx, (uint64_t)e->b, (double)e->a / 1e6);
		break;
	case RMD_EV_UNEXPECTED:
		if (e->b >= 0)
			tool_log(5,
				 "%s: unexpected frame 0x%03" PRIX64 " command 0x%02" PRIX64
				 " (neither a reply nor a report; at most one such line a second)",
				 rmdd_bus_name(cfg, e->bus), (uint64_t)e->a, (uint64_t)e->b);
		else
			tool_log(5, "%s: unexpected empty frame 0x%03" PRIX64,
				 rmdd_bus_name(cfg, e->bus), (uint64_t)e->a);
		break;
	default:
		tool_log(7, "event %u (a %" PRId64 ", b %" PRId64 ")", e->kind, e->a, e->b);
		break;
	}
	if (m->incidents) {
		const char *kind;
		char what[160];

		if (rmdd_incident_kind(cfg, e, what, sizeof(what), &kind))
			rmdd_incidents_trigger(m->incidents, e->t_ns, kind, what, false);
	}
}

/* Once a second: the overruns that followed the first one. */
static void overrun_summary(struct rmdd_monitor *m, int64_t now)
{
	if (!m->overruns_logged || now - m->overrun_window_ns < RMD_NS_PER_S)
		return;
	if (m->overruns_pending)
		tool_log(4,
			 "rt loop: %" PRIu64 " more overrun(s) in the last second, %" PRIu64
			 " period(s) skipped",
			 m->overruns_pending, m->skipped_pending);
	m->overrun_window_ns = now;
	m->overruns_logged = m->overruns_pending ? 1 : 0;
	m->overruns_pending = 0;
	m->skipped_pending = 0;
}

void rmdd_monitor_drain(struct rmdd_monitor *m)
{
	struct rt_note rt = { 0 };
	struct rmd_event e;
	uint64_t dropped;

	while (rmd_ring_pop(m->events, &e))
		log_event(m, &e, &rt);
	log_rt(&rt);
	dropped = rmd_ring_dropped(m->events);
	if (dropped != m->ring_dropped) {
		tool_log(4, "%" PRIu64 " rt loop event(s) lost: the ring was full",
			 dropped - m->ring_dropped);
		m->ring_dropped = dropped;
	}
}

/* ---- the thread ----------------------------------------------------------------- */

/*
 * The wait until there is something to do: the loop's event eventfd (or
 * a stop) without a timeout; with overruns summed up, until the end of
 * their one-second window.
 */
static int monitor_wait(struct rmdd_monitor *m)
{
	struct pollfd pfd[2] = {
		{ .fd = m->stop_fd, .events = POLLIN },
		{ .fd = m->wake_fd, .events = POLLIN },
	};
	struct timespec ts, *tsp = NULL;

	if (m->overruns_logged) {
		int64_t left = m->overrun_window_ns + RMD_NS_PER_S - rmd_now_ns();

		if (left < 0)
			left = 0;
		ts.tv_sec = left / RMD_NS_PER_S;
		ts.tv_nsec = left % RMD_NS_PER_S;
		tsp = &ts;
	}
	if (ppoll(pfd, 2, tsp, NULL) < 0 && errno != EINTR)
		return -errno;
	if (pfd[0].revents & POLLIN)
		return 1;
	if (pfd[1].revents & POLLIN) {
		uint64_t v;

		if (read(m->wake_fd, &v, sizeof(v)) < 0) {
			/* EAGAIN: another read took it */
		}
	}
	return 0;
}

static void *monitor_main(void *arg)
{
	struct rmdd_monitor *m = arg;

	pthread_setname_np(pthread_self(), "rmdd-monitor");
	for (;;) {
		if (monitor_wait(m) != 0)
			break;
		rmdd_monitor_drain(m);
		overrun_summary(m, rmd_now_ns());
	}
	return NULL;
}

int rmdd_monitor_init(struct rmdd_monitor *m, const struct rmd_config *cfg, struct rmd_loop *loop,
		      struct rmd_ring *events)
{
	int r;

	memset(m, 0, sizeof(*m));
	m->cfg = cfg;
	m->loop = loop;
	m->events = events;
	m->wake_fd = -1;
	m->shutdown_sent = -1;
	m->stop_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (m->stop_fd < 0)
		return -errno;
	m->wake_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (m->wake_fd < 0) {
		r = -errno;
		close(m->stop_fd);
		m->stop_fd = -1;
		return r;
	}
	/* the loop writes it in a cycle that pushed events: the monitor sleeps otherwise */
	rmd_loop_set_events_fd(loop, m->wake_fd);
	return 0;
}

int rmdd_monitor_start(struct rmdd_monitor *m)
{
	int r;

	if (m->running)
		return -EALREADY;
	r = rmd_thread_start_normal(&m->thread, monitor_main, m);
	if (!r)
		m->running = true;
	return r;
}

void rmdd_monitor_stop(struct rmdd_monitor *m)
{
	uint64_t one = 1;

	if (m->running) {
		if (write(m->stop_fd, &one, sizeof(one)) < 0) {
			/* only on overflow: already signalled */
		}
		pthread_join(m->thread, NULL);
		m->running = false;
	}
	rmdd_monitor_drain(m);
	overrun_summary(m, INT64_MAX);
}

void rmdd_monitor_fini(struct rmdd_monitor *m)
{
	rmdd_monitor_stop(m);
	if (m->stop_fd >= 0)
		close(m->stop_fd);
	m->stop_fd = -1;
	if (m->wake_fd >= 0) {
		rmd_loop_set_events_fd(m->loop, -1);
		close(m->wake_fd);
	}
	m->wake_fd = -1;
}
