// SPDX-License-Identifier: MIT
/*
 * The rt loop against firmware as the field reports it (issue 32;
 * harness/loop_rig.h; docs/protocol-v4.md "Firmware in the field"): what
 * rmdd reports and does for the quirks rmd_firmware_quirks() knows, and
 * that firmware without them is taken as the manual says.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#include "harness/loop_rig.h"
#include "harness/suite.h"
#include "rmd/dialect.h"

/* The version of the field reports (X4-36, X4-64, X6-P20). */
#define FIELD_FW 2025070202u

static uint32_t fw_version;

/* Motor 1 V4 in both the entry and the simulated firmware. */
static void v4_entry(struct rmd_config *cfg)
{
	cfg->motors[0].proto = RMD_PROTO_V4;
}

static void v4_firmware(struct rmd_sim_setup *sim)
{
	sim->motors[0].proto = RMD_PROTO_V4;
	sim->motors[0].version_date = fw_version;
}

/*
 * A tap hook: motor 1's status answers (0x9A) carry in DATA[3] the
 * opposite of its brake.  On 2025070202 firmware the byte says whether it
 * runs commands (issue 32 point 5), which is not the brake: it may say
 * either; this makes it say the one thing it must not be taken for.
 */
static void byte3_not_brake(unsigned b, const struct rmd_sim_pending *p, int64_t start_ns)
{
	struct rmd_frame *f = (struct rmd_frame *)&p->f;

	(void)start_ns;
	if (b == 0 && p->src == 0 && f->len == 8 && f->data[0] == 0x9A)
		f->data[3] = sim_motor(0)->brake_locked;
}

/* Motor 1 up on firmware `version`, its 0x9A answers rewritten by byte3_not_brake(). */
static void up_on(uint32_t version)
{
	fw_version = version;
	rig_sim_tweak = v4_firmware;
	rig_up(1, v4_entry);
	rig_sim_tweak = NULL;
	rig_tap_hook = byte3_not_brake;
	bring_up();
	assert_int_equal(R.report.motor[0].version, version);
	cmd_clear();
}

/*
 * On 2025070202 firmware 0x9A DATA[3] tells that the motor runs, not its
 * brake: state_t's brake_released is what the motor acknowledged -- 0x77
 * released, 0x78 locked -- judged against the simulated brake, while the
 * byte says the opposite: READY (locked), enabled (released), disabled
 * (STOPPING's 0x78 echoed: locked).
 */
