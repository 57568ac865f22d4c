// SPDX-License-Identifier: MIT
/*
 * leg_stand: stands the leg of examples/physics/leg.xml through rmdd, and
 * hops it.  A controller as one for the real leg would be: it knows the
 * motors by name ("hip", "knee": --hip, --knee), speaks only rmdd's LCM
 * interface (docs/lcm.md), and runs unchanged against the physics sim
 * (rmdd --config examples/physics/leg.yaml) and against rmd-sim on a CAN
 * interface (leg-vcan.yaml):
 *
 *   make build/leg_stand
 *   rmdd --config examples/physics/leg.yaml &
 *   build/leg_stand                    # stand at 0.35 m, until Ctrl-C
 *   build/leg_stand --hops 3           # stand, hop three times, stand
 *
 * What it does:
 *   1. config_t (asked on PREFIX CONFIG_REQUEST, 2 s at most): the two
 *      motors by name, and that they take MIT mode and --kp/--kd;
 *   2. enable = 0 until both are READY, then enable = 1 in MIT mode (a PD
 *      in each motor: kp (p_des - p) + kd (v_des - v)) from where the leg
 *      lies, the setpoint moving to the standing pose (leg.h: the foot
 *      under the hip at --height) over --rise seconds;
 *   3. standing, it prints once a second the hip's height from the joint
 *      angles (leg.h; the foot is on the floor) and the angles;
 *   4. each hop: crouch 0.30 s, push to a nearly straight leg with twice
 *      the stiffness for 0.12 s, fold the leg back to the pose in the air,
 *      land and stand 1 s;
 *   5. Ctrl-C, SIGTERM or --duration: enable = 0 (three times), exit 0.
 *      Killed, it leaves the motors to rmdd's watchdog (leg.yaml: stop,
 *      the leg falls).  Exit 1: rmdd not there, gone, a motor missing or
 *      not enabled; 2: bad options.
 *
 * Commands go out at --rate Hz with both motors in each (rmdd keeps only
 * the newest).  Single-threaded: poll(2) on LCM's descriptor, at
 * SCHED_FIFO --rt-priority (default 20, below rmdd's loop) where it may:
 * a leg falls when its controller is late for command_timeout_ms, and a
 * busy machine holds a normal process off for that long.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <sched.h>
#include <sys/random.h>
#include <unistd.h>

#include <lcm/lcm.h>

#include "leg.h"
#include "rmd/channels.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_state_t.h"

#define PROG "leg_stand"
#define DEFAULT_URL "udpm://239.255.76.67:7667?ttl=0"

#define NS_PER_S INT64_C(1000000000)
#define NS_PER_MS INT64_C(1000000)
#define WAIT_NS (2 * NS_PER_S) /* config_t, state_t, READY: within this, or rmdd is not there */
#define QUIET_NS NS_PER_S      /* no state_t for this long: rmdd went away */
#define CROUCH_S 0.30	       /* a hop: down to CROUCH_M ... */
#define PUSH_S 0.12	       /* ... push to PUSH_M ... */
#define FOLD_S 0.25	       /* ... fold back to the pose in the air ... */
#define LAND_S 1.0	       /* ... and stand again before the next */
#define CROUCH_M 0.27
#define PUSH_M 0.41

enum { HIP, KNEE, N_JOINTS };

struct opts {
	const char *url, *prefix, *name[N_JOINTS];
	double kp, kd, height_m, rise_s, rate_hz, duration_s, rt_priority;
	unsigned hops;
};

struct ctl {
	struct opts o;
	lcm_t *lcm;
	char ch_command[96], ch_config[96], ch_config_req[96], ch_state[96];
	bool have_config, have_state;
	int index[N_JOINTS]; /* config_t's index of each joint's motor; -1: none */
	double kp_max[N_JOINTS], kd_max[N_JOINTS];
	int modes[N_JOINTS];
	int lc[N_JOINTS];
	double pos[N_JOINTS];
	unsigned long n_states;
	int64_t seq, id;
	rmd_motor_command_t mc[N_JOINTS];
	uint8_t buf[1024];
};

static volatile sig_atomic_t stop_signal;

static void on_signal(int sig)
{
	stop_signal = sig;
}

static int64_t now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * NS_PER_S + ts.tv_nsec;
}

