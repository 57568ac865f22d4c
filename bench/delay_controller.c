// SPDX-License-Identifier: MIT
/*
 * bench/control-delay.sh's controller and its matcher (issue 23 point 1:
 * the time from a motor's reply on the wire to the frame carrying the
 * controller's response to it).
 *
 *   delay_controller run --url URL [--prefix P] [--seconds S] [--rt-priority N]
 *                        [--warmup-ms MS] --out LOG
 *   delay_controller match LOG CANDUMP... [--kernel-stamps]
 *
 * run: a controller that answers each state_t at once.  It asks for
 * rmdd's configuration (config_t: each motor's bus and ID, each bus's
 * bitrate), disables every motor (rmdd wants an enable edge, docs/lcm.md),
 * and then, inside the handler of every state_t, publishes a command_t
 * that enables every motor in speed mode at a velocity that names the
 * state: tag = 1 + cycle % TAG_MOD, velocity = tag * 0.01 deg/s, which
 * rmdd rounds to the raw value tag in the 0xA2 frame (int32 speed in
 * 0.01 dps, bytes 4..7, as codec_v3.c's 0xA2 row packs it; at most
 * 10 deg/s, harmless to a simulated motor).  At SCHED_FIFO --rt-priority (set it below rmdd's LCM
 * bridge) and mlockall()ed; states are logged into memory allocated before
 * the first one: per state and motor, the cycle, the tag, when the state
 * was read and the command published, the motor's lifecycle and its
 * rx_time_ns (the end of its reply on the wire for the sim bus, the
 * kernel's receive stamp for SocketCAN).  Recording starts --warmup-ms
 * after every motor is ENABLED and lasts --seconds; then enable = 0 to
 * every motor and the log (text) is written to LOG:
 *   o OFFSET_NS                              CLOCK_REALTIME - CLOCK_MONOTONIC
 *   b BUS BITRATE                            one line a bus
 *   m INDEX BUS ID                           one line a motor
 *   s CYCLE TAG READ_NS PUB_NS INDEX LC RX_NS  one line a state and motor
 *
 * match: the delays.  For each motor, each reply counts once, in the first
 * state that carries it (a new rx_time_ns); its frame is the motor's 0xA2
 * reply (0x240 + ID) in the candump -l file of its bus stamped at
 * rx_time_ns (within a microsecond), and the response is the first frame
 * to that motor (0x140 + ID, direction T; without a direction, the
 * identifier says it) after it that is a 0xA2 with the state's tag.  Both
 * are taken at their start: the candump stamp (end of frame for the sim
 * bus's tap, in CLOCK_MONOTONIC) minus the frame's wire time up to its end
 * of frame, its exact bits with stuffing (rmd_can_frame_bits() less the
 * interframe space) at the bus's bitrate.  --kernel-stamps: the candump
 * of a SocketCAN interface (candump -L), stamped by the kernel in
 * CLOCK_REALTIME, which rmdd's rx_time_ns are moved from onto
 * CLOCK_MONOTONIC: the reply is looked for at rx_time_ns + the log's
 * offset (within TOL_KERNEL_US, the nearest), and the stamps are taken as
 * they are (vcan has no wire time).  Prints "INDEX DELAY_US" a reply on stdout, and to stderr what
 * was counted and what was not: replies without a response frame within
 * 100 ms (superseded: the next state's command went out first) and
 * replies not found in the candump.
 *
 * Non-rt, a benchmark: only the state handler of `run` is meant to be
 * quick (no allocation, no formatting).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <sched.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/mman.h>

#include <lcm/lcm.h>

#include "rmd/can_timing.h"
#include "rmd/channels.h"
#include "rmd/frame.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"

#define PROG "delay_controller"
#define MAX_MOTORS RMD_COMMAND_T_MAX_MOTORS
#define MAX_BUSES 16
#define NAME_LEN 32
#define TAG_MOD 1000 /* tags 1..1000: unique over 1000 states */
#define DEG_PER_RAD (180.0 / M_PI)
#define NS_PER_MS INT64_C(1000000)
#define NS_PER_S INT64_C(1000000000)
#define SEARCH_US 100000	    /* a response later than this is not looked for */
#define MAX_RECS (4u * 1024 * 1024) /* states x motors a run keeps */
#define TOL_KERNEL_US 50	    /* --kernel-stamps: rmdd's offset and ours differ a little */

/* ---- run ------------------------------------------------------------------ */