static void test_byte3_is_not_the_brake(void **state)
{
	(void)state;
	assert_true(rmd_firmware_quirks(FIELD_FW) & RMD_QUIRK_9A_BYTE3_RUNNING);
	up_on(FIELD_FW);
	run(300, true);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	assert_true(sim_motor(0)->brake_locked);
	assert_false(snap().m[0].brake_released);
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 0.5;
	run(300, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_false(sim_motor(0)->brake_locked);
	assert_true(snap().m[0].brake_released);
	cmd_motor(0, false, RMD_MODE_SPEED);
	run(300, true);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	assert_true(sim_motor(0)->brake_locked);
	assert_false(snap().m[0].brake_released);
	rig_tap_hook = NULL;
	rig_down();
}

/*
 * The same byte on firmware without the quirk is its brake, as V3 §2.12
 * says, and rmdd reports what it says (here the opposite of the
 * simulated brake): the test above is not passed by ignoring the byte.
 */
static void test_byte3_is_the_brake_elsewhere(void **state)
{
	(void)state;
	assert_int_equal(rmd_firmware_quirks(2026042402u), 0);
	up_on(2026042402u);
	run(300, true);
	assert_int_equal(lifecycle(0), RMD_LC_READY);
	assert_true(sim_motor(0)->brake_locked);
	assert_true(snap().m[0].brake_released);
	cmd_motor(0, true, RMD_MODE_SPEED)->vel_rad_s = 0.5;
	run(300, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_false(sim_motor(0)->brake_locked);
	assert_false(snap().m[0].brake_released);
	rig_tap_hook = NULL;
	rig_down();
}

/* ---- 0xA4 after MIT (issue 32 point 4) --------------------------------------------- */

static const char *fw_model;

/* Motor 1 V4 firmware of fw_version and fw_model (its personality picked by them). */
static void v4_model_firmware(struct rmd_sim_setup *sim)
{
	sim->motors[0].proto = RMD_PROTO_V4;
	sim->motors[0].version_date = fw_version;
	snprintf(sim->motors[0].model, sizeof(sim->motors[0].model), "%s", fw_model);
}

/* Motor 1 V4 in MIT mode, its position kept through a power cycle (certain). */
static void v4_mit_entry(struct rmd_config *cfg)
{
	cfg->motors[0].proto = RMD_PROTO_V4;
	cfg->motors[0].mode = RMD_MODE_MIT;
	cfg->motors[0].multi_turn_saved = true;
}

/*
 * Motor 1, brought up, driven in MIT for 200 cycles, then asked for
 * position 0.5 rad for `cycles`; returns where the trace stood when
 * position was asked.
 */
static unsigned drive_mit_then_position(unsigned cycles)
{
	struct rmd_setpoint *sp;
	unsigned from;

	cmd_clear();
	sp = cmd_motor(0, true, RMD_MODE_MIT);
	sp->kp = 5.0;
	sp->kd = 0.5;
	run(200, true);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_true(sent_to(0, 0x400, 0) > 150);
	from = trace_n;
	sp = cmd_motor(0, true, RMD_MODE_POSITION);
	sp->pos_rad = 0.5;
	sp->max_vel_rad_s = 2.0;
	R.nev = 0;
	run(cycles, true);
	return from;
}

/* Motor 1 of fw_model on fw_version, drive_mit_then_position() for 300 cycles. */
static unsigned mit_then_position(const char *model, uint32_t version)
{
	fw_model = model;
	fw_version = version;
	rig_sim_tweak = v4_model_firmware;
	rig_up(1, v4_mit_entry);
	rig_sim_tweak = NULL;
	bring_up();
	assert_int_equal(R.report.motor[0].version, version);
	return drive_mit_then_position(300);
}

/*
 * X6-P20 on 2025070202 ignores 0xA4 after an MIT frame until it is reset:
 * rmdd does not send it one -- the motor would hold its MIT output while
 * rmdd reported the target asked -- and says why, once: refused, counted
 * (IGN_FIRMWARE), the motor SAFE.  Judged on the wire: no 0xA4.
 */
static void test_a4_after_mit_refused(void **state)
{
	struct rmd_loop_counters c;
	unsigned from;

	(void)state;
	assert_true(rmd_firmware_quirks(FIELD_FW) & RMD_QUIRK_A4_AFTER_MIT);
	from = mit_then_position("X6-P20", FIELD_FW);
	assert_int_equal(sent_to(0, 0xA4, from), 0);
	assert_int_equal(count_ev(RMD_EV_FW_REFUSED, 0), 1);
	assert_int_equal(lifecycle(0), RMD_LC_SAFE);
	rmd_loop_get_counters(R.l, &c);
	assert_true(c.ignored[RMD_IGN_FIRMWARE] >= 1);
	rig_down();
}

/* An X8-P20 on 2026042402 switches freely: 0xA4 goes out, the joint goes to 0.5 rad. */
static void test_a4_after_mit_elsewhere(void **state)
{
	unsigned from;

	(void)state;
	from = mit_then_position("X8-P20", 2026042402u);
	assert_true(sent_to(0, 0xA4, from) > 250);
	assert_int_equal(count_ev(RMD_EV_FW_REFUSED, 0), 0);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_true(fabs(sim_motor(0)->pos_rad - 0.5) < 0.05);
	rig_down();
}

/* ---- a position command with no effect (rmd/proc_effect.h) --------------------------- */

/* Motor 1 V3 firmware rmdd knows nothing odd of, that ignores 0xA4 after an MIT frame. */
static void v3_ignores_a4(struct rmd_sim_setup *sim)
{
	sim->motors[0].a4_ignored_after_mit = true;
}

static void mit_entry(struct rmd_config *cfg)
{
	cfg->motors[0].proto = RMD_PROTO_MIT;
	cfg->motors[0].mode = RMD_MODE_MIT;
	cfg->motors[0].multi_turn_saved = true;
}

/* Brought up, drive_mit_then_position() for 1000 cycles. */
static unsigned mit_then_far(void)
{
	bring_up();
	return drive_mit_then_position(1000);
}

/*
 * Firmware not in rmdd's table that takes 0xA4 and does not run it: rmdd
 * sends the position commands (nothing refuses them), the motor's answers
 * say it stays where it was, and rmdd tells it once -- within a hold and a
 * status poll -- rather than let the target pass for reached.  Judged by
 * the simulated shaft: it did not move, and the report says how far.
 */
static void test_no_effect_told(void **state)
{
	unsigned from;

	(void)state;
	rig_sim_tweak = v3_ignores_a4;
	rig_up(1, mit_entry);
	rig_sim_tweak = NULL;
	from = mit_then_far();
	assert_true(sent_to(0, 0xA4, from) > 900);
	assert_true(fabs(sim_motor(0)->pos_rad) < 0.05);
	assert_int_equal(count_ev(RMD_EV_NO_EFFECT, 0), 1);
	for (unsigned k = 0; k < R.nev; k++)
		if (R.ev[k].kind == RMD_EV_NO_EFFECT)
			assert_true(fabs((double)R.ev[k].a / 1e6 - 0.5) < 0.06);
	rig_down();
}

/* The same motor without the quirk goes to 0.5 rad: nothing told. */
static void test_no_effect_not_told(void **state)
{
	(void)state;
	rig_up(1, mit_entry);
	mit_then_far();
	assert_true(fabs(sim_motor(0)->pos_rad - 0.5) < 0.05);
	assert_int_equal(count_ev(RMD_EV_NO_EFFECT, 0), 0);
	rig_down();
}

SUITE_MAIN("loop_field", NULL, NULL,
	   {
		   cmocka_unit_test(test_byte3_is_not_the_brake),
		   cmocka_unit_test(test_byte3_is_the_brake_elsewhere),
		   cmocka_unit_test(test_a4_after_mit_refused),
		   cmocka_unit_test(test_a4_after_mit_elsewhere),
		   cmocka_unit_test(test_no_effect_told),
		   cmocka_unit_test(test_no_effect_not_told),
	   })