static void usage(FILE *out)
{
	fprintf(out,
		"usage: " PROG
		" [--height M] [--hops N] [--kp KP] [--kd KD] [--rise S] [--rate HZ]\n"
		"                 [--duration S] [--hip NAME] [--knee NAME] [--url URL] [--prefix P]\n"
		"\n"
		"Stands the leg of examples/physics/leg.xml through rmdd (MIT mode: a PD in each\n"
		"motor), hops it --hops times, and prints its height once a second.\n"
		"\n"
		"  --height M     the hip's height to stand at (default 0.35, 0.10..0.41)\n"
		"  --hops N       hops after standing (default 0)\n"
		"  --kp KP        stiffness, N*m/rad (default 100)\n"
		"  --kd KD        damping, N*m*s/rad (default 2)\n"
		"  --rise S       seconds from where the leg lies to standing (default 1.5)\n"
		"  --rate HZ      commands per second (default 500)\n"
		"  --duration S   stop after S seconds (default 0: until Ctrl-C)\n"
		"  --rt-priority N  SCHED_FIFO priority where allowed (default 20; 0: none)\n"
		"  --hip, --knee  the motors' names in rmdd's configuration (hip, knee)\n"
		"  --url URL      LCM URL (default $LCM_DEFAULT_URL, else %s)\n"
		"  --prefix P     rmdd's channel prefix (default RMD_)\n"
		"\n"
		"Exit status: 0 stopped, 1 rmdd not running, gone or refusing, 2 bad options.\n",
		DEFAULT_URL);
}

static int parse_args(int argc, char **argv, struct opts *o)
{
	static const struct option longopts[] = {
		{ "height", required_argument, NULL, 'H' },
		{ "hops", required_argument, NULL, 'n' },
		{ "kp", required_argument, NULL, 'p' },
		{ "kd", required_argument, NULL, 'd' },
		{ "rise", required_argument, NULL, 'r' },
		{ "rate", required_argument, NULL, 'R' },
		{ "duration", required_argument, NULL, 't' },
		{ "hip", required_argument, NULL, 'h' },
		{ "knee", required_argument, NULL, 'k' },
		{ "url", required_argument, NULL, 'u' },
		{ "prefix", required_argument, NULL, 'P' },
		{ "help", no_argument, NULL, '?' + 256 },
		{ "rt-priority", required_argument, NULL, 'F' },
		{ NULL, 0, NULL, 0 },
	};
	const char *env = getenv("LCM_DEFAULT_URL");
	double hops = 0;
	int c;

	*o = (struct opts){ .url = env && *env ? env : DEFAULT_URL,
			    .prefix = "RMD_",
			    .name = { "hip", "knee" },
			    .kp = 100,
			    .kd = 2,
			    .height_m = LEG_STAND_M,
			    .rise_s = 1.5,
			    .rate_hz = 500,
			    .rt_priority = 20 };
	while ((c = getopt_long(argc, argv, "", longopts, NULL)) != -1) {
		struct {
			int c;
			double *dst, min, max;
		} nums[] = { { 'H', &o->height_m, 0.10, 0.41 }, { 'n', &hops, 0, 1000 },
			     { 'p', &o->kp, 0, 500 },		{ 'd', &o->kd, 0, 5 },
			     { 'r', &o->rise_s, 0.01, 60 },	{ 'R', &o->rate_hz, 10, 5000 },
			     { 't', &o->duration_s, 0, 1e9 },	{ 'F', &o->rt_priority, 0, 99 } };
		bool done = false;

		if (c == '?' + 256) {
			usage(stdout);
			return 1;
		}
		if (c == 'h' || c == 'k') {
			o->name[c == 'h' ? HIP : KNEE] = optarg;
			continue;
		}
		if (c == 'u' || c == 'P') {
			*(c == 'u' ? &o->url : &o->prefix) = optarg;
			continue;
		}
		for (size_t i = 0; i < sizeof(nums) / sizeof(nums[0]) && c != '?'; i++) {
			char *end;
			double v;

			if (nums[i].c != c)
				continue;
			errno = 0;
			v = strtod(optarg, &end);
			if (errno || end == optarg || *end || !isfinite(v) || v < nums[i].min ||
			    v > nums[i].max) {
				fprintf(stderr, PROG ": %s: a number in %g..%g\n", optarg,
					nums[i].min, nums[i].max);
				return -EINVAL;
			}
			*nums[i].dst = v;
			done = true;
		}
		if (!done) {
			usage(stderr);
			return -EINVAL;
		}
	}
	if (optind < argc) {
		fprintf(stderr, PROG ": unexpected argument \"%s\"\n", argv[optind]);
		return -EINVAL;
	}
	if (strlen(o->prefix) > 64) {
		fprintf(stderr, PROG ": --prefix: at most 64 characters\n");
		return -EINVAL;
	}
	o->hops = (unsigned)hops;
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
	for (int j = 0; j < N_JOINTS; j++) {
		c->index[j] = -1;
		for (int i = 0; i < msg->motor_count; i++) {
			const rmd_motor_config_t *mc = &msg->motor[i];

			if (strcmp(mc->name, c->o.name[j]))
				continue;
			c->index[j] = mc->index;
			c->modes[j] = mc->modes;
			c->kp_max[j] = mc->kp_max;
			c->kd_max[j] = mc->kd_max;
		}
	}
	c->have_config = true;
}

