/* SPDX-License-Identifier: MIT */
/*
 * What a motor is commanded with, and what its setpoint means: one
 * numbering for the configuration (motors[].mode), the rt loop, the bridge
 * and rmd.command_t's mode field (lcm_types/command_t.lcm).
 */
#ifndef RMD_MODE_H
#define RMD_MODE_H

enum rmd_mode {
	RMD_MODE_TORQUE = 0,   /* "torque": V2/V3 0xA1 (iq), V2 0x280; torque_nm = Kt * iq */
	RMD_MODE_SPEED = 1,    /* "speed": 0xA2; vel_rad_s */
	RMD_MODE_POSITION = 2, /* "position": V3 0xA4 / V2 0xA4; pos_rad, max_vel_rad_s */
	RMD_MODE_MIT = 3,      /* "mit": V3 §5, 0x400 + ID; pos, vel, kp, kd, torque */
	RMD_MODE_COUNT
};

#endif /* RMD_MODE_H */
