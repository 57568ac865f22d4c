/* SPDX-License-Identifier: MIT */
/*
 * rmdd's LCM channels (docs/lcm.md "Channels"): each name is the
 * configured prefix (lcm.channel_prefix, default "RMD_") followed by one of
 * these suffixes, so "RMD_" RMD_CHANNEL_COMMAND is "RMD_COMMAND".  The one
 * place they are spelled in C: rmdd's bridge, its incident log, rmdctl top,
 * the example controllers and the tests take them from here.
 *
 * Installed with the LCM types (`pkg-config --cflags rmd-lcm` finds it as
 * "rmd/channels.h" beside "rmd/rmd_command_t.h"), for controllers in C:
 * string literals only, no library, no other header.
 */
#ifndef RMD_CHANNELS_H
#define RMD_CHANNELS_H

#define RMD_CHANNEL_COMMAND "COMMAND"		    /* rmd.command_t, controller -> rmdd */
#define RMD_CHANNEL_STATE "STATE"		    /* rmd.state_t, rmdd -> all */
#define RMD_CHANNEL_HEALTH "HEALTH"		    /* rmd.health_t, rmdd -> all */
#define RMD_CHANNEL_CONFIG "CONFIG"		    /* rmd.config_t, rmdd -> all */
#define RMD_CHANNEL_CONFIG_REQUEST "CONFIG_REQUEST" /* any message, anyone -> rmdd */
#define RMD_CHANNEL_HOME "HOME"			    /* rmd.home_t, controller -> rmdd */
/*
 * The robot's channels (docs/robot.md), spelled whole, without the prefix:
 * the daemons of one robot each have a prefix of their own, and these are
 * what they share.  A daemon receives what starts with
 * RMD_CHANNEL_ROBOT_PREFIX beside its own prefix.
 */
#define RMD_CHANNEL_ROBOT_PREFIX "RMD_ROBOT_"
#define RMD_CHANNEL_ROBOT_HEARTBEAT "RMD_ROBOT_HEARTBEAT" /* rmd.heartbeat_t, rmdd -> all */
#define RMD_CHANNEL_ROBOT_STOP "RMD_ROBOT_STOP"		  /* rmd.robot_stop_t, anyone -> rmdd */
/* rmd.config_t again, when a peer appears: the robot's motor names side by side */
#define RMD_CHANNEL_ROBOT_CONFIG "RMD_ROBOT_CONFIG"
/*
 * Only in an incident recording's window.lcmlog (docs/design.md
 * "Incidents"): the command_t the rt loop took.  Not COMMAND, so that
 * lcm-logplayer replaying a recording beside a running rmdd never drives
 * its motors.
 */
#define RMD_CHANNEL_COMMAND_TAKEN "COMMAND_TAKEN"

/* Room for the longest suffix and its NUL: a channel name fits prefix length + this. */
#define RMD_CHANNEL_SUFFIX_SIZE sizeof(RMD_CHANNEL_CONFIG_REQUEST)

#endif /* RMD_CHANNELS_H */