struct rec {
	int64_t cycle, read_ns, pub_ns, rx_ns;
	int16_t tag, index;
	int8_t lc;
};

struct ctl {
	lcm_t *lcm;
	char ch_command[96], ch_state[96], ch_config[96], ch_config_req[96];
	bool have_config;
	int n_buses, n_motors;
	char bus_name[MAX_BUSES][NAME_LEN];
	int32_t bitrate[MAX_BUSES];
	int motor_bus[MAX_MOTORS], motor_id[MAX_MOTORS];

	bool enable; /* answer with enable = 1 (after the disable edge) */
	int last_lc[MAX_MOTORS];
	int64_t enabled_ns; /* when every motor was first seen ENABLED; 0: not yet */
	int64_t warmup_ns;
	int64_t record_from, record_until; /* CLOCK_MONOTONIC ns; 0: not set */
	unsigned long states;

	struct rec *recs;
	size_t n_recs, lost_recs;

	int64_t seq, id;
	int64_t rt_offset_ns; /* CLOCK_REALTIME - CLOCK_MONOTONIC at start */
	rmd_command_t msg;
	rmd_motor_command_t msg_motor[MAX_MOTORS];
	uint8_t buf[4096];
};

static volatile sig_atomic_t stop_signal;

static void on_signal(int sig)
{
	stop_signal = sig;
}

/*
 * One command_t to every motor: speed mode at tag * 0.01 deg/s, or enable
 * = 0; enable = 0 also to a motor last seen SAFE or FAULT, which takes
 * enable = 1 only after it (docs/lcm.md; a stalled machine trips the
 * command timeout).  Returns 0 or -EIO.
 */
static int publish(struct ctl *c, bool enable, int tag)
{
	rmd_command_t *msg = &c->msg;
	int len;

	msg->utime = rmd_now_ns() / 1000;
	msg->seq = c->seq++;
	msg->controller = c->id;
	msg->takeover = false;
	msg->count = (int16_t)c->n_motors;
	msg->motor = c->msg_motor;
	for (int i = 0; i < c->n_motors; i++) {
		rmd_motor_command_t *mc = &msg->motor[i];

		memset(mc, 0, sizeof(*mc));
		mc->index = (int16_t)i;
		mc->enable = enable && c->last_lc[i] != RMD_STATE_T_LC_SAFE &&
			     c->last_lc[i] != RMD_STATE_T_LC_FAULT;
		mc->mode = RMD_COMMAND_T_MODE_SPEED;
		mc->velocity = tag * 0.01 / DEG_PER_RAD;
	}
	len = rmd_command_t_encode(c->buf, 0, (int)sizeof(c->buf), msg);
	if (len < 0 || lcm_publish(c->lcm, c->ch_command, c->buf, (unsigned)len) < 0)
		return -EIO;
	return 0;
}

static void on_config(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_config_t *msg,
		      void *user)
{
	struct ctl *c = user;

	(void)rbuf;
	(void)channel;
	if (c->have_config)
		return;
	c->n_buses = msg->bus_count < MAX_BUSES ? msg->bus_count : MAX_BUSES;
	for (int b = 0; b < c->n_buses; b++) {
		snprintf(c->bus_name[b], NAME_LEN, "%s", msg->bus[b].name);
		c->bitrate[b] = msg->bus[b].bitrate;
	}
	c->n_motors = msg->motor_count < MAX_MOTORS ? msg->motor_count : MAX_MOTORS;
	for (int i = 0; i < c->n_motors; i++) {
		c->motor_bus[i] = msg->motor[i].bus;
		c->motor_id[i] = msg->motor[i].id;
	}
	c->have_config = true;
}

