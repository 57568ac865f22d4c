// SPDX-License-Identifier: MIT
/*
 * sine_controller: an rmdd controller in C.  Every motor that can follows a
 * sine, in position mode or in MIT mode, and the tracking error is printed
 * once a second.  It uses nothing of rmdd but its LCM types (lcm_types/,
 * generated into build/gen), their channel names (rmd/channels.h; both
 * installed for controllers: pkg-config rmd-lcm) and liblcm:
 *
 *   make build/sine_controller
 *   rmdd --config examples/sim-sine.yaml &
 *   build/sine_controller --mode position
 *   build/sine_controller --mode mit --kp 20 --kd 1
 *
 * What it does, in order:
 *   1. asks for rmdd's configuration (anything on PREFIX "CONFIG_REQUEST";
 *      config_t comes back on PREFIX "CONFIG") and gives up after 2 s with a
 *      message: rmdd is not running, or not on this URL and prefix;
 *   2. picks every motor whose modes (config_t motor.modes) allow the mode,
 *      and checks --kp and --kd against each MIT motor's gain ranges;
 *   3. centres each sine on the motor's position (state_t), inside its
 *      position limits;
 *   4. sends enable = 0 and waits for READY (a motor back from a fault or
 *      a loss takes enable = 1 only after an enable = 0: docs/lcm.md; rmdd
 *      keeps that enable = 0 until its loop has acted on it, so enable = 1
 *      may follow at once);
 *   5. publishes command_t at --rate Hz, every driven motor in each
 *      message (rmdd keeps only the newest), with a random controller id
 *      chosen at start (command_t.controller: until it disables its
 *      motors, silent or not, rmdd takes commands from no other controller;
 *      --takeover takes them from one that died owning them), and from
 *      every state_t adds up target - position per motor: RMS and largest
 *      magnitude, printed once a second;
 *   6. on Ctrl-C, SIGTERM or the end of --duration: enable = 0 to every
 *      driven motor, the whole run's error, exit 0.  Exit 1 when rmdd is
 *      not there or goes away, 2 for a bad command line.
 *
 * Several rmdd instances as one robot (docs/robot.md): --prefix LEFT_,RIGHT_
 * does all of this for each prefix (struct inst: its channels, its daemon,
 * its config_t and state_t) on one LCM handle, and drives every motor of
 * them all: one command_t per instance per tick, motor names unique across
 * the instances (a clash is refused at start), each motor named with its
 * instance in what is printed ("LEFT_/hip", or config_t.instance_name
 * "left_leg/hip"), every instance told enable = 0 at the end, and exit 1
 * when any of them goes away.
 *
 * Single-threaded: poll(2) on LCM's descriptor until the next publish.
 * Non-rt (an example: a real controller would run its loop at SCHED_FIFO).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <sys/random.h>
#include <unistd.h>

#include <lcm/lcm.h>

#include "rmd/channels.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"

#define PROG "sine_controller"
#define DEFAULT_URL "udpm://239.255.76.67:7667?ttl=0"
#define DEFAULT_PREFIX "RMD_"

#define NS_PER_S INT64_C(1000000000)
#define NS_PER_MS INT64_C(1000000)
#define CONFIG_WAIT_NS (2 * NS_PER_S)	    /* no config_t within this: rmdd is not there */
#define CONFIG_ASK_NS (250 * NS_PER_MS)	    /* ask again this often while waiting */
#define STATE_WAIT_NS NS_PER_S		    /* no state_t for this long: rmdd went away */
#define READY_WAIT_NS (500 * NS_PER_MS)	    /* enable = 0, then READY within this */
#define PRINT_PERIOD_NS NS_PER_S	    /* the tracking error, once a second */
#define STOP_REPEAT 3			    /* enable = 0 goes out this often ... */
#define STOP_GAP_NS (5 * NS_PER_MS)	    /* ... this far apart (UDP may drop one) */
#define MAX_MOTORS RMD_COMMAND_T_MAX_MOTORS /* 32 */
#define NAME_LEN 64
#define PREFIX_LEN 64	/* rmdd's lcm.channel_prefix is at most this long */
#define MAX_INSTANCES 8 /* prefixes in --prefix P1,P2,... */

enum exit_status {
	EXIT_OK = 0,
	EXIT_FAIL = 1,	/* rmdd not there, gone, or refusing */
	EXIT_USAGE = 2, /* bad command line, or options the motors cannot take */
};

struct opts {
	bool mit; /* --mode mit, else position */
	double amplitude_rad;
	double freq_hz;
	double rate_hz;
	double kp, kd;
	const char *url;
	const char *prefix; /* as given: one prefix or a comma list */
	char prefixes[MAX_INSTANCES][PREFIX_LEN + 1];
	int n_prefixes;
	double duration_s; /* 0: until Ctrl-C */
	bool takeover;	   /* command_t.takeover: take the motors from their owner */
};

