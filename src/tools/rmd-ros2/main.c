// SPDX-License-Identifier: MIT
/*
 * rmd-ros2: rmdd on ROS 2's wire (docs/ros2.md).  A process of its own
 * beside rmdd, never in its rt loop: LCM on one side (rmd.state_t,
 * health_t and config_t in, command_t out, docs/lcm.md), DDS as ROS 2 on
 * Cyclone DDS speaks it on the other (ros2_msgs.idl): joint states as
 * sensor_msgs/msg/JointState on rt/joint_states, rmdd's health as
 * diagnostic_msgs/msg/DiagnosticArray on rt/diagnostics, and joint
 * commands (sensor_msgs/msg/JointState, the shape topic_based_ros2_control
 * publishes) from rt/joint_commands, which move motors only with --enable.
 * One thread: LCM's descriptor polled with a 1 ms timeout, the DDS reader
 * taken after each.  Non-rt.
 */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>

#include <dds/dds.h>
#include <lcm/lcm.h>

#include "map.h"
#include "rmd/channels.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/time.h"
#include "ros2_msgs.h"
#include "tools/common/cli.h"
#include "tools/common/log.h"
#include "tools/common/names.h"

#define USAGE_LINE "rmd-ros2 [--enable] [--mode position|velocity|effort] [OPTION]..."
#define EXIT_USAGE 2
#define EXIT_FAIL 1
#define ASK_EVERY_NS (500 * RMD_NS_PER_MS) /* config_t requests until one comes */
#define RESEND_NS (10 * RMD_NS_PER_MS)	   /* --hold-ms: the last command again this often */
#define TAKE_MAX 16

/* getopt_long's values: TOOL_OPT_BASE + the row of opts[] below, in its order. */
enum {
	OPT_LCM_URL = TOOL_OPT_BASE,
	OPT_PREFIX,
	OPT_DOMAIN,
	OPT_STATES,
	OPT_COMMANDS,
	OPT_DIAG,
	OPT_MODE,
	OPT_ENABLE,
	OPT_HOLD,
	OPT_MAX_JUMP,
	OPT_SENSOR_QOS,
	OPT_HELP = 'h',
	OPT_VERBOSE = 'v',
	OPT_QUIET = 'q',
	OPT_VERSION = 'V',
};

static const struct tool_opt opts[] = {
	TOOL_OPT_ARG("lcm-url", "URL", "rmdd's LCM URL (default: $LCM_DEFAULT_URL, else LCM's)"),
	TOOL_OPT_ARG("prefix", "PREFIX", "rmdd's channel prefix (default RMD_)"),
	TOOL_OPT_ARG("domain", "ID",
		     "the DDS domain: ROS_DOMAIN_ID (default: $ROS_DOMAIN_ID, else 0)"),
	TOOL_OPT_ARG("joint-states", "TOPIC",
		     "ROS 2 topic of the joint states (default joint_states)"),
	TOOL_OPT_ARG("joint-commands", "TOPIC",
		     "ROS 2 topic of the joint commands (default joint_commands)"),
	TOOL_OPT_ARG("diagnostics", "TOPIC", "ROS 2 topic of rmdd's health (default diagnostics)"),
	{ .name = "mode",
	  .has_arg = required_argument,
	  .arg = "MODE",
	  .help = "the command interface ROS drives: position (default), velocity or effort",
	  .value = TOOL_VAL_WORDS,
	  .words = "position velocity effort" },
	{ .name = "enable",
	  .help = "let joint commands enable and move the motors (rmdd's enable procedure);\n"
		  "without it rmd-ros2 only publishes, and counts the commands it refuses" },
	TOOL_OPT_ARG("hold-ms", "MS",
		     "repeat the last joint command to rmdd for MS after it came (default 0:\n"
		     "each command once, so rmdd's watchdog sees ROS's silence)"),
	TOOL_OPT_ARG("max-jump", "RAD",
		     "position mode: enable a motor only with a first command within RAD of where\n"
		     "it is (default 0.2)"),
	{ .name = "sensor-qos",
	  .help = "publish joint states with ROS 2's sensor-data QoS (best effort, keep last 5)\n"
		  "instead of the default QoS (reliable, volatile, keep last 10)" },
	TOOL_OPT_HELP,
	TOOL_OPT_VERBOSE("log every refused joint command, not only the first of a kind"),
	TOOL_OPT_QUIET("errors only"),
	TOOL_OPT_VERSION("print the version and exit"),
};

