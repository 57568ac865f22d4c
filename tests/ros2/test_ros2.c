// SPDX-License-Identifier: MIT
/*
 * rmd-ros2 (docs/ros2.md) between a real `rmdd --sim 2` and a DDS
 * participant of this suite's own, built from the same ROS 2 definitions
 * (src/tools/rmd-ros2/ros2_msgs.idl through idlc): what ROS 2 nodes on
 * Cyclone DDS would see and send.  Each test has its own LCM URL and DDS
 * domain, so suites and tests never hear each other.
 *
 * Judged on the wires: rmdd's own rmd.state_t on LCM (the simulated motors'
 * positions as rmdd reads them from the sim bus), every rmd.command_t the
 * bridge sends (RMD_COMMAND, heard by this suite), and the serialized
 * samples on DDS, which tests/ros2/ros2_cdr.py decodes and encodes with
 * rosbags (ROS 2's message definitions and a CDR coder of its own, no code
 * shared with Cyclone DDS).  rosbags is in the venv `make python-venv`
 * makes ($RMD_PYTHON, else build/venv/bin/python3).
 */
#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <lcm/lcm.h>

#include "harness/lcm_loopback.h"
#include "harness/proc.h"
#include "harness/suite.h"
#include "rmd/rmd_command_t.h"
#include "rmd/rmd_config_request_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"
#include "rmd/time.h"
#include "ros2_msgs.h"

#define SUITE "test_ros2"
#define MOTORS 2
#define RING 4096      /* state_t kept: 4 s at 1 kHz */
#define LIMIT_MS 10000 /* a wait for something that takes milliseconds; a busy machine's margin */

struct seen_state {
	int64_t utime;
	double pos[MOTORS], vel[MOTORS], tq[MOTORS];
	int8_t lc[MOTORS];
};

struct fixture {
	char url[96];
	uint32_t domain;
	struct kid *rmdd, *bridge;
	lcm_t *lcm;
	rmd_state_t_subscription_t *s_state;
	rmd_config_t_subscription_t *s_config;
	rmd_health_t_subscription_t *s_health;
	rmd_command_t_subscription_t *s_command;
	rmd_config_t *cfg;
	struct seen_state ring[RING];
	unsigned n_states;
	/* every command_t the bridge sent */
	unsigned n_cmds;
	int first_enable[MOTORS]; /* each motor's first entry's enable, -1: none yet */
	int last_enable[MOTORS];
	rmd_health_t *health;

	dds_entity_t pp, t_states, t_cmds, t_diag, r_states, r_raw, r_diag, w_cmds;
};

static char rmdd_bin[PATH_MAX], bridge_bin[PATH_MAX], python[PATH_MAX], script[PATH_MAX];
static char tmpdir[64];
static bool multicast, have_rosbags;
static unsigned test_no;
static struct fixture *cur; /* for the service of kid waits */

/* ---- LCM: what rmdd says and what the bridge sends it ---------------------------- */

static void on_state(const lcm_recv_buf_t *rb, const char *ch, const rmd_state_t *m, void *u)
{
	struct fixture *f = u;
	struct seen_state *s = &f->ring[f->n_states++ % RING];

	(void)rb;
	(void)ch;
	s->utime = m->utime;
	for (int i = 0; i < MOTORS && i < m->count; i++) {
		s->pos[i] = m->motor[i].position;
		s->vel[i] = m->motor[i].velocity;
		s->tq[i] = m->motor[i].torque;
		s->lc[i] = m->motor[i].lifecycle;
	}
}

static void on_config(const lcm_recv_buf_t *rb, const char *ch, const rmd_config_t *m, void *u)
{
	struct fixture *f = u;

	(void)rb;
	(void)ch;
	if (!f->cfg)
		f->cfg = rmd_config_t_copy(m);
}

static void on_health(const lcm_recv_buf_t *rb, const char *ch, const rmd_health_t *m, void *u)
{
	struct fixture *f = u;

	(void)rb;
	(void)ch;
	if (f->health)
		rmd_health_t_destroy(f->health);
	f->health = rmd_health_t_copy(m);
}

static void on_command(const lcm_recv_buf_t *rb, const char *ch, const rmd_command_t *m, void *u)
{
	struct fixture *f = u;

	(void)rb;
	(void)ch;
	f->n_cmds++;
	for (int i = 0; i < m->count; i++) {
		int k = m->motor[i].index;

		if (k < 0 || k >= MOTORS)
			continue;
		if (f->first_enable[k] < 0)
			f->first_enable[k] = m->motor[i].enable;
		f->last_enable[k] = m->motor[i].enable;
	}
}

static void pump_ms(struct fixture *f, int ms)
{
	int64_t end = rmd_now_ns() + ms * RMD_NS_PER_MS;

	while (rmd_now_ns() < end) {
		lcm_handle_timeout(f->lcm, 2);
		if (f->rmdd)
			kid_read(f->rmdd);
		if (f->bridge)
			kid_read(f->bridge);
	}
}

static void service(int ms)
{
	pump_ms(cur, ms < 1 ? 1 : ms);
}

static const struct seen_state *last_state(const struct fixture *f)
{
	return f->n_states ? &f->ring[(f->n_states - 1) % RING] : NULL;
}

/* ---- fixture -------------------------------------------------------------------------- */

