// SPDX-License-Identifier: MIT
/*
 * The rig bench/insn-per-cycle.sh and bench/insn-guard.sh run under
 * callgrind: rmdd's loop on simulated buses with an injected clock, every
 * motor brought up, then WARM cycles, then CYCLES cycles measured.
 *
 *   insn_rig [--incidents] CONFIG.yaml [enabled|ready] [CYCLES]
 *   insn_rig [--incidents] --sim N     [enabled|ready] [CYCLES]   N V3 torque motors, 3 a bus
 *
 * --incidents: with the incident recorder on, its ring made as rmdd makes
 * it (src/tools/rmdd/incidents.c: the config's window, incidents.enabled
 * or not); without, the recorder is off.  A build without the recorder
 * (the baseline of bench/insn-per-cycle.sh) exits 3 when asked for it.
 * "enabled": a command enabling every motor in its configured mode each
 * cycle (the bridge's hand-over, as rmdd runs); "ready": no command, every
 * motor READY (status polls only).  The measured cycles are
 * rig_cycle(), the thread's cycle; the scripts exclude the simulated bus and motors with
 * callgrind's --toggle-collect on the sim bus's send and receive, and
 * the rig zeroes callgrind's counts before the measured cycles and dumps
 * them after (valgrind/callgrind.h's client requests).  The
 * rig prints how many cycles it measured and the motors' lifecycles, so a
 * run that did not reach the state it claims fails loudly.
 *
 * Non-rt, a benchmark: it allocates at set-up only.  The clock is
 * tests/harness/clock.c (self-contained: the baseline build links it too).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "harness/clock.h" /* the loop suites' injected clock: t_now */
#include "harness/loop_io.h"
#include "rmd/bringup.h"
#include "rmd/bus_open.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#if __has_include("rmd/incident.h")
#include "rmd/incident.h"
#define RIG_INCIDENTS 1
#endif
#include "rmd/loop.h"
#include "rmd/plan.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else
#define CALLGRIND_ZERO_STATS
#define CALLGRIND_DUMP_STATS_AT(s) ((void)(s))
#endif

#define MS INT64_C(1000000)
#define WARM 2000

static struct rig_loop R; /* configuration, plan, buses, channels */
static struct rmd_command cmd;
static struct rmd_snapshot snap;
static struct rmd_bringup report;

static void command_for(unsigned k)
{
	cmd.rx_ns = t_now;
	cmd.seq = k;
	for (unsigned i = 0; i < R.cfg.n_motors; i++) {
		struct rmd_setpoint *sp = &cmd.m[i];

		cmd.present |= 1u << i;
		sp->enable = true;
		sp->mode = (uint8_t)R.cfg.motors[i].mode;
		sp->pos_rad = 0.5 * sin(k * 0.001);
		sp->vel_rad_s = 0.5 * cos(k * 0.002);
		sp->torque_nm = 0.2 * sin(k * 0.003);
		sp->kp = 5.0;
		sp->kd = 0.2;
		sp->max_vel_rad_s = 2.0;
	}
}

/*
 * One cycle as the rt thread runs it (harness/loop_io.h rig_loop_cycle()).
 * Callgrind counts inside it
 * (bench/insn-count.sh; a baseline's rig counts inside rmd_loop_cycle()).
 */
__attribute__((noinline)) void rig_cycle(struct rmd_loop *l);
__attribute__((noinline)) void rig_cycle(struct rmd_loop *l)
{
	rig_loop_cycle(l, t_now, R.plan.period_ns);
}

/* The measured part: callgrind's --toggle-collect names this function. */
__attribute__((noinline)) void rig_cycles(struct rmd_loop *l, unsigned n, bool enabled,
					  unsigned k0);
__attribute__((noinline)) void rig_cycles(struct rmd_loop *l, unsigned n, bool enabled, unsigned k0)
{
	struct rmd_event ev;
	const void *p;

	for (unsigned k = k0; k < k0 + n; k++) {
		if (enabled) {
			command_for(k);
			rmd_latest_put(&R.cmds, &cmd);
		}
		rig_cycle(l);
		t_now += R.plan.period_ns;
		while (rmd_ring_pop(&R.events, &ev))
			;
		rmd_latest_get(&R.snaps, &p);
		rmd_latest_get(&R.health, &p);
	}
}

/*
 * The incident recorder's ring into o, as rmdd's rmdd_incidents_init()
 * makes it: seconds before + after the event.  0, or -1 with a message.
 */
