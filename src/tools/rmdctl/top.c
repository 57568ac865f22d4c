// SPDX-License-Identifier: MIT
/*
 * rmdctl top: a live view of a running rmdd, from what it publishes on LCM
 * (docs/lcm.md): rmd.config_t names the buses and motors (asked for on
 * PREFIX CONFIG_REQUEST, as the bridge expects), rmd.health_t gives the
 * loop, the buses, the watchdog and each motor's comm-loss protection
 * (0xB3), rmd.state_t each motor's lifecycle, mode and measurements.
 *
 * It never opens a bus: it only listens (and asks for config_t), so it runs
 * beside rmdd, unlike `rmdctl monitor`.  On a terminal the operator's screen
 * (top_screen.c, ncurses) is redrawn every --interval (100 ms); otherwise,
 * or when TERM is dumb, a plain table is printed every --interval (1 s).
 * --once prints one table, --json one JSON object, each once config, health
 * and state have all come.
 *
 * --prefix A_,B_ names several daemons of one robot (issue 30): one set of
 * subscriptions per prefix on the one LCM URL, a top_view each; the views
 * show every motor with its instance (its prefix) and each instance's
 * health, an instance silent for 1 s said so while the others update.
 * One prefix shows exactly what it always did.  Non-rt.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <lcm/lcm.h>

#include "rmd/channels.h"
#include "rmd/config.h"
#include "rmd/time.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmdctl.h"
#include "top_screen.h"
#include "tools/common/names.h"

#define DEFAULT_PREFIX "RMD_"
#define TTY_INTERVAL_MS 100.0
#define PLAIN_INTERVAL_MS 1000.0
#define WAIT_S 3.0
#define TOP_MIXED_WAIT_NS INT64_C(250000000) /* 2.5 health_t periods */
#define ASK_EVERY_NS INT64_C(500000000)	     /* config_t requests until one comes */
#define POLL_MAX_MS 100 /* the screen's keys and config_t requests: at least this often */
#define TOP_CHANNEL_LEN 96
#define TOP_MAX_INSTANCES 8 /* --prefix A_,B_,...: daemons in one view */
#define TOP_PREFIXES_LEN 512

/* One daemon's channels and subscriptions (one per --prefix). */
struct top_inst {
	char ch_state[TOP_CHANNEL_LEN], ch_health[TOP_CHANNEL_LEN], ch_config[TOP_CHANNEL_LEN],
		ch_request[TOP_CHANNEL_LEN];
	int64_t next_ask_ns; /* the next config_t request while none came */
	rmd_state_t_subscription_t *s_state;
	rmd_health_t_subscription_t *s_health;
	rmd_config_t_subscription_t *s_config;
};

/* top: its options, its LCM link and what it shows (filled from LCM, read by the views). */
struct top {
	bool json, once, tty, robot;
	double interval_ms, wait_s;

	lcm_t *lcm;
	char prefixes[TOP_PREFIXES_LEN]; /* --prefix, split at its commas into v[].prefix */
	int n;				 /* instances: 1 unless --prefix listed more */
	struct top_inst in[TOP_MAX_INSTANCES];
	struct top_view v[TOP_MAX_INSTANCES];
};

/* Set by SIGINT and SIGTERM: every loop of top ends. */
static volatile sig_atomic_t rmdctl_top_stop;

static void on_signal(int sig)
{
	(void)sig;
	rmdctl_top_stop = 1;
}

/*
 * top's options, one table for getopt_long, --help, "did you mean" and
 * `rmdctl --completion bash`.  Its rows, in order: getopt_long returns
 * TOOL_OPT_BASE + row (-j and -h: the letter).
 */
enum { OPT_URL, OPT_PREFIX, OPT_JSON, OPT_ONCE, OPT_INTERVAL, OPT_WAIT, OPT_ROBOT, OPT_HELP };

const struct tool_opt rmdctl_top_opts[] = {
	{ .name = "lcm-url",
	  .has_arg = required_argument,
	  .arg = "URL",
	  .help = "rmdd's LCM URL (default $LCM_DEFAULT_URL, else\n" RMD_CONFIG_DEFAULT_LCM_URL
		  ")" },
	{ .name = "prefix",
	  .has_arg = required_argument,
	  .arg = "P[,P...]",
	  .help = "rmdd's channel prefix (default " DEFAULT_PREFIX "); a comma list:\n"
		  "several rmdd of one robot in one view" },
	{ .name = "json", .shortc = 'j', .help = "print one JSON object and exit (scripts)" },
	{ .name = "once", .help = "print one table and exit" },
	TOOL_OPT_ARG("interval", "MS", "refresh period (default 100 on a terminal, else 1000)"),
	TOOL_OPT_ARG("wait", "S",
		     "with --json or --once: give up after S seconds without\n"
		     "config, health and state (default 3)"),
	{ .name = "robot",
	  .help = "every rmdd of the robot: the instances whose heartbeats\n"
		  "(" RMD_CHANNEL_ROBOT_HEARTBEAT ") are heard at start, instead of --prefix" },
	TOOL_OPT_HELP,
};
const size_t rmdctl_n_top_opts = sizeof(rmdctl_top_opts) / sizeof(rmdctl_top_opts[0]);

