// SPDX-License-Identifier: MIT
/*
 * rmd-ros2's translation (src/tools/rmd-ros2/map.c), table-driven, without
 * processes or sockets: which joint commands are taken and which refused,
 * with what reason, and the command_t entries each motor's way through
 * rmdd's enable procedure gives.  tests/ros2/test_ros2.c judges the same on
 * the wires.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "harness/suite.h"
#include "map.h"

static rmd_motor_config_t motors[2];
static rmd_config_t cfg = { .motor_count = 2, .motor = motors };

static void config(struct ros2_map *map, int mode, bool enable)
{
	char err[160];

	motors[0] = (rmd_motor_config_t){ .index = 0, .name = "hip", .modes = 7 };
	motors[1] = (rmd_motor_config_t){ .index = 1, .name = "knee", .modes = 7 };
	assert_int_equal(ros2_map_config(map, &cfg, mode, enable, 0.2, err, sizeof(err)), 0);
}

/* state_t with both motors in lifecycle lc at positions p0, p1. */
static void state(struct ros2_map *map, int lc, double p0, double p1)
{
	rmd_motor_state_t ms[2] = { { .index = 0, .lifecycle = (int8_t)lc, .position = p0 },
				    { .index = 1, .lifecycle = (int8_t)lc, .position = p1 } };
	rmd_state_t st = { .count = 2, .motor = ms };

	ros2_map_state(map, &st);
}

struct take_row {
	const char *what;
	int mode;
	bool enable;
	unsigned n;
	const char *names[3];
	unsigned n_field; /* values in the driven array */
	double values[3];
	int want;	 /* 1, or -1 - ROS2_REJ_* */
	const char *why; /* in the reason, or NULL */
};

static const struct take_row takes[] = {
	{ "take_both_at_rest",
	  RMD_COMMAND_T_MODE_POSITION,
	  true,
	  2,
	  { "hip", "knee" },
	  2,
	  { 0.1, -0.1 },
	  1,
	  NULL },
	{ "take_one_of_two", RMD_COMMAND_T_MODE_POSITION, true, 1, { "knee" }, 1, { 0.0 }, 1, NULL },
	{ "refuse_unknown_name",
	  RMD_COMMAND_T_MODE_POSITION,
	  true,
	  2,
	  { "hip", "ankle" },
	  2,
	  { 0, 0 },
	  -1 - ROS2_REJ_NAME,
	  "\"ankle\": no motor of rmdd has it" },
	{ "refuse_a_name_twice",
	  RMD_COMMAND_T_MODE_POSITION,
	  true,
	  2,
	  { "hip", "hip" },
	  2,
	  { 0, 0 },
	  -1 - ROS2_REJ_NAME,
	  "named twice" },
	{ "refuse_more_names_than_motors",
	  RMD_COMMAND_T_MODE_POSITION,
	  true,
	  3,
	  { "hip", "knee", "x" },
	  3,
	  { 0, 0, 0 },
	  -1 - ROS2_REJ_NAME,
	  "3 names, rmdd has 2 motors" },
	{ "refuse_short_array",
	  RMD_COMMAND_T_MODE_POSITION,
	  true,
	  2,
	  { "hip", "knee" },
	  1,
	  { 0 },
	  -1 - ROS2_REJ_SHAPE,
	  "2 names but 1 position values" },
	{ "refuse_nan",
	  RMD_COMMAND_T_MODE_POSITION,
	  true,
	  2,
	  { "hip", "knee" },
	  2,
	  { 0, NAN },
	  -1 - ROS2_REJ_NONFINITE,
	  "position of knee is nan" },
	{ "refuse_infinity",
	  RMD_COMMAND_T_MODE_SPEED,
	  true,
	  1,
	  { "hip" },
	  1,
	  { INFINITY },
	  -1 - ROS2_REJ_NONFINITE,
	  "velocity of hip is inf" },
	{ "refuse_a_leap",
	  RMD_COMMAND_T_MODE_POSITION,
	  true,
	  2,
	  { "hip", "knee" },
	  2,
	  { 0.0, 0.5 },
	  -1 - ROS2_REJ_JUMP,
	  "position 0.5 of knee" },
	{ "take_speed_far_from_position",
	  RMD_COMMAND_T_MODE_SPEED,
	  true,
	  1,
	  { "knee" },
	  1,
	  { 3.0 },
	  1,
	  NULL },
	{ "refuse_without_enable",
	  RMD_COMMAND_T_MODE_POSITION,
	  false,
	  1,
	  { "hip" },
	  1,
	  { 0.0 },
	  -1 - ROS2_REJ_DISABLED,
	  NULL },
};

/* Each row from motors at rest at 0 (READY): taken or refused as the row says, and nothing else. */
static void test_take(void **state_)
{
	const struct take_row *r = *state_;
	struct ros2_map map;
	sensor_msgs_msg_dds__JointState_ js = { 0 };
	double zeros[3] = { 0 };
	char why[160];
	int got;

	config(&map, r->mode, r->enable);
	state(&map, RMD_STATE_T_LC_READY, 0.0, 0.0);
	js.name._buffer = (char **)r->names;
	js.name._length = r->n;
	js.position._buffer = js.velocity._buffer = js.effort._buffer = zeros;
	js.position._length = js.velocity._length = js.effort._length = r->n;
	if (r->mode == RMD_COMMAND_T_MODE_POSITION) {
		js.position._buffer = (double *)r->values;
		js.position._length = r->n_field;
	} else {
		js.velocity._buffer = (double *)r->values;
		js.velocity._length = r->n_field;
	}
	got = ros2_map_take(&map, &js, why, sizeof(why));
	if (got != r->want || (r->why && !strstr(why, r->why)))
		fail_msg("%s: %d \"%s\", want %d \"%s\"", r->what, got, why, r->want,
			 r->why ? r->why : "");
	for (unsigned i = 0; i < 2; i++)
		assert_int_equal(map.m[i].phase,
				 got > 0 && (i == 1 || r->n == 2) ? ROS2_ENABLING : ROS2_IDLE);
	assert_int_equal(map.accepted, got > 0);
	if (got < 0)
		assert_int_equal(map.rejected[-1 - got], 1);
}

