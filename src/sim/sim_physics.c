// SPDX-License-Identifier: MIT
/*
 * A simulated RMD motor's physics (sim_physics.h): units and encoder,
 * fault detection, the firmware's control loops, mechanics and
 * temperature, stepped at RMD_SIM_STEP_NS.  The protocol side is
 * sim_motor.c.  Section numbers (§) are the manuals' (see sim_motor.c).
 *
 * No allocation, I/O or clock: every function here is rt-safe.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rmd/sim.h"
#include "rmd/sim_body.h"
#include "sim_physics.h"

/* -------------------------------------------------------------------------- */
/* Model: units and encoder                                                   */

#define STEP_S ((double)RMD_SIM_STEP_NS * 1e-9)
/*
 * Firmware loop tuning, from the motor's own inertia and torque constant
 * (the firmware is tuned for its motor): speed loop bandwidth 100 Hz,
 * position loop a fifth of it.  The current loop is ideal.
 */
#define SPEED_BW_RAD_S (2.0 * M_PI * 100.0)
#define POS_BW_RAD_S (SPEED_BW_RAD_S / 5.0)
/* Gains written with 0x31/0x32 (V2 0x36..0x41) scale these, within 0..4x. */
#define GAIN_SCALE_MAX 4.0
/* V3 §8.2 "stall": the current near its limit while the speed stays low. */
#define STALL_CURRENT_FRACTION 0.8
#define STALL_SPEED_RAD_S 0.2
/* Hysteresis of the level-2 faults, which clear by themselves (V3 §8.2). */
#define VOLTAGE_HYSTERESIS_V 1.0
#define OVERSPEED_CLEAR_FRACTION 0.9

/* Multi-turn counts per output radian: the encoder is on the motor (V3 §2.13.4). */
static double counts_per_rad(const struct rmd_sim_motor *m)
{
	return ldexp(1.0, (int)m->p.encoder_bits) * m->p.gear_ratio / (2.0 * M_PI);
}

/* The multi-turn encoder value without offset (V3 §2.7, 0x61). */
int64_t rmd_sim_raw_counts(const struct rmd_sim_motor *m)
{
	return (int64_t)llround(clamp(m->pos_rad * counts_per_rad(m), -0x1p62, 0x1p62));
}

/* The zero offset in use (V3 §2.8), as an output angle. */
double rmd_sim_offset_rad(const struct rmd_sim_motor *m)
{
	return (double)m->ram.encoder_offset / counts_per_rad(m);
}

/* The output shaft angle the motor reports: from its zero (V3 §2.11). */
double rmd_sim_angle_rad(const struct rmd_sim_motor *m)
{
	return m->pos_rad - rmd_sim_offset_rad(m);
}

/* 0x43 index (V3 §2.5.4) in rad/s^2; 0 is taken as "no limit". */
double rmd_sim_accel_rad(const struct rmd_sim_motor *m, unsigned index)
{
	uint32_t a = m->ram.accel_dps2[index];

	return a ? rad((double)a) : INFINITY;
}

/* Electrical power drawn: copper loss plus shaft power, >= 0 (V3 §2.24). */
double rmd_sim_power_w(const struct rmd_sim_motor *m)
{
	double iq = m->iq_a;
	double p = 1.5 * m->p.phase_resistance_ohm * iq * iq + m->p.kt_nm_a * iq * m->vel_rad_s;

	return p > 0.0 ? p : 0.0;
}

/* -------------------------------------------------------------------------- */
/* Model: faults                                                              */

/* Output off and the running state cleared (V3 §2.15.1). */
void rmd_sim_off_state(struct rmd_sim_motor *m)
{
	m->ctrl = RMD_SIM_OFF;
	m->ctrl_stopped = RMD_SIM_OFF;
	m->sp_current_a = 0.0;
	m->sp_speed_rad_s = 0.0;
	m->ramp_speed_rad_s = 0.0;
	m->ramp_acc_rad_s2 = 0.0;
	m->sp_pos_rad = m->pos_rad;
	m->sp_max_speed_rad_s = 0.0;
	m->hold_pos_rad = m->pos_rad;
	m->traj_pos_rad = m->pos_rad;
	m->traj_vel_rad_s = 0.0;
	m->traj_acc_rad_s2 = 0.0;
	m->speed_int_a = 0.0;
	m->tf_current_a = 0.0;
	memset(&m->mit, 0, sizeof(m->mit));
	m->iq_a = 0.0;
}