void rmdctl_top_usage(FILE *f)
{
	fprintf(f,
		"usage: rmdctl top [--lcm-url URL] [--prefix P[,P...] | --robot] [--json | --once]\n"
		"                  [--interval MS] [--wait S]\n"
		"\n"
		"A live view of a running rmdd, from what it publishes on LCM: every motor's\n"
		"name, bus and id, lifecycle and mode, position (rad; \"?\" after it: uncertain\n"
		"after a power cycle, docs/faults.md), velocity (rad/s), torque\n"
		"(N*m), temperature (degC), error flags, reply latency (us) and age (ms),\n"
		"missed replies and comm-loss protection (0xB3); each bus's state, load, frames\n"
		"and errors; the rt loop's wake-up latency, overruns, and the watchdog.\n"
		"It only listens (and asks for rmd.config_t), so it runs beside rmdd; `rmdctl\n"
		"monitor` opens the bus itself and is refused on a bus rmdd drives.\n"
		"\n");
	tool_opts_help(f, rmdctl_top_opts, rmdctl_n_top_opts);
	fprintf(f, "\n"
		   "On a terminal it is a full screen, one line per motor, as wide as the\n"
		   "terminal (narrow ones drop the less urgent columns); states that need\n"
		   "attention are marked ! and coloured: SAFE, LOST, FAULT, STALE (nothing from\n"
		   "rmdd for 1 s) and comm-loss protection not armed.  Keys: q quit, p or space\n"
		   "pause, up/down or j/k pick a motor (its details show below the table).\n"
		   "Otherwise (a pipe, a file, TERM=dumb) a plain table is printed each period.\n"
		   "JSON numbers are SI (rad, rad/s, N*m, degC, V); a value a motor has not\n"
		   "reported yet is null.\n"
		   "\n"
		   "--prefix A_,B_ shows several rmdd of one robot (each its own prefix, on\n"
		   "the one --lcm-url): every motor with its instance (INST: the prefix), one\n"
		   "line per instance with its rate, watchdog and buses, and SILENT on the\n"
		   "line of one that sent no health for 1 s while the others update.  Plain\n"
		   "tables get an INST column; --json prints {\"url\", \"instances\": [one\n"
		   "object each, as above]}, each motor with its \"instance\"; --json and\n"
		   "--once wait for every instance.\n"
		   "\n"
		   "exit status: 0 ok; 1 nothing heard from rmdd within --wait (--json, --once),\n"
		   "or LCM failed; 2 usage error.\n");
}

/* ---- LCM ------------------------------------------------------------------------------ */

/*
 * msg, of lcm-gen type T, becomes the view's newest in slot, heard now
 * (rx_ns); paused, a view that has one keeps it -- the screen keeps what
 * it showed -- and only the time is news (that rmdd lives).
 */
#define TOP_KEEP(T, paused, slot, rx_ns, msg)      \
	do {                                       \
		if (!((paused) && (slot))) {       \
			if (slot)                  \
				T##_destroy(slot); \
			(slot) = T##_copy(msg);    \
		}                                  \
		(rx_ns) = rmd_now_ns();            \
	} while (0)

static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *msg,
		     void *user)
{
	struct top_view *v = user;

	(void)rbuf;
	(void)channel;
	TOP_KEEP(rmd_state_t, v->paused, v->state, v->state_rx_ns, msg);
}

/*
 * Whether a message of daemon `instance` is the one shown: the first heard
 * is; another is noted as the other daemon (and flags the view).
 */
static bool same_daemon(struct top_view *v, int64_t instance, const char *host, int32_t pid,
			const char *source)
{
	if (!v->instance)
		v->instance = instance;
	if (instance == v->instance)
		return true;
	v->mixed = true;
	if (instance != v->other_instance)
		v->other_source[0] = '\0';
	v->other_instance = instance;
	v->other_pid = pid;
	snprintf(v->other_host, sizeof(v->other_host), "%s", host ? host : "");
	if (source)
		snprintf(v->other_source, sizeof(v->other_source), "%s", source);
	return false;
}

static void on_health(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_health_t *msg,
		      void *user)
{
	struct top_view *v = user;

	(void)rbuf;
	(void)channel;
	if (same_daemon(v, msg->instance, msg->host, msg->pid, NULL))
		TOP_KEEP(rmd_health_t, v->paused, v->health, v->health_rx_ns, msg);
}

static void on_config(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_config_t *msg,
		      void *user)
{
	struct top_view *v = user;

	(void)rbuf;
	(void)channel;
	if (same_daemon(v, msg->instance, msg->host, msg->pid, msg->source))
		TOP_KEEP(rmd_config_t, v->paused, v->cfg, v->cfg_rx_ns, msg);
}

/* config_t, health_t and state_t have come, and agree on the motors. */
static bool complete(const struct top_view *v)
{
	return v->cfg && v->health && v->state && v->state->count == v->cfg->motor_count &&
	       v->health->motor_count == v->cfg->motor_count;
}

/* Every instance complete. */
static bool all_complete(const struct top *t)
{
	for (int k = 0; k < t->n; k++)
		if (!complete(&t->v[k]))
			return false;
	return true;
}