static int group_setup(void **state)
{
	char dir[] = "/tmp/rmd-ros2-XXXXXX";
	const char *py = getenv("RMD_PYTHON");
	const char *build = getenv("BUILD") ? getenv("BUILD") : "build";
	char cmd[PATH_MAX * 2 + 64];

	(void)state;
	multicast = lcm_loopback_ready(SUITE);
	if (find_prog(rmdd_bin, sizeof(rmdd_bin), "RMDD", "rmdd") < 0 ||
	    find_prog(bridge_bin, sizeof(bridge_bin), "RMD_ROS2", "rmd-ros2") < 0)
		return -1;
	assert_non_null(mkdtemp(dir));
	snprintf(tmpdir, sizeof(tmpdir), "%s", dir);
	if (py)
		snprintf(python, sizeof(python), "%s", py);
	else if (snprintf(python, sizeof(python), "%s/venv/bin/python3", build),
		 access(python, X_OK))
		snprintf(python, sizeof(python), "build/venv/bin/python3");
	snprintf(script, sizeof(script), "tests/ros2/ros2_cdr.py");
	snprintf(cmd, sizeof(cmd), "'%s' -c 'import rosbags.typesys' >/dev/null 2>&1", python);
	have_rosbags = access(script, R_OK) == 0 && system(cmd) == 0;
	if (!have_rosbags)
		printf("%s: SKIP the rosbags tests: no %s with rosbags (make python-venv) or no %s\n",
		       SUITE, python, script);
	return 0;
}

static int group_teardown(void **state)
{
	(void)state;
	kid_kill_all();
	rm_tree(tmpdir);
	return 0;
}

static dds_qos_t *qos(bool reliable, int depth)
{
	dds_qos_t *q = dds_create_qos();

	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
	dds_qset_reliability(q, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
			     DDS_INFINITY);
	dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
	return q;
}

static int setup(void **state)
{
	struct fixture *f = calloc(1, sizeof(*f));
	dds_qos_t *q;

	assert_non_null(f);
	*state = f;
	cur = f;
	if (!multicast)
		return 0;
	lcm_test_url(f->url, sizeof(f->url), 47000, 40, test_no);
	f->domain = 1 + (uint32_t)(getpid() % 40) * 5 + test_no % 5;
	test_no++;
	for (int i = 0; i < MOTORS; i++)
		f->first_enable[i] = f->last_enable[i] = -1;
	f->lcm = lcm_create(f->url);
	assert_non_null(f->lcm);
	f->s_state = rmd_state_t_subscribe(f->lcm, "RMD_STATE", on_state, f);
	f->s_config = rmd_config_t_subscribe(f->lcm, "RMD_CONFIG", on_config, f);
	f->s_health = rmd_health_t_subscribe(f->lcm, "RMD_HEALTH", on_health, f);
	f->s_command = rmd_command_t_subscribe(f->lcm, "RMD_COMMAND", on_command, f);

	f->pp = dds_create_participant(f->domain, NULL, NULL);
	assert_true(f->pp > 0);
	f->t_states = dds_create_topic(f->pp, &sensor_msgs_msg_dds__JointState__desc,
				       "rt/joint_states", NULL, NULL);
	f->t_cmds = dds_create_topic(f->pp, &sensor_msgs_msg_dds__JointState__desc,
				     "rt/joint_commands", NULL, NULL);
	f->t_diag = dds_create_topic(f->pp, &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
				     "rt/diagnostics", NULL, NULL);
	assert_true(f->t_states > 0 && f->t_cmds > 0 && f->t_diag > 0);
	/* a reliable reader: what ros2 topic echo asks for by default */
	q = qos(true, 1000);
	f->r_states = dds_create_reader(f->pp, f->t_states, q, NULL);
	f->r_raw = dds_create_reader(f->pp, f->t_states, q, NULL);
	f->r_diag = dds_create_reader(f->pp, f->t_diag, q, NULL);
	dds_delete_qos(q);
	/* topic_based_ros2_control's publisher: rclcpp::QoS(1), reliable */
	q = qos(true, 1);
	f->w_cmds = dds_create_writer(f->pp, f->t_cmds, q, NULL);
	dds_delete_qos(q);
	assert_true(f->r_states > 0 && f->r_raw > 0 && f->r_diag > 0 && f->w_cmds > 0);
	return 0;
}

static int teardown(void **state)
{
	struct fixture *f = *state;

	kid_kill_all();
	if (f->pp > 0)
		dds_delete(f->pp);
	if (f->lcm) {
		rmd_state_t_unsubscribe(f->lcm, f->s_state);
		rmd_config_t_unsubscribe(f->lcm, f->s_config);
		rmd_health_t_unsubscribe(f->lcm, f->s_health);
		rmd_command_t_unsubscribe(f->lcm, f->s_command);
		lcm_destroy(f->lcm);
	}
	if (f->cfg)
		rmd_config_t_destroy(f->cfg);
	if (f->health)
		rmd_health_t_destroy(f->health);
	free(f);
	cur = NULL;
	return 0;
}

static struct fixture *bridge_or_skip(void **state)
{
	struct fixture *f = *state;

	if (!multicast) {
		print_message("skipped: no multicast on loopback (LCM)\n");
		skip();
	}
	return f;
}

static bool all_ready(const struct fixture *f)
{
	const struct seen_state *s = last_state(f);

	if (!s)
		return false;
	for (int i = 0; i < MOTORS; i++)
		if (s->lc[i] != RMD_STATE_T_LC_READY)
			return false;
	return true;
}