#define NOPTS (sizeof(opts) / sizeof(opts[0]))

struct bridge {
	const char *url;
	const char *prefix;
	uint32_t domain;
	char states_topic[256], commands_topic[256], diag_topic[256];
	int mode;
	bool enable, sensor_qos;
	int64_t hold_ns;
	double max_jump;

	lcm_t *lcm;
	char ch_state[64], ch_health[64], ch_config[64], ch_request[64], ch_command[64];
	rmd_config_t *cfg;  /* the first config_t (rmdd's motors) */
	rmd_state_t *state; /* the newest state_t */
	int64_t next_ask_ns;
	bool other_instance_told;

	dds_entity_t participant, w_states, w_diag, r_commands;
	struct ros2_map map;
	struct ros2_js_buf js_buf;
	struct ros2_diag_buf diag_buf;

	int64_t controller, seq;
	int64_t last_ros_ns, last_sent_ns;
	bool told[ROS2_REJ_KINDS];
	bool verbose;
};

static volatile sig_atomic_t stop;

static void on_signal(int sig)
{
	(void)sig;
	stop = 1;
}

static void usage(void)
{
	printf("usage: %s\n\n"
	       "rmdd on ROS 2's wire (docs/ros2.md): rmdd's state_t as sensor_msgs/msg/JointState\n"
	       "on rt/TOPIC (ROS 2 topic /joint_states), its health as\n"
	       "diagnostic_msgs/msg/DiagnosticArray (/diagnostics), and joint commands\n"
	       "(sensor_msgs/msg/JointState, as topic_based_ros2_control publishes them) from\n"
	       "/joint_commands to rmdd's command_t, with --enable only.\n\n",
	       USAGE_LINE);
	tool_opts_help(stdout, opts, NOPTS);
}

/* "/joint_states" or "joint_states" as the DDS topic "rt/joint_states" (ROS 2's topic prefix). */
static int ros_topic(char *out, size_t size, const char *name, const char *opt)
{
	while (*name == '/')
		name++;
	if (!*name || strchr(name, ' ') || (size_t)snprintf(out, size, "rt/%s", name) >= size) {
		tool_log(TOOL_LOG_ERR, "--%s %s: not a ROS 2 topic name", opt, name);
		return -EINVAL;
	}
	return 0;
}

static void channel(char *out, size_t size, const char *prefix, const char *suffix)
{
	snprintf(out, size, "%s%s", prefix, suffix);
}

/* ---- LCM side ----------------------------------------------------------------------- */

static void on_config(const lcm_recv_buf_t *rbuf, const char *ch, const rmd_config_t *msg, void *u)
{
	struct bridge *b = u;
	char err[160];

	(void)rbuf;
	(void)ch;
	if (b->cfg) {
		if (msg->instance != b->cfg->instance && !b->other_instance_told) {
			tool_log(TOOL_LOG_WARNING,
				 "another rmdd (instance %" PRIx64
				 ", pid %d) on %s: rmd-ros2 keeps the "
				 "motors of the first one (pid %d); restart rmd-ros2 to follow it",
				 (uint64_t)msg->instance, msg->pid, b->ch_config, b->cfg->pid);
			b->other_instance_told = true;
		}
		return;
	}
	if (ros2_map_config(&b->map, msg, b->mode, b->enable, b->max_jump, err, sizeof(err)) < 0) {
		tool_log(TOOL_LOG_ERR, "rmdd's configuration (%s): %s", msg->source, err);
		stop = 2;
		return;
	}
	b->cfg = rmd_config_t_copy(msg);
	tool_log(TOOL_LOG_NOTICE,
		 "rmdd pid %d, %d motors; publishing rt/%s, rt/%s; joint commands from %s in mode "
		 "%s%s",
		 msg->pid, msg->motor_count, b->states_topic + 3, b->diag_topic + 3,
		 b->commands_topic, ros2_mode_word(b->mode),
		 b->enable ? " (--enable: they enable the motors they name)" :
			     " refused: no --enable, rmd-ros2 only publishes");
}