/*
 * Ask each rmdd with no config_t yet for one (docs/lcm.md: any message on
 * PREFIX CONFIG_REQUEST), when its last request is 500 ms old.
 */
static void ask_config_due(struct top *t)
{
	int64_t now = rmd_now_ns();

	for (int k = 0; k < t->n; k++) {
		rmd_config_request_t req = { .utime = now / 1000 };

		if (t->v[k].cfg || now < t->in[k].next_ask_ns)
			continue;
		rmd_config_request_t_publish(t->lcm, t->in[k].ch_request, &req);
		t->in[k].next_ask_ns = now + ASK_EVERY_NS;
	}
}

/* Handle LCM until deadline_ns (monotonic), asking for config_t meanwhile when missing. */
static int pump(struct top *t, int64_t deadline_ns)
{
	for (;;) {
		int64_t now = rmd_now_ns();
		int ms, r;

		ask_config_due(t);
		if (now >= deadline_ns || rmdctl_top_stop)
			return 0;
		ms = (int)((deadline_ns - now + 999999) / 1000000);
		r = lcm_handle_timeout(t->lcm, ms > 50 ? 50 : ms);
		if (r < 0 && !rmdctl_top_stop) /* Ctrl-C interrupts the wait: not an error */
			return -EIO;
	}
}

/* ---- the view ------------------------------------------------------------------------- */

static const char *num(char *buf, size_t size, double v, int prec)
{
	if (!isfinite(v))
		return "-";
	snprintf(buf, size, "%.*f", prec, v);
	return buf;
}

/*
 * One daemon's table; multi (--prefix A_,B_): each motor's row starts with
 * its instance (INST).
 */
static void print_table(const struct top_view *v, bool multi, FILE *f)
{
	const rmd_config_t *c = v->cfg;
	const rmd_health_t *h = v->health;
	int64_t now = rmd_now_ns();
	char b[6][32];

	fprintf(f, "rmdd on %s, prefix %s", v->url, v->prefix);
	if (c)
		fprintf(f, ", period %d us, state every %d", c->period_us, c->state_every);
	if (v->state)
		fprintf(f, ", cycle %" PRId64, v->state->cycle);
	fputc('\n', f);
	if (!c || !h || !v->state) {
		fprintf(f, "waiting for rmdd: config %s, health %s, state %s\n", c ? "yes" : "no",
			h ? "yes" : "no", v->state ? "yes" : "no");
		return;
	}
	if (v->mixed) {
		char line[640];

		top_mixed_line(v, line, sizeof(line));
		fprintf(f, "%s\n", line);
	}
	if (top_stale(v))
		fprintf(f, "STALE: no health for %.1f s, no state for %.1f s (rmdd stopped?)\n",
			(double)(now - v->health_rx_ns) / 1e9,
			(double)(now - v->state_rx_ns) / 1e9);
	fprintf(f,
		"loop: cycles %" PRId64 ", overruns %" PRId64 ", plan misses %" PRId64
		"; wake-up us min %s avg %s p99 %s max %s; cycle max %s us\n",
		h->cycles, h->overruns, h->plan_misses, num(b[0], 32, h->wake_min_us, 1),
		num(b[1], 32, h->wake_avg_us, 1), num(b[2], 32, h->wake_p99_us, 1),
		num(b[3], 32, h->wake_max_us, 1), num(b[4], 32, h->cycle_max_us, 1));
	fprintf(f,
		"watchdog %s, safe actions %" PRId64 "; commands accepted %" PRId64
		", rejected %" PRId64 ", clamped %" PRId64 "; %s\n",
		tool_watchdog_name((unsigned)h->watchdog), h->safe_action_events,
		h->commands_accepted, h->commands_rejected, h->commands_clamped,
		h->owned ? "owned" : "no owner");
	fprintf(f, "\n%-12s %-9s %-14s %6s %10s %10s %7s %8s %8s %6s\n", "BUS", "KIND", "STATE",
		"LOAD%", "TX", "RX", "TXBUSY", "RXERR", "BUSERR", "CHG");
	for (int i = 0; i < h->bus_count && i < RMD_HEALTH_T_MAX_BUSES; i++) {
		const rmd_bus_health_t *bh = &h->bus[i];

		fprintf(f,
			"%-12s %-9s %-14s %6.1f %10" PRId64 " %10" PRId64 " %7" PRId64 " %8" PRId64
			" %8" PRId64 " %6" PRId64 "\n",
			bh->name, i < c->bus_count ? c->bus[i].kind : "?",
			top_bus_state_name(bh->state), bh->load * 100.0, bh->tx_frames,
			bh->rx_frames, bh->tx_busy, bh->rx_errors, bh->bus_errors,
			bh->state_changes);
	}
	fputc('\n', f);
	if (multi)
		fprintf(f, "%-8s ", "INST");
	fprintf(f, "%3s %-12s %-8s %3s %-8s %-8s %9s %9s %8s %6s %6s %6s %7s %8s %s\n", "IDX",
		"NAME", "BUS", "ID", "LIFECYC", "MODE", "POS_RAD", "VEL_RAD_S", "TORQUE", "TEMP",
		"ERR", "LAT_US", "AGE_MS", "MISSED", "PROTECTION");
	for (int i = 0; i < c->motor_count; i++) {
		const rmd_motor_config_t *mc = &c->motor[i];
		const rmd_motor_state_t *ms = top_motor_state(v, i);
		char prot[32];

		snprintf(prot, sizeof(prot), "%s %dms",
			 i < h->motor_count ? tool_comm_loss_name((unsigned)h->comm_loss[i]) : "?",
			 i < h->motor_count ? h->comm_loss_ms[i] : -1);
		if (multi)
			fprintf(f, "%-8s ", top_instance_name(v));
		if (!ms) {
			fprintf(f, "%3d %-12s (not in state_t)\n", i, mc->name);
			continue;
		}
		/* "?": uncertain after a power cycle (docs/faults.md), not trusted for position mode */
		num(b[0], 31, ms->position, 4);
		if (isfinite(ms->position) && !ms->position_certain)
			strcat(b[0], "?");
		fprintf(f,
			"%3d %-12s %-8s %3d %-8s %-8s %9s %9s %8s %6s %#6x %6d %7.1f %8" PRId64
			" %s\n",
			i, mc->name,
			mc->bus >= 0 && mc->bus < c->bus_count ? c->bus[mc->bus].name : "?", mc->id,
			tool_lifecycle_name((unsigned)ms->lifecycle), top_mode_name(ms->mode),
			isfinite(ms->position) ? b[0] : "-", num(b[1], 32, ms->velocity, 3),
			num(b[2], 32, ms->torque, 3), num(b[3], 32, ms->temperature, 0),
			(unsigned)ms->error_code, ms->reply_latency_us,
			ms->reply_age_cycles * c->period_us / 1000.0, ms->missed_replies, prot);
	}
}