static bool all_enabled(const struct fixture *f)
{
	const struct seen_state *s = last_state(f);

	return s && s->lc[0] == RMD_STATE_T_LC_ENABLED && s->lc[1] == RMD_STATE_T_LC_ENABLED;
}

/* rmdd --sim 2 with every motor READY and its config_t; then rmd-ros2 (args after its own). */
static void start_bridge(struct fixture *f, const char *const *extra);

static void start(struct fixture *f, const char *const *extra)
{
	const char *rargv[] = { rmdd_bin, "--sim", "2", "--lcm-url", f->url, NULL };
	int64_t end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;

	f->rmdd = kid_spawn("rmdd", rargv, NULL, 0);
	while (!f->cfg || !all_ready(f)) {
		rmd_config_request_t req = { 0 };

		rmd_config_request_t_publish(f->lcm, "RMD_CONFIG_REQUEST", &req);
		pump_ms(f, 50);
		if (kid_poll_exit(f->rmdd))
			fail_msg("rmdd exited: %s", kid_tail(f->rmdd));
		if (rmd_now_ns() > end)
			fail_msg("rmdd --sim 2: no config_t or motors not READY within %d ms:\n%s",
				 LIMIT_MS, kid_tail(f->rmdd));
	}
	assert_int_equal(f->cfg->motor_count, MOTORS);
	start_bridge(f, extra);
}

/* rmd-ros2 on this test's URL and domain, with extra after its own arguments. */
static void start_bridge(struct fixture *f, const char *const *extra)
{
	char domain[16];
	const char *bargv[16] = { bridge_bin, "--lcm-url", f->url, "--domain", domain };
	unsigned n = 5;

	snprintf(domain, sizeof(domain), "%" PRIu32, f->domain);
	for (; extra && *extra && n < 15; extra++)
		bargv[n++] = *extra;
	bargv[n] = NULL;
	f->bridge = kid_spawn("rmd-ros2", bargv, NULL, 0);
	kid_wait_output(f->bridge, "publishing rt/joint_states", LIMIT_MS, service);
}

/* Wait until writer w has a reader (or reader r a writer) of the other side. */
static void wait_matched(struct fixture *f, dds_entity_t w, dds_entity_t r, const char *what)
{
	int64_t end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;

	for (;;) {
		dds_publication_matched_status_t pm = { 0 };
		dds_subscription_matched_status_t sm = { 0 };

		if (w)
			dds_get_publication_matched_status(w, &pm);
		if (r)
			dds_get_subscription_matched_status(r, &sm);
		if ((!w || pm.current_count > 0) && (!r || sm.current_count > 0))
			return;
		if (rmd_now_ns() > end)
			fail_msg("DDS domain %" PRIu32
				 ": %s not matched within %d ms; rmd-ros2:\n%s",
				 f->domain, what, LIMIT_MS, kid_tail(f->bridge));
		pump_ms(f, 10);
	}
}

/* A JointState command as topic_based_ros2_control writes it (every array, one per name). */
static void send_command(struct fixture *f, const char *const *names, const double *pos, unsigned n,
			 unsigned n_pos)
{
	sensor_msgs_msg_dds__JointState_ js = { 0 };
	double zeros[MOTORS + 2] = { 0 };

	js.header.frame_id = (char *)"";
	js.name._buffer = (char **)names;
	js.name._length = js.name._maximum = n;
	js.position._buffer = (double *)pos;
	js.position._length = js.position._maximum = n_pos;
	js.velocity._buffer = js.effort._buffer = zeros;
	js.velocity._length = js.velocity._maximum = n;
	js.effort._length = js.effort._maximum = n;
	assert_int_equal(dds_write(f->w_cmds, &js), DDS_RETCODE_OK);
}

static bool at(const struct fixture *f, const double *target, double tol)
{
	const struct seen_state *s = last_state(f);

	if (!s)
		return false;
	for (int i = 0; i < MOTORS; i++)
		if (s->lc[i] != RMD_STATE_T_LC_ENABLED || !(fabs(s->pos[i] - target[i]) < tol))
			return false;
	return true;
}

/*
 * Commands at 100 Hz, where the motors are until they are ENABLED, then to
 * target, until state_t shows both there.
 */
static void drive_to(struct fixture *f, const double *target)
{
	const char *names[MOTORS] = { f->cfg->motor[0].name, f->cfg->motor[1].name };
	int64_t end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;

	while (!at(f, target, 0.01)) {
		const struct seen_state *s = last_state(f);
		bool enabled = s && s->lc[0] == RMD_STATE_T_LC_ENABLED &&
			       s->lc[1] == RMD_STATE_T_LC_ENABLED;

		/* as a joint trajectory controller starts: where the motors are, then the target */
		send_command(f, names, enabled ? target : s->pos, MOTORS, MOTORS);
		pump_ms(f, 10);
		if (rmd_now_ns() > end)
			fail_msg("motors not ENABLED at %.3f %.3f within %d ms (now %d %.3f, %d "
				 "%.3f); %u command_t sent; rmd-ros2:\n%s\nrmdd:\n%s",
				 target[0], target[1], LIMIT_MS, s ? s->lc[0] : -1,
				 s ? s->pos[0] : NAN, s ? s->lc[1] : -1, s ? s->pos[1] : NAN,
				 f->n_cmds, kid_tail(f->bridge), kid_tail(f->rmdd));
	}
}

