// SPDX-License-Identifier: MIT
/* The rig of the SocketCAN system suites (vsys.h). */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <net/if.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/types.h>

#include <linux/can/raw.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "rmd/time.h"
#include "rmd/codec.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"

#include "harness/evloop.h"
#include "harness/vsys.h"

#define SYNC_MS 60000			      /* candump's log catches up with a marker (a wait) */
#define CANDUMP_FIFO_PRIO (SIM_FIFO_PRIO + 1) /* see candump_start() */
#define SLEEPER_PERIOD_MS 5	    /* the reference sleepers wake every 5 ms: cheap in the guest */
#define KEEPALIVE_MS 50		    /* see keepalive() */
#define URL_PLACEHOLDER "@LCM_URL@" /* in tests/data/vcan/system.yaml */
#define MAX_VEL_RAD_S 1.0
#define VEL_STEPS 13 /* max_velocity takes this many values in turn (publish_as()) */
#define SINE_HZ 0.25 /* issue 13: the slow sine of test_system_fine_position */

struct vsys S;

/* ---- small helpers ----------------------------------------------------------- */

double ms_of(int64_t ns)
{
	return (double)ns / 1e6;
}

void sleepers_mark(void)
{
	gap_mark(&S.own);
	sleeper_mark(&S.sl_sim);
	sleeper_mark(&S.sl_loop);
	sleeper_mark(&S.sl_other);
}

unsigned pace(void)
{
	return S.pace > 1 ? S.pace : 1;
}

void sleepers_up(int loop_prio)
{
	if (S.sl_sim.started) {
		if (S.sl_loop.fifo != loop_prio) { /* the configuration's, now that it is read */
			sleeper_stop(&S.sl_loop);
			if (sleeper_start(&S.sl_loop, SLEEPER_PERIOD_MS * NS_PER_MS, loop_prio) < 0)
				fail_msg("cannot start the reference sleepers");
		}
		return;
	}
	if (sleeper_start(&S.sl_sim, SLEEPER_PERIOD_MS * NS_PER_MS, SIM_FIFO_PRIO) < 0 ||
	    sleeper_start(&S.sl_loop, SLEEPER_PERIOD_MS * NS_PER_MS, loop_prio) < 0 ||
	    sleeper_start(&S.sl_other, SLEEPER_PERIOD_MS * NS_PER_MS, 0) < 0)
		fail_msg("cannot start the reference sleepers");
}

double own_gap_ms(void)
{
	return ms_of(S.own.max_ns);
}

double stall_rt_ms(void)
{
	double l = sleeper_stall_ms(&S.sl_loop), m = sleeper_stall_ms(&S.sl_sim);

	return l > m ? l : m;
}

const char *disable_explained(void)
{
	static char why[192];
	double period_ms = 1000.0 / S.cfg.loop.rate_hz;

	if (stall_rt_ms() + 2 * period_ms >= S.cfg.safety.comm_loss_ms) {
		snprintf(why, sizeof(why),
			 "the guest held the loop's or rmd-sim's priority off %.1f ms (comm-loss "
			 "%u ms, period %.1f ms)",
			 stall_rt_ms(), S.cfg.safety.comm_loss_ms, period_ms);
		return why;
	}
	if (sleeper_stall_ms(&S.sl_sim) + period_ms >=
	    S.cfg.safety.missed_replies_lost * period_ms) {
		snprintf(why, sizeof(why),
			 "the guest held rmd-sim's priority off %.1f ms (%u missed replies in a "
			 "row make a motor lost, period %.1f ms)",
			 sleeper_stall_ms(&S.sl_sim), S.cfg.safety.missed_replies_lost, period_ms);
		return why;
	}
	if (sleeper_stall_ms(&S.sl_other) + CTL_PERIOD_MS >= S.cfg.safety.command_timeout_ms ||
	    own_gap_ms() >= S.cfg.safety.command_timeout_ms) {
		snprintf(
			why, sizeof(why),
			"the guest held the controller (normal priority) off %.1f ms, its commands "
			"%.1f ms apart (command timeout %u ms)",
			sleeper_stall_ms(&S.sl_other), own_gap_ms(),
			S.cfg.safety.command_timeout_ms);
		return why;
	}
	return NULL;
}

const char *iface(unsigned b)
{
	return S.cfg.buses[b].interface;
}

uint8_t safe_cmd(enum rmd_safe_action a)
{
	switch (a) {
	case RMD_SAFE_STOP:
	case RMD_SAFE_BRAKE:
		return 0x80;
	case RMD_SAFE_HOLD:
		return 0x81;
	case RMD_SAFE_DAMP:
		return 0xA2;
	}
	return 0;
}

