// SPDX-License-Identifier: MIT
/*
 * soak_wire CONFIG [TAP]: bench/soak.sh's wire checker.  Reads the sim
 * buses' wire tap (sim.tap, rmd/bus_sim.h: `candump -l` lines, T for the
 * frames rmdd sent) from TAP or standard input until end of file, decodes
 * every setpoint rmdd sent (0xA1 torque, 0xA2 speed, 0xA4 position, MIT
 * 0x400 + ID) with the codec and the motor's own units (rmd/motor.h), and
 * checks it against the motor's configured limits and MIT ranges, within
 * one LSB of the field.  Prints, at the end:
 *
 *   wire: frames N (sent S, received R), setpoints P, violations V, unparsed U
 *   wire: bus NAME first S.US sent S received R foreign F short D
 *   wire: VIOLATION ...     (the first 20, as they come)
 *
 * Exit status 0: no violation and every line parsed; 1: a violation or an
 * unparsed line; 2: a bad argument or configuration.  Non-rt.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/candump.h"
#include "rmd/codec.h"
#include "rmd/config_yaml.h"
#include "rmd/mit.h"
#include "rmd/motor.h"
#include "rmd/sim_setup.h"

#define DEG_PER_RAD (180.0 / M_PI)
#define MAX_SHOWN 20

struct bus_count {
	uint64_t sent, received, foreign;
	uint64_t short_frames; /* received with DLC < 8 */
	double first_s;	       /* stamp of its first frame; < 0: none yet */
};

static struct rmd_config cfg;
static struct rmd_sim_setup sim;
static struct rmd_motor motors[RMD_MAX_MOTORS];
static struct rmd_motor_info info[RMD_MAX_MOTORS];
static struct bus_count buses[RMD_MAX_BUSES];
static uint64_t n_setpoints, n_violations;

static void violation(const char *line, const struct rmd_motor *m, const char *what, double v,
		      double lo, double hi)
{
	n_violations++;
	if (n_violations <= MAX_SHOWN)
		printf("wire: VIOLATION %s: %s %.6g outside [%.6g, %.6g]: %s", m->name, what, v, lo,
		       hi, line);
}

/* v within [lo - tol, hi + tol]?  Counts and shows a violation if not. */
static void check(const char *line, const struct rmd_motor *m, const char *what, double v,
		  double lo, double hi, double tol)
{
	if (!(v >= lo - tol && v <= hi + tol))
		violation(line, m, what, v, lo, hi);
}

/* One field of a decoded request, native units, and its LSB. */
static double field(const struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_field f,
		    double *lsb)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, RMD_DIR_REQUEST, f);

	*lsb = fs && fs->scale > 0.0 ? fs->scale : 1.0;
	return rmd_msg_get_native(msg, spec, RMD_DIR_REQUEST, f, 0.0);
}

/* A V3/V2 request of motor m: a setpoint command is checked. */
static void check_cmd(const char *line, const struct rmd_motor *m, const struct rmd_motor_info *mi,
		      const struct rmd_frame *f)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(m->d->table, f->data[0]);
	struct rmd_msg msg;
	double lsb, lsb2, v, ms;

	if (!spec || (f->data[0] != 0xA1 && f->data[0] != 0xA2 && f->data[0] != 0xA4))
		return;
	if (rmd_decode(m->d->table, RMD_DIR_REQUEST, f, &msg, NULL) < 0) {
		violation(line, m, "undecodable setpoint", f->data[0], 0, 0);
		return;
	}
	n_setpoints++;
	switch (f->data[0]) {
	case 0xA1: /* iq = dir * torque / kt */
		v = m->dir * field(&msg, spec, RMD_FLD_CURRENT, &lsb) * m->kt_nm_a;
		check(line, m, "torque_nm", v, -mi->torque_max_nm, mi->torque_max_nm,
		      lsb * m->kt_nm_a);
		break;
	case 0xA2:
		v = m->dir * field(&msg, spec, RMD_FLD_SPEED, &lsb) / DEG_PER_RAD /
		    m->native_per_output;
		check(line, m, "velocity_rad_s", v, -mi->vel_max_rad_s, mi->vel_max_rad_s,
		      lsb / DEG_PER_RAD / m->native_per_output);
		break;
	case 0xA4:
		v = rmd_motor_from_native_pos(m, field(&msg, spec, RMD_FLD_ANGLE, &lsb) /
							 DEG_PER_RAD / m->native_per_output);
		check(line, m, "position_rad", v, mi->pos_min_rad, mi->pos_max_rad,
		      lsb / DEG_PER_RAD / m->native_per_output);
		ms = field(&msg, spec, RMD_FLD_MAX_SPEED, &lsb2) / DEG_PER_RAD /
		     m->native_per_output;
		check(line, m, "max_velocity_rad_s", ms, 0, mi->vel_max_rad_s,
		      lsb2 / DEG_PER_RAD / m->native_per_output);
		break;
	default:
		break;
	}
}