static void publish_command(struct bridge *b, rmd_motor_command_t *e, unsigned n)
{
	rmd_command_t c = { 0 };

	c.utime = rmd_now_ns() / RMD_NS_PER_US;
	c.seq = ++b->seq;
	c.controller = b->controller;
	c.count = (int16_t)n;
	c.motor = e;
	rmd_command_t_publish(b->lcm, b->ch_command, &c);
	b->last_sent_ns = rmd_now_ns();
}

static void tell_stopped(struct bridge *b)
{
	for (unsigned i = 0; i < b->map.count; i++) {
		const struct ros2_motor *m = &b->map.m[i];

		if (m->phase == ROS2_STOPPED && m->seen_enabled)
			tool_log(TOOL_LOG_WARNING,
				 "motor %s left enabled (now %s): rmd-ros2 sends it enable = 0 and "
				 "does not enable it again; restart rmd-ros2 to run it",
				 m->name, tool_lifecycle_name((unsigned)m->lifecycle));
	}
	b->map.stopped_new = 0;
}

static void on_state(const lcm_recv_buf_t *rbuf, const char *ch, const rmd_state_t *msg, void *u)
{
	struct bridge *b = u;
	sensor_msgs_msg_dds__JointState_ js;
	int64_t mono;

	(void)rbuf;
	(void)ch;
	if (!b->cfg || msg->count != (int16_t)b->map.count)
		return;
	if (b->state)
		rmd_state_t_destroy(b->state);
	b->state = rmd_state_t_copy(msg);
	ros2_map_state(&b->map, msg);
	if (b->map.stopped_new)
		tell_stopped(b);
	ros2_joint_state(&b->map, msg, rmd_realtime_offset_ns(&mono), &b->js_buf, &js);
	dds_write(b->w_states, &js);
}

static void on_health(const lcm_recv_buf_t *rbuf, const char *ch, const rmd_health_t *msg, void *u)
{
	struct bridge *b = u;
	diagnostic_msgs_msg_dds__DiagnosticArray_ da;
	int64_t mono;

	(void)rbuf;
	(void)ch;
	if (!b->cfg || msg->instance != b->cfg->instance)
		return;
	ros2_diagnostics(&b->map, b->cfg, msg, b->state, rmd_realtime_offset_ns(&mono),
			 &b->diag_buf, &da);
	dds_write(b->w_diag, &da);
}

/* ---- DDS side ----------------------------------------------------------------------- */

/*
 * The QoS rmw_cyclonedds_cpp gives ROS 2's default profile
 * (rmw_qos_profile_default: reliable, volatile, keep last 10;
 * rmw_node.cpp create_readwrite_qos: autodispose off, automatic
 * liveliness), or the sensor-data profile (rmw_qos_profile_sensor_data:
 * best effort, keep last 5).
 */
static dds_qos_t *ros_qos(bool sensor_data)
{
	dds_qos_t *q = dds_create_qos();

	dds_qset_writer_data_lifecycle(q, false);
	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, sensor_data ? 5 : 10);
	if (sensor_data)
		dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
	else
		dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_INFINITY);
	dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
	dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, DDS_INFINITY);
	return q;
}