/* ---- children ----------------------------------------------------------------- */

static void kids_kill_all(void)
{
	kid_kill_all();
	for (unsigned b = 0; b < NBUS_MAX; b++)
		S.sims[b] = NULL;
	S.candump = S.rmdd_kid = NULL;
}

/* ---- candump's log ---------------------------------------------------------------- */

/* Parse what candump wrote since the last call. */
static void tail_log(void)
{
	canlog_tail(&S.log);
}

static void can_send(unsigned b, uint32_t id, const uint8_t data[8])
{
	canlog_send(&S.log, b, id, data);
}

/* ---- the controller and the event loop ------------------------------------------------ */

/* One motor's entry of a state_t into its fine position statistics. */
static void fine_take(struct fine_stats *fs, const rmd_motor_state_t *ms, int64_t utime)
{
	double cd = ms->position * 18000.0 / M_PI; /* centidegrees: direction 1, no offset */
	double off = fabs(cd - round(cd));
	int64_t t = utime * 1000;

	fs->states++;
	fs->enabled += ms->lifecycle == RMD_STATE_T_LC_ENABLED;
	fs->off_lsb += off > 1e-6;
	if (off > fs->worst_off)
		fs->worst_off = off;
	fs->fine += fabs(cd / 100.0 - round(cd / 100.0)) > 0.004;
	fs->new_times += ms->position_rx_time_ns != fs->last_time_ns;
	fs->last_time_ns = ms->position_rx_time_ns;
	if (ms->position_rx_time_ns && t - ms->position_rx_time_ns > fs->pos_age_max)
		fs->pos_age_max = t - ms->position_rx_time_ns;
	if (ms->rx_time_ns && t - ms->rx_time_ns > fs->vel_age_max)
		fs->vel_age_max = t - ms->rx_time_ns;
}

static void on_state(const lcm_recv_buf_t *rb, const char *ch, const rmd_state_t *m, void *u)
{
	(void)rb;
	(void)ch;
	(void)u;
	S.n_state++;
	S.st_count = m->count;
	S.st_utime = m->utime;
	S.st_cycle = m->cycle;
	for (int i = 0; i < m->count && i < RMD_MAX_MOTORS; i++) {
		S.lc[i] = m->motor[i].lifecycle;
		S.seen_lost[i] |= S.lc[i] == RMD_STATE_T_LC_LOST;
		if (S.fine_on && m->motor[i].position_rx_time_ns)
			fine_take(&S.fine[i], &m->motor[i], m->utime);
	}
}

static void on_health(const lcm_recv_buf_t *rb, const char *ch, const rmd_health_t *m, void *u)
{
	(void)rb;
	(void)ch;
	(void)u;
	S.n_health++;
	for (int b = 0; b < m->bus_count && b < NBUS_MAX; b++) {
		S.bus_state[b] = m->bus[b].state;
		S.seen_no_ack[b] |= m->bus[b].state == RMD_BUS_HEALTH_T_BUS_NO_ACK;
	}
	S.h = (struct health){
		.utime = m->utime,
		.cycles = m->cycles,
		.overruns = m->overruns,
		.plan_misses = m->plan_misses,
		.wake_avg_us = m->wake_avg_us,
		.wake_p99_us = m->wake_p99_us,
		.wake_max_us = m->wake_max_us,
		.cycle_max_us = m->cycle_max_us,
		.watchdog = m->watchdog,
		.safe_action_events = m->safe_action_events,
		.accepted = m->commands_accepted,
		.rejected = m->commands_rejected,
		.owned = m->owned,
		.owner = m->owner,
		.intruder = m->intruder,
		.rejected_owner = m->rejected_by_kind[RMD_HEALTH_T_REJ_OWNER],
		.takeovers = m->takeovers,
	};
}

