// SPDX-License-Identifier: MIT
/*
 * The physics behind a simulated motor (rmd/sim_body.h, docs/physics.md),
 * judged by what the motor says: its 0x92 replies (multi-turn angle,
 * 0.01 deg) decoded by the real codec, in the simulator's own time (the
 * test's clock `now`, so nothing depends on the machine's load).  The
 * pendulum is tests/data/physics/pendulum.xml: a 1 kg bob 0.5 m below a
 * hinge, 1e-4 kg·m² about its centre; the motor adds its own inertia
 * (armature) and friction (damping) to the hinge.
 *
 * Needs the physics module: $RMD_PHYSICS_MODULE, else build/lib beside
 * the suite (build/tests/unit/..); without MuJoCo the suite is skipped.
 * Data: tests/data/physics under the repository root ($RMD_SRCDIR).
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "rmd/codec.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/sim.h"
#include "rmd/sim_body.h"
#include "rmd/sim_setup.h"
#include "harness/pendulum.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)
#define G 9.81
#define MASS 1.0
#define LEN 0.5
#define I_BOB (MASS * LEN * LEN + 1e-4)
#define J_MOTOR 0.001 /* the motor's inertia_kgm2: the hinge's armature */
#define KT 1.0

static int64_t now;
static char model_path[PATH_MAX];
static bool have_module;

/* A model file of the data folder. */
static void data_path(char *out, size_t len, const char *name)
{
	const char *dir = getenv("RMD_SRCDIR");

	snprintf(out, len, "%s/tests/data/physics/%s", dir && dir[0] ? dir : ".", name);
}

/* The module beside the suite (build/tests/unit/x -> build/lib/), unless the caller chose one. */
static int group_setup(void **state)
{
	const char *env = getenv(RMD_PHYSICS_MODULE_ENV);
	char exe[PATH_MAX - 64], path[PATH_MAX];
	ssize_t n;

	(void)state;
	data_path(model_path, sizeof(model_path), "pendulum.xml");
	if (!env || !env[0]) {
		n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
		assert_true(n > 0);
		exe[n] = '\0';
		*strrchr(exe, '/') = '\0';
		snprintf(path, sizeof(path), "%s/../../lib/rmd-physics.so", exe);
		setenv(RMD_PHYSICS_MODULE_ENV, path, 1);
	}
	have_module = access(getenv(RMD_PHYSICS_MODULE_ENV), R_OK) == 0;
	if (!have_module)
		fprintf(stderr, "test_sim_body: no physics module (%s): built without MuJoCo\n",
			getenv(RMD_PHYSICS_MODULE_ENV));
	return 0;
}

/* sim.physics of one motor (configuration motor 0) on joint `joint` of model `path`. */
static void setup_of(struct rmd_sim_physics_setup *ps, const char *path, const char *joint)
{
	memset(ps, 0, sizeof(*ps));
	snprintf(ps->model, sizeof(ps->model), "%s", path);
	snprintf(ps->source, sizeof(ps->source), "test.yaml");
	ps->model_line = 7;
	ps->rate_hz = RMD_SIM_PHYSICS_RATE_HZ;
	ps->substeps = 1;
	ps->joints[0] = (struct rmd_sim_physics_joint){ .motor = 0, .line = 9 };
	snprintf(ps->joints[0].joint, sizeof(ps->joints[0].joint), "%s", joint);
	ps->n_joints = 1;
}

/* The pendulum's motor: no brake, kt 1 N·m/A, no friction unless asked, at start_deg. */
static void pendulum(struct rmd_sim_body **b, struct rmd_sim_motor *m, double start_deg,
		     double viscous)
{
	struct rmd_sim_physics_setup ps;
	struct rmd_sim_motor_params p;
	char err[512];

	if (!have_module)
		skip();
	setup_of(&ps, model_path, "swing");
	assert_int_equal(rmd_sim_body_load(b, &ps, err, sizeof(err)), 0);
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.has_brake = false;
	p.kt_nm_a = KT;
	p.coulomb_nm = 0.0;
	p.viscous_nm_s_rad = viscous;
	p.inertia_kgm2 = J_MOTOR;
	p.start_angle_deg = start_deg;
	now = 0;
	rmd_sim_motor_init(m, &p, now);
	assert_int_equal(rmd_sim_body_attach(*b, 0, m), 1);
}