/* A ROS stamp back on rmdd's CLOCK_MONOTONIC, in µs, with this process's offset. */
static int64_t stamp_utime(int32_t sec, uint32_t nsec)
{
	int64_t mono;
	int64_t off = rmd_realtime_offset_ns(&mono);

	return ((int64_t)sec * RMD_NS_PER_S + nsec - off) / RMD_NS_PER_US;
}

/* The state_t a stamp came from: within 200 µs (the two processes' clock offsets differ by less). */
static const struct seen_state *state_of_stamp(const struct fixture *f, int32_t sec, uint32_t nsec)
{
	int64_t u = stamp_utime(sec, nsec);
	unsigned n = f->n_states < RING ? f->n_states : RING;

	for (unsigned i = 0; i < n; i++) {
		const struct seen_state *s = &f->ring[(f->n_states - 1 - i) % RING];

		if (llabs(s->utime - u) < 200)
			return s;
	}
	return NULL;
}

/* The utime of the oldest state_t the ring still holds (0: none yet). */
static int64_t oldest_kept(const struct fixture *f)
{
	if (!f->n_states)
		return 0;
	return f->ring[f->n_states < RING ? 0 : f->n_states % RING].utime;
}

static bool same(double a, double b)
{
	return (isnan(a) && isnan(b)) || a == b;
}

/* ---- tests -------------------------------------------------------------------------- */

/*
 * Joint commands move the motors: the bridge runs rmdd's enable procedure
 * (its first entry for each motor is enable = 0, then enable = 1), the
 * simulated motors reach the targets (state_t), and on SIGTERM it sends
 * enable = 0 and they go READY.
 */
static void test_joint_commands_move_motors(void **state)
{
	struct fixture *f = bridge_or_skip(state);
	const char *extra[] = { "--enable", NULL };
	const double target[MOTORS] = { 0.6, -0.4 };
	int64_t end;
	unsigned n;

	start(f, extra);
	wait_matched(f, f->w_cmds, 0, "the joint-command writer");
	drive_to(f, target);
	for (int i = 0; i < MOTORS; i++) {
		assert_int_equal(f->first_enable[i], 0);
		assert_int_equal(f->last_enable[i], 1);
	}
	/* no --hold-ms: one command_t per ROS command, none when ROS is silent */
	pump_ms(f, 20);
	n = f->n_cmds;
	pump_ms(f, 200);
	assert_int_equal(f->n_cmds, n);
	kill(f->bridge->pid, SIGTERM);
	if (kid_wait_exit(f->bridge, LIMIT_MS, service) != 0)
		fail_msg("rmd-ros2 exited %d after SIGTERM:\n%s", f->bridge->status,
			 kid_tail(f->bridge));
	end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;
	while (!all_ready(f) && rmd_now_ns() < end)
		pump_ms(f, 10);
	for (int i = 0; i < MOTORS; i++)
		assert_int_equal(f->last_enable[i], 0);
	assert_true(all_ready(f));
}

/*
 * rt/joint_states is rmdd's state_t: every sample's stamp is a state_t's
 * utime, its names config_t's, its positions, velocities and efforts that
 * state_t's exactly (SI, no conversion), while the motors move.
 */
static void test_joint_states_are_state_t(void **state)
{
	struct fixture *f = bridge_or_skip(state);
	const char *extra[] = { "--enable", NULL };
	const double target[MOTORS] = { -0.5, 0.7 };
	unsigned matched = 0, unmatched = 0, older = 0;
	double lo = INFINITY, hi = -INFINITY;

	start(f, extra);
	wait_matched(f, f->w_cmds, f->r_states, "the joint states and commands");
	drive_to(f, target);
	pump_ms(f, 300);
	for (;;) {
		void *samples[64] = { NULL };
		dds_sample_info_t info[64];
		int n = dds_take(f->r_states, samples, info, 64, 64);

		if (n <= 0)
			break;
		for (int i = 0; i < n; i++) {
			const sensor_msgs_msg_dds__JointState_ *js = samples[i];
			const struct seen_state *s;

			if (!info[i].valid_data)
				continue;
			assert_int_equal(js->name._length, MOTORS);
			assert_int_equal(js->position._length, MOTORS);
			assert_int_equal(js->velocity._length, MOTORS);
			assert_int_equal(js->effort._length, MOTORS);
			for (int k = 0; k < MOTORS; k++)
				assert_string_equal(js->name._buffer[k], f->cfg->motor[k].name);
			s = state_of_stamp(f, js->header.stamp.sec, js->header.stamp.nanosec);
			if (!s && stamp_utime(js->header.stamp.sec, js->header.stamp.nanosec) <
					  oldest_kept(f)) {
				older++; /* from before the ring's 4 s: a busy machine's slow start */
				continue;
			}
			if (!s) {
				unmatched++;
				continue;
			}
			for (int k = 0; k < MOTORS; k++) {
				if (!same(js->position._buffer[k], s->pos[k]) ||
				    !same(js->velocity._buffer[k], s->vel[k]) ||
				    !same(js->effort._buffer[k], s->tq[k]))
					fail_msg("motor %d at utime %" PRId64
						 ": JointState %.17g %.17g "
						 "%.17g, state_t %.17g %.17g %.17g",
						 k, s->utime, js->position._buffer[k],
						 js->velocity._buffer[k], js->effort._buffer[k],
						 s->pos[k], s->vel[k], s->tq[k]);
				if (isfinite(s->pos[k]) && s->pos[k] < lo)
					lo = s->pos[k];
				if (isfinite(s->pos[k]) && s->pos[k] > hi)
					hi = s->pos[k];
			}
			matched++;
		}
		dds_return_loan(f->r_states, samples, n);
	}
	print_message("%u JointState samples matched a state_t, %u did not, %u older than the "
		      "kept ones; positions %.3f .. %.3f rad\n",
		      matched, unmatched, older, lo, hi);
	/* a state_t this suite's LCM lost on a busy machine leaves its sample unjudged, no more */
	assert_true(matched >= 200 && unmatched * 10 <= matched);
	/* they moved while judged: from near 0 to the targets */
	assert_true(hi - lo > 1.0);
}