static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *msg,
		     void *user)
{
	struct ctl *c = user;

	(void)rbuf;
	(void)channel;
	for (int j = 0; j < N_JOINTS; j++) {
		int i = c->index[j];

		if (i < 0 || i >= msg->count)
			continue;
		c->lc[j] = msg->motor[i].lifecycle;
		c->pos[j] = msg->motor[i].position;
	}
	c->have_state = true;
	c->n_states++;
}

/* Messages until `deadline` or a signal; -EIO when LCM fails. */
static int handle_until(struct ctl *c, int64_t deadline)
{
	struct pollfd pfd = { .fd = lcm_get_fileno(c->lcm), .events = POLLIN };
	int64_t left;

	while (!stop_signal && (left = deadline - now_ns()) > 0) {
		struct timespec ts = { left / NS_PER_S, left % NS_PER_S };
		int r = ppoll(&pfd, 1, &ts, NULL);

		if (r < 0 && errno != EINTR)
			return -EIO;
		if (r > 0 && lcm_handle(c->lcm) < 0)
			return -EIO;
	}
	return 0;
}

/* Wait until done(c) or WAIT_NS; `ask` is published every 250 ms meanwhile. */
static bool wait_for(struct ctl *c, bool (*done)(const struct ctl *), void (*ask)(struct ctl *))
{
	int64_t end = now_ns() + WAIT_NS;

	while (!done(c) && !stop_signal && now_ns() < end) {
		if (ask)
			ask(c);
		if (handle_until(c, now_ns() + (ask ? 250 : 10) * NS_PER_MS) < 0)
			return false;
	}
	return done(c);
}

static bool have_config(const struct ctl *c)
{
	return c->have_config;
}

static bool have_state(const struct ctl *c)
{
	return c->have_state;
}

static bool both(const struct ctl *c, int lc)
{
	return c->lc[HIP] == lc && c->lc[KNEE] == lc;
}

static bool both_ready(const struct ctl *c)
{
	return both(c, RMD_STATE_T_LC_READY);
}

static void ask_config(struct ctl *c)
{
	rmd_config_request_t req = { .utime = now_ns() / 1000 };

	rmd_config_request_t_publish(c->lcm, c->ch_config_req, &req);
}

/*
 * One command_t with both motors: enable, and in MIT mode the setpoint
 * (p[], v[]) with gains kp, kd.  Encoded into our buffer (the generated
 * _publish() allocates).  Returns 0 or -EIO.
 */
static int publish(struct ctl *c, bool enable, const double *p, const double *v, double kp)
{
	rmd_command_t msg = { .utime = now_ns() / 1000,
			      .seq = c->seq++,
			      .controller = c->id,
			      .count = N_JOINTS,
			      .motor = c->mc };
	int len;

	for (int j = 0; j < N_JOINTS; j++)
		c->mc[j] = (rmd_motor_command_t){ .index = (int16_t)c->index[j],
						  .enable = enable,
						  .mode = RMD_COMMAND_T_MODE_MIT,
						  .position = p ? p[j] : c->pos[j],
						  .velocity = v ? v[j] : 0.0,
						  .kp = enable ? kp : 0.0,
						  .kd = enable ? c->o.kd : 0.0 };
	len = rmd_command_t_encode(c->buf, 0, (int)sizeof(c->buf), &msg);
	if (len < 0 || lcm_publish(c->lcm, c->ch_command, c->buf, (unsigned)len) < 0)
		return -EIO;
	return 0;
}

/* Smooth 0..1 over 0..1 (zero slope at both ends), and its slope. */
static double blend(double s, double *slope)
{
	s = s < 0 ? 0 : s > 1 ? 1 : s;
	*slope = M_PI / 2 * sin(M_PI * s);
	return 0.5 - 0.5 * cos(M_PI * s);
}

/*
 * A segment of the motion: from `from` to the pose of height_m over
 * seconds, at stiffness kp; then standing there.  Returns 0, 1 (stopped:
 * a signal or --duration) or -1 after a message (rmdd gone, a motor not
 * enabled).
 */
struct run {
	struct ctl *c;
	int64_t t0, next_pub, next_print, last_look, end;
	unsigned long last_states;
};