/* The way through rmdd's enable procedure, one command_t after another. */
static void test_enable_procedure(void **state_)
{
	struct ros2_map map;
	rmd_motor_command_t e[ROS2_MAX_MOTORS];
	const char *names[1] = { "knee" };
	double pos[1] = { 0.05 };
	sensor_msgs_msg_dds__JointState_ js = { 0 };
	char why[160];

	(void)state_;
	config(&map, RMD_COMMAND_T_MODE_POSITION, true);
	state(&map, RMD_STATE_T_LC_READY, 0.0, 0.0);
	/* nothing named yet: nothing sent */
	assert_int_equal(ros2_map_command(&map, e), 0);
	js.name._buffer = (char **)names;
	js.name._length = 1;
	js.position._buffer = pos;
	js.position._length = 1;
	assert_int_equal(ros2_map_take(&map, &js, why, sizeof(why)), 1);
	/* step 1: enable = 0 for knee only */
	assert_int_equal(ros2_map_command(&map, e), 1);
	assert_int_equal(e[0].index, 1);
	assert_false(e[0].enable);
	assert_int_equal(e[0].mode, RMD_COMMAND_T_MODE_POSITION);
	/* READY (it was): step 3, enable = 1 with the setpoint */
	assert_int_equal(ros2_map_command(&map, e), 1);
	assert_true(e[0].enable);
	assert_true(e[0].position == 0.05);
	/* it runs, then rmdd makes it SAFE: enable = 0 from then on, never 1 again */
	state(&map, RMD_STATE_T_LC_ENABLED, 0.0, 0.05);
	assert_int_equal(map.stopped_new, 0);
	state(&map, RMD_STATE_T_LC_SAFE, 0.0, 0.05);
	assert_int_equal(map.stopped_new, 1);
	assert_int_equal(map.m[1].phase, ROS2_STOPPED);
	state(&map, RMD_STATE_T_LC_READY, 0.0, 0.05);
	assert_int_equal(ros2_map_take(&map, &js, why, sizeof(why)), 1);
	assert_int_equal(ros2_map_command(&map, e), 1);
	assert_false(e[0].enable);
	/* the exit: enable = 0 for every motor past IDLE */
	assert_int_equal(ros2_map_release(&map, e), 1);
	assert_false(e[0].enable);
}

/* ENABLING waits while the motor is not READY (here: STOPPING after a previous controller). */
static void test_enabling_waits_for_ready(void **state_)
{
	struct ros2_map map;
	rmd_motor_command_t e[ROS2_MAX_MOTORS];
	const char *names[2] = { "hip", "knee" };
	double pos[2] = { 0.0, 0.0 };
	sensor_msgs_msg_dds__JointState_ js = { 0 };
	char why[160];

	(void)state_;
	config(&map, RMD_COMMAND_T_MODE_POSITION, true);
	state(&map, RMD_STATE_T_LC_STOPPING, 0.0, 0.0);
	js.name._buffer = (char **)names;
	js.name._length = 2;
	js.position._buffer = pos;
	js.position._length = 2;
	assert_int_equal(ros2_map_take(&map, &js, why, sizeof(why)), 1);
	for (int k = 0; k < 3; k++) {
		assert_int_equal(ros2_map_command(&map, e), 2);
		assert_false(e[0].enable || e[1].enable);
	}
	state(&map, RMD_STATE_T_LC_READY, 0.0, 0.0);
	assert_int_equal(ros2_map_command(&map, e), 2);
	assert_int_equal(ros2_map_command(&map, e), 2);
	assert_true(e[0].enable && e[1].enable);
}

/* A motor not configured for --mode is named at start. */
static void test_mode_not_configured(void **state_)
{
	struct ros2_map map;
	char err[160];

	(void)state_;
	motors[0] = (rmd_motor_config_t){ .index = 0, .name = "hip", .modes = 7 };
	motors[1] = (rmd_motor_config_t){ .index = 1,
					  .name = "knee",
					  .modes = RMD_MOTOR_CONFIG_T_MODE_BIT_POSITION };
	assert_int_equal(ros2_map_config(&map, &cfg, RMD_COMMAND_T_MODE_TORQUE, true, 0.2, err,
					 sizeof(err)),
			 -EINVAL);
	assert_string_equal(err, "motor knee is not configured for mode effort (--mode)");
}

int main(void)
{
	static struct CMUnitTest tests[SUITE_N(takes) + 4];
	size_t n = 0;

	for (size_t i = 0; i < SUITE_N(takes); i++)
		tests[n++] = SUITE_ROW(takes[i].what, test_take, &takes[i]);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_enable_procedure);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_enabling_waits_for_ready);
	tests[n++] = (struct CMUnitTest)cmocka_unit_test(test_mode_not_configured);
	return suite_run("test_ros2_map", tests, n, NULL, NULL);
}