/*
 * A joint command with a name rmdd has no motor of, a NaN, a position
 * array shorter than its names, or a first position 2.5 rad from where a
 * motor is (--max-jump 2) is refused whole: the bridge sends rmdd no
 * command_t at all, the motors stay READY where they were, and rt/diagnostics
 * counts each kind.
 */
static void test_bad_commands_move_nothing(void **state)
{
	struct fixture *f = bridge_or_skip(state);
	const char *extra[] = { "--enable", "--max-jump", "2", NULL };
	const char *unknown[MOTORS] = { "no_such_joint", NULL };
	const char *names[MOTORS];
	const double nan_pos[MOTORS] = { NAN, 0.0 }, pos[MOTORS] = { 0.0, 0.0 };
	const double leap[MOTORS] = { 2.5, 0.0 };
	const struct seen_state *s;
	double before[MOTORS];
	static const char *const kinds[4] = { "ros_rejected_name", "ros_rejected_nonfinite",
					      "ros_rejected_shape", "ros_rejected_jump" };
	long seen[4] = { 0, 0, 0, 0 };

	start(f, extra);
	names[0] = f->cfg->motor[0].name;
	names[1] = f->cfg->motor[1].name;
	unknown[1] = names[1];
	wait_matched(f, f->w_cmds, f->r_diag, "the joint commands and diagnostics");
	s = last_state(f);
	before[0] = s->pos[0];
	before[1] = s->pos[1];
	for (int k = 0; k < 30; k++) {
		send_command(f, unknown, pos, MOTORS, MOTORS);
		send_command(f, names, nan_pos, MOTORS, MOTORS);
		send_command(f, names, pos, MOTORS, 1);
		send_command(f, names, leap, MOTORS, MOTORS);
		pump_ms(f, 10);
	}
	pump_ms(f, 300);
	assert_int_equal(f->n_cmds, 0);
	assert_true(all_ready(f));
	s = last_state(f);
	for (int i = 0; i < MOTORS; i++)
		assert_true(fabs(s->pos[i] - before[i]) < 1e-3);
	kid_wait_output(f->bridge, "refused (name): name \"no_such_joint\"", LIMIT_MS, service);
	kid_wait_output(f->bridge, "refused (non-finite)", LIMIT_MS, service);
	kid_wait_output(f->bridge, "refused (shape)", LIMIT_MS, service);
	kid_wait_output(f->bridge, "refused (leap): position 2.5 of", LIMIT_MS, service);
	kid_wait_output(f->bridge, "more than 2 rad away", LIMIT_MS, service);
	/* the counts, as a ROS node reads them on /diagnostics */
	for (int64_t end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;
	     !(seen[0] && seen[1] && seen[2] && seen[3]) && rmd_now_ns() < end;) {
		void *samples[16] = { NULL };
		dds_sample_info_t info[16];
		int n = dds_take(f->r_diag, samples, info, 16, 16);

		for (int i = 0; i < n; i++) {
			const diagnostic_msgs_msg_dds__DiagnosticArray_ *da = samples[i];
			const diagnostic_msgs_msg_dds__DiagnosticStatus_ *st;

			if (!info[i].valid_data || da->status._length < 1)
				continue;
			st = &da->status._buffer[0];
			assert_string_equal(st->name, "rmdd");
			for (uint32_t k = 0; k < st->values._length; k++) {
				const char *key = st->values._buffer[k].key;
				long v = strtol(st->values._buffer[k].value, NULL, 10);

				/* 30 sent of each; ROS's default QoS (keep last 10) may drop some
				 * on a loaded machine: each kind counted, none more than sent */
				for (int j = 0; j < 4; j++) {
					if (strcmp(key, kinds[j]))
						continue;
					assert_in_range(v, 0, 30);
					seen[j] = v;
				}
			}
		}
		if (n > 0)
			dds_return_loan(f->r_diag, samples, n);
		pump_ms(f, 20);
	}
	if (!(seen[0] && seen[1] && seen[2] && seen[3]))
		fail_msg(
			"/diagnostics counted name %ld, non-finite %ld, shape %ld, leap %ld of 30 each",
			seen[0], seen[1], seen[2], seen[3]);
}