static int move(struct run *r, const double *from, double height_m, double seconds, double kp)
{
	struct ctl *c = r->c;
	int64_t start = now_ns(), period = (int64_t)(1e9 / c->o.rate_hz);
	double to[N_JOINTS];

	leg_pose(height_m, &to[HIP], &to[KNEE]);
	for (;;) {
		int64_t now = now_ns();
		double s = (double)(now - start) / 1e9 / seconds, slope, b, p[N_JOINTS],
		       v[N_JOINTS];

		if (stop_signal || (r->end && now >= r->end))
			return 1;
		if (s >= 1.0)
			return 0;
		if (now >= r->next_pub) {
			b = blend(s, &slope);
			for (int j = 0; j < N_JOINTS; j++) {
				p[j] = from[j] + (to[j] - from[j]) * b;
				v[j] = (to[j] - from[j]) * slope / seconds;
			}
			if (publish(c, true, p, v, kp) < 0) {
				fprintf(stderr, PROG ": LCM publish failed\n");
				return -1;
			}
			r->next_pub += period;
			if (r->next_pub <= now) /* late: skip, never catch up in a burst */
				r->next_pub = now + period;
		}
		if (now >= r->next_print) {
			printf("[%6.1f s] height %.3f m  hip %+.3f rad  knee %+.3f rad\n",
			       (double)(now - r->t0) / 1e9, leg_height_m(c->pos[HIP], c->pos[KNEE]),
			       c->pos[HIP], c->pos[KNEE]);
			r->next_print += NS_PER_S;
		}
		if (now - r->last_look >= QUIET_NS) {
			if (c->n_states == r->last_states) {
				fprintf(stderr, PROG ": no state_t from rmdd for 1 s: stopping\n");
				return -1;
			}
			r->last_states = c->n_states;
			r->last_look = now;
		}
		if (c->seq > 50 && !both(c, RMD_STATE_T_LC_ENABLED)) {
			fprintf(stderr,
				PROG ": the motors are no longer enabled (hip %d, knee %d)\n",
				c->lc[HIP], c->lc[KNEE]);
			return -1;
		}
		if (handle_until(c, r->next_pub < r->next_print ? r->next_pub : r->next_print) < 0)
			return -1;
	}
}

/* Stand, hop, stand until stopped.  Returns an exit status. */
static int motion(struct ctl *c)
{
	struct run r = { .c = c };
	double pose[N_JOINTS], here[N_JOINTS] = { c->pos[HIP], c->pos[KNEE] };
	int ret;

	r.t0 = r.next_pub = r.next_print = r.last_look = now_ns();
	r.end = c->o.duration_s > 0 ? r.t0 + (int64_t)(c->o.duration_s * 1e9) : 0;
	r.last_states = c->n_states;
	leg_pose(c->o.height_m, &pose[HIP], &pose[KNEE]);
	printf(PROG ": standing up to %.3f m (hip %.3f, knee %.3f rad) in %.1f s, kp %g, kd %g\n",
	       c->o.height_m, pose[HIP], pose[KNEE], c->o.rise_s, c->o.kp, c->o.kd);
	ret = move(&r, here, c->o.height_m, c->o.rise_s, c->o.kp);
	if (!ret)
		ret = move(&r, pose, c->o.height_m, LAND_S, c->o.kp);
	for (unsigned h = 0; !ret && h < c->o.hops; h++) {
		double crouch[N_JOINTS], push[N_JOINTS];

		printf(PROG ": hop %u\n", h + 1);
		leg_pose(CROUCH_M, &crouch[HIP], &crouch[KNEE]);
		leg_pose(PUSH_M, &push[HIP], &push[KNEE]);
		ret = move(&r, pose, CROUCH_M, CROUCH_S, c->o.kp);
		if (!ret)
			ret = move(&r, crouch, PUSH_M, PUSH_S, 2 * c->o.kp);
		if (!ret)
			ret = move(&r, push, c->o.height_m, FOLD_S, c->o.kp);
		if (!ret)
			ret = move(&r, pose, c->o.height_m, LAND_S, c->o.kp);
	}
	if (!ret)
		printf(PROG ": standing\n");
	while (!ret)
		ret = move(&r, pose, c->o.height_m, LAND_S, c->o.kp);
	return ret < 0 ? 1 : 0;
}