static int dds_open(struct bridge *b)
{
	dds_entity_t ts, td, tc;
	dds_qos_t *q;

	b->participant = dds_create_participant(b->domain, NULL, NULL);
	if (b->participant < 0) {
		tool_log(TOOL_LOG_ERR, "DDS: no participant on domain %" PRIu32 ": %s", b->domain,
			 dds_strretcode(b->participant));
		return -EIO;
	}
	ts = dds_create_topic(b->participant, &sensor_msgs_msg_dds__JointState__desc,
			      b->states_topic, NULL, NULL);
	tc = dds_create_topic(b->participant, &sensor_msgs_msg_dds__JointState__desc,
			      b->commands_topic, NULL, NULL);
	td = dds_create_topic(b->participant, &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
			      b->diag_topic, NULL, NULL);
	if (ts < 0 || tc < 0 || td < 0) {
		tool_log(TOOL_LOG_ERR, "DDS: cannot create the topics: %s",
			 dds_strretcode(ts < 0 ? ts :
					tc < 0 ? tc :
						 td));
		return -EIO;
	}
	q = ros_qos(b->sensor_qos);
	b->w_states = dds_create_writer(b->participant, ts, q, NULL);
	dds_delete_qos(q);
	q = ros_qos(false);
	b->w_diag = dds_create_writer(b->participant, td, q, NULL);
	dds_delete_qos(q);
	/*
	 * Best effort: it matches a reliable writer (topic_based_ros2_control's
	 * QoS(1)) and a best-effort one; a command that is lost is replaced by
	 * the next, and one that comes late is worse than none.
	 */
	q = ros_qos(true);
	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, TAKE_MAX);
	b->r_commands = dds_create_reader(b->participant, tc, q, NULL);
	dds_delete_qos(q);
	if (b->w_states < 0 || b->w_diag < 0 || b->r_commands < 0) {
		tool_log(TOOL_LOG_ERR, "DDS: cannot create the writers and the reader");
		return -EIO;
	}
	return 0;
}

static const char *reject_word(int kind)
{
	switch (kind) {
	case ROS2_REJ_NAME:
		return "name";
	case ROS2_REJ_SHAPE:
		return "shape";
	case ROS2_REJ_NONFINITE:
		return "non-finite";
	case ROS2_REJ_DISABLED:
		return "not enabled";
	case ROS2_REJ_JUMP:
		return "leap";
	default:
		return "?";
	}
}

static void take_commands(struct bridge *b)
{
	void *samples[TAKE_MAX] = { NULL };
	dds_sample_info_t info[TAKE_MAX];
	rmd_motor_command_t e[ROS2_MAX_MOTORS];
	bool taken = false;
	int n = dds_take(b->r_commands, samples, info, TAKE_MAX, TAKE_MAX);

	for (int i = 0; i < n; i++) {
		char why[160];
		int r;

		if (!info[i].valid_data)
			continue;
		if (!b->cfg) {
			b->map.rejected[ROS2_REJ_DISABLED]++;
			continue;
		}
		r = ros2_map_take(&b->map, samples[i], why, sizeof(why));
		if (r > 0) {
			taken = true;
			continue;
		}
		r = -1 - r;
		if (!b->told[r] || b->verbose) {
			if (r == ROS2_REJ_DISABLED)
				tool_log(TOOL_LOG_WARNING,
					 "joint command on %s refused: rmd-ros2 runs without "
					 "--enable (further ones are counted in rt/%s)",
					 b->commands_topic, b->diag_topic + 3);
			else
				tool_log(TOOL_LOG_WARNING,
					 "joint command on %s refused (%s): %s; the whole message "
					 "is dropped (further ones are counted in rt/%s)",
					 b->commands_topic, reject_word(r), why, b->diag_topic + 3);
			b->told[r] = true;
		}
	}
	if (n > 0)
		dds_return_loan(b->r_commands, samples, n);
	if (!taken)
		return;
	b->last_ros_ns = rmd_now_ns();
	publish_command(b, e, ros2_map_command(&b->map, e));
}