/* Without --enable the bridge publishes but sends rmdd nothing: the motors stay READY. */
static void test_no_enable_no_motion(void **state)
{
	struct fixture *f = bridge_or_skip(state);
	const double pos[MOTORS] = { 0.5, 0.5 };
	const char *names[MOTORS];

	start(f, NULL);
	names[0] = f->cfg->motor[0].name;
	names[1] = f->cfg->motor[1].name;
	wait_matched(f, f->w_cmds, f->r_states, "the joint states and commands");
	for (int k = 0; k < 50; k++) {
		send_command(f, names, pos, MOTORS, MOTORS);
		pump_ms(f, 10);
	}
	kid_wait_output(f->bridge, "refused: rmd-ros2 runs without --enable", LIMIT_MS, service);
	assert_int_equal(f->n_cmds, 0);
	assert_true(all_ready(f));
}

/*
 * --hold-ms: the last command goes to rmdd again (every 10 ms) for the hold
 * after ROS fell silent, then no more, and rmdd's own watchdog applies its
 * safe action; without it (every other test) nothing follows ROS's last
 * command.  Judged on the command_t rmdd receives.
 */
static void test_hold_repeats_then_stops(void **state)
{
	struct fixture *f = bridge_or_skip(state);
	const char *extra[] = { "--enable", "--hold-ms", "1000", NULL };
	const double here[MOTORS] = { 0.0, 0.0 };
	unsigned n0, n1, n2;
	int64_t end;

	start(f, extra);
	wait_matched(f, f->w_cmds, 0, "the joint-command writer");
	drive_to(f, here);
	n0 = f->n_cmds;
	pump_ms(f, 300);
	n1 = f->n_cmds;
	/* about 30; a busy machine may hold rmd-ros2 off some of the time */
	if (n1 - n0 < 5)
		fail_msg("%u command_t in the 300 ms after ROS's last command, with --hold-ms 1000",
			 n1 - n0);
	assert_true(all_enabled(f));
	pump_ms(f, 1200);
	n1 = f->n_cmds;
	pump_ms(f, 300);
	n2 = f->n_cmds;
	if (n2 != n1)
		fail_msg("%u command_t 1.5 s after ROS's last command (--hold-ms 1000)", n2 - n1);
	end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;
	while (last_state(f)->lc[0] != RMD_STATE_T_LC_SAFE && rmd_now_ns() < end)
		pump_ms(f, 10);
	assert_int_equal(last_state(f)->lc[0], RMD_STATE_T_LC_SAFE);
	kid_wait_output(f->bridge, "left enabled (now safe)", LIMIT_MS, service);
}

/* What discovery says of the one endpoint of the bridge matched with ours. */
static dds_builtintopic_endpoint_t *bridge_endpoint(dds_entity_t ours, bool ours_is_reader)
{
	dds_instance_handle_t h[4];
	int n = ours_is_reader ? dds_get_matched_publications(ours, h, 4) :
				 dds_get_matched_subscriptions(ours, h, 4);
	dds_builtintopic_endpoint_t *ep;

	assert_int_equal(n, 1);
	ep = ours_is_reader ? dds_get_matched_publication_data(ours, h[0]) :
			      dds_get_matched_subscription_data(ours, h[0]);
	assert_non_null(ep);
	return ep;
}

/* ep: topic, type, reliability and durability as a ROS 2 node on rmw_cyclonedds_cpp sees them. */
static void assert_endpoint(const dds_builtintopic_endpoint_t *ep, const char *topic,
			    const char *type, dds_reliability_kind_t rel)
{
	dds_reliability_kind_t r;
	dds_durability_kind_t d;
	dds_duration_t block;

	assert_string_equal(ep->topic_name, topic);
	assert_string_equal(ep->type_name, type);
	assert_true(dds_qget_reliability(ep->qos, &r, &block));
	assert_int_equal(r, rel);
	assert_true(dds_qget_durability(ep->qos, &d));
	assert_int_equal(d, DDS_DURABILITY_VOLATILE);
}

/*
 * The bridge's endpoints as discovery announces them to other participants:
 * ROS 2's topic and type names, the default QoS (reliable, volatile) for the
 * joint states and diagnostics, a best-effort command reader; with
 * --sensor-qos, best-effort joint states, which a reliable reader (ROS 2's
 * default subscription) then does not match.
 */
static void test_endpoints_as_ros2_sees_them(void **state)
{
	struct fixture *f = bridge_or_skip(state);
	const char *extra[] = { "--sensor-qos", NULL };
	dds_builtintopic_endpoint_t *ep;
	dds_entity_t be;
	dds_qos_t *q;

	start(f, NULL);
	wait_matched(f, f->w_cmds, f->r_states, "the joint states and commands");
	wait_matched(f, 0, f->r_diag, "the diagnostics");
	ep = bridge_endpoint(f->r_states, true);
	assert_endpoint(ep, "rt/joint_states", "sensor_msgs::msg::dds_::JointState_",
			DDS_RELIABILITY_RELIABLE);
	dds_builtintopic_free_endpoint(ep);
	ep = bridge_endpoint(f->r_diag, true);
	assert_endpoint(ep, "rt/diagnostics", "diagnostic_msgs::msg::dds_::DiagnosticArray_",
			DDS_RELIABILITY_RELIABLE);
	dds_builtintopic_free_endpoint(ep);
	ep = bridge_endpoint(f->w_cmds, false);
	assert_endpoint(ep, "rt/joint_commands", "sensor_msgs::msg::dds_::JointState_",
			DDS_RELIABILITY_BEST_EFFORT);
	dds_builtintopic_free_endpoint(ep);

	kill(f->bridge->pid, SIGTERM);
	assert_int_equal(kid_wait_exit(f->bridge, LIMIT_MS, service), 0);
	kid_free(f->bridge);
	f->bridge = NULL;
	q = qos(false, 5);
	be = dds_create_reader(f->pp, f->t_states, q, NULL);
	dds_delete_qos(q);
	assert_true(be > 0);
	start_bridge(f, extra);
	wait_matched(f, 0, be, "a best-effort joint-state reader");
	ep = bridge_endpoint(be, true);
	assert_endpoint(ep, "rt/joint_states", "sensor_msgs::msg::dds_::JointState_",
			DDS_RELIABILITY_BEST_EFFORT);
	dds_builtintopic_free_endpoint(ep);
	/* the reliable reader: still no writer (QoS mismatch), while the other is served */
	pump_ms(f, 300);
	{
		dds_subscription_matched_status_t sm;

		dds_get_subscription_matched_status(f->r_states, &sm);
		assert_int_equal(sm.current_count, 0);
	}
}