/* What we keep of config_t: one motor's name and limits. */
struct motor_cfg {
	int index;
	char name[NAME_LEN];
	int modes; /* RMD_MOTOR_CONFIG_T_MODE_BIT_* */
	double pos_min, pos_max;
	double kp_min, kp_max, kd_min, kd_max;
};

/* Squared errors, largest magnitude and samples over a window. */
struct err_acc {
	double sum_sq;
	double max_abs;
	unsigned long n;
};

struct ctl;

/* One rmdd instance: a prefix, its channels, the daemon answering there, its config and state. */
struct inst {
	struct ctl *c;
	const char *prefix;
	char who[NAME_LEN + 1]; /* config_t.instance_name, else the prefix */
	char ch_command[96], ch_config[96], ch_config_req[96], ch_state[96], ch_health[96];
	rmd_config_t_subscription_t *sub_config;
	rmd_health_t_subscription_t *sub_health;
	rmd_state_t_subscription_t *sub_state;

	bool have_config;
	/*
	 * The daemon that answered (config_t, health_t: docs/lcm.md "One daemon
	 * per prefix"); another instance on the prefix makes us stop.
	 */
	int64_t instance;
	int32_t pid;
	char host[64];
	bool mixed;
	int64_t other_instance;
	int32_t other_pid;
	char other_host[64];
	int period_us, bus_count, motor_count;
	struct motor_cfg cfg[MAX_MOTORS];

	bool have_state;
	int state_count;
	int state_lc[MAX_MOTORS];
	double state_pos[MAX_MOTORS];
	unsigned long n_states;
	int64_t seq; /* its command_t.seq */
};

/* A motor we drive. */
struct motor {
	struct inst *in;
	const struct motor_cfg *cfg;
	char label[2 * NAME_LEN + 8]; /* its name; "LEFT_/hip" beside other instances */
	double center_rad;
	int lifecycle; /* from state_t, -1 before the first */
	bool was_enabled;
	struct err_acc window, total;
};

struct ctl {
	const struct opts *o;
	lcm_t *lcm;
	struct inst in[MAX_INSTANCES]; /* one per prefix */
	int n_in;

	struct motor m[MAX_INSTANCES * MAX_MOTORS];
	int n;
	int64_t t0_ns; /* the sine's time 0; 0: not running yet */
	int64_t id;    /* command_t.controller: random, chosen at start */
	rmd_command_t msg;
	rmd_motor_command_t msg_motor[MAX_MOTORS]; /* msg.motor */
	uint8_t buf[4096];			   /* an encoded command_t is at most 1.7 kB */
};

static volatile sig_atomic_t stop_signal;

static const char *const lc_names[] = { "probe", "ready", "enabled", "fault", "lost", "safe" };

static const char *lc_name(int lc)
{
	return lc >= 0 && lc < (int)(sizeof(lc_names) / sizeof(lc_names[0])) ? lc_names[lc] :
									       "unknown";
}

static int64_t now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * NS_PER_S + ts.tv_nsec;
}

static void on_signal(int sig)
{
	stop_signal = sig;
}

static void usage(FILE *out)
{
	fprintf(out,
		"usage: " PROG " [--mode position|mit] [--amplitude RAD] [--freq HZ] [--rate HZ]\n"
		"                       [--kp KP] [--kd KD] [--url URL] [--prefix P] [--duration S]\n"
		"                       [--takeover]\n"
		"\n"
		"Makes every rmdd motor that takes the mode follow a sine around its position,\n"
		"and prints each motor's tracking error (target - position, RMS and max) once a\n"
		"second.  Ctrl-C sends enable = 0 to those motors and exits 0.\n"
		"\n"
		"  -m, --mode MODE      position (default) or mit\n"
		"  -a, --amplitude RAD  sine amplitude (default 0.5)\n"
		"  -f, --freq HZ        sine frequency (default 0.5)\n"
		"  -r, --rate HZ        commands per second (default 500)\n"
		"  -p, --kp KP          MIT stiffness, N*m/rad (default 20)\n"
		"  -d, --kd KD          MIT damping, N*m*s/rad (default 1)\n"
		"  -u, --url URL        LCM URL (default $LCM_DEFAULT_URL, else %s)\n"
		"  -P, --prefix P       rmdd's channel prefix (default " DEFAULT_PREFIX
		"); P1,P2,...:\n"
		"                       several rmdd instances driven as one robot\n"
		"  -t, --duration S     stop after S seconds (default 0: until Ctrl-C)\n"
		"  -T, --takeover       take the motors from the controller that owns them\n"
		"                       (one that died owning them, say; rmdd logs it)\n"
		"  -h, --help           this text\n"
		"\n"
		"Exit status: 0 stopped, 1 rmdd not running or gone, 2 bad options.\n",
		DEFAULT_URL);
}

