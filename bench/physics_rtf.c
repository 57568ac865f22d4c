// SPDX-License-Identifier: MIT
/*
 * bench/physics-rtf.sh's rig: simulated motors on a model's joints
 * (rmd/sim_body.h), driven as rmdd's loop drives them, one 0xA1 frame per
 * motor per loop cycle (1 kHz) with its reply, as fast as the machine
 * steps them, in the simulator's own time.  It prints the real-time
 * factor (simulated seconds per second of CPU) with the physics and
 * without it (the same motors turning their own inertia), and for the
 * first motor the period of its swing and the drift of the energy at its
 * turning points, as a pendulum (tests/data/physics/pendulum.xml: bob
 * 1 kg at 0.5 m, motor inertia 0.001) would have them.
 *
 *   physics_rtf MODEL JOINT[,JOINT...] RATE_HZ SUBSTEPS SECONDS [TORQUE_NM]
 *
 * TORQUE_NM (default 0): each motor's 0xA1 torque.  Non-rt, a bench.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "rmd/codec.h"
#include "rmd/sim.h"
#include "rmd/sim_body.h"
#include "rmd/sim_setup.h"

#define MS INT64_C(1000000)

static double cpu_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* One frame to motor m at now, its one reply decoded into *r; false when none. */
static bool ask(struct rmd_sim_motor *m, int64_t now, const struct rmd_msg *req, struct rmd_msg *r)
{
	struct rmd_frame f, out[8];

	if (rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, 1, req, &f) < 0)
		return false;
	if (rmd_sim_motor_receive(m, now, &f, out, 8) != 1)
		return false;
	return rmd_decode(RMD_PROTO_V3, RMD_DIR_REPLY, &out[0], r, NULL) == 0;
}

struct result {
	double rtf, cpu_us_per_sim_s, period_s, energy_drift;
};

/*
 * n motors for `seconds`: a 0xA1 each ms, and a 0x92 of motor 0 for the
 * swing's figures.  b NULL: no physics.
 */
static int run(struct rmd_sim_body *b, unsigned n, double seconds, double torque,
	       struct result *res)
{
	static struct rmd_sim_motor m[RMD_MAX_MOTORS];
	struct rmd_sim_motor_params p;
	struct rmd_msg cmd = { .cmd = 0xA1 }, rd = { .cmd = 0x92 }, r;
	double c0, prev = NAN, prev2 = NAN, t_first = NAN, t_last = NAN, e0 = NAN, worst = 0.0;
	unsigned crossings = 0;
	int64_t now = 0, end = (int64_t)(seconds * 1e3) * MS;

	rmd_msg_set(&cmd, RMD_FLD_CURRENT, (int64_t)lround(torque * 100.0));
	for (unsigned i = 0; i < n; i++) {
		rmd_sim_motor_params_default(&p, 1, RMD_PROTO_V3);
		p.has_brake = false;
		p.kt_nm_a = 1.0;
		p.coulomb_nm = 0.0;
		p.viscous_nm_s_rad = 0.0;
		p.inertia_kgm2 = 0.001;
		p.start_angle_deg = i ? 0.0 : 60.0;
		rmd_sim_motor_init(&m[i], &p, now);
		if (b && rmd_sim_body_attach(b, i, &m[i]) != 1)
			return -EINVAL;
	}
	c0 = cpu_s();
	while (now < end) {
		double a;

		now += MS;
		for (unsigned i = 0; i < n; i++)
			if (!ask(&m[i], now, &cmd, &r))
				return -EIO;
		if (!ask(&m[0], now, &rd, &r))
			return -EIO;
		a = (double)r.v[RMD_FLD_ANGLE] / 100.0;
		if (prev < 0.0 && a >= 0.0) {
			double t = (double)now * 1e-9 - 1e-3 * a / (a - prev);

			if (!crossings)
				t_first = t;
			t_last = t;
			crossings++;
		}
		/* a turning point: |angle| at a local maximum */
		if (!isnan(prev2) && fabs(prev) >= fabs(prev2) && fabs(prev) > fabs(a) &&
		    fabs(prev) > 1.0) {
			double e = 1.0 - cos(prev * M_PI / 180.0);

			if (isnan(e0))
				e0 = e;
			else if (fabs(e / e0 - 1.0) > worst)
				worst = fabs(e / e0 - 1.0);
		}
		prev2 = prev;
		prev = a;
	}
	res->cpu_us_per_sim_s = (cpu_s() - c0) / seconds * 1e6;
	res->rtf = seconds / fmax(cpu_s() - c0, 1e-9);
	res->period_s = crossings > 1 ? (t_last - t_first) / (crossings - 1) : NAN;
	res->energy_drift = worst;
	return 0;
}

int main(int argc, char **argv)
{
	struct rmd_sim_physics_setup ps = { 0 };
	struct rmd_sim_body *b;
	struct result with, without;
	char err[1024], joints[512], *tok, *save = NULL;
	double seconds, torque;
	int r;

	if (argc < 6) {
		fprintf(stderr,
			"usage: physics_rtf MODEL JOINT[,JOINT...] RATE_HZ SUBSTEPS SECONDS "
			"[TORQUE_NM]\n");
		return 2;
	}
	snprintf(ps.model, sizeof(ps.model), "%s", argv[1]);
	snprintf(ps.source, sizeof(ps.source), "physics_rtf");
	snprintf(joints, sizeof(joints), "%s", argv[2]);
	for (tok = strtok_r(joints, ",", &save); tok && ps.n_joints < RMD_MAX_MOTORS;
	     tok = strtok_r(NULL, ",", &save)) {
		ps.joints[ps.n_joints].motor = ps.n_joints;
		snprintf(ps.joints[ps.n_joints].joint, sizeof(ps.joints[0].joint), "%s", tok);
		ps.n_joints++;
	}
	ps.rate_hz = (unsigned)atoi(argv[3]);
	ps.substeps = (unsigned)atoi(argv[4]);
	seconds = atof(argv[5]);
	torque = argc > 6 ? atof(argv[6]) : 0.0;
	r = rmd_sim_body_load(&b, &ps, err, sizeof(err));
	if (r < 0) {
		fprintf(stderr, "physics_rtf: %s\n", err);
		return 1;
	}
	if (run(b, ps.n_joints, seconds, torque, &with) < 0 ||
	    run(NULL, ps.n_joints, seconds, torque, &without) < 0) {
		fprintf(stderr, "physics_rtf: a motor did not answer\n");
		return 1;
	}
	rmd_sim_body_describe(b, err, sizeof(err));
	printf("# %s\n", err);
	printf("motors %u rate_hz %u substeps %u rtf %.1f rtf_without %.1f "
	       "cpu_us_per_sim_s %.0f cpu_us_per_sim_s_without %.0f period_s %.6f "
	       "energy_drift_pct %.4f diverged %u\n",
	       ps.n_joints, ps.rate_hz, ps.substeps, with.rtf, without.rtf, with.cpu_us_per_sim_s,
	       without.cpu_us_per_sim_s, with.period_s, 100.0 * with.energy_drift,
	       rmd_sim_body_diverged(b));
	rmd_sim_body_free(b);
	return 0;
}