/* ---- rosbags: the bytes on the wire, read and written by ROS 2's own definitions --------- */

static struct fixture *rosbags_or_skip(void **state)
{
	struct fixture *f = bridge_or_skip(state);

	if (!have_rosbags) {
		print_message("skipped: no Python with rosbags (make python-venv)\n");
		skip();
	}
	return f;
}

/* Up to max serialized samples of reader r into DIR/prefix.N; their count. */
static unsigned take_raw(struct fixture *f, dds_entity_t r, const char *prefix, unsigned max,
			 char files[][PATH_MAX])
{
	unsigned got = 0;
	int64_t end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;

	while (got < max && rmd_now_ns() < end) {
		struct ddsi_serdata *sd[8];
		dds_sample_info_t info[8];
		int n = dds_takecdr(r, sd, 8, info, DDS_ANY_STATE);

		for (int i = 0; i < n; i++) {
			uint32_t size = ddsi_serdata_size(sd[i]);
			unsigned char *buf = malloc(size);
			FILE *out;

			if (info[i].valid_data && got < max) {
				assert_non_null(buf);
				ddsi_serdata_to_ser(sd[i], 0, size, buf);
				snprintf(files[got], PATH_MAX, "%s/%s.%u", tmpdir, prefix, got);
				out = fopen(files[got], "wb");
				assert_non_null(out);
				assert_int_equal(fwrite(buf, 1, size, out), size);
				fclose(out);
				got++;
			}
			free(buf);
			ddsi_serdata_unref(sd[i]);
		}
		pump_ms(f, 5);
	}
	return got;
}

/* python ros2_cdr.py args... to its end, exit 0; its output. */
static char *run_cdr(const char *const *args, unsigned n)
{
	const char *argv[64] = { python, script };
	struct run r = { 0 };
	char *out;

	for (unsigned i = 0; i < n && i < 60; i++)
		argv[2 + i] = args[i];
	run_prog(&r, python, argv + 1, NULL);
	if (r.status != 0)
		fail_msg("ros2_cdr.py %s: exit %d:\n%s%s", args[0], r.status, r.out, r.err);
	out = strdup(r.out);
	run_free(&r);
	return out;
}

/*
 * The serialized JointState and DiagnosticArray samples on the wire, as
 * rosbags decodes them with ROS 2's Humble and Jazzy definitions: rosbags
 * encodes each again to the same bytes, and the values are rmdd's state_t
 * (the sample's stamp names it) and config_t's names.
 */
static void test_cdr_read_by_rosbags(void **state)
{
	struct fixture *f = rosbags_or_skip(state);
	static char files[40][PATH_MAX];
	const char *args[41];
	const char *extra[] = { "--enable", NULL };
	const double target[MOTORS] = { 0.4, 0.4 };
	unsigned n, lines = 0, unmatched = 0;
	char *out, *line, *save;

	start(f, extra);
	wait_matched(f, f->w_cmds, f->r_raw, "the joint states and commands");
	drive_to(f, target);
	n = take_raw(f, f->r_raw, "js", 40, files);
	assert_int_equal(n, 40);
	args[0] = "joint-state";
	for (unsigned i = 0; i < n; i++)
		args[1 + i] = files[i];
	out = run_cdr(args, n + 1);
	for (line = strtok_r(out, "\n", &save); line; line = strtok_r(NULL, "\n", &save)) {
		char name[MOTORS][64], frame[64];
		double p[MOTORS], v[MOTORS], t[MOTORS];
		int32_t sec;
		uint32_t nsec;
		unsigned cnt;
		const struct seen_state *s;

		if (sscanf(line,
			   "js %" SCNd32 " %" SCNu32 " %63s %u %63s %lf %lf %lf %63s %lf %lf %lf",
			   &sec, &nsec, frame, &cnt, name[0], &p[0], &v[0], &t[0], name[1], &p[1],
			   &v[1], &t[1]) != 12)
			fail_msg("ros2_cdr.py: unexpected line \"%s\"", line);
		assert_int_equal(cnt, MOTORS);
		s = state_of_stamp(f, sec, nsec);
		lines++;
		if (!s) {
			unmatched++;
			continue;
		}
		for (int k = 0; k < MOTORS; k++) {
			assert_string_equal(name[k], f->cfg->motor[k].name);
			if (!same(p[k], s->pos[k]) || !same(v[k], s->vel[k]) ||
			    !same(t[k], s->tq[k]))
				fail_msg(
					"rosbags read %s %.17g %.17g %.17g, state_t has %.17g %.17g "
					"%.17g",
					name[k], p[k], v[k], t[k], s->pos[k], s->vel[k], s->tq[k]);
		}
	}
	free(out);
	assert_int_equal(lines, n);
	/* a state_t this suite's LCM lost leaves its sample unjudged, no more */
	assert_true(unmatched * 10 <= n);

	n = take_raw(f, f->r_diag, "da", 3, files);
	assert_int_equal(n, 3);
	args[0] = "diagnostics";
	for (unsigned i = 0; i < n; i++)
		args[1 + i] = files[i];
	out = run_cdr(args, n + 1);
	print_message("rosbags read /diagnostics:\n%.1500s\n", out);
	assert_non_null(strstr(out, "\nst 0 rmdd|watchdog "));
	for (int k = 0; k < MOTORS; k++) {
		char want[96];

		snprintf(want, sizeof(want), "\nst 0 rmdd/%s|enabled, ros running|sim",
			 f->cfg->motor[k].name);
		if (!strstr(out, want))
			fail_msg("no \"%s\" in:\n%s", want + 1, out);
	}
	free(out);
}

