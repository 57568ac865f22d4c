/* SPDX-License-Identifier: MIT */
/*
 * The V2 0x280 frame (V2 §4.1) seen by a motor it was not meant for: a
 * V3/V4 motor whose CAN-ID filter is off reads its bytes as a command of
 * its own (V3 §3), so a test of issue 33 point 2 drives the batched
 * motors with torques that make the frame's first bytes a command.
 */
#ifndef RMD_TESTS_V2_BATCH_H
#define RMD_TESTS_V2_BATCH_H

#include <stdint.h>

struct rmd_motor;

/*
 * The torque of ms[0] (motor 1, 0x280's data[0..1]: its int16 current)
 * that makes the frame begin `cmd` 00, the other three at 0 N·m, found
 * with rmd_motor_encode_v2_batch() (0 .. 10 N·m in 0.0005 N·m steps).
 * Fails the test when none does.
 */
double v2_batch_torque_for(const struct rmd_motor *const ms[4], uint8_t cmd);

#endif /* RMD_TESTS_V2_BATCH_H */