/* Answer at once, then log.  Quick: no allocation, no formatting. */
static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *msg,
		     void *user)
{
	struct ctl *c = user;
	int64_t read_ns = rmd_now_ns(), pub_ns;
	int tag = 1 + (int)(msg->cycle % TAG_MOD);
	int n = msg->count < c->n_motors ? msg->count : c->n_motors;
	bool all_enabled = n == c->n_motors;

	(void)rbuf;
	(void)channel;
	for (int i = 0; i < n; i++) {
		c->last_lc[i] = msg->motor[i].lifecycle;
		all_enabled &= msg->motor[i].lifecycle == RMD_STATE_T_LC_ENABLED;
	}
	if (c->enable && publish(c, true, tag) < 0)
		stop_signal = SIGPIPE;
	pub_ns = rmd_now_ns();
	c->states++;
	if (all_enabled && !c->enabled_ns) {
		c->enabled_ns = read_ns;
		c->record_from = read_ns + c->warmup_ns;
	}
	if (!c->record_from || read_ns < c->record_from ||
	    (c->record_until && read_ns >= c->record_until))
		return;
	for (int i = 0; i < n; i++) {
		if (c->n_recs >= MAX_RECS) {
			c->lost_recs++;
			continue;
		}
		c->recs[c->n_recs++] = (struct rec){ .cycle = msg->cycle,
						     .read_ns = read_ns,
						     .pub_ns = pub_ns,
						     .rx_ns = msg->motor[i].rx_time_ns,
						     .tag = (int16_t)tag,
						     .index = (int16_t)i,
						     .lc = msg->motor[i].lifecycle };
	}
}

/*
 * Handle messages until deadline (CLOCK_MONOTONIC ns) or a signal, each as it
 * comes (lcm_handle_timeout() returns on the first; the wait, the time left
 * rounded up to a millisecond, only bounds a quiet spell).  0 or -EIO.
 */
static int handle_until(struct ctl *c, int64_t deadline)
{
	int64_t left;

	while (!stop_signal && (left = deadline - rmd_now_ns()) > 0)
		if (lcm_handle_timeout(c->lcm, (int)((left + NS_PER_MS - 1) / NS_PER_MS)) < 0 &&
		    errno != EINTR)
			return -EIO;
	return 0;
}

static bool all_lc(const struct ctl *c, int lc)
{
	for (int i = 0; i < c->n_motors; i++)
		if (c->last_lc[i] != lc)
			return false;
	return c->n_motors > 0;
}

static int write_log(const struct ctl *c, const char *path)
{
	FILE *f = fopen(path, "w");

	if (!f)
		return -errno;
	fprintf(f, "o %" PRId64 "\n", c->rt_offset_ns);
	for (int b = 0; b < c->n_buses; b++)
		fprintf(f, "b %s %" PRId32 "\n", c->bus_name[b], c->bitrate[b]);
	for (int i = 0; i < c->n_motors; i++)
		fprintf(f, "m %d %s %d\n", i,
			c->motor_bus[i] >= 0 && c->motor_bus[i] < c->n_buses ?
				c->bus_name[c->motor_bus[i]] :
				"?",
			c->motor_id[i]);
	for (size_t k = 0; k < c->n_recs; k++) {
		const struct rec *r = &c->recs[k];

		fprintf(f, "s %" PRId64 " %d %" PRId64 " %" PRId64 " %d %d %" PRId64 "\n", r->cycle,
			r->tag, r->read_ns, r->pub_ns, r->index, r->lc, r->rx_ns);
	}
	return fclose(f) ? -errno : 0;
}

static int set_fifo(int prio)
{
	struct sched_param sp = { .sched_priority = prio };

	if (prio <= 0)
		return 0;
	if (sched_setscheduler(0, SCHED_FIFO, &sp) < 0)
		return -errno;
	return 0;
}