/* A JSON string (names from config_t: [a-z0-9_] and paths, escaped anyway). */
static void json_str(FILE *f, const char *s)
{
	fputc('"', f);
	for (; *s; s++) {
		if (*s == '"' || *s == '\\')
			fprintf(f, "\\%c", *s);
		else if ((unsigned char)*s < 0x20)
			fprintf(f, "\\u%04x", (unsigned char)*s);
		else
			fputc(*s, f);
	}
	fputc('"', f);
}

/* A number, or null (NaN: not reported yet). */
static void json_num(FILE *f, double v)
{
	if (isfinite(v))
		fprintf(f, "%.9g", v);
	else
		fputs("null", f);
}

/* ,"key":"value" */
static void json_kstr(FILE *f, const char *key, const char *v)
{
	fprintf(f, ",\"%s\":", key);
	json_str(f, v);
}

static void json_knum(FILE *f, const char *key, double v)
{
	fprintf(f, ",\"%s\":", key);
	json_num(f, v);
}

static void json_kint(FILE *f, const char *key, int64_t v)
{
	fprintf(f, ",\"%s\":%" PRId64, key, v);
}

/* One daemon's object; multi (--prefix A_,B_): each motor with its "instance" (the prefix). */
static void print_json(const struct top_view *v, bool multi, FILE *f)
{
	const rmd_config_t *c = v->cfg;
	const rmd_health_t *h = v->health;
	const rmd_state_t *s = v->state;

	fputs("{\"url\":", f);
	json_str(f, v->url);
	json_kstr(f, "prefix", c->prefix);
	fprintf(f, ",\"instance\":\"%016" PRIx64 "\"", (uint64_t)c->instance);
	json_kstr(f, "host", c->host);
	json_kint(f, "pid", c->pid);
	json_kstr(f, "source", c->source);
	/* another daemon on the prefix: null, or who it is */
	if (v->mixed) {
		fprintf(f, ",\"mixed\":{\"instance\":\"%016" PRIx64 "\"",
			(uint64_t)v->other_instance);
		json_kstr(f, "host", v->other_host);
		json_kint(f, "pid", v->other_pid);
		json_kstr(f, "source", v->other_source);
		fputc('}', f);
	} else {
		fputs(",\"mixed\":null", f);
	}
	json_kint(f, "period_us", c->period_us);
	json_kint(f, "state_every", c->state_every);
	json_kint(f, "cycle", s->cycle);
	json_kint(f, "cycles", h->cycles);
	json_kint(f, "overruns", h->overruns);
	json_kint(f, "plan_misses", h->plan_misses);
	json_knum(f, "wake_min_us", h->wake_min_us);
	json_knum(f, "wake_avg_us", h->wake_avg_us);
	json_knum(f, "wake_p99_us", h->wake_p99_us);
	json_knum(f, "wake_max_us", h->wake_max_us);
	json_knum(f, "cycle_max_us", h->cycle_max_us);
	json_kstr(f, "watchdog", tool_watchdog_name((unsigned)h->watchdog));
	json_kint(f, "safe_action_events", h->safe_action_events);
	json_kint(f, "commands_accepted", h->commands_accepted);
	json_kint(f, "commands_rejected", h->commands_rejected);
	json_kint(f, "commands_clamped", h->commands_clamped);
	fprintf(f, ",\"owned\":%s", h->owned ? "true" : "false");
	json_kint(f, "owner", h->owner);
	fputs(",\"buses\":[", f);
	for (int i = 0; i < h->bus_count && i < RMD_HEALTH_T_MAX_BUSES; i++) {
		const rmd_bus_health_t *bh = &h->bus[i];

		fputs(i ? ",{\"name\":" : "{\"name\":", f);
		json_str(f, bh->name);
		json_kstr(f, "kind", i < c->bus_count ? c->bus[i].kind : "?");
		json_kint(f, "bitrate", i < c->bus_count ? c->bus[i].bitrate : 0);
		json_kstr(f, "state", top_bus_state_name(bh->state));
		json_knum(f, "load", bh->load);
		json_kint(f, "tx_frames", bh->tx_frames);
		json_kint(f, "rx_frames", bh->rx_frames);
		json_kint(f, "tx_busy", bh->tx_busy);
		json_kint(f, "rx_errors", bh->rx_errors);
		json_kint(f, "bus_errors", bh->bus_errors);
		json_kint(f, "state_changes", bh->state_changes);
		fputc('}', f);
	}
	fputs("],\"motors\":[", f);
	for (int i = 0; i < c->motor_count; i++) {
		const rmd_motor_config_t *mc = &c->motor[i];
		const rmd_motor_state_t *ms = top_motor_state(v, i);

		fprintf(f, "%s{\"index\":%d", i ? "," : "", i);
		if (multi)
			json_kstr(f, "instance", top_instance_name(v));
		json_kstr(f, "name", mc->name);
		json_kstr(f, "bus",
			  mc->bus >= 0 && mc->bus < c->bus_count ? c->bus[mc->bus].name : "?");
		json_kint(f, "id", mc->id);
		json_kstr(f, "protocol", mc->protocol);
		if (ms) {
			json_kstr(f, "lifecycle", tool_lifecycle_name((unsigned)ms->lifecycle));
			json_kstr(f, "mode", top_mode_name(ms->mode));
			json_knum(f, "position", ms->position);
			fprintf(f, ",\"position_certain\":%s",
				ms->position_certain ? "true" : "false");
			json_knum(f, "velocity", ms->velocity);
			json_knum(f, "torque", ms->torque);
			json_knum(f, "current", ms->current);
			json_knum(f, "temperature", ms->temperature);
			json_knum(f, "voltage", ms->voltage);
			json_kint(f, "error_code", ms->error_code);
			json_kint(f, "reply_latency_us", ms->reply_latency_us);
			json_kint(f, "reply_age_cycles", ms->reply_age_cycles);
			json_kint(f, "missed_replies", ms->missed_replies);
		}
		json_kstr(f, "comm_loss", tool_comm_loss_name((unsigned)h->comm_loss[i]));
		json_kint(f, "comm_loss_ms", h->comm_loss_ms[i]);
		json_kint(f, "unarmed_rejects", h->unarmed_rejects[i]);
		fputc('}', f);
	}
	fputs("]}", f);
}