/* A command of controller `id` to every motor at SETPOINT_RAD + off_rad (+ the sine). */
static void publish_as(int64_t id, double off_rad, bool takeover)
{
	static rmd_motor_command_t motors[RMD_MAX_MOTORS]; /* c.motor: variable-length */
	rmd_command_t c;
	double sine = S.sine_amp_rad *
		      sin(2.0 * M_PI * SINE_HZ * ms_of(rmd_now_ns() - S.sine_t0) / 1000.0);

	memset(&c, 0, sizeof(c));
	memset(motors, 0, sizeof(motors));
	c.motor = motors;
	c.utime = rmd_now_ns() / 1000;
	c.seq = ++S.seq;
	c.controller = id;
	c.takeover = takeover;
	c.count = (int16_t)S.cfg.n_motors;
	for (unsigned i = 0; i < S.cfg.n_motors; i++) {
		rmd_motor_command_t *m = &c.motor[i];

		m->index = (int16_t)i;
		m->enable = S.ctl_enable;
		m->mode = RMD_COMMAND_T_MODE_POSITION;
		m->position = SETPOINT_RAD + off_rad + sine;
		/*
		 * Thirteen values in turn: the frames tell which command a cycle
		 * carried.  Two were too few: a loop slowed to a period of two
		 * or more of the controller's (the slower paces) took commands
		 * of one parity only, every cycle alike.  The loop takes 1..8
		 * commands a cycle at the paces here, never a multiple of 13.
		 */
		m->max_velocity = MAX_VEL_RAD_S + (double)(c.seq % VEL_STEPS) * 0.05;
	}
	S.last_pub_real = real_ns();
	if (rmd_command_t_publish(S.lcm, "RMD_COMMAND", &c) < 0)
		fail_msg("LCM publish on %s failed", S.url);
	S.n_pub++;
}

static void publish(void)
{
	gap_note(&S.own);
	publish_as(S.ctl_id, 0, false);
	if (S.intruder_id) {
		publish_as(S.intruder_id, INTRUDER_OFF_RAD, S.intruder_takeover);
		S.intruder_takeover = false;
	}
}

/*
 * A motor whose 0xB3 protection tripped only echoes the first frame it
 * hears next (docs/design.md), and trips again comm_loss_ms after the last
 * one.  A program that starts longer than that after the previous frame
 * (rmdctl in the guest: 0.1-1 s) always meets a freshly tripped motor.
 * keepalive() reads one motor's status 2 (0x9C, V3 §2.13: changes nothing)
 * every KEEPALIVE_MS so that a tool run meanwhile gets real answers.
 */
static void keepalive(int64_t now)
{
	static const uint8_t read_9c[8] = { 0x9C };

	if (S.ka_bus < 0 || now < S.ka_next)
		return;
	can_send((unsigned)S.ka_bus, RMD_CAN_REQ_BASE + S.ka_id, read_9c);
	S.ka_next = now + KEEPALIVE_MS * NS_PER_MS;
}

void service(int max_ms)
{
	evloop_turn(S.lcm, &S.ctl, S.ka_bus >= 0 ? S.ka_next : INT64_MAX, max_ms);
	keepalive(rmd_now_ns());
	tail_log();
}

void run_for(int ms)
{
	evloop_run_for(service, ms);
}

void controller(bool on, bool enable)
{
	if (on && !S.ctl.on) {
		S.ctl.next_ns = rmd_now_ns();
		gap_pause(&S.own); /* a pause of its own is no gap (own_gap_ms()) */
	}
	S.ctl.on = on;
	S.ctl_enable = enable;
}

void sync_log(void)
{
	canlog_sync(&S.log, SYNC_MS, service, &S.sl_other);
}

/* ---- one tool run ------------------------------------------------------------------ */

void run_tool(struct run *r, const char *const *argv)
{
	run_free(r);
	run_prog(r, argv[0], argv + 1,
		 &(struct run_opts){ .limit_ms = TOOL_MS, .service = service });
}

/* ---- environment -------------------------------------------------------------------- */

/* NULL when SocketCAN and vcan0..vcan2 are here, else why not. */
static const char *no_socketcan(void)
{
	int fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);

	if (fd < 0)
		return "no SocketCAN here (make test runs this suite in the VM)";
	close(fd);
	if (!if_nametoindex("vcan0") || !if_nametoindex("vcan1") || !if_nametoindex("vcan2"))
		return "no vcan0..vcan2 here (tests/vm/vm-run --vcan 3 creates them)";
	return NULL;
}

static void paths_init(void)
{
	const char *b = getenv("BUILD");

	snprintf(S.build, sizeof(S.build), "%s", b && *b ? b : "build");
	snprintf(S.rmdd, sizeof(S.rmdd), "%s/rmdd", S.build);
	snprintf(S.rmdsim, sizeof(S.rmdsim), "%s/rmd-sim", S.build);
	snprintf(S.rmdctl, sizeof(S.rmdctl), "%s/rmdctl", S.build);
	snprintf(S.dir, sizeof(S.dir), "/dev/shm/rmd-vsys-%d", (int)getpid());
	snprintf(S.cfgpath, sizeof(S.cfgpath), "%s/rmdd.yaml", S.dir);
	snprintf(S.logpath, sizeof(S.logpath), "%s/candump.log", S.dir);
	canlog_init(&S.log);
	S.ka_bus = -1;
	S.ctl.period_ns = CTL_PERIOD_MS * NS_PER_MS;
	S.ctl.publish = publish;
}