/* --hold-ms: the last joint command again every RESEND_NS while it is younger than the hold. */
static void hold(struct bridge *b)
{
	rmd_motor_command_t e[ROS2_MAX_MOTORS];
	int64_t now = rmd_now_ns();
	unsigned n;

	if (!b->hold_ns || !b->last_ros_ns || now - b->last_ros_ns > b->hold_ns ||
	    now - b->last_sent_ns < RESEND_NS)
		return;
	n = ros2_map_command(&b->map, e);
	if (n)
		publish_command(b, e, n);
}

static int run(struct bridge *b)
{
	rmd_motor_command_t e[ROS2_MAX_MOTORS];
	rmd_config_t_subscription_t *sc;
	rmd_state_t_subscription_t *ss;
	rmd_health_t_subscription_t *sh;
	unsigned n;
	int rc = 0;

	sc = rmd_config_t_subscribe(b->lcm, b->ch_config, on_config, b);
	ss = rmd_state_t_subscribe(b->lcm, b->ch_state, on_state, b);
	sh = rmd_health_t_subscribe(b->lcm, b->ch_health, on_health, b);
	while (!stop) {
		int64_t now = rmd_now_ns();

		if (!b->cfg && now >= b->next_ask_ns) {
			rmd_config_request_t req = { .utime = now / RMD_NS_PER_US };

			rmd_config_request_t_publish(b->lcm, b->ch_request, &req);
			b->next_ask_ns = now + ASK_EVERY_NS;
		}
		if (lcm_handle_timeout(b->lcm, 1) < 0 && !stop) {
			tool_log(TOOL_LOG_ERR, "LCM: receive failed on %s", b->url ? b->url : "");
			rc = EXIT_FAIL;
			break;
		}
		take_commands(b);
		hold(b);
	}
	if (stop == 2)
		rc = EXIT_FAIL;
	n = ros2_map_release(&b->map, e);
	if (n) {
		publish_command(b, e, n);
		tool_log(TOOL_LOG_NOTICE, "stopping: enable = 0 sent for the %u motors ROS drove",
			 n);
	}
	rmd_config_t_unsubscribe(b->lcm, sc);
	rmd_state_t_unsubscribe(b->lcm, ss);
	rmd_health_t_unsubscribe(b->lcm, sh);
	return rc;
}

static int parse_u32(const char *s, uint32_t max, uint32_t *out)
{
	char *end;
	unsigned long v;

	errno = 0;
	v = strtoul(s, &end, 10);
	if (errno || end == s || *end || s[0] == '-' || v > max)
		return -EINVAL;
	*out = (uint32_t)v;
	return 0;
}

static int bad_arg(const char *opt, const char *val, const char *what)
{
	tool_log(TOOL_LOG_ERR, "--%s %s: %s", opt, val, what);
	tool_usage_hint(USAGE_LINE, "rmd-ros2 --help");
	return EXIT_USAGE;
}