static int run(int argc, char **argv)
{
	static struct ctl c;
	const char *url = NULL, *prefix = "RMD_", *out = NULL;
	double seconds = 5, warmup_ms = 300;
	int prio = 0, r;
	int64_t end;

	for (int a = 2; a < argc; a++) {
		const char *v = a + 1 < argc ? argv[a + 1] : NULL;

		if (!v) {
			fprintf(stderr, PROG ": %s: needs a value\n", argv[a]);
			return 2;
		}
		if (!strcmp(argv[a], "--url"))
			url = v;
		else if (!strcmp(argv[a], "--prefix"))
			prefix = v;
		else if (!strcmp(argv[a], "--seconds"))
			seconds = atof(v);
		else if (!strcmp(argv[a], "--warmup-ms"))
			warmup_ms = atof(v);
		else if (!strcmp(argv[a], "--rt-priority"))
			prio = atoi(v);
		else if (!strcmp(argv[a], "--out"))
			out = v;
		else {
			fprintf(stderr, PROG ": unknown argument %s\n", argv[a]);
			return 2;
		}
		a++;
	}
	if (!url || !out || seconds <= 0) {
		fprintf(stderr, PROG " run: --url and --out are needed, --seconds > 0\n");
		return 2;
	}
	c.recs = calloc(MAX_RECS, sizeof(*c.recs));
	if (!c.recs)
		return 1;
	/* touch the log before the first state: no page fault in the handler */
	memset(c.recs, 0, MAX_RECS * sizeof(*c.recs));
	if (mlockall(MCL_CURRENT | MCL_FUTURE) < 0)
		fprintf(stderr, PROG ": mlockall: %s (going on)\n", strerror(errno));
	r = set_fifo(prio);
	if (r < 0) {
		fprintf(stderr, PROG ": SCHED_FIFO %d: %s\n", prio, strerror(-r));
		return 1;
	}
	c.id = (int64_t)rmd_now_ns() ^ ((int64_t)getpid() << 32);
	c.warmup_ns = (int64_t)(warmup_ms * 1e6);
	c.rt_offset_ns = rmd_realtime_offset_ns(&end);
	for (int i = 0; i < MAX_MOTORS; i++)
		c.last_lc[i] = -1;
	snprintf(c.ch_command, sizeof(c.ch_command), "%s" RMD_CHANNEL_COMMAND, prefix);
	snprintf(c.ch_state, sizeof(c.ch_state), "%s" RMD_CHANNEL_STATE, prefix);
	snprintf(c.ch_config, sizeof(c.ch_config), "%s" RMD_CHANNEL_CONFIG, prefix);
	snprintf(c.ch_config_req, sizeof(c.ch_config_req), "%s" RMD_CHANNEL_CONFIG_REQUEST, prefix);
	signal(SIGINT, on_signal);
	signal(SIGTERM, on_signal);
	c.lcm = lcm_create(url);
	if (!c.lcm) {
		fprintf(stderr, PROG ": lcm_create(%s) failed\n", url);
		return 1;
	}
	rmd_config_t_subscribe(c.lcm, c.ch_config, on_config, &c);
	rmd_state_t_subscribe(c.lcm, c.ch_state, on_state, &c);

	/* rmdd's configuration: the motors' buses and IDs */
	end = rmd_now_ns() + 5 * NS_PER_S;
	while (!c.have_config && !stop_signal && rmd_now_ns() < end) {
		rmd_config_request_t req = { .utime = rmd_now_ns() / 1000 };

		rmd_config_request_t_publish(c.lcm, c.ch_config_req, &req);
		if (handle_until(&c, rmd_now_ns() + 200 * NS_PER_MS) < 0)
			break;
	}
	if (!c.have_config) {
		fprintf(stderr, PROG ": no config_t on %s (%s)\n", c.ch_config, url);
		return 1;
	}
	/* enable = 0 until READY (the enable edge), then answer every state */
	end = rmd_now_ns() + 10 * NS_PER_S;
	while (!all_lc(&c, RMD_STATE_T_LC_READY) && !stop_signal && rmd_now_ns() < end) {
		if (publish(&c, false, 0) < 0 ||
		    handle_until(&c, rmd_now_ns() + 20 * NS_PER_MS) < 0)
			break;
	}
	if (!all_lc(&c, RMD_STATE_T_LC_READY)) {
		fprintf(stderr,
			PROG ": the motors did not become READY (lifecycle of motor 0: %d)\n",
			c.last_lc[0]);
		return 1;
	}
	c.enable = true;
	end = rmd_now_ns() + 5 * NS_PER_S;
	while (!c.enabled_ns && !stop_signal && rmd_now_ns() < end)
		if (handle_until(&c, rmd_now_ns() + 10 * NS_PER_MS) < 0)
			break;
	if (!c.enabled_ns) {
		fprintf(stderr, PROG ": the motors were not ENABLED within 5 s\n");
		return 1;
	}
	c.record_until = c.record_from + (int64_t)(seconds * 1e9);
	r = handle_until(&c, c.record_until);
	c.enable = false;
	for (int k = 0; k < 3; k++) {
		publish(&c, false, 0);
		handle_until(&c, rmd_now_ns() + 5 * NS_PER_MS);
	}
	lcm_destroy(c.lcm);
	if (r < 0 || stop_signal == SIGPIPE) {
		fprintf(stderr, PROG ": LCM failed\n");
		return 1;
	}
	r = write_log(&c, out);
	if (r < 0) {
		fprintf(stderr, PROG ": %s: %s\n", out, strerror(-r));
		return 1;
	}
	fprintf(stderr, PROG ": %lu states, %zu records (%zu lost)\n", c.states, c.n_recs,
		c.lost_recs);
	return 0;
}

/* ---- match ---------------------------------------------------------------- */