void need_exec(const char *path)
{
	if (access(path, X_OK) != 0)
		fail_msg("%s not found or not executable: build it, e.g. make BUILD=%s %s", path,
			 S.build, path);
}

/*
 * The value after "key:" in gen (a YAML text we wrote) replaced by value;
 * fails when the key is not there.
 */
static char *yaml_set(char *gen, const char *key, const char *value)
{
	char *at = strstr(gen, key), *eol, *out;

	if (!at)
		fail_msg("tests/data/vcan/system.yaml has no %s", key);
	eol = strchr(at, '\n');
	if (asprintf(&out, "%.*s%s %s%s", (int)(at - gen), gen, key, value, eol ? eol : "") < 0)
		fail_msg("out of memory");
	free(gen);
	return out;
}

void write_config(void)
{
	const char *src = getenv("RMD_SRCDIR");
	char tpl[256], err[4096], *text, *at, *gen = NULL;
	size_t gen_len = 0;
	FILE *in, *out;
	long n;

	snprintf(tpl, sizeof(tpl), "%s/tests/data/vcan/system.yaml", src && *src ? src : ".");
	in = fopen(tpl, "r");
	if (!in)
		fail_msg("%s: %s (run from the repository root, or set RMD_SRCDIR)", tpl,
			 strerror(errno));
	fseek(in, 0, SEEK_END);
	n = ftell(in);
	rewind(in);
	text = calloc(1, (size_t)n + 1);
	assert_non_null(text);
	assert_int_equal(fread(text, 1, (size_t)n, in), (size_t)n);
	fclose(in);
	if (!strstr(text, URL_PLACEHOLDER))
		fail_msg("%s has no %s", tpl, URL_PLACEHOLDER);
	/* a port per run: concurrent runs never hear each other */
	snprintf(S.url, sizeof(S.url), "udpm://239.255.76.67:%d?ttl=0",
		 20000 + (int)(getpid() % 20000));
	out = open_memstream(&gen, &gen_len);
	assert_non_null(out);
	for (const char *p = text; *p;) {
		at = strstr(p, URL_PLACEHOLDER);
		if (!at) {
			fputs(p, out);
			break;
		}
		fprintf(out, "%.*s%s", (int)(at - p), p, S.url);
		p = at + strlen(URL_PLACEHOLDER);
	}
	assert_int_equal(fclose(out), 0);
	free(text);
	out = fopen(S.cfgpath, "w");
	assert_non_null(out);
	if (S.pace > 1) {
		char v[32];
		unsigned p = S.pace;

		snprintf(v, sizeof(v), "%u", S.base_rate_hz / p);
		gen = yaml_set(gen, "rate_hz:", v);
		snprintf(v, sizeof(v), "%u", S.base_timeout_ms * p);
		gen = yaml_set(gen, "command_timeout_ms:", v);
		snprintf(v, sizeof(v), "%u", S.base_loss_ms * p);
		gen = yaml_set(gen, "comm_loss_ms:", v);
		/* each motor's status polls (the default 10 Hz), as one more key of its map */
		for (char *m = gen; (m = strstr(m, "gear_ratio: 6}"));) {
			char *g;

			if (asprintf(&g, "%.*sgear_ratio: 6, status_poll_hz: %g}%s", (int)(m - gen),
				     gen, 10.0 / p, m + strlen("gear_ratio: 6}")) < 0)
				fail_msg("out of memory");
			m = g + (m - gen) + strlen("gear_ratio: 6, status_poll_hz: }");
			free(gen);
			gen = g;
		}
	}
	/* issue 13: a key for every motor (S.motor_extra), as one more entry of its map */
	for (char *m = gen; S.motor_extra && (m = strstr(m, "gear_ratio: 6"));) {
		char *g;

		if (asprintf(&g, "%.*sgear_ratio: 6, %s%s", (int)(m - gen), gen, S.motor_extra,
			     m + strlen("gear_ratio: 6")) < 0)
			fail_msg("out of memory");
		m = g + (m - gen) + strlen("gear_ratio: 6, ") + strlen(S.motor_extra);
		free(gen);
		gen = g;
	}
	fputs(gen, out);
	free(gen);
	assert_int_equal(fclose(out), 0);
	if (rmd_config_load(S.cfgpath, &S.cfg, NULL, err, sizeof(err)) < 0)
		fail_msg("%s (from %s): %s", S.cfgpath, tpl, err);
	S.nbus = S.cfg.n_buses;
	if (S.pace <= 1) {
		S.base_rate_hz = S.cfg.loop.rate_hz;
		S.base_timeout_ms = S.cfg.safety.command_timeout_ms;
		S.base_loss_ms = S.cfg.safety.comm_loss_ms;
	}
	if (S.nbus > NBUS_MAX)
		fail_msg("%s: %u buses, the test handles %d", tpl, S.nbus, NBUS_MAX);
	for (unsigned b = 0; b < S.nbus; b++)
		if (S.cfg.buses[b].kind != RMD_BUS_KIND_SOCKETCAN)
			fail_msg("%s: bus %s is not socketcan", tpl, S.cfg.buses[b].name);
	for (unsigned i = 0; i < S.cfg.n_motors; i++)
		if (S.cfg.motors[i].proto != RMD_PROTO_V3 ||
		    S.cfg.motors[i].mode != RMD_MODE_POSITION)
			fail_msg("%s: motor %s: the test drives V3 motors in position mode", tpl,
				 S.cfg.motors[i].name);
}

