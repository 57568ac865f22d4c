/* SPDX-License-Identifier: MIT */
/*
 * A classical CAN data frame as rmdd's layers pass it around, and the
 * identifier ranges of the RMD protocols.
 */
#ifndef RMD_FRAME_H
#define RMD_FRAME_H

#include <stdint.h>

#define RMD_MAX_MOTORS 32
#define RMD_MAX_BUSES 16
#define RMD_FRAME_LEN 8 /* V2 §1, V3 §1.1.2: DLC is always 8 */

/* V2 §1, V3 §1.1.2: single-motor requests on 0x140 + ID (1..32). */
#define RMD_CAN_REQ_BASE 0x140u
/* V3 §1.1.2: replies on 0x240 + ID.  V2 replies share 0x140 + ID. */
#define RMD_CAN_V3_REPLY_BASE 0x240u
/* V2 §4.1: four torque setpoints; V3 §3: one command to every motor. */
#define RMD_CAN_MULTI 0x280u
/* V3 §4: 0x79 CAN-ID setting and reading, received by every motor. */
#define RMD_CAN_SET_ID 0x300u
/* V3 §5: MIT motion mode requests on 0x400 + ID, replies on 0x500 + ID. */
#define RMD_CAN_MIT_REQ_BASE 0x400u
#define RMD_CAN_MIT_REPLY_BASE 0x500u

/*
 * A CAN controller's error state (ISO 11898-1 fault confinement): what a
 * transport reports in struct rmd_bus and the simulated wire models.
 * RMD_BUS_NO_ACK is not a confinement state but what rmdd must act on: no
 * node acknowledges the host's frames (every motor unpowered: an e-stop),
 * so they stay queued and would all go out when power returns
 * (docs/faults.md "E-stop").  A controller that transmits alone stays
 * error-passive (ISO 11898-1: an ACK error of an error-passive
 * transmitter does not raise its counter), never bus-off.
 */
enum rmd_bus_state {
	RMD_BUS_ACTIVE = 0,
	RMD_BUS_WARNING, /* error counters >= 96 */
	RMD_BUS_PASSIVE, /* error counters >= 128 */
	RMD_BUS_OFF,	 /* the controller left the bus */
	RMD_BUS_NO_ACK,	 /* no node acknowledges: frames written stay queued */
};

struct rmd_frame {
	uint32_t can_id; /* 11-bit standard identifier */
	uint8_t len;	 /* data length code, 0..8 */
	uint8_t data[RMD_FRAME_LEN];
};

#endif /* RMD_FRAME_H */