static int add_incidents(struct rmd_loop_opts *o)
{
#ifdef RIG_INCIDENTS
	const struct rmd_config_incidents *ic = &R.cfg.incidents;
	int64_t window_ns = (int64_t)((ic->seconds_before + ic->seconds_after) * 1e9);
	char err[512];

	o->incidents = rmd_incident_ring_new(&R.cfg, &R.plan, window_ns, err, sizeof(err));
	if (!o->incidents) {
		fprintf(stderr, "insn_rig: %s\n", err);
		return -1;
	}
	return 0;
#else
	(void)o;
	fprintf(stderr, "insn_rig: this build has no incident recorder\n");
	return -1;
#endif
}

static int open_buses(void)
{
	char err[512];

	for (unsigned b = 0; b < R.cfg.n_buses; b++) {
		struct rmd_bus_open_motor ms[RMD_MAX_MOTORS];
		struct rmd_bus_open_ctx ctx;

		rmd_bus_open_ctx_of(&R.cfg, &R.sim, b, ms, &ctx);
		if (rmd_bus_open(&R.buses[b], &R.cfg.buses[b], &ctx, err, sizeof(err)) < 0) {
			fprintf(stderr, "insn_rig: bus %s: %s\n", R.cfg.buses[b].name, err);
			return -1;
		}
	}
	return 0;
}

int main(int argc, char **argv)
{
	struct rmd_loop_counters c;
	struct rmd_loop_stats st;
	struct rmd_loop_opts o;
	struct rmd_loop *l;
	unsigned cycles = 1000, n_lc[8] = { 0 };
	bool enabled = true, incidents = false;
	char err[2048];
	int a = 1, r;

	if (argc > 1 && !strcmp(argv[1], "--incidents")) {
		incidents = true;
		argv++;
		argc--;
	}
	if (argc < 2) {
		fprintf(stderr, "usage: insn_rig [--incidents] CONFIG.yaml|--sim N [enabled|ready] "
				"[CYCLES]\n");
		return 2;
	}
	if (!strcmp(argv[1], "--sim") && argc > 2) {
		r = rmd_config_sim_default(&R.cfg, &R.sim, (unsigned)atoi(argv[2]));
		a = 3;
	} else {
		r = rmd_config_load(argv[1], &R.cfg, &R.sim, err, sizeof(err));
		a = 2;
	}
	if (r) {
		fprintf(stderr, "insn_rig: config: %s\n", r == -EINVAL ? err : "cannot load");
		return 1;
	}
	if (argc > a)
		enabled = strcmp(argv[a], "ready") != 0;
	if (argc > a + 1)
		cycles = (unsigned)atoi(argv[a + 1]);
	if (rmd_plan_build(&R.cfg, &R.plan, err, sizeof(err))) {
		fprintf(stderr, "insn_rig: plan: %s\n", err);
		return 1;
	}
	if (open_buses())
		return 1;
	t_now = 1000 * MS;
	if (rig_loop_opts(&R, &o)) {
		fprintf(stderr, "insn_rig: event ring\n");
		return 1;
	}
	if (incidents && add_incidents(&o))
		return 3;
	l = rmd_loop_new(&o, err, sizeof(err));
	if (!l) {
		fprintf(stderr, "insn_rig: %s\n", err);
		return 1;
	}
	if (rmd_loop_bringup(l, &report)) {
		fprintf(stderr, "insn_rig: bring-up failed\n");
		return 1;
	}
	t_now = (t_now / MS + 1) * MS;
	rig_cycles(l, WARM, enabled, 0);
	/* only the measured cycles in callgrind's dump (no-ops outside valgrind) */
	CALLGRIND_ZERO_STATS;
	rig_cycles(l, cycles, enabled, WARM);
	CALLGRIND_DUMP_STATS_AT("measured");
	rmd_loop_get_snapshot(l, &snap);
	rmd_loop_get_stats(l, &st);
	rmd_loop_get_counters(l, &c);
	for (unsigned i = 0; i < snap.n; i++)
		n_lc[snap.m[i].lifecycle & 7]++;
	printf("insn_rig: motors %u buses %u measured_cycles %u mode %s incidents %s enabled %u "
	       "ready %u plan_misses %llu replies %llu bad_replies %llu missed %llu\n",
	       R.cfg.n_motors, R.cfg.n_buses, cycles, enabled ? "enabled" : "ready",
	       incidents ? "on" : "off", n_lc[RMD_LC_ENABLED], n_lc[RMD_LC_READY],
	       (unsigned long long)st.plan_misses, (unsigned long long)c.replies,
	       (unsigned long long)c.bad_replies, (unsigned long long)c.missed);
	rmd_loop_free(l);
#ifdef RIG_INCIDENTS
	rmd_incident_ring_free(o.incidents);
#endif
	for (unsigned b = 0; b < R.cfg.n_buses; b++)
		rmd_bus_close(&R.buses[b]);
	return (enabled ? n_lc[RMD_LC_ENABLED] : n_lc[RMD_LC_READY]) == R.cfg.n_motors ? 0 : 1;
}