/* ---- the system's fixture: rmd-sim per bus, candump, LCM -------------------------- */

/*
 * One rmd-sim a bus, on the same file rmdd runs (issue 22.7: a bus described
 * once serves both): rmd-sim picks the bus whose interface --can names and
 * simulates its motors as the file describes them.
 */
static void sims_start(void)
{
	for (unsigned b = 0; b < S.nbus; b++) {
		char seed[16], name[32];
		const char *argv[16];
		unsigned a = 0;

		snprintf(seed, sizeof(seed), "%u", b + 1);
		snprintf(name, sizeof(name), "rmd-sim %s", iface(b));
		argv[a++] = S.rmdsim;
		argv[a++] = "--config";
		argv[a++] = S.cfgpath;
		argv[a++] = "--can";
		argv[a++] = iface(b);
		argv[a++] = "--seed";
		argv[a++] = seed;
		argv[a] = NULL;
		S.sims[b] = kid_spawn(name, argv, NULL, SIM_FIFO_PRIO);
	}
	for (unsigned b = 0; b < S.nbus; b++)
		kid_wait_output(S.sims[b], ": ready", READY_MS, service);
}

static void candump_start(void)
{
	const char *ifaces[NBUS_MAX];

	for (unsigned b = 0; b < S.nbus; b++)
		ifaces[b] = iface(b);
	/*
	 * candump is the test's instrument: above every thread of the system
	 * under test, so that a busy guest, whose emulated CPUs the real-time
	 * threads then fill, never starves it (it only reads and writes).
	 */
	canlog_start(&S.log, S.logpath, ifaces, S.nbus, CANDUMP_FIFO_PRIO, SYNC_MS, service,
		     &S.sl_other);
	S.candump = S.log.candump;
}

static void lcm_start(void)
{
	S.lcm = lcm_create(S.url);
	if (!S.lcm)
		fail_msg("lcm_create(%s) failed: multicast on loopback? (tests/vm/net-setup)",
			 S.url);
	S.sub_state = rmd_state_t_subscribe(S.lcm, "RMD_STATE", on_state, NULL);
	S.sub_health = rmd_health_t_subscribe(S.lcm, "RMD_HEALTH", on_health, NULL);
	assert_non_null(S.sub_state);
	assert_non_null(S.sub_health);
}

static bool fixture_tried, fixture_up;

void system_begin(void)
{
	if (!S.have_can)
		skip();
	if (fixture_tried) {
		if (!fixture_up)
			fail_msg("rmd-sim, candump or LCM did not start in an earlier test");
		return;
	}
	fixture_tried = true;
	need_exec(S.rmdd);
	need_exec(S.rmdsim);
	need_exec(S.rmdctl);
	if (mkdir(S.dir, 0755) < 0 && errno != EEXIST)
		fail_msg("mkdir %s: %s", S.dir, strerror(errno));
	write_config();
	sleepers_up((int)S.cfg.loop.rt_priority);
	sims_start();
	candump_start();
	lcm_start();
	fixture_up = true;
	print_message("system: %u motors on %u buses, loop %u Hz, command timeout %u ms, safe "
		      "action 0x%02X, comm-loss (0xB3) %u ms, LCM %s\n",
		      S.cfg.n_motors, S.nbus, S.cfg.loop.rate_hz, S.cfg.safety.command_timeout_ms,
		      safe_cmd(S.cfg.safety.safe_action), S.cfg.safety.comm_loss_ms, S.url);
}

bool rmdd_running(void)
{
	return S.rmdd_kid && !kid_poll_exit(S.rmdd_kid);
}