/* Send f at now; its one reply decoded. */
static struct rmd_msg ask(struct rmd_sim_motor *m, const struct rmd_msg *req)
{
	struct rmd_frame f, out[8];
	struct rmd_msg msg;

	assert_int_equal(rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, 1, req, &f), 0);
	assert_int_equal(rmd_sim_motor_receive(m, now, &f, out, 8), 1);
	assert_int_equal(rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, &out[0], &msg, NULL), 0);
	return msg;
}

/* The angle the motor reports (0x92, V3 §2.11), deg. */
static double angle_deg(struct rmd_sim_motor *m)
{
	struct rmd_msg req = { .cmd = 0x92 }, r = ask(m, &req);

	assert_true(rmd_msg_has(&r, RMD_FLD_ANGLE));
	return (double)r.v[RMD_FLD_ANGLE] / 100.0;
}

/* 0xA1 (V3 §2.17): torque control at iq = tau / kt. */
static void torque(struct rmd_sim_motor *m, double tau_nm)
{
	struct rmd_msg req = { .cmd = 0xA1 };

	rmd_msg_set(&req, RMD_FLD_CURRENT, (int64_t)lround(tau_nm / KT * 100.0));
	(void)ask(m, &req);
}

/* A swing's angle every ms for `s` seconds (n samples into out). */
static unsigned record(struct rmd_sim_motor *m, double s, double *out, unsigned max)
{
	unsigned n = 0;

	for (int64_t end = now + (int64_t)(s * 1e3) * MS; now < end && n < max;) {
		now += MS;
		out[n++] = angle_deg(m);
	}
	return n;
}

/* Times (ms) of the downward zero crossings of a[0..n-1], interpolated. */
static unsigned crossings(const double *a, unsigned n, double *t, unsigned max)
{
	unsigned k = 0;

	for (unsigned i = 1; i < n && k < max; i++)
		if (a[i - 1] > 0.0 && a[i] <= 0.0)
			t[k++] = (double)(i - 1) + a[i - 1] / (a[i - 1] - a[i]);
	return k;
}

#define SAMPLES 20000

/*
 * (a) Released with the output off from 60 deg, the period matches the
 * large-angle formula T = 4 sqrt(I / (m g l)) K(sin(theta0 / 2)), I the
 * bob's and the motor's inertia (its armature), within 2 %.
 */
static void test_pendulum_period(void **state)
{
	static double a[SAMPLES];
	struct rmd_sim_body *b = NULL;
	struct rmd_sim_motor m;
	double t[32], want, got;
	unsigned n, k;

	(void)state;
	pendulum(&b, &m, 60.0, 0.0);
	n = record(&m, 12.0, a, SAMPLES);
	k = crossings(a, n, t, 32);
	assert_true(k >= 5);
	got = (t[k - 1] - t[0]) / (k - 1) * 1e-3;
	want = pendulum_period_s(I_BOB + J_MOTOR, MASS, LEN, G, M_PI / 3.0);
	print_message("period %.5f s, formula %.5f s (%+.3f %%), small-angle %.5f s\n", got, want,
		      100.0 * (got / want - 1.0),
		      2.0 * M_PI * sqrt((I_BOB + J_MOTOR) / (MASS * G * LEN)));
	assert_true(fabs(got / want - 1.0) < 0.02);
	/* and the swing starts where it was let go */
	assert_true(fabs(a[0] - 60.0) < 0.5);
	rmd_sim_body_free(b);
}