/*
 * Combine the error sources.  A level-1 fault (V3 §8.2 "一级": cannot
 * recover, restart needed) also clears the mode; a level-2 one only holds
 * the output off while it lasts.  The first error of a run schedules an
 * error report at once (V3 §2.33.4 index 3).
 */
void rmd_sim_update_errors(struct rmd_sim_motor *m)
{
	uint16_t e = m->errors_live | m->errors_latched | m->errors_injected;

	if (e && !m->errors)
		m->next_9a_ns = m->t_ns;
	if ((e & RMD_SIM_ERR_LEVEL1) && m->ctrl != RMD_SIM_OFF)
		rmd_sim_off_state(m);
	m->errors = e;
}

/* Fault detection after a step of dt seconds (V3 §2.12 table 1, §8.2). */
static void detect_faults(struct rmd_sim_motor *m, double dt)
{
	const struct rmd_sim_motor_params *p = &m->p;
	uint16_t live = m->errors_live;
	double vmax = rad(p->max_speed_dps), v = fabs(m->vel_rad_s);

	if (m->temp_c > p->over_temp_c)
		live |= RMD_SIM_ERR_OVER_TEMP;
	else if (m->temp_c < p->over_temp_clear_c)
		live &= (uint16_t)~RMD_SIM_ERR_OVER_TEMP;
	if (p->supply_v < p->under_voltage_v)
		live |= RMD_SIM_ERR_LOW_VOLTAGE;
	else if (p->supply_v >= p->under_voltage_v + VOLTAGE_HYSTERESIS_V)
		live &= (uint16_t)~RMD_SIM_ERR_LOW_VOLTAGE;
	if (p->supply_v > p->over_voltage_v)
		live |= RMD_SIM_ERR_OVER_VOLTAGE;
	else if (p->supply_v <= p->over_voltage_v - VOLTAGE_HYSTERESIS_V)
		live &= (uint16_t)~RMD_SIM_ERR_OVER_VOLTAGE;
	if (v > vmax)
		live |= RMD_SIM_ERR_OVERSPEED;
	else if (v < OVERSPEED_CLEAR_FRACTION * vmax)
		live &= (uint16_t)~RMD_SIM_ERR_OVERSPEED;
	m->errors_live = live;

	if (fabs(m->iq_a) >= STALL_CURRENT_FRACTION * p->max_current_a && v < STALL_SPEED_RAD_S)
		m->stall_s += dt;
	else
		m->stall_s = 0.0;
	if (m->stall_s > p->stall_time_s)
		m->errors_latched |= RMD_SIM_ERR_STALL;
	rmd_sim_update_errors(m);
}

/* -------------------------------------------------------------------------- */
/* Model: the firmware's control loops                                        */

/* The shaft is held by the brake. */
static bool held(const struct rmd_sim_motor *m)
{
	return m->p.has_brake && m->brake_locked;
}

/*
 * Gain i (enum rmd_field order from RMD_FLD_CURR_KP) relative to the
 * factory value.  V3 §2.1.1: uint8 units of a model-dependent maximum.
 */
static double gain_scale(const struct rmd_sim_motor *m, unsigned i)
{
	double def = (double)rmd_sim_pid_default(m->p.proto, i);

	/* V4.2 §2.1: one float gain by index, 1.0 from the factory */
	if (m->gain_index[i] >= 0)
		return clamp((double)m->ram.gain[m->gain_index[i]] / V4_GAIN_DEFAULT, 0.0,
			     GAIN_SCALE_MAX);

	return clamp((double)m->ram.pid[i] / def, 0.0, GAIN_SCALE_MAX);
}

/* The window iq can take: the current limit and the supply voltage. */
static void iq_window(const struct rmd_sim_motor *m, double *lo, double *hi)
{
	const struct rmd_sim_motor_params *p = &m->p;
	/* q-axis back-EMF per output rad/s (amplitude-invariant dq: kt / 1.5). */
	double emf = p->kt_nm_a / 1.5 * m->vel_rad_s;
	/* Space-vector modulation reaches Vdc / sqrt(3) per phase. */
	double vq = p->supply_v / sqrt(3.0);

	*lo = -p->max_current_a;
	*hi = p->max_current_a;
	if (p->phase_resistance_ohm > 0.0) {
		*lo = fmax(*lo, (-vq - emf) / p->phase_resistance_ohm);
		*hi = fmin(*hi, (vq - emf) / p->phase_resistance_ohm);
	}
	if (*lo > *hi)
		*lo = *hi = clamp(0.0, *lo, *hi);
}