static int check_motors(const struct ctl *c)
{
	for (int j = 0; j < N_JOINTS; j++) {
		if (c->index[j] < 0) {
			fprintf(stderr, PROG ": rmdd has no motor \"%s\" (--%s NAME)\n",
				c->o.name[j], j == HIP ? "hip" : "knee");
			return 1;
		}
		if (!(c->modes[j] & RMD_MOTOR_CONFIG_T_MODE_BIT_MIT)) {
			fprintf(stderr,
				PROG ": %s does not take MIT mode (mode: mit in rmdd.yaml)\n",
				c->o.name[j]);
			return 1;
		}
		if (c->o.kp * 2 > c->kp_max[j] || c->o.kd > c->kd_max[j]) {
			fprintf(stderr,
				PROG ": %s: --kp %g (twice that in a push) --kd %g outside "
				     "kp ..%g, kd ..%g\n",
				c->o.name[j], c->o.kp, c->o.kd, c->kp_max[j], c->kd_max[j]);
			return 2;
		}
	}
	return 0;
}

static int run(struct ctl *c)
{
	const struct timespec gap = { 0, 5 * NS_PER_MS };
	rmd_config_t_subscription_t *sub_config = NULL;
	rmd_state_t_subscription_t *sub_state = NULL;
	int ret = 1;

	if (getrandom(&c->id, sizeof(c->id), 0) != (ssize_t)sizeof(c->id))
		c->id = now_ns() ^ ((int64_t)getpid() << 32);
	c->lc[HIP] = c->lc[KNEE] = -1;
	c->index[HIP] = c->index[KNEE] = -1;
	c->lcm = lcm_create(c->o.url);
	if (!c->lcm) {
		fprintf(stderr, PROG ": LCM %s: cannot create (see docs/lcm.md)\n", c->o.url);
		return 1;
	}
	snprintf(c->ch_command, sizeof(c->ch_command), "%s" RMD_CHANNEL_COMMAND, c->o.prefix);
	snprintf(c->ch_config, sizeof(c->ch_config), "%s" RMD_CHANNEL_CONFIG, c->o.prefix);
	snprintf(c->ch_config_req, sizeof(c->ch_config_req), "%s" RMD_CHANNEL_CONFIG_REQUEST,
		 c->o.prefix);
	snprintf(c->ch_state, sizeof(c->ch_state), "%s" RMD_CHANNEL_STATE, c->o.prefix);
	sub_config = rmd_config_t_subscribe(c->lcm, c->ch_config, on_config, c);
	sub_state = rmd_state_t_subscribe(c->lcm, c->ch_state, on_state, c);
	if (!sub_config || !sub_state) {
		fprintf(stderr, PROG ": LCM %s: cannot subscribe\n", c->o.url);
		goto out;
	}
	if (!wait_for(c, have_config, ask_config)) {
		if (!stop_signal)
			fprintf(stderr,
				PROG ": no config_t on %s within 2 s: is rmdd running, with "
				     "--lcm-url %s and channel prefix %s?\n",
				c->ch_config, c->o.url, c->o.prefix);
		ret = stop_signal ? 0 : 1;
		goto out;
	}
	ret = check_motors(c);
	if (ret)
		goto out;
	ret = 1;
	if (!wait_for(c, have_state, NULL))
		goto out;
	/* a motor back from a fault, a loss or a safe action wants enable = 0 first */
	if (publish(c, false, NULL, NULL, 0) < 0 || !wait_for(c, both_ready, NULL)) {
		if (!stop_signal)
			fprintf(stderr, PROG ": the motors are not READY (hip %d, knee %d)\n",
				c->lc[HIP], c->lc[KNEE]);
		ret = stop_signal ? 0 : 1;
		goto out;
	}
	ret = motion(c);
	for (int k = 0; k < 3; k++) {
		publish(c, false, NULL, NULL, 0);
		nanosleep(&gap, NULL);
	}
	printf(PROG ": stopped: enable = 0 sent\n");
out:
	if (sub_state)
		rmd_state_t_unsubscribe(c->lcm, sub_state);
	if (sub_config)
		rmd_config_t_unsubscribe(c->lcm, sub_config);
	lcm_destroy(c->lcm);
	return ret;
}

int main(int argc, char **argv)
{
	static struct ctl c;
	struct sigaction sa = { .sa_handler = on_signal };
	int r = parse_args(argc, argv, &c.o);

	if (r)
		return r < 0 ? 2 : 0;
	setvbuf(stdout, NULL, _IOLBF, 0);
	if (c.o.rt_priority > 0) {
		struct sched_param sp = { .sched_priority = (int)c.o.rt_priority };

		if (sched_setscheduler(0, SCHED_FIFO, &sp) < 0)
			printf(PROG ": SCHED_FIFO %d: %s: running as a normal process\n",
			       sp.sched_priority, strerror(errno));
	}
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	return run(&c);
}