/*
 * (b) A constant torque command (0xA1) holds the pendulum where gravity
 * balances it: asin(tau / (m g l)), within 1 deg, once the motor's own
 * viscous friction has damped the swing.
 */
static void test_pendulum_static_torque(void **state)
{
	static double a[SAMPLES];
	const double tau = 2.0;
	struct rmd_sim_body *b = NULL;
	struct rmd_sim_motor m;
	double want = asin(tau / (MASS * G * LEN)) * 180.0 / M_PI, got;
	unsigned n;

	(void)state;
	pendulum(&b, &m, 0.0, 0.5);
	torque(&m, tau);
	n = record(&m, 20.0, a, SAMPLES);
	got = a[n - 1];
	print_message("static angle %.3f deg at %.1f N·m, asin(tau / (m g l)) %.3f deg\n", got, tau,
		      want);
	assert_true(fabs(got - want) < 1.0);
	/* and at rest: the last second within 0.1 deg */
	for (unsigned i = n - 1000; i < n; i++)
		assert_true(fabs(a[i] - got) < 0.1);
	rmd_sim_body_free(b);
}

/*
 * (c) An unforced, undamped swing keeps its energy within 1 % over 10 s:
 * at each turning point (at rest) the energy is m g l (1 - cos theta).
 */
static void test_pendulum_energy(void **state)
{
	static double a[SAMPLES];
	struct rmd_sim_body *b = NULL;
	struct rmd_sim_motor m;
	double e0 = MASS * G * LEN * (1.0 - cos(M_PI / 3.0)), worst = 0.0;
	unsigned n, peaks = 0;

	(void)state;
	pendulum(&b, &m, 60.0, 0.0);
	n = record(&m, 10.0, a, SAMPLES);
	for (unsigned i = 1; i + 1 < n; i++) {
		double e, th;

		if (!(fabs(a[i]) >= fabs(a[i - 1]) && fabs(a[i]) > fabs(a[i + 1]) &&
		      fabs(a[i]) > 30.0))
			continue;
		th = a[i] * M_PI / 180.0;
		e = MASS * G * LEN * (1.0 - cos(th));
		if (fabs(e / e0 - 1.0) > worst)
			worst = fabs(e / e0 - 1.0);
		peaks++;
	}
	print_message("energy at %u turning points over 10 s: worst %.4f %% off\n", peaks,
		      100.0 * worst);
	assert_true(peaks >= 10);
	assert_true(worst < 0.01);
	rmd_sim_body_free(b);
}

/* Same frames at the same times, same world: two runs give the same replies. */
static void test_deterministic(void **state)
{
	static double a1[4000], a2[4000];
	struct rmd_sim_body *b = NULL;
	struct rmd_sim_motor m;

	(void)state;
	pendulum(&b, &m, 45.0, 0.1);
	torque(&m, 1.0);
	record(&m, 3.0, a1, 4000);
	rmd_sim_body_free(b);
	pendulum(&b, &m, 45.0, 0.1);
	torque(&m, 1.0);
	record(&m, 3.0, a2, 4000);
	rmd_sim_body_free(b);
	assert_memory_equal(a1, a2, sizeof(a1));
}

/* The triple pendulum, its shoulder and elbow motors (configuration motors 0 and 1). */
static void two_motors(struct rmd_sim_body **b, struct rmd_sim_motor m[2])
{
	struct rmd_sim_physics_setup ps;
	struct rmd_sim_motor_params p;
	char err[512], path[PATH_MAX];

	if (!have_module)
		skip();
	data_path(path, sizeof(path), "double.xml");
	setup_of(&ps, path, "shoulder");
	ps.joints[1] = (struct rmd_sim_physics_joint){ .motor = 1, .line = 10 };
	snprintf(ps.joints[1].joint, sizeof(ps.joints[1].joint), "elbow");
	ps.n_joints = 2;
	assert_int_equal(rmd_sim_body_load(b, &ps, err, sizeof(err)), 0);
	now = 0;
	for (int i = 0; i < 2; i++) {
		rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
		p.has_brake = false;
		p.kt_nm_a = KT;
		p.start_angle_deg = i ? -20.0 : 40.0;
		rmd_sim_motor_init(&m[i], &p, now);
		assert_int_equal(rmd_sim_body_attach(*b, (unsigned)i, &m[i]), 1);
	}
}

