/* SPDX-License-Identifier: MIT */
/*
 * rmd-ros2's translation between rmdd's LCM types and ROS 2's messages
 * (docs/ros2.md), apart from any I/O: a joint command (sensor_msgs/JointState
 * from topic_based_ros2_control) checked and turned into rmd.command_t
 * entries, each motor's way through rmdd's enable procedure (docs/lcm.md
 * "Enabling a motor"), and rmd.state_t / rmd.health_t as JointState and
 * DiagnosticArray.  Pure functions of their arguments and struct ros2_map;
 * tests/ros2/test_ros2.c drives them through the bridge.  Non-rt.
 */
#ifndef RMD_ROS2_MAP_H
#define RMD_ROS2_MAP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/rmd_command_t.h"
#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"
#include "ros2_msgs.h"

#define ROS2_MAX_MOTORS 32
#define ROS2_NAME_MAX 64

/* DiagnosticStatus levels (diagnostic_msgs/msg/DiagnosticStatus.msg's constants). */
enum {
	ROS2_DIAG_OK = 0,
	ROS2_DIAG_WARN = 1,
	ROS2_DIAG_ERROR = 2,
	ROS2_DIAG_STALE = 3,
};

/* Where a motor is on its way to running ROS's commands. */
enum ros2_phase {
	ROS2_IDLE,     /* no command named it yet: rmd-ros2 sends nothing for it */
	ROS2_ENABLING, /* enable = 0 sent (step 1), waiting for LC_READY */
	ROS2_RUNNING,  /* enable = 1 with ROS's setpoints */
	ROS2_STOPPED, /* it left ENABLED (SAFE, LOST, FAULT, a restart): enable = 0, never again 1 */
};

/* Why a joint command was refused (each counted; the first of a kind logged). */
enum ros2_reject {
	ROS2_REJ_NAME,	    /* a name no motor of rmdd has, or a name twice */
	ROS2_REJ_SHAPE,	    /* the driven field's array is not one value per name */
	ROS2_REJ_NONFINITE, /* a NaN or infinite value in the driven field */
	ROS2_REJ_DISABLED,  /* commands came, but rmd-ros2 runs without --enable */
	ROS2_REJ_JUMP, /* a position command that would enable a motor this far from where it is */
	ROS2_REJ_KINDS,
};

struct ros2_motor {
	char name[ROS2_NAME_MAX];
	int8_t modes;	  /* config_t MODE_BIT_* */
	int8_t lifecycle; /* the newest state_t's LC_*, -1 before one */
	double position;  /* the newest state_t's, rad (NaN: none yet) */
	enum ros2_phase phase;
	bool seen_enabled; /* LC_ENABLED seen while RUNNING */
	double setpoint;   /* rad, rad/s or N*m, as `field` says */
};

struct ros2_map {
	unsigned count;
	struct ros2_motor m[ROS2_MAX_MOTORS];
	int8_t mode;	 /* command_t MODE_POSITION, _SPEED or _TORQUE: what ROS drives */
	bool enable;	 /* --enable: ROS's commands may enable the motors */
	double max_jump; /* --max-jump: rad between a motor and the position that enables it */
	int64_t accepted;
	int64_t rejected[ROS2_REJ_KINDS];
	unsigned stopped_new; /* motors that went STOPPED since ros2_map_stopped() was asked */
};

/*
 * The ROS 2 command interface name ("position", "velocity", "effort": ros2_control's
 * hardware_interface names) as a command_t MODE_*; -1 for any other word.
 */
int ros2_mode_of(const char *word);

/* The interface name of a MODE_* (ros2_mode_of()'s inverse). */
const char *ros2_mode_word(int mode);

/*
 * The motors of rmdd's config_t, each driven in mode (MODE_*).  0, or
 * -EINVAL with the reason ("motor knee: not configured for velocity
 * (modes: position)") in err.
 */
int ros2_map_config(struct ros2_map *map, const rmd_config_t *cfg, int mode, bool enable,
		    double max_jump, char *err, size_t size);