/* Speed PI with feed-forward; dt > 0 integrates, with anti-windup. */
static double speed_loop(struct rmd_sim_motor *m, double v_ref, double ff_a, double dt)
{
	double kp0 = m->p.inertia_kgm2 * SPEED_BW_RAD_S / m->p.kt_nm_a;
	double kp = kp0 * gain_scale(m, RMD_FLD_SPD_KP - RMD_FLD_CURR_KP);
	double ki = kp0 * SPEED_BW_RAD_S / 4.0 * gain_scale(m, RMD_FLD_SPD_KI - RMD_FLD_CURR_KP);
	double e = v_ref - m->vel_rad_s, lo, hi, u;

	iq_window(m, &lo, &hi);
	u = kp * e + m->speed_int_a + ff_a;
	if (dt > 0.0 && !((u >= hi && e > 0.0) || (u <= lo && e < 0.0)))
		m->speed_int_a = clamp(m->speed_int_a + ki * e * dt, -m->p.max_current_a,
				       m->p.max_current_a);
	return u;
}

static double pos_gain(const struct rmd_sim_motor *m)
{
	return POS_BW_RAD_S * gain_scale(m, RMD_FLD_POS_KP - RMD_FLD_CURR_KP);
}

/*
 * 0xA2 speed reference under the 0x43 limits (V3 §2.5.4): index 2 when
 * the speed grows (either direction), index 3 when it falls in the same
 * direction.
 */
static void ramp_step(struct rmd_sim_motor *m, double dt)
{
	double r = m->ramp_speed_rad_s, d = m->sp_speed_rad_s - r, a, nr;
	bool faster = r == 0.0 || (d > 0.0) == (r > 0.0);

	if (dt <= 0.0)
		return;
	a = rmd_sim_accel_rad(m, faster ? 2 : 3);
	nr = (isinf(a) || fabs(d) <= a * dt) ? m->sp_speed_rad_s : r + copysign(a * dt, d);
	m->ramp_acc_rad_s2 = (nr - r) / dt;
	m->ramp_speed_rad_s = nr;
}

/*
 * The trapezoid planner of the absolute moves (0xA4 family, V3 §2.20):
 * accelerate at 0x43 index 0 up to the move's max speed, brake at index 1
 * along v = sqrt(2 a d) so the target is reached at rest, then hold it.
 */
static void plan_step(struct rmd_sim_motor *m, double target, double vmax, double dt)
{
	double acc = rmd_sim_accel_rad(m, 0), dec = rmd_sim_accel_rad(m, 1);
	double v = m->traj_vel_rad_s, d = target - m->traj_pos_rad;
	double vdes, rate, vn, pn;

	if (dt <= 0.0)
		return;
	if (d == 0.0 && v == 0.0) {
		m->traj_acc_rad_s2 = 0.0;
		return;
	}
	vdes = vmax;
	if (!isinf(dec))
		vdes = fmin(vdes, sqrt(2.0 * dec * fabs(d)));
	vdes = copysign(vdes, d);
	/* Growing speed (from rest or in its direction): acceleration. */
	rate = (v == 0.0 || (vdes - v > 0.0) == (v > 0.0)) ? acc : dec;
	vn = isinf(rate) ? vdes : v + clamp(vdes - v, -rate * dt, rate * dt);
	pn = m->traj_pos_rad + 0.5 * (v + vn) * dt;
	/* Reached or crossed the target at (almost) rest: arrived. */
	if ((target - pn) * d <= 0.0 && (isinf(dec) || fabs(vn) <= 2.0 * dec * dt)) {
		pn = target;
		vn = 0.0;
	}
	m->traj_acc_rad_s2 = (vn - v) / dt;
	m->traj_vel_rad_s = vn;
	m->traj_pos_rad = pn;
}

/*
 * The current the firmware asks for now; dt > 0 also advances ramps,
 * planner and integrator by dt.  While the output is cut (fault, brake
 * locked) the mode is kept but its loops restart from the shaft's state.
 */