/*
 * One world for two motors (as on two buses): whichever is stepped or
 * asked first, and however far one runs ahead of the other, the world
 * advances only with both, so the replies are the same.  And the model's
 * coupling moves the elbow (its motor off) when the shoulder is driven.
 */
static void test_two_motors_lockstep(void **state)
{
	static double a[3][2][3000];
	struct rmd_sim_body *b = NULL;
	struct rmd_sim_motor m[2];

	(void)state;
	for (int run = 0; run < 3; run++) {
		two_motors(&b, m);
		torque(&m[0], 1.5);
		for (int k = 0; k < 3000; k++) {
			now += MS;
			if (run == 0) {
				a[run][0][k] = angle_deg(&m[0]);
				a[run][1][k] = angle_deg(&m[1]);
			} else if (run == 1) {
				a[run][1][k] = angle_deg(&m[1]);
				a[run][0][k] = angle_deg(&m[0]);
			} else {
				/* motor 1 stepped 0.3 ms ahead of each read, motor 0 left behind */
				rmd_sim_motor_step(&m[1], now + 300000);
				a[run][1][k] = angle_deg(&m[1]);
				a[run][0][k] = angle_deg(&m[0]);
			}
		}
		rmd_sim_body_free(b);
	}
	assert_memory_equal(a[0], a[1], sizeof(a[0]));
	assert_memory_equal(a[0], a[2], sizeof(a[0]));
	/* the elbow's motor is off, yet its joint swings with the shoulder's */
	{
		double lo = 1e9, hi = -1e9;

		for (int k = 0; k < 3000; k++) {
			lo = fmin(lo, a[0][1][k]);
			hi = fmax(hi, a[0][1][k]);
		}
		print_message("elbow (motor off) between %.2f and %.2f deg\n", lo, hi);
		assert_true(hi - lo > 10.0);
	}
}

/* A locked brake (power-on, V3 §2.27.1) holds the joint against gravity; 0x77 lets it swing. */
static void test_brake_holds_joint(void **state)
{
	struct rmd_sim_physics_setup ps;
	struct rmd_sim_motor_params p;
	struct rmd_sim_body *b = NULL;
	struct rmd_sim_motor m;
	struct rmd_msg release = { .cmd = 0x77 };
	char err[512];
	double lo = 1e9;

	(void)state;
	if (!have_module)
		skip();
	setup_of(&ps, model_path, "swing");
	assert_int_equal(rmd_sim_body_load(&b, &ps, err, sizeof(err)), 0);
	rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
	p.has_brake = true;
	p.start_angle_deg = 60.0;
	now = 0;
	rmd_sim_motor_init(&m, &p, now);
	assert_int_equal(rmd_sim_body_attach(b, 0, &m), 1);
	for (int k = 0; k < 1000; k++) {
		now += MS;
		assert_true(fabs(angle_deg(&m) - 60.0) < 0.01);
	}
	(void)ask(&m, &release);
	for (int k = 0; k < 1000; k++) {
		now += MS;
		lo = fmin(lo, angle_deg(&m));
	}
	assert_true(lo < 0.0);
	rmd_sim_body_free(b);
}