/*
 * A joint command: all or nothing.  Each name must be a motor's, once; the
 * driven field's array (position for MODE_POSITION, velocity for
 * MODE_SPEED, effort for MODE_TORQUE) must hold one finite value per name;
 * the other arrays are not read (topic_based_ros2_control fills them with
 * 0, its successor leaves them empty).  In position mode a motor not yet
 * driven (IDLE) is enabled only by a position within max_jump of where
 * state_t says it is: a first command is never a leap.  Taken: the named motors' setpoints
 * change, an IDLE one goes ENABLING, and 1 is returned.  Refused: nothing
 * changes, the kind is counted and returned as -1 - kind, with the culprit
 * (a name, an index) in why.
 */
int ros2_map_take(struct ros2_map *map, const sensor_msgs_msg_dds__JointState_ *js, char *why,
		  size_t size);

/*
 * The newest state_t: each motor's lifecycle; ENABLING with its enable = 0
 * sent and LC_READY goes RUNNING; RUNNING that was ENABLED and is not any
 * more goes STOPPED (counted in stopped_new).
 */
void ros2_map_state(struct ros2_map *map, const rmd_state_t *st);

/*
 * The entries of the next command_t into e[0..ROS2_MAX_MOTORS): every
 * motor past IDLE (ENABLING and STOPPED: enable = 0; RUNNING: enable = 1
 * with its setpoint).  Their count.
 */
unsigned ros2_map_command(struct ros2_map *map, rmd_motor_command_t *e);

/* enable = 0 entries for every motor past IDLE, all STOPPED (rmd-ros2's exit).  Their count. */
unsigned ros2_map_release(struct ros2_map *map, rmd_motor_command_t *e);

/* Storage a JointState borrows from while it is written. */
struct ros2_js_buf {
	char *names[ROS2_MAX_MOTORS];
	double position[ROS2_MAX_MOTORS];
	double velocity[ROS2_MAX_MOTORS];
	double effort[ROS2_MAX_MOTORS];
};

/*
 * A ROS time of a CLOCK_MONOTONIC time: mono_ns + realtime_offset_ns
 * (CLOCK_REALTIME - CLOCK_MONOTONIC) as builtin_interfaces/Time.
 */
void ros2_stamp(builtin_interfaces_msg_dds__Time_ *t, int64_t mono_ns, int64_t realtime_offset_ns);

/*
 * state_t as a JointState (SI as rmdd gives them: rad, rad/s, N*m; NaN where a
 * motor has reported nothing yet), stamped with the state's utime.
 */
void ros2_joint_state(const struct ros2_map *map, const rmd_state_t *st, int64_t realtime_offset_ns,
		      struct ros2_js_buf *buf, sensor_msgs_msg_dds__JointState_ *js);

#define ROS2_DIAG_VALUES 16

/* Storage a DiagnosticArray borrows from. */
struct ros2_diag_buf {
	diagnostic_msgs_msg_dds__DiagnosticStatus_ status[1 + ROS2_MAX_MOTORS];
	diagnostic_msgs_msg_dds__KeyValue_ kv[1 + ROS2_MAX_MOTORS][ROS2_DIAG_VALUES];
	char text[1 + ROS2_MAX_MOTORS][ROS2_DIAG_VALUES][2][48];
	char name[1 + ROS2_MAX_MOTORS][ROS2_NAME_MAX + 8];
	char message[1 + ROS2_MAX_MOTORS][96];
	char hwid[1 + ROS2_MAX_MOTORS][48];
};

/*
 * health_t (and the newest state_t, NULL: none yet) as a DiagnosticArray:
 * status[0] "rmdd" (the loop, the watchdog, the buses and rmd-ros2's own
 * counts), then one "rmdd/<motor>" per motor (its lifecycle: OK when READY
 * or ENABLED, WARN when PROBE, STOPPING or SAFE, ERROR when FAULT or LOST).
 */
void ros2_diagnostics(const struct ros2_map *map, const rmd_config_t *cfg, const rmd_health_t *h,
		      const rmd_state_t *st, int64_t realtime_offset_ns, struct ros2_diag_buf *buf,
		      diagnostic_msgs_msg_dds__DiagnosticArray_ *da);

#endif /* RMD_ROS2_MAP_H */