/* Print rmdd's bring-up report (the lines between "bring-up" and "running"). */
static void print_bringup(const struct kid *k)
{
	const char *p = strstr(k->out, "bring-up of");

	for (; p && *p;) {
		const char *nl = strchr(p, '\n');
		int n = nl ? (int)(nl - p) : (int)strlen(p);

		if (memmem(p, (size_t)n, "rmdd: running", 13))
			break;
		print_message("  rmdd: %.*s\n", n, p);
		p = nl ? nl + 1 : NULL;
	}
}

void rmdd_start(void)
{
	const char *argv[] = { S.rmdd, "--config", S.cfgpath, NULL };

	if (S.rmdd_kid)
		kid_free(S.rmdd_kid);
	S.rmdd_kid = kid_spawn("rmdd", argv, NULL, 0);
	kid_wait_output_held(S.rmdd_kid, "rmdd: running:", READY_MS, service, &S.sl_other);
	print_bringup(S.rmdd_kid);
	/* docs/design.md: after a comm-loss trip the first command is only echoed */
	if (strstr(S.rmdd_kid->out, "(no model)"))
		fail_msg("bring-up took the echo of 0xB5 from a motor whose 0xB3 protection had "
			 "tripped for its model (\"(no model)\"):\n%s",
			 S.rmdd_kid->out);
}

bool all_lc(int8_t lc)
{
	if (S.st_count < (int16_t)S.cfg.n_motors)
		return false;
	for (unsigned i = 0; i < S.cfg.n_motors; i++)
		if (S.lc[i] != lc)
			return false;
	return true;
}

const char *lc_list(void)
{
	static char s[256];
	size_t n = 0;

	s[0] = '\0';
	for (unsigned i = 0; i < S.cfg.n_motors && n < sizeof(s) - 16; i++)
		n += (size_t)snprintf(s + n, sizeof(s) - n, "%s%s=%d", i ? " " : "",
				      S.cfg.motors[i].name, S.lc[i]);
	return s;
}

/* ---- frame queries ------------------------------------------------------------------ */

const struct cframe *first_frame(size_t from, unsigned b, unsigned id, int cmd, int64_t t0,
				 int64_t t1)
{
	return canlog_first(&S.log, from, b, id, cmd, t0, t1);
}

const struct cframe *last_frame(size_t from, unsigned b, unsigned id, int cmd, int64_t t0,
				int64_t t1)
{
	return canlog_last(&S.log, from, b, id, cmd, t0, t1);
}

unsigned count_frames(size_t from, unsigned b, unsigned id, int cmd, int64_t t0, int64_t t1)
{
	return canlog_count(&S.log, from, b, id, cmd, t0, t1);
}

unsigned req_id(unsigned i)
{
	return RMD_CAN_REQ_BASE + S.cfg.motors[i].id;
}

unsigned rep_id(unsigned i)
{
	return RMD_CAN_V3_REPLY_BASE + S.cfg.motors[i].id;
}

bool wait_all_lc(int8_t lc, int ms)
{
	int64_t end = rmd_now_ns() + ms * NS_PER_MS;
	uint64_t n0 = S.n_state;

	while (S.n_state == n0 || !all_lc(lc)) {
		if (rmd_now_ns() > end)
			return false;
		service(10);
	}
	return true;
}

/*
 * Enable every motor and wait until state_t shows them ENABLED.  rmdd
 * takes enable = 1 for a motor that came back from LOST only after an
 * enable = 0 (include/rmd/loop.h, "need_edge"); a motor still READY a
 * second after enable = 1 gets what rmdd's log asks for: enable = 0 (once
 * every motor is READY), then 1 again.  Returns the time taken, ms.
 */
static bool enable_try(double *ms)
{
	int64_t t0 = rmd_now_ns(), end = t0 + ENABLE_MS * NS_PER_MS;

	for (;;) {
		controller(true, true);
		if (wait_all_lc(RMD_STATE_T_LC_ENABLED, 1000 * (int)pace())) {
			*ms = ms_of(rmd_now_ns() - t0);
			return true;
		}
		if (rmd_now_ns() > end)
			return false;
		S.edge_toggles++;
		controller(true, false);
		wait_all_lc(RMD_STATE_T_LC_READY, 2000 * (int)pace());
		run_for(3 * CTL_PERIOD_MS);
	}
}