/* Load ps; expect ret and every piece of want[] in the one-line message. */
static void expect_load_error(const struct rmd_sim_physics_setup *ps, int ret,
			      const char *const *want)
{
	struct rmd_sim_body *b = (void *)1;
	char err[1024];

	assert_int_equal(rmd_sim_body_load(&b, ps, err, sizeof(err)), ret);
	assert_null(b);
	assert_null(strchr(err, '\n'));
	for (; *want; want++)
		if (!strstr(err, *want))
			fail_msg("\"%s\" not in: %s", *want, err);
}

/* A model file with this text, in a temporary folder. */
static void write_model(char *path, size_t len, const char *text)
{
	FILE *f;

	snprintf(path, len, "/tmp/rmd-test-sim-body-%ld.xml", (long)getpid());
	f = fopen(path, "w");
	assert_non_null(f);
	fputs(text, f);
	fclose(f);
}

/* (d) Bad input: each names the configuration's file and line, and the model's message. */
static void test_load_errors(void **state)
{
	struct rmd_sim_physics_setup ps;
	char path[PATH_MAX];

	(void)state;
	if (!have_module)
		skip();
	/* MuJoCo's own message, with the model's line */
	write_model(path, sizeof(path),
		    "<mujoco>\n  <worldbody>\n    <body>\n      <joint name='j' type='hinge'/>\n"
		    "      <geom size='0.1'/>\n    </bdy>\n  </worldbody>\n</mujoco>\n");
	setup_of(&ps, path, "j");
	expect_load_error(&ps, -EINVAL,
			  (const char *const[]){ "test.yaml:7: sim.physics.model: ", path,
						 "XML_ERROR_MISMATCHED_ELEMENT", "Line number=3",
						 NULL });
	/* a missing file */
	setup_of(&ps, "/nonexistent/leg.xml", "j");
	expect_load_error(&ps, -EINVAL,
			  (const char *const[]){ "test.yaml:7: sim.physics.model: ",
						 "/nonexistent/leg.xml", NULL });
	/* a joint the model lacks: the model's joints listed */
	setup_of(&ps, model_path, "knee");
	expect_load_error(&ps, -ENOENT,
			  (const char *const[]){ "test.yaml:9: sim.physics.joints: ", "\"knee\"",
						 "its joints: swing", NULL });
	/* a free joint: not one degree of freedom */
	write_model(path, sizeof(path),
		    "<mujoco>\n  <worldbody>\n    <body>\n      <freejoint name='f'/>\n"
		    "      <geom size='0.1'/>\n    </body>\n  </worldbody>\n</mujoco>\n");
	setup_of(&ps, path, "f");
	expect_load_error(&ps, -EINVAL,
			  (const char *const[]){ "test.yaml:9: ", "neither a hinge nor a slide",
						 NULL });
	/* one joint for two motors */
	setup_of(&ps, model_path, "swing");
	ps.joints[1] = (struct rmd_sim_physics_joint){ .motor = 1, .line = 10 };
	snprintf(ps.joints[1].joint, sizeof(ps.joints[1].joint), "swing");
	ps.n_joints = 2;
	expect_load_error(&ps, -EINVAL,
			  (const char *const[]){ "test.yaml:10: ", "mapped twice", "line 9",
						 NULL });
	unlink(path);
}

/* No module: what is missing and how to get it. */
static void test_no_module(void **state)
{
	struct rmd_sim_physics_setup ps;
	char *was = strdup(getenv(RMD_PHYSICS_MODULE_ENV));

	(void)state;
	setenv(RMD_PHYSICS_MODULE_ENV, "/nonexistent/rmd-physics.so", 1);
	setup_of(&ps, model_path, "swing");
	expect_load_error(&ps, -ENOENT,
			  (const char *const[]){ "test.yaml:7: sim.physics: ", "no physics module",
						 "/nonexistent/rmd-physics.so: not found",
						 "install the rmdd-physics package",
						 "libmujoco-dev", NULL });
	setenv(RMD_PHYSICS_MODULE_ENV, was, 1);
	free(was);
}