struct wframe {
	int64_t t_us; /* the candump stamp */
	struct rmd_frame f;
	bool tx; /* T: the host sent it */
};

struct wbus {
	char name[NAME_LEN];
	uint32_t bitrate;
	struct wframe *fr;
	size_t n, cap;
};

static struct wbus wbuses[MAX_BUSES];
static int n_wbuses;

static struct wbus *wbus_of(const char *name)
{
	for (int b = 0; b < n_wbuses; b++)
		if (!strcmp(wbuses[b].name, name))
			return &wbuses[b];
	if (n_wbuses == MAX_BUSES)
		return NULL;
	snprintf(wbuses[n_wbuses].name, NAME_LEN, "%s", name);
	return &wbuses[n_wbuses++];
}

static int hexval(int ch)
{
	return ch >= '0' && ch <= '9' ? ch - '0' :
	       ch >= 'A' && ch <= 'F' ? ch - 'A' + 10 :
	       ch >= 'a' && ch <= 'f' ? ch - 'a' + 10 :
					-1;
}

/* "(sec.usec) bus ID#DATA [T|R]" into its bus's list.  Returns 0, or -EINVAL for a line skipped. */
static int parse_candump(const char *line)
{
	char bus[NAME_LEN], frame[64], dir[4] = "";
	unsigned long long sec, usec;
	struct wframe w = { 0 };
	struct wbus *b;
	char *hash;
	unsigned id;
	size_t dl;

	if (sscanf(line, " (%llu.%llu) %31s %63s %3s", &sec, &usec, bus, frame, dir) < 4)
		return -EINVAL;
	hash = strchr(frame, '#');
	if (!hash || sscanf(frame, "%x#", &id) != 1)
		return -EINVAL;
	dl = strlen(hash + 1);
	if (dl % 2 || dl > 2 * RMD_FRAME_LEN)
		return -EINVAL;
	w.t_us = (int64_t)(sec * 1000000 + usec);
	w.f.can_id = id;
	w.f.len = (uint8_t)(dl / 2);
	for (size_t i = 0; i < w.f.len; i++) {
		int hi = hexval(hash[1 + 2 * i]), lo = hexval(hash[2 + 2 * i]);

		if (hi < 0 || lo < 0)
			return -EINVAL;
		w.f.data[i] = (uint8_t)(hi << 4 | lo);
	}
	/* candump -L without -x: the motors answer on 0x240 + ID (V3 §1), the host sends the rest */
	w.tx = dir[0] ? dir[0] == 'T' : !(id >= 0x240 && id < 0x280);
	b = wbus_of(bus);
	if (!b)
		return -EINVAL;
	if (b->n == b->cap) {
		size_t cap = b->cap ? 2 * b->cap : 65536;
		struct wframe *p = realloc(b->fr, cap * sizeof(*p));

		if (!p)
			return -ENOMEM;
		b->fr = p;
		b->cap = cap;
	}
	b->fr[b->n++] = w;
	return 0;
}

/* The frame's start: its stamp less its wire time to the end of frame (ns). */
static int64_t start_ns(const struct wbus *b, const struct wframe *w, bool wire_time)
{
	int64_t t = w->t_us * 1000;

	if (!wire_time || !b->bitrate)
		return t;
	return t - rmd_can_wire_ns(rmd_can_frame_bits(&w->f) - RMD_CAN_IFS_BITS, b->bitrate);
}

/* First index of b's frames stamped at or after t_us (they are in stamp order). */
static size_t lower_bound(const struct wbus *b, int64_t t_us)
{
	size_t lo = 0, hi = b->n;

	while (lo < hi) {
		size_t mid = (lo + hi) / 2;

		if (b->fr[mid].t_us < t_us)
			lo = mid + 1;
		else
			hi = mid;
	}
	return lo;
}

static int32_t le32(const uint8_t *p)
{
	return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
			 (uint32_t)p[3] << 24);
}