/*
 * A JointState serialized by rosbags (as topic_based_ros2_control would
 * publish it), written onto rt/joint_commands as those bytes
 * (dds_writecdr), moves the motors there.
 */
static void test_rosbags_command_moves(void **state)
{
	struct fixture *f = rosbags_or_skip(state);
	const char *extra[] = { "--enable", NULL };
	const double target[MOTORS] = { -0.3, 0.45 };
	double here[MOTORS];
	char path[PATH_MAX], p0[32], p1[32];
	const char *args[7];
	unsigned char buf[4096];
	size_t len;
	FILE *in;
	struct ddsi_serdata *sd[1];
	const struct ddsi_sertype *type;
	dds_entity_t scratch, w, r;
	int64_t end;

	start(f, extra);
	wait_matched(f, f->w_cmds, 0, "the joint-command writer");
	snprintf(path, sizeof(path), "%s/command.cdr", tmpdir);
	snprintf(p0, sizeof(p0), "%.17g", target[0]);
	snprintf(p1, sizeof(p1), "%.17g", target[1]);
	args[0] = "command";
	args[1] = path;
	args[2] = "0";
	args[3] = f->cfg->motor[0].name;
	args[4] = p0;
	args[5] = f->cfg->motor[1].name;
	args[6] = p1;
	free(run_cdr(args, 7));
	in = fopen(path, "rb");
	assert_non_null(in);
	len = fread(buf, 1, sizeof(buf), in);
	fclose(in);
	assert_true(len > 4 && len < sizeof(buf));

	/*
	 * Enabled where they are first, the bytes are then a move (and sent at
	 * once after: a pause past rmdd's command timeout would trip them SAFE,
	 * and rmd-ros2 does not enable a motor twice).
	 */
	memcpy(here, last_state(f)->pos, sizeof(here));
	drive_to(f, here);
	/* the JointState sertype of this participant: from a sample of a topic of its own */
	scratch = dds_create_topic(f->pp, &sensor_msgs_msg_dds__JointState__desc,
				   "rmd_ros2_scratch", NULL, NULL);
	w = dds_create_writer(f->pp, scratch, NULL, NULL);
	r = dds_create_reader(f->pp, scratch, NULL, NULL);
	{
		sensor_msgs_msg_dds__JointState_ js = { 0 };

		js.header.frame_id = (char *)"";
		assert_int_equal(dds_write(w, &js), DDS_RETCODE_OK);
	}
	for (end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;; pump_ms(f, 5)) {
		dds_sample_info_t info;

		if (dds_takecdr(r, sd, 1, &info, DDS_ANY_STATE) == 1)
			break;
		assert_true(rmd_now_ns() < end);
	}
	type = sd[0]->type;
	end = rmd_now_ns() + LIMIT_MS * RMD_NS_PER_MS;
	while (!at(f, target, 0.01)) {
		ddsrt_iovec_t iov = { .iov_base = buf, .iov_len = (ddsrt_iov_len_t)len };
		struct ddsi_serdata *cmd = ddsi_serdata_from_ser_iov(type, SDK_DATA, 1, &iov, len);

		assert_non_null(cmd);
		assert_int_equal(dds_writecdr(f->w_cmds, cmd), DDS_RETCODE_OK);
		pump_ms(f, 10);
		if (rmd_now_ns() > end)
			fail_msg("rosbags' command: motors not at %.3f %.3f within %d ms; "
				 "rmd-ros2:\n%s",
				 target[0], target[1], LIMIT_MS, kid_tail(f->bridge));
	}
	ddsi_serdata_unref(sd[0]);
}

int main(void)
{
	static struct CMUnitTest tests[] = {
		cmocka_unit_test(test_joint_commands_move_motors),
		cmocka_unit_test(test_joint_states_are_state_t),
		cmocka_unit_test(test_bad_commands_move_nothing),
		cmocka_unit_test(test_no_enable_no_motion),
		cmocka_unit_test(test_hold_repeats_then_stops),
		cmocka_unit_test(test_endpoints_as_ros2_sees_them),
		cmocka_unit_test(test_cdr_read_by_rosbags),
		cmocka_unit_test(test_rosbags_command_moves),
	};

	suite_fixture(tests, SUITE_N(tests), setup, teardown);
	return SUITE_RUN(SUITE, tests, group_setup, group_teardown);
}