int main(int argc, char **argv)
{
	static struct bridge b;
	struct option lo[NOPTS + 1];
	char shorts[32], msg[200];
	const char *states = "joint_states", *commands = "joint_commands", *diag = "diagnostics";
	const char *env = getenv("ROS_DOMAIN_ID");
	uint32_t u;
	int c;

	tool_log_init("rmd-ros2", TOOL_LOG_INFO, 0);
	b.prefix = "RMD_";
	b.mode = RMD_COMMAND_T_MODE_POSITION;
	b.max_jump = 0.2;
	if (env && *env && parse_u32(env, 232, &b.domain) < 0) {
		tool_log(TOOL_LOG_ERR, "ROS_DOMAIN_ID=%s: not a domain id (0..232)", env);
		return EXIT_USAGE;
	}
	tool_opts_getopt(opts, NOPTS, lo, shorts, sizeof(shorts));
	opterr = 0;
	while ((c = getopt_long(argc, argv, shorts, lo, NULL)) != -1) {
		switch (c) {
		case OPT_LCM_URL:
			b.url = optarg;
			break;
		case OPT_PREFIX:
			b.prefix = optarg;
			break;
		case OPT_DOMAIN:
			if (parse_u32(optarg, 232, &b.domain) < 0)
				return bad_arg("domain", optarg, "not a domain id (0..232)");
			break;
		case OPT_STATES:
			states = optarg;
			break;
		case OPT_COMMANDS:
			commands = optarg;
			break;
		case OPT_DIAG:
			diag = optarg;
			break;
		case OPT_MODE:
			b.mode = ros2_mode_of(optarg);
			if (b.mode < 0)
				return bad_arg("mode", optarg, "not position, velocity or effort");
			break;
		case OPT_ENABLE:
			b.enable = true;
			break;
		case OPT_HOLD:
			if (parse_u32(optarg, 60000, &u) < 0)
				return bad_arg("hold-ms", optarg, "not a time in ms (0..60000)");
			b.hold_ns = (int64_t)u * RMD_NS_PER_MS;
			break;
		case OPT_MAX_JUMP: {
			char *end;

			b.max_jump = strtod(optarg, &end);
			if (end == optarg || *end || !(b.max_jump >= 0))
				return bad_arg("max-jump", optarg, "not a distance in rad (>= 0)");
			break;
		}
		case OPT_SENSOR_QOS:
			b.sensor_qos = true;
			break;
		case OPT_HELP:
			usage();
			return 0;
		case OPT_VERBOSE:
			b.verbose = true;
			break;
		case OPT_QUIET:
			tool_log_set_level(TOOL_LOG_ERR);
			break;
		case OPT_VERSION:
			tool_print_version("rmd-ros2");
			return 0;
		default:
			tool_log(TOOL_LOG_ERR, "%s",
				 tool_getopt_error(msg, sizeof(msg), c, argv, opts, NOPTS));
			tool_usage_hint(USAGE_LINE, "rmd-ros2 --help");
			return EXIT_USAGE;
		}
	}
	if (optind < argc) {
		tool_log(TOOL_LOG_ERR, "unexpected argument \"%s\"", argv[optind]);
		tool_usage_hint(USAGE_LINE, "rmd-ros2 --help");
		return EXIT_USAGE;
	}
	if (ros_topic(b.states_topic, sizeof(b.states_topic), states, "joint-states") < 0 ||
	    ros_topic(b.commands_topic, sizeof(b.commands_topic), commands, "joint-commands") < 0 ||
	    ros_topic(b.diag_topic, sizeof(b.diag_topic), diag, "diagnostics") < 0)
		return EXIT_USAGE;
	if (strlen(b.prefix) > 32)
		return bad_arg("prefix", b.prefix, "longer than 32 characters");
	channel(b.ch_state, sizeof(b.ch_state), b.prefix, RMD_CHANNEL_STATE);
	channel(b.ch_health, sizeof(b.ch_health), b.prefix, RMD_CHANNEL_HEALTH);
	channel(b.ch_config, sizeof(b.ch_config), b.prefix, RMD_CHANNEL_CONFIG);
	channel(b.ch_request, sizeof(b.ch_request), b.prefix, RMD_CHANNEL_CONFIG_REQUEST);
	channel(b.ch_command, sizeof(b.ch_command), b.prefix, RMD_CHANNEL_COMMAND);
	if (getrandom(&b.controller, sizeof(b.controller), 0) != (ssize_t)sizeof(b.controller))
		b.controller = (int64_t)rmd_now_ns();

	b.lcm = lcm_create(b.url);
	if (!b.lcm) {
		tool_log(TOOL_LOG_ERR, "LCM: cannot open %s (docs/lcm.md)",
			 b.url ? b.url : "the default URL");
		return EXIT_FAIL;
	}
	if (dds_open(&b) < 0) {
		lcm_destroy(b.lcm);
		return EXIT_FAIL;
	}
	signal(SIGINT, on_signal);
	signal(SIGTERM, on_signal);
	c = run(&b);
	dds_delete(b.participant);
	lcm_destroy(b.lcm);
	if (b.cfg)
		rmd_config_t_destroy(b.cfg);
	if (b.state)
		rmd_state_t_destroy(b.state);
	return c;
}