double enable_all(void)
{
	double ms, stall;
	int st;

	while (!enable_try(&ms)) {
		stall = sleeper_stall_ms(&S.sl_loop) > sleeper_stall_ms(&S.sl_sim) ?
				sleeper_stall_ms(&S.sl_loop) :
				sleeper_stall_ms(&S.sl_sim);
		if (stall < 1000.0 / S.cfg.loop.rate_hz || pace() * 2 > MAX_PACE)
			fail_msg("not every motor ENABLED %d ms after enable at %u Hz (lifecycles "
				 "%s; %" PRIu64 " state_t, %" PRIu64 " health_t received; the "
				 "guest's worst delay at the loop's or rmd-sim's priority %.1f "
				 "ms); rmdd:\n%s",
				 ENABLE_MS, S.cfg.loop.rate_hz, lc_list(), S.n_state, S.n_health,
				 stall, kid_tail(S.rmdd_kid));
		print_message("busy machine: not every motor ENABLED %d ms after enable at %u Hz "
			      "(lifecycles %s), the guest stalling threads at the loop's or "
			      "rmd-sim's priority for %.1f ms (the period is %.1f ms).  Again at a "
			      "slower pace: every time of the configuration %u times the file's; "
			      "the later tests run at it too\n",
			      ENABLE_MS, S.cfg.loop.rate_hz, lc_list(), stall,
			      1000.0 / S.cfg.loop.rate_hz, pace() * 2);
		controller(false, false);
		kill(S.rmdd_kid->pid, SIGTERM);
		st = kid_wait_exit_held(S.rmdd_kid, EXIT_MS, service, &S.sl_other);
		if (st != 0)
			fail_msg("rmdd: exit status %d after SIGTERM; its output:\n%s", st,
				 kid_tail(S.rmdd_kid));
		S.pace = pace() * 2;
		write_config();
		sleepers_mark();
		rmdd_start();
	}
	return ms;
}

/*
 * rmdd has just started: report what its start did to the motors.  Its
 * bring-up writes 0xB3 (comm_loss_ms) and ends with the scan of the ids
 * not configured (0x9A to 0x160 last); the loop's first cycle comes after
 * LCM, mlockall and the thread's start.  A gap longer than comm_loss_ms
 * trips every motor's protection (0xF1) before rmdd drives it.
 */
static void report_start(int64_t t_start)
{
	const struct cframe *scan_end = NULL, *first = NULL;
	unsigned trips = 0;

	sync_log();
	for (size_t i = 0; i < S.log.nframes; i++) {
		const struct cframe *f = &S.log.frames[i];

		if (f->t_ns >= t_start && f->id == RMD_CAN_REQ_BASE + RMD_MAX_MOTORS &&
		    (!scan_end || f->t_ns > scan_end->t_ns))
			scan_end = f;
	}
	if (!scan_end) {
		print_message("rmdd start: no bring-up scan (0x160) in candump's log\n");
		return;
	}
	for (size_t i = 0; i < S.log.nframes; i++) {
		const struct cframe *f = &S.log.frames[i];

		for (unsigned m = 0; m < S.cfg.n_motors; m++)
			if (cframe_is(f, S.cfg.motors[m].bus, req_id(m), -1, scan_end->t_ns + 1,
				      T_END) &&
			    (!first || f->t_ns < first->t_ns))
				first = f;
	}
	/* a motor that heard the bring-up sends 0xF1 only when it trips anew */
	for (unsigned m = 0; first && m < S.cfg.n_motors; m++)
		trips += first_frame(0, S.cfg.motors[m].bus, rep_id(m), 0xF1, scan_end->t_ns + 1,
				     first->t_ns + 1) != NULL;
	print_message("rmdd start: bring-up's last frame to the first cycle's: %.0f ms "
		      "(comm_loss_ms %u); motors whose 0xB3 protection tripped meanwhile: %u%s\n",
		      first ? ms_of(first->t_ns - scan_end->t_ns) : -1.0, S.cfg.safety.comm_loss_ms,
		      trips,
		      trips ? " -- rmdd let them go silent between bring-up and its first cycle" :
			      "");
	/*
	 * What rmdd does between the two (LCM, mlockall, the thread's start)
	 * runs at normal priority: on a busy machine the guest may hold it off
	 * longer than comm_loss_ms.  rmdd is at fault only when the gap, less
	 * the worst delay a normal-priority sleeper saw during the start, is
	 * still longer.
	 */
	if (trips && first &&
	    ms_of(first->t_ns - scan_end->t_ns) - sleeper_stall_ms(&S.sl_other) <=
		    S.cfg.safety.comm_loss_ms) {
		print_message("busy machine: the guest held a normal-priority thread off for up "
			      "to %.1f ms during rmdd's start: the trips are the machine's, not "
			      "rmdd's (it re-probes the motors; enable follows)\n",
			      sleeper_stall_ms(&S.sl_other));
		trips = 0;
	}
	if (trips)
		fail_msg("%u motor(s) tripped their comm-loss protection between bring-up and "
			 "the first cycle",
			 trips);
}