/* The configuration's checks of sim.physics, with FILE:LINE: key. */
static void test_config_errors(void **state)
{
	static const struct {
		const char *physics, *want;
	} rows[] = {
		{ "    joints: {ghost: swing}\n", "x.yaml:13: sim.physics.joints.ghost: no motor" },
		{ "    joints: {a: swing, b: swing}\n",
		  "x.yaml:13: sim.physics.joints.b: joint \"swing\" is mapped twice (motor a" },
		{ "    rate_hz: 3000\n    joints: {a: swing}\n",
		  "x.yaml:13: sim.physics.rate_hz: 3000 Hz does not divide" },
		{ "    rate_hz: 500\n    joints: {a: swing}\n",
		  "x.yaml:13: sim.physics.rate_hz: 500 Hz is below loop.rate_hz" },
		{ "    joints: [swing]\n", "x.yaml:13: sim.physics.joints: expected a mapping" },
		{ "    modle: p.xml\n    joints: {a: swing}\n",
		  "x.yaml:13: sim.physics.modle: unknown key (did you mean model?)" },
	};
	static struct rmd_sim_setup sim;
	struct rmd_config cfg;
	char path[64], err[2048];

	(void)state;
	snprintf(path, sizeof(path), "/tmp/x.yaml");
	for (size_t i = 0; i < sizeof(rows) / sizeof(rows[0]); i++) {
		FILE *f = fopen(path, "w");

		assert_non_null(f);
		fprintf(f,
			"loop: {rate_hz: 1000}\n"
			"buses: [{name: s0, type: sim}]\n"
			"motors:\n"
			"  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 1}\n"
			"  - {name: b, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 1}\n"
			"\n\n\n\n\n"
			"sim:\n"
			"  physics:\n"
			"%s%s",
			rows[i].physics,
			strstr(rows[i].physics, "model") ? "" : "    model: p.xml\n");
		fclose(f);
		assert_int_equal(rmd_config_load(path, &cfg, &sim, err, sizeof(err)), -EINVAL);
		if (!strstr(err, rows[i].want))
			fail_msg("row %zu: \"%s\" not in: %s", i, rows[i].want, err);
	}
	/* a good one: the model beside the file, the joint of motor b */
	{
		FILE *f = fopen(path, "w");

		assert_non_null(f);
		fprintf(f, "loop: {rate_hz: 1000}\n"
			   "buses: [{name: s0, type: sim}]\n"
			   "motors:\n"
			   "  - {name: a, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 1}\n"
			   "  - {name: b, bus: s0, id: 2, mode: torque, torque_constant_nm_a: 1}\n"
			   "sim: {physics: {model: p.xml, rate_hz: 4000, substeps: 2, joints: {b: "
			   "swing}}}\n");
		fclose(f);
		assert_int_equal(rmd_config_load(path, &cfg, &sim, err, sizeof(err)), 0);
		assert_string_equal(sim.physics.model, "/tmp/p.xml");
		assert_int_equal(sim.physics.rate_hz, 4000);
		assert_int_equal(sim.physics.substeps, 2);
		assert_int_equal(sim.physics.n_joints, 1);
		assert_int_equal(sim.physics.joints[0].motor, 1);
		assert_string_equal(sim.physics.joints[0].joint, "swing");
		assert_int_equal(sim.physics.joints[0].line, 6);
	}
	unlink(path);
}

SUITE_MAIN("sim_body", group_setup, NULL,
	   {
		   cmocka_unit_test(test_pendulum_period),
		   cmocka_unit_test(test_pendulum_static_torque),
		   cmocka_unit_test(test_pendulum_energy),
		   cmocka_unit_test(test_deterministic),
		   cmocka_unit_test(test_two_motors_lockstep),
		   cmocka_unit_test(test_brake_holds_joint),
		   cmocka_unit_test(test_load_errors),
		   cmocka_unit_test(test_no_module),
		   cmocka_unit_test(test_config_errors),
	   })