static double control(struct rmd_sim_motor *m, double dt)
{
	const struct rmd_sim_motor_params *p = &m->p;
	double iq = 0.0, v_ref, lo, hi;

	if (m->ctrl == RMD_SIM_OFF)
		return 0.0;
	if (m->errors || held(m)) {
		m->speed_int_a = 0.0;
		m->ramp_speed_rad_s = m->vel_rad_s;
		m->traj_pos_rad = m->pos_rad;
		m->traj_vel_rad_s = m->vel_rad_s;
		m->traj_acc_rad_s2 = 0.0;
		return 0.0;
	}
	switch (m->ctrl) {
	case RMD_SIM_TORQUE:
		iq = m->sp_current_a;
		break;
	case RMD_SIM_SPEED:
		ramp_step(m, dt);
		iq = speed_loop(m, m->ramp_speed_rad_s,
				p->inertia_kgm2 * m->ramp_acc_rad_s2 / p->kt_nm_a + m->tf_current_a,
				dt);
		break;
	case RMD_SIM_POS_TRACK:
		/* V3 §2.19.1: position error through the PI, speed within the limit. */
		v_ref = clamp(pos_gain(m) * (m->sp_pos_rad - m->pos_rad), -m->sp_max_speed_rad_s,
			      m->sp_max_speed_rad_s);
		iq = speed_loop(m, v_ref, m->tf_current_a, dt);
		break;
	case RMD_SIM_POS_ABS:
	case RMD_SIM_HOLD:
		if (m->ctrl == RMD_SIM_HOLD)
			plan_step(m, m->hold_pos_rad, rad(p->fw_max_speed_dps), dt);
		else
			plan_step(m, m->sp_pos_rad, m->sp_max_speed_rad_s, dt);
		v_ref = m->traj_vel_rad_s + pos_gain(m) * (m->traj_pos_rad - m->pos_rad);
		iq = speed_loop(m, v_ref,
				p->inertia_kgm2 * m->traj_acc_rad_s2 / p->kt_nm_a + m->tf_current_a,
				dt);
		break;
	case RMD_SIM_MIT:
		/* V3 §5.1: IqRef = [kp (p_des - p) + kd (v_des - v) + t_ff] / KT. */
		iq = (m->mit.kp * (m->mit.p_des_rad - rmd_sim_angle_rad(m)) +
		      m->mit.kd * (m->mit.v_des_rad_s - m->vel_rad_s) + m->mit.t_ff_nm) /
		     p->kt_nm_a;
		break;
	case RMD_SIM_OFF:
		break;
	}
	iq_window(m, &lo, &hi);
	return isnan(iq) ? 0.0 : clamp(iq, lo, hi);
}

/* -------------------------------------------------------------------------- */
/* Model: mechanics and heat                                                  */

/*
 * One semi-implicit Euler step at the output shaft:
 * J dv/dt = kt iq - load - viscous v - coulomb sign(v).  At rest, a drive
 * within the Coulomb friction leaves the shaft at rest (no chatter), and a
 * step in which friction alone would reverse the speed ends at rest.
 */
static void mechanics(struct rmd_sim_motor *m, double dt)
{
	const struct rmd_sim_motor_params *p = &m->p;
	double drive = p->kt_nm_a * m->iq_a - p->load_nm, v0 = m->vel_rad_s, a, v1;

	if (held(m)) {
		m->vel_rad_s = 0.0;
		return;
	}
	if (v0 == 0.0) {
		if (fabs(drive) <= p->coulomb_nm)
			return;
		a = (drive - copysign(p->coulomb_nm, drive)) / p->inertia_kgm2;
	} else {
		a = (drive - p->viscous_nm_s_rad * v0 - copysign(p->coulomb_nm, v0)) /
		    p->inertia_kgm2;
	}
	v1 = v0 + a * dt;
	if (v0 != 0.0 && (v1 > 0.0) != (v0 > 0.0) && fabs(drive) <= p->coulomb_nm)
		v1 = 0.0;
	if (!isfinite(v1))
		v1 = 0.0;
	m->vel_rad_s = v1;
	m->pos_rad += v1 * dt;
}

/* dT/dt = (P_cu - (T - T_amb) / R_th) / C_th, C_th = tau / R_th; P_cu = 1.5 R iq^2. */
static void thermal(struct rmd_sim_motor *m, double dt)
{
	const struct rmd_sim_motor_params *p = &m->p;
	double pcu = 1.5 * p->phase_resistance_ohm * m->iq_a * m->iq_a;
	double c = p->thermal_tau_s / p->thermal_resistance_c_w;

	m->temp_c += dt * (pcu - (m->temp_c - p->ambient_c) / p->thermal_resistance_c_w) / c;
}

/*
 * V3 §2.30: no frame for longer than the 0xB3 time cuts the output and
 * locks the brake; docs/design.md: 0xF1 frames from then on, each second.
 */