static int match(int argc, char **argv)
{
	struct wbus *mbus[MAX_MOTORS] = { 0 };
	int mid[MAX_MOTORS] = { 0 };
	int64_t last_rx[MAX_MOTORS] = { 0 };
	int64_t offset_us = 0, tol_us = 1;
	bool wire_time = true, kernel = false;
	unsigned long counted = 0, superseded = 0, no_reply = 0, not_enabled = 0;
	char line[256];
	FILE *log;

	if (argc < 4) {
		fprintf(stderr, "usage: " PROG " match LOG CANDUMP... [--kernel-stamps]\n");
		return 2;
	}
	for (int a = 3; a < argc; a++) {
		FILE *f;

		if (!strcmp(argv[a], "--kernel-stamps")) {
			kernel = true;
			wire_time = false;
			tol_us = TOL_KERNEL_US;
			continue;
		}
		f = fopen(argv[a], "r");
		if (!f) {
			fprintf(stderr, PROG ": %s: %s\n", argv[a], strerror(errno));
			return 1;
		}
		while (fgets(line, sizeof(line), f))
			if (parse_candump(line) == -ENOMEM)
				return 1;
		fclose(f);
	}
	log = fopen(argv[2], "r");
	if (!log) {
		fprintf(stderr, PROG ": %s: %s\n", argv[2], strerror(errno));
		return 1;
	}
	while (fgets(line, sizeof(line), log)) {
		char name[NAME_LEN];
		long long cycle, read_ns, pub_ns, rx_ns;
		int tag, idx, lc, id;
		unsigned long br;
		long long off;
		const struct wframe *rep = NULL, *cmd = NULL;
		struct wbus *b;
		size_t k;

		if (sscanf(line, "o %lld", &off) == 1) {
			if (kernel)
				offset_us = off / 1000;
			continue;
		}
		if (sscanf(line, "b %31s %lu", name, &br) == 2) {
			b = wbus_of(name);
			if (b)
				b->bitrate = (uint32_t)br;
			continue;
		}
		if (sscanf(line, "m %d %31s %d", &idx, name, &id) == 3) {
			if (idx >= 0 && idx < MAX_MOTORS) {
				mbus[idx] = wbus_of(name);
				mid[idx] = id;
			}
			continue;
		}
		if (sscanf(line, "s %lld %d %lld %lld %d %d %lld", &cycle, &tag, &read_ns, &pub_ns,
			   &idx, &lc, &rx_ns) != 7 ||
		    idx < 0 || idx >= MAX_MOTORS || !mbus[idx])
			continue;
		/* a reply counts once: in the first state that carries it */
		if (!rx_ns || rx_ns == last_rx[idx])
			continue;
		last_rx[idx] = rx_ns;
		if (lc != RMD_STATE_T_LC_ENABLED) {
			not_enabled++;
			continue;
		}
		b = mbus[idx];
		for (k = lower_bound(b, rx_ns / 1000 + offset_us - tol_us); k < b->n; k++) {
			const struct wframe *w = &b->fr[k];
			int64_t at = rx_ns / 1000 + offset_us;

			if (w->t_us > at + tol_us)
				break;
			if (!w->tx && w->f.can_id == 0x240u + (unsigned)mid[idx] &&
			    w->f.data[0] == 0xA2 &&
			    (!rep || llabs(w->t_us - at) < llabs(rep->t_us - at)))
				rep = w;
		}
		if (!rep) {
			no_reply++;
			continue;
		}
		for (k = (size_t)(rep - b->fr) + 1; k < b->n; k++) {
			const struct wframe *w = &b->fr[k];

			if (w->t_us > rep->t_us + SEARCH_US)
				break;
			if (w->tx && w->f.can_id == 0x140u + (unsigned)mid[idx] && w->f.len == 8 &&
			    w->f.data[0] == 0xA2 && le32(&w->f.data[4]) == tag) {
				cmd = w;
				break;
			}
		}
		if (!cmd) {
			superseded++;
			continue;
		}
		printf("%d %.1f\n", idx,
		       (double)(start_ns(b, cmd, wire_time) - start_ns(b, rep, wire_time)) / 1e3);
		counted++;
	}
	fclose(log);
	fprintf(stderr,
		PROG ": replies counted %lu, superseded (no response frame) %lu, not found in the "
		     "candump %lu, motor not enabled %lu\n",
		counted, superseded, no_reply, not_enabled);
	return counted ? 0 : 1;
}

int main(int argc, char **argv)
{
	if (argc >= 2 && !strcmp(argv[1], "run"))
		return run(argc, argv);
	if (argc >= 2 && !strcmp(argv[1], "match"))
		return match(argc, argv);
	fprintf(stderr, "usage: " PROG " run --url URL --out LOG [--prefix P] [--seconds S]\n"
			"                        [--rt-priority N] [--warmup-ms MS]\n"
			"       " PROG " match LOG CANDUMP... [--kernel-stamps]\n");
	return 2;
}