/* ---- the command ---------------------------------------------------------------------- */

/* Every instance's table or object (one prefix: exactly as before --prefix took a list). */
static void print_all(const struct top *t, FILE *f)
{
	bool multi = t->n > 1 || t->robot; /* --robot: which part, even of one */

	if (t->json && multi) {
		fputs("{\"url\":", f);
		json_str(f, t->v[0].url);
		fputs(",\"instances\":[", f);
	}
	for (int k = 0; k < t->n; k++) {
		if (t->json) {
			if (k)
				fputc(',', f);
			print_json(&t->v[k], multi, f);
		} else {
			if (k)
				fputc('\n', f);
			print_table(&t->v[k], multi, f);
		}
	}
	if (t->json)
		fputs(multi ? "]}\n" : "\n", f);
}

/* --prefix's comma list into t->v[].prefix (t->n of them): 0, or -1 (reported). */
static int split_prefixes(struct top *t)
{
	char *p = t->prefixes;

	for (t->n = 0;; t->n++) {
		char *comma = strchr(p, ',');

		if (comma)
			*comma = '\0';
		if (t->n == TOP_MAX_INSTANCES) {
			tool_log(TOOL_LOG_ERR, "--prefix: more than %d prefixes",
				 TOP_MAX_INSTANCES);
			return -1;
		}
		/* "" alone is a prefix (rmdd's lcm.channel_prefix may be empty), not in a list */
		if (!*p && (comma || t->n)) {
			tool_log(TOOL_LOG_ERR, "--prefix: an empty prefix in the list");
			return -1;
		}
		if (strlen(p) + strlen(RMD_CHANNEL_CONFIG_REQUEST) >= TOP_CHANNEL_LEN) {
			tool_log(TOOL_LOG_ERR, "--prefix \"%s\" is too long", p);
			return -1;
		}
		for (int k = 0; k < t->n; k++)
			if (!strcmp(t->v[k].prefix, p)) {
				tool_log(TOOL_LOG_ERR, "--prefix: \"%s\" twice", p);
				return -1;
			}
		t->v[t->n].prefix = p;
		t->v[t->n].url = t->v[0].url;
		if (!comma)
			break;
		p = comma + 1;
	}
	t->n++;
	return 0;
}