void rmdd_up_and_enabled(void)
{
	if (!rmdd_running()) {
		int64_t t_start = real_ns();
		unsigned toggles = S.edge_toggles;
		double ms;

		sleepers_mark();
		rmdd_start();
		ms = enable_all();
		report_start(t_start);
		print_message("enable: every motor ENABLED in state_t %.0f ms after the first "
			      "enable%s\n",
			      ms,
			      S.edge_toggles != toggles ? " (after enable = 0 first, as rmdd asked "
							  "for motors back from LOST)" :
							  "");
		return;
	}
	enable_all();
}

const char *motor_frames(unsigned i, int64_t t_ref)
{
	static char text[8192];
	const struct rmd_config_motor *m = &S.cfg.motors[i];
	size_t n = 0, first = 0, count = 0;

	for (size_t k = 0; k < S.log.nframes; k++)
		if (S.log.frames[k].bus == m->bus &&
		    (S.log.frames[k].id == req_id(i) || S.log.frames[k].id == rep_id(i)))
			count++;
	text[0] = '\0';
	for (size_t k = 0; k < S.log.nframes && n < sizeof(text) - 64; k++) {
		const struct cframe *f = &S.log.frames[k];

		if (f->bus != m->bus || (f->id != req_id(i) && f->id != rep_id(i)))
			continue;
		if (first++ + 40 < count)
			continue;
		n += (size_t)snprintf(text + n, sizeof(text) - n, "  %+9.2f ms %03X %02X\n",
				      ms_of(f->t_ns - t_ref), f->id, f->data[0]);
	}
	return text;
}

int rmdctl_teardown(void **state)
{
	(void)state;
	kids_kill_all();
	return 0;
}

void config_file(const char *name, const char *text, char *path, size_t len)
{
	FILE *f;

	if (mkdir(S.dir, 0755) < 0 && errno != EEXIST)
		fail_msg("mkdir %s: %s", S.dir, strerror(errno));
	snprintf(path, len, "%s/%s", S.dir, name);
	f = fopen(path, "w");
	if (!f || fputs(text, f) < 0 || fclose(f))
		fail_msg("%s: %s", path, strerror(errno));
}

void rmdd_restart_at(unsigned pace)
{
	int st;

	controller(false, false);
	if (rmdd_running()) {
		kill(S.rmdd_kid->pid, SIGTERM);
		st = kid_wait_exit_held(S.rmdd_kid, EXIT_MS, service, &S.sl_other);
		if (st != 0)
			fail_msg("rmdd: exit status %d after SIGTERM; its output:\n%s", st,
				 kid_tail(S.rmdd_kid));
	}
	S.pace = pace;
	write_config();
	rmdd_up_and_enabled();
}

/* RMD_VSYS_KEEP=DIR: keep candump's log and the configuration there (the guest's /dev/shm is its own). */
static void keep_files(void)
{
	const char *dir = getenv("RMD_VSYS_KEEP");
	const char *files[] = { S.logpath, S.cfgpath };

	if (!dir || !*dir)
		return;
	for (unsigned k = 0; k < 2; k++) {
		char dst[512], buf[65536];
		const char *base = strrchr(files[k], '/') + 1;
		int in = open(files[k], O_RDONLY | O_CLOEXEC), out;
		ssize_t n;

		snprintf(dst, sizeof(dst), "%s/%s", dir, base);
		out = open(dst, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
		while (in >= 0 && out >= 0 && (n = read(in, buf, sizeof(buf))) > 0)
			if (write(out, buf, (size_t)n) != n)
				break;
		if (in >= 0)
			close(in);
		if (out >= 0)
			close(out);
	}
}

static int group_teardown(void **state)
{
	(void)state;
	kids_kill_all();
	sleeper_stop(&S.sl_sim);
	sleeper_stop(&S.sl_loop);
	sleeper_stop(&S.sl_other);
	keep_files();
	if (S.lcm) {
		if (S.sub_state)
			rmd_state_t_unsubscribe(S.lcm, S.sub_state);
		if (S.sub_health)
			rmd_health_t_unsubscribe(S.lcm, S.sub_health);
		lcm_destroy(S.lcm);
		S.lcm = NULL;
	}
	canlog_free(&S.log);
	unlink(S.cfgpath);
	unlink(S.logpath);
	rmdir(S.dir);
	return 0;
}
int vsys_main(const char *name, const struct CMUnitTest *tests, size_t n)
{
	const char *why;

	signal(SIGPIPE, SIG_IGN);
	paths_init();
	why = no_socketcan();
	S.have_can = !why;
	if (why)
		printf("SKIP: %s\n", why);
	return _cmocka_run_group_tests(name, tests, n, NULL, group_teardown);
}