/* "0.5" -> 0.5 when it is a finite number in [min, max].  Returns 0 or -EINVAL. */
static int parse_num(const char *opt, const char *s, double min, double max, double *out)
{
	char *end;
	double v;

	errno = 0;
	v = strtod(s, &end);
	if (errno || end == s || *end || !isfinite(v) || v < min || v > max) {
		fprintf(stderr, PROG ": --%s %s: a number in %g..%g\n", opt, s, min, max);
		return -EINVAL;
	}
	*out = v;
	return 0;
}

/* A numeric option: its letter, its long name, its range and where it goes. */
struct num_opt {
	int c;
	const char *name;
	double min, max;
	double *dst;
};

static const struct num_opt *num_opt(const struct num_opt *t, size_t n, int c)
{
	for (size_t i = 0; i < n; i++)
		if (t[i].c == c)
			return &t[i];
	return NULL;
}

/* --prefix P, or P1,P2,... (none empty, none twice): o->prefixes.  0 or -EINVAL after a message. */
static int parse_prefixes(struct opts *o)
{
	const char *s = o->prefix;
	bool list = strchr(s, ',') != NULL;

	for (;;) {
		const char *comma = strchr(s, ',');
		size_t len = comma ? (size_t)(comma - s) : strlen(s);
		char *p = o->prefixes[o->n_prefixes];

		if (len > PREFIX_LEN) {
			fprintf(stderr, PROG ": --prefix: at most %d characters\n", PREFIX_LEN);
			return -EINVAL;
		}
		if (o->n_prefixes == MAX_INSTANCES) {
			fprintf(stderr, PROG ": --prefix %s: at most %d prefixes\n", o->prefix,
				MAX_INSTANCES);
			return -EINVAL;
		}
		memcpy(p, s, len);
		p[len] = '\0';
		if (list && !len) {
			fprintf(stderr, PROG ": --prefix %s: an empty prefix in the list\n",
				o->prefix);
			return -EINVAL;
		}
		for (int i = 0; i < o->n_prefixes; i++)
			if (!strcmp(o->prefixes[i], p)) {
				fprintf(stderr, PROG ": --prefix %s: %s given twice\n", o->prefix,
					p);
				return -EINVAL;
			}
		o->n_prefixes++;
		if (!comma)
			return 0;
		s = comma + 1;
	}
}