/* The command line into t: 0, 1 after --help, or -1 after a usage error (reported). */
static int parse(struct top *t, int argc, char **argv)
{
	struct option longopts[sizeof(rmdctl_top_opts) / sizeof(rmdctl_top_opts[0]) + 1];
	char shorts[16], msg[160];
	int c;

	tool_opts_getopt(rmdctl_top_opts, rmdctl_n_top_opts, longopts, shorts, sizeof(shorts));
	optind = 0; /* glibc: full re-initialisation */
	opterr = 0;
	while ((c = getopt_long(argc, argv, shorts, longopts, NULL)) != -1) {
		switch (c) {
		case TOOL_OPT_BASE + OPT_URL:
			t->v[0].url = optarg;
			break;
		case TOOL_OPT_BASE + OPT_PREFIX:
			if (strlen(optarg) >= sizeof(t->prefixes)) {
				tool_log(TOOL_LOG_ERR, "--prefix is too long");
				return -1;
			}
			snprintf(t->prefixes, sizeof(t->prefixes), "%s", optarg);
			break;
		case 'j':
			t->json = true;
			break;
		case TOOL_OPT_BASE + OPT_ONCE:
			t->once = true;
			break;
		case TOOL_OPT_BASE + OPT_INTERVAL:
			if (rmdctl_parse_double(optarg, &t->interval_ms) < 0 ||
			    t->interval_ms < 10 || t->interval_ms > 3600000) {
				tool_log(TOOL_LOG_ERR, "bad --interval \"%s\" (10..3600000 ms)",
					 optarg);
				return -1;
			}
			break;
		case TOOL_OPT_BASE + OPT_WAIT:
			if (rmdctl_parse_double(optarg, &t->wait_s) < 0 || t->wait_s <= 0 ||
			    t->wait_s > 3600) {
				tool_log(TOOL_LOG_ERR, "bad --wait \"%s\" (seconds, 0..3600)",
					 optarg);
				return -1;
			}
			break;
		case TOOL_OPT_BASE + OPT_ROBOT:
			t->robot = true;
			break;
		case 'h':
			rmdctl_top_usage(stdout);
			return 1;
		default: /* '?' and ':': "unknown option "--jsn" (did you mean --json?)" */
			tool_log(TOOL_LOG_ERR, "%s",
				 tool_getopt_error(msg, sizeof(msg), c, argv, rmdctl_top_opts,
						   rmdctl_n_top_opts));
			return -1;
		}
	}
	if (optind < argc) {
		tool_log(TOOL_LOG_ERR, "unexpected argument \"%s\"", argv[optind]);
		return -1;
	}
	if (t->json && t->once) {
		tool_log(TOOL_LOG_ERR, "--json and --once exclude each other");
		return -1;
	}
	if (t->robot && strcmp(t->prefixes, DEFAULT_PREFIX)) {
		tool_log(TOOL_LOG_ERR, "--robot and --prefix exclude each other");
		return -1;
	}
	return t->robot ? 0 : split_prefixes(t);
}

/* The instances --robot heard: prefix and name, from their heartbeats. */
struct heard {
	unsigned n, more;
	char prefix[TOP_MAX_INSTANCES][TOP_CHANNEL_LEN], name[TOP_MAX_INSTANCES][64];
	int64_t last_new_ns;
};

static void on_heartbeat(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_heartbeat_t *h,
			 void *user)
{
	struct heard *d = user;

	(void)rbuf;
	(void)channel;
	if (strlen(h->prefix) + strlen(RMD_CHANNEL_CONFIG_REQUEST) >= TOP_CHANNEL_LEN)
		return;
	for (unsigned k = 0; k < d->n; k++)
		if (!strcmp(d->prefix[k], h->prefix))
			return;
	if (d->n == TOP_MAX_INSTANCES) {
		d->more++;
		return;
	}
	snprintf(d->prefix[d->n], sizeof(d->prefix[0]), "%s", h->prefix);
	snprintf(d->name[d->n], sizeof(d->name[0]), "%s", h->instance);
	d->n++;
	d->last_new_ns = rmd_now_ns();
}

/*
 * --robot: listen to the robot's heartbeats until none new came for
 * DISCOVER_QUIET_NS (at most --wait s), and view each instance heard, in
 * the order of their names.  0, or -ETIMEDOUT (reported) when none was.
 */
#define DISCOVER_QUIET_NS (300 * RMD_NS_PER_MS)