/* An MIT request (0x400 + ID) of motor m. */
static void check_mit(const char *line, const struct rmd_motor *m, const struct rmd_motor_info *mi,
		      const struct rmd_frame *f)
{
	const struct rmd_mit_ranges *r = &m->mit;
	struct rmd_mit_cmd c;
	uint8_t id;

	if (rmd_mit_decode_cmd(r, f, &id, &c) < 0) {
		violation(line, m, "undecodable MIT frame", f->can_id, 0, 0);
		return;
	}
	n_setpoints++;
	/* 12 bits for v, kp, kd, t (V3 §5.1); p has 16, so this bound holds for it too */
	check(line, m, "position_rad", rmd_motor_from_native_pos(m, c.p_des_rad), mi->pos_min_rad,
	      mi->pos_max_rad, (r->p_max - r->p_min) / 4095.0);
	check(line, m, "velocity_rad_s", m->dir * c.v_des_rad_s, -mi->vel_max_rad_s,
	      mi->vel_max_rad_s, (r->v_max - r->v_min) / 4095.0);
	check(line, m, "torque_nm", m->dir * c.t_ff_nm, -mi->torque_max_nm, mi->torque_max_nm,
	      (r->t_max - r->t_min) / 4095.0);
	check(line, m, "kp", c.kp, mi->kp_min, mi->kp_max, (r->kp_max - r->kp_min) / 4095.0);
	check(line, m, "kd", c.kd, mi->kd_min, mi->kd_max, (r->kd_max - r->kd_min) / 4095.0);
}

/* The configured motor with identifier id on bus b, or -1. */
static int motor_of(unsigned b, unsigned id)
{
	for (unsigned i = 0; i < cfg.n_motors; i++)
		if (motors[i].bus == b && motors[i].id == id)
			return (int)i;
	return -1;
}

static int bus_of(const char *name)
{
	for (unsigned b = 0; b < cfg.n_buses; b++)
		if (!strcmp(cfg.buses[b].name, name))
			return (int)b;
	return -1;
}

int main(int argc, char **argv)
{
	static char err[4096];
	char line[256];
	uint64_t n = 0, unparsed = 0, sent = 0;
	FILE *in = stdin;

	if (argc < 2 || argc > 3) {
		fprintf(stderr, "usage: soak_wire CONFIG [TAP]\n");
		return 2;
	}
	if (rmd_config_load(argv[1], &cfg, &sim, err, sizeof(err)) < 0) {
		fprintf(stderr, "soak_wire: %s\n", err);
		return 2;
	}
	for (unsigned i = 0; i < cfg.n_motors; i++) {
		if (rmd_motor_init(&motors[i], &cfg.motors[i]) < 0) {
			fprintf(stderr, "soak_wire: motor %s: bad configuration\n",
				cfg.motors[i].name);
			return 2;
		}
		rmd_motor_info(&motors[i], false, &info[i]);
	}
	for (unsigned b = 0; b < RMD_MAX_BUSES; b++)
		buses[b].first_s = -1;
	if (argc == 3 && !(in = fopen(argv[2], "r"))) {
		perror(argv[2]);
		return 2;
	}

	while (fgets(line, sizeof(line), in)) {
		struct rmd_candump_line c;
		const struct rmd_frame *f = &c.frame;
		bool host;
		int b, i;

		n++;
		/* "... ID#DATA T|R": the direction token is the tap's */
		host = strstr(line, " T\n") != NULL;
		if (rmd_candump_parse(line, &c) < 0 || (b = bus_of(c.iface)) < 0) {
			if (unparsed++ < MAX_SHOWN)
				printf("wire: unparsed line: %s", line);
			continue;
		}
		if (buses[b].first_s < 0)
			buses[b].first_s =
				(double)c.time_sec + c.time_frac / pow(10, c.time_digits);
		if (!host) {
			buses[b].received++;
			/* a motor's identifier: 0x140.., 0x240.., 0x500..; else a foreign node */
			if (f->len < RMD_FRAME_LEN)
				buses[b].short_frames++;
			if (!((f->can_id > 0x140 && f->can_id <= 0x160) ||
			      (f->can_id > 0x240 && f->can_id <= 0x260) ||
			      (f->can_id > 0x500 && f->can_id <= 0x520)))
				buses[b].foreign++;
			continue;
		}
		buses[b].sent++;
		sent++;
		if (f->can_id > 0x140 && f->can_id <= 0x160 &&
		    (i = motor_of((unsigned)b, f->can_id - 0x140)) >= 0)
			check_cmd(line, &motors[i], &info[i], f);
		else if (f->can_id > 0x400 && f->can_id <= 0x420 &&
			 (i = motor_of((unsigned)b, f->can_id - 0x400)) >= 0 && motors[i].mit_mode)
			check_mit(line, &motors[i], &info[i], f);
		else if (f->can_id != 0x280 && f->can_id != 0x300 && f->len &&
			 (f->data[0] == 0xA1 || f->data[0] == 0xA2 || f->data[0] == 0xA4 ||
			  f->can_id > 0x400)) {
			/* bring-up's scan reads ids not configured; nothing may move them */
			n_violations++;
			if (n_violations <= MAX_SHOWN)
				printf("wire: VIOLATION a setpoint to no configured motor: %s",
				       line);
		}
	}
	printf("wire: frames %llu (sent %llu, received %llu), setpoints %llu, violations %llu, "
	       "unparsed %llu\n",
	       (unsigned long long)n, (unsigned long long)sent, (unsigned long long)(n - sent),
	       (unsigned long long)n_setpoints, (unsigned long long)n_violations,
	       (unsigned long long)unparsed);
	for (unsigned b = 0; b < cfg.n_buses; b++)
		printf("wire: bus %s first %.6f sent %llu received %llu foreign %llu short %llu\n",
		       cfg.buses[b].name, buses[b].first_s, (unsigned long long)buses[b].sent,
		       (unsigned long long)buses[b].received, (unsigned long long)buses[b].foreign,
		       (unsigned long long)buses[b].short_frames);
	return n_violations || unparsed ? 1 : 0;
}