static void check_comm(struct rmd_sim_motor *m)
{
	if (!m->comm_armed || m->comm_lost || !m->ram.comm_timeout_ms ||
	    !rmd_dialect_has(m->d, RMD_DIALECT_COMM_LOSS_B3))
		return;
	if (m->t_ns - m->last_rx_ns <= (int64_t)m->ram.comm_timeout_ms * 1000000)
		return;
	rmd_sim_off_state(m);
	m->brake_locked = true;
	m->comm_lost = true;
	m->echo_next = !m->p.comm_loss_executes_first;
	m->next_f1_ns = m->t_ns;
}

static void step_once(struct rmd_sim_motor *m)
{
	m->t_ns += RMD_SIM_STEP_NS;
	check_comm(m);
	m->iq_a = control(m, STEP_S);
	mechanics(m, STEP_S);
	thermal(m, STEP_S);
	detect_faults(m, STEP_S);
}

/*
 * Steps that change nothing but the temperature, from now on: the shaft at
 * rest and staying so, no current, no fault that time could clear, and
 * not past the comm-loss deadline.  0 when the motor is not that idle.
 */
static int64_t idle_steps(const struct rmd_sim_motor *m, int64_t n)
{
	const struct rmd_sim_motor_params *p = &m->p;
	uint16_t steady = RMD_SIM_ERR_LOW_VOLTAGE | RMD_SIM_ERR_OVER_VOLTAGE;

	if (m->vel_rad_s != 0.0 || m->iq_a != 0.0 || m->stall_s != 0.0)
		return 0;
	if (m->ctrl != RMD_SIM_OFF && !m->errors && !held(m))
		return 0;
	if (!held(m) && fabs(p->load_nm) > p->coulomb_nm)
		return 0;
	if (m->errors_live & (uint16_t)~steady)
		return 0;
	if (m->temp_c > p->over_temp_c || p->ambient_c > p->over_temp_c)
		return 0;
	if (m->comm_armed && !m->comm_lost && m->ram.comm_timeout_ms &&
	    rmd_dialect_has(m->d, RMD_DIALECT_COMM_LOSS_B3)) {
		int64_t deadline = m->last_rx_ns + (int64_t)m->ram.comm_timeout_ms * 1000000;
		int64_t k = (deadline - m->t_ns) / RMD_SIM_STEP_NS;

		if (k < n)
			n = k;
	}
	return n;
}

/*
 * A motor on a world: the same firmware step, the mechanics the world's.
 * Its torque at the output is kt iq less the constant load; the friction
 * and the rotor's inertia are the joint's (rmd_sim_body_attach()).
 */
void rmd_sim_motor_substep(struct rmd_sim_motor *m)
{
	m->t_ns += RMD_SIM_STEP_NS;
	check_comm(m);
	m->iq_a = control(m, STEP_S);
	rmd_sim_body_push(m->body, m->body_slot, m->p.kt_nm_a * m->iq_a - m->p.load_nm);
	thermal(m, STEP_S);
	detect_faults(m, STEP_S);
}

/* Through the world: no idle skipping, the world may move a shaft at rest. */
static void step_on_body(struct rmd_sim_motor *m, int64_t now_ns)
{
	while (now_ns - m->t_ns >= RMD_SIM_STEP_NS) {
		if (!rmd_sim_body_room(m->body, m->body_slot))
			rmd_sim_body_advance(m->body);
		rmd_sim_motor_substep(m);
		/* at once, so that what it reports at the exchange's end is the world's then */
		if (!rmd_sim_body_room(m->body, m->body_slot))
			rmd_sim_body_advance(m->body);
	}
}

void rmd_sim_motor_step(struct rmd_sim_motor *m, int64_t now_ns)
{
	if (m->body) {
		step_on_body(m, now_ns);
		return;
	}
	while (now_ns - m->t_ns >= RMD_SIM_STEP_NS) {
		int64_t n = idle_steps(m, (now_ns - m->t_ns) / RMD_SIM_STEP_NS);

		if (n > 1) {
			const struct rmd_sim_motor_params *p = &m->p;

			m->t_ns += n * RMD_SIM_STEP_NS;
			m->temp_c =
				p->ambient_c + (m->temp_c - p->ambient_c) *
						       exp(-(double)n * STEP_S / p->thermal_tau_s);
			control(m, 0.0);
			detect_faults(m, 0.0);
			continue;
		}
		step_once(m);
	}
}

/* The exported faces of the two the step inlines (sim_physics.h). */
void rmd_sim_detect_faults(struct rmd_sim_motor *m, double dt)
{
	detect_faults(m, dt);
}

double rmd_sim_control(struct rmd_sim_motor *m, double dt)
{
	return control(m, dt);
}

bool rmd_sim_motor_held(const struct rmd_sim_motor *m)
{
	return held(m);
}