static int discover(struct top *t)
{
	static struct heard d;
	rmd_heartbeat_t_subscription_t *sub =
		rmd_heartbeat_t_subscribe(t->lcm, RMD_CHANNEL_ROBOT_HEARTBEAT, on_heartbeat, &d);
	int64_t start = rmd_now_ns(), end = start + (int64_t)(t->wait_s * 1e9);
	size_t len = 0;

	memset(&d, 0, sizeof(d));
	while (!rmdctl_top_stop && rmd_now_ns() < end &&
	       !(d.n && rmd_now_ns() - d.last_new_ns > DISCOVER_QUIET_NS))
		lcm_handle_timeout(t->lcm, 20);
	rmd_heartbeat_t_unsubscribe(t->lcm, sub);
	if (!d.n) {
		tool_log(TOOL_LOG_ERR,
			 "--robot: no rmdd's heartbeat on %s within %g s (an rmdd without a "
			 "robot: section sends none: name it with --prefix)",
			 t->v[0].url, t->wait_s);
		return -ETIMEDOUT;
	}
	if (d.more)
		tool_log(TOOL_LOG_WARNING, "--robot: %u more instances than the %d shown", d.more,
			 TOP_MAX_INSTANCES);
	/* by name: the same robot shows the same way each time */
	for (unsigned i = 1; i < d.n; i++)
		for (unsigned j = i; j > 0 && strcmp(d.name[j - 1], d.name[j]) > 0; j--) {
			char tp[TOP_CHANNEL_LEN], tn[64];

			memcpy(tp, d.prefix[j], sizeof(tp));
			memcpy(tn, d.name[j], sizeof(tn));
			memcpy(d.prefix[j], d.prefix[j - 1], sizeof(tp));
			memcpy(d.name[j], d.name[j - 1], sizeof(tn));
			memcpy(d.prefix[j - 1], tp, sizeof(tp));
			memcpy(d.name[j - 1], tn, sizeof(tn));
		}
	t->prefixes[0] = '\0';
	for (unsigned k = 0; k < d.n; k++)
		len += (size_t)snprintf(t->prefixes + len, sizeof(t->prefixes) - len, "%s%s",
					k ? "," : "", d.prefix[k]);
	return split_prefixes(t) < 0 ? -EINVAL : 0;
}

/* The instances not complete, as "A_ (config no, health yes, state no), ...". */
static void incomplete(const struct top *t, char *buf, size_t len)
{
	size_t n = 0;

	buf[0] = '\0';
	for (int k = 0; k < t->n && n < len; k++) {
		const struct top_view *v = &t->v[k];

		if (complete(v))
			continue;
		n += (size_t)snprintf(buf + n, len - n, "%s%s (config %s, health %s, state %s)",
				      n ? ", " : "", v->prefix, v->cfg ? "yes" : "no",
				      v->health ? "yes" : "no", v->state ? "yes" : "no");
	}
}

/*
 * --json and --once: one object or table once config, health and state
 * have come (from every instance).
 */
static int run_once(struct top *t)
{
	int64_t start = rmd_now_ns();
	bool multi = t->n > 1 || t->robot;

	for (;;) {
		if (pump(t, rmd_now_ns() + 20000000) < 0)
			return -EIO;
		if (all_complete(t)) {
			/* another daemon's health_t (10 Hz) would come meanwhile: "mixed" */
			if (pump(t, rmd_now_ns() + TOP_MIXED_WAIT_NS) < 0)
				return -EIO;
			break;
		}
		if (rmdctl_top_stop || rmd_now_ns() - start > (int64_t)(t->wait_s * 1e9)) {
			const struct top_view *v = &t->v[0];
			char which[TOP_MAX_INSTANCES * 64];

			if (!multi) {
				tool_log(TOOL_LOG_ERR,
					 "no complete %s" RMD_CHANNEL_CONFIG
					 ", %s" RMD_CHANNEL_HEALTH " and %s" RMD_CHANNEL_STATE
					 " within %g s "
					 "(config %s, health %s, state %s): is rmdd running, with "
					 "--lcm-url %s and prefix %s?",
					 v->prefix, v->prefix, v->prefix, t->wait_s,
					 v->cfg ? "yes" : "no", v->health ? "yes" : "no",
					 v->state ? "yes" : "no", v->url, v->prefix);
				return -ETIMEDOUT;
			}
			incomplete(t, which, sizeof(which));
			tool_log(TOOL_LOG_ERR,
				 "no complete config, health and state within %g s from %s: are "
				 "they running, with --lcm-url %s?",
				 t->wait_s, which, v->url);
			return -ETIMEDOUT;
		}
	}
	print_all(t, stdout);
	return 0;
}

/* Not a terminal (or one curses cannot drive): a plain table every --interval. */
static int run_plain(struct top *t)
{
	int64_t next_draw = rmd_now_ns();

	for (;;) {
		next_draw += (int64_t)(t->interval_ms * 1e6);
		if (pump(t, next_draw) < 0)
			return -EIO;
		if (rmdctl_top_stop)
			return 0;
		fputc('\n', stdout);
		print_all(t, stdout);
		fflush(stdout);
	}
}

/*
 * On a terminal: the screen, redrawn every --interval and at each key, until
 * q, Ctrl-C or SIGTERM.  Returns 0, -EIO when LCM failed, or -ENOTTY when
 * curses cannot drive this terminal (the caller prints plain tables instead).
 */