/* Fill o from the command line.  Returns 0, 1 (--help printed) or -EINVAL after a message. */
static int parse_args(int argc, char **argv, struct opts *o)
{
	static const struct option longopts[] = {
		{ "mode", required_argument, NULL, 'm' },
		{ "amplitude", required_argument, NULL, 'a' },
		{ "freq", required_argument, NULL, 'f' },
		{ "rate", required_argument, NULL, 'r' },
		{ "kp", required_argument, NULL, 'p' },
		{ "kd", required_argument, NULL, 'd' },
		{ "url", required_argument, NULL, 'u' },
		{ "prefix", required_argument, NULL, 'P' },
		{ "duration", required_argument, NULL, 't' },
		{ "takeover", no_argument, NULL, 'T' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	const struct num_opt nums[] = {
		{ 'a', "amplitude", 0, 100, &o->amplitude_rad },
		{ 'f', "freq", 0, 100, &o->freq_hz },
		{ 'r', "rate", 1, 10000, &o->rate_hz },
		{ 'p', "kp", 0, 1e6, &o->kp },
		{ 'd', "kd", 0, 1e6, &o->kd },
		{ 't', "duration", 0, 1e9, &o->duration_s },
	};
	const char *env = getenv("LCM_DEFAULT_URL");
	int c, r = 0;

	*o = (struct opts){
		.amplitude_rad = 0.5,
		.freq_hz = 0.5,
		.rate_hz = 500,
		.kp = 20,
		.kd = 1,
		.url = env && *env ? env : DEFAULT_URL,
		.prefix = DEFAULT_PREFIX,
	};
	while (!r && (c = getopt_long(argc, argv, "m:a:f:r:p:d:u:P:t:Th", longopts, NULL)) != -1) {
		switch (c) {
		case 'm':
			if (strcmp(optarg, "mit") && strcmp(optarg, "position")) {
				fprintf(stderr, PROG ": --mode %s: position or mit\n", optarg);
				r = -EINVAL;
			}
			o->mit = !strcmp(optarg, "mit");
			break;
		case 'u':
			o->url = optarg;
			break;
		case 'P':
			o->prefix = optarg;
			break;
		case 'T':
			o->takeover = true;
			break;
		case 'h':
			usage(stdout);
			return 1;
		default: {
			const struct num_opt *n = num_opt(nums, sizeof(nums) / sizeof(nums[0]), c);

			if (!n) {
				usage(stderr);
				return -EINVAL;
			}
			r = parse_num(n->name, optarg, n->min, n->max, n->dst);
			break;
		}
		}
	}
	if (!r && optind < argc) {
		fprintf(stderr, PROG ": unexpected argument \"%s\"\n", argv[optind]);
		r = -EINVAL;
	}
	return r ? r : parse_prefixes(o);
}

/* ---- LCM ------------------------------------------------------------------ */

/* A message's motor count, as many as we keep: 0..MAX_MOTORS. */
static int motors_in(int count)
{
	return count < 0 ? 0 : count < MAX_MOTORS ? count : MAX_MOTORS;
}

/* A message of daemon `instance`: the first one heard is ours; another one is a mixed stream. */
static void heard(struct inst *in, int64_t instance, const char *host, int32_t pid)
{
	if (!in->instance) {
		in->instance = instance;
		in->pid = pid;
		snprintf(in->host, sizeof(in->host), "%s", host);
	} else if (instance != in->instance && !in->mixed) {
		in->mixed = true;
		in->other_instance = instance;
		in->other_pid = pid;
		snprintf(in->other_host, sizeof(in->other_host), "%s", host);
	}
}

static void on_health(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_health_t *msg,
		      void *user)
{
	(void)rbuf;
	(void)channel;
	heard(user, msg->instance, msg->host, msg->pid);
}

/* Two rmdd on a prefix of ours: say who, and that we stop (our commands would drive both). */
static bool refuse_mixed(const struct ctl *c)
{
	for (int j = 0; j < c->n_in; j++) {
		const struct inst *in = &c->in[j];

		if (!in->mixed)
			continue;
		fprintf(stderr,
			PROG
			": two rmdd publish on %s prefix %s: instance %016" PRIx64
			" (host %s, pid %d) and %016" PRIx64
			" (host %s, pid %d); our commands would drive both: stopping (stop one, "
			"or give one another lcm.channel_prefix)\n",
			c->o->url, in->prefix, (uint64_t)in->instance, in->host, (int)in->pid,
			(uint64_t)in->other_instance, in->other_host, (int)in->other_pid);
		return true;
	}
	return false;
}

static void on_config(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_config_t *msg,
		      void *user)
{
	struct inst *in = user;

	(void)rbuf;
	(void)channel;
	heard(in, msg->instance, msg->host, msg->pid);
	if (in->have_config ||
	    msg->instance != in->instance) /* the motors do not change while rmdd runs */
		return;
	snprintf(in->who, sizeof(in->who), "%s",
		 msg->instance_name && *msg->instance_name ? msg->instance_name : in->prefix);
	in->period_us = msg->period_us;
	in->bus_count = msg->bus_count;
	in->motor_count = motors_in(msg->motor_count);
	for (int i = 0; i < in->motor_count; i++) {
		const rmd_motor_config_t *mc = &msg->motor[i];
		struct motor_cfg *m = &in->cfg[i];

		m->index = mc->index;
		snprintf(m->name, sizeof(m->name), "%s", mc->name);
		m->modes = mc->modes;
		m->pos_min = mc->position_min;
		m->pos_max = mc->position_max;
		m->kp_min = mc->kp_min;
		m->kp_max = mc->kp_max;
		m->kd_min = mc->kd_min;
		m->kd_max = mc->kd_max;
	}
	in->have_config = true;
}

static double target_rad(const struct ctl *c, const struct motor *m, double t)
{
	return m->center_rad + c->o->amplitude_rad * sin(2 * M_PI * c->o->freq_hz * t);
}

static void acc_add(struct err_acc *a, double e)
{
	a->sum_sq += e * e;
	if (fabs(e) > a->max_abs)
		a->max_abs = fabs(e);
	a->n++;
}

/* Tracking error and lifecycle changes of instance in's driven motors, from its state_t. */
static void track(struct inst *in, double t)
{
	struct ctl *c = in->c;

	for (int k = 0; k < c->n; k++) {
		struct motor *m = &c->m[k];
		int i = m->cfg->index, lc;

		if (m->in != in || i < 0 || i >= in->state_count)
			continue;
		lc = in->state_lc[i];
		if (lc != m->lifecycle) {
			/* said once: a motor that leaves ENABLED (safe action, fault, loss) */
			if (m->was_enabled)
				printf(PROG ": %s: now %s\n", m->label, lc_name(lc));
			m->lifecycle = lc;
			m->was_enabled |= lc == RMD_STATE_T_LC_ENABLED;
		}
		if (lc == RMD_STATE_T_LC_ENABLED && isfinite(in->state_pos[i])) {
			double e = target_rad(c, m, t) - in->state_pos[i];

			acc_add(&m->window, e);
			acc_add(&m->total, e);
		}
	}
}

static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *msg,
		     void *user)
{
	struct inst *in = user;

	(void)rbuf;
	(void)channel;
	in->state_count = motors_in(msg->count);
	for (int i = 0; i < in->state_count; i++) {
		in->state_lc[i] = msg->motor[i].lifecycle;
		in->state_pos[i] = msg->motor[i].position;
	}
	in->have_state = true;
	in->n_states++;
	if (in->c->t0_ns)
		track(in, (double)(now_ns() - in->c->t0_ns) / 1e9);
}

/* Handle messages until `deadline` (CLOCK_MONOTONIC ns) or a signal.  -errno on failure. */
static int handle_until(struct ctl *c, int64_t deadline)
{
	struct pollfd pfd = { .fd = lcm_get_fileno(c->lcm), .events = POLLIN };

	while (!stop_signal) {
		int64_t left = deadline - now_ns();
		struct timespec ts;
		int r;

		if (left <= 0)
			return 0;
		ts = (struct timespec){ .tv_sec = left / NS_PER_S, .tv_nsec = left % NS_PER_S };
		r = ppoll(&pfd, 1, &ts, NULL);
		if (r < 0 && errno != EINTR)
			return -errno;
		if (r > 0 && lcm_handle(c->lcm) < 0)
			return -EIO;
	}
	return 0;
}

static void request_config(struct inst *in)
{
	rmd_config_request_t req = { .utime = now_ns() / 1000 };

	rmd_config_request_t_publish(in->c->lcm, in->ch_config_req, &req);
}

/*
 * One command_t to instance in for each of its driven motors: the sine at
 * time t, or enable = 0 (none: it has no motor of ours).  Encoded into our
 * own buffer (the generated _publish() allocates each time).  Returns 0 or
 * -EIO.
 */
static int publish(struct inst *in, bool enable, double t)
{
	struct ctl *c = in->c;
	rmd_command_t *msg = &c->msg;
	double w = 2 * M_PI * c->o->freq_hz;
	int len, n = 0;

	memset(msg, 0, sizeof(*msg));
	memset(c->msg_motor, 0, sizeof(c->msg_motor));
	msg->motor = c->msg_motor;
	for (int k = 0; k < c->n; k++) {
		rmd_motor_command_t *mc;

		if (c->m[k].in != in)
			continue;
		mc = &msg->motor[n++];
		mc->index = (int16_t)c->m[k].cfg->index;
		mc->enable = enable;
		mc->mode = c->o->mit ? RMD_COMMAND_T_MODE_MIT : RMD_COMMAND_T_MODE_POSITION;
		mc->position = target_rad(c, &c->m[k], t);
		if (c->o->mit) {
			mc->velocity = c->o->amplitude_rad * w * cos(w * t);
			mc->kp = c->o->kp;
			mc->kd = c->o->kd;
		}
		/* position mode: max_velocity 0 = the motor's configured velocity_max */
	}
	if (!n)
		return 0;
	msg->utime = now_ns() / 1000;
	msg->seq = in->seq++;
	msg->controller = c->id;
	msg->takeover = c->o->takeover;
	msg->count = (int16_t)n;
	len = rmd_command_t_encode(c->buf, 0, (int)sizeof(c->buf), msg);
	if (len < 0 || lcm_publish(c->lcm, in->ch_command, c->buf, (unsigned)len) < 0)
		return -EIO;
	return 0;
}

/* publish() to every instance, each tried whatever the others did.  Returns 0 or -EIO. */
static int publish_all(struct ctl *c, bool enable, double t)
{
	int r = 0;

	for (int j = 0; j < c->n_in; j++)
		if (publish(&c->in[j], enable, t) < 0)
			r = -EIO;
	return r;
}

/* ---- the run ---------------------------------------------------------------- */

/* Each instance's config_t, asked for until it comes, within CONFIG_WAIT_NS for all. */
static int wait_config(struct ctl *c)
{
	int64_t end = now_ns() + CONFIG_WAIT_NS;

	for (;;) {
		int64_t now = now_ns(), next = now + CONFIG_ASK_NS;
		int missing = 0;

		for (int j = 0; j < c->n_in; j++)
			missing += !c->in[j].have_config;
		if (!missing || stop_signal)
			return 0;
		if (now >= end) {
			for (int j = 0; j < c->n_in; j++)
				if (!c->in[j].have_config)
					fprintf(stderr,
						PROG
						": no rmd.config_t on %s within %.0f s: is rmdd "
						"running, with --lcm-url %s and channel prefix "
						"%s?\n",
						c->in[j].ch_config, (double)CONFIG_WAIT_NS / 1e9,
						c->o->url, c->in[j].prefix);
			return -ETIMEDOUT;
		}
		for (int j = 0; j < c->n_in; j++)
			if (!c->in[j].have_config)
				request_config(&c->in[j]);
		if (handle_until(c, next < end ? next : end) < 0)
			return -EIO;
	}
}

/* A motor as we name it: its name alone, or "WHO/name" when several instances are driven. */
static void label_motor(const struct inst *in, const struct motor_cfg *mc, char *out, size_t len)
{
	if (in->c->n_in == 1)
		snprintf(out, len, "%s", mc->name);
	else
		snprintf(out, len, "%s/%s", in->who, mc->name);
}

/* One robot: no motor name in two instances (docs/robot.md).  Returns an exit status. */
static int check_names(const struct ctl *c)
{
	for (int a = 0; a < c->n_in; a++)
		for (int b = a + 1; b < c->n_in; b++)
			for (int i = 0; i < c->in[a].motor_count; i++)
				for (int k = 0; k < c->in[b].motor_count; k++) {
					const struct inst *x = &c->in[a], *y = &c->in[b];

					if (strcmp(x->cfg[i].name, y->cfg[k].name))
						continue;
					fprintf(stderr,
						PROG ": motor %s is in two instances, %s (prefix "
						     "%s) and %s (prefix %s): motor names must be "
						     "unique across the robot\n",
						x->cfg[i].name, x->who, x->prefix, y->who,
						y->prefix);
					return EXIT_FAIL;
				}
	return EXIT_OK;
}

/* Every motor of instance in whose modes allow ours.  Returns an exit status. */
static int choose_motors_of(struct inst *in)
{
	struct ctl *c = in->c;
	int bit = c->o->mit ? RMD_MOTOR_CONFIG_T_MODE_BIT_MIT :
			      RMD_MOTOR_CONFIG_T_MODE_BIT_POSITION;
	const char *mode = c->o->mit ? "mit" : "position";
	char left_out[MAX_MOTORS * (sizeof(c->m[0].label) + 1)] = "";
	size_t used = 0;

	printf(PROG ": rmdd at %s: %d motors on %d buses, loop %.0f Hz, prefix %s\n", c->o->url,
	       in->motor_count, in->bus_count, in->period_us > 0 ? 1e6 / in->period_us : 0.0,
	       in->prefix);
	for (int i = 0; i < in->motor_count; i++) {
		const struct motor_cfg *mc = &in->cfg[i];
		struct motor *m = &c->m[c->n];

		*m = (struct motor){ .in = in, .cfg = mc, .lifecycle = -1 };
		label_motor(in, mc, m->label, sizeof(m->label));
		if (!(mc->modes & bit)) {
			used += (size_t)snprintf(left_out + used, sizeof(left_out) - used, " %s",
						 m->label);
			continue;
		}
		if (c->o->mit && !(c->o->kp >= mc->kp_min && c->o->kp <= mc->kp_max &&
				   c->o->kd >= mc->kd_min && c->o->kd <= mc->kd_max)) {
			fprintf(stderr,
				PROG ": %s: --kp %g --kd %g outside its ranges kp %g..%g, "
				     "kd %g..%g\n",
				m->label, c->o->kp, c->o->kd, mc->kp_min, mc->kp_max, mc->kd_min,
				mc->kd_max);
			return EXIT_USAGE;
		}
		c->n++;
	}
	if (used)
		printf(PROG ": left alone (no %s mode):%s\n", mode, left_out);
	return EXIT_OK;
}

/* Every motor of every instance whose modes allow ours.  Returns an exit status. */
static int choose_motors(struct ctl *c)
{
	int ret = check_names(c);

	for (int j = 0; j < c->n_in && ret == EXIT_OK; j++)
		ret = choose_motors_of(&c->in[j]);
	if (ret == EXIT_OK && !c->n) {
		fprintf(stderr,
			PROG ": no motor of rmdd's configuration takes %s mode "
			     "(examples/sim-sine.yaml has both kinds)\n",
			c->o->mit ? "mit" : "position");
		return EXIT_FAIL;
	}
	return ret;
}

/* Centre each sine on the motor's position, moved inside its limits.  Returns an exit status. */
static int set_centers(struct ctl *c)
{
	int64_t end = now_ns() + STATE_WAIT_NS;
	double amp = c->o->amplitude_rad;
	int missing;

	for (;;) {
		missing = 0;
		for (int j = 0; j < c->n_in; j++)
			missing += !c->in[j].have_state;
		if (!missing || stop_signal || now_ns() >= end)
			break;
		if (handle_until(c, end) < 0)
			return EXIT_FAIL;
	}
	if (missing) {
		if (stop_signal)
			return EXIT_OK;
		for (int j = 0; j < c->n_in; j++)
			if (!c->in[j].have_state)
				fprintf(stderr, PROG ": no rmd.state_t on %s within %.0f s\n",
					c->in[j].ch_state, (double)STATE_WAIT_NS / 1e9);
		return EXIT_FAIL;
	}
	for (int k = 0; k < c->n; k++) {
		struct motor *m = &c->m[k];
		int i = m->cfg->index;
		double p = i >= 0 && i < m->in->state_count ? m->in->state_pos[i] : 0;
		double lo = m->cfg->pos_min + amp, hi = m->cfg->pos_max - amp;

		if (!isfinite(p))
			p = 0; /* no reply yet */
		if (lo > hi) {
			fprintf(stderr,
				PROG ": %s: --amplitude %g does not fit its position limits "
				     "%g..%g rad\n",
				m->label, amp, m->cfg->pos_min, m->cfg->pos_max);
			return EXIT_USAGE;
		}
		m->center_rad = p < lo ? lo : p > hi ? hi : p;
	}
	return EXIT_OK;
}

/* A driven motor's lifecycle in its instance's last state_t, -1 when it has none. */
static int lifecycle_of(const struct motor *m)
{
	int i = m->cfg->index;

	return i >= 0 && i < m->in->state_count ? m->in->state_lc[i] : -1;
}

static bool all_ready(const struct ctl *c)
{
	for (int k = 0; k < c->n; k++)
		if (lifecycle_of(&c->m[k]) != RMD_STATE_T_LC_READY)
			return false;
	return true;
}

/* enable = 0, then wait for READY: a motor back from a fault or loss needs it. */
static int disable_first(struct ctl *c)
{
	int64_t end = now_ns() + READY_WAIT_NS;

	if (publish_all(c, false, 0) < 0)
		return -EIO;
	while (!stop_signal && now_ns() < end && !all_ready(c))
		if (handle_until(c, now_ns() + 10 * NS_PER_MS) < 0)
			return -EIO;
	for (int k = 0; k < c->n; k++) {
		int lc = lifecycle_of(&c->m[k]);

		if (lc != RMD_STATE_T_LC_READY)
			printf(PROG ": %s: %s, not ready: it may not follow\n", c->m[k].label,
			       lc_name(lc));
	}
	return 0;
}

static void print_acc(const struct ctl *c, const struct motor *m, const struct err_acc *a,
		      const char *head)
{
	const char *mode = c->o->mit ? "mit" : "position";

	if (a->n)
		printf("%s %-12s %-8s tracking error rms %.5f rad  max %.5f rad  (%lu states)\n",
		       head, m->label, mode, sqrt(a->sum_sq / (double)a->n), a->max_abs, a->n);
	else
		printf("%s %-12s %-8s tracking error none: the motor is %s, not enabled\n", head,
		       m->label, mode, lc_name(m->lifecycle));
}

static void print_window(struct ctl *c, double t)
{
	char head[32];

	snprintf(head, sizeof(head), "[%6.1f s]", t);
	for (int k = 0; k < c->n; k++) {
		print_acc(c, &c->m[k], &c->m[k].window, head);
		c->m[k].window = (struct err_acc){ 0 };
	}
}

/* An instance that sent no state_t since *last_states: say so.  True when it went quiet. */
static bool went_quiet(const struct inst *in, unsigned long *last_states)
{
	if (in->n_states != *last_states) {
		*last_states = in->n_states;
		return false;
	}
	if (in->c->n_in == 1)
		fprintf(stderr, PROG ": no state_t from rmdd for %.0f s: stopping\n",
			(double)STATE_WAIT_NS / 1e9);
	else
		fprintf(stderr, PROG ": no state_t from rmdd %s (prefix %s) for %.0f s: stopping\n",
			in->who, in->prefix, (double)STATE_WAIT_NS / 1e9);
	return true;
}

/* Stream the sine until a signal, --duration, or an rmdd goes quiet.  Returns an exit status. */
static int stream(struct ctl *c)
{
	int64_t period = (int64_t)(1e9 / c->o->rate_hz);
	int64_t t0 = now_ns(), next_pub = t0, next_print = t0 + PRINT_PERIOD_NS;
	int64_t duration = (int64_t)(c->o->duration_s * 1e9), last_look = t0;
	unsigned long last_states[MAX_INSTANCES];

	for (int j = 0; j < c->n_in; j++)
		last_states[j] = c->in[j].n_states;
	c->t0_ns = t0;
	while (!stop_signal) {
		int64_t now = now_ns(), next;
		double t = (double)(now - t0) / 1e9;

		if (refuse_mixed(c))
			return EXIT_FAIL;
		if (duration && now - t0 >= duration)
			break;
		if (now >= next_pub) {
			if (publish_all(c, true, t) < 0) {
				fprintf(stderr, PROG ": LCM publish failed: stopping\n");
				return EXIT_FAIL;
			}
			next_pub += period;
			if (next_pub <= now) /* late: skip, never catch up in a burst */
				next_pub = now + period;
		}
		if (now >= next_print) {
			print_window(c, t);
			next_print += PRINT_PERIOD_NS;
		}
		if (now - last_look >= STATE_WAIT_NS) {
			for (int j = 0; j < c->n_in; j++)
				if (went_quiet(&c->in[j], &last_states[j]))
					return EXIT_FAIL;
			last_look = now;
		}
		next = next_pub < next_print ? next_pub : next_print;
		if (duration && t0 + duration < next)
			next = t0 + duration;
		if (handle_until(c, next) < 0) {
			fprintf(stderr, PROG ": LCM receive failed: stopping\n");
			return EXIT_FAIL;
		}
	}
	return EXIT_OK;
}

/* enable = 0 for every driven motor, STOP_REPEAT times, and the whole run's error. */
static void shutdown_motors(struct ctl *c)
{
	const struct timespec gap = { 0, STOP_GAP_NS };
	double t = c->t0_ns ? (double)(now_ns() - c->t0_ns) / 1e9 : 0;

	for (int k = 0; k < STOP_REPEAT; k++) {
		if (publish_all(c, false, t) < 0)
			fprintf(stderr, PROG ": LCM publish of enable = 0 failed\n");
		nanosleep(&gap, NULL);
	}
	printf(PROG ": stopped: enable = 0 sent to %d motors\n", c->n);
	for (int k = 0; k < c->n; k++)
		print_acc(c, &c->m[k], &c->m[k].total, PROG ": whole run:");
}

/* Instance in on prefix: its channels and subscriptions.  Returns 0 or -EIO. */
static int inst_open(struct ctl *c, struct inst *in, const char *prefix)
{
	in->c = c;
	in->prefix = prefix;
	snprintf(in->who, sizeof(in->who), "%s", prefix);
	snprintf(in->ch_command, sizeof(in->ch_command), "%s" RMD_CHANNEL_COMMAND, prefix);
	snprintf(in->ch_config, sizeof(in->ch_config), "%s" RMD_CHANNEL_CONFIG, prefix);
	snprintf(in->ch_config_req, sizeof(in->ch_config_req), "%s" RMD_CHANNEL_CONFIG_REQUEST,
		 prefix);
	snprintf(in->ch_state, sizeof(in->ch_state), "%s" RMD_CHANNEL_STATE, prefix);
	snprintf(in->ch_health, sizeof(in->ch_health), "%s" RMD_CHANNEL_HEALTH, prefix);
	/* LCM subscribes by regular expression: the prefix is taken as written. */
	in->sub_config = rmd_config_t_subscribe(c->lcm, in->ch_config, on_config, in);
	in->sub_state = rmd_state_t_subscribe(c->lcm, in->ch_state, on_state, in);
	in->sub_health = rmd_health_t_subscribe(c->lcm, in->ch_health, on_health, in);
	return in->sub_config && in->sub_state && in->sub_health ? 0 : -EIO;
}

static void inst_close(struct inst *in)
{
	if (in->sub_health)
		rmd_health_t_unsubscribe(in->c->lcm, in->sub_health);
	if (in->sub_state)
		rmd_state_t_unsubscribe(in->c->lcm, in->sub_state);
	if (in->sub_config)
		rmd_config_t_unsubscribe(in->c->lcm, in->sub_config);
}

static int run(struct ctl *c)
{
	int ret = EXIT_OK;

	/* docs/lcm.md "One controller at a time": who we are to rmdd */
	if (getrandom(&c->id, sizeof(c->id), 0) != (ssize_t)sizeof(c->id))
		c->id = now_ns() ^ ((int64_t)getpid() << 32);
	c->lcm = lcm_create(c->o->url);
	if (!c->lcm) {
		fprintf(stderr,
			PROG ": LCM %s: cannot create (bad URL, or multicast not routable: see "
			     "docs/lcm.md)\n",
			c->o->url);
		return EXIT_FAIL;
	}
	for (c->n_in = 0; c->n_in < c->o->n_prefixes && ret == EXIT_OK; c->n_in++)
		if (inst_open(c, &c->in[c->n_in], c->o->prefixes[c->n_in]) < 0) {
			fprintf(stderr, PROG ": LCM %s: cannot subscribe (see docs/lcm.md)\n",
				c->o->url);
			ret = EXIT_FAIL;
		}
	if (ret != EXIT_OK)
		goto err_close_instances;

	ret = wait_config(c) < 0 ? EXIT_FAIL : EXIT_OK;
	if (ret != EXIT_OK || stop_signal)
		goto err_close_instances;
	ret = choose_motors(c);
	if (ret == EXIT_OK)
		ret = set_centers(c);
	if (ret != EXIT_OK || stop_signal)
		goto err_close_instances;
	printf(PROG ": %s mode on %d motors:", c->o->mit ? "mit" : "position", c->n);
	for (int k = 0; k < c->n; k++)
		printf(" %s", c->m[k].label);
	printf("; amplitude %g rad, %g Hz, %g commands/s", c->o->amplitude_rad, c->o->freq_hz,
	       c->o->rate_hz);
	if (c->o->mit)
		printf(", kp %g, kd %g", c->o->kp, c->o->kd);
	printf("\n");

	if (disable_first(c) < 0 || refuse_mixed(c))
		ret = EXIT_FAIL;
	else
		ret = stream(c);
	shutdown_motors(c);

err_close_instances:
	for (int j = c->n_in - 1; j >= 0; j--)
		inst_close(&c->in[j]);
	lcm_destroy(c->lcm);
	return ret;
}

int main(int argc, char **argv)
{
	static struct opts o;
	static struct ctl c; /* ~100 kB of instances and motors: off the stack */
	struct sigaction sa = { .sa_handler = on_signal };

	int r = parse_args(argc, argv, &o);

	c.o = &o;

	if (r)
		return r < 0 ? EXIT_USAGE : EXIT_OK;
	setvbuf(stdout, NULL, _IOLBF, 0);
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	return run(&c);
}