static int run_screen(struct top *t)
{
	int64_t period = (int64_t)(t->interval_ms * 1e6), next_draw = rmd_now_ns();
	struct top_screen *scr = top_screen_open();
	bool dirty = false;
	int r = 0;

	if (!scr)
		return -ENOTTY;
	while (!rmdctl_top_stop) {
		struct pollfd p[2] = {
			{ .fd = lcm_get_fileno(t->lcm), .events = POLLIN },
			{ .fd = STDIN_FILENO, .events = POLLIN },
		};
		int64_t now = rmd_now_ns();
		unsigned int keys;
		int ms;

		ask_config_due(t);
		if (now >= next_draw || dirty) {
			top_screen_draw(scr, t->v, t->n);
			dirty = false;
			if (now >= next_draw)
				next_draw = now + period; /* late draws are not caught up */
		}
		ms = (int)((next_draw - now) / 1000000) + 1;
		if (ms > POLL_MAX_MS)
			ms = POLL_MAX_MS;
		/* a signal (Ctrl-C, a resize) interrupts the wait: the loop looks again */
		if (poll(p, 2, ms) < 0 && errno != EINTR) {
			r = -EIO;
			break;
		}
		if ((p[0].revents & POLLIN) && lcm_handle(t->lcm) < 0) {
			r = -EIO;
			break;
		}
		keys = top_screen_keys(scr, t->v, t->n);
		if (keys & TOP_SCREEN_PAUSE)
			for (int k = 0; k < t->n; k++)
				t->v[k].paused = !t->v[k].paused;
		if (keys & TOP_SCREEN_KEYED)
			dirty = true;
		if (keys & TOP_SCREEN_QUIT)
			break;
	}
	top_screen_close(scr);
	return r;
}

/* The screen wants a terminal that is more than a teletype. */
static bool screen_terminal(void)
{
	const char *term = getenv("TERM");

	return isatty(STDOUT_FILENO) && isatty(STDIN_FILENO) && term && *term &&
	       strcmp(term, "dumb") != 0;
}

static int run(struct top *t)
{
	int r;

	if (t->json || t->once)
		return run_once(t);
	if (t->tty) {
		r = run_screen(t);
		if (r != -ENOTTY)
			return r;
		tool_log(TOOL_LOG_WARNING, "curses cannot drive TERM=%s: plain tables",
			 getenv("TERM"));
	}
	return run_plain(t);
}

int rmdctl_top_run(int argc, char **argv)
{
	struct top t = { .prefixes = DEFAULT_PREFIX, .wait_s = WAIT_S };
	struct sigaction sa;
	const char *env = getenv("LCM_DEFAULT_URL");
	int r;

	t.v[0].url = env && *env ? env : RMD_CONFIG_DEFAULT_LCM_URL;
	t.tty = screen_terminal();
	r = parse(&t, argc, argv);
	if (r > 0)
		return RMDCTL_EXIT_OK;
	if (r < 0) {
		rmdctl_usage_hint_name("top");
		return RMDCTL_EXIT_USAGE;
	}
	if (t.interval_ms == 0)
		t.interval_ms = t.tty ? TTY_INTERVAL_MS : PLAIN_INTERVAL_MS;

	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);

	t.lcm = lcm_create(t.v[0].url);
	if (!t.lcm) {
		tool_log(TOOL_LOG_ERR,
			 "LCM: cannot open %s (docs/lcm.md: a robot PC without a network)",
			 t.v[0].url);
		return RMDCTL_EXIT_DATA;
	}
	if (t.robot && discover(&t) < 0) {
		lcm_destroy(t.lcm);
		return RMDCTL_EXIT_DATA;
	}
	for (int k = 0; k < t.n; k++) {
		struct top_inst *in = &t.in[k];
		const char *p = t.v[k].prefix;

		snprintf(in->ch_state, sizeof(in->ch_state), "%s" RMD_CHANNEL_STATE, p);
		snprintf(in->ch_health, sizeof(in->ch_health), "%s" RMD_CHANNEL_HEALTH, p);
		snprintf(in->ch_config, sizeof(in->ch_config), "%s" RMD_CHANNEL_CONFIG, p);
		snprintf(in->ch_request, sizeof(in->ch_request), "%s" RMD_CHANNEL_CONFIG_REQUEST,
			 p);
	}
	/* one set per instance; the generated subscriptions are the caller's to free (lcm-gen's C) */
	for (int k = 0; k < t.n; k++) {
		struct top_inst *in = &t.in[k];

		in->s_state = rmd_state_t_subscribe(t.lcm, in->ch_state, on_state, &t.v[k]);
		in->s_health = rmd_health_t_subscribe(t.lcm, in->ch_health, on_health, &t.v[k]);
		in->s_config = rmd_config_t_subscribe(t.lcm, in->ch_config, on_config, &t.v[k]);
	}
	r = run(&t);
	if (r == -EIO)
		tool_log(TOOL_LOG_ERR, "LCM: receiving on %s failed", t.v[0].url);
	for (int k = 0; k < t.n; k++) {
		struct top_inst *in = &t.in[k];
		struct top_view *v = &t.v[k];

		rmd_state_t_unsubscribe(t.lcm, in->s_state);
		rmd_health_t_unsubscribe(t.lcm, in->s_health);
		rmd_config_t_unsubscribe(t.lcm, in->s_config);
		if (v->cfg)
			rmd_config_t_destroy(v->cfg);
		if (v->health)
			rmd_health_t_destroy(v->health);
		if (v->state)
			rmd_state_t_destroy(v->state);
	}
	lcm_destroy(t.lcm);
	if (fflush(stdout) != 0 || ferror(stdout)) {
		tool_log(TOOL_LOG_ERR, "write error: %s", strerror(errno));
		return RMDCTL_EXIT_DATA;
	}
	return r < 0 ? RMDCTL_EXIT_DATA : RMDCTL_EXIT_OK;
}
